#!/usr/bin/env python3
"""Independent numpy implementation of lumifit's fluorescence pipeline (Fichet et al. 2024).

Writes
  fixtures/fluor/synthetic.bfc        a synthetic BFC-450 matrix (generated here, deterministic)
  fixtures/fluor/reference.json       reductions and one-bounce ΔE00 for the synthetic matrix and,
                                      when ../shared/data/fluorescence exists, for the 10 measured ones

Protocol (identical to docs/fluorescence.md, written independently of the Rust code):
  grid 300–780 nm, 1 nm; D[emission, excitation]; negatives clipped; diagonal interpolated
  linearly (zero outside), off-diagonal bilinearly as density (÷10 nm, ×1 nm, zero outside);
  CMFs CIE 2006 2° (calib/cmfs/cie2015_2.csv) linearly, zero outside; U = clamped quadratic
  B-spline element 0 with knots 300,300,300,550 scaled to Σ U = Σ ȳ; 7 bases of Appendix A;
  dual P = Sᵀ A S (SᵀS)⁻¹; naive P = S̄ᵀ A S̄ with unit-L2 columns; CIE illuminants from
  calib/illuminants (linear inside, zero outside); white Y = 100; Lab and CIEDE2000 by colour.

Usage: python scripts/reference/fluor_numpy_reference.py   (from the crate root; pinned versions
in scripts/reference/requirements.txt). Also importable: the benchmark reuses `evaluate_all`.
"""
import json
import os
import sys

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
DATA = os.path.join(ROOT, "..", "shared", "data", "fluorescence")
WL = np.arange(300.0, 781.0, 1.0)
H = 1.0
ILLUMINANTS = ["A", "E", "D60", "D65", "FL1", "FL2", "HP5"]
METHODS = ["dual-xyz", "dual-xyzu", "naive-xyz", "naive-xyzu", "dual-xyz7u"]


def read_bfc(path):
    with open(path) as f:
        lines = [l.strip() for l in f]
    i = next(k for k, l in enumerate(lines) if l and not l.startswith(";") and not l.startswith("VEC_") and "BFC-450" not in l)
    e0, e1, es, nx, x0, xs = [float(v) for v in lines[i].split()]
    em = np.arange(e0, e1 + es / 2, es)
    ex = x0 + xs * np.arange(int(nx))
    rows = []
    for l in lines[i + 2:]:
        if l.startswith("EOD"):
            break
        if l:
            rows.append([float(v) for v in l.split()[1:]])
    m = np.array(rows)
    assert m.shape == (len(em), len(ex)), m.shape
    return em, ex, m


def to_operator(em, ex, m):
    m = np.clip(m, 0.0, None)
    off = m.copy()
    diag_wl, diag_v = [], []
    for r, e in enumerate(em):
        c = int(np.argmin(np.abs(ex - e)))
        assert abs(ex[c] - e) < 1e-6
        diag_wl.append(e)
        diag_v.append(m[r, c])
        off[r, c] = 0.0
    step = ex[1] - ex[0]
    tmp = np.array([np.interp(WL, ex, row, left=0.0, right=0.0) for row in off]) / step * H  # (n_em, N)
    a = np.array([np.interp(WL, em, tmp[:, j], left=0.0, right=0.0) for j in range(len(WL))]).T
    a += np.diag(np.interp(WL, diag_wl, diag_v, left=0.0, right=0.0))
    return a


def cmfs():
    t = np.genfromtxt(os.path.join(ROOT, "calib", "cmfs", "cie2015_2.csv"), delimiter=",", skip_header=1)
    return np.stack([np.interp(WL, t[:, 0], t[:, k], left=0.0, right=0.0) for k in (1, 2, 3)], axis=1)


def smoothstep(x, mu, sigma):
    t = np.clip(0.5 * ((x - mu) / sigma + 1.0), 0.0, 1.0)
    return 3 * t**2 - 2 * t**3


def bases():
    s = cmfs()
    x, y, z = s[:, 0], s[:, 1], s[:, 2]
    u = np.where(WL < 550.0, ((550.0 - WL) / 250.0) ** 2, 0.0)
    u = u * y.sum() / u.sum()
    s500, s590, s570 = smoothstep(WL, 500, 2), smoothstep(WL, 590, 60), smoothstep(WL, 570, 60)
    b7 = np.stack([x * (1 - s500), x * s500 * s590, x * s500 * (1 - s590), y * s570, y * (1 - s570), z, u], axis=1)
    t7 = np.array([[1, 1, 1, 0, 0, 0, 0], [0, 0, 0, 1, 1, 0, 0], [0, 0, 0, 0, 0, 1, 0]], dtype=float)
    return {
        "xyz": (s, np.eye(3)),
        "xyzu": (np.column_stack([s, u]), np.hstack([np.eye(3), np.zeros((3, 1))])),
        "xyz7u": (b7, t7),
    }


def reduce(a, s, method):
    if method == "dual":
        dual = s @ np.linalg.inv(s.T @ s)
        return s.T @ a @ dual
    sn = s / np.linalg.norm(s, axis=0)
    return sn.T @ a @ sn


