// The Python module `imuforge` (docs/python.md): thin bindings over the host libraries, no logic of its
// own beyond converting between numpy/dicts and the C++ types. Errors raise Python exceptions carrying
// the C++ message (which names the file, line, column, key or dataset at fault).
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cmath>
#include <fstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "host/diagnosis/diagnose.h"
#include "host/diagnosis/sources.h"
#include "host/diagnosis/table_errors.h"
#include "host/io/campaign_file.h"
#include "host/io/import.h"
#include "host/io/log.h"
#include "host/model/sensor_model.h"
#include "host/nav/strapdown.h"
#include "host/navigate/candidates.h"
#include "host/navigate/impact.h"
#include "host/navigate/report.h"
#include "host/sim/trajectory_file.h"
#include "host/sim/vehicle_sim.h"
#include "host/solver/calfile.h"
#include "host/solver/fixture.h"
#include "host/solver/reference_free.h"
#include "host/solver/sha256.h"
#include "host/solver/table_out.h"
#include "host/table/host_kernel.h"
#include "host/table/table_writer.h"

namespace py = pybind11;
using namespace imuforge;

namespace {

// ----------------------------------------------------------------------------- JSON <-> Python objects
py::object to_py(const nlohmann::json& j) { return py::module_::import("json").attr("loads")(j.dump()); }
nlohmann::json from_py(const py::handle& o) {
  return nlohmann::json::parse(py::module_::import("json").attr("dumps")(o).cast<std::string>());
}
// A model given as a path to a JSON file or as a dict.
nlohmann::json json_arg(const py::object& o, const char* what) {
  if (py::isinstance<py::str>(o)) {
    const std::string path = o.cast<std::string>();
    std::ifstream f(path);
    if (!f) throw std::runtime_error(std::string(what) + ": cannot open '" + path + "'");
    try {
      return nlohmann::json::parse(f);
    } catch (const std::exception& e) {
      throw std::runtime_error(std::string(what) + " '" + path + "': not valid JSON: " + e.what());
    }
  }
  return from_py(o);
}

// ---------------------------------------------------------------------------------------------- logs
const char* const kReservedNumbers[] = {"sample_rate_hz", "accel_lsb_mps2", "gyro_lsb_rad_s", "latitude_deg", "height_m",
                                        "gravity_mps2"};

py::dict meta_to_py(const io::LogMeta& m) {
  py::dict d;
  d["format_version"] = m.format_version;
  d["serial"] = m.serial;
  const double v[] = {m.sample_rate_hz, m.accel_lsb_mps2, m.gyro_lsb_rad_s, m.latitude_deg, m.height_m, m.gravity_mps2};
  for (std::size_t i = 0; i < 6; ++i) d[kReservedNumbers[i]] = v[i];
  d["table_axes"] = m.table_axes;
  for (const auto& [k, val] : m.extra) d[py::str(k)] = val;
  return d;
}

io::LogMeta meta_from_py(const py::dict& d) {
  io::LogMeta m;
  double* num[] = {&m.sample_rate_hz, &m.accel_lsb_mps2, &m.gyro_lsb_rad_s, &m.latitude_deg, &m.height_m, &m.gravity_mps2};
  for (auto kv : d) {
    const std::string k = kv.first.cast<std::string>();
    bool done = false;
    for (std::size_t i = 0; i < 6; ++i)
      if (k == kReservedNumbers[i]) {
        *num[i] = kv.second.cast<double>();
        done = true;
      }
    if (done || k == "format_version" || k == "format") continue;
    if (k == "serial") m.serial = kv.second.cast<std::string>();
    else if (k == "table_axes") m.table_axes = kv.second.cast<int>();
    else m.set(k, py::str(kv.second).cast<std::string>());
  }
  return m;
}

template <class T>
py::array_t<T> array2(std::size_t n, std::size_t cols) {
  return py::array_t<T>({static_cast<py::ssize_t>(n), static_cast<py::ssize_t>(cols)});
}

py::dict read_log(const std::string& path) {
  io::LogReader r(path);
  std::vector<io::LogRow> rows;
  io::LogRow row;
  while (r.next(row)) rows.push_back(row);
  const std::size_t n = rows.size();
  py::array_t<double> t(static_cast<py::ssize_t>(n)), temp(static_cast<py::ssize_t>(n)), chamber(static_cast<py::ssize_t>(n));
  py::array_t<std::int32_t> seg(static_cast<py::ssize_t>(n));
  py::array_t<bool> has_ref(static_cast<py::ssize_t>(n));
  auto f = array2<double>(n, 3), w = array2<double>(n, 3), ang = array2<double>(n, 3), rate = array2<double>(n, 3);
  auto acc = array2<double>(n, 3), gyr = array2<double>(n, 3);
  auto raw = array2<std::int32_t>(n, 6);
  auto T = t.mutable_unchecked<1>(), TE = temp.mutable_unchecked<1>(), CH = chamber.mutable_unchecked<1>();
  auto S = seg.mutable_unchecked<1>();
  auto H = has_ref.mutable_unchecked<1>();
  auto F = f.mutable_unchecked<2>(), W = w.mutable_unchecked<2>(), A = ang.mutable_unchecked<2>(),
       R = rate.mutable_unchecked<2>(), AC = acc.mutable_unchecked<2>(), GY = gyr.mutable_unchecked<2>();
  auto RAW = raw.mutable_unchecked<2>();
  const double la = r.meta().accel_lsb_mps2, lg = r.meta().gyro_lsb_rad_s;
  for (py::ssize_t i = 0; i < static_cast<py::ssize_t>(n); ++i) {
    const io::LogRow& x = rows[static_cast<std::size_t>(i)];
    T(i) = x.t_s;
    S(i) = x.segment;
    TE(i) = x.temp_C;
    CH(i) = x.chamber_C;
    H(i) = x.has_ref;
    for (py::ssize_t k = 0; k < 3; ++k) {
      F(i, k) = x.has_ref ? x.f_ref[k] : std::nan("");
      W(i, k) = x.has_ref ? x.w_ref[k] : std::nan("");
      A(i, k) = x.table_angle_rad[k];
      R(i, k) = x.table_rate_rad_s[k];
      AC(i, k) = x.raw[k] * la;
      GY(i, k) = x.raw[3 + k] * lg;
    }
    for (py::ssize_t k = 0; k < 6; ++k) RAW(i, k) = x.raw[k];
  }
  py::dict d;
  d["meta"] = meta_to_py(r.meta());
  d["encoding"] = r.encoding() == io::LogEncoding::kHdf5 ? "h5" : r.encoding() == io::LogEncoding::kBinary ? "bin" : "csv";
  d["t_s"] = t;
  d["segment"] = seg;
  d["temp_C"] = temp;
  d["chamber_C"] = chamber;
  d["has_ref"] = has_ref;
  d["f_ref"] = f;
  d["w_ref"] = w;
  d["raw"] = raw;
  d["accel_mps2"] = acc;
  d["gyro_rad_s"] = gyr;
  d["table_angle_rad"] = ang;
  d["table_rate_rad_s"] = rate;
  return d;
}

void write_log(const std::string& path, const py::dict& log, const std::string& format) {
  if (!log.contains("meta") || !log.contains("t_s") || !log.contains("raw"))
    throw std::runtime_error("write_log: the dict needs 'meta', 't_s' and 'raw' (N×6 counts)");
  const io::LogMeta meta = meta_from_py(log["meta"].cast<py::dict>());
  auto t = log["t_s"].cast<py::array_t<double, py::array::c_style | py::array::forcecast>>();
  auto raw = log["raw"].cast<py::array_t<std::int32_t, py::array::c_style | py::array::forcecast>>();
  const py::ssize_t n = t.shape(0);
  if (raw.ndim() != 2 || raw.shape(0) != n || raw.shape(1) != 6)
    throw std::runtime_error("write_log: 'raw' must be N×6 with N = len(t_s) = " + std::to_string(n));
  auto col = [&](const char* key, py::ssize_t cols) -> py::array_t<double, py::array::c_style | py::array::forcecast> {
    if (!log.contains(key)) return {};
    auto a = log[key].cast<py::array_t<double, py::array::c_style | py::array::forcecast>>();
    if (a.shape(0) != n || (cols > 1 && (a.ndim() != 2 || a.shape(1) != cols)))
      throw std::runtime_error(std::string("write_log: '") + key + "' has the wrong shape");
    return a;
  };
  auto temp = col("temp_C", 1), chamber = col("chamber_C", 1), f = col("f_ref", 3), w = col("w_ref", 3),
       ang = col("table_angle_rad", 3), rate = col("table_rate_rad_s", 3);
  py::array_t<std::int32_t, py::array::c_style | py::array::forcecast> seg;
  if (log.contains("segment")) seg = log["segment"].cast<py::array_t<std::int32_t, py::array::c_style | py::array::forcecast>>();
  io::LogWriter wr(path, meta, io::encoding_from_name(format));
  for (py::ssize_t i = 0; i < n; ++i) {
    io::LogRow r;
    r.t_s = t.at(i);
    if (seg.size()) r.segment = seg.at(i);
    if (temp.size()) r.temp_C = temp.at(i);
    if (chamber.size()) r.chamber_C = chamber.at(i);
    if (f.size() && w.size()) {
      r.has_ref = true;
      for (py::ssize_t k = 0; k < 3; ++k) {
        r.f_ref[k] = f.at(i, k);
        r.w_ref[k] = w.at(i, k);
        if (std::isnan(r.f_ref[k]) || std::isnan(r.w_ref[k])) r.has_ref = false;
      }
    }
    for (py::ssize_t k = 0; k < 6; ++k) r.raw[k] = raw.at(i, k);
    for (py::ssize_t k = 0; k < 3; ++k) {
      if (ang.size()) r.table_angle_rad[k] = ang.at(i, k);
      if (rate.size()) r.table_rate_rad_s[k] = rate.at(i, k);
    }
    wr.write(r);
  }
  wr.close();
}

// ----------------------------------------------------------------------------------- solve, diagnose
py::object solve(const std::string& log_path, const py::object& model, const std::string& mode,
                 const std::string& table_path, const std::string& serial, double static_window_s,
                 double static_min_s) {
  const nlohmann::json spec_json = json_arg(model, "model");
  const model::ModelSpec spec = model::model_spec_from_json(spec_json);
  io::LogReader log(log_path);
  solver::CalibrationResult res;
  res.mode = mode;
  res.model = spec_json;
  res.T_ref_C = spec.T_ref_C;
  res.log_path = log_path;
  res.log_sha256 = solver::sha256_file_hex(log_path);
  if (mode == "reference-free") {
    const solver::RawRecording rec = solver::read_recording(log);
    solver::ReferenceFreeOptions o;
    o.detect.window_s = static_window_s;
    o.detect.min_dwell_s = static_min_s;
    o.for_table = !table_path.empty();
    const solver::ReferenceFreeResult r = solver::solve_reference_free(rec, spec, o);
    res.estimate = r.estimate;
    res.observability = r.observability;
    res.observability.unobservable.clear();
    res.residual_rms = r.residual_rms;
    res.noise_sigma = r.residual_rms;
    res.noise_source = "within-pose scatter";
    res.samples = static_cast<long long>(rec.y.size());
    res.extra["reference_free"] = solver::reference_free_summary(r, rec);
  } else if (mode == "fixture") {
    solver::FixtureAccumulator acc(spec, log.meta());
    io::LogRow row;
    while (log.next(row)) acc.add(row);
    acc.finish();
    const solver::FixtureSolution sol = solver::solve_fixture_widened(acc, acc.static_noise_sigma());
    res.estimate = sol.estimate;
    res.observability = sol.observability;
    res.residual_rms = sol.residual_rms;
    res.noise_sigma = sol.noise_sigma;
    res.noise_source = "static";
    res.samples = acc.samples_used();
  } else {
    throw std::runtime_error("solve: mode '" + mode + "' is not 'fixture' or 'reference-free' (the CLI has the others)");
  }
  if (!table_path.empty()) {
    if (serial.empty()) throw std::runtime_error("solve: table= needs serial=");
    log.rewind();
    const solver::TableReport tr = solver::write_coefficient_table(res, log, table_path, serial);
    res.extra["table"] = tr.to_json();
  }
  return to_py(solver::calibration_to_json(res));
}

py::object diagnose(const std::string& log_path, const py::object& model, const std::string& mode, const std::string& campaign) {
  diagnosis::BaseModel base;
  if (py::isinstance<py::str>(model) && model.cast<std::string>() == "basic") {
    base = diagnosis::basic_model();
  } else {
    nlohmann::json j = json_arg(model, "model");
    if (j.is_object() && j.contains("model") && j["model"].is_object()) j = j["model"];  // a cal.json
    base = diagnosis::base_model_from_spec(model::model_spec_from_json(j));
  }
  diagnosis::LogSource real(log_path);
  diagnosis::SampleSource* src = &real;
  bool any_ref = false;
  diagnosis::Sample s;
  while (!any_ref && src->next(s)) any_ref = s.has_ref;
  src->rewind();
  std::unique_ptr<diagnosis::ReferenceFreeSource> rf;
  if (mode == "reference-free" || (mode == "auto" && !any_ref)) {
    rf = std::make_unique<diagnosis::ReferenceFreeSource>(*src, real.meta().gravity_mps2);
    src = rf.get();
  } else if (mode != "fixture" && mode != "auto") {
    throw std::runtime_error("diagnose: mode must be auto, fixture or reference-free");
  } else if (!any_ref) {
    throw std::runtime_error("diagnose: " + log_path + " has no reference columns; use mode='reference-free'");
  }
  diagnosis::Options opt;
  if (!campaign.empty()) {
    if (rf) throw std::runtime_error("diagnose: campaign= needs a log with a fixture reference; " + log_path + " is diagnosed reference-free");
    opt.table = diagnosis::table_of_campaign(io::load_campaign(campaign), real.meta().table_axes, campaign);
  }
  const diagnosis::DiagnosisResult r = diagnosis::diagnose(*src, base, opt);
  nlohmann::json j = diagnosis::to_json(r);
  j["inputs"] = {{"log", log_path}, {"mode", rf ? "reference-free" : "fixture"}};
  return to_py(j);
}

// ------------------------------------------------------------------------------------ cal.json, tables
py::object read_cal(const std::string& path) {
  std::ifstream f(path);
  if (!f) throw std::runtime_error(path + ": cannot open");
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(f);
  } catch (const std::exception& e) {
    throw std::runtime_error(path + ": not valid JSON: " + e.what());
  }
  try {
    solver::calibration_from_json(j);  // the same validation as every consumer of cal.json
  } catch (const std::exception& e) {
    throw std::runtime_error(path + ": " + e.what());
  }
  return to_py(j);
}

