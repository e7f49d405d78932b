// Coefficient table format v1: the calibration result shipped from the host solver to the IMU.
// Byte-by-byte layout: docs/table-format.md. Everything is little endian on every host and is
// (de)serialised field by field (firmware/common/endian.h), never by memcpy of a struct.
//
// What the table means (per breakpoint temperature T_i, per triad):
//     accel:  f = C_a(T) · (raw_a · lsb_a − b_a(T))                                  [m/s²]
//     gyro:   w = C_g(T) · (raw_g · lsb_g − b_g(T)) + G(T) · f                        [rad/s]
// C = (I+M)^-1 is the inverse of the sensor's scale/misalignment matrix, computed on the host in double
// precision; b is the bias in SI units; G is the g-sensitivity correction the kernel ADDS, in
// (rad/s)/(m/s²) (for a sensor model w_meas = b + (I+M)w + G_s f, the shipped G is −C_g·G_s).
// Between breakpoints every coefficient is interpolated linearly; outside, the nearest end is used.
//
// Usage (no heap; the Table is ~2.3 KB, keep it static or in the caller's instance):
//     static imuforge::fw::Table table;
//     int rc = imuforge::fw::table_parse(blob, blob_len, &table);
//     if (rc != 0) { /* table_strerror(rc); the Table is marked invalid and must not be used */ }
#pragma once
#include <cstddef>
#include <cstdint>

#include "firmware/common/error.h"

