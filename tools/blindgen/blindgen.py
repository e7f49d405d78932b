#!/usr/bin/env python3
"""blindgen: an independent IMU log generator for validating `imuforge diagnose`.

Written from the documentation only (docs/formats.md "Log format v1" and "Sensor model file",
docs/error-model.md, IEEE Std 952 / 1293 / 1431 error models), NOT from host/sim, host/physics or host/model: it
shares no code with the program it checks, so a convention slip in either one shows up as a
disagreement (see FINDINGS / docs/diagnosis.md "Blind battery").

What a case is:
  * a scenario ("campaign"): a 3-axis table (inner z, middle x, outer z, as in docs/formats.md) that
    jumps INSTANTANEOUSLY between poses (multi-position tumble, tilted poses), spins at constant rates
    about body and diagonal axes (rates start and stop instantly), oscillates (sines), while a chamber
    steps between temperature plateaus and ramps; 100 Hz; references in the IMU (body) frame;
  * a sensor (the documented sensor JSON: catalog effects, noise, thermal block), evaluated with the
    documented measurement equation, timing realised exactly (inputs evaluated at t - latency - ppm*t);
  * extras the catalog cannot express: out-of-catalog deterministic effects (bias following the table
    heading, a bias step, bias ~ |w|^3, accel bias ~ |w|, a periodic bias) and extra stochastic terms
    (single Gauss-Markov, flicker-like GM sums, temperature-dependent white noise);
  * a truth file: what is present (catalog parameter names and units), what the diagnosis should say.

Usage:
  blindgen.py case --kind random --seed 7 --out DIR          one case: DIR/log.csv, truth.json, sensor.json
  blindgen.py case --kind example --sensor docs/examples/sensor-automotive.json --seed 3 --out DIR
  blindgen.py selftest                                       checks of the generator's own physics
Kinds: random (3-6 beyond-model effects), single, example, null, stochastic, ooc, mixed (random + one ooc).
"""
import argparse
import json
import math
import os
import sys

import numpy as np

# ----------------------------------------------------------------------------------------------------
# Earth: WGS-84 normal gravity (Somigliana, NIMA TR8350.2 eq. 4-1) with the second-order free-air term
# (eq. 4-3), and the Earth rate. Plumb-bob gravity: already contains the centripetal term of Earth rotation.
WGS84_A = 6378137.0
WGS84_F = 1.0 / 298.257223563
WGS84_GE = 9.7803253359
WGS84_K = 0.00193185265241
WGS84_E2 = 0.00669437999013
WGS84_M = 0.00344978650684
OMEGA_E = 7.292115e-5


def normal_gravity(lat_deg, h_m):
    s2 = math.sin(math.radians(lat_deg)) ** 2
    g0 = WGS84_GE * (1 + WGS84_K * s2) / math.sqrt(1 - WGS84_E2 * s2)
    return g0 * (1 - 2 / WGS84_A * (1 + WGS84_F + WGS84_M - 2 * WGS84_F * s2) * h_m + 3 * h_m * h_m / WGS84_A ** 2)


# ----------------------------------------------------------------------------------------------------
# Rotations (active, right-handed). Vectorised over the leading dimension.
def rz(a):
    c, s = np.cos(a), np.sin(a)
    o, z = np.ones_like(a), np.zeros_like(a)
    return np.stack([np.stack([c, -s, z], -1), np.stack([s, c, z], -1), np.stack([z, z, o], -1)], -2)


def rx(a):
    c, s = np.cos(a), np.sin(a)
    o, z = np.ones_like(a), np.zeros_like(a)
    return np.stack([np.stack([o, z, z], -1), np.stack([z, c, -s], -1), np.stack([z, s, c], -1)], -2)


def rotvec_matrix(v):
    """Rotation matrix of a small rotation vector (Rodrigues)."""
    v = np.asarray(v, float)
    th = np.linalg.norm(v)
    if th < 1e-15:
        return np.eye(3)
    k = v / th
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(th) * K + (1 - math.cos(th)) * K @ K


def mv(M, v):
    return np.einsum('...ij,...j->...i', M, v)


def mtv(M, v):
    return np.einsum('...ji,...j->...i', M, v)


# ----------------------------------------------------------------------------------------------------
# Scenario: a list of segments. Each segment: start time, duration, gimbal angles at its start
# (inner, middle, outer; rad), constant gimbal rates (rad/s), an optional sine on one gimbal, and the
# chamber setpoint behaviour. The pose JUMPS at a segment start (instantaneous pose change).
class Segment:
    __slots__ = ('t0', 'dur', 'ang0', 'rate', 'sine', 'kind', 'label', 'set_from', 'set_to')

    def __init__(self, kind, dur, ang0_deg, rate_dps=(0, 0, 0), sine=None, label='', set_from=None, set_to=None):
        self.kind = kind
        self.dur = float(dur)
        self.ang0 = np.radians(np.asarray(ang0_deg, float))
        self.rate = np.radians(np.asarray(rate_dps, float))
        self.sine = sine  # (gimbal index, amplitude rad, frequency Hz) or None
        self.label = label
        self.set_from = set_from  # chamber setpoint at the segment start (degC)
        self.set_to = set_to      # ... at its end (linear ramp in between); equal for plateaus
        self.t0 = 0.0


class Scenario:
    def __init__(self, segments, fs, lat_deg, h_m, lever_arm_m, mount_err_rad, chamber, T0_C):
        t = 0.0
        for s in segments:
            s.t0 = t
            t += s.dur
        self.segments = segments
        self.duration = t
        self.fs = fs
        self.lat = lat_deg
        self.h = h_m
        self.g = normal_gravity(lat_deg, h_m)
        phi = math.radians(lat_deg)
        self.w_ie_n = np.array([OMEGA_E * math.cos(phi), 0.0, -OMEGA_E * math.sin(phi)])
        self.r = np.asarray(lever_arm_m, float)
        self.C_imu_plat = rotvec_matrix(mount_err_rad).T  # true mount: C_plat<-imu = R(err)
        self.mount_err = np.asarray(mount_err_rad, float)
        self.chamber = chamber
        self.T0 = T0_C
        self.t0s = np.array([s.t0 for s in segments])
        self.ang0 = np.array([s.ang0 for s in segments])
        self.rates = np.array([s.rate for s in segments])
        sa = np.zeros((len(segments), 3))  # sine: gimbal, amplitude, freq (gimbal -1 = none)
        sa[:, 0] = -1
        for i, s in enumerate(segments):
            if s.sine is not None:
                sa[i] = [s.sine[0], s.sine[1], s.sine[2]]
        self.sines = sa

    def seg_index(self, t):
        return np.clip(np.searchsorted(self.t0s, t, side='right') - 1, 0, len(self.segments) - 1)

    def gimbal(self, idx, tau):
        """Gimbal angles, rates, accelerations at time tau into segment idx (arrays)."""
        ang = self.ang0[idx] + self.rates[idx] * tau[:, None]
        rate = self.rates[idx].copy()
        acc = np.zeros_like(rate)
        sg = self.sines[idx]
        has = sg[:, 0] >= 0
        if np.any(has):
            gi = sg[has, 0].astype(int)
            A, f = sg[has, 1], sg[has, 2]
            w = 2 * np.pi * f
            tt = tau[has]
            rows = np.nonzero(has)[0]
            # theta = c - A cos(w tau): starts at rest at c - A (docs/formats.md "sine")
            ang[rows, gi] += -A * np.cos(w * tt)
            rate[rows, gi] += A * w * np.sin(w * tt)
            acc[rows, gi] += A * w * w * np.cos(w * tt)
        return ang, rate, acc

    def attitude(self, ang):
        """C_n<-plat = Rz(outer) Rx(middle) Rz(inner), written out (selftest checks it against the product)."""
        ci, si = np.cos(ang[:, 0]), np.sin(ang[:, 0])
        cm, sm = np.cos(ang[:, 1]), np.sin(ang[:, 1])
        co, so = np.cos(ang[:, 2]), np.sin(ang[:, 2])
        C = np.empty((len(ang), 3, 3))
        C[:, 0, 0] = co * ci - so * cm * si
        C[:, 0, 1] = -co * si - so * cm * ci
        C[:, 0, 2] = so * sm
        C[:, 1, 0] = so * ci + co * cm * si
        C[:, 1, 1] = -so * si + co * cm * ci
        C[:, 1, 2] = -co * sm
        C[:, 2, 0] = sm * si
        C[:, 2, 1] = sm * ci
        C[:, 2, 2] = cm
        return C

    def body_rate_nb(self, ang, rate):
        """Platform rate w.r.t. the local level frame, platform axes:
        w = rate_inner e_z + Rz(inner)^T (rate_middle e_x) + Rz(inner)^T Rx(middle)^T (rate_outer e_z)."""
        ci, si = np.cos(ang[:, 0]), np.sin(ang[:, 0])
        cm, sm = np.cos(ang[:, 1]), np.sin(ang[:, 1])
        return np.stack([rate[:, 1] * ci + rate[:, 2] * si * sm,
                         -rate[:, 1] * si + rate[:, 2] * ci * sm,
                         rate[:, 0] + rate[:, 2] * cm], -1)

    def kinematics(self, t, h=1e-4):
        """True inputs at times t (arrays), platform frame: f (at the IMU reference point), w_ib, wdot,
        plus gimbal angles/rates. The segment is the one containing t, so derivatives never straddle a
        pose jump (instantaneous changes have no defined derivative at the jump).
        wdot = d/dt w_nb (central difference of the gimbal rates, same segment) - w_nb x (C^T w_ie): the
        second term is the exact derivative of the Earth rate seen in the turning platform."""
        t = np.asarray(t, float)
        idx = self.seg_index(t)
        tau = t - self.t0s[idx]
        ang, rate, _ = self.gimbal(idx, tau)
        C = self.attitude(ang)
        w_nb = self.body_rate_nb(ang, rate)
        w_ie_b = mtv(C, np.broadcast_to(self.w_ie_n, (len(t), 3)))
        w = w_nb + w_ie_b
        moving = np.any(self.rates[idx] != 0, axis=1) | (self.sines[idx, 0] >= 0)
        wdot = np.zeros_like(w)
        if np.any(moving):
            m = np.nonzero(moving)[0]
            ap, rp, _ = self.gimbal(idx[m], tau[m] + h)
            am, rm, _ = self.gimbal(idx[m], tau[m] - h)
            wdot[m] = (self.body_rate_nb(ap, rp) - self.body_rate_nb(am, rm)) / (2 * h) - np.cross(w_nb[m], w_ie_b[m])
        f = mtv(C, np.broadcast_to(np.array([0.0, 0.0, -self.g]), (len(t), 3)))
        r = np.broadcast_to(self.r, f.shape)
        f = f + np.cross(wdot, r) + np.cross(w, np.cross(w, r))
        return f, w, wdot, ang, rate, idx

    def imu_inputs(self, t):
        """True inputs in the IMU case frame (the mount error rotates them)."""
        f, w, wdot, ang, rate, idx = self.kinematics(t)
        M = self.C_imu_plat
        return f @ M.T, w @ M.T, wdot @ M.T, ang, rate, idx


# ----------------------------------------------------------------------------------------------------
# Thermal: chamber setpoint (slew-limited), air first-order lag, die first-order lag + self-heating.
def thermal_profile(scn, t, thermal):
    fs = scn.fs
    n = len(t)
    idx = scn.seg_index(t)
    set_from = np.array([s.set_from for s in scn.segments])[idx]
    set_to = np.array([s.set_to for s in scn.segments])[idx]
    dur = np.array([s.dur for s in scn.segments])[idx]
    tau_seg = t - scn.t0s[idx]
    sp = set_from + (set_to - set_from) * np.clip(tau_seg / dur, 0, 1)
    ch = scn.chamber
    dt = 1.0 / fs
    slew = ch['slew_C_per_min'] / 60.0 * dt
    a_air = 1 - math.exp(-dt / ch['air_tau_s'])
    die_tau = float(thermal.get('die_tau_s', 60))
    a_die = 1 - math.exp(-dt / die_tau)
    sh_C = float(thermal.get('self_heating_C', 0.0))
    sh_tau = float(thermal.get('self_heating_tau_s', 100.0))
    air = np.empty(n)
    die = np.empty(n)
    slewed = scn.T0
    a, d = scn.T0, scn.T0
    sh = sh_C * (1 - np.exp(-t / sh_tau))
    # Sequential recursion (first-order lags); plain Python loop is too slow for 1e6 rows, so run it in
    # chunks of constant coefficients with numpy's cumulative tools where possible. A direct loop over
    # ~3.5e5 samples is ~0.3 s, acceptable.
    spl = sp.tolist()
    shl = sh.tolist()
    for k in range(n):
        target = spl[k]
        if target > slewed + slew:
            slewed += slew
        elif target < slewed - slew:
            slewed -= slew
        else:
            slewed = target
        a += (slewed - a) * a_air
        d += (a + shl[k] - d) * a_die
        air[k] = a
        die[k] = d
    Tdot = (air + sh - die) / die_tau  # exact derivative of the die ODE
    return air, die, Tdot


def hysteresis_direction(T, threshold):
    """docs/error-model.md 'Hysteresis tracker': d=0 until the first move beyond the threshold from the
    start; then follow the extreme in the current direction, flip when the temperature comes back by
    more than the threshold."""
    d = np.zeros(len(T))
    state = 0
    ref = T[0]
    Tl = T.tolist()
    for k, x in enumerate(Tl):
        if state == 0:
            if x > ref + threshold:
                state, ref = 1, x
            elif x < ref - threshold:
                state, ref = -1, x
        elif state == 1:
            if x > ref:
                ref = x
            elif x < ref - threshold:
                state, ref = -1, x
        else:
            if x < ref:
                ref = x
            elif x > ref + threshold:
                state, ref = 1, x
        d[k] = state
    return d


# ----------------------------------------------------------------------------------------------------
# Sensor model (docs/formats.md "Sensor model file", docs/error-model.md catalog).
AX = 'xyz'
DETERMINISTIC = ['bias', 'scale', 'misalign', 'bias_temp', 'scale_temp', 'misalign_temp', 'scale_nonlinearity',
                 'scale_asymmetry', 'cross_coupling', 'cross_axis_nonlinearity', 'g_sensitivity', 'g2_sensitivity',
                 'size_effect', 'temp_hysteresis', 'temp_rate', 'timing']
STOCHASTIC = ['white_noise', 'bias_instability', 'rate_random_walk', 'quantization', 'saturation', 'turn_on_bias']
GYRO_ONLY = {'g_sensitivity', 'g2_sensitivity'}
ACCEL_ONLY = {'size_effect', 'cross_axis_nonlinearity'}


def applies(sensor, effect):
    if effect in GYRO_ONLY:
        return sensor == 'gyro'
    if effect in ACCEL_ONLY:
        return sensor == 'accel'
    return True


def sensor_effects(sensor_json):
    """{'accel': {effect: {component: value}}, 'gyro': {...}} of the enabled effects."""
    out = {'accel': {}, 'gyro': {}}
    for key, comps in sensor_json.get('effects', {}).items():
        if key.startswith('_'):
            continue
        if not isinstance(comps, dict) or comps.get('enabled', True) is False:
            continue
        vals = {k: float(v) for k, v in comps.items() if not k.startswith('_') and k != 'enabled'}
        if '.' in key:
            s, e = key.split('.', 1)
            targets = [s]
        else:
            e = key
            targets = [s for s in ('accel', 'gyro') if applies(s, e)]
        if e not in DETERMINISTIC and e not in STOCHASTIC:
            raise ValueError('effects.%s: unknown effect %r' % (key, e))
        for s in targets:
            if not applies(s, e):
                raise ValueError('effects.%s: effect %r does not apply to the %s' % (key, e, s))
            out[s].setdefault(e, {}).update(vals)
    return out


