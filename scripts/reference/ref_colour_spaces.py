#!/usr/bin/env python3
"""Reference values for lumifit's colour-space maths (src/colorimetry/{xyy,lab,cat,rgb,delta_e,
cct,blackbody,daylight}.rs), computed with colour-science.

Imported by colour_reference.py (``write(fixtures_dir)``); also runnable on its own:

    python3 scripts/reference/ref_colour_spaces.py      # writes fixtures/colour_spaces_*.json

Writes:
- colour_spaces_roundtrips.json: random XYZ -> xyY, Lab (D65, D50), LCh, sRGB, linear and encoded RGB
  in four spaces with three chromatic adaptation transforms, and the inverses back to XYZ;
- colour_spaces_delta_e.json: Sharma, Wu & Dalal (2005) Table 1 pairs and random Lab pairs;
- colour_spaces_cct.json: xy near the Planckian locus -> CCT, Duv (Ohno 2013, Robertson 1968) and back;
- colour_spaces_spectra.json: CIE D-series and blackbody spectra, Planck's law, the D-series basis.

Every float is written with Python's repr (shortest round-trip), so the Rust side reads colour's
doubles bit for bit.
"""

import json
import os
import warnings

warnings.filterwarnings("ignore")

import colour  # noqa: E402
import numpy as np  # noqa: E402
from colour.temperature import (  # noqa: E402
    CCT_to_uv_Ohno2013,
    CCT_to_uv_Robertson1968,
    CCT_to_xy_CIE_D,
    uv_to_CCT_Ohno2013,
    uv_to_CCT_Robertson1968,
)
from colour.models import UCS_uv_to_xy, xy_to_UCS_uv  # noqa: E402

ROOT = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", ".."))
SEED = 20261123
TOLERANCE = {"relative": 1e-6, "absolute": 1e-9}

OBSERVER = "CIE 1931 2 Degree Standard Observer"
WHITES = {k: colour.CCS_ILLUMINANTS[OBSERVER][k] for k in ("A", "D50", "D65")}
# lumifit key -> colour's name
SPACES = {"srgb": "sRGB", "display-p3": "Display P3", "rec2020": "ITU-R BT.2020", "acescg": "ACEScg"}
# lumifit key -> colour's name
CATS = {"bradford": "Bradford", "cat02": "CAT02", "von-kries": "Von Kries"}

# Sharma, G., Wu, W., & Dalal, E. N. (2005). The CIEDE2000 color-difference formula:
# Implementation notes, supplementary test data, and mathematical observations. Color Research &
# Application, 30(1), 21-30, Table 1: (L1, a1, b1), (L2, a2, b2), published Delta E00 (4 decimals).
# Typed from colour's own test file colour/difference/tests/test_delta_e.py, which lists all 34
# pairs (the 14th commented out there because of a platform-dependent arctan2 rounding).
SHARMA_2005 = [
    ((50.0000, 2.6772, -79.7751), (50.0000, 0.0000, -82.7485), 2.0425),
    ((50.0000, 3.1571, -77.2803), (50.0000, 0.0000, -82.7485), 2.8615),
    ((50.0000, 2.8361, -74.0200), (50.0000, 0.0000, -82.7485), 3.4412),
    ((50.0000, -1.3802, -84.2814), (50.0000, 0.0000, -82.7485), 1.0000),
    ((50.0000, -1.1848, -84.8006), (50.0000, 0.0000, -82.7485), 1.0000),
    ((50.0000, -0.9009, -85.5211), (50.0000, 0.0000, -82.7485), 1.0000),
    ((50.0000, 0.0000, 0.0000), (50.0000, -1.0000, 2.0000), 2.3669),
    ((50.0000, -1.0000, 2.0000), (50.0000, 0.0000, 0.0000), 2.3669),
    ((50.0000, 2.4900, -0.0010), (50.0000, -2.4900, 0.0009), 7.1792),
    ((50.0000, 2.4900, -0.0010), (50.0000, -2.4900, 0.0010), 7.1792),
    ((50.0000, 2.4900, -0.0010), (50.0000, -2.4900, 0.0011), 7.2195),
    ((50.0000, 2.4900, -0.0010), (50.0000, -2.4900, 0.0012), 7.2195),
    ((50.0000, -0.0010, 2.4900), (50.0000, 0.0009, -2.4900), 4.8045),
    ((50.0000, -0.0010, 2.4900), (50.0000, 0.0010, -2.4900), 4.8045),
    ((50.0000, -0.0010, 2.4900), (50.0000, 0.0011, -2.4900), 4.7461),
    ((50.0000, 2.5000, 0.0000), (50.0000, 0.0000, -2.5000), 4.3065),
    ((50.0000, 2.5000, 0.0000), (73.0000, 25.0000, -18.0000), 27.1492),
    ((50.0000, 2.5000, 0.0000), (61.0000, -5.0000, 29.0000), 22.8977),
    ((50.0000, 2.5000, 0.0000), (56.0000, -27.0000, -3.0000), 31.9030),
    ((50.0000, 2.5000, 0.0000), (58.0000, 24.0000, 15.0000), 19.4535),
    ((50.0000, 2.5000, 0.0000), (50.0000, 3.1736, 0.5854), 1.0000),
    ((50.0000, 2.5000, 0.0000), (50.0000, 3.2972, 0.0000), 1.0000),
    ((50.0000, 2.5000, 0.0000), (50.0000, 1.8634, 0.5757), 1.0000),
    ((50.0000, 2.5000, 0.0000), (50.0000, 3.2592, 0.3350), 1.0000),
    ((60.2574, -34.0099, 36.2677), (60.4626, -34.1751, 39.4387), 1.2644),
    ((63.0109, -31.0961, -5.8663), (62.8187, -29.7946, -4.0864), 1.2630),
    ((61.2901, 3.7196, -5.3901), (61.4292, 2.2480, -4.9620), 1.8731),
    ((35.0831, -44.1164, 3.7933), (35.0232, -40.0716, 1.5901), 1.8645),
    ((22.7233, 20.0904, -46.6940), (23.0331, 14.9730, -42.5619), 2.0373),
    ((36.4612, 47.8580, 18.3852), (36.2715, 50.5065, 21.2231), 1.4146),
    ((90.8027, -2.0831, 1.4410), (91.1528, -1.6435, 0.0447), 1.4441),
    ((90.9257, -0.5406, -0.9208), (88.6381, -0.8985, -0.7239), 1.5381),
    ((6.7747, -0.2908, -2.4247), (5.8714, -0.0985, -2.2286), 0.6377),
    ((2.0776, 0.0795, -1.1350), (0.9033, -0.0636, -0.5514), 0.9082),
]


