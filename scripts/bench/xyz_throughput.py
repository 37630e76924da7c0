#!/usr/bin/env python3
"""Side by side, in one run: spectra -> XYZ per second, lumifit versus colour-science.

    cargo build --release
    pip install -r scripts/reference/requirements.txt
    python3 scripts/bench/xyz_throughput.py [--n 10000]

The same N random smooth reflectance spectra (380-780 nm) are converted under D65 with the
CIE 1931 2 degree observer by both tools, for both methods and at 5 and 10 nm sampling.
colour is timed as a user calls it: `sd_to_XYZ` on each spectrum (its ASTM E308 default), and
the vectorised `msds_to_XYZ(..., method="Integration")` on the whole set. lumifit is timed by
`lumifit color table`: its own compute time (printed by the command) and the wall time of the
whole process (start-up, CSV parsing, writing the output). Agreement is the largest relative
difference of X, Y, Z between the two tools. Prints a Markdown table for docs/performance.md.
"""

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
import warnings

warnings.filterwarnings("ignore")

import colour  # noqa: E402
import numpy as np  # noqa: E402

ROOT = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", ".."))
BIN = os.path.join(ROOT, "target", "release", "lumifit")


def spectra(n, w, rng):
    c = rng.uniform(380, 780, (n, 3))
    s = rng.uniform(20, 120, (n, 3))
    h = rng.uniform(-0.5, 0.9, (n, 3))
    base = rng.uniform(0.05, 0.5, (n, 1))
    v = base + np.sum(h[:, :, None] * np.exp(-0.5 * ((w[None, None, :] - c[:, :, None]) / s[:, :, None]) ** 2), axis=1)
    return np.clip(v, 0.0, 1.0) * 0.95 + 0.02


def write_csv(path, w, values):
    with open(path, "w") as f:
        f.write("wavelength_nm," + ",".join(f"s{i}" for i in range(values.shape[0])) + "\n")
        for j, wl in enumerate(w):
            f.write(repr(float(wl)) + "," + ",".join(repr(float(x)) for x in values[:, j]) + "\n")


def read_xyz(path):
    data = np.genfromtxt(path, delimiter=",", names=True, dtype=None, encoding="utf-8")
    return np.column_stack([data["X"], data["Y"], data["Z"]])


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--n", type=int, default=10000)
    args = ap.parse_args()
    if not os.path.exists(BIN):
        subprocess.run(["cargo", "build", "--release"], cwd=ROOT, check=True)
    rng = np.random.default_rng(7)
    cmfs = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]
    d65 = colour.SDS_ILLUMINANTS["D65"]
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for interval in (5, 10):
            w = np.arange(380.0, 780.1, interval)
            v = spectra(args.n, w, rng)
            csv = os.path.join(tmp, f"spectra_{interval}.csv")
            write_csv(csv, w, v)
            msds = colour.MultiSpectralDistributions(v.T, w)
            for method in ("astm-e308", "integration"):
                # colour, per spectrum (as sd_to_XYZ is usually called)
                t0 = time.perf_counter()
                ref = np.array(
                    [
                        colour.sd_to_XYZ(
                            colour.SpectralDistribution(v[i], w),
                            cmfs,
                            d65,
                            method="ASTM E308" if method == "astm-e308" else "Integration",
                        )
                        for i in range(args.n)
                    ]
                )
                t_loop = time.perf_counter() - t0
                t_vec = None
                if method == "integration":
                    t0 = time.perf_counter()
                    ref_vec = colour.msds_to_XYZ(msds, cmfs, d65, method="Integration")
                    t_vec = time.perf_counter() - t0
                    assert np.allclose(ref_vec, ref, rtol=1e-10)
                out = os.path.join(tmp, f"xyz_{interval}_{method}.csv")
                t0 = time.perf_counter()
                p = subprocess.run(
                    [BIN, "color", "table", "--sds", csv, "--illuminant", "D65", "--observer", "cie1931-2",
                     "--method", method, "--out", out],
                    check=True, capture_output=True, text=True,
                )
                t_wall = time.perf_counter() - t0
                summary = json.loads(p.stdout)
                got = read_xyz(out)
                rel = np.max(np.abs(got - ref) / np.maximum(np.abs(ref), 1e-12))
                rows.append(
                    {
                        "interval": interval,
                        "method": method,
                        "colour_loop_per_s": args.n / t_loop,
                        "colour_vec_per_s": None if t_vec is None else args.n / t_vec,
                        "lumifit_compute_per_s": summary["spectra_per_second"],
                        "lumifit_wall_per_s": args.n / t_wall,
                        "max_rel_diff": float(rel),
                    }
                )
    print(f"N = {args.n} spectra, 380-780 nm, D65, CIE 1931 2 deg; colour {colour.__version__}, numpy {np.__version__}, "
          f"python {platform.python_version()}, {platform.machine()} ({os.cpu_count()} cores)\n")
    print("| sampling | method | colour `sd_to_XYZ` loop (spectra/s) | colour `msds_to_XYZ` vectorised (spectra/s) "
          "| lumifit compute (spectra/s) | lumifit whole process incl. CSV I/O (spectra/s) | ratio compute / best colour "
          "| ratio whole process / best colour | max relative difference |")
    print("|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        best = max(x for x in (r["colour_loop_per_s"], r["colour_vec_per_s"]) if x is not None)
        vec = "—" if r["colour_vec_per_s"] is None else f"{r['colour_vec_per_s']:,.0f}"
        print(f"| {r['interval']} nm | {r['method']} | {r['colour_loop_per_s']:,.0f} | {vec} | "
              f"{r['lumifit_compute_per_s']:,.0f} | {r['lumifit_wall_per_s']:,.0f} | "
              f"{r['lumifit_compute_per_s'] / best:,.0f}× | {r['lumifit_wall_per_s'] / best:,.0f}× | {r['max_rel_diff']:.1e} |")


if __name__ == "__main__":
    sys.exit(main())
