// Log format v1: one row per IMU sample, with fixture reference and raw counts (docs/formats.md).
//
// Three encodings carry identical content:
//   CSV    `# key=value` metadata lines, one header line, one text row per sample (human-readable).
//   binary magic "IMUFLOG1", a length-prefixed metadata block (the same key=value lines), then packed
//          little-endian fixed-size records of kLogBinaryRecordBytes (fast, 3.6 M rows/h at 1 kHz).
//   HDF5   the same metadata as root attributes, one chunked, compressed 1-D dataset per CSV column
//          (docs/formats.md; h5py and MATLAB's h5read open it without imuforge).
// LogReader auto-detects the encoding from the first bytes, so every command accepts all three.
//
// Conventions
//   - f_ref (m/s²) and w_ref (rad/s) are what an ideal IMU would read, in the IMU's NOMINAL frame,
//     computed from the table's REPORTED angles/rates with the NOMINAL geometry (so they carry the
//     fixture's own errors). has_ref == false (empty CSV cells) when there is no fixture reference
//     (hand-held poses, imported real recordings).
//   - segment numbers each dwell (position, rate, soak ...) from 0; −1 while the table moves.
//   - raw[0..5] = ax ay az gx gy gz in signed counts about zero; output in SI = raw · lsb.
//   - temp_C / chamber_C may be NaN (CSV: empty cell) when unknown, e.g. imported recordings.
// Errors: every failure throws LogError whose message names the file, and for CSV the line and column.
#pragma once

#include <cstdint>
#include <cstdio>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <unordered_set>
#include <utility>
#include <vector>

#include "host/io/input_error.h"

namespace imuforge::io {

namespace h5 {
class Reader;
class Writer;
}  // namespace h5

constexpr int kLogFormatVersion = 1;
// Packed record size of the binary form (see docs/formats.md for the byte layout).
constexpr std::size_t kLogBinaryRecordBytes = 152;
// The 8 magic bytes opening a binary log.
constexpr char kLogBinaryMagic[9] = "IMUFLOG1";

// Bad input (exit code 2), also for a log that cannot be created where the user asked.
class LogError : public InputError {
 public:
  using InputError::InputError;
};

struct LogMeta {
  int format_version = kLogFormatVersion;
  std::string serial;                                       // device serial ("" if unknown)
  double sample_rate_hz = 0.0;                              // nominal output data rate
  double accel_lsb_mps2 = 0.0;                              // m/s² per count
  double gyro_lsb_rad_s = 0.0;                              // rad/s per count
  double latitude_deg = std::numeric_limits<double>::quiet_NaN();
  double height_m = std::numeric_limits<double>::quiet_NaN();
  double gravity_mps2 = std::numeric_limits<double>::quiet_NaN();  // local normal gravity used for f_ref
  // Number of rate-table axes whose REPORTED angles/rates are logged (0..3). CSV carries the optional
  // columns tbl_angle_<i>, tbl_rate_<i> only for i < table_axes; binary always reserves 3.
  int table_axes = 0;
  // Width of the raw signed word per triad, in bits (2..32). Optional keys, 16 when absent (logs
  // written before they existed). Counts must lie in [−2^(bits−1), 2^(bits−1) − 1] (a row outside is
  // an error naming its line); a count AT either limit is a clipped (saturated) sample.
  int accel_bits = 16;
  int gyro_bits = 16;
  // Free key/values in file order (e.g. "source", "campaign", "raw_offset_ax"). Keys: [A-Za-z0-9_.-]+,
  // values: any text without newline. The reserved keys above are never stored here.
  std::vector<std::pair<std::string, std::string>> extra;

