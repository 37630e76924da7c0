//! Whole-profile fit of an LVF lamp image by variable projection.
//!
//! Nonlinear parameters θ = (a0, a1[, a2], FWHM[, v1 … vJ]) with the map written in the
//! normalised position u = (px − px_mid)/half_length as λ(u) = a0 + a1·u [+ a2·u²] (well
//! conditioned) and the fall-off V(u) = 1 + Σ vⱼ uʲ; linear parameters per channel: offset
//! b + s·u, one amplitude ≥ 0 per line and the continuum's B-spline coefficients ≥ 0
//! ([`crate::lvf::background`]), solved by Lawson–Hanson non-negative least squares on the normal
//! equations for every θ. θ is refined by the crate's Levenberg–Marquardt
//! ([`fit::lm`](crate::fit::lm)) on the projected residual (central-difference Jacobian), started
//! from the best few cells of a coarse grid over (a0, a1) at the guessed FWHM with the offset
//! only; the background terms (continuum, fall-off degree) are then chosen by BIC among refined
//! candidates. The covariance of θ is the HAC sandwich (JᵀJ)⁻¹B(JᵀJ)⁻¹ of
//! [`crate::lvf::sigma`] (noise growing with the signal and residuals correlated along the
//! profile; s²(JᵀJ)⁻¹ with s² = SSE/(N − p − k) is kept in the diagnostics) and is propagated to
//! the coefficients in pixels; the spread between background models (within ΔBIC ≤ 10, every continuum when one was chosen; within ΔBIC ≤ 100 with a shared spectrum) is reported as the systematic
//! part of σ at 400/700 nm. [`assess`] then refuses physically impossible maps and flags what the
//! model does not explain.
//!
//! The map's degree: linear unless asked; with `MapChoice::Auto` or `Quadratic` every background
//! candidate is refitted with a quadratic map and the degree is chosen with the background (a
//! continuum takes up a bowed map's misfit when the map is held linear); with the linear map the
//! offset alone with a quadratic map is fitted once more and warned of when it wins. The
//! passband's shape g: Gaussian, a generalised normal ([`Passband::GenNormal`], β fitted by
//! [`calibrate_whole_profile`] when [`FitOptions::passband_exponent_search`] is set; with the
//! Gaussian a profile left above the noise is checked at β = 1.75 and 2.25), or measured.

use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::fit::stats;
use crate::fit::{levenberg_marquardt, LmOptions, Residuals};
use crate::lvf::background::{
    continuum_intervals_for, cubic_bspline_row, estimate_radial_falloff, falloff, BackgroundChoice,
    BackgroundTerms, CONTINUUM_KNOT_FWHM,
};
use crate::lvf::calibration::{
    BackgroundReport, CandidateReport, LineReport, LvfCalibration, MapKind, MapModel, MapSelection,
    ProfileCurves, UnexplainedLine,
};
use crate::lvf::lamp::Lamp;
use crate::lvf::passband_continuum::{PassbandBasis, PASSBAND_KNOT_FWHM, PASSBAND_REACH_FWHM};
use crate::lvf::profile::Profile;
use crate::lvf::shared_continuum::{
    solve_joint, CameraResponse, SharedBasis, SHARED_KNOT_FWHM, SHARED_SMOOTHNESS,
};
use crate::math::minimize::brent_min;

/// Points after which [`Passband::eval_uniform`]'s Gaussian recurrence restarts from an exact
/// `exp`.
const RECURRENCE_RESTART: usize = 32;
/// The Gaussian passband is 0 beyond this many standard deviations …
const GAUSSIAN_CUTOFF_SIGMA: f64 = 8.0;
/// … and the generalised normal where its exponent ln2·|2Δλ/FWHM|^β exceeds this.
const GENNORM_CUTOFF_EXPONENT: f64 = 40.0;

/// The Gaussian's standard deviation for a full width at half maximum `fwhm`.
fn gaussian_sigma(fwhm: f64) -> f64 {
    fwhm / (8.0 * std::f64::consts::LN_2).sqrt()
}

/// Passband shape g(Δλ).
#[derive(Debug, Clone, PartialEq)]
pub enum Passband {
    /// Gaussian with the fitted FWHM.
    Gaussian,
    /// A generalised normal exp(−ln 2·|2Δλ/FWHM|^β) with the fitted FWHM: β = 2 is the Gaussian,
    /// β < 2 peakier with longer tails, β > 2 flatter-topped with steeper edges (an
    /// interference filter's passband is rarely Gaussian).
    GenNormal {
        /// The exponent β (> 0).
        beta: f64,
    },
    /// A measured shape (offset from the centre in nm, transmission), stretched to the fitted
    /// FWHM.
    Measured {
        /// Offsets (nm), increasing.
        offset_nm: Vec<f64>,
        /// Transmission, peak-normalised.
        transmission: Vec<f64>,
        /// FWHM of the measured shape (nm).
        fwhm_nm: f64,
    },
}

impl Passband {
    /// A measured passband from offsets (nm, strictly increasing, spanning 0) and transmission.
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] when the shape has no peak inside or no half-maximum crossing on
    /// each side.
    pub fn measured(offset_nm: Vec<f64>, transmission: Vec<f64>) -> Result<Self> {
        let max = transmission.iter().cloned().fold(f64::MIN, f64::max);
        if offset_nm.len() != transmission.len()
            || offset_nm.len() < 3
            || max.is_nan()
            || max <= 0.0
        {
            return Err(Error::invalid(
                "--passband",
                "expected at least 3 rows offset_nm,transmission with a positive peak",
            ));
        }
        let t: Vec<f64> = transmission.iter().map(|v| v / max).collect();
        let imax = t.iter().position(|&v| v == 1.0).unwrap_or(0);
        let cross = |range: Box<dyn Iterator<Item = usize>>| -> Option<f64> {
            let mut prev: Option<usize> = None;
            for i in range {
                if let Some(p) = prev {
                    if (t[p] - 0.5) * (t[i] - 0.5) <= 0.0 && t[p] != t[i] {
                        let f = (0.5 - t[p]) / (t[i] - t[p]);
                        return Some(offset_nm[p] + f * (offset_nm[i] - offset_nm[p]));
                    }
                }
                prev = Some(i);
            }
            None
        };
        let left = cross(Box::new((0..=imax).rev()));
        let right = cross(Box::new(imax..t.len()));
        match (left, right) {
            (Some(l), Some(r)) if r > l => Ok(Passband::Measured {
                offset_nm,
                transmission: t,
                fwhm_nm: r - l,
            }),
            _ => Err(Error::invalid(
                "--passband",
                "the measured shape does not fall below half maximum on both sides of its peak",
            )),
        }
    }

    /// The shape as lvf.json reports it (`passband`): `{"shape": "gaussian"}`, `{"shape":
    /// "gennorm", "beta": β}` or `{"shape": "measured", "offset_nm": […], "transmission": […],
    /// "fwhm_nm": …}` (the measured shape's own FWHM; it is stretched to `fwhm_nm` of the fit).
    pub fn report(&self) -> serde_json::Value {
        match self {
            Passband::Gaussian => serde_json::json!({"shape": "gaussian"}),
            Passband::GenNormal { beta } => serde_json::json!({"shape": "gennorm", "beta": beta}),
            Passband::Measured {
                offset_nm,
                transmission,
                fwhm_nm,
            } => serde_json::json!({"shape": "measured", "offset_nm": offset_nm,
                "transmission": transmission, "fwhm_nm": fwhm_nm}),
        }
    }

    /// The passband of a [`Passband::report`] (lvf.json's `passband`).
    ///
    /// # Errors
    /// [`Error::Parse`] naming `source` and the field when the shape is unknown or its
    /// parameters are missing or out of range.
    pub fn from_report(v: &serde_json::Value, source: &str) -> Result<Self> {
        let bad = |field: &str, expected: &str| {
            Error::parse(
                source,
                0,
                format!("field 'passband.{field}': expected {expected}"),
            )
        };
        match v.get("shape").and_then(|s| s.as_str()) {
            Some("gaussian") => Ok(Passband::Gaussian),
            Some("gennorm") => match v.get("beta").and_then(|b| b.as_f64()) {
                Some(beta) if (0.5..=20.0).contains(&beta) => Ok(Passband::GenNormal { beta }),
                _ => Err(bad("beta", "a number in [0.5, 20]")),
            },
            Some("measured") => {
                let list = |field: &str| -> Result<Vec<f64>> {
                    v.get(field)
                        .and_then(|a| a.as_array())
                        .and_then(|a| a.iter().map(|x| x.as_f64()).collect::<Option<Vec<f64>>>())
                        .ok_or_else(|| bad(field, "an array of numbers"))
                };
                Passband::measured(list("offset_nm")?, list("transmission")?)
                    .map_err(|e| bad("transmission", &format!("a measured passband ({e})")))
            }
            _ => Err(bad("shape", "\"gaussian\", \"gennorm\" or \"measured\"")),
        }
    }

    /// `out[m]` = [`Passband::eval`]`(d0 + m·step, fwhm)` for m = 0, 1, …: the passband on a
    /// uniform grid. The Gaussian follows the grid by a multiplicative recurrence (two
    /// multiplications per point instead of an `exp`, restarted exactly every
    /// [`RECURRENCE_RESTART`] points so that rounding stays below 1e-14 relative); the other
    /// shapes are evaluated point by point.
    pub fn eval_uniform(&self, d0: f64, step: f64, fwhm: f64, out: &mut [f64]) {
        match self {
            Passband::Gaussian => {
                let s = gaussian_sigma(fwhm);
                let dz = step / s;
                // exp(−z²/2) at z + dz = exp(−z²/2) · exp(−z·dz − dz²/2); the second factor
                // itself is multiplied by q = exp(−dz²) per step
                let q = (-dz * dz).exp();
                for (c, chunk) in out.chunks_mut(RECURRENCE_RESTART).enumerate() {
                    let m0 = c * RECURRENCE_RESTART;
                    let z0 = (d0 + m0 as f64 * step) / s;
                    let mut t = (-0.5 * z0 * z0).exp();
                    let mut r = (-z0 * dz - 0.5 * dz * dz).exp();
                    for (j, o) in chunk.iter_mut().enumerate() {
                        let z = z0 + j as f64 * dz;
                        *o = if z.abs() > GAUSSIAN_CUTOFF_SIGMA {
                            0.0
                        } else {
                            t
                        };
                        t *= r;
                        r *= q;
                    }
                }
            }
            _ => {
                for (m, o) in out.iter_mut().enumerate() {
                    *o = self.eval(d0 + m as f64 * step, fwhm);
                }
            }
        }
    }

    /// Half-width (nm) beyond which [`Passband::eval`] is exactly 0 (∞ when it never is).
    pub fn support_nm(&self, fwhm: f64) -> f64 {
        match self {
            Passband::Gaussian => GAUSSIAN_CUTOFF_SIGMA * gaussian_sigma(fwhm),
            Passband::GenNormal { beta } if *beta > 0.0 => {
                0.5 * fwhm * (GENNORM_CUTOFF_EXPONENT / std::f64::consts::LN_2).powf(1.0 / beta)
            }
            Passband::GenNormal { .. } => f64::INFINITY,
            Passband::Measured {
                offset_nm, fwhm_nm, ..
            } => match (offset_nm.first(), offset_nm.last()) {
                (Some(a), Some(b)) if *fwhm_nm > 0.0 => a.abs().max(b.abs()) * fwhm / fwhm_nm,
                _ => f64::INFINITY,
            },
        }
    }

    /// g(Δλ) for a passband of full width at half maximum `fwhm`.
    #[inline]
    pub fn eval(&self, delta_nm: f64, fwhm: f64) -> f64 {
        match self {
            Passband::Gaussian => {
                let z = delta_nm / gaussian_sigma(fwhm);
                if z.abs() > GAUSSIAN_CUTOFF_SIGMA {
                    0.0
                } else {
                    (-0.5 * z * z).exp()
                }
            }
            Passband::GenNormal { beta } => {
                let e = std::f64::consts::LN_2 * (2.0 * delta_nm / fwhm).abs().powf(*beta);
                if e > GENNORM_CUTOFF_EXPONENT {
                    0.0
                } else {
                    (-e).exp()
                }
            }
            Passband::Measured {
                offset_nm,
                transmission,
                fwhm_nm,
            } => {
                let d = delta_nm * fwhm_nm / fwhm;
                let n = offset_nm.len();
                if d <= offset_nm[0] || d >= offset_nm[n - 1] {
                    return 0.0;
                }
                let i = offset_nm.partition_point(|&o| o <= d).clamp(1, n - 1);
                let f = (d - offset_nm[i - 1]) / (offset_nm[i] - offset_nm[i - 1]);
                transmission[i - 1] + f * (transmission[i] - transmission[i - 1])
            }
        }
    }
}

/// Polynomial degree of the map requested.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MapChoice {
    /// Linear map.
    Linear,
    /// Quadratic map.
    Quadratic,
    /// Quadratic only if justified: F-test p < 0.001 against linear and |a2| > 3σ.
    Auto,
}

/// Which way wavelength runs along the axis.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Direction {
    /// From the camera channels: blue light's centroid lies on the short-wavelength side.
    Auto,
    /// λ increases with px.
    Increasing,
    /// λ decreases with px.
    Decreasing,
}

/// Options of the calibration.
#[derive(Debug, Clone, PartialEq)]
pub struct FitOptions {
    /// Map degree.
    pub map: MapChoice,
    /// Passband shape.
    pub passband: Passband,
    /// Starting FWHM (nm) for the coarse search.
    pub fwhm_guess_nm: f64,
    /// Direction of the wavelength gradient.
    pub direction: Direction,
    /// Number of bands from 400 to 700 nm.
    pub n_bands: usize,
    /// Continuum and fall-off terms (see [`crate::lvf::background`]).
    pub background: BackgroundChoice,
    /// Estimate a radial fall-off from the strips across the axis and divide it out
    /// ([`crate::lvf::background::estimate_radial_falloff`]).
    pub radial_falloff: bool,
    /// Weight every profile sample by its noise, estimated from the profile
    /// ([`crate::lvf::noise`]): the bright line blobs carry shot noise, the dim flanks less.
    /// `None` (the default): weighted when `camera` is given, unweighted otherwise — weighting
    /// gives the dim flanks their due, which helps a continuum model that can follow the
    /// continuum (the penalised shared spectrum) and hurts the biased ones left without the
    /// camera (CFL at 5 % noise: 0.57 → 0.89 nm; docs/performance.md, issue 12, seventeenth
    /// session).
    pub noise_weights: Option<bool>,
    /// Knot spacings of the continuum candidates (× FWHM, coarsest first; the first is also
    /// the fixed choice). Default
    /// [`CONTINUUM_KNOT_FWHM`].
    pub continuum_knots_fwhm: Vec<f64>,
    /// Knot spacings (× FWHM) of the per-channel continuum spectra seen through the passband
    /// ([`crate::lvf::passband_continuum`]) among the `Auto` candidates; empty: none. Default
    /// [`PASSBAND_KNOT_FWHM`].
    pub passband_knots_fwhm: Vec<f64>,
    /// The camera's sensitivities, when known: adds continuum candidates whose spectrum is
    /// shared by the three channels ([`crate::lvf::shared_continuum`]).
    pub camera: Option<CameraResponse>,
    /// Knot spacings (× FWHM) of the shared continuum spectrum's candidates when `camera` is
    /// given. Default [`SHARED_KNOT_FWHM`].
    pub shared_knots_fwhm: Vec<f64>,
    /// Prior roughness values of the shared spectrum's candidates (see [`SHARED_SMOOTHNESS`],
    /// the default); 0: no roughness penalty (the knot spacing alone limits it).
    pub shared_smoothness: Vec<f64>,
    /// A known fall-off V at each profile position (e.g. from a flat-field photo,
    /// [`crate::lvf::flat`]) multiplying lines and continuum; replaces the radial estimate.
    /// Ignored unless it has one value per profile position.
    pub fixed_falloff: Option<Vec<f64>>,
    /// The accuracy the user needs at 400 and 700 nm (nm): without `camera`, a continuum model
    /// whose σ there exceeds it draws a warning naming what would narrow it. Default
    /// [`CONTINUUM_SIGMA_HINT_NM`].
    pub sigma_hint_nm: f64,
    /// Fit the exponent β of a generalised-normal passband ([`Passband::GenNormal`]) by BIC over
    /// [`PASSBAND_EXPONENTS`] (`--passband gennorm`); `passband` is then ignored.
    pub passband_exponent_search: bool,
    /// Width τ (1σ, natural log) of the prior on how a mercury lamp's unresolved pairs
    /// (404.7/407.8, 577.0/579.1 nm) split their blob, around the table's ratio
    /// ([`SPLIT_PRIOR_TAU`], the default; 0: splits free). Per-channel continuum models only;
    /// the shared continuum spectrum (`camera`) is fitted without it.
    pub split_prior_tau: f64,
}

impl Default for FitOptions {
    fn default() -> Self {
        Self {
            map: MapChoice::Linear,
            passband: Passband::Gaussian,
            fwhm_guess_nm: 25.0,
            direction: Direction::Auto,
            n_bands: 31,
            background: BackgroundChoice::Auto,
            radial_falloff: true,
            noise_weights: None,
            continuum_knots_fwhm: CONTINUUM_KNOT_FWHM.to_vec(),
            passband_knots_fwhm: PASSBAND_KNOT_FWHM.to_vec(),
            camera: None,
            shared_knots_fwhm: SHARED_KNOT_FWHM.to_vec(),
            shared_smoothness: SHARED_SMOOTHNESS.to_vec(),
            fixed_falloff: None,
            sigma_hint_nm: CONTINUUM_SIGMA_HINT_NM,
            passband_exponent_search: false,
            split_prior_tau: SPLIT_PRIOR_TAU,
        }
    }
}

/// A channel's least-squares rows on the scale of the residuals: Φ's rows and y times the
/// channel's weights `w` (one per sample; empty: unweighted, Φ borrowed and y copied). One
/// place for the weighting of [`Problem::eval_with`] and the shared continuum's joint solve.
pub(crate) fn weighted_rows<'p>(
    phi: &'p DMatrix<f64>,
    y: &[f64],
    w: &[f64],
) -> (std::borrow::Cow<'p, DMatrix<f64>>, DVector<f64>) {
    if w.is_empty() {
        return (
            std::borrow::Cow::Borrowed(phi),
            DVector::from_column_slice(y),
        );
    }
    let wi = |i: usize| w.get(i).copied().unwrap_or(1.0);
    let mut pw = phi.clone();
    for (i, mut row) in pw.row_iter_mut().enumerate() {
        row *= wi(i);
    }
    let yw = DVector::from_fn(y.len(), |i, _| wi(i) * y[i]);
    (std::borrow::Cow::Owned(pw), yw)
}

/// Lawson–Hanson NNLS on normal equations G x = h, with the first `n_free` variables
/// unconstrained. Columns with zero norm stay at zero.
pub(crate) fn nnls_gram(g: &DMatrix<f64>, h: &DVector<f64>, n_free: usize) -> DVector<f64> {
    let k = h.len();
    let scale = (0..k).map(|i| g[(i, i)]).fold(0.0, f64::max).max(1e-300);
    let ridge = 1e-12 * scale;
    // the passive set's Cholesky factor, grown by one row when a variable enters (O(m²)
    // instead of a new O(m³) factorisation per step) and rebuilt when one leaves
    let mut chol = GrowingCholesky::new(g, ridge);
    let mut solve = |passive: &[usize]| -> Option<DVector<f64>> {
        let z = chol.solve(passive, h)?;
        let mut full = DVector::zeros(k);
        for (i, &pi) in passive.iter().enumerate() {
            full[pi] = z[i];
        }
        Some(full)
    };
    let mut passive: Vec<usize> = (0..n_free.min(k)).filter(|&i| g[(i, i)] > 0.0).collect();
    let mut x = if passive.is_empty() {
        DVector::zeros(k)
    } else {
        solve(&passive).unwrap_or_else(|| DVector::zeros(k))
    };
    let tol = 1e-12 * scale.sqrt() * h.norm().max(1e-300);
    for _ in 0..3 * k + 10 {
        let w = h - g * &x;
        let cand = (n_free..k)
            .filter(|j| !passive.contains(j) && g[(*j, *j)] > 0.0)
            .max_by(|&a, &b| w[a].total_cmp(&w[b]));
        let Some(j) = cand.filter(|&j| w[j] > tol) else {
            break;
        };
        passive.push(j);
        let mut guard = 0;
        loop {
            guard += 1;
            let Some(z) = solve(&passive) else {
                passive.retain(|&p| p != j);
                return x;
            };
            let bad: Vec<usize> = passive
                .iter()
                .copied()
                .filter(|&p| p >= n_free && z[p] <= 0.0)
                .collect();
            if bad.is_empty() || guard > 3 * k + 10 {
                x = z;
                break;
            }
            let mut alpha = 1.0f64;
            for &p in &bad {
                let d = x[p] - z[p];
                if d > 0.0 {
                    alpha = alpha.min(x[p] / d);
                }
            }
            x = &x + (z - &x) * alpha;
            passive.retain(|&p| p < n_free || x[p] > 1e-15 * scale.sqrt());
            for i in 0..k {
                if !passive.contains(&i) {
                    x[i] = 0.0;
                }
            }
        }
    }
    x
}

