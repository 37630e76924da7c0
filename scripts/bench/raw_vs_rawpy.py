"""Decode the same DNG with lumifit (rawler) and rawpy (LibRaw) in one run: time per frame and
agreement of the linear values in regions of interest.

    cargo build --release
    pip install -r scripts/bench/requirements.txt
    python3 scripts/bench/raw_vs_rawpy.py [--dng ../shared/data/raw/tinydng_colorchart_rawler_uncompressed16.dng] [--n 10]

Linear values on both sides: (raw - black[colour]) / (white - black), 2x2 superpixels
(R, mean of the two G, B) over the visible area. lumifit's ROI coordinates are in the visible
(full-resolution) image's pixels, the same as rawpy's raw_image_visible.
"""

import argparse
import csv
import json
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np
import rawpy

ROOT = Path(__file__).resolve().parents[2]
LUMIFIT = ROOT / "target" / "release" / "lumifit"


def rawpy_linear(path):
    with rawpy.imread(str(path)) as r:
        raw = r.raw_image_visible.astype(np.float64)
        colors = r.raw_colors_visible
        black = np.array(r.black_level_per_channel, dtype=np.float64)
        white = float(r.white_level)
        lin = (raw - black[colors]) / (white - black[colors])
        # colour indices: 0 R, 1 G, 2 B, 3 second G
        h, w = lin.shape
        h2, w2 = h // 2, w // 2
        lin = lin[: 2 * h2, : 2 * w2]
        col = colors[: 2 * h2, : 2 * w2]
        out = np.zeros((h2, w2, 3))
        for dy in range(2):
            for dx in range(2):
                c = col[dy, dx]
                ch = {0: 0, 1: 1, 2: 2, 3: 1}[int(c)]
                weight = 0.5 if ch == 1 else 1.0
                out[:, :, ch] += weight * lin[dy::2, dx::2]
        return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--dng", default=str(ROOT / "../shared/data/raw/tinydng_colorchart_rawler_uncompressed16.dng"))
    ap.add_argument("--n", type=int, default=10)
    a = ap.parse_args()
    dng = Path(a.dng).resolve()

    t = time.perf_counter()
    for _ in range(a.n):
        img = rawpy_linear(dng)
    t_rawpy = (time.perf_counter() - t) / a.n

    with tempfile.TemporaryDirectory() as d:
        d = Path(d)
        man = d / "m.csv"
        man.write_text("file,time_s,exposure_s,iso,f_number\n" + "".join(f"{dng},{i},1,100,1\n" for i in range(a.n)))
        t = time.perf_counter()
        subprocess.run([str(LUMIFIT), "series", "inspect", str(man), "--json"], check=True, capture_output=True)
        t_lumifit = (time.perf_counter() - t) / a.n
        one = d / "one.csv"
        one.write_text(f"file,time_s,exposure_s,iso,f_number\n{dng},0,1,100,1\n")
        t = time.perf_counter()
        subprocess.run([str(LUMIFIT), "series", "inspect", str(one), "--json"], check=True, capture_output=True)
        t_lumifit_one = time.perf_counter() - t

        h2, w2, _ = img.shape
        diffs = []
        rois = []
        for gy in range(4):
            for gx in range(6):
                x = 2 * (w2 * (2 * gx + 1) // 12) - 40
                y = 2 * (h2 * (2 * gy + 1) // 8) - 40
                rois.append((x, y, 80, 80))
        for (x, y, w, h) in rois:
            out = d / "c.csv"
            subprocess.run([str(LUMIFIT), "series", "extract", str(one), "--roi", f"{x},{y},{w},{h}", "--out", str(out)],
                           check=True, capture_output=True)
            row = next(csv.DictReader(out.open()))
            lum = np.array([float(row["r"]), float(row["g"]), float(row["b"])])
            ref = img[y // 2:(y + h) // 2, x // 2:(x + w) // 2].reshape(-1, 3).mean(axis=0)
            diffs.append(np.abs(lum - ref).max() / max(ref.max(), 1e-12))
    print(json.dumps({
        "file": str(dng),
        "rawpy": rawpy.__version__,
        "libraw": ".".join(map(str, rawpy.libraw_version)),
        "frames": a.n,
        "rawpy_s_per_frame_decode_and_bin": round(t_rawpy, 4),
        "lumifit_s_per_frame_parallel_series": round(t_lumifit, 4),
        "lumifit_s_single_frame_whole_process": round(t_lumifit_one, 4),
        "rois": len(rois),
        "max_relative_difference_of_roi_means": float(max(diffs)),
    }, indent=2))


if __name__ == "__main__":
    main()
