// SPDX-License-Identifier: BSD-3-Clause
// The one explicit instantiation of the FPFH feature tree (declared extern in feature_index.hpp).
#include "plumb/registration/feature_index.hpp"

#include "core/eigen_instantiations.hpp"

namespace plumb {
template class FeatureKdTree<33>;
template std::vector<std::uint32_t> feature_knn<33>(const std::vector<std::array<float, 33>>&,
                                                    const std::vector<std::size_t>&,
                                                    const std::vector<std::array<float, 33>>&,
                                                    const std::vector<std::size_t>&, std::size_t);
}  // namespace plumb
