//! Planck's law and blackbody spectral distributions.
//!
//! Spectral radiance of a blackbody at temperature `T` (K) and wavelength `λ` (m):
//!
//! ```text
//! L(λ, T) = c1 / (π · n² · λ⁵) · 1 / (exp(c2 / (n·λ·T)) − 1)      [W·sr⁻¹·m⁻³]
//! ```
//!
//! with colour's constants `c1 = 3.741771e-16 W·m²` (first radiation constant 2πhc²),
//! `c2 = 1.4388e-2 m·K` (the ITS-90 second radiation constant used by CIE 015) and refractive
//! index `n = 1`. [`sd_blackbody`] samples it at the shape's wavelengths and multiplies by 1e-9,
//! i.e. values are per nanometre (W·sr⁻¹·m⁻²·nm⁻¹), exactly like colour.
//!
//! Reference: CIE 015:2018 *Colorimetry*, §B.1 (Planckian radiator).
//!
//! colour-science counterparts: `colour.colorimetry.planck_law`, `colour.sd_blackbody`
//! (`CONSTANT_C1`, `CONSTANT_C2`, `CONSTANT_N`).

use std::f64::consts::PI;

use crate::error::{Error, Result};
use crate::spectrum::{SpectralShape, Spectrum};

/// First radiation constant `c1 = 2πhc²` as colour uses it (W·m²).
pub const PLANCK_C1: f64 = 3.741771e-16;
/// Second radiation constant `c2 = hc/k` as colour uses it (m·K).
pub const PLANCK_C2: f64 = 1.4388e-2;
/// Refractive index of the medium.
pub const PLANCK_N: f64 = 1.0;

/// Planck's law with explicit constants; no validation (callers check `λ, T > 0`).
pub(crate) fn planck_law_unchecked(
    lambda_m: f64,
    temperature_k: f64,
    c1: f64,
    c2: f64,
    n: f64,
) -> f64 {
    let d = 1.0 / (c2 / (n * lambda_m * temperature_k)).exp_m1();
    ((c1 * n.powf(-2.0) * lambda_m.powf(-5.0)) / PI) * d
}

fn check_temperature(temperature_k: f64) -> Result<()> {
    if temperature_k.is_finite() && temperature_k > 0.0 {
        Ok(())
    } else {
        Err(Error::invalid(
            "temperature",
            format!("{temperature_k} K; expected a finite temperature > 0 K"),
        ))
    }
}

/// Spectral radiance (W·sr⁻¹·m⁻³) of a blackbody at `temperature_k` and `lambda_m` metres
/// (`colour.colorimetry.planck_law`).
pub fn planck_law(lambda_m: f64, temperature_k: f64) -> Result<f64> {
    if !(lambda_m.is_finite() && lambda_m > 0.0) {
        return Err(Error::invalid(
            "wavelength",
            format!("{lambda_m} m; expected a finite wavelength > 0 m"),
        ));
    }
    check_temperature(temperature_k)?;
    Ok(planck_law_unchecked(
        lambda_m,
        temperature_k,
        PLANCK_C1,
        PLANCK_C2,
        PLANCK_N,
    ))
}

/// The blackbody spectral distribution at `temperature_k` on `shape`, per nanometre
/// (`colour.sd_blackbody(temperature, shape)`). Named like colour: `"{T}K Blackbody"`.
pub fn sd_blackbody(temperature_k: f64, shape: &SpectralShape) -> Result<Spectrum> {
    check_temperature(temperature_k)?;
    let w = shape.wavelengths();
    if let Some(bad) = w.iter().find(|&&l| l <= 0.0) {
        return Err(Error::invalid(
            "spectral shape",
            format!("{shape} contains the wavelength {bad} nm; expected positive wavelengths"),
        ));
    }
    let values = w
        .iter()
        .map(|&l| {
            planck_law_unchecked(l * 1e-9, temperature_k, PLANCK_C1, PLANCK_C2, PLANCK_N) * 1e-9
        })
        .collect();
    Spectrum::new(format!("{temperature_k}K Blackbody"), w, values)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wien_peak_is_near_2898_um_k_over_t() {
        let shape = SpectralShape::new(300.0, 1500.0, 1.0).unwrap();
        let sd = sd_blackbody(3000.0, &shape).unwrap();
        let (i, _) = sd
            .values()
            .iter()
            .enumerate()
            .fold((0, f64::MIN), |b, (i, &v)| if v > b.1 { (i, v) } else { b });
        assert!((sd.wavelengths()[i] - 2.8978e6 / 3000.0).abs() < 2.0);
    }

    #[test]
    fn non_positive_temperature_is_an_error() {
        let shape = SpectralShape::new(360.0, 830.0, 5.0).unwrap();
        assert!(sd_blackbody(0.0, &shape).is_err());
        assert!(sd_blackbody(-5.0, &shape).is_err());
        assert!(planck_law(555e-9, f64::NAN).is_err());
        assert!(planck_law(0.0, 5000.0).is_err());
    }
}
