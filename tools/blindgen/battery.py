#!/usr/bin/env python3
"""The blind battery: runs the real `imuforge diagnose` on cases written by blindgen.py (an independent
generator) or by `imuforge simulate` (the project's own simulator, second source), and scores the
diagnosis against the acceptance figures of issue 12 (docs/diagnosis.md, "Blind battery").

  battery.py --imuforge build/host/bin/imuforge --suite smoke --work /tmp/blind      # the ctest subset
  battery.py --imuforge build/host/bin/imuforge --suite full --work /tmp/blind       # the benchmark
  battery.py ... --suite holdout   # stochastic + mixed cases at seeds no change was tuned on (stop 24)
  battery.py ... --suite varied    # every kind on another lab's schedule (blindgen size 'varied', stop 25)
  battery.py ... --suite varied2 / varied3 / varied4 / varied5 / varied6 / varied7 / varied8 / varied9 / varied10 / varied11 / varied12 / varied13 / varied14 / varied15   # the same schedule at fresh seeds (stops 26, 29, 30, 31, 36–42, 44–46)
  battery.py ... --source simulate      # same sensors through `imuforge simulate` (catalog effects only)
  battery.py ... --floors tools/blindgen/floors-smoke.json   # exit 1 when a figure falls below its floor

Scoring (against model-thermal unless the case says otherwise):
  recall    = |selected ∩ beyond-model effects present| / |beyond-model effects present|
  false     = selected effects that are not present (stochastic findings in `selected` are not counted)
  ooc pass  = nothing selected and every affected axis is named in `unexplained`; ooc.pass_detectable asks only
              for the axes whose term stands >= DETECTABLE_SNR above what the base model absorbs (blindgen 'ooc:' snr)
  null pass = nothing selected and `unexplained` empty (absent key = nothing flagged)
  stochastic at_noise = the same for a stochastic-only case (colored noise, random walk, a coarse output step)
  single    = top-1 of the deterministic ranking is the injected effect; magnitude: every injected
              component within 3 sigma of the truth (final joint fit if selected, else the ranking's fit)
"""
import argparse
import hashlib
import json
import math
import os
import shutil
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import blindgen  # noqa: E402

REPO = blindgen.repo_root()
STOCH_EFFECTS = {'white_noise', 'bias_instability', 'rate_random_walk', 'quantization', 'saturation', 'turn_on_bias',
                 'flicker', 'gauss_markov'}

DETECTABLE_SNR = 10.0  # blindgen's detectability estimate (truth.json "snr") above which an effect counts as detectable

# acceptance figures of issue 12 (name: (target, 'min' | 'max'))
TARGETS = {
    'random.mean_recall': (0.90, 'min'),
    'random.frac_le1_false': (0.90, 'min'),
    'example.automotive.recall': (0.90, 'min'),
    'example.automotive.false': (1, 'max'),
    'example.automotive.max_chi2_after': (3.0, 'max'),
    'example.automotive-eol.recall': (0.90, 'min'),
    'example.automotive-eol.false': (1, 'max'),
    'example.automotive-eol.max_chi2_after': (3.0, 'max'),
    'single.top1': (0.95, 'min'),
    'single.mag3sigma': (0.95, 'min'),
    'ooc.pass': (0.90, 'min'),
    'null.pass': (0.95, 'min'),
    'stochastic.nothing_selected': (0.95, 'min'),
}


def varied_fresh(seed0, per_class_null, per_class_stoch, n_random, ooc_each, full_catalog=False):
    """Cases of blindgen size 'varied' at seeds seed0 + 0.., +100.., +200.., +300.. (ooc), +390.. (mixed).
    full_catalog: the random and mixed cases draw from every catalog effect (blindgen.TYPICAL_LATER too)."""
    cases = []
    extra = {'full_catalog': True} if full_catalog else {}
    for i, cls in enumerate(blindgen.CLASSES * per_class_null):
        cases.append(('null-%s-%d' % (cls, i), 'null', seed0 + i, {'cls': cls, 'size': 'varied'}))
    for i, cls in enumerate(blindgen.CLASSES * per_class_stoch):
        cases.append(('stoch-%s-%d' % (cls, i), 'stochastic', seed0 + 100 + i, {'cls': cls, 'size': 'varied'}))
    for i in range(n_random):
        cases.append(('random-%d' % i, 'random', seed0 + 200 + i, dict({'size': 'varied'}, **extra)))
    for k, kind in enumerate(blindgen.OOC_KINDS):
        for i in range(ooc_each):
            name = 'ooc-%s-%d' % (kind, i) if ooc_each > 1 else 'ooc-%s' % kind
            seed = seed0 + 300 + 10 * k + i if ooc_each > 1 else seed0 + 300 + k
            cases.append((name, 'ooc', seed, {'ooc': kind, 'size': 'varied'}))
        cases.append(('mixed-%s' % kind, 'mixed', seed0 + (390 if ooc_each > 1 else 400) + k, dict({'ooc': kind, 'size': 'varied'}, **extra)))
    return cases


def unseen_kinds(kinds, seed0):
    """Three cases of each out-of-catalog kind alone and one beside catalog effects, the varied schedule: alone at
    seeds seed0 + 10 k + i, beside at seed0 + 100 + k."""
    cases = []
    for k, kind in enumerate(kinds):
        for i in range(3):
            cases.append(('ooc-%s-%d' % (kind, i), 'ooc', seed0 + 10 * k + i, {'ooc': kind, 'size': 'varied'}))
        cases.append(('mixed-%s' % kind, 'mixed', seed0 + 100 + k, {'ooc': kind, 'size': 'varied'}))
    return cases


