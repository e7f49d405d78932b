#include "firmware/table/table.h"

#include "firmware/common/crc32.h"
#include "firmware/common/endian.h"

namespace imuforge::fw {

namespace {

// v1 header offsets (docs/table-format.md).
constexpr std::size_t kOffMagic = 0;
constexpr std::size_t kOffVersion = 4;
constexpr std::size_t kOffHeaderLen = 6;
constexpr std::size_t kOffTotalLen = 8;
constexpr std::size_t kOffFlags = 12;
constexpr std::size_t kOffSerial = 16;
constexpr std::size_t kOffSequence = 24;
constexpr std::size_t kOffReserved0 = 28;  // 4 bytes
constexpr std::size_t kOffCreated = 32;
constexpr std::size_t kOffAccelLsb = 40;
constexpr std::size_t kOffGyroLsb = 44;
constexpr std::size_t kOffAccelBits = 48;
constexpr std::size_t kOffGyroBits = 49;
constexpr std::size_t kOffCount = 50;
constexpr std::size_t kOffReserved1 = 51;  // 1 byte
constexpr std::size_t kOffRecordLen = 52;
constexpr std::size_t kOffReserved2 = 56;  // 8 bytes

// Finite test without <cmath> classification macros (which may promote to double on some libcs).
bool is_finite(float v) noexcept {
  std::uint8_t b[4];
  store_lef32(b, v);
  return ((load_le32(b) >> 23) & 0xFFu) != 0xFFu;
}
float fabs_f(float v) noexcept { return v < 0.0f ? -v : v; }

// Coefficients of one breakpoint in file order.
void record_to_array(const BreakpointCoeffs& c, float out[kTableCoeffsPerBreakpoint]) noexcept {
  std::size_t k = 0;
  for (float v : c.accel.C) out[k++] = v;
  for (float v : c.accel.b) out[k++] = v;
  for (float v : c.gyro.C) out[k++] = v;
  for (float v : c.gyro.b) out[k++] = v;
  for (float v : c.G) out[k++] = v;
}
void array_to_record(const float in[kTableCoeffsPerBreakpoint], BreakpointCoeffs* c) noexcept {
  std::size_t k = 0;
  for (float& v : c->accel.C) v = in[k++];
  for (float& v : c->accel.b) v = in[k++];
  for (float& v : c->gyro.C) v = in[k++];
  for (float& v : c->gyro.b) v = in[k++];
  for (float& v : c->G) v = in[k++];
}

bool lsb_ok(float lsb) noexcept { return is_finite(lsb) && lsb > 0.0f; }
bool bits_ok(std::uint8_t bits) noexcept { return bits >= kTableMinRawBits && bits <= kTableMaxRawBits; }
float full_scale(float lsb, std::uint8_t bits) noexcept {
  return lsb * static_cast<float>(1ul << (bits - 1u));
}

bool is_identity(const float C[9]) noexcept {
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c)
      if (C[3 * r + c] != (r == c ? 1.0f : 0.0f)) return false;
  return true;
}
bool is_zero(const float* v, int n) noexcept {
  for (int i = 0; i < n; ++i)
    if (v[i] != 0.0f) return false;
  return true;
}

void zero_table(Table* t) noexcept {
  auto* p = reinterpret_cast<unsigned char*>(t);
  for (std::size_t i = 0; i < sizeof(Table); ++i) p[i] = 0;
}

}  // namespace

const char* table_strerror(int code) noexcept {
  switch (code) {
    case kTableOk: return "ok";
    case kTableNullArgument: return "null argument";
    case kTableTooShort: return "table shorter than header + CRC";
    case kTableBadMagic: return "bad magic (not an imuforge coefficient table)";
    case kTableUnsupportedVersion: return "unsupported format version";
    case kTableBadHeaderLength: return "bad header length";
    case kTableLengthMismatch: return "length mismatch (total_len field vs data size)";
    case kTableCrcMismatch: return "CRC-32 mismatch";
    case kTableReservedNonZero: return "reserved field not zero";
    case kTableZeroBreakpoints: return "zero breakpoints";
    case kTableTooManyBreakpoints: return "too many breakpoints (max 16)";
    case kTableBadRecordLength: return "bad record length";
    case kTableSizeMismatch: return "total length does not match breakpoint count";
    case kTableBadLsb: return "bad LSB (must be finite and > 0)";
    case kTableBadRawBits: return "bad raw bit width (must be 8..24)";
    case kTableUnknownModelFlags: return "unknown model flag bits";
    case kTableBreakpointNotFinite: return "breakpoint not finite";
    case kTableBreakpointOutOfRange: return "breakpoint outside [-100, 250] degC";
    case kTableBreakpointsNotIncreasing: return "breakpoints not strictly increasing";
    case kTableCoefficientNotFinite: return "coefficient not finite";
    case kTableCoefficientOutOfRange: return "coefficient out of range";
    case kTableFlagsMismatch: return "model flags do not match the coefficients";
    case kTableBufferTooSmall: return "output buffer too small";
    case kTableNotValid: return "table not validated";
    default: return "unknown table error";
  }
}

