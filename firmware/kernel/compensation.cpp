#include "firmware/kernel/compensation.h"

#include <climits>
#include <cstddef>

namespace imuforge::fw {

namespace {

// ------------------------------------------------------------------------------------------ shared
void set_limits(std::uint8_t bits, std::int32_t lim[2], std::int32_t lim16[2]) noexcept {
  const std::int32_t half = static_cast<std::int32_t>(1) << (bits - 1u);
  lim[0] = -half;
  lim[1] = half - 1;
  lim16[0] = bits >= 16 ? -32768 : lim[0];
  lim16[1] = bits >= 16 ? 32767 : lim[1];
}

// Clamps a count to [lim[0], lim[1]]; a count at or beyond a limit raises `bit` in *sat.
inline std::int32_t clamp_count(std::int32_t v, const std::int32_t lim[2], std::uint32_t* sat,
                                std::uint32_t bit) noexcept {
  if (v <= lim[0]) {
    *sat |= bit;
    return lim[0];
  }
  if (v >= lim[1]) {
    *sat |= bit;
    return lim[1];
  }
  return v;
}


// ------------------------------------------------------------------------------------------- f32
void interp_f32(KernelF32* k, float T) noexcept {
  const Table* t = k->table;
  const std::size_t n = t->n_breakpoints;
  const float* bp = t->breakpoints_degC;
  std::uint32_t st = 0;
  float Tc = T;
  if (!(T >= bp[0])) {  // also catches NaN: treated as below range
    Tc = bp[0];
    st = kStatusTempClamped;
  } else if (T > bp[n - 1]) {
    Tc = bp[n - 1];
    st = kStatusTempClamped;
  }
  if (n == 1) st = 0;  // a one-breakpoint table is temperature-independent: nothing to clamp
  std::size_t i = 0;
  while (i + 2 < n && Tc >= bp[i + 1]) ++i;
  float w = 0.0f;
  std::size_t j = i;
  if (n > 1) {
    j = i + 1;
    w = (Tc - bp[i]) / (bp[j] - bp[i]);
  }
  const BreakpointCoeffs& c0 = t->coeffs[i];
  const BreakpointCoeffs& c1 = t->coeffs[j];
  auto lerp = [w](float a, float b) { return a + w * (b - a); };
  float Ca[9], Cg[9], G[9], ba[3], bg[3];
  for (int m = 0; m < 9; ++m) {
    Ca[m] = lerp(c0.accel.C[m], c1.accel.C[m]);
    Cg[m] = lerp(c0.gyro.C[m], c1.gyro.C[m]);
    G[m] = lerp(c0.G[m], c1.G[m]);
  }
  for (int m = 0; m < 3; ++m) {
    ba[m] = lerp(c0.accel.b[m], c1.accel.b[m]);
    bg[m] = lerp(c0.gyro.b[m], c1.gyro.b[m]);
  }
  const float lsb_a = t->accel_lsb_mps2;
  const float lsb_g = t->gyro_lsb_rad_s;
  for (int r = 0; r < 3; ++r) {
    float oa = 0.0f, og = 0.0f;
    for (int c = 0; c < 3; ++c) {
      k->A_a[3 * r + c] = Ca[3 * r + c] * lsb_a;
      k->A_g[3 * r + c] = Cg[3 * r + c] * lsb_g;
      oa -= Ca[3 * r + c] * ba[c];
      og -= Cg[3 * r + c] * bg[c];
    }
    k->o_a[r] = oa;
    k->o_g[r] = og;
  }
  for (int r = 0; r < 3; ++r) {
    float og = k->o_g[r];
    for (int c = 0; c < 3; ++c) {
      float s = 0.0f;
      for (int m = 0; m < 3; ++m) s += G[3 * r + m] * k->A_a[3 * m + c];
      k->A_ga[3 * r + c] = s;
      og += G[3 * r + c] * k->o_a[c];
    }
    k->o_g[r] = og;
  }
  // The window is empty for a NaN input, so a NaN temperature re-interpolates on every call.
  k->T_lo_degC = T - k->step_degC;
  k->T_hi_degC = T + k->step_degC;
  k->cached_status = st;
}

// Per-sample affine correction. The cached coefficients are contiguous in KernelF32 (A_a, o_a, A_g, A_ga,
// o_g), which lets the Cortex-M4F version load them with two VLDM instructions; the arithmetic (FMA chain
// o + A·x in column order) is the same in both versions.
#if defined(__ARM_FP) && ((__ARM_FP & 4) != 0) && defined(__thumb2__) && !defined(IMUFORGE_KERNEL_NO_ASM)
#define IMUFORGE_KERNEL_F32_ASM 1
#endif

__attribute__((always_inline)) inline void affine_f32(const KernelF32* k, std::int32_t a0, std::int32_t a1,
                                                      std::int32_t a2, std::int32_t g0, std::int32_t g1,
                                                      std::int32_t g2, ImuF32* out) noexcept {
#ifdef IMUFORGE_KERNEL_F32_ASM
  const float* c = k->A_a;
  float* o = out->accel_mps2;
  __asm volatile(
      "vmov s21, s22, %[a0], %[a1]\n\t"
      "vmov s23, s24, %[a2], %[g0]\n\t"
      "vmov s25, s26, %[g1], %[g2]\n\t"
      "vcvt.f32.s32 s21, s21\n\t"
      "vcvt.f32.s32 s22, s22\n\t"
      "vcvt.f32.s32 s23, s23\n\t"
      "vcvt.f32.s32 s24, s24\n\t"
      "vcvt.f32.s32 s25, s25\n\t"
      "vcvt.f32.s32 s26, s26\n\t"
      "vldmia %[c]!, {s0-s11}\n\t"  // A_a s0..s8, o_a s9..s11
      "vfma.f32 s9, s0, s21\n\t"
      "vfma.f32 s10, s3, s21\n\t"
      "vfma.f32 s11, s6, s21\n\t"
      "vfma.f32 s9, s1, s22\n\t"
      "vfma.f32 s10, s4, s22\n\t"
      "vfma.f32 s11, s7, s22\n\t"
      "vfma.f32 s9, s2, s23\n\t"
      "vfma.f32 s10, s5, s23\n\t"
      "vfma.f32 s11, s8, s23\n\t"
      "vstmia %[o]!, {s9-s11}\n\t"
      "vldmia %[c], {s0-s20}\n\t"  // A_g s0..s8, A_ga s9..s17, o_g s18..s20
      "vfma.f32 s18, s0, s24\n\t"
      "vfma.f32 s19, s3, s24\n\t"
      "vfma.f32 s20, s6, s24\n\t"
      "vfma.f32 s18, s1, s25\n\t"
      "vfma.f32 s19, s4, s25\n\t"
      "vfma.f32 s20, s7, s25\n\t"
      "vfma.f32 s18, s2, s26\n\t"
      "vfma.f32 s19, s5, s26\n\t"
      "vfma.f32 s20, s8, s26\n\t"
      "vfma.f32 s18, s9, s21\n\t"
      "vfma.f32 s19, s12, s21\n\t"
      "vfma.f32 s20, s15, s21\n\t"
      "vfma.f32 s18, s10, s22\n\t"
      "vfma.f32 s19, s13, s22\n\t"
      "vfma.f32 s20, s16, s22\n\t"
      "vfma.f32 s18, s11, s23\n\t"
      "vfma.f32 s19, s14, s23\n\t"
      "vfma.f32 s20, s17, s23\n\t"
      "vstmia %[o], {s18-s20}\n\t"
      : [c] "+r"(c), [o] "+r"(o)
      : [a0] "r"(a0), [a1] "r"(a1), [a2] "r"(a2), [g0] "r"(g0), [g1] "r"(g1), [g2] "r"(g2)
      : "s0", "s1", "s2", "s3", "s4", "s5", "s6", "s7", "s8", "s9", "s10", "s11", "s12", "s13", "s14", "s15",
        "s16", "s17", "s18", "s19", "s20", "s21", "s22", "s23", "s24", "s25", "s26", "memory");
#else
  const float xa0 = static_cast<float>(a0), xa1 = static_cast<float>(a1), xa2 = static_cast<float>(a2);
  const float xg0 = static_cast<float>(g0), xg1 = static_cast<float>(g1), xg2 = static_cast<float>(g2);
  const float* A = k->A_a;
  const float* Ag = k->A_g;
  const float* Aga = k->A_ga;
  for (int r = 0; r < 3; ++r) {
    out->accel_mps2[r] = k->o_a[r] + A[3 * r] * xa0 + A[3 * r + 1] * xa1 + A[3 * r + 2] * xa2;
    out->gyro_rad_s[r] = k->o_g[r] + Ag[3 * r] * xg0 + Ag[3 * r + 1] * xg1 + Ag[3 * r + 2] * xg2 +
                         Aga[3 * r] * xa0 + Aga[3 * r + 1] * xa1 + Aga[3 * r + 2] * xa2;
  }
#endif
}

// Saturation flags for int16 counts when no clamping is needed (raw_bits ≥ 16): r ^ (r >> 15) maps
// both limits −32768 and 32767 to 32767, so bit 15 of (that + 1) is set exactly at a limit. OR-ing the
// six terms costs 3 instructions per axis instead of two compare-and-branch pairs.
__attribute__((always_inline)) inline std::uint32_t sat_flags16(std::int32_t a0, std::int32_t a1, std::int32_t a2,
                                                                 std::int32_t g0, std::int32_t g1,
                                                                 std::int32_t g2) noexcept {
  auto t = [](std::int32_t v) { return static_cast<std::uint32_t>((v ^ (v >> 15)) + 1); };
  const std::uint32_t sa = t(a0) | t(a1) | t(a2);
  const std::uint32_t sg = t(g0) | t(g1) | t(g2);
  return ((sa >> 14) & kStatusAccelSaturated) | ((sg >> 13) & kStatusGyroSaturated);
}

// One sample's counts, clamped to the table's raw width, and their saturation flags: the common prologue
// of both kernels' run functions (K is KernelF32 or KernelQ; both carry the same limits).
struct Counts {
  std::int32_t a0, a1, a2, g0, g1, g2;
};

template <class K>
__attribute__((always_inline)) inline std::uint32_t load_counts(const K* k, const RawSample16* raw, Counts& c) noexcept {
  c = {raw->accel[0], raw->accel[1], raw->accel[2], raw->gyro[0], raw->gyro[1], raw->gyro[2]};
  if (!k->narrow16) return sat_flags16(c.a0, c.a1, c.a2, c.g0, c.g1, c.g2);
  std::uint32_t sat = 0;
  c.a0 = clamp_count(c.a0, k->lim16_a, &sat, kStatusAccelSaturated);
  c.a1 = clamp_count(c.a1, k->lim16_a, &sat, kStatusAccelSaturated);
  c.a2 = clamp_count(c.a2, k->lim16_a, &sat, kStatusAccelSaturated);
  c.g0 = clamp_count(c.g0, k->lim16_g, &sat, kStatusGyroSaturated);
  c.g1 = clamp_count(c.g1, k->lim16_g, &sat, kStatusGyroSaturated);
  c.g2 = clamp_count(c.g2, k->lim16_g, &sat, kStatusGyroSaturated);
  return sat;
}

template <class K>
__attribute__((always_inline)) inline std::uint32_t load_counts(const K* k, const RawSample32* raw, Counts& c) noexcept {
  std::uint32_t sat = 0;
  c.a0 = clamp_count(raw->accel[0], k->lim_a, &sat, kStatusAccelSaturated);
  c.a1 = clamp_count(raw->accel[1], k->lim_a, &sat, kStatusAccelSaturated);
  c.a2 = clamp_count(raw->accel[2], k->lim_a, &sat, kStatusAccelSaturated);
  c.g0 = clamp_count(raw->gyro[0], k->lim_g, &sat, kStatusGyroSaturated);
  c.g1 = clamp_count(raw->gyro[1], k->lim_g, &sat, kStatusGyroSaturated);
  c.g2 = clamp_count(raw->gyro[2], k->lim_g, &sat, kStatusGyroSaturated);
  return sat;
}

void zero_f32(ImuF32* out) noexcept {
  for (int i = 0; i < 3; ++i) out->accel_mps2[i] = out->gyro_rad_s[i] = 0.0f;
}

// ----------------------------------------------------------------------------------------- fixed
constexpr std::int64_t kKLimit = (static_cast<std::int64_t>(1) << 29) - 2;  // |K| bound, 2 guard bits + lerp
constexpr std::int64_t kGLimit = (static_cast<std::int64_t>(1) << 30) - 2;

double pow2(int e) noexcept {
  double v = 1.0;
  for (; e > 0; --e) v *= 2.0;
  for (; e < 0; ++e) v *= 0.5;
  return v;
}
std::int64_t round_to_i64(double v) noexcept {
  return static_cast<std::int64_t>(v >= 0.0 ? v + 0.5 : v - 0.5);
}
double absd(double v) noexcept { return v < 0.0 ? -v : v; }
inline double D(float v) noexcept { return static_cast<double>(v); }

// Largest f in [−64, 62] with vmax · 2^f ≤ limit (62 when vmax is 0).
int frac_bits_for(double vmax, std::int64_t limit) noexcept {
  if (!(vmax > 0.0)) return 62;
  const double lim = static_cast<double>(limit);
  int f = 62;
  while (f > -64 && vmax * pow2(f) > lim) --f;
  return f;
}

// Round-half-up shift right by s (s ≤ 0: shift left, saturating). Every caller passes |v| < 2^62, so a
// right shift by 63 or more rounds to 0. Arithmetic >> on signed values is what GCC and Clang do; the
// project only builds with those.
std::int64_t shift_round(std::int64_t v, int s) noexcept {
  if (s >= 63) return 0;
  if (s > 0) return (v + (static_cast<std::int64_t>(1) << (s - 1))) >> s;
  if (s == 0) return v;
  const int l = -s;
  const std::int64_t lim = l >= 63 ? 0 : (INT64_MAX >> l);
  if (v > lim) return INT64_MAX;
  if (v < -lim) return -INT64_MAX;
  return v * (static_cast<std::int64_t>(1) << l);
}
std::int32_t sat_i32(std::int64_t v, std::int64_t lim) noexcept {
  return static_cast<std::int32_t>(v > lim ? lim : (v < -lim ? -lim : v));
}

// a + w·(b − a) with w in Q30 (0..2^30), rounded half up. |result error| ≤ ½ on top of a's and b's.
inline std::int32_t lerp_q30(std::int32_t a, std::int32_t b, std::int32_t w) noexcept {
  const std::int64_t d = static_cast<std::int64_t>(b) - a;
  return static_cast<std::int32_t>(a + ((d * w + (static_cast<std::int64_t>(1) << 29)) >> 30));
}

void interp_q(KernelQ* k, std::int32_t T) noexcept {
  const std::size_t n = k->n_bp;
  const std::int32_t* bp = k->bp_q16;
  std::uint32_t st = 0;
  std::int32_t Tc = T;
  if (T < bp[0]) {
    Tc = bp[0];
    st = kStatusTempClamped;
  } else if (T > bp[n - 1]) {
    Tc = bp[n - 1];
    st = kStatusTempClamped;
  }
  if (n == 1) st = 0;  // a one-breakpoint table is temperature-independent: nothing to clamp
  std::size_t i = 0;
  while (i + 2 < n && Tc >= bp[i + 1]) ++i;
  std::int32_t w = 0;
  std::size_t j = i;
  if (n > 1) {
    j = i + 1;
    // 64-bit division, only on re-interpolation. 0 ≤ w ≤ 2^30 because bp[i] ≤ Tc ≤ bp[j].
    w = static_cast<std::int32_t>((static_cast<std::int64_t>(Tc - bp[i]) << 30) / (bp[j] - bp[i]));
  }
  const KernelQBreakpoint& c0 = k->bp[i];
  const KernelQBreakpoint& c1 = k->bp[j];
  std::int32_t G[9], ba[3], bg[3];
  for (int m = 0; m < 9; ++m) {
    k->Ka[m] = lerp_q30(c0.Ka[m], c1.Ka[m], w);
    k->Kg[m] = lerp_q30(c0.Kg[m], c1.Kg[m], w);
    G[m] = lerp_q30(c0.G[m], c1.G[m], w);
  }
  for (int m = 0; m < 3; ++m) {
    ba[m] = lerp_q30(c0.beta_a[m], c1.beta_a[m], w);
    bg[m] = lerp_q30(c0.beta_g[m], c1.beta_g[m], w);
  }
  // Kga = G·Ka: frac fG + fa → fga.
  const int sh = static_cast<int>(k->fG) + static_cast<int>(k->fa) - static_cast<int>(k->fga);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) {
      std::int64_t s = 0;
      if (k->has_G)
        for (int m = 0; m < 3; ++m) s += static_cast<std::int64_t>(G[3 * r + m]) * k->Ka[3 * m + c];
      k->Kga[3 * r + c] = sat_i32(shift_round(s, sh), kKLimit);
    }
  // Offsets in accumulator units (frac S); the + 2^(S−1) makes the final >> S round half up.
  const int Sa = k->os_a + 32, Sg = k->os_g + 32;
  for (int r = 0; r < 3; ++r) {
    std::int64_t oa = static_cast<std::int64_t>(1) << (Sa - 1);
    std::int64_t og = static_cast<std::int64_t>(1) << (Sg - 1);
    for (int c = 0; c < 3; ++c) {
      oa -= static_cast<std::int64_t>(k->Ka[3 * r + c]) * ba[c];
      og -= static_cast<std::int64_t>(k->Kg[3 * r + c]) * bg[c];
      og -= static_cast<std::int64_t>(k->Kga[3 * r + c]) * ba[c];
    }
    k->oa[r] = oa;
    k->og[r] = og;
  }
  // Saturating window [T − step, T + step] (step ≤ 2^30).
  const std::int64_t lo = static_cast<std::int64_t>(T) - k->step_q16, hi = static_cast<std::int64_t>(T) + k->step_q16;
  k->T_lo_q16 = lo < INT32_MIN ? INT32_MIN : static_cast<std::int32_t>(lo);
  k->T_hi_q16 = hi > INT32_MAX ? INT32_MAX : static_cast<std::int32_t>(hi);
  k->cached_status = st;
}

inline std::int32_t shl_count(std::int32_t v, unsigned s) noexcept {
  return static_cast<std::int32_t>(static_cast<std::uint32_t>(v) << s);
}

__attribute__((always_inline)) inline std::uint32_t run_q_core(KernelQ* k, std::int32_t a0, std::int32_t a1,
                                                                std::int32_t a2, std::int32_t g0, std::int32_t g1,
                                                                std::int32_t g2, std::int32_t T, ImuQ* out) noexcept {
  if (T < k->T_lo_q16 || T > k->T_hi_q16) interp_q(k, T);
  const unsigned sa = k->xs_a, sg = k->xs_g;
  const std::int32_t xa0 = shl_count(a0, sa), xa1 = shl_count(a1, sa), xa2 = shl_count(a2, sa);
  const std::int32_t xg0 = shl_count(g0, sg), xg1 = shl_count(g1, sg), xg2 = shl_count(g2, sg);
  const std::int32_t* Ka = k->Ka;
  const std::int32_t* Kg = k->Kg;
  const std::int32_t* Kga = k->Kga;
  const unsigned osa = k->os_a, osg = k->os_g;
  for (int r = 0; r < 3; ++r) {
    const std::int64_t acc = k->oa[r] + static_cast<std::int64_t>(Ka[3 * r]) * xa0 +
                             static_cast<std::int64_t>(Ka[3 * r + 1]) * xa1 +
                             static_cast<std::int64_t>(Ka[3 * r + 2]) * xa2;
    out->accel[r] = static_cast<std::int32_t>(acc >> 32) >> osa;
  }
  for (int r = 0; r < 3; ++r) {
    const std::int64_t acc = k->og[r] + static_cast<std::int64_t>(Kg[3 * r]) * xg0 +
                             static_cast<std::int64_t>(Kg[3 * r + 1]) * xg1 +
                             static_cast<std::int64_t>(Kg[3 * r + 2]) * xg2 +
                             static_cast<std::int64_t>(Kga[3 * r]) * xa0 +
                             static_cast<std::int64_t>(Kga[3 * r + 1]) * xa1 +
                             static_cast<std::int64_t>(Kga[3 * r + 2]) * xa2;
    out->gyro[r] = static_cast<std::int32_t>(acc >> 32) >> osg;
  }
  return k->cached_status;
}

void zero_q(ImuQ* out) noexcept {
  for (int i = 0; i < 3; ++i) out->accel[i] = out->gyro[i] = 0;
}

}  // namespace

