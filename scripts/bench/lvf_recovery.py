"""Spectral recovery through the LVF: speed against error, and lumifit's solver against scipy.

    cargo build --release
    pip install -r scripts/bench/requirements.txt   # colour-science, numpy, scipy
    python3 scripts/bench/lvf_recovery.py [--out-json results.json] [--keep DIR] \
        [--figure docs/figures/recovery_narrow.png]

Runs the chain of tests/lvf_recovery_e2e.rs with the same sizes and seeds (600 x 24 px LVF at
0.6 nm/px, 60 Lee gels, grey target and ColorChecker N Ohta patches under LED-B3, white reference
1.0): `synth lvf-hg` -> `lvf calibrate` -> `lvf transmission` (nnls, gaussian, super-gaussian;
`calibration` = the lvf.json alone) -> `spectrum recover --illuminant LED-B3 --white` for the 24
patches at 0.2 / 1 / 3 % noise, with every band model plus plain least squares (`--reg 0
--no-nonneg`) and non-negative least squares without smoothing (`--reg 0`), both on the nnls bands.

Per configuration and noise level it prints the mean / max CIEDE2000 under D65 (CIE 1931 2 deg,
computed with colour-science from the recovered 400-700 nm reflectance, which colour extends
constant to the CMFs' range) against the true Ohta reflectance, the spectral RMS error on the grid,
and the median whole-process time of `spectrum recover`. It checks that lumifit's own L*a*b*
(`lumifit color table --method integration`) of the same spectra agrees with colour's.

Then, for each dumped system (`--dump-system`: the weighted A, b, mu actually solved), it solves the
identical problem with scipy.optimize.nnls on the stacked [A; sqrt(mu) D] system and with
scipy.optimize.lsq_linear(bounds=(0, inf)) (plain least squares: numpy lstsq and unbounded
lsq_linear), in the same run, and reports the time ratios against lumifit's Lawson-Hanson NNLS on
the same stacked system (`nnls_stacked_seconds` in the dump) and against lumifit's whole recovery
(`solve_seconds`: GCV search, solve, uncertainty and resolution matrix), and the largest
|x_lumifit - x_scipy| relative to the largest |x|.
"""

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

try:
    import colour
    import scipy
    from scipy.optimize import lsq_linear, nnls
except ImportError as e:  # pragma: no cover
    sys.exit(f"{e}: pip install -r scripts/bench/requirements.txt")

ROOT = Path(__file__).resolve().parents[2]
LUMIFIT = str(ROOT / "target" / "release" / "lumifit")
LEE = ROOT / ".." / "shared" / "data" / "filters" / "lee_filters_sd_lighting_filters_0.1.1.csv"
NOISES = ["0.002", "0.01", "0.03"]
# (label, band file, extra spectrum-recover flags)
CONFIGS = [
    ("nnls bands, GCV", "bands_nnls.json", []),
    ("gaussian bands, GCV", "bands_gaussian.json", []),
    ("super-gaussian bands, GCV", "bands_super-gaussian.json", []),
    ("calibration (lvf.json), GCV", "lvf.json", []),
    ("nnls bands, NNLS without smoothing (--reg 0)", "bands_nnls.json", ["--reg", "0"]),
    ("nnls bands, plain LS (--reg 0 --no-nonneg)", "bands_nnls.json", ["--reg", "0", "--no-nonneg"]),
]
WORKERS = 2


def run(args):
    t = time.perf_counter()
    r = subprocess.run([LUMIFIT, *args], capture_output=True, text=True)
    dt = time.perf_counter() - t
    if r.returncode != 0:
        sys.exit(f"lumifit {' '.join(args)} failed ({r.returncode}): {r.stderr}")
    return r, dt


def run_all(jobs):
    with ThreadPoolExecutor(WORKERS) as ex:
        return list(ex.map(run, jobs))


def ohta():
    t = np.genfromtxt(ROOT / "calib" / "colorchecker_n_ohta.csv", delimiter=",", names=True, comments="#")
    names = t.dtype.names
    with open(ROOT / "calib" / "colorchecker_n_ohta.csv") as f:
        header = next(l for l in f if not l.startswith("#")).strip().split(",")
    wl = np.asarray(t[names[0]], float)
    return wl, [(header[i], np.asarray(t[names[i]], float)) for i in range(1, len(names))]


