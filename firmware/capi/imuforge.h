/* C11 API of the imuforge firmware library: coefficient table v1 and the compensation kernel.
 *
 * The same functions as firmware/table/table.h and firmware/kernel/compensation.h (read those for the
 * math, Q formats and error bounds), for C firmware (STM32Cube, Zephyr, bare metal): plain structs,
 * no namespaces, extern "C". Same guarantees as the C++ API:
 *   - no heap, no blocking, no global state: every instance is a struct owned by the caller (static
 *     storage recommended: a table is ~2.3 KB, a fixed-point kernel ~2.4 KB);
 *   - stable negative error codes, numerically identical to the C++ enums (checked at compile time in
 *     capi.cpp); 0 means success;
 *   - the same code runs behind both APIs, so outputs are bit-identical (tests/consumer checks it).
 *
 * Instances (imuforge_table, imuforge_kernel_f32, imuforge_kernel_q) are opaque storage of the right
 * size and alignment for this target: do not read or write their bytes; pass pointers to the functions.
 * A kernel BORROWS the table it loaded (f32 path): the table must stay alive and unchanged while the
 * kernel uses it. The fixed-point kernel keeps its own integer copy.
 *
 * Minimal use (docs/kernel.md has the full 20-line example):
 *     static imuforge_table table;
 *     static imuforge_kernel_f32 kernel;
 *     if (imuforge_table_parse(blob, blob_len, &table) != 0) ...       // imuforge_table_strerror(rc)
 *     imuforge_kernel_f32_init(&kernel, 0.1f);                           // re-interpolate every 0.1 °C
 *     if (imuforge_kernel_f32_load(&kernel, &table) != 0) ...
 *     uint32_t status = imuforge_kernel_f32_run(&kernel, &raw, temp_degC, &out);
 */
#ifndef IMUFORGE_FIRMWARE_CAPI_IMUFORGE_H
#define IMUFORGE_FIRMWARE_CAPI_IMUFORGE_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* ------------------------------------------------------------------------------------ error codes */
/* Coefficient table v1 (block -100..-199; same meaning as TableError in firmware/table/table.h). */
#define IMUFORGE_TABLE_OK 0
#define IMUFORGE_TABLE_ERR_NULL_ARGUMENT (-100)
#define IMUFORGE_TABLE_ERR_TOO_SHORT (-101)
#define IMUFORGE_TABLE_ERR_BAD_MAGIC (-102)
#define IMUFORGE_TABLE_ERR_UNSUPPORTED_VERSION (-103)
#define IMUFORGE_TABLE_ERR_BAD_HEADER_LENGTH (-104)
#define IMUFORGE_TABLE_ERR_LENGTH_MISMATCH (-105)
#define IMUFORGE_TABLE_ERR_CRC_MISMATCH (-106)
#define IMUFORGE_TABLE_ERR_RESERVED_NONZERO (-107)
#define IMUFORGE_TABLE_ERR_ZERO_BREAKPOINTS (-108)
#define IMUFORGE_TABLE_ERR_TOO_MANY_BREAKPOINTS (-109)
#define IMUFORGE_TABLE_ERR_BAD_RECORD_LENGTH (-110)
#define IMUFORGE_TABLE_ERR_SIZE_MISMATCH (-111)
#define IMUFORGE_TABLE_ERR_BAD_LSB (-112)
#define IMUFORGE_TABLE_ERR_BAD_RAW_BITS (-113)
#define IMUFORGE_TABLE_ERR_UNKNOWN_MODEL_FLAGS (-114)
#define IMUFORGE_TABLE_ERR_BREAKPOINT_NOT_FINITE (-115)
#define IMUFORGE_TABLE_ERR_BREAKPOINT_OUT_OF_RANGE (-116)
#define IMUFORGE_TABLE_ERR_BREAKPOINTS_NOT_INCREASING (-117)
#define IMUFORGE_TABLE_ERR_COEFFICIENT_NOT_FINITE (-118)
#define IMUFORGE_TABLE_ERR_COEFFICIENT_OUT_OF_RANGE (-119)
#define IMUFORGE_TABLE_ERR_FLAGS_MISMATCH (-120)
#define IMUFORGE_TABLE_ERR_BUFFER_TOO_SMALL (-121)
#define IMUFORGE_TABLE_ERR_NOT_VALID (-122)
/* Compensation kernel (block -200..-299; KernelError in firmware/kernel/compensation.h). */
#define IMUFORGE_KERNEL_ERR_NULL_ARGUMENT (-200)
#define IMUFORGE_KERNEL_ERR_TABLE_NOT_VALID (-201)
#define IMUFORGE_KERNEL_ERR_FIXED_RANGE (-202)

