// Generic column-mapping CSV import (`imuforge import --format csv --map map.json`): a lab's own export
// read without code. The map (docs/formats.md "Column-mapping import") says which column is what, in
// which unit or LSB. Streaming: two passes over the file when the sample rate must be inferred.
#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "host/io/import.h"
#include "host/io/import_detail.h"
#include "host/io/log_detail.h"

namespace imuforge::io {

namespace {

struct ColRef {
  std::string name;   // by header name, or
  int index = -1;     // by position, 0-based once resolved (the map counts from 1)
  std::string role;   // "accel x", "time" … for error messages
};

struct Channel {
  std::vector<ColRef> cols;
  bool counts = true;       // unit "counts": integer cells
  double unit_si = 1.0;     // SI per unit (physical units)
  double lsb_unit = 0.0;    // counts: SI per count; physical: the quantum in the given unit
  double offset = 0.0;      // subtracted from the cell first (in the cell's unit)
  double lsb_si() const { return counts ? lsb_unit : lsb_unit * unit_si; }
};

struct Map {
  std::string path;
  char delim = ',';
  bool whitespace = false;
  bool header = true;
  int skip_lines = 0;
  std::string comment = "#";
  std::optional<ColRef> time;
  double time_scale = 1.0;  // s per unit
  double rate_hz = 0.0;     // when no time column (or to override the inferred rate)
  Channel accel, gyro;
  std::optional<ColRef> temp;
  std::string temp_unit = "degC";
  std::string serial;
  std::vector<std::pair<std::string, std::string>> metadata;
};

[[noreturn]] void map_error(const Map& m, const std::string& what) { throw LogError(m.path + ": " + what); }

ColRef col_ref(const Map& m, const nlohmann::json& j, const std::string& role) {
  ColRef c;
  c.role = role;
  if (j.is_string() && !j.get<std::string>().empty()) c.name = j.get<std::string>();
  else if (j.is_number_integer() && j.get<long long>() >= 1 && j.get<long long>() <= 100000) c.index = j.get<int>() - 1;
  else map_error(m, role + ": a column is a header name or a 1-based index, got " + j.dump());
  return c;
}

double unit_factor(const Map& m, const std::string& unit, const std::string& what) {
  static const std::pair<const char*, double> kUnits[] = {
      {"m/s2", 1.0},           {"m/s^2", 1.0},         {"g", detail::kG},      {"mg", 1e-3 * detail::kG},
      {"rad/s", 1.0},          {"deg/s", M_PI / 180},  {"dps", M_PI / 180},    {"mdeg/s", 1e-3 * M_PI / 180},
      {"s", 1.0},              {"ms", 1e-3},           {"us", 1e-6},           {"ns", 1e-9}};
  for (const auto& [n, f] : kUnits)
    if (unit == n) return f;
  map_error(m, what + ": unknown unit '" + unit + "'");
}

void check_keys(const Map& m, const nlohmann::json& j, const std::string& where, std::initializer_list<const char*> keys) {
  if (!j.is_object()) map_error(m, where + " must be an object");
  for (auto it = j.begin(); it != j.end(); ++it) {
    if (!it.key().empty() && it.key()[0] == '_') continue;  // comments
    if (std::find_if(keys.begin(), keys.end(), [&](const char* k) { return it.key() == k; }) == keys.end())
      map_error(m, "unknown key '" + where + "." + it.key() + "'");
  }
}

Channel channel(const Map& m, const nlohmann::json& j, const std::string& name, bool accel) {
  check_keys(m, j, name, {"columns", "unit", "lsb", "offset"});
  Channel c;
  if (!j.contains("columns") || !j["columns"].is_array() || j["columns"].size() != 3)
    map_error(m, name + ".columns must list 3 columns (x, y, z)");
  const char* axes = "xyz";
  for (std::size_t k = 0; k < 3; ++k) c.cols.push_back(col_ref(m, j["columns"][k], name + " " + axes[k]));
  const std::string unit = j.value("unit", "counts");
  c.counts = unit == "counts";
  if (!c.counts) {
    c.unit_si = unit_factor(m, unit, name + ".unit");
    const bool accel_unit = unit == "m/s2" || unit == "m/s^2" || unit == "g" || unit == "mg";
    if (accel_unit != accel) map_error(m, name + ".unit '" + unit + "' is not a unit of " + (accel ? "acceleration" : "angular rate"));
  }
  if (!j.contains("lsb") || !j["lsb"].is_number() || !(j["lsb"].get<double>() > 0))
    map_error(m, name + ".lsb must be a number > 0 (" +
                     (c.counts ? std::string(accel ? "m/s² per count" : "rad/s per count")
                               : "the sensor's resolution in " + unit) + ")");
  c.lsb_unit = j["lsb"].get<double>();
  if (j.contains("offset")) {
    if (!j["offset"].is_number()) map_error(m, name + ".offset must be a number");
    c.offset = j["offset"].get<double>();
  }
  return c;
}

Map load_map(const std::string& path) {
  Map m;
  m.path = path;
  std::ifstream f(path);
  if (!f) throw LogError(path + ": cannot open the column map");
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(f);
  } catch (const std::exception& e) {
    throw LogError(path + ": not valid JSON: " + e.what());
  }
  check_keys(m, j, "map", {"delimiter", "header", "skip_lines", "comment", "time", "accel", "gyro", "temperature",
                           "serial", "sample_rate_hz", "metadata"});
  const std::string d = j.value("delimiter", ",");
  if (d == "whitespace") m.whitespace = true;
  else if (d.size() == 1 && d[0] != '\n' && d[0] != '"') m.delim = d[0];
  else map_error(m, "delimiter must be one character (\",\", \";\", \"\\t\" …) or \"whitespace\"");
  m.header = j.value("header", true);
  m.skip_lines = j.value("skip_lines", 0);
  if (m.skip_lines < 0) map_error(m, "skip_lines must be >= 0");
  m.comment = j.value("comment", "#");
  if (j.contains("time")) {
    check_keys(m, j["time"], "time", {"column", "unit"});
    if (!j["time"].contains("column")) map_error(m, "time.column is required (or leave out \"time\" and give sample_rate_hz)");
    m.time = col_ref(m, j["time"]["column"], "time");
    m.time_scale = unit_factor(m, j["time"].value("unit", "s"), "time.unit");
  }
  if (j.contains("sample_rate_hz")) {
    if (!j["sample_rate_hz"].is_number() || !(j["sample_rate_hz"].get<double>() > 0))
      map_error(m, "sample_rate_hz must be a number > 0");
    m.rate_hz = j["sample_rate_hz"].get<double>();
  }
  if (!m.time && !(m.rate_hz > 0)) map_error(m, "no \"time\" column: give \"sample_rate_hz\"");
  if (!j.contains("accel") || !j.contains("gyro")) map_error(m, "\"accel\" and \"gyro\" are required");
  m.accel = channel(m, j["accel"], "accel", true);
  m.gyro = channel(m, j["gyro"], "gyro", false);
  if (j.contains("temperature")) {
    check_keys(m, j["temperature"], "temperature", {"column", "unit"});
    if (!j["temperature"].contains("column")) map_error(m, "temperature.column is required");
    m.temp = col_ref(m, j["temperature"]["column"], "temperature");
    m.temp_unit = j["temperature"].value("unit", "degC");
    if (m.temp_unit != "degC" && m.temp_unit != "degF" && m.temp_unit != "K")
      map_error(m, "temperature.unit must be degC, degF or K");
  }
  m.serial = j.value("serial", "");
  if (j.contains("metadata")) {
    if (!j["metadata"].is_object()) map_error(m, "metadata must be an object of key: value");
    for (auto it = j["metadata"].begin(); it != j["metadata"].end(); ++it)
      m.metadata.emplace_back(it.key(), it->is_string() ? it->get<std::string>() : it->dump());
  }
  return m;
}

// Splits one line on the delimiter, keeping empty cells; trims spaces and one pair of double quotes.
void split_cells(const Map& m, const std::string& line, std::vector<std::string>& out) {
  if (m.whitespace) return detail::split(line, " \t", out);
  out.clear();
  std::size_t a = 0;
  while (true) {
    std::size_t b = line.find(m.delim, a);
    std::string c = line.substr(a, b == std::string::npos ? std::string::npos : b - a);
    const std::size_t s = c.find_first_not_of(" \t"), e = c.find_last_not_of(" \t");
    c = s == std::string::npos ? std::string() : c.substr(s, e - s + 1);
    if (c.size() >= 2 && c.front() == '"' && c.back() == '"') c = c.substr(1, c.size() - 2);
    out.push_back(c);
    if (b == std::string::npos) break;
    a = b + 1;
  }
}

// Streams the data rows of the file: skip_lines, comments, blank lines and the header taken care of.
class Rows {
 public:
  Rows(Map& m, const std::string& path) : m_(m), path_(path), f_(path) {
    if (!f_) throw LogError(path + ": cannot open");
    std::string line;
    for (int i = 0; i < m.skip_lines; ++i)
      if (!next_line(line)) throw LogError(path + ": ends within the " + std::to_string(m.skip_lines) + " skipped lines");
    if (m.header) {
      if (!next_content(line)) throw LogError(path + ": no header line");
      split_cells(m, line, names_);
      header_line_ = line_no_;
    }
    for (ColRef* c : refs()) resolve(*c);
  }
  // Next data row's cells; false at the end of the file.
  bool next(std::vector<std::string>& cells) {
    std::string line;
    if (!next_content(line)) return false;
    split_cells(m_, line, cells);
    if (cells.size() <= static_cast<std::size_t>(max_index_))
      throw LogError(where() + ": " + std::to_string(cells.size()) + " cells, the map reads column " +
                     std::to_string(max_index_ + 1) + " (" + max_role_ + ")");
    return true;
  }
  std::string where() const { return path_ + ":" + std::to_string(line_no_); }
  std::string cell_where(const ColRef& c) const {
    std::string n = c.index < static_cast<int>(names_.size()) ? names_[static_cast<std::size_t>(c.index)] : c.role;
    return where() + ": column " + std::to_string(c.index + 1) + " (" + n + ")";
  }

