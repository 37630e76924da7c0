//! The models lumifit fits and writes into presets (λ in µm):
//!
//! - **Cauchy** with k terms: n(λ) = Σ_{i<k} cᵢ λ⁻²ⁱ = A + B/λ² + C/λ⁴ … (Blanchette 2012 §4.1,
//!   Eq. 2; coefficients `[A, B, C]`, B in µm², C in µm⁴).
//! - **Sellmeier** with k terms: n(λ)² = 1 + Σ_{i<k} Bᵢ λ²/(λ² − Cᵢ) (refractiveindex.info
//!   "formula 2" without constant; coefficients `[B₁, C₁, B₂, C₂, …]`, Cᵢ in µm²).
//!
//! The preset's `model.kind` is `"cauchy"` or `"sellmeier"`, its `coefficients` these lists.

use crate::error::{Error, Result};

/// A fitted model family and its number of terms.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ModelKind {
    /// n = A + B/λ².
    Cauchy2,
    /// n = A + B/λ² + C/λ⁴.
    Cauchy3,
    /// n² = 1 + B₁λ²/(λ² − C₁).
    Sellmeier1,
    /// Two Sellmeier terms.
    Sellmeier2,
    /// Three Sellmeier terms (the form of the Schott catalogue).
    Sellmeier3,
}

impl ModelKind {
    /// Every kind, smallest first (by number of parameters, then Cauchy before Sellmeier).
    pub const ALL: [ModelKind; 5] = [
        ModelKind::Cauchy2,
        ModelKind::Sellmeier1,
        ModelKind::Cauchy3,
        ModelKind::Sellmeier2,
        ModelKind::Sellmeier3,
    ];

    /// The CLI name: `cauchy2`, `cauchy3`, `sellmeier1`, `sellmeier2`, `sellmeier3`.
    pub fn key(self) -> &'static str {
        match self {
            ModelKind::Cauchy2 => "cauchy2",
            ModelKind::Cauchy3 => "cauchy3",
            ModelKind::Sellmeier1 => "sellmeier1",
            ModelKind::Sellmeier2 => "sellmeier2",
            ModelKind::Sellmeier3 => "sellmeier3",
        }
    }

    /// Parses a CLI name.
    pub fn from_name(name: &str) -> Result<ModelKind> {
        ModelKind::ALL
            .into_iter()
            .find(|k| k.key() == name.trim().to_ascii_lowercase())
            .ok_or_else(|| Error::UnknownName {
                kind: "dispersion model",
                name: name.to_string(),
                expected: "auto, cauchy2, cauchy3, sellmeier1, sellmeier2, sellmeier3".into(),
            })
    }

    /// Number of fitted parameters.
    pub fn n_params(self) -> usize {
        match self {
            ModelKind::Cauchy2 | ModelKind::Sellmeier1 => 2,
            ModelKind::Cauchy3 => 3,
            ModelKind::Sellmeier2 => 4,
            ModelKind::Sellmeier3 => 6,
        }
    }

    /// Number of Sellmeier terms (0 for Cauchy).
    pub fn sellmeier_terms(self) -> usize {
        match self {
            ModelKind::Sellmeier1 => 1,
            ModelKind::Sellmeier2 => 2,
            ModelKind::Sellmeier3 => 3,
            _ => 0,
        }
    }
}

/// A model with its coefficients (λ in µm).
#[derive(Debug, Clone, PartialEq)]
pub enum Model {
    /// n = Σ cᵢ λ⁻²ⁱ; `[A, B, C, …]`.
    Cauchy(Vec<f64>),
    /// n² = 1 + Σ Bᵢ λ²/(λ² − Cᵢ); `[B₁, C₁, B₂, C₂, …]`, Cᵢ in µm².
    Sellmeier(Vec<f64>),
}

impl Model {
    /// The preset's `model.kind`.
    pub fn family(&self) -> &'static str {
        match self {
            Model::Cauchy(_) => "cauchy",
            Model::Sellmeier(_) => "sellmeier",
        }
    }

    /// The coefficients as written into a preset.
    pub fn coefficients(&self) -> &[f64] {
        match self {
            Model::Cauchy(c) | Model::Sellmeier(c) => c,
        }
    }

    /// A model from a preset's `kind` and `coefficients`, checked.
    pub fn from_parts(kind: &str, coefficients: Vec<f64>) -> Result<Model> {
        if coefficients.is_empty() || coefficients.iter().any(|c| !c.is_finite()) {
            return Err(Error::invalid(
                "dispersion.model.coefficients",
                "expected at least one finite coefficient",
            ));
        }
        match kind {
            "cauchy" => Ok(Model::Cauchy(coefficients)),
            "sellmeier" if coefficients.len() % 2 == 0 => Ok(Model::Sellmeier(coefficients)),
            "sellmeier" => Err(Error::invalid(
                "dispersion.model.coefficients",
                format!(
                    "a Sellmeier model takes pairs [B1, C1, B2, C2, …], got {} numbers",
                    coefficients.len()
                ),
            )),
            other => Err(Error::UnknownName {
                kind: "dispersion.model.kind",
                name: other.to_string(),
                expected: "cauchy, sellmeier".into(),
            }),
        }
    }

    /// n at λ in µm.
    pub fn n_um(&self, l: f64) -> f64 {
        let l2 = l * l;
        match self {
            Model::Cauchy(c) => {
                let inv = 1.0 / l2;
                // Horner in λ⁻²
                c.iter().rev().fold(0.0, |acc, ci| acc * inv + ci)
            }
            Model::Sellmeier(c) => {
                let n2 = 1.0
                    + c.chunks_exact(2)
                        .map(|bc| bc[0] * l2 / (l2 - bc[1]))
                        .sum::<f64>();
                n2.sqrt()
            }
        }
    }
}

impl super::RefractiveIndex for Model {
    fn n_at(&self, lambda_nm: f64) -> f64 {
        self.n_um(lambda_nm * 1e-3)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cauchy_horner_matches_the_sum() {
        let m = Model::Cauchy(vec![1.5, 0.004, 1e-4]);
        let l: f64 = 0.55;
        let direct = 1.5 + 0.004 / l.powi(2) + 1e-4 / l.powi(4);
        assert!((m.n_um(l) - direct).abs() < 1e-15);
    }

    #[test]
    fn kinds_are_ordered_by_parameter_count() {
        let p: Vec<usize> = ModelKind::ALL.iter().map(|k| k.n_params()).collect();
        assert!(p.windows(2).all(|w| w[0] <= w[1]));
        assert_eq!(
            ModelKind::from_name("Sellmeier2").unwrap(),
            ModelKind::Sellmeier2
        );
        assert!(ModelKind::from_name("conrady").is_err());
    }
}
