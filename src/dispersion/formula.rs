//! The nine dispersion formulas of the refractiveindex.info database (Polyanskiy 2024,
//! "Dispersion formulas.pdf" of the database), λ in µm, coefficients C₁ … C₁₇ in file order
//! (`c[0]` is C₁):
//!
//! | type | name | formula |
//! |---|---|---|
//! | 1 | Sellmeier | n² − 1 = C₁ + Σᵢ C₂ᵢ λ² / (λ² − C₂ᵢ₊₁²) |
//! | 2 | Sellmeier-2 | n² − 1 = C₁ + Σᵢ C₂ᵢ λ² / (λ² − C₂ᵢ₊₁) |
//! | 3 | Polynomial | n² = C₁ + Σᵢ C₂ᵢ λ^C₂ᵢ₊₁ |
//! | 4 | RefractiveIndex.INFO | n² = C₁ + C₂ λ^C₃/(λ² − C₄^C₅) + C₆ λ^C₇/(λ² − C₈^C₉) + Σ_{i≥5} C₂ᵢ λ^C₂ᵢ₊₁ |
//! | 5 | Cauchy | n = C₁ + Σᵢ C₂ᵢ λ^C₂ᵢ₊₁ |
//! | 6 | Gases | n − 1 = C₁ + Σᵢ C₂ᵢ / (C₂ᵢ₊₁ − λ⁻²) |
//! | 7 | Herzberger | n = C₁ + C₂/(λ² − 0.028) + C₃/(λ² − 0.028)² + C₄ λ² + C₅ λ⁴ + C₆ λ⁶ |
//! | 8 | Retro | (n² − 1)/(n² + 2) = C₁ + C₂ λ²/(λ² − C₃) + C₄ λ² |
//! | 9 | Exotic | n² = C₁ + C₂/(λ² − C₃) + C₄ (λ − C₅) / ((λ − C₅)² + C₆) |
//!
//! Missing trailing coefficients are zero (as in the database). The independent numpy evaluation
//! is `scripts/reference/dispersion_reference.py`; `tests/dispersion_reference.rs` compares the two
//! to 1e-12.

use crate::error::{Error, Result};

/// The formula type (1–9).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FormulaKind {
    /// 1: n² − 1 = C₁ + Σ C₂ᵢ λ²/(λ² − C₂ᵢ₊₁²).
    Sellmeier,
    /// 2: n² − 1 = C₁ + Σ C₂ᵢ λ²/(λ² − C₂ᵢ₊₁).
    Sellmeier2,
    /// 3: n² = C₁ + Σ C₂ᵢ λ^C₂ᵢ₊₁.
    Polynomial,
    /// 4: the database's own two-pole form plus powers.
    RefractiveIndexInfo,
    /// 5: n = C₁ + Σ C₂ᵢ λ^C₂ᵢ₊₁.
    Cauchy,
    /// 6: n − 1 = C₁ + Σ C₂ᵢ/(C₂ᵢ₊₁ − λ⁻²).
    Gases,
    /// 7: Herzberger.
    Herzberger,
    /// 8: Lorentz–Lorenz ("retro").
    Retro,
    /// 9: "exotic".
    Exotic,
}

impl FormulaKind {
    /// From the number after `formula ` in the YAML `type` field.
    pub fn from_number(number: u32) -> Result<FormulaKind> {
        Ok(match number {
            1 => FormulaKind::Sellmeier,
            2 => FormulaKind::Sellmeier2,
            3 => FormulaKind::Polynomial,
            4 => FormulaKind::RefractiveIndexInfo,
            5 => FormulaKind::Cauchy,
            6 => FormulaKind::Gases,
            7 => FormulaKind::Herzberger,
            8 => FormulaKind::Retro,
            9 => FormulaKind::Exotic,
            _ => {
                return Err(Error::invalid(
                    "type",
                    format!("formula {number} is unknown; expected formula 1 to 9"),
                ))
            }
        })
    }

    /// The type number 1–9.
    pub fn number(self) -> u32 {
        match self {
            FormulaKind::Sellmeier => 1,
            FormulaKind::Sellmeier2 => 2,
            FormulaKind::Polynomial => 3,
            FormulaKind::RefractiveIndexInfo => 4,
            FormulaKind::Cauchy => 5,
            FormulaKind::Gases => 6,
            FormulaKind::Herzberger => 7,
            FormulaKind::Retro => 8,
            FormulaKind::Exotic => 9,
        }
    }

    /// Most coefficients the formula takes.
    pub fn max_coefficients(self) -> usize {
        match self {
            FormulaKind::Herzberger => 6,
            FormulaKind::Retro => 4,
            FormulaKind::Exotic => 6,
            _ => 17,
        }
    }
}

/// One formula with its coefficients and validity range.
#[derive(Debug, Clone, PartialEq)]
pub struct Formula {
    /// Which of the nine formulas.
    pub kind: FormulaKind,
    /// C₁, C₂, … in file order (λ in µm).
    pub coefficients: Vec<f64>,
    /// Validity range in µm, `[lo, hi]`.
    pub range_um: [f64; 2],
}

