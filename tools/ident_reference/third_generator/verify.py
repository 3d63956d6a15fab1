#!/usr/bin/env python3
"""Checks generate.py's output (`verify.py DIR`, DIR as given to `generate.py --out`): parse, finiteness, time-base traits, encoder steps, and the stated
effect_rms_over_noise (re-simulated noise-free signals + CSV-only closed-form checks)."""
import json
import math
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import generate as gen3  # noqa: E402

if len(sys.argv) != 2:
    sys.exit("usage: verify.py DIR (the folder given to generate.py --out)")
ROOT = sys.argv[1]
bad = []


def fail(name, msg):
    bad.append(f"{name}: {msg}")
    print("FAIL", name, msg, flush=True)


def rms(a):
    return float(np.sqrt(np.mean(np.square(a))))


summary = {}
for seed in (1, 2):
    d = os.path.join(ROOT, f"s{seed}")
    A = json.load(open(os.path.join(d, "answers.json")))
    csvs = sorted(f for f in os.listdir(d) if f.endswith(".csv"))
    if sorted(A) != csvs:
        fail(d, "answers/CSV mismatch")
    byidx = {int(n[:3]): n for n in A}
    for idx, eff, timing, enc in gen3.plan(seed):
        name = byidx[idx]
        a = A[name]
        p = os.path.join(d, name)
        with open(p) as fh:
            if fh.readline().strip() != "t,deflection,torque":
                fail(name, "header")
        M = np.loadtxt(p, delimiter=",", skiprows=1)
        t, x, tq = M[:, 0], M[:, 1], M[:, 2]
        n = len(t)
        if not np.all(np.isfinite(M)):
            fail(name, "non-finite")
        if n != a["n_samples"] or n >= 300000:
            fail(name, f"rows {n}")
        # time base
        dt = np.diff(t)
        if timing == "repeat3":
            if np.sum(dt < 0) != 2 or abs(t[0]) > 1e-9:
                fail(name, "repeat3 resets")
        elif np.any(dt <= 0):
            fail(name, "t not increasing")
        if timing in ("plain", "epoch", "bin20"):
            if np.ptp(dt) > 2e-6 * (1 if timing != "epoch" else 2) or abs(np.median(dt) * a["fs"] - 1) > 1e-3:
                fail(name, f"dt irregular {np.ptp(dt)}")
        if timing == "jitter" and (dt.max() < 0.02 or np.std(dt) * a["fs"] < 1e-3):
            fail(name, "no jitter/gaps")
        if timing == "epoch" and not (1.69e9 < t[0] < 1.8e9):
            fail(name, "epoch")
        if timing != "epoch" and t[0] > 0.03:
            fail(name, "t0")
        # encoder steps
        q = gen3.ENC_STEP[enc]
        if timing != "bin20":
            r = x / q
            if np.max(np.abs(r - np.round(r))) > 1e-4:
                fail(name, "not quantised")
        amax = np.max(np.abs(x))
        if not (0.009 < amax < 0.201):
            fail(name, f"amplitude {amax}")
        # re-simulate
        t2, x2, tq2, a2, I = gen3.build_record(seed, idx, eff, timing, enc, want_internal=True)
        if np.max(np.abs(x2 - x)) > 1e-8 * max(1, amax) or np.max(np.abs(tq2 - tq)) > 1e-6 * np.max(np.abs(tq)) + 1e-9:
            fail(name, "regenerated record differs from CSV")
        sig = a["noise"]
        res = tq - I["full"]
        nr = rms(res) / sig
        if abs(nr - 1) > 4 / math.sqrt(n) + 0.02:
            fail(name, f"noise rms/stated {nr:.3f}")
        frac = sig / np.ptp(I["full"])
        if not (0.005 <= frac <= 0.05):
            fail(name, f"noise fraction {frac}")
        for e, c in I["contrib"].items():
            r_sim = rms(c) / sig
            r_st = a["effect_rms_over_noise"][e]
            if abs(r_sim / r_st - 1) > 1e-6 or not (1.5 <= r_st <= 10):
                fail(name, f"{e} ratio {r_st} vs {r_sim}")
        # CSV-only closed-form checks (need nothing but the CSV and the answers)
        P = a["params"]
        k = a["baseline"]["k"]
        chk = {}
        if "vibration" in eff:
            chk["vibration"] = P["amplitude"] / math.sqrt(2) / sig
        if "sensor_offset" in eff and P.get("drift", 0) == 0:
            chk["sensor_offset"] = abs(P["offset"]) / sig
        if "time_delay" not in eff:
            if "stiffness_nonlinearity" in eff:
                chk["stiffness_nonlinearity"] = rms(P["k3"] * x ** 3) / sig
            if "dead_zone" in eff and a["model"]["dead_zone"] == "sharp":
                w = P["width"]
                chk["dead_zone"] = rms(k * (np.sign(x) * np.maximum(np.abs(x) - w, 0) - x)) / sig
        for e, r_csv in chk.items():
            tol = 0.02 if e in ("vibration", "sensor_offset") else 0.08
            if abs(r_csv / a["effect_rms_over_noise"][e] - 1) > tol:
                fail(name, f"{e} CSV-only ratio {r_csv:.3f} vs stated {a['effect_rms_over_noise'][e]:.3f}")
        summary[(seed, name)] = (a, chk, nr)
        print(f"ok s{seed} {name:58s} n={n:6d} noise_rms/stated={nr:.3f} ratios="
              f"{ {e: round(v, 2) for e, v in a['effect_rms_over_noise'].items()} } csv-only="
              f"{ {e: round(v, 2) for e, v in chk.items()} }", flush=True)

# parameter ranges
rng = {}
for (seed, name), (a, chk, nr) in summary.items():
    for kk, v in a["params"].items():
        rng.setdefault(kk, []).append(v)
    for e, v in a["effect_rms_over_noise"].items():
        rng.setdefault("ratio", []).append(v)
    rng.setdefault("noise_frac", []).append(a["noise_fraction_of_range"])
for kk, v in rng.items():
    v = np.array(v)
    print(f"{kk:12s} n={len(v):3d} min={v.min():.4g} max={v.max():.4g}")
print("FAILURES:", len(bad))
sys.exit(1 if bad else 0)
