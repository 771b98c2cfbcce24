// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/io/stamps.hpp"

#include <algorithm>

namespace plumb::io {

StampOrder order_stamps(const std::vector<double>& stamps) {
  StampOrder out;
  std::vector<double> original;  // the kept records' own stamps (non-decreasing)
  for (std::size_t k = 0; k < stamps.size(); ++k) {
    if (!original.empty() && stamps[k] < original.back()) {
      out.dropped.push_back(k);
      continue;
    }
    out.kept.push_back(k);
    original.push_back(stamps[k]);
  }
  out.stamps = original;
  // Runs of equal stamps: spread over the interval to the next stamp.
  std::vector<double> spacings;
  std::size_t last_run_begin = original.size(), last_run_end = original.size();
  for (std::size_t b = 0; b < original.size();) {
    std::size_t e = b + 1;
    while (e < original.size() && original[e] == original[b]) ++e;
    const std::size_t m = e - b;
    if (m > 1) {
      out.respread += m - 1;
      if (e < original.size()) {
        const double step = (original[e] - original[b]) / static_cast<double>(m);
        for (std::size_t j = 1; j < m; ++j) out.stamps[b + j] = original[b] + step * static_cast<double>(j);
        spacings.push_back(step);
      } else {
        last_run_begin = b;
        last_run_end = e;
      }
    }
    b = e;
  }
  if (last_run_begin < last_run_end) {
    double step = 1e-3;
    if (!spacings.empty()) {
      std::nth_element(spacings.begin(), spacings.begin() + static_cast<std::ptrdiff_t>(spacings.size() / 2),
                       spacings.end());
      step = spacings[spacings.size() / 2];
    }
    for (std::size_t j = last_run_begin + 1; j < last_run_end; ++j) {
      out.stamps[j] = original[last_run_begin] + step * static_cast<double>(j - last_run_begin);
    }
  }
  return out;
}

}  // namespace plumb::io