void write_cal(const std::string& path, const py::object& cal) {
  const nlohmann::json j = from_py(cal);
  solver::calibration_from_json(j);  // refuse to write what no reader would accept
  std::ofstream f(path);
  f << j.dump(2) << "\n";
  if (!f) throw std::runtime_error(path + ": cannot write");
}

py::array_t<float> floats(const float* v, py::ssize_t n) {
  py::array_t<float> a(n);
  for (py::ssize_t i = 0; i < n; ++i) a.mutable_at(i) = v[i];
  return a;
}

py::dict read_table(const std::string& path) {
  const fw::Table t = table::read_table_file(path);
  py::dict d;
  d["device_serial"] = t.device_serial;
  d["table_sequence"] = t.table_sequence;
  d["created_unix_s"] = t.created_unix_s;
  d["model_flags"] = t.model_flags;
  d["accel_lsb_mps2"] = t.accel_lsb_mps2;
  d["gyro_lsb_rad_s"] = t.gyro_lsb_rad_s;
  d["accel_raw_bits"] = t.accel_raw_bits;
  d["gyro_raw_bits"] = t.gyro_raw_bits;
  py::list bps;
  for (std::size_t i = 0; i < t.n_breakpoints; ++i) {
    const fw::BreakpointCoeffs& c = t.coeffs[i];
    py::dict b;
    b["temp_degC"] = t.breakpoints_degC[i];
    b["accel_C"] = floats(c.accel.C, 9).reshape({3, 3});
    b["accel_b"] = floats(c.accel.b, 3);
    b["gyro_C"] = floats(c.gyro.C, 9).reshape({3, 3});
    b["gyro_b"] = floats(c.gyro.b, 3);
    b["gyro_G"] = floats(c.G, 9).reshape({3, 3});
    bps.append(b);
  }
  d["breakpoints"] = bps;
  return d;
}

