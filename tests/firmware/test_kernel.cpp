// Compensation kernel: both arithmetic paths against a double-precision reference of
//   f = C_a(T)(raw_a·lsb_a − b_a(T)),   w = C_g(T)(raw_g·lsb_g − b_g(T)) + G(T)·f
// over the full int16 input range (every value on the host, a stride under qemu) and the full
// temperature range (including beyond both ends), plus exhaustive edge combinations.
//   fixed path: |out − ref/LSB| ≤ 1 output LSB (Q15.16 m/s², Q13.18 rad/s)
//   f32 path:   |out − ref| ≤ 16·2^-24·M, M = Σ|terms| of the row (docs/kernel.md derives the bound)
#include <cstring>

#include "firmware/kernel/compensation.h"
#include "firmware/table/table.h"
#include "tests/firmware/fwtest.h"
#include "tests/firmware/test_tables.h"

using namespace imuforge::fw;

#if defined(__arm__)
constexpr int kSweepStride = 41;  // qemu: every 97th count (+ the edges), soft double is slow on M3
constexpr bool kFullEdges = false;
#else
constexpr int kSweepStride = 1;  // host: every int16 value on every axis
constexpr bool kFullEdges = true;
#endif

struct Ref {
  double accel[3], gyro[3];
  double mag_a[3], mag_g[3];  // Σ|terms| per row, for the float bound
  bool clamped;
};

static double absd(double v) { return v < 0 ? -v : v; }

static void reference(const Table& t, double T, const std::int32_t ra[3], const std::int32_t rg[3], Ref* r) {
  const int n = t.n_breakpoints;
  const double b0 = static_cast<double>(t.breakpoints_degC[0]);
  const double bn = static_cast<double>(t.breakpoints_degC[n - 1]);
  r->clamped = n > 1 && (T < b0 || T > bn);  // one breakpoint: temperature-independent, never clamped
  const double Tc = T < b0 ? b0 : (T > bn ? bn : T);
  int i = 0;
  while (i + 2 < n && Tc >= static_cast<double>(t.breakpoints_degC[i + 1])) ++i;
  const int j = n > 1 ? i + 1 : i;
  const double w = n > 1 ? (Tc - static_cast<double>(t.breakpoints_degC[i])) /
                               (static_cast<double>(t.breakpoints_degC[j]) - static_cast<double>(t.breakpoints_degC[i]))
                         : 0.0;
  auto L = [w](float a, float b) { return static_cast<double>(a) + w * (static_cast<double>(b) - static_cast<double>(a)); };
  // Float interpolation rounds relative to the end points, not to the (possibly cancelled) result.
  auto Mx = [](float a, float b) { return absd(static_cast<double>(a)) > absd(static_cast<double>(b)) ? absd(static_cast<double>(a)) : absd(static_cast<double>(b)); };
  const BreakpointCoeffs& c0 = t.coeffs[i];
  const BreakpointCoeffs& c1 = t.coeffs[j];
  const double la = static_cast<double>(t.accel_lsb_mps2), lg = static_cast<double>(t.gyro_lsb_rad_s);
  for (int row = 0; row < 3; ++row) {
    double s = 0, m = 0;
    for (int k = 0; k < 3; ++k) {
      const double c = L(c0.accel.C[3 * row + k], c1.accel.C[3 * row + k]);
      const double u = ra[k] * la, b = L(c0.accel.b[k], c1.accel.b[k]);
      s += c * (u - b);
      m += Mx(c0.accel.C[3 * row + k], c1.accel.C[3 * row + k]) * (absd(u) + Mx(c0.accel.b[k], c1.accel.b[k]));
    }
    r->accel[row] = s;
    r->mag_a[row] = m;
  }
  for (int row = 0; row < 3; ++row) {
    double s = 0, m = 0;
    for (int k = 0; k < 3; ++k) {
      const double c = L(c0.gyro.C[3 * row + k], c1.gyro.C[3 * row + k]);
      const double u = rg[k] * lg, b = L(c0.gyro.b[k], c1.gyro.b[k]);
      const double g = L(c0.G[3 * row + k], c1.G[3 * row + k]);
      s += c * (u - b) + g * r->accel[k];
      m += Mx(c0.gyro.C[3 * row + k], c1.gyro.C[3 * row + k]) * (absd(u) + Mx(c0.gyro.b[k], c1.gyro.b[k])) +
           Mx(c0.G[3 * row + k], c1.G[3 * row + k]) * r->mag_a[k];
    }
    r->gyro[row] = s;
    r->mag_g[row] = m;
  }
}

