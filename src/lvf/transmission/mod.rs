//! Band transmissions of an LVF from photos of a grey target through colour gels (Nalbach et
//! al. 2017, §4.2, following Kirk & O'Brien 2011).
//!
//! **Model.** Band *j* (a window of positions along the filter, see [`LvfGeometry::window`])
//! has a transmission T_j(λ). A photo *k* of a target of reflectance R lit by a source S, taken
//! through gel F_k (F ≡ 1 for the open LVF) by a camera of sensitivities Q_c, reads in band *j*
//! and channel *c*
//!
//! ```text
//! y_{k,c,j} = Σ_q w_q · S(λ_q) R(λ_q) F_k(λ_q) Q_c(λ_q) · T_j(λ_q)
//! ```
//!
//! on a uniform quadrature grid λ_q with weights w_q = Δλ (the caller samples S, R, F_k, Q_c on
//! it; the quadrature grid may equal the solve grid or be finer). The design matrix is the same
//! for every band; each band is solved on its own. T_j absorbs the camera's exposure and the
//! source's absolute scale, so its peak is relative (only ratios between bands and wavelengths
//! matter for spectral recovery).
//!
//! **Models** ([`BandModel`]):
//! - `nnls`: T_j on the solve grid (5 nm by default), linear between nodes: min ‖A x − b‖² +
//!   μ‖D x‖², x ≥ 0, D the second difference of T padded with zeros beyond the support edges (so
//!   the penalty also charges a band that does not fall smoothly to zero there; an edge set by
//!   the grid rather than the support is not padded), μ = λ·tr(AᵀA)/tr(DᵀD) as in
//!   [`solve_regularized`], λ by *robust* GCV (Lukas 2006, γ = 0.1: GCV·(γ + (1 − γ)·tr(H²)/m))
//!   scanned over 10⁻¹⁰…10⁴, or given. Plain GCV picks λ ≈ 10⁻¹⁰ for the bands at the ends of
//!   the range, where the gels carry no information, and their shapes explode. **Prior:** T_j = 0
//!   outside a support window of ± `support_fwhm` (2.5) times the band's effective FWHM from the
//!   wavelength calibration around its calibrated centre (reported as `support_nm`). The
//!   full-grid system is badly conditioned (beyond the gels' measured range even singular, all
//!   gels being held constant there); window, positivity and smoothness make each band's problem
//!   well posed. λ = 0 falls back to plain (NN)LS by QR / NNLS.
//! - `lstsq`: the same windows, but plain least squares (no penalty, no sign constraint) — the
//!   baseline showing why the constraints matter.
//! - `gaussian` / `super-gaussian`: T_j(λ) = peak · mean_{p ∈ window} g(λ − λ(p) − δ; w, e) with
//!   g(x) = exp(−ln 2 · |2x / w|^(2e)) (e = 1: Gaussian; `super-gaussian` fits e too), the centre
//!   shift δ, passband FWHM w (and e) fitted by Levenberg–Marquardt on the variable-projection
//!   residual (peak ≥ 0 solved linearly for each trial; start from a coarse grid), uncertainties
//!   from the covariance s²(JᵀJ)⁻¹ of all parameters, s² = RSS/(m − p). **Prior:** δ within
//!   ± w_cal/2 and w within 0.5–2 w_cal; fits ending on a bound (bands the data do not
//!   determine) are listed in `diagnostics.at_bound`.
//! - `calibration`: no gel photos — centre from the map, FWHM from the lamp fit, peak 1
//!   ([`calibration_bands`]). Expected error: that of the wavelength calibration (≈ 0.1–0.3 nm
//!   in centre, its `fwhm_sigma_nm` in width) plus whatever the true passband departs from a
//!   Gaussian; and peaks are all 1, so band-to-band throughput differences (vignetting, coating)
//!   are not modelled.
//!
//! **Weights.** With readings' standard errors available, equation (k, c) of band j is divided
//! by σ = √(se² + (floor · max_k,c |y_j|)²); the floor (default 1e-3) keeps near-zero standard
//! errors (few positions per window) from dominating. Dark readings (below 2 per-pixel noise σ,
//! estimated per capture as the median of se·√pixels) get σ ≥ σ_pixel/2: a mean of pixels
//! clipped at black is biased by up to σ_pixel/√(2π), which averaging does not remove.
//!
//! **Output.** A [`BandSet`], written as `lvf_bands.json` (schema `lumifit.lvf-bands/1`), embeds
//! the `lvf.json` it was solved for so spectral recovery can rebuild the geometry.
//!
//! Units: wavelengths in nm, readings in the frame's linear units. No colour-science
//! counterpart.

// Index loops mirror the matrix notation of the maths.
#![allow(clippy::needless_range_loop)]

use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::fit::regularized::{
    condition_number, solve_regularized, RegularizedOptions, Smoothness, Weight,
};
use crate::fit::stats;
use crate::fit::{levenberg_marquardt, LmOptions, Residuals};
use crate::lvf::geometry::{BandReadings, LvfGeometry};

mod band_file;
mod curves;
mod gaussian;
mod grids;
mod problem;
mod solve;
#[cfg(test)]
mod tests;

pub use band_file::{BandModel, BandSet, BandTransmission};
pub use curves::half_max_width;
pub use grids::{calibration_band_shape, calibration_bands, default_grid, uniform_grid};
pub use problem::{GelCapture, TransmissionDiagnostics, TransmissionOptions, TransmissionProblem};
pub use solve::solve_transmissions;

#[allow(unused_imports)]
use band_file::*;
#[allow(unused_imports)]
use curves::*;
#[allow(unused_imports)]
use gaussian::*;
#[allow(unused_imports)]
use grids::*;
#[allow(unused_imports)]
use problem::*;
#[allow(unused_imports)]
use solve::*;

/// Schema tag of `lvf_bands.json`.
pub const BANDS_SCHEMA: &str = "lumifit.lvf-bands/1";

/// Default half-width of a band's support window, in effective FWHMs of the calibration.
pub const DEFAULT_SUPPORT_FWHM: f64 = 2.5;

/// Default relative noise floor of the equation weights.
pub const DEFAULT_NOISE_FLOOR: f64 = 1e-3;

/// Step of the fine grid on which effective FWHMs of parametric bands are measured (nm).
pub(super) const FINE_STEP_NM: f64 = 0.05;

/// γ of robust GCV (Lukas 2006); 1 is plain GCV, smaller values guard against the
/// under-smoothing plain GCV falls into when errors are correlated.
pub(super) const ROBUST_GCV_GAMMA: f64 = 0.1;

/// Readings below this many per-pixel noise σ count as dark (possibly clipped at zero).
pub(super) const DARK_SIGMAS: f64 = 2.0;

/// The σ floor of a dark reading, in per-pixel noise σ (the bias of a zero-clipped mean is
/// σ/√(2π) ≈ 0.4 σ at a true value of zero).
pub(super) const DARK_FRACTION: f64 = 0.5;
