"""Where the CIE FL tables put lumifit's CFL lines (issue 12): the floor that lumifit's CFL line
list (`Lamp::cfl()`, src/lvf/lamp.rs) has on the independent images of
scripts/reference/lvf_images.py, which render the CIE 15:2018 FL10/FL11/FL12 tables (5 nm,
piecewise linear) through a 25 nm Gaussian passband and the Canon 5D Mark II.

    python3 scripts/reference/cfl_table_floor.py [--write-lamps DIR]

For each listed line: the table's local peak nearest to it (a sample within 5 nm that is higher
than both neighbours, or the higher of two equal-ish neighbours), the window around it out to
the local minima (at most 10 nm either side), a straight baseline between the window's ends
removed, and the first moment of what is left, taken as piecewise linear on a 0.1 nm grid and
weighted by each camera channel (Q_c). A Gaussian passband preserves a feature's first moment,
so this is where the blob sits through the LVF (per channel; the channels are combined by the
square of their share of the blob, the weight of its position in a least-squares fit). Lines
that share a table peak (542.4 + 546.1, 707.0/709.0/712.3, the 577-600 nm group, 625.7/631.1)
have one centroid; the fit's free per-line amplitudes let such a group's centroid sit anywhere
between its lines, so the floor only counts where the centroid lies outside that span.

Then the map error this floor implies: the blob positions (centroid -> px through the true map)
fitted to the listed wavelengths by weighted least squares (weights = blob energy, sum over
channels of the squared peak amplitude), evaluated at the true 400 and 700 nm positions. That
is the error a fit with perfectly drawn continuum and passband would make with this list.

`--write-lamps DIR` writes, per table, a lamp CSV (wavelength_nm,relative_power) with each
listed line moved by its table peak's offset (the table-derived list) for `lumifit lvf
calibrate --lamp`.
"""

import argparse
import math
import os
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
# the shared data beside the checkout, or where LUMIFIT_SHARED_DATA says (a worktree elsewhere)
DATA = Path(os.environ.get("LUMIFIT_SHARED_DATA", ROOT.parent / "shared" / "data"))
CAMERA = DATA / "camera" / "jiang2013_canon_5d_mark_ii_400_720_10.csv"
FL = ROOT / "calib" / "illuminants"
C0, C1 = 372.3, 0.3117
W = 1200
FWHM = 25.0
SIGMA = FWHM / math.sqrt(8 * math.log(2))

# Lamp::cfl() (src/lvf/lamp.rs): mercury at half power plus the phosphor lines.
HG = [(404.656, 0.40), (407.783, 0.04), (435.833, 1.00), (546.074, 0.90), (576.960, 0.20), (579.066, 0.22)]
PHOSPHOR = [
    (487.7, 0.30), (542.4, 1.00), (587.6, 0.10), (593.4, 0.07), (599.7, 0.05), (611.6, 0.90),
    (625.7, 0.06), (631.1, 0.14), (650.8, 0.05), (707.0, 0.04), (709.0, 0.02), (712.3, 0.03),
]
CFL = sorted([(nm, 0.5 * p) for nm, p in HG] + PHOSPHOR)


def camera():
    rows = [l for l in CAMERA.read_text().splitlines() if l and not l.startswith("#")]
    d = np.array([[float(v) for v in r.split(",")] for r in rows[1:]])
    return d[:, 0], d[:, 1:4]


def table(name):
    rows = [l for l in (FL / f"{name}.csv").read_text().splitlines() if l and not l.startswith("#")]
    t = np.array([[float(v) for v in r.split(",")] for r in rows[1:]])
    return t[:, 0], t[:, 1]


def humps(s):
    """The table cut at its local minima: (lo, hi) index pairs, each one feature."""
    cuts = [0] + [k for k in range(1, len(s) - 1) if s[k] <= s[k - 1] and s[k] <= s[k + 1]] + [len(s) - 1]
    return list(zip(cuts[:-1], cuts[1:]))