struct Stats {
  double max_q_lsb = 0;       // fixed: worst |error| in output LSB
  double max_f_ratio = 0;     // f32: worst |error| / bound
  long samples = 0;
};

static KernelF32 g_kf;
static KernelQ g_kq;
static Table g_t;

// Runs one sample through both paths (int16 entry) and checks it against the reference.
static void check_sample(const Table& t, const std::int16_t ra16[3], const std::int16_t rg16[3], std::int32_t T_q16,
                         Stats* st) {
  RawSample16 raw;
  std::int32_t ra[3], rg[3];
  for (int k = 0; k < 3; ++k) {
    raw.accel[k] = ra16[k];
    raw.gyro[k] = rg16[k];
    ra[k] = ra16[k];
    rg[k] = rg16[k];
  }
  const double T = T_q16 / 65536.0;
  Ref r;
  reference(t, T, ra, rg, &r);

  ImuQ q;
  const std::uint32_t sq = kernel_q_run(&g_kq, &raw, T_q16, &q);
  ImuF32 f;
  const float Tf = static_cast<float>(T);  // exact: |T_q16| < 2^24
  const std::uint32_t sf = kernel_f32_run(&g_kf, &raw, Tf, &f);

  bool sat = false;
  for (int k = 0; k < 3; ++k) sat = sat || ra[k] == -32768 || ra[k] == 32767 || rg[k] == -32768 || rg[k] == 32767;
  // The fixed path holds breakpoints in Q16.16 °C (rounded): within 2^-16 °C of an end, its clamp flag
  // may legitimately differ from the float one.
  const double e0 = static_cast<double>(t.breakpoints_degC[0]);
  const double e1 = static_cast<double>(t.breakpoints_degC[t.n_breakpoints - 1]);
  const bool near_end = absd(T - e0) <= 1.0 / 65536 || absd(T - e1) <= 1.0 / 65536;
  if (!near_end) FW_EXPECT_EQ_INT((sq & kStatusTempClamped) != 0, r.clamped);
  FW_EXPECT_EQ_INT((sf & kStatusTempClamped) != 0, r.clamped);
  FW_EXPECT_EQ_INT((sq & kStatusInputSaturated) != 0, sat);
  if (!near_end) FW_EXPECT_EQ_INT(sq, sf);

  const double u = 1.0 / 16777216.0;  // 2^-24, float unit roundoff
  for (int k = 0; k < 3; ++k) {
    const double ea = absd(q.accel[k] - r.accel[k] * 65536.0);
    const double eg = absd(q.gyro[k] - r.gyro[k] * 262144.0);
    if (ea > st->max_q_lsb) st->max_q_lsb = ea;
    if (eg > st->max_q_lsb) st->max_q_lsb = eg;
    const double fa = absd(static_cast<double>(f.accel_mps2[k]) - r.accel[k]) / (16 * u * r.mag_a[k] + 1e-30);
    const double fg = absd(static_cast<double>(f.gyro_rad_s[k]) - r.gyro[k]) / (16 * u * r.mag_g[k] + 1e-30);
    if (fa > st->max_f_ratio) st->max_f_ratio = fa;
    if (fg > st->max_f_ratio) st->max_f_ratio = fg;
    if (ea > 1.0 || eg > 1.0 || fa > 1.0 || fg > 1.0) {
      std::printf("  T=%.6f raw a=(%d %d %d) g=(%d %d %d) axis %d: q err %.3f/%.3f LSB, f32 err/bound %.3f/%.3f\n", T,
                  static_cast<int>(ra[0]), static_cast<int>(ra[1]), static_cast<int>(ra[2]), static_cast<int>(rg[0]),
                  static_cast<int>(rg[1]), static_cast<int>(rg[2]), k, ea, eg, fa, fg);
      FW_EXPECT(ea <= 1.0 && eg <= 1.0 && fa <= 1.0 && fg <= 1.0);
    } else {
      ++fwtest::state().checks;
    }
  }
  ++st->samples;
}

