"""Independent LVF lamp images beyond the issue-12 geometry (numpy only, no lumifit code), run
through `lumifit lvf calibrate`: other FWHMs and dispersions, a reversed filter, a black pedestal,
few rows, an off-range start, weak lines missing from the lamp list, a bowed (quadratic) map,
passbands that are not Gaussian, saturation, other cameras, 5 % noise, an 8-bit PNG, a filter
rotated in the image (slanted iso-wavelength lines), an Hg-Ar lamp's unlisted Ar I lines, dust
shadows and hot pixels, and a filter along y.

    cargo build --release
    python3 scripts/reference/lvf_robustness.py [--lumifit target/release/lumifit] [--cases 0,30]
        [--seeds 1-12] [--camera "Nokia N900"] [--with-camera] [--write fixtures/lvf_reference]

Prints a markdown table: the signed error of the fitted map at the true 400 / 700 nm positions,
the reported σ there, the background model chosen and the first warning; with --seeds a row per
noise draw; with --with-camera every calibration is also given the rendering camera's curves
(`lvf calibrate --camera DB:NAME`) and the row says what the line-colour check found; with --write the images and their truth JSON instead (test fixtures).

Images (unless a case says otherwise): 1200 x 160 px, lambda(px) = 372.3 + 0.3117 px (px = column,
pixel centres at integers), passband FWHM 25 nm, Gaussian, the Canon 5D Mark II of the Jiang et al.
2013 database (../shared/data/camera/jiang2013_camspec_all_cameras_long.csv, read in place, linear
interpolation, zero outside its range), NIST Hg I lines 404.656, 407.783, 435.833, 546.074, 576.960,
579.066 nm (relative powers 0.40, 0.04, 1.00, 0.90, 0.20, 0.22), a flat continuum scaled to 5 % of
the 546 nm blob's peak (integrated on a 0.25 nm grid through passband and camera), quadratic
vignetting 1 - 0.2 r^2, Gaussian noise 1 % of the peak (numpy PCG64, seed 1), brightest pixel 0.8
of full scale, 16-bit RGB PNG written with zlib + struct. Lines are deltas averaged over each
pixel's wavelength span: exactly with math.erf for the Gaussian; for the generalised normal
exp(-ln2 |2 d / FWHM|^beta) by the trapezoid rule on 41 points per pixel. A rotated filter: row y
sees the map at px + (y - (H-1)/2) tan(angle), its profile read off a 0.05 px grid by linear
interpolation; the truth is the middle row's map. Dust: soft-edged dark discs (1 - depth
exp(-(r/R)^4)) multiplying the image; hot pixels: 200 pixels of one channel raised by 0.1-0.5 of
full scale (a fixed generator, seed 99). "Filter along y": the image transposed (rows and columns
swapped, noise and dust included) and calibrated with --axis y; it must give what the untransposed
image gives with --axis x.
"""

import argparse
import json
import math
import struct
import subprocess
import sys
import tempfile
import zlib
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
DB = ROOT.parent / "shared" / "data" / "camera" / "jiang2013_camspec_all_cameras_long.csv"
HG = [(404.656, 0.40), (407.783, 0.04), (435.833, 1.00), (546.074, 0.90), (576.960, 0.20), (579.066, 0.22)]
# weak Hg I lines the lamp list of `--lamp hg` does not carry
HG_WEAK = [(491.607, 0.02), (623.437, 0.015), (690.752, 0.01)]
# Ar I lines of an Hg-Ar pen lamp within the filter's range (NIST; powers relative to Hg 435.8)
AR = [(696.543, 0.10), (706.722, 0.06), (714.704, 0.02), (727.294, 0.04), (738.398, 0.08)]
# dust specks on the filter: (centre x px, centre y px, radius px, depth) in the base geometry
DUST = [(520.0, 60.0, 14.0, 0.35), (560.0, 120.0, 10.0, 0.35), (930.0, 90.0, 18.0, 0.35)]
BOW_C2 = 5e-6  # lambda += 5e-6 px^2: the middle lies 1.80 nm below the chord through the ends

