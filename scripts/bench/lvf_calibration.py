"""Whole-profile fit versus peak picking on synthetic LVF lamp images (one run, same images).

    cargo build --release
    python3 scripts/bench/lvf_calibration.py [--seeds 5] [--lumifit BINARY]

Prints, per case, the mean and max |error| of lambda at the true 400 and 700 nm positions and the
median fit time reported by `lumifit lvf calibrate` (fit only, excluding decoding).
"""

import argparse
import json
import subprocess
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
LUMIFIT = str(ROOT / "target" / "release" / "lumifit")

CASES = [  # (label, synth lamp, noise, vignetting, fit lamp, continuum fraction, continuum spectrum)
    ("Hg, 1 % noise", "hg", 0.01, 0.2, "hg", 0.0, "flat"),
    ("Hg, 5 % noise", "hg", 0.05, 0.2, "hg", 0.0, "flat"),
    ("Hg, 1 % noise, no vignetting", "hg", 0.01, 0.0, "hg", 0.0, "flat"),
    ("CFL, 1 % noise, --lamp cfl", "cfl", 0.01, 0.2, "cfl", 0.0, "flat"),
    ("CFL, 1 % noise, fitted as --lamp hg", "cfl", 0.01, 0.2, "hg", 0.0, "flat"),
    # issue 12's hard cases: a continuum under the lines and stronger fall-off
    ("Hg, 10 % flat continuum, vignetting 0.3, 1 % noise", "hg", 0.01, 0.3, "hg", 0.10, "flat"),
    ("Hg, 10 % flat continuum, vignetting 0.3, 5 % noise", "hg", 0.05, 0.3, "hg", 0.10, "flat"),
    ("CFL, 10 % its continuum, vignetting 0.3, 1 % noise", "cfl", 0.01, 0.3, "cfl", 0.10, "cfl"),
]


def run(args):
    return subprocess.run([LUMIFIT, *args], check=False, capture_output=True, text=True)


LUMIFIT_DEFAULT = LUMIFIT


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--lumifit", default=LUMIFIT_DEFAULT, help="the lumifit binary (default target/release/lumifit)")
    a = ap.parse_args()
    global LUMIFIT
    LUMIFIT = a.lumifit
    print("| case | method | mean abs err 400 nm | mean abs err 700 nm | max abs err | median fit time (s) | failures |")
    print("|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as d:
        d = Path(d)
        for label, lamp, noise, vig, fit_lamp, cont, cspec in CASES:
            res = {"whole-profile": [], "peaks": []}
            times = {"whole-profile": [], "peaks": []}
            fails = {"whole-profile": 0, "peaks": 0}
            for seed in range(1, a.seeds + 1):
                img, truth = d / "i.tiff", d / "t.json"
                r = run(["synth", "lvf-hg", "--out", str(img), "--truth", str(truth), "--lamp", lamp,
                         "--noise", str(noise), "--vignetting", str(vig), "--seed", str(seed),
                         "--continuum", str(cont), "--continuum-spectrum", cspec])
                assert r.returncode == 0, r.stderr
                t = json.loads(truth.read_text())
                for method in res:
                    out = d / "o.json"
                    r = run(["lvf", "calibrate", str(img), "--roi", "0,0,1200,160", "--axis", "x",
                             "--lamp", fit_lamp, "--method", method, "--out", str(out)])
                    if r.returncode != 0:
                        fails[method] += 1
                        continue
                    cal = json.loads(out.read_text())
                    c = cal["map"]["coefficients"]
                    lam = lambda px: sum(ci * px**i for i, ci in enumerate(c))
                    res[method].append((abs(lam(t["px_at_400"]) - 400), abs(lam(t["px_at_700"]) - 700)))
                    times[method].append(cal["diagnostics"]["fit_seconds"])
            for method in res:
                e = np.array(res[method]) if res[method] else np.full((1, 2), np.nan)
                print(f"| {label} | {method} | {e[:,0].mean():.3f} | {e[:,1].mean():.3f} | {e.max():.3f} | "
                      f"{np.median(times[method]) if times[method] else float('nan'):.4f} | {fails[method]}/{a.seeds} |")


if __name__ == "__main__":
    main()
