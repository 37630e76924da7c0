//! RGB colour spaces (sRGB, Display P3, ITU-R BT.2020, ACEScg): matrices, transfer functions,
//! XYZ ↔ RGB.
//!
//! Normalised primary matrix (SMPTE RP 177-1993): with primaries `(xr, yr), (xg, yg), (xb, yb)`
//! and white `(xw, yw)`,
//!
//! ```text
//! P = [[xr, xg, xb], [yr, yg, yb], [1−xr−yr, 1−xg−yg, 1−xb−yb]]
//! S = P⁻¹ · (xw/yw, 1, (1−xw−yw)/yw)ᵀ,          NPM = P · diag(S)      (RGB → XYZ)
//! ```
//!
//! XYZ → RGB (colour's `XYZ_to_RGB`): adapt XYZ from the *illuminant* under which it was seen
//! to the space's white with a chromatic adaptation transform (optional), multiply by the
//! space's XYZ → RGB matrix, then optionally apply the encoding transfer function:
//!
//! - sRGB / Display P3 (IEC 61966-2-1 inverse EOTF): `V = 12.92·L` if `L ≤ 0.0031308`, else
//!   `1.055·L^(1/2.4) − 0.055`;
//! - ITU-R BT.2020 (colour's `cctf_encoding` for it is the BT.2020 OETF, 10-bit constants
//!   α = 1.099, β = 0.018): `E' = 4.5·E` if `E < β`, else `α·E^0.45 − (α − 1)`;
//! - ACEScg: linear.
//!
//! Powers of negative values are signed (colour's `spow`). Units: XYZ and RGB on the 0–1 scale.
//!
//! As in colour, sRGB uses the *published* IEC 61966-2-1 matrices (4 decimals), not the NPM of
//! its primaries (they differ by ≈ 1e-4); the other spaces use the NPM and its inverse.
//!
//! colour-science counterparts: `colour.RGB_COLOURSPACES`, `colour.normalised_primary_matrix`,
//! `colour.XYZ_to_RGB`, `colour.RGB_to_XYZ`, `colour.XYZ_to_sRGB`, `colour.sRGB_to_XYZ`,
//! `colour.models.eotf_inverse_sRGB`, `eotf_sRGB`, `oetf_BT2020`, `oetf_inverse_BT2020`.

use crate::calib;
use crate::colorimetry::cat::{chromatic_adaptation_matrix, Cat};
use crate::colorimetry::lab::spow;
use crate::colorimetry::xyy::xy_to_xyz;
use crate::error::{Error, Result};
use crate::math::linalg::{mat3_inv, mat3_mul_vec, Mat3};

/// colour's `MATRIX_XYZ_TO_sRGB` (IEC 61966-2-1:1999, 4 decimals).
pub const MATRIX_XYZ_TO_SRGB: Mat3 = [
    [3.2406, -1.5372, -0.4986],
    [-0.9689, 1.8758, 0.0415],
    [0.0557, -0.2040, 1.0570],
];

/// CIE 1931 xy of D65 as colour tabulates it (`CCS_ILLUMINANTS[...]["D65"]`).
pub const D65_XY: [f64; 2] = [0.3127, 0.329];

/// Accepted names of [`RgbSpace::from_name`] (aliases after the `/`).
pub const RGB_SPACE_NAMES: &str = "srgb, display-p3/p3, rec2020/bt2020, acescg";

/// A colour component transfer function.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Transfer {
    /// IEC 61966-2-1 sRGB (also Display P3).
    Srgb,
    /// ITU-R BT.2020 OETF (10-bit constants).
    Rec2020,
    /// Identity.
    Linear,
}

impl Transfer {
    /// Linear → encoded (colour's `cctf_encoding`).
    pub fn encode(self, v: f64) -> f64 {
        match self {
            Transfer::Srgb => eotf_inverse_srgb(v),
            Transfer::Rec2020 => oetf_bt2020(v),
            Transfer::Linear => v,
        }
    }