CASES = [
    ("base", {}, []),
    ("FWHM 15 nm", {"fwhm": 15}, []),
    ("FWHM 40 nm", {"fwhm": 40}, []),
    ("0.2 nm/px, 1800 px", {"W": 1800, "map": [380.0, 0.2]}, []),
    ("0.6 nm/px, 600 px", {"W": 600, "map": [362.0, 0.6]}, []),
    ("red to blue (decreasing)", {"map": [746.0, -0.3117]}, []),
    ("black pedestal 2 % of the peak", {"pedestal": 0.016}, []),
    ("40 rows", {"H": 40}, []),
    ("400 nm at px 32", {"map": [390.0, 0.3117]}, []),
    ("weak Hg lines not in the list", {"weak_lines": True}, []),
    ("bow 1.8 nm", {"map": [372.3, 0.3117, BOW_C2]}, []),
    ("bow 1.8 nm", {"map": [372.3, 0.3117, BOW_C2]}, ["--map", "auto"]),
    ("bow 1.8 nm, no continuum", {"map": [372.3, 0.3117, BOW_C2], "continuum": 0}, []),
    ("bow 1.8 nm, no continuum", {"map": [372.3, 0.3117, BOW_C2], "continuum": 0}, ["--map", "auto"]),
    ("passband beta 1.5", {"beta": 1.5}, []),
    ("passband beta 1.5", {"beta": 1.5}, ["--passband", "gennorm"]),
    ("passband beta 1.8", {"beta": 1.8}, []),
    ("passband beta 1.8", {"beta": 1.8}, ["--passband", "gennorm"]),
    ("passband beta 2.2", {"beta": 2.2}, []),
    ("passband beta 2.2", {"beta": 2.2}, ["--passband", "gennorm"]),
    ("passband beta 2.5", {"beta": 2.5}, []),
    ("passband beta 2.5", {"beta": 2.5}, ["--passband", "gennorm"]),
    ("passband beta 2.5, no continuum or vignetting", {"beta": 2.5, "continuum": 0, "vignetting": 0}, []),
    ("passband beta 2.5, no continuum or vignetting", {"beta": 2.5, "continuum": 0, "vignetting": 0}, ["--passband", "gennorm"]),
    ("passband beta 4 (flat top)", {"beta": 4.0}, []),
    ("passband beta 4 (flat top)", {"beta": 4.0}, ["--passband", "gennorm"]),
    ("Gaussian passband", {}, ["--passband", "gennorm"]),
    ("546 nm blob saturated (peak 1.3 x full scale)", {"peak": 1.3}, []),
    ("Nikon D700", {"camera": "Nikon D700"}, []),
    ("Nokia N900", {"camera": "Nokia N900"}, []),
    ("5 % noise", {"noise": 0.05}, []),
    ("dim: peak 0.05 of full scale", {"peak": 0.05}, []),
    ("8-bit PNG of linear values", {"bits": 8}, []),
    ("filter rotated 1 deg", {"rotate_deg": 1.0}, []),
    ("filter rotated 3 deg", {"rotate_deg": 3.0}, []),
    ("Hg-Ar lamp: Ar I lines not in the list", {"argon": True}, []),
    ("dust shadows (3 specks, 35 % deep)", {"dust": True}, []),
    ("hot pixels (200, 0.1-0.5 of full scale)", {"hot": True}, []),
    ("filter along y (case 34 transposed: rotated 3 deg)", {"rotate_deg": 3.0, "transpose": True}, []),
    ("filter along y (case 36 transposed: dust)", {"dust": True, "transpose": True}, []),
    # a level the lens does not vignette (black-level residue, flare) under a strong fall-off
    ("black pedestal 5 % of the peak, vignetting 0.3", {"pedestal": 0.04, "vignetting": 0.3}, []),
    ("black pedestal 5 % of the peak, vignetting 0.3, Nikon D700",
     {"pedestal": 0.04, "vignetting": 0.3, "camera": "Nikon D700"}, []),
]


def camera(name):
    rows = [r.split(",") for r in DB.read_text().splitlines()[1:] if r.startswith(name + ",")]
    d = np.array([[float(v) for v in r[1:]] for r in rows])
    return d[:, 0], d[:, 1:4]


def png(path, img, bits):
    h, w, _ = img.shape
    dtype = ">u2" if bits == 16 else np.uint8
    raw = b"".join(b"\x00" + img[y].astype(dtype).tobytes() for y in range(h))

    def chunk(t, d):
        return struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d) & 0xFFFFFFFF)

    Path(path).write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, bits, 2, 0, 0, 0))
                           + chunk(b"IDAT", zlib.compress(raw, 6)) + chunk(b"IEND", b""))


