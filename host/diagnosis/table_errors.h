// The rate table's axis errors for the diagnosis (Options::table; docs/diagnosis.md § 6, "Fixture errors"): the
// reference's change when the table's axes are tilted and its encoders' zeros offset, and its derivative by each
// error, evaluated at the reported angles and rates by the one kinematics the simulator and the fixture+errors
// solver use (host/physics/table.h). diagnose.cpp estimates the errors from the derivative's block means and
// re-runs on a source that adds the correction to the logged reference.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <string>
#include <vector>

#include "host/diagnosis/diagnose.h"
#include "host/physics/campaign.h"
#include "host/physics/table.h"

namespace imuforge::diagnosis {

// Options::table for a log taken with campaign c (`diagnose --campaign`, the Python module, the tests): its nominal
// geometry and the Earth at its site. Throws DiagnosisError naming campaign_name when the log does not carry the
// reported angle of every table axis (log_table_axes: io::LogMeta::table_axes).
Options::Table table_of_campaign(const physics::Campaign& c, int log_table_axes, const std::string& campaign_name);

// The rate table's axis errors (Options::table; docs/diagnosis.md, "Fixture errors"). Error m = 3·axis + {tilt_a,
// tilt_b, zero} (physics::AxisError: the fixture+errors solver's nuisance parameters, in its order). The
// kinematics are the one implementation the simulator and the solver use (physics::table_kinematics), evaluated
// at the REPORTED angles and rates, as the log's reference was; the table's angular acceleration is not logged
// and taken as 0 (a dwell turns at a constant rate). Each instance caches its last evaluation: the reported
// angles carry encoder noise of micro-radians, far below the kTol the reference's dependence on the pose needs
// (a change of 1e-4 rad moves a correction of 1e-3 m/s² by 1e-7), so a static dwell costs one evaluation.
// Cost per call: O(1) within kTol of the cached state, else 2 (correction) or 1 + 3·axes (derivative) evaluations
// of the kinematics, each O(axes); no allocation after construction. Not thread-safe (the cache).
class TableErrors {
 public:
  static constexpr int kMax = 3 * physics::kMaxTableAxes;
  using Jac = Eigen::Matrix<double, 6, kMax>;  // ∂(f, ω)/∂error, f rows 0–2 and ω rows 3–5
  explicit TableErrors(const Options& o) : known_(o.table.known), g_(o.table.g_ned), wie_(o.table.wie_ned) {
    if (!known_) return;
    n_axes_ = o.table.nominal.n_axes;
    physics::TableGeometry cur = o.table.nominal;
    for (int i = 0; i < n_axes_; ++i) cur.axes[static_cast<std::size_t>(i)].error = o.fixture_error[static_cast<std::size_t>(i)];
    for (int m = 0; m < 3 * n_axes_; ++m) corrected_ = corrected_ || o.fixture_error[static_cast<std::size_t>(m / 3)].part(m % 3) != 0.0;
    tables_.emplace_back(o.table.nominal);
    tables_.emplace_back(cur);
    for (int m = 0; m < 3 * n_axes_; ++m) {
      physics::TableGeometry g = cur;
      g.axes[static_cast<std::size_t>(m / 3)].error.part(m % 3) += kStep;
      tables_.emplace_back(g);
    }
  }
  bool known() const { return known_; }
  bool corrected() const { return corrected_; }
  int n() const { return 3 * n_axes_; }
  // The reported table state of a sample, dt_s earlier (a sensor read at its shifted time: the angle moves back by
  // rate·dt within a dwell, the only place a shifted sample is read); false when the log carries no angles.
  bool state_of(const Sample& s, double dt_s, physics::TableState& st) const {
    for (int i = 0; i < n_axes_; ++i) {
      const double a = s.table_angle_rad[i], r = std::isfinite(s.table_rate_rad_s[i]) ? s.table_rate_rad_s[i] : 0.0;
      if (!std::isfinite(a)) return false;
      st.angle_rad[static_cast<std::size_t>(i)] = a - r * dt_s;
      st.rate_rad_s[static_cast<std::size_t>(i)] = r;
      st.accel_rad_s2[static_cast<std::size_t>(i)] = 0.0;
    }
    return true;
  }
  // What the reference lacks: (f, ω) at the corrected geometry minus at the nominal one.
  const Eigen::Matrix<double, 6, 1>& correction(const physics::TableState& st) {
    if (!fresh(st, have_corr_, corr_state_, kTol)) {
      const auto kn = physics::table_kinematics(tables_[0], st, g_, wie_);
      const auto kc = physics::table_kinematics(tables_[1], st, g_, wie_);
      corr_.head<3>() = kc.f_mps2 - kn.f_mps2;
      corr_.tail<3>() = kc.w_rad_s - kn.w_rad_s;
    }
    return corr_;
  }
  // ∂(f, ω)/∂error at the corrected geometry (forward differences; the step's truncation is kStep·|f| ≈ 1e-5 of D).
  const Jac& derivative(const physics::TableState& st) {
    if (!fresh(st, have_jac_, jac_state_, kTolJac)) {
      jac_.setZero();
      const auto k0 = physics::table_kinematics(tables_[1], st, g_, wie_);
      for (int m = 0; m < n(); ++m) {
        const auto k = physics::table_kinematics(tables_[static_cast<std::size_t>(2 + m)], st, g_, wie_);
        jac_.block<3, 1>(0, m) = (k.f_mps2 - k0.f_mps2) / kStep;
        jac_.block<3, 1>(3, m) = (k.w_rad_s - k0.w_rad_s) / kStep;
      }
    }
    return jac_;
  }