/* Status bits returned by every run call (KernelStatus). */
#define IMUFORGE_STATUS_OK 0u
#define IMUFORGE_STATUS_TEMP_CLAMPED (1u << 0)    /* temperature outside the breakpoints: clamped */
#define IMUFORGE_STATUS_ACCEL_SATURATED (1u << 1) /* an accel count at or beyond its raw limits */
#define IMUFORGE_STATUS_GYRO_SATURATED (1u << 2)  /* a gyro count at or beyond its raw limits */
#define IMUFORGE_STATUS_NO_TABLE (1u << 3)        /* no valid table loaded: outputs are zero */

/* model_flags bits of a table (ModelFlags). */
#define IMUFORGE_MODEL_ACCEL_MATRIX (1u << 0)
#define IMUFORGE_MODEL_ACCEL_BIAS (1u << 1)
#define IMUFORGE_MODEL_GYRO_MATRIX (1u << 2)
#define IMUFORGE_MODEL_GYRO_BIAS (1u << 3)
#define IMUFORGE_MODEL_GYRO_GSENS (1u << 4)
#define IMUFORGE_MODEL_TEMPERATURE (1u << 5)

#define IMUFORGE_TABLE_MAX_BREAKPOINTS 16
#define IMUFORGE_TABLE_MAX_SIZE 2244 /* serialised bytes of a 16-breakpoint table */

/* Fixed-point output LSBs: accel Q15.16 m/s² (2^-16), gyro Q13.18 rad/s (2^-18); temperature input
 * of the fixed path is Q16.16 °C (1 °C = 65536). */
#define IMUFORGE_Q_ACCEL_FRAC_BITS 16
#define IMUFORGE_Q_GYRO_FRAC_BITS 18
#define IMUFORGE_Q_TEMP_ONE 65536

/* -------------------------------------------------------------------------------- plain data types */
typedef struct imuforge_raw16 {
  int16_t accel[3]; /* counts */
  int16_t gyro[3];  /* counts */
} imuforge_raw16;

typedef struct imuforge_raw32 {
  int32_t accel[3];
  int32_t gyro[3];
} imuforge_raw32;

typedef struct imuforge_imu_f32 {
  float accel_mps2[3];
  float gyro_rad_s[3];
} imuforge_imu_f32;

typedef struct imuforge_imu_q {
  int32_t accel[3]; /* LSB 2^-16 m/s² */
  int32_t gyro[3];  /* LSB 2^-18 rad/s */
} imuforge_imu_q;

/* What a parsed table says about itself (copied out by imuforge_table_info). */
typedef struct imuforge_table_info {
  uint64_t device_serial;
  uint32_t table_sequence;
  int64_t created_unix_s;
  uint32_t model_flags;   /* IMUFORGE_MODEL_* */
  float accel_lsb_mps2;   /* m/s² per count */
  float gyro_lsb_rad_s;   /* rad/s per count */
  uint8_t accel_raw_bits; /* 8..24 */
  uint8_t gyro_raw_bits;
  uint8_t n_breakpoints;  /* 1..16 */
  float breakpoints_degC[IMUFORGE_TABLE_MAX_BREAKPOINTS]; /* first n_breakpoints are used */
} imuforge_table_info;

/* Opaque instance storage. Sizes are per target (pointer width); capi.cpp checks them at compile time. */
#if UINTPTR_MAX > 0xFFFFFFFFu
#define IMUFORGE_KERNEL_F32_WORDS 25 /* 200 bytes with 64-bit pointers */
#else
#define IMUFORGE_KERNEL_F32_WORDS 24 /* 188 bytes on Cortex-M */
#endif
#define IMUFORGE_TABLE_WORDS 279
#define IMUFORGE_KERNEL_Q_WORDS 300