const char* kernel_strerror(int code) noexcept {
  switch (code) {
    case 0: return "ok";
    case kKernelNullArgument: return "null argument";
    case kKernelTableNotValid: return "table not valid";
    case kKernelFixedRange: return "table ranges do not fit the fixed-point formats";
    default: return table_strerror(code);
  }
}

// -------------------------------------------------------------------------------------- f32 API
void kernel_f32_init(KernelF32* k, float step_degC) noexcept {
  if (k == nullptr) return;
  *k = KernelF32{};
  k->step_degC = step_degC > 0.0f ? step_degC : 0.0f;
  k->T_lo_degC = 1.0f;  // empty window
  k->T_hi_degC = 0.0f;
}

int kernel_f32_load(KernelF32* k, const Table* t) noexcept {
  if (k == nullptr || t == nullptr) return kKernelNullArgument;
  k->table = nullptr;
  k->T_lo_degC = 1.0f;  // empty window: the first sample interpolates
  k->T_hi_degC = 0.0f;
  if (!table_is_valid(t)) return kKernelTableNotValid;
  set_limits(t->accel_raw_bits, k->lim_a, k->lim16_a);
  set_limits(t->gyro_raw_bits, k->lim_g, k->lim16_g);
  k->narrow16 = t->accel_raw_bits < 16 || t->gyro_raw_bits < 16;
  k->table = t;
  return 0;
}

