// K-fold held-out evaluation on the information form (estimator.h): the statistics of each fold are
// kept apart, so the fit without fold k is total − fold k (no second pass over the data), and the
// withheld fold is scored from its own sufficient statistics:
//   Σ r²/v over fold k = c_k − 2 θᵀ g_k + θᵀ H_k θ,   its expectation = n_k + tr(H_k Σ_train)
// (θ, Σ_train from the fit without fold k). Used by the diagnosis for every candidate and per-fold fit;
// any estimator (solver or diagnosis) that withholds data goes through it.
#pragma once

#include <vector>

#include "host/estimator/estimator.h"

namespace imuforge::estimator {

// Filled either row by row (add_row, then finish(): total = Σ folds), or, when withholding a fold changes
// the other rows' whitening (the diagnosis's Kalman-whitened GLS), directly: total from the all-data run and
// fold[k] = total − (the run with fold k missing), so fit_without(k) is the exact fit on the training data
// and the fold's own statistics score it; finish() is then not called.
struct FoldedNormalEquations {
  std::vector<NormalEquations> fold;  // per fold (n_obs counts its rows)
  std::vector<double> weight;         // per fold Σ w (the gap's denominator: a weighted mean of r²)
  NormalEquations total;              // Σ over folds (finish())

  FoldedNormalEquations() = default;
  FoldedNormalEquations(int folds, int n_params) { reset(folds, n_params); }
  void reset(int folds, int n_params);
  int folds() const { return static_cast<int>(fold.size()); }
  // One whitened row of fold k (lower triangle only until finish()).
  void add_row(int k, const Eigen::Ref<const Eigen::VectorXd>& x, double r, double w);
  // Symmetrizes every fold and forms the total. Call once, after the last add_row.
  void finish();
  double total_weight() const;
};

// Fold of unit i (a segment, in time order) among K: ⌊K · frac(i · φ⁻¹)⌋, φ the golden ratio. Like i mod K,
// neighbouring units fall in different folds (withholding interleaves in time); unlike it, a schedule that repeats
// one sequence of units (a campaign's per-plateau tumble and rate runs) does not put every unit of one kind in one
// fold when its length is a multiple of K: the Weyl sequence of φ⁻¹, the most badly approximable irrational,
// spreads any period over all folds. Fold sizes stay within about ±2 of n/K. O(1).
int interleaved_fold(int unit, int folds);

// The held-out score of a column set summed over the withheld folds.
struct HeldOut {
  double chi2 = 0, expected = 0, W = 0;
  // Σ over folds of rᵀ(V + X Σ_train Xᵀ)⁻¹ r: the withheld residuals judged against their predictive covariance,
  // the fit's uncertainty included as the rank-p correlation it is, not as the scalar tr(H_k Σ_train) that
  // `expected` adds. It differs from chi2 where a withheld fold lies outside the training folds' span (a long
  // soak withheld whole, its temperatures reached by no other fold): the extrapolated prediction's error is then
  // large along a few directions of the fold's design, and chi2 counts it as misfit. By Woodbury,
  // c − eᵀ(H_train + H_k)⁻¹e with e = g_k − H_k θ. Σ_train = H_train⁻¹ is taken in the SCORE's metric (its rows
  // of the training folds), so H_train + H_k is the score's total information: a leverage correction of the
  // withheld rows' design. The fit's own covariance is in another metric where the two differ (the diagnosis fits
  // blocks under a correlated bias, GLS, and scores segment means on their marginal variances): a random walk
  // leaves a bias column little GLS information, and judged against it every fold's mean offset was forgiven
  // (varied14 ooc-periodic-1 gyro.x: 24.7 per segment to 2.6, a periodic bias of 20–50 σ called at noise). Where
  // fit and score are one set of statistics, E = nb under the model whatever the design. O(p³) per fold.
  double chi2_pred = 0;
  int nb = 0;
  // sqrt(weighted mean of squared held-out residuals) − the same for their predicted variance, units of r.
  double gap() const;
  double rms() const;    // sqrt(chi2 / W)
  double floor() const;  // sqrt(expected / W)
};

// For every fold k that holds rows in `score`: fits the columns `sel` (priority order, fit_subset) on
// `fit` without fold k and scores them on `score`'s fold k. `fit` and `score` share folds and columns;
// they may differ in granularity (e.g. fitted on blocks, scored on whole segments).
HeldOut heldout(const FoldedNormalEquations& fit, const FoldedNormalEquations& score, const std::vector<int>& sel,
                double drop_tol = kDefaultDropTolerance);

// The fit of `sel` without fold k (k < 0: on all data).
SubsetFit fit_without(const FoldedNormalEquations& fne, const std::vector<int>& sel, int k,
                      double drop_tol = kDefaultDropTolerance);

}  // namespace imuforge::estimator
