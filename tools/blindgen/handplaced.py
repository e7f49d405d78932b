#!/usr/bin/env python3
"""handplaced: an independent generator of HAND-PLACED reference-free recordings, and the check that
`imuforge solve --mode reference-free` counts their poses and beats imu_tk's method on them (issue 17).

Written from the documentation only (docs/formats.md "column map", docs/error-model.md's catalog terms,
docs/calibration.md), NOT from host/poses, host/solver or host/model: it shares no code with what it
checks. It has its own attitude kinematics, its own sensor model, its own re-implementation of imu_tk's
accelerometer method (Tedaldi, Pretto, Menegatti, ICRA 2014; Kyle-ak/imu_tk src/calibration.cpp) and
its own application of the calibration written to cal.json.

  handplaced.py fixture  --out DIR [--seed S]   # 20-face fixture, ADXL355-like 20-bit accel + BMI160 gyro
  handplaced.py handheld --out DIR [--seed S]   # float export (m/s², rad/s), gyro peaks 8.4 rad/s
  handplaced.py check --imuforge BIN --work DIR [--seed S]   # both, through the CLI, scored (exit 1 = fail)
  handplaced.py selftest                        # the generator's own kinematics against closed forms

The fixture recording (the shape of the issue's real one: 237 s at 100 Hz, ~36 hand placements):
  * a 20-face fixture (icosahedron) set down by hand on a table: 12 s still, then 35 placements on faces
    in random order (every face at least once, never the same face twice in a row), 1.8-2.8 s of hand
    motion between them (minimum-jerk turn plus hand tremor, a lift of a few cm), 3.6-5.0 s dwells;
  * after each placement the fixture rocks (0.6 deg, 4 Hz, decaying in 0.35 s) and on every third one
    also creeps 0.3 deg over ~1 s (slow settling); four dwells are bumped mid-way (15 Hz shake, 0.15 s);
  * accelerometer y = (I + M) f + b + k2 f^2 (per axis, a systematic scale nonlinearity of a few mm/s^2
    at 1 g, the kind imu_tk's model leaves) + white noise 1.5e-3 m/s^2, 20-bit counts of 9.80665/256000;
  * gyro y = (I + M_g) w + b_g + noise 1.2e-3 rad/s, 16-bit counts of (pi/180)/16.4 (BMI160 +-2000 deg/s);
  * 1 kHz internally, averaged to 100 Hz.
Truth: the still spans (from placement+1.2 s to the lift) and every parameter, in truth.json.

Scores (check): pose count within 1 of the truth; |a| - g RMS over the true still spans (shrunk by 1 s
at each end, so neither program chose the samples it is scored on) for the nominal scale, imu_tk's
method, imuforge's cal.json, and the truth (the noise floor). The issue's target: imuforge at most half
of imu_tk where imu_tk leaves systematic error.
"""
import argparse
import json
import math
import os
import subprocess
import sys

import numpy as np

G = 9.80665
ACC_LSB = G / 256000.0          # ADXL355 +-2 g, 20-bit
GYR_LSB = math.pi / 180 / 16.4  # BMI160 +-2000 deg/s, 16-bit
FS = 100.0
SUB = 10                        # internal samples per output sample (1 kHz)


# ---- quaternions (w, x, y, z), body -> world ---------------------------------------------------------
def qmul(a, b):
    aw, ax, ay, az = np.moveaxis(np.asarray(a), -1, 0)
    bw, bx, by, bz = np.moveaxis(np.asarray(b), -1, 0)
    return np.stack([aw * bw - ax * bx - ay * by - az * bz,
                     aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx,
                     aw * bz + ax * by - ay * bx + az * bw], axis=-1)


def qexp(v):
    """Rotation vector(s) -> unit quaternion(s)."""
    v = np.asarray(v, dtype=float)
    ang = np.linalg.norm(v, axis=-1, keepdims=True)
    half = 0.5 * ang
    s = np.where(ang > 1e-12, np.sin(half) / np.where(ang > 1e-12, ang, 1.0), 0.5)
    return np.concatenate([np.cos(half), s * v], axis=-1)


