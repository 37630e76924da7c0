"""The line-colour check of `lvf calibrate --camera` (`lumifit::lvf::line_colour`) over the issue-12 grid.

    cargo build --release
    python3 scripts/bench/lvf_camera_check.py [--cases 5,9,13,15,16] [--seeds 1-2] \
        [--lumifit PATH] [--before PATH] [--own-only]

Renders the cases of scripts/bench/lvf_continuum.py (by index) with `lumifit synth lvf-hg`
through the Canon 5D Mark II, Nikon D700 and SONY NEX-5N of the Jiang database
(../shared/data/camera/jiang2013_camspec_all_cameras_long.csv, read in place) and calibrates each
image with --camera set to its own camera and to other cameras (the two other renderers and
Nokia N900, Canon 20D, Nikon D80, Canon 1DMarkIII, Nikon D3, Nikon D200, Nikon D40). Prints one
row per fit (max |λ error| at 400 / 700 nm, σ at 700, the model chosen, the misfit, whether the
shared spectrum was dropped) and a summary: the largest misfit of the own cameras, and — with
--before, a binary without the check, run on the same images — the wrong-camera fits that took
the shared spectrum there and missed by more than 0.15 nm, how many the check drops and what
they give after. --own-only calibrates with the rendering camera alone (`--cases all --seeds
1-3 --own-only`: the 135 renders of docs/performance.md, issue 12, twenty-sixth session). Two
calibrations run at a time.
"""

import argparse
import json
import subprocess
import sys
import tempfile
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(Path(__file__).resolve().parent))
from lvf_continuum import CASES  # noqa: E402

DB = ROOT.parent / "shared" / "data" / "camera" / "jiang2013_camspec_all_cameras_long.csv"
RENDER = ["Canon 5DMarkII", "Nikon D700", "SONY NEX-5N"]
OTHERS = ["Nokia N900", "Canon 20D", "Nikon D80", "Canon 1DMarkIII", "Nikon D3", "Nikon D200", "Nikon D40"]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--cases", default="5,9,13,15,16", help="indices of lvf_continuum.py's cases, or all")
    ap.add_argument("--seeds", default="1-2")
    ap.add_argument("--lumifit", default=str(ROOT / "target" / "release" / "lumifit"))
    ap.add_argument("--before", help="a binary without the check, run on the same images")
    ap.add_argument("--own-only", action="store_true", help="calibrate with the rendering camera only")
    a = ap.parse_args()
    lo, _, hi = a.seeds.partition("-")
    seeds = range(int(lo), int(hi or lo) + 1)
    with tempfile.TemporaryDirectory(dir=ROOT / "target") as d:
        d = Path(d)
        images = []
        indices = range(len(CASES)) if a.cases == "all" else [int(i) for i in a.cases.split(",")]
        for ci in indices:
            _, lamp, noise, vig, cont, spec = CASES[ci]
            for r in RENDER:
                for s in seeds if noise > 0 else [1]:
                    stem = d / f"c{ci}_{RENDER.index(r)}_{s}"
                    subprocess.run([a.lumifit, "synth", "lvf-hg", "--out", f"{stem}.tiff", "--truth", f"{stem}.t.json",
                                    "--lamp", lamp, "--nm-at-start", "372.3", "--nm-per-px", "0.3117", "--fwhm", "25",
                                    "--camera", f"{DB}:{r}", "--noise", str(noise), "--vignetting", vig,
                                    "--continuum", str(cont), "--continuum-spectrum", spec, "--seed", str(s)],
                                   check=True, capture_output=True)
                    images.append((ci, lamp, r, s, stem))

        def fit(job):
            binary, (ci, lamp, r, s, stem), cam, tag = job
            out = Path(f"{stem}.{tag}.{cam.replace(' ', '_')}.json")
            p = subprocess.run([binary, "lvf", "calibrate", f"{stem}.tiff", "--axis", "x", "--lamp", lamp,
                                "--out", str(out), "--camera", f"{DB}:{cam}"], capture_output=True, text=True)
            if p.returncode != 0:
                return job, None
            o = json.loads(out.read_text())
            t = json.loads(Path(f"{stem}.t.json").read_text())
            c = o["map"]["coefficients"]
            lam = lambda px: sum(ci * px**k for k, ci in enumerate(c))
            err = max(abs(lam(t["px_at_400"]) - 400), abs(lam(t["px_at_700"]) - 700))
            return job, (err, o["sigma_nm_at_700"], o["background"]["model"], o["diagnostics"].get("camera_check"))

        cams = lambda im: [im[2]] if a.own_only else RENDER + OTHERS
        jobs = [(a.lumifit, im, cam, "n") for im in images for cam in cams(im)]
        if a.before:
            jobs += [(a.before, im, cam, "b") for im in images for cam in cams(im) if cam != im[2]]
        with ThreadPoolExecutor(2) as ex:
            res = {(j[1][4], j[2], j[3]): v for j, v in ex.map(fit, jobs)}
    print("| case | rendered | seed | --camera | max error 400/700 nm | σ 700 | model | misfit |")
    print("|---|---|---|---|---|---|---|---|")
    own, harmful = [], []
    for ci, lamp, r, s, stem in images:
        for cam in [r] if a.own_only else RENDER + OTHERS:
            v = res.get((stem, cam, "n"))
            if v is None:
                print(f"| {ci} | {r} | {s} | {cam} | failed | | | |")
                continue
            err, sig, model, cc = v
            mis = "—" if not cc else f"{cc['misfit']:.4f}" + ("" if cc["consistent"] else " dropped")
            print(f"| {ci} | {r} | {s} | {cam}{' (own)' if cam == r else ''} | {err:.3f} | {sig:.3f} | {model} | {mis} |")
            if cam == r and cc:
                own.append(cc["misfit"])
            b = res.get((stem, cam, "b"))
            if cam != r and b and b[2].startswith("shared") and b[0] > 0.15:
                harmful.append((ci, r, s, cam, b, v))
    print(f"\nown cameras: {len(own)} fits with a check, largest misfit {max(own, default=float('nan')):.4f}, "
          f"{sum(m > 0.03 for m in own)} over 0.03")
    if a.before:
        dropped = [h for h in harmful if h[5][3] and not h[5][3]["consistent"]]
        print(f"wrong cameras that took the shared spectrum without the check and missed by > 0.15 nm: "
              f"{len(harmful)}; dropped by the check: {len(dropped)}")
        for ci, r, s, cam, b, v in harmful:
            print(f"  case {ci} {r} seed {s} --camera {cam}: before {b[0]:.3f} nm (σ {b[1]:.3f}, {b[2]}), "
                  f"misfit {v[3]['misfit'] if v[3] else float('nan'):.4f}, after {v[0]:.3f} nm (σ {v[1]:.3f}, {v[2]})")


if __name__ == "__main__":
    main()
