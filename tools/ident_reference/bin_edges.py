#!/usr/bin/env python3
"""How well a log of bin averages lets eq. 3.5's arctan be averaged over each bin (docs/benchmarks.md,
"Measured and not taken (2026-12-06): the rate at a bin's edges read from a histopolant").

    .venv-interop/bin/python tools/ident_reference/bin_edges.py write DIR   # the clean records
    .venv-interop/bin/python tools/ident_reference/bin_edges.py oracle      # the numpy figures

The records: a 40 Nm/rad spring and eq. 3.5's arctan of 0.5 Nm x 88 s/rad (or none) on a
multi-sine of six waves from 0.1 Hz up to `fmax`, 0.05 rad, computed at 1 kHz through a 14-bit
encoder with 0.05 Nm of torque noise, written as 50 ms means (`f{fmax}_ka{k_a}.csv`). The oracle
knows the motion: it averages the arctan along the path `identify` uses (the rate from the
interval's start edge to its own rate and on to its end edge) with the edges read several ways,
and prints how far each lands from the true bin means of the friction. Needs numpy.
"""
import os
import sys

import numpy as np

FINE_HZ, BIN_S, SECONDS = 1000.0, 0.05, 60.0
K, KA, KB, AMPLITUDE, NOISE = 40.0, 0.5, 88.0, 0.05, 0.05
COUNT = 2 * np.pi / 16384


def motion(fmax, seed=1, seconds=SECONDS):
    rng = np.random.default_rng(seed)
    t = np.arange(int(seconds * FINE_HZ)) / FINE_HZ
    x, v = np.zeros_like(t), np.zeros_like(t)
    for f in np.geomspace(0.1, fmax, 6):
        phase, a = rng.uniform(0, 2 * np.pi), AMPLITUDE / 6
        x += a * np.sin(2 * np.pi * f * t + phase)
        v += a * 2 * np.pi * f * np.cos(2 * np.pi * f * t + phase)
    return t, x, v, rng


def bins(s):
    per = int(BIN_S * FINE_HZ)
    m = len(s) // per
    return s[: m * per].reshape(m, per)


def write(folder):
    os.makedirs(folder, exist_ok=True)
    for fmax in (0.5, 1, 2, 4):
        for ka in (0.0, KA):
            t, x, v, rng = motion(fmax)
            tau = K * x + ka * np.arctan(KB * v) + rng.normal(0, NOISE, len(t))
            xq = np.round(x / COUNT) * COUNT
            with open(os.path.join(folder, f"f{fmax:g}_ka{ka:g}.csv"), "w") as out:
                out.write("t,deflection,torque\n")
                for a, b, c in zip(bins(t).mean(1), bins(xq).mean(1), bins(tau).mean(1)):
                    out.write(f"{a:.6f},{b:.9g},{c:.9g}\n")


def path_mean(start, middle, end, n=64):
    s = np.linspace(0, 1, n)
    rate = np.concatenate([start[:, None] + (middle - start)[:, None] * s, middle[:, None] + (end - middle)[:, None] * s], 1)
    return (KA * np.arctan(KB * rate)).mean(1)


def slope_weights(centres):
    """Weights on the bin means (centres in widths from the point) of the slope there [per width]
    of the least-squares cubic whose means over the bins come closest to them (exact for four)."""
    a = np.stack([((centres + 0.5) ** (k + 1) - (centres - 0.5) ** (k + 1)) / (k + 1) for k in range(min(4, len(centres)))], 1)
    return np.linalg.pinv(a)[1]


def edges_from(xb, centres):
    w, half = slope_weights(centres) / BIN_S, len(centres) // 2
    e = np.zeros(len(xb) + 1)
    for j in range(half, len(xb) - half + 1):
        e[j] = w @ xb[j - half : j + half]
    return e


def oracle():
    rms = lambda e: np.sqrt(np.mean(e[4:-4] ** 2))
    four, six = np.array([-1.5, -0.5, 0.5, 1.5]), np.arange(-2.5, 3.0, 1.0)
    print(f"scatter carried into an edge's slope (root sum of squares of the weights, per width): four {np.linalg.norm(slope_weights(four)):.2f}, six {np.linalg.norm(slope_weights(six)):.2f}")
    for fmax in (1, 2, 4):
        t, x, v, _ = motion(fmax)
        fb, vbar, xb = bins(KA * np.arctan(KB * v)).mean(1), bins(v).mean(1), bins(np.round(x / COUNT) * COUNT).mean(1)
        neighbours = np.r_[vbar[0], 0.5 * (vbar[:-1] + vbar[1:]), vbar[-1]]
        per = int(BIN_S * FINE_HZ)
        m = len(vbar)
        true_edges = np.r_[v[0], 0.5 * (v[per - 1 : m * per - 1 : per] + v[per : m * per : per]), v[m * per - 1]]
        row = [f"neighbours' mean {rms(path_mean(neighbours[:-1], vbar, neighbours[1:]) - fb):.4f}", f"true edges {rms(path_mean(true_edges[:-1], vbar, true_edges[1:]) - fb):.4f}"]
        for name, centres in (("four", four), ("six", six)):
            e = edges_from(xb, centres)
            row.append(f"{name} {rms(path_mean(e[:-1], vbar, e[1:]) - fb):.4f}")
        print(f"fmax {fmax} Hz, the true interval rates, edges by: " + ", ".join(row) + " Nm rms off")
        if fmax == 2:
            e = edges_from(xb, four)
            central = np.r_[0, (xb[2:] - xb[:-2]) / (2 * BIN_S), 0]
            cubic = np.zeros(m)
            w = np.linalg.pinv(np.stack([np.arange(-2, 3.0) ** k for k in range(4)], 1))[1] / BIN_S
            cubic[2:-2] = np.convolve(xb, w[::-1], "valid")
            print(f"fmax 2 Hz, the four's edges, the interval's rate read by: a central difference {rms(path_mean(e[:-1], central, e[1:]) - fb):.4f}, the local cubic {rms(path_mean(e[:-1], cubic, e[1:]) - fb):.4f} Nm rms off")
    rng = np.random.default_rng(3)
    for fmax in (0.5, 2):
        own, quadratic = [], []
        for _ in range(400):
            t, x, v, _ = motion(fmax, seed=int(rng.integers(1 << 30)), seconds=3.0)
            xb, vbar = bins(np.round(x / COUNT) * COUNT).mean(1), bins(v).mean(1)
            own.append(vbar[-1] - v[-1])
            quadratic.append(slope_weights(np.array([-2.5, -1.5, -0.5])) @ xb[-3:] / BIN_S - v[-1])
        print(f"fmax {fmax} Hz, a segment's last edge: the interval's own rate {np.sqrt(np.mean(np.square(own))):.4f}, a quadratic through the last three {np.sqrt(np.mean(np.square(quadratic))):.4f} rad/s rms off")


if __name__ == "__main__":
    if len(sys.argv) == 3 and sys.argv[1] == "write":
        write(sys.argv[2])
    elif len(sys.argv) == 2 and sys.argv[1] == "oracle":
        oracle()
    else:
        sys.exit(__doc__)
