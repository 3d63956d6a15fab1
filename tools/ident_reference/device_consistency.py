#!/usr/bin/env python3
"""One device's variants through `jointctl identify`: the same causes, and parameters that agree.

    python3 tools/ident_reference/device_consistency.py BINARY DIR... [--jobs 2] [--cache C] [--worst N]

Each DIR holds the blind generator's device records (`blind-gen --out DIR --set devices`):
`devX_k_<variant>.csv`, the variants of one device (irregular sampling, 20 Hz bins, one
repetition, three repetitions, and as a test rig logs a stiffness test at one or five drive
amplitudes) and `answers.json`. Every record runs once
(`identify --data FILE --json`); `--cache C` keeps and reads the reports as
`compare_binaries.py` does (`C/<tag>/<folder>/<record>.json`).

Prints, over the devices (issue 36's "the same causes are named across the variants of one
device; the parameters agree within their stated uncertainty"):
- devices whose variants all name the same causes, and of those the ones that are the hidden;
- per variant, the hidden effects named and the records with a cause beside them;
- for the devices with the same causes, every pair of variants and every reported parameter
  with a standard error on both sides (a loop's `shape`, a grid value, is left out): agree when
  `|a - b| <= 2 sqrt(se_a^2 + se_b^2)`; the count, by parameter and by pair of variants, and the
  `--worst` pairs furthest apart in combined errors.
"""
import argparse
import collections
import concurrent.futures
import itertools
import json
import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from compare_binaries import hidden_effects, records, report  # noqa: E402

# Parameters from a grid, not estimated with an error.
GRID_VALUED = {"shape"}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("binary")
    ap.add_argument("dirs", nargs="+")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--cache")
    ap.add_argument("--worst", type=int, default=15)
    a = ap.parse_args()
    jobs = [(d, name, answer) for d, name, _, answer in records(a.dirs) if name.startswith("dev")]
    with concurrent.futures.ThreadPoolExecutor(a.jobs) as ex:
        reps = list(ex.map(lambda j: report(a.binary, os.path.join(j[0], j[1]), a.cache), jobs))
    devices = collections.defaultdict(list)
    for (d, name, answer), rep in zip(jobs, reps):
        device, _, variant = name[:-4].split("_", 2)
        want = tuple(sorted(hidden_effects(answer)))
        causes = {} if "refused" in rep else {c["effect"]: (c["params"], c.get("uncertainty", {})) for c in rep["causes"] if c["effect"] != "dropout"}
        devices[(os.path.basename(os.path.normpath(d)), device)].append((variant, want, causes))
    same = hidden = 0
    pairs = agree = 0
    by_param, by_param_all, by_variants, worst, devices_agreeing = collections.Counter(), collections.Counter(), collections.Counter(), [], 0
    for (folder, device), variants in sorted(devices.items()):
        named = {tuple(sorted(c)) for _, _, c in variants}
        if len(named) != 1:
            print(f"{folder} {device}: different causes: " + "; ".join(f"{v} {sorted(c)}" for v, _, c in variants))
            continue
        same += 1
        hidden += next(iter(named)) == variants[0][1]
        all_agree = True
        for (va, _, ca), (vb, _, cb) in itertools.combinations(variants, 2):
            for effect, (pa, ua) in ca.items():
                pb, ub = cb[effect]
                for param, x in pa.items():
                    if param in GRID_VALUED or param not in pb or param not in ua or param not in ub:
                        continue
                    combined = math.hypot(ua[param], ub[param])
                    pairs += 1
                    by_param_all[f"{effect}.{param}"] += 1
                    if abs(x - pb[param]) <= 2.0 * combined:
                        agree += 1
                        continue
                    all_agree = False
                    by_param[f"{effect}.{param}"] += 1
                    by_variants[f"{va} / {vb}"] += 1
                    apart = abs(x - pb[param]) / combined if combined > 0 else math.inf
                    worst.append((apart, f"{folder} {device} {effect}.{param}: {va} {x:.5g} +- {ua[param]:.2g}, {vb} {pb[param]:.5g} +- {ub[param]:.2g}"))
        devices_agreeing += all_agree
    print(f"\ndevices: {len(devices)}; the same causes over their variants: {same} (the hidden ones: {hidden})")
    # Per variant: the hidden effects named, the records with a cause beside them.
    per_variant = collections.defaultdict(collections.Counter)
    for variants in devices.values():
        for variant, want, causes in variants:
            t = per_variant[variant]
            t["hidden"] += len(want)
            t["named"] += len(set(want) & set(causes))
            t["beside"] += bool(set(causes) - set(want))
    print("per variant, hidden effects named (records with a cause beside): " + ", ".join(f"{v} {t['named']} of {t['hidden']} ({t['beside']})" for v, t in sorted(per_variant.items())))
    print(f"parameter pairs within 2 combined standard errors: {agree} of {pairs}; devices with every pair so: {devices_agreeing} of {same}")
    print("apart, by parameter: " + ", ".join(f"{k} {v} of {by_param_all[k]}" for k, v in by_param.most_common()))
    print("apart, by variants: " + ", ".join(f"{k} {v}" for k, v in by_variants.most_common()))
    for apart, line in sorted(worst, reverse=True)[: a.worst]:
        print(f"  {apart:5.1f} errors apart: {line}")


if __name__ == "__main__":
    main()