def illuminant(name):
    t = np.genfromtxt(os.path.join(ROOT, "calib", "illuminants", f"{name}.csv"), delimiter=",", skip_header=1)
    return np.interp(WL, t[:, 0], t[:, 1], left=0.0, right=0.0)


def xyz_to_lab(xyz, white):
    import colour

    return colour.XYZ_to_Lab(xyz / 100.0, colour.XYZ_to_xy(white / 100.0))


def delta_e00(a, b):
    import colour

    return float(colour.delta_E(a, b, method="CIE 2000"))


def evaluate_all(materials, ills, bs, with_de=True):
    """materials: {name: A}; returns list of row dicts (illuminant-major per material)."""
    sx = bs["xyz"][0]
    red = {}
    rows = []
    for name, a in materials.items():
        for m in METHODS:
            r, b = m.split("-")
            red[(name, m)] = reduce(a, bs[b][0], r)
        for ill_name, e in ills.items():
            k = 100.0 / (sx[:, 1] @ e)
            white = k * (sx.T @ e)
            ref = k * (sx.T @ (a @ e))
            for m in METHODS:
                r, b = m.split("-")
                s, t = bs[b]
                out = k * (t @ (red[(name, m)] @ (s.T @ e)))
                row = {"material": name, "illuminant": ill_name, "method": m, "xyz_reference": ref.tolist(), "xyz_reduced": out.tolist()}
                if with_de:
                    row["delta_e00"] = delta_e00(xyz_to_lab(ref, white), xyz_to_lab(out, white))
                rows.append(row)
    return rows, red


def synthetic_bfc():
    em = np.arange(380.0, 781.0, 10.0)
    ex = np.arange(300.0, 781.0, 10.0)
    rng = np.random.default_rng(20240617)
    m = 0.004 * rng.standard_normal((len(em), len(ex)))
    for r, e in enumerate(em):
        for c, x in enumerate(ex):
            if x < e:
                m[r, c] += 0.08 * np.exp(-0.5 * ((x - 360) / 35) ** 2) * np.exp(-0.5 * ((e - 520) / 30) ** 2)
        c = int(np.argmin(np.abs(ex - e)))
        m[r, c] = 0.15 + 0.7 / (1 + np.exp(-(e - 560) / 20))
    lines = ["VEC_01\t5167", "BFC-450 Matrix File", ";synthetic.BFC", ";synthetic fluorescent material (lumifit fixture)",
             ";scripts/reference/fluor_numpy_reference.py", ";<none>", ";<none>", ";<none>", ";<none>", ";<none>",
             "380\t780\t10\t49\t300\t10", "r:c:\t" + "\t".join(f"{x:g}" for x in ex)]
    for r, e in enumerate(em):
        lines.append(f"{e:g}\t" + "\t".join(f"{v:.9g}" for v in m[r]))
    lines.append("EOD")
    return "\n".join(lines) + "\n"


def main():
    out_dir = os.path.join(ROOT, "fixtures", "fluor")
    os.makedirs(out_dir, exist_ok=True)
    syn_path = os.path.join(out_dir, "synthetic.bfc")
    with open(syn_path, "w") as f:
        f.write(synthetic_bfc())
    bs = bases()
    ills = {n: illuminant(n) for n in ILLUMINANTS}
    mats = {"synthetic": to_operator(*read_bfc(syn_path))}
    real = []
    if os.path.isdir(DATA):
        for sub in ("rit_gonzalez_bfc", "labsphere_3m_postit"):
            for fn in sorted(os.listdir(os.path.join(DATA, sub))):
                if fn.upper().endswith(".BFC"):
                    name = os.path.splitext(fn)[0]
                    mats[name] = to_operator(*read_bfc(os.path.join(DATA, sub, fn)))
                    real.append(name)
    else:
        print(f"note: {DATA} absent; writing the synthetic fixture only", file=sys.stderr)
    rows, red = evaluate_all(mats, ills, bs)
    import colour

    doc = {
        "generator": "scripts/reference/fluor_numpy_reference.py",
        "versions": {"numpy": np.__version__, "colour-science": colour.__version__},
        "grid_nm": [300.0, 780.0, 1.0],
        "observer": "cie2015-2",
        "dual_check_max_abs": {b: float(np.abs(bs[b][0].T @ (bs[b][0] @ np.linalg.inv(bs[b][0].T @ bs[b][0])) - np.eye(bs[b][0].shape[1])).max()) for b in bs},
        "u_at_300_400_549": [float(bs["xyzu"][0][i, 3]) for i in (0, 100, 249)],
        "materials_real": real,
        "reduced": {f"{n}|{m}": red[(n, m)].tolist() for (n, m) in red},
        "rows": rows,
    }
    with open(os.path.join(out_dir, "reference.json"), "w") as f:
        json.dump(doc, f, indent=1)
    print(f"wrote {len(rows)} rows for {len(mats)} materials to fixtures/fluor/reference.json")


if __name__ == "__main__":
    main()
