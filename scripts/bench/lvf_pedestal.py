"""A level under the lamp photo that the lens does not vignette (black-level residue, flare):
how far it moves the map, and how often the strips report one where there is none.

    cargo build --release
    python3 scripts/bench/lvf_pedestal.py [--lumifit BINARY] [--calibrate-with BINARY] [--seeds 2] [--fp-seeds 4]

Issue 12's geometry (1200x160 px, 372.3 nm + 0.3117 nm/px, Gaussian FWHM 25 nm), 10 % continuum
(flat under Hg, the phosphor's under the CFL), quadratic vignetting 0.3, three cameras of the
Jiang database read in place. Part 1: 1 % noise, `synth lvf-hg --pedestal` 0, 0.016 and 0.04 of
full scale (2 and 5 % of the brightest pixel), error at 400 / 700 nm and the pedestal reported
in lvf.json (`background.radial_falloff.pedestal`). Part 2: 1 and 5 % noise without a pedestal,
Hg and CFL, seeds 1..fp-seeds: how many report one. `--calibrate-with` calibrates with another
build (e.g. one from before the pedestal was estimated, whose `synth` has no `--pedestal`): the
images are rendered by `--lumifit` either way.
"""

import argparse
import json
import subprocess
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
DB = ROOT.parent / "shared" / "data" / "camera" / "jiang2013_camspec_all_cameras_long.csv"
CAMERAS = ["Canon 5DMarkII", "Nikon D700", "SONY NEX-5N"]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--lumifit", default=str(ROOT / "target" / "release" / "lumifit"))
    ap.add_argument("--calibrate-with", help="the lumifit binary that calibrates (default --lumifit)")
    ap.add_argument("--seeds", type=int, default=2)
    ap.add_argument("--fp-seeds", type=int, default=4)
    a = ap.parse_args()

    def calibrate(d, lamp, cspec, cam, noise, seed, pedestal):
        img, truth, out = d / "i.tiff", d / "t.json", d / "o.json"
        subprocess.run([a.lumifit, "synth", "lvf-hg", "--out", str(img), "--truth", str(truth), "--lamp", lamp,
                        "--nm-at-start", "372.3", "--nm-per-px", "0.3117", "--fwhm", "25",
                        "--camera", f"{DB}:{cam}", "--noise", str(noise), "--vignetting", "quadratic:0.3",
                        "--continuum", "0.1", "--continuum-spectrum", cspec, "--seed", str(seed),
                        "--pedestal", str(pedestal)], check=True, capture_output=True)
        subprocess.run([a.calibrate_with or a.lumifit, "lvf", "calibrate", str(img), "--axis", "x", "--lamp", lamp, "--out", str(out)],
                       check=True, capture_output=True)
        t, c = json.loads(truth.read_text()), json.loads(out.read_text())
        k = c["map"]["coefficients"]
        lam = lambda px: sum(ci * px**i for i, ci in enumerate(k))
        e = (lam(t["px_at_400"]) - 400, lam(t["px_at_700"]) - 700)
        return e, c["background"]["radial_falloff"].get("pedestal")

    with tempfile.TemporaryDirectory() as d:
        d = Path(d)
        print("| lamp | camera | seed | pedestal 0 | 0.016 | 0.04 | reported at 0.04 (r, g, b) |")
        print("|---|---|---|---|---|---|---|")
        for lamp, cspec in (("hg", "flat"), ("cfl", "cfl")):
            for cam in CAMERAS:
                for seed in range(1, a.seeds + 1):
                    cells, rep = [], "none"
                    for ped in (0.0, 0.016, 0.04):
                        e, p = calibrate(d, lamp, cspec, cam, 0.01, seed, ped)
                        cells.append(f"{e[0]:+.3f} / {e[1]:+.3f}")
                        if ped == 0.04 and p:
                            rep = ", ".join(f"{x[0]:.4f} ± {x[1]:.4f}" for x in p)
                    print(f"| {lamp} | {cam} | {seed} | " + " | ".join(cells) + f" | {rep} |", flush=True)
        n, hits = 0, 0
        for lamp, cspec in (("hg", "flat"), ("cfl", "cfl")):
            for noise in (0.01, 0.05):
                for cam in CAMERAS:
                    for seed in range(1, a.fp_seeds + 1):
                        _, p = calibrate(d, lamp, cspec, cam, noise, seed, 0.0)
                        n += 1
                        if p:
                            hits += 1
                            print(f"  a pedestal where there is none: {lamp}, {noise:.0%} noise, {cam}, seed {seed}: "
                                  + ", ".join(f"{x[0]:.4f} ± {x[1]:.4f}" for x in p), flush=True)
        print(f"{hits} of {n} images without a pedestal reported one")


if __name__ == "__main__":
    main()
