"""How much `lvf calibrate --camera` depends on the camera being the image's own.

    cargo build --release
    python3 scripts/bench/lvf_camera_choice.py --render "Canon 5DMarkII" --lamp cfl --noise 0.05 \
        --vignetting quadratic:0.3 --continuum 0.1 --continuum-spectrum cfl --seed 5 [--lumifit PATH]

Renders one lamp image with `lumifit synth lvf-hg` through the --render camera of the Jiang
database (../shared/data/camera/jiang2013_camspec_all_cameras_long.csv, read in place; geometry
of docs/performance.md, issue 12), then calibrates it once without --camera and once with
--camera set to each of the database's 28 cameras. Prints, best shared-spectrum BIC first: the
signed λ error at the true 400 / 700 nm positions, the background model BIC chose, the chosen
fit's BIC, the best shared-spectrum candidate's BIC (— when the line-colour check dropped them),
the reported σ at 700 nm and the line-colour misfit of the curves (`diagnostics.camera_check`,
`lumifit::lvf::line_colour`; "dropped" above its limit). Two calibrations run at a time.
"""

import argparse
import csv
import json
import subprocess
import tempfile
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
DB = ROOT.parent / "shared" / "data" / "camera" / "jiang2013_camspec_all_cameras_long.csv"


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--render", default="Canon 5DMarkII")
    ap.add_argument("--lamp", default="cfl")
    ap.add_argument("--noise", default="0.05")
    ap.add_argument("--vignetting", default="quadratic:0.3")
    ap.add_argument("--continuum", default="0.1")
    ap.add_argument("--continuum-spectrum", default="cfl")
    ap.add_argument("--seed", default="5")
    ap.add_argument("--lumifit", default=str(ROOT / "target" / "release" / "lumifit"))
    a = ap.parse_args()
    with DB.open() as f:
        cams = sorted({r["camera"] for r in csv.DictReader(f)})
    with tempfile.TemporaryDirectory(dir=ROOT / "target") as d:
        d = Path(d)
        img, truth = d / "i.tiff", d / "t.json"
        subprocess.run([a.lumifit, "synth", "lvf-hg", "--out", str(img), "--truth", str(truth),
                        "--lamp", a.lamp, "--nm-at-start", "372.3", "--nm-per-px", "0.3117", "--fwhm", "25",
                        "--camera", f"{DB}:{a.render}", "--noise", a.noise, "--vignetting", a.vignetting,
                        "--continuum", a.continuum, "--continuum-spectrum", a.continuum_spectrum,
                        "--seed", a.seed], check=True, capture_output=True)
        t = json.loads(truth.read_text())

        def one(i_cam):
            i, cam = i_cam
            out = d / f"o{i}.json"
            r = subprocess.run([a.lumifit, "lvf", "calibrate", str(img), "--axis", "x", "--lamp", a.lamp,
                                "--out", str(out), *(["--camera", f"{DB}:{cam}"] if cam else [])],
                               capture_output=True, text=True)
            if r.returncode != 0:
                return cam, None, r.stderr.strip().splitlines()[-1][:160]
            o = json.loads(out.read_text())
            c = o["map"]["coefficients"]
            lam = lambda px: sum(ci * px**k for k, ci in enumerate(c))
            cands = o["background"]["candidates"]
            shared = [x["bic"] for x in cands if x["model"].startswith("shared")]
            return cam, (lam(t["px_at_400"]) - 400, lam(t["px_at_700"]) - 700, o["background"]["model"],
                         cands[0]["bic"], min(shared) if shared else None, o["sigma_nm_at_700"],
                         o["diagnostics"].get("camera_check")), None

        with ThreadPoolExecutor(2) as ex:
            res = list(ex.map(one, enumerate([None, *cams])))
    print(f"rendered through {a.render}: {a.lamp}, noise {a.noise}, vignetting {a.vignetting}, "
          f"continuum {a.continuum} {a.continuum_spectrum}, seed {a.seed}\n")
    print("| --camera | error 400 / 700 nm | model chosen | BIC chosen | best shared BIC | σ at 700 | colour misfit |")
    print("|---|---|---|---|---|---|---|")
    res.sort(key=lambda r: (r[1] is None, r[1][4] if r[1] and r[1][4] is not None else float("inf")))
    for cam, v, err in res:
        name = "(none)" if cam is None else cam + (" ← rendering camera" if cam == a.render else "")
        if v is None:
            print(f"| {name} | failed: {err} | | | | | |")
            continue
        sh = f"{v[4]:.1f}" if v[4] is not None else "—"
        cc = v[6]
        mis = "—" if not cc else f"{cc['misfit']:.3f}" + ("" if cc["consistent"] else " dropped")
        print(f"| {name} | {v[0]:+.3f} / {v[1]:+.3f} | {v[2]} | {v[3]:.1f} | {sh} | {v[5]:.3f} | {mis} |")


if __name__ == "__main__":
    main()
