// SPDX-License-Identifier: BSD-3-Clause
// The one explicit instantiation of the kd-trees every module uses (declared extern in kdtree.hpp):
// compiled here once instead of in every source and test that includes the header.
#include "plumb/search/kdtree.hpp"

namespace plumb {
template class KdTree<2>;
template class KdTree<3>;
}  // namespace plumb