def fl(a):
    """A numpy value or array as (nested lists of) Python floats."""
    a = np.asarray(a, dtype=float)
    return float(a) if a.ndim == 0 else [fl(x) for x in a]


def header(description):
    return {
        "generator": "scripts/reference/colour_reference.py",
        "colour_version": colour.__version__,
        "numpy_version": np.__version__,
        "description": description,
        "tolerance": dict(TOLERANCE),
    }


def dump(path, obj):
    """JSON with one case per line: small diffs, readable, compact."""
    cases = obj.pop("cases")
    head = json.dumps(obj, indent=1)
    assert head.endswith("\n}")
    body = ",\n".join("  " + json.dumps(c, separators=(",", ":")) for c in cases)
    with open(path, "w") as fh:
        fh.write(head[:-2] + ',\n "cases": [\n' + body + "\n ]\n}\n")


def roundtrips(rng):
    n_random = 100
    xyzs = [rng.uniform(0.0, 1.0, 3) for _ in range(n_random)]
    # Dark colours exercise the linear segments of Lab and the transfer functions.
    xyzs += [rng.uniform(0.0, 0.012, 3) for _ in range(10)]
    # Black: colour 0.4.7's XYZ_to_xyY returns (0, 0, 0).
    xyzs.append(np.zeros(3))
    cases = []
    for i, xyz in enumerate(xyzs):
        xyy = colour.XYZ_to_xyY(xyz)
        lab65 = colour.XYZ_to_Lab(xyz, WHITES["D65"])
        lab50 = colour.XYZ_to_Lab(xyz, WHITES["D50"])
        lch65 = colour.Lab_to_LCHab(lab65)
        srgb = colour.XYZ_to_sRGB(xyz)
        case = {
            "id": i,
            "xyz": fl(xyz),
            "xyy": fl(xyy),
            "xyy_to_xyz": fl(colour.xyY_to_XYZ(xyy)),
            "lab_d65": fl(lab65),
            "lab_d50": fl(lab50),
            "lab_d65_to_xyz": fl(colour.Lab_to_XYZ(lab65, WHITES["D65"])),
            "lab_d50_to_xyz": fl(colour.Lab_to_XYZ(lab50, WHITES["D50"])),
            "lch_d65": fl(lch65),
            "lch_d65_to_lab": fl(colour.LCHab_to_Lab(lch65)),
            "srgb_encoded": fl(srgb),
            "srgb_encoded_to_xyz": fl(colour.sRGB_to_XYZ(srgb)),
            "rgb": [],
        }
        for key, name in SPACES.items():
            cs = colour.RGB_COLOURSPACES[name]
            for cat_key, cat in CATS.items():
                for white in ("A", "D65"):
                    rgb = colour.XYZ_to_RGB(xyz, cs, WHITES[white], cat, apply_cctf_encoding=False)
                    back = colour.RGB_to_XYZ(rgb, cs, WHITES[white], cat, apply_cctf_decoding=False)
                    case["rgb"].append(
                        {"space": key, "cat": cat_key, "illuminant": white, "encoded": False,
                         "rgb": fl(rgb), "rgb_to_xyz": fl(back)}
                    )
            # Encoded (transfer function applied), from D65 with CAT02 and without adaptation.
            for cat_key, cat in (("cat02", "CAT02"), (None, None)):
                rgb = colour.XYZ_to_RGB(xyz, cs, WHITES["D65"], cat, apply_cctf_encoding=True)
                back = colour.RGB_to_XYZ(rgb, cs, WHITES["D65"], cat, apply_cctf_decoding=True)
                case["rgb"].append(
                    {"space": key, "cat": cat_key, "illuminant": "D65", "encoded": True,
                     "rgb": fl(rgb), "rgb_to_xyz": fl(back)}
                )
        cases.append(case)
    out = header(
        "colour.XYZ_to_xyY, XYZ_to_Lab (D65, D50), Lab_to_LCHab, XYZ_to_sRGB, XYZ_to_RGB for "
        "sRGB, Display P3, ITU-R BT.2020 and ACEScg with Bradford, CAT02 and Von Kries from "
        "illuminants A and D65 (linear), and encoded from D65; each with its inverse"
    )
    out["whites_xy"] = {k: fl(v) for k, v in WHITES.items()}
    out["cases"] = cases
    return out


