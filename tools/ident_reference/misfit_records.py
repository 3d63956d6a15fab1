#!/usr/bin/env python3
"""Characterisation records whose torque has structure no cause of `jointctl identify` models
exactly, with what was put in (a check of identify written apart from it, for changes to its
rules: run identify before and after on the same records and compare what it names).

    .venv-interop/bin/python tools/ident_reference/misfit_records.py OUT_DIR [--seeds 1-48]

Each record: a 14-bit deflection, a spring of 30-300 Nm/rad and eq. 3.5's arctan friction, moved
by one to three sines of 0.1-1.2 Hz; the seed picks (seed mod 3) a Bouc-Wen loop in the torque,
the torque behind a first-order filter (2-20 Hz) and a transport delay (5-50 ms), or nothing
more; and (seed div 3, mod 3) an irregular log, 20 Hz bin means or 1 kHz. Noise 0.5-3 % of the
torque's range. Writes OUT_DIR/rSEED.csv (t, deflection, torque) and OUT_DIR/rSEED.json (what
is in it: `kind` bw, filter or none, for which the hidden effect expected is hysteresis,
time_delay or nothing; the spring, the arctan, the sines, the loop's or the filter's values, the
log and the noise). Needs numpy.
"""
import argparse
import json
import os

import numpy as np


def record(seed):
    rng = np.random.default_rng(seed)
    dt = 5e-4
    n = int(rng.uniform(30, 60) / dt)
    t = np.arange(n) * dt
    count = rng.integers(1, 4)
    freqs, amp = rng.uniform(0.1, 1.2, count), rng.uniform(0.02, 0.1)
    phases = rng.uniform(0, 2 * np.pi, count)
    x = sum(amp / count * np.sin(2 * np.pi * f * t + p) for f, p in zip(freqs, phases))
    v = np.gradient(x, dt)
    k = rng.uniform(30, 300)
    kind = ["bw", "filter", "none"][seed % 3]
    k_a, k_b = rng.uniform(0.02, 0.3), rng.uniform(20, 150)
    tau = k * x + k_a * np.arctan(k_b * v)
    info = {"kind": kind, "k_nm_per_rad": k, "k_a_nm": k_a, "k_b_s_per_rad": k_b, "sines_hz": list(freqs), "amplitude_rad": amp}
    if kind == "bw":
        # Bouc-Wen: dz = dx/x_h (1 - (beta sgn(dx z) + gamma) |z|^n), torque F z.
        beta = rng.uniform(0.3, 0.7)
        gamma, power, x_h = 1 - beta, rng.uniform(1.2, 3), rng.uniform(0.002, 0.02)
        force = rng.uniform(0.1, 1.0) * amp * k * 0.1
        z, zs = 0.0, np.zeros(n)
        for i in range(1, n):
            dx = (x[i] - x[i - 1]) / x_h
            z += dx * (1 - (beta * np.sign(dx * z) + gamma) * abs(z) ** power)
            zs[i] = z
        tau = tau + force * zs
        info["force_nm"] = force
    elif kind == "filter":
        cutoff, transport = rng.uniform(2, 20), rng.uniform(0.005, 0.05)
        lag = int(transport / dt)
        delayed = np.concatenate([np.full(lag, tau[0]), tau[:n - lag]])
        a = dt * 2 * np.pi * cutoff / (1 + dt * 2 * np.pi * cutoff)
        out, acc = np.zeros(n), delayed[0]
        for i in range(n):
            acc += a * (delayed[i] - acc)
            out[i] = acc
        tau = out
        info.update(cutoff_hz=cutoff, transport_s=transport)
    noise = rng.uniform(0.005, 0.03) * np.ptp(tau)
    q = 2 * np.pi / 16384
    xq, y = np.round(x / q) * q, tau + noise * rng.standard_normal(n)
    log = ["irregular", "bin20", "plain"][(seed // 3) % 3]
    if log == "bin20":
        b = 100
        m = n // b
        ts, xs, ys = t[:m * b].reshape(m, b)[:, 0], xq[:m * b].reshape(m, b).mean(1), y[:m * b].reshape(m, b).mean(1)
    elif log == "irregular":
        idx = np.cumsum(rng.geometric(0.3, n))
        idx = idx[idx < n]
        ts, xs, ys = t[idx], xq[idx], y[idx]
    else:
        ts, xs, ys = t[::2], xq[::2], y[::2]
    info.update(log=log, noise_nm=noise)
    return np.vstack([ts, xs, ys]).T, info


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("out")
    ap.add_argument("--seeds", default="1-48", help="first-last, or one seed")
    a = ap.parse_args()
    first, _, last = a.seeds.partition("-")
    first, last = int(first), int(last or first)
    os.makedirs(a.out, exist_ok=True)
    for seed in range(first, last + 1):
        rows, info = record(seed)
        np.savetxt(os.path.join(a.out, f"r{seed}.csv"), rows, delimiter=",", header="t,deflection,torque", comments="", fmt="%.9g")
        with open(os.path.join(a.out, f"r{seed}.json"), "w") as f:
            json.dump(info, f)


if __name__ == "__main__":
    main()