/// The Cholesky factor L Lᵀ = G[P, P] + ridge·I of a Gram matrix restricted to an ordered index
/// set P, kept between calls: a set that extends the last one adds rows (bordered Cholesky),
/// any other is factored anew.
struct GrowingCholesky<'g> {
    g: &'g DMatrix<f64>,
    ridge: f64,
    /// The indices factored so far, in order.
    order: Vec<usize>,
    /// L row-major with stride `g.nrows()`.
    l: Vec<f64>,
    /// False once a row failed (not positive definite): nothing more is added until a rebuild.
    ok: bool,
}

impl<'g> GrowingCholesky<'g> {
    fn new(g: &'g DMatrix<f64>, ridge: f64) -> Self {
        let k = g.nrows();
        Self {
            g,
            ridge,
            order: Vec::with_capacity(k),
            l: vec![0.0; k * k],
            ok: true,
        }
    }

    /// Adds index `p` as the next row; false when the matrix is then not positive definite.
    fn push(&mut self, p: usize) -> bool {
        let k = self.g.nrows();
        let m = self.order.len();
        let row = m * k;
        let mut d = self.g[(p, p)] + self.ridge;
        for i in 0..m {
            let ri = i * k;
            let dot: f64 = (0..i).map(|c| self.l[row + c] * self.l[ri + c]).sum();
            let v = (self.g[(p, self.order[i])] - dot) / self.l[ri + i];
            self.l[row + i] = v;
            d -= v * v;
        }
        if !(d > 0.0 && d.is_finite()) {
            self.ok = false;
            return false;
        }
        self.l[row + m] = d.sqrt();
        self.order.push(p);
        true
    }

    /// Solves (G[P, P] + ridge·I) z = h[P] for the ordered set `passive`; None when that
    /// matrix is not positive definite.
    fn solve(&mut self, passive: &[usize], h: &DVector<f64>) -> Option<Vec<f64>> {
        let extends =
            self.ok && passive.len() >= self.order.len() && passive.starts_with(&self.order);
        if !extends {
            self.order.clear();
            self.ok = true;
        }
        for &p in &passive[self.order.len()..] {
            if !self.push(p) {
                return None;
            }
        }
        let (k, m) = (self.g.nrows(), passive.len());
        let mut z: Vec<f64> = passive.iter().map(|&p| h[p]).collect();
        for i in 0..m {
            let s: f64 = (0..i).map(|c| self.l[i * k + c] * z[c]).sum();
            z[i] = (z[i] - s) / self.l[i * k + i];
        }
        for i in (0..m).rev() {
            let s: f64 = (i + 1..m).map(|r| self.l[r * k + i] * z[r]).sum();
            z[i] = (z[i] - s) / self.l[i * k + i];
        }
        Some(z)
    }
}

/// The separable least-squares problem on one profile: θ = (map coefficients in u, FWHM,
/// fall-off coefficients v_1…v_J); linear per channel: offset b + s·u, one amplitude ≥ 0 per
/// line, continuum coefficients ≥ 0 (see [`crate::lvf::background`]).
pub(crate) struct Problem<'a> {
    u: Vec<f64>,
    y: [&'a [f64]; 3],
    lines: Vec<f64>,
    passband: &'a Passband,
    px_mid: f64,
    half: f64,
    /// Number of map coefficients (2 linear, 3 quadratic).
    n_map: usize,
    terms: BackgroundTerms,
    /// Continuum basis at every sample, row-major n × n_continuum (independent of θ).
    spline: Vec<f64>,
    /// A fixed fall-off at every sample (radial, estimated across the axis), or empty.
    vfix: Vec<f64>,
    /// The camera and spectrum range of a shared continuum, if one may be used.
    camera: Option<(&'a CameraResponse, f64, f64)>,
    /// The shared continuum's basis when `terms.shared_intervals > 0`.
    shared: Option<SharedBasis>,
    /// Wavelength range (nm) of a passband continuum, if one may be used.
    passband_range: Option<(f64, f64)>,
    /// The passband continuum's basis when `terms.passband_intervals > 0`
    /// ([`crate::lvf::passband_continuum`]).
    passband_basis: Option<PassbandBasis>,
    /// Per channel and sample, the weight √(mean variance / variance) of weighted least squares
    /// ([`crate::lvf::noise`]); empty: unweighted.
    w: [Vec<f64>; 3],
    /// s²/RMS² of a shared continuum spectrum: its roughness penalty is this over the
    /// smoothness squared ([`SharedBasis::with_penalty`], [`SHARED_SMOOTHNESS`]).
    shared_penalty_unit: f64,
    /// Priors on the split of unresolved line pairs ([`SplitPrior`]); empty: none.
    splits: Vec<SplitPrior>,
}

/// A prior on how an unresolved pair of lines shares its blob: per channel, the log ratio of
/// the amplitudes A_b/A_a is within `tau` (1σ) of the table's `ratio` (powers p_b/p_a). Added
/// to the per-channel linear solve as the penalty s²·(A_b − ratio·A_a)²/(tau·ratio·Â_a)², with
/// s² the channel's noise variance and Â_a the pair's fitted total shared by the table's split.
/// Free splits let a pair put its blob anywhere within its span, so a mercury lamp's map rested
/// on 435.8 and 546.1 nm alone (docs/performance.md, issue 12, twenty-fifth session).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct SplitPrior {
    pub(crate) a_nm: f64,
    pub(crate) b_nm: f64,
    pub(crate) ratio: f64,
    pub(crate) tau: f64,
}

/// Evaluation of θ: residuals (channel-major, times the weights when the problem is weighted),
/// linear coefficients per channel, SSE of the weighted residuals.
pub(crate) struct Eval {
    pub(crate) residual: Vec<f64>,
    pub(crate) alpha: [DVector<f64>; 3],
    pub(crate) sse: f64,
    pub(crate) n_active: usize,
    /// Effective number of linear parameters (`n_active`, less what a roughness penalty takes).
    pub(crate) dof_linear: f64,
    /// The shared continuum: β and per channel its curve (fall-off included).
    shared: Option<(Vec<f64>, [Vec<f64>; 3])>,
}

pub(crate) const N_BG: usize = 2;

impl<'a> Problem<'a> {
    fn new(
        px: &[f64],
        y: [&'a [f64]; 3],
        lines: Vec<f64>,
        passband: &'a Passband,
        n_map: usize,
        terms: BackgroundTerms,
        vfix: Vec<f64>,
    ) -> Self {
        let lo = px.iter().cloned().fold(f64::INFINITY, f64::min);
        let hi = px.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
        let px_mid = 0.5 * (lo + hi);
        let half = (0.5 * (hi - lo)).max(0.5);
        let u: Vec<f64> = px.iter().map(|p| (p - px_mid) / half).collect();
        let spline = Self::spline_rows(&u, terms);
        Self {
            u,
            y,
            lines,
            passband,
            px_mid,
            half,
            n_map,
            terms,
            spline,
            vfix,
            camera: None,
            shared: None,
            passband_range: None,
            passband_basis: None,
            w: std::array::from_fn(|_| Vec::new()),
            shared_penalty_unit: 0.0,
            splits: Vec::new(),
        }
    }

    /// Variance of a (weighted) residual where the model is right: the mean variance of the
    /// noise model when weighted, else the data's second-difference noise estimate.
    pub(crate) fn noise_variance(&self, model: Option<&crate::lvf::noise::NoiseModel>) -> f64 {
        match model {
            Some(m) if !self.w.iter().all(Vec::is_empty) => m.mean_variance,
            _ => {
                (0..3)
                    .map(|c| profile_noise(self.y[c]).powi(2))
                    .sum::<f64>()
                    / 3.0
            }
        }
    }

    /// Weights every sample's residual (`w`: per channel, one per sample; from
    /// [`crate::lvf::noise::weights`]). Weights of the wrong length are ignored.
    pub(crate) fn set_weights(&mut self, w: [Vec<f64>; 3]) {
        if w.iter().all(|c| c.len() == self.u.len()) {
            self.w = w;
        }
    }

    /// The weight of sample `i` of channel `c` (1 when unweighted).
    fn weight(&self, c: usize, i: usize) -> f64 {
        self.w[c].get(i).copied().unwrap_or(1.0)
    }

    /// Channel `c`'s profile times the weights: the data on the scale of the residuals.
    pub(crate) fn whitened(&self, c: usize) -> Vec<f64> {
        (0..self.u.len())
            .map(|i| self.weight(c, i) * self.y[c][i])
            .collect()
    }

    /// A channel-major residual of this problem back in image units (divided by the weights).
    pub(crate) fn unweighted(&self, residual: &[f64]) -> Vec<f64> {
        let n = self.u.len();
        residual
            .iter()
            .enumerate()
            .map(|(k, r)| r / self.weight(k / n, k % n))
            .collect()
    }

    fn spline_rows(u: &[f64], terms: BackgroundTerms) -> Vec<f64> {
        let k = terms.n_continuum();
        let mut s = vec![0.0; u.len() * k];
        if k > 0 {
            for (i, &ui) in u.iter().enumerate() {
                cubic_bspline_row(ui, terms.continuum_intervals, &mut s[i * k..(i + 1) * k]);
            }
        }
        s
    }

    /// The same data with another map degree and other background terms.
    fn with(&self, n_map: usize, terms: BackgroundTerms) -> Problem<'a> {
        Problem {
            u: self.u.clone(),
            y: self.y,
            lines: self.lines.clone(),
            passband: self.passband,
            px_mid: self.px_mid,
            half: self.half,
            n_map,
            terms,
            spline: Self::spline_rows(&self.u, terms),
            vfix: self.vfix.clone(),
            camera: self.camera,
            shared: match (self.camera, terms.shared_intervals) {
                (Some((cam, lo, hi)), k) if k > 0 => {
                    let penalty = match terms.shared_smoothness_milli {
                        0 => 0.0,
                        m => self.shared_penalty_unit / (f64::from(m) / 1000.0).powi(2),
                    };
                    Some(SharedBasis::new(cam, lo, hi, k).with_penalty(penalty))
                }
                _ => None,
            },
            passband_range: self.passband_range,
            passband_basis: match (self.passband_range, terms.passband_intervals) {
                (Some((lo, hi)), k) if k > 0 => Some(PassbandBasis::new(lo, hi, k)),
                _ => None,
            },
            w: self.w.clone(),
            shared_penalty_unit: self.shared_penalty_unit,
            splits: self.splits.clone(),
        }
    }

    /// The per-channel continuum basis at every sample for θ, row-major n × n_continuum: the
    /// spline in u (independent of θ) or the passband continuum (seen through θ's map and FWHM).
    fn continuum_rows(&self, theta: &[f64]) -> std::borrow::Cow<'_, [f64]> {
        match &self.passband_basis {
            Some(b) => {
                let lams: Vec<f64> = self.u.iter().map(|&u| self.lambda(theta, u)).collect();
                std::borrow::Cow::Owned(b.rows(&lams, self.fwhm(theta), self.passband))
            }
            None => std::borrow::Cow::Borrowed(&self.spline),
        }
    }

    /// The same problem with another line list (the lamp's plus unlisted lines found in the
    /// residual, [`crate::lvf::extra_lines`]).
    pub(crate) fn with_lines(&self, lines: Vec<f64>) -> Problem<'a> {
        let mut p = self.with(self.n_map, self.terms);
        p.lines = lines;
        p
    }

    /// Number of map coefficients (2 linear, 3 quadratic).
    pub(crate) fn n_map(&self) -> usize {
        self.n_map
    }

    /// Number of profile samples per channel.
    pub(crate) fn n_samples(&self) -> usize {
        self.u.len()
    }

    /// Normalised positions u of the samples.
    pub(crate) fn u(&self) -> &[f64] {
        &self.u
    }

    /// The three channels' profiles.
    pub(crate) fn data(&self) -> [&'a [f64]; 3] {
        self.y
    }

    /// Line wavelengths of the model (nm).
    pub(crate) fn lines(&self) -> &[f64] {
        &self.lines
    }

    /// The fixed fall-off at every sample, or empty.
    pub(crate) fn vfix(&self) -> &[f64] {
        &self.vfix
    }

    /// The passband shape.
    pub(crate) fn passband(&self) -> &Passband {
        self.passband
    }

    fn n_theta(&self) -> usize {
        self.n_map + 1 + self.terms.falloff_degree
    }

    pub(crate) fn lambda(&self, theta: &[f64], u: f64) -> f64 {
        theta[..self.n_map]
            .iter()
            .rev()
            .fold(0.0, |acc, c| acc * u + c)
    }

    pub(crate) fn fwhm(&self, theta: &[f64]) -> f64 {
        theta[self.n_map]
    }

    pub(crate) fn falloff_coefficients<'t>(&self, theta: &'t [f64]) -> &'t [f64] {
        &theta[self.n_map + 1..]
    }

    /// θ of this problem from θ of another (map, FWHM kept; fall-off kept where both have it).
    pub(crate) fn theta_from(&self, other: &Problem, theta: &[f64]) -> Vec<f64> {
        let mut t = vec![0.0; self.n_theta()];
        let k = self.n_map.min(other.n_map);
        t[..k].copy_from_slice(&theta[..k]);
        t[self.n_map] = other.fwhm(theta);
        let of = other.falloff_coefficients(theta);
        for (j, v) in of.iter().enumerate().take(self.terms.falloff_degree) {
            t[self.n_map + 1 + j] = *v;
        }
        t
    }

    /// Design matrix for θ with the given line wavelengths: offset, lines, continuum.
    fn design(&self, theta: &[f64], lines: &[f64]) -> DMatrix<f64> {
        let n = self.u.len();
        let nc = self.terms.n_continuum();
        let k = N_BG + lines.len() + nc;
        let fwhm = self.fwhm(theta);
        let v = self.falloff_coefficients(theta);
        let cont = self.continuum_rows(theta);
        // Beyond its support the passband is exactly 0: skip its evaluation there (a
        // generalised normal's powf is most of a fit's time otherwise). The margin keeps every
        // value the same as eval's own cut-off gives, rounding included.
        let reach = self.passband.support_nm(fwhm) * (1.0 + 1e-9);
        let mut phi = DMatrix::zeros(n, k);
        for (i, &u) in self.u.iter().enumerate() {
            let lam = self.lambda(theta, u);
            let f = falloff(v, u) * self.vfix.get(i).copied().unwrap_or(1.0);
            phi[(i, 0)] = 1.0;
            phi[(i, 1)] = u;
            for (j, &l) in lines.iter().enumerate() {
                if (l - lam).abs() <= reach {
                    phi[(i, N_BG + j)] = f * self.passband.eval(l - lam, fwhm);
                }
            }
            for j in 0..nc {
                phi[(i, N_BG + lines.len() + j)] = f * cont[i * nc + j];
            }
        }
        phi
    }

    pub(crate) fn eval_with(&self, theta: &[f64], lines: &[f64]) -> Eval {
        let phi = self.design(theta, lines);
        if let Some(sb) = &self.shared {
            return self.eval_shared(theta, &phi, sb);
        }
        let n = self.u.len();
        let unweighted = self.w.iter().all(Vec::is_empty);
        let g = unweighted.then(|| phi.transpose() * &phi);
        let mut residual = Vec::with_capacity(3 * n);
        let mut sse = 0.0;
        let mut n_active = 0;
        let pairs: Vec<(usize, usize, f64, f64)> = self
            .splits
            .iter()
            .filter_map(|sp| {
                let ia = lines.iter().position(|&l| l == sp.a_nm)?;
                let ib = lines.iter().position(|&l| l == sp.b_nm)?;
                Some((N_BG + ia, N_BG + ib, sp.ratio, sp.tau))
            })
            .collect();
        let alpha: [DVector<f64>; 3] = std::array::from_fn(|c| {
            // weighted: rows of Φ and y times the channel's weights, a Gram per channel
            let (phi_c, y) = weighted_rows(&phi, self.y[c], &self.w[c]);
            let h = phi_c.transpose() * &y;
            let own;
            let gc = match &g {
                Some(g) => g,
                None => {
                    own = phi_c.transpose() * phi_c.as_ref();
                    &own
                }
            };
            let mut a = nnls_gram(gc, &h, N_BG);
            if !pairs.is_empty() {
                let s2 = profile_noise(y.as_slice()).powi(2);
                let mut gp = gc.clone();
                let mut any = false;
                for &(ja, jb, rho, tau) in &pairs {
                    let aa = (a[ja] + a[jb]) / (1.0 + rho);
                    if aa > 0.0 && s2 > 0.0 {
                        let kappa = s2 / (tau * rho * aa).powi(2);
                        gp[(jb, jb)] += kappa;
                        gp[(ja, ja)] += kappa * rho * rho;
                        gp[(ja, jb)] -= kappa * rho;
                        gp[(jb, ja)] -= kappa * rho;
                        any = true;
                    }
                }
                if any {
                    a = nnls_gram(&gp, &h, N_BG);
                }
            }
            n_active += a.iter().filter(|v| **v != 0.0).count();
            let r = y - phi_c.as_ref() * &a;
            sse += r.norm_squared();
            residual.extend(r.iter());
            a
        });
        Eval {
            residual,
            alpha,
            sse,
            n_active,
            dof_linear: n_active as f64,
            shared: None,
        }
    }

    /// [`Problem::eval_with`] with a continuum shared by the channels: one joint NNLS.
    fn eval_shared(&self, theta: &[f64], phi: &DMatrix<f64>, sb: &SharedBasis) -> Eval {
        let v = self.falloff_coefficients(theta);
        let lams: Vec<f64> = self.u.iter().map(|&u| self.lambda(theta, u)).collect();
        let scale: Vec<f64> = (0..self.u.len())
            .map(|i| falloff(v, self.u[i]) * self.vfix.get(i).copied().unwrap_or(1.0))
            .collect();
        let cols = sb.columns(&lams, &scale, self.fwhm(theta), self.passband);
        let (alpha, beta, curve, dof_linear) =
            solve_joint(phi, self.y, &cols, sb.n(), N_BG, &self.w, sb.penalty);
        let n = self.u.len();
        let mut residual = Vec::with_capacity(3 * n);
        let mut sse = 0.0;
        for c in 0..3 {
            let fit = phi * &alpha[c];
            for i in 0..n {
                let r = self.weight(c, i) * (self.y[c][i] - fit[i] - curve[c][i]);
                sse += r * r;
                residual.push(r);
            }
        }
        let n_active = alpha
            .iter()
            .map(|a| a.iter().filter(|v| **v != 0.0).count())
            .sum::<usize>()
            + beta.iter().filter(|b| **b != 0.0).count();
        Eval {
            residual,
            alpha,
            sse,
            n_active,
            dof_linear,
            shared: Some((beta, curve)),
        }
    }

    pub(crate) fn eval(&self, theta: &[f64]) -> Eval {
        self.eval_with(theta, &self.lines)
    }

    /// Inside the domain: finite, 1 < FWHM < 200 nm, a non-vanishing slope, and a fall-off
    /// that stays between 0.05 and 5 over the profile.
    pub(crate) fn valid(&self, theta: &[f64]) -> bool {
        let f = self.fwhm(theta);
        let v = self.falloff_coefficients(theta);
        theta.iter().all(|v| v.is_finite())
            && f > 1.0
            && f < 200.0
            && theta[1].abs() > 1e-3
            && (0..=20).all(|i| {
                let x = falloff(v, -1.0 + 0.1 * i as f64);
                (0.05..5.0).contains(&x)
            })
    }

    fn jacobian(&self, theta: &[f64]) -> DMatrix<f64> {
        let p = theta.len();
        let cols = central_difference_columns(
            theta,
            |j| {
                if j < self.n_map {
                    1e-4 * theta[j].abs().max(1.0)
                } else if j == self.n_map {
                    1e-5 * theta[j].abs().max(1.0)
                } else {
                    1e-5
                }
            },
            |t| self.eval(t).residual,
        );
        let m = cols[0].len();
        DMatrix::from_fn(m, p, |i, j| cols[j][i])
    }

    /// Levenberg–Marquardt ([`fit::lm`](crate::fit::lm)) on the projected residual.
    fn levenberg_marquardt(&self, theta0: &[f64]) -> Fitted {
        let p = theta0.len();
        let opts = LmOptions {
            covariance: true,
            ..LmOptions::default()
        };
        let rep = levenberg_marquardt(&Projected { problem: self, p }, theta0, &opts);
        let eval = self.eval(&rep.theta);
        let m = eval.residual.len();
        let jac = match rep.jacobian {
            Some(j) => DMatrix::from_column_slice(m, p, &j),
            None => self.jacobian(&rep.theta),
        };
        Fitted {
            theta: rep.theta,
            eval,
            jac,
            iterations: rep.iterations,
        }
    }

    /// BIC = N·ln(SSE/N) + k·ln N of a fit of this problem.
    pub(crate) fn bic(&self, fit: &Fitted) -> f64 {
        let n = (3 * self.u.len()) as f64;
        let k = self.n_theta() as f64 + fit.eval.dof_linear;
        n * (fit.eval.sse.max(1e-300) / n).ln() + k * n.ln()
    }
}

