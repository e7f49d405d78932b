// Recursive estimation during collection: a square-root information filter (SRIF, Bierman 1977).
//
// The state is the upper-triangular square root R of the information (H = RᵀR) and z = R θ̂. Adding
// whitened measurement rows A θ ≈ b is one Householder QR of the stacked array [R z; A b], O(n²(n+m)).
// Because the calibration parameters are constant (no process noise), after the last segment R and z carry
// exactly the batch normal equations, so the recursive estimate equals the batch one to rounding.
//
// Use:
//   SquareRootInformationFilter f(names);
//   for each segment: f.add_information(H_s, g_s);  // or add_rows(A, b)
//   f.insert_parameter(k, "x@plateau2");            // a new unknown appears (zero information)
//   Estimate e = f.estimate();    // σ = +inf for parameters the data so far cannot determine
#pragma once

#include <Eigen/Dense>
#include <string>
#include <vector>

#include "host/solver/estimate.h"

namespace imuforge::solver {

class SquareRootInformationFilter {
 public:
  explicit SquareRootInformationFilter(std::vector<std::string> names);

  // Whitened rows: each row a_i θ ≈ b_i with unit noise. O(n²(n+m)).
  void add_rows(const Eigen::MatrixXd& a, const Eigen::VectorXd& b);
  // A segment given as normal equations (H_s = Σ aᵢᵀaᵢ, g_s = Σ aᵢᵀbᵢ). Factored into ≤ n rows by an
  // eigen-decomposition (H_s may be singular: one segment rarely determines every parameter). O(n³).
  void add_information(const Eigen::MatrixXd& h, const Eigen::VectorXd& g);

  // Grows the state by one parameter at index pos (0..size()) with zero prior information, e.g. a
  // per-plateau slot when a new plateau is discovered. Inserting a zero row and column at the same
  // index keeps R upper triangular, so the filter continues exactly. O(n²).
  void insert_parameter(int pos, std::string name);
  // Renames the parameters (same count), e.g. when plateau indices shift after an insertion.
  void rename(std::vector<std::string> names);

  int size() const { return static_cast<int>(names_.size()); }
  const std::vector<std::string>& names() const { return names_; }
  long long segments() const { return segments_; }
  Eigen::MatrixXd information() const { return r_.transpose() * r_; }
  // Estimate and covariance so far; σ = +inf where not yet observable.
  Estimate estimate() const;
  // True once every parameter is observable.
  bool complete() const;

 private:
  std::vector<std::string> names_;
  Eigen::MatrixXd r_;
  Eigen::VectorXd z_;
  long long segments_ = 0;
};

}  // namespace imuforge::solver