typedef struct imuforge_table {
  uint64_t opaque_[IMUFORGE_TABLE_WORDS];
} imuforge_table;
typedef struct imuforge_kernel_f32 {
  uint64_t opaque_[IMUFORGE_KERNEL_F32_WORDS];
} imuforge_kernel_f32;
typedef struct imuforge_kernel_q {
  uint64_t opaque_[IMUFORGE_KERNEL_Q_WORDS];
} imuforge_kernel_q;

/* ------------------------------------------------------------------------------------------ table */
/* Parses a serialised v1 table of exactly len bytes into *out. Returns 0 or an IMUFORGE_TABLE_ERR_*;
 * on failure *out is marked invalid (a kernel refuses it). O(len). */
int imuforge_table_parse(const uint8_t* buf, size_t len, imuforge_table* out);
/* 1 if *t holds a table that parsed successfully, 0 otherwise (also for NULL). O(1). */
int imuforge_table_is_valid(const imuforge_table* t);
/* Copies the header fields and breakpoints of a valid table. Returns 0, IMUFORGE_TABLE_ERR_NULL_ARGUMENT
 * or IMUFORGE_TABLE_ERR_NOT_VALID. O(1). */
int imuforge_table_info_get(const imuforge_table* t, imuforge_table_info* out);
/* Static human-readable name of a table error code ("CRC mismatch"...). */
const char* imuforge_table_strerror(int code);
/* Serialised size of a table with n breakpoints (64 + n·136 + 4 bytes). */
size_t imuforge_table_serialized_size(size_t n_breakpoints);

/* -------------------------------------------------------------------------------------- f32 kernel */
/* No table; outputs zero with IMUFORGE_STATUS_NO_TABLE until a load succeeds. step_degC < 0 → 0. O(1). */
void imuforge_kernel_f32_init(imuforge_kernel_f32* k, float step_degC);
/* Borrows *t. Returns 0, IMUFORGE_KERNEL_ERR_NULL_ARGUMENT or IMUFORGE_KERNEL_ERR_TABLE_NOT_VALID. O(1). */
int imuforge_kernel_f32_load(imuforge_kernel_f32* k, const imuforge_table* t);
/* One 6-axis sample; returns IMUFORGE_STATUS_* bits. O(1); O(n_breakpoints) when it re-interpolates. */
uint32_t imuforge_kernel_f32_run(imuforge_kernel_f32* k, const imuforge_raw16* raw, float temp_degC,
                                 imuforge_imu_f32* out);
uint32_t imuforge_kernel_f32_run32(imuforge_kernel_f32* k, const imuforge_raw32* raw, float temp_degC,
                                   imuforge_imu_f32* out);

/* ------------------------------------------------------------------------------------ fixed kernel */
/* Integer-only per sample (the path for FPU-less parts). step_q16 < 0 → 0. O(1). */
void imuforge_kernel_q_init(imuforge_kernel_q* k, int32_t step_q16);
/* Converts *t to integer form (the table may go away afterwards). Returns 0,
 * IMUFORGE_KERNEL_ERR_NULL_ARGUMENT, _TABLE_NOT_VALID or _FIXED_RANGE. O(n_breakpoints). */
int imuforge_kernel_q_load(imuforge_kernel_q* k, const imuforge_table* t);
uint32_t imuforge_kernel_q_run(imuforge_kernel_q* k, const imuforge_raw16* raw, int32_t temp_q16_degC,
                               imuforge_imu_q* out);
uint32_t imuforge_kernel_q_run32(imuforge_kernel_q* k, const imuforge_raw32* raw, int32_t temp_q16_degC,
                                 imuforge_imu_q* out);
/* °C in 0.01 steps → Q16.16 °C, rounded to nearest. */
int32_t imuforge_temp_q16_from_cdegC(int32_t cdegC);

/* Static name of a kernel or table error code. */
const char* imuforge_kernel_strerror(int code);

#ifdef __cplusplus
}
#endif

#endif /* IMUFORGE_FIRMWARE_CAPI_IMUFORGE_H */