def suite(name):
    """(case name, kind, seed, options) of a suite."""
    cases = []
    if name == 'smoke':
        # a few short cases and one of the varied schedule: ~2-3 min in total on a loaded 2-core machine
        for s in (101, 104):  # 104: no table columns (seed % 4 == 0)
            cases.append(('random-%d' % s, 'random', s, {'size': 'short'}))
        cases.append(('null-201', 'null', 201, {'size': 'short', 'cls': 'automotive'}))
        cases.append(('stoch-301', 'stochastic', 301, {'size': 'short', 'cls': 'automotive'}))
        cases.append(('ooc-heading-401', 'ooc', 401, {'size': 'short', 'ooc': 'heading', 'cls': 'automotive'}))
        cases.append(('single-gyro.g_sensitivity-501', 'single', 501, {'size': 'short', 'effect': 'gyro.g_sensitivity', 'cls': 'automotive'}))
        cases.append(('ooc-g_cubed-402', 'ooc', 402, {'size': 'short', 'ooc': 'g_cubed', 'cls': 'automotive'}))
        cases.append(('example-automotive', 'example', 3, {'size': 'short', 'sensor': 'docs/examples/sensor-automotive.json'}))
        # varied6 stoch-automotive-10 (stop 36): an accel.z random walk the 6 s dwells read as flicker took
        # accel.temp_rate for itself, and hid from the re-test the very wander that explains it
        # The varied schedule's logs run to hours (up to 1.2 M rows): written binary, so the work folder stays small.
        cases.append(('stoch-varied-11610', 'stochastic', 11610, {'cls': 'automotive', 'size': 'varied', 'log_format': 'bin'}))
        # varied6 stoch-consumer-6 (stop 37): a gyro.z output step with 0.26 step of noise ahead of it, whose
        # rounding bias the temperature carries through the steps: a line of period 284 s in the whole log's
        # residual, within the rounding staircase, was named unexplained
        cases.append(('stoch-varied-11606', 'stochastic', 11606, {'cls': 'consumer', 'size': 'varied', 'log_format': 'bin'}))
        # varied7 random-10 (stop 37): a 0.42 mrad mount beside a 2.8e-3 gyro cross-coupling; the selected false
        # g2_sensitivity and scale_nonlinearity took the rotation's signature from the mount estimate
        cases.append(('random-varied-12210', 'random', 12210, {'size': 'varied', 'log_format': 'bin'}))
        # varied4 stoch-automotive-7 (stop 38): an accel.y random walk the dwells read as flicker B 1.67e-3; raised
        # beside that flicker held, the walk came out 36 % short and accel.temp_rate kept its evidence (p 4.2e-4)
        cases.append(('stoch-varied-10607', 'stochastic', 10607, {'cls': 'automotive', 'size': 'varied', 'log_format': 'bin'}))
        # varied8 random-10 (stop 38): a gyro scale_nonlinearity of 2.6 rad/s at 1351 deg/s (snr 6e4) withdrawn by the
        # form check for a remainder of 5.5e-5 of its signal; gyro.x and gyro.z were then named unexplained
        cases.append(('random-varied-12710', 'random', 12710, {'size': 'varied', 'log_format': 'bin'}))
        # varied9 null-tactical-2 (stop 39): a 300 s bias instability the dwells read at B 3.4e-6 (upper 4.9e-6,
        # truth 5.8e-6); gyro.z stood at held-out chi2/dof 5.8 on the point estimate and was named unexplained
        cases.append(('null-varied-13002', 'null', 13002, {'cls': 'tactical', 'size': 'varied', 'log_format': 'bin'}))
        # varied9 random-11 (stop 39): a 0.435 ms gyro latency at 100 Hz, no sines; the steps read it late at 4 of
        # 109 (none early), below the old sign rule's count, and the timing went unnamed
        cases.append(('random-varied-13211', 'random', 13211, {'size': 'varied', 'log_format': 'bin'}))
        # unseen11 ooc-axis_skew-0 (stop 63): gyro.z sampled 0.49 ms early and accel.y 3.5 ms late, the gyro's
        # latency seen only on sines in two of the five folds. Without either, the fold fit's latency and clock drift
        # per axis are pinned only as one combination, and its extrapolation raised the withheld blocks' plain chi2
        # from 766 to 8925: a latency fitted at 25 sigma scored -451 %, unselected, gyro.z unnamed. Passes with the
        # timing's block gain on the predictive chi2 (Options::heldout_gain_predictive).
        cases.append(('ooc-axis_skew-44020', 'ooc', 44020, {'ooc': 'axis_skew', 'size': 'varied', 'log_format': 'bin'}))
        # varied39 stoch-consumer-3 (stop 68): accel.x rounded to 0.13 m/s^2 at 0.33 step of noise beside flicker
        # B 9.5e-4, no deterministic effect; f_z*T passed the follows bar (LR 41.5 over 108 functions) on a rounding
        # bias the die temperature carries through the steps, and the axis was named unexplained. Passes with the
        # rounding rule asked of what the function takes (rms 0.0017, the staircase's sigma 0.0033)
        cases.append(('stoch-varied-55103', 'stochastic', 55103, {'cls': 'consumer', 'size': 'varied', 'log_format': 'bin'}))
        # unseen15 ooc-beat_chirp-0 (stop 68): a gyro.z bias beating at ~170 s whose frequency follows the die
        # temperature; the static dwells read it as a rate random walk of K 4.2e-5 (the part's: 4e-9), the walk
        # raised on the whole log gained only 22.7 (a line at p 7.5e-11 under it) and gyro.z went unnamed at held-out
        # chi2/dof 0.83. Passes with the line's own sinusoid weighed (gain 115)
        cases.append(('ooc-beat_chirp-52010', 'ooc', 52010, {'ooc': 'beat_chirp', 'size': 'varied', 'log_format': 'bin'}))
        # unseen17 ooc-thermal_gradient-2 (stop 71): a gyro.x and an accel.z bias in the die's temperature minus a lag
        # of 470 and 710 s (a board following the die), blindgen SNR 303 and 129; the whole log's wander took each for a
        # random walk (9.1x and 7.6x the dwells'), Tdot gained LR 18 beside it (bar 34), and both axes went unnamed.
        # Passes with the die-to-board gradient among the followed functions (LR 117 and 67)
        cases.append(('ooc-thermal_gradient-56002', 'ooc', 56002, {'ooc': 'thermal_gradient', 'size': 'varied', 'log_format': 'bin'}))
        # varied40 ooc-periodic-1 (stop 71): an accel.z bias of period 536 s (SNR 560) named for its line within the
        # held-out threshold, beside a false accel.temp_rate whose z component took the line's share that Tdot
        # follows. Passes with the stand-in check asking the line's sinusoid (the effect beside it: LR 0.0)
        cases.append(('ooc-periodic-57341', 'ooc', 57341, {'ooc': 'periodic', 'size': 'varied', 'log_format': 'bin'}))
        # unseen18 ooc-temp_exp-1 (stop 72): a consumer accel.y bias doubling every 9.3 degC over 0-40 degC (blindgen
        # SNR 28) that the whole log's walk took beside the model's quadratic in T; the hats of T read LR 49 on 10 dof
        # (p 3.9e-7, bar 2.2e-9) and the axis went unnamed. Passes with (T - mean)^3 among the followed functions (LR
        # 35.7 against a bar of 34.4: a thin margin, kept as it is, so that a change that costs it shows here)
        cases.append(('ooc-temp_exp-58011', 'ooc', 58011, {'ooc': 'temp_exp', 'size': 'varied', 'log_format': 'bin'}))
        return cases
    if name == 'holdout':
        # cases no diagnosis change was tuned on (added at stop 24, after its changes were fixed): stochastic-only
        # and mixed cases at seeds outside the full suite's, to check that its figures carry over
        for i, cls in enumerate(blindgen.CLASSES * 8):
            cases.append(('stoch-%s-%d' % (cls, i), 'stochastic', 7000 + i, {'cls': cls}))
        for k, kind in enumerate(blindgen.OOC_KINDS):
            for i in range(2):
                cases.append(('mixed-%s-%d' % (kind, i), 'mixed', 8000 + 10 * k + i, {'ooc': kind}))
        return cases
    if name == 'varied':
        # the same kinds on another lab's schedule (blindgen size 'varied': 2-5 plateaus in any order, ramps,
        # short soaks, 2.5-10 s dwells, 2-4 rate levels, encoder noise), seeds 9000+; added at stop 25 to check
        # that nothing leans on the shape of the 'full' scenario
        for i, cls in enumerate(blindgen.CLASSES * 4):
            cases.append(('null-%s-%d' % (cls, i), 'null', 9000 + i, {'cls': cls, 'size': 'varied'}))
        for i, cls in enumerate(blindgen.CLASSES * 3):
            cases.append(('stoch-%s-%d' % (cls, i), 'stochastic', 9100 + i, {'cls': cls, 'size': 'varied'}))
        for i in range(15):
            cases.append(('random-%d' % i, 'random', 9200 + i, {'size': 'varied'}))
        for k, kind in enumerate(blindgen.OOC_KINDS):
            cases.append(('ooc-%s' % kind, 'ooc', 9300 + k, {'ooc': kind, 'size': 'varied'}))
            cases.append(('mixed-%s' % kind, 'mixed', 9400 + k, {'ooc': kind, 'size': 'varied'}))
        for k, eff in enumerate(blindgen.CANDIDATES[::3]):
            cases.append(('single-%s' % eff, 'single', 9500 + k, {'effect': eff, 'size': 'varied'}))
        return cases
    if name == 'varied2':
        # the varied schedule at new seeds (9600+), added at stop 26 after its change was fixed: nothing was tuned
        # on it; two out-of-catalog cases per kind, since the varied suite's one each cannot tell 0.9 from 0.75
        return varied_fresh(9600, per_class_null=4, per_class_stoch=3, n_random=10, ooc_each=2)
    if name == 'varied3':
        # the varied schedule at new seeds (10000+), added at stop 29 before any change of that stop: nothing was
        # tuned on it. Weighted to the cases where a false claim costs most (nothing beyond the model, stochastic
        # only) and to multi-effect recall.
        return varied_fresh(10000, per_class_null=5, per_class_stoch=5, n_random=15, ooc_each=1)
    if name == 'varied4':
        # the varied schedule at new seeds (10500+), added at stop 30 and run on the stop-29 binary before any change
        # of that stop: weighted to multi-effect recall, the figure still short of the issue's
        return varied_fresh(10500, per_class_null=3, per_class_stoch=3, n_random=20, ooc_each=1)
    if name == 'varied5':
        # the varied schedule at new seeds (11000+), added at stop 31 and run on the stop-30 binary before any change
        # of that stop: weighted to multi-effect recall
        return varied_fresh(11000, per_class_null=3, per_class_stoch=3, n_random=25, ooc_each=1)
    if name == 'varied6':
        # the varied schedule at new seeds (11500+), added at stop 36 and run on the stop-35 binary before any change
        # of that stop: a check that stop 35's Allan cut carries over, weighted to false claims and to recall
        return varied_fresh(11500, per_class_null=4, per_class_stoch=4, n_random=20, ooc_each=1)
    if name == 'varied7':
        # the varied schedule at new seeds (12000+), added at stop 37 and run on the stop-36 binary before any change
        # of that stop: weighted to multi-effect recall and to stochastic-only false claims
        return varied_fresh(12000, per_class_null=3, per_class_stoch=4, n_random=25, ooc_each=1)
    if name == 'varied8':
        # the varied schedule at new seeds (12500+), added at stop 38 and run on the stop-37 binary before any change
        # of that stop: weighted to the figures still short (stochastic-only false claims, out-of-catalog) and recall
        return varied_fresh(12500, per_class_null=3, per_class_stoch=5, n_random=20, ooc_each=2)
    if name == 'varied9':
        # the varied schedule at new seeds (13000+), added at stop 39 and run on the stop-38 binary before any change
        # of that stop: weighted to multi-effect recall, the figure furthest short, and to out-of-catalog cases
        return varied_fresh(13000, per_class_null=3, per_class_stoch=4, n_random=25, ooc_each=2)
    if name == 'varied10':
        # the varied schedule at new seeds (13500+), added at stop 40 and run on the stop-39 binary before any change
        # of that stop: weighted to multi-effect recall and to false claims on stochastic-only sensors
        return varied_fresh(13500, per_class_null=3, per_class_stoch=5, n_random=25, ooc_each=2)
    if name == 'varied11':
        # the varied schedule at new seeds (14000+), added at stop 41 and run on the stop-39 diagnosis before any
        # change: weighted to multi-effect recall and to out-of-catalog cases
        return varied_fresh(14000, per_class_null=3, per_class_stoch=4, n_random=25, ooc_each=2)
    if name == 'varied12':
        # the varied schedule at new seeds (14500+), added at stop 42 and run on the stop-41 binary before any
        # change: weighted to multi-effect recall and to false claims on stochastic-only sensors
        return varied_fresh(14500, per_class_null=3, per_class_stoch=5, n_random=25, ooc_each=2)
    if name == 'varied13':
        # the varied schedule at new seeds (15000+), added at stop 44 and run on the stop-43 binary before any
        # change: weighted to multi-effect recall and to out-of-catalog cases
        return varied_fresh(15000, per_class_null=3, per_class_stoch=4, n_random=25, ooc_each=2)
    if name == 'varied14':
        # the varied schedule at new seeds (16000+), added at stop 45 and run on the stop-44 binary before any
        # change: weighted to null sensors (stop 45 changes how a withheld segment is scored)
        return varied_fresh(16000, per_class_null=5, per_class_stoch=3, n_random=20, ooc_each=2)
    if name == 'varied15':
        # the varied schedule at new seeds (17000+), added at stop 46 and run on the stop-45 binary before any
        # change: weighted to multi-effect recall (the figure still short) and to out-of-catalog cases
        return varied_fresh(17000, per_class_null=2, per_class_stoch=2, n_random=30, ooc_each=2)
    if name == 'unseen':
        # out-of-catalog kinds written at stop 44 and first run on the stop-43 binary (a warm-up transient, a
        # linear ageing drift), which nothing in the diagnosis had been tuned on; stop 44's drift and settling
        # checks were developed on it. Four alone and two beside catalog effects per kind, the varied schedule
        # at seeds 15500+
        for k, kind in enumerate(blindgen.OOC_KINDS_UNSEEN):
            for i in range(4):
                cases.append(('ooc-%s-%d' % (kind, i), 'ooc', 15500 + 10 * k + i, {'ooc': kind, 'size': 'varied'}))
            for i in range(2):
                cases.append(('mixed-%s-%d' % (kind, i), 'mixed', 15600 + 10 * k + i, {'ooc': kind, 'size': 'varied'}))
        return cases
    if name == 'unseen2':
        # out-of-catalog kinds written at stop 46 and first run on the stop-45 binary (an accel bias odd in the
        # rate, a gyro bias in another axis' rate squared, a bias step at a die temperature, a scale moving with
        # time). Three alone and one beside catalog effects per kind, the varied schedule at seeds 17500+
        return unseen_kinds(blindgen.OOC_KINDS_UNSEEN2, 17500)
    if name == 'unseen3':
        # out-of-catalog kinds written at stop 47 and first run on the stop-46 binary (a g-sensitivity moving with
        # temperature, a g-dependent scale factor, a bias flipping with the rotation's direction). Three alone and
        # one beside catalog effects per kind, the varied schedule at seeds 18500+
        return unseen_kinds(blindgen.OOC_KINDS_UNSEEN3, 18500)
    if name == 'varied16':
        # the varied schedule at new seeds (18000+), added at stop 47 and run on the stop-46 binary before any change
        return varied_fresh(18000, per_class_null=2, per_class_stoch=2, n_random=30, ooc_each=2)
    if name == 'varied17':
        # the varied schedule at new seeds (19000+), added at the end of stop 47 and run once on its final binary
        return varied_fresh(19000, per_class_null=2, per_class_stoch=2, n_random=30, ooc_each=2)
    if name == 'varied18':
        # the varied schedule at new seeds (20000+), added at stop 48 and run on the stop-47 binary before any change
        return varied_fresh(20000, per_class_null=2, per_class_stoch=2, n_random=30, ooc_each=2)
    if name == 'varied19':
        # the varied schedule at new seeds (21000+), added at stop 49 and run on the stop-48 binary before any change
        return varied_fresh(21000, per_class_null=2, per_class_stoch=2, n_random=30, ooc_each=2)
    if name == 'varied20':
        # the varied schedule at new seeds (22000+), added at stop 50 and run on the stop-49 binary before any change
        return varied_fresh(22000, per_class_null=2, per_class_stoch=2, n_random=30, ooc_each=2)
    if name == 'varied21':
        # the varied schedule at new seeds (23000+), added at stop 51 and run on the stop-50 binary before any change
        return varied_fresh(23000, per_class_null=2, per_class_stoch=2, n_random=30, ooc_each=2)
    if name == 'varied22':
        # the varied schedule at new seeds (24000+), added at stop 52 and run on the stop-51 binary before any change
        return varied_fresh(24000, per_class_null=2, per_class_stoch=2, n_random=30, ooc_each=2)
    if name == 'varied23':
        # the varied schedule at new seeds (25000+), added at stop 53 and run on the stop-52 diagnosis before any change
        return varied_fresh(25000, per_class_null=2, per_class_stoch=2, n_random=30, ooc_each=2)
    if name == 'varied24':
        # the varied schedule at new seeds (26000+), added at stop 54 and run on the stop-53 binary before any change
        return varied_fresh(26000, per_class_null=2, per_class_stoch=2, n_random=30, ooc_each=2)
    if name == 'varied25':
        # the varied schedule at new seeds (28000+), added at stop 55 and run on the stop-54 binary before any change
        return varied_fresh(28000, per_class_null=2, per_class_stoch=2, n_random=30, ooc_each=2)
    if name == 'varied26':
        # the varied schedule at new seeds (29000+), added at stop 55 after its changes were fixed: the random and
        # mixed cases draw from the whole catalog, IEEE 1293's cross-axis nonlinearity (new at stop 55) included,
        # and four single cases of it at the class magnitudes raised to an SNR of 10-30
        cases = varied_fresh(29000, per_class_null=2, per_class_stoch=2, n_random=30, ooc_each=2, full_catalog=True)
        for i, cls in enumerate(['consumer', 'automotive', 'tactical', 'automotive']):
            cases.append(('single-accel.cross_axis_nonlinearity-%d' % i, 'single', 29500 + i,
                          {'effect': 'accel.cross_axis_nonlinearity', 'cls': cls, 'size': 'varied'}))
        return cases
    if name == 'varied27':
        # the varied schedule at new seeds (30000+), whole catalog, added at stop 56 and run on the stop-55 binary
        # before any change
        return varied_fresh(30000, per_class_null=2, per_class_stoch=2, n_random=30, ooc_each=2, full_catalog=True)
    if name == 'unseen5':
        # out-of-catalog kinds written at stop 56 and first run on the stop-55 binary (a bias while the table
        # turns, a bias bump about one temperature, an accel bias remembering the last load); seeds 31000+
        return unseen_kinds(blindgen.OOC_KINDS_UNSEEN5, 31000)
    if name == 'unseen6':
        # out-of-catalog kinds written at stop 57 and first run on the stop-56 binary (a scale bump about one die
        # temperature, an accel bias in w_j f_j, a gyro bias settling after each rotation); seeds 33000+
        return unseen_kinds(blindgen.OOC_KINDS_UNSEEN6, 33000)
    if name == 'varied28':
        # the varied schedule at new seeds (32000+), whole catalog, added at stop 57 and run on the stop-56 binary
        # before any change
        return varied_fresh(32000, per_class_null=2, per_class_stoch=2, n_random=30, ooc_each=2, full_catalog=True)
    if name == 'unseen7':
        # out-of-catalog kinds written at stop 58 and first run on the stop-57 binary (an accel bias in f_x f_y f_z,
        # a gyro bias in |f_j|, a bias lagging the table motor's heat); seeds 34000+
        return unseen_kinds(blindgen.OOC_KINDS_UNSEEN7, 34000)
    if name == 'varied29':
        # the varied schedule at new seeds (35000+), whole catalog, added at stop 58 and run on the stop-57 binary
        # before any change
        return varied_fresh(35000, per_class_null=2, per_class_stoch=2, n_random=30, ooc_each=2, full_catalog=True)
    if name == 'unseen8':
        # out-of-catalog kinds written at stop 59 and first run on the stop-58 binary (a bias at one speed of the table,
        # a bias following the turns wound up about the vertical, an accel compressing beyond a knee); seeds 38000+
        return unseen_kinds(blindgen.OOC_KINDS_UNSEEN8, 38000)
    if name == 'varied30':
        # the varied schedule at new seeds (37000+), whole catalog, added at stop 59 and run on the stop-58 binary
        # before any change
        return varied_fresh(37000, per_class_null=2, per_class_stoch=2, n_random=30, ooc_each=2, full_catalog=True)
    if name == 'unseen9':
        # out-of-catalog kinds written at stop 60 and first run on the stop-59 binary (the package slipping once on
        # its mount, random telegraph noise on the bias, the chamber's compressor shaking the fixture while it
        # cools); seeds 40000+
        return unseen_kinds(blindgen.OOC_KINDS_UNSEEN9, 40000)
    if name == 'varied31':
        # the varied schedule at new seeds (39000+), whole catalog, added at stop 60 and run on the stop-59 binary
        # before any change
        return varied_fresh(39000, per_class_null=2, per_class_stoch=2, n_random=30, ooc_each=2, full_catalog=True)
    if name == 'unseen10':
        # out-of-catalog kinds written at stop 61 and first run on the stop-60 binary (a bias while the chamber
        # heats, single-sample bit errors on the bus, an auto-ranging gyro); seeds 42000+
        return unseen_kinds(blindgen.OOC_KINDS_UNSEEN10, 42000)
    if name == 'varied32':
        # the varied schedule at new seeds (41000+), whole catalog, added at stop 61 and run on the stop-60 binary
        # before any change
        return varied_fresh(41000, per_class_null=2, per_class_stoch=2, n_random=30, ooc_each=2, full_catalog=True)
    if name == 'unseen11':
        # out-of-catalog kinds written at stop 62 and first run on the stop-61 binary (periodic converter
        # nonlinearity, a sawtooth in the die temperature, one axis sampled late); seeds 44000+
        return unseen_kinds(blindgen.OOC_KINDS_UNSEEN11, 44000)
    if name == 'varied33':
        # the varied schedule at new seeds (43000+), whole catalog, added at stop 62 and run on the stop-61 binary
        # before any change
        return varied_fresh(43000, per_class_null=2, per_class_stoch=2, n_random=30, ooc_each=2, full_catalog=True)
    if name == 'unseen12':
        # out-of-catalog kinds written at stop 63 and first run on the stop-62 binary (a scale with a memory of the
        # die's last temperature move, a bias locked to the table motor's rotor, an accel reading another axis'
        # specific force times the squared rate); seeds 46000+
        return unseen_kinds(blindgen.OOC_KINDS_UNSEEN12, 46000)
    if name == 'varied34':
        # the varied schedule at new seeds (45000+), whole catalog, added at stop 63 and run on the stop-62 binary
        # before any change
        return varied_fresh(45000, per_class_null=2, per_class_stoch=2, n_random=30, ooc_each=2, full_catalog=True)
    if name == 'unseen13':
        # out-of-catalog kinds written at stop 64 and first run on the stop-63 binary (a scale moving with the die's
        # temperature rate, a bias within a window of table angles, a stuck output bit); seeds 48000+
        return unseen_kinds(blindgen.OOC_KINDS_UNSEEN13, 48000)
    if name == 'varied35':
        # the varied schedule at new seeds (47000+), whole catalog, added at stop 64 and run on the stop-63 binary
        # before any change
        return varied_fresh(47000, per_class_null=2, per_class_stoch=2, n_random=30, ooc_each=2, full_catalog=True)
    if name == 'unseen14':
        # out-of-catalog kinds written at stop 65 and first run on the stop-64 binary (a bias past a knee in the die
        # temperature, bursts of rows reading 0, a bias in the table's angular acceleration); seeds 50000+
        return unseen_kinds(blindgen.OOC_KINDS_UNSEEN14, 50000)
    if name == 'varied36':
        # the varied schedule at new seeds (49000+), whole catalog, added at stop 65 and run on the stop-64 binary
        # before any change
        return varied_fresh(49000, per_class_null=2, per_class_stoch=2, n_random=30, ooc_each=2, full_catalog=True)
    if name == 'unseen15':
        # out-of-catalog kinds written at stop 66 and first run on the stop-65 binary (a gyro's zero-rate band, a bias
        # beating at a frequency that follows the die temperature, a scale settling after power-up); seeds 52000+
        return unseen_kinds(blindgen.OOC_KINDS_UNSEEN15, 52000)
    if name == 'varied37':
        # the varied schedule at new seeds (51000+), whole catalog, added at stop 66 and run on the stop-65 binary
        # before any change
        return varied_fresh(51000, per_class_null=2, per_class_stoch=2, n_random=30, ooc_each=2, full_catalog=True)
    if name == 'varied38':
        # the varied schedule at new seeds (53000+), whole catalog, added at stop 67 and run on the stop-67 binary
        # and, case by case where the change acts, on the stop-66 one
        return varied_fresh(53000, per_class_null=2, per_class_stoch=2, n_random=30, ooc_each=2, full_catalog=True)
    if name == 'unseen16':
        # out-of-catalog kinds written at stop 68 and first run on the stop-67 binary (a gyro biased along the Earth's
        # magnetic field, mount play reading |w| about another axis, a bias oscillating in the die temperature);
        # seeds 54000+
        return unseen_kinds(blindgen.OOC_KINDS_UNSEEN16, 54000)
    if name == 'varied39':
        # the varied schedule at new seeds (55000+), whole catalog, added at stop 68 and run on the stop-67 binary
        # before any change
        return varied_fresh(55000, per_class_null=2, per_class_stoch=2, n_random=30, ooc_each=2, full_catalog=True)
    if name == 'unseen17':
        # out-of-catalog kinds written at stop 71 and first run on the stop-70 binary (a bias in the die-to-board
        # temperature gradient, a k2 moving with the die temperature, a gyro bias in w_j w_k^2); seeds 56000+
        return unseen_kinds(blindgen.OOC_KINDS_UNSEEN17, 56000)
    if name == 'varied40':
        # the varied schedule at new seeds (57000+), whole catalog, added at stop 71 and run on the stop-70 binary
        # before any change
        return varied_fresh(57000, per_class_null=2, per_class_stoch=2, n_random=30, ooc_each=2, full_catalog=True)
    if name == 'unseen18':
        # out-of-catalog kinds written at stop 72 and first run on the stop-71 binary (a gyro bias in the angular
        # acceleration about another axis, a leakage bias doubling every 6-14 degC, an accel bias in the product of its
        # cross axes' rates); seeds 58000+
        return unseen_kinds(blindgen.OOC_KINDS_UNSEEN18, 58000)
    if name in ('lossy18', 'lossless18'):
        # the same logs with and without rows lost on the link (stop 72): losses of 1-300 rows (3 s), one every 2 min
        # on average. Nothing the sensor did changes, so a diagnosis should say the same on both
        loss = {'row_loss': {'interval_s': 120.0, 'max_rows': 300}} if name == 'lossy18' else {}
        for i, cls in enumerate(blindgen.CLASSES):
            cases.append(('null-%s' % cls, 'null', 59000 + i, dict({'cls': cls, 'size': 'varied'}, **loss)))
        for i in range(2):
            cases.append(('stoch-%d' % i, 'stochastic', 59100 + i, dict({'size': 'varied'}, **loss)))
        for i in range(8):
            cases.append(('random-%d' % i, 'random', 59200 + i, dict({'size': 'varied', 'full_catalog': True}, **loss)))
        for k, kind in enumerate(('heading', 'periodic', 'g_cubed')):
            cases.append(('ooc-%s' % kind, 'ooc', 59300 + k, dict({'ooc': kind, 'size': 'varied'}, **loss)))
        return cases
    if name == 'unseen4':
        # out-of-catalog kinds written at stop 54 and first run on the stop-53 binary (a bias even in the die's
        # temperature rate, an accel cross-axis square, an accel creep after each pose change); seeds 27000+
        return unseen_kinds(blindgen.OOC_KINDS_UNSEEN4, 27000)
    if name != 'full':
        raise SystemExit('unknown suite ' + name)
    for s in range(1, 51):
        cases.append(('random-%d' % s, 'random', 1000 + s, {}))
    for cls in blindgen.CLASSES:
        cases.append(('example-%s' % cls, 'example', 3, {'sensor': 'docs/examples/sensor-%s.json' % cls}))
    # the issue's own reproduction: the automotive example on campaign-eol (simulate source only)
    cases.append(('example-automotive-eol', 'example', 3, {'sensor': 'docs/examples/sensor-automotive.json',
                                                            'campaign': 'docs/examples/campaign-eol.json', 'size': 'short'}))
    # 30 null and 30 stochastic-only cases (10 per class; the first 6 of each are the original ones): a pass
    # rate of >= 0.95 cannot be told from 0.83 on 6 cases (one-sided 95 % lower bounds are printed)
    for i, cls in enumerate(blindgen.CLASSES * 10):
        cases.append(('null-%s-%d' % (cls, i), 'null', 2000 + i, {'cls': cls}))
        cases.append(('stoch-%s-%d' % (cls, i), 'stochastic', 3000 + i, {'cls': cls}))
    # g_cubed, angle2, rate_memory (added 26 Nov 2026): out-of-catalog forms the diagnosis was not tuned on
    for k, kind in enumerate(['heading', 'bias_step', 'w_cubed', 'abs_rate', 'periodic', 'g_cubed', 'angle2', 'rate_memory']):
        for i in range(2):
            cases.append(('ooc-%s-%d' % (kind, i), 'ooc', 4000 + 10 * k + i, {'ooc': kind}))
    cases.append(('ooc_noise-0', 'ooc_noise', 4100, {}))
    # a realistic sensor: catalog effects plus one out-of-catalog bias (added 26 Nov 2026)
    for k, kind in enumerate(blindgen.OOC_KINDS):
        cases.append(('mixed-%s' % kind, 'mixed', 6000 + k, {'ooc': kind}))
    # clock drift accumulating >= 1 s over the run (issue 12: timing must hold to 1 s of shift), automotive noise
    cases.append(('single-accel.timing-1s', 'single', 5900, {'effect': 'accel.timing', 'cls': 'automotive', 'timing': {'ppm': 420.0, 'latency_s': 5e-4}}))
    cases.append(('single-gyro.timing-1s', 'single', 5901, {'effect': 'gyro.timing', 'cls': 'automotive', 'timing': {'ppm': -420.0}}))
    for k, eff in enumerate(blindgen.CANDIDATES):
        for i, cls in enumerate(['consumer', 'automotive']):
            cases.append(('single-%s-%s' % (eff, cls), 'single', 5000 + 10 * k + i, {'effect': eff, 'cls': cls}))
    return cases