/// A refined θ with its evaluation, Jacobian and iteration count.
pub(crate) struct Fitted {
    pub(crate) theta: Vec<f64>,
    pub(crate) eval: Eval,
    pub(crate) jac: DMatrix<f64>,
    pub(crate) iterations: usize,
}

/// The projected problem of θ for [`fit::lm`](crate::fit::lm): residuals of all three channels
/// with the linear coefficients solved by NNLS; θ outside [`Problem::valid`] is outside the
/// domain. The Jacobian is the problem's own central differences (one rayon task per column,
/// steps scaled per parameter).
struct Projected<'p, 'a> {
    problem: &'p Problem<'a>,
    p: usize,
}

impl Residuals for Projected<'_, '_> {
    fn n_residuals(&self) -> usize {
        3 * self.problem.u.len()
    }
    fn n_params(&self) -> usize {
        self.p
    }
    fn residuals(&self, theta: &[f64], out: &mut [f64]) -> bool {
        if !self.problem.valid(theta) {
            return false;
        }
        out.copy_from_slice(&self.problem.eval(theta).residual);
        true
    }
    fn jacobian(&self, theta: &[f64], jac: &mut [f64]) -> bool {
        jac.copy_from_slice(self.problem.jacobian(theta).as_slice());
        true
    }
}

/// λ increases with px? From the centroids of the blue and red channels' positive signal.
impl Direction {
    /// Whether wavelength increases with position: as given, or detected from the profile
    /// (`Auto`, see [`detect_direction`]).
    pub(crate) fn is_increasing(self, profile: &Profile) -> Result<bool> {
        match self {
            Direction::Auto => detect_direction(profile),
            Direction::Increasing => Ok(true),
            Direction::Decreasing => Ok(false),
        }
    }
}

pub(crate) fn detect_direction(profile: &Profile) -> Result<bool> {
    let centroid = |c: usize| {
        let v = &profile.values[c];
        let mut sorted = v.clone();
        sorted.sort_by(f64::total_cmp);
        let base = sorted[sorted.len() / 10];
        let (mut sw, mut swx) = (0.0, 0.0);
        for (x, y) in profile.px.iter().zip(v) {
            let w = (y - base).max(0.0);
            sw += w;
            swx += w * x;
        }
        (sw > 0.0).then(|| swx / sw)
    };
    let len = profile.px.last().unwrap_or(&0.0) - profile.px.first().unwrap_or(&0.0);
    match (centroid(2), centroid(0)) {
        (Some(b), Some(r)) if (r - b).abs() > 0.02 * len.abs() => Ok(r > b),
        _ => Err(Error::invalid(
            "--direction",
            format!(
                "{}: cannot tell from the colour channels which end of the filter is blue (the blue and red light are not separated); give --direction increasing|decreasing",
                profile.source
            ),
        )),
    }
}

/// Checks that the profile shows lines at all: the largest channel range must exceed 20 times
/// the point-to-point noise.
pub(crate) fn check_signal(profile: &Profile) -> Result<()> {
    let mut best = 0.0f64;
    for v in &profile.values {
        let mut s = v.clone();
        s.sort_by(f64::total_cmp);
        let range = s[s.len() - 1] - s[s.len() / 10];
        let diffs: Vec<f64> = v.windows(2).map(|w| (w[1] - w[0]).abs()).collect();
        let mut d = diffs.clone();
        d.sort_by(f64::total_cmp);
        let noise = d.get(d.len() / 2).copied().unwrap_or(0.0) / 0.954; // median |Δ| of white noise = 0.954 σ
        let ratio = if noise > 0.0 {
            range / noise
        } else if range > 0.0 {
            f64::INFINITY
        } else {
            0.0
        };
        best = best.max(ratio);
    }
    if best < 20.0 {
        return Err(Error::invalid(
            "lamp image",
            format!(
                "{}: no lamp lines in ROI {:?} (signal range is only {best:.1}× the noise); check the ROI, the exposure and that the lamp was on",
                profile.source, profile.roi
            ),
        ));
    }
    Ok(())
}

fn downsample(profile: &Profile, max_points: usize) -> (Vec<f64>, [Vec<f64>; 3]) {
    let n = profile.px.len();
    let bin = n.div_ceil(max_points).max(1);
    let mut px = Vec::new();
    let mut ys: [Vec<f64>; 3] = Default::default();
    for chunk in (0..n).collect::<Vec<_>>().chunks(bin) {
        let k = chunk.len() as f64;
        px.push(chunk.iter().map(|&i| profile.px[i]).sum::<f64>() / k);
        for (c, y) in ys.iter_mut().enumerate() {
            y.push(chunk.iter().map(|&i| profile.values[c][i]).sum::<f64>() / k);
        }
    }
    (px, ys)
}

/// The shift of one group of unresolved lines (`idx`: indices into `pr.lines`), alone, that
/// fits the profile best at θ, and its standard uncertainty (nm); `None` when the profile does
/// not determine it ([`LINE_SHIFT_DETERMINED_FWHM`]).
///
/// The group moves rigidly, every line keeping its own free amplitude, all other lines where the
/// map puts them, so that at d = 0 the cost is the fit's own SSE and a chain of lines wider than
/// the passband (a CFL's 577–612 nm) is drawn as it is. The cost can have more than one basin
/// (unresolved lines with free amplitudes can swap roles), so its minimum is searched on a grid
/// of ±½ FWHM first and refined by Brent in its cell. σ is half the width of the interval where
/// Δχ² = (SSE(d) − SSE*)/s² ≤ 1 (profile likelihood: a blend's cost can be flat-bottomed, where
/// the curvature at the minimum would understate it), with s² the noise variance where the
/// group's blobs lie (within one FWHM of its lines; shot noise makes it larger there than in the
/// gaps) from the data's second differences, floored at `s2_floor`. Not determined: an interval
/// that reaches the edge of the search, σ above the bound, or another basin within Δχ² of
/// [`LINE_SHIFT_OTHER_CHI2`]. For a blend (several lines within [`BLEND_SPAN_FWHM`]) what is
/// returned is the move of the group's centroid ([`centroid`]) from the fit (`fit_eval`, θ's
/// own evaluation) to the best d, and half its range over the interval's ends and the best d.
fn group_shift(
    pr: &Problem,
    theta: &[f64],
    fit_eval: &Eval,
    lams: &[f64],
    idx: &[usize],
    fwhm: f64,
    s2_floor: f64,
) -> Option<(f64, f64)> {
    let cost = |d: f64| {
        let mut l = pr.lines.clone();
        for &i in idx {
            l[i] += d;
        }
        pr.eval_with(theta, &l).sse
    };
    let step = LINE_SHIFT_GRID_FWHM * fwhm;
    let n_grid = (0.5 / LINE_SHIFT_GRID_FWHM).round() as i32;
    let grid: Vec<(f64, f64)> = (-n_grid..=n_grid)
        .map(|i| (f64::from(i) * step, cost(f64::from(i) * step)))
        .collect();
    let (d_grid, _) = grid.iter().copied().min_by(|a, b| a.1.total_cmp(&b.1))?;
    let d = brent_min(
        cost,
        (d_grid - step).max(-0.5 * fwhm),
        (d_grid + step).min(0.5 * fwhm),
        1e-4,
    );
    let window: Vec<usize> = (0..lams.len())
        .filter(|&i| idx.iter().any(|&k| (lams[i] - pr.lines[k]).abs() <= fwhm))
        .collect();
    let s2 = ((0..3)
        .map(|c| {
            let wy = pr.whitened(c);
            let v: Vec<f64> = window.iter().map(|&i| wy[i]).collect();
            profile_noise(&v).powi(2)
        })
        .sum::<f64>()
        / 3.0)
        .max(s2_floor);
    // σ: half the width of {d : Δχ²(d) ≤ 1} (the profile-likelihood interval; a blend's cost can
    // be flat-bottomed, where the curvature at the minimum would understate it), each end
    // bracketed by the first grid point beyond d with Δχ² > 1 and bisected.
    let c0 = cost(d);
    let dchi2 = |x: f64| (cost(x) - c0) / s2;
    let crossing = |outward: f64| -> Option<f64> {
        let far = grid
            .iter()
            .filter(|(di, ci)| (di - d) * outward > 0.0 && (ci - c0) / s2 > 1.0)
            .min_by(|a, b| ((a.0 - d) * outward).total_cmp(&((b.0 - d) * outward)))?;
        let (mut inside, mut outside) = (d, far.0);
        for _ in 0..LINE_SHIFT_BISECTIONS {
            let mid = 0.5 * (inside + outside);
            if dchi2(mid) > 1.0 {
                outside = mid;
            } else {
                inside = mid;
            }
        }
        Some(0.5 * (inside + outside))
    };
    let (lo, hi) = (crossing(-1.0), crossing(1.0));
    let sigma = match (lo, hi) {
        (Some(lo), Some(hi)) => 0.5 * (hi - lo),
        _ => f64::INFINITY,
    };
    let other_basin = grid
        .iter()
        .filter(|(di, _)| (di - d).abs() > 2.0 * step)
        .any(|(_, ci)| (ci - c0) / s2 < LINE_SHIFT_OTHER_CHI2);
    if other_basin || sigma > LINE_SHIFT_DETERMINED_FWHM * fwhm {
        return None;
    }
    let span = idx
        .iter()
        .map(|&i| pr.lines[i])
        .fold([f64::INFINITY, f64::NEG_INFINITY], |[a, b], l| {
            [a.min(l), b.max(l)]
        });
    let blend = idx.len() > 1 && span[1] - span[0] <= BLEND_SPAN_FWHM * fwhm;
    match (blend, lo, hi) {
        (false, _, _) => Some((d, sigma)),
        // A blend narrower than the passband reports its centroid's move: its lines' free
        // amplitudes can trade their split for a rigid shift (a CFL's 542.4 / 546.1 nm moved
        // −1.7 ± 0.4 nm on 5 % draws whose map was right), and the blob's place is the
        // amplitude-weighted mean. A chain wider than that (a CFL's 577–612 nm) is not one
        // blob: its shift is reported.
        (true, Some(lo), Some(hi)) => {
            let c0 = centroid(fit_eval, &pr.lines, idx)?;
            let at = [lo, d, hi].map(|x| {
                let mut l = pr.lines.clone();
                for &i in idx {
                    l[i] += x;
                }
                centroid(&pr.eval_with(theta, &l), &l, idx)
            });
            let [Some(c_lo), Some(c_d), Some(c_hi)] = at else {
                return None;
            };
            let spread = c_lo.max(c_d).max(c_hi) - c_lo.min(c_d).min(c_hi);
            Some((c_d - c0, 0.5 * spread))
        }
        _ => None,
    }
}

/// The amplitude-weighted mean wavelength (nm) of the lines `idx` of `lines` in the evaluation
/// `e` of those lines, amplitudes summed over the channels; None when the group has no
/// amplitude.
fn centroid(e: &Eval, lines: &[f64], idx: &[usize]) -> Option<f64> {
    let (mut sw, mut swl) = (0.0, 0.0);
    for &i in idx {
        let a: f64 = (0..3).map(|c| e.alpha[c][N_BG + i]).sum();
        sw += a;
        swl += a * lines[i];
    }
    (sw > 0.0).then(|| swl / sw)
}

/// Lines grouped when closer than `gap` nm (consecutive).
pub(crate) fn group_lines(lines: &[f64], gap: f64) -> Vec<Vec<usize>> {
    let mut groups: Vec<Vec<usize>> = Vec::new();
    for (i, &l) in lines.iter().enumerate() {
        match groups.last_mut() {
            Some(g) if l - lines[*g.last().unwrap_or(&i)] < gap => g.push(i),
            _ => groups.push(vec![i]),
        }
    }
    groups
}

/// Whole-profile calibration of an LVF lamp profile (see the module docs and
/// [`crate::lvf::background`]).
///
/// # Errors
/// [`Error::InvalidArgument`] when the profile shows no lines or the direction cannot be told;
/// [`Error::Numerical`] when no fit explains the profile, or the fitted map is physically
/// impossible (see [`assess`]).
pub fn calibrate_whole_profile(
    profile: &Profile,
    lamp: &Lamp,
    opts: &FitOptions,
) -> Result<LvfCalibration> {
    // The passband's exponent β by BIC (profile likelihood over β; the same data and the same
    // parameter count at every β): a grid, then Brent's method between the best grid
    // point's neighbours. With the passband taken as Gaussian, a passband of β = 2.5 put the
    // per-channel continuum under the lines and the map 8 nm off at 700 nm (docs/performance.md,
    // issue 12, twenty-first session).
    let shape = |beta: f64| {
        if beta == 2.0 {
            Passband::Gaussian
        } else {
            Passband::GenNormal { beta }
        }
    };
    // Each exponent is fitted with the coarsest spline continuum as the background (one fit,
    // no search for unlisted lines): its elements are far wider than a line blob, so it cannot
    // take up a wrong passband shape, and a wrong shape's misfit does not start the slow
    // searches of the full fit (gennorm:1.25 took 21 s on a Gaussian image, the full fit 1 s).
    // The chosen exponent is then fitted as the options ask.
    let fit_at = |beta: f64| -> Result<(LvfCalibration, f64)> {
        let o = FitOptions {
            passband: shape(beta),
            passband_exponent_search: false,
            background: BackgroundChoice::Fixed {
                continuum: true,
                falloff_degree: 0,
            },
            ..opts.clone()
        };
        let cal = calibrate_shape(profile, lamp, &o)?;
        let bic = cal
            .background
            .as_ref()
            .and_then(|b| b.candidates.iter().find(|c| c.delta_bic == 0.0))
            .map_or(f64::INFINITY, |c| c.bic);
        Ok((cal, bic))
    };
    if !opts.passband_exponent_search {
        let mut cal = calibrate_shape(profile, lamp, opts)?;
        // A Gaussian passband that leaves structure: is the shape the cause? β a little either
        // side of 2, each with the coarse continuum (three fits, only on such a profile).
        let over = cal.diagnostics["residual_over_noise"]
            .as_f64()
            .unwrap_or(0.0);
        if matches!(opts.passband, Passband::Gaussian)
            && opts.background == BackgroundChoice::Auto
            && over > SHAPE_CHECK_OVER_NOISE
        {
            let at = |b: f64| fit_at(b).map_or(f64::INFINITY, |f| f.1);
            let (lo, mid, hi) = (at(1.75), at(2.0), at(2.25));
            let (gain, beta) = if lo < hi {
                (mid - lo, 1.75)
            } else {
                (mid - hi, 2.25)
            };
            // and the shape must explain much of the misfit: the residual sum of squares at
            // least SHAPE_CHECK_SSE_DROP lower (BIC gain = N·ln(SSE₂/SSE_β)), not the few
            // per cent another β wins on a profile that is no lamp of this list at all (a
            // blackbody frame with --lamp hg: 4 %; a β = 4 passband: 31 %, β = 2.2: 87 %)
            let n_obs = (3 * profile.px.len()).max(1) as f64;
            let sse_drop = 1.0 - (-gain / n_obs).exp();
            cal.diagnostics["passband_shape_check"] = serde_json::json!({
                "bic_at_beta_1_75_2_2_25": [lo, mid, hi],
                "sse_drop": sse_drop,
                "note": "a generalised-normal passband exp(−ln2·|2Δλ/FWHM|^β) either side of the Gaussian (β = 2), each fitted with the coarsest spline continuum; run because residual_over_noise exceeded 1.3; a warning when one lowers BIC by more than 25 and the residual sum of squares by at least 20 %"
            });
            if gain > SHAPE_CHECK_DELTA_BIC && sse_drop >= SHAPE_CHECK_SSE_DROP {
                // first: the other warnings (displaced lines, a wide σ) are its symptoms
                cal.warnings.insert(
                    0,
                    format!(
                    "the passband may not be Gaussian: exponent β = {beta} instead of 2 lowers BIC by {gain:.0} (with the coarsest continuum; residual {over:.2}× the noise); a wrong shape moves the continuum and the lines — fit the shape with --passband gennorm, or give a measured one (--passband FILE.csv)"
                    ),
                );
            }
        }
        return Ok(cal);
    }
    // (BIC, β) of the best exponent so far
    type Best = Option<(f64, f64)>;
    let mut tried: Vec<(f64, f64)> = Vec::new();
    let mut best: Best = None;
    let mut first_err: Option<Error> = None;
    let consider = |beta: f64,
                    best: &mut Best,
                    tried: &mut Vec<(f64, f64)>,
                    first_err: &mut Option<Error>| match fit_at(beta) {
        Ok((_, bic)) => {
            tried.push((beta, bic));
            if best.as_ref().is_none_or(|b| bic < b.0) {
                *best = Some((bic, beta));
            }
        }
        Err(e) => {
            first_err.get_or_insert(e);
        }
    };
    for &beta in &PASSBAND_EXPONENTS {
        consider(beta, &mut best, &mut tried, &mut first_err);
    }
    // Brent's method (the crate's one 1-D minimiser, `math::minimize::brent_min` on argmin) in
    // ln β between the best grid point's neighbours: the BIC over β is sharply peaked (on a
    // β = 2.2 image −43,308 at 2.0, −50,529 at 2.25, −42,189 at 2.5)
    if let Some(b) = best.as_ref().map(|b| b.1) {
        let i = PASSBAND_EXPONENTS.iter().position(|&x| x == b).unwrap_or(0);
        let lo = PASSBAND_EXPONENTS[i.saturating_sub(1)].ln();
        let hi = PASSBAND_EXPONENTS[(i + 1).min(PASSBAND_EXPONENTS.len() - 1)].ln();
        let state =
            std::cell::RefCell::new((best.take(), std::mem::take(&mut tried), first_err.take()));
        crate::math::minimize::brent_min(
            |x: f64| {
                let mut st = state.borrow_mut();
                let (best, tried, first_err) = &mut *st;
                consider(x.exp(), best, tried, first_err);
                tried
                    .iter()
                    .find(|t| (t.0 - x.exp()).abs() < 1e-12)
                    .map_or(f64::INFINITY, |t| t.1)
            },
            lo,
            hi,
            PASSBAND_EXPONENT_TOL_LN,
        );
        (best, tried, first_err) = state.into_inner();
    }
    let Some((_, beta)) = best else {
        return Err(first_err.unwrap_or_else(|| Error::Numerical {
            what: "LVF whole-profile fit".into(),
            reason: "no passband exponent could be fitted".into(),
        }));
    };
    let mut cal = calibrate_shape(
        profile,
        lamp,
        &FitOptions {
            passband: shape(beta),
            passband_exponent_search: false,
            ..opts.clone()
        },
    )?;
    tried.sort_by(|a, b| a.0.total_cmp(&b.0));
    cal.passband["exponent_search"] = serde_json::json!(tried
        .iter()
        .map(|(b, bic)| serde_json::json!({"beta": b, "bic": bic}))
        .collect::<Vec<_>>());
    cal.passband["exponent_note"] = serde_json::json!(
        "β chosen by BIC over the exponents tried, each fitted with the coarsest spline continuum as the background (exponent_search), then fitted with the background chosen as asked; σ at 400/700 nm does not include β's uncertainty"
    );
    Ok(cal)
}

/// Residual over noise above which a Gaussian passband's shape is checked (the check fits
/// β = 1.75, 2 and 2.25 with the coarsest continuum). Well-fitted profiles sit at 1.0–1.1; a
/// β = 2.2 passband taken as Gaussian left 2.2.
const SHAPE_CHECK_OVER_NOISE: f64 = 1.3;
/// BIC gain of β = 1.75 or 2.25 over the Gaussian above which the shape warning is given.
const SHAPE_CHECK_DELTA_BIC: f64 = 25.0;
/// The fraction by which β = 1.75 or 2.25 must lower the residual sum of squares for the shape
/// warning.
const SHAPE_CHECK_SSE_DROP: f64 = 0.2;

