"""LVF calibration under continuum, vignetting and noise, over cameras of the Jiang database.

    cargo build --release
    python3 scripts/bench/lvf_continuum.py [--seeds 3] [--cases all|quick|11,12,…] [--background auto] [--shared]
        [--lumifit PATH]   (a copy of the binary, so that a rebuild during the run does not change it)
        [--per-seed]       (each seed's signed error, statistical and reported σ, model)

Geometry of docs/performance.md / issue 12: 1200x160 px, 372.3 nm + 0.3117 nm/px, Gaussian
passband FWHM 25 nm. Images from `lumifit synth lvf-hg` (lines integrated over each pixel's span),
camera from ../shared/data/camera/jiang2013_camspec_all_cameras_long.csv (read in place).
Prints |error| of lambda at the true 400 and 700 nm positions (mean and max over seeds), the
background model the fit chose and the reported sigma, as a markdown table.
"""

import argparse
import json
import subprocess
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
LUMIFIT = str(ROOT / "target" / "release" / "lumifit")
DB = ROOT.parent / "shared" / "data" / "camera" / "jiang2013_camspec_all_cameras_long.csv"
CAMERAS = ["Canon 5DMarkII", "Nikon D700", "SONY NEX-5N"]

# (label, lamp, noise, vignetting, continuum fraction, continuum spectrum)
CASES = [
    ("lines only", "hg", 0.0, "0", 0.0, "flat"),
    ("+ quadratic vignetting 0.2", "hg", 0.0, "quadratic:0.2", 0.0, "flat"),
    ("+ flat continuum 4 %", "hg", 0.0, "0", 0.04, "flat"),
    ("both, 1 % noise", "hg", 0.01, "quadratic:0.2", 0.04, "flat"),
    ("1 % noise, no continuum/vignetting", "hg", 0.01, "0", 0.0, "flat"),
    ("cont. 10 % flat + quadratic 0.3, 1 %", "hg", 0.01, "quadratic:0.3", 0.10, "flat"),
    ("cont. 10 % blackbody 2700 K + cos4 0.3, 1 %", "hg", 0.01, "cos4:0.3", 0.10, "blackbody:2700"),
    ("cont. 10 % flat + linear tilt 0.3, 1 %", "hg", 0.01, "linear:0.3", 0.10, "flat"),
    ("cont. 10 % flat + off-centre 0.3, 1 %", "hg", 0.01, "offcentre:0.3", 0.10, "flat"),
    ("cont. 10 % flat + quadratic 0.3, 5 %", "hg", 0.05, "quadratic:0.3", 0.10, "flat"),
    ("hg-weak, cont. 10 % + quadratic 0.3, 1 %", "hg-weak", 0.01, "quadratic:0.3", 0.10, "flat"),
    ("CFL, 1 % noise, no continuum/vignetting", "cfl", 0.01, "0", 0.0, "cfl"),
    ("CFL, quadratic 0.3, 1 %", "cfl", 0.01, "quadratic:0.3", 0.0, "cfl"),
    ("CFL, cont. 10 % cfl, 1 %", "cfl", 0.01, "0", 0.10, "cfl"),
    ("CFL, cont. 10 % flat, 1 %", "cfl", 0.01, "0", 0.10, "flat"),
    ("CFL, cont. 10 % cfl + quadratic 0.3, 1 %", "cfl", 0.01, "quadratic:0.3", 0.10, "cfl"),
    ("CFL, cont. 10 % cfl + quadratic 0.3, 5 %", "cfl", 0.05, "quadratic:0.3", 0.10, "cfl"),
]
QUICK = [0, 1, 2, 3, 5, 15]


def run(args):
    return subprocess.run([LUMIFIT, *args], check=False, capture_output=True, text=True)