def case_hash(kind, seed, opt):
    src = open(os.path.join(HERE, 'blindgen.py'), 'rb').read()
    h = hashlib.sha256(src + json.dumps([kind, seed, opt], sort_keys=True).encode()).hexdigest()
    return h[:16]


def make(work, name, kind, seed, opt, fmt, reuse=False):
    d = os.path.join(work, 'cases', name)
    h = case_hash(kind, seed, opt)
    tp = os.path.join(d, 'truth.json')
    if os.path.exists(tp):
        t = json.load(open(tp))
        if (reuse or t.get('case_hash') == h) and os.path.exists(os.path.join(d, 'log.' + fmt)):
            return d, t
    shutil.rmtree(d, ignore_errors=True)
    opt2 = dict(opt)
    sensor = opt2.pop('sensor', None)
    if sensor:
        sensor = os.path.join(REPO, sensor)
    case = blindgen.make_case(kind, seed, opt2.get('size', 'full'), sensor, opt2.get('cls'), opt2.get('effect'),
                              opt2.get('g2_squares', False), opt2.get('ooc'), opt2.get('timing'),
                              opt2.get('full_catalog', False))
    if opt2.get('row_loss'):
        case['scenario']['row_loss'] = opt2['row_loss']
    truth, _ = blindgen.write_case(case, d, fmt, name)
    truth['case_hash'] = h
    with open(tp, 'w') as f:
        json.dump(truth, f, indent=1)
    return d, truth


