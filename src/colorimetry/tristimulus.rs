//! Spectral distribution → CIE XYZ tristimulus values, as `colour.sd_to_XYZ`.
//!
//! Two methods, both ported from colour-science 0.4.7 so that results agree to rounding:
//!
//! * **Integration** (`colour.colorimetry.sd_to_XYZ_integration`): the spectrum and the illuminant
//!   are aligned to the observer's grid (Sprague / cubic spline, constant extrapolation), then
//!   `X = k Σ R(λ) S(λ) x̄(λ) Δλ`, likewise Y, Z, with `k = 100 / Σ S(λ) ȳ(λ) Δλ`.
//! * **ASTM E308-15** (`colour.colorimetry.sd_to_XYZ_ASTME308`, colour's default): CMFs trimmed to
//!   the practice range 360–780 nm; data at 1 nm are integrated; data at 5 nm are integrated against
//!   CMFs sampled every 5 nm (the "5 nm omission" method); data at 10 nm use the ASTM E2022
//!   tristimulus weighting factors (Lagrange-interpolated CMF × illuminant products, with the
//!   weights outside the measured range folded into its end bands, which is E308's bandpass-free
//!   treatment of a truncated range); data at 20 nm are first Lagrange-interpolated to 10 nm
//!   (E308's 20 nm interpolation method). Only 1, 5, 10 and 20 nm data are accepted.
//!
//! Normalisation (both methods): without `k`, Y of the perfect reflector under the illuminant is
//! 100 (reflectance factors on the 0–1 scale give XYZ on the 0–100 scale). With `k` given (e.g.
//! 683 lm/W for absolute photometric values of an emission spectrum, whose illuminant is then
//! usually E), `XYZ = k · Σ R S x̄ Δλ / 100`, exactly as colour computes it (colour's E is 100
//! everywhere, so `k = 683` with E yields `683 · Σ R ȳ Δλ`).
//!
//! All steps are linear in the spectrum's values, so [`XyzOperator`] precomputes the 3 × n matrix
//! that maps a spectrum on a fixed grid to XYZ — the fast path for many spectra on one grid.

use crate::error::{Error, Result};
use crate::math::interpolation::Interpolator;
use crate::spectrum::{MultiSpectrum, SpectralShape, Spectrum};

use super::illuminant::Illuminant;
use super::observer::Observer;

/// How tristimulus values are computed from a spectrum.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum XyzMethod {
    /// ASTM E308-15, colour's default.
    #[default]
    AstmE308,
    /// Plain summation on the observer's grid.
    Integration,
}

impl XyzMethod {
    /// Parses `astm-e308` or `integration` (case-insensitive).
    pub fn from_name(name: &str) -> Result<Self> {
        match name.trim().to_ascii_lowercase().as_str() {
            "astm-e308" | "astm e308" | "astme308" => Ok(XyzMethod::AstmE308),
            "integration" => Ok(XyzMethod::Integration),
            _ => Err(Error::UnknownName {
                kind: "XYZ integration method",
                name: name.into(),
                expected: "astm-e308, integration".into(),
            }),
        }
    }

    /// The command-line name.
    pub fn cli_name(self) -> &'static str {
        match self {
            XyzMethod::AstmE308 => "astm-e308",
            XyzMethod::Integration => "integration",
        }
    }
}

/// colour's default chromaticity for black (XYZ = 0) in xy conversions: CIE 1931 D65.
pub const D65_XY: [f64; 2] = [0.3127, 0.3290];

/// XYZ tristimulus values together with the observer that produced them.
#[derive(Debug, Clone, PartialEq)]
pub struct Tristimulus {
    /// X, Y, Z (0–100 scale for reflectances without `k`).
    pub xyz: [f64; 3],
    /// Name of the observer whose CMFs were used.
    pub observer: String,
}

impl Tristimulus {
    /// Fails unless `other` was computed with the same observer.
    pub fn check_same_observer(&self, other: &Tristimulus, what: &str) -> Result<()> {
        if self.observer != other.observer {
            return Err(Error::ObserverMismatch {
                what: what.to_string(),
                expected: other.observer.clone(),
                found: self.observer.clone(),
            });
        }
        Ok(())
    }