    /// Encoded → linear (colour's `cctf_decoding`).
    pub fn decode(self, v: f64) -> f64 {
        match self {
            Transfer::Srgb => eotf_srgb(v),
            Transfer::Rec2020 => oetf_inverse_bt2020(v),
            Transfer::Linear => v,
        }
    }

    fn from_key(key: &str) -> Result<Transfer> {
        match key {
            "srgb" => Ok(Transfer::Srgb),
            "rec2020" => Ok(Transfer::Rec2020),
            "linear" => Ok(Transfer::Linear),
            other => Err(Error::UnknownName {
                kind: "transfer function",
                name: other.to_string(),
                expected: "srgb, rec2020, linear".into(),
            }),
        }
    }
}

/// sRGB inverse EOTF, linear → encoded (`colour.models.eotf_inverse_sRGB`).
pub fn eotf_inverse_srgb(l: f64) -> f64 {
    if l <= 0.0031308 {
        l * 12.92
    } else {
        1.055 * spow(l, 1.0 / 2.4) - 0.055
    }
}

/// sRGB EOTF, encoded → linear (`colour.models.eotf_sRGB`).
pub fn eotf_srgb(v: f64) -> f64 {
    if eotf_inverse_srgb(0.0031308) >= v {
        v / 12.92
    } else {
        spow((v + 0.055) / 1.055, 2.4)
    }
}

const BT2020_ALPHA: f64 = 1.099;
const BT2020_BETA: f64 = 0.018;

/// ITU-R BT.2020 OETF, scene-linear → non-linear (`colour.models.oetf_BT2020`, 10-bit).
pub fn oetf_bt2020(e: f64) -> f64 {
    if BT2020_BETA > e {
        e * 4.5
    } else {
        BT2020_ALPHA * spow(e, 0.45) - (BT2020_ALPHA - 1.0)
    }
}

/// Inverse ITU-R BT.2020 OETF (`colour.models.oetf_inverse_BT2020`, 10-bit).
pub fn oetf_inverse_bt2020(e_p: f64) -> f64 {
    if e_p < oetf_bt2020(BT2020_BETA) {
        e_p / 4.5
    } else {
        spow((e_p + (BT2020_ALPHA - 1.0)) / BT2020_ALPHA, 1.0 / 0.45)
    }
}

/// An RGB colour space.
#[derive(Debug, Clone, PartialEq)]
pub struct RgbSpace {
    /// lumifit's key: `srgb`, `display-p3`, `rec2020`, `acescg`.
    pub key: String,
    /// colour's name (`sRGB`, `Display P3`, `ITU-R BT.2020`, `ACEScg`).
    pub name: String,
    /// CIE 1931 xy of the R, G, B primaries.
    pub primaries_xy: [[f64; 2]; 3],
    /// CIE 1931 xy of the white point.
    pub whitepoint_xy: [f64; 2],
    /// Encoding transfer function.
    pub transfer: Transfer,
    /// RGB → XYZ matrix as colour uses it.
    pub matrix_rgb_to_xyz: Mat3,
    /// XYZ → RGB matrix as colour uses it.
    pub matrix_xyz_to_rgb: Mat3,
}