def run_diagnose(imuforge, log, model, out, timeout_s=1800, campaign=None):
    t0 = time.time()
    extra = ['--campaign', campaign] if campaign else []  # the table's geometry: its axis errors are estimated
    p = subprocess.run([imuforge, 'diagnose', '--log', log, '--model', model, '--out', out] + extra,
                       stdout=subprocess.PIPE, stderr=subprocess.PIPE, timeout=timeout_s)
    with open(out + '.txt', 'wb') as f:
        f.write(p.stdout + p.stderr)
    if p.returncode != 0:
        return None, 'imuforge diagnose exit %d: %s' % (p.returncode, p.stderr.decode(errors='replace').strip()[:300])
    return json.load(open(os.path.join(out, 'diagnosis.json'))), time.time() - t0


def deterministic_selected(d):
    return sorted({'%s.%s' % (s['sensor'], s['effect']) for s in d.get('selected', []) if s['effect'] not in STOCH_EFFECTS})


def unexplained_axes(d):
    # new key (issue 12): top-level list of {axis, chi2_dof_after, signature}; absent = nothing flagged
    return sorted({u['axis'] for u in (d.get('unexplained') or [])})


def top1(d):
    for r in d.get('ranking', []):
        if r.get('excitable', True) and r['effect'] not in STOCH_EFFECTS:
            return '%s.%s' % (r['sensor'], r['effect'])
    return None


