#include "host/io/log.h"

#include "host/io/log_detail.h"
#include "host/io/log_h5.h"

#include <cctype>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <unistd.h>

namespace imuforge::io {

static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__, "binary log I/O assumes a little-endian host");
static_assert(sizeof(double) == 8, "binary log needs IEEE-754 binary64");

// Shared with the HDF5 encoding (log_h5.cpp) through log_detail.h.
namespace detail {

constexpr std::size_t kBinHeaderFixed = 28;      // magic 8, version 4, record bytes 4, row count 8, meta len 4
constexpr std::size_t kMaxLine = 1u << 20;       // a CSV line longer than this is rejected (hostile input)
constexpr std::size_t kMaxMeta = 1u << 20;
const char* const kRequired[16] = {"t_s",     "segment", "temp_C",  "chamber_C", "f_ref_x", "f_ref_y",
                                   "f_ref_z", "w_ref_x", "w_ref_y", "w_ref_z",   "ax",      "ay",
                                   "az",      "gx",      "gy",      "gz"};

const char* const kReserved[] = {"format",   "format_version", "serial",      "sample_rate_hz", "accel_lsb_mps2",
                                 "gyro_lsb_rad_s", "latitude_deg", "height_m", "gravity_mps2", "table_axes", "accel_bits", "gyro_bits"};

bool reserved(const std::string& k) {
  for (const char* r : kReserved)
    if (k == r) return true;
  return false;
}

bool valid_key(const std::string& k) {
  if (k.empty()) return false;
  for (char c : k)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '.' || c == '-')) return false;
  return true;
}

void append_double(std::string& s, double v) {
  if (std::isnan(v)) return;  // empty cell
  char tmp[32];
  auto r = std::to_chars(tmp, tmp + sizeof tmp, v);
  s.append(tmp, r.ptr);
}

std::string fmt_double(double v) {
  if (std::isnan(v)) return "nan";
  std::string s;
  append_double(s, v);
  return s;
}

bool parse_double(const char* b, const char* e, double& out) {
  if (b == e) return false;
  if (*b == '+') ++b;
  auto r = std::from_chars(b, e, out);
  if (r.ec != std::errc() || r.ptr != e) {
    // from_chars does not accept "nan"/"inf" spelled differently by other tools; accept the usual ones.
    std::string t(b, e);
    if (t == "nan" || t == "NaN" || t == "NAN") { out = std::nan(""); return true; }
    return false;
  }
  return true;
}

bool parse_int32(const char* b, const char* e, std::int32_t& out) {
  if (b == e) return false;
  if (*b == '+') ++b;
  auto r = std::from_chars(b, e, out);
  return r.ec == std::errc() && r.ptr == e;
}

// Applies one metadata key/value (CSV "# key=value" line or binary header line).
void apply_meta(LogMeta& m, const std::string& key, const std::string& val, const std::string& where) {
  // Metadata is text in every encoding: a NUL cannot survive an HDF5 string attribute or a C API, so a
  // value that holds one is refused here, once for all encodings (found by fuzz_log_h5's round trip).
  if (key.find('\0') != std::string::npos || val.find('\0') != std::string::npos)
    throw LogError(where + ": metadata " + quote_for_message(key) + " holds a NUL byte");
  auto need_num = [&](double& dst) {
    if (!parse_double(val.data(), val.data() + val.size(), dst))
      throw LogError(where + ": metadata '" + key + "' is not a number: " + quote_for_message(val));
  };
  if (key == "format") {
    if (val != "imuforge-log") throw LogError(where + ": format is " + quote_for_message(val) + ", expected imuforge-log");
  } else if (key == "format_version") {
    double v;
    need_num(v);
    if (v != kLogFormatVersion)
      throw LogError(where + ": log format version " + val + " is not supported (this build reads 1)");
    m.format_version = 1;
  } else if (key == "serial") {
    m.serial = val;
  } else if (key == "sample_rate_hz") {
    need_num(m.sample_rate_hz);
  } else if (key == "accel_lsb_mps2") {
    need_num(m.accel_lsb_mps2);
  } else if (key == "gyro_lsb_rad_s") {
    need_num(m.gyro_lsb_rad_s);
  } else if (key == "latitude_deg") {
    need_num(m.latitude_deg);
  } else if (key == "height_m") {
    need_num(m.height_m);
  } else if (key == "gravity_mps2") {
    need_num(m.gravity_mps2);
  } else if (key == "table_axes") {
    double v;
    need_num(v);
    if (v != std::floor(v) || v < 0 || v > 3) throw LogError(where + ": table_axes must be 0..3");
    m.table_axes = static_cast<int>(v);
  } else if (key == "accel_bits" || key == "gyro_bits") {
    double v;
    need_num(v);
    if (v != std::floor(v) || v < 2 || v > 32) throw LogError(where + ": " + key + " must be an integer 2..32, got '" + val + "'");
    (key == "accel_bits" ? m.accel_bits : m.gyro_bits) = static_cast<int>(v);
  } else {
    if (!valid_key(key)) throw LogError(where + ": invalid metadata key " + quote_for_message(key));
    // One value per key: which of two would a reader believe? (HDF5 cannot even store both.)
    for (const auto& kv : m.extra)
      if (kv.first == key) throw LogError(where + ": metadata " + quote_for_message(key) + " is given twice");
    m.extra.emplace_back(key, val);
  }
}

