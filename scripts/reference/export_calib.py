#!/usr/bin/env python3
"""Export the reference tables lumifit ships in calib/ from colour-science.

Run from the repository root:
    pip install -r scripts/reference/requirements.txt
    python3 scripts/reference/export_calib.py

Every float is written with Python's repr (shortest round-trip form), so parsing the CSV in Rust
yields the very same IEEE-754 doubles colour holds (checked by tests/calib_tables.rs through the
SHA-256 digests that colour_reference.py stores in fixtures/).
"""

import json
import os
import warnings

warnings.filterwarnings("ignore")

import colour  # noqa: E402
import numpy as np  # noqa: E402

ROOT = os.path.normpath(os.path.join(os.path.dirname(__file__), "..", ".."))
CALIB = os.path.join(ROOT, "calib")

CMFS = {
    "cie1931_2": "CIE 1931 2 Degree Standard Observer",
    "cie1964_10": "CIE 1964 10 Degree Standard Observer",
    "cie2015_2": "CIE 2015 2 Degree Standard Observer",
    "cie2015_10": "CIE 2015 10 Degree Standard Observer",
}

ILLUMINANTS = (
    ["A", "C", "D50", "D55", "D60", "D65", "D75", "E"]
    + [f"FL{i}" for i in range(1, 13)]
    + [f"HP{i}" for i in range(1, 6)]
    + [f"LED-B{i}" for i in range(1, 6)]
)

RGB_SPACES = {
    "srgb": ("sRGB", "srgb"),
    "display-p3": ("Display P3", "srgb"),
    "rec2020": ("ITU-R BT.2020", "rec2020"),
    "acescg": ("ACEScg", "linear"),
}


def fmt(v):
    return repr(float(v))


def write_csv(path, header, columns):
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, "w", newline="\n") as f:
        f.write(",".join(header) + "\n")
        for row in zip(*columns):
            f.write(",".join(fmt(v) for v in row) + "\n")


def main():
    for key, name in CMFS.items():
        cmfs = colour.MSDS_CMFS[name]
        write_csv(
            os.path.join(CALIB, "cmfs", f"{key}.csv"),
            ["wavelength_nm", "x_bar", "y_bar", "z_bar"],
            [cmfs.wavelengths] + [cmfs.values[:, i] for i in range(3)],
        )
    for name in ILLUMINANTS:
        sd = colour.SDS_ILLUMINANTS[name]
        write_csv(
            os.path.join(CALIB, "illuminants", f"{name}.csv"),
            ["wavelength_nm", "relative_power"],
            [sd.wavelengths, sd.values],
        )
    basis = colour.colorimetry.SDS_BASIS_FUNCTIONS_CIE_ILLUMINANT_D_SERIES
    write_csv(
        os.path.join(CALIB, "d_series_basis.csv"),
        ["wavelength_nm", "S0", "S1", "S2"],
        [basis["S0"].wavelengths] + [basis[k].values for k in ("S0", "S1", "S2")],
    )
    cc = colour.SDS_COLOURCHECKERS["ColorChecker N Ohta"]
    names = list(cc.keys())
    write_csv(
        os.path.join(CALIB, "colorchecker_n_ohta.csv"),
        ["wavelength_nm"] + [n.replace(",", " ") for n in names],
        [cc[names[0]].wavelengths] + [cc[n].values for n in names],
    )
    # Named white chromaticities per observer (colour.CCS_ILLUMINANTS) and RGB spaces.
    whites = {}
    for key, name in CMFS.items():
        table = colour.CCS_ILLUMINANTS.get(name)
        if table is None:
            continue
        whites[key] = {
            k: [float(v) for v in table[k]] for k in ILLUMINANTS + ["ACES"] if k in table
        }
    spaces = {}
    for key, (name, transfer) in RGB_SPACES.items():
        cs = colour.RGB_COLOURSPACES[name]
        spaces[key] = {
            "colour_name": name,
            "primaries_xy": [[float(v) for v in p] for p in cs.primaries],
            "whitepoint_xy": [float(v) for v in cs.whitepoint],
            "whitepoint_name": cs.whitepoint_name,
            "transfer": transfer,
            "matrix_rgb_to_xyz": [[float(v) for v in r] for r in cs.matrix_RGB_to_XYZ],
        }
    meta = {
        "source": f"colour-science {colour.__version__}, numpy {np.__version__}",
        "white_chromaticities_xy": whites,
        "rgb_colourspaces": spaces,
    }
    with open(os.path.join(CALIB, "colourspaces.json"), "w") as f:
        json.dump(meta, f, indent=1)
        f.write("\n")
    print("calib/ written from colour", colour.__version__)


if __name__ == "__main__":
    main()