def magnitude_check(d, truth, effect_key):
    """(all injected components within 3 sigma, details). Final joint fit if the effect was selected, else
    the ranking's fit of that candidate."""
    params = {}
    for p in d.get('parameters', []):
        params.setdefault(p['name'], p)
    ranked = {}
    for r in d.get('ranking', []):
        if '%s.%s' % (r['sensor'], r['effect']) == effect_key:
            for p in r.get('magnitude', []):
                ranked.setdefault(p['name'], p)
    ok, det = True, []
    for name, val in truth['parameters'].items():
        if not name.startswith(effect_key + '.'):
            continue
        p = params.get(name) or ranked.get(name)
        if p is None or p.get('value') is None or p.get('sigma') in (None, 0):
            ok = False
            det.append('%s: not estimated' % name)
            continue
        z = (p['value'] - val) / p['sigma']
        if not abs(z) <= 3:
            ok = False
        det.append('%s: %.4g vs %.4g (z=%.1f)' % (name, p['value'], val, z))
    return ok, det


def max_chi2_after(d):
    ga = d.get('gap_after') or {}
    v = [a.get('heldout_chi2_dof') for a in ga.values() if a.get('heldout_chi2_dof') is not None]
    return max(v) if v else float('nan')


def score(truth, d):
    exp = set(truth['beyond_model'])
    sel = set(deterministic_selected(d))
    une = set(unexplained_axes(d))
    r = {'selected': sorted(sel), 'expected': sorted(exp), 'unexplained': sorted(une),
         'missed': sorted(exp - sel), 'false_effects': sorted(sel - exp), 'false': len(sel - exp),
         'recall': (len(exp & sel) / len(exp)) if exp else None, 'max_chi2_after': max_chi2_after(d)}
    snr = truth.get('snr') or {}
    det = {k for k in exp if snr.get(k, float('inf')) >= DETECTABLE_SNR}
    r['recall_detectable'] = (len(det & sel) / len(det)) if det else None
    r['missed_snr'] = {k: round(snr[k], 1) for k in r['missed'] if k in snr}
    kind = truth['kind']
    if kind == 'single':
        eff = truth['beyond_model'][0]
        r['top1'] = top1(d) == eff
        r['top1_effect'] = top1(d)
        r['mag3sigma'], r['mag_detail'] = magnitude_check(d, truth, eff)
    if kind == 'mixed':
        want = set(truth['unexplained_axes'])
        r['ooc_axes'] = sorted(want)
        r['named'] = want <= une
        r['extra_unexplained'] = sorted(une - want)
    if kind == 'ooc':
        want = set(truth['unexplained_axes'])
        r['ooc_axes'] = sorted(want)
        r['pass'] = (not sel) and want <= une
        # over the axes whose out-of-catalog term stands above the base model (blindgen's 'ooc:' snr; cases
        # written before stop 54 have none and count as detectable)
        want_det = {a for a in want if snr.get('ooc:' + a, float('inf')) >= DETECTABLE_SNR}
        r['ooc_snr'] = {a: round(snr['ooc:' + a], 1) for a in want if 'ooc:' + a in snr}
        r['pass_detectable'] = (not sel) and want_det <= une
        r['nothing_selected'] = not sel
        r['named'] = want <= une
        r['extra_unexplained'] = sorted(une - want)
    if kind in ('null', 'stochastic', 'ooc_noise'):
        r['nothing_selected'] = not sel
        r['pass'] = (not sel) and (not une) if kind == 'null' else (not sel)
        # colored noise is noise: an axis named "unexplained" is as wrong as a selected effect
        r['at_noise'] = (not sel) and (not une)
    return r


