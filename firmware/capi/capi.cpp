// The C API (firmware/capi/imuforge.h) over the C++ firmware library: no logic of its own. Instances are
// C++ objects created in the caller's opaque storage (placement new of a trivial type: no heap), so the
// C and the C++ paths run the same instructions on the same data and give bit-identical outputs.
#include "firmware/capi/imuforge.h"

#include <new>
#include <type_traits>

#include "firmware/kernel/compensation.h"
#include "firmware/table/table.h"

namespace fw = imuforge::fw;

namespace {

template <class Storage, class T>
constexpr bool fits() {
  return sizeof(Storage) >= sizeof(T) && sizeof(Storage) - sizeof(T) < 8 && alignof(Storage) >= alignof(T);
}
static_assert(fits<imuforge_table, fw::Table>(), "IMUFORGE_TABLE_WORDS does not match fw::Table");
static_assert(fits<imuforge_kernel_f32, fw::KernelF32>(), "IMUFORGE_KERNEL_F32_WORDS does not match fw::KernelF32");
static_assert(fits<imuforge_kernel_q, fw::KernelQ>(), "IMUFORGE_KERNEL_Q_WORDS does not match fw::KernelQ");
static_assert(std::is_trivially_copyable_v<fw::Table> && std::is_trivially_copyable_v<fw::KernelF32> &&
                  std::is_trivially_copyable_v<fw::KernelQ>,
              "opaque storage holds trivially copyable objects only");

// The error codes are one contract: the C macros must equal the C++ enums.
static_assert(IMUFORGE_TABLE_ERR_NULL_ARGUMENT == fw::kTableNullArgument && IMUFORGE_TABLE_ERR_TOO_SHORT == fw::kTableTooShort &&
              IMUFORGE_TABLE_ERR_BAD_MAGIC == fw::kTableBadMagic &&
              IMUFORGE_TABLE_ERR_UNSUPPORTED_VERSION == fw::kTableUnsupportedVersion &&
              IMUFORGE_TABLE_ERR_BAD_HEADER_LENGTH == fw::kTableBadHeaderLength &&
              IMUFORGE_TABLE_ERR_LENGTH_MISMATCH == fw::kTableLengthMismatch &&
              IMUFORGE_TABLE_ERR_CRC_MISMATCH == fw::kTableCrcMismatch &&
              IMUFORGE_TABLE_ERR_RESERVED_NONZERO == fw::kTableReservedNonZero &&
              IMUFORGE_TABLE_ERR_ZERO_BREAKPOINTS == fw::kTableZeroBreakpoints &&
              IMUFORGE_TABLE_ERR_TOO_MANY_BREAKPOINTS == fw::kTableTooManyBreakpoints &&
              IMUFORGE_TABLE_ERR_BAD_RECORD_LENGTH == fw::kTableBadRecordLength &&
              IMUFORGE_TABLE_ERR_SIZE_MISMATCH == fw::kTableSizeMismatch && IMUFORGE_TABLE_ERR_BAD_LSB == fw::kTableBadLsb &&
              IMUFORGE_TABLE_ERR_BAD_RAW_BITS == fw::kTableBadRawBits &&
              IMUFORGE_TABLE_ERR_UNKNOWN_MODEL_FLAGS == fw::kTableUnknownModelFlags &&
              IMUFORGE_TABLE_ERR_BREAKPOINT_NOT_FINITE == fw::kTableBreakpointNotFinite &&
              IMUFORGE_TABLE_ERR_BREAKPOINT_OUT_OF_RANGE == fw::kTableBreakpointOutOfRange &&
              IMUFORGE_TABLE_ERR_BREAKPOINTS_NOT_INCREASING == fw::kTableBreakpointsNotIncreasing &&
              IMUFORGE_TABLE_ERR_COEFFICIENT_NOT_FINITE == fw::kTableCoefficientNotFinite &&
              IMUFORGE_TABLE_ERR_COEFFICIENT_OUT_OF_RANGE == fw::kTableCoefficientOutOfRange &&
              IMUFORGE_TABLE_ERR_FLAGS_MISMATCH == fw::kTableFlagsMismatch &&
              IMUFORGE_TABLE_ERR_BUFFER_TOO_SMALL == fw::kTableBufferTooSmall &&
              IMUFORGE_TABLE_ERR_NOT_VALID == fw::kTableNotValid,
              "C table error codes differ from firmware/table/table.h");
static_assert(IMUFORGE_KERNEL_ERR_NULL_ARGUMENT == fw::kKernelNullArgument &&
                  IMUFORGE_KERNEL_ERR_TABLE_NOT_VALID == fw::kKernelTableNotValid &&
                  IMUFORGE_KERNEL_ERR_FIXED_RANGE == fw::kKernelFixedRange,
              "C kernel error codes differ from firmware/kernel/compensation.h");
static_assert(IMUFORGE_STATUS_TEMP_CLAMPED == fw::kStatusTempClamped &&
                  IMUFORGE_STATUS_ACCEL_SATURATED == fw::kStatusAccelSaturated &&
                  IMUFORGE_STATUS_GYRO_SATURATED == fw::kStatusGyroSaturated && IMUFORGE_STATUS_NO_TABLE == fw::kStatusNoTable,
              "C status bits differ");
static_assert(IMUFORGE_MODEL_ACCEL_MATRIX == fw::kModelAccelMatrix && IMUFORGE_MODEL_ACCEL_BIAS == fw::kModelAccelBias &&
                  IMUFORGE_MODEL_GYRO_MATRIX == fw::kModelGyroMatrix && IMUFORGE_MODEL_GYRO_BIAS == fw::kModelGyroBias &&
                  IMUFORGE_MODEL_GYRO_GSENS == fw::kModelGyroGSens && IMUFORGE_MODEL_TEMPERATURE == fw::kModelTemperature,
              "C model flags differ");
static_assert(IMUFORGE_TABLE_MAX_BREAKPOINTS == fw::kTableMaxBreakpoints && IMUFORGE_TABLE_MAX_SIZE == fw::kTableMaxSize &&
                  IMUFORGE_Q_ACCEL_FRAC_BITS == fw::kQAccelFracBits && IMUFORGE_Q_GYRO_FRAC_BITS == fw::kQGyroFracBits &&
                  IMUFORGE_Q_TEMP_ONE == fw::kQTempOne,
              "C constants differ");

// The C sample types mirror the C++ ones field by field; conversion is a copy the compiler folds.
fw::RawSample16 to_fw(const imuforge_raw16& r) {
  return {{r.accel[0], r.accel[1], r.accel[2]}, {r.gyro[0], r.gyro[1], r.gyro[2]}};
}
fw::RawSample32 to_fw(const imuforge_raw32& r) {
  return {{r.accel[0], r.accel[1], r.accel[2]}, {r.gyro[0], r.gyro[1], r.gyro[2]}};
}
void from_fw(const fw::ImuF32& o, imuforge_imu_f32* out) {
  for (int i = 0; i < 3; ++i) {
    out->accel_mps2[i] = o.accel_mps2[i];
    out->gyro_rad_s[i] = o.gyro_rad_s[i];
  }
}
void from_fw(const fw::ImuQ& o, imuforge_imu_q* out) {
  for (int i = 0; i < 3; ++i) {
    out->accel[i] = o.accel[i];
    out->gyro[i] = o.gyro[i];
  }
}

// Objects live in the opaque storage from the first init/parse on (placement new of a trivial type).
template <class T, class S>
T* obj(S* s) {
  return std::launder(reinterpret_cast<T*>(s->opaque_));
}
template <class T, class S>
const T* obj(const S* s) {
  return std::launder(reinterpret_cast<const T*>(s->opaque_));
}

}  // namespace

