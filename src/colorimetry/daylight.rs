//! CIE daylight (D-series) illuminants from a correlated colour temperature.
//!
//! Chromaticity of the daylight locus for `T` in 4000–25000 K (CIE 015:2018 eq. 4.3–4.5):
//!
//! ```text
//! x_D = −4.6070e9/T³ + 2.9678e6/T² + 0.09911e3/T + 0.244063     (4000 K ≤ T ≤ 7000 K)
//! x_D = −2.0064e9/T³ + 1.9018e6/T² + 0.24748e3/T + 0.23704      (7000 K < T ≤ 25000 K)
//! y_D = −3.000·x_D² + 2.870·x_D − 0.275
//! ```
//!
//! Relative spectral power from the basis functions (CIE 015:2018 eq. 4.6–4.8):
//!
//! ```text
//! M  = 0.0241 + 0.2562·x − 0.7341·y
//! M1 = (−1.3515 − 1.7703·x + 5.9114·y) / M,    M2 = (0.0300 − 31.4424·x + 30.0717·y) / M
//! S(λ) = S0(λ) + M1·S1(λ) + M2·S2(λ)
//! ```
//!
//! with `M1`, `M2` rounded to 3 decimals (CIE's recommendation and colour 0.4.7's default
//! `M1_M2_rounding=True`; numpy's round-half-to-even), on the basis' grid 300–830 nm every 5 nm.
//! Values are relative (≈ 100 at 560 nm).
//!
//! The canonical D65 is not "6500 K": its CCT is 6500 K on the temperature scale of 1931
//! (`c2 = 1.4380e-2 m·K`), i.e. `6500·1.4388/1.4380 ≈ 6503.6 K` with today's `c2`. Use
//! [`D65_CCT_K`] (or 6504 K) to reproduce D65, and likewise `5000·1.4388/1.4380` for D50.
//!
//! colour-science counterparts: `colour.temperature.CCT_to_xy_CIE_D`,
//! `colour.colorimetry.daylight_locus_function`, `colour.sd_CIE_illuminant_D_series`,
//! `colour.colorimetry.SDS_BASIS_FUNCTIONS_CIE_ILLUMINANT_D_SERIES`. Unlike colour (which only
//! warns), a CCT outside 4000–25000 K is an error here.

use crate::calib;
use crate::error::{Error, Result};
use crate::spectrum::Spectrum;

/// Lowest CCT of the CIE daylight locus (K).
pub const CCT_D_SERIES_MIN_K: f64 = 4000.0;
/// Highest CCT of the CIE daylight locus (K).
pub const CCT_D_SERIES_MAX_K: f64 = 25000.0;
/// CCT that reproduces CIE D65 with today's `c2`: `6500·1.4388/1.4380` K.
pub const D65_CCT_K: f64 = 6500.0 * 1.4388 / 1.4380;

/// y of the CIE daylight locus at `x` (`colour.colorimetry.daylight_locus_function`).
pub fn daylight_locus_y(x: f64) -> f64 {
    -3.000 * (x * x) + 2.870 * x - 0.275
}

/// xy of the CIE daylight illuminant of correlated colour temperature `cct_k`
/// (`colour.temperature.CCT_to_xy_CIE_D`); valid for 4000–25000 K.
pub fn cct_to_xy_cie_d(cct_k: f64) -> Result<[f64; 2]> {
    if !(cct_k.is_finite() && (CCT_D_SERIES_MIN_K..=CCT_D_SERIES_MAX_K).contains(&cct_k)) {
        return Err(Error::invalid(
            "correlated colour temperature",
            format!(
                "{cct_k} K is outside the CIE daylight locus; expected {CCT_D_SERIES_MIN_K}–{CCT_D_SERIES_MAX_K} K"
            ),
        ));
    }
    let t3 = cct_k.powf(3.0);
    let t2 = cct_k * cct_k;
    let x = if cct_k <= 7000.0 {
        -4.607 * 1e9 / t3 + 2.9678 * 1e6 / t2 + 0.09911 * 1e3 / cct_k + 0.244063
    } else {
        -2.0064 * 1e9 / t3 + 1.9018 * 1e6 / t2 + 0.24748 * 1e3 / cct_k + 0.23704
    };
    Ok([x, daylight_locus_y(x)])
}

/// numpy's `around(v, 3)`: scale, round half to even, unscale.
fn around3(v: f64) -> f64 {
    (v * 1000.0).round_ties_even() / 1000.0
}

