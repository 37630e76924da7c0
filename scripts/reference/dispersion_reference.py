#!/usr/bin/env python3
"""Independent numpy evaluation of lumifit's dispersion pipeline.

Writes fixtures/dispersion/reference.json with
  formulas   n(λ) of every formula entry of ../shared/data/ior (read with PyYAML), at 1 nm over
             380–780 nm clipped to the entry's range plus the F, d, C, e lines; n_d, V_d
  synthetic  n(λ) of made-up coefficient sets for formula types 3–9 (the data folder only has
             types 1 and 2), so every formula of refractiveindex.info is compared
  cauchy     numpy lstsq Cauchy 2- and 3-term fits of every formula entry over 380–780 nm
             (clipped to the entry's range) at 1 nm, with RMS and max |Δn|
  samples    N = 3, 7, 21 wavelength samples over 380–780 nm for illuminant E, CIE 1931 2°
             (calib/cmfs/cie1931_2.csv), sRGB (IEC 61966-2-1 matrix) and ACEScg (AP1): slice XYZ
             with end slices halved, Bradford to the space white, per-channel renormalisation,
             gamut mapping by adding the least neutral per band, then one common scale

Written from docs/dispersion.md and the formulas' definitions, not from the Rust code.
Usage (from the crate root): python scripts/reference/dispersion_reference.py
Pinned versions: scripts/reference/requirements.txt (numpy; PyYAML).
"""
import glob
import json
import os
import time

import numpy as np
import yaml

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
DATA = os.path.join(ROOT, "..", "shared", "data", "ior")
LINES = {"F": 486.1327, "d": 587.5618, "C": 656.2725, "e": 546.0740}


def n_formula(kind, c, lam_um):
    c = list(c) + [0.0] * (17 - len(c))
    l = np.asarray(lam_um, dtype=float)
    l2 = l * l
    if kind in (1, 2):
        s = 1.0 + c[0]
        for i in range(1, 17, 2):
            pole = c[i + 1] ** 2 if kind == 1 else c[i + 1]
            if c[i] != 0.0:
                s = s + c[i] * l2 / (l2 - pole)
        return np.sqrt(s)
    if kind == 3:
        s = c[0] + sum(c[i] * l ** c[i + 1] for i in range(1, 17, 2) if c[i] != 0.0)
        return np.sqrt(s)
    if kind == 4:
        s = c[0] + c[1] * l ** c[2] / (l2 - c[3] ** c[4]) + c[5] * l ** c[6] / (l2 - c[7] ** c[8])
        s = s + sum(c[i] * l ** c[i + 1] for i in range(9, 17, 2) if c[i] != 0.0)
        return np.sqrt(s)
    if kind == 5:
        return c[0] + sum(c[i] * l ** c[i + 1] for i in range(1, 17, 2) if c[i] != 0.0)
    if kind == 6:
        return 1.0 + c[0] + sum(c[i] / (c[i + 1] - l ** -2) for i in range(1, 17, 2) if c[i] != 0.0)
    if kind == 7:
        q = 1.0 / (l2 - 0.028)
        return c[0] + c[1] * q + c[2] * q ** 2 + c[3] * l2 + c[4] * l2 ** 2 + c[5] * l2 ** 3
    if kind == 8:
        r = c[0] + c[1] * l2 / (l2 - c[2]) + c[3] * l2
        return np.sqrt((1 + 2 * r) / (1 - r))
    if kind == 9:
        d = l - c[4]
        return np.sqrt(c[0] + c[1] / (l2 - c[2]) + c[3] * d / (d * d + c[5]))
    raise ValueError(kind)


def abbe(f):
    nd, nF, nC = f(LINES["d"]), f(LINES["F"]), f(LINES["C"])
    return float(nd), float((nd - 1) / (nF - nC))


SYNTHETIC = [
    (3, [2.28, -0.01, 2, 0.012, -2, 0.0001, -4], [0.3, 2.0]),
    (4, [2.0, 0.5, 2, 0.1, 2, 0.3, 2, 10, 2, 0.001, -2, 0.0002, -4], [0.3, 2.0]),
    (5, [1.5, 0.004, -2, 0.0001, -4], [0.3, 2.0]),
    (6, [0, 0.05792105, 238.0185, 0.00167917, 57.362], [0.23, 1.69]),
    (7, [1.5, 0.005, 0.0001, -0.002, 1e-5, -1e-7], [0.3, 2.0]),
    (8, [0.25, 0.02, 0.01, -0.001], [0.3, 2.0]),
    (9, [2.2, 0.02, 0.015, 0.001, 2.0, 0.1], [0.3, 2.0]),
]


def grid_for(range_um):
    lo = max(380.0, range_um[0] * 1e3)
    hi = min(780.0, range_um[1] * 1e3)
    g = np.arange(np.ceil(lo), np.floor(hi) + 0.5, 1.0)
    return np.concatenate([g, list(LINES.values())])


def cauchy_fit(lam_nm, n, k):
    l = lam_nm * 1e-3
    A = np.stack([l ** (-2 * i) for i in range(k)], axis=1)
    c, *_ = np.linalg.lstsq(A, n, rcond=None)
    r = A @ c - n
    return c.tolist(), float(np.sqrt(np.mean(r * r))), float(np.max(np.abs(r)))


