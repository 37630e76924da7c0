#!/usr/bin/env python3
"""Side by side, in one run: dispersion speed, lumifit (criterion, benches/dispersion.rs) versus numpy.

    python3 scripts/bench/dispersion_speed.py      (crate root; runs `cargo bench --bench dispersion`)

Both sides do the same work:
  1. n(λ) of N-BK7 (refractiveindex.info formula 2, three Sellmeier terms) at 10^6 wavelengths
     380–780 nm (numpy: one vectorised expression);
  2. the prism reference render of `lumifit dispersion prism` with its defaults (apex 60°,
     minimum deviation at d, screen 1 m, beam 2 mm, pixels 0.05 mm, illuminant E, CIE 1931 2°,
     sRGB): 401 spectral slices and 7 samples splatted as boxes onto the strip (numpy: an overlap
     matrix), Lab and CIEDE2000 per pixel (numpy: vectorised).
Slices and samples are built once outside the timed part on both sides.
Prints a Markdown table for docs/performance.md.
"""
import os
import re
import subprocess
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, os.path.join(ROOT, "scripts", "reference"))
import dispersion_reference as ref  # noqa: E402

BK7 = [0, 1.03961212, 0.00600069867, 0.231792344, 0.0200179144, 1.01046945, 103.560653]


def n_bk7(lam_nm):
    l2 = (lam_nm * 1e-3) ** 2
    return np.sqrt(1 + BK7[1] * l2 / (l2 - BK7[2]) + BK7[3] * l2 / (l2 - BK7[4]) + BK7[5] * l2 / (l2 - BK7[6]))


def lab(xyz, white):
    t = xyz / white
    e = 216 / 24389
    k = 24389 / 27
    f = np.where(t > e, np.cbrt(t), (k * t + 16) / 116)
    return np.stack([116 * f[:, 1] - 16, 500 * (f[:, 0] - f[:, 1]), 200 * (f[:, 1] - f[:, 2])], axis=1)


def ciede2000(a, b):
    L1, a1, b1 = a.T
    L2, a2, b2 = b.T
    C1, C2 = np.hypot(a1, b1), np.hypot(a2, b2)
    Cb = (C1 + C2) / 2
    G = 0.5 * (1 - np.sqrt(Cb ** 7 / (Cb ** 7 + 25 ** 7)))
    a1p, a2p = (1 + G) * a1, (1 + G) * a2
    C1p, C2p = np.hypot(a1p, b1), np.hypot(a2p, b2)
    h1 = np.degrees(np.arctan2(b1, a1p)) % 360
    h2 = np.degrees(np.arctan2(b2, a2p)) % 360
    dL, dC = L2 - L1, C2p - C1p
    dh = h2 - h1
    dh = np.where(dh > 180, dh - 360, np.where(dh < -180, dh + 360, dh))
    dh = np.where(C1p * C2p == 0, 0, dh)
    dH = 2 * np.sqrt(C1p * C2p) * np.sin(np.radians(dh / 2))
    Lb, Cbp = (L1 + L2) / 2, (C1p + C2p) / 2
    hs = h1 + h2
    hb = np.where(np.abs(h1 - h2) > 180, np.where(hs < 360, hs + 360, hs - 360) / 2, hs / 2)
    hb = np.where(C1p * C2p == 0, hs, hb)
    T = 1 - 0.17 * np.cos(np.radians(hb - 30)) + 0.24 * np.cos(np.radians(2 * hb)) \
        + 0.32 * np.cos(np.radians(3 * hb + 6)) - 0.20 * np.cos(np.radians(4 * hb - 63))
    SL = 1 + 0.015 * (Lb - 50) ** 2 / np.sqrt(20 + (Lb - 50) ** 2)
    SC, SH = 1 + 0.045 * Cbp, 1 + 0.015 * Cbp * T
    RT = -2 * np.sqrt(Cbp ** 7 / (Cbp ** 7 + 25 ** 7)) * np.sin(np.radians(60 * np.exp(-((hb - 275) / 25) ** 2)))
    return np.sqrt((dL / SL) ** 2 + (dC / SC) ** 2 + (dH / SH) ** 2 + RT * (dC / SC) * (dH / SH))