    /// CIE L*a*b* of these values relative to `white` (the tristimulus values of the illuminant
    /// or of the perfect reflector under it, same observer): `XYZ_to_Lab(XYZ / Y_w, xy_w)`.
    pub fn lab_relative_to(&self, white: &Tristimulus) -> Result<[f64; 3]> {
        self.check_same_observer(white, "L*a*b* white point")?;
        let yw = white.xyz[1];
        if yw.is_nan() || yw <= 0.0 {
            return Err(Error::invalid(
                "white point",
                format!("Y must be positive, got {yw}"),
            ));
        }
        let xyz = self.xyz.map(|v| v / yw);
        let xy = super::xyy::xyz_to_xy(white.xyz, D65_XY);
        super::lab::xyz_to_lab(xyz, xy)
    }
}

fn is_close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-9 * b.abs().max(1.0)
}

/// Tristimulus values of `sd` under `illuminant` for `observer`, as `colour.sd_to_XYZ`.
pub fn sd_to_xyz(
    sd: &Spectrum,
    observer: &Observer,
    illuminant: &Illuminant,
    method: XyzMethod,
    k: Option<f64>,
) -> Result<Tristimulus> {
    if let Some(k) = k {
        if !(k.is_finite() && k > 0.0) {
            return Err(Error::invalid(
                "k",
                format!("expected a positive finite number, got {k}"),
            ));
        }
    }
    let xyz = match method {
        XyzMethod::Integration => integration(sd, observer.cmfs(), illuminant, k)?,
        XyzMethod::AstmE308 => astm_e308(sd, observer.cmfs(), illuminant, k)?,
    };
    Ok(Tristimulus {
        xyz,
        observer: observer.name().to_string(),
    })
}

/// Tristimulus values of the perfect reflector under `illuminant` (its white point), computed on
/// the sample grid `wavelengths_nm` with the same method and `k` as the samples it will serve as
/// white for — so a flat reflectance has a* = b* = 0 exactly. Y = 100 without `k`.
pub fn illuminant_white(
    observer: &Observer,
    illuminant: &Illuminant,
    method: XyzMethod,
    wavelengths_nm: &[f64],
    k: Option<f64>,
) -> Result<Tristimulus> {
    let ones = Spectrum::new(
        "perfect reflector",
        wavelengths_nm.to_vec(),
        vec![1.0; wavelengths_nm.len()],
    )?;
    sd_to_xyz(&ones, observer, illuminant, method, k)
}

/// Aligns `s` onto the grid of `target` unless it is already on it (colour compares shapes).
fn align_to(s: &Spectrum, target: &[f64]) -> Result<Spectrum> {
    s.resample(target, Interpolator::Default)
}

/// colour.sd_to_XYZ_integration with explicit CMFs and illuminant.
fn integration(
    sd: &Spectrum,
    cmfs: &MultiSpectrum,
    illuminant: &Illuminant,
    k: Option<f64>,
) -> Result<[f64; 3]> {
    let grid = cmfs.wavelengths();
    let ill = illuminant
        .spectrum()
        .resample(grid, illuminant.interpolator())?;
    let r = align_to(sd, grid)?;
    Ok(integrate_on_grid(r.values(), cmfs, ill.values(), k))
}

fn integrate_on_grid(r: &[f64], cmfs: &MultiSpectrum, s: &[f64], k: Option<f64>) -> [f64; 3] {
    let dw = cmfs.shape().interval_nm;
    let ybar = cmfs.channel(1);
    let (k, scale) = match k {
        Some(k) => (k, 0.01),
        None => {
            let norm: f64 = ybar.iter().zip(s).map(|(y, s)| y * s).sum::<f64>() * dw;
            (if norm == 0.0 { 0.0 } else { 100.0 / norm }, 1.0)
        }
    };
    let mut xyz = [0.0; 3];
    for (c, out) in xyz.iter_mut().enumerate() {
        let dot: f64 = r
            .iter()
            .zip(s)
            .zip(cmfs.channel(c))
            .map(|((r, s), b)| r * s * b)
            .sum();
        *out = k * dot * dw * scale;
    }
    xyz
}

/// The ASTM E308 practice range.
const PRACTICE_START_NM: f64 = 360.0;
const PRACTICE_END_NM: f64 = 780.0;