def deterministic_output(eff, u, f, w, wdot, T, Tdot, d, T_ref, sensor):
    """The measurement equation of docs/error-model.md for one triad, without timing (the caller passes
    inputs already evaluated at the shifted time) and without noise. u: (n,3) input; f: specific force
    (gyro g-sensitivity); w, wdot: rates (size effect)."""
    n = u.shape[0]
    y = u.copy()
    tau = T - T_ref
    for j, aj in enumerate(AX):
        def c(e, comp):
            return eff.get(e, {}).get(comp, 0.0)
        b = c('bias', aj) + sum(c('bias_temp', '%s.t%d' % (aj, p)) * tau ** p for p in (1, 2, 3))
        y[:, j] += b
        for k, ak in enumerate(AX):
            if j == k:
                m = c('scale', aj) + sum(c('scale_temp', '%s.t%d' % (aj, p)) * tau ** p for p in (1, 2, 3))
            else:
                comp = aj + ak
                m = c('misalign', comp) + sum(c('misalign_temp', '%s.t%d' % (comp, p)) * tau ** p for p in (1, 2, 3))
            y[:, j] += m * u[:, k]
        uj = u[:, j]
        y[:, j] += c('scale_nonlinearity', aj + '.k2') * uj ** 2 + c('scale_nonlinearity', aj + '.k3') * uj ** 3
        y[:, j] += c('scale_asymmetry', aj) * np.minimum(uj, 0.0)
        for k, ak in enumerate(AX):
            if k != j:
                y[:, j] += c('cross_coupling', aj + ak) * uj * u[:, k]
        if sensor == 'accel':
            # IEEE 1293 cross-axis nonlinearity: the squares (K_pp, K_oo) and the product (K_po) of the two other axes
            for kl in ('xx', 'yy', 'zz', 'xy', 'yz', 'zx'):
                xn = c('cross_axis_nonlinearity', aj + '.' + kl)
                if xn != 0.0:
                    y[:, j] += xn * u[:, AX.index(kl[0])] * u[:, AX.index(kl[1])]
        if sensor == 'gyro':
            for k, ak in enumerate(AX):
                y[:, j] += c('g_sensitivity', aj + ak) * f[:, k]
            # IEEE 1431 g^2 terms: squares (kk) and products (kl); the catalog's pair names are xy, yz, zx
            for kl in ('xx', 'yy', 'zz', 'xy', 'yz', 'zx'):
                g2 = c('g2_sensitivity', aj + '.' + kl)
                if g2 != 0.0:
                    y[:, j] += g2 * f[:, AX.index(kl[0])] * f[:, AX.index(kl[1])]
        if sensor == 'accel' and 'size_effect' in eff:
            r_j = np.array([c('size_effect', '%s.r%s' % (aj, ak)) for ak in AX])
            if np.any(r_j != 0):
                # [w x (w x r_j) + wdot x r_j]_j
                s = np.cross(w, np.cross(w, np.broadcast_to(r_j, w.shape))) + np.cross(wdot, np.broadcast_to(r_j, w.shape))
                y[:, j] += s[:, j]
        y[:, j] += c('temp_hysteresis', aj) * d
        y[:, j] += c('temp_rate', aj) * Tdot
    return y


# ---- noise -------------------------------------------------------------------------------------------
def gm_avar(sigma, tau_c, T):
    """Allan variance of a first-order Gauss-Markov process (autocovariance sigma^2 e^{-|s|/tau_c})."""
    x = T / tau_c
    return sigma ** 2 / x ** 2 * (2 * x - 3 + 4 * np.exp(-x) - np.exp(-2 * x))


def gm_process(rng, n, dt, sigma, tau_c):
    """Stationary first-order GM, exact discretisation, started in steady state."""
    phi = math.exp(-dt / tau_c)
    q = sigma * math.sqrt(1 - phi * phi)
    w = rng.standard_normal(n) * q
    w[0] = rng.standard_normal() * sigma
    # x_k = phi x_{k-1} + w_k: a first-order IIR filter
    return _iir1(w, phi)


def _iir1(w, phi):
    """x_k = phi x_{k-1} + w_k (x_{-1} = 0). numpy has no IIR filter: blocks of B samples use
    x_{s+i} = phi^i (phi x_{s-1} + sum_{l<=i} phi^-l w_{s+l}), B small enough that phi^-B stays moderate."""
    n = len(w)
    out = np.empty(n)
    B = int(max(1, min(4096, math.floor(20.0 / max(-math.log(phi), 1e-12)))))
    pw = phi ** np.arange(B)
    inv = phi ** -np.arange(B, dtype=float)
    x = 0.0
    for s in range(0, n, B):
        blk = w[s:s + B]
        m = len(blk)
        xs = pw[:m] * (phi * x + np.cumsum(blk * inv[:m]))
        out[s:s + m] = xs
        x = xs[-1]
    return out


FLICKER_TAUS = np.logspace(-1.5, 1.3, 8)  # x tau_s: correlation times of the GM sum


def flicker_sigma(B, tau_s):
    """Common sigma of the GM components so the sum's Allan deviation is 0.664 B (IEEE 952 flicker floor
    B sqrt(2 ln2 / pi)), geometric mean over 0.2..10 tau_s."""
    T = tau_s * np.logspace(math.log10(0.2), 1, 25)
    avar1 = sum(gm_avar(1.0, tc * tau_s, T) for tc in FLICKER_TAUS)
    target = (2 * math.log(2) / math.pi) * B * B
    return math.sqrt(target / math.exp(np.mean(np.log(avar1))))


def flicker_process(rng, n, dt, B, tau_s):
    s = flicker_sigma(B, tau_s)
    return sum(gm_process(rng, n, dt, s, tc * tau_s) for tc in FLICKER_TAUS)


# ----------------------------------------------------------------------------------------------------
# Scenario builder.
FACES = [(0, 0), (0, 180), (0, 90), (180, 90), (90, 90), (270, 90)]  # (inner, middle): +z,-z,+y,-y,+x,-x down


def build_scenario(rng, spec):
    fs = spec.get('sample_rate_hz', 100)
    plateaus = spec['plateaus_C']
    dwell = spec.get('dwell_s', 5.0)
    rdwell = spec.get('rate_dwell_s', 6.0)
    rates = spec.get('rates_dps', [30, 100, 300])
    segs = []
    cur_set = spec.get('chamber_initial_C', 25.0)

    def seg(kind, dur, ang, rate=(0, 0, 0), sine=None, label=''):
        segs.append(Segment(kind, dur, ang, rate, sine, label, cur_set, cur_set))

    for pi, Tp in enumerate(plateaus):
        # soak: setpoint step (instantaneous), table still; the first soak is long (Allan record)
        cur_set = Tp
        soak = spec.get('first_soak_s', 300) if pi == 0 else spec.get('soak_s', 150)
        az = float(rng.uniform(0, 360))
        seg('soak', soak, (0, 0, az), label='soak %g C' % Tp)
        # tumble: 6 faces at n_az azimuths + tilted poses (several tilt levels separate u^2, u^3, min(u,0))
        poses = []
        for a in rng.choice([0, 90, 180, 270], size=spec.get('n_az', 2), replace=False):
            for (i, m) in FACES:
                poses.append((i, m, float(a) + float(rng.uniform(-5, 5))))
        for _ in range(spec.get('n_tilt', 10)):
            poses.append((float(rng.uniform(0, 360)), float(rng.choice([30, 45, 60, 120, 135, 150])) + float(rng.uniform(-5, 5)),
                          float(rng.uniform(0, 360))))
        order = rng.permutation(len(poses))
        for k in order:
            seg('position', dwell, poses[k], label='pose')
        # rates: about each body axis (held vertical, outer axis spins), both signs, each level
        rsegs = []
        for (i, m, lab) in [(0, 0, 'z'), (90, 90, 'x'), (0, 90, 'y'), (45, 54.7356, 'diag'), (135, 125.2644, 'diag2')]:
            lv = rates if lab in 'xyz' else rates[-1:]
            for r in lv:
                for sg in (1, -1):
                    rsegs.append(((i, m, float(rng.uniform(0, 360))), (0, 0, sg * r), 'rate %s %+g dps' % (lab, sg * r)))
        # rotation about a horizontal body axis: gravity turns in the body (inner at middle=90; middle at inner=0)
        for r in rates[:2]:
            for sg in (1, -1):
                rsegs.append(((float(rng.uniform(0, 360)), 90, float(rng.uniform(0, 360))), (sg * r, 0, 0), 'tumble z %+g dps' % (sg * r)))
                rsegs.append(((0, float(rng.uniform(0, 360)), float(rng.uniform(0, 360))), (0, sg * r, 0), 'tumble x %+g dps' % (sg * r)))
        for k in rng.permutation(len(rsegs)):
            ang, rate, lab = rsegs[k]
            seg('rate', rdwell, ang, rate, label=lab)
        # sines: middle (horizontal) and outer (vertical) axis
        if spec.get('sines', True):
            seg('sine', 10, (float(rng.uniform(0, 360)), 90, float(rng.uniform(0, 360))), sine=(1, math.radians(20), 0.5), label='sine middle')
            seg('sine', 10, (float(rng.uniform(0, 360)), 45, 0), sine=(2, math.radians(30), 0.4), label='sine outer')
        # ramp to the next plateau (or the final ramp): static, chamber ramps
        last = pi + 1 == len(plateaus)
        nxt = plateaus[pi + 1] if not last else (Tp - 20 if Tp > 20 else Tp + 20)
        rate_cpm = spec.get('ramp_C_per_min', 0) if not last else spec.get('final_ramp', 0)
        if rate_cpm > 0:
            dur = abs(nxt - Tp) / rate_cpm * 60
            segs.append(Segment('ramp', dur, (0, 180, float(rng.uniform(0, 360))), label='ramp to %g C' % nxt,
                                set_from=Tp, set_to=nxt))
            cur_set = nxt
    lever = spec.get('lever_arm_m')
    if lever is None:
        lever = rng.uniform(-0.03, 0.03, 3).tolist()
    merr = spec.get('mount_error_rad')
    if merr is None:
        merr = np.radians(rng.uniform(-0.03, 0.03, 3)).tolist()
    chamber = {'slew_C_per_min': spec.get('slew_C_per_min', 5.0), 'air_tau_s': spec.get('air_tau_s', 60.0)}
    return Scenario(segs, fs, spec.get('latitude_deg', 48.14), spec.get('height_m', 520.0), lever, merr, chamber,
                    spec.get('chamber_initial_C', 25.0))


# ----------------------------------------------------------------------------------------------------
# Out-of-catalog effects (functions of the inputs that no catalog effect has), added to y in SI.
def zero_burst_mask(o, t):
    """The rows a zero_burst term clears: bursts of 3 to max_rows rows at Poisson times, one per interval_s."""
    rng = np.random.default_rng(o['seed'])
    n = int(rng.poisson(t[-1] / o['interval_s']))
    mask = np.zeros(len(t), dtype=bool)
    for i0, ln in zip(rng.integers(0, len(t), n), rng.integers(3, o['max_rows'] + 1, n)):
        mask[i0:i0 + ln] = True
    return mask


