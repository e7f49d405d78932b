// Robust location and scale: the median, and σ from the median absolute value (1.4826 × MAD is a normal
// distribution's σ). One definition for every part that reads a scale off residuals with outliers among them
// (the diagnosis's glitch filter and timing probes, the estimator's drift model, the solver's repeatability, the
// batch report), so a robust σ means the same thing wherever it is printed.
//
// Header-only, no allocation of its own. Each function is O(n) (std::nth_element) and reorders its argument.
#pragma once

#include <algorithm>
#include <cstddef>
#include <vector>

namespace imuforge::estimator {

// σ of a normal distribution over its median absolute deviation (1 / Φ⁻¹(3/4)).
inline constexpr double kMadToSigma = 1.4826;

// Element n/2 of v once sorted (for an even n the upper of the two middle values: the callers read a scale off
// hundreds of values, where the difference is noise, and need no copy). v must not be empty; it is reordered.
inline double upper_median_in_place(std::vector<double>& v) {
  const std::size_t m = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(m), v.end());
  return v[m];
}

// σ of values scattered about zero, from their magnitudes: kMadToSigma × the upper median of |e|. magnitudes must
// hold |e| (not e) and must not be empty; it is reordered.
inline double robust_sigma_of_magnitudes(std::vector<double>& magnitudes) {
  return kMadToSigma * upper_median_in_place(magnitudes);
}

// The median (for an even n the mean of the two middle values), for reports where a batch of a few units is summed
// up. O(n log n); v is taken by value. 0 for an empty v.
inline double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

}  // namespace imuforge::estimator
