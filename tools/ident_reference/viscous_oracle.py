#!/usr/bin/env python3
"""How far the data let anyone see a hidden viscous friction: the blind generator's own model as
an oracle beside `jointctl identify` (issue 31's misses).

For each record of the blind generator (`tests/blind-gen`, a folder with its `answers.json`; or
of the third generator, `third_generator/generate.py`, whose arctan is its answers' `baseline`)
whose hidden effects are a viscous friction alone or beside a torque offset, and whose friction is
eq. 3.5's arctan or a Stribeck curve: the torque is fitted on identify's training part with the
generator's own structure, the friction's shape taken as the generator made it (`k_b`, or the
Stribeck speeds) and every coefficient refitted by least squares (spring, offset, friction level,
damping), once with the damping and once without. Both are scored on the window identify held
out (its `held_out_window`), beside identify's own held-out RMSE after its causes. The rate is the
slope of a local least-squares line over +-w samples within each segment, w (1-100) chosen by the
training fit: what an oracle that knows the model but not the motion can read from the samples.

    .venv-interop/bin/python tools/ident_reference/viscous_oracle.py [--jointctl BIN] FILE.csv...

Where the oracle with the damping does no better on the held-out part than identify's model (or
than itself without the damping), the record does not show its viscous friction: the quantised
or irregular samples, or a held-out part slower than the training part, hide it from any model.
Needs numpy.
"""
import argparse
import json
import os
import subprocess

import numpy as np

from ls_reference import segments


def slope(t, x, w):
    """The local least-squares slope of `x` over +-w samples, within each segment [rad/s]: from
    running sums, each segment's time taken from its own start."""
    v = np.zeros_like(x)
    for seg in segments(t):
        ts, xs = t[seg] - t[seg[0]], x[seg] - x[seg[0]]
        n = len(seg)
        sums = [np.concatenate([[0.0], np.cumsum(q)]) for q in (np.ones(n), ts, xs, ts * ts, ts * xs)]
        k = np.arange(n)
        lo, hi = np.maximum(k - w, 0), np.minimum(k + w + 1, n)
        m, st, sx, stt, stx = (s[hi] - s[lo] for s in sums)
        den = stt - st * st / m
        ok = den > 1e-12 * np.maximum(stt, 1e-300)
        v[seg] = np.where(ok, (stx - st * sx / m) / np.where(ok, den, 1.0), 0.0)
    return v


def friction(answer, v):
    """The generator's friction shape at rate `v`, its level 1 (the level is refitted)."""
    f = answer['friction']
    if 'k_b' in f:
        return np.arctan(f['k_b'] * v)
    return (f['fc'] + (f['fs'] - f['fc']) * np.exp(-(v / f['vs']) ** 2)) * np.tanh(v / f.get('v_eps', 1e-3)) / f['fc']


def oracle(path, answer, window):
    """(with the damping, without it): held-out RMSE [Nm] on `window` (fractions of the time
    range), fitted on the rest."""
    a = np.genfromtxt(path, delimiter=',', names=True, dtype=float)
    t, d, y = a['t'] - a['t'][0], a['deflection'], a['torque']
    dt = np.diff(t)
    if np.any(dt < 0):
        dt[dt < 0] = 1.0
        t = np.concatenate([[0.0], np.cumsum(dt)])
    test = (t >= window[0] * t[-1]) & (t <= window[1] * t[-1])
    train = ~test
    rms = lambda r: float(np.sqrt(np.mean(r ** 2)))
    best = None
    for w in (1, 2, 3, 5, 8, 12, 20, 35, 50, 100):
        v = slope(t, d, w)
        cols = [d, np.ones_like(d), friction(answer, v)]
        results = []
        for columns in (cols + [v], cols):
            x = np.column_stack(columns)
            c, *_ = np.linalg.lstsq(x[train], y[train], rcond=None)
            results.append((np.sum((y[train] - x[train] @ c) ** 2), rms(y[test] - x[test] @ c)))
        if best is None or results[0][0] < best[0][0]:
            best = results
    return best[0][1], best[1][1]


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--jointctl', default='target/release/jointctl')
    parser.add_argument('files', nargs='+')
    args = parser.parse_args()
    answers = {}
    for path in args.files:
        folder, name = os.path.split(path)
        if folder not in answers:
            with open(os.path.join(folder, 'answers.json')) as f:
                answers[folder] = json.load(f)
        answer = answers[folder].get(name)
        if answer is None:
            continue
        if 'friction' not in answer and 'baseline' in answer:
            # The third generator's answers: eq. 3.5's arctan and the spring in `baseline`.
            answer = dict(answer, friction={'k_b': answer['baseline']['k_b']}, k=answer['baseline']['k'])
        hidden = set(answer['effect'].split('+'))
        if 'viscous_friction' not in hidden or not hidden <= {'viscous_friction', 'sensor_offset'} or answer.get('k', 0) == 0:
            continue
        if 'k_b' not in answer['friction'] and 'fc' not in answer['friction']:
            continue
        out = subprocess.run([args.jointctl, 'identify', '--data', path, '--json'], capture_output=True, text=True)
        if out.returncode != 0:
            print(f'{path:60s} identify refused')
            continue
        report = json.loads(out.stdout)
        held = report.get('held_out_window') or {}
        window = (held.get('start', 0.7), held.get('end', 1.0))
        with_b, without_b = oracle(path, answer, window)
        named = 'viscous_friction' in {c['effect'] for c in report['causes']}
        causes = '+'.join(c['effect'] for c in report['causes']) or 'no cause'
        floor = (report.get('unexplained') or {}).get('noise_floor_nm', float('nan'))
        print(f"{path:60s} {'named ' if named else 'missed'} held out {100 * window[0]:.0f}-{100 * window[1]:.0f} % [Nm]: "
              f"identify {report['rmse_before']:.4f} -> {report['rmse_after']:.4f} ({causes}); "
              f"oracle {without_b:.4f} without the damping, {with_b:.4f} with it (b = {answer['params']['b']:.2f} Nm s/rad); noise floor {floor:.4f}")


if __name__ == '__main__':
    main()