impl RgbSpace {
    /// A space by name (case-insensitive): `srgb`, `display-p3` / `p3`, `rec2020` / `bt2020`,
    /// `acescg`. Data come from `calib/colourspaces.json` (exported from colour).
    pub fn from_name(name: &str) -> Result<RgbSpace> {
        let lower = name.trim().to_ascii_lowercase();
        let key = match lower.as_str() {
            "srgb" => "srgb",
            "display-p3" | "displayp3" | "display p3" | "p3" | "p3-d65" => "display-p3",
            "rec2020" | "rec.2020" | "bt2020" | "bt.2020" | "itu-r bt.2020" => "rec2020",
            "acescg" => "acescg",
            _ => {
                return Err(Error::UnknownName {
                    kind: "RGB colour space",
                    name: name.to_string(),
                    expected: RGB_SPACE_NAMES.into(),
                })
            }
        };
        let data = calib::colourspaces()
            .rgb_colourspaces
            .get(key)
            .ok_or_else(|| Error::Numerical {
                what: "calib/colourspaces.json".into(),
                reason: format!("embedded table lacks the '{key}' colour space"),
            })?;
        let transfer = Transfer::from_key(&data.transfer)?;
        let matrix_rgb_to_xyz = data.matrix_rgb_to_xyz;
        let matrix_xyz_to_rgb = if key == "srgb" {
            MATRIX_XYZ_TO_SRGB
        } else {
            mat3_inv(&matrix_rgb_to_xyz)?
        };
        Ok(RgbSpace {
            key: key.to_string(),
            name: data.colour_name.clone(),
            primaries_xy: data.primaries_xy,
            whitepoint_xy: data.whitepoint_xy,
            transfer,
            matrix_rgb_to_xyz,
            matrix_xyz_to_rgb,
        })
    }

    /// sRGB (IEC 61966-2-1).
    pub fn srgb() -> Result<RgbSpace> {
        RgbSpace::from_name("srgb")
    }
}

fn check_xy(field: &str, xy: [f64; 2]) -> Result<()> {
    if xy[0].is_finite() && xy[1].is_finite() && xy[1] > 0.0 {
        Ok(())
    } else {
        Err(Error::invalid(
            field,
            format!(
                "xy = ({}, {}); expected finite chromaticities with y > 0",
                xy[0], xy[1]
            ),
        ))
    }
}

/// The normalised primary matrix RGB → XYZ (`colour.normalised_primary_matrix`).
pub fn normalised_primary_matrix(primaries_xy: [[f64; 2]; 3], white_xy: [f64; 2]) -> Result<Mat3> {
    for p in primaries_xy {
        if !(p[0].is_finite() && p[1].is_finite()) {
            return Err(Error::invalid(
                "primaries",
                format!("{primaries_xy:?}; expected finite xy"),
            ));
        }
    }
    check_xy("white point", white_xy)?;
    let mut p: Mat3 = [[0.0; 3]; 3];
    for (j, xy) in primaries_xy.iter().enumerate() {
        p[0][j] = xy[0];
        p[1][j] = xy[1];
        p[2][j] = 1.0 - xy[0] - xy[1];
    }
    let w = xy_to_xyz(white_xy);
    let p_inv = mat3_inv(&p).map_err(|_| {
        Error::invalid(
            "primaries",
            format!("{primaries_xy:?} are collinear; expected a triangle"),
        )
    })?;
    let s = mat3_mul_vec(&p_inv, w);
    let mut npm = p;
    for row in npm.iter_mut() {
        for (j, cell) in row.iter_mut().enumerate() {
            *cell *= s[j];
        }
    }
    Ok(npm)
}

/// XYZ (0–1) seen under the white `illuminant_xy` → RGB of `space`
/// (`colour.XYZ_to_RGB(XYZ, colourspace, illuminant, chromatic_adaptation_transform,
/// apply_cctf_encoding)`).
///
/// colour's defaults are `illuminant = space.whitepoint_xy`, `cat = Some(Cat::Cat02)`,
/// `encode = false`. With `cat = None` no adaptation is made (the illuminant is then ignored).
pub fn xyz_to_rgb(
    xyz: [f64; 3],
    illuminant_xy: [f64; 2],
    space: &RgbSpace,
    cat: Option<Cat>,
    encode: bool,
) -> Result<[f64; 3]> {
    let mut v = xyz;
    if let Some(cat) = cat {
        check_xy("illuminant", illuminant_xy)?;
        let m = chromatic_adaptation_matrix(
            xy_to_xyz(illuminant_xy),
            xy_to_xyz(space.whitepoint_xy),
            cat,
        )?;
        v = mat3_mul_vec(&m, v);
    }
    let mut rgb = mat3_mul_vec(&space.matrix_xyz_to_rgb, v);
    if encode {
        for c in rgb.iter_mut() {
            *c = space.transfer.encode(*c);
        }
    }
    Ok(rgb)
}

