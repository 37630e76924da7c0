"""`lvf calibrate --camera-database` against the fit without curves, on cameras that are not in the
database (issue 12, "any camera").

    cargo build --release
    python3 scripts/bench/lvf_camera_database.py [--lumifit PATH] [--renders jiang|weta|all]
        [--lamps hg,cfl] [--noise 0.01,0.05] [--seeds 1,2] [--cameras NAME,NAME]
        [--cfl-continuum cfl|flat] [--vignetting quadratic:0.3]

Renders lamp images with `lumifit synth lvf-hg` (issue 12's geometry, 10 % continuum — by default
the CFL's phosphor under the CFL (`--cfl-continuum flat`: a flat one), flat under Hg — and
`--vignetting`, default quadratic 0.3) through
  * jiang: the Canon 5D Mark II, Nikon D700 and SONY NEX-5N of the Jiang et al. 2013 database
    (../shared/data/camera/jiang2013_camspec_all_cameras_long.csv, read in place), each
    calibrated with a copy of the database without its rows written to a temporary directory
    (leave one out: the camera is not in the database, as a user's may not be);
  * weta: Weta's 2025 measurements of the Canon 5D Mark II, 5D Mark III and 600D
    (../shared/data/camera/rawtoaces-data/*.json), curves no lumifit code made, calibrated with
    the whole Jiang database (which holds a 5D Mark II and a 600D measured elsewhere).
Each image is calibrated without curves and with `--camera-database`; prints the signed λ error at
the true 400 / 700 nm positions, σ at 700 nm, the background chosen, the camera picked and the
cameras tried (misfit; x: outside the colour check, ~: in its near zone; "not consulted" when the
fit without curves meets --sigma-hint's default 0.3 nm), then, per lamp and noise,
how many images miss issue 12's bound (Hg 0.15 nm, CFL 0.3 nm at 1 %; 0.4 nm at 5 %) either way.
Two images at a time.
"""

import argparse
import csv
import json
import subprocess
import sys
import tempfile
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
CAM = ROOT.parent / "shared" / "data" / "camera"
DB = CAM / "jiang2013_camspec_all_cameras_long.csv"
JIANG = ["Canon 5DMarkII", "Nikon D700", "SONY NEX-5N"]
WETA = ["Canon_EOS_5D_Mark_II_380_780_5.json", "Canon_EOS_5D_Mark_III_380_780_5.json",
        "Canon_EOS_600D_380_780_5.json"]


def bound(lamp, noise):
    return 0.4 if float(noise) > 0.02 else (0.15 if lamp == "hg" else 0.3)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--lumifit", default=str(ROOT / "target" / "release" / "lumifit"))
    ap.add_argument("--renders", default="all", choices=["jiang", "weta", "all"])
    ap.add_argument("--lamps", default="hg,cfl")
    ap.add_argument("--noise", default="0.01,0.05")
    ap.add_argument("--seeds", default="1,2")
    ap.add_argument("--cameras", default="", help="only these renders (comma-separated names)")
    ap.add_argument("--cfl-continuum", default="cfl", choices=["cfl", "flat"])
    ap.add_argument("--vignetting", default="quadratic:0.3")
    a = ap.parse_args()
    rows = list(csv.reader(DB.open()))
    renders = (JIANG if a.renders != "weta" else []) + (WETA if a.renders != "jiang" else [])
    if a.cameras:
        renders = [r for r in renders if r in a.cameras.split(",")]
    jobs = [(r, l, n, s) for r in renders for l in a.lamps.split(",") for n in a.noise.split(",")
            for s in a.seeds.split(",")]

    def one(job):
        render, lamp, noise, seed = job
        with tempfile.TemporaryDirectory(dir=ROOT / "target") as d:
            d = Path(d)
            weta = render.endswith(".json")
            db = DB
            if not weta:
                db = d / "leave_one_out.csv"
                with db.open("w", newline="") as f:
                    csv.writer(f).writerows(r for r in rows if r[0] != render)
            cam = str(CAM / "rawtoaces-data" / render) if weta else f"{DB}:{render}"
            args = [a.lumifit, "synth", "lvf-hg", "--out", str(d / "i.tiff"), "--truth", str(d / "t.json"),
                    "--lamp", lamp, "--nm-at-start", "372.3", "--nm-per-px", "0.3117", "--fwhm", "25",
                    "--camera", cam, "--noise", noise, "--vignetting", a.vignetting, "--continuum", "0.1",
                    "--seed", seed]
            if lamp == "cfl":
                args += ["--continuum-spectrum", a.cfl_continuum]
            subprocess.run(args, check=True, capture_output=True)
            t = json.loads((d / "t.json").read_text())
            res = {}
            for tag, extra in (("without", []), ("database", ["--camera-database", str(db)])):
                out = d / f"{tag}.json"
                subprocess.run([a.lumifit, "lvf", "calibrate", str(d / "i.tiff"), "--axis", "x", "--lamp", lamp,
                                "--out", str(out), *extra], check=True, capture_output=True)
                o = json.loads(out.read_text())
                c = o["map"]["coefficients"]
                lam = lambda px: sum(ck * px ** k for k, ck in enumerate(c))
                cd = o["diagnostics"].get("camera_database", {})
                tried = " ".join(
                    f"{x['camera']}:{x['misfit']:.3f}{'' if x['matches'] else ('~' if x['consistent'] else 'x')}"
                    for x in cd.get("tried", []))
                chosen = cd.get("chosen") or ("" if cd.get("consulted", True) else "(not consulted)")
                res[tag] = (lam(t["px_at_400"]) - 400, lam(t["px_at_700"]) - 700, o["sigma_nm_at_700"],
                            o["background"]["model"], chosen, tried)
            return job, res

    with ThreadPoolExecutor(2) as ex:
        results = list(ex.map(one, jobs))
    misses = {}
    for (render, lamp, noise, seed), res in results:
        print(f"{render} {lamp} {noise} seed {seed}")
        for tag, (e4, e7, s7, bg, chosen, tried) in res.items():
            print(f"   {tag:9s} {e4:+.3f} / {e7:+.3f}  σ700 {s7:.3f}  {bg:24s} {chosen} [{tried}]")
            key = (lamp, noise, tag)
            m = misses.setdefault(key, [0, 0])
            m[0] += max(abs(e4), abs(e7)) > bound(lamp, noise)
            m[1] += 1
    print("\nimages over issue 12's bound (without curves / --camera-database):")
    for lamp in a.lamps.split(","):
        for noise in a.noise.split(","):
            w, db = misses.get((lamp, noise, "without")), misses.get((lamp, noise, "database"))
            if w:
                print(f"   {lamp} {noise} (bound {bound(lamp, noise)} nm): {w[0]}/{w[1]}  /  {db[0]}/{db[1]}")
    sys.stdout.flush()


if __name__ == "__main__":
    main()
