// Internal to host/io: the pieces of the log v1 reader/writer that every encoding shares (metadata
// keys and their parsing, the CSV column names, number formatting), so CSV, binary and HDF5 accept and
// reject exactly the same metadata. Internal, not API (installed only as part of the folder); include
// only from host/io/*.cpp.
#pragma once

#include <cstdint>
#include <string>

#include "host/io/log.h"

namespace imuforge::io::detail {

// Log v1 column names in file order (CSV header, HDF5 dataset names): t_s … gz.
extern const char* const kRequired[16];
// Applies one metadata key/value (any encoding), validating reserved keys; `where` prefixes errors.
void apply_meta(LogMeta& m, const std::string& key, const std::string& val, const std::string& where);
// Throws LogError naming `path` when the metadata cannot be written (bad key, newline, table_axes).
void check_meta(const LogMeta& m, const std::string& path);
// Shortest round-trip text of a double ("nan" for NaN).
std::string fmt_double(double v);
bool parse_double(const char* b, const char* e, double& out);

}  // namespace imuforge::io::detail
