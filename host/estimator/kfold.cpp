#include "host/estimator/kfold.h"

#include <algorithm>
#include <cmath>

namespace imuforge::estimator {

int interleaved_fold(int unit, int folds) {
  if (folds <= 1) return 0;
  const double inv_phi = 0.5 * (std::sqrt(5.0) - 1.0);
  const double x = static_cast<double>(unit) * inv_phi;
  return std::min(folds - 1, static_cast<int>(static_cast<double>(folds) * (x - std::floor(x))));
}

void FoldedNormalEquations::reset(int folds, int n_params) {
  fold.assign(static_cast<size_t>(std::max(folds, 0)), NormalEquations(n_params));
  weight.assign(fold.size(), 0.0);
  total.reset(n_params);
}

void FoldedNormalEquations::add_row(int k, const Eigen::Ref<const Eigen::VectorXd>& x, double r, double w) {
  if (k < 0 || k >= folds()) throw EstimatorError("k-fold: fold index out of range");
  fold[static_cast<size_t>(k)].add_row_lower(x, r, w);
  weight[static_cast<size_t>(k)] += w;
}

void FoldedNormalEquations::finish() {
  total.reset(total.size());
  for (auto& f : fold) {
    f.symmetrize();
    total += f;
  }
}

double FoldedNormalEquations::total_weight() const {
  double s = 0;
  for (double w : weight) s += w;
  return s;
}

double HeldOut::gap() const { return W > 0 ? (std::sqrt(std::max(chi2, 0.0)) - std::sqrt(expected)) / std::sqrt(W) : 0.0; }
double HeldOut::rms() const { return W > 0 ? std::sqrt(std::max(chi2, 0.0) / W) : 0.0; }
double HeldOut::floor() const { return W > 0 ? std::sqrt(expected / W) : 0.0; }

SubsetFit fit_without(const FoldedNormalEquations& fne, const std::vector<int>& sel, int k, double drop_tol) {
  if (k >= fne.folds()) throw EstimatorError("k-fold: fold index out of range");
  return fit_subset(fne.total, sel, k >= 0 ? &fne.fold[static_cast<size_t>(k)] : nullptr, drop_tol);
}

HeldOut heldout(const FoldedNormalEquations& fit, const FoldedNormalEquations& score, const std::vector<int>& sel,
                double drop_tol) {
  if (fit.folds() != score.folds() || fit.total.size() != score.total.size())
    throw EstimatorError("k-fold: fitted and scored statistics differ in folds or columns");
  HeldOut h;
  for (int k = 0; k < score.folds(); ++k) {
    const NormalEquations& sk = score.fold[static_cast<size_t>(k)];
    if (sk.n_obs == 0) continue;
    const SubsetFit f = fit_without(fit, sel, k, drop_tol);
    const int p = static_cast<int>(f.kept.size());
    Eigen::MatrixXd Hs(p, p);
    Eigen::VectorXd gs(p);
    for (int i = 0; i < p; ++i) {
      gs[i] = sk.rhs[f.kept[static_cast<size_t>(i)]];
      for (int j = 0; j < p; ++j) Hs(i, j) = sk.info(f.kept[static_cast<size_t>(i)], f.kept[static_cast<size_t>(j)]);
    }
    double c = sk.cost, c_pred = 0;
    if (p > 0) {
      c += -2.0 * f.theta.dot(gs) + f.theta.dot(Hs * f.theta);
      h.expected += (Hs * f.cov).trace();
      // eᵀ(H_train + H_k)⁻¹e, H_train + H_k in the score's own metric: its total information (the header says why
      // not the fit's). Solved by fit_subset, whose drop tolerance keeps a column that is a combination of the
      // others at the segment level (a rate's derivative averaged over whole dwells) from blowing the term up.
      NormalEquations m = score.total;
      m.rhs.setZero();
      for (int i = 0; i < p; ++i) m.rhs[f.kept[static_cast<size_t>(i)]] = gs[i] - Hs.row(i).dot(f.theta);
      const SubsetFit q = fit_subset(m, f.kept, nullptr, drop_tol);
      for (int i = 0; i < static_cast<int>(q.kept.size()); ++i) c_pred += m.rhs[q.kept[static_cast<size_t>(i)]] * q.theta[i];
    }
    h.chi2 += c;
    h.chi2_pred += std::max(c - c_pred, 0.0);
    h.expected += static_cast<double>(sk.n_obs);
    h.W += score.weight[static_cast<size_t>(k)];
    h.nb += static_cast<int>(sk.n_obs);
  }
  return h;
}

}  // namespace imuforge::estimator
