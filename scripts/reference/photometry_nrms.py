#!/usr/bin/env python3
"""NRMS of every shading method against a converged reference, in the shape of Luksch et al.
2020 Fig. 10 (a 1 x 1 light at heights 0.1, 1.0, 2.5 above a ground plane, orientations between
n_A and n_g of pi/2, 3pi/4 and pi, errors over the stitched orientations), with the Monte Carlo
sample count that matches the paper's cubature and the time ratio at that count.

Only numpy and the lumifit release binary are needed:

    python3 scripts/reference/photometry_nrms.py [N_SIDE]

Reference: `cubature-adaptive --tolerance 0.001`. Its own error is <= 0.08 % on the Lambertian
closed form (tests/photometry_shading.rs) and <= 0.7 % against MC at 2e5 samples at tolerance
0.01 on the real profile, below 1/10 of the smallest NRMS it judges here (the paper's
cubature, >= 1 %); for MC it is judged against the same reference, whose error is then part of
MC's NRMS floor at large N. NRMS = RMS(E - E_ref) / RMS(E_ref) over all points of all three
orientations. Heights are those of the rectangle's lowest point above the ground.
Profiles: the real Prolicht E30 file and a Lambertian I = 1000 cos(gamma) written here.
"""
import json
import math
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
LUMIFIT = ROOT / "target" / "release" / "lumifit"
DATA = ROOT / "../shared/data/photometric/lidrs_MIT/example.ldt"
N = int(sys.argv[1]) if len(sys.argv) > 1 else 100
MC_N = [4, 8, 16, 32, 64, 128, 256, 512]


def lambert_ies(d: Path) -> Path:
    v = [k * 0.5 for k in range(181)]
    cd = [1000 * math.cos(math.radians(g)) for g in v]
    p = d / "lambert.ies"
    p.write_text("IES:LM-63-2019\n[TEST] lambert\nTILT=NONE\n1 -1 1 181 1 1 2 1 1 0\n1 1.00001 0\n"
                 + " ".join(map(str, v)) + "\n0\n" + " ".join(map(str, cd)) + "\n")
    return p


def run(light, pts, center, normal, up, method, extra=()):
    with tempfile.TemporaryDirectory() as d:
        out = Path(d) / "e.csv"
        r = subprocess.run([str(LUMIFIT), "light", "illuminance", str(light), "--rect", "1,1",
                            "--center", ",".join(map(str, center)), "--normal", ",".join(map(str, normal)),
                            "--up", ",".join(map(str, up)), "--points", str(pts), "--method", method, *extra,
                            "--out", str(out)], check=True, capture_output=True)
        info = json.loads(r.stdout)
        e = np.loadtxt(out, delimiter=",", skiprows=1, usecols=6)
    return e, info["compute_seconds"]


def main():
    tmp = Path(tempfile.mkdtemp())
    pts = tmp / "pts.csv"
    xs = np.linspace(-2.5, 2.5, N)
    X, Y = np.meshgrid(xs, xs)
    with open(pts, "w") as f:
        f.write("x,y,z,nx,ny,nz\n")
        for x, y in zip(X.ravel(), Y.ravel()):
            f.write(f"{x + 1e-4:.6f},{y + 2e-4:.6f},0,0,0,1\n")
    profiles = {"Prolicht E30 (real)": DATA, "Lambertian": lambert_ies(tmp)}
    methods = [("point", ()), ("structured", ()), ("mrp", ()), ("cubature", ()), ("cubature-adaptive", ("--tolerance", "0.01"))]
    methods += [(f"mc {n}", ("--samples", str(n), "--seed", "5")) for n in MC_N]
    print(f"{N}x{N} ground points over 5 x 5 units, 3 orientations each\n")
    print("| profile | height | " + " | ".join(m for m, _ in methods) + " | MC N matching cubature | time MC(N)/cubature |")
    print("|---" * (len(methods) + 4) + "|")
    for pname, light in profiles.items():
        for h in [0.1, 1.0, 2.5]:
            errs = {m: [] for m, _ in methods}
            ref_all, times = [], {m: 0.0 for m, _ in methods}
            for angle in [math.pi / 2, 3 * math.pi / 4, math.pi]:
                # n_A · n_g = cos(angle), n_g = +z; the light tilts about y
                normal = (math.sin(angle), 0.0, math.cos(angle))
                up = (0.0, 1.0, 0.0)
                half_drop = 0.5 * abs(math.sin(math.pi - angle))  # lowest point of the tilted square
                center = (0.0, 0.0, h + half_drop)
                ref, _ = run(light, pts, center, normal, up, "cubature-adaptive", ("--tolerance", "0.001"))
                ref_all.append(ref)
                for m, extra in methods:
                    name = m.split()[0]
                    e, t = run(light, pts, center, normal, up, name, extra)
                    errs[m].append(e - ref)
                    times[m] += t
            ref = np.concatenate(ref_all)
            scale = math.sqrt(np.mean(ref ** 2))
            nrms = {m: math.sqrt(np.mean(np.concatenate(v) ** 2)) / scale for m, v in errs.items()}
            match = next((n for n in MC_N if nrms[f"mc {n}"] <= nrms["cubature"]), None)
            ratio = f"{times[f'mc {match}'] / times['cubature']:.1f}" if match else "—"
            print(f"| {pname} | {h} | " + " | ".join(f"{100 * nrms[m]:.2f} %" for m, _ in methods)
                  + f" | {match if match else '> ' + str(MC_N[-1])} | {ratio} |")


if __name__ == "__main__":
    main()