def build(d: Path, patches, wl):
    p = lambda n: str(d / n)
    run(["synth", "lvf-hg", "--out", p("hg.tiff"), "--truth", p("truth.json"), "--size", "600x24",
         "--nm-per-px", "0.6", "--noise", "0.002", "--vignetting", "0", "--seed", "3"])
    run(["lvf", "calibrate", p("hg.tiff"), "--roi", "0,0,600,24", "--axis", "x", "--out", p("lvf.json")])
    (d / "grey.csv").write_text("wavelength_nm,value\n380,0.5\n780,0.5\n")
    (d / "white.csv").write_text("wavelength_nm,value\n380,1.0\n780,1.0\n")
    codes = [l.split(",")[0] for l in LEE.read_text().splitlines()
             if l and not l.startswith("#") and not l.startswith("code,")][::4][:60]

    def cap(refl, noise, seed, out):
        return ["synth", "lvf-capture", "--reflectance", refl, "--illuminant", "LED-B3", "--lvf",
                p("truth.json"), "--noise", noise, "--seed", str(seed), "--out", out]

    jobs, csv = [], "image,filter\n"
    for k, code in enumerate(["none", *codes]):
        img = f"gel_{k:02}.tiff"
        a = cap(p("grey.csv"), "0.002", 1000 + k, p(img))
        if code != "none":
            a += ["--filter", f"{LEE}:{code}"]
        jobs.append(a)
        csv += f"{img},{code}\n"
    (d / "captures.csv").write_text(csv)
    for i, (_, r) in enumerate(patches):
        (d / f"patch_{i:02}.csv").write_text(
            "wavelength_nm,value\n" + "".join(f"{l},{v}\n" for l, v in zip(wl, r)))
    for tag in NOISES:
        jobs.append(cap(p("white.csv"), tag, 5000, p(f"white_{tag}.tiff")))
        for i in range(len(patches)):
            jobs.append(cap(p(f"patch_{i:02}.csv"), tag, 6000 + i, p(f"patch_{i:02}_{tag}.tiff")))
    run_all(jobs)
    run_all([["lvf", "transmission", "--lvf", p("lvf.json"), "--captures", p("captures.csv"),
              "--filters", str(LEE), "--source", "LED-B3", "--target", p("grey.csv"), "--model", m,
              "--out", p(f"bands_{m}.json")] for m in ["nnls", "gaussian", "super-gaussian"]])


CMFS = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]
D65 = colour.SDS_ILLUMINANTS["D65"]


def lab(wl, r):
    sd = colour.SpectralDistribution(dict(zip(wl, r)))
    xyz = colour.sd_to_XYZ(sd, CMFS, D65, method="Integration")
    white = colour.sd_to_XYZ(colour.SpectralDistribution(dict(zip(wl, np.ones_like(r)))), CMFS, D65,
                             method="Integration")
    return colour.XYZ_to_Lab(xyz / white[1], colour.XYZ_to_xy(white))


def lumifit_lab(d: Path, wl, spectra):
    """L*a*b* from `lumifit color table` (integration, D65, CIE 1931 2 deg) for spectra on wl."""
    src = d / "lab_in.csv"
    src.write_text("wavelength_nm," + ",".join(f"s{i}" for i in range(len(spectra))) + "\n" + "".join(
        f"{l}," + ",".join(repr(float(s[k])) for s in spectra) + "\n" for k, l in enumerate(wl)))
    run(["color", "table", "--sds", str(src), "--method", "integration", "--out", str(d / "lab_out.csv")])
    rows = np.genfromtxt(d / "lab_out.csv", delimiter=",", names=True, dtype=None, encoding=None)
    return np.array([[r["L"], r["a"], r["b"]] for r in rows], float)


