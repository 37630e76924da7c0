//! The calibration result (`lvf.json`): map, passband width, line residuals and bands.
//!
//! Contract read by other tools (more fields may be added):
//! `{"axis":"x","roi":[x,y,w,h],"map":{"kind":"linear","coefficients":[c0,c1]},"fwhm_nm":…,
//! "rms_residual_nm":…,"sigma_nm_at_400":…,"sigma_nm_at_700":…,"bands":[{"nm":…,"px":…,"width_px":…},…]}`
//! with λ(px) = Σ coefficients[i]·pxⁱ and px in the input image's own pixels.

use crate::error::{Error, Result};
use crate::lvf::profile::Axis;

/// Schema tag of `lvf.json`.
pub const LVF_SCHEMA: &str = "lumifit.lvf/1";

/// Polynomial degree of the position → wavelength map.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum MapKind {
    /// λ = c0 + c1·px.
    Linear,
    /// λ = c0 + c1·px + c2·px².
    Quadratic,
}

/// λ(px) = Σ coefficients[i]·pxⁱ with the coefficients' covariance.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct MapModel {
    /// Degree.
    pub kind: MapKind,
    /// Coefficients c0, c1[, c2] (nm, nm/px, nm/px²).
    pub coefficients: Vec<f64>,
    /// Covariance of the coefficients.
    pub covariance: Vec<Vec<f64>>,
}

impl MapModel {
    /// λ at `px`.
    pub fn eval(&self, px: f64) -> f64 {
        self.coefficients
            .iter()
            .rev()
            .fold(0.0, |acc, c| acc * px + c)
    }

    /// dλ/dpx at `px`.
    pub fn slope(&self, px: f64) -> f64 {
        self.coefficients
            .iter()
            .enumerate()
            .skip(1)
            .map(|(i, c)| i as f64 * c * px.powi(i as i32 - 1))
            .sum()
    }

    /// Standard uncertainty of λ(px) from the coefficients' covariance.
    pub fn sigma_at(&self, px: f64) -> f64 {
        let v: Vec<f64> = (0..self.coefficients.len())
            .map(|i| px.powi(i as i32))
            .collect();
        let mut s = 0.0;
        for (i, vi) in v.iter().enumerate() {
            for (j, vj) in v.iter().enumerate() {
                s += vi * self.covariance[i][j] * vj;
            }
        }
        s.max(0.0).sqrt()
    }

    /// Position where λ = `nm`, searched by Newton's method from the linear solution.
    pub fn inverse(&self, nm: f64) -> Option<f64> {
        let c = &self.coefficients;
        if c.len() < 2 || c[1] == 0.0 {
            return None;
        }
        let mut px = (nm - c[0]) / c[1];
        for _ in 0..50 {
            let d = self.slope(px);
            if d == 0.0 || !d.is_finite() {
                return None;
            }
            let step = (self.eval(px) - nm) / d;
            px -= step;
            if step.abs() < 1e-10 {
                break;
            }
        }
        (px.is_finite() && (self.eval(px) - nm).abs() < 1e-6).then_some(px)
    }
}

/// A lamp line as calibrated.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct LineReport {
    /// Line wavelength (nm).
    pub nm: f64,
    /// Position where the map puts it (px).
    pub px: f64,
    /// Map wavelength at the line's observed position minus the line's wavelength (nm): the
    /// shift of its group of unresolved lines, alone, that fits the profile best (for a blend
    /// of lines within half the FWHM, the move of its amplitude-weighted centroid, which a
    /// trade between the lines' amplitudes cannot fake); `None` (`null`) where the profile does
    /// not determine that shift.
    pub residual_nm: Option<f64>,
    /// Standard uncertainty of `residual_nm` (nm), when determined (whole-profile only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub residual_sigma_nm: Option<f64>,
    /// Fitted amplitude per camera channel (linear units); zeros for the peaks method.
    pub amplitude: [f64; 3],
}

fn in_roi_default() -> bool {
    true
}

/// One averaging band (written to and read from `lvf.json` by serde).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Band {
    /// Centre wavelength (nm).
    pub nm: f64,
    /// Centre along the axis (px, input image's pixels).
    pub px: f64,
    /// Width to average over (px): the band spacing in nm divided by |dλ/dpx|.
    pub width_px: f64,
    /// Whether the band centre lies inside the ROI (true when absent).
    #[serde(default = "in_roi_default")]
    pub in_roi: bool,
}

/// How the map degree was chosen.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct MapSelection {
    /// What was asked: `linear`, `quadratic` or `auto`.
    pub requested: String,
    /// F statistic of quadratic versus linear (auto only).
    pub f_statistic: Option<f64>,
    /// Quadratic coefficient over its standard error (auto only).
    pub quadratic_t: Option<f64>,
    /// Why the chosen degree won.
    pub reason: String,
}

