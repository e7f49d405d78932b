// Log v1 fuzzing (CSV, binary and HDF5 targets): read every row; a log that reads must also write back and
// read again to the same metadata and rows (bit for bit, NaN for NaN).
#pragma once
#include <cmath>
#include <cstring>
#include <vector>

#include "host/io/log.h"
#include "tests/fuzz/host/fuzz_io.h"

namespace fuzzio {

inline bool same(double a, double b) { return (std::isnan(a) && std::isnan(b)) || std::memcmp(&a, &b, sizeof a) == 0; }

inline bool same_row(const imuforge::io::LogRow& a, const imuforge::io::LogRow& b) {
  if (!same(a.t_s, b.t_s) || a.segment != b.segment || !same(a.temp_C, b.temp_C) || !same(a.chamber_C, b.chamber_C) ||
      a.has_ref != b.has_ref)
    return false;
  for (int i = 0; i < 3; ++i) {
    if (a.has_ref && (!same(a.f_ref[i], b.f_ref[i]) || !same(a.w_ref[i], b.w_ref[i]))) return false;
    if (!same(a.table_angle_rad[i], b.table_angle_rad[i]) || !same(a.table_rate_rad_s[i], b.table_rate_rad_s[i]))
      return false;
  }
  for (int i = 0; i < 6; ++i)
    if (a.raw[i] != b.raw[i]) return false;
  return true;
}

// Rows beyond this are not read (keeps executions fast; the reader is per-row, nothing accumulates).
constexpr std::size_t kMaxRows = 4096;

// enc: the encoding the input must read as; back: the encoding it is written back in and read again
// (the HDF5 target reads CSV and round-trips it through the HDF5 writer and reader).
inline void fuzz_log(const std::string& path, imuforge::io::LogEncoding enc, imuforge::io::LogEncoding back_enc) {
  using namespace imuforge::io;
  std::vector<LogRow> rows;
  LogMeta meta;
  try {
    LogReader r(path);
    FUZZ_CHECK(r.encoding() == enc);
    LogRow row;
    while (rows.size() < kMaxRows && r.next(row)) rows.push_back(row);
    meta = r.meta();
  } catch (const std::exception& e) {
    check_refusal(e);
    return;
  }
  for (const auto& row : rows) {
    FUZZ_CHECK(std::isfinite(row.t_s));
    FUZZ_CHECK(row.segment >= -1);
  }
  for (std::size_t i = 1; i < rows.size(); ++i) FUZZ_CHECK(rows[i].t_s >= rows[i - 1].t_s);
  if (meta.table_axes < 0 || meta.table_axes > 3) std::abort();
  // CSV writes only the table columns of the logged axes: compare those.
  for (auto& row : rows) {
    for (int i = meta.table_axes; i < 3; ++i) row.table_angle_rad[i] = row.table_rate_rad_s[i] = std::nan("");
  }
  const std::string back =
      scratch(back_enc == LogEncoding::kCsv ? "back.csv" : back_enc == LogEncoding::kHdf5 ? "back.h5" : "back.bin");
  try {
    LogWriter w(back, meta, back_enc);
    for (const auto& row : rows) w.write(row);
    w.close();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "a log that reads cannot be written back: %s\n", e.what());
    std::abort();
  }
  LogReader r2(back);
  LogRow row;
  std::size_t n = 0;
  while (r2.next(row)) {
    FUZZ_CHECK(n < rows.size());
    FUZZ_CHECK(same_row(row, rows[n]));
    ++n;
  }
  FUZZ_CHECK(n == rows.size());
  FUZZ_CHECK(r2.meta().serial == meta.serial && r2.meta().table_axes == meta.table_axes);
  FUZZ_CHECK(r2.meta().extra == meta.extra);
}

}  // namespace fuzzio
