/* Deterministic sample stream shared by the C and the C++ consumer (both must feed the kernels the
 * same inputs). Plain C, header-only. */
#ifndef IMUFORGE_CONSUMER_GEN_H
#define IMUFORGE_CONSUMER_GEN_H
#include <math.h>
#include <stdint.h>

#define CONSUMER_SAMPLES 3000

static uint32_t consumer_lcg(uint32_t* s) {
  *s = *s * 1664525u + 1013904223u;
  return *s >> 8;
}

/* Sample i: counts over the full int16 range with 2 % at or beyond the limits (saturation), int32
 * counts up to ±2^17 for the 32-bit entry, temperature sweeping −55..105 °C (both ends clamp) with a
 * NaN every 500 samples. */
static void consumer_sample(uint32_t* s, int i, int16_t raw16[6], int32_t raw32[6], float* temp_degC,
                            int32_t* temp_q16) {
  int k;
  for (k = 0; k < 6; ++k) {
    uint32_t r = consumer_lcg(s);
    int32_t v = (int32_t)(r % 60000u) - 30000;
    if (r % 50u == 0u) v = (r & 1u) ? 32767 : -32768;
    raw16[k] = (int16_t)v;
    raw32[k] = v * 4 + (int32_t)(consumer_lcg(s) % 7u) - 3;
  }
  *temp_degC = -55.0f + 160.0f * (float)(i % 1000) / 1000.0f;
  if (i % 500 == 499) *temp_degC = NAN;
  *temp_q16 = (int32_t)(-55 * 65536 + (int32_t)((i % 1000) * 10486));
}
#endif