std::string meta_text(const LogMeta& m, const char* prefix) {
  std::string s;
  auto line = [&](const std::string& k, const std::string& v) { s += prefix + k + "=" + v + "\n"; };
  line("format", "imuforge-log");
  line("format_version", std::to_string(kLogFormatVersion));
  line("serial", m.serial);
  line("sample_rate_hz", fmt_double(m.sample_rate_hz));
  line("accel_lsb_mps2", fmt_double(m.accel_lsb_mps2));
  line("gyro_lsb_rad_s", fmt_double(m.gyro_lsb_rad_s));
  line("latitude_deg", fmt_double(m.latitude_deg));
  line("height_m", fmt_double(m.height_m));
  line("gravity_mps2", fmt_double(m.gravity_mps2));
  line("table_axes", std::to_string(m.table_axes));
  line("accel_bits", std::to_string(m.accel_bits));
  line("gyro_bits", std::to_string(m.gyro_bits));
  for (const auto& [k, v] : m.extra) line(k, v);
  return s;
}

void check_meta(const LogMeta& m, const std::string& path) {
  if (m.table_axes < 0 || m.table_axes > 3) throw LogError(path + ": table_axes must be 0..3");
  if (m.accel_bits < 2 || m.accel_bits > 32 || m.gyro_bits < 2 || m.gyro_bits > 32)
    throw LogError(path + ": accel_bits/gyro_bits must be 2..32");
  if (m.serial.find('\n') != std::string::npos) throw LogError(path + ": serial contains a newline");
  for (const auto& [k, v] : m.extra) {
    if (!valid_key(k) || reserved(k)) throw LogError(path + ": invalid or reserved metadata key '" + k + "'");
    if (v.find('\n') != std::string::npos) throw LogError(path + ": metadata value of '" + k + "' has a newline");
  }
}

template <class T>
void put(char*& p, T v) {
  std::memcpy(p, &v, sizeof v);
  p += sizeof v;
}
template <class T>
T get(const char*& p) {
  T v;
  std::memcpy(&v, p, sizeof v);
  p += sizeof v;
  return v;
}

}  // namespace detail
using namespace detail;

const std::string* LogMeta::find(const std::string& key) const {
  for (const auto& kv : extra)
    if (kv.first == key) return &kv.second;
  return nullptr;
}

void LogMeta::set(const std::string& key, const std::string& value) {
  if (!valid_key(key) || reserved(key)) throw LogError("invalid or reserved metadata key '" + key + "'");
  if (value.find('\n') != std::string::npos) throw LogError("metadata value of '" + key + "' contains a newline");
  for (auto& kv : extra)
    if (kv.first == key) {
      kv.second = value;
      return;
    }
  extra.emplace_back(key, value);
}

LogEncoding encoding_from_path(const std::string& path) {
  auto ends = [&](const char* suf) {
    std::size_t n = std::strlen(suf);
    return path.size() >= n && path.compare(path.size() - n, n, suf) == 0;
  };
  if (ends(".h5") || ends(".hdf5")) return LogEncoding::kHdf5;
  return (ends(".bin") || ends(".imulog") || ends(".ilog")) ? LogEncoding::kBinary : LogEncoding::kCsv;
}