# ---- samples -------------------------------------------------------------------------------
SRGB_XYZ_TO_RGB = np.array([[3.2406, -1.5372, -0.4986], [-0.9689, 1.8758, 0.0415], [0.0557, -0.2040, 1.0570]])
BRADFORD = np.array([[0.8951, 0.2664, -0.1614], [-0.7502, 1.7135, 0.0367], [0.0389, -0.0685, 1.0296]])


def npm(primaries, white):
    xyz = lambda xy: np.array([xy[0] / xy[1], 1.0, (1 - xy[0] - xy[1]) / xy[1]])
    P = np.stack([xyz(p) for p in primaries], axis=1)
    S = np.linalg.solve(P, xyz(white))
    return P * S


def spaces():
    with open(os.path.join(ROOT, "calib", "colourspaces.json")) as f:
        cs = json.load(f)["rgb_colourspaces"]
    a = cs["acescg"]
    return {
        "srgb": (SRGB_XYZ_TO_RGB, [0.3127, 0.3290]),
        "acescg": (np.linalg.inv(np.array(a["matrix_rgb_to_xyz"])), a["whitepoint_xy"]),
    }


def samples(n_samples, space, lo=380.0, hi=780.0):
    cmf = np.loadtxt(os.path.join(ROOT, "calib", "cmfs", "cie1931_2.csv"), delimiter=",", skiprows=1)
    keep = (cmf[:, 0] >= lo) & (cmf[:, 0] <= hi)
    lam, xyz = cmf[keep, 0], cmf[keep, 1:4].copy()
    wgt = np.ones_like(lam)
    wgt[0] = wgt[-1] = 0.5
    xyz *= wgt[:, None]  # illuminant E
    total = xyz.sum(axis=0)
    xyz /= total[1]
    white_src = total / total[1]
    m_rgb, white_xy = spaces()[space]
    white_dst = np.array([white_xy[0] / white_xy[1], 1.0, (1 - white_xy[0] - white_xy[1]) / white_xy[1]])
    D = np.diag((BRADFORD @ white_dst) / (BRADFORD @ white_src))
    cat = np.linalg.inv(BRADFORD) @ D @ BRADFORD
    rgb = (m_rgb @ cat @ xyz.T).T
    rgb /= rgb.sum(axis=0)
    step = (hi - lo) / n_samples
    target = np.zeros((n_samples, 3))
    for k, l in enumerate(lam):
        a, b = max(l - 0.5, lo), min(l + 0.5, hi)
        for i in range(n_samples):
            e0, e1 = lo + i * step, lo + (i + 1) * step
            ov = max(0.0, min(b, e1) - max(a, e0)) / (b - a)
            target[i] += rgb[k] * ov
    added = np.maximum(0.0, -target.min(axis=1))
    w = (target + added[:, None]) / (1.0 + added.sum())
    w /= w.sum(axis=0)
    return {
        "lambda_nm": (lo + step * (np.arange(n_samples) + 0.5)).tolist(),
        "rgb": w.tolist(),
        "target_rgb": target.tolist(),
    }


def main():
    out = {"generator": "scripts/reference/dispersion_reference.py", "numpy": np.__version__,
           "formulas": [], "synthetic": [], "cauchy": [], "samples": []}
    for path in sorted(glob.glob(os.path.join(DATA, "*.yml"))):
        with open(path, encoding="utf-8") as f:
            doc = yaml.safe_load(f)
        item = next((d for d in doc["DATA"] if d["type"].startswith("formula")), None)
        if item is None:
            continue
        kind = int(item["type"].split()[1])
        c = [float(x) for x in str(item["coefficients"]).split()]
        rng = [float(x) for x in str(item.get("wavelength_range", item.get("range"))).split()]
        g = grid_for(rng)
        f = lambda lam_nm: n_formula(kind, c, np.asarray(lam_nm) * 1e-3)
        n = f(g)
        nd, vd = abbe(f)
        name = os.path.basename(path)
        out["formulas"].append({"file": name, "type": kind, "lambda_nm": g.tolist(), "n": n.tolist(),
                                "n_d": nd, "v_d": vd})
        fit_grid = g[: -len(LINES)]
        for k in (2, 3):
            coef, rms, mx = cauchy_fit(fit_grid, f(fit_grid), k)
            out["cauchy"].append({"file": name, "terms": k, "range_nm": [fit_grid[0], fit_grid[-1]],
                                  "coefficients": coef, "rms": rms, "max_abs": mx})
    for kind, c, rng in SYNTHETIC:
        g = grid_for(rng)
        out["synthetic"].append({"type": kind, "coefficients": c, "range_um": rng, "lambda_nm": g.tolist(),
                                 "n": n_formula(kind, c, g * 1e-3).tolist()})
    for space in ("srgb", "acescg"):
        for ns in (3, 7, 21):
            s = samples(ns, space)
            s.update({"n_samples": ns, "space": space})
            out["samples"].append(s)
    dst = os.path.join(ROOT, "fixtures", "dispersion", "reference.json")
    os.makedirs(os.path.dirname(dst), exist_ok=True)
    with open(dst, "w") as f:
        json.dump(out, f, indent=1)
    print(f"wrote {dst}: {len(out['formulas'])} formula entries, {len(out['synthetic'])} synthetic, "
          f"{len(out['samples'])} sample sets")


if __name__ == "__main__":
    main()
