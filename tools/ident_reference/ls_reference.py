#!/usr/bin/env python3
"""A plain least-squares reference for `jointctl identify` (issue 36's yardstick).

The thesis baseline (a linear spring and eq. 3.5's arctan friction) plus a torque offset, a cubic
stiffness and a unit Dahl state driven by the deflection's 25 ms moving average, fitted by linear
least squares on the first 70 % of the time range; the arctan's k_b and the Dahl state's scale are
taken from small grids by the training fit. Scored on the last 30 %, or on the window identify
held out instead (its `held_out_window`: a record whose last 30 % moves unlike the rest is
judged on the window most like it), trained on the rest: both judged on the same samples. Prints, per record, identify's held-out RMSE before and after its causes beside
the reference's, and flags records where identify is more than 1.25 times the reference.

    .venv-interop/bin/python tools/ident_reference/ls_reference.py [--jointctl BIN] FILE.csv...

Needs numpy. The reference names nothing: it says how far a generic fit gets, so that a record
where identify stops far above it points at a cause the search missed.

With `--library` the reference is a larger generic fit, in the manner of a sparse-regression
library (PySINDy's): every column at once, fitted by least squares on the same part (no
thresholding, so at least as close on the training part as any sparse subset): a polynomial of
the deflection to the fifth power, the rate, `v |v|`, `v^3`, `sign(v) sqrt|v|`, five arctans of
the rate, five Dahl states of different scales, an offset and a drift in time.
"""
import argparse
import json
import os
import subprocess

import numpy as np

# Time steps above this start a new segment (a gap in the log, a repetition) [s].
GAP_S = 0.5
# The moving average the Dahl state and the rate are computed from [s].
AVERAGE_S = 0.025


def segments(t):
    cut = np.where((np.diff(t) <= 0) | (np.diff(t) > GAP_S))[0] + 1
    return np.split(np.arange(len(t)), cut)


def moving_average(t, x):
    c = np.concatenate([[0.0], np.cumsum(x)])
    lo = np.searchsorted(t, t - AVERAGE_S / 2, 'left')
    hi = np.searchsorted(t, t + AVERAGE_S / 2, 'right')
    return (c[hi] - c[lo]) / np.maximum(hi - lo, 1)


def dahl(t, x, scale_rad):
    """The unit Dahl state (limit 1) of `x`, exact per step, started afresh on each segment."""
    z = np.zeros_like(x)
    for seg in segments(t):
        u, prev = 0.0, x[seg[0]]
        for i in seg:
            step = x[i] - prev
            prev = x[i]
            if step != 0.0:
                target = 1.0 if step > 0 else -1.0
                u = target + (u - target) * np.exp(-abs(step) / scale_rad)
            z[i] = u
    return z


def read(path):
    """Time, deflection and torque by their header names, as identify reads them."""
    a = np.genfromtxt(path, delimiter=',', names=True, dtype=float)
    if a.ndim == 0 or len(a) < 10:
        raise ValueError('fewer than 10 rows')
    missing = [c for c in ('t', 'deflection', 'torque') if c not in a.dtype.names]
    if missing:
        raise ValueError(f'no column {", ".join(missing)}')
    return a['t'], a['deflection'], a['torque']


def prepared(path, window, left_out=()):
    """Time from the record's start [s] (repetitions laid one after the other), deflection,
    torque, the deflection's moving average and its rate, and the held-out `window`'s samples
    (fractions of the time range) as a mask, without those in `left_out` (the intervals identify
    left out of its fit and judgement, its `after_pauses`, on the clock of the record as it reads
    it: repetitions whose time restarts laid a second apart, as here)."""
    t, d, y = read(path)
    t0 = t[0]
    t = t - t0
    dt = np.diff(t)
    if np.any(dt == 0):
        raise ValueError('a time stamp repeats')
    if np.any(dt < 0):
        # Time that restarts per repetition: laid one after the other, a second apart (as
        # identify does).
        dt[dt < 0] = 1.0
        t = np.concatenate([[0.0], np.cumsum(dt)])
    # Within half a step of an interval's ends: identify lays a logger's bursts evenly, which
    # moves a stamp by less than the stall it follows.
    tolerance = 0.5 * float(np.median(np.diff(t))) if len(t) > 1 else 0.0
    out = np.zeros(len(t), dtype=bool)
    for a, b in left_out:
        out |= (t + t0 >= a - tolerance) & (t + t0 <= b + tolerance)
    smooth = np.empty_like(d)
    rate = np.zeros_like(d)
    for s in segments(t):
        smooth[s] = moving_average(t[s], d[s])
        if len(s) > 2:
            rate[s] = np.gradient(smooth[s], t[s])
    window_mask = (t >= window[0] * t[-1]) & (t <= window[1] * t[-1])
    return t, d, y, smooth, rate, window_mask & ~out, ~window_mask & ~out