static void load_both(Table* t) {
  kernel_f32_init(&g_kf, 0.0f);
  kernel_q_init(&g_kq, 0);
  FW_EXPECT_EQ_INT(kernel_f32_load(&g_kf, t), 0);
  FW_EXPECT_EQ_INT(kernel_q_load(&g_kq, t), 0);
}

static void accuracy_for(fwtest::Rng& rng, int n_bp, float accel_fs_g, float gyro_fs_dps) {
  fwtest::make_random_table(&g_t, rng, n_bp, accel_fs_g, gyro_fs_dps);
  FW_EXPECT_EQ_INT(table_validate(&g_t), kTableOk);
  load_both(&g_t);
  const std::int32_t lo = static_cast<std::int32_t>((static_cast<double>(g_t.breakpoints_degC[0]) - 15.0) * 65536.0);
  const std::int32_t hi =
      static_cast<std::int32_t>((static_cast<double>(g_t.breakpoints_degC[n_bp - 1]) + 15.0) * 65536.0);
  Stats st;
  std::int16_t ra[3], rg[3];
  // Full input range, one axis at a time, the others random; temperature random over the range.
  for (int axis = 0; axis < 6; ++axis) {
    for (std::int32_t v = -32768; v <= 32767; v += kSweepStride) {
      for (int k = 0; k < 3; ++k) {
        ra[k] = static_cast<std::int16_t>(rng.range_i32(-32768, 32767));
        rg[k] = static_cast<std::int16_t>(rng.range_i32(-32768, 32767));
      }
      (axis < 3 ? ra[axis] : rg[axis - 3]) = static_cast<std::int16_t>(v);
      check_sample(g_t, ra, rg, rng.range_i32(lo, hi), &st);
    }
  }
  // Edge combinations at the breakpoints, just beyond the ends and between.
  const std::int16_t e_full[] = {-32768, -32767, -1, 0, 1, 32766, 32767};
  const std::int16_t e_small[] = {-32768, 0, 32767};
  const std::int16_t* e = kFullEdges ? e_full : e_small;
  const int ne = kFullEdges ? 7 : 3;
  std::int32_t temps[kTableMaxBreakpoints + 4];
  int nt = 0;
  temps[nt++] = lo;
  temps[nt++] = hi;
  for (int i = 0; i < n_bp; ++i) temps[nt++] = static_cast<std::int32_t>(static_cast<double>(g_t.breakpoints_degC[i]) * 65536.0);
  if (n_bp > 1) temps[nt++] = (temps[2] / 2 + temps[3] / 2);
  int combos = 1;
  for (int k = 0; k < 6; ++k) combos *= ne;
  for (int c = 0; c < combos; ++c) {
    int x = c;
    for (int k = 0; k < 3; ++k, x /= ne) ra[k] = e[x % ne];
    for (int k = 0; k < 3; ++k, x /= ne) rg[k] = e[x % ne];
    check_sample(g_t, ra, rg, temps[c % nt], &st);
  }
  std::printf("  table %d bp, %.0f g, %.0f dps: %ld samples, fixed max err %.3f LSB, f32 max err/bound %.3f\n", n_bp,
              static_cast<double>(accel_fs_g), static_cast<double>(gyro_fs_dps), st.samples, st.max_q_lsb,
              st.max_f_ratio);
  FW_EXPECT(st.max_q_lsb <= 1.0);
  FW_EXPECT(st.max_f_ratio <= 1.0);
}

static void test_accuracy() {
  fwtest::Rng rng(2024);
  accuracy_for(rng, 16, 16.0f, 2000.0f);
  accuracy_for(rng, 5, 2.0f, 125.0f);
  accuracy_for(rng, 2, 8.0f, 500.0f);
  accuracy_for(rng, 1, 4.0f, 250.0f);
}

