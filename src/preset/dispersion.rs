//! The `dispersion` section of a material preset: a contract other tools read.
//!
//! ```json
//! "dispersion": {
//!   "model": {"kind": "sellmeier", "coefficients": [B1, C1, …], "wavelength_unit": "um"},
//!   "range_nm": [380, 780], "n_d": 1.5168, "abbe_number": 64.17,
//!   "rms_residual": 1e-7, "max_abs_residual": 4e-7,
//!   "samples": [{"lambda_nm": 408.6, "n": 1.531, "rgb": [r, g, b]}, …],
//!   "working_space": "srgb"
//! }
//! ```
//!
//! `model.kind` is `"cauchy"` (n = Σ cᵢ λ⁻²ⁱ) or `"sellmeier"` (n² = 1 + Σ Bᵢ λ²/(λ² − Cᵢ), Cᵢ in
//! µm²), λ in µm ([`crate::dispersion::model`]). The sample weights are linear RGB of
//! `working_space` and sum to its white (1, 1, 1). Further fields (derived numbers, every fitted
//! candidate, the illuminant and observer of the samples) are kept in `extra`.

use serde::{Deserialize, Serialize};

use super::types::OpenSection;
use crate::dispersion::model::Model;
use crate::error::Result;

/// The model of a dispersion section.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DispersionModel {
    /// `"cauchy"` or `"sellmeier"`.
    pub kind: String,
    /// Coefficients in the kind's order (λ in µm).
    pub coefficients: Vec<f64>,
    /// Always `"um"`.
    pub wavelength_unit: String,
}

/// One wavelength sample for an RGB renderer.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DispersionSample {
    /// Wavelength in nm.
    pub lambda_nm: f64,
    /// Refractive index of the model at that wavelength.
    pub n: f64,
    /// Linear RGB weight in the working space (≥ 0).
    pub rgb: [f64; 3],
}

/// The `dispersion` section.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DispersionSection {
    /// The fitted model.
    pub model: DispersionModel,
    /// The range the model was fitted over, nm.
    pub range_nm: [f64; 2],
    /// n at the d line (587.5618 nm).
    pub n_d: f64,
    /// Abbe number V_d.
    pub abbe_number: f64,
    /// RMS of model − data over the range.
    pub rms_residual: f64,
    /// max |model − data| over the range.
    pub max_abs_residual: f64,
    /// Wavelength samples whose weights sum to the working space's white.
    pub samples: Vec<DispersionSample>,
    /// The RGB working space of the weights (`srgb`, `acescg`).
    pub working_space: String,
    /// Further fields, kept as read.
    #[serde(flatten)]
    pub extra: OpenSection,
}

impl DispersionSection {
    /// The model as the dispersion domain evaluates it.
    pub fn to_model(&self) -> Result<Model> {
        Model::from_parts(&self.model.kind, self.model.coefficients.clone())
    }
}

/// Checks JSON Schema cannot express, each as `(pointer, message)`.
pub(super) fn check(section: &DispersionSection) -> Vec<(String, String)> {
    let mut out = Vec::new();
    if let Err(e) = section.to_model() {
        out.push(("/dispersion/model".to_string(), e.to_string()));
    }
    if section.range_nm[0] >= section.range_nm[1] {
        out.push((
            "/dispersion/range_nm".to_string(),
            format!(
                "[{}, {}]; expected lo < hi",
                section.range_nm[0], section.range_nm[1]
            ),
        ));
    }
    for w in section.samples.windows(2) {
        if w[1].lambda_nm <= w[0].lambda_nm {
            out.push((
                "/dispersion/samples".to_string(),
                "lambda_nm must be strictly increasing".to_string(),
            ));
            break;
        }
    }
    if !section.samples.is_empty() {
        for c in 0..3 {
            let total: f64 = section.samples.iter().map(|s| s.rgb[c]).sum();
            if (total - 1.0).abs() > 1e-9 {
                out.push((
                    "/dispersion/samples".to_string(),
                    format!(
                        "the {} weights sum to {total}; expected 1 (the working space's white)",
                        ["red", "green", "blue"][c]
                    ),
                ));
            }
        }
    }
    out
}

/// What `lumifit dispersion fit` asks for.
#[derive(Debug, Clone)]
pub struct FitConfig<'a> {
    /// Candidate models (all of [`crate::dispersion::ModelKind::ALL`] for `--model auto`).
    pub kinds: Vec<crate::dispersion::ModelKind>,
    /// Requested range in nm.
    pub range_nm: [f64; 2],
    /// Tolerance on max |Δn|.
    pub tolerance: f64,
    /// Number of wavelength samples.
    pub n_samples: usize,
    /// Air ↔ vacuum conversion of the source.
    pub conversion: crate::dispersion::AirVacuum,
    /// Observer of the sample colours.
    pub observer: &'a crate::colorimetry::Observer,
    /// Illuminant whose white the samples sum to.
    pub illuminant: &'a crate::colorimetry::Illuminant,
    /// Working space of the weights.
    pub space: &'a crate::colorimetry::rgb::RgbSpace,
    /// Name of the source in errors and in the section (`source`).
    pub source_name: &'a str,
}

/// The fitted section and the full fit report.
#[derive(Debug, Clone)]
pub struct FittedDispersion {
    /// The preset section.
    pub section: DispersionSection,
    /// Every candidate and the choice.
    pub report: crate::dispersion::FitReport,
    /// Derived numbers of the chosen model.
    pub derived: crate::dispersion::DerivedNumbers,
    /// Standard deviation of V_d from the fit (measured data only).
    pub abbe_number_std: Option<f64>,
}