def reference(path, window=(0.7, 1.0), left_out=()):
    """(the reference's baseline alone, the whole reference): RMSE [Nm] on the held-out
    `window` (fractions of the time range), fitted on the rest."""
    t, d, y, smooth, rate, test, train = prepared(path, window, left_out)
    span = np.ptp(smooth) or 1.0
    speed = np.percentile(np.abs(rate), 95) or 1.0
    rms = lambda r: float(np.sqrt(np.mean(r ** 2)))
    states = [dahl(t, smooth, span / share) for share in [3, 10, 30, 100, 300, 1000]]
    best_base = best = None
    for kb in [0.3, 1, 3, 10, 30, 100, 300, 1000]:
        friction = np.arctan(kb / speed * rate)
        base = np.column_stack([d, friction])
        c, *_ = np.linalg.lstsq(base[train], y[train], rcond=None)
        fit = np.sum((y[train] - base[train] @ c) ** 2)
        if best_base is None or fit < best_base[0]:
            best_base = (fit, rms(y[test] - base[test] @ c))
        for state in states:
            x = np.column_stack([d, friction, np.ones_like(d), d ** 3, state])
            c, *_ = np.linalg.lstsq(x[train], y[train], rcond=None)
            fit = np.sum((y[train] - x[train] @ c) ** 2)
            if best is None or fit < best[0]:
                best = (fit, rms(y[test] - x[test] @ c))
    return best_base[1], best[1]


def library(path, window=(0.7, 1.0), left_out=()):
    """The library fit's RMSE [Nm] on the held-out `window`, fitted on the rest (see above)."""
    t, d, y, smooth, rate, test, train = prepared(path, window, left_out)
    span = np.ptp(smooth) or 1.0
    # Normalised so that the columns' sizes are alike (the fit's conditioning).
    x = d / (np.max(np.abs(d)) or 1.0)
    v = rate / (np.percentile(np.abs(rate), 95) or 1.0)
    columns = [np.ones_like(d), t / (t[-1] or 1.0)] + [x ** p for p in range(1, 6)]
    columns += [v, v * np.abs(v), v ** 3, np.sign(v) * np.sqrt(np.abs(v))]
    columns += [np.arctan(kb * v) for kb in [1, 3, 10, 30, 100]]
    columns += [dahl(t, smooth, span / share) for share in [3, 10, 30, 100, 300]]
    a = np.column_stack(columns)
    c, *_ = np.linalg.lstsq(a[train], y[train], rcond=None)
    return float(np.sqrt(np.mean((y[test] - a[test] @ c) ** 2)))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--jointctl', default='target/release/jointctl')
    parser.add_argument('--library', action='store_true', help='the larger generic fit (see above) in place of the plain one')
    parser.add_argument('files', nargs='+')
    args = parser.parse_args()
    kind = 'library' if args.library else 'reference'
    for path in args.files:
        name = os.path.basename(path)
        out = subprocess.run([args.jointctl, 'identify', '--data', path, '--json'], capture_output=True, text=True)
        report = json.loads(out.stdout) if out.returncode == 0 else None
        held = (report or {}).get('held_out_window') or {}
        window = (held.get('start', 0.7), held.get('end', 1.0))
        try:
            # Scored on the samples identify scored: those it left out after pauses out here too.
            left_out = (report or {}).get('after_pauses', {}).get('intervals_s', [])
            base, ref = reference(path, window, left_out)
            if args.library:
                ref = library(path, window, left_out)
        except (OSError, ValueError) as e:
            print(f'{name:45s} no reference: {e}')
            continue
        if report is None:
            why = out.stderr.strip().splitlines()[-1] if out.stderr.strip() else f'exit {out.returncode}'
            print(f'{name:45s} identify refused ({why}); {kind} {ref:.4f} Nm')
            continue
        causes = '+'.join(c['effect'] for c in report['causes']) or 'no cause'
        # A friction record's stops are left out of identify's own figures; the reference is
        # scored on every held-out sample, so identify's are taken over every sample too.
        rest = report.get('at_rest') or {}
        before = rest.get('rmse_before_all_nm') if rest else report['rmse_before']
        after = rest.get('rmse_after_all_nm') if rest else report['rmse_after']
        stops = f", stops included ({rest['held_out_samples']} held-out samples at rest)" if rest else ''
        if window != (0.7, 1.0):
            stops += f", held out {100 * window[0]:.0f}-{100 * window[1]:.0f} % as identify did"

        if before is None or after is None:
            print(f'{name:45s} identify gave no figure over every held-out sample (stops left out); {kind} {ref:.4f} Nm')
            continue
        ratio = after / ref if ref > 0 else float('nan')
        flag = '  WORSE' if ratio > 1.25 else ''
        print(f"{name:45s} held out [Nm]: identify {before:.4f} -> {after:.4f} ({causes}{stops}); "
              f"{kind} {ref:.4f} (the plain baseline alone {base:.4f}); identify/{kind} {ratio:.2f}{flag}")

if __name__ == '__main__':
    main()