static void test_status_and_no_table() {
  KernelF32 kf;
  KernelQ kq;
  kernel_f32_init(&kf, 0.1f);
  kernel_q_init(&kq, 6554);
  RawSample16 raw = {{100, -100, 5}, {1, 2, 3}};
  ImuF32 f;
  ImuQ q;
  FW_EXPECT_EQ_INT(kernel_f32_run(&kf, &raw, 25.0f, &f), kStatusNoTable);
  FW_EXPECT_EQ_INT(kernel_q_run(&kq, &raw, 25 * kQTempOne, &q), kStatusNoTable);
  FW_EXPECT(f.accel_mps2[0] == 0.0f && f.gyro_rad_s[2] == 0.0f && q.accel[0] == 0 && q.gyro[2] == 0);
  // A table that failed validation is never used.
  Table bad;
  fwtest::Rng rng(3);
  fwtest::make_random_table(&bad, rng, 3, 16.0f, 2000.0f);
  bad.breakpoints_degC[1] = bad.breakpoints_degC[0];
  (void)table_validate(&bad);
  FW_EXPECT_EQ_INT(kernel_f32_load(&kf, &bad), kKernelTableNotValid);
  FW_EXPECT_EQ_INT(kernel_q_load(&kq, &bad), kKernelTableNotValid);
  FW_EXPECT_EQ_INT(kernel_q_run(&kq, &raw, 0, &q), kStatusNoTable);
  FW_EXPECT_EQ_INT(kernel_f32_load(nullptr, &bad), kKernelNullArgument);
  // Saturation flags per triad.
  fwtest::make_random_table(&g_t, rng, 3, 16.0f, 2000.0f);
  (void)table_validate(&g_t);
  FW_EXPECT_EQ_INT(kernel_f32_load(&kf, &g_t), 0);
  FW_EXPECT_EQ_INT(kernel_q_load(&kq, &g_t), 0);
  const float mid = 0.5f * (g_t.breakpoints_degC[0] + g_t.breakpoints_degC[2]);
  const std::int32_t mid_q = static_cast<std::int32_t>(static_cast<double>(mid) * 65536.0);
  FW_EXPECT_EQ_INT(kernel_f32_run(&kf, &raw, mid, &f), kStatusOk);
  raw.accel[1] = -32768;
  FW_EXPECT_EQ_INT(kernel_f32_run(&kf, &raw, mid, &f), kStatusAccelSaturated);
  FW_EXPECT_EQ_INT(kernel_q_run(&kq, &raw, mid_q, &q), kStatusAccelSaturated);
  raw.accel[1] = 0;
  raw.gyro[2] = 32767;
  FW_EXPECT_EQ_INT(kernel_q_run(&kq, &raw, mid_q, &q), kStatusGyroSaturated);
  FW_EXPECT_EQ_INT(kernel_f32_run(&kf, &raw, 500.0f, &f), kStatusGyroSaturated | kStatusTempClamped);
  FW_EXPECT_EQ_INT(kernel_q_run(&kq, &raw, -200 * kQTempOne, &q), kStatusGyroSaturated | kStatusTempClamped);
  // NaN temperature: clamped to the low end, flagged, re-evaluated on every call.
  std::uint8_t nb[4] = {0, 0, 0xC0, 0x7F};
  float nan;
  std::memcpy(&nan, nb, 4);
  raw.gyro[2] = 0;
  FW_EXPECT_EQ_INT(kernel_f32_run(&kf, &raw, nan, &f), kStatusTempClamped);
  FW_EXPECT_EQ_INT(kernel_f32_run(&kf, &raw, mid, &f), kStatusOk);
  FW_EXPECT_EQ_INT(temp_q16_from_cdegC(2550), 25 * 65536 + 32768);
  FW_EXPECT_EQ_INT(temp_q16_from_cdegC(-100), -65536);
}