namespace {
// The per-sample path of both raw widths (inlined: the 16-bit one is what bench-kernel counts).
template <class Raw>
__attribute__((always_inline)) inline std::uint32_t run_f32(KernelF32* k, const Raw* raw, float temp_degC,
                                                            ImuF32* out) noexcept {
  if (k->table == nullptr) {
    zero_f32(out);
    return kStatusNoTable;
  }
  Counts c;
  const std::uint32_t sat = load_counts(k, raw, c);
  if (!(temp_degC >= k->T_lo_degC && temp_degC <= k->T_hi_degC)) interp_f32(k, temp_degC);
  affine_f32(k, c.a0, c.a1, c.a2, c.g0, c.g1, c.g2, out);
  return sat | k->cached_status;
}
}  // namespace

std::uint32_t kernel_f32_run(KernelF32* k, const RawSample16* raw, float temp_degC, ImuF32* out) noexcept {
  return run_f32(k, raw, temp_degC, out);
}

std::uint32_t kernel_f32_run32(KernelF32* k, const RawSample32* raw, float temp_degC, ImuF32* out) noexcept {
  return run_f32(k, raw, temp_degC, out);
}

// ------------------------------------------------------------------------------------ fixed API
void kernel_q_init(KernelQ* k, std::int32_t step_q16) noexcept {
  if (k == nullptr) return;
  *k = KernelQ{};
  k->step_q16 = step_q16 > 0 ? (step_q16 > (1 << 30) ? (1 << 30) : step_q16) : 0;
  k->T_lo_q16 = 1;  // empty window
  k->T_hi_q16 = 0;
}