LogEncoding encoding_from_name(const std::string& name) {
  if (name == "auto") return LogEncoding::kAuto;
  if (name == "csv") return LogEncoding::kCsv;
  if (name == "bin") return LogEncoding::kBinary;
  if (name == "h5") return LogEncoding::kHdf5;
  throw LogError("unknown log format '" + name + "' (auto, csv, bin or h5)");
}

// ================================================================= reader

LogReader::LogReader() = default;
LogReader::LogReader(const std::string& path) { open(path); }
LogReader::~LogReader() { close(); }

void LogReader::close() {
  if (f_) std::fclose(f_);
  f_ = nullptr;
  h5_.reset();
}

namespace {
// Reads one line (without '\n', '\r' stripped) into buf. False at EOF with nothing read.
bool read_line(std::FILE* f, std::vector<char>& buf, const std::string& where) {
  buf.clear();
  int c;
  bool any = false;
  while ((c = getc_unlocked(f)) != EOF) {
    any = true;
    if (c == '\n') break;
    if (buf.size() >= kMaxLine) throw LogError(where + ": line longer than 1 MiB");
    buf.push_back(static_cast<char>(c));
  }
  if (c == EOF && std::ferror(f)) throw LogError(where + ": read error: " + std::strerror(errno));
  if (!buf.empty() && buf.back() == '\r') buf.pop_back();
  return any;
}
}  // namespace


void LogReader::open(const std::string& path) {
  // A header that does not parse leaves the reader closed (the constructor throws, so the destructor
  // would never run: without this, every refused file leaked its FILE*).
  try {
    open_parse(path);
  } catch (...) {
    close();
    throw;
  }
}

void LogReader::open_parse(const std::string& path) {
  close();
  path_ = path;
  meta_ = LogMeta{};
  meta_.format_version = 0;
  rows_ = 0;
  line_ = 0;
  declared_rows_ = 0;
  last_t_s_ = 0.0;
  cur_segment_ = -1;
  closed_segments_.clear();
  f_ = std::fopen(path.c_str(), "rb");
  if (!f_) throw LogError(path + ": cannot open: " + std::strerror(errno));
  char magic[8] = {};
  std::size_t got = std::fread(magic, 1, 8, f_);
  if (got == 8 && h5::is_hdf5_signature(magic)) {
    close();
    enc_ = LogEncoding::kHdf5;
    h5_ = std::make_unique<h5::Reader>(path, meta_);
    declared_rows_ = h5_->rows();
    return;
  }
  if (got == 8 && std::memcmp(magic, kLogBinaryMagic, 8) == 0) {
    enc_ = LogEncoding::kBinary;
    char h[kBinHeaderFixed - 8];
    if (std::fread(h, 1, sizeof h, f_) != sizeof h) throw LogError(path + ": binary log header truncated");
    const char* p = h;
    auto version = get<std::uint32_t>(p);
    auto rec = get<std::uint32_t>(p);
    declared_rows_ = get<std::uint64_t>(p);
    auto mlen = get<std::uint32_t>(p);
    if (version != kLogFormatVersion)
      throw LogError(path + ": binary log version " + std::to_string(version) + " not supported");
    if (rec != kLogBinaryRecordBytes)
      throw LogError(path + ": binary record size " + std::to_string(rec) + ", expected " +
                     std::to_string(kLogBinaryRecordBytes));
    if (mlen > kMaxMeta) throw LogError(path + ": binary metadata block too large");
    std::string text(mlen, '\0');
    if (std::fread(text.data(), 1, mlen, f_) != mlen) throw LogError(path + ": binary metadata block truncated");
    std::size_t pos = 0, ln = 0;
    while (pos < text.size()) {
      std::size_t nl = text.find('\n', pos);
      if (nl == std::string::npos) nl = text.size();
      std::string l = text.substr(pos, nl - pos);
      ++ln;
      pos = nl + 1;
      if (l.empty()) continue;
      auto eq = l.find('=');
      std::string where = path + ": metadata line " + std::to_string(ln);
      if (eq == std::string::npos) throw LogError(where + ": expected key=value");
      apply_meta(meta_, l.substr(0, eq), l.substr(eq + 1), where);
    }
    if (meta_.format_version != kLogFormatVersion) throw LogError(path + ": metadata lacks format_version=1");
    data_offset_ = static_cast<long>(kBinHeaderFixed + mlen);
    buf_.resize(kLogBinaryRecordBytes);
    return;
  }
  // CSV
  enc_ = LogEncoding::kCsv;
  std::rewind(f_);
  std::vector<char> line;
  std::vector<int> cols;
  while (true) {
    if (!read_line(f_, line, path)) throw LogError(path + ": no header line (empty or truncated CSV log)");
    ++line_;
    std::string l(line.begin(), line.end());
    std::string where = path + ":" + std::to_string(line_);
    if (l.empty()) continue;
    if (l[0] == '#') {
      std::size_t s = 1;
      while (s < l.size() && l[s] == ' ') ++s;
      auto eq = l.find('=', s);
      if (eq == std::string::npos) continue;  // a plain comment
      apply_meta(meta_, l.substr(s, eq - s), l.substr(eq + 1), where);
      continue;
    }
    // Header
    if (meta_.format_version != kLogFormatVersion)
      throw LogError(path + ": not an imuforge log v1 (no '# format_version=1' before the header)");
    std::vector<std::string> names;
    std::size_t a = 0;
    while (true) {
      std::size_t c = l.find(',', a);
      names.push_back(l.substr(a, c == std::string::npos ? std::string::npos : c - a));
      if (c == std::string::npos) break;
      a = c + 1;
    }
    cols.assign(names.size(), -1);
    bool have[22] = {};
    for (std::size_t i = 0; i < names.size(); ++i) {
      int fld = -1;
      for (int r = 0; r < 16; ++r)
        if (names[i] == kRequired[r]) fld = r;
      for (int t = 0; t < 3; ++t) {
        if (names[i] == "tbl_angle_" + std::to_string(t)) fld = 16 + 2 * t;
        if (names[i] == "tbl_rate_" + std::to_string(t)) fld = 17 + 2 * t;
      }
      if (fld >= 0) {
        if (have[fld]) throw LogError(where + ": column " + quote_for_message(names[i]) + " appears twice");
        have[fld] = true;
      }
      cols[i] = fld;
    }
    for (int r = 0; r < 16; ++r)
      if (!have[r]) throw LogError(where + ": header lacks required column '" + std::string(kRequired[r]) + "'");
    break;
  }
  col_map_ = std::move(cols);
  data_offset_ = std::ftell(f_);
  data_line_ = line_;
}