def main():
    global LUMIFIT
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--cases", default="all")
    ap.add_argument("--cameras", default=",".join(CAMERAS))
    ap.add_argument("--background", default="auto")
    ap.add_argument("--shared", action="store_true",
                    help="pass the rendering camera to lvf calibrate (--camera): shared continuum spectrum")
    ap.add_argument("--knots", default=None, help="--continuum-knots of lvf calibrate, e.g. 2.5,1.5")
    ap.add_argument("--lumifit", default=LUMIFIT, help="the lumifit binary (default target/release/lumifit)")
    ap.add_argument("--pedestal", type=float, default=0.0,
                    help="synth lvf-hg --pedestal: a level over the fall-off (fraction of full scale)")
    ap.add_argument("--per-seed", action="store_true",
                    help="also print each seed's signed error, statistical and reported σ at 400 / 700 nm and model")
    a = ap.parse_args()
    LUMIFIT = a.lumifit
    cases = CASES if a.cases == "all" else [CASES[int(i)] for i in (QUICK if a.cases == "quick" else a.cases.split(","))]
    cams = a.cameras.split(",")
    print("| image | camera | mean abs err 400 / 700 nm | max abs err | reported σ 400 / 700 | background chosen | old model (linear offset, no fall-off) mean 400 / 700 | failures |")
    print("|---|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory(dir=ROOT / "target") as d:
        d = Path(d)
        for label, lamp, noise, vig, cont, cspec in cases:
            for cam in cams:
                errs, sig, models, fails, old = [], [], [], 0, []
                seeds = range(1, (a.seeds if noise > 0 else 1) + 1)
                for seed in seeds:
                    img, truth, out = d / "i.tiff", d / "t.json", d / "o.json"
                    r = run(["synth", "lvf-hg", "--out", str(img), "--truth", str(truth), "--lamp", lamp,
                             "--nm-at-start", "372.3", "--nm-per-px", "0.3117", "--fwhm", "25",
                             "--camera", f"{DB}:{cam}", "--noise", str(noise), "--vignetting", vig,
                             "--continuum", str(cont), "--continuum-spectrum", cspec, "--seed", str(seed),
                             *(["--pedestal", str(a.pedestal)] if a.pedestal else [])])
                    assert r.returncode == 0, r.stderr
                    t = json.loads(truth.read_text())
                    r = run(["lvf", "calibrate", str(img), "--axis", "x", "--lamp", lamp,
                             "--background", a.background, "--out", str(out),
                             *(["--continuum-knots", a.knots] if a.knots else []),
                             *(["--camera", f"{DB}:{cam}"] if a.shared else [])])
                    if r.returncode != 0:
                        fails += 1
                        print("  failed:", r.stderr.strip().splitlines()[-1][:200])
                        continue
                    cal = json.loads(out.read_text())
                    c = cal["map"]["coefficients"]
                    lam = lambda px: sum(ci * px**i for i, ci in enumerate(c))
                    errs.append((abs(lam(t["px_at_400"]) - 400), abs(lam(t["px_at_700"]) - 700)))
                    if a.per_seed:
                        print(f"  {cam} seed {seed}: {lam(t['px_at_400']) - 400:+.3f} / {lam(t['px_at_700']) - 700:+.3f} nm, "
                              f"statistical σ {cal['sigma_statistical_nm_at_400']:.3f} / "
                              f"{cal['sigma_statistical_nm_at_700']:.3f}, reported σ {cal['sigma_nm_at_400']:.3f} / "
                              f"{cal['sigma_nm_at_700']:.3f}, {cal['background']['model']}", flush=True)
                    sig.append((cal["sigma_nm_at_400"], cal["sigma_nm_at_700"]))
                    models.append(cal["background"]["model"])
                    if cal.get("unexplained_lines"):
                        print(f"  note: {cam} seed {seed}: unexplained lines "
                              + ", ".join(f"{u['nm']:.1f} nm{' (fitted)' if u.get('fitted') else ''}"
                                          for u in cal["unexplained_lines"]), flush=True)
                    r = run(["lvf", "calibrate", str(img), "--axis", "x", "--lamp", lamp, "--background",
                             "linear", "--no-radial-falloff", "--out", str(out)])
                    if r.returncode == 0:
                        c = json.loads(out.read_text())["map"]["coefficients"]
                        lam = lambda px: sum(ci * px**i for i, ci in enumerate(c))
                        old.append((abs(lam(t["px_at_400"]) - 400), abs(lam(t["px_at_700"]) - 700)))
                e = np.array(errs) if errs else np.full((1, 2), np.nan)
                s = np.array(sig) if sig else np.full((1, 2), np.nan)
                chosen = ", ".join(sorted(set(models)))
                o = np.array(old) if old else np.full((1, 2), np.nan)
                print(f"| {label} | {cam} | {e[:,0].mean():.3f} / {e[:,1].mean():.3f} | {e.max():.3f} | "
                      f"{s[:,0].mean():.3f} / {s[:,1].mean():.3f} | {chosen} | {o[:,0].mean():.3f} / {o[:,1].mean():.3f} | "
                      f"{fails}/{len(seeds)} |", flush=True)


if __name__ == "__main__":
    main()
