"""Export lumifit's default camera sensitivities (calib/camera_default.csv) from colour-science.

Source: colour-science 0.4.7 `colour.MSDS_CAMERA_SENSITIVITIES["Nikon 5100 (NPL)"]` (BSD-3-Clause;
data: National Physical Laboratory measurements as distributed by colour). Channels are written as
colour ships them, rescaled so that the largest value over all channels is 1 (relative units).
Versions are pinned in scripts/reference/requirements.txt.

    python3 scripts/reference/export_camera.py
"""

from pathlib import Path

import colour
import numpy as np

NAME = "Nikon 5100 (NPL)"
OUT = Path(__file__).resolve().parents[2] / "calib" / "camera_default.csv"


def main() -> None:
    msds = colour.MSDS_CAMERA_SENSITIVITIES[NAME]
    wl = np.asarray(msds.wavelengths, dtype=float)
    values = np.asarray(msds.values, dtype=float)
    values = np.nan_to_num(values, nan=0.0)
    values = np.clip(values, 0.0, None)
    values = values / values.max()
    lines = [
        f"# {NAME} camera spectral sensitivities, colour-science {colour.__version__} "
        "MSDS_CAMERA_SENSITIVITIES (BSD-3-Clause), peak-normalised over all channels",
        "wavelength_nm,r,g,b",
    ]
    for w, (r, g, b) in zip(wl, values):
        lines.append(f"{w:g},{r:.6g},{g:.6g},{b:.6g}")
    OUT.write_text("\n".join(lines) + "\n")
    print(f"wrote {OUT} ({len(wl)} rows, {wl[0]:g}-{wl[-1]:g} nm)")


if __name__ == "__main__":
    main()