 private:
  // The derivative is held over 1e-3 rad (rad/s): it enters only block means that estimate errors of ~1e-4 rad, and
  // a hold that long moves it by 1e-3 of itself (2e-7 m/s² at that error). Inside motion the caller asks for it
  // about every 10 ms only (diagnose.cpp, DerivativeGroup: the midpoint of each group of samples); on the sines'
  // slow ends and on every dwell the hold spares even those. The correction, added to every sample, is held over
  // kTol only.
  static constexpr double kStep = 1e-6, kTol = 1e-4, kTolJac = 1e-3;
  bool fresh(const physics::TableState& st, bool& have, physics::TableState& last, double tol) const {
    bool same = have;
    for (int i = 0; i < n_axes_ && same; ++i) {
      const auto ui = static_cast<std::size_t>(i);
      same = std::fabs(st.angle_rad[ui] - last.angle_rad[ui]) < tol && std::fabs(st.rate_rad_s[ui] - last.rate_rad_s[ui]) < tol;
    }
    if (!same) {
      last = st;
      have = true;
    }
    return same;
  }
  bool known_ = false, corrected_ = false;
  int n_axes_ = 0;
  Eigen::Vector3d g_, wie_;
  std::vector<physics::PreparedTable> tables_;  // nominal, corrected, corrected + kStep on each error
  bool have_corr_ = false, have_jac_ = false;
  physics::TableState corr_state_, jac_state_;
  Eigen::Matrix<double, 6, 1> corr_ = Eigen::Matrix<double, 6, 1>::Zero();
  Jac jac_ = Jac::Zero();
};

// The log's reference re-evaluated at the table's axis errors (Options::fixture_error): every pass of a run
// reads it, so the timing's interpolation, the noise and the blocks all see one reference.
class FixtureCorrectedSource : public SampleSource {
 public:
  FixtureCorrectedSource(SampleSource& inner, const Options& o) : inner_(inner), te_(o) {}
  bool active() const { return te_.known() && te_.corrected(); }
  void rewind() override { inner_.rewind(); }
  bool next(Sample& s) override {
    if (!inner_.next(s)) return false;
    physics::TableState st;
    if (s.has_ref && te_.state_of(s, 0.0, st)) {
      const auto& c = te_.correction(st);
      for (int k = 0; k < 3; ++k) {
        s.f[k] += c[k];
        s.w[k] += c[3 + k];
      }
    }
    return true;
  }

 private:
  SampleSource& inner_;
  TableErrors te_;
};

}  // namespace imuforge::diagnosis