/// Tolerance in ln β of the Brent search of `--passband gennorm` after the grid (β to ≈ 1 %).
const PASSBAND_EXPONENT_TOL_LN: f64 = 0.01;

/// The exponents β of the passband tried by `--passband gennorm` (β = 2: the Gaussian).
pub const PASSBAND_EXPONENTS: [f64; 10] = [1.25, 1.5, 1.75, 2.0, 2.25, 2.5, 3.0, 3.5, 4.0, 6.0];

/// [`calibrate_whole_profile`] with the passband's shape given.
fn calibrate_shape(profile: &Profile, lamp: &Lamp, opts: &FitOptions) -> Result<LvfCalibration> {
    check_signal(profile)?;
    let increasing = opts.direction.is_increasing(profile)?;
    let sign = if increasing { 1.0 } else { -1.0 };
    let lines: Vec<f64> = lamp.lines.iter().map(|l| l.nm).collect();

    // Coarse grid on a downsampled profile.
    let (cpx, cys) = downsample(profile, 240);
    let coarse = Problem::new(
        &cpx,
        [&cys[0], &cys[1], &cys[2]],
        lines.clone(),
        &opts.passband,
        2,
        BackgroundTerms::LINEAR,
        Vec::new(),
    );
    let a0s: Vec<f64> = (0..=200).map(|i| 350.0 + 2.0 * i as f64).collect();
    let mut a1s = Vec::new();
    let mut a1 = 15.0;
    while a1 < 900.0 {
        a1s.push(a1);
        a1 *= 1.03;
    }
    let fwhm0 = opts.fwhm_guess_nm;
    let mut grid: Vec<(f64, f64, f64)> = a0s
        .par_iter()
        .flat_map_iter(|&a0| {
            let coarse = &coarse;
            a1s.iter().map(move |&a1| {
                let th = [a0, sign * a1, fwhm0];
                (coarse.eval(&th).sse, a0, a1)
            })
        })
        .collect();
    grid.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut starts: Vec<(f64, f64)> = Vec::new();
    for &(_, a0, a1) in &grid {
        if starts
            .iter()
            .all(|&(b0, b1)| (a0 - b0).abs() > 8.0 || (a1 / b1).ln().abs() > 0.08)
        {
            starts.push((a0, a1));
        }
        if starts.len() >= 6 {
            break;
        }
    }

    // Radial fall-off from the strips across the axis (applied when significant).
    let fixed = opts
        .fixed_falloff
        .as_ref()
        .filter(|v| v.len() == profile.px.len() && v.iter().all(|x| x.is_finite() && *x > 0.0));
    let radial = if opts.radial_falloff && fixed.is_none() {
        estimate_radial_falloff(profile)
    } else {
        None
    };
    let radial_applied = radial.as_ref().is_some_and(|r| r.significant());
    let vfix = match (fixed, &radial, radial_applied) {
        (Some(v), _, _) => v.clone(),
        (None, Some(r), true) => r.along.clone(),
        _ => Vec::new(),
    };

    // Refine on the full profile with the linear offset only.
    let mut full = Problem::new(
        &profile.px,
        [&profile.values[0], &profile.values[1], &profile.values[2]],
        lines.clone(),
        &opts.passband,
        2,
        BackgroundTerms::LINEAR,
        vfix,
    );
    let noise_model = opts
        .noise_weights
        .unwrap_or(opts.camera.is_some())
        .then(|| {
            crate::lvf::noise::estimate([
                &profile.values[0],
                &profile.values[1],
                &profile.values[2],
            ])
        })
        .flatten();
    if let Some(m) = &noise_model {
        full.set_weights(crate::lvf::noise::weights(
            m,
            [&profile.values[0], &profile.values[1], &profile.values[2]],
        ));
    }
    full.splits = split_priors(lamp, opts.split_prior_tau);
    let mut plain: Vec<Fitted> = starts
        .par_iter()
        .map(|&(a0, a1)| full.levenberg_marquardt(&[a0, sign * a1, fwhm0]))
        .collect();
    plain.sort_by(|a, b| a.eval.sse.total_cmp(&b.eval.sse));
    let Some(plain_best) = plain.first() else {
        return Err(Error::Numerical {
            what: "LVF whole-profile fit".into(),
            reason: "no starting point".into(),
        });
    };

    // Background terms: candidates, each refined from the best (and for a continuum also the
    // second best) linear-offset fit, chosen by BIC.
    let span = (full.lambda(&plain_best.theta, 1.0) - full.lambda(&plain_best.theta, -1.0)).abs();
    let fwhm_plain = full.fwhm(&plain_best.theta).min(4.0 * fwhm0);
    let k_of = |knot: f64| continuum_intervals_for(span, fwhm_plain, knot);
    let knots: &[f64] = if opts.continuum_knots_fwhm.is_empty() {
        &CONTINUUM_KNOT_FWHM
    } else {
        &opts.continuum_knots_fwhm
    };
    let k_coarse = k_of(knots[0]);
    let with_k = |continuum: bool, falloff_degree: usize| BackgroundTerms {
        continuum_intervals: if continuum { k_coarse } else { 0 },
        falloff_degree,
        ..BackgroundTerms::LINEAR
    };
    let mut auto = vec![with_k(false, 0), with_k(true, 0)];
    for &knot in &knots[1..] {
        let t = BackgroundTerms {
            continuum_intervals: k_of(knot),
            ..BackgroundTerms::LINEAR
        };
        if !auto.contains(&t) {
            auto.push(t);
        }
    }
    // Per-channel continuum spectra seen through the passband (crate::lvf::passband_continuum),
    // on the range the passband sees from the profile's ends.
    if !opts.passband_knots_fwhm.is_empty() {
        let l0 = full.lambda(&plain_best.theta, -1.0);
        let l1 = full.lambda(&plain_best.theta, 1.0);
        let reach = PASSBAND_REACH_FWHM * fwhm_plain;
        let (lo, hi) = (l0.min(l1) - reach, l0.max(l1) + reach);
        full.passband_range = Some((lo, hi));
        for &knot in &opts.passband_knots_fwhm {
            let t = BackgroundTerms {
                passband_intervals: PassbandBasis::intervals_for(lo, hi, fwhm_plain, knot),
                ..BackgroundTerms::LINEAR
            };
            if !auto.contains(&t) {
                auto.push(t);
            }
        }
    }
    // A continuum spectrum shared by the channels, when the camera is known: its range is what
    // the passband sees from the profile's ends (±1.5 FWHM).
    if let Some(cam) = &opts.camera {
        let l0 = full.lambda(&plain_best.theta, -1.0);
        let l1 = full.lambda(&plain_best.theta, 1.0);
        let reach = 1.5 * fwhm_plain;
        if let Some((lo, hi)) = SharedBasis::range(cam, l0.min(l1) - reach, l0.max(l1) + reach) {
            full.camera = Some((cam, lo, hi));
            // the roughness penalty's scale: the RMS from an unpenalised pilot on knots 1.5 FWHM apart at the
            // linear-offset fit's map (one linear solve), s² from the noise
            let pilot = full.with(
                full.n_map,
                BackgroundTerms {
                    shared_intervals: SharedBasis::intervals_for(lo, hi, 1.5 * fwhm_plain),
                    ..BackgroundTerms::LINEAR
                },
            );
            let pe = pilot.eval(&plain_best.theta);
            let rms = match (&pe.shared, &pilot.shared) {
                (Some((beta, _)), Some(sb)) => sb.spectrum_rms(beta),
                _ => 0.0,
            };
            full.shared_penalty_unit = if rms > 0.0 {
                full.noise_variance(noise_model.as_ref()) / (rms * rms)
            } else {
                0.0
            };
            for &knot in &opts.shared_knots_fwhm {
                for &smooth in &opts.shared_smoothness {
                    let t = BackgroundTerms {
                        shared_intervals: SharedBasis::intervals_for(lo, hi, knot * fwhm_plain),
                        shared_smoothness_milli: (1000.0 * smooth).round().max(0.0) as u32,
                        ..BackgroundTerms::LINEAR
                    };
                    if !auto.contains(&t) {
                        auto.push(t);
                    }
                }
            }
        }
    }
    let full = full;
    let (candidates, selection_rule) = match opts.background {
        BackgroundChoice::Auto => (auto, "bic"),
        BackgroundChoice::Fixed {
            continuum,
            falloff_degree,
        } => (vec![with_k(continuum, falloff_degree.min(6))], "requested"),
    };
    let ln_n = ((3 * profile.px.len()) as f64).ln();
    let ident = identification_starts(&full, &plain, fwhm0);
    let starts: Vec<&[f64]> = ident.iter().map(|f| f.theta.as_slice()).collect();
    let Candidates {
        pr: mut chosen_pr,
        fit: mut chosen_fit,
        bic: mut best_bic,
        per_start,
        mut others,
    } = fit_candidates(&candidates, &full, &starts, 0, ln_n);
    // The camera's curves checked against the lines' colours before anything leans on the
    // shared continuum drawn through them.
    let mut camera_check = opts
        .camera
        .as_ref()
        .and_then(|cam| judge_camera_colours(cam, &chosen_pr, &chosen_fit, best_bic, &others))
        .map(|check| {
            apply_camera_verdict(
                check,
                &mut chosen_pr,
                &mut chosen_fit,
                &mut best_bic,
                &mut others,
            )
        });
    // A strong line the lamp list lacks would bias every candidate: search the chosen fit's
    // residual, and when lines are found, choose the background again with them in the model.
    // Only when the background is chosen (`Auto`): a requested model is fitted as asked.
    // The search runs in the coarsest continuum's fit when a finer one was chosen (a fine
    // continuum element takes up part of a line-wide blob), and fits each unlisted line with a
    // free wavelength jointly with the map ([`crate::lvf::unlisted`]).
    let search = if opts.background == BackgroundChoice::Auto {
        let coarse = others.iter().find(|(cpr, _, _)| {
            finer_than_coarse(&chosen_pr.terms, k_coarse)
                && is_coarse(&cpr.terms, k_coarse)
                && cpr.terms.falloff_degree == chosen_pr.terms.falloff_degree
        });
        let (spr, sfit) = coarse.map_or((&chosen_pr, &chosen_fit), |(p, f, _)| (p, f));
        let found = crate::lvf::unlisted::search(spr, sfit);
        let theta_x = full.theta_from(spr, &found.theta);
        let blended_shift: Vec<[f64; 2]> = found
            .blended
            .iter()
            .map(|b| {
                let at = |u: f64| spr.lambda(&b.theta, u) - spr.lambda(&sfit.theta, u);
                [at(-1.0), at(1.0)]
            })
            .collect();
        Some((found, theta_x, blended_shift))
    } else {
        None
    };
    let extra: Vec<crate::lvf::unlisted::Found> =
        search.as_ref().map_or(Vec::new(), |s| s.0.found.clone());
    if !extra.is_empty() {
        let mut l = lines.clone();
        l.extend(extra.iter().map(|e| e.nm));
        let full_x = full.with_lines(l);
        let x_start = search.as_ref().map_or(Vec::new(), |s| s.1.clone());
        let starts_x: Vec<&[f64]> = vec![&x_start, &plain_best.theta];
        let c = fit_candidates(&candidates, &full_x, &starts_x, extra.len(), ln_n);
        (chosen_pr, chosen_fit, best_bic, others) = (c.pr, c.fit, c.bic, c.others);
        if let Some(cam) = &opts.camera {
            // Judged again on the refit's amplitudes; when nothing can be judged there, the
            // first verdict still holds for the refitted shared-continuum candidates.
            let first = camera_check.take().map(|c| c.check);
            camera_check = judge_camera_colours(cam, &chosen_pr, &chosen_fit, best_bic, &others)
                .or(first)
                .map(|check| {
                    apply_camera_verdict(
                        check,
                        &mut chosen_pr,
                        &mut chosen_fit,
                        &mut best_bic,
                        &mut others,
                    )
                });
        }
        // the chosen background refined once more with the unlisted wavelengths free, so the
        // map's covariance carries their uncertainty
        let listed_only = chosen_pr.with_lines(lines.clone());
        let fw = chosen_pr.fwhm(&chosen_fit.theta);
        let free0 = chosen_pr.lines()[lines.len()..].to_vec();
        let bounds: Vec<(f64, f64)> = free0
            .iter()
            .map(|&l| (l - 0.5 * fw, l + 0.5 * fw))
            .collect();
        let j = crate::lvf::unlisted::refine(&listed_only, &chosen_fit.theta, &free0, &bounds);
        let mut l = lines.clone();
        l.extend(j.free_nm.iter().copied());
        chosen_pr = chosen_pr.with_lines(l);
        chosen_fit = Fitted {
            theta: j.theta,
            eval: j.eval,
            jac: j.jac,
            iterations: j.iterations,
        };
    }
    // The continuum checked for λ by the focused criterion ([`focused_refinement`]); not when
    // unlisted lines were fitted, whose free wavelengths only the chosen fit carries.
    let mut focused: Option<FocusedChoice> = None;
    if opts.background == BackgroundChoice::Auto && extra.is_empty() {
        if let Some((k, fc)) = focused_refinement(&chosen_pr, &chosen_fit, best_bic, &others) {
            let (fpr, ffit, fbic) = others.swap_remove(k);
            let old_pr = std::mem::replace(&mut chosen_pr, fpr);
            let old_fit = std::mem::replace(&mut chosen_fit, ffit);
            others.push((old_pr, old_fit, best_bic));
            best_bic = fbic;
            focused = Some(fc);
        }
    }
    let n_obs = 3 * profile.px.len();

    // Map degree. Fits of the other degree, kept for the model-choice systematic.
    let mut map_alternatives: Vec<(Problem, Fitted, f64)> = Vec::new();
    let mut bow_warning: Option<String> = None;
    let (pr, chosen, selection) = match opts.map {
        MapChoice::Linear => {
            // A bowed map on a lamp without a continuum: a continuum takes up the bow and the
            // map is off by the bow at the ends with σ none the wiser (1.8 nm at 700 nm for σ
            // 0.28, docs/performance.md, issue 12, twenty-first session). The offset alone with
            // a quadratic map (one fit) beating the chosen model by BIC says so.
            let offset_only = std::iter::once((&chosen_pr, &chosen_fit))
                .chain(others.iter().map(|(p, f, _)| (p, f)))
                .find(|(p, _)| !p.terms.has_continuum() && p.terms.falloff_degree == 0);
            if let Some((lpr, lfit)) = offset_only {
                let n_extra = chosen_pr.lines().len().saturating_sub(lines.len());
                let (qpr, quad, qbic, f, t_a2) =
                    quadratic_of(lpr, lfit, n_extra as f64 * ln_n, n_obs);
                if qbic < best_bic - 10.0 && quadratic_justified(f, t_a2) {
                    let moved = [-1.0, 1.0].map(|u| {
                        qpr.lambda(&quad.theta, u) - chosen_pr.lambda(&chosen_fit.theta, u)
                    });
                    bow_warning = Some(format!(
                        "the map may not be linear: the offset alone with a quadratic map explains the profile better than {} with the linear map (BIC lower by {:.0}, a2 at {:.0}σ) and puts the ROI's ends {:+.2} / {:+.2} nm away; a continuum may be drawing the bow — run with --map auto",
                        chosen_pr.terms.name(),
                        best_bic - qbic,
                        t_a2.abs(),
                        moved[0],
                        moved[1]
                    ));
                    // and σ counts it as a map of the other degree (ΔBIC < 0 ≤ 10)
                    map_alternatives.push((qpr, quad, qbic));
                }
            }
            (
                chosen_pr,
                chosen_fit,
                MapSelection {
                    requested: "linear".into(),
                    f_statistic: None,
                    quadratic_t: None,
                    reason: "linear map requested".into(),
                },
            )
        }
        MapChoice::Quadratic | MapChoice::Auto => {
            // The map's degree is chosen together with the background: with the map held
            // linear, a continuum takes up a curved map's misfit (a passband continuum drew a
            // 7 nm bow on a lamp with no continuum at all, and the quadratic term then gained
            // nothing; docs/performance.md, issue 12, twenty-first session). So every
            // background candidate is refitted with a quadratic map and the pair with the
            // smallest BIC wins; a quadratic map must also pass the F-test (p < 0.001) and
            // |a2| > 3σ against the same background with a linear map.
            let n_extra = chosen_pr.lines().len().saturating_sub(lines.len());
            let quads: Vec<QuadraticFit> = std::iter::once((&chosen_pr, &chosen_fit))
                .chain(others.iter().map(|(p, f, _)| (p, f)))
                .collect::<Vec<_>>()
                .par_iter()
                .map(|&(lpr, lfit)| quadratic_of(lpr, lfit, n_extra as f64 * ln_n, n_obs))
                .collect();
            let justified = |q: &QuadraticFit| quadratic_justified(q.3, q.4);
            let requested = if opts.map == MapChoice::Quadratic {
                "quadratic"
            } else {
                "auto"
            };
            let best_quad = (0..quads.len())
                .filter(|&i| opts.map == MapChoice::Quadratic || justified(&quads[i]))
                .min_by(|&a, &b| quads[a].2.total_cmp(&quads[b].2));
            let take_quad = match best_quad {
                Some(i) => opts.map == MapChoice::Quadratic || quads[i].2 < best_bic,
                None => false,
            };
            // F and t as reported: the winning quadratic's, or when the linear map wins, those
            // of the quadratic with the chosen background.
            let (mut quads, report_i) = (quads, if take_quad { best_quad.unwrap_or(0) } else { 0 });
            let (f, t_a2) = (quads[report_i].3, quads[report_i].4);
            let reason = match (opts.map, take_quad) {
                (MapChoice::Quadratic, _) => "quadratic map requested (background chosen by BIC among the quadratic-map fits)".to_string(),
                (_, true) => "quadratic: the smallest BIC over every background with either map degree, and against the same background with a linear map F-test p < 0.001 and |a2| > 3σ".to_string(),
                (_, false) => match best_quad {
                    Some(i) => format!(
                        "linear: the best quadratic map that passes the F-test and |a2| > 3σ ({}) is ΔBIC {:+.1} from the chosen linear one",
                        quads[i].0.terms.name(),
                        quads[i].2 - best_bic
                    ),
                    None => "linear: no quadratic map is justified with any background (needs F > 10.83 and |a2| > 3σ against the same background with a linear map)".to_string(),
                },
            };
            let selection = MapSelection {
                requested: requested.into(),
                f_statistic: (opts.map == MapChoice::Auto).then_some(f),
                quadratic_t: (opts.map == MapChoice::Auto).then_some(t_a2),
                reason,
            };
            if take_quad {
                // The background alternatives are now the other quadratic-map fits; the
                // linear-map fits are the alternatives of the other degree (none counted when
                // the degree was requested).
                let (qpr, quad, qbic, _, _) = quads.swap_remove(report_i);
                if focused.is_some() && qpr.terms != chosen_pr.terms {
                    focused = None;
                }
                let linear: Vec<(Problem, Fitted, f64)> =
                    std::iter::once((chosen_pr, chosen_fit, best_bic))
                        .chain(std::mem::take(&mut others))
                        .collect();
                others = quads.into_iter().map(|(p, f, b, _, _)| (p, f, b)).collect();
                if opts.map == MapChoice::Auto {
                    map_alternatives = linear;
                }
                best_bic = qbic;
                (qpr, quad, selection)
            } else {
                map_alternatives = quads.into_iter().map(|(p, f, b, _, _)| (p, f, b)).collect();
                (chosen_pr, chosen_fit, selection)
            }
        }
    };
    let Fitted {
        theta,
        eval,
        jac,
        iterations,
    } = chosen;
    // parameters: θ plus any unlisted wavelengths refined with it (columns of the Jacobian);
    // an unlisted line left without amplitude in every channel has no influence (a zero column:
    // its wavelength is undetermined and says nothing of the map) and is left out, else the
    // covariance is singular (a flat-top passband fitted as Gaussian, docs/performance.md)
    let jac = without_inert_columns(jac, pr.n_theta());
    let p = jac.ncols();
    let deg = pr.n_map;
    let dof = n_obs.saturating_sub(p + eval.n_active).max(1) as f64;
    let cov_theta = covariance(&jac, eval.sse, dof).ok_or_else(|| Error::Numerical {
        what: "LVF whole-profile fit".into(),
        reason: format!(
            "{}: the map is not determined by the profile (singular Jacobian); does the ROI show at least two separated lamp lines?",
            profile.source
        ),
    })?;
    // The residual's correlation length τ (reported; the covariance before the sandwich was
    // s²(JᵀJ)⁻¹·τ, kept in the diagnostics for comparison).
    let tau = crate::lvf::misfit::correlation_length(&eval.residual, 3);
    let fwhm = pr.fwhm(&theta);

    // Map in pixels: λ = Σ a_k ((px − m)/h)^k  →  Σ c_i px^i, c = T a.
    let (m, h) = (pr.px_mid, pr.half);
    let mut t = DMatrix::zeros(deg, deg);
    t[(0, 0)] = 1.0;
    t[(0, 1)] = -m / h;
    t[(1, 1)] = 1.0 / h;
    if deg == 3 {
        t[(0, 2)] = m * m / (h * h);
        t[(1, 2)] = -2.0 * m / (h * h);
        t[(2, 2)] = 1.0 / (h * h);
    }
    let a = DVector::from_iterator(deg, theta[..deg].iter().copied());
    let c = &t * a;
    // Statistical covariance of θ: the HAC sandwich ([`crate::lvf::sigma`]), its bandwidth
    // chosen from the scores of λ at the 400 and 700 nm positions.
    let provisional = MapModel {
        kind: MapKind::Linear,
        coefficients: c.iter().copied().collect(),
        covariance: Vec::new(),
    };
    let targets: Vec<DVector<f64>> = [400.0, 700.0]
        .iter()
        .filter_map(|&nm| provisional.inverse(nm))
        .map(|px| {
            let u = (px - m) / h;
            lambda_gradient(p, deg, u)
        })
        .collect();
    let sandwich =
        crate::lvf::sigma::hac_sandwich(&jac, &eval.residual, 3, eval.n_active, &targets);
    let sigma_compare = |cov: &DMatrix<f64>| -> Vec<f64> {
        targets
            .iter()
            .map(|a| (a.transpose() * cov * a)[(0, 0)].max(0.0).sqrt())
            .collect()
    };
    let sigma_homoscedastic = sigma_compare(&cov_theta);
    let sigma_tau = sigma_compare(&(&cov_theta * tau));
    let cov_theta = match &sandwich {
        Some(s) => s.covariance.clone(),
        None => cov_theta * tau,
    };
    // The radial fall-off divided out is itself an estimate (κ from the strips, with its
    // cluster-robust covariance): its uncertainty moves the map by dθ/dκ, added to the
    // statistical covariance.
    // Not divided out, the fall-off is taken as none, but the strips only bound it: κ₀ = 0 ± its
    // σ fitted alone moves the map as much, and is added the same way.
    let radial_g = match (&radial, fixed) {
        (Some(r), None) => radial_sensitivity(&pr, &theta, &jac, r),
        _ => None,
    };
    let (cov_theta, sigma_radial) = match (&radial_g, &radial) {
        (Some(g), Some(r)) => {
            let kc = r.uncertainty(radial_applied);
            let k = DMatrix::from_fn(2, 2, |i, j| kc[i][j]);
            let add = g * k * g.transpose();
            let s = sigma_compare(&add);
            (cov_theta + add, Some(s))
        }
        _ => (cov_theta, None),
    };
    let cov_a = cov_theta.view((0, 0), (deg, deg)).into_owned();
    let cov_c = &t * cov_a * t.transpose();
    let map = MapModel {
        kind: if deg == 3 {
            MapKind::Quadratic
        } else {
            MapKind::Linear
        },
        coefficients: c.iter().copied().collect(),
        covariance: (0..deg)
            .map(|i| (0..deg).map(|j| cov_c[(i, j)]).collect())
            .collect(),
    };

    // Per-line residuals: shift each group of blended lines (closer than half the FWHM) alone.
    let lams: Vec<f64> = pr.u.iter().map(|&u| pr.lambda(&theta, u)).collect();
    let lam_lo = lams.iter().cloned().fold(f64::INFINITY, f64::min);
    let lam_hi = lams.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    let in_range: Vec<usize> = (0..lines.len())
        .filter(|&i| lines[i] >= lam_lo - 0.5 * fwhm && lines[i] <= lam_hi + 0.5 * fwhm)
        .collect();
    let in_lines: Vec<f64> = in_range.iter().map(|&i| lines[i]).collect();
    // Lines closer than half the FWHM are not resolved: each such group is shifted alone
    // ([`group_shift`]). (Representing a group by one line at its lamp-power centroid, as before,
    // could not draw a chain wider than the passband, as a CFL's 577–612 nm lines, and moved it
    // by up to half the FWHM; a line too weak to place got an arbitrary shift.)
    let groups = group_lines(&in_lines, 0.5 * fwhm);
    let peak = profile
        .values
        .iter()
        .flatten()
        .cloned()
        .fold(f64::MIN, f64::max)
        .max(1e-300);
    let s2_floor = (peak / 65535.0).powi(2);
    // per group: (shift, σ) when determined, and the group's amplitude (its weight in the RMS)
    let per_group: Vec<(Option<(f64, f64)>, f64)> = groups
        .par_iter()
        .map(|g| {
            // A group with no amplitude in any channel is not observed.
            let amp: f64 = g
                .iter()
                .map(|&k| {
                    (0..3)
                        .map(|c| eval.alpha[c][N_BG + in_range[k]])
                        .sum::<f64>()
                })
                .sum();
            if amp <= 0.0 {
                return (None, amp);
            }
            let idx: Vec<usize> = g.iter().map(|&k| in_range[k]).collect();
            (
                group_shift(&pr, &theta, &eval, &lams, &idx, fwhm, s2_floor),
                amp,
            )
        })
        .collect();
    let mut shifts: Vec<Option<(f64, f64)>> = vec![None; in_lines.len()];
    let mut group_res: Vec<(f64, f64)> = Vec::new();
    for (g, (res, amp)) in groups.iter().zip(&per_group) {
        for &k in g {
            shifts[k] = *res;
        }
        if let Some((d, _)) = res {
            group_res.push((*d, *amp));
        }
    }
    let sw: f64 = group_res.iter().map(|(_, a)| a * a).sum();
    let rms = if group_res.is_empty() || sw <= 0.0 {
        0.0
    } else {
        (group_res.iter().map(|(d, a)| a * a * d * d).sum::<f64>() / sw).sqrt()
    };
    let rms_unweighted = if group_res.is_empty() {
        0.0
    } else {
        (group_res.iter().map(|(d, _)| d * d).sum::<f64>() / group_res.len() as f64).sqrt()
    };
    let line_reports: Vec<LineReport> = in_range
        .iter()
        .enumerate()
        .map(|(k, &i)| LineReport {
            nm: lines[i],
            px: map.inverse(lines[i]).unwrap_or(f64::NAN),
            residual_nm: shifts[k].map(|(d, _)| d),
            residual_sigma_nm: shifts[k].map(|(_, s)| s),
            amplitude: std::array::from_fn(|c| eval.alpha[c][N_BG + i]),
        })
        .collect();

    // Curves: data, model, what is not lines (offset + fall-off × continuum), fall-off.
    let n = profile.px.len();
    let nc = pr.terms.n_continuum();
    let vcoef = pr.falloff_coefficients(&theta).to_vec();
    let fall: Vec<f64> =
        pr.u.iter()
            .enumerate()
            .map(|(i, &u)| falloff(&vcoef, u) * pr.vfix.get(i).copied().unwrap_or(1.0))
            .collect();
    let crow = pr.continuum_rows(&theta);
    let cont_of = |c: usize, i: usize| -> f64 {
        let a = &eval.alpha[c];
        (0..nc)
            .map(|j| a[N_BG + pr.lines.len() + j] * crow[i * nc + j])
            .sum::<f64>()
            * fall[i]
    };
    let shared_of = |c: usize, i: usize| eval.shared.as_ref().map_or(0.0, |(_, cu)| cu[c][i]);
    let background_curve: [Vec<f64>; 3] = std::array::from_fn(|c| {
        (0..n)
            .map(|i| {
                eval.alpha[c][0] + eval.alpha[c][1] * pr.u[i] + cont_of(c, i) + shared_of(c, i)
            })
            .collect()
    });
    let residual_image = pr.unweighted(&eval.residual);
    let curves = ProfileCurves {
        px: profile.px.clone(),
        data: profile.values.clone(),
        model: std::array::from_fn(|c| {
            (0..n)
                .map(|i| profile.values[c][i] - residual_image[c * n + i])
                .collect()
        }),
        background: background_curve,
        falloff: fall.clone(),
        falloff_sigma: match (&radial, fixed) {
            (Some(r), None) if r.q_along.len() == n => r.ln_v_sigma(radial_applied),
            _ => Vec::new(),
        },
    };
    // The free offset and the spline (a partition of unity) share the constant, so the spline
    // alone is not meaningful: the continuum's size is that of everything that is not lines
    // (offset + continuum), above its own minimum, when a continuum was fitted.
    let cont_peak = if !pr.terms.has_continuum() {
        0.0
    } else {
        curves
            .background
            .iter()
            .map(|b| {
                let lo = b.iter().cloned().fold(f64::INFINITY, f64::min);
                b.iter().map(|v| v - lo).fold(0.0f64, f64::max)
            })
            .fold(0.0f64, f64::max)
    };

    // Model-choice systematic at the 400/700 nm positions: the largest difference to any other
    // candidate within ΔBIC ≤ 10 and, when a continuum was chosen, to every other continuum
    // (knot spacing, or with a shared spectrum every candidate within ΔBIC ≤
    // MODEL_CHOICE_DELTA_BIC) — how much the map depends on how the continuum is drawn.
    let u_at = |nm: f64| map.inverse(nm).map(|px| (px - m) / h);
    let (u400, u700) = (u_at(400.0), u_at(700.0));
    let mut sys = [0.0f64; 2];
    let mut candidate_reports: Vec<CandidateReport> = Vec::new();
    let lam_of = |cpr: &Problem, th: &[f64], u: Option<f64>| u.map(|u| cpr.lambda(th, u));
    candidate_reports.push(CandidateReport {
        model: pr.terms.name(),
        bic: best_bic,
        delta_bic: 0.0,
        profile_rms: (eval.sse / n_obs as f64).sqrt(),
        nm_at_400_position: lam_of(&pr, &theta, u400),
        nm_at_700_position: lam_of(&pr, &theta, u700),
    });
    // Curves that fit the lines' colours only nearly (`lvf::line_colour::MISFIT_NEAR`): the
    // per-channel passband continuum — the model of what lies under the lines that needs no
    // curves (see `focused_refinement`) — counts as a model-choice alternative of a chosen
    // shared spectrum (the best by BIC of that family; of any continuum without the curves when
    // there is none). The best by BIC alone was tried: on the D80-on-D700 image it is a spline
    // in u that agrees with the shared spectrum's biased map (σ unchanged, 0.23 for +0.585 nm).
    let near_alternative = camera_check
        .as_ref()
        .filter(|cc| cc.check.near() && is_shared(&pr))
        .and_then(|_| {
            let best = |family: &dyn Fn(&BackgroundTerms) -> bool| {
                others
                    .iter()
                    .enumerate()
                    .filter(|(_, (p, _, _))| p.n_map == pr.n_map && family(&p.terms))
                    .min_by(|a, b| a.1 .2.total_cmp(&b.1 .2))
                    .map(|(i, _)| i)
            };
            best(&|t| t.passband_intervals > 0)
                .or_else(|| best(&|t| t.shared_intervals == 0 && t.has_continuum()))
        });
    for (k, (cpr, cf, cb)) in others.iter().chain(&map_alternatives).enumerate() {
        let l4 = lam_of(cpr, &cf.theta, u400);
        let l7 = lam_of(cpr, &cf.theta, u700);
        // a map of the other degree (`--map auto`) counts as a background alternative would
        // without a continuum: within ΔBIC ≤ 10
        let counted = if cpr.n_map != pr.n_map {
            cb - best_bic <= 10.0
        } else if pr.terms.shared_intervals > 0 {
            cb - best_bic <= MODEL_CHOICE_DELTA_BIC
        } else {
            cb - best_bic <= 10.0 || (pr.terms.has_continuum() && cpr.terms.has_continuum())
        } || near_alternative == Some(k);
        if counted {
            if let Some(l) = l4 {
                sys[0] = sys[0].max((l - 400.0).abs());
            }
            if let Some(l) = l7 {
                sys[1] = sys[1].max((l - 700.0).abs());
            }
        }
        candidate_reports.push(CandidateReport {
            model: match (cpr.n_map == pr.n_map, cpr.n_map) {
                (true, _) => cpr.terms.name(),
                (false, 3) => format!("{} · quadratic map", cpr.terms.name()),
                (false, _) => format!("{} · linear map", cpr.terms.name()),
            },
            bic: *cb,
            delta_bic: cb - best_bic,
            profile_rms: (cf.eval.sse / n_obs as f64).sqrt(),
            nm_at_400_position: l4,
            nm_at_700_position: l7,
        });
    }
    candidate_reports.sort_by(|a, b| a.bic.total_cmp(&b.bic));
    let background = BackgroundReport {
        model: pr.terms.name(),
        selection: match &focused {
            None => selection_rule.into(),
            Some(f) => format!(
                "bic chose {}; {} has the smaller estimated mean squared error of λ at 400 + 700 nm (focused information criterion against the model that draws the continuum without bias, the most flexible shared spectrum (finest spacing, then weakest roughness penalty) or, for a spline in u, the passband continuum: {:.3e} against {:.3e} nm²; it moves λ there by {:+.3} / {:+.3} nm)",
                f.bic_choice,
                pr.terms.name(),
                f.mse[1],
                f.mse[0],
                f.shift_nm[0],
                f.shift_nm[1]
            ),
        },
        flat_field: None,
        falloff_source: match (fixed.is_some(), radial_applied, pr.terms.falloff_degree) {
            (true, _, _) => "given: a fall-off supplied by the caller".into(),
            (false, true, 0) => "modelled: radial about the image centre (estimated from the ROI's strips across the axis)".into(),
            (false, true, j) => format!("modelled: radial from the strips × fitted polynomial of degree {j} along the axis"),
            (false, false, 0) => "none".into(),
            (false, false, j) => format!("modelled: fitted polynomial of degree {j} along the axis"),
        },
        u_definition: format!("u = (px − {m})/{h}"),
        px_mid: m,
        half_length_px: h,
        offset: std::array::from_fn(|c| [eval.alpha[c][0], eval.alpha[c][1]]),
        continuum_intervals: pr.terms.continuum_intervals,
        continuum_coefficients: std::array::from_fn(|c| {
            (0..nc)
                .map(|j| eval.alpha[c][N_BG + pr.lines.len() + j])
                .collect()
        }),
        shared_spectrum: match (&pr.shared, &eval.shared, &opts.camera) {
            (Some(sb), Some((beta, _)), Some(cam)) => Some(sb.report(&cam.source, beta)),
            _ => None,
        },
        continuum_peak_relative: cont_peak / peak,
        falloff_degree: pr.terms.falloff_degree,
        falloff_coefficients: vcoef.clone(),
        falloff_at_ends: [falloff(&vcoef, -1.0), falloff(&vcoef, 1.0)],
        radial_falloff: radial,
        radial_falloff_applied: radial_applied,
        candidates: candidate_reports,
        black_clipping: profile.censoring.clone(),
        sigma_includes_systematic: selection_rule == "bic",
        systematic_note: if selection_rule == "bic" {
            "sigma_nm_at_400/700 = √(statistical² + systematic²); the statistical part is the sandwich covariance (JᵀJ)⁻¹B(JᵀJ)⁻¹ with a heteroscedasticity- and autocorrelation-consistent B (Newey–West, bandwidth diagnostics.statistical_sigma.hac_bandwidth_lags), so noise that grows with the signal and a smooth misfit correlated along the profile widen it, and it includes the uncertainty of the radial fall-off estimated from the strips, divided out or bounded (diagnostics.statistical_sigma.radial_falloff_nm_at_400_700 and its note); the systematic part is the largest difference at that position to another background model within ΔBIC ≤ 10, or to every other continuum when a continuum was chosen (with a shared continuum spectrum through --camera: every candidate within ΔBIC ≤ 100) (model-choice uncertainty; background.candidates lists every candidate's λ there), and how far the map moves when a listed line the other lines put elsewhere is freed (diagnostics.displaced_lines); a fall-off the strips cannot see (tilt, off-centre; not identified by the profile, only a flat field measures it) and errors common to all candidates (passband shape, line list) are not included".into()
        } else {
            "sigma_nm_at_400/700 are statistical only (the sandwich covariance with a heteroscedasticity- and autocorrelation-consistent middle, Newey–West; one background model was requested, so there is no model-choice spread)".into()
        },
    };

    let mut cal = LvfCalibration {
        schema: crate::lvf::calibration::LVF_SCHEMA,
        method: "whole-profile".into(),
        source: profile.source.clone(),
        axis: profile.axis,
        roi: profile.roi,
        tilt: profile.tilt,
        lamp: lamp.name.clone(),
        map,
        fwhm_nm: fwhm,
        fwhm_sigma_nm: cov_theta[(deg, deg)].max(0.0).sqrt(),
        passband: opts.passband.report(),
        rms_residual_nm: rms,
        rms_residual_relative: None,
        sigma_nm_at_400: 0.0,
        sigma_nm_at_700: 0.0,
        sigma_statistical_nm_at_400: 0.0,
        sigma_statistical_nm_at_700: 0.0,
        sigma_systematic_nm_at_400: sys[0],
        sigma_systematic_nm_at_700: sys[1],
        lines: line_reports,
        bands: Vec::new(),
        map_selection: selection,
        wavelength_increases_with_px: increasing,
        background: Some(background),
        unexplained_lines: Vec::new(),
        warnings: Vec::new(),
        diagnostics: serde_json::json!({
            "iterations": iterations,
            "profile_points": n,
            "profile_rms": (eval.sse / n_obs as f64).sqrt(),
            "coarse_starts": starts.len(),
            "active_linear_parameters": eval.n_active,
            "rms_residual_nm_unweighted": rms_unweighted,
            "residual_correlation_length": tau,
            "noise_model": match &noise_model {
                Some(m) => serde_json::json!({
                    "weighted": true,
                    "variance": "read_variance + shot_gain · level (from the profile's fourth differences)",
                    "read_variance": m.read_variance,
                    "shot_gain": m.shot_gain,
                    "peak_over_dark": m.peak_over_dark,
                    "note": "residuals, SSE, BIC and profile_rms are of the weighted residual (weights √(mean variance / variance), mean 1 in variance)",
                }),
                None => serde_json::json!({
                    "weighted": false,
                    "note": if opts.noise_weights.unwrap_or(opts.camera.is_some()) { "no noise seen in the profile (noise-free or too short): unweighted" } else if opts.noise_weights.is_none() { "unweighted without --camera (--weights auto)" } else { "--weights off" },
                }),
            },
            "statistical_sigma": {
                "method": if sandwich.is_some() { "hac-sandwich" } else { "homoscedastic × correlation length (sandwich singular)" },
                "hac_bandwidth_lags": sandwich.as_ref().map(|s| s.bandwidth),
                "score_lag1_autocorrelation": sandwich.as_ref().map(|s| s.score_rho.clone()),
                "homoscedastic_nm_at_400_700": sigma_homoscedastic,
                "correlation_length_scaled_nm_at_400_700": sigma_tau,
                "radial_falloff_nm_at_400_700": sigma_radial,
                "radial_falloff_note": match (sigma_radial.is_some(), radial_applied) {
                    (true, true) => "included: the uncertainty of the radial fall-off divided out (κ's cluster-robust covariance) propagated to λ by linear response",
                    (true, false) => "included: no fall-off was divided out (not significant), but the strips bound it only to κ₀ = 0 ± its σ fitted alone; that uncertainty propagated to λ by linear response",
                    (false, _) => "not included: no radial estimate from the strips (a flat field was given, --no-radial-falloff, the ROI has no strips across the axis, or the sensitivity was singular)",
                },
            },
        }),
        curves,
    };
    // Unexplained lines are searched for in the residual of the coarsest continuum when a finer
    // one was chosen: a fine continuum takes up part of a missing line.
    let detect = others.iter().find(|(cpr, _, _)| {
        finer_than_coarse(&pr.terms, k_coarse)
            && is_coarse(&cpr.terms, k_coarse)
            && cpr.terms.falloff_degree == pr.terms.falloff_degree
    });
    let detect = match detect {
        Some((cpr, cf, _)) => Detect {
            problem: cpr,
            theta: &cf.theta,
            eval: &cf.eval,
        },
        None => Detect {
            problem: &pr,
            theta: &theta,
            eval: &eval,
        },
    };
    assess(
        &mut cal,
        &pr,
        &theta,
        &eval,
        &detect,
        lamp,
        opts.fwhm_guess_nm,
    )?;
    if let Some(w) = bow_warning {
        cal.warnings.insert(0, w);
    }
    for (e, x) in extra.iter().enumerate() {
        let a = (0..3)
            .map(|c| eval.alpha[c][N_BG + lines.len() + e])
            .fold(0.0f64, f64::max);
        cal.unexplained_lines.push(UnexplainedLine {
            nm: pr.lines[lines.len() + e],
            px: cal
                .map
                .inverse(pr.lines[lines.len() + e])
                .unwrap_or(f64::NAN),
            amplitude_relative: a / peak,
            significance: x.blob.significance,
            fitted: true,
        });
        cal.warnings.push(format!(
            "unexplained line near {:.1} nm (px {:.0}): a blob {:.1} % of the peak ({:.0}σ in the residual) that no line of lamp '{}' explains; it was fitted as an extra line of free wavelength so that it does not bias the map (add it to the lamp list, or exclude it with --roi)",
            pr.lines[lines.len() + e],
            cal.map.inverse(pr.lines[lines.len() + e]).unwrap_or(f64::NAN),
            100.0 * a / peak,
            x.blob.significance,
            lamp.name
        ));
    }
    // Unlisted lines that merged with a listed one: not separable, so the map is reported with
    // σ widened by how far such a line moves it (linear in u between the profile's ends).
    if let Some((s, _, shift)) = &search {
        for (b, d) in s.blended.iter().zip(shift) {
            let at = |u: f64| 0.5 * (1.0 - u) * d[0] + 0.5 * (1.0 + u) * d[1];
            let w = [u400.map_or(0.0, at), u700.map_or(0.0, at)];
            cal.sigma_systematic_nm_at_400 = cal.sigma_systematic_nm_at_400.max(w[0].abs());
            cal.sigma_systematic_nm_at_700 = cal.sigma_systematic_nm_at_700.max(w[1].abs());
            cal.warnings.push(format!(
                "a blob {:.1} % of the peak ({:.0}σ in the residual) near {:.1} nm is best explained by a second line at {:.1} nm that cannot be separated from lamp line {} nm (closer than {} FWHM): it was not fitted; σ at 400/700 nm is widened by how far it moves the map ({:.3} / {:.3} nm); check the lamp list",
                100.0 * b.blob.relative,
                b.blob.significance,
                b.blob.nm,
                b.nm,
                b.listed_nm,
                crate::lvf::unlisted::BLEND_FWHM,
                w[0].abs(),
                w[1].abs()
            ));
        }
    }
    // A listed line the other lines put elsewhere (an unlisted line blended with it, or a wrong
    // list entry): σ widened by how far freeing it moves the map, and a warning when the shift
    // is significant (> 3 of its σ and > 0.3 nm) and moves the map by more than the map's own σ
    // ([`crate::lvf::unlisted::displaced_groups`]).
    if opts.background == BackgroundChoice::Auto {
        use crate::lvf::unlisted as ul;
        cal.set_bands(opts.n_bands)?;
        let sigma_map = cal.sigma_nm_at_400.max(cal.sigma_nm_at_700);
        let mut report = Vec::new();
        // with a passband continuum chosen, in the best fit without one: a passband continuum
        // trades with a line's position (false warnings on clean lamps) — but only while that
        // fit is plausible (within DISPLACED_REFERENCE_DELTA_BIC of the chosen one): a continuum
        // model the data reject leaves a misfit that freeing a bright line takes up (a CFL under
        // its phosphor continuum, noise-free: 436 and 405/408 nm "displaced" by 0.6 and 3 nm in
        // continuum12, 26,800 BIC worse, σ widened to 1.8 nm for an error of 0.08)
        let (dpr, dth) = if pr.terms.passband_intervals > 0 {
            others
                .iter()
                .filter(|(cpr, _, cb)| {
                    cpr.terms.passband_intervals == 0
                        && cb - best_bic <= DISPLACED_REFERENCE_DELTA_BIC
                })
                .min_by(|a, b| a.2.total_cmp(&b.2))
                .map_or((&pr, &theta), |(cpr, cf, _)| (cpr, &cf.theta))
        } else {
            (&pr, &theta)
        };
        for d in ul::displaced_groups(dpr, dth, lines.len()) {
            let w = [
                u400.map_or(0.0, |u| {
                    (dpr.lambda(&d.theta, u) - dpr.lambda(dth, u)).abs()
                }),
                u700.map_or(0.0, |u| {
                    (dpr.lambda(&d.theta, u) - dpr.lambda(dth, u)).abs()
                }),
            ];
            cal.sigma_systematic_nm_at_400 = cal.sigma_systematic_nm_at_400.max(w[0]);
            cal.sigma_systematic_nm_at_700 = cal.sigma_systematic_nm_at_700.max(w[1]);
            let shift = d.fitted_nm - d.centroid_nm;
            let warned = shift.abs() > ul::DISPLACED_MIN_NM
                && shift.abs() > ul::DISPLACED_SIGMA * d.sigma_nm
                && w[0].max(w[1]) > sigma_map;
            report.push(serde_json::json!({
                "lines_nm": d.listed_nm, "centroid_nm": d.centroid_nm, "freed_nm": d.fitted_nm,
                "freed_sigma_nm": d.sigma_nm, "delta_bic": d.delta_bic,
                "map_change_nm_at_400_700": w, "warned": warned,
            }));
            if warned {
                cal.warnings.push(format!(
                    "lamp line {} nm (with the lines blended with it, centroid {:.2} nm) is not where the other lines put it: freed, it sits at {:.2} ± {:.2} nm (BIC lower by {:.0}); an unlisted line blended with it (closer than the passband separates) or a wrong list entry{}; the map is kept, and σ at 400/700 nm is widened by how far freeing the line moves it ({:.3} / {:.3} nm); check the lamp list",
                    d.listed_nm.iter().map(|l| l.to_string()).collect::<Vec<_>>().join(" + "),
                    d.centroid_nm,
                    d.fitted_nm,
                    d.sigma_nm,
                    d.delta_bic,
                    // without the camera a continuum drawn per channel can itself trade with a
                    // line (5 % CFL draws: 436 and 405/408 nm "displaced" on a correct list)
                    if opts.camera.is_none() && dpr.terms.has_continuum() {
                        format!(
                            ", or the continuum drawn per channel ({}, no --camera) trading with it",
                            dpr.terms.name()
                        )
                    } else {
                        String::new()
                    },
                    w[0],
                    w[1]
                ));
            }
        }
        cal.diagnostics["displaced_lines"] = serde_json::json!(report);
    }
    if let Some(cc) = &camera_check {
        let limit = crate::lvf::line_colour::MISFIT_MAX;
        cal.diagnostics["camera_check"] = serde_json::json!({
            "camera": opts.camera.as_ref().map(|c| c.source.clone()),
            "misfit": cc.check.misfit,
            "misfit_max": limit,
            "consistent": !cc.check.inconsistent(),
            "lines": cc.check.lines,
            "shared_candidates_dropped": cc.dropped.iter().map(|(m, b)| serde_json::json!({"model": m, "bic": b})).collect::<Vec<_>>(),
            "misfit_near": crate::lvf::line_colour::MISFIT_NEAR,
            "near_alternative_counted": near_alternative.map(|k| others[k].0.terms.name()),
            "note": "each judged line's per-channel amplitudes (summed with the lines within half a FWHM it dominates) against the camera's colour at those lines, one free scale per line, from the best fit whose continuum is shared through the curves; misfit = sqrt(sum |observed - predicted|^2 / sum |observed|^2); above misfit_max the shared spectrum is not used, above misfit_near the best per-channel passband-continuum fit (or, without one, the best other continuum not shared) counts in the model-choice systematic of sigma (near_alternative_counted)",
        });
        if let Some(k) = near_alternative {
            cal.warnings.push(format!(
                "the lamp lines' colours fit the --camera curves ({}) only to {:.1} % (the image's own curves fit lumifit's renders to ≤ 1 %, two measurements of one camera model differ by 1–3 %): σ at 400/700 nm counts the map of the best fit that draws the continuum per channel ({}) as a model-choice alternative",
                opts.camera.as_ref().map_or("", |c| c.source.as_str()),
                100.0 * cc.check.misfit,
                others[k].0.terms.name()
            ));
        }
        if cc.check.inconsistent() {
            let worst = cc.check.furthest_off(3);
            cal.warnings.push(format!(
                "the lamp lines' colours disagree with the --camera curves ({}) by {:.1} % (at most {:.0} % is taken as the image's own camera): {worst}; these curves are not the image's channels (another camera, a white-balanced, 8-bit or otherwise processed image), so the continuum shared through them was not used{}",
                opts.camera.as_ref().map_or("", |c| c.source.as_str()),
                100.0 * cc.check.misfit,
                100.0 * limit,
                match &cc.chosen_replaced {
                    Some(m) => format!(" (BIC had chosen {m}; the map is that of {})", pr.terms.name()),
                    None => String::new(),
                }
            ));
        }
    }
    if !full.splits.is_empty() {
        cal.diagnostics["split_prior"] = serde_json::json!({
            "tau": opts.split_prior_tau,
            "pairs": full.splits.iter().map(|sp| serde_json::json!({
                "lines_nm": [sp.a_nm, sp.b_nm], "table_ratio": sp.ratio,
            })).collect::<Vec<_>>(),
            "note": "per channel, the log ratio of each unresolved mercury pair's amplitudes (second over first) has a Gaussian prior of width tau around the lamp table's ratio, a penalty in the per-channel linear solve (not with a shared continuum spectrum); with the splits free a pair can put its blob anywhere within its span and only 435.8 and 546.1 nm fix the map; --split-prior 0 frees them",
        });
    }
    report_identifications(&mut cal, &per_start, fwhm);
    cal.unexplained_lines.sort_by(|a, b| a.nm.total_cmp(&b.nm));
    cal.set_bands(opts.n_bands)?;
    // A mercury table off the NIST wavelengths: the profile cannot catch it (the doublets can
    // move their blobs within their span, even under the split prior), so the table is checked
    // against NIST instead, for the lines inside the calibrated range.
    let ends = [
        profile.px.first().map(|&p| cal.map.eval(p)),
        profile.px.last().map(|&p| cal.map.eval(p)),
    ];
    if let [Some(a), Some(b)] = ends {
        let (lo, hi) = (a.min(b), a.max(b));
        let off: Vec<String> = lamp
            .off_table_mercury_lines()
            .into_iter()
            .filter(|(nm, _)| (lo..=hi).contains(nm))
            .map(|(nm, nist)| format!("{nm} nm ({:+.3} nm from {nist})", nm - nist))
            .collect();
        if !off.is_empty() {
            cal.warnings.push(format!(
                "the lamp table is not at the mercury lines' NIST air wavelengths: {}; the map follows the table and the profile cannot catch it (the 404.7/407.8 and 577.0/579.1 nm doublets can move their blobs within their span, so 435.8 and 546.1 nm alone fix the map against such an entry), so σ does not include it — list the wavelengths to 0.01 nm (--lamp hg does)",
                off.join(", ")
            ));
        }
    }
    // Without the camera's curves a continuum is drawn per channel, and its freedom (or its
    // bias, as the model-choice systematic) can dominate σ: say so, and what would narrow it.
    let sigma_ends = [cal.sigma_nm_at_400, cal.sigma_nm_at_700];
    if opts.camera.is_none()
        && pr.terms.has_continuum()
        && sigma_ends.iter().any(|s| *s > opts.sigma_hint_nm)
    {
        cal.warnings.push(format!(
            "σ at 400 / 700 nm is {:.2} / {:.2} nm (statistical {:.2} / {:.2}, systematic {:.2} / {:.2}; --sigma-hint {} nm): the continuum under the lines ({}) is drawn per channel without the camera's curves and trades with the lines; give the camera's sensitivities (--camera) so that one continuum spectrum is shared by the three channels, or without them a database of measured cameras (--camera-database) whose lines' colours may match one{}",
            cal.sigma_nm_at_400,
            cal.sigma_nm_at_700,
            cal.sigma_statistical_nm_at_400,
            cal.sigma_statistical_nm_at_700,
            cal.sigma_systematic_nm_at_400,
            cal.sigma_systematic_nm_at_700,
            opts.sigma_hint_nm,
            pr.terms.name(),
            if lamp.is_mercury() {
                ""
            } else {
                ", or calibrate with a mercury lamp (few strong lines over a weak continuum)"
            }
        ));
    }
    Ok(cal)
}

