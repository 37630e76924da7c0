//! Refractive index of standard air and conversion between wavelengths in air and in vacuum.
//!
//! Standard dry air (15 °C, 101 325 Pa, 450 ppm CO₂) by Ciddor (1996), Appl. Opt. 35, 1566,
//! Eq. (1) with σ = 1/λ_vac in µm⁻¹:
//!
//! n_air − 1 = 0.05792105 / (238.0185 − σ²) + 0.00167917 / (57.362 − σ²)
//!
//! (the formula refractiveindex.info uses for its air page, valid 0.23–1.69 µm). Glass
//! catalogues (Schott) give n relative to air at wavelengths in air; refractiveindex.info marks
//! absolute indices with `SPECS: n_absolute: true` and vacuum wavelengths with
//! `wavelength_vacuum: true`. Converting: λ_vac = n_air(λ_vac) λ_air (solved by fixed-point
//! iteration, which converges in a few steps because n_air − 1 ≈ 3 × 10⁻⁴), and
//! n_absolute = n_relative · n_air.

/// n of standard air (Ciddor 1996) at the vacuum wavelength `lambda_vac_nm`.
pub fn n_air_ciddor1996(lambda_vac_nm: f64) -> f64 {
    let s2 = (1e3 / lambda_vac_nm).powi(2);
    1.0 + 0.05792105 / (238.0185 - s2) + 0.00167917 / (57.362 - s2)
}

/// The vacuum wavelength of light whose wavelength in standard air is `lambda_air_nm`.
pub fn air_to_vacuum_nm(lambda_air_nm: f64) -> f64 {
    let mut vac = lambda_air_nm;
    for _ in 0..8 {
        vac = lambda_air_nm * n_air_ciddor1996(vac);
    }
    vac
}

/// The wavelength in standard air of light of vacuum wavelength `lambda_vac_nm`.
pub fn vacuum_to_air_nm(lambda_vac_nm: f64) -> f64 {
    lambda_vac_nm / n_air_ciddor1996(lambda_vac_nm)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn standard_air_at_the_d_line_is_about_1_000277() {
        // Ciddor 1996 standard air at 587.6 nm: n − 1 = 2.7717e-4 (refractiveindex.info)
        let n = n_air_ciddor1996(587.725);
        assert!((n - 1.0 - 2.7717e-4).abs() < 2e-7, "{}", n - 1.0);
    }

    #[test]
    fn air_and_vacuum_wavelengths_round_trip() {
        for l in [380.0, 587.5618, 780.0] {
            let back = vacuum_to_air_nm(air_to_vacuum_nm(l));
            assert!((back - l).abs() < 1e-10);
        }
    }
}