// Re-interpolation happens only when |T − T_cached| > step.
static void test_step_caching() {
  fwtest::Rng rng(99);
  fwtest::make_random_table(&g_t, rng, 4, 16.0f, 2000.0f);
  // Steep temperature dependence so a re-interpolation is visible in the output.
  for (int i = 0; i < 4; ++i) g_t.coeffs[i].accel.b[0] = 0.2f * static_cast<float>(i);
  (void)table_validate(&g_t);
  KernelF32 kf;
  KernelQ kq;
  kernel_f32_init(&kf, 0.5f);
  kernel_q_init(&kq, kQTempOne / 2);
  FW_EXPECT_EQ_INT(kernel_f32_load(&kf, &g_t), 0);
  FW_EXPECT_EQ_INT(kernel_q_load(&kq, &g_t), 0);
  const RawSample16 raw = {{1000, 2000, -3000}, {100, -200, 300}};
  const float T0 = 0.5f * (g_t.breakpoints_degC[1] + g_t.breakpoints_degC[2]);
  const std::int32_t T0q = static_cast<std::int32_t>(static_cast<double>(T0) * 65536.0);
  ImuF32 f0, f1, f2;
  ImuQ q0, q1, q2;
  kernel_f32_run(&kf, &raw, T0, &f0);
  kernel_f32_run(&kf, &raw, T0 + 0.45f, &f1);
  kernel_f32_run(&kf, &raw, T0 + 1.0f, &f2);
  FW_EXPECT(f1.accel_mps2[0] == f0.accel_mps2[0]);  // within the step: the cached correction
  FW_EXPECT(f2.accel_mps2[0] != f0.accel_mps2[0]);  // beyond: re-interpolated
  kernel_q_run(&kq, &raw, T0q, &q0);
  kernel_q_run(&kq, &raw, T0q + kQTempOne / 2, &q1);  // exactly the step: not more than it
  kernel_q_run(&kq, &raw, T0q + kQTempOne / 2 + 1, &q2);
  FW_EXPECT_EQ_INT(q1.accel[0], q0.accel[0]);
  FW_EXPECT(q2.accel[0] != q0.accel[0]);
  // The cached output equals the reference at the cached temperature.
  std::int32_t ra[3] = {1000, 2000, -3000}, rg[3] = {100, -200, 300};
  Ref r;
  reference(g_t, T0q / 65536.0, ra, rg, &r);
  FW_EXPECT(absd(q1.accel[0] - r.accel[0] * 65536.0) <= 1.0);
}

// Narrow sensors (12-bit counts) clamp and flag; 24-bit counts through the int32 entries stay accurate.
static void test_raw_widths() {
  fwtest::Rng rng(12);
  fwtest::make_random_table(&g_t, rng, 3, 16.0f, 2000.0f, 12);
  FW_EXPECT_EQ_INT(table_validate(&g_t), kTableOk);
  load_both(&g_t);
  const float Tm = g_t.breakpoints_degC[1];
  const std::int32_t Tq = static_cast<std::int32_t>(static_cast<double>(Tm) * 65536.0);
  RawSample16 raw = {{3000, 0, 0}, {0, 0, -2048}};
  RawSample16 clamped = {{2047, 0, 0}, {0, 0, -2048}};
  ImuQ q, qc;
  FW_EXPECT_EQ_INT(kernel_q_run(&g_kq, &raw, Tq, &q), kStatusAccelSaturated | kStatusGyroSaturated);
  kernel_q_run(&g_kq, &clamped, Tq, &qc);
  FW_EXPECT(std::memcmp(&q, &qc, sizeof q) == 0);

  fwtest::make_random_table(&g_t, rng, 6, 16.0f, 2000.0f, 24);
  FW_EXPECT_EQ_INT(table_validate(&g_t), kTableOk);
  load_both(&g_t);
  double worst = 0;
  for (int s = 0; s < 3000; ++s) {
    RawSample32 r32;
    std::int32_t ra[3], rg[3];
    for (int k = 0; k < 3; ++k) {
      ra[k] = r32.accel[k] = rng.range_i32(-(1 << 23), (1 << 23) - 1);
      rg[k] = r32.gyro[k] = rng.range_i32(-(1 << 23), (1 << 23) - 1);
    }
    if (s == 0) ra[0] = r32.accel[0] = -(1 << 23);
    const std::int32_t T = rng.range_i32(-60 * 65536, 120 * 65536);
    Ref ref;
    reference(g_t, T / 65536.0, ra, rg, &ref);
    ImuQ out;
    const std::uint32_t st = kernel_q_run32(&g_kq, &r32, T, &out);
    FW_EXPECT_EQ_INT((st & kStatusAccelSaturated) != 0, s == 0);
    for (int k = 0; k < 3; ++k) {
      const double ea = absd(out.accel[k] - ref.accel[k] * 65536.0), eg = absd(out.gyro[k] - ref.gyro[k] * 262144.0);
      if (ea > worst) worst = ea;
      if (eg > worst) worst = eg;
    }
    ImuF32 f;
    kernel_f32_run32(&g_kf, &r32, static_cast<float>(T / 65536.0), &f);
    FW_EXPECT(absd(static_cast<double>(f.accel_mps2[1]) - ref.accel[1]) <= 16.0 / 16777216.0 * ref.mag_a[1]);
  }
  std::printf("  24-bit counts: fixed max err %.3f LSB\n", worst);
  FW_EXPECT(worst <= 1.0);
}

