"""Independent LVF lamp images for issue 12 (no lumifit code): the fit is checked on inputs
lumifit did not make.

    pip install -r scripts/reference/requirements.txt   # numpy only is needed here
    python3 scripts/reference/lvf_images.py [--out fixtures/lvf_reference]

Geometry (issue 12, docs/performance.md): 1200 x 160 px, lambda(px) = 372.3 + 0.3117 px (px =
column, pixel centres at integers), Gaussian passband FWHM 25 nm, Canon 5D Mark II
sensitivities of the Jiang et al. 2013 database read in place from
../shared/data/camera/jiang2013_canon_5d_mark_ii_400_720_10.csv (linear interpolation, zero
outside 400-720 nm), mercury lines (NIST Hg I: 404.656, 407.783, 435.833, 546.074, 576.960,
579.066 nm; relative powers 0.40, 0.04, 1.00, 0.90, 0.20, 0.22).

Lines are evaluated exactly: each line is a delta, its passband response is averaged over the
pixel's own wavelength span analytically with the Gaussian CDF (math.erf), no wavelength grid.
The flat continuum is integrated on a 0.25 nm grid (trapezoid) through passband and camera and
scaled so its largest value is 4 % of the 546 nm blob's peak (over channels, before
vignetting). Vignetting: V = 1 - 0.2 r^2, r = distance from the image centre over the half
diagonal. Noise: Gaussian, sigma = 1 % of the image's peak, numpy PCG64 seed 12. Images are
scaled so the brightest pixel is 0.8 of full scale and written as 16-bit RGB PNG (zlib +
struct, no imaging library), with a truth JSON beside each.

Images: lines.png, vignetting.png (+ quadratic vignetting 0.2), continuum.png (+ flat
continuum 4 %), both_noise.png (both + 1 % noise).

Compact fluorescent lamps (issue 12), from a published spectrum, not from lumifit's line list:
the CIE 15:2018 fluorescent illuminants FL10 (5000 K), FL11 (4000 K) and FL12 (3000 K), the
narrow-band tri-phosphor lamps (Tb3+ green, Eu3+ red, Eu2+ blue phosphors plus the mercury
lines) that CFLs use, 380-780 nm at 5 nm, read from calib/illuminants/FLn.csv (exported from
colour-science `SDS_ILLUMINANTS`, see calib/README.md). The tabulated SPD is taken as piecewise
linear between its 5 nm samples (each sample a triangle of 5 nm half-width, whose first moment
is the sample's wavelength) and integrated on a 0.1 nm grid, each 0.1 nm element averaged over
the pixel's span like a line. The table's lines and bands are as CIE gives them: a line's
position inside its 5 nm interval is only known through the neighbouring samples, so these
images check the line list to the table's resolution (about 1 nm), not to 0.1 nm. Cases:
cfl_fl10.png, cfl_fl11.png and cfl_fl12.png (clean), cfl_fl11_noise.png (+ quadratic
vignetting 0.3, 1 % noise, seed 13).

Issue 12's hardest Hg case, on another camera: d700_blackbody_cos4.png — Nikon D700 of the
Jiang database (../shared/data/camera/jiang2013_camspec_all_cameras_long.csv, read in place),
a 2700 K blackbody continuum (Planck's law) scaled to 10 % of the brightest line blob, cos^4
fall-off V = 1/(1 + r^2/f^2)^2 with V = 0.7 at the corners, 1 % noise (seed 13).
"""

import argparse
import json
import math
import struct
import zlib
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
CAMERA = ROOT.parent / "shared" / "data" / "camera" / "jiang2013_canon_5d_mark_ii_400_720_10.csv"
DATABASE = ROOT.parent / "shared" / "data" / "camera" / "jiang2013_camspec_all_cameras_long.csv"
W, H = 1200, 160
C0, C1 = 372.3, 0.3117
FWHM = 25.0
SIGMA = FWHM / math.sqrt(8 * math.log(2))
FL = ROOT / "calib" / "illuminants"
HG = [(404.656, 0.40), (407.783, 0.04), (435.833, 1.00), (546.074, 0.90), (576.960, 0.20), (579.066, 0.22)]


def camera():
    rows = [l for l in CAMERA.read_text().splitlines() if l and not l.startswith("#")]
    data = np.array([[float(v) for v in r.split(",")] for r in rows[1:]])
    return data[:, 0], data[:, 1:4]


def camera_from_database(name):
    """One camera of the long-format Jiang table camera,wavelength_nm,r,g,b."""
    rows = [r.split(",") for r in DATABASE.read_text().splitlines()[1:] if r.startswith(name + ",")]
    data = np.array([[float(v) for v in r[1:]] for r in rows])
    return data[:, 0], data[:, 1:4]


