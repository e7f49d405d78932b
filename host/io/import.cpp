#include "host/io/import.h"
#include "host/io/staged_file.h"

#include "host/io/import_detail.h"

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cstdio>
#include <cmath>
#include <cstring>
#include <fstream>
#include <vector>

namespace imuforge::io {

// Shared with the column-mapping import (import_csv.cpp) through import_detail.h.
namespace detail {


std::string base_name(const std::string& p) {
  auto s = p.find_last_of('/');
  std::string b = s == std::string::npos ? p : p.substr(s + 1);
  auto d = b.find_last_of('.');
  return d == std::string::npos ? b : b.substr(0, d);
}

// Splits on any run of the separators; fields are views into line.
void split(const std::string& line, const char* seps, std::vector<std::string>& out) {
  out.clear();
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && std::strchr(seps, line[i])) ++i;
    if (i >= line.size()) break;
    std::size_t j = i;
    while (j < line.size() && !std::strchr(seps, line[j])) ++j;
    out.push_back(line.substr(i, j - i));
    i = j;
  }
}

double to_double(const std::string& s, const std::string& where) {
  double v;
  const char* b = s.data();
  if (!s.empty() && *b == '+') ++b;
  auto r = std::from_chars(b, s.data() + s.size(), v);
  if (r.ec != std::errc() || r.ptr != s.data() + s.size() || !std::isfinite(v))
    throw LogError(where + ": expected a number, got " + quote_for_message(s));
  return v;
}

std::int32_t to_count(const std::string& s, double lo, double hi, const std::string& where) {
  double v = to_double(s, where);
  if (v != std::floor(v) || v < lo || v > hi)
    throw LogError(where + ": expected an integer count in [" + std::to_string(static_cast<long>(lo)) + ", " +
                   std::to_string(static_cast<long>(hi)) + "], got " + quote_for_message(s));
  return static_cast<std::int32_t>(v);
}

}  // namespace detail
using namespace detail;