def ooc_signal(o, t, ang, w_imu, f_imu, T, Tdot, wd_imu=None):
    kind = o['kind']
    if kind == 'heading':        # bias following the table heading (outer angle): motor / table field
        return o['amplitude'] * np.cos(ang[:, 2] - o.get('phase_rad', 0.0))
    if kind == 'bias_step':      # a bias jump at t_step (shock, relay, ...)
        return o['amplitude'] * (t >= o['t_step_s'])
    if kind == 'w_cubed':        # bias ~ |w|^3 (all rotation axes)
        return o['coefficient'] * np.linalg.norm(w_imu, axis=1) ** 3
    if kind == 'abs_rate':       # accel bias ~ |w| (rotation-induced, even in w, linear in |w|)
        return o['coefficient'] * np.linalg.norm(w_imu, axis=1)
    if kind == 'periodic':       # slow periodic bias (mains-cycled HVAC / supply), period P
        return o['amplitude'] * np.sin(2 * np.pi * t / o['period_s'] + o.get('phase_rad', 0.0))
    if kind == 'warmup':         # turn-on transient: the bias settles exponentially after power-up (die and
        return o['amplitude'] * np.exp(-t / o['tau_s'])  # package stress relaxing), whatever the chamber does
    if kind == 'drift':          # ageing: a bias that moves linearly with time over the run (not a random walk)
        return o['amplitude'] * (t / o['duration_s'] - 0.5)
    if kind == 'temp_step':      # a bias that jumps where the die crosses T0, both ways, no hysteresis (a package
        return o['amplitude'] * (T >= o['T0_C'])  # stress relief or a regulator changing mode at a temperature)
    if kind == 'abs_temp_rate':  # a bias that grows with how fast the die's temperature moves, either way (a thermal
        return o['coefficient'] * np.abs(Tdot)  # gradient across the package stresses it alike when heating or
        # cooling; the catalog's temp_rate is odd in the rate and temp_hysteresis constant between turns)
    if kind == 'motor_on':       # a bias while the table turns, whatever its rate or axis: the drive's field or
        return o['amplitude'] * (np.linalg.norm(w_imu, axis=1) > o['threshold_rad_s'])  # supply load (no polynomial
        # in the rate has a step at rest; the catalog's terms vanish at zero rate and grow with it)
    if kind == 'temp_bump':      # a bias bump about one die temperature (a mode crossing, an activity dip): no
        return o['amplitude'] * np.exp(-0.5 * ((T - o['T0_C']) / o['width_C']) ** 2)  # polynomial in T has it
    j = AX.index(o['axis'])
    if kind == 'scale_bump':     # a scale factor bump about one die temperature (a resonance of the drive or sense
        u = f_imu if o['sensor'] == 'accel' else w_imu  # loop crossing at T0): the scale analogue of temp_bump; the
        return o['per_unit'] * np.exp(-0.5 * ((T - o['T0_C']) / o['width_C']) ** 2) * u[:, j]  # catalog's is linear in T
    if kind == 'f_times_w':      # accel bias ~ w_j f_j: the proof mass loaded along its axis and turned about it
        return o['coefficient'] * w_imu[:, j] * f_imu[:, j]  # (the catalog's only accel term odd in w is latency's
        # w x f, whose j-th component has no w_j)
    if kind == 'spin_settle':    # gyro bias that jumps when a rotation stops and settles with tau (the drive's ring-
        moving = np.linalg.norm(w_imu, axis=1) > o['threshold_rad_s']  # down, motor heat): zero while turning and
        idx = np.arange(len(t))  # before the first rotation
        last = np.maximum.accumulate(np.where(moving, idx, -1))
        dt = t - t[np.maximum(last, 0)]
        return np.where((last >= 0) & ~moving, o['amplitude'] * np.exp(-dt / o['tau_s']), 0.0)
    if kind == 'rate_odd':       # accel bias linear in the rate about another axis (odd in w; no catalog accel
        return o['coefficient'] * w_imu[:, AX.index(o['input_axis'])]  # effect is odd in the rate)
    if kind == 'creep':          # anelastic creep of the proof mass' suspension: after a change of the input the
        u = f_imu[:, j]          # output keeps moving with time constant tau (its steady part is a scale factor, left
        a = 1.0 - math.exp(-1.0 / (o['fs_hz'] * o['tau_s']))  # out: the bias is the transient)
        lp = np.empty_like(u)
        acc = u[0]
        for i in range(len(u)):
            acc += a * (u[i] - acc)
            lp[i] = acc
        return o['coefficient'] * (lp - u)
    if kind == 'cross_w2':       # gyro bias ~ the square of the rate about ANOTHER axis (the catalog's cross-coupling
        return o['coefficient'] * w_imu[:, AX.index(o['input_axis'])] ** 2  # is on-axis x cross-axis, k2 on-axis)
    if kind == 'scale_age':      # a scale factor that moves linearly with time over the run (settling of the sense
        u = f_imu if o['sensor'] == 'accel' else w_imu  # element after mounting), whatever the temperature does
        return o['per_unit'] * (t / o['duration_s'] - 0.5) * u[:, j]
    if kind == 'g_temp':         # gyro g-sensitivity that moves with the die temperature (f_j (T - T0); the catalog
        return o['coefficient'] * f_imu[:, j] * (T - o['T0_C'])  # has g_sensitivity f_j and gyro misalign_temp w_k T)
    if kind == 'w_times_f':      # a g-dependent gyro scale factor: w_j f_j (the spin axis up reads a different
        return o['coefficient'] * w_imu[:, j] * f_imu[:, j]  # scale from the spin axis down; no catalog term is w f)
    if kind == 'sign_rate':      # a bias that flips with the direction of rotation and saturates within a few deg/s
        w = w_imu[:, j]          # (odd and bounded: no polynomial in w of the catalog has that shape)
        return o['amplitude'] * np.sign(w) * (1.0 - np.exp(-np.abs(w) / o['w0_rad_s']))
    if kind == 'g_cubed':        # gyro bias ~ f_j^3 (cubic g-sensitivity: odd in f like g_sensitivity, which it
        return o['coefficient'] * f_imu[:, j] ** 3  # equals on the +-1 g faces and departs from on the tilts)
    if kind == 'angle2':         # bias following twice the table heading (outer angle): a two-lobed field. Not the
        # inner angle: on static poses that one sets the gravity direction, and cos(2 angle) = 2 cos^2 - 1 is then
        # a square of the specific force, which the catalog has (g2_sensitivity, scale_nonlinearity)
        return o['amplitude'] * np.cos(2 * ang[:, 2] + o.get('phase_rad', 0.0))
    if kind == 'rate_memory':    # gyro bias set by the sign of the last rotation about its axis (backlash-like
        w = w_imu[:, j]          # memory: it persists through the following static poses)
        moving = np.abs(w) > o.get('threshold_rad_s', 0.2)
        last = np.maximum.accumulate(np.where(moving, np.arange(len(w)), -1))
        d = np.where(last >= 0, np.sign(w[np.maximum(last, 0)]), 0.0)
        return o['amplitude'] * d
    if kind == 'f_triple':       # accel bias ~ f_x f_y f_z (a cubic cross term of the pendulum's suspension: zero on
        return o['coefficient'] * f_imu[:, 0] * f_imu[:, 1] * f_imu[:, 2]  # every face and every pose with one axis
        # level, so only the generic tilts see it; the catalog's accel squares and k2/k3 are not odd in all three)
    if kind == 'abs_g':          # gyro bias ~ |f_j|: a g-sensitivity rectified by an asymmetric suspension (even in
        return o['coefficient'] * np.abs(f_imu[:, j])  # f like g2's f_j^2, which it equals on the faces and departs
        # from on the tilts: |cos 45| = 0.71 against cos^2 45 = 0.5)
    if kind == 'motor_heat':     # a bias that follows the table motor's heat: a first-order lag (tau) of 'the table
        moving = (np.linalg.norm(w_imu, axis=1) > o['threshold_rad_s']).astype(float)  # turns', rising through
        a = 1.0 - math.exp(-1.0 / (o['fs_hz'] * o['tau_s']))  # each block of rotations and decaying after; the
        lp = np.empty_like(moving)  # die's sensor does not see this heat, so no function of T carries it
        acc = 0.0
        for i in range(len(moving)):
            acc += a * (moving[i] - acc)
            lp[i] = acc
        return o['amplitude'] * lp
    if kind == 'rate_bump':      # a bias at one speed of the table, whatever the axis: a structural resonance the
        wn = np.linalg.norm(w_imu, axis=1)  # drive excites there (zero at rest, not monotone in the rate: no
        return o['amplitude'] * np.exp(-0.5 * ((wn - o['w0_rad_s']) / (o['width_frac'] * o['w0_rad_s'])) ** 2)  # polynomial)
    if kind == 'cable_wrap':     # a bias following the turns the table has wound up about the vertical since the
        fn = np.linalg.norm(f_imu, axis=1)  # start (a cable without a slip ring twists and strains the mount): the
        up = np.where(fn[:, None] > 0, f_imu / np.maximum(fn, 1e-9)[:, None], 0.0)  # rate about the specific force,
        dt = np.diff(t, prepend=t[0])  # integrated; scaled to amp at its largest excursion. A history, no function
        theta = np.cumsum(np.sum(w_imu * up, axis=1) * dt)  # of the present inputs has it
        m = np.max(np.abs(theta))
        return o['amplitude'] * theta / m if m > 0 else np.zeros_like(t)
    if kind == 'knee':           # accel output compressing beyond a knee f0 (the front end leaving its linear range):
        u = f_imu[:, j]          # odd, zero below f0, quadratic past it; the catalog's k3 u^3 is a cubic everywhere
        return -o['coefficient'] * np.sign(u) * np.maximum(np.abs(u) - o['f0_m_s2'], 0.0) ** 2
    if kind == 'mount_slip':     # the package slips on its mount once (an adhesive or solder joint giving way under
        u = f_imu if o['sensor'] == 'accel' else w_imu  # the turns' load): a misalignment step, theta times another
        t_slip = o['t_frac'] * t[-1]  # axis' input from t_slip on. The catalog's misalignment is constant over the run
        return o['theta_rad'] * u[:, AX.index(o['input_axis'])] * (t >= t_slip)
    if kind == 'popcorn':        # random telegraph (burst) noise: the bias jumps between 0 and amp at random times
        rng = np.random.default_rng(o['seed'])  # with a mean dwell of hundreds of seconds (a trap in the ASIC's
        flips, tt = [], 0.0      # reference charging and discharging); no function of the inputs and not the
        while tt < t[-1]:        # catalog's Gaussian noises: two levels, sharp edges
            tt += float(rng.exponential(o['dwell_s']))
            flips.append(tt)
        state = np.searchsorted(np.asarray(flips), t, side='right') % 2
        return o['amplitude'] * state
    if kind == 'compressor':     # the chamber's compressor runs while it cools and shakes the fixture: a bias
        on = Tdot < -o['gate_C_per_s']  # oscillating with its cycle period while the die cools, none while it
        return o['amplitude'] * on * np.sin(2 * np.pi * t / o['period_s'] + o['phase_rad'])  # warms or holds
    if kind == 'heater_on':      # the chamber's heater loads the fixture's supply while the die warms: a bias step
        return o['amplitude'] * (Tdot > o['gate_C_per_s'])  # while it heats faster than the gate, none while it cools
        # or holds (the catalog's temp_rate is linear and odd in the rate, abs_temp_rate's kind even in it)
    if kind == 'glitch':         # single-sample bit errors on the bus (an SPI word with one high bit flipped): a
        rng = np.random.default_rng(o['seed'])  # few isolated samples off by a large power of two, either sign,
        n = int(rng.poisson(t[-1] / o['interval_s']))  # at random times; no function of the inputs and nothing
        out = np.zeros_like(t)   # Gaussian: the samples around each are clean
        idx = rng.integers(0, len(t), n)
        out[idx] = o['height'] * rng.choice([-1.0, 1.0], n)
        return out
    if kind == 'range_switch':   # an auto-ranging gyro: past |w_j| = w_r the front end switches range and its scale
        w = w_imu[:, j]          # differs by per_unit (a piecewise-linear scale with a jump at w_r, odd in w; the
        return o['per_unit'] * w * (np.abs(w) > o['w_r_rad_s'])  # catalog's k2, k3 are smooth polynomials)
    if kind == 'inl_periodic':   # the converter's integral nonlinearity, periodic in the output code (a segmented or
        u = f_imu if o['sensor'] == 'accel' else w_imu  # sigma-delta DAC whose segments mismatch): a bias sinusoidal in
        return o['amplitude'] * np.sin(2 * np.pi * u[:, j] / o['period'] + o['phase_rad'])  # the axis' own input, a
        # few periods over the range; the catalog's k2, k3 and asymmetry are one smooth bend
    if kind == 'temp_saw':       # the die's temperature read through a coarse sensor (a step of q C) by the part's own
        x = T / o['q_C']         # compensation: the bias it corrects follows the staircase, and what is left is a
        return o['amplitude'] * 2.0 * (x - np.round(x))  # sawtooth in T of q's period (no polynomial in T has it)
    if kind == 'axis_skew':      # one axis sampled tau after the others (a multiplexed converter): its output is its
        u = f_imu if o['sensor'] == 'accel' else w_imu  # input at t - tau. The catalog's latency is one per triad, and
        return np.interp(t - o['tau_s'], t, u[:, j]) - u[:, j]  # is absent here on the other two axes
    if kind == 'scale_temp_hyst':  # a scale factor that remembers which way the die's temperature last moved (the
        u = f_imu if o['sensor'] == 'accel' else w_imu  # package's stress relaxing one way on heating, the other on
        moving = np.abs(Tdot) > o['gate_C_per_s']  # cooling): +per_unit after a warming, -per_unit after a cooling,
        last = np.maximum.accumulate(np.where(moving, np.arange(len(t)), -1))  # 0 before the first. The catalog's
        d = np.where(last >= 0, np.sign(Tdot[np.maximum(last, 0)]), 0.0)  # temp_hysteresis is a bias, its scale_temp
        return o['per_unit'] * d * u[:, j]  # a function of T alone
    if kind == 'cogging':        # a bias locked to the table motor's rotor: n lobes per turn of the outer axis (its
        return o['amplitude'] * np.sin(o['lobes'] * ang[:, 2] + o['phase_rad'])  # cogging field); while the table
        # turns it oscillates at n times the turn rate, at rest it depends on where the table stopped
    if kind == 'mount_flex':     # accel bias from the mount flexing under the centripetal load of a rotation: the
        k = AX.index(o['input_axis'])  # package tilts by c |w|^2 about an axis, so the axis reads another axis'
        return o['coefficient'] * np.sum(w_imu ** 2, axis=1) * f_imu[:, k]  # specific force times |w|^2 (the
        # catalog's size_effect is |w|^2 alone, g_sensitivity f alone)
    if kind == 'tdot_scale':     # a scale factor that moves with the die's temperature RATE (a gradient across the
        u = f_imu if o['sensor'] == 'accel' else w_imu  # die while it heats or cools bends the sense structure): the
        return o['per_unit_per_C_s'] * Tdot * u[:, j]  # catalog's temp_rate is a bias in Tdot, its scale_temp in T
    if kind == 'angle_window':   # a bias while the outer axis stands within a window of angles (a connector or a
        d = np.mod(ang[:, 2] - o['center_rad'] + np.pi, 2 * np.pi) - np.pi  # cable contact intermittent there):
        return o['amplitude'] * (np.abs(d) < o['half_width_rad'])  # a step in angle, no harmonic of it
    if kind == 'stuck_bit':      # one bit of the output word stuck at 0: acts on the counts (output stage below);
        return np.zeros(len(t))  # here nothing is added to the input-side signal
    if kind == 'temp_knee':      # the part's own compensation table ends at T0: past it the bias it leaves grows
        return o['amplitude'] * np.maximum(T - o['T0_C'], 0.0) / o['span_C']  # linearly with the die temperature
        # (a kink in T: zero below T0; the catalog's bias_temp is a smooth polynomial in T)
    if kind == 'zero_burst':     # the axis' data register read as cleared while the converter rewrote it (a
        return np.zeros(len(t))  # read-during-update race): short bursts of rows reading exactly 0, on the counts
    if kind == 'drive_current':  # the table drive's current while it accelerates or brakes loads the fixture's
        wd = np.gradient(w_imu, t, axis=0)  # supply: a bias in |angular acceleration| (both signs of torque),
        return o['amplitude'] * np.minimum(np.linalg.norm(wd, axis=1) / o['alpha0_rad_s2'], 1.0)  # up to amp
    if kind == 'dead_zone':      # a gyro that reports 0 within +-d of zero rate (a zero-rate threshold in the part's
        return -np.clip(w_imu[:, j], -o['d_rad_s'], o['d_rad_s'])  # output stage): static poses lose the Earth's rate,
        # rotations read d short of their rate (odd in w; no catalog term is a band about zero)
    if kind == 'beat_chirp':     # a switching regulator beating with the sample clock: a slow sinusoidal bias whose
        f = o['f0_hz'] * (1.0 + o['sweep'] * (T - o['T_mid_C']) / o['half_span_C'])  # frequency follows the die
        phase = np.concatenate([[0.0], np.cumsum(0.5 * (f[1:] + f[:-1]) * np.diff(t))])  # temperature (the
        return o['amplitude'] * np.sin(2 * np.pi * phase + o['phase_rad'])  # regulator's tempco, aliased)
    if kind == 'scale_warmup':   # a scale factor settling after power-up (the drive amplitude or the reference
        u = f_imu if o['sensor'] == 'accel' else w_imu  # settling), by time, whatever the die's temperature does
        return o['per_unit'] * np.exp(-t / o['tau_s']) * u[:, j]
    if kind == 'mag_field':      # a gyro sensitive to the magnetic field (its drive's or sense's magnet, a
        C = Scenario.attitude(None, ang)  # ferromagnetic package): a bias along the Earth's field as the axis sees
        m = np.array([math.cos(o['decl_rad']), math.sin(o['decl_rad']), 0.0])  # it. Only the field's horizontal
        return o['amplitude'] * mtv(C, np.broadcast_to(m, (len(t), 3)))[:, j]  # part: its vertical part turns with
        # the axis as gravity does, a g-sensitivity the catalog has (a diagnosis that selects g_sensitivity for it is
        # right), so the case asks only what no catalog term has. amplitude: the horizontal field's share
    if kind == 'cross_abs_rate':  # play in the gyro's mount: a rotation about another axis k tilts the package the
        return o['coefficient'] * np.abs(w_imu[:, AX.index(o['input_axis'])])  # same way whichever its sense, so the
        # axis reads c |w_k| (even in w_k; the catalog's asymmetry is on the axis' own rate, its cross-coupling a product)
    if kind == 'temp_ripple':    # a quadrature leak whose demodulation phase turns with the die temperature: a bias
        return o['amplitude'] * np.sin(o['k_rad_per_C'] * (T - o['T0_C']) + o['phase_rad'])  # oscillating in T,
        # 0.5-1 period over the range (no polynomial in T of the catalog's degree follows it)
    if kind == 'thermal_gradient':  # a bias in the gradient between the die and the board it sits on (the board's
        a = 1.0 - math.exp(-1.0 / (o['fs_hz'] * o['tau_s']))  # copper lags the die by tau, and the difference bends the
        lag = np.empty_like(T)   # package): T minus a first-order lag of T, scaled to amp at its largest over the run.
        acc = T[0]               # Not the catalog's temp_rate (the rate itself: the two agree only while a ramp
        for i in range(len(T)):  # has run much longer than tau) nor its temp_hysteresis (a level set by the last
            acc += a * (T[i] - acc)  # turn, constant between turns)
            lag[i] = acc
        g = T - lag
        m = np.max(np.abs(g))
        return o['amplitude'] * g / m if m > 0 else np.zeros_like(t)
    if kind == 'k2_temp':        # a second-order scale nonlinearity that moves with the die temperature (the
        u = f_imu if o['sensor'] == 'accel' else w_imu  # suspension's stiffening varies with T): u_j^2 (T - T_mid);
        return o['coefficient'] * (T - o['T_mid_C']) / o['half_span_C'] * u[:, j] ** 2  # the catalog's k2 is
        # constant, its scale_temp linear in u
    if kind == 'w_cross_cubic':  # a gyro bias in its own rate times another axis' rate squared (the drive mode's
        k = AX.index(o['input_axis'])  # frequency pulled by the centrifugal load of a rotation about k): w_j w_k^2,
        return o['coefficient'] * w_imu[:, j] * w_imu[:, k] ** 2  # zero on every single-axis rotation (the catalog's
        # k3 is w_j^3, its cross-coupling w_j w_k)
    if kind == 'w_dot_cross':    # a gyro bias in the angular acceleration about ANOTHER axis k (the drive mass'
        k = AX.index(o['input_axis'])  # inertia torqued by the table's angular acceleration: an 'angular
        return o['coefficient'] * wd_imu[:, k]  # acceleration sensitivity'; the catalog's timing reads the axis' own
        # acceleration only (latency: -tau wdot_j), its size_effect is the accelerometers'
    if kind == 'temp_exp':       # a leakage current doubling every d degrees (Arrhenius): a bias 0 at the coldest
        e = np.exp2((T - o['T_hi_C']) / o['double_C'])  # plateau and amp at the hottest, convex beyond any cubic in
        e0 = 2.0 ** ((o['T_lo_C'] - o['T_hi_C']) / o['double_C'])  # T over 6-12 doublings
        return o['amplitude'] * (e - e0) / (1.0 - e0)
    if kind == 'w_cross_pair':   # accel bias in the product of the rates about its two CROSS axes (a proof mass'
        k, l = [i for i in range(3) if i != j]  # product of inertia): w_k w_l. The catalog's size_effect on axis j
        return o['coefficient'] * w_imu[:, k] * w_imu[:, l]  # has w_j w_k and w_k^2 + w_l^2 with one lever arm,
        # never w_k w_l
    if kind == 'f_memory':       # accel bias set by the sign of the specific force along its axis at the last pose
        u = f_imu[:, j]          # that loaded it (> threshold): mechanical hysteresis of the proof mass' stops; it
        loaded = np.abs(u) > o.get('threshold_m_s2', 5.0)  # persists through poses that leave the axis level
        last = np.maximum.accumulate(np.where(loaded, np.arange(len(u)), -1))
        d = np.where(last >= 0, np.sign(u[np.maximum(last, 0)]), 0.0)
        return o['amplitude'] * d
    raise ValueError('unknown out-of-catalog kind %r' % kind)