extern "C" {

int imuforge_table_parse(const uint8_t* buf, size_t len, imuforge_table* out) {
  if (out == nullptr) return fw::kTableNullArgument;
  fw::Table* t = new (out->opaque_) fw::Table;
  return fw::table_parse(buf, len, t);
}

int imuforge_table_is_valid(const imuforge_table* t) {
  return t != nullptr && fw::table_is_valid(obj<fw::Table>(t)) ? 1 : 0;
}

int imuforge_table_info_get(const imuforge_table* t, imuforge_table_info* out) {
  if (t == nullptr || out == nullptr) return fw::kTableNullArgument;
  const fw::Table* tb = obj<fw::Table>(t);
  if (!fw::table_is_valid(tb)) return fw::kTableNotValid;
  *out = imuforge_table_info{};
  out->device_serial = tb->device_serial;
  out->table_sequence = tb->table_sequence;
  out->created_unix_s = tb->created_unix_s;
  out->model_flags = tb->model_flags;
  out->accel_lsb_mps2 = tb->accel_lsb_mps2;
  out->gyro_lsb_rad_s = tb->gyro_lsb_rad_s;
  out->accel_raw_bits = tb->accel_raw_bits;
  out->gyro_raw_bits = tb->gyro_raw_bits;
  out->n_breakpoints = tb->n_breakpoints;
  for (std::size_t i = 0; i < tb->n_breakpoints; ++i) out->breakpoints_degC[i] = tb->breakpoints_degC[i];
  return 0;
}

const char* imuforge_table_strerror(int code) { return fw::table_strerror(code); }

size_t imuforge_table_serialized_size(size_t n_breakpoints) { return fw::table_serialized_size(n_breakpoints); }

void imuforge_kernel_f32_init(imuforge_kernel_f32* k, float step_degC) {
  if (k == nullptr) return;
  fw::kernel_f32_init(new (k->opaque_) fw::KernelF32, step_degC);
}

int imuforge_kernel_f32_load(imuforge_kernel_f32* k, const imuforge_table* t) {
  if (k == nullptr) return fw::kKernelNullArgument;
  return fw::kernel_f32_load(obj<fw::KernelF32>(k), t == nullptr ? nullptr : obj<fw::Table>(t));
}

uint32_t imuforge_kernel_f32_run(imuforge_kernel_f32* k, const imuforge_raw16* raw, float temp_degC,
                                 imuforge_imu_f32* out) {
  if (k == nullptr || raw == nullptr || out == nullptr) return fw::kStatusNoTable;
  const fw::RawSample16 r = to_fw(*raw);
  fw::ImuF32 o;
  const std::uint32_t st = fw::kernel_f32_run(obj<fw::KernelF32>(k), &r, temp_degC, &o);
  from_fw(o, out);
  return st;
}

uint32_t imuforge_kernel_f32_run32(imuforge_kernel_f32* k, const imuforge_raw32* raw, float temp_degC,
                                   imuforge_imu_f32* out) {
  if (k == nullptr || raw == nullptr || out == nullptr) return fw::kStatusNoTable;
  const fw::RawSample32 r = to_fw(*raw);
  fw::ImuF32 o;
  const std::uint32_t st = fw::kernel_f32_run32(obj<fw::KernelF32>(k), &r, temp_degC, &o);
  from_fw(o, out);
  return st;
}

void imuforge_kernel_q_init(imuforge_kernel_q* k, int32_t step_q16) {
  if (k == nullptr) return;
  fw::kernel_q_init(new (k->opaque_) fw::KernelQ, step_q16);
}

int imuforge_kernel_q_load(imuforge_kernel_q* k, const imuforge_table* t) {
  if (k == nullptr) return fw::kKernelNullArgument;
  return fw::kernel_q_load(obj<fw::KernelQ>(k), t == nullptr ? nullptr : obj<fw::Table>(t));
}

uint32_t imuforge_kernel_q_run(imuforge_kernel_q* k, const imuforge_raw16* raw, int32_t temp_q16_degC,
                               imuforge_imu_q* out) {
  if (k == nullptr || raw == nullptr || out == nullptr) return fw::kStatusNoTable;
  const fw::RawSample16 r = to_fw(*raw);
  fw::ImuQ o;
  const std::uint32_t st = fw::kernel_q_run(obj<fw::KernelQ>(k), &r, temp_q16_degC, &o);
  from_fw(o, out);
  return st;
}

uint32_t imuforge_kernel_q_run32(imuforge_kernel_q* k, const imuforge_raw32* raw, int32_t temp_q16_degC,
                                 imuforge_imu_q* out) {
  if (k == nullptr || raw == nullptr || out == nullptr) return fw::kStatusNoTable;
  const fw::RawSample32 r = to_fw(*raw);
  fw::ImuQ o;
  const std::uint32_t st = fw::kernel_q_run32(obj<fw::KernelQ>(k), &r, temp_q16_degC, &o);
  from_fw(o, out);
  return st;
}

int32_t imuforge_temp_q16_from_cdegC(int32_t cdegC) { return fw::temp_q16_from_cdegC(cdegC); }

const char* imuforge_kernel_strerror(int code) { return fw::kernel_strerror(code); }

}  // extern "C"
