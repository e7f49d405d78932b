// Internal to host/io: the HDF5 encoding of log v1, behind LogReader/LogWriter (host/io/log.h).
// Layout (docs/formats.md "HDF5 encoding"): root attributes carry the metadata (the reserved keys typed,
// numbers as 64-bit floats, table_axes and format_version as 32-bit ints, everything else as UTF-8
// strings, in creation order); each CSV column is a 1-D dataset of the same name and length at the root
// (t_s, segment, temp_C, chamber_C, f_ref_x … w_ref_z, ax … gz, tbl_angle_<i>, tbl_rate_<i>), chunked
// (kH5ChunkRows) and compressed (shuffle + deflate 4). Missing values are NaN; a row without fixture
// reference has NaN in all six f_ref/w_ref datasets. Uses the serial libhdf5: not thread-safe.
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "host/io/log.h"

namespace imuforge::io::h5 {

constexpr std::size_t kH5ChunkRows = 32768;

// True when the first 8 bytes are the HDF5 signature.
bool is_hdf5_signature(const char first8[8]);

class Reader {
 public:
  // Opens the file, reads the metadata into *meta and checks the datasets. Throws LogError naming the
  // file and the attribute or dataset at fault.
  Reader(const std::string& path, LogMeta& meta);
  ~Reader();
  bool next(LogRow& row);  // false after the last row
  void rewind();
  std::uint64_t rows() const;
  struct Impl;

 private:
  std::unique_ptr<Impl> p_;
};

class Writer {
 public:
  Writer(const std::string& path, const LogMeta& meta);
  ~Writer();
  void write(const LogRow& row);
  void flush();  // extends the datasets by the buffered rows and flushes the file
  void close();  // flush + close; throws LogError on failure
  struct Impl;

 private:
  std::unique_ptr<Impl> p_;
};

}  // namespace imuforge::io::h5