# ----------------------------------------------------------------------------------------------------
# Generation.
# ----------------------------------------------------------------------------------------------------
# Detectability: how far above the noise an effect stands on THIS scenario once the base model
# (model-thermal: bias, scale, misalign, bias_temp t1-t2, scale_temp t1) has absorbed what it can.
# Chunk means (segments cut at 30 s) of the effect's own signal are projected off the base model's regressors
# (weighted by the chunk-mean noise variance: white N^2/T + flicker floor (0.664 B)^2 + RRW K^2 T/3); the SNR
# is sqrt(sum of weighted squared residuals) over the triad's three axes. It ignores the other effects of the
# case and within-chunk structure, so it is a guide (recall is also reported over effects with SNR >= 10).
def beyond_model_keys(sensor_json):
    out = []
    for s, ee in sensor_effects(sensor_json).items():
        for e, comps in ee.items():
            if e in STOCHASTIC or e in MODEL_THERMAL[s]:
                continue
            if any(v != 0.0 for k, v in comps.items() if k != 'tau_s'):
                out.append('%s.%s' % (s, e))
    return sorted(out)


def _chunks(scn, t, seg_idx):
    tau = t - scn.t0s[seg_idx]
    key = seg_idx.astype(np.int64) * 100000 + np.floor(tau / 30.0).astype(np.int64)
    _, inv, cnt = np.unique(key, return_inverse=True, return_counts=True)
    return inv, cnt


def _cmean(x, chunks):
    inv, cnt = chunks
    return np.bincount(inv, weights=x, minlength=len(cnt)) / cnt


def effect_snr(key, case, scn, t, chunks, inputs, die, Tdot, d, T_ref, f_ref, w_ref):
    s, e = key.split('.', 1)
    eff = sensor_effects(case['sensor'])[s]
    f_i, w_i, wd_i, _, _, _ = inputs[s]
    u = f_i if s == 'accel' else w_i
    if e == 'timing':
        f0, w0, _, _, _, _ = scn.imu_inputs(t)
        sig = u - (f0 if s == 'accel' else w0)
    else:
        sig = deterministic_output({e: eff[e]}, u, f_i, w_i, wd_i, die, Tdot, d, T_ref, s) - u
    return signal_snr(sig, s, case, scn, chunks, die, T_ref, f_ref, w_ref)


def signal_snr(sig, s, case, scn, chunks, die, T_ref, f_ref, w_ref):
    """The detectability of an additive signal sig (n x 3, SI) on sensor s: chunk means projected off the base
    model's columns, weighted by the chunk-mean noise variance (see above)."""
    eff = sensor_effects(case['sensor'])[s]
    uref = f_ref if s == 'accel' else w_ref
    tau = die - T_ref
    inv, cnt = chunks
    T = cnt / scn.fs
    total = 0.0
    for j, aj in enumerate(AX):
        cols = [np.ones_like(tau), tau, tau * tau, uref[:, j], tau * uref[:, j]] + [uref[:, k] for k in range(3) if k != j]
        X = np.column_stack([_cmean(c, chunks) for c in cols])
        z = _cmean(sig[:, j], chunks)
        N = eff.get('white_noise', {}).get(aj, 0.0)
        B = eff.get('bias_instability', {}).get(aj, 0.0)
        K = eff.get('rate_random_walk', {}).get(aj, 0.0)
        var = N * N / T + (0.664 * B) ** 2 + K * K * T / 3 + float(case['sensor'][s]['lsb']) ** 2 / 12 / cnt
        for x in case.get('noise_extra', []):
            if x['sensor'] == s and x['axis'] == aj:
                if x['kind'] == 'gm':
                    var = var + gm_avar(x['sigma'], x['tau_s'], T)
                elif x['kind'] == 'flicker':
                    var = var + (0.664 * x['B']) ** 2
                elif x['kind'] == 'rrw':
                    var = var + x['K'] ** 2 * T / 3
        w = 1.0 / np.maximum(var, 1e-300)
        sw = np.sqrt(w)
        beta, *_ = np.linalg.lstsq(X * sw[:, None], z * sw, rcond=None)
        r = z - X @ beta
        total += float(np.sum(w * r * r))
    return math.sqrt(total)


def generate(case, out_dir, fmt='csv'):
    """case: {'scenario': spec, 'sensor': sensor JSON, 'ooc': [...], 'noise_extra': [...], 'seed': int}."""
    seed = int(case['seed'])
    ss = np.random.SeedSequence(seed)
    r_scn, r_noise, r_ton, r_meas = [np.random.default_rng(s) for s in ss.spawn(4)]
    scn = build_scenario(r_scn, case['scenario'])
    sensor = case['sensor']
    eff = sensor_effects(sensor)
    thermal = sensor.get('thermal', {})
    T_ref = float(sensor.get('T_ref_C', 25.0))
    fs = scn.fs
    n = int(round(scn.duration * fs))
    t = np.arange(n) / fs
    air, die, Tdot = thermal_profile(scn, t, thermal)
    d = hysteresis_direction(die, float(thermal.get('hysteresis_threshold_C', 0.5)))

    # references: the reported (nominal, error-free) kinematics at the log time, platform = nominal IMU frame
    f_ref, w_ref, _, ang, rate, seg_idx = scn.kinematics(t)
    inputs = {}
    for s in ('accel', 'gyro'):
        tm = eff[s].get('timing', {})
        ts = t - tm.get('latency_s', 0.0) - tm.get('ppm', 0.0) * 1e-6 * t  # the sample stamped t reads the input at ts
        inputs[s] = scn.imu_inputs(ts)
    # detectability of each beyond-model effect (and, for single cases, scale it up to a target SNR)
    snr = {}
    if case.get('score_snr', True):
        chunks = _chunks(scn, t, seg_idx)
        for key in beyond_model_keys(sensor):
            snr[key] = effect_snr(key, case, scn, t, chunks, inputs, die, Tdot, d, T_ref, f_ref, w_ref)
        tgt = case.get('target_snr')
        if tgt:
            for key, v in list(snr.items()):
                goal = tgt[key] if isinstance(tgt, dict) else tgt
                if 0 < v < goal:
                    s_, e_ = key.split('.', 1)
                    comps = case['sensor']['effects'][key]
                    for c in comps:
                        if not c.startswith('_') and c != 'enabled':
                            comps[c] = float(comps[c]) * goal / v
                    eff = sensor_effects(sensor)
                    if e_ == 'timing':
                        tm = eff[s_]['timing']
                        inputs[s_] = scn.imu_inputs(t - tm.get('latency_s', 0.0) - tm.get('ppm', 0.0) * 1e-6 * t)
                    snr[key] = effect_snr(key, case, scn, t, chunks, inputs, die, Tdot, d, T_ref, f_ref, w_ref)
    y = {}
    realised = {}
    for s in ('accel', 'gyro'):
        e = eff[s]
        f_i, w_i, wd_i, ang_s, _, _ = inputs[s]
        u = f_i if s == 'accel' else w_i
        ys = deterministic_output(e, u, f_i, w_i, wd_i, die, Tdot, d, T_ref, s)
        for o in case.get('ooc', []):
            if o['sensor'] == s:
                sig = np.zeros_like(ys)
                if o['kind'] == 'zero_burst':
                    # acts on the counts below; its SNR is taken on the noise-free output it clears
                    jj = AX.index(o['axis'])
                    sig[:, jj] = -ys[:, jj] * zero_burst_mask(o, t)
                elif o['kind'] == 'stuck_bit':
                    # acts on the counts below; its SNR is taken on what it does on average to the noisy samples
                    # (white noise dithers the bit: a bit well under the sample noise is only a constant bias)
                    jj = AX.index(o['axis'])
                    lsb_s = float(sensor[s]['lsb'])
                    if o['bit'] is None:
                        o['bit'] = int(max(0, round(math.log2(abs(o.pop('amplitude')) / lsb_s))))
                    sd = e.get('white_noise', {}).get(o['axis'], 0.0) * math.sqrt(fs)
                    rdraw = np.random.default_rng(seed + 7)
                    acc_ = np.zeros(len(t))
                    for _ in range(8):
                        c0 = np.round((ys[:, jj] + sd * rdraw.standard_normal(len(t))) / lsb_s).astype(np.int64)
                        acc_ += ((c0 & ~(1 << o['bit'])) - c0) * lsb_s
                    sig[:, jj] = acc_ / 8
                else:
                    sig[:, AX.index(o['axis'])] = ooc_signal(o, t, ang_s, w_i, f_i, die, Tdot, wd_i)
                    ys += sig
                if case.get('score_snr', True):
                    # what of the out-of-catalog term the base model cannot absorb: below DETECTABLE_SNR no
                    # diagnosis can be asked to name its axis (battery.py scores ooc cases over both)
                    snr['ooc:%s.%s' % (s, o['axis'])] = signal_snr(sig, s, case, scn, chunks, die, T_ref, f_ref, w_ref)
        y[s] = ys

    # noise and output stage, per axis in order: + turn-on + noise -> quantization -> saturation -> counts
    streams = {k: np.random.default_rng(c) for k, c in zip(
        [(s, j) for s in ('accel', 'gyro') for j in range(3)], np.random.SeedSequence(seed + 1).spawn(6))}
    counts = {}
    dt = 1.0 / fs
    for s in ('accel', 'gyro'):
        e = eff[s]
        lsb = float(sensor[s]['lsb'])
        bits = int(sensor[s].get('bits', 16))
        rng_ = float(sensor[s].get('range', 0.0)) or lsb * 2 ** (bits - 1)
        cs = np.empty((n, 3), dtype=np.int64)
        for j, aj in enumerate(AX):
            rg = streams[(s, j)]
            v = y[s][:, j]
            ton = e.get('turn_on_bias', {}).get(aj, 0.0)
            if ton:
                tb = r_ton.standard_normal() * ton
                realised['%s.turn_on_bias.%s' % (s, aj)] = tb
                v = v + tb
            N = e.get('white_noise', {}).get(aj, 0.0)
            sig = N * math.sqrt(fs)
            scale = np.ones(n)
            for x in case.get('noise_extra', []):
                if x['sensor'] == s and x['axis'] == aj and x['kind'] == 'temp_white':
                    # out-of-catalog stochastic: white level grows with temperature
                    scale = np.maximum(0.1, 1 + x['per_C'] * (die - T_ref))
            if sig > 0:
                v = v + sig * scale * rg.standard_normal(n)
            B = e.get('bias_instability', {}).get(aj, 0.0)
            if B > 0:
                v = v + flicker_process(rg, n, dt, B, e['bias_instability'].get('tau_s', 100.0))
            K = e.get('rate_random_walk', {}).get(aj, 0.0)
            if K > 0:
                v = v + np.cumsum(K * math.sqrt(dt) * rg.standard_normal(n)) - K * math.sqrt(dt) * 0
            for x in case.get('noise_extra', []):
                if x['sensor'] == s and x['axis'] == aj:
                    if x['kind'] == 'gm':
                        v = v + gm_process(rg, n, dt, x['sigma'], x['tau_s'])
                    elif x['kind'] == 'flicker':
                        v = v + flicker_process(rg, n, dt, x['B'], x['tau_s'])
                    elif x['kind'] == 'rrw':
                        v = v + np.cumsum(x['K'] * math.sqrt(dt) * rg.standard_normal(n))
            q = e.get('quantization', {}).get(aj, 0.0)
            if q > 0:
                v = q * np.round(v / q)
            L = e.get('saturation', {}).get(aj, 0.0)
            if L > 0:
                v = np.clip(v, -L, L)
            c = np.round(v / lsb)
            lim_hi = min(2 ** (bits - 1) - 1, math.floor(rng_ / lsb))
            lim_lo = max(-2 ** (bits - 1), -math.floor(rng_ / lsb))
            cs[:, j] = np.clip(c, lim_lo, lim_hi).astype(np.int64)
            for o in case.get('ooc', []):
                if o['sensor'] == s and o['axis'] == aj and o['kind'] == 'stuck_bit':
                    cs[:, j] &= ~(1 << o['bit'])  # two's complement: the bit reads 0 in either sign
                if o['sensor'] == s and o['axis'] == aj and o['kind'] == 'zero_burst':
                    cs[zero_burst_mask(o, t), j] = 0
        counts[s] = cs

    sim = case.get('scenario', {})
    temp_noise = sim.get('temp_noise_C', 0.02)
    temp_C = np.round((die + temp_noise * r_meas.standard_normal(n)) / 0.01) * 0.01  # 0.01 degC sensor resolution
    chamber_C = air + sim.get('chamber_noise_C', 0.05) * r_meas.standard_normal(n)
    log_table = sim.get('log_table', True)
    enc = math.radians(sim.get('encoder_noise_deg', 0.0))
    tbl = None
    if log_table:
        tang = np.mod(ang + np.pi, 2 * np.pi) - np.pi
        if enc > 0:
            tang = tang + enc * r_meas.standard_normal(tang.shape)
        tbl = (tang, rate)
    meta = {
        'format': 'imuforge-log', 'format_version': 1, 'serial': 'BLIND-%d' % seed,
        'sample_rate_hz': fs, 'accel_lsb_mps2': float(sensor['accel']['lsb']), 'gyro_lsb_rad_s': float(sensor['gyro']['lsb']),
        'accel_bits': int(sensor['accel'].get('bits', 16)), 'gyro_bits': int(sensor['gyro'].get('bits', 16)),
        'latitude_deg': scn.lat, 'height_m': scn.h, 'gravity_mps2': scn.g, 'table_axes': 3 if log_table else 0,
        'source': 'blindgen', 'frame': 'NED',
    }
    segment_col = seg_idx.astype(np.int64)
    os.makedirs(out_dir, exist_ok=True)
    path = os.path.join(out_dir, 'log.' + ('bin' if fmt == 'bin' else 'csv'))
    keep = row_loss_keep(sim.get('row_loss'), seed, t)
    if keep is not None:  # rows the logger never got (a USB or bus hiccup): gone from every column, stamps kept
        k_ = keep
        tbl_k = (tbl[0][k_], tbl[1][k_]) if tbl is not None else None
        write_log(path, meta, t[k_], segment_col[k_], temp_C[k_], chamber_C[k_], f_ref[k_], w_ref[k_],
                  counts['accel'][k_], counts['gyro'][k_], tbl_k, fmt)
    else:
        write_log(path, meta, t, segment_col, temp_C, chamber_C, f_ref, w_ref, counts['accel'], counts['gyro'], tbl, fmt)
    n_lost = 0 if keep is None else int(n - np.count_nonzero(keep))
    segs = [{'id': i, 't0_s': s.t0, 't1_s': s.t0 + s.dur, 'kind': s.kind, 'label': s.label} for i, s in enumerate(scn.segments)]
    return {'rows': n - n_lost, 'rows_lost': n_lost, 'duration_s': scn.duration, 'realised': realised, 'log': path, 'snr': snr,
            'lever_arm_m': scn.r.tolist(), 'mount_error_rad': scn.mount_err.tolist(), 'gravity_mps2': scn.g,
            'segments': segs, 'T_die_range_C': [float(die.min()), float(die.max())],
            '_arrays': {'t': t, 'seg': segment_col, 'die': die, 'Tdot': Tdot, 'd': d, 'f': f_ref, 'w': w_ref, 'ang': ang}}