def delta_e(rng):
    sharma = []
    for i, (lab1, lab2, published) in enumerate(SHARMA_2005):
        sharma.append(
            {
                "pair": i + 1,
                "lab1": list(lab1),
                "lab2": list(lab2),
                "published_cie2000": published,
                "cie2000": fl(colour.difference.delta_E_CIE2000(lab1, lab2)),
            }
        )
    cases = []
    n = 1000
    for i in range(n):
        lab1 = np.array([rng.uniform(0, 100), rng.uniform(-110, 110), rng.uniform(-110, 110)])
        kind = i % 5
        if kind == 0:  # independent colours
            lab2 = np.array([rng.uniform(0, 100), rng.uniform(-110, 110), rng.uniform(-110, 110)])
        elif kind == 1:  # small differences, the formula's intended use
            lab2 = lab1 + rng.normal(0, 1.5, 3)
        elif kind == 2:  # near-neutral pairs straddling the achromatic axis (hue branches)
            lab1[1:] = rng.normal(0, 2, 2)
            lab2 = np.array([lab1[0] + rng.normal(0, 2), -lab1[1] + rng.normal(0, 0.5),
                             -lab1[2] + rng.normal(0, 0.5)])
        elif kind == 3:  # opposite hues
            lab2 = np.array([rng.uniform(0, 100), -lab1[1] * rng.uniform(0.5, 1.5),
                             -lab1[2] * rng.uniform(0.5, 1.5)])
        else:  # one achromatic colour (C' = 0 branch) every tenth case, else hue near 0/360
            if i % 10 == 4:
                lab1[1:] = 0.0
                lab2 = lab1 + rng.normal(0, 5, 3)
            else:
                lab1[2] = rng.normal(0, 1)
                lab2 = np.array([lab1[0] + rng.normal(0, 3), lab1[1] + rng.normal(0, 3),
                                 -lab1[2] + rng.normal(0, 1)])
        cases.append(
            {
                "lab1": fl(lab1),
                "lab2": fl(lab2),
                "cie1976": fl(colour.difference.delta_E_CIE1976(lab1, lab2)),
                "cie1994": fl(colour.difference.delta_E_CIE1994(lab1, lab2)),
                "cie1994_textiles": fl(colour.difference.delta_E_CIE1994(lab1, lab2, textiles=True)),
                "cie2000": fl(colour.difference.delta_E_CIE2000(lab1, lab2)),
            }
        )
    out = header(
        "colour.difference.delta_E_CIE1976, delta_E_CIE1994 (graphic arts and textiles), "
        "delta_E_CIE2000 on Sharma, Wu & Dalal (2005) Table 1 and on random Lab pairs"
    )
    out["tolerance"]["published_sharma_2005"] = 5e-5
    out["sharma_2005"] = sharma
    out["cases"] = cases
    return out


