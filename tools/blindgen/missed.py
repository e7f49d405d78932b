#!/usr/bin/env python3
"""Per-case analysis of a blind battery run: present vs selected, and for each missed effect its entry in the
diagnosis ranking (ΔBIC, held-out shrink, significance, implausible components), plus unexplained axes.
`--ceiling` adds how far each present effect stands above the noise in the diagnosis's OWN fit of it
(the largest |truth| / σ over its components, σ from the first-step ranking fit under the diagnosis's noise
model): recall per band of that ratio. An effect below ~3 of its own σ cannot be told from the noise by any
selection rule; what is missed above it is the selection's.
`--coverage` adds whether the reported σ covers the truth: for every selected effect that is present, each of
its components in the final fit (`parameters`) against the truth (0 where the case did not inject it), as
|z| = |value − truth| / σ, per effect: how many within 3σ, the median and the largest |z|.
`--truth` reads the truth from another folder of cases: the second source's outputs sit in WORK/sim/<case>.

  missed.py WORK/cases [--tag diag] [--ceiling] [--coverage]
  missed.py WORK/sim --truth WORK/cases --tag TAG --coverage
"""
import argparse
import json
import math
import os


def own_snr(d, t, effect):
    """max over the effect's components of |truth| / σ of the diagnosis's first-step fit (0: not fitted)."""
    for r in d.get('ranking', []):
        if r['sensor'] + '.' + r['effect'] != effect:
            continue
        sig = {m['name']: m['sigma'] for m in r.get('magnitude', []) if m.get('sigma')}
        z = [abs(v) / sig[n] for n, v in t.get('parameters', {}).items() if n.startswith(effect + '.') and sig.get(n)]
        return max(z) if z else 0.0
    return 0.0


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument('cases')
    ap.add_argument('--tag', default='diag')
    ap.add_argument('--ceiling', action='store_true', help='recall by the effect\'s size over its own fitted sigma')
    ap.add_argument('--coverage', action='store_true', help='selected true effects: final-fit components within 3 sigma of the truth')
    ap.add_argument('--truth', help='folder of the cases holding truth.json (default: the cases folder itself)')
    a = ap.parse_args()
    cover = {}  # effect (no sensor) -> list of |z|
    bands = [(0, 1), (1, 3), (3, 5), (5, 10), (10, math.inf)]
    tally = {b: [0, 0] for b in bands}
    for name in sorted(os.listdir(a.cases)):
        dj = os.path.join(a.cases, name, a.tag, 'diagnosis.json')
        tj = os.path.join(a.truth or a.cases, name, 'truth.json')
        if not (os.path.exists(dj) and os.path.exists(tj)):
            continue
        d, t = json.load(open(dj)), json.load(open(tj))
        present = set(t.get('beyond_model', []))
        snr = t.get('snr', {})
        sel = {s['sensor'] + '.' + s['effect'] for s in d.get('selected', [])}
        rank = {r['sensor'] + '.' + r['effect']: (i, r) for i, r in enumerate(d.get('ranking', []))}
        print('%s: present %d, selected %s, false %s' % (name, len(present), sorted(sel & present), sorted(sel - present)))
        for u in d.get('unexplained', []):
            print('   unexplained %s chi2/dof %.1f withdrawn %s' % (u['axis'], u['chi2_dof_after'], u.get('withdrawn')))
        for e in sorted(present - sel):
            i, r = rank.get(e, (None, {}))
            print('   missed %-28s snr %7.1f own %5.1f rank %s dBIC %s shrink%% %s sig %s impl %s' % (
                e, snr.get(e, float('nan')), own_snr(d, t, e), i, '%.1f' % r['delta_bic'] if r.get('delta_bic') is not None else '-',
                '%.1f' % r['heldout_shrink_pct'] if r.get('heldout_shrink_pct') is not None else '-', r.get('significant'), r.get('implausible')))
        fitted = {p['name']: p for p in d.get('parameters', []) if p.get('sigma')}
        for e in sorted(sel & present):
            for n, p in fitted.items():
                if n.startswith(e + '.'):
                    z = abs(p['value'] - t.get('parameters', {}).get(n, 0.0)) / p['sigma']
                    # components on an axis named unexplained are flagged by the diagnosis (not a finding)
                    cover.setdefault(('[flagged] ' if p.get('on_unexplained_axis') else '') + e.split('.', 1)[1], []).append(z)
        if t.get('kind') in ('random', 'example'):
            for e in present:
                z = own_snr(d, t, e)
                for b in bands:
                    if b[0] <= z < b[1]:
                        tally[b][0] += 1
                        tally[b][1] += e in sel
    if a.ceiling:
        print('\nrecall of the random and example cases by |truth| / own fitted sigma (largest component):')
        n_all = sum(v[0] for v in tally.values())
        for b in bands:
            n, k = tally[b]
            print('  %4g - %-4g: %3d effects, %3d selected (%s)' % (b[0], b[1], n, k, '%.2f' % (k / n) if n else '-'))
        print('  all        : %3d effects, %3d selected' % (n_all, sum(v[1] for v in tally.values())))
    if a.coverage:
        print('\nselected true effects, final-fit components against the truth (|z| = |value - truth| / sigma):')
        for e in sorted(cover):
            z = sorted(cover[e])
            print('  %-20s %4d components, %4d within 3 sigma (%.2f), median |z| %.2f, max %.1f' % (
                e, len(z), sum(1 for x in z if x <= 3), sum(1 for x in z if x <= 3) / len(z), z[len(z) // 2], z[-1]))
        z = [x for k, v in cover.items() if not k.startswith('[flagged]') for x in v]
        if z:
            print('  %-20s %4d components, %4d within 3 sigma (%.2f)' % ('all unflagged', len(z), sum(1 for x in z if x <= 3), sum(1 for x in z if x <= 3) / len(z)))


if __name__ == '__main__':
    main()