def row_loss_keep(spec, seed, t):
    """The rows a lossy link delivers: spec {'interval_s': mean time between losses, 'max_rows': longest loss}.
    Losses of 1 to max_rows rows (log-uniform: most short, a few long) at Poisson times; None keeps every row."""
    if not spec:
        return None
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), 31]))
    n = len(t)
    k = int(rng.poisson(t[-1] / float(spec['interval_s'])))
    keep = np.ones(n, dtype=bool)
    lens = np.exp(rng.uniform(0.0, math.log(float(spec['max_rows'])), k)).astype(int) + 1
    for i0, ln in zip(rng.integers(1, n - 1, k), lens):
        keep[i0:min(i0 + ln, n - 1)] = False  # the first and last rows stay: the run's span is known
    return keep


def write_log(path, meta, t, seg, temp, chamber, f, w, acc, gyr, tbl, fmt):
    tmp = path + '.part'
    if fmt == 'bin':
        md = ''.join('%s=%s\n' % (k, _meta_val(v)) for k, v in meta.items() if k not in ('format', 'format_version'))
        md = 'format=imuforge-log\nformat_version=1\n' + md
        mdb = md.encode()
        n = len(t)
        dt = np.dtype([('t', '<f8'), ('seg', '<i4'), ('flags', '<u4'), ('temp', '<f8'), ('ch', '<f8'), ('f', '<f8', 3),
                       ('w', '<f8', 3), ('raw', '<i4', 6), ('ang', '<f8', 3), ('rate', '<f8', 3)])
        assert dt.itemsize == 152
        rec = np.zeros(n, dtype=dt)
        rec['t'], rec['seg'], rec['flags'], rec['temp'], rec['ch'] = t, seg, 1, temp, chamber
        rec['f'], rec['w'] = f, w
        rec['raw'][:, :3], rec['raw'][:, 3:] = acc, gyr
        if tbl is not None:
            rec['ang'], rec['rate'] = tbl
        else:
            rec['ang'], rec['rate'] = np.nan, np.nan
        with open(tmp, 'wb') as o:
            o.write(b'IMUFLOG1')
            o.write(np.array([1, 152], '<u4').tobytes())
            o.write(np.array([n], '<u8').tobytes())
            o.write(np.array([len(mdb)], '<u4').tobytes())
            o.write(mdb)
            o.write(rec.tobytes())
    else:
        cols = ['t_s', 'segment', 'temp_C', 'chamber_C', 'f_ref_x', 'f_ref_y', 'f_ref_z', 'w_ref_x', 'w_ref_y', 'w_ref_z',
                'ax', 'ay', 'az', 'gx', 'gy', 'gz']
        arrs = [t[:, None], seg[:, None], temp[:, None], chamber[:, None], f, w, acc, gyr]
        fmts = ['%.15g', '%d', '%.6g', '%.6g'] + ['%.17g'] * 6 + ['%d'] * 6
        if tbl is not None:
            for i in range(3):
                cols += ['tbl_angle_%d' % i, 'tbl_rate_%d' % i]
                arrs += [tbl[0][:, i:i + 1], tbl[1][:, i:i + 1]]
                fmts += ['%.17g', '%.17g']
        # one row format string; written in chunks to bound memory
        rowfmt = ','.join(fmts) + '\n'
        n = len(t)
        with open(tmp, 'w') as o:
            for k, v in meta.items():
                o.write('# %s=%s\n' % (k, _meta_val(v)))
            o.write(','.join(cols) + '\n')
            CH = 20000
            for s in range(0, n, CH):
                block = np.hstack([a[s:s + CH].astype(object) if False else a[s:s + CH] for a in arrs])
                # integer columns keep exact values when written with %d from float64 (|counts| < 2^53)
                o.write(''.join(rowfmt % tuple(r) for r in block.tolist()))
    os.replace(tmp, path)


def _meta_val(v):
    if isinstance(v, float):
        return 'nan' if math.isnan(v) else repr(v)
    return str(v)


# ----------------------------------------------------------------------------------------------------
# Case construction.
MODEL_THERMAL = {'accel': {'bias': None, 'scale': None, 'misalign': None, 'bias_temp': 2, 'scale_temp': 1},
                 'gyro': {'bias': None, 'scale': None, 'misalign': None, 'bias_temp': 2, 'scale_temp': 1}}

# Beyond-model candidates (model-thermal) and their representative magnitudes per sensor class.
# Values from docs/examples/sensor-{consumer,automotive,tactical}.json where the file has the effect;
# otherwise by analogy (same ratio to the class' scale/misalignment errors), marked '~'.
# Each entry: (component templates, magnitude per class {consumer, automotive, tactical}).
TYPICAL = {
    'accel.misalign_temp': (['xy.t1', 'xz.t1', 'yx.t1', 'yz.t1', 'zx.t1', 'zy.t1'], {'consumer': 5e-5, 'automotive': 1e-5, 'tactical': 2e-6}),   # ~ (tactical from file)
    'accel.scale_nonlinearity': (['x.k2', 'y.k2', 'z.k2'], {'consumer': 2.5e-4, 'automotive': 1.02e-5, 'tactical': 1.3e-6}),
    'accel.scale_asymmetry': (['x', 'y', 'z'], {'consumer': 3e-3, 'automotive': 3e-4, 'tactical': 5e-5}),                         # ~
    'accel.cross_coupling': (['xy', 'xz', 'yx', 'yz', 'zx', 'zy'], {'consumer': 6e-5, 'automotive': 1e-5, 'tactical': 2.04e-6}),   # ~ c/a
    'accel.size_effect': (['x.rx', 'y.ry', 'z.rz', 'x.ry', 'y.rx', 'z.rx', 'z.ry'], {'consumer': 2e-3, 'automotive': 5e-3, 'tactical': 2.45e-3}),
    'accel.temp_hysteresis': (['x', 'y', 'z'], {'consumer': 4e-3, 'automotive': 1e-3, 'tactical': 1.5e-4}),
    'accel.temp_rate': (['x', 'y', 'z'], {'consumer': 2e-3, 'automotive': 8e-4, 'tactical': 1.5e-4}),                              # ~ c/a
    'accel.timing': (['latency_s', 'ppm'], {'consumer': (2e-3, 50.0), 'automotive': (5e-4, 20.0), 'tactical': (3e-4, 5.0)}),
    'gyro.misalign_temp': (['xy.t1', 'xz.t1', 'yx.t1', 'yz.t1', 'zx.t1', 'zy.t1'], {'consumer': 5e-5, 'automotive': 1e-5, 'tactical': 2e-6}),    # ~
    'gyro.scale_nonlinearity': (['x.k2', 'y.k2', 'z.k2', 'x.k3', 'y.k3', 'z.k3'], {'consumer': 1.05e-4, 'automotive': 1.146e-4, 'tactical': 1.05e-5}),
    'gyro.scale_asymmetry': (['x', 'y', 'z'], {'consumer': 2e-3, 'automotive': 4e-4, 'tactical': 5e-5}),                          # c ~
    'gyro.cross_coupling': (['xy', 'xz', 'yx', 'yz', 'zx', 'zy'], {'consumer': 5e-3, 'automotive': 2e-3, 'tactical': 5.73e-4}),   # c, a ~
    'gyro.g_sensitivity': (['xx', 'yy', 'zz', 'xy', 'xz', 'yx', 'yz', 'zx', 'zy'], {'consumer': 1.5e-4, 'automotive': 1.5e-5, 'tactical': 4e-6}),
    'gyro.g2_sensitivity': (['x.xy', 'x.yz', 'x.zx', 'y.xy', 'y.yz', 'y.zx', 'z.xy', 'z.yz', 'z.zx'], {'consumer': 1e-7, 'automotive': 1.8e-8, 'tactical': 9e-10}),  # c ~
    'gyro.temp_hysteresis': (['x', 'y', 'z'], {'consumer': 3e-4, 'automotive': 8.7e-5, 'tactical': 3.5e-6}),                       # c ~
    'gyro.temp_rate': (['x', 'y', 'z'], {'consumer': 3.5e-4, 'automotive': 5e-5, 'tactical': 3.5e-6}),
    'gyro.timing': (['latency_s', 'ppm'], {'consumer': (2e-3, 50.0), 'automotive': (5e-4, 20.0), 'tactical': (3e-4, 5.0)}),
}
# IEEE 1431 g^2 squares (not in the catalog before issue 12): drawn only when asked (--g2-squares).
G2_SQUARES = ['x.xx', 'x.yy', 'x.zz', 'y.xx', 'y.yy', 'y.zz', 'z.xx', 'z.yy', 'z.zz']
# Effects the catalog gained after the suites above were fixed: drawn only where a case asks for the whole catalog
# (full_catalog), so that every earlier seed still draws what it drew. IEEE 1293's cross-axis nonlinearity (stop
# 55) at the magnitudes of the class' own k2 (by analogy, '~').
TYPICAL_LATER = {
    'accel.cross_axis_nonlinearity': (['x.yy', 'x.zz', 'x.yz', 'y.xx', 'y.zz', 'y.zx', 'z.xx', 'z.yy', 'z.xy'],
                                      {'consumer': 2.5e-4, 'automotive': 1.02e-5, 'tactical': 1.3e-6}),   # ~
}
CANDIDATES = sorted(TYPICAL)
CANDIDATES_ALL = sorted(list(TYPICAL) + list(TYPICAL_LATER))
CLASSES = ['consumer', 'automotive', 'tactical']
STOCH_AXES = ['accel.x', 'accel.y', 'accel.z', 'gyro.x', 'gyro.y', 'gyro.z']


def load_json(path):
    with open(path) as f:
        return json.load(f)


def repo_root():
    return os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', '..'))


def class_sensor(cls):
    return load_json(os.path.join(repo_root(), 'docs', 'examples', 'sensor-%s.json' % cls))


def in_model(sensor, effect, comp):
    m = MODEL_THERMAL[sensor]
    if effect not in m:
        return False
    order = m[effect]
    if order is None:
        return True
    p = int(comp.split('.t')[1])
    return p <= order


def base_only(sensor_json):
    """The class sensor with every beyond-model deterministic effect removed (and order > model dropped)."""
    s = json.loads(json.dumps(sensor_json))
    eff = {}
    for key, comps in s['effects'].items():
        sen, e = key.split('.', 1)
        if e in STOCHASTIC:
            eff[key] = comps
        elif e in MODEL_THERMAL[sen]:
            c2 = {k: v for k, v in comps.items() if k.startswith('_') or k == 'enabled' or in_model(sen, e, k)}
            eff[key] = c2
    s['effects'] = eff
    return s


def draw_effect(rng, key, cls, scale=1.0, g2_squares=False):
    comps, mag = TYPICAL[key] if key in TYPICAL else TYPICAL_LATER[key]
    if key.endswith('.timing'):
        lat, ppm = mag[cls]
        out = {}
        which = rng.choice(['latency', 'ppm', 'both'])
        if which in ('latency', 'both'):
            out['latency_s'] = float(lat * scale * rng.uniform(0.5, 2.0))
        if which in ('ppm', 'both'):
            out['ppm'] = float(ppm * scale * rng.uniform(0.5, 2.0) * rng.choice([-1, 1]))
        return out
    pool = list(comps)
    if key == 'gyro.g2_sensitivity' and g2_squares:
        pool += G2_SQUARES
    k = int(rng.integers(1, min(3, len(pool)) + 1))
    chosen = rng.choice(pool, size=k, replace=False)
    m = mag[cls] * scale
    return {str(c): float(m * math.exp(rng.uniform(math.log(0.5), math.log(2.0))) * rng.choice([-1, 1])) for c in chosen}