  // Value of an extra key, or nullptr.
  const std::string* find(const std::string& key) const;
  // Insert or replace an extra key (throws LogError on an invalid key or a value with a newline).
  void set(const std::string& key, const std::string& value);
};

struct LogRow {
  double t_s = 0.0;            // seconds since log start (sample time as stamped by the logger)
  std::int32_t segment = -1;   // dwell index, −1 while moving
  double temp_C = std::numeric_limits<double>::quiet_NaN();     // sensor (die) temperature reported
  double chamber_C = std::numeric_limits<double>::quiet_NaN();  // chamber air temperature reported
  bool has_ref = false;
  double f_ref[3] = {0, 0, 0};  // m/s², IMU nominal frame (meaningful only if has_ref)
  double w_ref[3] = {0, 0, 0};  // rad/s, IMU nominal frame (meaningful only if has_ref)
  std::int32_t raw[6] = {0, 0, 0, 0, 0, 0};  // ax ay az gx gy gz, signed counts
  // Table axes as REPORTED by the fixture (innermost first), rad and rad/s; NaN when not logged.
  // The solver's fixture+errors mode re-runs physics::table_kinematics() on these with nuisance errors.
  double table_angle_rad[3] = {std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::quiet_NaN(),
                               std::numeric_limits<double>::quiet_NaN()};
  double table_rate_rad_s[3] = {std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::quiet_NaN(),
                                std::numeric_limits<double>::quiet_NaN()};
};

// Signed range of a `bits`-wide raw word (bits 2..32).
constexpr std::int64_t raw_min(int bits) { return -(std::int64_t{1} << (bits - 1)); }
constexpr std::int64_t raw_max(int bits) { return (std::int64_t{1} << (bits - 1)) - 1; }
constexpr bool raw_fits(std::int64_t count, int bits) { return count >= raw_min(bits) && count <= raw_max(bits); }
// A count at either limit of the word: the sensor saturated there.
constexpr bool raw_clipped(std::int64_t count, int bits) { return count <= raw_min(bits) || count >= raw_max(bits); }

enum class LogEncoding { kAuto, kCsv, kBinary, kHdf5 };

// Encoding from a file name: ".bin"/".imulog"/".ilog" -> binary, ".h5"/".hdf5" -> HDF5, else CSV.
LogEncoding encoding_from_path(const std::string& path);
// Encoding from a command-line name: "auto", "csv", "bin" or "h5" (throws LogError otherwise).
LogEncoding encoding_from_name(const std::string& name);
// The names encoding_from_name accepts, for CLI checks.
inline const char* const kLogFormatNames[] = {"auto", "csv", "bin", "h5"};

// Streaming reader: memory does not depend on file length. Not copyable.
class LogReader {
 public:
  LogReader();
  explicit LogReader(const std::string& path);
  ~LogReader();
  LogReader(const LogReader&) = delete;
  LogReader& operator=(const LogReader&) = delete;

  // Opens and parses the metadata + header (CSV) or header block (binary). Throws LogError.
  void open(const std::string& path);
  // Next row; false at a clean end of file. Throws LogError on malformed data (truncated binary record,
  // bad number, wrong column count), naming file, line and column.
  bool next(LogRow& row);
  // Back to the first row (for multi-pass consumers such as the solver). Throws on I/O errors.
  void rewind();
  void close();

  const LogMeta& meta() const { return meta_; }
  LogEncoding encoding() const { return enc_; }
  const std::string& path() const { return path_; }
  std::uint64_t rows_read() const { return rows_; }
  // Binary: records announced in the header (0 if the writer did not close cleanly); HDF5: dataset length.
  std::uint64_t declared_rows() const { return declared_rows_; }

 private:
  void open_parse(const std::string& path);
  bool next_csv(LogRow& row);
  bool next_bin(LogRow& row);
  std::unique_ptr<h5::Reader> h5_;  // HDF5 encoding (host/io/log_h5.cpp)
  void check_row(const LogRow& row);  // throws LogError: time backwards, segment again, Inf
  double last_t_s_ = 0.0;
  std::int32_t cur_segment_ = -1;
  std::unordered_set<std::int32_t> closed_segments_;
  std::FILE* f_ = nullptr;
  std::string path_;
  LogMeta meta_;
  LogEncoding enc_ = LogEncoding::kAuto;
  long data_offset_ = 0;
  std::uint64_t rows_ = 0;
  std::uint64_t line_ = 0;
  std::uint64_t declared_rows_ = 0;
  std::uint64_t data_line_ = 0;
  std::vector<int> col_map_;  // CSV: field per column (−1 ignored)
  std::vector<char> buf_;     // reused line / record buffer
};

// Streaming writer. CSV writes doubles in shortest round-trip form (std::to_chars), so CSV and binary
// carry bit-identical numbers. Rows are buffered (1 MiB); flush()/sync() push them out.
class LogWriter {
 public:
  LogWriter();
  // enc == kAuto chooses by extension (encoding_from_path).
  LogWriter(const std::string& path, const LogMeta& meta, LogEncoding enc = LogEncoding::kAuto);
  ~LogWriter();  // closes (errors are swallowed here; call close() to see them)
  LogWriter(const LogWriter&) = delete;
  LogWriter& operator=(const LogWriter&) = delete;

  void open(const std::string& path, const LogMeta& meta, LogEncoding enc = LogEncoding::kAuto);
  void write(const LogRow& row);
  // Pushes buffered rows to the OS; sync() additionally fsyncs (end-of-line journaling).
  void flush();
  void sync();
  // Finalises (binary: patches the row count in the header). Throws LogError on I/O failure.
  void close();

  LogEncoding encoding() const { return enc_; }
  std::uint64_t rows_written() const { return rows_; }

 private:
  std::unique_ptr<h5::Writer> h5_;  // HDF5 encoding (host/io/log_h5.cpp)
  std::FILE* f_ = nullptr;
  std::string path_;
  LogEncoding enc_ = LogEncoding::kAuto;
  std::uint64_t rows_ = 0;
  long count_offset_ = 0;
  int table_axes_ = 0;
  std::string line_;
  std::vector<char> buf_;
  void flush_buffer();
};

}  // namespace imuforge::io