/// Fits `source` as `cfg` says and builds the preset section: observations over the range,
/// every candidate model, the automatic choice, derived numbers of the chosen model, and the
/// wavelength samples (weights from the observer, illuminant and working space; n from the model).
pub fn fit_section(
    source: &crate::dispersion::Source,
    cfg: &FitConfig<'_>,
) -> Result<FittedDispersion> {
    use crate::dispersion::{blanchette2012, derived, fit, source as src, RefractiveIndex};
    let (obs, covered) = src::observations(source, cfg.range_nm, cfg.conversion, cfg.source_name)?;
    let report = fit::fit_auto(&obs, &cfg.kinds, cfg.tolerance, covered)?;
    let best = report.best();
    let mut d = derived::derived_numbers(&best.model, covered)?;
    // For a formula source the glTF curve's error is taken against the source itself (the full
    // model), and the source's own derived numbers are kept beside the fitted model's.
    let mut source_numbers = None;
    if let crate::dispersion::Source::Formula(f) = source {
        let full = src::Converted {
            formula: f,
            conversion: cfg.conversion,
        };
        let cauchy = crate::dispersion::Model::Cauchy(vec![d.gltf_cauchy.a, d.gltf_cauchy.b_um2]);
        let (rms, max) = derived::model_difference(&cauchy, &full, covered);
        d.gltf_cauchy.rms_error = rms;
        d.gltf_cauchy.max_abs_error = max;
        source_numbers = Some(derived::derived_numbers(&full, covered)?);
    }
    let vd_std = best
        .covariance
        .as_ref()
        .and_then(|c| derived::abbe_number_std(&best.model, c));
    let range_int = [covered[0].ceil(), covered[1].floor()];
    let slices = blanchette2012::slices_for(cfg.observer, cfg.illuminant, cfg.space, range_int)?;
    let set = blanchette2012::wavelength_samples(&slices, cfg.n_samples)?;
    let samples: Vec<DispersionSample> = set
        .samples
        .iter()
        .map(|s| DispersionSample {
            lambda_nm: s.lambda_nm,
            n: best.model.n_at(s.lambda_nm),
            rgb: s.rgb,
        })
        .collect();
    let mut values: Vec<f64> = samples.iter().map(|s| s.n).collect();
    values.extend_from_slice(best.model.coefficients());
    values.extend_from_slice(&[
        d.n_d,
        d.abbe_number_d,
        best.rms_residual,
        best.max_abs_residual,
    ]);
    crate::error::ensure_finite("dispersion fit", cfg.source_name, &values)?;
    let mut extra = OpenSection::new();
    let candidates: Vec<serde_json::Value> = report
        .candidates
        .iter()
        .map(|c| {
            serde_json::json!({
                "model": c.kind.key(),
                "kind": c.model.family(),
                "coefficients": if c.valid { serde_json::json!(c.model.coefficients()) } else { serde_json::Value::Null },
                "rms_residual": if c.valid { serde_json::json!(c.rms_residual) } else { serde_json::Value::Null },
                "max_abs_residual": if c.valid { serde_json::json!(c.max_abs_residual) } else { serde_json::Value::Null },
                "termination": c.termination,
                "valid": c.valid,
                "note": c.note,
            })
        })
        .collect();
    let json = |v: serde_json::Result<serde_json::Value>| v.unwrap_or(serde_json::Value::Null);
    extra.insert("derived".into(), json(serde_json::to_value(&d)));
    extra.insert(
        "gltf_cauchy_error_against".into(),
        serde_json::json!(if source_numbers.is_some() {
            "source formula"
        } else {
            "fitted model"
        }),
    );
    if let Some(sn) = &source_numbers {
        extra.insert("derived_source".into(), json(serde_json::to_value(sn)));
    }
    if let Some(s) = vd_std {
        extra.insert("abbe_number_std".into(), serde_json::json!(s));
    }
    extra.insert("chosen_model".into(), serde_json::json!(best.kind.key()));
    extra.insert("tolerance".into(), serde_json::json!(report.tolerance));
    extra.insert(
        "tolerance_met".into(),
        serde_json::json!(report.tolerance_met),
    );
    extra.insert("candidates".into(), serde_json::Value::Array(candidates));
    extra.insert(
        "n_observations".into(),
        serde_json::json!(report.n_observations),
    );
    extra.insert("source".into(), serde_json::json!(cfg.source_name));
    extra.insert("air_vacuum".into(), serde_json::json!(cfg.conversion.key()));
    extra.insert(
        "illuminant".into(),
        serde_json::json!(cfg.illuminant.name()),
    );
    extra.insert("observer".into(), serde_json::json!(cfg.observer.name()));
    extra.insert(
        "samples_rule".into(),
        serde_json::json!("blanchette2012: equal intervals, interval colours, neutral added to out-of-gamut bands, common scale"),
    );
    let section = DispersionSection {
        model: DispersionModel {
            kind: best.model.family().to_string(),
            coefficients: best.model.coefficients().to_vec(),
            wavelength_unit: "um".into(),
        },
        range_nm: covered,
        n_d: d.n_d,
        abbe_number: d.abbe_number_d,
        rms_residual: best.rms_residual,
        max_abs_residual: best.max_abs_residual,
        samples,
        working_space: cfg.space.key.clone(),
        extra,
    };
    Ok(FittedDispersion {
        section,
        report,
        derived: d,
        abbe_number_std: vd_std,
    })
}