def default_scenario(rng, size='full', max_rate_dps=300.0):
    """The scenario of a case. Rates stay below 80 % of the gyro's range (a saturated gyro is another test).
    Plateaus are chamber setpoint steps (slew-limited), visited in an order that reverses at least once
    (hysteresis needs both heating and cooling history); one static chamber ramp ends the run."""
    temps = [float(x) for x in rng.choice([-10, 0, 10, 25, 40, 55, 65], size=4 if size == 'full' else 3, replace=False)]
    if temps == sorted(temps) or temps == sorted(temps, reverse=True):
        temps[-1], temps[-2] = temps[-2], temps[-1]
    top = min(300.0, 0.8 * max_rate_dps)
    common = {'sample_rate_hz': 100, 'plateaus_C': temps, 'latitude_deg': float(rng.uniform(-60, 60)),
              'height_m': float(rng.uniform(0, 1500)), 'log_table': True, 'encoder_noise_deg': 0.0,
              'slew_C_per_min': 10.0, 'air_tau_s': 60.0, 'ramp_C_per_min': 0.0, 'final_ramp': 2.0}
    if size == 'full':
        common.update({'first_soak_s': 300, 'soak_s': 150, 'n_az': 2, 'n_tilt': 8, 'rate_dwell_s': 6, 'dwell_s': 5,
                       'rates_dps': [round(top / 10), round(top / 3), round(top)]})
    elif size == 'varied':
        # another lab's schedule: the diagnosis must not lean on the shape of the two above. 2-5 plateaus in any
        # order (monotonic allowed: no guaranteed reversal), chamber ramps between them in half the cases,
        # a short first soak (a short Allan record), 2.5-10 s dwells, 2-4 rate levels, sines in half,
        # encoder noise on the logged angles
        n_pl = int(rng.integers(2, 6))
        common['plateaus_C'] = [float(x) for x in rng.choice([-20, -10, 0, 10, 25, 40, 55, 70], size=n_pl, replace=False)]
        top_v = float(rng.uniform(0.4, 0.8)) * max_rate_dps
        n_lv = int(rng.integers(2, 5))
        ramp = float(rng.choice([0.0, 1.0, 2.0]))
        common.update({'first_soak_s': float(rng.uniform(60, 200)), 'soak_s': float(rng.uniform(40, 180)),
                       'n_az': int(rng.integers(1, 4)), 'n_tilt': int(rng.integers(3, 13)),
                       'dwell_s': float(rng.uniform(2.5, 10)), 'rate_dwell_s': float(rng.uniform(3, 10)),
                       'rates_dps': [round(top_v * f) for f in np.geomspace(0.08, 1.0, n_lv)],
                       'sines': bool(rng.integers(0, 2)), 'ramp_C_per_min': ramp,
                       'final_ramp': float(rng.choice([0.0, 1.0, 3.0])),
                       'slew_C_per_min': float(rng.uniform(3, 15)), 'air_tau_s': float(rng.uniform(20, 200)),
                       'encoder_noise_deg': float(rng.choice([0.0, 0.001, 0.005]))})
    else:
        common.update({'first_soak_s': 120, 'soak_s': 60, 'n_az': 1, 'n_tilt': 6, 'rate_dwell_s': 4, 'dwell_s': 4,
                       'rates_dps': [round(top / 5), round(top)]})
    return common


def seg_noise(sensor_json, key, T_seg=5.0):
    """Noise of a T_seg-second mean on one axis (white + flicker floor), SI: the yardstick for magnitudes of
    the out-of-catalog effects."""
    s, a = key.split('.')
    e = sensor_effects(sensor_json)[s]
    N = e.get('white_noise', {}).get(a, 0.0)
    B = e.get('bias_instability', {}).get(a, 0.0)
    lsb = float(sensor_json[s]['lsb'])
    return math.sqrt(N * N / T_seg + (0.664 * B) ** 2 + lsb * lsb / 12 / (T_seg * 100))


OOC_KINDS = ['heading', 'bias_step', 'w_cubed', 'abs_rate', 'periodic', 'g_cubed', 'angle2', 'rate_memory']
# written at stop 44, after every change to the diagnosis until then (suite 'unseen'); stop 44's drift and settling
# checks were then developed on them, so from stop 44 on they are a development set like the eight above
OOC_KINDS_UNSEEN = ['warmup', 'drift']
# written at stop 46 and first run on the stop-45 binary (suite 'unseen2'): functions of the inputs that none of
# the kinds above has (an accel bias odd in the rate, a gyro bias in another axis' rate squared, a bias step at a
# temperature, a scale that moves with time)
OOC_KINDS_UNSEEN2 = ['rate_odd', 'cross_w2', 'temp_step', 'scale_age']
# written at stop 47 and first run on the stop-46 binary (suite 'unseen3'): gyro terms that mix two inputs or
# have no polynomial shape (a g-sensitivity moving with temperature, a g-dependent scale factor, a bias that flips
# with the direction of rotation)
OOC_KINDS_UNSEEN3 = ['g_temp', 'w_times_f', 'sign_rate']
# written at stop 54 and first run on the stop-53 binary (suite 'unseen4'): a bias even in the die's temperature
# rate and an accel creep after each pose change. Its third kind, an accel bias in another axis' f² (IEEE 1293's
# K_pp), became the catalog's cross_axis_nonlinearity at stop 55 and left the out-of-catalog kinds.
OOC_KINDS_UNSEEN4 = ['abs_temp_rate', 'creep']
# written at stop 56 and first run on the stop-55 binary (suite 'unseen5'): a bias while the table turns at any
# rate, a bias bump about one die temperature, and an accel bias that remembers which way the last pose loaded
# its axis
OOC_KINDS_UNSEEN5 = ['motor_on', 'temp_bump', 'f_memory']
# written at stop 57 and first run on the stop-56 binary (suite 'unseen6'): a scale bump about one die temperature,
# an accel bias in its own axis' rate times its own specific force, a gyro bias that settles after each rotation
OOC_KINDS_UNSEEN6 = ['scale_bump', 'f_times_w', 'spin_settle']
# written at stop 58 and first run on the stop-57 binary (suite 'unseen7'): an accel bias in f_x f_y f_z, a gyro
# bias in |f_j|, a bias that lags the table motor's heat
OOC_KINDS_UNSEEN7 = ['f_triple', 'abs_g', 'motor_heat']
# written at stop 59 and first run on the stop-58 binary (suite 'unseen8'): a bias at one speed of the table (a
# structural resonance the motor excites), a bias following the turns the table has wound up about the vertical
# (a cable without a slip ring strains the mount), an accel output that compresses beyond a knee (odd, zero below it)
OOC_KINDS_UNSEEN8 = ['rate_bump', 'cable_wrap', 'knee']
# written at stop 60 and first run on the stop-59 binary (suite 'unseen9'): the package slipping once on its mount
# (a misalignment step), random telegraph (burst) noise on the bias, the chamber's compressor shaking the fixture
# while it cools (a bias oscillating with its cycle, gated on the die cooling)
OOC_KINDS_UNSEEN9 = ['mount_slip', 'popcorn', 'compressor']
# written at stop 61 and first run on the stop-60 binary (suite 'unseen10'): a bias while the chamber heats (its
# heater loading the fixture's supply), isolated single-sample bit errors on the bus, an auto-ranging gyro whose
# scale jumps past a switch-over rate
OOC_KINDS_UNSEEN10 = ['heater_on', 'glitch', 'range_switch']
# written at stop 62 and first run on the stop-61 binary (suite 'unseen11'): the converter's integral nonlinearity
# periodic in the output code, a bias sawtooth in the die temperature (a coarse temperature sensor feeding the part's
# own compensation), one axis sampled later than the other two (a multiplexed converter)
OOC_KINDS_UNSEEN11 = ['inl_periodic', 'temp_saw', 'axis_skew']
# written at stop 63 and first run on the stop-62 binary (suite 'unseen12'): a scale factor that remembers which way
# the die's temperature last moved, a bias locked to the table motor's rotor (n lobes per turn), an accel reading
# another axis' specific force times the squared rate (the mount flexing under the centripetal load)
OOC_KINDS_UNSEEN12 = ['scale_temp_hyst', 'cogging', 'mount_flex']
# written at stop 64 and first run on the stop-63 binary (suite 'unseen13'): a scale factor that moves with the die's
# temperature rate, a bias while the outer axis stands within a window of angles (an intermittent contact), one bit
# of the output word stuck at 0
OOC_KINDS_UNSEEN13 = ['tdot_scale', 'angle_window', 'stuck_bit']
# written at stop 65 and first run on the stop-64 binary (suite 'unseen14'): a bias growing past a knee in the die
# temperature (the part's compensation table ending), bursts of rows reading exactly 0 (a register read while it was
# rewritten), a bias in the table's angular acceleration (the drive's current loading the supply)
OOC_KINDS_UNSEEN14 = ['temp_knee', 'zero_burst', 'drive_current']
# written at stop 66 and first run on the stop-65 binary (suite 'unseen15'): a gyro reading 0 within a band about zero
# rate (a zero-rate threshold), a slow sinusoidal bias whose frequency follows the die temperature (a regulator
# beating with the sample clock), a scale factor settling after power-up by time
OOC_KINDS_UNSEEN15 = ['dead_zone', 'beat_chirp', 'scale_warmup']
# written at stop 68 and first run on the stop-67 binary (suite 'unseen16'): a gyro biased along the Earth's magnetic
# field's horizontal part (its first version, with the vertical part, had two of three cases select g_sensitivity
# for that part, which is right: the catalog has it), a gyro reading the magnitude of the rate about another axis
# (mount play), a bias oscillating in the die temperature (a quadrature leak with a temperature-dependent phase)
OOC_KINDS_UNSEEN16 = ['mag_field', 'cross_abs_rate', 'temp_ripple']
# written at stop 71 and first run on the stop-70 binary (suite 'unseen17'): a bias in the gradient between the die and
# a board lagging it by minutes, a second-order scale nonlinearity moving with the die temperature, a gyro bias in its
# own rate times another axis' rate squared (zero on every single-axis rotation)
OOC_KINDS_UNSEEN17 = ['thermal_gradient', 'k2_temp', 'w_cross_cubic']
# written at stop 72 and first run on the stop-71 binary (suite 'unseen18'): a gyro bias in the angular acceleration
# about another axis, a bias doubling every 6-14 degC (leakage), an accel bias in the product of its two cross axes'
# rates
OOC_KINDS_UNSEEN18 = ['w_dot_cross', 'temp_exp', 'w_cross_pair']
# kinds that sit on one sensor only (their axis is drawn among that sensor's)
OOC_GYRO_ONLY = ('w_cubed', 'g_cubed', 'rate_memory', 'cross_w2', 'g_temp', 'w_times_f', 'sign_rate', 'spin_settle', 'abs_g',
                 'range_switch', 'dead_zone', 'mag_field', 'cross_abs_rate', 'w_cross_cubic', 'w_dot_cross')
OOC_ACCEL_ONLY = ('abs_rate', 'rate_odd', 'creep', 'f_memory', 'f_times_w', 'f_triple', 'knee', 'mount_flex', 'w_cross_pair')