def planck(nm, t_k):
    h, c, k = 6.62607015e-34, 2.99792458e8, 1.380649e-23
    lam = np.asarray(nm, dtype=float) * 1e-9
    return 2 * h * c * c / lam**5 / np.expm1(h * c / (lam * k * t_k))


def sens(wl, q, nm):
    nm = np.asarray(nm, dtype=float)
    out = np.stack([np.interp(nm, wl, q[:, c], left=0.0, right=0.0) for c in range(3)], axis=-1)
    return out


def phi(x):
    return 0.5 * (1.0 + np.vectorize(math.erf)(x / math.sqrt(2.0)))


def line_profile(wl, q):
    """(W, 3): sum over lines of P * Q_c(line) * mean over the pixel of g(line - lambda)."""
    px = np.arange(W, dtype=float)
    lo, hi = C0 + C1 * (px - 0.5), C0 + C1 * (px + 0.5)
    out = np.zeros((W, 3))
    per_line = {}
    for nm, p in HG:
        # mean of exp(-(nm - l)^2 / 2 s^2) over l in [lo, hi]
        mean_g = SIGMA * math.sqrt(2 * math.pi) * (phi((nm - lo) / SIGMA) - phi((nm - hi) / SIGMA)) / (hi - lo)
        prof = p * mean_g[:, None] * sens(wl, q, nm)[None, :]
        per_line[nm] = prof
        out += prof
    return out, per_line


def continuum_profile(wl, q, spectrum=None):
    grid = np.arange(360.0, 830.0001, 0.25)
    qg = sens(wl, q, grid) * (1.0 if spectrum is None else spectrum(grid)[:, None])
    px = np.arange(W, dtype=float)
    lam = C0 + C1 * px
    g = np.exp(-0.5 * ((grid[None, :] - lam[:, None]) / SIGMA) ** 2)
    return np.stack([np.trapezoid(g * qg[None, :, c], grid, axis=1) for c in range(3)], axis=-1)


def cfl_profile(wl, q, name):
    """(W, 3): the CIE FLn table (piecewise linear, 5 nm samples) through passband and camera,
    each 0.1 nm element averaged over the pixel's span (Gaussian CDF)."""
    rows = [l for l in (FL / f"{name}.csv").read_text().splitlines() if l and not l.startswith("#")]
    t = np.array([[float(v) for v in r.split(",")] for r in rows[1:]])
    step = 0.1
    grid = np.arange(t[0, 0], t[-1, 0] + 1e-9, step)
    s = np.interp(grid, t[:, 0], t[:, 1])
    w = s * step
    w[0] *= 0.5
    w[-1] *= 0.5
    qg = sens(wl, q, grid)
    px = np.arange(W, dtype=float)
    edges = C0 + C1 * (np.arange(W + 1, dtype=float) - 0.5)
    cdf = phi((grid[:, None] - edges[None, :]) / SIGMA)  # (G, W+1)
    mean_g = SIGMA * math.sqrt(2 * math.pi) * (cdf[:, :-1] - cdf[:, 1:]) / C1  # (G, W)
    return np.einsum("gw,gc->wc", mean_g, w[:, None] * qg)


def vignetting(amount):
    cx, cy = (W - 1) / 2, (H - 1) / 2
    y, x = np.mgrid[0:H, 0:W]
    r2 = ((x - cx) ** 2 + (y - cy) ** 2) / (cx * cx + cy * cy)
    return 1.0 - amount * r2


def cos4(amount):
    """1/(1 + r^2/f^2)^2 with 1 - amount at r = 1 (the corners)."""
    cx, cy = (W - 1) / 2, (H - 1) / 2
    y, x = np.mgrid[0:H, 0:W]
    r2 = ((x - cx) ** 2 + (y - cy) ** 2) / (cx * cx + cy * cy)
    inv_f2 = (1.0 - amount) ** -0.5 - 1.0
    return 1.0 / (1.0 + r2 * inv_f2) ** 2