int kernel_q_load(KernelQ* k, const Table* t) noexcept {
  if (k == nullptr || t == nullptr) return kKernelNullArgument;
  k->has_table = false;
  k->T_lo_q16 = 1;  // empty window: the first sample interpolates
  k->T_hi_q16 = 0;
  if (!table_is_valid(t)) return kKernelTableNotValid;
  const std::size_t n = t->n_breakpoints;
  const double scale_a = static_cast<double>(t->accel_lsb_mps2) * 65536.0;   // accel out-LSB per count
  const double scale_g = static_cast<double>(t->gyro_lsb_rad_s) * 262144.0;  // gyro out-LSB per count
  const double scale_G = 262144.0 / 65536.0;  // gyro out-LSB per accel out-LSB, per (rad/s)/(m/s²)
  double ka_max = 0.0, kg_max = 0.0, g_max = 0.0;
  for (std::size_t i = 0; i < n; ++i)
    for (int m = 0; m < 9; ++m) {
      const BreakpointCoeffs& c = t->coeffs[i];
      if (absd(D(c.accel.C[m]) * scale_a) > ka_max) ka_max = absd(D(c.accel.C[m]) * scale_a);
      if (absd(D(c.gyro.C[m]) * scale_g) > kg_max) kg_max = absd(D(c.gyro.C[m]) * scale_g);
      if (absd(D(c.G[m]) * scale_G) > g_max) g_max = absd(D(c.G[m]) * scale_G);
    }
  const int xs_a = 31 - t->accel_raw_bits;  // r − 1 with r = 32 − bits: |x| ≤ 2^30
  const int xs_g = 31 - t->gyro_raw_bits;
  int fa = frac_bits_for(ka_max, kKLimit);
  if (fa + xs_a > 62) fa = 62 - xs_a;
  // G·Ka lands on the accel counts inside the gyro accumulator: bound it like a gyro coefficient.
  const double kga_max = 3.0 * g_max * ka_max * pow2(xs_g - xs_a);
  int fg = frac_bits_for(kg_max > kga_max ? kg_max : kga_max, kKLimit);
  if (fg + xs_g > 62) fg = 62 - xs_g;
  const int Sa = fa + xs_a, Sg = fg + xs_g;
  if (Sa < 32 || Sg < 32) return kKernelFixedRange;
  int fG = frac_bits_for(g_max, kGLimit);
  if (fG > 62) fG = 62;
  k->fa = static_cast<std::uint8_t>(fa);
  k->fg = static_cast<std::uint8_t>(fg);
  k->fG = static_cast<std::uint8_t>(fG < 0 ? 0 : fG);
  k->fga = static_cast<std::uint8_t>(Sg - xs_a);
  k->xs_a = static_cast<std::uint8_t>(xs_a);
  k->xs_g = static_cast<std::uint8_t>(xs_g);
  k->os_a = static_cast<std::uint8_t>(Sa - 32);
  k->os_g = static_cast<std::uint8_t>(Sg - 32);
  k->has_G = g_max > 0.0;
  if (fG < 0) return kKernelFixedRange;  // unreachable with |G| ≤ 1 (table limit); kept as a guard
  const double ka_s = scale_a * pow2(fa), kg_s = scale_g * pow2(fg), g_s = scale_G * pow2(fG);
  const double ba_s = pow2(xs_a) / static_cast<double>(t->accel_lsb_mps2);
  const double bg_s = pow2(xs_g) / static_cast<double>(t->gyro_lsb_rad_s);
  for (std::size_t i = 0; i < n; ++i) {
    const BreakpointCoeffs& c = t->coeffs[i];
    KernelQBreakpoint& q = k->bp[i];
    for (int m = 0; m < 9; ++m) {
      q.Ka[m] = sat_i32(round_to_i64(D(c.accel.C[m]) * ka_s), kKLimit);
      q.Kg[m] = sat_i32(round_to_i64(D(c.gyro.C[m]) * kg_s), kKLimit);
      q.G[m] = sat_i32(round_to_i64(D(c.G[m]) * g_s), kGLimit);
    }
    // |b| ≤ full scale (table rule) → |beta| ≤ 2^30.
    for (int m = 0; m < 3; ++m) {
      q.beta_a[m] = sat_i32(round_to_i64(D(c.accel.b[m]) * ba_s), static_cast<std::int64_t>(1) << 30);
      q.beta_g[m] = sat_i32(round_to_i64(D(c.gyro.b[m]) * bg_s), static_cast<std::int64_t>(1) << 30);
    }
    k->bp_q16[i] = static_cast<std::int32_t>(round_to_i64(static_cast<double>(t->breakpoints_degC[i]) * 65536.0));
  }
  k->n_bp = static_cast<std::uint8_t>(n);
  set_limits(t->accel_raw_bits, k->lim_a, k->lim16_a);
  set_limits(t->gyro_raw_bits, k->lim_g, k->lim16_g);
  k->narrow16 = t->accel_raw_bits < 16 || t->gyro_raw_bits < 16;
  k->has_table = true;
  return 0;
}