// From the correction form read_table returns (C, b, G per breakpoint), validated by the firmware rules.
void write_table(const std::string& path, const py::dict& d) {
  table::TableSpec s;
  s.kind = table::SpecKind::kCorrection;
  s.device_serial = d["device_serial"].cast<std::uint64_t>();
  if (d.contains("table_sequence")) s.table_sequence = d["table_sequence"].cast<std::uint32_t>();
  if (d.contains("created_unix_s")) s.created_unix_s = d["created_unix_s"].cast<std::int64_t>();
  s.accel_lsb_mps2 = d["accel_lsb_mps2"].cast<double>();
  s.gyro_lsb_rad_s = d["gyro_lsb_rad_s"].cast<double>();
  if (d.contains("accel_raw_bits")) s.accel_raw_bits = d["accel_raw_bits"].cast<int>();
  if (d.contains("gyro_raw_bits")) s.gyro_raw_bits = d["gyro_raw_bits"].cast<int>();
  auto mat = [](const py::handle& o, Eigen::Matrix3d& m) {
    auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(o);
    if (!a || a.size() != 9) throw std::runtime_error("write_table: a matrix must have 9 elements (3×3)");
    for (int i = 0; i < 9; ++i) m(i / 3, i % 3) = a.data()[i];
  };
  auto vec = [](const py::handle& o, Eigen::Vector3d& v) {
    auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(o);
    if (!a || a.size() != 3) throw std::runtime_error("write_table: a bias must have 3 elements");
    for (int i = 0; i < 3; ++i) v[i] = a.data()[i];
  };
  for (auto h : d["breakpoints"].cast<py::list>()) {
    const py::dict b = h.cast<py::dict>();
    table::BreakpointSpec bp;
    bp.temp_degC = b["temp_degC"].cast<double>();
    if (b.contains("accel_C")) mat(b["accel_C"], bp.accel_C);
    if (b.contains("gyro_C")) mat(b["gyro_C"], bp.gyro_C);
    if (b.contains("gyro_G")) mat(b["gyro_G"], bp.gyro_G);
    if (b.contains("accel_b")) vec(b["accel_b"], bp.accel_b);
    if (b.contains("gyro_b")) vec(b["gyro_b"], bp.gyro_b);
    s.breakpoints.push_back(bp);
  }
  table::write_table_file(path, table::serialize_table(s));
}