void table_init_identity(Table* t, float accel_lsb_mps2, float gyro_lsb_rad_s, std::uint8_t accel_raw_bits,
                         std::uint8_t gyro_raw_bits) noexcept {
  if (t == nullptr) return;
  zero_table(t);
  t->accel_lsb_mps2 = accel_lsb_mps2;
  t->gyro_lsb_rad_s = gyro_lsb_rad_s;
  t->accel_raw_bits = accel_raw_bits;
  t->gyro_raw_bits = gyro_raw_bits;
  t->n_breakpoints = 1;
  t->breakpoints_degC[0] = 25.0f;
  for (int i = 0; i < 3; ++i) {
    t->coeffs[0].accel.C[4 * i] = 1.0f;
    t->coeffs[0].gyro.C[4 * i] = 1.0f;
  }
}

int table_validate(Table* t) noexcept {
  if (t == nullptr) return kTableNullArgument;
  t->valid_marker = 0;
  const std::size_t n = t->n_breakpoints;
  if (n == 0) return kTableZeroBreakpoints;
  if (n > kTableMaxBreakpoints) return kTableTooManyBreakpoints;
  if (!lsb_ok(t->accel_lsb_mps2) || !lsb_ok(t->gyro_lsb_rad_s)) return kTableBadLsb;
  if (!bits_ok(t->accel_raw_bits) || !bits_ok(t->gyro_raw_bits)) return kTableBadRawBits;
  if ((t->model_flags & ~static_cast<std::uint32_t>(kModelAllKnown)) != 0) return kTableUnknownModelFlags;
  for (std::size_t i = 0; i < n; ++i)
    if (!is_finite(t->breakpoints_degC[i])) return kTableBreakpointNotFinite;
  for (std::size_t i = 0; i < n; ++i)
    if (t->breakpoints_degC[i] < kTableMinTempDegC || t->breakpoints_degC[i] > kTableMaxTempDegC)
      return kTableBreakpointOutOfRange;
  for (std::size_t i = 1; i < n; ++i)
    if (!(t->breakpoints_degC[i] - t->breakpoints_degC[i - 1] >= kTableMinBreakpointStepDegC))
      return kTableBreakpointsNotIncreasing;
  const float fs_a = full_scale(t->accel_lsb_mps2, t->accel_raw_bits);
  const float fs_g = full_scale(t->gyro_lsb_rad_s, t->gyro_raw_bits);
  for (std::size_t i = 0; i < n; ++i) {
    float v[kTableCoeffsPerBreakpoint];
    record_to_array(t->coeffs[i], v);
    for (float x : v)
      if (!is_finite(x)) return kTableCoefficientNotFinite;
    const BreakpointCoeffs& c = t->coeffs[i];
    for (int k = 0; k < 9; ++k)
      if (fabs_f(c.accel.C[k]) > kTableMaxAbsC || fabs_f(c.gyro.C[k]) > kTableMaxAbsC ||
          fabs_f(c.G[k]) > kTableMaxAbsG)
        return kTableCoefficientOutOfRange;
    for (int k = 0; k < 3; ++k)
      if (fabs_f(c.accel.b[k]) > fs_a || fabs_f(c.gyro.b[k]) > fs_g) return kTableCoefficientOutOfRange;
  }
  const std::uint32_t f = t->model_flags;
  if (((f & kModelTemperature) != 0) != (n > 1)) return kTableFlagsMismatch;
  for (std::size_t i = 0; i < n; ++i) {
    const BreakpointCoeffs& c = t->coeffs[i];
    if (!(f & kModelAccelMatrix) && !is_identity(c.accel.C)) return kTableFlagsMismatch;
    if (!(f & kModelAccelBias) && !is_zero(c.accel.b, 3)) return kTableFlagsMismatch;
    if (!(f & kModelGyroMatrix) && !is_identity(c.gyro.C)) return kTableFlagsMismatch;
    if (!(f & kModelGyroBias) && !is_zero(c.gyro.b, 3)) return kTableFlagsMismatch;
    if (!(f & kModelGyroGSens) && !is_zero(c.G, 9)) return kTableFlagsMismatch;
  }
  t->valid_marker = kTableValidMarker;
  return kTableOk;
}

