#!/usr/bin/env python3
"""Scores `jointctl identify --data FILE --json` on generate.py's records, per effect.

    python3 tools/ident_reference/third_generator/score.py [--jointctl BIN] [-v] DIR

DIR as given to `generate.py --out` (its s<seed>/ folders with answers.json). Per hidden effect:
named of hidden; records with a cause beside the hidden ones; clean records with any cause;
records identify refused. `-v` lists each miss and each cause beside. Runs two identify
processes at a time. Parameters are not scored (this generator's hysteresis and delay models
are not identify's, by design).
"""
import argparse
import collections
import concurrent.futures
import glob
import json
import os
import subprocess


def identify(binary, path):
    r = subprocess.run([binary, "identify", "--data", path, "--json"], capture_output=True, text=True)
    if r.returncode != 0:
        return None, r.stderr.strip()[-300:]
    return json.loads(r.stdout), None


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("dir")
    ap.add_argument("--jointctl", default="target/release/jointctl")
    ap.add_argument("-v", action="store_true", help="list the misses and the causes beside")
    a = ap.parse_args()
    jobs = []
    for folder in sorted(glob.glob(os.path.join(a.dir, "s*"))):
        answers = json.load(open(os.path.join(folder, "answers.json")))
        jobs += [(os.path.basename(folder), name, answer, os.path.join(folder, name)) for name, answer in sorted(answers.items())]
    with concurrent.futures.ThreadPoolExecutor(2) as pool:
        results = list(pool.map(lambda j: identify(a.jointctl, j[3]), jobs))
    hidden, named = collections.Counter(), collections.Counter()
    beside, clean, clean_with, refused, lines = 0, 0, 0, 0, []
    for (seed, name, answer, _), (report, why) in zip(jobs, results):
        want = {e for e in answer["effect"].split("+") if e != "none"}
        if report is None:
            refused += 1
            lines.append(f"REFUSED {seed} {name}: {why}")
        got = {c["effect"] for c in report["causes"]} if report else set()
        for w in sorted(want):
            hidden[w] += 1
            named[w] += w in got
            if w not in got:
                lines.append(f"MISS {seed} {name}: hidden {answer['effect']}, named {sorted(got) or 'nothing'}")
        if got - want:
            beside += 1
            lines.append(f"BESIDE {seed} {name}: hidden {answer['effect']}, named {sorted(got)}")
        if not want:
            clean += 1
            clean_with += bool(got)
    print(f"named {sum(named.values())} of {sum(hidden.values())} hidden effects; " + ", ".join(f"{k} {named[k]}/{hidden[k]}" for k in sorted(hidden)))
    print(f"records with a cause beside the hidden ones: {beside}; clean records with a cause: {clean_with} of {clean}; refused: {refused}")
    if a.v:
        print("\n".join(lines))


if __name__ == "__main__":
    main()
