"""Issue 12 end to end at the issue's own geometry, over three cameras: lamp photo -> lvf.json ->
`spectrum recover` of the 24 ColorChecker patches, scored with colour-science (not lumifit code).

    cargo build --release
    pip install -r scripts/bench/requirements.txt      # colour-science
    python3 scripts/bench/lvf_e2e_cameras.py [--seed 1] [--cameras "Canon 5DMarkII,…"]

For each camera of the Jiang et al. 2013 database (read in place from ../shared/data/camera/) and
each lamp — Hg under a flat continuum 10 % of the brightest blob, CFL under its phosphor continuum
10 % — with quadratic vignetting 0.3 and 1 % noise (1200x160 px, 372.3 nm + 0.3117 nm/px, Gaussian
passband FWHM 25 nm, `lumifit synth lvf-hg`), the lamp is calibrated three ways: the default fit
(no camera), the default fit with `--camera` (shared continuum spectrum offered), and the model
before issue 12 (`--background linear --no-radial-falloff`). The 24 N Ohta patches and a white
(reflectance 1) are rendered under LED-B3 through the *true* LVF of that lamp image (`synth
lvf-capture --lvf truth.json`, same camera, same vignetting, 1 % noise), recovered with each
lvf.json (`spectrum recover --bands lvf.json --illuminant LED-B3 --white white.tiff --camera`,
400-700 nm at 5 nm, held constant beyond its ends) and, as the floor, with the default lvf.json
given the true map, FWHM and band windows ("true map"). ΔE00 under D65 (CIE 1931 2°) against the measured reflectance, by colour-science.
Prints a markdown table.
"""

import argparse
import csv
import json
import subprocess
import tempfile
import warnings
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

warnings.filterwarnings("ignore")
import colour  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
LUMIFIT = str(ROOT / "target" / "release" / "lumifit")
SHARED = ROOT.parent / "shared" / "data"
DB = SHARED / "camera" / "jiang2013_camspec_all_cameras_long.csv"
OHTA = SHARED / "spectra" / "colorchecker_n_ohta_reflectance.csv"
CAMERAS = ["Canon 5DMarkII", "Nikon D700", "SONY NEX-5N"]
LAMPS = [("Hg, flat continuum 10 %", "hg", "flat"), ("CFL, its continuum 10 %", "cfl", "cfl")]


def run(args):
    r = subprocess.run([LUMIFIT, *args], capture_output=True, text=True)
    if r.returncode != 0:
        raise RuntimeError(" ".join(args[:3]) + ": " + r.stderr.strip()[-400:])
    return r


def ohta():
    rows = [r for r in csv.reader(l for l in OHTA.open() if not l.startswith("#"))]
    names = rows[0][1:]
    wl = np.array([float(r[0]) for r in rows[1:]])
    v = np.array([[float(x) if x not in ("", "nan", "NaN") else np.nan for x in r[1:]] for r in rows[1:]])
    out = []
    for j, n in enumerate(names):
        y = v[:, j]
        ok = np.isfinite(y)
        out.append((n, wl, np.interp(wl, wl[ok], y[ok])))  # held constant beyond the measured range
    return out