int table_parse(const std::uint8_t* buf, std::size_t len, Table* out) noexcept {
  if (out == nullptr) return kTableNullArgument;
  zero_table(out);
  if (buf == nullptr) return kTableNullArgument;
  if (len < kTableHeaderLen + kTableCrcLen) return kTableTooShort;
  if (load_le32(buf + kOffMagic) != kTableMagic) return kTableBadMagic;
  if (load_le16(buf + kOffVersion) != kTableFormatVersion) return kTableUnsupportedVersion;
  if (load_le16(buf + kOffHeaderLen) != kTableHeaderLen) return kTableBadHeaderLength;
  const std::uint32_t total_len = load_le32(buf + kOffTotalLen);
  if (total_len != len) return kTableLengthMismatch;
  const std::uint32_t crc_stored = load_le32(buf + len - kTableCrcLen);
  if (crc32(buf, len - kTableCrcLen) != crc_stored) return kTableCrcMismatch;
  if (load_le32(buf + kOffReserved0) != 0 || buf[kOffReserved1] != 0 || load_le64(buf + kOffReserved2) != 0)
    return kTableReservedNonZero;
  const std::size_t n = buf[kOffCount];
  if (n == 0) return kTableZeroBreakpoints;
  if (n > kTableMaxBreakpoints) return kTableTooManyBreakpoints;
  if (load_le32(buf + kOffRecordLen) != kTableRecordLen) return kTableBadRecordLength;
  if (total_len != table_serialized_size(n)) return kTableSizeMismatch;

  Table t;
  zero_table(&t);
  t.model_flags = load_le32(buf + kOffFlags);
  t.device_serial = load_le64(buf + kOffSerial);
  t.table_sequence = load_le32(buf + kOffSequence);
  t.created_unix_s = load_le64s(buf + kOffCreated);
  t.accel_lsb_mps2 = load_lef32(buf + kOffAccelLsb);
  t.gyro_lsb_rad_s = load_lef32(buf + kOffGyroLsb);
  t.accel_raw_bits = buf[kOffAccelBits];
  t.gyro_raw_bits = buf[kOffGyroBits];
  t.n_breakpoints = static_cast<std::uint8_t>(n);
  const std::uint8_t* p = buf + kTableHeaderLen;
  for (std::size_t i = 0; i < n; ++i, p += 4) t.breakpoints_degC[i] = load_lef32(p);
  for (std::size_t i = 0; i < n; ++i) {
    float v[kTableCoeffsPerBreakpoint];
    for (float& x : v) {
      x = load_lef32(p);
      p += 4;
    }
    array_to_record(v, &t.coeffs[i]);
  }
  t.crc32 = crc_stored;
  const int rc = table_validate(&t);
  if (rc != kTableOk) return rc;
  *out = t;
  return kTableOk;
}

int table_serialize(Table* t, std::uint8_t* buf, std::size_t cap) noexcept {
  if (t == nullptr || buf == nullptr) return kTableNullArgument;
  const int rc = table_validate(t);
  if (rc != kTableOk) return rc;
  const std::size_t n = t->n_breakpoints;
  const std::size_t size = table_serialized_size(n);
  if (cap < size) return kTableBufferTooSmall;
  for (std::size_t i = 0; i < kTableHeaderLen; ++i) buf[i] = 0;  // reserved fields
  store_le32(buf + kOffMagic, kTableMagic);
  store_le16(buf + kOffVersion, kTableFormatVersion);
  store_le16(buf + kOffHeaderLen, static_cast<std::uint16_t>(kTableHeaderLen));
  store_le32(buf + kOffTotalLen, static_cast<std::uint32_t>(size));
  store_le32(buf + kOffFlags, t->model_flags);
  store_le64(buf + kOffSerial, t->device_serial);
  store_le32(buf + kOffSequence, t->table_sequence);
  store_le64s(buf + kOffCreated, t->created_unix_s);
  store_lef32(buf + kOffAccelLsb, t->accel_lsb_mps2);
  store_lef32(buf + kOffGyroLsb, t->gyro_lsb_rad_s);
  buf[kOffAccelBits] = t->accel_raw_bits;
  buf[kOffGyroBits] = t->gyro_raw_bits;
  buf[kOffCount] = static_cast<std::uint8_t>(n);
  store_le32(buf + kOffRecordLen, static_cast<std::uint32_t>(kTableRecordLen));
  std::uint8_t* p = buf + kTableHeaderLen;
  for (std::size_t i = 0; i < n; ++i, p += 4) store_lef32(p, t->breakpoints_degC[i]);
  for (std::size_t i = 0; i < n; ++i) {
    float v[kTableCoeffsPerBreakpoint];
    record_to_array(t->coeffs[i], v);
    for (float x : v) {
      store_lef32(p, x);
      p += 4;
    }
  }
  const std::uint32_t crc = crc32(buf, size - kTableCrcLen);
  store_le32(p, crc);
  t->crc32 = crc;
  return static_cast<int>(size);
}

}  // namespace imuforge::fw