/// Profile, model and residuals for plotting.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ProfileCurves {
    /// Positions (px).
    pub px: Vec<f64>,
    /// Measured profile per channel.
    pub data: [Vec<f64>; 3],
    /// Model per channel.
    pub model: [Vec<f64>; 3],
    /// The model without the lines: offset + fall-off × continuum, per channel (empty for
    /// peaks).
    pub background: [Vec<f64>; 3],
    /// The fall-off V at each position (empty for peaks).
    pub falloff: Vec<f64>,
    /// 1σ of ln V at each position from the radial estimate's covariance (the two-term κ's when
    /// divided out, κ₀ = 0 ± its σ alone when not); empty when there was no radial estimate.
    pub falloff_sigma: Vec<f64>,
}

/// One background model tried by the whole-profile fit.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct CandidateReport {
    /// Terms (`linear`, `falloff2`, `continuum6+falloff2`, …).
    pub model: String,
    /// BIC = N·ln(SSE/N) + k·ln N.
    pub bic: f64,
    /// BIC minus the chosen model's (negative for BIC's own choice when the focused criterion
    /// chose a finer knot spacing; see [`BackgroundReport::selection`]).
    pub delta_bic: f64,
    /// RMS of the profile residual (linear units).
    pub profile_rms: f64,
    /// This model's λ at the chosen map's 400 nm position (nm).
    pub nm_at_400_position: Option<f64>,
    /// This model's λ at the chosen map's 700 nm position (nm).
    pub nm_at_700_position: Option<f64>,
}

/// What the whole-profile fit put under and over the lines (see [`crate::lvf::background`]).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct BackgroundReport {
    /// Chosen terms.
    pub model: String,
    /// `bic` (chosen among candidates), `requested`, or — when the focused information criterion
    /// replaced BIC's knot spacing by a finer one of the same continuum family — a sentence
    /// starting `bic chose …` that names BIC's choice and gives both estimated mean squared errors
    /// of λ (then BIC's choice is among `candidates` with a negative `delta_bic`).
    pub selection: String,
    /// The flat-field photo divided out, if any (`null`: none; the fall-off is modelled).
    pub flat_field: Option<String>,
    /// Which fall-off multiplied lines and continuum: `flat-field FILE (…)`, `modelled: …` or
    /// `none`.
    pub falloff_source: String,
    /// The normalised position the coefficients refer to.
    pub u_definition: String,
    /// Centre of the profile (px).
    pub px_mid: f64,
    /// Half its length (px).
    pub half_length_px: f64,
    /// Offset b, s per channel (r, g, b) in y = b + s·u + ….
    pub offset: [[f64; 2]; 3],
    /// Intervals of the cubic B-spline continuum on u ∈ [−1, 1] (0: none).
    pub continuum_intervals: usize,
    /// Its coefficients (≥ 0) per channel; when `model` is `passband-continuumK`, those of the
    /// per-channel spectrum's spline in wavelength (K intervals, `continuum_intervals` 0; see
    /// [`crate::lvf::passband_continuum`]).
    pub continuum_coefficients: [Vec<f64>; 3],
    /// The continuum spectrum shared by the three channels through the camera (`null` unless
    /// that model was chosen; see [`crate::lvf::shared_continuum`]).
    pub shared_spectrum: Option<crate::lvf::shared_continuum::SharedSpectrumReport>,
    /// Largest height of offset + continuum above its own minimum over the profile's peak (0
    /// without a continuum; the spline's coefficients alone share a constant with the offset).
    pub continuum_peak_relative: f64,
    /// Degree J of the fall-off V(u) = 1 + Σ vⱼ uʲ (0: none).
    pub falloff_degree: usize,
    /// v₁ … v_J.
    pub falloff_coefficients: Vec<f64>,
    /// V(−1), V(1).
    pub falloff_at_ends: [f64; 2],
    /// The radial fall-off estimated across the axis (`null` when the ROI has no strips).
    pub radial_falloff: Option<crate::lvf::background::RadialFalloff>,
    /// Whether it was applied (significant at 3σ).
    pub radial_falloff_applied: bool,
    /// Every model tried, best first.
    pub candidates: Vec<CandidateReport>,
    /// Whether `sigma_nm_at_400/700` include the model-choice systematic.
    pub sigma_includes_systematic: bool,
    /// What the σ include, in words.
    pub systematic_note: String,
    /// Noise clipped at black, undone in the profile before the fit
    /// ([`crate::lvf::censored`]); absent when no pixel was clipped.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub black_clipping: Option<crate::lvf::censored::Censoring>,
}

/// A blob in the residual that no listed lamp line explains.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct UnexplainedLine {
    /// Where the map puts it (nm).
    pub nm: f64,
    /// Position (px).
    pub px: f64,
    /// Its amplitude over the profile's peak.
    pub amplitude_relative: f64,
    /// Its amplitude over its standard error (in the residual where it was found).
    pub significance: f64,
    /// Whether it was fitted as an extra line of free wavelength (so the map does not absorb
    /// it, [`crate::lvf::extra_lines`]) or only found in the final residual.
    pub fitted: bool,
}