// The firmware kernel (same source as the MCU) over N samples.
py::tuple compensate(const std::string& table_path, const py::array_t<std::int32_t, py::array::c_style | py::array::forcecast>& raw,
                     const py::array_t<double, py::array::c_style | py::array::forcecast>& temp_C, const std::string& path,
                     double step_degC) {
  if (raw.ndim() != 2 || raw.shape(1) != 6) throw std::runtime_error("compensate: raw must be N×6 counts");
  const py::ssize_t n = raw.shape(0);
  if (temp_C.ndim() != 1 || temp_C.shape(0) != n) throw std::runtime_error("compensate: temp_C must have N values");
  if (path != "f32" && path != "fixed") throw std::runtime_error("compensate: path must be 'f32' or 'fixed'");
  table::HostKernel k(table::read_table_file(table_path), path == "f32" ? table::KernelPath::kF32 : table::KernelPath::kFixed,
                      step_degC);
  auto acc = array2<double>(static_cast<std::size_t>(n), 3), gyr = array2<double>(static_cast<std::size_t>(n), 3);
  py::array_t<std::uint32_t> status(n);
  auto A = acc.mutable_unchecked<2>(), G = gyr.mutable_unchecked<2>();
  for (py::ssize_t i = 0; i < n; ++i) {
    const table::CompensatedSample s = k.run(raw.data(i, 0), temp_C.at(i));
    for (py::ssize_t j = 0; j < 3; ++j) {
      A(i, j) = s.accel_mps2[j];
      G(i, j) = s.gyro_rad_s[j];
    }
    status.mutable_at(i) = s.status;
  }
  return py::make_tuple(acc, gyr, status);
}