 private:
  std::vector<ColRef*> refs() {
    std::vector<ColRef*> r;
    if (m_.time) r.push_back(&*m_.time);
    for (auto& c : m_.accel.cols) r.push_back(&c);
    for (auto& c : m_.gyro.cols) r.push_back(&c);
    if (m_.temp) r.push_back(&*m_.temp);
    return r;
  }
  void resolve(ColRef& c) {
    if (!c.name.empty()) {
      if (!m_.header) throw LogError(m_.path + ": " + c.role + " names column '" + c.name + "' but the map says header: false");
      auto it = std::find(names_.begin(), names_.end(), c.name);
      if (it == names_.end()) {
        std::string have;
        for (const auto& n : names_) have += (have.empty() ? "" : ", ") + n;
        throw LogError(m_.path + ": " + c.role + " column '" + c.name + "' is not in the header at " + path_ + ":" +
                       std::to_string(header_line_) + " (" + have + ")");
      }
      c.index = static_cast<int>(it - names_.begin());
    }
    if (c.index > max_index_) {
      max_index_ = c.index;
      max_role_ = c.role;
    }
  }
  bool next_line(std::string& line) {
    if (!std::getline(f_, line)) {
      if (f_.bad()) throw LogError(path_ + ": read error");
      return false;
    }
    ++line_no_;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    return true;
  }
  bool next_content(std::string& line) {
    while (next_line(line)) {
      if (line.find_first_not_of(" \t") == std::string::npos) continue;
      if (!m_.comment.empty() && line.compare(0, m_.comment.size(), m_.comment) == 0) continue;
      return true;
    }
    return false;
  }
  Map& m_;
  std::string path_;
  std::ifstream f_;
  std::vector<std::string> names_;
  std::size_t line_no_ = 0, header_line_ = 0;
  int max_index_ = -1;
  std::string max_role_;
};

// The count a cell maps to, refused unless it fits the log's declared raw word (`bits`, the metadata
// key `key`): a log the import wrote must read back (found by fuzz_import_csv: an offset that pushed a
// gyro count to -32769 in a 16-bit log).
std::int32_t to_raw(const Rows& rows, const Channel& ch, const ColRef& c, const std::string& cell, int bits,
                    const char* key) {
  const std::string where = rows.cell_where(c);
  double q = 0;
  if (ch.counts) {
    q = detail::to_double(cell, where) - ch.offset;
    if (q != std::floor(q) || std::fabs(q) > 2147483647.0)
      throw LogError(where + ": expected an integer count (unit \"counts\"), got '" + cell + "'");
  } else {
    q = std::round((detail::to_double(cell, where) - ch.offset) / ch.lsb_unit);
    if (std::fabs(q) > 2147483647.0) throw LogError(where + ": '" + cell + "' is beyond ±2^31 LSB");
  }
  const auto count = static_cast<std::int64_t>(q);
  if (!raw_fits(count, bits))
    throw LogError(where + ": '" + cell + "' maps to " + std::to_string(count) + " counts, outside the " +
                   std::to_string(bits) + "-bit raw word (" + key + "; set it in the map's \"metadata\")");
  return static_cast<std::int32_t>(count);
}

double to_degC(const Map& m, double v) {
  if (m.temp_unit == "degF") return (v - 32.0) * 5.0 / 9.0;
  if (m.temp_unit == "K") return v - 273.15;
  return v;
}

}  // namespace

