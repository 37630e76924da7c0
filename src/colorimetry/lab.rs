//! CIE 1976 L\*a\*b\* and its cylindrical form LCh(ab).
//!
//! With the white's tristimulus values `(Xn, Yn, Zn)` from its xy at `Yn = 1`:
//!
//! ```text
//! f(t) = t^(1/3)                   if t > (24/116)^3   (ε = 216/24389)
//!        (841/108)·t + 16/116      otherwise           (= (κ·t + 16)/116, κ = 24389/27)
//! L* = 116·f(Y/Yn) − 16,   a* = 500·(f(X/Xn) − f(Y/Yn)),   b* = 200·(f(Y/Yn) − f(Z/Zn))
//! C*ab = hypot(a*, b*),    hab = atan2(b*, a*) in degrees, wrapped to [0, 360)
//! ```
//!
//! and the inverse `f⁻¹(f) = f³` if `f > 24/116`, else `(f − 16/116)·108/841`.
//!
//! Units: XYZ on the 0–1 scale (relative to a perfect diffuser of Y = 1); L\* in 0–100; a\*, b\*,
//! C\* in the same units; h in degrees. White points are given as CIE 1931 xy chromaticities.
//!
//! Reference: CIE 015:2018 *Colorimetry*, §8.2.1.
//!
//! colour-science counterparts: `colour.XYZ_to_Lab`, `colour.Lab_to_XYZ` (via
//! `colour.colorimetry.intermediate_lightness_function_CIE1976` and
//! `intermediate_luminance_function_CIE1976`), `colour.Lab_to_LCHab`, `colour.LCHab_to_Lab`.

use crate::colorimetry::xyy::xy_to_xyz;
use crate::error::{Error, Result};

/// The CIE constant ε = (24/116)³ = 216/24389, threshold of the cube-root segment.
pub fn cie_epsilon() -> f64 {
    (24.0f64 / 116.0).powf(3.0)
}

/// The CIE constant κ = 24389/27 (slope of L\* on its linear segment).
pub const CIE_KAPPA: f64 = 24389.0 / 27.0;

/// `f(Y/Yn)` of CIE 1976 (`colour.colorimetry.intermediate_lightness_function_CIE1976`), with
/// colour's signed power for negative ratios.
pub fn intermediate_lightness_cie1976(y: f64, y_n: f64) -> f64 {
    let r = y / y_n;
    if r > cie_epsilon() {
        spow(r, 1.0 / 3.0)
    } else {
        (841.0 / 108.0) * r + 16.0 / 116.0
    }
}

/// Inverse of [`intermediate_lightness_cie1976`] times `Yn`
/// (`colour.colorimetry.intermediate_luminance_function_CIE1976`).
pub fn intermediate_luminance_cie1976(f: f64, y_n: f64) -> f64 {
    if f > 24.0 / 116.0 {
        y_n * f.powf(3.0)
    } else {
        y_n * (f - 16.0 / 116.0) * (108.0 / 841.0)
    }
}

/// colour's `spow`: `sign(a)·|a|^p`.
pub(crate) fn spow(a: f64, p: f64) -> f64 {
    if a == 0.0 {
        return 0.0;
    }
    a.signum() * a.abs().powf(p)
}

/// The white's XYZ (Y = 1) from its xy, validated.
fn white_xyz(white_xy: [f64; 2]) -> Result<[f64; 3]> {
    if !(white_xy[0].is_finite() && white_xy[1].is_finite())
        || white_xy[1] <= 0.0
        || white_xy[0] < 0.0
    {
        return Err(Error::invalid(
            "white point",
            format!(
                "xy = ({}, {}); expected finite chromaticities with x ≥ 0 and y > 0",
                white_xy[0], white_xy[1]
            ),
        ));
    }
    Ok(xy_to_xyz(white_xy))
}

/// XYZ (0–1) → CIE L\*a\*b\* relative to the white of chromaticity `white_xy`
/// (`colour.XYZ_to_Lab(XYZ, illuminant)`).
pub fn xyz_to_lab(xyz: [f64; 3], white_xy: [f64; 2]) -> Result<[f64; 3]> {
    let [x_n, y_n, z_n] = white_xyz(white_xy)?;
    let fx = intermediate_lightness_cie1976(xyz[0], x_n);
    let fy = intermediate_lightness_cie1976(xyz[1], y_n);
    let fz = intermediate_lightness_cie1976(xyz[2], z_n);
    Ok([116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz)])
}

/// CIE L\*a\*b\* → XYZ (0–1) (`colour.Lab_to_XYZ(Lab, illuminant)`).
pub fn lab_to_xyz(lab: [f64; 3], white_xy: [f64; 2]) -> Result<[f64; 3]> {
    let [x_n, y_n, z_n] = white_xyz(white_xy)?;
    let [l, a, b] = lab;
    let fy = (l + 16.0) / 116.0;
    let fx = a / 500.0 + fy;
    let fz = fy - b / 200.0;
    Ok([
        intermediate_luminance_cie1976(fx, x_n),
        intermediate_luminance_cie1976(fy, y_n),
        intermediate_luminance_cie1976(fz, z_n),
    ])
}

/// L\*a\*b\* → L\*C\*h with h in degrees in [0, 360) (`colour.Lab_to_LCHab`).
pub fn lab_to_lch(lab: [f64; 3]) -> [f64; 3] {
    let [l, a, b] = lab;
    let c = a.hypot(b);
    let h = b.atan2(a).to_degrees().rem_euclid(360.0);
    [l, c, h]
}

/// L\*C\*h (h in degrees) → L\*a\*b\* (`colour.LCHab_to_Lab`).
pub fn lch_to_lab(lch: [f64; 3]) -> [f64; 3] {
    let [l, c, h] = lch;
    let phi = h.to_radians();
    [l, c * phi.cos(), c * phi.sin()]
}

#[cfg(test)]
mod tests {
    use super::*;

    const D65: [f64; 2] = [0.3127, 0.329];

    #[test]
    fn white_maps_to_l_100_and_black_to_zero() {
        let lab = xyz_to_lab(xy_to_xyz(D65), D65).unwrap();
        assert!((lab[0] - 100.0).abs() < 1e-12 && lab[1].abs() < 1e-12 && lab[2].abs() < 1e-12);
        assert_eq!(xyz_to_lab([0.0; 3], D65).unwrap(), [0.0, 0.0, 0.0]);
    }

    #[test]
    fn lab_round_trips_on_both_segments() {
        for xyz in [[0.2065, 0.1219, 0.0514], [0.001, 0.002, 0.0005]] {
            let back = lab_to_xyz(xyz_to_lab(xyz, D65).unwrap(), D65).unwrap();
            for i in 0..3 {
                assert!((back[i] - xyz[i]).abs() < 1e-15, "{xyz:?} → {back:?}");
            }
        }
    }

    #[test]
    fn lch_hue_is_wrapped_to_0_360() {
        let lch = lab_to_lch([50.0, 10.0, -10.0]);
        assert!((lch[2] - 315.0).abs() < 1e-12);
        let lab = lch_to_lab(lch);
        assert!((lab[1] - 10.0).abs() < 1e-12 && (lab[2] + 10.0).abs() < 1e-12);
    }

    #[test]
    fn a_white_with_y_zero_is_rejected() {
        assert!(xyz_to_lab([0.5; 3], [0.3, 0.0]).is_err());
    }
}