namespace {

// The sample rate from the median interval. Rounded to the mHz, where that keeps it a rate: a median
// interval of hours (a fuzzed file) once rounded to 0 Hz and was accepted.
double rate_from_median_interval(std::vector<double>& dts, const std::string& file) {
  if (dts.empty()) throw LogError(file + ": need at least two samples to infer the sample rate");
  std::nth_element(dts.begin(), dts.begin() + static_cast<long>(dts.size() / 2), dts.end());
  const double med = dts[dts.size() / 2];
  if (!(med > 0) || !std::isfinite(med)) throw LogError(file + ": timestamps do not increase");
  const double raw = 1.0 / med;
  const double fs = raw >= 1.0 ? std::round(raw * 1000.0) / 1000.0 : raw;
  if (!(fs > 0) || !std::isfinite(fs)) throw LogError(file + ": cannot infer a sample rate from the timestamps");
  return fs;
}

struct XsensRow {
  double t;
  std::int32_t v[3];
};

// Reads one `t x y z` line; false at EOF. Blank lines are skipped.
bool xsens_line(std::ifstream& f, const std::string& path, std::size_t& line_no, std::vector<std::string>& cells,
                XsensRow& r) {
  std::string line;
  while (read_line_bounded(f, line, path + ":" + std::to_string(line_no + 1))) {
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    split(line, " \t", cells);
    if (cells.empty()) continue;
    const std::string where = path + ":" + std::to_string(line_no);
    if (cells.size() != 4) throw LogError(where + ": expected 4 columns (t x y z), got " + std::to_string(cells.size()));
    r.t = to_double(cells[0], where + ": column 1 (t)");
    for (int k = 0; k < 3; ++k)
      r.v[k] = to_count(cells[static_cast<std::size_t>(k + 1)], 0, 65535, where + ": column " + std::to_string(k + 2)) -
               32768;
    return true;
  }
  if (f.bad()) throw LogError(path + ": read error");
  return false;
}

ImportSummary import_xsens(const ImportOptions& o, const std::string& out, LogEncoding enc) {
  if (o.in_gyro.empty()) throw LogError("xsens-imutk import needs --in ACC.txt and --in-gyro GYRO.txt");
  // Pass 1: sample rate from the median interval (the files carry a time column).
  std::ifstream fa(o.in), fg(o.in_gyro);
  if (!fa) throw LogError(o.in + ": cannot open");
  if (!fg) throw LogError(o.in_gyro + ": cannot open");
  std::vector<std::string> cells;
  double fs = o.sample_rate_hz;
  double t_first = 0;
  {
    std::size_t ln = 0;
    XsensRow r;
    std::vector<double> dts;
    double prev = std::nan("");
    while (dts.size() < 2000 && xsens_line(fa, o.in, ln, cells, r)) {
      if (std::isnan(prev)) t_first = r.t;
      else dts.push_back(r.t - prev);
      prev = r.t;
    }
    if (std::isnan(prev)) throw LogError(o.in + ": no samples");
    if (!(fs > 0)) fs = rate_from_median_interval(dts, o.in);
    fa.clear();
    fa.seekg(0);
  }
  LogMeta m;
  m.serial = o.serial.empty() ? "xsens-mti-imutk" : o.serial;
  m.sample_rate_hz = fs;
  m.accel_lsb_mps2 = 1.0 / 415.0;
  m.gyro_lsb_rad_s = 1.0 / 4770.0;
  m.set("source", "imported: xsens-imutk (IMU-TK test data, Xsens MTi)");
  m.set("lsb_note", "nominal sensitivities from the data README (unverified starting values)");
  m.accel_bits = m.gyro_bits = 16;  // unsigned 16-bit ADC words, shifted to signed
  m.set("raw_offset", "32768");
  m.set("t0_s", std::to_string(t_first));
  m.set("input_accel", base_name(o.in));
  m.set("input_gyro", base_name(o.in_gyro));
  LogWriter w(out, m, enc);
  std::size_t la = 0, lg = 0;
  XsensRow a, g;
  LogRow row;
  ImportSummary sum;
  double prev_t = -1e300;
  while (true) {
    bool ha = xsens_line(fa, o.in, la, cells, a);
    bool hg = xsens_line(fg, o.in_gyro, lg, cells, g);
    if (ha != hg)
      throw LogError(std::string(ha ? o.in_gyro : o.in) + ": ends after " + std::to_string(sum.rows) +
                     " samples but the other file continues (files must have identical timestamps)");
    if (!ha) break;
    if (std::fabs(a.t - g.t) > 1e-6)
      throw LogError(o.in_gyro + ":" + std::to_string(lg) + ": timestamp " + std::to_string(g.t) +
                     " differs from the accelerometer's " + std::to_string(a.t) + " (" + o.in + ":" +
                     std::to_string(la) + ")");
    if (!(a.t > prev_t)) throw LogError(o.in + ":" + std::to_string(la) + ": timestamps must increase");
    prev_t = a.t;
    row.t_s = a.t - t_first;
    row.segment = -1;
    row.has_ref = false;
    for (int k = 0; k < 3; ++k) {
      row.raw[k] = a.v[k];
      row.raw[3 + k] = g.v[k];
    }
    w.write(row);
    ++sum.rows;
    sum.duration_s = row.t_s;
  }
  w.close();
  sum.sample_rate_hz = fs;
  return sum;
}

ImportSummary import_mpu6050(const ImportOptions& o, const std::string& out, LogEncoding enc) {
  std::ifstream f(o.in);
  if (!f) throw LogError(o.in + ": cannot open");
  std::string line;
  std::vector<std::string> cells;
  std::size_t ln = 0;
  double fs = 0;
  std::vector<std::pair<std::string, std::string>> file_meta;
  // Metadata rows until the header `ax,ay,az,gx,gy,gz`.
  while (true) {
    if (!read_line_bounded(f, line, o.in + ":" + std::to_string(ln + 1)))
      throw LogError(o.in + ": no header line 'ax,ay,az,gx,gy,gz'");
    ++ln;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    split(line, ",", cells);
    // The header (also one in another order: the columns are positional, so that is an error below).
    if (cells.size() == 6 && std::find(cells.begin(), cells.end(), "ax") != cells.end()) {
      const char* want[6] = {"ax", "ay", "az", "gx", "gy", "gz"};
      for (int k = 0; k < 6; ++k)
        if (cells[static_cast<std::size_t>(k)] != want[k])
          throw LogError(o.in + ":" + std::to_string(ln) + ": header column " + std::to_string(k + 1) + " is " +
                         quote_for_message(cells[static_cast<std::size_t>(k)]) + ", expected '" + want[k] + "'");
      break;
    }
    if (cells.size() == 2) {
      file_meta.emplace_back(cells[0], cells[1]);
      if (cells[0] == "Fs") fs = to_double(cells[1], o.in + ":" + std::to_string(ln) + ": Fs");
    } else if (!cells.empty()) {
      throw LogError(o.in + ":" + std::to_string(ln) + ": expected a 'key,value' metadata row or the header");
    }
  }
  if (o.sample_rate_hz > 0) fs = o.sample_rate_hz;
  if (!(fs > 0)) fs = 100.0;  // the README: 100 Hz
  LogMeta m;
  m.serial = o.serial.empty() ? "mpu6050-" + base_name(o.in) : o.serial;
  m.sample_rate_hz = fs;
  m.accel_lsb_mps2 = kG / 16384.0;
  m.gyro_lsb_rad_s = M_PI / 180.0 / 131.0;
  m.accel_bits = m.gyro_bits = 16;  // int16 output registers
  m.set("source", "imported: mpu6050-csv (tomisuarez2/ImuCalibration, InvenSense MPU-6050)");
  m.set("lsb_note", "nominal sensitivities of the configured ranges (+-2 g, +-250 dps), not a calibration");
  m.set("time_note", "no time column in the recording: t_s synthesised as i / Fs");
  m.set("input", base_name(o.in));
  for (const auto& [k, v] : file_meta) {
    std::string key = "file.";
    for (char c : k) key += std::isalnum(static_cast<unsigned char>(c)) ? c : '_';
    m.set(key, v);
  }
  LogWriter w(out, m, enc);
  LogRow row;
  row.segment = -1;
  row.has_ref = false;
  ImportSummary sum;
  while (read_line_bounded(f, line, o.in + ":" + std::to_string(ln + 1))) {
    ++ln;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    split(line, ",", cells);
    if (cells.empty()) continue;
    const std::string where = o.in + ":" + std::to_string(ln);
    if (cells.size() != 6) throw LogError(where + ": expected 6 columns, got " + std::to_string(cells.size()));
    for (std::size_t k = 0; k < 6; ++k)
      row.raw[k] = to_count(cells[k], -32768, 32767, where + ": column " + std::to_string(k + 1));
    row.t_s = static_cast<double>(sum.rows) / fs;
    w.write(row);
    sum.duration_s = row.t_s;
    ++sum.rows;
  }
  if (f.bad()) throw LogError(o.in + ": read error");
  w.close();
  sum.sample_rate_hz = fs;
  return sum;
}

// Floats in SI (m/s², rad/s) -> counts of a declared LSB in a declared word width. A value beyond the
// word is refused by line, never wrapped or clipped silently (a clipped sample would look saturated).
ImportSummary import_si_csv(const ImportOptions& o, const std::string& out, LogEncoding enc) {
  std::ifstream f(o.in);
  if (!f) throw LogError(o.in + ": cannot open");
  if (!(o.accel_lsb_mps2 > 0) || !(o.gyro_lsb_rad_s > 0)) throw LogError(o.in + ": si-csv needs positive LSBs");
  if (o.bits < 2 || o.bits > 32) throw LogError(o.in + ": si-csv word width must be 2..32 bits");
  std::string line;
  std::vector<std::string> cells;
  std::size_t ln = 0;
  const char* want[7] = {"t_s", "ax", "ay", "az", "gx", "gy", "gz"};
  while (true) {
    if (!std::getline(f, line)) throw LogError(o.in + ": no header line 't_s,ax,ay,az,gx,gy,gz'");
    ++ln;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty() || line[0] == '#') continue;
    split(line, ",", cells);
    if (cells.size() != 7) throw LogError(o.in + ":" + std::to_string(ln) + ": header must be t_s,ax,ay,az,gx,gy,gz");
    for (int k = 0; k < 7; ++k)
      if (cells[static_cast<std::size_t>(k)] != want[k])
        throw LogError(o.in + ":" + std::to_string(ln) + ": header column " + std::to_string(k + 1) + " is '" +
                       cells[static_cast<std::size_t>(k)] + "', expected '" + want[k] + "' (units m/s^2, rad/s)");
    break;
  }
  LogMeta m;
  m.serial = o.serial.empty() ? base_name(o.in) : o.serial;
  m.accel_lsb_mps2 = o.accel_lsb_mps2;
  m.gyro_lsb_rad_s = o.gyro_lsb_rad_s;
  m.accel_bits = m.gyro_bits = o.bits;
  m.set("source", "imported: si-csv (floats in m/s^2 and rad/s mapped to counts)");
  m.set("input", base_name(o.in));
  std::vector<LogRow> rows;
  std::vector<double> dts;
  double prev = std::nan("");
  const double lo = static_cast<double>(raw_min(o.bits)), hi = static_cast<double>(raw_max(o.bits));
  while (std::getline(f, line)) {
    ++ln;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty() || line[0] == '#') continue;
    split(line, ",", cells);
    const std::string where = o.in + ":" + std::to_string(ln);
    if (cells.size() != 7) throw LogError(where + ": expected 7 columns, got " + std::to_string(cells.size()));
    LogRow row;
    row.segment = -1;
    row.t_s = to_double(cells[0], where + ": column 1 (t_s)");
    if (!std::isnan(prev)) {
      if (!(row.t_s > prev)) throw LogError(where + ": t_s must increase");
      dts.push_back(row.t_s - prev);
    }
    prev = row.t_s;
    for (int k = 0; k < 6; ++k) {
      const double v = to_double(cells[static_cast<std::size_t>(k + 1)], where + ": column " + std::to_string(k + 2));
      const double c = std::round(v / (k < 3 ? o.accel_lsb_mps2 : o.gyro_lsb_rad_s));
      if (!(c >= lo && c <= hi))
        throw LogError(where + ": column " + std::to_string(k + 2) + " (" + want[k + 1] + ") = " + cells[static_cast<std::size_t>(k + 1)] +
                       " is beyond the " + std::to_string(o.bits) + "-bit word at this LSB (choose a larger LSB or width)");
      row.raw[k] = static_cast<std::int32_t>(c);
    }
    rows.push_back(row);
  }
  if (rows.size() < 2) throw LogError(o.in + ": need at least two samples");
  double fs = o.sample_rate_hz;
  if (!(fs > 0)) fs = rate_from_median_interval(dts, o.in);
  m.sample_rate_hz = fs;
  const double t0 = rows.front().t_s;
  LogWriter w(out, m, enc);
  ImportSummary sum;
  for (LogRow& r : rows) {
    r.t_s -= t0;
    w.write(r);
    ++sum.rows;
    sum.duration_s = r.t_s;
  }
  w.close();
  sum.sample_rate_hz = fs;
  return sum;
}

}  // namespace

ImportSummary import_recording(const ImportOptions& opt, const std::string& out_path, LogEncoding enc) {
  ImportSummary (*fn)(const ImportOptions&, const std::string&, LogEncoding) = nullptr;
  if (opt.format == "xsens-imutk") fn = import_xsens;
  else if (opt.format == "mpu6050-csv") fn = import_mpu6050;
  else if (opt.format == "si-csv") fn = import_si_csv;
  else if (opt.format == "csv") fn = import_mapped_csv;
  else throw LogError("unknown import format '" + opt.format + "' (expected xsens-imutk, mpu6050-csv, si-csv or csv)");
  if (enc == LogEncoding::kAuto) enc = encoding_from_path(out_path);
  StagedFile staged(out_path);  // a failed import leaves nothing behind (removed by its destructor)
  const ImportSummary s = fn(opt, staged.path(), enc);
  staged.commit();
  return s;
}

}  // namespace imuforge::io