// Navigation impact (imuforge navigate without the σ-requirement section): nav.json as a dict.
py::object navigate_impact(const std::string& trajectory, const std::string& sensor_path, const std::vector<std::string>& cals,
                           const std::string& outage, double outage_start_s, double outage_s, int runs,
                           std::uint64_t seed, int threads) {
  const sim::TrajectoryFile tf = sim::load_trajectory(trajectory);
  const model::SensorModel sensor = model::load_sensor_model(sensor_path);
  navigate::NavReport rep;
  navigate::ImpactOptions& opt = rep.opt;
  if (std::isfinite(outage_start_s) && std::isfinite(outage_s)) {
    opt.outage_start_s = outage_start_s;
    opt.outage_s = outage_s;
  } else {
    sim::labelled_span(tf.trajectory, outage, opt.outage_start_s, opt.outage_s);
    rep.outage_label = outage;
  }
  opt.runs = runs;
  opt.seed = seed;
  opt.threads = threads;
  const sim::VehicleTruth truth = sim::vehicle_truth(tf, sensor);
  const navigate::RawFormat fmt = navigate::raw_format(sensor);
  opt.accel_shift = fmt.accel_shift;
  opt.gyro_shift = fmt.gyro_shift;
  std::vector<navigate::Candidate> cands{navigate::uncompensated_candidate(fmt)};
  for (const auto& c : cals) cands.push_back(navigate::calibration_candidate(c, fmt, truth.temp_C));
  cands.push_back(navigate::oracle_candidate(sensor, fmt, truth.temp_C));
  rep.trajectory_path = trajectory;
  rep.trajectory_name = tf.name;
  rep.sensor_path = sensor_path;
  rep.sensor_name = sensor.name;
  rep.ambient_C = tf.ambient_C;
  rep.truth = &truth;
  for (std::size_t i = 1; i < truth.states.size(); ++i)
    rep.distance_m += nav::horizontal_offset_m(truth.states[i].pos, truth.states[i - 1].pos).norm();
  rep.result = navigate::run_impact(truth, sensor, cands, opt);
  rep.predicted_rms_m.assign(cands.size(), std::nan(""));
  return to_py(navigate::nav_json(rep));
}