def write_png16(path, img):
    """img (H, W, 3) in [0, 1] -> 16-bit RGB PNG."""
    v = np.clip(np.round(img * 65535.0), 0, 65535).astype(">u2")
    raw = b"".join(b"\x00" + v[r].tobytes() for r in range(v.shape[0]))
    def chunk(tag, data):
        c = struct.pack(">I", len(data)) + tag + data
        return c + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF)
    ihdr = struct.pack(">IIBBBBB", v.shape[1], v.shape[0], 16, 2, 0, 0, 0)
    png = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b"")
    path.write_bytes(png)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", default=str(ROOT / "fixtures" / "lvf_reference"))
    a = ap.parse_args()
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    wl, q = camera()
    lines, per_line = line_profile(wl, q)
    cont = continuum_profile(wl, q)
    blob546 = per_line[546.074].max()
    cont *= 0.04 * blob546 / cont.max()
    rng = np.random.Generator(np.random.PCG64(12))
    cases = {
        "lines": (0.0, False, 0.0),
        "vignetting": (0.2, False, 0.0),
        "continuum": (0.0, True, 0.0),
        "both_noise": (0.2, True, 0.01),
    }
    for name, (vig, with_cont, noise) in cases.items():
        prof = lines + (cont if with_cont else 0.0)
        img = prof[None, :, :] * vignetting(vig)[:, :, None]
        img *= 0.8 / img.max()
        if noise > 0:
            img = img + rng.normal(0.0, noise * img.max(), img.shape)
        write_png16(out / f"{name}.png", img)
        truth = {
            "schema": "lumifit.lvf-reference-truth/1",
            "generator": "scripts/reference/lvf_images.py (numpy " + np.__version__ + ")",
            "size": [W, H],
            "map": {"kind": "linear", "coefficients": [C0, C1]},
            "fwhm_nm": FWHM,
            "px_at_400": (400 - C0) / C1,
            "px_at_700": (700 - C0) / C1,
            "camera": "Jiang 2013 Canon 5DMarkII",
            "vignetting_quadratic": vig,
            "continuum_flat_relative_to_546_blob": 0.04 if with_cont else 0.0,
            "noise_relative_to_peak": noise,
            "seed": 12,
        }
        (out / f"{name}.json").write_text(json.dumps(truth, indent=1) + "\n")
        print(name, (out / f"{name}.png").stat().st_size, "bytes")
    cfl = {
        "cfl_fl11": ("FL11", 0.0, 0.0, 0),
        "cfl_fl11_noise": ("FL11", 0.3, 0.01, 13),
        "cfl_fl10": ("FL10", 0.0, 0.0, 0),
        "cfl_fl12": ("FL12", 0.0, 0.0, 0),
    }
    for name, (fl, vig, noise, seed) in cfl.items():
        img = cfl_profile(wl, q, fl)[None, :, :] * vignetting(vig)[:, :, None]
        img *= 0.8 / img.max()
        if noise > 0:
            rng = np.random.Generator(np.random.PCG64(seed))
            img = img + rng.normal(0.0, noise * img.max(), img.shape)
        write_png16(out / f"{name}.png", img)
        truth = {
            "schema": "lumifit.lvf-reference-truth/1",
            "generator": "scripts/reference/lvf_images.py (numpy " + np.__version__ + ")",
            "size": [W, H],
            "map": {"kind": "linear", "coefficients": [C0, C1]},
            "fwhm_nm": FWHM,
            "px_at_400": (400 - C0) / C1,
            "px_at_700": (700 - C0) / C1,
            "camera": "Jiang 2013 Canon 5DMarkII",
            "lamp_spectrum": f"CIE 15:2018 {fl} (calib/illuminants/{fl}.csv, 5 nm, piecewise linear)",
            "vignetting_quadratic": vig,
            "noise_relative_to_peak": noise,
            "seed": seed,
        }
        (out / f"{name}.json").write_text(json.dumps(truth, indent=1) + "\n")
        print(name, (out / f"{name}.png").stat().st_size, "bytes")

    # Nikon D700, 10 % blackbody 2700 K continuum (of the brightest blob), cos^4 0.3, 1 % noise
    wl, q = camera_from_database("Nikon D700")
    lines, _ = line_profile(wl, q)
    cont = continuum_profile(wl, q, lambda nm: planck(nm, 2700.0))
    cont *= 0.10 * lines.max() / cont.max()
    img = (lines + cont)[None, :, :] * cos4(0.3)[:, :, None]
    img *= 0.8 / img.max()
    rng = np.random.Generator(np.random.PCG64(13))
    img = img + rng.normal(0.0, 0.01 * img.max(), img.shape)
    name = "d700_blackbody_cos4"
    write_png16(out / f"{name}.png", img)
    truth = {
        "schema": "lumifit.lvf-reference-truth/1",
        "generator": "scripts/reference/lvf_images.py (numpy " + np.__version__ + ")",
        "size": [W, H],
        "map": {"kind": "linear", "coefficients": [C0, C1]},
        "fwhm_nm": FWHM,
        "px_at_400": (400 - C0) / C1,
        "px_at_700": (700 - C0) / C1,
        "camera": "Jiang 2013 Nikon D700",
        "vignetting_cos4": 0.3,
        "continuum_blackbody_k": 2700.0,
        "continuum_relative_to_brightest_blob": 0.10,
        "noise_relative_to_peak": 0.01,
        "seed": 13,
    }
    (out / f"{name}.json").write_text(json.dumps(truth, indent=1) + "\n")
    print(name, (out / f"{name}.png").stat().st_size, "bytes")


if __name__ == "__main__":
    main()