def ooc_params(ooc_kind, amp, rng, scenario):
    """The parameters of one out-of-catalog bias of size amp (SI, at the largest input it sees)."""
    if ooc_kind == 'heading':
        return dict(amplitude=amp, phase_rad=float(rng.uniform(0, 2 * np.pi)))
    if ooc_kind == 'bias_step':
        return dict(amplitude=amp, t_step_s=None)  # filled once the duration is known
    if ooc_kind == 'w_cubed':
        return dict(coefficient=amp / (math.radians(max(scenario['rates_dps']))) ** 3)
    if ooc_kind == 'abs_rate':
        return dict(coefficient=amp / math.radians(max(scenario['rates_dps'])))
    if ooc_kind == 'periodic':
        return dict(amplitude=amp, period_s=float(rng.uniform(400, 900)), phase_rad=float(rng.uniform(0, 2 * np.pi)))
    if ooc_kind == 'g_cubed':
        return dict(coefficient=amp / 9.80665 ** 3)
    if ooc_kind == 'angle2':
        return dict(amplitude=amp, phase_rad=float(rng.uniform(0, 2 * np.pi)))
    if ooc_kind == 'rate_memory':
        return dict(amplitude=amp)
    if ooc_kind == 'warmup':
        return dict(amplitude=amp, tau_s=float(rng.uniform(120, 400)))
    if ooc_kind == 'temp_step':
        lo, hi = min(scenario['plateaus_C']), max(scenario['plateaus_C'])
        return dict(amplitude=amp, T0_C=float(lo + rng.uniform(0.3, 0.7) * (hi - lo)))
    if ooc_kind == 'rate_odd':
        return dict(coefficient=amp / math.radians(max(scenario['rates_dps'])), input_axis=str(rng.choice(list(AX))))
    if ooc_kind == 'cross_w2':
        return dict(coefficient=amp / math.radians(max(scenario['rates_dps'])) ** 2, input_axis=None)  # set per axis
    if ooc_kind == 'scale_age':
        return dict(per_unit=None, amplitude=amp, duration_s=None,  # scaled per sensor, duration once known
                    _top_rate=math.radians(max(scenario['rates_dps'])))
    if ooc_kind == 'g_temp':
        lo, hi = min(scenario['plateaus_C']), max(scenario['plateaus_C'])
        return dict(coefficient=amp / (9.80665 * max(0.5 * (hi - lo), 1.0)), T0_C=float(lo + rng.uniform(0.4, 0.6) * (hi - lo)))
    if ooc_kind == 'w_times_f':
        return dict(coefficient=amp / (9.80665 * math.radians(max(scenario['rates_dps']))))
    if ooc_kind == 'sign_rate':
        return dict(amplitude=amp, w0_rad_s=math.radians(float(rng.uniform(1.0, 4.0))))
    if ooc_kind == 'drift':
        return dict(amplitude=amp, duration_s=None)  # filled once the duration is known
    if ooc_kind == 'abs_temp_rate':  # amp at the chamber's slew rate
        return dict(coefficient=amp / (scenario['slew_C_per_min'] / 60.0))
    if ooc_kind == 'creep':  # amp: the transient just after a 1 g step
        return dict(coefficient=amp / 9.80665, tau_s=float(rng.uniform(5, 30)), fs_hz=float(scenario['sample_rate_hz']))
    if ooc_kind == 'motor_on':
        return dict(amplitude=amp, threshold_rad_s=math.radians(1.0))
    if ooc_kind == 'temp_bump':
        lo, hi = min(scenario['plateaus_C']), max(scenario['plateaus_C'])
        return dict(amplitude=amp, T0_C=float(lo + rng.uniform(0.2, 0.8) * (hi - lo)),
                    width_C=float(max(0.05 * (hi - lo), 1.0) * rng.uniform(1.0, 2.0)))
    if ooc_kind == 'f_memory':
        return dict(amplitude=amp, threshold_m_s2=5.0)
    if ooc_kind == 'scale_bump':  # amp at the largest input (1 g, or the top rate), at the bump's peak
        lo, hi = min(scenario['plateaus_C']), max(scenario['plateaus_C'])
        return dict(per_unit=None, amplitude=amp, _top_rate=math.radians(max(scenario['rates_dps'])),
                    T0_C=float(lo + rng.uniform(0.2, 0.8) * (hi - lo)),
                    width_C=float(max(0.05 * (hi - lo), 1.0) * rng.uniform(1.0, 2.0)))
    if ooc_kind == 'f_times_w':
        return dict(coefficient=amp / (9.80665 * math.radians(max(scenario['rates_dps']))))
    if ooc_kind == 'spin_settle':
        return dict(amplitude=amp, tau_s=float(rng.uniform(3, 15)), threshold_rad_s=math.radians(1.0))
    if ooc_kind == 'f_triple':  # amp on the body diagonal (each |f_k| = g / sqrt 3)
        return dict(coefficient=amp / (9.80665 / math.sqrt(3.0)) ** 3)
    if ooc_kind == 'abs_g':
        return dict(coefficient=amp / 9.80665)
    if ooc_kind == 'motor_heat':  # amp once the lag has settled while turning
        return dict(amplitude=amp, tau_s=float(rng.uniform(40, 200)), threshold_rad_s=math.radians(1.0),
                    fs_hz=float(scenario['sample_rate_hz']))
    if ooc_kind == 'rate_bump':  # amp at the bump's speed, one of the schedule's rate levels
        return dict(amplitude=amp, w0_rad_s=math.radians(float(rng.choice(scenario['rates_dps']))), width_frac=0.1)
    if ooc_kind == 'cable_wrap':  # amp at the most the table has wound up over the run
        return dict(amplitude=amp)
    if ooc_kind == 'knee':  # amp at |f_j| = 1 g
        f0 = 9.80665 * float(rng.uniform(0.4, 0.7))
        return dict(coefficient=amp / (9.80665 - f0) ** 2, f0_m_s2=f0)
    if ooc_kind == 'mount_slip':  # amp at the largest input (1 g, or the top rate)
        return dict(theta_rad=None, amplitude=amp, _top_rate=math.radians(max(scenario['rates_dps'])),
                    t_frac=float(rng.uniform(0.3, 0.7)), input_axis=None)
    if ooc_kind == 'popcorn':
        return dict(amplitude=amp, dwell_s=float(rng.uniform(200, 800)), seed=int(rng.integers(1 << 30)))
    if ooc_kind == 'compressor':  # gated on a die cooling faster than a fifth of the chamber's slew
        return dict(amplitude=amp, period_s=float(rng.uniform(60, 200)), phase_rad=float(rng.uniform(0, 2 * np.pi)),
                    gate_C_per_s=0.2 * scenario['slew_C_per_min'] / 60.0)
    if ooc_kind == 'heater_on':  # gated on a die warming faster than a fifth of the chamber's slew
        return dict(amplitude=amp, gate_C_per_s=0.2 * scenario['slew_C_per_min'] / 60.0)
    if ooc_kind == 'glitch':  # amp: a hundredth of each glitch's height (a 5 s mean holding one glitch moves by
        return dict(height=100.0 * amp, interval_s=float(rng.uniform(20, 120)),  # a fifth of amp at 100 Hz)
                    seed=int(rng.integers(1 << 30)))
    if ooc_kind == 'range_switch':  # amp at the top rate, in the upper range
        top = math.radians(max(scenario['rates_dps']))
        return dict(per_unit=amp / top, w_r_rad_s=top * float(rng.uniform(0.3, 0.7)))
    if ooc_kind == 'inl_periodic':  # amp at the sine's crest; 1.5-4 periods over the axis' largest input
        return dict(amplitude=amp, period=None, _cycles=float(rng.uniform(1.5, 4.0)),
                    _top_rate=math.radians(max(scenario['rates_dps'])), phase_rad=float(rng.uniform(0, 2 * np.pi)))
    if ooc_kind == 'temp_saw':  # amp at the sawtooth's edge (half a step of the sensor times the axis' coefficient)
        return dict(amplitude=amp, q_C=float(rng.uniform(0.5, 2.0)))
    if ooc_kind == 'axis_skew':  # amp: the error at the sines' largest rate of change (3.4 rad/s^2 for the gyro, the
        return dict(tau_s=None, amplitude=amp)  # gravity turning at 1.1 rad/s, 10.8 m/s^3, for the accel)
    if ooc_kind == 'scale_temp_hyst':  # amp at the largest input (1 g, or the top rate); gated as the compressor
        return dict(per_unit=None, amplitude=amp, _top_rate=math.radians(max(scenario['rates_dps'])),
                    gate_C_per_s=0.2 * scenario['slew_C_per_min'] / 60.0)
    if ooc_kind == 'cogging':
        return dict(amplitude=amp, lobes=int(rng.integers(4, 13)), phase_rad=float(rng.uniform(0, 2 * np.pi)))
    if ooc_kind == 'tdot_scale':  # amp at the largest input (1 g, or the top rate) while the die moves at the chamber's
        return dict(per_unit_per_C_s=None, amplitude=amp, _top_rate=math.radians(max(scenario['rates_dps'])),  # slew
                    _tdot_C_s=scenario['slew_C_per_min'] / 60.0)
    if ooc_kind == 'angle_window':
        return dict(amplitude=amp, center_rad=float(rng.uniform(-np.pi, np.pi)),
                    half_width_rad=math.radians(float(rng.uniform(15, 60))))
    if ooc_kind == 'stuck_bit':  # the bit whose weight is nearest amp (filled once the sensor's LSB is known)
        return dict(bit=None, amplitude=amp)
    if ooc_kind == 'temp_knee':  # amp at the hottest plateau; the knee in the upper two thirds of the range
        lo, hi = min(scenario['plateaus_C']), max(scenario['plateaus_C'])
        T0 = float(lo + rng.uniform(0.3, 0.7) * (hi - lo))
        return dict(amplitude=amp, T0_C=T0, span_C=max(hi - T0, 1.0))
    if ooc_kind == 'zero_burst':  # bursts of 3-12 rows, one every 30-120 s on average (their size is the axis' own
        return dict(seed=int(rng.integers(1 << 30)), interval_s=float(rng.uniform(30, 120)), max_rows=12)  # output)
    if ooc_kind == 'drive_current':  # amp at the sines' largest angular acceleration (3.4 rad/s^2) and beyond
        return dict(amplitude=amp, alpha0_rad_s2=3.4)
    if ooc_kind == 'dead_zone':  # the band's half-width: 1-6 times the Earth's rate, or amp if larger
        return dict(d_rad_s=float(max(abs(amp), 7.292115e-5 * rng.uniform(1.0, 6.0))))
    if ooc_kind == 'beat_chirp':  # a beat of period 60-300 s at mid temperature, +-20-60 % over the range
        lo, hi = min(scenario['plateaus_C']), max(scenario['plateaus_C'])
        return dict(amplitude=amp, f0_hz=1.0 / float(rng.uniform(60, 300)), sweep=float(rng.uniform(0.2, 0.6)),
                    T_mid_C=0.5 * (lo + hi), half_span_C=max(0.5 * (hi - lo), 1.0),
                    phase_rad=float(rng.uniform(0, 2 * np.pi)))
    if ooc_kind == 'scale_warmup':  # amp at the largest input at power-up; settles with tau 120-600 s
        return dict(per_unit=None, amplitude=amp, tau_s=float(rng.uniform(120, 600)),
                    _top_rate=math.radians(max(scenario['rates_dps'])))
    if ooc_kind == 'mag_field':  # amp along the horizontal field, pointing anywhere in the level plane
        return dict(amplitude=amp, decl_rad=float(rng.uniform(0, 2 * np.pi)))
    if ooc_kind == 'cross_abs_rate':  # amp at the top rate about the other axis
        return dict(coefficient=amp / math.radians(max(scenario['rates_dps'])), input_axis=None)
    if ooc_kind == 'temp_ripple':  # 3-6 rad of phase over the plateaus' range
        lo, hi = min(scenario['plateaus_C']), max(scenario['plateaus_C'])
        return dict(amplitude=amp, T0_C=float(lo), k_rad_per_C=float(rng.uniform(3, 6)) / max(hi - lo, 1.0),
                    phase_rad=float(rng.uniform(0, 2 * np.pi)))
    if ooc_kind == 'thermal_gradient':  # amp at the largest die-to-board difference over the run; the board lags 5-20 min
        return dict(amplitude=amp, tau_s=float(rng.uniform(300, 1200)), fs_hz=float(scenario['sample_rate_hz']))
    if ooc_kind == 'k2_temp':  # amp at the largest input (1 g, or the top rate) at an end of the plateaus' range
        lo, hi = min(scenario['plateaus_C']), max(scenario['plateaus_C'])
        return dict(coefficient=None, amplitude=amp, _top_rate=math.radians(max(scenario['rates_dps'])),
                    T_mid_C=0.5 * (lo + hi), half_span_C=max(0.5 * (hi - lo), 1.0))
    if ooc_kind == 'w_cross_cubic':  # amp on the body diagonal at the top rate (each component top / sqrt 3)
        return dict(coefficient=amp / (math.radians(max(scenario['rates_dps'])) / math.sqrt(3.0)) ** 3, input_axis=None)
    if ooc_kind == 'w_dot_cross':  # amp at the sines' largest angular acceleration (3.4 rad/s^2)
        return dict(coefficient=amp / 3.4, input_axis=None)
    if ooc_kind == 'temp_exp':  # doubling every 6-14 degC between the coldest and hottest plateaus
        lo, hi = min(scenario['plateaus_C']), max(scenario['plateaus_C'])
        return dict(amplitude=amp, T_lo_C=float(lo), T_hi_C=float(max(hi, lo + 1.0)), double_C=float(rng.uniform(6, 14)))
    if ooc_kind == 'w_cross_pair':  # amp at the top rate about the diagonal between the two cross axes
        return dict(coefficient=amp / (0.5 * math.radians(max(scenario['rates_dps'])) ** 2))
    if ooc_kind == 'mount_flex':  # amp at the top rate and 1 g along the input axis
        return dict(coefficient=amp / (9.80665 * math.radians(max(scenario['rates_dps'])) ** 2), input_axis=None)
    raise ValueError('unknown out-of-catalog kind %r' % ooc_kind)


def ooc_fill_axis(o, rng):
    """The parts of an out-of-catalog term that depend on the axis it sits on."""
    if o['kind'] == 'cross_w2':
        o['input_axis'] = str(rng.choice([k for k in AX if k != o['axis']]))
    if o['kind'] == 'scale_age':  # the scale change over the run gives amp at the largest input (1 g, or the top rate)
        top = o.pop('_top_rate')
        o['per_unit'] = 2.0 * o.pop('amplitude') / (9.80665 if o['sensor'] == 'accel' else top)
    if o['kind'] == 'scale_warmup':
        top = o.pop('_top_rate')
        o['per_unit'] = o.pop('amplitude') / (9.80665 if o['sensor'] == 'accel' else top)
    if o['kind'] == 'mount_slip':
        top = o.pop('_top_rate')
        o['theta_rad'] = o.pop('amplitude') / (9.80665 if o['sensor'] == 'accel' else top)
        o['input_axis'] = str(rng.choice([k for k in AX if k != o['axis']]))
    if o['kind'] == 'inl_periodic':
        top = o.pop('_top_rate')
        o['period'] = (9.80665 if o['sensor'] == 'accel' else top) / o.pop('_cycles')
    if o['kind'] == 'axis_skew':  # sign of amp: late (+) or early (-); 0.2-8 ms, within a 100 Hz sample
        rate = 9.80665 * math.radians(20) * math.pi if o['sensor'] == 'accel' else math.radians(20) * math.pi ** 2
        a = o.pop('amplitude')
        o['tau_s'] = math.copysign(min(max(abs(a) / rate, 2e-4), 8e-3), a)
    if o['kind'] == 'scale_temp_hyst':
        top = o.pop('_top_rate')
        o['per_unit'] = o.pop('amplitude') / (9.80665 if o['sensor'] == 'accel' else top)
    if o['kind'] == 'cross_abs_rate':
        o['input_axis'] = str(rng.choice([k for k in AX if k != o['axis']]))
    if o['kind'] == 'k2_temp':
        top = o.pop('_top_rate')
        o['coefficient'] = o.pop('amplitude') / (9.80665 if o['sensor'] == 'accel' else top) ** 2
    if o['kind'] == 'w_cross_cubic':
        o['input_axis'] = str(rng.choice([k for k in AX if k != o['axis']]))
    if o['kind'] == 'w_dot_cross':
        o['input_axis'] = str(rng.choice([k for k in AX if k != o['axis']]))
    if o['kind'] == 'mount_flex':
        o['input_axis'] = str(rng.choice([k for k in AX if k != o['axis']]))
    if o['kind'] == 'tdot_scale':
        top = o.pop('_top_rate')
        o['per_unit_per_C_s'] = o.pop('amplitude') / ((9.80665 if o['sensor'] == 'accel' else top) * o.pop('_tdot_C_s'))
    if o['kind'] == 'scale_bump':
        top = o.pop('_top_rate')
        o['per_unit'] = o.pop('amplitude') / (9.80665 if o['sensor'] == 'accel' else top)