ImportSummary import_mapped_csv(const ImportOptions& o, const std::string& out, LogEncoding enc) {
  if (o.map.empty()) throw LogError("import --format csv needs --map MAP.json (docs/formats.md)");
  Map m = load_map(o.map);
  std::vector<std::string> cells;
  // Pass 1 (time column, no rate given): the sample rate is the median interval of the first 2000 rows.
  double fs = o.sample_rate_hz > 0 ? o.sample_rate_hz : m.rate_hz;
  double t_first = 0.0;
  if (m.time) {
    Rows r(m, o.in);
    std::vector<double> dts;
    double prev = std::nan("");
    while (dts.size() < 2000 && r.next(cells)) {
      const std::string& c = cells[static_cast<std::size_t>(m.time->index)];
      const double t = detail::to_double(c, r.cell_where(*m.time)) * m.time_scale;
      if (std::isnan(prev)) t_first = t;
      else if (!(t > prev)) throw LogError(r.cell_where(*m.time) + ": time " + c + " does not increase");
      else dts.push_back(t - prev);
      prev = t;
    }
    if (std::isnan(prev)) throw LogError(o.in + ": no data rows");
    if (!(fs > 0)) {
      if (dts.empty()) throw LogError(o.in + ": one data row: give sample_rate_hz in the map");
      std::nth_element(dts.begin(), dts.begin() + static_cast<long>(dts.size() / 2), dts.end());
      if (!(dts[dts.size() / 2] > 0)) throw LogError(o.in + ": the time column does not increase");
      fs = 1.0 / dts[dts.size() / 2];
    }
  }
  LogMeta meta;
  meta.serial = !o.serial.empty() ? o.serial : !m.serial.empty() ? m.serial : detail::base_name(o.in);
  meta.sample_rate_hz = fs;
  meta.accel_lsb_mps2 = m.accel.lsb_si();
  meta.gyro_lsb_rad_s = m.gyro.lsb_si();
  meta.set("source", "imported: column map " + detail::base_name(o.map));
  meta.set("input", detail::base_name(o.in));
  if (m.time) meta.set("t0_s", detail::fmt_double(t_first));
  if (m.accel.offset != 0) meta.set("raw_offset_accel", detail::fmt_double(m.accel.offset));
  if (m.gyro.offset != 0) meta.set("raw_offset_gyro", detail::fmt_double(m.gyro.offset));
  // The map's own metadata goes through the same parser as a log's, so reserved keys (latitude_deg,
  // gravity_mps2 …) land typed and checked, and any other key is carried as is.
  for (const auto& [k, v] : m.metadata) detail::apply_meta(meta, k, v, o.map + ": metadata '" + k + "'");

  Rows rows(m, o.in);
  LogWriter w(out, meta, enc);
  ImportSummary sum;
  LogRow row;
  row.segment = -1;
  row.has_ref = false;
  double prev_t = -std::numeric_limits<double>::infinity();
  while (rows.next(cells)) {
    if (m.time) {
      const double t = detail::to_double(cells[static_cast<std::size_t>(m.time->index)], rows.cell_where(*m.time)) * m.time_scale;
      if (!(t > prev_t))
        throw LogError(rows.cell_where(*m.time) + ": time " + cells[static_cast<std::size_t>(m.time->index)] +
                       " does not increase");
      prev_t = t;
      row.t_s = t - t_first;
    } else {
      row.t_s = static_cast<double>(sum.rows) / fs;
    }
    for (int k = 0; k < 3; ++k) {
      const ColRef& ca = m.accel.cols[static_cast<std::size_t>(k)];
      const ColRef& cg = m.gyro.cols[static_cast<std::size_t>(k)];
      row.raw[k] = to_raw(rows, m.accel, ca, cells[static_cast<std::size_t>(ca.index)], meta.accel_bits, "accel_bits");
      row.raw[3 + k] = to_raw(rows, m.gyro, cg, cells[static_cast<std::size_t>(cg.index)], meta.gyro_bits, "gyro_bits");
    }
    if (m.temp) {
      const std::string& c = cells[static_cast<std::size_t>(m.temp->index)];
      row.temp_C = c.empty() ? std::nan("") : to_degC(m, detail::to_double(c, rows.cell_where(*m.temp)));
    }
    w.write(row);
    ++sum.rows;
    sum.duration_s = row.t_s;
  }
  if (sum.rows == 0) throw LogError(o.in + ": no data rows");
  w.close();
  sum.sample_rate_hz = fs;
  return sum;
}

}  // namespace imuforge::io
