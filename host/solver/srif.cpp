#include "host/solver/srif.h"

#include <cmath>

namespace imuforge::solver {

SquareRootInformationFilter::SquareRootInformationFilter(std::vector<std::string> names) : names_(std::move(names)) {
  const int n = size();
  r_ = Eigen::MatrixXd::Zero(n, n);
  z_ = Eigen::VectorXd::Zero(n);
}

void SquareRootInformationFilter::add_rows(const Eigen::MatrixXd& a, const Eigen::VectorXd& b) {
  const int n = size();
  if (a.cols() != n || a.rows() != b.size()) throw SolverError("SRIF: measurement rows have the wrong shape");
  if (!a.allFinite() || !b.allFinite()) throw SolverError("SRIF: measurement rows are not finite");
  const int m = static_cast<int>(a.rows());
  Eigen::MatrixXd stack(n + m, n + 1);
  stack.topLeftCorner(n, n) = r_;
  stack.topRightCorner(n, 1) = z_;
  stack.bottomLeftCorner(m, n) = a;
  stack.bottomRightCorner(m, 1) = b;
  Eigen::HouseholderQR<Eigen::MatrixXd> qr(stack);
  // m ≥ 1, so the factor has at least n + 1 rows; its top n×(n+1) block is the new [R z].
  const Eigen::MatrixXd rr = qr.matrixQR().topRows(n + 1).triangularView<Eigen::Upper>();
  r_ = rr.topLeftCorner(n, n);
  z_ = rr.topRightCorner(n, 1);
  ++segments_;
}

void SquareRootInformationFilter::add_information(const Eigen::MatrixXd& h, const Eigen::VectorXd& g) {
  const int n = size();
  if (h.rows() != n || h.cols() != n || g.size() != n) throw SolverError("SRIF: information has the wrong size");
  // Factor in unit-diagonal coordinates: an eigen-decomposition of the raw information would lose the
  // small directions of parameters with tiny regressors (τ³ terms next to biases) to rounding.
  Eigen::VectorXd d = Eigen::VectorXd::Zero(n);
  for (int i = 0; i < n; ++i) d[i] = h(i, i) > 0 ? 1.0 / std::sqrt(h(i, i)) : 0.0;
  const Eigen::MatrixXd hs = d.asDiagonal() * (0.5 * (h + h.transpose())) * d.asDiagonal();
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(hs);
  const Eigen::VectorXd& lam = es.eigenvalues();
  const double lmax = n ? std::max(lam.maxCoeff(), 0.0) : 0.0;
  std::vector<int> keep;
  for (int k = 0; k < n; ++k)
    if (lam[k] > lmax * 1e-15 && lam[k] > 0) keep.push_back(k);
  const int m = static_cast<int>(keep.size());
  Eigen::MatrixXd a(m, n);
  Eigen::VectorXd b(m);
  const Eigen::VectorXd gs = d.asDiagonal() * g;
  for (int i = 0; i < m; ++i) {
    const int k = keep[static_cast<size_t>(i)];
    const Eigen::VectorXd v = es.eigenvectors().col(k);
    const double s = std::sqrt(lam[k]);
    // Scaled rows aₛ = √λ vᵀ satisfy aₛᵀaₛ = Hₛ; back in raw coordinates a = aₛ D⁻¹ with θₛ = D⁻¹θ.
    for (int c = 0; c < n; ++c) a(i, c) = d[c] > 0 ? s * v[c] / d[c] : 0.0;
    b[i] = v.dot(gs) / s;
  }
  if (m == 0) {
    ++segments_;
    return;
  }
  add_rows(a, b);
}

void SquareRootInformationFilter::insert_parameter(int pos, std::string name) {
  const int n = size();
  if (pos < 0 || pos > n) throw SolverError("SRIF: insert position out of range");
  Eigen::MatrixXd r = Eigen::MatrixXd::Zero(n + 1, n + 1);
  Eigen::VectorXd z = Eigen::VectorXd::Zero(n + 1);
  // Old index k moves to k (< pos) or k + 1: entry (i, j) with i ≤ j keeps i' ≤ j', and row/column pos
  // are zero, so [R z] stays upper triangular and still encodes the same information on the old slots.
  const int a = pos, b = n - pos;
  r.topLeftCorner(a, a) = r_.topLeftCorner(a, a);
  r.topRightCorner(a, b) = r_.topRightCorner(a, b);
  r.bottomRightCorner(b, b) = r_.bottomRightCorner(b, b);
  z.head(a) = z_.head(a);
  z.tail(b) = z_.tail(b);
  r_ = std::move(r);
  z_ = std::move(z);
  names_.insert(names_.begin() + pos, std::move(name));
}

void SquareRootInformationFilter::rename(std::vector<std::string> names) {
  if (names.size() != names_.size()) throw SolverError("SRIF: rename with a different number of names");
  names_ = std::move(names);
}

Estimate SquareRootInformationFilter::estimate() const {
  const int n = size();
  if (complete()) {
    Estimate e;
    e.names = names_;
    // θ = R⁻¹ z; covariance = R⁻¹R⁻ᵀ. Triangular solves keep the square-root's accuracy.
    e.value = r_.triangularView<Eigen::Upper>().solve(z_);
    Eigen::MatrixXd rinv = r_.triangularView<Eigen::Upper>().solve(Eigen::MatrixXd::Identity(n, n));
    e.covariance = rinv * rinv.transpose();
    return e;
  }
  return solve_partial(information(), r_.transpose() * z_, names_);
}

bool SquareRootInformationFilter::complete() const {
  const int n = size();
  if (n == 0) return true;
  const Observability o = analyse_observability(information(), names_);
  return o.rank == n;
}

}  // namespace imuforge::solver