bool LogReader::next(LogRow& row) {
  if (h5_) {
    if (!h5_->next(row)) return false;
    ++rows_;
  } else {
    if (!f_) throw LogError(path_ + ": log not open");
    if (!(enc_ == LogEncoding::kBinary ? next_bin(row) : next_csv(row))) return false;
  }
  check_row(row);
  // A count outside the declared word width is a corrupt row or wrong metadata: either way the clip
  // rule (a count at the width's limit) would misjudge it, so it is refused here, by line.
  for (int c = 0; c < 6; ++c) {
    const int bits = c < 3 ? meta_.accel_bits : meta_.gyro_bits;
    if (raw_fits(row.raw[c], bits)) continue;
    static const char* kCol[6] = {"ax", "ay", "az", "gx", "gy", "gz"};
    const std::string where = enc_ == LogEncoding::kCsv ? path_ + ":" + std::to_string(line_)
                                                        : path_ + ": record " + std::to_string(rows_ - 1);
    throw LogError(where + ": " + kCol[c] + " count " + std::to_string(row.raw[c]) + " exceeds the declared " +
                   std::to_string(bits) + "-bit raw word (" + (c < 3 ? "accel_bits" : "gyro_bits") + "=" +
                   std::to_string(bits) + ", range " + std::to_string(raw_min(bits)) + ".." +
                   std::to_string(raw_max(bits)) + ")");
  }
  return true;
}