namespace imuforge::fw {

constexpr std::uint32_t kTableMagic = 0x54434649u;  // bytes "IFCT" (imuforge coefficient table)
constexpr std::uint16_t kTableFormatVersion = 1;
constexpr std::size_t kTableHeaderLen = 64;         // v1 header, bytes
constexpr std::size_t kTableMaxBreakpoints = 16;
constexpr std::size_t kTableCoeffsPerBreakpoint = 33;  // accel C(9) b(3), gyro C(9) b(3) G(9)
constexpr std::size_t kTableRecordLen = kTableCoeffsPerBreakpoint * 4;  // 132 bytes
constexpr std::size_t kTableCrcLen = 4;
// Total serialised size for n breakpoints: header, n breakpoints (f32), n records, CRC-32.
constexpr std::size_t table_serialized_size(std::size_t n_breakpoints) noexcept {
  return kTableHeaderLen + n_breakpoints * (4 + kTableRecordLen) + kTableCrcLen;
}
constexpr std::size_t kTableMaxSize = table_serialized_size(kTableMaxBreakpoints);  // 2244 bytes

// Validity limits (checked by table_validate / table_parse; the fixed-point kernel relies on them).
constexpr float kTableMinTempDegC = -100.0f;   // breakpoints must lie in [min, max]
constexpr float kTableMaxTempDegC = 250.0f;
constexpr float kTableMinBreakpointStepDegC = 1.0f / 256.0f;  // strictly increasing by at least this
constexpr float kTableMaxAbsC = 4.0f;          // |C_jk| (C ≈ I for any sane sensor)
constexpr float kTableMaxAbsG = 1.0f;          // |G_jk|, (rad/s)/(m/s²)
constexpr std::uint8_t kTableMinRawBits = 8;   // sensor raw word width, two's complement
constexpr std::uint8_t kTableMaxRawBits = 24;
// |b_j| must not exceed the triad's full scale, lsb · 2^(raw_bits−1).

// model_flags: which terms carry information. A term whose flag is clear must hold its neutral value
// (C = I, b = 0, G = 0) at every breakpoint; a table with kModelTemperature clear has exactly one
// breakpoint. Unknown bits are rejected, so a v1 parser never misreads a future term.
enum ModelFlags : std::uint32_t {
  kModelAccelMatrix = 1u << 0,  // accel C differs from identity
  kModelAccelBias = 1u << 1,    // accel b present
  kModelGyroMatrix = 1u << 2,   // gyro C differs from identity
  kModelGyroBias = 1u << 3,     // gyro b present
  kModelGyroGSens = 1u << 4,    // gyro G present
  kModelTemperature = 1u << 5,  // more than one breakpoint (temperature-dependent coefficients)
  kModelAllKnown = 0x3Fu,
};

// Stable error codes (block -100..-199 of firmware/common/error.h). Never renumber.
enum TableError : int {
  kTableOk = 0,
  kTableNullArgument = -100,         // buf or out is null
  kTableTooShort = -101,             // fewer bytes than an empty table (header + CRC)
  kTableBadMagic = -102,             // bytes 0..3 are not "IFCT"
  kTableUnsupportedVersion = -103,   // format_version != 1
  kTableBadHeaderLength = -104,      // header_len != 64
  kTableLengthMismatch = -105,       // total_len field != buffer length
  kTableCrcMismatch = -106,          // CRC-32 over bytes [0, total_len−4) != stored CRC
  kTableReservedNonZero = -107,      // a reserved byte is not zero
  kTableZeroBreakpoints = -108,      // breakpoint_count == 0
  kTableTooManyBreakpoints = -109,   // breakpoint_count > 16
  kTableBadRecordLength = -110,      // record_len != 132
  kTableSizeMismatch = -111,         // total_len != 64 + n·136 + 4
  kTableBadLsb = -112,               // an LSB is not finite or not > 0
  kTableBadRawBits = -113,           // raw_bits outside [8, 24]
  kTableUnknownModelFlags = -114,    // a model_flags bit outside kModelAllKnown
  kTableBreakpointNotFinite = -115,  // a breakpoint is NaN or infinite
  kTableBreakpointOutOfRange = -116, // a breakpoint outside [−100, 250] °C
  kTableBreakpointsNotIncreasing = -117,  // T_(i+1) − T_i < 1/256 °C
  kTableCoefficientNotFinite = -118, // a coefficient is NaN or infinite
  kTableCoefficientOutOfRange = -119,// |C| > 4, |G| > 1 or |b| > full scale
  kTableFlagsMismatch = -120,        // a term flagged absent is not neutral, or kModelTemperature vs count
  kTableBufferTooSmall = -121,       // table_serialize: capacity below table_serialized_size(n)
  kTableNotValid = -122,             // a Table that did not come from a successful parse/validate
};

// Static, human-readable name of a TableError ("CRC mismatch"...), "unknown table error" otherwise.
const char* table_strerror(int code) noexcept;

// One triad's correction at one breakpoint. Matrices are row-major: C[3*row + col].
struct TriadCoeffs {
  float C[9];  // dimensionless
  float b[3];  // bias, SI units (m/s² or rad/s)
};
struct BreakpointCoeffs {
  TriadCoeffs accel;
  TriadCoeffs gyro;
  float G[9];  // gyro g-sensitivity correction, (rad/s)/(m/s²), row-major
};

// The parsed table. Plain data: fill it, call table_validate(), then serialise or hand it to the kernel.
struct Table {
  std::uint32_t valid_marker;     // kTableValidMarker after a successful parse/validate, 0 otherwise
  std::uint64_t device_serial;    // the IMU's serial number
  std::uint32_t table_sequence;   // increases with every table written for this device
  std::int64_t created_unix_s;    // creation time, seconds since 1970-01-01 UTC
  std::uint32_t model_flags;      // ModelFlags
  float accel_lsb_mps2;           // m/s² per raw count
  float gyro_lsb_rad_s;           // rad/s per raw count
  std::uint8_t accel_raw_bits;    // raw word width; full scale = lsb · 2^(bits−1)
  std::uint8_t gyro_raw_bits;
  std::uint8_t n_breakpoints;     // 1..16
  float breakpoints_degC[kTableMaxBreakpoints];  // strictly increasing
  BreakpointCoeffs coeffs[kTableMaxBreakpoints];
  std::uint32_t crc32;            // CRC of the last parsed/serialised image (informational)
};
constexpr std::uint32_t kTableValidMarker = 0x56414C31u;  // "1LAV"

// Makes *t a neutral one-breakpoint table (C = I, b = G = 0, at 25 °C, flags 0) with the given LSBs
// and raw widths, NOT yet validated (valid_marker = 0). Cannot fail. O(1).
void table_init_identity(Table* t, float accel_lsb_mps2, float gyro_lsb_rad_s, std::uint8_t accel_raw_bits,
                         std::uint8_t gyro_raw_bits) noexcept;

// Checks every semantic rule above and sets valid_marker on success (clears it on failure).
// Returns 0 or the first failing TableError in the order of docs/table-format.md. O(n).
int table_validate(Table* t) noexcept;

// True iff t passed table_parse()/table_validate() since its last modification by those functions.
inline bool table_is_valid(const Table* t) noexcept { return t != nullptr && t->valid_marker == kTableValidMarker; }

// Parses a serialised v1 table of exactly `len` bytes. On success fills *out and returns 0.
// On failure returns a TableError and leaves *out zeroed with valid_marker = 0 (never half-filled).
// Checks, in order: length, magic, version, header length, total length, CRC, reserved bytes, counts,
// record length, size, LSBs, raw widths, flags, breakpoints, coefficients, flag consistency. O(len).
int table_parse(const std::uint8_t* buf, std::size_t len, Table* out) noexcept;

// Validates *t (setting its marker and crc32 field) and writes table_serialized_size(n) bytes to buf.
// Returns the number of bytes written (> 0) or a negative TableError. O(n).
int table_serialize(Table* t, std::uint8_t* buf, std::size_t cap) noexcept;

}  // namespace imuforge::fw
