//! A per-channel continuum drawn as a spectrum seen through the fitted passband.
//!
//! Behind the LVF, a broadband spectrum S(λ) reaches channel c as
//!
//! ```text
//! C_c(u) = V(u) · Σ_λ S(λ)·Q_c(λ)·g(λ − λ(u)) · Δλ
//! ```
//!
//! (Q_c the camera's sensitivity, g the passband, λ(u) the map). Without the camera
//! ([`crate::lvf::shared_continuum`] needs it) the product P_c = S·Q_c is unknown but
//! non-negative, so it is written as a cubic B-spline in wavelength with coefficients ≥ 0,
//! P_c(λ) = Σ_k β_{k,c}·B_k(λ), and every basis column is B_k seen through the *same* passband and
//! map as the lines: Φ_k(u) = Σ_λ B_k(λ)·g(λ − λ(u)) (1 nm grid). The column depends on θ (map,
//! FWHM) and is rebuilt with it.
//!
//! Why this and not only the spline in u of [`crate::lvf::background`]: a camera whose
//! sensitivity rises steeply makes P_c an edge, and through a Gaussian passband an edge becomes
//! an error function exactly σ_g wide (10.6 nm for FWHM 25 nm) — narrower than any spline
//! element in u that is still wider than a line blob. The Sony NEX-5N rises 7–10× in all three
//! channels between 400 and 410 nm (under the 405/408 nm lines) and its red fourfold between 570
//! and 580 nm (under the 577/579 nm doublet); the u-spline's misfit there moves the lines and
//! biased the map by +0.135 / −0.281 nm at 400 / 700 nm with no noise and no vignetting at all
//! (weak violet lines, 10 % flat continuum; `continuum12` chosen). Seen through the passband, an
//! element of knot spacing h has the width √(σ_g² + h²/3): always wider than a line's blob (σ_g),
//! and it draws an edge as sharp as the passband allows. The knot spacings tried
//! ([`PASSBAND_KNOT_FWHM`]) are in units of the fitted FWHM; BIC chooses among them and the
//! other candidates.

use crate::lvf::fit::Passband;
use crate::lvf::shared_continuum::{CameraResponse, SharedBasis};

/// Knot spacings (× FWHM, wavelength) of the passband continuum tried. At 0.75 × FWHM an element
/// seen through the passband is √(1 + 0.75²·2.355²/3) ≈ 1.43× as wide as a line blob — the
/// same ratio as the finest spline in u (1.0 × FWHM, [`crate::lvf::background`]), but its
/// edges are those of the passband. 0.5 × FWHM (1.2× a blob) was tried: it traded with the
/// FWHM and the lines (Canon 5D Mark II, weak violet lines: 0.172 nm at 700 nm, against 0.021
/// at 0.75 × FWHM; a spacing of 1.0 × FWHM left 0.106 nm on the Nikon D700).
pub const PASSBAND_KNOT_FWHM: [f64; 1] = [0.75];

/// How far beyond the profile's ends (× FWHM) the spectrum reaches: the passband sees ±1.5 FWHM.
pub const PASSBAND_REACH_FWHM: f64 = 1.5;

/// The basis: uniform cubic B-splines in wavelength on [lo, hi], seen through the passband.
#[derive(Debug, Clone)]
pub(crate) struct PassbandBasis {
    inner: SharedBasis,
}

impl PassbandBasis {
    /// The basis on [lo, hi] nm (whole nm, lo < hi) with `intervals` spline intervals.
    pub fn new(lo_nm: f64, hi_nm: f64, intervals: usize) -> Self {
        let lo = lo_nm.floor();
        let hi = hi_nm.ceil().max(lo + 10.0);
        // A flat "camera" of 1 in every channel: the basis is that of P_c = S·Q_c itself.
        let unit = CameraResponse {
            source: "unit".into(),
            first_nm: lo,
            q: vec![[1.0; 3]; (hi - lo) as usize + 1],
        };
        Self {
            inner: SharedBasis::new(&unit, lo, hi, intervals),
        }
    }

    /// Intervals for knots `knot_fwhm` × `fwhm_nm` apart on [lo, hi] (3–60).
    pub fn intervals_for(lo_nm: f64, hi_nm: f64, fwhm_nm: f64, knot_fwhm: f64) -> usize {
        ((hi_nm - lo_nm).abs() / (knot_fwhm * fwhm_nm).max(1e-6))
            .floor()
            .clamp(3.0, 60.0) as usize
    }

    /// Number of columns (intervals + 3).
    #[cfg(test)]
    pub fn n(&self) -> usize {
        self.inner.n()
    }