// A table whose ranges do not fit the fixed formats is refused by the fixed path (the f32 path takes it).
static void test_fixed_range() {
  Table t;
  table_init_identity(&t, 0.5f, 1e-3f, 16, 16);  // accel full scale 16384 m/s²: beyond Q15.16
  FW_EXPECT_EQ_INT(table_validate(&t), kTableOk);
  KernelQ kq;
  KernelF32 kf;
  kernel_q_init(&kq, 0);
  kernel_f32_init(&kf, 0.0f);
  FW_EXPECT_EQ_INT(kernel_q_load(&kq, &t), kKernelFixedRange);
  FW_EXPECT_EQ_INT(kernel_f32_load(&kf, &t), 0);
  RawSample16 raw = {{1, 2, 3}, {4, 5, 6}};
  ImuQ q;
  FW_EXPECT_EQ_INT(kernel_q_run(&kq, &raw, 0, &q), kStatusNoTable);
}

// Degenerate but valid tables (C = 0, tiny G) must load without undefined shifts and give the model's
// answer (here: zero), on both paths. UBSan (host-sanitize preset) watches the shift arithmetic.
static void test_degenerate_table() {
  Table t;
  table_init_identity(&t, 16.0f * 9.80665f / 32768.0f, 2000.0f * fwtest::kPi / 180.0f / 32768.0f, 16, 16);
  for (int m = 0; m < 9; ++m) {
    t.coeffs[0].accel.C[m] = 0.0f;
    t.coeffs[0].gyro.C[m] = 0.0f;
    t.coeffs[0].G[m] = 1e-9f;
  }
  t.model_flags = kModelAccelMatrix | kModelGyroMatrix | kModelGyroGSens;
  FW_EXPECT_EQ_INT(table_validate(&t), kTableOk);
  KernelQ kq;
  KernelF32 kf;
  kernel_q_init(&kq, 0);
  kernel_f32_init(&kf, 0.0f);
  FW_EXPECT_EQ_INT(kernel_q_load(&kq, &t), 0);
  FW_EXPECT_EQ_INT(kernel_f32_load(&kf, &t), 0);
  const RawSample16 raw = {{32000, -32000, 100}, {-5, 5, 31000}};
  ImuQ q;
  ImuF32 f;
  FW_EXPECT_EQ_INT(kernel_q_run(&kq, &raw, 25 * kQTempOne, &q), kStatusOk);
  FW_EXPECT_EQ_INT(kernel_f32_run(&kf, &raw, 25.0f, &f), kStatusOk);
  for (int k = 0; k < 3; ++k) {
    FW_EXPECT(q.accel[k] == 0 && q.gyro[k] == 0);
    FW_EXPECT(f.accel_mps2[k] == 0.0f && absd(static_cast<double>(f.gyro_rad_s[k])) < 1e-12);
  }
}

int main() {
  FW_RUN(test_degenerate_table);
  FW_RUN(test_accuracy);
  FW_RUN(test_status_and_no_table);
  FW_RUN(test_step_caching);
  FW_RUN(test_raw_widths);
  FW_RUN(test_fixed_range);
  return fwtest::summary("fw_kernel");
}