def qlog(q):
    q = np.asarray(q, dtype=float)
    q = q * np.sign(np.where(q[..., :1] == 0, 1.0, q[..., :1]))
    vn = np.linalg.norm(q[..., 1:], axis=-1, keepdims=True)
    ang = 2 * np.arctan2(vn, q[..., :1])
    return np.where(vn > 1e-15, q[..., 1:] * ang / np.where(vn > 1e-15, vn, 1.0), 2 * q[..., 1:])


def qconj(q):
    q = np.asarray(q, dtype=float)
    return q * np.array([1, -1, -1, -1])


def qrot_inv(q, v):
    """R(q)^T v: a world vector in body axes."""
    vq = np.concatenate([np.zeros(v.shape[:-1] + (1,)), v], axis=-1)
    return qmul(qmul(qconj(q), vq), q)[..., 1:]


def icosahedron_face_normals():
    p = (1 + 5 ** 0.5) / 2
    v = []
    for a in (-1, 1):
        for b in (-p, p):
            v += [(0, a, b), (a, b, 0), (b, 0, a)]
    v = np.array(v, dtype=float)
    faces = []
    n = len(v)
    for i in range(n):
        for j in range(i + 1, n):
            for k in range(j + 1, n):
                d = [np.linalg.norm(v[i] - v[j]), np.linalg.norm(v[j] - v[k]), np.linalg.norm(v[i] - v[k])]
                if all(abs(x - 2) < 1e-9 for x in d):
                    c = (v[i] + v[j] + v[k]) / 3
                    faces.append(c / np.linalg.norm(c))
    return np.array(faces)


def attitude_on_face(n, yaw, tilt_vec):
    """Body->world quaternion with face normal n (body) pointing down, yaw about vertical, small tilt."""
    down = np.array([0.0, 0.0, -1.0])
    axis = np.cross(n, down)
    s, c = np.linalg.norm(axis), float(np.dot(n, down))
    rv = axis / s * math.atan2(s, c) if s > 1e-12 else (np.array([math.pi, 0, 0]) if c < 0 else np.zeros(3))
    q = qexp(rv)                                     # n -> down
    q = qmul(qexp(np.array([0, 0, yaw])), q)         # yaw about world vertical
    return qmul(qexp(np.asarray(tilt_vec)), q)       # table / hand tilt, world frame


def min_jerk(u):
    return 10 * u ** 3 - 15 * u ** 4 + 6 * u ** 5