def cct(rng):
    cases = []
    for i in range(20):
        T = float(np.exp(rng.uniform(np.log(2000), np.log(20000))))
        # Every fourth point within |Duv| < 0.002 (Ohno's triangular solution), else up to 0.02.
        D_uv = float(rng.uniform(-0.002, 0.002) if i % 4 == 0 else rng.uniform(-0.02, 0.02))
        xy = UCS_uv_to_xy(CCT_to_uv_Ohno2013([T, D_uv]))
        uv = xy_to_UCS_uv(xy)
        cases.append(
            {
                "id": i,
                "cct_k": T,
                "duv": D_uv,
                "xy": fl(xy),
                "uv": fl(uv),
                "ohno2013": fl(uv_to_CCT_Ohno2013(uv)),
                "robertson1968": fl(uv_to_CCT_Robertson1968(uv)),
                "ohno2013_to_xy": fl(UCS_uv_to_xy(CCT_to_uv_Ohno2013([T, D_uv]))),
                "robertson1968_to_xy": fl(UCS_uv_to_xy(CCT_to_uv_Robertson1968([T, D_uv]))),
            }
        )
    out = header(
        "xy -> CCT, Duv with colour.temperature.uv_to_CCT_Ohno2013 (defaults: CIE 1931 2 deg on "
        "360-780 nm, 1000-100000 K, spacing 1.001) and uv_to_CCT_Robertson1968 on "
        "colour.xy_to_UCS_uv(xy); (CCT, Duv) -> xy with CCT_to_uv_* then UCS_uv_to_xy"
    )
    out["cases"] = cases
    return out


def spectra():
    basis = colour.colorimetry.SDS_BASIS_FUNCTIONS_CIE_ILLUMINANT_D_SERIES
    d_series = []
    for T in (4000.0, 5003.0, 6504.0, 9000.0, 25000.0):
        xy = CCT_to_xy_CIE_D(T)
        sd = colour.sd_CIE_illuminant_D_series(xy)
        sd_unrounded = colour.sd_CIE_illuminant_D_series(xy, M1_M2_rounding=False)
        d_series.append(
            {
                "cct_k": T,
                "xy": fl(xy),
                "wavelength_nm": fl(sd.wavelengths),
                "value": fl(sd.values),
                "value_unrounded_m1_m2": fl(sd_unrounded.values),
            }
        )
    shape = colour.SpectralShape(360, 830, 5)
    blackbody = []
    for T in (1000.0, 2856.0, 5000.0, 6500.0, 15000.0):
        sd = colour.sd_blackbody(T, shape)
        blackbody.append({"temperature_k": T, "wavelength_nm": fl(sd.wavelengths), "value": fl(sd.values)})
    planck = []
    for lam_nm in (300.0, 555.0, 830.0, 2000.0):
        for T in (500.0, 3000.0, 6500.0, 50000.0):
            planck.append(
                {"lambda_m": lam_nm * 1e-9, "temperature_k": T,
                 "value": fl(colour.colorimetry.planck_law(lam_nm * 1e-9, T))}
            )
    return {
        "generator": "scripts/reference/colour_reference.py",
        "colour_version": colour.__version__,
        "numpy_version": np.__version__,
        "description": "colour.sd_CIE_illuminant_D_series(CCT_to_xy_CIE_D(T)) with and without "
        "M1/M2 rounding; colour.sd_blackbody(T, SpectralShape(360, 830, 5)); "
        "colour.colorimetry.planck_law; SDS_BASIS_FUNCTIONS_CIE_ILLUMINANT_D_SERIES",
        "tolerance": dict(TOLERANCE),
        "d_series_basis": {
            "wavelength_nm": fl(basis["S0"].wavelengths),
            "S0": fl(basis["S0"].values),
            "S1": fl(basis["S1"].values),
            "S2": fl(basis["S2"].values),
        },
        "d_series": d_series,
        "blackbody": blackbody,
        "planck_law": planck,
    }


def write(fixtures_dir):
    """Writes fixtures/colour_spaces_{roundtrips,delta_e,cct,spectra}.json into ``fixtures_dir``."""
    os.makedirs(fixtures_dir, exist_ok=True)
    rng = np.random.default_rng(SEED)
    dump(os.path.join(fixtures_dir, "colour_spaces_roundtrips.json"), roundtrips(rng))
    dump(os.path.join(fixtures_dir, "colour_spaces_delta_e.json"), delta_e(rng))
    dump(os.path.join(fixtures_dir, "colour_spaces_cct.json"), cct(rng))
    with open(os.path.join(fixtures_dir, "colour_spaces_spectra.json"), "w") as fh:
        json.dump(spectra(), fh, separators=(",", ":"))
        fh.write("\n")


if __name__ == "__main__":
    write(os.path.join(ROOT, "fixtures"))
    print(f"fixtures/colour_spaces_*.json written with colour {colour.__version__}, numpy {np.__version__}")