/// colour.sd_to_XYZ_ASTME308 with its defaults (practice range, 5 nm omission, 20 nm
/// interpolation).
fn astm_e308(
    sd: &Spectrum,
    cmfs_in: &MultiSpectrum,
    illuminant: &Illuminant,
    k: Option<f64>,
) -> Result<[f64; 3]> {
    let cmfs_shape = cmfs_in.shape();
    if !is_close(cmfs_shape.interval_nm, 1.0) || !cmfs_in.is_uniform() {
        return Err(Error::invalid(
            "observer",
            format!(
                "ASTM E308 needs colour-matching functions at 1 nm, '{}' is sampled {}; use --method integration",
                cmfs_in.name(),
                cmfs_shape
            ),
        ));
    }
    // colour's handle_spectral_arguments: the illuminant on the full CMF grid.
    let ill_full = illuminant
        .spectrum()
        .resample(cmfs_in.wavelengths(), illuminant.interpolator())?;
    let interval = sd.shape().interval_nm;
    let which = [1.0, 5.0, 10.0, 20.0]
        .into_iter()
        .find(|&i| is_close(interval, i));
    let Some(mut interval) = which else {
        return Err(Error::invalid(
            "spectrum",
            format!(
                "ASTM E308 needs data sampled every 1, 5, 10 or 20 nm; '{}' is sampled every {} nm (use --method integration)",
                sd.name(),
                interval
            ),
        ));
    };
    let mut sd = sd.clone();
    let s = sd.shape();
    if (interval == 10.0 || interval == 20.0)
        && (s.start_nm % 10.0 != 0.0 || s.end_nm % 10.0 != 0.0)
    {
        // colour aligns such data to the CMF grid (1 nm); E308 does not define this case.
        sd = align_to(&sd, cmfs_in.wavelengths())?;
        interval = 1.0;
    }
    let practice = SpectralShape {
        start_nm: PRACTICE_START_NM,
        end_nm: PRACTICE_END_NM,
        interval_nm: 1.0,
    };
    let cmfs = cmfs_in.trim(&practice)?;
    let ill = Illuminant::from_spectrum(
        illuminant.name(),
        ill_full.resample(cmfs.wavelengths(), illuminant.interpolator())?,
    )
    .with_interpolator(illuminant.interpolator());
    if interval == 1.0 {
        return integration(&sd, &cmfs, &ill, k);
    }
    if interval == 5.0 {
        let cs = cmfs.shape();
        let grid5 = SpectralShape::new(cs.start_nm, cs.end_nm, 5.0)?.wavelengths();
        let cmfs5 = cmfs.resample(&grid5, Interpolator::Default)?;
        return integration(&sd, &cmfs5, &ill, k);
    }
    let cs = cmfs.shape();
    if sd.shape().start_nm != cs.start_nm || sd.shape().end_nm != cs.end_nm {
        sd = sd.trim(&cs)?;
    }
    if interval == 20.0 {
        sd = interpolate_20_to_10(&sd)?;
    }
    weighting_factors_path(&sd, &cmfs, ill.spectrum(), k)
}

/// E308's 20 nm → 10 nm Lagrange interpolation (colour's `mi_20nm_interpolation_method`).
fn interpolate_20_to_10(sd: &Spectrum) -> Result<Spectrum> {
    let s = sd.shape();
    let ext = SpectralShape::new(s.start_nm - 20.0, s.end_nm + 20.0, 10.0)?;
    let aligned = sd.align(&ext, Interpolator::Default)?;
    let mut v = aligned.values().to_vec();
    let n = v.len();
    if n < 8 {
        return Err(Error::invalid(
            "spectrum",
            format!(
                "'{}' has too few 20 nm samples for ASTM E308 interpolation",
                sd.name()
            ),
        ));
    }
    for i in 0..2 {
        v[i] = 3.0 * v[i + 2] - 3.0 * v[i + 4] + v[i + 6];
        let ie = n - 1 - i;
        v[ie] = v[ie - 6] - 3.0 * v[ie - 4] + 3.0 * v[ie - 2];
    }
    let mut i = 3;
    while i < n - 3 {
        v[i] = -0.0625 * v[i - 3] + 0.5625 * v[i - 1] + 0.5625 * v[i + 1] - 0.0625 * v[i + 3];
        i += 2;
    }
    let full = Spectrum::new(sd.name(), aligned.wavelengths().to_vec(), v)?;
    full.trim(&SpectralShape::new(s.start_nm, s.end_nm, 10.0)?)
}