# ---- trajectory ----------------------------------------------------------------------------------------
def build_trajectory(rng, attitudes, t_init, tr_range, dwell_range, tremor_rad, settle=True, bumps=(),
                     hand_tremor_still=0.0):
    """Piecewise: still (with settling) on attitudes[i], then a hand move to attitudes[i+1].
    Returns t (1 kHz), q (body->world), a_lin (world, m/s^2), still spans [(t0, t1)] (settled part)."""
    dt = 1.0 / (FS * SUB)
    segs = []   # (kind, t0, t1, data)
    bump_times = []
    t = 0.0
    spans = []
    for i, q in enumerate(attitudes):
        dwell = t_init if i == 0 else rng.uniform(*dwell_range)
        segs.append(('still', t, t + dwell, i))
        spans.append((t + (0.0 if i == 0 else 1.2), t + dwell))
        t += dwell
        if i + 1 < len(attitudes):
            tr = rng.uniform(*tr_range)
            segs.append(('move', t, t + tr, i))
            t += tr
    n = int(round(t / dt))
    tt = np.arange(n) * dt
    rv = np.zeros((n, 3))          # extra body-frame rotation vector on top of the base attitude
    qb = np.zeros((n, 4))
    alin = np.zeros((n, 3))
    for kind, t0, t1, i in segs:
        m = (tt >= t0) & (tt < t1)
        u = (tt[m] - t0) / (t1 - t0)
        if kind == 'still':
            qb[m] = attitudes[i]
            if i > 0 and settle:
                tau = tt[m] - t0
                ax = rng.normal(size=3); ax[2] = 0; ax /= np.linalg.norm(ax)   # world horizontal
                rock = math.radians(0.6) * np.exp(-tau / 0.35) * np.sin(2 * math.pi * 4.0 * tau)
                creep = math.radians(0.3) * np.exp(-tau / 0.8) if i % 3 == 0 else 0.0 * tau
                w = (rock + creep)[:, None] * ax[None, :]
                qb[m] = qmul(qexp(w), qb[m])
            if hand_tremor_still > 0:
                # hand-held: slow tremor (sum of a few sines, 2-8 Hz), a fraction of a degree
                tau = tt[m] - t0
                w = np.zeros((m.sum(), 3))
                for _ in range(4):
                    w += (hand_tremor_still * rng.normal(size=3))[None, :] * np.sin(
                        2 * math.pi * rng.uniform(2, 8) * tau + rng.uniform(0, 2 * math.pi))[:, None]
                qb[m] = qmul(qb[m], qexp(w))
            if i in bumps:
                tb = t0 + 0.5 * (t1 - t0)
                bump_times.append(tb)
                mb = m & (tt >= tb) & (tt < tb + 0.15)
                alin[mb] += 1.5 * np.sin(2 * math.pi * 15 * (tt[mb] - tb))[:, None] * np.array([0.6, 0.5, 0.62])
        else:
            qa, qc = attitudes[i], attitudes[i + 1]
            d = qlog(qmul(qconj(qa), qc))                          # body-frame rotation vector a -> c
            s = min_jerk(u)
            env = np.sin(math.pi * u) ** 2
            trem = np.zeros((m.sum(), 3))
            for _ in range(3):
                trem += (tremor_rad * rng.normal(size=3))[None, :] * np.sin(
                    2 * math.pi * rng.uniform(1.5, 5) * (tt[m] - t0) + rng.uniform(0, 2 * math.pi))[:, None]
            qb[m] = qmul(qa, qexp(s[:, None] * d[None, :] + env[:, None] * trem))
            lift = 0.05 * rng.uniform(0.6, 1.4)                     # m, up and back down
            T = t1 - t0
            alin[m, 2] += lift * (2 * math.pi / T) ** 2 * 0.5 * np.cos(2 * math.pi * u)
            alin[m, 0] += 0.03 * (2 * math.pi / T) ** 2 * 0.5 * np.cos(2 * math.pi * u) * rng.uniform(-1, 1)
    # Spans for scoring: the still spans with 0.5 s before to 1 s after each bump cut out.
    score = []
    for a, b in spans:
        cuts = [tb for tb in bump_times if a < tb < b]
        for tb in cuts:
            score.append((a, tb - 0.5))
            a = tb + 1.0
        score.append((a, b))
    return tt, qb, alin, spans, score


def kinematics(tt, q, alin):
    """Body rate (rad/s) and specific force (m/s^2, body) at 1 kHz."""
    dt = tt[1] - tt[0]
    dq = qmul(qconj(q[:-1]), q[1:])
    w = qlog(dq) / dt                                  # body frame: q_{k+1} = q_k exp(w dt)
    w = np.vstack([w, w[-1:]])
    # rate at the midpoint -> shift half a step by averaging neighbours
    w = 0.5 * (w + np.vstack([w[:1], w[:-1]]))
    f = qrot_inv(q, alin + np.array([0.0, 0.0, G]))
    return w, f


