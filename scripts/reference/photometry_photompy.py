#!/usr/bin/env python3
"""Compare lumifit's IES/EULUMDAT readers with an independent reader, photompy (PyPI).

Pinned: photompy==0.3.1 (and its numpy/matplotlib). Usage, from the repository root after a
release build:

    python3 -m venv /tmp/pp && /tmp/pp/bin/pip install photompy==0.3.1
    /tmp/pp/bin/python scripts/reference/photometry_photompy.py [../shared/data/photometric]

For every file it prints: the largest difference between the two candela grids at every node of
lumifit's expanded grid (photompy's expanded grid interpolated there by lumifit's own
interpolation of photompy's values is *not* used: the nodes are compared where both have them),
the flux of each reader, and the maximum candela. lumifit's grid is taken from
`lumifit light convert FILE --out X.ies` (LM-63-2019 written with every value in full
precision), read back by a few lines of Python below, so the comparison does not go through
photompy's writer. Flux: lumifit integrates the bilinear interpolant exactly; photompy uses
half-way zonal bands (a midpoint rule), so the two differ by the quadrature error of the
coarser rule on the file's own angle grid.
"""
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import photompy

ROOT = Path(__file__).resolve().parents[2]
LUMIFIT = ROOT / "target" / "release" / "lumifit"


def lumifit_grid(path: Path):
    with tempfile.TemporaryDirectory() as d:
        out = Path(d) / "g.ies"
        subprocess.run([str(LUMIFIT), "light", "convert", str(path), "--out", str(out)], check=True, capture_output=True)
        lines = out.read_text().splitlines()
    i = next(k for k, l in enumerate(lines) if l.startswith("TILT="))
    nums = " ".join(lines[i + 1:]).split()
    nv, nh = int(nums[3]), int(nums[4])
    vals = [float(x) for x in nums[13:]]
    v = np.array(vals[:nv])
    h = np.array(vals[nv:nv + nh])
    cd = np.array(vals[nv + nh:]).reshape(nh, nv)
    return h, v, cd


def photompy_read(path: Path):
    if path.suffix.lower() == ".ies":
        f = photompy.IESFile.read(path, strict=False)
    else:
        f = photompy.LDTFile.read(path, strict=False)
    return f.photometry


def main():
    data = Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT / "../shared/data/photometric"
    files = sorted(p for p in data.glob("*/*") if p.suffix.lower() in (".ies", ".ldt"))
    print("| file | nodes compared | max abs Δcd | max rel Δcd | flux lumifit lm | flux photompy lm | Δflux | max cd lumifit | max cd photompy |")
    print("|---|---|---|---|---|---|---|---|---|")
    for p in files:
        rel = p.relative_to(data)
        insp = json.loads(subprocess.run([str(LUMIFIT), "light", "inspect", str(p), "--json"], check=True, capture_output=True).stdout)
        try:
            ph = photompy_read(p)
            full = ph.expanded()
        except Exception as e:  # an independent reader may refuse a file; say so
            print(f"| {rel} | photompy failed: {type(e).__name__}: {e} | | | {insp['flux_from_grid_lm']:.2f} | | | {insp['max_cd']:.6g} | |")
            continue
        h, v, cd = lumifit_grid(p)
        pt, pp, pv = np.asarray(full.thetas), np.asarray(full.phis), np.asarray(full.values)
        # map lumifit's stored planes onto photompy's expanded ones (phis 0..360)
        worst_abs, worst_rel, n = 0.0, 0.0, 0
        for ih, c in enumerate(h):
            jp = np.where(np.isclose(pp, c % 360.0))[0]
            if len(jp) == 0:
                continue
            for iv, g in enumerate(v):
                jt = np.where(np.isclose(pt, g))[0]
                if len(jt) == 0:
                    continue
                a, b = cd[ih, iv], pv[jp[0], jt[0]]
                worst_abs = max(worst_abs, abs(a - b))
                if max(abs(a), abs(b)) > 0:
                    worst_rel = max(worst_rel, abs(a - b) / max(abs(a), abs(b)))
                n += 1
        flux_pp = full.total_optical_power()
        flux_lf = insp["flux_from_grid_lm"]
        print(f"| {rel} | {n} | {worst_abs:.3g} | {worst_rel:.3g} | {flux_lf:.2f} | {flux_pp:.2f} | {100 * (flux_pp / flux_lf - 1):+.2f} % | {insp['max_cd']:.6g} | {full.max():.6g} |")


if __name__ == "__main__":
    main()