def render(p, out):
    W, H = p.get("W", 1200), p.get("H", 160)
    c = p.get("map", [372.3, 0.3117])
    fwhm = p.get("fwhm", 25.0)
    sg = fwhm / math.sqrt(8 * math.log(2))
    beta = p.get("beta")
    wl, S = camera(p.get("camera", "Canon 5DMarkII"))
    lam = lambda px: sum(ci * px**i for i, ci in enumerate(c))
    lines = HG + (HG_WEAK if p.get("weak_lines") else []) + (AR if p.get("argon") else [])

    def profile(xs):  # the lines averaged over each pixel's span [x - 0.5, x + 0.5]
        le0, le1 = lam(xs - 0.5), lam(xs + 0.5)
        lo, hi = np.minimum(le0, le1), np.maximum(le0, le1)

        def blob(l0):  # mean passband over each pixel's wavelength span
            if beta is None:
                e = np.vectorize(math.erf)
                return (0.5 * (e((hi - l0) / (sg * 2**0.5)) - e((lo - l0) / (sg * 2**0.5)))) * sg * math.sqrt(2 * math.pi) / (hi - lo)
            f = np.linspace(0, 1, 41)[:, None]
            x = lo[None, :] + f * (hi - lo)[None, :]
            return np.trapezoid(np.exp(-math.log(2) * np.abs(2 * (x - l0) / fwhm) ** beta), f[:, 0], axis=0)

        out = np.zeros((len(xs), 3))
        for l0, pw in lines:
            s = np.array([np.interp(l0, wl, S[:, k], left=0, right=0) for k in range(3)])
            out += pw * blob(l0)[:, None] * s[None, :]
        return out

    def continuum(xs):  # a flat spectrum through passband and camera at each pixel's centre
        g = np.arange(300, 800, 0.25)
        Sg = np.stack([np.interp(g, wl, S[:, k], left=0, right=0) for k in range(3)], -1)
        d = g[None, :] - lam(xs)[:, None]
        T = np.exp(-0.5 * (d / sg) ** 2) if beta is None else np.exp(-math.log(2) * np.abs(2 * d / fwhm) ** beta)
        return np.trapezoid(T[:, :, None] * Sg[None, :, :], g, axis=1)

    px = np.arange(W, dtype=float)
    prof = profile(px)
    cont = p.get("continuum", 0.05)
    scale = cont * prof[np.argmin(abs(lam(px) - 546.074))].max()
    hx, hy = (W - 1) / 2, (H - 1) / 2
    t = math.tan(math.radians(p.get("rotate_deg", 0.0)))
    if t == 0.0:
        if cont > 0:
            cp = continuum(px)
            prof = prof + cp * scale / cp.max()
        rows = np.broadcast_to(prof[None, :, :], (H, W, 3))
    else:
        # the iso-wavelength lines slant: row y sees the map at px + (y - hy) tan(theta); the
        # truth is the map of the middle row, which the mean over all rows is symmetric about
        fine = np.arange(-60.0, W + 60.0, 0.05)
        pf = profile(fine)
        if cont > 0:
            coarse = np.arange(-60.0, W + 61.0)
            cc = continuum(coarse)
            cm = continuum(px).max()
            pf = pf + np.stack([np.interp(fine, coarse, cc[:, k]) for k in range(3)], -1) * scale / cm
        rows = np.stack([np.stack([np.interp(px + (y - hy) * t, fine, pf[:, k]) for k in range(3)], -1)
                         for y in range(H)])
    hx, hy = (W - 1) / 2, (H - 1) / 2
    x, y = np.arange(W) - hx, np.arange(H) - hy
    r2 = (x[None, :] ** 2 + y[:, None] ** 2) / (hx**2 + hy**2)
    shade = 1 - p.get("vignetting", 0.2) * r2
    if p.get("dust"):  # soft-edged dark discs: dust on the filter, out of focus
        for dx, dy, rad, depth in DUST:
            rr = np.hypot(np.arange(W)[None, :] - dx, np.arange(H)[:, None] - dy) / rad
            shade = shade * (1 - depth * np.exp(-rr**4))
    img = shade[:, :, None] * rows
    peak = p.get("peak", 0.8)
    img = img / img.max() * peak
    rng = np.random.default_rng(p.get("seed", 1))
    img = img + p.get("pedestal", 0.0) + p.get("noise", 0.01) * peak * rng.standard_normal(img.shape)
    if p.get("hot"):  # hot pixels: a fixed extra level in one channel of 200 random pixels
        hot = np.random.default_rng(99)
        img[hot.integers(0, H, 200), hot.integers(0, W, 200), hot.integers(0, 3, 200)] += hot.uniform(0.1, 0.5, 200)
    img = np.clip(img, 0, 1)
    if p.get("transpose"):  # the filter's axis along y: the same image with rows and columns swapped
        img = np.ascontiguousarray(img.transpose(1, 0, 2))
    bits = p.get("bits", 16)
    png(out, np.round(img * (2**bits - 1)), bits)
    xs = np.linspace(-50, W + 50, 400001)
    v = lam(xs)  # the middle row's map (a rotated filter's other rows are shifted)
    return {t: float(xs[np.argmin(abs(v - t))]) for t in (400, 700)}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--lumifit", default=str(ROOT / "target" / "release" / "lumifit"))
    ap.add_argument("--cases", help="comma-separated case indices (default all)")
    ap.add_argument("--seeds", help="noise seeds FIRST-LAST: each case rendered once per seed "
                    "(default: the case's own, 1), a row per draw")
    ap.add_argument("--camera", help="render every case through this camera of the database instead")
    ap.add_argument("--with-camera", action="store_true",
                    help="give lvf calibrate the rendering camera's curves (--camera DB:NAME)")
    ap.add_argument("--write", metavar="DIR",
                    help="write each image as DIR/robustness_case{I}_seed{S}.png with its truth JSON "
                         "instead of calibrating (fixtures for the tests)")
    a = ap.parse_args()
    sel = None if not a.cases else {int(i) for i in a.cases.split(",")}
    seeds = [None]
    if a.seeds:
        lo, _, hi = a.seeds.partition("-")
        seeds = list(range(int(lo), int(hi or lo) + 1))
    if a.write:
        Path(a.write).mkdir(parents=True, exist_ok=True)
    else:
        print("| # | image | options | error at 400 / 700 nm | σ 400 / 700 | background | first warning |")
        print("|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        for i, (name, p0, extra) in enumerate(CASES):
            if sel is not None and i not in sel:
                continue
            for seed in seeds:
                p = dict(p0)
                if seed is not None:
                    p["seed"] = seed
                    name_s = f"{CASES[i][0]}, seed {seed}"
                else:
                    name_s = CASES[i][0]
                if a.camera:
                    p["camera"] = a.camera
                    name_s += f", {a.camera}"
                if a.write:
                    stem = Path(a.write) / f"robustness_case{i}_seed{p.get('seed', 1)}"
                    truth = render(p, stem.with_suffix(".png"))
                    doc = {
                        "schema": "lumifit.lvf-reference-truth/1",
                        "generator": f"scripts/reference/lvf_robustness.py --cases {i} --seeds {p.get('seed', 1)} (numpy {np.__version__})",
                        "case": name_s,
                        "parameters": p,
                        "px_at_400": truth[400],
                        "px_at_700": truth[700],
                        "options": extra,
                    }
                    stem.with_suffix(".json").write_text(json.dumps(doc, indent=1) + "\n")
                    print(stem.with_suffix(".png"), stem.with_suffix(".png").stat().st_size, "bytes")
                    continue
                run_case(a, tmp, i, name_s, p, extra)


def run_case(a, tmp, i, name, p, extra):
    """Calibrates one rendered case and prints its table row."""
    img = Path(tmp) / f"case{i}.png"
    truth = render(p, img)
    out = Path(tmp) / f"case{i}.json"
    axis = "y" if p.get("transpose") else "x"
    cam = ["--camera", f"{DB}:{p.get('camera', 'Canon 5DMarkII')}"] if a.with_camera else []
    r = subprocess.run([a.lumifit, "lvf", "calibrate", str(img), "--axis", axis, "--out", str(out), *extra, *cam],
                       capture_output=True, text=True)
    opts = " ".join(extra + (["--camera"] if cam else [])) or "defaults"
    if r.returncode != 0:
        print(f"| {i} | {name} | {opts} | exit {r.returncode}: {r.stderr.strip().splitlines()[-1][:120]} | | | |", flush=True)
        return
    cal = json.loads(out.read_text())
    c = cal["map"]["coefficients"]
    lam = lambda px: sum(ci * px**k for k, ci in enumerate(c))
    e4, e7 = lam(truth[400]) - 400, lam(truth[700]) - 700
    w = cal.get("warnings", [])
    first = (w[0][:90] + "…") if w else ""
    cc = cal.get("diagnostics", {}).get("camera_check")
    if cc:
        first = f"colour misfit {cc['misfit']:.4f}{'' if cc['consistent'] else ' (shared dropped)'}; " + first
    beta = cal.get("passband", {}).get("beta")
    model = cal["background"]["model"] + (f", β {beta:.2f}" if beta else "") + (", quadratic map" if cal["map"]["kind"] == "quadratic" else "")
    print(f"| {i} | {name} | {opts} | {e4:+.3f} / {e7:+.3f} | {cal['sigma_nm_at_400']:.3f} / {cal['sigma_nm_at_700']:.3f} | {model} | {first} |", flush=True)


if __name__ == "__main__":
    sys.exit(main())