def lab(wl, refl):
    grid = np.arange(380, 781, 5.0)
    r = np.interp(grid, wl, refl)  # constant beyond the ends
    sd = colour.SpectralDistribution(dict(zip(grid, r)))
    cmfs = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]
    ill = colour.SDS_ILLUMINANTS["D65"]
    xyz = colour.sd_to_XYZ(sd, cmfs, ill) / 100.0
    white = colour.sd_to_XYZ(colour.sd_ones(), cmfs, ill) / 100.0
    return colour.XYZ_to_Lab(xyz, colour.XYZ_to_xy(white))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--cameras", default=",".join(CAMERAS))
    a = ap.parse_args()
    patches = ohta()
    truth_lab = [lab(wl, r) for _, wl, r in patches]
    print("| lamp | camera | model | λ error 400 / 700 nm | mean ΔE00 | max ΔE00 (patch) |")
    print("|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory(dir=ROOT / "target") as d, ThreadPoolExecutor(2) as pool:
        d = Path(d)
        for i, (_, wl, r) in enumerate(patches):
            (d / f"p{i:02}.csv").write_text("wavelength_nm,value\n" + "".join(f"{l},{x}\n" for l, x in zip(wl, r)))
        (d / "white.csv").write_text("wavelength_nm,value\n380,1\n780,1\n")
        for label, lamp, cspec in LAMPS:
            for cam in a.cameras.split(","):
                camarg = f"{DB}:{cam}"
                img, truth = d / "lamp.tiff", d / "truth.json"
                run(["synth", "lvf-hg", "--out", str(img), "--truth", str(truth), "--lamp", lamp,
                     "--size", "1200x160", "--nm-at-start", "372.3", "--nm-per-px", "0.3117", "--fwhm", "25",
                     "--camera", camarg, "--noise", "0.01", "--vignetting", "quadratic:0.3",
                     "--continuum", "0.1", "--continuum-spectrum", cspec, "--seed", str(a.seed)])
                t = json.loads(truth.read_text())
                cap = lambda refl, out, seed: ["synth", "lvf-capture", "--reflectance", str(refl),
                                               "--illuminant", "LED-B3", "--lvf", str(truth), "--camera", camarg,
                                               "--vignetting", "quadratic:0.3", "--noise", "0.01",
                                               "--seed", str(seed), "--out", str(out)]
                jobs = [cap(d / "white.csv", d / "white.tiff", 9000)]
                jobs += [cap(d / f"p{i:02}.csv", d / f"c{i:02}.tiff", 100 + i) for i in range(len(patches))]
                list(pool.map(run, jobs))
                models = {"default": [], "--camera": ["--camera", camarg],
                          "before issue 12": ["--background", "linear", "--no-radial-falloff"]}
                for name, extra in [*models.items(), ("true map", None)]:
                    if extra is None:
                        # the default fit's lvf.json with the true map, FWHM and band windows
                        j = json.loads((d / "lvf_default.json").read_text())
                        c0, c1 = t["map"]["coefficients"]
                        j["map"] = {"kind": "linear", "coefficients": [c0, c1]}
                        j["fwhm_nm"] = t["fwhm_nm"]
                        for b in j["bands"]:
                            b["px"] = (b["nm"] - c0) / c1
                            b["width_px"] = abs((j["bands"][1]["nm"] - j["bands"][0]["nm"]) / c1)
                        bands, err = d / "lvf_true.json", "0 / 0"
                        bands.write_text(json.dumps(j))
                    else:
                        bands = d / ("lvf_default.json" if name == "default" else "lvf.json")
                        run(["lvf", "calibrate", str(img), "--axis", "x", "--lamp", lamp, "--out", str(bands), *extra])
                        c = json.loads(bands.read_text())["map"]["coefficients"]
                        lam = lambda px: sum(ci * px**k for k, ci in enumerate(c))
                        err = f"{lam(t['px_at_400']) - 400:+.3f} / {lam(t['px_at_700']) - 700:+.3f}"
                    rec = lambda i: ["spectrum", "recover", str(d / f"c{i:02}.tiff"), "--bands", str(bands),
                                     "--camera", camarg, "--illuminant", "LED-B3", "--white", str(d / "white.tiff"),
                                     "--out", str(d / f"r{i:02}.csv")]
                    try:
                        list(pool.map(run, [rec(i) for i in range(len(patches))]))
                    except RuntimeError as e:
                        print(f"| {label} | {cam} | {name} | {err} | failed: {e} | |", flush=True)
                        continue
                    des = []
                    for i in range(len(patches)):
                        rr = np.loadtxt(d / f"r{i:02}.csv", delimiter=",", skiprows=1, usecols=(0, 1))
                        des.append(float(colour.delta_E(truth_lab[i], lab(rr[:, 0], rr[:, 1]), method="CIE 2000")))
                    k = int(np.argmax(des))
                    print(f"| {label} | {cam} | {name} | {err} | {np.mean(des):.3f} | {des[k]:.3f} ({patches[k][0]}) |",
                          flush=True)


if __name__ == "__main__":
    main()