// What a row may not be whatever its encoding: time running backwards, a segment that comes back after
// another one began (the same dwell twice: a spliced or duplicated file), infinite values (NaN is the
// format's "unknown" for temperatures and table axes, Inf is never a reading).
void LogReader::check_row(const LogRow& row) {
  const std::string where = enc_ == LogEncoding::kBinary ? path_ + ": record " + std::to_string(rows_ - 1)
                                                         : path_ + ":" + std::to_string(line_);
  if (rows_ > 1 && row.t_s < last_t_s_) {
    throw LogError(where + ": t_s " + std::to_string(row.t_s) + " goes back in time (previous row " +
                   std::to_string(last_t_s_) + ")");
  }
  last_t_s_ = row.t_s;
  if (row.segment < -1) throw LogError(where + ": segment " + std::to_string(row.segment) + " (must be >= -1)");
  if (row.segment != cur_segment_) {
    if (cur_segment_ >= 0) closed_segments_.insert(cur_segment_);
    if (row.segment >= 0 && closed_segments_.count(row.segment) != 0) {
      throw LogError(where + ": segment " + std::to_string(row.segment) +
                     " appears again after other segments (a duplicated or spliced segment)");
    }
    cur_segment_ = row.segment;
  }
  const auto inf = [](double v) { return std::isinf(v); };
  if (inf(row.temp_C) || inf(row.chamber_C)) throw LogError(where + ": temp_C/chamber_C is infinite");
  for (int i = 0; i < 3; ++i) {
    if (inf(row.table_angle_rad[i]) || inf(row.table_rate_rad_s[i])) throw LogError(where + ": table angle/rate is infinite");
    if (row.has_ref && !(std::isfinite(row.f_ref[i]) && std::isfinite(row.w_ref[i]))) {
      throw LogError(where + ": f_ref/w_ref is not finite");
    }
  }
}

bool LogReader::next_bin(LogRow& row) {
  std::size_t got = std::fread(buf_.data(), 1, kLogBinaryRecordBytes, f_);
  if (got == 0) {
    if (std::ferror(f_)) throw LogError(path_ + ": read error: " + std::strerror(errno));
    if (declared_rows_ != 0 && declared_rows_ != rows_)
      throw LogError(path_ + ": header announces " + std::to_string(declared_rows_) + " records, file holds " +
                     std::to_string(rows_));
    return false;
  }
  if (got != kLogBinaryRecordBytes)
    throw LogError(path_ + ": truncated record " + std::to_string(rows_) + " (" + std::to_string(got) + " of " +
                   std::to_string(kLogBinaryRecordBytes) + " bytes)");
  const char* p = buf_.data();
  row.t_s = get<double>(p);
  row.segment = get<std::int32_t>(p);
  auto flags = get<std::uint32_t>(p);
  row.has_ref = (flags & 1u) != 0;
  row.temp_C = get<double>(p);
  row.chamber_C = get<double>(p);
  for (double& v : row.f_ref) v = get<double>(p);
  for (double& v : row.w_ref) v = get<double>(p);
  for (auto& v : row.raw) v = get<std::int32_t>(p);
  for (double& v : row.table_angle_rad) v = get<double>(p);
  for (double& v : row.table_rate_rad_s) v = get<double>(p);
  if ((flags & ~1u) != 0)
    throw LogError(path_ + ": record " + std::to_string(rows_) + ": unknown flag bits set (corrupt file?)");
  if (!std::isfinite(row.t_s))
    throw LogError(path_ + ": record " + std::to_string(rows_) + ": t_s is not finite");
  ++rows_;
  return true;
}

