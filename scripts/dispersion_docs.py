#!/usr/bin/env python3
"""Regenerates the tables of docs/dispersion.md by running the release binary.

Usage (crate root, after `cargo build --release`): python3 scripts/dispersion_docs.py > /tmp/tables.md
Reads ../shared/data/ior in place; writes only into a temporary directory.
"""
import csv
import json
import os
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BIN = os.path.join(ROOT, "target", "release", "lumifit")
DATA = os.path.join(ROOT, "..", "shared", "data", "ior")
ENTRIES = ["schott_N-BK7.yml", "schott_N-K5.yml", "schott_N-BAK4.yml", "schott_N-BAF10.yml", "schott_F2.yml",
           "schott_N-SF11.yml", "SiO2_Malitson.yml", "H2O_Daimon-20.0C.yml", "H2O_Hale.yml", "C_Peter.yml"]
TABLE1 = [("Fused silica", "SiO2_Malitson.yml", 1.4580, 0.00354), ("BK7", "schott_N-BK7.yml", 1.5046, 0.00420),
          ("K5", "schott_N-K5.yml", 1.5220, 0.00459), ("BaK4", "schott_N-BAK4.yml", 1.5690, 0.00531),
          ("BaF10", "schott_N-BAF10.yml", 1.6700, 0.00743)]


def run(*args):
    o = subprocess.run([BIN, *args], capture_output=True, text=True)
    if o.returncode != 0:
        sys.exit(f"lumifit {' '.join(args)} failed: {o.stderr}")
    return json.loads(o.stdout) if o.stdout.strip() else None


def n_formula(path, lam_nm):
    import yaml
    with open(path) as f:
        d = yaml.safe_load(f)
    item = next(x for x in d["DATA"] if x["type"].startswith("formula"))
    kind = int(item["type"].split()[1])
    c = [float(v) for v in str(item["coefficients"]).split()]
    l2 = (lam_nm * 1e-3) ** 2
    s = 1 + c[0]
    for i in range(1, len(c), 2):
        pole = c[i + 1] ** 2 if kind == 1 else c[i + 1]
        s += c[i] * l2 / (l2 - pole)
    return s ** 0.5


def main():
    tmp = tempfile.mkdtemp()
    fits = {}
    print("## Fit table (380–780 nm, tolerance max |Δn| ≤ 1e-4)\n")
    print("| entry | range nm | chosen | cauchy2 RMS / max | sellmeier1 | cauchy3 | sellmeier2 | sellmeier3 | n_d | V_d | glTF Cauchy max |Δn| |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for e in ENTRIES:
        out = os.path.join(tmp, e + ".json")
        s = run("dispersion", "fit", os.path.join(DATA, e), "--out", out)
        fits[e] = (s, out)
        cells = []
        for c in s["candidates"]:
            cells.append(f"{c['rms_residual']:.1e} / {c['max_abs_residual']:.1e}" if c["valid"] else "—")
        d = s["derived"]
        vd = f"{d['abbe_number_d']:.2f}"
        if s.get("abbe_number_std"):
            vd += f" ± {s['abbe_number_std']:.1f}"
        chosen = s["chosen_model"] + ("" if s["tolerance_met"] else " (tolerance not met; lowest BIC)")
        print(f"| {e} | {s['range_nm'][0]:.0f}–{s['range_nm'][1]:.0f} | {chosen} | " + " | ".join(cells)
              + f" | {d['n_d']:.5f} | {vd} | {d['gltf_cauchy']['max_abs_error']:.1e} |")

    print("\n## Blanchette (2012) Table 1 checked\n")
    print("| material (file) | Table 1 A | Table 1 B µm² | fitted A | fitted B µm² | Table 1 max |Δn| 380–780 | fitted Cauchy2 max |Δn| |")
    print("|---|---|---|---|---|---|---|")
    for name, e, a, b in TABLE1:
        out = os.path.join(tmp, e + ".c2.json")
        s = run("dispersion", "fit", os.path.join(DATA, e), "--model", "cauchy2", "--out", out)
        with open(out) as f:
            m = json.load(f)["dispersion"]["model"]["coefficients"]
        worst = max(abs(a + b / (l * 1e-3) ** 2 - n_formula(os.path.join(DATA, e), l)) for l in range(380, 781))
        print(f"| {name} ({e}) | {a:.4f} | {b:.5f} | {m[0]:.4f} | {m[1]:.5f} | {worst:.1e} | "
              f"{s['candidates'][0]['max_abs_residual']:.1e} |")

    print("\n## Blanchette (2012) Table 2 beside computed weights (same wavelengths: 7 samples over 355–705 nm)\n")
    out = os.path.join(tmp, "t2.json")
    s = run("dispersion", "fit", "--glass", "fused-silica", "--range", "355:705", "--out", out)
    t2 = [(380, 77, 0, 204), (430, 51, 51, 255), (480, 0, 229.5, 255), (530, 76.5, 255, 102),
          (580, 204, 229.5, 77), (630, 229.5, 128, 0), (680, 255, 0, 0)]
    print("| λ nm | Table 2 RGB / 893 | computed sRGB weights (E, CIE 1931 2°) |")
    print("|---|---|---|")
    for row, smp in zip(t2, s["samples"]):
        print(f"| {smp['lambda_nm']:.0f} | {row[1]/893:.3f}, {row[2]/893:.3f}, {row[3]/893:.3f} | "
              + ", ".join(f"{v:.3f}" for v in smp["rgb"]) + " |")

    print("\n## Prism ΔE00 (apex 60°, minimum deviation at d, screen 1 m, beam 2 mm, pixel 0.05 mm)\n")
    print("Cells: mean / max ΔE00 of the weights as exported; in brackets mean / max of sampling alone.\n")
    print("| glass | N=3 | N=5 | N=7 | N=11 | N=21 | Table 2 | smallest N, sampling max ΔE00 ≤ 2 | ≤ 1 |")
    print("|---|---|---|---|---|---|---|---|---|")
    for e in ["schott_N-BK7.yml", "schott_N-K5.yml", "schott_N-BAK4.yml", "schott_N-BAF10.yml", "schott_F2.yml",
              "schott_N-SF11.yml", "SiO2_Malitson.yml", "H2O_Daimon-20.0C.yml"]:
        s, preset = fits[e]
        table = os.path.join(tmp, e + ".csv")
        run("dispersion", "prism", preset, "--out", os.path.join(tmp, e + ".png"), "--table", table)
        with open(table) as f:
            rows = list(csv.DictReader(f))[1:]
        cells = [f"{float(r['mean_de00']):.1f} / {float(r['max_de00']):.1f}"
                 + (f" ({float(r['mean_de00_sampling_only']):.1f} / {float(r['max_de00_sampling_only']):.1f})"
                    if r['mean_de00_sampling_only'] else "") for r in rows]
        smallest = []
        for t in ("2", "1"):
            o = subprocess.run([BIN, "dispersion", "prism", preset, "--target-de00", t, "--out",
                                os.path.join(tmp, "t.png")], capture_output=True, text=True)
            smallest.append(str(json.loads(o.stdout)["smallest_n_for_target"]) if o.returncode == 0 else "> 400")
        print(f"| {e} | " + " | ".join(cells) + " | " + " | ".join(smallest) + " |")


if __name__ == "__main__":
    main()
