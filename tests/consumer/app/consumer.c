/* The C side of the consumer test (C11, -Wall -Wextra -Werror -pedantic): loads table.bin written by
 * consumer_cpp through the C API and prints the same lines; the driver requires identical output. */
#include <inttypes.h>
#include <stdio.h>
#include <string.h>

#include "firmware/capi/imuforge.h"
#include "gen.h"

static unsigned long bits(float f) {
  uint32_t u;
  memcpy(&u, &f, sizeof u);
  return u;
}

static imuforge_table table;
static imuforge_table bad;
static imuforge_kernel_f32 kf;
static imuforge_kernel_q kq;
static uint8_t blob[IMUFORGE_TABLE_MAX_SIZE];

int main(void) {
  FILE* f = fopen("table.bin", "rb");
  size_t len;
  int rc, i, k;
  uint32_t seed = 15u;
  imuforge_table_info info;
  if (f == NULL) {
    printf("cannot open table.bin\n");
    return 1;
  }
  len = fread(blob, 1, sizeof blob, f);
  fclose(f);

  blob[70] ^= 0x01u;
  rc = imuforge_table_parse(blob, len, &bad);
  printf("corrupt %d %s\n", rc, imuforge_table_strerror(rc));
  blob[70] ^= 0x01u;
  if (imuforge_kernel_f32_load(&kf, &bad) != IMUFORGE_KERNEL_ERR_TABLE_NOT_VALID) return 2;

  rc = imuforge_table_parse(blob, len, &table);
  if (imuforge_table_info_get(&table, &info) != 0) return 3;
  printf("parse %d breakpoints %u flags %" PRIu32 "\n", rc, (unsigned)info.n_breakpoints, info.model_flags);
  imuforge_kernel_f32_init(&kf, 0.25f);
  imuforge_kernel_q_init(&kq, IMUFORGE_Q_TEMP_ONE / 4);
  printf("load %d %d\n", imuforge_kernel_f32_load(&kf, &table), imuforge_kernel_q_load(&kq, &table));

  for (i = 0; i < CONSUMER_SAMPLES; ++i) {
    int16_t r16[6];
    int32_t r32[6];
    float temp;
    int32_t temp_q;
    imuforge_raw16 s16;
    imuforge_raw32 s32;
    imuforge_imu_f32 o;
    imuforge_imu_q q;
    uint32_t st;
    consumer_sample(&seed, i, r16, r32, &temp, &temp_q);
    for (k = 0; k < 3; ++k) {
      s16.accel[k] = r16[k];
      s16.gyro[k] = r16[3 + k];
      s32.accel[k] = r32[k];
      s32.gyro[k] = r32[3 + k];
    }
    st = imuforge_kernel_f32_run(&kf, &s16, temp, &o);
    printf("f %d %" PRIu32, i, st);
    for (k = 0; k < 3; ++k) printf(" %08lx", bits(o.accel_mps2[k]));
    for (k = 0; k < 3; ++k) printf(" %08lx", bits(o.gyro_rad_s[k]));
    st = imuforge_kernel_f32_run32(&kf, &s32, temp, &o);
    printf(" | %" PRIu32, st);
    for (k = 0; k < 3; ++k) printf(" %08lx", bits(o.accel_mps2[k]));
    for (k = 0; k < 3; ++k) printf(" %08lx", bits(o.gyro_rad_s[k]));
    st = imuforge_kernel_q_run(&kq, &s16, temp_q, &q);
    printf("\nq %d %" PRIu32, i, st);
    for (k = 0; k < 3; ++k) printf(" %" PRId32, q.accel[k]);
    for (k = 0; k < 3; ++k) printf(" %" PRId32, q.gyro[k]);
    st = imuforge_kernel_q_run32(&kq, &s32, temp_q, &q);
    printf(" | %" PRIu32, st);
    for (k = 0; k < 3; ++k) printf(" %" PRId32, q.accel[k]);
    for (k = 0; k < 3; ++k) printf(" %" PRId32, q.gyro[k]);
    printf("\n");
  }
  printf("end\n");
  return 0;
}