bool LogReader::next_csv(LogRow& row) {
  while (true) {
    if (!read_line(f_, buf_, path_)) return false;
    ++line_;
    if (buf_.empty()) continue;
    if (buf_[0] == '#') continue;
    break;
  }
  const char* s = buf_.data();
  const char* end = s + buf_.size();
  double refv[6];
  int ref_present = 0, ref_empty = 0;
  for (double& v : row.table_angle_rad) v = std::nan("");
  for (double& v : row.table_rate_rad_s) v = std::nan("");
  std::size_t col = 0;
  const char* a = s;
  while (true) {
    const char* c = static_cast<const char*>(std::memchr(a, ',', static_cast<std::size_t>(end - a)));
    const char* e = c ? c : end;
    if (col >= col_map_.size())
      throw LogError(path_ + ":" + std::to_string(line_) + ": more cells than header columns (" +
                     std::to_string(col_map_.size()) + ")");
    int fld = col_map_[col];
    auto fail = [&](const char* what) {
      throw LogError(path_ + ":" + std::to_string(line_) + ": column " + std::to_string(col + 1) + " (" +
                     (fld >= 0 && fld < 16 ? kRequired[fld] : "table") + "): " + what + ": " +
                     quote_for_message(std::string(a, e)));
    };
    if (fld >= 0) {

      if (fld == 0) {
        if (!parse_double(a, e, row.t_s) || !std::isfinite(row.t_s)) fail("expected a finite time");
      } else if (fld == 1) {
        if (!parse_int32(a, e, row.segment) || row.segment < -1) fail("expected an integer >= -1");
      } else if (fld == 2 || fld == 3) {
        double& d = fld == 2 ? row.temp_C : row.chamber_C;
        if (a == e) d = std::nan("");
        else if (!parse_double(a, e, d)) fail("expected a number or an empty cell");
      } else if (fld < 10) {
        if (a == e) {
          ++ref_empty;
        } else {
          if (!parse_double(a, e, refv[fld - 4]) || !std::isfinite(refv[fld - 4])) fail("expected a number");
          ++ref_present;
        }
      } else if (fld < 16) {
        if (!parse_int32(a, e, row.raw[fld - 10])) fail("expected an integer count");
      } else {
        double v = std::nan("");
        if (a != e && !parse_double(a, e, v)) fail("expected a number or an empty cell");
        // A plain branch: GCC 12 with -fsanitize=undefined miscompiles `(c ? arr1 : arr2)[i / 2]` on built-in
        // arrays (the index is evaluated in one arm only; see host/diagnosis/diagnose.cpp).
        if ((fld - 16) % 2 == 0) row.table_angle_rad[(fld - 16) / 2] = v;
        else row.table_rate_rad_s[(fld - 16) / 2] = v;
      }
    }
    ++col;
    if (!c) break;
    a = c + 1;
  }
  if (col != col_map_.size())
    throw LogError(path_ + ":" + std::to_string(line_) + ": " + std::to_string(col) + " cells, header has " +
                   std::to_string(col_map_.size()));
  if (ref_present != 0 && ref_empty != 0)
    throw LogError(path_ + ":" + std::to_string(line_) +
                   ": reference columns f_ref/w_ref must be all present or all empty");
  row.has_ref = ref_present == 6;
  if (row.has_ref) {
    for (int i = 0; i < 3; ++i) {
      row.f_ref[i] = refv[i];
      row.w_ref[i] = refv[3 + i];
    }
  } else {
    for (int i = 0; i < 3; ++i) row.f_ref[i] = row.w_ref[i] = 0.0;
  }
  ++rows_;
  return true;
}

void LogReader::rewind() {
  if (h5_) {
    h5_->rewind();
  } else {
    if (!f_) throw LogError(path_ + ": log not open");
    if (std::fseek(f_, data_offset_, SEEK_SET) != 0) throw LogError(path_ + ": cannot seek: " + std::strerror(errno));
    line_ = data_line_;
  }
  rows_ = 0;
  last_t_s_ = 0.0;
  cur_segment_ = -1;
  closed_segments_.clear();
}

// ================================================================= writer

LogWriter::LogWriter() = default;
LogWriter::LogWriter(const std::string& path, const LogMeta& meta, LogEncoding enc) { open(path, meta, enc); }

LogWriter::~LogWriter() {
  try {
    close();
  } catch (...) {
  }
}

void LogWriter::open(const std::string& path, const LogMeta& meta, LogEncoding enc) {
  close();
  check_meta(meta, path);
  path_ = path;
  enc_ = enc == LogEncoding::kAuto ? encoding_from_path(path) : enc;
  rows_ = 0;
  table_axes_ = meta.table_axes;
  if (enc_ == LogEncoding::kHdf5) {
    h5_ = std::make_unique<h5::Writer>(path, meta);
    return;
  }
  f_ = std::fopen(path.c_str(), "wb");
  if (!f_) throw LogError(path + ": cannot create: " + std::strerror(errno));
  buf_.clear();
  buf_.reserve(1u << 20);
  if (enc_ == LogEncoding::kBinary) {
    std::string text = meta_text(meta, "");
    char h[kBinHeaderFixed];
    char* p = h;
    std::memcpy(p, kLogBinaryMagic, 8);
    p += 8;
    put<std::uint32_t>(p, kLogFormatVersion);
    put<std::uint32_t>(p, static_cast<std::uint32_t>(kLogBinaryRecordBytes));
    count_offset_ = static_cast<long>(p - h);
    put<std::uint64_t>(p, 0);  // patched by close()
    put<std::uint32_t>(p, static_cast<std::uint32_t>(text.size()));
    buf_.insert(buf_.end(), h, h + kBinHeaderFixed);
    buf_.insert(buf_.end(), text.begin(), text.end());
  } else {
    std::string text = meta_text(meta, "# ");
    for (int i = 0; i < 16; ++i) text += std::string(i ? "," : "") + kRequired[i];
    for (int t = 0; t < meta.table_axes; ++t)
      text += ",tbl_angle_" + std::to_string(t) + ",tbl_rate_" + std::to_string(t);
    text += "\n";
    buf_.insert(buf_.end(), text.begin(), text.end());
  }
}