/// The displaced-line check runs in the best fit without a passband continuum when that fit's
/// BIC is at most this much above the chosen one's, else in the chosen fit.
const DISPLACED_REFERENCE_DELTA_BIC: f64 = MODEL_CHOICE_DELTA_BIC;

/// Without `--camera`, a continuum model whose σ at 400 or 700 nm exceeds this (nm; issue 12's
/// bound for a CFL at 1 % noise) draws a warning naming what would narrow it, unless the user
/// sets another accuracy ([`FitOptions::sigma_hint_nm`], `--sigma-hint`).
pub const CONTINUUM_SIGMA_HINT_NM: f64 = 0.3;

/// A group of lines spanning at most this (× FWHM) is one blob through the passband: its
/// residual is its centroid's move ([`group_shift`]).
const BLEND_SPAN_FWHM: f64 = 0.5;

/// Grid step of the search for a line group's shift, in FWHM (±½ FWHM in 21 steps).
const LINE_SHIFT_GRID_FWHM: f64 = 0.05;
/// A second basin of the shift cost within this Δχ² of the minimum makes the shift ambiguous.
const LINE_SHIFT_OTHER_CHI2: f64 = 4.0;
/// Bisections of each end of a line group's Δχ² = 1 interval (a grid cell of 0.05 FWHM to
/// 0.05 FWHM / 2¹²: 0.0003 nm at 25 nm).
const LINE_SHIFT_BISECTIONS: usize = 12;
/// A line group's residual is reported when the profile determines its shift to this fraction of
/// the FWHM (1σ, a Δχ² ≤ 1 interval inside the search's ±½ FWHM). Unresolved lines with
/// free amplitudes can trade their split for a shift (Hg 404.7/407.8 on a camera that hardly sees
/// 405 nm, a CFL's 542.4/546.1 nm), and lines too weak to place leave the cost flat: their
/// residual is `null`, not a number that looks like a misplaced line.
const LINE_SHIFT_DETERMINED_FWHM: f64 = 0.04;
/// ΔBIC under which another identification of the blobs is reported as ambiguous.
const IDENT_AMBIGUOUS_DELTA_BIC: f64 = 10.0;
/// Offset-only fits up to this multiple of the best SSE are refined as other identifications.
const IDENT_SSE_RATIO: f64 = 4.0;
/// At most this many offset-only fits are refined with every background candidate.
const IDENT_MAX_STARTS: usize = 4;