/// `colour.algebra.lagrange_coefficients(r, n)`.
fn lagrange_coefficients(r: f64, n: usize) -> Vec<f64> {
    (0..n)
        .map(|j| {
            let mut acc: Option<f64> = None;
            for i in (0..n).filter(|&i| i != j) {
                let term = (r - i as f64) / (j as f64 - i as f64);
                acc = Some(match acc {
                    None => term,
                    Some(a) => a * term,
                });
            }
            acc.unwrap_or(1.0)
        })
        .collect()
}

/// `colour.colorimetry.lagrange_coefficients_ASTME2022(interval, boundary|inner)`.
fn lagrange_coefficients_astm_e2022(interval: usize, inner: bool) -> Vec<Vec<f64>> {
    let m = interval - 1;
    let (offset, d) = if inner { (1.0, 4) } else { (0.0, 3) };
    let r_n = crate::spectrum::linspace(1.0 / interval as f64, 1.0 - 1.0 / interval as f64, m);
    r_n.iter()
        .map(|&r| lagrange_coefficients(r + offset, d))
        .collect()
}

/// `colour.colorimetry.tristimulus_weighting_factors_ASTME2022`: rows every `interval` nm from the
/// start of the 1 nm CMFs.
// The index arithmetic mirrors colour's (and ASTM E2022's) loops one to one, which is what makes
// the port checkable line by line; iterator rewrites would obscure that.
#[allow(clippy::needless_range_loop)]
fn tristimulus_weighting_factors(
    cmfs: &MultiSpectrum,
    ill: &[f64],
    interval: usize,
    k: Option<f64>,
) -> Vec<[f64; 3]> {
    let y = |h: usize, i: usize| cmfs.channel(i)[h];
    let s = ill;
    let w_c = cmfs.len();
    let mut w: Vec<[f64; 3]> = (0..w_c)
        .step_by(interval)
        .map(|h| [s[h] * y(h, 0), s[h] * y(h, 1), s[h] * y(h, 2)])
        .collect();
    let c_c = lagrange_coefficients_astm_e2022(interval, false);
    let c_b = lagrange_coefficients_astm_e2022(interval, true);
    let r_c = c_b.len();
    let w_lif = w_c - (w_c - 1) % interval - 1 - r_c;
    let i_c = w.len();
    let i_cm = i_c - 1;
    for i in 0..3 {
        for h in 0..r_c {
            for g in 0..3 {
                w[g][i] += c_c[h][g] * s[h + 1] * y(h + 1, i);
            }
        }
        for h in 0..r_c {
            for g in [i_cm, i_cm - 1, i_cm - 2] {
                w[g][i] += c_c[r_c - h - 1][i_cm - g] * s[h + w_lif] * y(h + w_lif, i);
            }
        }
        for h in 0..i_c.saturating_sub(3) {
            for (g, cb) in c_b.iter().enumerate() {
                let w_i = (r_c + 1) * (h + 1) + 1 + g;
                w[h][i] += cb[0] * s[w_i] * y(w_i, i);
                w[h + 1][i] += cb[1] * s[w_i] * y(w_i, i);
                w[h + 2][i] += cb[2] * s[w_i] * y(w_i, i);
                w[h + 3][i] += cb[3] * s[w_i] * y(w_i, i);
            }
        }
        for h in (w_c - (w_c - 1) % interval)..w_c {
            w[i_cm][i] += s[h] * y(h, i);
        }
    }
    let factor = match k {
        Some(k) => k,
        None => {
            let sum_y: f64 = w.iter().map(|r| r[1]).sum();
            if sum_y == 0.0 {
                0.0
            } else {
                100.0 / sum_y
            }
        }
    };
    for row in w.iter_mut() {
        for v in row.iter_mut() {
            *v *= factor;
        }
    }
    w
}