namespace {
template <class Raw>
__attribute__((always_inline)) inline std::uint32_t run_q(KernelQ* k, const Raw* raw, std::int32_t temp_q16_degC,
                                                          ImuQ* out) noexcept {
  if (!k->has_table) {
    zero_q(out);
    return kStatusNoTable;
  }
  Counts c;
  const std::uint32_t sat = load_counts(k, raw, c);
  return sat | run_q_core(k, c.a0, c.a1, c.a2, c.g0, c.g1, c.g2, temp_q16_degC, out);
}
}  // namespace

std::uint32_t kernel_q_run(KernelQ* k, const RawSample16* raw, std::int32_t temp_q16_degC, ImuQ* out) noexcept {
  return run_q(k, raw, temp_q16_degC, out);
}

std::uint32_t kernel_q_run32(KernelQ* k, const RawSample32* raw, std::int32_t temp_q16_degC, ImuQ* out) noexcept {
  return run_q(k, raw, temp_q16_degC, out);
}

}  // namespace imuforge::fw

// The M4F path loads the cached coefficients with VLDM in this order.
static_assert(offsetof(imuforge::fw::KernelF32, o_a) == offsetof(imuforge::fw::KernelF32, A_a) + 36, "layout");
static_assert(offsetof(imuforge::fw::KernelF32, A_g) == offsetof(imuforge::fw::KernelF32, A_a) + 48, "layout");
static_assert(offsetof(imuforge::fw::KernelF32, A_ga) == offsetof(imuforge::fw::KernelF32, A_a) + 84, "layout");
static_assert(offsetof(imuforge::fw::KernelF32, o_g) == offsetof(imuforge::fw::KernelF32, A_a) + 120, "layout");
static_assert(offsetof(imuforge::fw::ImuF32, gyro_rad_s) == 12, "layout");