/// `diagnostics.line_identification`: each start's identification (λ at the profile's ends) and
/// BIC under the chosen background, and a warning when one that differs by more than half the
/// FWHM at an end is within [`IDENT_AMBIGUOUS_DELTA_BIC`] of the best.
fn report_identifications(cal: &mut LvfCalibration, per_start: &[StartFit], fwhm: f64) {
    if let Some((report, warning)) = identification_report(per_start, fwhm) {
        cal.diagnostics["line_identification"] = report;
        cal.warnings.extend(warning);
    }
}

/// Two maps identify the blobs differently: λ at either end of the profile (`ends_nm`) differs
/// by more than half the FWHM.
fn other_identification(a: [f64; 2], b: [f64; 2], fwhm: f64) -> bool {
    (a[0] - b[0]).abs() > 0.5 * fwhm || (a[1] - b[1]).abs() > 0.5 * fwhm
}

/// The report and the warning of [`report_identifications`]; `None` without starts.
fn identification_report(
    per_start: &[StartFit],
    fwhm: f64,
) -> Option<(serde_json::Value, Option<String>)> {
    let best = per_start.iter().min_by(|a, b| a.bic.total_cmp(&b.bic))?;
    let differs = |s: &StartFit| other_identification(s.ends_nm, best.ends_nm, fwhm);
    let rows: Vec<serde_json::Value> = per_start
        .iter()
        .map(|s| {
            serde_json::json!({
                "start": s.start,
                "lambda_at_ends_nm": s.ends_nm,
                "bic": s.bic,
                "delta_bic": s.bic - best.bic,
                "same_identification": !differs(s),
            })
        })
        .collect();
    let runner_up = per_start
        .iter()
        .filter(|s| differs(s))
        .min_by(|a, b| a.bic.total_cmp(&b.bic));
    let report = serde_json::json!({
        "rule": format!("every offset-only fit within {IDENT_SSE_RATIO}× the best SSE that places the profile's ends more than half an FWHM apart (up to {IDENT_MAX_STARTS}) is refined with each background candidate; the lowest BIC picks which blob is which line"),
        "chosen_lambda_at_ends_nm": best.ends_nm,
        "starts": rows,
        "runner_up_delta_bic": runner_up.map(|r| r.bic - best.bic),
    });
    let warning = runner_up
        .filter(|r| r.bic - best.bic <= IDENT_AMBIGUOUS_DELTA_BIC)
        .map(|r| {
            format!(
                "the lamp lines can be matched to the blobs another way: an identification with the profile's ends at {:.1} / {:.1} nm (chosen: {:.1} / {:.1} nm) fits within ΔBIC {:.1}; check the ROI, the lamp (--lamp) and the direction (--direction)",
                r.ends_nm[0],
                r.ends_nm[1],
                best.ends_nm[0],
                best.ends_nm[1],
                r.bic - best.bic
            )
        });
    Some((report, warning))
}

/// Every background candidate refined from the given starts (θ in the layout of `full`), the
/// best by BIC (`n_extra` unlisted line wavelengths counted as parameters, `ln_n` each) and the
/// others.
#[allow(clippy::type_complexity)]
fn fit_candidates<'a>(
    candidates: &[BackgroundTerms],
    full: &Problem<'a>,
    starts: &[&[f64]],
    n_extra: usize,
    ln_n: f64,
) -> Candidates<'a> {
    let mut fitted: Vec<(Problem<'a>, Fitted, f64, Vec<StartFit>)> = candidates
        .par_iter()
        .map(|&terms| {
            let pr = full.with(2, terms);
            let score = |i: usize, f: &Fitted| StartFit {
                start: i,
                ends_nm: [pr.lambda(&f.theta, -1.0), pr.lambda(&f.theta, 1.0)],
                bic: pr.bic(f) + n_extra as f64 * ln_n,
            };
            let mut best = pr.levenberg_marquardt(&pr.theta_from(full, starts[0]));
            let mut per_start = vec![score(0, &best)];
            if terms.has_continuum() {
                for (i, st) in starts.iter().enumerate().skip(1) {
                    let f = pr.levenberg_marquardt(&pr.theta_from(full, st));
                    per_start.push(score(i, &f));
                    if f.eval.sse < best.eval.sse {
                        best = f;
                    }
                }
            }
            let bic = pr.bic(&best) + n_extra as f64 * ln_n;
            (pr, best, bic, per_start)
        })
        .collect();
    let best_i = (0..fitted.len())
        .min_by(|&a, &b| fitted[a].2.total_cmp(&fitted[b].2))
        .unwrap_or(0);
    let (pr, fit, bic, per_start) = fitted.swap_remove(best_i);
    Candidates {
        pr,
        fit,
        bic,
        per_start,
        others: fitted.into_iter().map(|(p, f, b, _)| (p, f, b)).collect(),
    }
}

/// A background's fit with a quadratic map: the problem, the fit, its BIC, and against the same
/// background with a linear map the F statistic and a2 over its standard error.
type QuadraticFit<'a> = (Problem<'a>, Fitted, f64, f64, f64);

/// Refits `lpr`'s background with a quadratic map from its linear-map fit; `bic_extra` is added
/// to the BIC (unlisted lines' wavelengths), `n_obs` the number of profile values.
fn quadratic_of<'a>(
    lpr: &Problem<'a>,
    lfit: &Fitted,
    bic_extra: f64,
    n_obs: usize,
) -> QuadraticFit<'a> {
    let qpr = lpr.with(3, lpr.terms);
    let quad = qpr.levenberg_marquardt(&qpr.theta_from(lpr, &lfit.theta));
    let bic = qpr.bic(&quad) + bic_extra;
    let dof2 = n_obs
        .saturating_sub(qpr.n_theta() + quad.eval.n_active)
        .max(1) as f64;
    let f = (lfit.eval.sse - quad.eval.sse) / (quad.eval.sse / dof2).max(1e-300);
    let t_a2 = covariance(&quad.jac, quad.eval.sse, dof2)
        .as_ref()
        .map(|c| quad.theta[2] / c[(2, 2)].max(1e-300).sqrt())
        .unwrap_or(0.0);
    (qpr, quad, bic, f, t_a2)
}

