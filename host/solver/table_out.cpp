#include "host/solver/table_out.h"

#include <array>
#include <cmath>
#include <cstdlib>
#include <limits>

#include "host/table/host_kernel.h"
#include "host/table/table_writer.h"

namespace imuforge::solver {

nlohmann::json TableReport::to_json() const {
  nlohmann::json j;
  j["ok"] = ok;
  j["bytes"] = bytes;
  j["breakpoints_C"] = breakpoints_C;
  j["samples_checked"] = samples;
  j["quantisation_rms"] = rms_diff;
  j["quantisation_over_noise"] = ratio;
  j["worst_ratio"] = worst_ratio;
  j["worst_channel"] = worst_channel;
  j["limit"] = 0.1;
  return j;
}

namespace {
const char* kAxisLetter = "xyz";

// The calibrated sensor model at one temperature: b(T), M(T) per triad, from polynomial or per-plateau
// parameters. Throws for parameters the table cannot express.
struct TriadAt {
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  Eigen::Matrix3d M = Eigen::Matrix3d::Zero();
};

void check_expressible(const Estimate& e) {
  for (const auto& n : e.names)
    if (!table_expressible(n) || n.find(".g_sensitivity.") != std::string::npos)
      throw SolverError("coefficient table v1 holds bias, scale, misalignment and their temperature dependence; "
                        "it cannot express " + n);
}

// The triad's coefficients as polynomials in τ = T − T_ref (power 0..3), looked up by name once: the
// per-sample check below only evaluates them. `plateau` ≥ 0 also reads "<name>@plateau<k>".
struct TriadPoly {
  std::array<Eigen::Vector3d, 4> b;
  std::array<Eigen::Matrix3d, 4> M;
  Eigen::Matrix3d G = Eigen::Matrix3d::Zero();  // gyro g-sensitivity (sensor model), no temperature term
  TriadAt at(double tau) const {
    TriadAt t;
    double tp = 1.0;
    for (int p = 0; p <= 3; ++p, tp *= tau) {
      t.b += tp * b[static_cast<size_t>(p)];
      t.M += tp * M[static_cast<size_t>(p)];
    }
    return t;
  }
};

TriadPoly triad_poly(const Estimate& e, const std::string& s, int plateau) {
  TriadPoly t;
  for (int p = 0; p <= 3; ++p) {
    t.b[static_cast<size_t>(p)].setZero();
    t.M[static_cast<size_t>(p)].setZero();
  }
  auto get = [&](const std::string& name) {
    int i = e.index_of(name);
    if (i < 0 && plateau >= 0) i = e.index_of(name + "@plateau" + std::to_string(plateau));
    return i >= 0 ? e.value[i] : 0.0;
  };
  for (int j = 0; j < 3; ++j) {
    t.b[0][j] = get(s + ".bias." + kAxisLetter[j]);
    t.M[0](j, j) = get(s + ".scale." + kAxisLetter[j]);
    for (int p = 1; p <= 3; ++p) {
      t.b[static_cast<size_t>(p)][j] = get(s + ".bias_temp." + kAxisLetter[j] + ".t" + std::to_string(p));
      t.M[static_cast<size_t>(p)](j, j) = get(s + ".scale_temp." + kAxisLetter[j] + ".t" + std::to_string(p));
    }
    for (int k = 0; k < 3; ++k) {
      if (k == j) continue;
      const std::string c = std::string(1, kAxisLetter[j]) + kAxisLetter[k];
      t.M[0](j, k) = get(s + ".misalign." + c);
      for (int p = 1; p <= 3; ++p) t.M[static_cast<size_t>(p)](j, k) = get(s + ".misalign_temp." + c + ".t" + std::to_string(p));
    }
    if (s == "gyro")
      for (int k = 0; k < 3; ++k) t.G(j, k) = get(s + ".g_sensitivity." + std::string(1, kAxisLetter[j]) + kAxisLetter[k]);
  }
  return t;
}

TriadAt triad_at(const Estimate& e, const std::string& s, double T_C, double T_ref_C, int plateau) {
  return triad_poly(e, s, plateau).at(T_C - T_ref_C);
}
}  // namespace

bool table_expressible(const std::string& name) {
  const std::string base = name.substr(0, name.find('@'));
  for (const char* eff : {".bias.", ".scale.", ".misalign.", ".bias_temp.", ".scale_temp.", ".misalign_temp."})
    if (base.find(eff) != std::string::npos) return true;
  return base.rfind("fixture.", 0) == 0 || base.rfind("gyro.g_sensitivity.", 0) == 0;
}

table::TableSpec table_spec_from_estimate(const Estimate& e, double T_ref_C, const std::vector<double>& bps,
                                          const std::vector<int>& bp_plateau) {
  table::TableSpec spec;
  spec.kind = table::SpecKind::kSensorModel;
  const Eigen::Matrix3d G = triad_poly(e, "gyro", -1).G;
  for (size_t i = 0; i < bps.size(); ++i) {
    table::BreakpointSpec b;
    b.temp_degC = bps[i];
    const int pl = i < bp_plateau.size() ? bp_plateau[i] : -1;
    const TriadAt a = triad_at(e, "accel", bps[i], T_ref_C, pl);
    const TriadAt g = triad_at(e, "gyro", bps[i], T_ref_C, pl);
    b.accel_M = a.M;
    b.accel_b = a.b;
    b.gyro_M = g.M;
    b.gyro_b = g.b;
    b.gyro_G_sensor = G;
    spec.breakpoints.push_back(b);
  }
  return spec;
}

TableReport write_coefficient_table(const CalibrationResult& res, io::LogReader& log, const std::string& path,
                                    const std::string& serial) {
  const Estimate& e = res.estimate;
  check_expressible(e);
  char* end = nullptr;
  const unsigned long long ser = std::strtoull(serial.c_str(), &end, 10);
  if (serial.empty() || *end != '\0') throw SolverError("--serial must be a decimal device serial, got '" + serial + "'");
  // Pass 1: temperature span and raw word width of the log.
  log.rewind();
  io::LogRow row;
  double tmin = std::numeric_limits<double>::infinity(), tmax = -tmin;
  std::int64_t max_raw = 0;
  while (log.next(row)) {
    if (std::isfinite(row.temp_C)) {
      tmin = std::min(tmin, row.temp_C);
      tmax = std::max(tmax, row.temp_C);
    }
    for (int c = 0; c < 6; ++c) max_raw = std::max<std::int64_t>(max_raw, std::llabs(static_cast<long long>(row.raw[c])));
  }
  bool per_plateau = false;
  for (const auto& n : e.names) per_plateau = per_plateau || n.find("@plateau") != std::string::npos;
  table::TableSpec spec;
  spec.device_serial = ser;
  spec.table_sequence = 1;
  spec.accel_lsb_mps2 = log.meta().accel_lsb_mps2;
  spec.gyro_lsb_rad_s = log.meta().gyro_lsb_rad_s;
  const int bits = max_raw < 32768 ? 16 : max_raw < (1 << 19) ? 20 : 24;
  spec.accel_raw_bits = spec.gyro_raw_bits = bits;
  spec.kind = table::SpecKind::kSensorModel;
  std::vector<double> bps;
  std::vector<int> bp_plateau;
  if (per_plateau) {
    const auto it = res.extra.find("plateaus");
    if (it == res.extra.end()) throw SolverError("per-plateau estimate without plateau temperatures");
    int p = 0;
    for (const auto& pl : *it) {
      bps.push_back(pl["T_C"].get<double>());
      bp_plateau.push_back(p++);
    }
    if (bps.size() > 16) throw SolverError("more than 16 plateaus: table v1 holds at most 16 breakpoints");
  } else if (!std::isfinite(tmin) || tmax - tmin < 0.5) {
    bps.push_back(std::isfinite(tmin) ? 0.5 * (tmin + tmax) : res.T_ref_C);
    bp_plateau.push_back(-1);
  } else {
    // 16 breakpoints over the calibrated span: linear interpolation of a cubic over ≤ 1/15 of the span.
    for (int i = 0; i < 16; ++i) {
      bps.push_back(tmin + (tmax - tmin) * i / 15.0);
      bp_plateau.push_back(-1);
    }
  }
  {
    const table::TableSpec coeffs = table_spec_from_estimate(e, res.T_ref_C, bps, bp_plateau);
    spec.breakpoints = coeffs.breakpoints;
  }
  std::vector<std::uint8_t> bytes;
  fw::Table tbl;
  try {
    tbl = table::build_table(spec);
    bytes = table::serialize_table(tbl);
    table::write_table_file(path, bytes);
  } catch (const table::TableError& ex) {
    throw SolverError(std::string("coefficient table: ") + ex.what());
  }
  // Pass 2: the firmware kernel (f32 path, the host build of the MCU source) against the double-precision
  // inverse of the calibrated model on every logged sample.
  TableReport rep;
  rep.bytes = bytes.size();
  rep.breakpoints_C = bps;
  table::HostKernel k(tbl, table::KernelPath::kF32, 0.0);
  // Reference compensation (C, b per triad): per plateau, interpolated between the breakpoints as the
  // table does; with polynomials, the exact inverse at the sample's temperature.
  struct Comp {
    Eigen::Matrix3d Ca, Cg;
    Eigen::Vector3d ba, bg;
  };
  std::vector<Comp> at_bp;
  if (per_plateau)
    for (size_t i = 0; i < bps.size(); ++i) {
      const TriadAt a = triad_at(e, "accel", bps[i], res.T_ref_C, static_cast<int>(i));
      const TriadAt g = triad_at(e, "gyro", bps[i], res.T_ref_C, static_cast<int>(i));
      at_bp.push_back({(Eigen::Matrix3d::Identity() + a.M).inverse(), (Eigen::Matrix3d::Identity() + g.M).inverse(), a.b, g.b});
    }
  const TriadPoly pa = triad_poly(e, "accel", -1), pg = triad_poly(e, "gyro", -1);
  log.rewind();
  std::array<double, 6> ss{};
  while (log.next(row)) {
    const double T = std::isfinite(row.temp_C) ? std::min(std::max(row.temp_C, bps.front()), bps.back()) : bps.front();
    const table::CompensatedSample out = k.run(row.raw, row.temp_C);
    Comp r;
    if (per_plateau) {
      size_t i = 0;
      while (i + 1 < bps.size() && bps[i + 1] < T) ++i;
      const size_t i1 = std::min(i + 1, bps.size() - 1);
      const double w = i1 == i ? 0.0 : (T - bps[i]) / (bps[i1] - bps[i]);
      const Comp& c0 = at_bp[i];
      const Comp& c1 = at_bp[i1];
      r = {(1 - w) * c0.Ca + w * c1.Ca, (1 - w) * c0.Cg + w * c1.Cg, (1 - w) * c0.ba + w * c1.ba, (1 - w) * c0.bg + w * c1.bg};
    } else {
      const TriadAt a = pa.at(T - res.T_ref_C), g = pg.at(T - res.T_ref_C);
      r = {(Eigen::Matrix3d::Identity() + a.M).inverse(), (Eigen::Matrix3d::Identity() + g.M).inverse(), a.b, g.b};
    }
    const Eigen::Vector3d ya(row.raw[0] * spec.accel_lsb_mps2, row.raw[1] * spec.accel_lsb_mps2, row.raw[2] * spec.accel_lsb_mps2);
    const Eigen::Vector3d yg(row.raw[3] * spec.gyro_lsb_rad_s, row.raw[4] * spec.gyro_lsb_rad_s, row.raw[5] * spec.gyro_lsb_rad_s);
    const Eigen::Vector3d fa = r.Ca * (ya - r.ba), wg = r.Cg * (yg - r.bg);
    for (int c = 0; c < 3; ++c) {
      ss[static_cast<size_t>(c)] += std::pow(out.accel_mps2[c] - fa[c], 2);
      ss[static_cast<size_t>(3 + c)] += std::pow(out.gyro_rad_s[c] - wg[c], 2);
    }
    ++rep.samples;
  }
  rep.ok = rep.samples > 0;
  for (int c = 0; c < 6; ++c) {
    rep.rms_diff[static_cast<size_t>(c)] = rep.samples ? std::sqrt(ss[static_cast<size_t>(c)] / static_cast<double>(rep.samples)) : 0.0;
    const double sig = res.noise_sigma[static_cast<size_t>(c)];
    rep.ratio[static_cast<size_t>(c)] = sig > 0 ? rep.rms_diff[static_cast<size_t>(c)] / sig : std::numeric_limits<double>::infinity();
    if (rep.ratio[static_cast<size_t>(c)] >= rep.worst_ratio) {
      rep.worst_ratio = rep.ratio[static_cast<size_t>(c)];
      rep.worst_channel = channel_name(c);
    }
  }
  rep.ok = rep.ok && rep.worst_ratio < 0.1;
  return rep;
}

}  // namespace imuforge::solver