/// An LVF calibration (`lvf.json`).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct LvfCalibration {
    /// Schema tag.
    pub schema: &'static str,
    /// `whole-profile` or `peaks`.
    pub method: String,
    /// The image calibrated.
    pub source: String,
    /// Filter axis.
    pub axis: Axis,
    /// ROI `[x, y, w, h]`, input image's pixels.
    pub roi: [usize; 4],
    /// The slant of the filter's iso-wavelength lines the profile was averaged along
    /// ([`crate::lvf::profile::Tilt`]); absent: along the rows (columns for axis y). The map
    /// holds at `reference_px` across the axis; a pixel at `b` sees `map(a + slope·(b − reference_px))`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tilt: Option<crate::lvf::profile::Tilt>,
    /// Lamp name.
    pub lamp: String,
    /// Position → wavelength map.
    pub map: MapModel,
    /// Fitted passband FWHM (nm); for peaks the assumed value.
    pub fwhm_nm: f64,
    /// Standard uncertainty of the FWHM (nm).
    pub fwhm_sigma_nm: f64,
    /// The passband's shape ([`crate::lvf::Passband::report`]); with `--passband gennorm` also
    /// `exponent_search`, the BIC of the fit at each exponent tried.
    pub passband: serde_json::Value,
    /// RMS of the line residuals (nm): each group of blended lines shifted alone, weighted by
    /// its squared amplitude (its weight in the map fit).
    pub rms_residual_nm: f64,
    /// RMS of the profile residual over the profile's peak (whole-profile only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rms_residual_relative: Option<f64>,
    /// Standard uncertainty of λ at the 400 nm position (nm): √(statistical² + systematic²).
    pub sigma_nm_at_400: f64,
    /// Standard uncertainty of λ at the 700 nm position (nm): √(statistical² + systematic²).
    pub sigma_nm_at_700: f64,
    /// Statistical part at 400 nm (from the covariance of the map).
    pub sigma_statistical_nm_at_400: f64,
    /// Statistical part at 700 nm.
    pub sigma_statistical_nm_at_700: f64,
    /// Systematic part at 400 nm (background model choice; 0 when not estimated).
    pub sigma_systematic_nm_at_400: f64,
    /// Systematic part at 700 nm.
    pub sigma_systematic_nm_at_700: f64,
    /// Lines inside the calibrated range.
    pub lines: Vec<LineReport>,
    /// Bands equidistant in wavelength from 400 to 700 nm.
    pub bands: Vec<Band>,
    /// How the map degree was chosen.
    pub map_selection: MapSelection,
    /// Whether λ increases with px.
    pub wavelength_increases_with_px: bool,
    /// Continuum and fall-off of the whole-profile fit (`null` for peaks).
    pub background: Option<BackgroundReport>,
    /// Blobs in the residual that no listed line explains.
    pub unexplained_lines: Vec<UnexplainedLine>,
    /// What a user must look at: physically doubtful or unexplained results (also printed).
    pub warnings: Vec<String>,
    /// Fit diagnostics: iterations, residual RMS of the profile, samples.
    pub diagnostics: serde_json::Value,
    /// Profile and model for plotting (not serialised).
    #[serde(skip)]
    pub curves: ProfileCurves,
}

impl LvfCalibration {
    /// Fills `bands`, `sigma_nm_at_400/700` from the map: `n` bands from 400 to 700 nm.
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] when `n` < 2 or the map cannot be inverted at a band.
    pub fn set_bands(&mut self, n: usize) -> Result<()> {
        if n < 2 {
            return Err(Error::invalid(
                "--bands",
                format!("{n}: expected at least 2"),
            ));
        }
        let spacing = 300.0 / (n - 1) as f64;
        let (lo, hi) = match self.axis {
            Axis::X => (
                self.roi[0] as f64 - 0.5,
                (self.roi[0] + self.roi[2]) as f64 - 0.5,
            ),
            Axis::Y => (
                self.roi[1] as f64 - 0.5,
                (self.roi[1] + self.roi[3]) as f64 - 0.5,
            ),
        };
        let mut bands = Vec::with_capacity(n);
        for k in 0..n {
            let nm = 400.0 + spacing * k as f64;
            let px = self.map.inverse(nm).ok_or_else(|| Error::Numerical {
                what: "LVF band positions".into(),
                reason: format!("the fitted map does not reach {nm} nm monotonically"),
            })?;
            let slope = self.map.slope(px).abs();
            bands.push(Band {
                nm,
                px,
                width_px: spacing / slope.max(1e-12),
                in_roi: px >= lo && px <= hi,
            });
        }
        self.sigma_statistical_nm_at_400 = self.map.sigma_at(bands[0].px);
        self.sigma_statistical_nm_at_700 = self.map.sigma_at(bands[n - 1].px);
        self.combine_sigma();
        self.bands = bands;
        Ok(())
    }

    /// `sigma_nm_at_400/700` = √(statistical² + systematic²) from the parts.
    pub fn combine_sigma(&mut self) {
        self.sigma_nm_at_400 = self
            .sigma_statistical_nm_at_400
            .hypot(self.sigma_systematic_nm_at_400);
        self.sigma_nm_at_700 = self
            .sigma_statistical_nm_at_700
            .hypot(self.sigma_systematic_nm_at_700);
    }
}
