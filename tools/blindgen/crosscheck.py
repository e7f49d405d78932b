#!/usr/bin/env python3
"""Convention cross-check: one catalog effect at a time, noise-free, through blindgen AND `imuforge simulate`
on the same scenario (tools/blindgen/campaign.py mirrors it). Per static pose and per constant-rate dwell
about a vertical axis, the mean of (output - reference) must agree between the two generators. A sign,
index or unit slip in either one shows up as a disagreement of the size of the effect itself.

  crosscheck.py --imuforge build/host/bin/imuforge --work /tmp/xc
Exit 1 when an effect disagrees by more than 2 % of its own signal (plus a small absolute floor).
"""
import argparse
import json
import os
import subprocess
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import blindgen  # noqa: E402
from campaign import write_campaign  # noqa: E402

# (effect key, components): magnitudes large enough to dominate rounding, small enough to stay linear
EFFECTS = [
    ('accel.bias', {'x': 0.1, 'y': -0.2, 'z': 0.3}),
    ('accel.scale', {'x': 0.01, 'y': -0.02, 'z': 0.015}),
    ('accel.misalign', {'xy': 0.01, 'xz': -0.02, 'yx': 0.015, 'yz': 0.005, 'zx': -0.01, 'zy': 0.02}),
    ('accel.scale_nonlinearity', {'x.k2': 1e-3, 'y.k3': 1e-4, 'z.k2': -1e-3}),
    ('accel.scale_asymmetry', {'x': 0.01, 'y': -0.02, 'z': 0.015}),
    ('accel.cross_coupling', {'xy': 1e-3, 'xz': -2e-3, 'yz': 1.5e-3, 'zx': 1e-3}),
    ('accel.cross_axis_nonlinearity', {'x.yy': 1e-3, 'x.yz': -2e-3, 'y.zz': 1.5e-3, 'y.zx': -1e-3, 'z.xy': 1e-3, 'z.xx': -1e-3}),
    ('accel.size_effect', {'x.rx': 0.01, 'y.ry': -0.02, 'z.rz': 0.015, 'x.ry': 0.01, 'z.rx': -0.01}),
    ('gyro.bias', {'x': 0.01, 'y': -0.02, 'z': 0.03}),
    ('gyro.scale', {'x': 0.01, 'y': -0.02, 'z': 0.015}),
    ('gyro.misalign', {'xy': 0.01, 'xz': -0.02, 'yx': 0.015, 'yz': 0.005, 'zx': -0.01, 'zy': 0.02}),
    ('gyro.scale_nonlinearity', {'x.k2': 1e-2, 'y.k3': 1e-2, 'z.k2': -1e-2}),
    ('gyro.scale_asymmetry', {'x': 0.01, 'y': -0.02, 'z': 0.015}),
    ('gyro.cross_coupling', {'xy': 1e-2, 'xz': -2e-2, 'yz': 1.5e-2, 'zx': 1e-2}),
    ('gyro.g_sensitivity', {'xx': 1e-3, 'xy': -2e-3, 'yz': 1.5e-3, 'zx': 1e-3, 'zz': -1e-3}),
    ('gyro.g2_sensitivity', {'x.xy': 1e-4, 'y.yz': -2e-4, 'z.zx': 1.5e-4}),
]


def ideal_sensor():
    s = blindgen.class_sensor('automotive')
    s['effects'] = {}
    s['thermal']['self_heating_C'] = 0.0
    return s




def read_csv(path):
    meta = {}
    with open(path) as f:
        for line in f:
            if line.startswith('# '):
                k, v = line[2:].strip().split('=', 1)
                meta[k] = v
            else:
                header = line.strip().split(',')
                break
        data = np.loadtxt(f, delimiter=',', ndmin=2)
    col = {h: i for i, h in enumerate(header)}
    return meta, col, data