def make_case(kind, seed, size='full', sensor_path=None, cls=None, effect=None, g2_squares=False, ooc_kind=None,
              timing=None, full_catalog=False):
    rng = np.random.default_rng(np.random.SeedSequence([seed, 12]))
    candidates = CANDIDATES_ALL if full_catalog else CANDIDATES
    cls = cls or str(rng.choice(CLASSES))
    truth = {'kind': kind, 'sensor_class': cls, 'ooc': [], 'noise_extra': []}
    ooc = []
    noise_extra = []
    if kind == 'example':
        sensor = load_json(sensor_path)
        truth['sensor_class'] = os.path.basename(sensor_path)
    else:
        sensor = base_only(class_sensor(cls))
    g = sensor['gyro']
    gyro_range = float(g.get('range', 0)) or float(g['lsb']) * 2 ** (int(g.get('bits', 16)) - 1)
    scenario = default_scenario(rng, size, math.degrees(gyro_range))
    if kind == 'random':
        keys = rng.choice(candidates, size=int(rng.integers(3, 7)), replace=False)
        for key in keys:
            sensor['effects'][str(key)] = draw_effect(rng, str(key), cls, g2_squares=g2_squares)
    elif kind == 'single':
        # at the class magnitude, raised (never lowered) to an SNR of 10-30 on this scenario: the same
        # regime as the project's own single-effect battery (10 sigma), from an independent generator
        key = effect or str(rng.choice(candidates))
        sensor['effects'][key] = draw_effect(rng, key, cls, g2_squares=g2_squares)
        target_snr = float(rng.uniform(10, 30))
        if timing is not None:  # a given latency/clock drift (e.g. >= 1 s accumulated over the run), not scaled
            sensor['effects'][key] = dict(timing)
            target_snr = None
    elif kind == 'stochastic':
        # colored noise well above the class' own: single GM (tau 60 s), flicker GM sums, RRW, quantization
        for ax in rng.choice(STOCH_AXES, size=3, replace=False):
            s, a = ax.split('.')
            sn = seg_noise(sensor, ax)
            pick = rng.choice(['gm', 'flicker', 'rrw', 'quant'])
            if pick == 'gm':
                noise_extra.append({'sensor': s, 'axis': a, 'kind': 'gm', 'sigma': float(sn * rng.uniform(3, 8)), 'tau_s': 60.0})
            elif pick == 'flicker':
                noise_extra.append({'sensor': s, 'axis': a, 'kind': 'flicker', 'B': float(sn * rng.uniform(4, 10)), 'tau_s': float(rng.choice([30, 100, 300]))})
            elif pick == 'rrw':
                noise_extra.append({'sensor': s, 'axis': a, 'kind': 'rrw', 'K': float(sn * rng.uniform(0.3, 1.0))})
            else:
                N = sensor_effects(sensor)[s].get('white_noise', {}).get(a, 1e-4)
                sensor['effects'].setdefault(s + '.quantization', {})[a] = float(N * math.sqrt(100) * rng.uniform(2, 4))
    elif kind == 'ooc':
        ooc_kind = ooc_kind or str(rng.choice(['heading', 'bias_step', 'w_cubed', 'abs_rate', 'periodic']))
        axes = list(rng.choice(STOCH_AXES, size=int(rng.integers(1, 3)), replace=False))
        for sensor_only, kinds in (('gyro', OOC_GYRO_ONLY), ('accel', OOC_ACCEL_ONLY)):
            if ooc_kind in kinds:
                axes = [a for a in axes if a.startswith(sensor_only)] or [sensor_only + '.' + str(rng.choice(list(AX)))]
        for ax in axes:
            s, a = ax.split('.')
            amp = seg_noise(sensor, ax) * float(rng.uniform(20, 50)) * float(rng.choice([-1, 1]))
            o = {'sensor': s, 'axis': a, 'kind': ooc_kind}
            o.update(ooc_params(ooc_kind, amp, rng, scenario))
            ooc_fill_axis(o, rng)
            ooc.append(o)
    elif kind == 'mixed':
        # a realistic sensor: 3-6 catalog effects AND one out-of-catalog bias on one axis (20-50 segment sigma).
        # The diagnosis must keep the catalog effects and name the axis, selecting nothing for it.
        keys = rng.choice(candidates, size=int(rng.integers(3, 7)), replace=False)
        for key in keys:
            sensor['effects'][str(key)] = draw_effect(rng, str(key), cls, g2_squares=g2_squares)
        ooc_kind = ooc_kind or str(rng.choice(OOC_KINDS))
        ax = str(rng.choice(STOCH_AXES))
        if ooc_kind in OOC_GYRO_ONLY:
            ax = 'gyro.' + ax.split('.')[1]
        if ooc_kind in OOC_ACCEL_ONLY:
            ax = 'accel.' + ax.split('.')[1]
        s, a = ax.split('.')
        amp = seg_noise(sensor, ax) * float(rng.uniform(20, 50)) * float(rng.choice([-1, 1]))
        o = {'sensor': s, 'axis': a, 'kind': ooc_kind}
        o.update(ooc_params(ooc_kind, amp, rng, scenario))
        ooc_fill_axis(o, rng)
        ooc.append(o)
    elif kind == 'ooc_noise':
        # temperature-dependent white noise: stochastic, out of the catalog (its white level is constant)
        ax = str(rng.choice(STOCH_AXES))
        s, a = ax.split('.')
        noise_extra.append({'sensor': s, 'axis': a, 'kind': 'temp_white', 'per_C': 0.05})
    elif kind == 'null':
        pass
    elif kind != 'example':
        raise ValueError('unknown kind ' + kind)
    if any(o['kind'] == 'w_dot_cross' for o in ooc):
        scenario['sines'] = True  # the only segments with angular acceleration (rate dwells start at their rate)
    case = {'seed': seed, 'scenario': scenario, 'sensor': sensor, 'ooc': ooc, 'noise_extra': noise_extra, 'truth': truth}
    if kind == 'single' and target_snr:
        case['target_snr'] = target_snr
    # a quarter of the cases log no table columns (table_axes = 0): references only, like many blind logs
    scenario['log_table'] = seed % 4 != 0
    return case


def expectations(case):
    """What a correct diagnosis against model-thermal says: the beyond-model catalog effects present
    (expected selections), components a model-thermal diagnosis cannot name (bias_temp order 3), and the
    axes an out-of-catalog effect leaves unexplained."""
    eff = sensor_effects(case['sensor'])
    beyond, unnameable, params = [], [], {}
    for s in ('accel', 'gyro'):
        for e, comps in eff[s].items():
            if e in STOCHASTIC:
                continue
            nz = {k: v for k, v in comps.items() if v != 0.0 and k != 'tau_s'}
            if not nz:
                continue
            for k, v in nz.items():
                params['%s.%s.%s' % (s, e, k)] = v
            if e in MODEL_THERMAL[s]:
                for k in nz:
                    if not in_model(s, e, k):
                        unnameable.append('%s.%s.%s' % (s, e, k))
            else:
                beyond.append('%s.%s' % (s, e))
    unexplained = sorted({'%s.%s' % (o['sensor'], o['axis']) for o in case['ooc']})
    return {'beyond_model': sorted(beyond), 'beyond_model_unnameable': sorted(unnameable), 'parameters': params,
            'unexplained_axes': unexplained}


def write_case(case, out_dir, fmt='csv', name=None):
    # a bias step needs the duration: build the scenario once to know it (cheap)
    for o in case['ooc']:
        if o['kind'] == 'bias_step' and o.get('t_step_s') is None:
            rng = np.random.default_rng(case['seed'] + 99)
            dur = build_scenario(np.random.default_rng(np.random.SeedSequence(int(case['seed'])).spawn(4)[0]), case['scenario']).duration
            o['t_step_s'] = float(dur * rng.uniform(0.3, 0.7))
        if o['kind'] in ('drift', 'scale_age') and o.get('duration_s') is None:
            o['duration_s'] = float(build_scenario(np.random.default_rng(np.random.SeedSequence(int(case['seed'])).spawn(4)[0]), case['scenario']).duration)
    info = generate(case, out_dir, fmt)
    exp = expectations(case)
    truth = {
        'format': 'blindgen-truth', 'version': 1, 'name': name or os.path.basename(os.path.normpath(out_dir)),
        'seed': case['seed'], 'kind': case['truth']['kind'], 'sensor_class': case['truth']['sensor_class'],
        'model': 'docs/examples/model-thermal.json', 'T_ref_C': float(case['sensor'].get('T_ref_C', 25.0)),
        'beyond_model': exp['beyond_model'], 'beyond_model_unnameable': exp['beyond_model_unnameable'],
        'parameters': exp['parameters'], 'unexplained_axes': exp['unexplained_axes'],
        'out_of_catalog': case['ooc'], 'noise_extra': case['noise_extra'],
        'stochastic': {'%s.%s' % (s, e): c for s, ee in sensor_effects(case['sensor']).items() for e, c in ee.items() if e in STOCHASTIC},
        'realised': info['realised'], 'lever_arm_m': info['lever_arm_m'], 'mount_error_rad': info['mount_error_rad'],
        'gravity_mps2': info['gravity_mps2'], 'rows': info['rows'], 'duration_s': info['duration_s'],
        'rows_lost': info['rows_lost'],
        'T_die_range_C': info['T_die_range_C'], 'scenario': case['scenario'], 'segments': len(info['segments']),
        'snr': info['snr'],
    }
    truth['expect'] = {
        'selected': exp['beyond_model'],
        'nothing_selected': not exp['beyond_model'],
        'unexplained_axes': exp['unexplained_axes'],
    }
    with open(os.path.join(out_dir, 'truth.json'), 'w') as f:
        json.dump(truth, f, indent=1)
    with open(os.path.join(out_dir, 'sensor.json'), 'w') as f:
        json.dump(case['sensor'], f, indent=1)
    return truth, info


# ----------------------------------------------------------------------------------------------------
def selftest():
    """The generator's own physics, checked against closed forms (not against imuforge)."""
    ok = True

    def check(name, cond, detail=''):
        nonlocal ok
        print('%-60s %s %s' % (name, 'ok' if cond else 'FAIL', detail))
        ok &= bool(cond)

    angs = np.random.default_rng(5).uniform(-4, 4, (50, 3))
    Cp = rz(angs[:, 2]) @ rx(angs[:, 1]) @ rz(angs[:, 0])
    check('attitude closed form = Rz(outer) Rx(middle) Rz(inner)', np.max(np.abs(Scenario.attitude(None, angs) - Cp)) < 1e-14)
    rts = np.random.default_rng(6).uniform(-2, 2, (50, 3))
    R0t, R1t = np.swapaxes(rz(angs[:, 0]), -1, -2), np.swapaxes(rx(angs[:, 1]), -1, -2)
    wref = rts[:, 0:1] * np.array([0, 0, 1.0]) + mv(R0t, rts[:, 1:2] * np.array([1.0, 0, 0])) + mv(R0t, mv(R1t, rts[:, 2:3] * np.array([0, 0, 1.0])))
    check('gimbal rate closed form', np.max(np.abs(Scenario.body_rate_nb(None, angs, rts) - wref)) < 1e-14)
    # body rate = vee(C^T dC/dt) by finite differences
    hh = 1e-6
    dC = (Scenario.attitude(None, angs + hh * rts) - Scenario.attitude(None, angs - hh * rts)) / (2 * hh)
    W = np.einsum('nji,njk->nik', Cp, dC)
    vee = np.stack([W[:, 2, 1], W[:, 0, 2], W[:, 1, 0]], -1)
    check('gimbal rate = vee(C^T dC/dt)', np.max(np.abs(vee - wref)) < 1e-8)
    g = normal_gravity(45.0, 0.0)
    check('normal gravity at 45 deg, h=0 (Somigliana, TR8350.2 constants: 9.8061978)', abs(g - 9.8061978) < 1e-7, '%.8f' % g)
    rng = np.random.default_rng(1)
    spec = {'plateaus_C': [25], 'first_soak_s': 2, 'n_az': 1, 'n_tilt': 0, 'rates_dps': [100], 'rate_dwell_s': 2,
            'dwell_s': 1, 'sines': False, 'lever_arm_m': [0, 0, 0], 'mount_error_rad': [0, 0, 0], 'latitude_deg': 45}
    scn = build_scenario(rng, spec)
    t = np.arange(int(scn.duration * 100)) / 100
    f, w, wd, ang, rate, idx = scn.kinematics(t)
    # static faces: |f| = g, |w| = Earth rate
    st = np.array([scn.segments[i].kind in ('soak', 'position') for i in idx])
    check('static |f| = normal gravity', np.max(np.abs(np.linalg.norm(f[st], axis=1) - scn.g)) < 1e-9)
    check('static |w| = Earth rate', np.max(np.abs(np.linalg.norm(w[st], axis=1) - OMEGA_E)) < 1e-12)
    # faces: +x down reads f_x = -g? The IMU reads -g along the axis pointing DOWN ((0,0,-g) for +z down)
    for (i, m), axis, sign in [((0, 0), 2, -1), ((0, 180), 2, 1), ((0, 90), 1, -1), ((180, 90), 1, 1), ((90, 90), 0, -1), ((270, 90), 0, 1)]:
        C = scn.attitude(np.radians(np.array([[i, m, 17.0]])))
        fb = mtv(C, np.array([[0, 0, -scn.g]]))[0]
        check('face (%d,%d): f[%d] = %+d g' % (i, m, axis, sign), abs(fb[axis] - sign * scn.g) < 1e-9)
    # rate about body z with z down: w_z = rate + Earth vertical component
    rs = np.array([scn.segments[i].label == 'rate z +100 dps' for i in idx])
    check('rate z +100 dps reads w_z = 1.745 rad/s (+ Earth)', np.allclose(w[rs, 2], math.radians(100) - OMEGA_E * math.sin(math.radians(45)) * 1.0, atol=1e-4))
    # flicker: Allan deviation of the GM sum near 0.664 B
    B, tau = 1e-3, 10.0
    T = tau * np.array([0.2, 1, 5, 10])
    s = flicker_sigma(B, tau)
    ad = np.sqrt(sum(gm_avar(s, tc * tau, T) for tc in FLICKER_TAUS)) / B
    check('flicker GM sum: Allan/B within 10% of 0.664 over 0.2..10 tau', np.all(np.abs(ad / 0.664 - 1) < 0.1), str(np.round(ad, 3)))
    # GM process: empirical variance
    x = gm_process(np.random.default_rng(2), 200000, 0.01, 2.0, 1.0)
    check('GM process variance', abs(np.var(x) / 4 - 1) < 0.1, '%.3f' % (np.var(x) / 4))
    # hysteresis tracker
    d = hysteresis_direction(np.array([25, 25.3, 26, 27, 26.8, 26.4, 26.0, 25.5, 26.2]), 0.5)
    check('hysteresis d', list(d) == [0, 0, 1, 1, 1, -1, -1, -1, 1], str(list(d)))
    # the mag_field term is the horizontal field seen by the axes: over any attitude the three axes' terms form a unit
    # vector (times the amplitude) with no part along gravity (the specific force at rest)
    rs = np.random.default_rng(5)
    ang = rs.uniform(-np.pi, np.pi, (200, 3))
    f_rest = mtv(Scenario.attitude(None, ang), np.broadcast_to(np.array([0.0, 0.0, -9.8]), (200, 3)))
    tt = np.zeros(200)
    mb = np.stack([ooc_signal({'kind': 'mag_field', 'sensor': 'gyro', 'axis': a, 'amplitude': 2.0, 'decl_rad': 0.7},
                              tt, ang, f_rest * 0, f_rest, tt, tt) for a in AX], -1)
    check('mag_field: |m| = amplitude, m . f = 0 at rest',
          np.allclose(np.linalg.norm(mb, axis=1), 2.0) and np.max(np.abs(np.sum(mb * f_rest, axis=1))) < 1e-9,
          '%.3g' % np.max(np.abs(np.sum(mb * f_rest, axis=1))))
    return ok


def main(argv):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest='cmd', required=True)
    c = sub.add_parser('case', help='write one case (log + truth + sensor)')
    c.add_argument('--kind', required=True, choices=['random', 'single', 'example', 'null', 'stochastic', 'ooc', 'ooc_noise', 'mixed'])
    c.add_argument('--seed', type=int, required=True)
    c.add_argument('--out', required=True)
    c.add_argument('--size', default='full', choices=['full', 'short', 'varied'])
    c.add_argument('--sensor', help='sensor JSON (kind example)')
    c.add_argument('--class', dest='cls', choices=CLASSES)
    c.add_argument('--effect', help='kind single: e.g. gyro.g_sensitivity')
    c.add_argument('--ooc', help='kind ooc: heading | bias_step | w_cubed | abs_rate | periodic | g_cubed | angle2 | rate_memory | warmup | drift | rate_odd | cross_w2 | temp_step | scale_age')
    c.add_argument('--timing', help='kind single, effect *.timing: JSON of the components, e.g. {"ppm": 400}')
    c.add_argument('--g2-squares', action='store_true', help='also draw IEEE 1431 g^2 squares (x.xx ...)')
    c.add_argument('--full-catalog', action='store_true',
                   help='kinds random, single, mixed: draw from every catalog effect, those added after the first suites too')
    c.add_argument('--format', default='csv', choices=['csv', 'bin'])
    sub.add_parser('selftest', help='closed-form checks of the generator itself')
    a = ap.parse_args(argv)
    if a.cmd == 'selftest':
        return 0 if selftest() else 1
    case = make_case(a.kind, a.seed, a.size, a.sensor, a.cls, a.effect, a.g2_squares, a.ooc,
                     json.loads(a.timing) if a.timing else None, a.full_catalog)
    truth, info = write_case(case, a.out, a.format)
    print('%s: %d rows, %.0f s, beyond model: %s, unexplained: %s' % (info['log'], info['rows'], info['duration_s'],
          ' '.join(truth['beyond_model']) or '-', ' '.join(truth['unexplained_axes']) or '-'))
    return 0


if __name__ == '__main__':
    sys.exit(main(sys.argv[1:]))