/// A quadratic map is justified against the linear one with the same background: F-test
/// p < 0.001 (F(1, ∞) at p = 0.001 is 10.83) and |a2| > 3σ.
fn quadratic_justified(f: f64, t_a2: f64) -> bool {
    f > 10.83 && t_a2.abs() > 3.0
}

/// ∇_θ λ(u) for a map of `n_map` coefficients in u (θ's first entries) and `p` parameters.
fn lambda_gradient(p: usize, n_map: usize, u: f64) -> DVector<f64> {
    DVector::from_fn(p, |j, _| if j < n_map { u.powi(j as i32) } else { 0.0 })
}

/// The kinds of continuum a background can have (see [`BackgroundTerms`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum ContinuumFamily {
    /// Cubic B-spline in u per channel.
    SplineInU,
    /// Per-channel spectrum seen through the passband.
    Passband,
    /// One spectrum shared by the channels through a known camera.
    Shared,
}

/// The continuum family of a background and its number of intervals; None without a continuum.
fn continuum_family(t: &BackgroundTerms) -> Option<(ContinuumFamily, usize)> {
    if t.continuum_intervals > 0 {
        Some((ContinuumFamily::SplineInU, t.continuum_intervals))
    } else if t.passband_intervals > 0 {
        Some((ContinuumFamily::Passband, t.passband_intervals))
    } else if t.shared_intervals > 0 {
        // flexibility: intervals first, then a weaker penalty (no penalty the most flexible)
        let smooth = match t.shared_smoothness_milli {
            0 => 999_999,
            m => m as usize,
        };
        Some((
            ContinuumFamily::Shared,
            t.shared_intervals * 1_000_000 + smooth,
        ))
    } else {
        None
    }
}

/// λ and its statistical variance (HAC sandwich, [`crate::lvf::sigma`]) at the positions `us` of
/// a fit whose map is `pr.n_map` coefficients in u.
fn lambda_and_variance(pr: &Problem, fit: &Fitted, us: &[f64]) -> Option<Vec<(f64, f64)>> {
    let p = fit.jac.ncols();
    let targets: Vec<DVector<f64>> = us
        .iter()
        .map(|&u| lambda_gradient(p, pr.n_map, u))
        .collect();
    let s = crate::lvf::sigma::hac_sandwich(
        &fit.jac,
        &fit.eval.residual,
        3,
        fit.eval.n_active,
        &targets,
    )?;
    Some(
        us.iter()
            .zip(&targets)
            .map(|(&u, a)| {
                (
                    pr.lambda(&fit.theta, u),
                    (a.transpose() * &s.covariance * a)[(0, 0)].max(0.0),
                )
            })
            .collect(),
    )
}

/// What the `--camera` check found ([`judge_camera_colours`], [`apply_camera_verdict`]): the check, and the shared-continuum candidates it
/// dropped (name, BIC) when it judged the curves not the image's.
struct CameraColours {
    check: crate::lvf::line_colour::LineColourCheck,
    dropped: Vec<(String, f64)>,
    chosen_replaced: Option<String>,
}

/// The `--camera` curves judged by the lines' colours ([`crate::lvf::line_colour`]) in the best
/// (by BIC) candidate whose continuum is shared through them; None when there is no such
/// candidate or no line to judge.
fn judge_camera_colours(
    cam: &CameraResponse,
    chosen_pr: &Problem,
    chosen_fit: &Fitted,
    best_bic: f64,
    others: &[(Problem, Fitted, f64)],
) -> Option<crate::lvf::line_colour::LineColourCheck> {
    let best_shared = std::iter::once((chosen_pr, chosen_fit, best_bic))
        .chain(others.iter().map(|(p, f, b)| (p, f, *b)))
        .filter(|(p, _, _)| is_shared(p))
        .min_by(|a, b| a.2.total_cmp(&b.2))?;
    let (spr, sfit, _) = best_shared;
    let nm = spr.lines();
    let amp: Vec<[f64; 3]> = (0..nm.len())
        .map(|i| std::array::from_fn(|c| sfit.eval.alpha[c][N_BG + i]))
        .collect();
    crate::lvf::line_colour::check(cam, nm, &amp, spr.fwhm(&sfit.theta))
}

/// True for a candidate whose continuum spectrum is shared through the camera's curves.
fn is_shared(p: &Problem) -> bool {
    p.terms.shared_intervals > 0
}

/// Acts on a verdict of the curves: when they are not the image's, every shared-continuum
/// candidate is dropped (neither chosen nor counted in the model-choice systematic) and, if one
/// was chosen, the best remaining candidate by BIC takes its place.
fn apply_camera_verdict<'a>(
    check: crate::lvf::line_colour::LineColourCheck,
    chosen_pr: &mut Problem<'a>,
    chosen_fit: &mut Fitted,
    best_bic: &mut f64,
    others: &mut Vec<(Problem<'a>, Fitted, f64)>,
) -> CameraColours {
    if !check.inconsistent() {
        return CameraColours {
            check,
            dropped: Vec::new(),
            chosen_replaced: None,
        };
    }
    let mut dropped: Vec<(String, f64)> = others
        .iter()
        .filter(|(p, _, _)| is_shared(p))
        .map(|(p, _, b)| (p.terms.name(), *b))
        .collect();
    others.retain(|(p, _, _)| !is_shared(p));
    let mut chosen_replaced = None;
    if is_shared(chosen_pr) {
        let next = (0..others.len()).min_by(|&a, &b| others[a].2.total_cmp(&others[b].2));
        if let Some(k) = next {
            let (p, f, b) = others.swap_remove(k);
            dropped.push((chosen_pr.terms.name(), *best_bic));
            chosen_replaced = Some(chosen_pr.terms.name());
            *chosen_pr = p;
            *chosen_fit = f;
            *best_bic = b;
        }
    }
    dropped.sort_by(|a, b| a.1.total_cmp(&b.1));
    CameraColours {
        check,
        dropped,
        chosen_replaced,
    }
}

/// Largest BIC lead of a spline in u over the passband continuum at which the focused criterion
/// still compares the two ([`focused_refinement`]). Measured (docs/performance.md, issue 12,
/// twenty-fourth session): the 14 replacements seen on CFL images (its phosphor or a flat
/// continuum, 1 and 5 % noise, three cameras, seeds 1–6; 10 helpful, 3 harmful) had the passband
/// continuum 37–127 behind; on 36 independent 5 % Hg draws (`scripts/reference/lvf_robustness.py
/// --cases 30 --seeds 1-12`, Canon 5D Mark II, Nikon D700, Nokia N900) the five replacements were
/// 238–374 behind and four of them pushed 700 nm past issue 12's 0.4 nm (0.67–0.87 nm, BIC's own
/// choice ≤ 0.26). Not a statistical test: the variance of the difference between the two
/// non-nested fits is only bounded, and the passband continuum's λ scatters more than its
/// statistical σ where the data do not ask for it. Nor a full fix: on lumifit's own 5 % Hg
/// images harmful replacements also occur at ΔBIC 15–193, within the CFL's range.
pub(crate) const FOCUSED_ACROSS_MAX_DELTA_BIC: f64 = 200.0;

/// Why the continuum BIC chose was replaced (see [`focused_refinement`]).
#[derive(Debug, Clone)]
struct FocusedChoice {
    bic_choice: String,
    /// Estimated mean squared error of λ summed over 400 and 700 nm (nm²): BIC's choice, then the
    /// reference model W that replaced it.
    mse: [f64; 2],
    /// λ(W) − λ(BIC's choice) at the 400 / 700 nm positions.
    shift_nm: [f64; 2],
}

/// BIC weighs the whole profile; what the calibration is for is λ at 400 and 700 nm, which a
/// continuum a little too coarse for the image can bias while costing the likelihood less than
/// k·ln N. The focused information criterion (Claeskens & Hjort 2003, "The focused information
/// criterion", JASA 98) compares, for the quantity of interest μ, the estimated mean squared
/// error of a narrower model N against the widest one W of the family, taken as unbiased:
///
/// ```text
/// MSE(N) = max(0, (μ_N − μ_W)² − (v_W − v_N)) + v_N,      MSE(W) = v_W
/// ```
///
/// (the bias² estimate less the variance of the difference, v_W − v_N for nested models, plus
/// N's variance). Here μ is λ at the chosen map's 400 and 700 nm positions (MSEs summed) and v the
/// statistical variance of each fit. W is a model that can draw what lies under the lines
/// without bias: for a shared spectrum through a known camera (`--camera`) the most flexible of
/// that family — finest spacing, then weakest roughness penalty (close to nested); for a spline in u the per-channel passband continuum (not
/// nested: the bound v_W + v_N on the variance of the difference, below). The passband continuum
/// itself has one spacing and is not revised. Returns the index in `others` of W when its MSE is
/// the smaller, with the numbers.
fn focused_refinement(
    chosen_pr: &Problem,
    chosen_fit: &Fitted,
    chosen_bic: f64,
    others: &[(Problem, Fitted, f64)],
) -> Option<(usize, FocusedChoice)> {
    if chosen_pr.n_map != 2 {
        return None;
    }
    let (fam, k) = continuum_family(&chosen_pr.terms)?;
    // A spline in u is compared with the passband continuum, not with a finer spline in u: the
    // finest spline in u is itself biased where a camera edge or a phosphor band sits under a
    // line (CFL + its continuum, noise-free: continuum9 −0.40 / +0.86, continuum12 +0.43 / −1.17
    // nm at 400 / 700 nm), so it is no unbiased reference (tried: it took continuum12 for
    // continuum9 on the CFL at 5 % noise, Canon 0.85 → 1.26, SONY NEX-5N 0.72 → 0.94 nm), while
    // the passband continuum — any non-negative spectrum per channel seen through the passband —
    // is the general model of what lies under the lines. The two are not nested, so the variance
    // of the difference is taken as v_W + v_N, a bound when the two estimates of the same data
    // are not negatively correlated; it leans towards BIC's choice.
    let across = fam == ContinuumFamily::SplineInU;
    let (kw, _) = others
        .iter()
        .enumerate()
        .filter(|(_, (p, _, _))| {
            p.terms.falloff_degree == chosen_pr.terms.falloff_degree
                && p.n_map == chosen_pr.n_map
                && p.lines.len() == chosen_pr.lines.len()
                && continuum_family(&p.terms).is_some_and(|(f, kk)| {
                    if across {
                        f == ContinuumFamily::Passband
                    } else {
                        f == fam && kk > k
                    }
                })
        })
        .max_by_key(|(_, (p, _, _))| continuum_family(&p.terms).map_or(0, |x| x.1))?;
    let (wpr, wfit, wbic) = &others[kw];
    // Across families the variance of the difference is only bounded, and where the data do
    // not ask for the passband continuum its λ scatters more than its statistical σ says: the
    // comparison is made only when it is not far behind in BIC.
    if across && wbic - chosen_bic > FOCUSED_ACROSS_MAX_DELTA_BIC {
        return None;
    }
    let (a0, a1) = (chosen_fit.theta[0], chosen_fit.theta[1]);
    if a1.abs() < 1e-12 {
        return None;
    }
    let us: Vec<f64> = [400.0, 700.0]
        .iter()
        .map(|nm| (nm - a0) / a1)
        .filter(|u| u.abs() <= 1.5)
        .collect();
    if us.is_empty() {
        return None;
    }
    let n = lambda_and_variance(chosen_pr, chosen_fit, &us)?;
    let w = lambda_and_variance(wpr, wfit, &us)?;
    let mut mse = [0.0; 2];
    let mut shift = [0.0; 2];
    for (i, ((ln, vn), (lw, vw))) in n.iter().zip(&w).enumerate() {
        let d = lw - ln;
        let vd = if across { vw + vn } else { (vw - vn).max(0.0) };
        mse[0] += (d * d - vd).max(0.0) + vn;
        mse[1] += vw;
        if i < 2 {
            shift[i] = d;
        }
    }
    (mse[1] < mse[0]).then(|| {
        (
            kw,
            FocusedChoice {
                bic_choice: chosen_pr.terms.name(),
                mse,
                shift_nm: shift,
            },
        )
    })
}

/// What [`fit_candidates`] returns: the chosen background's problem, fit and BIC, the BIC and
/// map ends each start reached with that background, and the other candidates.
struct Candidates<'a> {
    pr: Problem<'a>,
    fit: Fitted,
    bic: f64,
    per_start: Vec<StartFit>,
    others: Vec<(Problem<'a>, Fitted, f64)>,
}

/// One start's refinement under the chosen background: the identification it reached (λ at
/// the profile's ends) and its BIC.
#[derive(Clone, Debug)]
struct StartFit {
    start: usize,
    ends_nm: [f64; 2],
    bic: f64,
}

/// Offset-only fits that identify the blobs differently (which blob is which lamp line): the
/// best and second best, then every fit within [`IDENT_SSE_RATIO`] of the best SSE whose λ at
/// either end of the profile differs by more than half the FWHM guess from every start already
/// kept, up to [`IDENT_MAX_STARTS`]. The offset-only fit cannot tell them apart when a broad
/// band the lamp list does not draw (a CFL's Eu²⁺ blue band) sits beside the lines; refined with
/// each background candidate, the continuum carries the band and BIC picks the identification.
fn identification_starts<'f>(
    full: &Problem,
    plain: &'f [Fitted],
    fwhm_guess: f64,
) -> Vec<&'f Fitted> {
    let ends = |f: &Fitted| [full.lambda(&f.theta, -1.0), full.lambda(&f.theta, 1.0)];
    let mut kept: Vec<&Fitted> = plain.iter().take(2).collect();
    let Some(best_sse) = plain.first().map(|f| f.eval.sse) else {
        return kept;
    };
    for f in plain.iter().skip(2) {
        if kept.len() >= IDENT_MAX_STARTS || f.eval.sse > IDENT_SSE_RATIO * best_sse {
            break;
        }
        let e = ends(f);
        let distinct = kept
            .iter()
            .all(|k| other_identification(e, ends(k), fwhm_guess));
        if distinct {
            kept.push(f);
        }
    }
    kept
}

/// The fit whose residual is searched for unexplained lines.
struct Detect<'d, 'a> {
    problem: &'d Problem<'a>,
    theta: &'d [f64],
    eval: &'d Eval,
}

/// Lines of a mercury table ([`Lamp::is_mercury_table`]) closer than this (nm) are a pair whose split
/// gets a prior ([`SplitPrior`]): 404.7/407.8 and 577.0/579.1 nm.
pub(crate) const SPLIT_PAIR_NM: f64 = 5.0;

/// Default width τ of the split prior ([`FitOptions::split_prior_tau`]): the log ratio within
/// 0.3 (±35 %) of the table's. Lamp tables and lamps differ by tens of per cent (404.7 : 407.8
/// nm is 10 : 1 in `--lamp hg`, 12 : 1 in NIST's intensities), and the camera's slope over the
/// pair's 2–3 nm moves a channel's ratio too (the Nikon D700's red rises 5× from 570 to 580
/// nm). Measured without `--camera`, 10 % flat continuum + quadratic 0.3, rms error at 700 nm
/// with the splits free → with τ = 0.3 (docs/performance.md, issue 12, twenty-fifth session):
/// 1 % noise Canon 5D Mark II 0.079 → 0.037, Nikon D700 0.040 → 0.038, SONY NEX-5N 0.043 →
/// 0.019 nm; 5 % 0.170 → 0.129, 0.175 → 0.170, 0.185 → 0.118 nm; and on a lamp rendered with
/// other splits (5 : 1 and 2 : 3) no worse: 1 % 0.071 → 0.028, 0.038 → 0.035, 0.042 → 0.025,
/// NEX-5N 5 % 0.194 → 0.098 nm. τ = 0.1 gained more on the D700 at 5 % (0.149 nm) but trusts
/// the table to 10 %, which lamps do not promise.
pub const SPLIT_PRIOR_TAU: f64 = 0.3;

/// The split priors of a lamp: each adjacent pair of a mercury table's lines closer than
/// [`SPLIT_PAIR_NM`], both with a positive power, with width `tau` (none for `tau` ≤ 0).
pub(crate) fn split_priors(lamp: &Lamp, tau: f64) -> Vec<SplitPrior> {
    if tau.is_nan() || tau <= 0.0 || !lamp.is_mercury_table() {
        return Vec::new();
    }
    let mut l: Vec<&crate::lvf::lamp::LampLine> = lamp.lines.iter().collect();
    l.sort_by(|a, b| a.nm.total_cmp(&b.nm));
    l.windows(2)
        .filter(|w| {
            w[1].nm - w[0].nm < SPLIT_PAIR_NM
                && w[0].relative_power > 0.0
                && w[1].relative_power > 0.0
        })
        .map(|w| SplitPrior {
            a_nm: w[0].nm,
            b_nm: w[1].nm,
            ratio: w[1].relative_power / w[0].relative_power,
            tau,
        })
        .collect()
}

/// Robust per-channel noise of a profile from its second differences:
/// σ = median|y[i−1] − 2y[i] + y[i+1]| / (0.6745·√6) (white noise; a smooth signal's second
/// differences are tiny at the pixel scale, so the lines do not inflate it).
pub(crate) fn profile_noise(values: &[f64]) -> f64 {
    let mut d: Vec<f64> = values
        .windows(3)
        .map(|w| (w[0] - 2.0 * w[1] + w[2]).abs())
        .collect();
    if d.is_empty() {
        return 0.0;
    }
    d.sort_by(f64::total_cmp);
    d[d.len() / 2] / (0.6745 * 6f64.sqrt())
}

/// With a shared continuum spectrum chosen (`--camera`), background candidates within this ΔBIC
/// enter the model-choice systematic. The shared spectrum draws a continuum as the camera sees
/// it, so a spline or passband continuum thousands of BIC worse is not a plausible alternative:
/// counting every continuum candidate whatever its ΔBIC, as without a camera, made σ at 700 nm
/// 1.3–4.5 nm on CFL images whose error was under 0.23 nm (a 9-interval spline at ΔBIC 2763 moved
/// λ at 700 nm by 0.96 nm for an error of 0.085). On the grid of `scripts/bench/lvf_sigma_grid.py
/// --shared` (Hg and CFL, three cameras, two seeds, without the tilted and off-centre fall-offs
/// the strips cannot see) σ covers the error at 2σ in 94 % (Hg) and 100 % (CFL) of (image,
/// position) pairs, median σ/|e| 1.7 and 2.6. Without a camera every candidate draws the continuum approximately, and
/// their whole spread is kept as the estimate of that systematic (ΔBIC ≤ 100 alone covered 88 %
/// of the CFL pairs there and failed `tests/lvf_sigma_coverage.rs`).
const MODEL_CHOICE_DELTA_BIC: f64 = 100.0;

/// dθ/dκ of the fit at θ for the radial fall-off's κ = (κ₀, κ₁) (p × 2, p = the Jacobian's
/// columns): the residual's change when ln V moves by ε·∂ln V/∂κ_k (central differences, the
/// linear coefficients re-solved), carried to θ by the Gauss–Newton step −(JᵀJ)⁻¹Jᵀ·dr.
/// None when the lengths disagree or JᵀJ is singular.
fn radial_sensitivity(
    pr: &Problem,
    theta: &[f64],
    jac: &DMatrix<f64>,
    r: &crate::lvf::background::RadialFalloff,
) -> Option<DMatrix<f64>> {
    let n = pr.u.len();
    if r.q_along.len() != n || !(pr.vfix.is_empty() || pr.vfix.len() == n) || jac.nrows() != 3 * n {
        return None;
    }
    let base = |i: usize| pr.vfix.get(i).copied().unwrap_or(1.0);
    let chol = (jac.transpose() * jac).cholesky()?;
    const EPS: f64 = 1e-4;
    let mut g = DMatrix::zeros(jac.ncols(), 2);
    for k in 0..2 {
        let residual = |sign: f64| {
            let mut q = pr.with(pr.n_map, pr.terms);
            q.vfix = r
                .q_along
                .iter()
                .enumerate()
                .map(|(i, &x)| {
                    let d = if k == 0 { x } else { 0.5 * x * x };
                    base(i) * (sign * EPS * d).exp()
                })
                .collect();
            q.eval(theta).residual
        };
        let (rp, rm) = (residual(1.0), residual(-1.0));
        if rp.len() != 3 * n || rm.len() != 3 * n {
            return None;
        }
        let dr = DVector::from_iterator(
            3 * n,
            rp.iter().zip(&rm).map(|(a, b)| (a - b) / (2.0 * EPS)),
        );
        g.set_column(k, &(-chol.solve(&(jac.transpose() * dr))));
    }
    Some(g)
}