impl Formula {
    /// A formula, checking the coefficient count and the range.
    pub fn new(kind: FormulaKind, coefficients: Vec<f64>, range_um: [f64; 2]) -> Result<Formula> {
        if coefficients.is_empty() || coefficients.len() > kind.max_coefficients() {
            return Err(Error::invalid(
                "coefficients",
                format!(
                    "formula {} takes 1 to {} coefficients, got {}",
                    kind.number(),
                    kind.max_coefficients(),
                    coefficients.len()
                ),
            ));
        }
        if let Some(bad) = coefficients.iter().find(|c| !c.is_finite()) {
            return Err(Error::invalid(
                "coefficients",
                format!("{bad} is not a finite number"),
            ));
        }
        if !(range_um[0].is_finite() && range_um[1].is_finite() && 0.0 < range_um[0])
            || range_um[0] >= range_um[1]
        {
            return Err(Error::invalid(
                "wavelength_range",
                format!(
                    "{} {} µm; expected two increasing positive wavelengths",
                    range_um[0], range_um[1]
                ),
            ));
        }
        Ok(Formula {
            kind,
            coefficients,
            range_um,
        })
    }

    /// n at λ in µm (no range check; NaN where the formula has no real value).
    pub fn n_um(&self, l: f64) -> f64 {
        eval(self.kind, &self.coefficients, l)
    }
}

impl super::RefractiveIndex for Formula {
    fn n_at(&self, lambda_nm: f64) -> f64 {
        self.n_um(lambda_nm * 1e-3)
    }
}

/// Evaluates formula `kind` with coefficients `c` at λ = `l` µm.
pub fn eval(kind: FormulaKind, c: &[f64], l: f64) -> f64 {
    let k = |i: usize| c.get(i).copied().unwrap_or(0.0);
    let l2 = l * l;
    match kind {
        FormulaKind::Sellmeier | FormulaKind::Sellmeier2 => {
            let mut n2 = 1.0 + k(0);
            let mut i = 1;
            while i < c.len() {
                let pole = if kind == FormulaKind::Sellmeier {
                    k(i + 1) * k(i + 1)
                } else {
                    k(i + 1)
                };
                n2 += k(i) * l2 / (l2 - pole);
                i += 2;
            }
            n2.sqrt()
        }
        FormulaKind::Polynomial => {
            let mut n2 = k(0);
            let mut i = 1;
            while i < c.len() {
                n2 += k(i) * l.powf(k(i + 1));
                i += 2;
            }
            n2.sqrt()
        }
        FormulaKind::RefractiveIndexInfo => {
            let mut n2 = k(0);
            n2 += k(1) * l.powf(k(2)) / (l2 - k(3).powf(k(4)));
            n2 += k(5) * l.powf(k(6)) / (l2 - k(7).powf(k(8)));
            let mut i = 9;
            while i < c.len() {
                n2 += k(i) * l.powf(k(i + 1));
                i += 2;
            }
            n2.sqrt()
        }
        FormulaKind::Cauchy => {
            let mut n = k(0);
            let mut i = 1;
            while i < c.len() {
                n += k(i) * l.powf(k(i + 1));
                i += 2;
            }
            n
        }
        FormulaKind::Gases => {
            let mut n = 1.0 + k(0);
            let mut i = 1;
            while i < c.len() {
                n += k(i) / (k(i + 1) - 1.0 / l2);
                i += 2;
            }
            n
        }
        FormulaKind::Herzberger => {
            let q = 1.0 / (l2 - 0.028);
            k(0) + k(1) * q + k(2) * q * q + k(3) * l2 + k(4) * l2 * l2 + k(5) * l2 * l2 * l2
        }
        FormulaKind::Retro => {
            let r = k(0) + k(1) * l2 / (l2 - k(2)) + k(3) * l2;
            ((1.0 + 2.0 * r) / (1.0 - r)).sqrt()
        }
        FormulaKind::Exotic => {
            let d = l - k(4);
            (k(0) + k(1) / (l2 - k(2)) + k(3) * d / (d * d + k(5))).sqrt()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn schott_n_bk7_gives_its_catalogue_n_d() {
        let f = Formula::new(
            FormulaKind::Sellmeier2,
            vec![
                0.0,
                1.03961212,
                0.00600069867,
                0.231792344,
                0.0200179144,
                1.01046945,
                103.560653,
            ],
            [0.3, 2.5],
        )
        .unwrap();
        // catalogue n_d 1.5168 printed to 4 decimals
        assert!((f.n_um(0.5875618) - 1.5168).abs() < 0.5e-4);
    }

    #[test]
    fn sellmeier_1_squares_the_pole_and_2_does_not() {
        let c1 = [0.0, 0.5, 0.1];
        let c2 = [0.0, 0.5, 0.01];
        let a = eval(FormulaKind::Sellmeier, &c1, 0.6);
        let b = eval(FormulaKind::Sellmeier2, &c2, 0.6);
        assert!((a - b).abs() < 1e-15);
    }

    #[test]
    fn unknown_formula_number_is_refused() {
        assert!(FormulaKind::from_number(10).is_err());
        assert!(FormulaKind::from_number(0).is_err());
    }

    #[test]
    fn retro_inverts_lorentz_lorenz() {
        // (n²−1)/(n²+2) = 0.3 for a constant-only formula
        let n = eval(FormulaKind::Retro, &[0.3], 0.5);
        assert!(((n * n - 1.0) / (n * n + 2.0) - 0.3).abs() < 1e-15);
    }
}
