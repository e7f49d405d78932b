#!/usr/bin/env python3
"""How much of a battery's missed recall any selection rule could recover: the oracle ceiling.

For each random or example case of a battery run and each true beyond-model effect E the diagnosis missed,
the log is diagnosed again against the ORACLE model: the case's base model plus every other true effect
(and, where the sensor has a temperature hysteresis, its true threshold, so nothing is profiled). E is then
the only thing left to find, and its first-step entry in that run's ranking is the most favourable test the
diagnosis can give it: no missing effect inflating the residual, no competitor, the fewest candidates. A miss
that is not significant there (the same test as the selection's: family-wise α, held-out gain and shrink)
cannot be recovered by any order of selection; one that is significant there was lost by the path (a
competitor, a withdrawal, a check).

  oracle.py WORK/cases --imuforge BIN --tag TAG
  oracle.py WORK/sim --truth WORK/cases --imuforge BIN --tag TAGsim     (the second source)

Prints one line per miss and, per kind, the recall observed and its ceiling:
(selected + misses significant under the oracle) / present. Slow: one diagnosis per miss.
"""
import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile

from missed import own_snr  # |truth| / σ of a ranking entry (this script's folder is on sys.path)

REPO = os.path.abspath(os.path.join(os.path.dirname(__file__), '..', '..'))


def oracle_model(truth, sensor, effect):
    """The case's base model plus every true beyond-model effect but `effect` (sensor.effect)."""
    path = truth.get('model', 'docs/examples/model-thermal.json')
    with open(path if os.path.isabs(path) else os.path.join(REPO, path)) as f:
        m = json.load(f)
    m['name'] = 'oracle-without-' + effect
    for e in truth.get('beyond_model', []):
        if e != effect:
            m['effects'][e] = {}
    thr = (sensor.get('thermal') or {}).get('hysteresis_threshold_C')
    if thr is not None and any(k.endswith('.temp_hysteresis') for k in truth.get('beyond_model', [])):
        m['hysteresis_threshold_C'] = float(thr)
    return m


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument('cases', help='folder of cases, each with log.bin (or log.csv) and TAG/diagnosis.json')
    ap.add_argument('--imuforge', required=True)
    ap.add_argument('--tag', default='diag', help='the diagnosis whose misses are tested')
    ap.add_argument('--truth', help='folder holding each case\'s truth.json and sensor.json (default: the cases folder)')
    ap.add_argument('--json', help='write the per-miss results and the ceilings here')
    a = ap.parse_args()
    tally = {}  # kind -> [present, selected, oracle-significant misses]
    rows = []
    work = tempfile.mkdtemp(prefix='oracle-')
    try:
        for name in sorted(os.listdir(a.cases)):
            case = os.path.join(a.cases, name)
            tdir = os.path.join(a.truth or a.cases, name)
            dj = os.path.join(case, a.tag, 'diagnosis.json')
            if not (os.path.exists(dj) and os.path.exists(os.path.join(tdir, 'truth.json'))):
                continue
            with open(os.path.join(tdir, 'truth.json')) as f:
                truth = json.load(f)
            if truth.get('kind') not in ('random', 'example'):
                continue
            sensor = {}
            if os.path.exists(os.path.join(tdir, 'sensor.json')):
                with open(os.path.join(tdir, 'sensor.json')) as f:
                    sensor = json.load(f)
            log = next((os.path.join(case, n) for n in ('log.bin', 'log.csv') if os.path.exists(os.path.join(case, n))), None)
            if log is None:
                sys.exit('oracle.py: %s: no log.bin or log.csv' % case)
            with open(dj) as f:
                d = json.load(f)
            present = set(truth.get('beyond_model', []))
            sel = {s['sensor'] + '.' + s['effect'] for s in d.get('selected', [])}
            t = tally.setdefault(truth['kind'], [0, 0, 0])
            t[0] += len(present)
            t[1] += len(present & sel)
            for e in sorted(present - sel):
                mp = os.path.join(work, 'model.json')
                with open(mp, 'w') as f:
                    json.dump(oracle_model(truth, sensor, e), f)
                out = os.path.join(work, 'out')
                shutil.rmtree(out, ignore_errors=True)
                p = subprocess.run([a.imuforge, 'diagnose', '--log', log, '--model', mp, '--out', out], capture_output=True, text=True)
                if p.returncode != 0:
                    sys.exit('oracle.py: %s %s: imuforge diagnose failed: %s' % (name, e, p.stderr.strip()[-400:]))
                with open(os.path.join(out, 'diagnosis.json')) as f:
                    od = json.load(f)
                r = next((r for r in od.get('ranking', []) if r['sensor'] + '.' + r['effect'] == e), None)
                if r is None:
                    row = {'case': name, 'effect': e, 'ranked': False, 'significant': False}
                else:
                    row = {'case': name, 'effect': e, 'ranked': True, 'significant': bool(r.get('significant')),
                           'p_value': r.get('p_value'), 'heldout_shrink_pct': r.get('heldout_shrink_pct'),
                           'oracle_snr': own_snr(od, truth, e)}
                t[2] += row['significant']
                rows.append(row)
                print('%-22s %-28s oracle |truth|/sigma %7.1f  p %-9s shrink %-7s %s' % (
                    name, e, row.get('oracle_snr', 0.0), '%.2g' % row['p_value'] if row.get('p_value') is not None else '-',
                    '%.0f%%' % row['heldout_shrink_pct'] if row.get('heldout_shrink_pct') is not None else '-',
                    'SIGNIFICANT: lost by the path' if row['significant'] else 'not significant: beyond any rule'), flush=True)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    print('\nrecall observed and its oracle ceiling ((selected + misses significant under the oracle) / present):')
    ceil = {}
    for kind, (n, k, s) in sorted(tally.items()):
        if n:
            ceil[kind] = {'present': n, 'selected': k, 'recoverable': s, 'recall': k / n, 'ceiling': (k + s) / n}
            print('  %-8s %4d present, %4d selected (%.3f), %3d more significant under the oracle: ceiling %.3f' % (kind, n, k, k / n, s, (k + s) / n))
    if a.json:
        with open(a.json, 'w') as f:
            json.dump({'misses': rows, 'ceiling': ceil}, f, indent=1)


if __name__ == '__main__':
    main()
