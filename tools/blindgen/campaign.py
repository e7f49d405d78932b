"""Write a blindgen scenario as an imuforge campaign (docs/formats.md "Campaign file"), so the same sensor
can be run through `imuforge simulate` (the battery's second source).

Differences that remain and are intended: the project's table moves between poses with its rate and
acceleration limits (segment -1 while moving) where blindgen jumps instantaneously, and the plateau soak is
held at the previous position. Table limits are set high so the moves are short.
"""
import json
import math

import numpy as np

import blindgen


def scenario_of(seed, spec):
    """The exact Scenario blindgen.generate() builds for this seed."""
    return blindgen.build_scenario(np.random.default_rng(np.random.SeedSequence(int(seed)).spawn(4)[0]), spec)


def write_campaign(spec, path, seed):
    scn = scenario_of(seed, spec)
    # table limits: moves between poses never faster than the fastest commanded rate (which blindgen keeps
    # at <= 80 % of the gyro's range), so no move saturates the sensor; sines stay inside these limits
    # (the moves run all three axes at once: the inner and middle axes are held to a third of the top rate so
    # that the combined body rate stays below the range; only the outer axis spins at the top rate)
    top_rate = max(spec.get('rates_dps', [300]))
    gimbal_rate = max(spec.get('rates_dps', [300])[:2])  # the inner/middle 'tumble' rates (full: top/3)
    phases = []
    cur = None
    for s in scn.segments:
        ang = [round(float(x), 6) for x in np.degrees(s.ang0)]
        if s.kind == 'soak':
            cur = {'type': 'plateau', 'label': s.label, 'setpoint_C': s.set_to, 'soak_s': s.dur, 'steps': []}
            phases.append(cur)
        elif s.kind == 'position':
            cur['steps'].append({'type': 'position', 'position_deg': ang, 'dwell_s': s.dur, 'label': s.label})
        elif s.kind == 'rate':
            cur['steps'].append({'type': 'position', 'position_deg': ang, 'dwell_s': 0.5, 'label': 'start ' + s.label})
            cur['steps'].append({'type': 'rate', 'rate_dps': [round(float(x), 6) for x in np.degrees(s.rate)],
                                 'dwell_s': s.dur, 'label': s.label})
        elif s.kind == 'sine':
            gi, A, f = s.sine
            amp = [0.0, 0.0, 0.0]
            fr = [0.0, 0.0, 0.0]
            lim = (top_rate if gi == 2 else gimbal_rate) * 0.95
            amp[gi] = min(math.degrees(A), lim / (2 * math.pi * f))  # sine peak rate inside the axis limit
            fr[gi] = f
            cur['steps'].append({'type': 'position', 'position_deg': ang, 'dwell_s': 0.5, 'label': 'start ' + s.label})
            cur['steps'].append({'type': 'sine', 'amplitude_deg': amp, 'frequency_hz': fr, 'dwell_s': s.dur, 'label': s.label})
        elif s.kind == 'ramp':
            cur['steps'].append({'type': 'position', 'position_deg': ang, 'dwell_s': 1.0, 'label': 'ramp pose'})
            rate = abs(s.set_to - s.set_from) / s.dur * 60
            phases.append({'type': 'ramp', 'label': s.label, 'setpoint_C': s.set_to, 'rate_C_per_min': rate})
        else:
            raise ValueError(s.kind)
    camp = {
        'format': 'imuforge-campaign', 'version': 1, 'name': 'blindgen-mirror',
        '_comment': 'written by tools/blindgen/campaign.py from a blindgen scenario',
        'site': {'latitude_deg': scn.lat, 'height_m': scn.h},
        'sample_rate_hz': scn.fs,
        'table': {'axes': [{'name': 'inner', 'axis': 'z', 'max_rate_dps': gimbal_rate, 'max_accel_dps2': 500},
                           {'name': 'middle', 'axis': 'x', 'max_rate_dps': gimbal_rate, 'max_accel_dps2': 500},
                           {'name': 'outer', 'axis': 'z', 'max_rate_dps': top_rate, 'max_accel_dps2': 500}],
                  'settle_s': 0.2, 'mount': {'rotation_deg': [0, 0, 0], 'lever_arm_m': scn.r.tolist()}},
        'chamber': {'initial_C': scn.T0, 'ramp_limit_C_per_min': scn.chamber['slew_C_per_min'], 'tau_s': scn.chamber['air_tau_s']},
        'sequences': {},
        'phases': phases,
        'simulation': {'encoder_noise_deg': 0.0, 'rate_noise_dps': 0.0, 'temp_noise_C': spec.get('temp_noise_C', 0.02),
                       'chamber_noise_C': spec.get('chamber_noise_C', 0.05),
                       'fixture_errors': {'mount_error_deg': [float(x) for x in np.degrees(scn.mount_err)]}},
    }
    with open(path, 'w') as f:
        json.dump(camp, f, indent=1)
    return camp
