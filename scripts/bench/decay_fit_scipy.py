#!/usr/bin/env python3
"""Side by side, in one run: phosphorescence decay fits per second, lumifit versus scipy.

    cargo build --release
    pip install -r scripts/bench/requirements.txt
    python3 scripts/bench/decay_fit_scipy.py [--n 1000] [--lumifit target/release/lumifit]

One deterministic generator (numpy PCG64, seed 2017) makes N synthetic RGB decay curves with
the distribution of benches/decay_fit.rs: 37 samples every 5 s, two states with
k1 ~ U[0.1, 0.3] 1/s, k2 = k1 / U[5, 10], amplitudes a1 ~ U[1, 2], a2 ~ U[0.2, 0.5], a spectrum
(U[0.2, 1], 1, U[0.2, 1]) and 1 % relative Gaussian noise. The curves are written to
target/decay_bench/curves.csv (the batch format `id,time_s,r,g,b`) and both tools fit the
same file:

- scipy: `scipy.optimize.curve_fit` with bounds >= 0 (trust-region reflective), the
  per-channel two-exponential model (8 parameters: 2 rates, 3 + 3 amplitudes), start
  k = (0.1, 0.01) 1/s and amplitudes from the first sample, numerical Jacobian (the default).
- lumifit: `lumifit phos fit-decay --batch curves.csv --states 2 [--per-channel]` with
  RAYON_NUM_THREADS=1 (single thread), timed by the command's own fit clock (printed as
  "fitted N curves in S s") and by the wall time of the whole process (start-up, CSV parsing,
  writing the output).

Issue 18 adds the default automatic mode (no --states: BIC over 1-3 states plus the collapse
rule, shared spectrum), whole `fit-decay --batch` process on one thread, and with
`--before EXE` the same rows for an older lumifit binary in the same run (before/after).
A curve for which the automatic mode chose another number of states than two counts as
"failed or other n".

Reports fits/s, the median absolute relative error of k1 and k2 against the truth, and the
ratios, as a Markdown table for docs/performance.md.
"""

import argparse
import os
import platform
import re
import subprocess
import sys
import time
import warnings

import numpy as np
import scipy
from scipy.optimize import curve_fit

N_SAMPLES = 37
DT_S = 5.0
SEED = 2017


def make_curves(n):
    rng = np.random.Generator(np.random.PCG64(SEED))
    t = np.arange(N_SAMPLES) * DT_S
    curves = []
    for _ in range(n):
        k1 = 0.1 + 0.2 * rng.uniform()
        k2 = k1 / (5.0 + 5.0 * rng.uniform())
        a = (1.0 + rng.uniform(), 0.2 + 0.3 * rng.uniform())
        s = np.array([0.2 + 0.8 * rng.uniform(), 1.0, 0.2 + 0.8 * rng.uniform()])
        f = a[0] * np.exp(-k1 * t) + a[1] * np.exp(-k2 * t)
        noise = 0.01 * f
        y = s[:, None] * f[None, :] + noise[None, :] * rng.standard_normal((3, N_SAMPLES))
        curves.append((t, y, (k1, k2)))
    return curves


def write_batch(path, curves):
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, "w") as fh:
        fh.write("id,time_s,r,g,b\n")
        for i, (t, y, _) in enumerate(curves):
            for j in range(len(t)):
                vals = (float(t[j]), float(y[0, j]), float(y[1, j]), float(y[2, j]))
                fh.write(f"c{i}," + ",".join(repr(v) for v in vals) + "\n")


def model(tt, k1, k2, a1r, a1g, a1b, a2r, a2g, a2b):
    # tt is the time axis repeated for R, G, B (3 × 37 values)
    m = tt.size // 3
    t = tt[:m]
    e1 = np.exp(-k1 * t)
    e2 = np.exp(-k2 * t)
    return np.concatenate([a1r * e1 + a2r * e2, a1g * e1 + a2g * e2, a1b * e1 + a2b * e2])


def fit_scipy(curves):
    out = []
    start = time.perf_counter()
    for t, y, _ in curves:
        tt = np.concatenate([t, t, t])
        yy = y.reshape(-1)
        y0 = np.maximum(y[:, 0], 1e-6)
        p0 = [0.1, 0.01, *(0.5 * y0), *(0.5 * y0)]
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                p, _ = curve_fit(model, tt, yy, p0=p0, bounds=(0.0, np.inf))
            k = sorted(p[:2], reverse=True)
            out.append((k[0], k[1]))
        except (RuntimeError, ValueError):
            out.append(None)
    return time.perf_counter() - start, out


