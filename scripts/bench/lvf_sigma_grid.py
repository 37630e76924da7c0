"""How often the reported σ of the LVF map covers its error, over the grid of lvf_continuum.py.

    cargo build --release
    python3 scripts/bench/lvf_sigma_grid.py [--seeds 2] [--cases 3,4,5,6,9,10,11,12,13,14,15,16] [--shared]

Renders each case of `scripts/bench/lvf_continuum.py` (issue 12 geometry, three cameras of the
Jiang database read in place, seeds 1..N) with `lumifit synth lvf-hg`, calibrates it with
`lumifit lvf calibrate` (with `--shared`: `--camera` the rendering camera) and prints, per lamp
(Hg / CFL), the fraction of (image, 400/700 nm position) pairs with |error| <= sigma and <= 2 sigma,
the median sigma/|error| (|error| floored at 0.01 nm) and the mean sigma. The default cases leave
out the linear tilt and the off-centre fall-off (7, 8), which the strips across the axis cannot
see and sigma says it does not include.
"""

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "scripts" / "bench"))
from lvf_continuum import CAMERAS, CASES, DB  # noqa: E402


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", type=int, default=2)
    ap.add_argument("--cases", default="3,4,5,6,9,10,11,12,13,14,15,16")
    ap.add_argument("--shared", action="store_true", help="pass the rendering camera (--camera)")
    ap.add_argument("--lumifit", default=str(ROOT / "target" / "release" / "lumifit"))
    a = ap.parse_args()
    pairs = {"hg": [], "cfl": []}
    with tempfile.TemporaryDirectory(dir=ROOT / "target") as d:
        d = Path(d)
        for ci in (int(c) for c in a.cases.split(",")):
            _, lamp, noise, vig, cont, cspec = CASES[ci]
            for cam in CAMERAS:
                for seed in range(1, (a.seeds if noise > 0 else 1) + 1):
                    img, truth, out = d / "i.tiff", d / "t.json", d / "o.json"
                    r = subprocess.run([a.lumifit, "synth", "lvf-hg", "--out", str(img), "--truth", str(truth),
                                        "--lamp", lamp, "--nm-at-start", "372.3", "--nm-per-px", "0.3117",
                                        "--fwhm", "25", "--camera", f"{DB}:{cam}", "--noise", str(noise),
                                        "--vignetting", vig, "--continuum", str(cont),
                                        "--continuum-spectrum", cspec, "--seed", str(seed)],
                                       capture_output=True, text=True)
                    assert r.returncode == 0, r.stderr
                    r = subprocess.run([a.lumifit, "lvf", "calibrate", str(img), "--axis", "x", "--lamp", lamp,
                                        "--out", str(out), *(["--camera", f"{DB}:{cam}"] if a.shared else [])],
                                       capture_output=True, text=True)
                    if r.returncode != 0:
                        print(f"failed: case {ci} {cam} seed {seed}: {r.stderr.strip()[-200:]}", flush=True)
                        continue
                    t = json.loads(truth.read_text())
                    cal = json.loads(out.read_text())
                    c = cal["map"]["coefficients"]
                    lam = lambda px: sum(ck * px**k for k, ck in enumerate(c))
                    for nm, key, sk in [(400, "px_at_400", "sigma_nm_at_400"), (700, "px_at_700", "sigma_nm_at_700")]:
                        pairs["cfl" if lamp == "cfl" else "hg"].append((abs(lam(t[key]) - nm), cal[sk]))
    print(f"{'with --camera' if a.shared else 'without a camera'}:")
    print("| lamp | pairs | error <= σ | error <= 2σ | median σ / error | mean σ (nm) |")
    print("|---|---|---|---|---|---|")
    for lamp, p in pairs.items():
        if not p:
            continue
        e, s = np.array(p).T
        print(f"| {lamp} | {len(p)} | {np.mean(e <= s):.2f} | {np.mean(e <= 2 * s):.2f} | "
              f"{np.median(s / np.maximum(e, 0.01)):.1f} | {s.mean():.3f} |")


if __name__ == "__main__":
    main()