def setup():
    cmf = np.loadtxt(os.path.join(ROOT, "calib", "cmfs", "cie1931_2.csv"), delimiter=",", skiprows=1)
    keep = (cmf[:, 0] >= 380) & (cmf[:, 0] <= 780)
    lam, xyz = cmf[keep, 0], cmf[keep, 1:4].copy()
    w = np.ones_like(lam)
    w[0] = w[-1] = 0.5
    xyz *= w[:, None]
    total = xyz.sum(axis=0)
    xyz /= total[1]
    m_rgb, wxy = ref.spaces()["srgb"]
    dst = np.array([wxy[0] / wxy[1], 1.0, (1 - wxy[0] - wxy[1]) / wxy[1]])
    D = np.diag((ref.BRADFORD @ dst) / (ref.BRADFORD @ (total / total[1])))
    xyz = (np.linalg.inv(ref.BRADFORD) @ D @ ref.BRADFORD @ xyz.T).T
    s = ref.samples(7, "srgb")
    rgb_to_xyz = np.linalg.inv(m_rgb)
    samp_xyz = (rgb_to_xyz @ np.array(s["rgb"]).T).T
    return lam, xyz, np.array(s["lambda_nm"]), samp_xyz, dst


def render(lam, xyz, s_lam, s_xyz, white):
    A = np.radians(60.0)
    nd = n_bk7(np.array([587.5618]))[0]
    t1 = np.arcsin(nd * np.sin(A / 2))
    dev = lambda n: t1 + np.arcsin(n * np.sin(A - np.arcsin(np.sin(t1) / n))) - A
    dd = dev(nd)
    x = 1000.0 * np.tan(dev(n_bk7(lam)) - dd)
    xs = 1000.0 * np.tan(dev(n_bk7(s_lam)) - dd)
    w, p = 2.0, 0.05
    x0 = x.min() - (w / 2 + p)
    npx = int(np.ceil((x.max() + w / 2 + p - x0) / p))
    p0 = x0 + p * np.arange(npx)

    def splat(pos, col):
        a, b = pos[:, None] - w / 2, pos[:, None] + w / 2
        ov = np.clip(np.minimum(b, p0 + p) - np.maximum(a, p0), 0, None) / p
        return ov.T @ col

    spec, samp = splat(x, xyz), splat(xs, s_xyz)
    lit = np.maximum(spec[:, 1], samp[:, 1]) > 1e-3
    de = ciede2000(lab(spec[lit], white), lab(samp[lit], white))
    return de.mean(), de.max()


def best_of(f, repeat):
    best = float("inf")
    for _ in range(repeat):
        t = time.perf_counter()
        f()
        best = min(best, time.perf_counter() - t)
    return best


def main():
    lam_big = np.linspace(380.0, 780.0, 1_000_000)
    t_n = best_of(lambda: n_bk7(lam_big).sum(), 20)
    args = setup()
    mean, mx = render(*args)
    t_r = best_of(lambda: render(*args), 50)
    print(f"numpy {np.__version__}: n(λ) 1e6 {t_n * 1e3:.2f} ms; prism render {t_r * 1e3:.2f} ms "
          f"(mean ΔE00 {mean:.2f}, max {mx:.2f})", file=sys.stderr)
    o = subprocess.run(["cargo", "bench", "--bench", "dispersion", "--", "--warm-up-time", "1",
                        "--measurement-time", "3"], cwd=ROOT, capture_output=True, text=True)
    if o.returncode != 0:
        sys.exit(o.stderr)
    times = re.findall(r"time:\s+\[\S+ \S+ (\S+) (\S+) \S+ \S+\]", o.stdout)
    unit = {"ns": 1e-9, "µs": 1e-6, "us": 1e-6, "ms": 1e-3, "s": 1.0}
    rust = [float(v) * unit[u] for v, u in times]
    print("| work | lumifit (criterion median) | numpy (best of runs) | numpy / lumifit |")
    print("|---|---|---|---|")
    for name, r, p in [("n(λ) N-BK7, 10⁶ wavelengths", rust[0], t_n),
                       ("prism render N-BK7 (401 slices + 7 samples, ΔE00)", rust[1], t_r)]:
        print(f"| {name} | {r * 1e3:.3f} ms | {p * 1e3:.3f} ms | {p / r:.1f}× |")


if __name__ == "__main__":
    main()