def centroid(wl, s, lo, hi, cam):
    """Per channel: first moment of (table - straight baseline) x Q_c on [wl[lo], wl[hi]], the
    table piecewise linear, on a 0.1 nm grid; and the channel's blob size."""
    g = np.arange(wl[lo], wl[hi] + 1e-9, 0.1)
    e = np.interp(g, wl, s) - np.interp(g, [wl[lo], wl[hi]], [s[lo], s[hi]])
    e = np.clip(e, 0.0, None)
    cw, q = cam
    out = []
    for c in range(3):
        w = e * np.interp(g, cw, q[:, c], left=0.0, right=0.0)
        out.append((float((w * g).sum() / max(w.sum(), 1e-300)), float(w.sum() * 0.1)))
    return out


def analyse(name, cam, verbose=True):
    """Per table feature holding listed lines: its centroid, the listed lines in it, and how far
    the centroid lies outside their span (the part of the offset no split of amplitude between
    the feature's lines can absorb)."""
    wl, s = table(name)
    feats = []
    for lo, hi in humps(s):
        inside = [(nm, p) for nm, p in CFL if wl[lo] <= nm < wl[hi]]
        if not inside:
            continue
        per_c = centroid(wl, s, lo, hi, cam)
        size = np.array([a for _, a in per_c])
        wts = size**2
        cen = float(sum(c * w for (c, _), w in zip(per_c, wts)) / max(wts.sum(), 1e-300))
        span = (min(nm for nm, _ in inside), max(nm for nm, _ in inside))
        d = cen - min(max(cen, span[0]), span[1])
        feats.append(dict(lo=wl[lo], hi=wl[hi], lines=inside, centroid=cen, span=span, offset=d,
                          per_channel=[c for c, _ in per_c], energy=float(wts.sum())))
    # implied map error: the features whose centroid a split of amplitude cannot reach pin the
    # map (blob px -> nearest listed wavelength), weighted by blob energy; a feature whose
    # centroid lies inside its lines' span pins nothing (its lines' amplitudes are free)
    pins = [f for f in feats if len(f["lines"]) == 1 or f["offset"] != 0.0]
    px = np.array([(f["centroid"] - C0) / C1 for f in pins])
    lam = np.array([f["centroid"] - f["offset"] for f in pins])
    w = np.array([f["energy"] for f in pins])
    a = np.stack([np.ones_like(px), px], axis=1)
    coef = np.linalg.lstsq(a * np.sqrt(w)[:, None], lam * np.sqrt(w), rcond=None)[0]
    err = [coef[0] + coef[1] * (t - C0) / C1 - t for t in (400.0, 700.0)]
    if verbose:
        wmax = max(f["energy"] for f in feats)
        print(f"== {name} (Canon 5D Mark II)")
        print("  table feature  listed line(s) nm                      centroid  R/G/B centroids          "
              "centroid - listed          outside span  energy")
        for f in feats:
            lines = " + ".join(f"{l:g}" for l, _ in f["lines"])
            offs = ", ".join(f"{f['centroid'] - l:+.2f}" for l, _ in f["lines"])
            pc = "/".join(f"{c:.2f}" for c in f["per_channel"])
            print(f"  {f['lo']:5.0f}-{f['hi']:<5.0f}    {lines:38s} {f['centroid']:8.2f}  {pc:24s} "
                  f"{offs:26s} {f['offset']:+6.2f}       {f['energy'] / wmax:.3f}")
        print(f"  implied map error (weighted LS of the pinning features on the listed lines): "
              f"400 nm {err[0]:+.3f}, 700 nm {err[1]:+.3f} nm")
    return feats, err


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--write-lamps", default=None)
    a = ap.parse_args()
    cam = camera()
    for name in ["FL10", "FL11", "FL12"]:
        feats, _ = analyse(name, cam)
        if a.write_lamps:
            out = Path(a.write_lamps)
            out.mkdir(parents=True, exist_ok=True)
            # each listed line moved by its feature's offset outside the span of its lines
            lines = [(nm + f["offset"], p) for f in feats for nm, p in f["lines"]]
            lines += [(nm, p) for nm, p in CFL if not any((nm, p) in f["lines"] for f in feats)]
            text = "wavelength_nm,relative_power\n" + "".join(f"{nm:.3f},{p}\n" for nm, p in sorted(lines))
            (out / f"cfl_{name.lower()}_table.csv").write_text(text)


if __name__ == "__main__":
    main()
