#!/usr/bin/env python3
"""Afterimage synthesis (Mikamo et al. 2013) in numpy, side by side with `lumifit afterimage synth`.

The same equations as src/afterimage/mikamo2013.rs (docs/afterimage.md): input normalised to its
brightest pixel, mask max(R,G,B) >= threshold x the image's largest channel, Lab with white D65 (Yn = 1), Eq. 1-2 and 4-6, gamut
correction (clamp negatives, restore Y), separable Gaussian blur (radius ceil(3 sigma), edges
clamped), 16-bit sRGB codes floor(65535 V + 1/2). The Rust code stores per-pixel planes and frames
as float32; this script does the same at the same points, so the frames agree to within one
16-bit code.

Run (from the repository root, after `cargo build --release`):

    python3 scripts/bench/afterimage_numpy.py [--lumifit target/release/lumifit] [--work DIR]

It writes a 1920x1080 16-bit sRGB PNG stimulus (five coloured "bulbs" on a dim gradient), runs
lumifit once and numpy once on the same frames (--times 0:80:8, sigma 8 px), compares every
16-bit code of every frame and prints frames per second of both and their ratio. Only numpy
(requirements.txt) and the standard library are needed.
"""

import argparse
import json
import os
import struct
import subprocess
import sys
import tempfile
import time
import zlib

import numpy as np

W, H = 1920, 1080
TIMES = [float(t) for t in range(0, 81, 8)]
GAMMA, K, THRESHOLD, SIGMA = 0.7, 0.05, 0.5, 8.0
REF_XY = (0.41, 0.42)
D65 = (0.3127, 0.329)
T1_XY = np.array([
    [0.41, 0.42], [0.37, 0.48], [0.32, 0.54], [0.31, 0.55], [0.36, 0.47], [0.34, 0.38],
    [0.39, 0.33], [0.47, 0.27], [0.48, 0.25], [0.44, 0.24], [0.35, 0.15], [0.26, 0.06],
    [0.24, 0.06], [0.23, 0.07], [0.23, 0.08], [0.23, 0.10], [0.21, 0.10], [0.20, 0.09],
    [0.18, 0.08], [0.16, 0.07], [0.15, 0.06]])


# --- colour maths (colour-science conventions, as lumifit::colorimetry) -----------------------

def npm():
    """Normalised primary matrix of the sRGB primaries and D65, and its inverse."""
    prim = [(0.64, 0.33), (0.30, 0.60), (0.15, 0.06)]
    p = np.array([[x for x, _ in prim], [y for _, y in prim], [1 - x - y for x, y in prim]])
    w = np.array([D65[0] / D65[1], 1.0, (1 - D65[0] - D65[1]) / D65[1]])
    m = p * np.linalg.solve(p, w)
    return m, np.linalg.inv(m)


def eotf_srgb(v):
    return np.where(v <= 0.04045, v / 12.92, np.power((v + 0.055) / 1.055, 2.4))


def eotf_inverse_srgb(l):
    return np.where(l <= 0.0031308, l * 12.92, 1.055 * np.power(np.maximum(l, 0), 1 / 2.4) - 0.055)


EPS = (24 / 116) ** 3


def f_lab(r):
    return np.where(r > EPS, np.power(np.maximum(r, 0), 1.0 / 3.0), (841 / 108) * r + 16 / 116)


def f_inv(f):
    return np.where(f > 24 / 116, np.power(f, 3.0), (f - 16 / 116) * (108 / 841))


WHITE = np.array([D65[0] / D65[1], 1.0, (1 - D65[0] - D65[1]) / D65[1]])


def xyz_to_lab(x, y, z):
    fx, fy, fz = f_lab(x / WHITE[0]), f_lab(y / WHITE[1]), f_lab(z / WHITE[2])
    return 116 * fy - 16, 500 * (fx - fy), 200 * (fy - fz)


def lab_to_xyz(l, a, b):
    fy = (l + 16) / 116
    fx = a / 500 + fy
    fz = fy - b / 200
    return f_inv(fx) * WHITE[0], f_inv(fy) * WHITE[1], f_inv(fz) * WHITE[2]


# --- curves -----------------------------------------------------------------------------------

def y_m(t):
    return np.exp(-0.083 * t - 0.978) if t <= 22 else np.exp(-0.055 * t - 1.584)


def xy_m(t):
    n = len(T1_XY)
    if t <= 0:
        return T1_XY[0]
    if t >= 80:
        return T1_XY[-1]
    s = t / 4.0
    i = min(int(np.floor(s)), n - 2)
    u = s - i

    def p(k):
        if k < 0:
            return 2 * T1_XY[0] - T1_XY[1]
        if k >= n:
            return 2 * T1_XY[-1] - T1_XY[-2]
        return T1_XY[k]
    p0, p1, p2, p3 = p(i - 1), p(i), p(i + 1), p(i + 2)
    return 0.5 * (2 * p1 + (-p0 + p2) * u + (2 * p0 - 5 * p1 + 4 * p2 - p3) * u * u
                  + (-p0 + 3 * p1 - 3 * p2 + p3) * u * u * u)


