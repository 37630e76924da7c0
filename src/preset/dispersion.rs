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