def figure(d: Path, png: str):
    """docs/figures/recovery_narrow.png: a 40 nm FWHM peak at 520 nm plus a 10 nm line at 610 nm
    (twice as high), captured at 1 % noise and recovered with the nnls bands in light mode."""
    g = lambda l, c, w: np.exp(-4 * np.log(2) * ((l - c) / w) ** 2)
    (d / "emission.csv").write_text("wavelength_nm,value\n" + "".join(
        f"{l},{g(l, 520.0, 40.0) + 2 * g(l, 610.0, 10.0)}\n" for l in range(360, 831)))
    run(["synth", "lvf-capture", "--spectrum", str(d / "emission.csv"), "--lvf", str(d / "truth.json"),
         "--noise", "0.01", "--seed", "77", "--out", str(d / "emission.tiff")])
    r, _ = run(["spectrum", "recover", str(d / "emission.tiff"), "--bands", str(d / "bands_nnls.json"),
                "--compare", str(d / "emission.csv"), "--out", str(d / "emission_rec.csv"), "--plot", png])
    s = json.loads(r.stdout)
    print(f"figure {png}: λ = {s['lambda']:.3g}, tr H = {s['effective_parameters']:.1f}, resolution "
          f"{s['resolution_nm']['min']:.1f}–{s['resolution_nm']['max']:.1f} nm, RMS / peak "
          f"{s['compare']['rms_relative_to_peak']:.3f}")


def difference(n, order):
    dmat = np.zeros((n - order, n))
    for i in range(n - order):
        dmat[i, i:i + order + 1] = [-1, 1] if order == 1 else [1, -2, 1]
    return dmat


def best_of(f, reps=5):
    best, out = float("inf"), None
    for _ in range(reps):
        t = time.perf_counter()
        out = f()
        best = min(best, time.perf_counter() - t)
    return best, out


