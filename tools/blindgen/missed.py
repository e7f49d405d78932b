#!/usr/bin/env python3
"""Per-case analysis of a blind battery run: present vs selected, and for each missed effect its entry in the
diagnosis ranking (ΔBIC, held-out shrink, significance, implausible components), plus unexplained axes.

  missed.py WORK/cases [--tag diag]
"""
import argparse
import json
import os


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument('cases')
    ap.add_argument('--tag', default='diag')
    a = ap.parse_args()
    for name in sorted(os.listdir(a.cases)):
        dj = os.path.join(a.cases, name, a.tag, 'diagnosis.json')
        tj = os.path.join(a.cases, name, 'truth.json')
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
            print('   missed %-28s snr %7.1f rank %s dBIC %s shrink%% %s sig %s impl %s' % (
                e, snr.get(e, float('nan')), i, '%.1f' % r['delta_bic'] if r else '-',
                '%.1f' % r['heldout_shrink_pct'] if r else '-', r.get('significant'), r.get('implausible')))


if __name__ == '__main__':
    main()