def run_lumifit(exe, batch, out_csv, per_channel, states="2"):
    args = [exe, "phos", "fit-decay", "--batch", batch, "--out", out_csv]
    if states is not None:
        args += ["--states", states]
    if per_channel:
        args.append("--per-channel")
    env = dict(os.environ, RAYON_NUM_THREADS="1")
    start = time.perf_counter()
    proc = subprocess.run(args, env=env, capture_output=True, text=True, check=False)
    wall = time.perf_counter() - start
    if proc.returncode != 0:
        sys.exit(f"lumifit failed ({proc.returncode}): {proc.stderr.strip()}")
    m = re.search(r"fitted (\d+) curves in ([0-9.]+) s", proc.stdout + proc.stderr)
    fit_s = float(m.group(2)) if m else float("nan")
    ks = {}
    with open(out_csv) as fh:
        header = fh.readline().strip().split(",")
        i_id, i_n = header.index("id"), header.index("n_states")
        i_k1, i_k2 = header.index("k1_per_s"), header.index("k2_per_s")
        for line in fh:
            f = line.rstrip("\n").split(",")
            if len(f) <= i_k2 or f[i_n] != "2" or not f[i_k1] or not f[i_k2]:
                ks[f[i_id]] = None
                continue
            ks[f[i_id]] = (float(f[i_k1]), float(f[i_k2]))
    return fit_s, wall, ks


def errors(results, curves):
    e1, e2, failed = [], [], 0
    for r, (_, _, k) in zip(results, curves):
        if r is None:
            failed += 1
            continue
        e1.append(abs(r[0] / k[0] - 1.0))
        e2.append(abs(r[1] / k[1] - 1.0))
    med = lambda v: float(np.median(v)) if v else float("nan")  # noqa: E731
    return med(e1), med(e2), failed


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=1000, help="number of curves")
    ap.add_argument("--lumifit", default="target/release/lumifit", help="lumifit executable")
    ap.add_argument("--dir", default="target/decay_bench", help="working directory")
    ap.add_argument("--before", help="an older lumifit executable, timed in the same run")
    a = ap.parse_args()
    for exe in [a.lumifit] + ([a.before] if a.before else []):
        if not os.path.exists(exe):
            sys.exit(f"{exe} not found; run `cargo build --release` first")
    curves = make_curves(a.n)
    batch = os.path.join(a.dir, "curves.csv")
    write_batch(batch, curves)

    rows = []
    runs = [
        ("lumifit --states 2, per-channel amplitudes", a.lumifit, True, "2"),
        ("lumifit --states 2, shared spectrum", a.lumifit, False, "2"),
        ("lumifit default (auto: BIC 1-3 + collapse, shared)", a.lumifit, False, None),
    ]
    if a.before:
        runs.append(("before: lumifit default (auto, shared)", a.before, False, None))
        runs.append(("before: lumifit --states 2, shared spectrum", a.before, False, "2"))
    for i, (name, exe, per_channel, states) in enumerate(runs):
        fit_s, wall, ks = run_lumifit(
            exe, batch, os.path.join(a.dir, f"fits_{i}.csv"), per_channel, states
        )
        res = [ks.get(f"c{i}") for i in range(len(curves))]
        rows.append((name, fit_s, wall, errors(res, curves)))
    secs, res = fit_scipy(curves)
    rows.append(("scipy curve_fit, bounds >= 0, per-channel", secs, secs, errors(res, curves)))

    scipy_rate = len(curves) / secs
    print(
        f"decay fit, {len(curves)} RGB curves x {N_SAMPLES} samples, two states, 1 % noise, "
        f"single thread; Python {platform.python_version()}, numpy {np.__version__}, "
        f"scipy {scipy.__version__}\n"
    )
    print(
        "| fitter | fits/s (fit) | fits/s (whole process) | × scipy (fit) "
        "| × scipy (whole process) | median abs. rel. error k₁ | k₂ | failed or other n |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for name, fit_s, wall, (e1, e2, failed) in rows:
        rate = len(curves) / fit_s
        whole = len(curves) / wall
        print(
            f"| {name} | {rate:,.0f} | {whole:,.0f} | {rate / scipy_rate:,.0f} "
            f"| {whole / scipy_rate:,.0f} | {e1:.2e} | {e2:.2e} | {failed} |"
        )
    if a.before:
        by = {r[0]: r for r in rows}
        new = by["lumifit default (auto: BIC 1-3 + collapse, shared)"]
        old = by["before: lumifit default (auto, shared)"]
        print(
            f"\ndefault auto mode, after / before: {old[1] / new[1]:.2f}x (fit clock), "
            f"{old[2] / new[2]:.2f}x (whole process)"
        )


if __name__ == "__main__":
    main()