def simulate_log(imuforge, case_dir, truth, work, name, campaign_path=None):
    """Second source: the same sensor through `imuforge simulate` with a campaign written in the documented
    campaign format (docs/formats.md) that mirrors the blindgen scenario (instantaneous changes are not
    possible there: the table moves with its rate/acceleration limits)."""
    from campaign import write_campaign  # local module
    d = os.path.join(work, 'sim', name)
    os.makedirs(d, exist_ok=True)
    camp = os.path.join(REPO, campaign_path) if campaign_path else os.path.join(d, 'campaign.json')
    if not campaign_path:
        write_campaign(truth['scenario'], camp, truth['seed'])
    log = os.path.join(d, 'log.bin')
    if os.path.exists(log) and os.path.getmtime(log) > os.path.getmtime(os.path.join(case_dir, 'sensor.json')):
        return log, d, camp  # simulated already from this sensor file
    p = subprocess.run([imuforge, 'simulate', '--campaign', camp, '--sensor', os.path.join(case_dir, 'sensor.json'),
                        '--seed', str(truth['seed']), '--out', log, '--quiet'], stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    if p.returncode != 0:
        return None, 'imuforge simulate exit %d: %s' % (p.returncode, p.stderr.decode(errors='replace').strip()[:300]), None
    return log, d, camp


def pass_lcb95(k, n):
    """One-sided 95 % lower confidence bound of a pass rate (Clopper-Pearson): the p at which k or more
    passes of n have probability 0.05."""
    if n == 0 or k == 0:
        return 0.0

    def sf(p):  # P(X >= k | n, p)
        return sum(math.comb(n, j) * p ** j * (1 - p) ** (n - j) for j in range(k, n + 1))
    lo, hi = 0.0, 1.0
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if sf(mid) < 0.05:
            lo = mid
        else:
            hi = mid
    return lo


def summarise(rows):
    S = {}
    by = {}
    for r in rows:
        by.setdefault(r['category'], []).append(r)

    def frac(xs):
        xs = [x for x in xs if x is not None]
        return (sum(1 for x in xs if x) / len(xs)) if xs else float('nan')

    def recall_figures(cat, rows_):
        """n, mean recall (all and over snr >= DETECTABLE_SNR) and the fraction with <= 1 false effect."""
        def mean(xs):
            xs = [x for x in xs if x is not None]
            return sum(xs) / len(xs) if xs else float('nan')
        S[cat + '.n'] = len(rows_)
        S[cat + '.mean_recall'] = mean([r['recall'] for r in rows_])
        S[cat + '.mean_recall_detectable'] = mean([r.get('recall_detectable') for r in rows_])
        S[cat + '.frac_le1_false'] = frac([r['false'] <= 1 for r in rows_])

    rnd = [r for r in by.get('random', []) if 'error' not in r]
    if rnd:
        recall_figures('random', rnd)
        S['random.mean_false'] = sum(r['false'] for r in rnd) / len(rnd)
        S['random.frac_chi2_after_le3'] = frac([r['max_chi2_after'] <= 3 for r in rnd])
        S['random.frac_unexplained'] = frac([bool(r['unexplained']) for r in rnd])  # in-catalog cases: should stay low
    for r in by.get('example', []):
        if 'error' in r:
            continue
        cls = r['name'].split('-', 1)[1]
        S['example.%s.recall' % cls] = r['recall']
        S['example.%s.false' % cls] = r['false']
        S['example.%s.max_chi2_after' % cls] = r['max_chi2_after']
    sg = [r for r in by.get('single', []) if 'error' not in r]
    if sg:
        S['single.n'] = len(sg)
        S['single.top1'] = frac([r['top1'] for r in sg])
        S['single.mag3sigma'] = frac([r['mag3sigma'] for r in sg])
        S['single.selected'] = frac([r['recall'] == 1 for r in sg])
    oc = [r for r in by.get('ooc', []) if 'error' not in r]
    if oc:
        S['ooc.n'] = len(oc)
        S['ooc.pass'] = frac([r['pass'] for r in oc])
        S['ooc.pass_lcb95'] = pass_lcb95(sum(1 for r in oc if r['pass']), len(oc))
        S['ooc.pass_detectable'] = frac([r.get('pass_detectable', r['pass']) for r in oc])
        S['ooc.nothing_selected'] = frac([r['nothing_selected'] for r in oc])
        S['ooc.named'] = frac([r['named'] for r in oc])
        S['ooc.mean_extra_unexplained_axes'] = sum(len(r['extra_unexplained']) for r in oc) / len(oc)
    mx = [r for r in by.get('mixed', []) if 'error' not in r]
    if mx:
        recall_figures('mixed', mx)
        S['mixed.named'] = frac([r['named'] for r in mx])
    nl = [r for r in by.get('null', []) if 'error' not in r]
    if nl:
        S['null.n'] = len(nl)
        S['null.pass'] = frac([r['pass'] for r in nl])
        S['null.pass_lcb95'] = pass_lcb95(sum(1 for r in nl if r['pass']), len(nl))
    st = [r for r in by.get('stochastic', []) if 'error' not in r]
    if st:
        S['stochastic.n'] = len(st)
        S['stochastic.nothing_selected'] = frac([r['nothing_selected'] for r in st])
        S['stochastic.nothing_selected_lcb95'] = pass_lcb95(sum(1 for r in st if r['nothing_selected']), len(st))
        S['stochastic.at_noise'] = frac([r['at_noise'] for r in st])
        S['stochastic.at_noise_lcb95'] = pass_lcb95(sum(1 for r in st if r['at_noise']), len(st))
    on = [r for r in by.get('ooc_noise', []) if 'error' not in r]
    if on:
        S['ooc_noise.nothing_selected'] = frac([r['nothing_selected'] for r in on])
    for cat in ('null', 'stochastic', 'ooc', 'single'):
        xs = [r for r in by.get(cat, []) if 'error' not in r]
        if xs:
            S['%s.max_false' % cat] = max(r['false'] for r in xs)
    ts = [r['diag_s'] for r in rows if isinstance(r.get('diag_s'), float)]
    if ts:
        S['diag_wall_s.mean'] = sum(ts) / len(ts)  # wall time of one `imuforge diagnose` (shared machine: a guide)
        S['diag_wall_s.max'] = max(ts)
    S['errors'] = sum(1 for r in rows if 'error' in r)
    return S


def fmt_num(v):
    if v is None:
        return '-'
    if isinstance(v, float):
        if math.isnan(v):
            return 'nan'
        return '%.3g' % v
    return str(v)


def print_table(rows, S, out=sys.stdout):
    w = out.write
    w('\n%-34s %-10s %6s %5s  %-40s %s\n' % ('case', 'category', 'recall', 'false', 'missed / false effects', 'other'))
    for r in rows:
        if 'error' in r:
            w('%-34s %-10s ERROR %s\n' % (r['name'], r['category'], r['error']))
            continue
        other = 'chi2_after<=%.3g' % r['max_chi2_after'] if r['max_chi2_after'] == r['max_chi2_after'] else ''
        if 'top1' in r:
            other += ' top1=%s(%s) mag3s=%s' % ('Y' if r['top1'] else 'N', r['top1_effect'], 'Y' if r['mag3sigma'] else 'N')
        if r['category'] in ('ooc', 'null', 'stochastic', 'ooc_noise'):
            other += ' pass=%s unexplained=%s' % ('Y' if r.get('pass') else 'N', ','.join(r['unexplained']) or '-')
            if r.get('ooc_snr'):
                other += ' ooc_snr=%s' % ','.join('%s:%g' % kv for kv in sorted(r['ooc_snr'].items()))
            if r['category'] == 'ooc':
                other += ' want=%s' % ','.join(r['ooc_axes'])
        if r['category'] == 'mixed':
            other += ' named=%s unexplained=%s want=%s' % ('Y' if r.get('named') else 'N', ','.join(r['unexplained']) or '-',
                                                           ','.join(r['ooc_axes']))
        mf = ' '.join(['-%s%s' % (m, '(snr %g)' % r['missed_snr'][m] if m in r.get('missed_snr', {}) else '') for m in r['missed']] +
                      ['+' + m for m in r['false_effects']])
        w('%-34s %-10s %6s %5d  %-40s %s\n' % (r['name'][:34], r['category'], fmt_num(r['recall']), r['false'], mf, other))
    w('\n%-34s %10s %10s  %s\n' % ('figure', 'measured', 'target', 'verdict'))
    for k in sorted(S):
        tgt = TARGETS.get(k)
        if tgt:
            v = S[k]
            met = (v is not None and v == v and ((v >= tgt[0]) if tgt[1] == 'min' else (v <= tgt[0])))
            w('%-34s %10s %10s  %s\n' % (k, fmt_num(v), ('>= ' if tgt[1] == 'min' else '<= ') + fmt_num(tgt[0]), 'met' if met else 'NOT met'))
        else:
            w('%-34s %10s\n' % (k, fmt_num(S[k])))


def check_floors(S, floors_path):
    """Regression floors: figures the current diagnosis reaches. Each entry {figure: [floor, 'min'|'max']}."""
    floors = json.load(open(floors_path))
    bad = []
    for k, v in floors.items():
        if k.startswith('_'):
            continue
        lim, how = v
        m = S.get(k)
        if m is None or m != m:
            bad.append('%s: not measured (floor %s)' % (k, lim))
        elif (how == 'min' and m < lim) or (how == 'max' and m > lim):
            bad.append('%s = %s, floor %s %s' % (k, fmt_num(m), '>=' if how == 'min' else '<=', lim))
    for k, (t, how) in TARGETS.items():
        m = S.get(k)
        if m is not None and m == m and ((how == 'min' and m < t) or (how == 'max' and m > t)):
            print('gap to the issue-12 target: %s = %s (target %s %s)' % (k, fmt_num(m), '>=' if how == 'min' else '<=', t))
    return bad


def selftest():
    """The scorer on hand-written diagnosis.json fragments (so the floors mean what they say)."""
    truth = {'kind': 'ooc', 'beyond_model': [], 'unexplained_axes': ['gyro.x'], 'parameters': {}, 'snr': {}}
    d = {'selected': [], 'unexplained': [{'axis': 'gyro.x', 'chi2_dof_after': 40.0, 'signature': [{'input': 'cos(tbl_angle_2)', 'correlation': 0.93}]}],
         'gap_after': {'gyro.x': {'heldout_chi2_dof': 40.0}}}
    ok = score(truth, d)['pass'] is True
    ok &= score(truth, {'selected': [], 'gap_after': {}})['pass'] is False                       # key absent = not flagged
    ok &= score(truth, dict(d, selected=[{'sensor': 'gyro', 'effect': 'g2_sensitivity'}]))['pass'] is False
    tw = dict(truth, snr={'ooc:gyro.x': 2.0})  # a term the base model absorbs: its axis need not be named
    ok &= score(tw, {'selected': [], 'gap_after': {}})['pass_detectable'] is True
    ok &= score(dict(truth, snr={'ooc:gyro.x': 20.0}), {'selected': [], 'gap_after': {}})['pass_detectable'] is False
    t2 = {'kind': 'random', 'beyond_model': ['gyro.g_sensitivity', 'accel.timing'], 'unexplained_axes': [], 'parameters': {},
          'snr': {'gyro.g_sensitivity': 50.0, 'accel.timing': 3.0}}
    r = score(t2, {'selected': [{'sensor': 'gyro', 'effect': 'g_sensitivity'}, {'sensor': 'gyro', 'effect': 'temp_rate'},
                                {'sensor': 'gyro', 'effect': 'bias_instability'}], 'gap_after': {}})
    ok &= r['recall'] == 0.5 and r['recall_detectable'] == 1.0 and r['false'] == 1   # stochastic findings are not false effects
    t3 = {'kind': 'single', 'beyond_model': ['gyro.g_sensitivity'], 'unexplained_axes': [], 'snr': {},
          'parameters': {'gyro.g_sensitivity.xz': 1e-4}}
    d3 = {'selected': [{'sensor': 'gyro', 'effect': 'g_sensitivity'}], 'gap_after': {},
          'ranking': [{'sensor': 'gyro', 'effect': 'g_sensitivity', 'excitable': True, 'magnitude': []}],
          'parameters': [{'name': 'gyro.g_sensitivity.xz', 'value': 1.05e-4, 'sigma': 1e-6}]}
    r3 = score(t3, d3)
    ok &= r3['top1'] and not r3['mag3sigma']                                                  # 5 sigma off
    d3['parameters'][0]['sigma'] = 2e-6
    ok &= score(t3, d3)['mag3sigma']
    print('battery scorer selftest: %s' % ('ok' if ok else 'FAIL'))
    return 0 if ok else 1


def main(argv):
    if argv[:1] == ['selftest']:
        return selftest()
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument('--imuforge', required=True)
    ap.add_argument('--work', required=True, help='folder for cases and outputs (a case folder is named after the case and reused while its content hash matches: suites sharing case names need folders of their own when run at once)')
    ap.add_argument('--suite', default='smoke', choices=['smoke', 'full', 'holdout', 'varied', 'varied2', 'varied3', 'varied4', 'varied5', 'varied6', 'varied7', 'varied8', 'varied9', 'varied10', 'varied11', 'varied12', 'varied13', 'varied14', 'varied15', 'varied16', 'varied17', 'varied18', 'varied19', 'varied20', 'varied21', 'varied22', 'varied23', 'varied24', 'varied25', 'varied26', 'varied27', 'unseen', 'unseen2', 'unseen3', 'unseen4', 'unseen5', 'unseen6', 'varied28', 'unseen7', 'varied29', 'varied30', 'unseen8', 'varied31', 'unseen9', 'varied32', 'unseen10', 'varied33', 'unseen11', 'varied34', 'unseen12', 'varied35', 'unseen13', 'varied36', 'unseen14', 'varied37', 'unseen15', 'varied38', 'unseen16', 'varied39', 'unseen17', 'varied40', 'unseen18', 'lossy18', 'lossless18'])
    ap.add_argument('--source', default='blindgen', choices=['blindgen', 'simulate'])
    ap.add_argument('--model', default=os.path.join(REPO, 'docs', 'examples', 'model-thermal.json'))
    ap.add_argument('--format', default='csv', choices=['csv', 'bin'], help='log encoding blindgen writes')
    ap.add_argument('--only', help='comma-separated substrings of case names')
    ap.add_argument('--reuse', action='store_true', help='use cached cases even if the generator changed since (re-score old cases)')
    ap.add_argument('--diag-tag', default='diag', help='output folder name per case (keeps several diagnoses side by side)')
    ap.add_argument('--json', help='write per-case scores and the summary here')
    ap.add_argument('--floors', help='regression floors JSON: exit 1 when a figure is below its floor')
    ap.add_argument('--discard-logs', action='store_true',
                    help="delete a case's log once it is diagnosed and scored (truth, diagnosis and report stay; a failed "
                         "case keeps its log): the smoke suite's logs take about 0.9 GB, which a CI machine short of disk "
                         "cannot spare; the next run writes them again")
    a = ap.parse_args(argv)
    os.makedirs(a.work, exist_ok=True)
    rows = []
    t_start = time.time()
    for name, kind, seed, opt in suite(a.suite):
        if a.only and not any(s in name for s in a.only.split(',')):
            continue
        cat = kind
        row = {'name': name, 'category': cat}
        try:
            if 'campaign' in opt and a.source != 'simulate':
                continue  # a campaign file only drives imuforge simulate
            fmt = opt.get('log_format', a.format)  # a case's own encoding (the smoke suite's hours-long logs: bin)
            d, truth = make(a.work, name, kind, seed, {k: v for k, v in opt.items() if k not in ('campaign', 'log_format')}, fmt, a.reuse)
            log = os.path.join(d, 'log.' + fmt)
            out = os.path.join(d, a.diag_tag)
            if a.source == 'simulate':
                if truth['out_of_catalog'] or truth['noise_extra'] or kind == 'ooc_noise':
                    continue  # the simulator cannot express these
                log, sd, camp = simulate_log(a.imuforge, d, truth, a.work, name, opt.get('campaign'))
                if log is None:
                    raise RuntimeError(sd)
                out = os.path.join(sd, a.diag_tag)
            # A simulated log's campaign is known (its user wrote it): the diagnosis gets its table geometry, as
            # docs/diagnosis.md's loop does. blindgen's logs carry body-frame references and no table to re-evaluate.
            dj, info = run_diagnose(a.imuforge, log, a.model, out, campaign=camp if a.source == 'simulate' else None)
            if dj is None:
                raise RuntimeError(info)
            if opt.get('campaign'):
                truth = dict(truth, snr={})  # blindgen's detectability is for its own scenario, not this campaign
            row.update(score(truth, dj))
            row['diag_s'] = info
            if a.discard_logs:
                os.remove(log)
        except Exception as e:  # a failed case is reported, never skipped silently
            row['error'] = '%s: %s' % (type(e).__name__, e)
        rows.append(row)
        r = row
        if 'error' in r:
            print('%-34s ERROR %s' % (name, r['error']), flush=True)
        else:
            print('%-34s recall=%s false=%d sel=[%s] missed=[%s] unexplained=[%s]' % (
                name, fmt_num(r['recall']), r['false'], ' '.join(r['selected']), ' '.join(r['missed']), ' '.join(r['unexplained'])), flush=True)
    S = summarise(rows)
    print_table(rows, S)
    print('\n%d cases, %.0f s wall' % (len(rows), time.time() - t_start))
    if a.json:
        with open(a.json, 'w') as f:
            json.dump({'suite': a.suite, 'source': a.source, 'model': a.model, 'summary': S, 'cases': rows}, f, indent=1)
    if a.floors:
        bad = check_floors(S, a.floors)
        if bad:
            print('REGRESSION below the floors of %s:\n  %s' % (a.floors, '\n  '.join(bad)))
            return 1
        print('all figures at or above the floors of %s' % a.floors)
    return 0 if S['errors'] == 0 else 1


if __name__ == '__main__':
    sys.exit(main(sys.argv[1:]))