py::dict import_recording(const std::string& format, const std::string& in, const std::string& out,
                          const std::string& in_gyro, const std::string& serial, double rate_hz, const std::string& map) {
  io::ImportOptions o;
  o.map = map;
  o.format = format;
  o.in = in;
  o.in_gyro = in_gyro;
  o.serial = serial;
  o.sample_rate_hz = rate_hz;
  const io::ImportSummary s = io::import_recording(o, out);
  py::dict d;
  d["rows"] = s.rows;
  d["duration_s"] = s.duration_s;
  d["sample_rate_hz"] = s.sample_rate_hz;
  return d;
}

}  // namespace

PYBIND11_MODULE(imuforge, m) {
  m.doc() = "imuforge: IMU calibration logs, solver, diagnosis, cal.json and coefficient tables (docs/python.md)";
  m.attr("__version__") = IMUFORGE_VERSION;
  py::register_exception<io::LogError>(m, "LogError", PyExc_ValueError);
  m.def("read_log", &read_log, py::arg("path"),
        "Reads a log v1 (CSV, binary or HDF5) into a dict: 'meta' (dict), 't_s', 'segment', 'temp_C', "
        "'chamber_C', 'has_ref' (N), 'f_ref', 'w_ref', 'accel_mps2', 'gyro_rad_s' (raw × nominal LSB), "
        "'table_angle_rad', 'table_rate_rad_s' (N×3), 'raw' (N×6 int32 counts). Missing values are NaN.");
  m.def("write_log", &write_log, py::arg("path"), py::arg("log"), py::arg("format") = "auto",
        "Writes a dict shaped like read_log's (needs 'meta', 't_s', 'raw'); format auto|csv|bin|h5.");
  m.def("solve", &solve, py::arg("log"), py::arg("model"), py::arg("mode") = "fixture", py::arg("table") = "",
        py::arg("serial") = "", py::arg("static_window_s") = 1.0, py::arg("static_min_s") = 1.5,
        "Calibrates (mode 'fixture' or 'reference-free'; model: path or dict) and returns the cal.json dict. "
        "table=path (with serial=) also writes the firmware coefficient table.");
  m.def("diagnose", &diagnose, py::arg("log"), py::arg("model") = "basic", py::arg("mode") = "auto", py::arg("campaign") = "",
        "Sim-to-real gap diagnosis; returns the diagnosis.json dict. campaign=path: the log's campaign, whose table's "
        "axis errors are then estimated (as `imuforge diagnose --campaign`).");
  m.def("read_cal", &read_cal, py::arg("path"), "Reads and validates a cal.json.");
  m.def("write_cal", &write_cal, py::arg("path"), py::arg("cal"), "Validates and writes a cal.json dict.");
  m.def("read_table", &read_table, py::arg("path"), "Parses a coefficient table v1 with the firmware parser.");
  m.def("write_table", &write_table, py::arg("path"), py::arg("table"),
        "Writes a coefficient table from read_table's dict form (validated by the firmware rules).");
  m.def("compensate", &compensate, py::arg("table"), py::arg("raw"), py::arg("temp_C"), py::arg("path") = "f32",
        py::arg("step_degC") = 0.0,
        "Runs the firmware kernel over N samples: returns (accel N×3 m/s², gyro N×3 rad/s, status N).");
  m.def("navigate", &navigate_impact, py::arg("trajectory"), py::arg("sensor"), py::arg("cals") = std::vector<std::string>{},
        py::arg("outage") = "tunnel", py::arg("outage_start_s") = NAN, py::arg("outage_s") = NAN, py::arg("runs") = 20,
        py::arg("seed") = 1, py::arg("threads") = 0,
        "Navigation impact of calibrations through a GNSS outage (Monte Carlo; docs/navigation.md): the nav.json "
        "dict. outage: a trajectory segment label, or outage_start_s and outage_s.");
  m.def("import_recording", &import_recording, py::arg("format"), py::arg("input"), py::arg("out"),
        py::arg("in_gyro") = "", py::arg("serial") = "", py::arg("rate_hz") = 0.0, py::arg("map") = "",
        "imuforge import as a function (xsens-imutk, mpu6050-csv, csv with map=); returns rows, duration, rate.");
}