    /// Φ_k at the sample wavelengths `lams` for the passband of `fwhm_nm`, row-major
    /// `lams.len()` × [`PassbandBasis::n`].
    pub fn rows(&self, lams: &[f64], fwhm_nm: f64, passband: &Passband) -> Vec<f64> {
        // the unit camera's three channel blocks are equal: the first is the rows
        self.inner.columns_of(1, lams, &[], fwhm_nm, passband)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lvf::background::cubic_bspline_row;
    use nalgebra::{DMatrix, DVector};

    /// Least-squares residual rms of `y` on the columns `phi` (n × k row-major), relative to
    /// y's peak.
    fn fit_rms(phi: &[f64], k: usize, y: &[f64]) -> f64 {
        let n = y.len();
        let a = DMatrix::from_row_slice(n, k, phi);
        let b = DVector::from_column_slice(y);
        let x = a
            .clone()
            .svd(true, true)
            .solve(&b, 1e-12)
            .expect("svd solve");
        let r = &a * x - &b;
        let peak = y.iter().cloned().fold(0.0, f64::max);
        (r.norm_squared() / n as f64).sqrt() / peak
    }

    /// A camera edge (sensitivity ×10 from 400 to 410 nm, as the NEX-5N's blue) under a flat
    /// spectrum, seen through a 25 nm Gaussian passband on issue 12's 372–746 nm profile.
    fn edge_profile(lams: &[f64]) -> Vec<f64> {
        let q = |l: f64| {
            if l < 400.0 {
                0.0
            } else if l < 410.0 {
                0.033 + (0.35 - 0.033) * (l - 400.0) / 10.0
            } else if l < 440.0 {
                0.35 + (0.65 - 0.35) * (l - 410.0) / 30.0
            } else {
                (0.65 - (l - 440.0) * 0.005).max(0.0)
            }
        };
        let g = Passband::Gaussian;
        lams.iter()
            .map(|&lc| {
                (300..=850)
                    .map(|l| q(l as f64) * g.eval(l as f64 - lc, 25.0))
                    .sum()
            })
            .collect()
    }

    #[test]
    fn a_camera_edge_is_drawn_by_the_passband_continuum_but_not_by_a_spline_in_u() {
        let lams: Vec<f64> = (0..1200).map(|p| 372.3 + 0.3117 * p as f64).collect();
        let y = edge_profile(&lams);
        let (lo, hi) = (372.3 - 37.5, lams[1199] + 37.5);
        let k = PassbandBasis::intervals_for(lo, hi, 25.0, 0.5);
        let b = PassbandBasis::new(lo, hi, k);
        let seen = fit_rms(&b.rows(&lams, 25.0, &Passband::Gaussian), b.n(), &y);
        // the finest spline in u of the background model: 12 intervals (1.0 × FWHM)
        let mut spline = vec![0.0; 1200 * 15];
        for (i, l) in lams.iter().enumerate() {
            let u = 2.0 * (l - lams[0]) / (lams[1199] - lams[0]) - 1.0;
            cubic_bspline_row(u, 12, &mut spline[i * 15..(i + 1) * 15]);
        }
        let in_u = fit_rms(&spline, 15, &y);
        assert!(seen < 2e-3, "passband continuum rms {seen}");
        assert!(in_u > 4.0 * seen, "u-spline {in_u} vs passband {seen}");
    }

    #[test]
    fn a_passband_continuum_element_is_wider_than_a_line_blob() {
        let lams: Vec<f64> = (0..2000).map(|i| 300.0 + 0.25 * i as f64).collect();
        let b = PassbandBasis::new(300.0, 800.0, 40); // 12.5 nm knots
        let rows = b.rows(&lams, 25.0, &Passband::Gaussian);
        let k = b.n() / 2;
        let col: Vec<f64> = (0..lams.len()).map(|i| rows[i * b.n() + k]).collect();
        let s: f64 = col.iter().sum();
        let mean = col.iter().zip(&lams).map(|(c, l)| c * l).sum::<f64>() / s;
        let var = col
            .iter()
            .zip(&lams)
            .map(|(c, l)| c * (l - mean).powi(2))
            .sum::<f64>()
            / s;
        let sigma_g = 25.0 / (8.0 * 2f64.ln()).sqrt();
        let expect = (sigma_g * sigma_g + 12.5f64.powi(2) / 3.0).sqrt();
        assert!(
            (var.sqrt() - expect).abs() < 0.05,
            "{} vs {expect}",
            var.sqrt()
        );
        assert!(var.sqrt() > 1.15 * sigma_g);
    }
}