/// RGB of `space` → XYZ (0–1) seen under the white `illuminant_xy`
/// (`colour.RGB_to_XYZ(RGB, colourspace, illuminant, chromatic_adaptation_transform,
/// apply_cctf_decoding)`); the inverse of [`xyz_to_rgb`].
pub fn rgb_to_xyz(
    rgb: [f64; 3],
    illuminant_xy: [f64; 2],
    space: &RgbSpace,
    cat: Option<Cat>,
    decode: bool,
) -> Result<[f64; 3]> {
    let mut v = rgb;
    if decode {
        for c in v.iter_mut() {
            *c = space.transfer.decode(*c);
        }
    }
    let mut xyz = mat3_mul_vec(&space.matrix_rgb_to_xyz, v);
    if let Some(cat) = cat {
        check_xy("illuminant", illuminant_xy)?;
        let m = chromatic_adaptation_matrix(
            xy_to_xyz(space.whitepoint_xy),
            xy_to_xyz(illuminant_xy),
            cat,
        )?;
        xyz = mat3_mul_vec(&m, xyz);
    }
    Ok(xyz)
}

/// XYZ → sRGB with colour's `XYZ_to_sRGB` conventions: CAT02 from `illuminant_xy` (colour's
/// default [`D65_XY`]), encoded when `encode` (colour's default `true`).
pub fn xyz_to_srgb(xyz: [f64; 3], illuminant_xy: [f64; 2], encode: bool) -> Result<[f64; 3]> {
    xyz_to_rgb(
        xyz,
        illuminant_xy,
        &RgbSpace::srgb()?,
        Some(Cat::Cat02),
        encode,
    )
}

/// sRGB → XYZ with colour's `sRGB_to_XYZ` conventions (CAT02 to `illuminant_xy`, decoded when
/// `decode`).
pub fn srgb_to_xyz(rgb: [f64; 3], illuminant_xy: [f64; 2], decode: bool) -> Result<[f64; 3]> {
    rgb_to_xyz(
        rgb,
        illuminant_xy,
        &RgbSpace::srgb()?,
        Some(Cat::Cat02),
        decode,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_space_loads_by_name_and_alias() {
        for (name, key) in [
            ("sRGB", "srgb"),
            ("p3", "display-p3"),
            ("Display-P3", "display-p3"),
            ("bt2020", "rec2020"),
            ("rec2020", "rec2020"),
            ("ACEScg", "acescg"),
        ] {
            assert_eq!(RgbSpace::from_name(name).unwrap().key, key);
        }
        assert!(matches!(
            RgbSpace::from_name("adobe-rgb"),
            Err(Error::UnknownName { .. })
        ));
    }

    #[test]
    fn transfer_functions_invert() {
        for t in [Transfer::Srgb, Transfer::Rec2020, Transfer::Linear] {
            for v in [-0.2, 0.0, 0.001, 0.02, 0.18, 0.5, 1.0, 1.3] {
                let back = t.decode(t.encode(v));
                assert!((back - v).abs() < 1e-12, "{t:?} {v} → {back}");
            }
        }
    }

    #[test]
    fn rgb_round_trips_through_xyz() {
        let space = RgbSpace::from_name("rec2020").unwrap();
        let xyz = [0.3, 0.4, 0.2];
        let rgb = xyz_to_rgb(xyz, [0.44758, 0.40745], &space, Some(Cat::Bradford), true).unwrap();
        let back = rgb_to_xyz(rgb, [0.44758, 0.40745], &space, Some(Cat::Bradford), true).unwrap();
        for i in 0..3 {
            assert!((back[i] - xyz[i]).abs() < 1e-12);
        }
    }
}