fn weighting_factors_path(
    sd: &Spectrum,
    cmfs: &MultiSpectrum,
    ill: &Spectrum,
    k: Option<f64>,
) -> Result<[f64; 3]> {
    let interval = sd.shape().interval_nm.round() as usize;
    let w = tristimulus_weighting_factors(cmfs, ill.values(), interval, k);
    // colour.colorimetry.adjust_tristimulus_weighting_factors_ASTME308
    let cs = cmfs.shape();
    let ss = sd.shape();
    let start_index = ((ss.start_nm - cs.start_nm) / interval as f64) as usize;
    let end_r = cs.start_nm + interval as f64 * (w.len() - 1) as f64;
    let end_index = ((end_r - ss.end_nm) / interval as f64).max(0.0) as usize;
    let mut w = w;
    if start_index + end_index >= w.len() {
        return Err(Error::invalid(
            "spectrum",
            format!(
                "'{}' does not overlap the ASTM E308 range 360–780 nm",
                sd.name()
            ),
        ));
    }
    for i in 0..start_index {
        let row = w[i];
        for c in 0..3 {
            w[start_index][c] += row[c];
        }
    }
    let n = w.len();
    for i in 0..end_index {
        let row = w[n - i - 1];
        for c in 0..3 {
            w[n - end_index - 1][c] += row[c];
        }
    }
    let w = &w[start_index..n - end_index];
    if w.len() != sd.len() {
        return Err(Error::ShapeMismatch {
            what: format!(
                "ASTM E308 weighting factors for '{}' (samples {})",
                sd.name(),
                ss
            ),
            expected: w.len(),
            got: sd.len(),
        });
    }
    let mut xyz = [0.0; 3];
    for (row, r) in w.iter().zip(sd.values()) {
        for c in 0..3 {
            xyz[c] += row[c] * r;
        }
    }
    if k.is_some() {
        for v in xyz.iter_mut() {
            *v /= 100.0;
        }
    }
    Ok(xyz)
}

/// A precomputed linear map from spectra sampled on one fixed grid to XYZ.
///
/// Every step of both methods (alignment, Lagrange interpolation, weighting) is linear in the
/// spectral values, so the whole computation is a 3 × n matrix, built once by passing the unit
/// spectra through [`sd_to_xyz`]. Applying it costs 3n multiply-adds per spectrum; results equal
/// [`sd_to_xyz`] to rounding (checked in tests).
#[derive(Debug, Clone)]
pub struct XyzOperator {
    wavelengths_nm: Vec<f64>,
    rows: [Vec<f64>; 3],
    observer: String,
}

impl XyzOperator {
    /// Builds the operator for spectra sampled at `wavelengths_nm`.
    pub fn new(
        wavelengths_nm: &[f64],
        observer: &Observer,
        illuminant: &Illuminant,
        method: XyzMethod,
        k: Option<f64>,
    ) -> Result<XyzOperator> {
        let n = wavelengths_nm.len();
        let mut rows = [vec![0.0; n], vec![0.0; n], vec![0.0; n]];
        // The default normalisation k = 100 / Σ S ȳ Δλ depends on the illuminant only, so each
        // unit spectrum's XYZ is one column of the linear map.
        for j in 0..n {
            let mut e = vec![0.0; n];
            e[j] = 1.0;
            let sd = Spectrum::new("unit", wavelengths_nm.to_vec(), e)?;
            let t = sd_to_xyz(&sd, observer, illuminant, method, k)?;
            for (row, v) in rows.iter_mut().zip(t.xyz) {
                row[j] = v;
            }
        }
        Ok(XyzOperator {
            wavelengths_nm: wavelengths_nm.to_vec(),
            rows,
            observer: observer.name().to_string(),
        })
    }

    /// The grid this operator expects.
    pub fn wavelengths(&self) -> &[f64] {
        &self.wavelengths_nm
    }

    /// XYZ of one spectrum's values on the operator's grid.
    pub fn apply(&self, values: &[f64]) -> Result<[f64; 3]> {
        if values.len() != self.wavelengths_nm.len() {
            return Err(Error::ShapeMismatch {
                what: "spectrum values for XYZ operator".into(),
                expected: self.wavelengths_nm.len(),
                got: values.len(),
            });
        }
        Ok(self
            .rows
            .each_ref()
            .map(|row| row.iter().zip(values).map(|(a, b)| a * b).sum()))
    }

    /// The observer the operator was built for.
    pub fn observer(&self) -> &str {
        &self.observer
    }
}