/// Wavelengths no lamp can put on a sensor behind a visible LVF.
const PHYSICAL_NM: (f64, f64) = (200.0, 1200.0);
/// Residual RMS over the noise above which the model does not explain the profile (warning).
const RESIDUAL_OVER_NOISE_WARN: f64 = 3.0;
/// Residual RMS relative to the profile's peak above which the calibration is refused, when it
/// is also [`RESIDUAL_OVER_NOISE_REJECT`] times the noise.
const RESIDUAL_RELATIVE_REJECT: f64 = 0.05;
/// See [`RESIDUAL_RELATIVE_REJECT`].
const RESIDUAL_OVER_NOISE_REJECT: f64 = 10.0;
/// A listed line (with its blended neighbours) is flagged absent when in no channel its amplitude
/// exceeds this fraction of the channel's brightest line … (measured, 1 % noise, three cameras:
/// lines listed but not in the image take at most 0.77 % of a channel's brightest under 4–10 %
/// continua and vignetting, 0.013 % on a clean CFL; the weakest real CFL line, 650.8 nm, is
/// 1.8–2.7 % of the red's brightest)
const ABSENT_RELATIVE: f64 = 0.01;
/// … and this many standard errors of the amplitude.
const ABSENT_SIGMA: f64 = 5.0;
/// Fitted FWHM over the guess outside [1/x, x] is flagged.
const FWHM_RATIO_WARN: f64 = 2.0;
/// An unexplained blob must exceed this fraction of the profile's peak (the coarse
/// continuum's misfit of a 4 % continuum under vignetting leaves blob-like bumps of 2.7 %) …
const UNEXPLAINED_RELATIVE: f64 = 0.04;
/// … and this many standard errors of its amplitude.
const UNEXPLAINED_SIGMA: f64 = 8.0;

/// Checks the fit for physically impossible or unexplained results: refuses maps outside
/// 200–1200 nm, fewer than two observed lines, or a profile the lamp list cannot explain
/// (residual > 5 % of the peak and > 10× the noise); flags (in `warnings`) a FWHM far from the
/// guess, residual structure above the noise, lines in range with no amplitude, and blobs in
/// the residual that no listed line explains (`unexplained_lines`, matched filter with the
/// fitted passband).
fn assess(
    cal: &mut LvfCalibration,
    pr: &Problem,
    theta: &[f64],
    eval: &Eval,
    detect: &Detect,
    lamp: &Lamp,
    fwhm_guess: f64,
) -> Result<()> {
    let n = pr.u.len();
    let lams: Vec<f64> = pr.u.iter().map(|&u| pr.lambda(theta, u)).collect();
    let lo = lams.iter().cloned().fold(f64::INFINITY, f64::min);
    let hi = lams.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    let src = &cal.source;
    if lo < PHYSICAL_NM.0 || hi > PHYSICAL_NM.1 {
        return Err(Error::Numerical {
            what: "LVF whole-profile fit".into(),
            reason: format!(
                "{src}: the best map puts the ROI at {lo:.1}–{hi:.1} nm, outside the physically possible {}–{} nm; lamp '{}' does not explain this image (wrong --lamp, not a lamp photo, wrong ROI or --direction)",
                PHYSICAL_NM.0, PHYSICAL_NM.1, lamp.name
            ),
        });
    }
    let observed = cal
        .lines
        .iter()
        .filter(|l| l.amplitude.iter().any(|a| *a > 0.0))
        .count();
    if observed < 2 {
        return Err(Error::Numerical {
            what: "LVF whole-profile fit".into(),
            reason: format!(
                "{src}: only {observed} of the lamp's lines is seen at {lo:.1}–{hi:.1} nm; at least two are needed to determine the map (wrong --lamp or ROI?)"
            ),
        });
    }
    let peak = (0..3)
        .flat_map(|c| pr.y[c].iter().copied())
        .fold(f64::MIN, f64::max)
        .max(1e-300);
    // the residual is weighted: the noise it is compared with is the whitened data's
    let noise: Vec<f64> = (0..3).map(|c| profile_noise(&pr.whitened(c))).collect();
    // amplitudes and their columns are in image units: so is the noise they are judged by
    let noise_image: Vec<f64> = (0..3).map(|c| profile_noise(pr.y[c])).collect();
    let noise_rms = (noise.iter().map(|s| s * s).sum::<f64>() / 3.0).sqrt();
    let resid_rms = (eval.sse / (3 * n) as f64).sqrt();
    let relative = resid_rms / peak;
    let over_noise = resid_rms / noise_rms.max(1e-12 * peak);
    cal.rms_residual_relative = Some(relative);
    cal.diagnostics["noise_rms"] = serde_json::json!(noise_rms);
    cal.diagnostics["residual_over_noise"] = serde_json::json!(over_noise);
    if relative > RESIDUAL_RELATIVE_REJECT && over_noise > RESIDUAL_OVER_NOISE_REJECT {
        return Err(Error::Numerical {
            what: "LVF whole-profile fit".into(),
            reason: format!(
                "{src}: lamp '{}' does not explain the profile: the residual is {:.1} % of the peak and {over_noise:.0}× the noise (best map {lo:.1}–{hi:.1} nm, FWHM {:.1} nm); check --lamp, the ROI and that this is a lamp photo",
                lamp.name,
                100.0 * relative,
                cal.fwhm_nm
            ),
        });
    }
    let mut warnings = Vec::new();
    let ratio = cal.fwhm_nm / fwhm_guess;
    if !(1.0 / FWHM_RATIO_WARN..=FWHM_RATIO_WARN).contains(&ratio) {
        warnings.push(format!(
            "fitted passband FWHM {:.1} nm is {ratio:.2}× the guess {fwhm_guess} nm: check --fwhm-guess and --lamp",
            cal.fwhm_nm
        ));
    }
    if over_noise > RESIDUAL_OVER_NOISE_WARN {
        warnings.push(format!(
            "residual structure {over_noise:.1}× the noise ({:.2} % of the peak): the model (lamp list, passband, background) does not fully explain the profile",
            100.0 * relative
        ));
    }
    // A line is detected in a channel when its amplitude is both more than ABSENT_RELATIVE of
    // that channel's brightest line (a CFL's violet mercury lines are 1 % of its green Tb³⁺ line
    // but 4 % of the blue channel's brightest) and ABSENT_SIGMA standard errors from zero
    // (σ_a = noise / ‖column‖, the column being the line's passband blob times the fall-off).
    // It is absent when neither it nor any listed line within half the FWHM (an unresolved
    // group, whose split of amplitude is arbitrary) is detected in any channel.
    let brightest: [f64; 3] =
        std::array::from_fn(|c| cal.lines.iter().map(|l| l.amplitude[c]).fold(0.0, f64::max));
    let fwhm_fit = pr.fwhm(theta);
    let v_fit = pr.falloff_coefficients(theta);
    let column_norm = |nm: f64| {
        lams.iter()
            .enumerate()
            .map(|(i, &lam)| {
                let f = falloff(v_fit, pr.u[i]) * pr.vfix.get(i).copied().unwrap_or(1.0);
                (f * pr.passband.eval(nm - lam, fwhm_fit)).powi(2)
            })
            .sum::<f64>()
            .sqrt()
    };
    let detected: Vec<bool> = cal
        .lines
        .iter()
        .map(|l| {
            let norm = column_norm(l.nm);
            (0..3).any(|c| {
                let a = l.amplitude[c];
                a > ABSENT_RELATIVE * brightest[c] && a * norm >= ABSENT_SIGMA * noise_image[c]
            })
        })
        .collect();
    for l in &cal.lines {
        let inside = l.nm > lo + 0.5 * cal.fwhm_nm && l.nm < hi - 0.5 * cal.fwhm_nm;
        let group_detected = cal
            .lines
            .iter()
            .zip(&detected)
            .any(|(o, &d)| d && (o.nm - l.nm).abs() < 0.5 * cal.fwhm_nm);
        if inside && !group_detected {
            warnings.push(format!(
                "lamp line {} nm lies inside the calibrated range but neither it nor a line blended with it is detected in any channel (amplitude at most {:.0} % of the channel's brightest line or under {ABSENT_SIGMA:.0}σ of the noise): it is absent from the image, too weak through this camera, or the lamp list is wrong",
                l.nm,
                100.0 * ABSENT_RELATIVE
            ));
        }
    }
    // Matched filter of the residual with the fitted passband (times the fall-off).
    let (pr, theta, eval) = (detect.problem, detect.theta, detect.eval);
    let lams: Vec<f64> = pr.u.iter().map(|&u| pr.lambda(theta, u)).collect();
    let fwhm = pr.fwhm(theta);
    let v = pr.falloff_coefficients(theta);
    let scale: Vec<f64> = (0..n)
        .map(|j| falloff(v, pr.u[j]) * pr.vfix.get(j).copied().unwrap_or(1.0))
        .collect();
    // (relative amplitude, significance) per sample, in image units (a blob's size relative to
    // the peak does not depend on the weights)
    let score = crate::lvf::extra_lines::matched_filter(
        &lams,
        &scale,
        &pr.unweighted(&eval.residual),
        &|d| pr.passband.eval(d, fwhm),
        2.0 * fwhm,
        [noise_image[0], noise_image[1], noise_image[2]],
        peak,
    );
    let mut found: Vec<UnexplainedLine> = Vec::new();
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| score[b].0.total_cmp(&score[a].0));
    for i in order {
        let (rel, sig) = score[i];
        if rel < UNEXPLAINED_RELATIVE || sig < UNEXPLAINED_SIGMA {
            break;
        }
        let li = lams[i];
        let edge = li < lo + 0.5 * fwhm || li > hi - 0.5 * fwhm;
        let near_listed = lamp.lines.iter().any(|l| (l.nm - li).abs() < 0.5 * fwhm);
        let near_found = found.iter().any(|f| (f.nm - li).abs() < fwhm);
        if edge || near_listed || near_found {
            continue;
        }
        found.push(UnexplainedLine {
            nm: li,
            px: cal.curves.px.get(i).copied().unwrap_or(f64::NAN),
            amplitude_relative: rel,
            significance: sig,
            fitted: false,
        });
        if found.len() >= 8 {
            break;
        }
    }
    found.sort_by(|a, b| a.nm.total_cmp(&b.nm));
    for f in &found {
        warnings.push(format!(
            "unexplained line near {:.1} nm (px {:.0}): a blob {:.1} % of the peak ({:.0}σ) that no line of lamp '{}' explains; add it to the lamp list or exclude it with --roi (the map near it may be biased)",
            f.nm,
            f.px,
            100.0 * f.amplitude_relative,
            f.significance,
            lamp.name
        ));
    }
    cal.unexplained_lines = found;
    cal.warnings.extend(warnings);
    Ok(())
}

/// `jac` without its columns past the first `keep` that are exactly zero (parameters with no
/// influence on the residual).
fn without_inert_columns(jac: DMatrix<f64>, keep: usize) -> DMatrix<f64> {
    let inert: Vec<usize> = (keep..jac.ncols())
        .filter(|&j| jac.column(j).iter().all(|v| *v == 0.0))
        .collect();
    if inert.is_empty() {
        jac
    } else {
        jac.remove_columns_at(&inert)
    }
}

/// s²(JᵀJ)⁻¹ with s² = SSE/dof ([`fit::stats`](crate::fit::stats), through the QR of J), or
/// None when J is rank deficient.
fn covariance(jac: &DMatrix<f64>, sse: f64, dof: f64) -> Option<DMatrix<f64>> {
    let (m, p) = jac.shape();
    let c = stats::covariance_scaled(jac.as_slice(), m, p, sse / dof)?;
    Some(DMatrix::from_column_slice(p, p, &c))
}

/// Whether a background's continuum can take up part of a line-wide blob more than the coarsest
/// spline in u can: a finer spline, or the passband continuum (elements ≈ 1.4 line blobs wide,
/// non-negative, so an unlisted line is a shape it can draw). Unlisted lines are then searched
/// in the coarsest spline's fit instead.
fn finer_than_coarse(t: &BackgroundTerms, k_coarse: usize) -> bool {
    t.continuum_intervals > k_coarse || t.passband_intervals > 0
}

/// The coarsest spline-in-u continuum and nothing finer beside it.
fn is_coarse(t: &BackgroundTerms, k_coarse: usize) -> bool {
    t.continuum_intervals == k_coarse && t.passband_intervals == 0 && t.shared_intervals == 0
}

/// Central-difference Jacobian columns of `residual` at `theta` (column j with step `step(j)`),
/// the columns computed in parallel: the whole-profile fit and the unlisted-line fit
/// ([`crate::lvf::unlisted`]) both differentiate their residuals this way.
pub(crate) fn central_difference_columns<H, R>(theta: &[f64], step: H, residual: R) -> Vec<Vec<f64>>
where
    H: Fn(usize) -> f64 + Sync,
    R: Fn(&[f64]) -> Vec<f64> + Sync,
{
    (0..theta.len())
        .into_par_iter()
        .map(|j| {
            let h = step(j);
            let mut tp = theta.to_vec();
            let mut tm = theta.to_vec();
            tp[j] += h;
            tm[j] -= h;
            let rp = residual(&tp);
            let rm = residual(&tm);
            rp.iter()
                .zip(&rm)
                .map(|(a, b)| (a - b) / (2.0 * h))
                .collect()
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inert_unlisted_columns_are_left_out_of_the_covariance() {
        // θ (3) and two unlisted wavelengths, the first without influence
        let jac = DMatrix::from_fn(6, 5, |i, j| match j {
            3 => 0.0,
            _ => ((i * 7 + j * 3) % 5) as f64 + if i == j { 2.0 } else { 0.0 },
        });
        assert!(covariance(&jac, 1.0, 1.0).is_none());
        let kept = without_inert_columns(jac.clone(), 3);
        assert_eq!(kept.ncols(), 4);
        assert_eq!(kept.column(3), jac.column(4));
        assert!(covariance(&kept, 1.0, 1.0).is_some());
        // a zero column among θ's own is kept (its singularity is a real failure)
        let mut z = jac.clone();
        z.column_mut(1).fill(0.0);
        assert_eq!(without_inert_columns(z, 3).ncols(), 4);
    }

    #[test]
    fn nnls_keeps_amplitudes_non_negative_and_backgrounds_free() {
        // y = -1 (background) + 2·col2; col3 would want a negative weight.
        let n = 20;
        let phi = DMatrix::from_fn(n, 3, |i, j| match j {
            0 => 1.0,
            1 => (i as f64 / 4.0).sin().abs(),
            _ => i as f64 / n as f64,
        });
        let y = DVector::from_fn(n, |i, _| -1.0 + 2.0 * phi[(i, 1)] - 0.5 * phi[(i, 2)]);
        let g = phi.transpose() * &phi;
        let h = phi.transpose() * &y;
        let x = nnls_gram(&g, &h, 1);
        assert!(x[0] < 0.0, "background stays free: {x}");
        assert!(x[1] > 0.0 && x[2] >= 0.0, "{x}");
        assert_eq!(x[2], 0.0);
    }

    /// The NNLS with its growing Cholesky factor is the exact NNLS: on random problems whose
    /// solutions need variables to enter and leave, it equals the best feasible point over every
    /// passive set (brute force, each set solved by nalgebra's Cholesky), and it satisfies the
    /// KKT conditions.
    #[test]
    fn nnls_equals_the_brute_force_optimum_over_all_passive_sets() {
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut rnd = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        for _ in 0..200 {
            let (m, k, n_free) = (14, 7, 2);
            // correlated columns: the unconstrained solution has negative entries
            let base = DMatrix::from_fn(m, 3, |_, _| rnd());
            let a = DMatrix::from_fn(m, k, |i, j| {
                base[(i, j % 3)] + 0.6 * rnd() * (j as f64 + 1.0) / 4.0
            });
            let y = DVector::from_fn(m, |_, _| rnd());
            let g = a.transpose() * &a;
            let h = a.transpose() * &y;
            let x = nnls_gram(&g, &h, n_free);
            let cost = |x: &DVector<f64>| (&y - &a * x).norm_squared();
            let mut best = f64::INFINITY;
            for mask in 0..1u32 << (k - n_free) {
                let set: Vec<usize> = (0..k)
                    .filter(|&j| j < n_free || mask & (1 << (j - n_free)) != 0)
                    .collect();
                let gs = DMatrix::from_fn(set.len(), set.len(), |i, j| g[(set[i], set[j])]);
                let hs = DVector::from_fn(set.len(), |i, _| h[set[i]]);
                let Some(ch) = gs.cholesky() else { continue };
                let z = ch.solve(&hs);
                if set
                    .iter()
                    .enumerate()
                    .any(|(i, &j)| j >= n_free && z[i] < 0.0)
                {
                    continue;
                }
                let mut full = DVector::zeros(k);
                for (i, &j) in set.iter().enumerate() {
                    full[j] = z[i];
                }
                best = best.min(cost(&full));
            }
            assert!(x.iter().skip(n_free).all(|v| *v >= 0.0), "{x}");
            assert!(
                cost(&x) <= best * (1.0 + 1e-9) + 1e-12,
                "{} vs {best}",
                cost(&x)
            );
            let w = &h - &g * &x;
            for j in n_free..k {
                assert!(w[j] <= 1e-8, "KKT: gradient {} at {j} (x {})", w[j], x[j]);
            }
        }
    }

    #[test]
    fn identifications_within_delta_bic_10_are_warned_and_the_same_one_is_not() {
        let st = |start, a: f64, b: f64, bic| StartFit {
            start,
            ends_nm: [a, b],
            bic,
        };
        // a near-copy of the best (within FWHM/2 at both ends) never warns, however close
        let same = [st(0, 372.0, 746.0, -100.0), st(1, 380.0, 752.0, -99.0)];
        let (r, w) = identification_report(&same, 25.0).unwrap();
        assert!(w.is_none(), "{r}");
        assert_eq!(r["starts"][1]["same_identification"], true);
        assert!(r["runner_up_delta_bic"].is_null());
        // another identification 8 behind: warned; 12 behind: reported, not warned
        for (gap, warned) in [(8.0, true), (12.0, false)] {
            let two = [
                st(0, 470.0, 870.0, -100.0 + gap),
                st(1, 372.0, 746.0, -100.0),
            ];
            let (r, w) = identification_report(&two, 25.0).unwrap();
            assert_eq!(w.is_some(), warned, "gap {gap}: {r}");
            assert_eq!(r["chosen_lambda_at_ends_nm"][0], 372.0);
            assert_eq!(r["starts"][0]["same_identification"], false);
            assert!((r["runner_up_delta_bic"].as_f64().unwrap() - gap).abs() < 1e-9);
        }
        assert!(identification_report(&[], 25.0).is_none());
    }

    #[test]
    fn gaussian_passband_is_half_at_half_the_fwhm() {
        let g = Passband::Gaussian;
        assert!((g.eval(12.5, 25.0) - 0.5).abs() < 1e-12);
        let m = Passband::measured(
            vec![-20.0, -10.0, 0.0, 10.0, 20.0],
            vec![0.0, 0.5, 1.0, 0.5, 0.0],
        )
        .unwrap();
        match &m {
            Passband::Measured { fwhm_nm, .. } => assert!((fwhm_nm - 20.0).abs() < 1e-12),
            _ => unreachable!(),
        }
        assert!((m.eval(20.0, 40.0) - 0.5).abs() < 1e-12);
    }

    /// The uniform-grid evaluation is the pointwise one: the Gaussian recurrence to 1e-13 of the
    /// peak over a run longer than several restarts (and with the same 8σ cut-off), the other
    /// shapes exactly; and every shape is 0 beyond its stated support.
    #[test]
    fn passband_on_a_uniform_grid_is_the_pointwise_passband() {
        let shapes = [
            (Passband::Gaussian, 1e-13),
            (Passband::GenNormal { beta: 3.1 }, 0.0),
            (
                Passband::measured(vec![-30.0, 0.0, 30.0], vec![0.0, 1.0, 0.0]).unwrap(),
                0.0,
            ),
        ];
        for (p, tol) in &shapes {
            for &(d0, step, fwhm, n) in &[
                (-100.37, 1.0, 25.0, 201),
                (-7.2, 0.25, 3.0, 60),
                (3.0, 1.0, 10.0, 5),
            ] {
                let edge = p.support_nm(fwhm) * 1.000_001;
                assert_eq!(p.eval(edge, fwhm), 0.0, "{p:?} beyond its support");
                assert_eq!(p.eval(-edge, fwhm), 0.0, "{p:?} beyond its support");
                let mut out = vec![f64::NAN; n];
                p.eval_uniform(d0, step, fwhm, &mut out);
                for (m, v) in out.iter().enumerate() {
                    let want = p.eval(d0 + m as f64 * step, fwhm);
                    assert!(
                        (v - want).abs() <= *tol,
                        "{p:?} d0 {d0} step {step} m {m}: {v} vs {want}"
                    );
                }
            }
        }
    }
}
