// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cmath>
#include <cstdint>
#include <random>

namespace plumb {

/// @brief The one random engine of plumb: every algorithm that samples takes `settings.seed` and
/// builds its own Rng, so results depend on the seed only (never on global state or time).
/// @note std::mt19937_64's sequence is fixed by the standard, so a seed gives the same numbers on
///       every platform; distributions are written here by hand for the same reason (the standard
///       library's distributions differ between implementations).
class Rng {
 public:
  explicit Rng(std::uint64_t seed = 42) : engine_(seed) {}

  /// @brief Uniform integer in [0, n), n > 0 (Lemire's unbiased method is overkill here; the
  /// rejection loop keeps it exact).
  std::uint64_t uniform_index(std::uint64_t n) {
    const std::uint64_t limit = ~std::uint64_t{0} - (~std::uint64_t{0} % n);
    std::uint64_t r;
    do { r = engine_(); } while (r >= limit);
    return r % n;
  }

  /// @brief Uniform double in [0, 1).
  double uniform() { return static_cast<double>(engine_() >> 11) * 0x1.0p-53; }

  /// @brief Uniform double in [lo, hi).
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }

  /// @brief Standard normal by the Box-Muller transform (portable across standard libraries).
  double normal() {
    if (has_spare_) { has_spare_ = false; return spare_; }
    double u1;
    do { u1 = uniform(); } while (u1 <= 0.0);
    const double u2 = uniform();
    const double r = std::sqrt(-2.0 * std::log(u1));
    const double a = 6.283185307179586476925 * u2;
    spare_ = r * std::sin(a);
    has_spare_ = true;
    return r * std::cos(a);
  }

  /// @brief Normal with mean mu and standard deviation sigma.
  double normal(double mu, double sigma) { return mu + sigma * normal(); }

  std::mt19937_64& engine() { return engine_; }

 private:
  std::mt19937_64 engine_;
  double spare_ = 0.0;
  bool has_spare_ = false;
};

}  // namespace plumb