def decimate(x):
    n = (len(x) // SUB) * SUB
    return x[:n].reshape(-1, SUB, x.shape[1]).mean(axis=1)


# ---- sensor truth ----------------------------------------------------------------------------------------
def fixture_truth():
    return {
        'accel': {'bias': [0.081, -0.052, 0.118], 'M': [[2.0e-3, 0.6e-3, -0.4e-3], [0.9e-3, -1.5e-3, 0.3e-3],
                                                        [-0.7e-3, 1.1e-3, 1.0e-3]],
                  'k2': [2.4e-4, -1.8e-4, 2.0e-4], 'noise': 1.5e-3},
        'gyro': {'bias': [0.012, -0.007, 0.004], 'M': [[8e-3, 2e-3, -1e-3], [-1.5e-3, -6e-3, 2.5e-3], [1e-3, -2e-3, 4e-3]],
                 'noise': 1.2e-3},
    }


def sense(rng, f, w, truth):
    a, g = truth['accel'], truth['gyro']
    Ma, Mg = np.eye(3) + np.array(a['M']), np.eye(3) + np.array(g['M'])
    ya = f @ Ma.T + np.array(a['bias']) + np.array(a['k2']) * f * f
    yg = w @ Mg.T + np.array(g['bias'])
    # white noise at 1 kHz, sqrt(SUB) larger, so the 100 Hz average has the stated sigma
    ya = ya + rng.normal(scale=a['noise'] * math.sqrt(SUB), size=ya.shape)
    yg = yg + rng.normal(scale=g['noise'] * math.sqrt(SUB), size=yg.shape)
    return decimate(ya), decimate(yg)


def write_csv(path, a, g, fmt):
    """t_s,ax,ay,az,gx,gy,gz at FS; returns the time column."""
    t = np.arange(len(a)) / FS
    os.makedirs(os.path.dirname(path) or '.', exist_ok=True)
    line = '%.2f,' + ','.join([fmt] * 6) + '\n'
    with open(path, 'w') as fh:
        fh.write('t_s,ax,ay,az,gx,gy,gz\n')
        for k in range(len(t)):
            fh.write(line % (t[k], *a[k], *g[k]))
    return t


def fixture(out, seed):
    rng = np.random.default_rng(seed)
    normals = icosahedron_face_normals()
    assert len(normals) == 20
    order = list(rng.permutation(20))
    while len(order) < 36:
        c = int(rng.integers(20))
        if c != order[-1]:
            order.append(c)
    att = [attitude_on_face(normals[k], rng.uniform(0, 2 * math.pi), rng.normal(scale=math.radians(0.3), size=3) * [1, 1, 0])
           for k in order]
    bumps = set(int(x) for x in rng.choice(np.arange(2, 35), size=4, replace=False))
    tt, q, alin, spans, score = build_trajectory(rng, att, 12.0, (1.8, 2.8), (3.6, 5.0), math.radians(6), True, bumps)
    w, f = kinematics(tt, q, alin)
    truth = fixture_truth()
    ya, yg = sense(rng, f, w, truth)
    ca = np.clip(np.round(ya / ACC_LSB), -2 ** 19, 2 ** 19 - 1).astype(np.int64)
    cg = np.clip(np.round(yg / GYR_LSB), -2 ** 15, 2 ** 15 - 1).astype(np.int64)
    t = write_csv(os.path.join(out, 'fixture.csv'), ca, cg, '%d')
    cmap = {'delimiter': ',', 'header': True, 'time': {'column': 't_s', 'unit': 's'},
            'accel': {'columns': ['ax', 'ay', 'az'], 'unit': 'counts', 'lsb': ACC_LSB},
            'gyro': {'columns': ['gx', 'gy', 'gz'], 'unit': 'counts', 'lsb': GYR_LSB},
            'serial': 'handplaced-fixture',
            'metadata': {'accel_bits': 20, 'gyro_bits': 16, 'gravity_mps2': G}}
    json.dump(cmap, open(os.path.join(out, 'fixture.map.json'), 'w'), indent=1)
    truth.update({'poses': len(att), 'still_spans_s': spans, 'score_spans_s': score, 'bumped_poses': sorted(bumps), 'duration_s': float(t[-1]),
                  'gyro_peak_rad_s': float(np.abs(yg).max()), 'faces': [int(k) for k in order]})
    json.dump(truth, open(os.path.join(out, 'fixture.truth.json'), 'w'), indent=1)
    return truth


def handheld(out, seed):
    """114 s held in the hand, 14 poses, fast turns (gyro peaks 8.4 rad/s), exported as floats."""
    rng = np.random.default_rng(seed + 1000)
    att = []
    for k in range(14):
        v = rng.normal(size=3)
        att.append(qexp(v / np.linalg.norm(v) * rng.uniform(0.5 * math.pi, math.pi)))
    # Turn durations scaled (secant steps) until the fastest turn peaks at 8.4 rad/s on some gyro axis.
    c, prev = 1.0, None
    for _ in range(12):
        r2 = np.random.default_rng(seed + 2000)
        tt, q, alin, spans, score = build_trajectory(r2, att, 10.0, (0.9 * c, 1.3 * c), (6.2, 7.6), math.radians(4), False, (),
                                              hand_tremor_still=math.radians(0.04))
        w, f = kinematics(tt, q, alin)
        peak = np.abs(decimate(w)).max()
        print('handheld: turn time factor %.3f, peak %.3f rad/s' % (c, peak), file=sys.stderr)
        if abs(peak - 8.4) < 0.05:
            break
        c *= peak / 8.4
    truth = fixture_truth()
    truth['accel']['k2'] = [0, 0, 0]
    truth['accel']['noise'] = 4e-3
    truth['gyro']['noise'] = 2e-3
    ya, yg = sense(rng, f, w, truth)
    t = write_csv(os.path.join(out, 'handheld.csv'), ya, yg, '%.6f')
    truth.update({'poses': len(att), 'still_spans_s': spans, 'score_spans_s': score, 'duration_s': float(t[-1]),
                  'gyro_peak_rad_s': float(np.abs(yg).max())})
    json.dump(truth, open(os.path.join(out, 'handheld.truth.json'), 'w'), indent=1)
    return truth


# ---- imu_tk's accelerometer method, re-implemented -----------------------------------------------------
def gravity_fit(means, g):
    """9 parameters (bias, scale, lower misalignment) minimising sum (|T^-1 (y - b)| - g)^2, Gauss-Newton/LM."""
    def apply(p, y):
        T = np.eye(3) + np.diag(p[3:6])
        T[1, 0], T[2, 0], T[2, 1] = p[6], p[7], p[8]
        return np.linalg.solve(T, (y - p[:3]).T).T

    def res(p):
        return np.linalg.norm(apply(p, means), axis=1) - g
    p = np.zeros(9)
    lam = 1e-3
    e = res(p)
    for _ in range(100):
        J = np.empty((len(means), 9))
        for k in range(9):
            h = 1e-6 if k < 3 else 1e-7
            d = np.zeros(9); d[k] = h
            J[:, k] = (res(p + d) - res(p - d)) / (2 * h)
        A, r = J.T @ J, -J.T @ e
        ok = False
        for _ in range(20):
            dx = np.linalg.solve(A + lam * np.diag(np.maximum(np.diag(A), 1e-12)), r)
            e2 = res(p + dx)
            if np.all(np.isfinite(e2)) and e2 @ e2 <= e @ e:
                done = e2 @ e2 > (1 - 1e-13) * (e @ e)
                p, e, lam, ok = p + dx, e2, max(1e-12, lam / 10), True
                break
            lam *= 10
        if not ok or done:
            break
    return p, lambda y: apply(p, y)


def imutk(acc, g, init_samples):
    """Static detector and calibration of imu_tk (see the module docstring). Returns (apply, intervals) or
    (None, 0) when no threshold gives 12 intervals."""
    n, h = len(acc), 50
    c = np.cumsum(np.vstack([np.zeros((1, 3)), acc]), axis=0)
    c2 = np.cumsum(np.vstack([np.zeros((1, 3)), acc * acc]), axis=0)
    idx = np.arange(h, n - h)
    s1 = c[idx + h + 1] - c[idx - h]
    s2 = c2[idx + h + 1] - c2[idx - h]
    var = (s2 - s1 * s1 / (2 * h + 1)) / (2 * h)
    vnorm = np.full(n, np.inf)
    vnorm[idx] = np.linalg.norm(var, axis=1)
    init = np.linalg.norm(acc[:init_samples + 1].var(axis=0, ddof=1))
    best = (None, np.inf, 0)
    for th in range(2, 11):
        still = vnorm < th * init
        spans, start = [], None
        for i in range(h, n - h):
            if still[i] and start is None:
                start = i
            if start is not None and (not still[i] or i + h + 1 == n):
                if i - start >= 100:
                    mid = (start + i) // 2
                    spans.append((mid - 50, mid + 50))
                start = None
        if len(spans) < 12:
            continue
        means = np.array([acc[a:b].mean(axis=0) for a, b in spans])
        p, ap = gravity_fit(means, g)
        cost = sum(((np.linalg.norm(ap(acc[a:b]), axis=1) - g) ** 2).sum() for a, b in spans)
        if cost < best[1]:
            best = (ap, cost, len(spans))
    return best[0], best[2]


# ---- a cal.json applied, from the documented model (docs/error-model.md) --------------------------------
def cal_apply(cal):
    par = {p['name']: p['value'] for p in cal['parameters']}
    ax = 'xyz'
    b = np.array([par.get('accel.bias.' + a, 0.0) for a in ax])
    M = np.eye(3)
    for j in range(3):
        M[j, j] += par.get('accel.scale.' + ax[j], 0.0)
        for k in range(3):
            if k != j:
                M[j, k] = par.get('accel.misalign.' + ax[j] + ax[k], 0.0)
    k2 = np.array([par.get('accel.scale_nonlinearity.%s.k2' % a, 0.0) for a in ax])
    k3 = np.array([par.get('accel.scale_nonlinearity.%s.k3' % a, 0.0) for a in ax])
    asym = np.array([par.get('accel.scale_asymmetry.' + a, 0.0) for a in ax])
    cc = np.zeros((3, 3))
    for j in range(3):
        for k in range(3):
            if k != j:
                cc[j, k] = par.get('accel.cross_coupling.' + ax[j] + ax[k], 0.0)

    def extra(f):  # y = (I+M) f + b + N(f): k2 f_j^2 + k3 f_j^3 + a_j min(f_j, 0) + sum_k c_jk f_j f_k
        return k2 * f ** 2 + k3 * f ** 3 + asym * np.minimum(f, 0) + f * (f @ cc.T)

    def apply(y):
        f = np.linalg.solve(M, (y - b).T).T
        for _ in range(8):
            f = np.linalg.solve(M, (y - b - extra(f)).T).T
        return f
    return apply


def truth_apply(truth):
    a = truth['accel']
    M = np.eye(3) + np.array(a['M'])
    b, k2 = np.array(a['bias']), np.array(a['k2'])

    def apply(y):
        f = np.linalg.solve(M, (y - b).T).T
        for _ in range(8):
            f = np.linalg.solve(M, (y - b - k2 * f * f).T).T
        return f
    return apply


def score_rms(acc, spans_s, apply, g):
    e = []
    for a, b in spans_s:
        i0, i1 = int(math.ceil((a + 1) * FS)), int((b - 1) * FS)
        if i1 - i0 < 50:
            continue
        e.append(np.linalg.norm(apply(acc[i0:i1].mean(axis=0, keepdims=True)), axis=1)[0] - g)
    e = np.array(e)
    return float(np.sqrt((e * e).mean())), len(e)


# ---- check through the CLI -----------------------------------------------------------------------------
def run(cmd):
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0:
        sys.stderr.write('FAILED (%d): %s\n%s%s' % (p.returncode, ' '.join(cmd), p.stdout, p.stderr))
        sys.exit(1)
    return p.stdout


def read_log_si(csv):
    """A CSV log (docs/formats.md "CSV encoding"): counts -> SI with the log's own LSBs."""
    meta, rows, header = {}, [], None
    for line in open(csv):
        line = line.strip()
        if line.startswith('#'):
            if '=' in line:
                k, v = line[1:].strip().split('=', 1)
                meta[k.strip()] = v.strip()
            continue
        if header is None:
            header = line.split(',')
            continue
        rows.append(line.split(','))
    cols = {c: i for i, c in enumerate(header)}
    raw = np.array([[float(r[cols[c]]) for c in ('ax', 'ay', 'az', 'gx', 'gy', 'gz')] for r in rows])
    return raw[:, :3] * float(meta['accel_lsb_mps2']), raw[:, 3:] * float(meta['gyro_lsb_rad_s']), meta


def check(imuforge, work, seed):
    ok = True
    os.makedirs(work, exist_ok=True)
    model = os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', '..', 'docs', 'examples', 'model-basic.json')
    # 1. the 20-face fixture recording
    tr = fixture(work, seed)
    log = os.path.join(work, 'fixture_log.csv')
    run([imuforge, 'import', '--format', 'csv', '--in', os.path.join(work, 'fixture.csv'), '--map',
         os.path.join(work, 'fixture.map.json'), '--out', log])
    out = run([imuforge, 'solve', '--mode', 'reference-free', '--log', log, '--model', model, '--out',
               os.path.join(work, 'fixture.cal.json'), '--explain-poses'])
    cal = json.load(open(os.path.join(work, 'fixture.cal.json')))
    rf = cal['reference_free']
    acc, gyr, meta = read_log_si(log)
    n = rf['static_poses']
    print('fixture: %d poses found, %d placed (truth); accel_bits %s, gyro_bits %s' % (n, tr['poses'], rf['accel_bits'], rf['gyro_bits']))
    if abs(n - tr['poses']) > 1:
        print('FAIL: pose count %d, truth %d (+-1)' % (n, tr['poses']))
        print(out)
        ok = False
    if rf['accel_bits'] != 20 or rf['gyro_bits'] != 16:
        print('FAIL: word widths %s/%s, expected 20/16' % (rf['accel_bits'], rf['gyro_bits']))
        ok = False
    run([imuforge, 'solve', '--mode', 'reference-free', '--log', log, '--model', model, '--out',
         os.path.join(work, 'fixture.cal9.json'), '--no-term-selection'])
    cal9 = json.load(open(os.path.join(work, 'fixture.cal9.json')))
    tk, tk_n = imutk(acc, G, 1000)
    spans = tr['score_spans_s']
    print('fixture imuforge with the 9 basic terms only (--no-term-selection): %.3e m/s^2' %
          score_rms(acc, spans, cal_apply(cal9), G)[0])
    nominal, m = score_rms(acc, spans, lambda y: y, G)
    ours, _ = score_rms(acc, spans, cal_apply(cal), G)
    floor, _ = score_rms(acc, spans, truth_apply(tr), G)
    print('fixture |a|-g RMS over %d true still spans (1 s margins): nominal %.3e, imu_tk method %s (%d intervals), '
          'imuforge %.3e, truth %.3e m/s^2' % (m, nominal, '%.3e' % score_rms(acc, spans, tk, G)[0] if tk else 'n/a', tk_n,
                                                ours, floor))
    ts = rf.get('term_selection', {})
    print('fixture term selection: added %s, held-out RMS %.3e -> %.3e m/s^2 (%s)' % (
        ts.get('added'), ts.get('heldout_rms_basic_mps2', 0), ts.get('heldout_rms_selected_mps2', 0), ts.get('note')))
    if tk is None:
        print('FAIL: the imu_tk method found no calibration'); ok = False
    else:
        tkr = score_rms(acc, spans, tk, G)[0]
        print('fixture imuforge / imu_tk = %.2f (target <= 0.50)' % (ours / tkr))
        if not ours <= 0.5 * tkr:
            print('FAIL: imuforge %.3e is not at most half of imu_tk %.3e' % (ours, tkr)); ok = False
    if not ours < 2.0 * floor + 2e-4:
        print('FAIL: imuforge %.3e far above the truth floor %.3e' % (ours, floor)); ok = False
    # 2. the float hand-held export: si-csv at the default LSB, no false clipping at 8.4 rad/s
    th = handheld(work, seed)
    log2 = os.path.join(work, 'handheld_log.csv')
    run([imuforge, 'import', '--format', 'si-csv', '--in', os.path.join(work, 'handheld.csv'), '--out', log2])
    run([imuforge, 'solve', '--mode', 'reference-free', '--log', log2, '--model', model, '--out',
         os.path.join(work, 'handheld.cal.json')])
    cal2 = json.load(open(os.path.join(work, 'handheld.cal.json')))
    rf2 = cal2['reference_free']
    acc2, gyr2, meta2 = read_log_si(log2)
    print('handheld: peak |gyro| %.2f rad/s, gyro LSB %s rad/s, gyro_bits %s, transitions clipped %d of %d, poses %d (truth %d)' % (
        np.abs(gyr2).max(), meta2['gyro_lsb_rad_s'], rf2['gyro_bits'], rf2['transitions_clipped'],
        rf2['transitions_used'] + rf2['transitions_clipped'], rf2['static_poses'], th['poses']))
    if rf2['transitions_clipped'] != 0:
        print('FAIL: false clipping'); ok = False
    raw2 = np.loadtxt(os.path.join(work, 'handheld.csv'), delimiter=',', skiprows=1)
    if not (np.abs(raw2[:, 4:]).max() > 8.0 and np.abs(gyr2 - raw2[:, 4:]).max() <= float(meta2['gyro_lsb_rad_s'])):
        print('FAIL: the gyro (peak %.2f rad/s) did not survive the import' % np.abs(raw2[:, 4:]).max()); ok = False
    if abs(rf2['static_poses'] - th['poses']) > 1:
        print('FAIL: hand-held pose count %d, truth %d' % (rf2['static_poses'], th['poses'])); ok = False
    h_nom, _ = score_rms(acc2, th['score_spans_s'], lambda y: y, G)
    h_ours, _ = score_rms(acc2, th['score_spans_s'], cal_apply(cal2), G)
    print('handheld |a|-g RMS: nominal %.3e, imuforge %.3e m/s^2' % (h_nom, h_ours))
    if not h_ours < 0.2 * h_nom:
        print('FAIL: the hand-held calibration does not improve |a|'); ok = False
    print('PASS' if ok else 'FAIL')
    return 0 if ok else 1


def selftest():
    normals = icosahedron_face_normals()
    assert len(normals) == 20
    for n in normals:
        q = attitude_on_face(n, 1.0, np.zeros(3))
        f = qrot_inv(q[None, :], np.array([[0, 0, G]]))[0]
        assert np.allclose(f, -G * n, atol=1e-9), (f, n)
    # a constant body rate integrates to the right attitude
    rng = np.random.default_rng(1)
    w = np.array([0.3, -1.2, 2.0])
    tt = np.arange(1001) / 1000.0
    q = qexp(tt[:, None] * w[None, :])
    wk, _ = kinematics(tt, q, np.zeros((1001, 3)))
    assert np.allclose(wk[5:-5], w, atol=1e-9)
    # the imu_tk re-implementation recovers an exact 9-parameter model from perfect poses
    dirs = rng.normal(size=(30, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    T = np.eye(3) + np.array([[2e-3, 0, 0], [1e-3, -3e-3, 0], [-2e-3, 1.5e-3, 1e-3]])
    y = (G * dirs) @ T.T + np.array([0.1, -0.2, 0.05])
    p, ap = gravity_fit(y, G)
    assert np.abs(np.linalg.norm(ap(y), axis=1) - G).max() < 1e-9
    print('selftest PASS')
    return 0


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument('what', choices=['fixture', 'handheld', 'check', 'selftest'])
    ap.add_argument('--out', default='.')
    ap.add_argument('--work', default='/tmp/handplaced')
    ap.add_argument('--imuforge', default='build/host/bin/imuforge')
    ap.add_argument('--seed', type=int, default=17)
    a = ap.parse_args()
    if a.what == 'selftest':
        return selftest()
    if a.what == 'fixture':
        print(json.dumps({k: v for k, v in fixture(a.out, a.seed).items() if not k.endswith('spans_s')}))
        return 0
    if a.what == 'handheld':
        print(json.dumps({k: v for k, v in handheld(a.out, a.seed).items() if not k.endswith('spans_s')}))
        return 0
    return check(a.imuforge, a.work, a.seed)


if __name__ == '__main__':
    sys.exit(main())
