#!/usr/bin/env python3
"""Times the full fluorescence evaluation (10 measured matrices × 7 illuminants × 5 methods) in
numpy and in lumifit, in one run, and prints the ratio (docs/performance.md, "Fluorescence").

numpy side: scripts/reference/fluor_numpy_reference.py (same protocol), timed end to end in one
process: read the 10 BFC files, resample to the 1 nm grid, build the bases, reduce, evaluate,
ΔE00 (colour-science for Lab/CIEDE2000). lumifit side: `lumifit fluor eval … --json` as a
subprocess (process start, parsing and JSON printing included). Best of N runs each.

Usage (crate root, after `cargo build --release`):
    python scripts/bench/fluor_eval.py [--runs 5]
"""
import argparse
import glob
import os
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "scripts", "reference"))
import fluor_numpy_reference as ref  # noqa: E402

DATA = os.path.join(ROOT, "..", "shared", "data", "fluorescence")


def numpy_run(files):
    bs = ref.bases()
    ills = {n: ref.illuminant(n) for n in ref.ILLUMINANTS}
    mats = {os.path.splitext(os.path.basename(f))[0]: ref.to_operator(*ref.read_bfc(f)) for f in files}
    rows, _ = ref.evaluate_all(mats, ills, bs)
    return rows


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--runs", type=int, default=5)
    args = ap.parse_args()
    files = sorted(glob.glob(os.path.join(DATA, "rit_gonzalez_bfc", "*.BFC")) + glob.glob(os.path.join(DATA, "labsphere_3m_postit", "*.BFC")))
    if len(files) != 10:
        sys.exit(f"expected the 10 measured matrices under {DATA}")
    exe = os.path.join(ROOT, "target", "release", "lumifit")
    cmd = [exe, "fluor", "eval", *files, "--json"]
    numpy_run(files)  # warm-up: imports colour, caches
    subprocess.run(cmd, check=True, capture_output=True)
    t_np, t_rs = [], []
    for _ in range(args.runs):
        t0 = time.perf_counter()
        rows = numpy_run(files)
        t_np.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        out = subprocess.run(cmd, check=True, capture_output=True)
        t_rs.append(time.perf_counter() - t0)
    n = len(rows)
    import json

    assert len(json.loads(out.stdout)) == n == 350
    bn, br = min(t_np), min(t_rs)
    print(f"rows: {n} (10 materials × 7 illuminants × 5 methods)")
    print(f"numpy  (in-process, best of {args.runs}): {bn * 1e3:8.1f} ms")
    print(f"lumifit (subprocess, best of {args.runs}): {br * 1e3:8.1f} ms")
    print(f"ratio numpy / lumifit: {bn / br:.1f}×")


if __name__ == "__main__":
    main()