/// The coefficients `[M1, M2]` of the D-series basis for chromaticity `xy`, rounded to 3
/// decimals when `rounding` (colour's `M1_M2_rounding`).
pub fn d_series_m1_m2(xy: [f64; 2], rounding: bool) -> Result<[f64; 2]> {
    let [x, y] = xy;
    let m = 0.0241 + 0.2562 * x - 0.7341 * y;
    if !(x.is_finite() && y.is_finite()) || m == 0.0 {
        return Err(Error::invalid(
            "chromaticity",
            format!("xy = ({x}, {y}); expected finite coordinates off the line M = 0"),
        ));
    }
    let m1 = (-1.3515 - 1.7703 * x + 5.9114 * y) / m;
    let m2 = (0.0300 - 31.4424 * x + 30.0717 * y) / m;
    Ok(if rounding {
        [around3(m1), around3(m2)]
    } else {
        [m1, m2]
    })
}

/// The CIE D-series relative spectral power distribution of chromaticity `xy` on 300–830 nm every
/// 5 nm, with M1/M2 rounded to 3 decimals (`colour.sd_CIE_illuminant_D_series(xy)`).
pub fn sd_cie_illuminant_d_series(xy: [f64; 2]) -> Result<Spectrum> {
    sd_cie_illuminant_d_series_with(xy, true)
}

/// As [`sd_cie_illuminant_d_series`], choosing whether M1/M2 are rounded
/// (`colour.sd_CIE_illuminant_D_series(xy, M1_M2_rounding)`).
pub fn sd_cie_illuminant_d_series_with(xy: [f64; 2], m1_m2_rounding: bool) -> Result<Spectrum> {
    let [m1, m2] = d_series_m1_m2(xy, m1_m2_rounding)?;
    let basis = calib::d_series_basis();
    let idx = |name: &str| {
        basis.column_index(name).ok_or_else(|| Error::Numerical {
            what: "calib/d_series_basis.csv".into(),
            reason: format!("embedded table lacks column {name}"),
        })
    };
    let (s0, s1, s2) = (idx("S0")?, idx("S1")?, idx("S2")?);
    let w = basis.columns[0].clone();
    let values = (0..w.len())
        .map(|i| basis.columns[s0][i] + m1 * basis.columns[s1][i] + m2 * basis.columns[s2][i])
        .collect();
    Spectrum::new(
        format!("CIE xy ({}, {}) - CIE Illuminant D Series", xy[0], xy[1]),
        w,
        values,
    )
}

/// The CIE D-series illuminant of correlated colour temperature `cct_k` (4000–25000 K):
/// `sd_cie_illuminant_d_series(cct_to_xy_cie_d(cct_k))`. For D65 pass [`D65_CCT_K`].
pub fn sd_d_series_from_cct(cct_k: f64) -> Result<Spectrum> {
    let sd = sd_cie_illuminant_d_series(cct_to_xy_cie_d(cct_k)?)?;
    Ok(sd.with_name(format!("CIE D-series {cct_k} K")))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn d65_cct_reproduces_d65_chromaticity() {
        // colour's D65 xy (0.3127, 0.3290) is integrated from the tabulated spectrum, not read
        // off the locus; the two agree to ≈ 1.3e-4.
        let xy = cct_to_xy_cie_d(D65_CCT_K).unwrap();
        assert!(
            (xy[0] - 0.3127).abs() < 2e-4 && (xy[1] - 0.3290).abs() < 2e-4,
            "{xy:?}"
        );
    }

    #[test]
    fn cct_outside_the_daylight_locus_is_an_error() {
        assert!(cct_to_xy_cie_d(3999.0).is_err());
        assert!(cct_to_xy_cie_d(25001.0).is_err());
        assert!(sd_d_series_from_cct(f64::NAN).is_err());
    }

    #[test]
    fn d_series_spectrum_is_on_the_basis_grid_and_near_100_at_560_nm() {
        let sd = sd_d_series_from_cct(D65_CCT_K).unwrap();
        assert_eq!(sd.wavelengths()[0], 300.0);
        assert_eq!(*sd.wavelengths().last().unwrap(), 830.0);
        let i560 = sd.wavelengths().iter().position(|&w| w == 560.0).unwrap();
        assert!((sd.values()[i560] - 100.0).abs() < 0.5);
    }

    #[test]
    fn m1_m2_rounding_is_half_to_even() {
        assert_eq!(around3(0.0125), 0.012);
        assert_eq!(around3(-1.2345), -1.234);
    }
}