void LogWriter::write(const LogRow& r) {
  if (h5_) {
    h5_->write(r);
    ++rows_;
    return;
  }
  if (!f_) throw LogError(path_ + ": log not open for writing");
  if (enc_ == LogEncoding::kBinary) {
    std::size_t n = buf_.size();
    buf_.resize(n + kLogBinaryRecordBytes);
    char* p = buf_.data() + n;
    put<double>(p, r.t_s);
    put<std::int32_t>(p, r.segment);
    put<std::uint32_t>(p, r.has_ref ? 1u : 0u);
    put<double>(p, r.temp_C);
    put<double>(p, r.chamber_C);
    for (double v : r.f_ref) put<double>(p, r.has_ref ? v : 0.0);
    for (double v : r.w_ref) put<double>(p, r.has_ref ? v : 0.0);
    for (auto v : r.raw) put<std::int32_t>(p, v);
    for (double v : r.table_angle_rad) put<double>(p, v);
    for (double v : r.table_rate_rad_s) put<double>(p, v);
  } else {
    line_.clear();
    append_double(line_, r.t_s);
    line_ += ',';
    line_ += std::to_string(r.segment);
    line_ += ',';
    append_double(line_, r.temp_C);
    line_ += ',';
    append_double(line_, r.chamber_C);
    for (int i = 0; i < 6; ++i) {
      line_ += ',';
      if (r.has_ref) append_double(line_, i < 3 ? r.f_ref[i] : r.w_ref[i - 3]);
    }
    for (int i = 0; i < 6; ++i) {
      line_ += ',';
      line_ += std::to_string(r.raw[i]);
    }
    for (int t = 0; t < table_axes_; ++t) {
      line_ += ',';
      append_double(line_, r.table_angle_rad[t]);
      line_ += ',';
      append_double(line_, r.table_rate_rad_s[t]);
    }
    line_ += '\n';
    buf_.insert(buf_.end(), line_.begin(), line_.end());
  }
  ++rows_;
  if (buf_.size() >= (1u << 20)) flush_buffer();
}

void LogWriter::flush_buffer() {
  if (buf_.empty()) return;
  if (std::fwrite(buf_.data(), 1, buf_.size(), f_) != buf_.size())
    throw LogError(path_ + ": write failed: " + std::strerror(errno));
  buf_.clear();
}

void LogWriter::flush() {
  if (h5_) {
    h5_->flush();
    return;
  }
  if (!f_) return;
  flush_buffer();
  if (std::fflush(f_) != 0) throw LogError(path_ + ": flush failed: " + std::strerror(errno));
}

void LogWriter::sync() {
  flush();
  if (f_ && ::fsync(fileno(f_)) != 0) throw LogError(path_ + ": fsync failed: " + std::strerror(errno));
}

void LogWriter::close() {
  if (h5_) {
    std::unique_ptr<h5::Writer> w = std::move(h5_);
    w->close();
    return;
  }
  if (!f_) return;
  std::FILE* f = f_;
  try {
    flush_buffer();
    if (enc_ == LogEncoding::kBinary) {
      char cnt[8];
      char* p = cnt;
      put<std::uint64_t>(p, rows_);
      if (std::fseek(f, count_offset_, SEEK_SET) != 0 || std::fwrite(cnt, 1, 8, f) != 8)
        throw LogError(path_ + ": cannot finalise record count: " + std::strerror(errno));
    }
  } catch (...) {
    std::fclose(f);
    f_ = nullptr;
    throw;
  }
  f_ = nullptr;
  if (std::fclose(f) != 0) throw LogError(path_ + ": close failed: " + std::strerror(errno));
}

}  // namespace imuforge::io