def lab_m(t):
    x, y = xy_m(t)
    yy = y_m(t)
    return [float(v) for v in xyz_to_lab(np.float64(x * yy / y), np.float64(yy),
                                         np.float64((1 - x - y) * yy / y))]


# --- synthesis --------------------------------------------------------------------------------

def prepare(rgb32):
    to_xyz, to_rgb = npm()
    rgb = np.maximum(rgb32.astype(np.float64), 0)
    ylum = rgb @ to_xyz[1]
    ymax = ylum.max()
    xyz = (rgb / ymax) @ to_xyz.T
    y = xyz[..., 1]
    cmax = rgb.max(axis=-1)
    mask = (y > 0) & (cmax >= THRESHOLD * cmax.max())
    l_on, a_on, b_on = xyz_to_lab(xyz[..., 0], y, xyz[..., 2])
    xr, yr = REF_XY
    _, a_r, b_r = xyz_to_lab(xr * y / yr, y, (1 - xr - yr) * y / yr)
    z = np.where(mask, np.power(np.maximum(l_on / 100, 0), GAMMA), 0).astype(np.float32)
    da = np.where(mask, a_on - a_r, 0).astype(np.float32)
    db = np.where(mask, b_on - b_r, 0).astype(np.float32)
    return mask, z, da, db, to_xyz, to_rgb


def kernel(sigma):
    r = int(np.ceil(3 * sigma))
    w = np.exp(-np.arange(-r, r + 1, dtype=np.float64) ** 2 / (2 * sigma * sigma))
    return (w / w.sum()).astype(np.float32)


def blur(img, k):
    r = len(k) // 2
    h, w, _ = img.shape
    pad = np.pad(img, ((0, 0), (r, r), (0, 0)), mode="edge")
    tmp = np.zeros_like(img)
    for i, wk in enumerate(k):
        tmp += wk * pad[:, i:i + w, :]
    pad = np.pad(tmp, ((r, r), (0, 0), (0, 0)), mode="edge")
    out = np.zeros_like(img)
    for i, wk in enumerate(k):
        out += wk * pad[i:i + h, :, :]
    return out


def frame(t, prep, k):
    mask, z, da, db, to_xyz, to_rgb = prep
    lm, am, bm = lab_m(t)
    tau = lm / lab_m(0.0)[0]
    z64 = z.astype(np.float64)
    l = lm * z64
    a = am * z64 + tau * K * da.astype(np.float64)
    b = bm * z64 + tau * K * db.astype(np.float64)
    x, y, zz = lab_to_xyz(l, a, b)
    xyz = np.stack([x, y, zz], axis=-1)
    rgb = xyz @ to_rgb.T
    neg = (rgb < 0).any(axis=-1)
    cl = np.maximum(rgb, 0)
    yc = cl @ to_xyz[1]
    target = np.maximum(y, 0)
    scale = np.where(yc > 0, target / np.where(yc > 0, yc, 1), 0)
    rgb = np.where(neg[..., None], cl * scale[..., None], rgb)
    rgb = np.where(mask[..., None], rgb, 0).astype(np.float32)
    if len(k) > 1:
        rgb = blur(rgb, k)
    return rgb


def codes(rgb):
    e = np.clip(eotf_inverse_srgb(np.clip(rgb.astype(np.float64), 0, 1)), 0, 1)
    return np.floor(e * 65535 + 0.5).astype(np.uint16)


# --- PNG in and out (standard library only) ---------------------------------------------------

def chunk(tag, data):
    c = struct.pack(">I", len(data)) + tag + data
    return c + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF)


def write_png16(path, codes16):
    h, w, _ = codes16.shape
    raw = np.zeros((h, 1 + 6 * w), dtype=np.uint8)
    raw[:, 1:] = codes16.astype(">u2").view(np.uint8).reshape(h, 6 * w)
    ihdr = struct.pack(">IIBBBBB", w, h, 16, 2, 0, 0, 0)
    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr)
                + chunk(b"IDAT", zlib.compress(raw.tobytes(), 6)) + chunk(b"IEND", b""))


