#include "host/solver/traditional.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <vector>

namespace imuforge::solver {

namespace {
constexpr double kAxisCos = 0.996;           // within ~5° of a table axis counts as "along e_k"
constexpr double kStaticRate_rad_s = 0.01;   // below: a static dwell (Earth rate is 7e-5)
constexpr double kRateRun_rad_s = 0.05;      // above: a rate-table run
const char* kAxis = "xyz";
const char* kSign[2] = {"+", "-"};

struct Group {
  Eigen::Vector3d y = Eigen::Vector3d::Zero(), ref = Eigen::Vector3d::Zero();
  int n = 0;
};

int along_axis(const Eigen::Vector3d& v, int& sign) {
  const double nv = v.norm();
  if (!(nv > 0)) return -1;
  for (int k = 0; k < 3; ++k)
    if (std::abs(v[k]) / nv > kAxisCos) {
      sign = v[k] > 0 ? 0 : 1;
      return k;
    }
  return -1;
}
}  // namespace

TraditionalResult solve_traditional(const std::map<int, SegmentSummary>& segments, double T_ref_C) {
  if (segments.empty()) throw SolverError("traditional method: the log has no fixture dwell");
  // Plateaus by distance of their mean die temperature from T_ref: the nearest one that holds all six
  // positions and both rate directions per axis is used (a campaign may soak at T_ref without a tumble).
  std::map<int, std::pair<double, long long>> pl;
  for (const auto& [id, s] : segments) {
    (void)id;
    if (s.plateau < 0) continue;  // in transit (fixture.h)
    pl[s.plateau].first += s.T_C * static_cast<double>(s.n);
    pl[s.plateau].second += s.n;
  }
  std::vector<std::pair<double, int>> order;  // (|T − T_ref|, plateau)
  std::map<int, double> plateau_T;
  for (const auto& [p, v] : pl) {
    plateau_T[p] = v.first / static_cast<double>(v.second);
    order.push_back({std::abs(plateau_T[p] - T_ref_C), p});
  }
  std::sort(order.begin(), order.end());
  Group acc[3][2], gyr[3][2];
  auto collect = [&](int plateau) {
    for (int k = 0; k < 3; ++k)
      for (int sg = 0; sg < 2; ++sg) acc[k][sg] = gyr[k][sg] = Group{};
    for (const auto& [id, s] : segments) {
      (void)id;
      if (s.plateau != plateau) continue;
      const Eigen::Vector3d ya(s.y[0], s.y[1], s.y[2]), yg(s.y[3], s.y[4], s.y[5]);
      int sg = 0;
      if (s.w_ref.norm() < kStaticRate_rad_s) {
        const int k = along_axis(s.f_ref, sg);
        if (k >= 0) {
          Group& g = acc[k][sg];
          g.y += ya; g.ref += s.f_ref; ++g.n;
        }
      } else if (s.w_ref.norm() > kRateRun_rad_s) {
        const int k = along_axis(s.w_ref, sg);
        if (k >= 0) {
          Group& g = gyr[k][sg];
          g.y += yg; g.ref += s.w_ref; ++g.n;
        }
      }
    }
    for (int k = 0; k < 3; ++k)
      for (int sg = 0; sg < 2; ++sg)
        if (acc[k][sg].n == 0 || gyr[k][sg].n == 0) return false;
    return true;
  };
  int plateau = order.empty() ? -1 : order.front().second;
  for (const auto& [d, p] : order) {
    (void)d;
    if (collect(p)) {
      plateau = p;
      break;
    }
  }
  if (plateau >= 0 && !collect(plateau)) collect(order.front().second);  // the nearest, for the error below
  TraditionalResult r;
  r.plateau_T_C = plateau >= 0 ? plateau_T[plateau] : 0.0;
  Eigen::Matrix3d IMa, IMg;
  Eigen::Vector3d ba = Eigen::Vector3d::Zero(), bg = Eigen::Vector3d::Zero();
  Eigen::Vector3d ya_sum = Eigen::Vector3d::Zero(), fa_sum = Eigen::Vector3d::Zero();
  Eigen::Vector3d yg_sum = Eigen::Vector3d::Zero(), wg_sum = Eigen::Vector3d::Zero();
  for (int k = 0; k < 3; ++k) {
    for (int sg = 0; sg < 2; ++sg) {
      if (acc[k][sg].n == 0)
        throw SolverError(std::string("traditional method: no static dwell with the reference along ") + kSign[sg] +
                          kAxis[k] + " at any plateau (six-position averages need all six)");
      if (gyr[k][sg].n == 0)
        throw SolverError(std::string("traditional method: no rate run about ") + kSign[sg] + kAxis[k] +
                          " at any plateau (CW/CCW averages need both directions per axis)");
      for (Group* g : {&acc[k][sg], &gyr[k][sg]}) {
        g->y /= g->n;
        g->ref /= g->n;
      }
      r.accel_dwells += acc[k][sg].n;
      r.gyro_dwells += gyr[k][sg].n;
    }
    IMa.col(k) = (acc[k][0].y - acc[k][1].y) / (acc[k][0].ref[k] - acc[k][1].ref[k]);
    IMg.col(k) = (gyr[k][0].y - gyr[k][1].y) / (gyr[k][0].ref[k] - gyr[k][1].ref[k]);
  }
  for (int k = 0; k < 3; ++k)
    for (int sg = 0; sg < 2; ++sg) {
      ya_sum += acc[k][sg].y;
      fa_sum += acc[k][sg].ref;
      yg_sum += gyr[k][sg].y;
      wg_sum += gyr[k][sg].ref;
    }
  ba = (ya_sum - IMa * fa_sum) / 6.0;
  bg = (yg_sum - IMg * wg_sum) / 6.0;
  Estimate& e = r.estimate;
  std::vector<double> v;
  for (int s = 0; s < 2; ++s) {
    const std::string sn = s ? "gyro" : "accel";
    const Eigen::Matrix3d& IM = s ? IMg : IMa;
    const Eigen::Vector3d& b = s ? bg : ba;
    for (int j = 0; j < 3; ++j) { e.names.push_back(sn + ".bias." + kAxis[j]); v.push_back(b[j]); }
    for (int j = 0; j < 3; ++j) { e.names.push_back(sn + ".scale." + kAxis[j]); v.push_back(IM(j, j) - 1.0); }
    for (int j = 0; j < 3; ++j)
      for (int k = 0; k < 3; ++k)
        if (j != k) { e.names.push_back(sn + ".misalign." + kAxis[j] + kAxis[k]); v.push_back(IM(j, k)); }
  }
  e.value = Eigen::Map<Eigen::VectorXd>(v.data(), static_cast<long>(v.size()));
  e.covariance.resize(0, 0);
  return r;
}

}  // namespace imuforge::solver