def scipy_compare(dump):
    s = json.loads(Path(dump).read_text())
    m, n = s["m"], s["n"]
    a = np.asarray(s["a_column_major"]).reshape(n, m).T
    b = np.asarray(s["b"])
    x = np.asarray(s["x"])
    peak = max(np.abs(x).max(), 1e-300)
    out = {"solve_seconds": s["solve_seconds"], "nonnegative": s["nonnegative"], "lambda": s["lambda"]}
    if s["nonnegative"]:
        st = np.vstack([a, np.sqrt(s["mu"]) * difference(n, s["difference_order"])])
        rhs = np.concatenate([b, np.zeros(st.shape[0] - m)])
        t_nnls, (xn, _) = best_of(lambda: nnls(st, rhs, maxiter=50 * n))
        t_lsq, rl = best_of(lambda: lsq_linear(st, rhs, bounds=(0, np.inf), method="bvls", tol=1e-12))
        out.update(lumifit_nnls_seconds=s["nnls_stacked_seconds"], scipy_nnls_seconds=t_nnls,
                   scipy_lsq_linear_seconds=t_lsq,
                   diff_nnls=np.abs(x - xn).max() / peak, diff_lsq_linear=np.abs(x - rl.x).max() / peak,
                   diff_lumifit_stacked=np.abs(x - np.asarray(s["nnls_stacked_x"])).max() / peak)
    else:
        t_ls, xl = best_of(lambda: np.linalg.lstsq(a, b, rcond=None)[0])
        t_lsq, rl = best_of(lambda: lsq_linear(a, b, method="bvls", tol=1e-12))
        out.update(numpy_lstsq_seconds=t_ls, scipy_lsq_linear_seconds=t_lsq,
                   diff_lstsq=np.abs(x - xl).max() / peak, diff_lsq_linear=np.abs(x - rl.x).max() / peak)
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--out-json", help="also write every number here")
    ap.add_argument("--keep", help="keep the working files in this directory")
    ap.add_argument("--figure", help="also draw the narrow-emission recovery plot to this PNG")
    args = ap.parse_args()
    if not LEE.is_file():
        sys.exit(f"{LEE}: the Lee gel table is needed")
    wl_t, patches = ohta()
    print(f"colour-science {colour.__version__}, numpy {np.__version__}, scipy {scipy.__version__}")
    results = {"table": [], "scipy": []}
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(args.keep or tmp)
        d.mkdir(parents=True, exist_ok=True)
        t0 = time.perf_counter()
        build(d, patches, wl_t)
        print(f"chain built in {time.perf_counter() - t0:.1f} s (lvf-hg, calibrate, 61 gel photos, 75 patch/white "
              "captures, 3 band models)\n")
        if args.figure:
            figure(d, str(Path(args.figure).resolve()))
        truth_lab = [lab(wl_t, r) for _, r in patches]
        lab_check = 0.0
        de_check = 0.0
        print("| bands and solver | noise | mean ΔE00 | max ΔE00 | mean spectral RMS | max spectral RMS "
              "| median time per recovery (s) |")
        print("|---|---|---|---|---|---|---|")
        for ci, (label, bands, extra) in enumerate(CONFIGS):
            for tag in NOISES:
                jobs = []
                for i in range(len(patches)):
                    stem = d / f"rec_{ci}_{i:02}_{tag}"
                    jobs.append(["spectrum", "recover", str(d / f"patch_{i:02}_{tag}.tiff"), "--bands",
                                 str(d / bands), "--illuminant", "LED-B3", "--white", str(d / f"white_{tag}.tiff"),
                                 *extra, "--out", f"{stem}.csv", "--dump-system", f"{stem}_sys.json"])
                outs = run_all(jobs)
                des, rmss, recs = [], [], []
                for i, (_, truth) in enumerate(patches):
                    rec = np.genfromtxt(d / f"rec_{ci}_{i:02}_{tag}.csv", delimiter=",", names=True)
                    wl, v = rec["wavelength_nm"], rec["value"]
                    recs.append(v)
                    des.append(float(colour.delta_E(lab(wl, v), truth_lab[i], method="CIE 2000")))
                    t_on = np.interp(wl, wl_t, truth)
                    rmss.append(float(np.sqrt(np.mean((v - t_on) ** 2))))
                ll = lumifit_lab(d, wl, recs)
                cl = np.array([lab(wl, v) for v in recs])
                lab_check = max(lab_check, float(np.abs(ll - cl).max()))
                de_l = [float(colour.delta_E(ll[i], truth_lab[i], method="CIE 2000")) for i in range(len(recs))]
                de_check = max(de_check, max(abs(a - b) for a, b in zip(des, de_l)))
                t_med = statistics.median(dt for _, dt in outs)
                row = dict(config=label, noise=float(tag), mean_de=float(np.mean(des)), max_de=float(np.max(des)),
                           mean_rms=float(np.mean(rmss)), max_rms=float(np.max(rmss)), median_seconds=t_med)
                results["table"].append(row)
                print(f"| {label} | {float(tag) * 100:.1f} % | {row['mean_de']:.3f} | {row['max_de']:.3f} | "
                      f"{row['mean_rms']:.4f} | {row['max_rms']:.4f} | {t_med:.3f} |", flush=True)
                for i in range(len(patches)):
                    c = scipy_compare(d / f"rec_{ci}_{i:02}_{tag}_sys.json")
                    c.update(config=label, noise=float(tag), patch=patches[i][0])
                    results["scipy"].append(c)
        print(f"\nlumifit's own L*a*b* (color table, integration) against colour's for every recovered spectrum: "
              f"max |ΔLab| = {lab_check:.2e}; ΔE00 computed from either differs by at most {de_check:.2e}")

        print("\n| bands and solver | systems | lumifit NNLS on [A; √μD] (ms, median) | scipy nnls (ms) | "
              "scipy lsq_linear bvls (ms) | lumifit whole recovery (ms) | scipy nnls / lumifit NNLS | "
              "max rel. |x_lumifit − x_scipy| nnls / lsq_linear |")
        print("|---|---|---|---|---|---|---|---|")
        for label, _, _ in CONFIGS:
            rows = [r for r in results["scipy"] if r["config"] == label]
            med = lambda k: statistics.median(r[k] for r in rows) * 1e3
            whole = med("solve_seconds")
            if rows[0]["nonnegative"]:
                ratio = statistics.median(r["scipy_nnls_seconds"] / max(r["lumifit_nnls_seconds"], 1e-9) for r in rows)
                print(f"| {label} | {len(rows)} | {med('lumifit_nnls_seconds'):.3f} | {med('scipy_nnls_seconds'):.3f} | "
                      f"{med('scipy_lsq_linear_seconds'):.3f} | {whole:.3f} | {ratio:.2f} | "
                      f"{max(r['diff_nnls'] for r in rows):.1e} / {max(r['diff_lsq_linear'] for r in rows):.1e} |")
            else:
                print(f"| {label} | {len(rows)} | (QR) | numpy lstsq {med('numpy_lstsq_seconds'):.3f} | "
                      f"{med('scipy_lsq_linear_seconds'):.3f} | {whole:.3f} | – | "
                      f"{max(r['diff_lstsq'] for r in rows):.1e} / {max(r['diff_lsq_linear'] for r in rows):.1e} |")
    if args.out_json:
        Path(args.out_json).write_text(json.dumps(results, indent=1))


if __name__ == "__main__":
    main()
