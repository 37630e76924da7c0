#!/usr/bin/env python3
"""Issue 18's "3x per thread": the default (automatic) decay fit of two lumifit binaries, side by side.

    cargo build --release                       # NEW: this checkout
    git worktree add /tmp/before 46fab2a && (cd /tmp/before && cargo build --release)
    python3 scripts/bench/phos_speed.py --old /tmp/before/target/release/lumifit [--n 5000] [--pairs 9]

The batch is the scipy script's generator (scripts/bench/decay_fit_scipy.py: numpy PCG64, seed
2017, 37 samples every 5 s, two states, 1 % noise), written once. The two binaries then run in
turn, NEW OLD NEW OLD ..., after one warm-up each, each as
`RAYON_NUM_THREADS=1 lumifit phos fit-decay --batch curves.csv --out o.csv` (the default mode: BIC
over 1-3 states plus the collapse rule, shared spectrum). Per run: the fit clock the command
prints ("fitted N curves in S s") and the whole process's wall time measured from outside.
Prints medians (min-max), the ratio OLD/NEW of the medians and pair by pair, and whether the two
binaries chose the same number of states for every curve (from the output CSVs of the last pair).
No assertion: a report for docs/performance.md.
"""

import argparse
import statistics
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import decay_fit_scipy as d  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]


def n_states(path):
    with open(path) as fh:
        header = fh.readline().strip().split(",")
        i_id, i_n = header.index("id"), header.index("n_states")
        return {f[i_id]: f[i_n] for f in (line.rstrip("\n").split(",") for line in fh)}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--new", default=str(ROOT / "target" / "release" / "lumifit"))
    ap.add_argument("--old", required=True, help="the binary to compare with (e.g. built at 46fab2a)")
    ap.add_argument("--n", type=int, default=5000, help="curves in the batch")
    ap.add_argument("--pairs", type=int, default=9, help="counted NEW/OLD pairs")
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        batch = tmp / "curves.csv"
        d.write_batch(str(batch), d.make_curves(a.n))
        runs = {"new": [], "old": []}
        for i in range(a.pairs + 1):
            for tag, exe in (("new", a.new), ("old", a.old)):
                fit_s, wall, _ = d.run_lumifit(exe, str(batch), str(tmp / f"{tag}.csv"), False, states=None)
                if i > 0:
                    runs[tag].append((fit_s, wall))
        same = n_states(tmp / "new.csv") == n_states(tmp / "old.csv")
    print(f"default automatic decay fit, {a.n} curves x 37 samples, one thread, {a.pairs} pairs after one warm-up each")
    print()
    print("| binary | fit clock, median (min-max) | fits/s (fit clock) | whole process, median (min-max) |")
    print("|---|---|---|---|")
    med = {}
    for tag, exe in (("old", a.old), ("new", a.new)):
        f = [r[0] for r in runs[tag]]
        w = [r[1] for r in runs[tag]]
        med[tag] = (statistics.median(f), statistics.median(w))
        print(f"| {tag} ({exe}) | {med[tag][0]:.3f} s ({min(f):.3f}-{max(f):.3f}) | {a.n / med[tag][0]:,.0f} "
              f"| {med[tag][1]:.3f} s ({min(w):.3f}-{max(w):.3f}) |")
    pair = sorted(o[1] / n[1] for o, n in zip(runs["old"], runs["new"]))
    print()
    print(f"old/new: fit clock {med['old'][0] / med['new'][0]:.2f}x, whole process {med['old'][1] / med['new'][1]:.2f}x "
          f"(pair by pair {pair[0]:.2f}-{pair[-1]:.2f}x, median {statistics.median(pair):.2f}x)")
    print(f"number of states the same for all {a.n} curves: {'yes' if same else 'NO'}")


if __name__ == "__main__":
    main()