def read_png16_up(path):
    """Decodes lumifit's 16-bit RGB PNG frames (every row uses the Up filter)."""
    data = open(path, "rb").read()
    pos, idat, w, h = 8, b"", 0, 0
    while pos < len(data):
        n = struct.unpack(">I", data[pos:pos + 4])[0]
        tag = data[pos + 4:pos + 8]
        body = data[pos + 8:pos + 8 + n]
        if tag == b"IHDR":
            w, h, depth, ctype = struct.unpack(">IIBB", body[:10])
            assert depth == 16 and ctype == 2, "expected 16-bit RGB"
        elif tag == b"IDAT":
            idat += body
        pos += 12 + n
    raw = np.frombuffer(zlib.decompress(idat), dtype=np.uint8).reshape(h, 1 + 6 * w)
    filters = set(raw[:, 0].tolist())
    if not filters <= {0, 2}:
        sys.exit(f"{path}: row filters {filters}; this decoder handles None and Up only")
    rows = raw[:, 1:].astype(np.uint64)
    up = raw[:, 0] == 2
    out = np.zeros_like(rows)
    prev = np.zeros(rows.shape[1], dtype=np.uint64)
    for r in range(h):
        out[r] = (rows[r] + prev) % 256 if up[r] else rows[r]
        prev = out[r]
    return out.astype(np.uint8).view(">u2").reshape(h, w, 3).astype(np.uint16)


def stimulus():
    """Five bulbs of different colour and brightness on a dim gradient, sRGB 16-bit codes."""
    _, to_rgb = npm()
    yy, xx = np.mgrid[0:H, 0:W]
    img = np.zeros((H, W, 3))
    img[...] = (0.01 + 0.03 * xx / W)[..., None] * np.array([1.0, 0.9, 0.8])
    bulbs = [((0.41, 0.42), 1.0, 300, 540, 130), ((0.60, 0.34), 0.9, 700, 400, 110),
             ((0.30, 0.55), 0.8, 1050, 640, 120), ((0.20, 0.18), 0.7, 1400, 420, 100),
             ((0.45, 0.41), 0.6, 1700, 760, 90)]
    for (x, y), lum, cx, cy, r in bulbs:
        xyz = np.array([x * lum / y, lum, (1 - x - y) * lum / y])
        rgb = np.clip(to_rgb @ xyz, 0, None)
        rgb = rgb * (lum / max((npm()[0] @ rgb)[1], 1e-12))
        d = np.hypot(xx - cx, yy - cy)
        glow = np.clip(1.2 - d / r, 0, 1)
        img += glow[..., None] * rgb
    peak = (img @ npm()[0][1]).max()
    img = img / peak
    return codes(np.clip(img, 0, 1))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--lumifit", default="target/release/lumifit")
    ap.add_argument("--work", default=None, help="working directory (default: a temporary one)")
    args = ap.parse_args()
    work = args.work or tempfile.mkdtemp(prefix="afterimage-bench-")
    os.makedirs(work, exist_ok=True)
    src = os.path.join(work, "stimulus.png")
    write_png16(src, stimulus())
    out = os.path.join(work, "lumifit")
    cmd = [args.lumifit, "afterimage", "synth", src, "--times", "0:80:8", "--gamma", str(GAMMA),
           "--k", str(K), "--mask-threshold", str(THRESHOLD), "--blur-sigma-px", str(SIGMA),
           "--out", out]
    t0 = time.perf_counter()
    res = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if res.returncode != 0:
        sys.exit(f"lumifit failed ({res.returncode}): {res.stderr}")
    summary = json.loads(res.stdout)

    # numpy: decode the same 16-bit PNG the same way (sRGB EOTF, float32), then the frames.
    codes_in = read_png16_up(src)
    rgb_in = eotf_srgb(codes_in.astype(np.float64) / 65535).astype(np.float32)
    t1 = time.perf_counter()
    prep = prepare(rgb_in)
    k = kernel(SIGMA)
    np_prep_s = time.perf_counter() - t1
    t2 = time.perf_counter()
    linear = [frame(t, prep, k) for t in TIMES]
    np_s = time.perf_counter() - t2
    frames = [codes(f) for f in linear]

    worst, differing, total = 0, 0, 0
    for t, f in zip(TIMES, frames):
        ours = read_png16_up(os.path.join(out, f"frame_t{t:07.3f}.png"))
        d = np.abs(ours.astype(np.int32) - f.astype(np.int32))
        worst = max(worst, int(d.max()))
        differing += int((d > 0).sum())
        total += d.size
    n = len(TIMES)
    lf_fps = n / summary["compute_s"]
    np_fps = n / np_s
    print(json.dumps({
        "size_px": [W, H], "frames": n, "blur_sigma_px": SIGMA,
        "lumifit_compute_s": summary["compute_s"],
        "lumifit_prepare_s": summary["read_and_prepare_s"],
        "lumifit_encode_s": summary["encode_s"], "lumifit_wall_s": wall,
        "numpy_prepare_s": np_prep_s, "numpy_compute_s": np_s,
        "lumifit_frames_per_s": lf_fps, "numpy_frames_per_s": np_fps,
        "speed_ratio": lf_fps / np_fps,
        "max_code_difference": worst, "codes_differing": differing, "codes_compared": total,
        "numpy": np.__version__, "work": work,
    }, indent=2))
    if worst > 1:
        sys.exit(f"frames differ by {worst} codes (> 1/65535)")


if __name__ == "__main__":
    main()