def residual_means(path, labels_per_segment):
    meta, col, d = read_csv(path)
    la, lg = float(meta['accel_lsb_mps2']), float(meta['gyro_lsb_rad_s'])
    seg = d[:, col['segment']].astype(int)
    y = np.column_stack([d[:, col[c]] * la for c in ('ax', 'ay', 'az')] + [d[:, col[c]] * lg for c in ('gx', 'gy', 'gz')])
    ref = np.column_stack([d[:, col[c]] for c in ('f_ref_x', 'f_ref_y', 'f_ref_z', 'w_ref_x', 'w_ref_y', 'w_ref_z')])
    out = {}
    count = {}
    for sid, lab in labels_per_segment:
        m = seg == sid
        if not np.any(m):
            continue
        # drop the first and last 10 % of a dwell (the project's table settles; blindgen jumps)
        idx = np.nonzero(m)[0]
        k = max(1, len(idx) // 10)
        idx = idx[k:-k]
        n = count.get(lab, 0)
        count[lab] = n + 1
        out[(lab, n)] = ((y[idx] - ref[idx]).mean(0), ref[idx].mean(0))
    return out


def comparable(label):
    return label == 'pose' or label.startswith('rate ')


# Effects whose regressor depends on the thermal history or on time: recovered from each log by least squares
# on the log's OWN columns (temp_C, f_ref, t_s) with the documented regressor, then compared.
# (effect key, components, axis column, regressor name, true value)
THERMAL = [
    ('gyro.bias_temp', {'x.t1': 1e-3}, 'gx', 'tau', 1e-3),
    ('accel.temp_rate', {'y': 0.5}, 'ay', 'Tdot', 0.5),
    ('gyro.temp_hysteresis', {'z': 5e-3}, 'gz', 'd', 5e-3),
    ('accel.timing', {'latency_s': 2e-3}, 'ax', 'lat', 2e-3),
    ('accel.timing', {'ppm': 200.0}, 'az', 'ppm', 200.0),
]


def recover(path, axis_col, kind, T_ref=25.0, thr=0.5):
    meta, col, d = read_csv(path)
    la, lg = float(meta['accel_lsb_mps2']), float(meta['gyro_lsb_rad_s'])
    j = 'xyz'.index(axis_col[1])
    lsb = la if axis_col[0] == 'a' else lg
    refc = ('f_ref_' if axis_col[0] == 'a' else 'w_ref_') + axis_col[1]
    r = d[:, col[axis_col]] * lsb - d[:, col[refc]]
    t = d[:, col['t_s']]
    seg = d[:, col['segment']]
    T = d[:, col['temp_C']]
    fs = float(meta['sample_rate_hz'])
    if kind == 'tau':
        x = T - T_ref
        m = seg >= 0
    elif kind == 'Tdot':
        w = int(10 * fs)
        Tp = np.concatenate([np.full(w, T[0]), T, np.full(w, T[-1])])
        x = (Tp[2 * w:] - Tp[:-2 * w]) / (2 * w / fs)
        m = (seg >= 0) & (np.arange(len(T)) > w) & (np.arange(len(T)) < len(T) - w)
    elif kind == 'd':
        x = blindgen.hysteresis_direction(T, thr)
        m = seg >= 0
    else:
        # timing: residual = -(lambda + eps t) du/dt with u the reference input of that axis
        u = d[:, col[refc]]
        du = np.gradient(u, 1 / fs)
        x = -du if kind == 'lat' else -1e-6 * t * du
        # only smooth motion: |d2u| small (away from jumps and starts)
        m = (seg >= 0) & (np.abs(np.gradient(du, 1 / fs)) < 50) & (np.abs(du) > 1e-3)
    X = np.column_stack([x[m], np.ones(m.sum())])
    coef, *_ = np.linalg.lstsq(X, r[m], rcond=None)
    return coef[0]


def both_logs(imuforge, work, key, comps, spec, camp, seed):
    """The effect alone through blindgen and `imuforge simulate`: (blindgen log, simulate log, simulate truth)
    or None (after printing why) when the simulator refuses."""
    sensor = ideal_sensor()
    sensor['effects'] = {key: comps}
    d = os.path.join(work, key)
    os.makedirs(d, exist_ok=True)
    sp = os.path.join(d, 'sensor.json')
    with open(sp, 'w') as f:
        json.dump(sensor, f)
    case = {'seed': seed, 'scenario': spec, 'sensor': sensor, 'ooc': [], 'noise_extra': [], 'truth': {'kind': 'x'}}
    blindgen.generate(case, os.path.join(d, 'blind'), 'csv')
    simlog = os.path.join(d, 'sim.csv')
    tr = os.path.join(d, 'sim_truth.json')
    p = subprocess.run([imuforge, 'simulate', '--campaign', camp, '--sensor', sp, '--seed', str(seed), '--out', simlog,
                        '--truth', tr, '--no-fixture-errors', '--quiet'], stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    if p.returncode != 0:
        print('%-28s simulate failed: %s' % (key, p.stderr.decode()[:200]))
        return None
    return os.path.join(d, 'blind', 'log.csv'), simlog, tr


def discard_logs(mylog, simlog):
    """An effect's two logs (tens of MB each) once they agree: a run over the whole catalog would otherwise leave
    about 0.5 GB in the build tree, which a CI machine short of disk cannot spare. A disagreement keeps both."""
    for f in (mylog, simlog):
        if os.path.exists(f):
            os.remove(f)


def main(argv):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument('--imuforge', required=True)
    ap.add_argument('--work', required=True)
    ap.add_argument('--only')
    a = ap.parse_args(argv)
    os.makedirs(a.work, exist_ok=True)
    rng = np.random.default_rng(7)
    spec = blindgen.default_scenario(rng, 'short', 250.0)
    spec['plateaus_C'] = [25.0]
    spec['final_ramp'] = 0.0
    spec['sines'] = False
    spec['lever_arm_m'] = [0.0, 0.0, 0.0]
    spec['mount_error_rad'] = [0.0, 0.0, 0.0]
    spec['temp_noise_C'] = 0.0
    spec['chamber_noise_C'] = 0.0
    seed = 11
    camp = os.path.join(a.work, 'campaign.json')
    write_campaign(spec, camp, seed)
    scn = blindgen.build_scenario(np.random.default_rng(np.random.SeedSequence(seed).spawn(4)[0]), spec)
    my_labels = [(i, s.label) for i, s in enumerate(scn.segments)]
    bad = []
    print('%-28s %12s %12s %s' % ('effect', 'signal', 'max |diff|', 'verdict'))
    for key, comps in EFFECTS:
        if a.only and a.only not in key:
            continue
        logs = both_logs(a.imuforge, a.work, key, comps, spec, camp, seed)
        if logs is None:
            bad.append(key)
            continue
        mylog, simlog, tr = logs
        sim_labels = [(s['id'], s.get('label', '')) for s in json.load(open(tr))['segments']]
        mine = residual_means(mylog, my_labels)
        theirs = residual_means(simlog, sim_labels)
        sig, dif, worst = 0.0, 0.0, None
        for k, (r1, ref1) in mine.items():
            if not comparable(k[0]) or k not in theirs:
                continue
            r2, ref2 = theirs[k]
            if np.max(np.abs(ref1 - ref2)) > 1e-3 * (1 + np.max(np.abs(ref1))):
                continue  # not the same pose (should not happen)
            sig = max(sig, np.max(np.abs(r1)))
            dd = np.max(np.abs(r1 - r2))
            if dd > dif:
                dif, worst = dd, (k, r1, r2)
        ok = dif <= 0.02 * sig + 1e-6
        print('%-28s %12.4g %12.4g %s' % (key, sig, dif, 'agree' if ok else 'DISAGREE'))
        if ok:
            discard_logs(mylog, simlog)
        else:
            bad.append(key)
            k, r1, r2 = worst
            print('    worst %s: blindgen %s  imuforge %s' % (k, np.array2string(r1, precision=5), np.array2string(r2, precision=5)))
    # thermal history and timing: a scenario with three plateaus and a final ramp
    spec2 = dict(spec)
    spec2['plateaus_C'] = [25.0, 45.0, 10.0]
    spec2['final_ramp'] = 2.0
    camp2 = os.path.join(a.work, 'campaign2.json')
    write_campaign(spec2, camp2, seed)
    print('%-28s %12s %12s %12s %s' % ('effect (recovered)', 'true', 'blindgen', 'imuforge', 'verdict'))
    for key, comps, axc, kind, true in THERMAL:
        if a.only and a.only not in key:
            continue
        logs = both_logs(a.imuforge, a.work, key, comps, spec2, camp2, seed)
        if logs is None:
            bad.append(key)
            continue
        mylog, simlog, _ = logs
        thr = float(ideal_sensor()['thermal'].get('hysteresis_threshold_C', 0.5))
        c1 = recover(mylog, axc, kind, thr=thr)
        c2 = recover(simlog, axc, kind, thr=thr)
        ok = abs(c1 - c2) <= 0.1 * abs(true) and np.sign(c1) == np.sign(true)
        print('%-28s %12.4g %12.4g %12.4g %s' % (key + ' ' + '/'.join(comps), true, c1, c2, 'agree' if ok else 'DISAGREE'))
        if ok:
            discard_logs(mylog, simlog)
        else:
            bad.append(key)
    print('disagreements: %s' % (', '.join(bad) or 'none'))
    return 1 if bad else 0


if __name__ == '__main__':
    sys.exit(main(sys.argv[1:]))
