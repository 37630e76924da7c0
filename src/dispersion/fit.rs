//! Least-squares fits of the [`Model`]s to n(λ) observations over a wavelength range, and the
//! automatic choice of the smallest model that meets a tolerance.
//!
//! - **Cauchy** (linear in its coefficients): weighted linear least squares, min Σ wᵢ (nᵢ − Σⱼ cⱼ
//!   λᵢ⁻²ʲ)², solved by QR ([`crate::fit::Qr`]).
//! - **Sellmeier** (linear in Bᵢ given the poles Cᵢ): variable projection
//!   ([`crate::fit::solve_separable`], Levenberg–Marquardt on the poles with the Bᵢ solved
//!   exactly at every step, once with Bᵢ ≥ 0 by NNLS and once unbounded, because a term that
//!   touches the bound Bᵢ = 0 has a zero gradient and its pole is stuck) on y = n² − 1 with row weights 1/(2nσ), so that the weighted
//!   residual is the first-order Δn (d(n²) = 2n dn). Several pole starts are tried (ultraviolet
//!   poles near 0.005–0.05 µm², an infrared pole near 100 µm² for three terms); the best
//!   converged one is kept. A fit with a pole ≤ 0 or inside the fitted range is rejected.
//!
//! The RMS and max |Δn| of every candidate are computed on n itself at the observations (for a
//! formula source, a 1 nm grid over the range, so they are the model error over the range).
//!
//! **Automatic choice** ([`fit_auto`]): candidates in [`ModelKind::ALL`] order (fewest parameters
//! first); the first valid one whose max |Δn| ≤ tolerance is chosen. When none meets the
//! tolerance (measured or rounded data whose scatter exceeds it), the valid candidate with the
//! lowest BIC is chosen and `tolerance_met` is false, so the report says so.

use super::model::{Model, ModelKind};
use super::RefractiveIndex;
use crate::error::{Error, Result};
use crate::fit::varpro::{solve_separable, SeparableData, SeparableModel, SolverOptions};
use crate::fit::{bic, covariance, Qr};

/// n(λ) observations: strictly increasing wavelengths, optional standard deviations.
#[derive(Debug, Clone, PartialEq)]
pub struct Observations {
    /// Wavelengths in nm, strictly increasing.
    pub lambda_nm: Vec<f64>,
    /// Refractive index at each wavelength.
    pub n: Vec<f64>,
    /// Standard deviation of each n (weights 1/σ²); `None` for unit weights.
    pub std: Option<Vec<f64>>,
    /// True when the values are measurements (tabulated or CSV), false when they are samples of
    /// an exact formula; parameter and V_d uncertainties are reported only for measurements.
    pub measured: bool,
}

impl Observations {
    /// Checks lengths, finiteness, monotonic wavelengths, n ≥ 1 and σ > 0 (`source` names them).
    pub fn new(
        lambda_nm: Vec<f64>,
        n: Vec<f64>,
        std: Option<Vec<f64>>,
        measured: bool,
        source: &str,
    ) -> Result<Observations> {
        if lambda_nm.len() != n.len() || std.as_ref().is_some_and(|s| s.len() != n.len()) {
            return Err(Error::ShapeMismatch {
                what: format!("{source}: wavelength, n and std columns"),
                expected: lambda_nm.len(),
                got: n.len(),
            });
        }
        for i in 0..n.len() {
            if !(lambda_nm[i].is_finite() && lambda_nm[i] > 0.0) {
                return Err(Error::invalid(
                    format!("{source}: wavelength #{}", i + 1),
                    format!("{}; expected a positive wavelength", lambda_nm[i]),
                ));
            }
            if i > 0 && lambda_nm[i] <= lambda_nm[i - 1] {
                return Err(Error::invalid(
                    format!("{source}: wavelength #{}", i + 1),
                    format!(
                        "{} nm after {} nm; expected strictly increasing wavelengths",
                        lambda_nm[i],
                        lambda_nm[i - 1]
                    ),
                ));
            }
            if !(n[i].is_finite() && n[i] >= 1.0) {
                return Err(Error::invalid(
                    format!("{source}: n at {} nm", lambda_nm[i]),
                    format!("{}; expected a refractive index ≥ 1", n[i]),
                ));
            }
            if let Some(s) = &std {
                if !(s[i].is_finite() && s[i] > 0.0) {
                    return Err(Error::invalid(
                        format!("{source}: std at {} nm", lambda_nm[i]),
                        format!("{}; expected a positive standard deviation", s[i]),
                    ));
                }
            }
        }
        Ok(Observations {
            lambda_nm,
            n,
            std,
            measured,
        })
    }

    /// The observations inside `[lo, hi]` nm.
    pub fn within(&self, range_nm: [f64; 2]) -> Observations {
        let keep: Vec<usize> = (0..self.n.len())
            .filter(|&i| self.lambda_nm[i] >= range_nm[0] && self.lambda_nm[i] <= range_nm[1])
            .collect();
        Observations {
            lambda_nm: keep.iter().map(|&i| self.lambda_nm[i]).collect(),
            n: keep.iter().map(|&i| self.n[i]).collect(),
            std: self
                .std
                .as_ref()
                .map(|s| keep.iter().map(|&i| s[i]).collect()),
            measured: self.measured,
        }
    }

    /// Number of observations.
    pub fn len(&self) -> usize {
        self.n.len()
    }

    /// True when there is no observation.
    pub fn is_empty(&self) -> bool {
        self.n.is_empty()
    }

    fn sqrt_w(&self, i: usize) -> f64 {
        self.std.as_ref().map_or(1.0, |s| 1.0 / s[i])
    }
}

/// One fitted candidate.
#[derive(Debug, Clone, PartialEq)]
pub struct Candidate {
    /// The model family and size.
    pub kind: ModelKind,
    /// The fitted model.
    pub model: Model,
    /// RMS of n_model − n over the observations.
    pub rms_residual: f64,
    /// max |n_model − n| over the observations.
    pub max_abs_residual: f64,
    /// Bayesian information criterion of the weighted residuals.
    pub bic: f64,
    /// Why the solver stopped (`"linear"` for the Cauchy solve).
    pub termination: String,
    /// Usable: solved, finite, poles outside the range.
    pub valid: bool,
    /// Why a candidate is not valid (empty when valid).
    pub note: String,
    /// Parameter covariance (p × p, column-major), for measured data only.
    pub covariance: Option<Vec<f64>>,
}

/// All candidates and the chosen one.
#[derive(Debug, Clone, PartialEq)]
pub struct FitReport {
    /// Every candidate, in the order tried.
    pub candidates: Vec<Candidate>,
    /// Index of the chosen candidate.
    pub chosen: usize,
    /// The tolerance on max |Δn|.
    pub tolerance: f64,
    /// Whether the chosen candidate meets it.
    pub tolerance_met: bool,
    /// The fitted range in nm.
    pub range_nm: [f64; 2],
    /// Number of observations used.
    pub n_observations: usize,
}

impl FitReport {
    /// The chosen candidate.
    pub fn best(&self) -> &Candidate {
        &self.candidates[self.chosen]
    }
}

/// Fits one model kind to the observations (already restricted to the range).
pub fn fit_model(obs: &Observations, kind: ModelKind) -> Result<Candidate> {
    let p = kind.n_params();
    if obs.len() < p + 1 {
        return Err(Error::invalid(
            "observations",
            format!(
                "{} points in the range; {} needs at least {}",
                obs.len(),
                kind.key(),
                p + 1
            ),
        ));
    }
    let (model, termination) = match kind {
        ModelKind::Cauchy2 | ModelKind::Cauchy3 => (fit_cauchy(obs, p)?, "linear".to_string()),
        _ => fit_sellmeier(obs, kind.sellmeier_terms()),
    };
    Ok(assess(obs, kind, model, termination))
}

/// Fits every kind in `kinds` and chooses as the module docs say.
pub fn fit_auto(
    obs: &Observations,
    kinds: &[ModelKind],
    tolerance: f64,
    range_nm: [f64; 2],
) -> Result<FitReport> {
    if !(tolerance.is_finite() && tolerance > 0.0) {
        return Err(Error::invalid(
            "--tolerance",
            format!("{tolerance}; expected a positive Δn such as 1e-4"),
        ));
    }
    let mut candidates = Vec::new();
    for &k in kinds {
        candidates.push(fit_model(obs, k)?);
    }
    let meets = |c: &Candidate| c.valid && c.max_abs_residual <= tolerance;
    let chosen = match candidates.iter().position(meets) {
        Some(i) => i,
        None => candidates
            .iter()
            .enumerate()
            .filter(|(_, c)| c.valid)
            .min_by(|a, b| a.1.bic.total_cmp(&b.1.bic))
            .map(|(i, _)| i)
            .ok_or_else(|| Error::Numerical {
                what: "dispersion fit".into(),
                reason: "no candidate model could be fitted".into(),
            })?,
    };
    let tolerance_met = meets(&candidates[chosen]);
    Ok(FitReport {
        candidates,
        chosen,
        tolerance,
        tolerance_met,
        range_nm,
        n_observations: obs.len(),
    })
}

fn fit_cauchy(obs: &Observations, k: usize) -> Result<Model> {
    let m = obs.len();
    let mut a = vec![0.0; m * k];
    let mut b = vec![0.0; m];
    for i in 0..m {
        let l = obs.lambda_nm[i] * 1e-3;
        let inv = 1.0 / (l * l);
        let w = obs.sqrt_w(i);
        let mut pw = 1.0;
        for j in 0..k {
            a[j * m + i] = w * pw;
            pw *= inv;
        }
        b[i] = w * obs.n[i];
    }
    let qr = Qr::new(&a, m, k);
    if !qr.full_rank() {
        return Err(Error::Numerical {
            what: "Cauchy fit".into(),
            reason: "the design matrix is rank deficient (too few distinct wavelengths)".into(),
        });
    }
    qr.qt_mul(&mut b);
    let mut x = vec![0.0; k];
    qr.solve_r(&b, &mut x);
    Ok(Model::Cauchy(x))
}

/// Sellmeier basis φᵢ(λ) = λ²/(λ² − Cᵢ), one pole parameter per column.
struct SellmeierBasis {
    l2: Vec<f64>,
    terms: usize,
    free: bool,
}

impl SeparableModel for SellmeierBasis {
    fn n_rows(&self) -> usize {
        self.l2.len()
    }
    fn n_params(&self) -> usize {
        self.terms
    }
    fn n_cols(&self) -> usize {
        self.terms
    }
    fn column_param(&self, col: usize) -> Option<usize> {
        Some(col)
    }
    fn column_free(&self, _col: usize) -> bool {
        self.free
    }
    fn eval(&self, theta: &[f64], basis: &mut [f64], dbasis: &mut [f64]) {
        let m = self.l2.len();
        for (j, &c) in theta.iter().enumerate() {
            for (i, &l2) in self.l2.iter().enumerate() {
                let d = l2 - c;
                basis[j * m + i] = l2 / d;
                dbasis[j * m + i] = l2 / (d * d);
            }
        }
    }
}

fn pole_starts(terms: usize) -> Vec<Vec<f64>> {
    match terms {
        1 => vec![vec![0.005], vec![0.01], vec![0.02], vec![0.04]],
        2 => vec![
            vec![0.005, 0.03],
            vec![0.01, 0.05],
            vec![0.01, 100.0],
            vec![0.003, 0.02],
        ],
        _ => vec![
            vec![0.006, 0.02, 100.0],
            vec![0.004, 0.015, 50.0],
            vec![0.01, 0.05, 120.0],
            vec![0.003, 0.03, 10.0],
        ],
    }
}

fn fit_sellmeier(obs: &Observations, terms: usize) -> (Model, String) {
    let m = obs.len();
    let l2: Vec<f64> = obs.lambda_nm.iter().map(|l| (l * 1e-3).powi(2)).collect();
    let y: Vec<f64> = obs.n.iter().map(|n| n * n - 1.0).collect();
    let sqrt_w: Vec<f64> = (0..m).map(|i| obs.sqrt_w(i) / (2.0 * obs.n[i])).collect();
    let bounded = SellmeierBasis {
        l2,
        terms,
        free: false,
    };
    let free = SellmeierBasis {
        l2: bounded.l2.clone(),
        terms,
        free: true,
    };
    let data = SeparableData {
        y: &y,
        n_rhs: 1,
        sqrt_w: Some(&sqrt_w),
    };
    let opts = SolverOptions {
        max_iter: 500,
        ftol: 1e-15,
        xtol: 1e-13,
        gtol: 1e-13,
    };
    let (lo2, hi2) = (bounded.l2[0], bounded.l2[m - 1]);
    let mut best: Option<(f64, Model, String)> = None;
    let starts = pole_starts(terms);
    for (basis, start) in [&bounded, &free]
        .into_iter()
        .flat_map(|b| starts.iter().map(move |s| (b, s)))
    {
        let fit = solve_separable(basis, data, start, &opts);
        // poles are squared resonance wavelengths: positive, and outside the fitted range
        let poles_outside = fit.theta.iter().all(|&c| c > 0.0 && (c < lo2 || c > hi2));
        if !fit.rss.is_finite() || !poles_outside {
            continue;
        }
        let mut coeffs = Vec::with_capacity(2 * terms);
        for j in 0..terms {
            coeffs.push(fit.coeffs[j]);
            coeffs.push(fit.theta[j]);
        }
        let better = best.as_ref().is_none_or(|b| fit.rss < b.0);
        if better {
            best = Some((
                fit.rss,
                Model::Sellmeier(coeffs),
                format!("{:?}", fit.termination),
            ));
        }
    }
    match best {
        Some((_, model, term)) => (model, term),
        None => (
            Model::Sellmeier(vec![f64::NAN; 2 * terms]),
            "no start converged with poles outside the range".into(),
        ),
    }
}

fn assess(obs: &Observations, kind: ModelKind, model: Model, termination: String) -> Candidate {
    let m = obs.len();
    let mut ss = 0.0;
    let mut wss = 0.0;
    let mut max_abs: f64 = 0.0;
    let mut finite = true;
    for i in 0..m {
        let r = model.n_at(obs.lambda_nm[i]) - obs.n[i];
        if !r.is_finite() {
            finite = false;
        }
        ss += r * r;
        let w = obs.sqrt_w(i);
        wss += (w * r) * (w * r);
        max_abs = max_abs.max(r.abs());
    }
    let mut note = String::new();
    if !finite {
        note = termination.clone();
    }
    let valid = finite && note.is_empty();
    let p = kind.n_params();
    let cov = if obs.measured && valid {
        parameter_covariance(obs, &model, wss)
    } else {
        None
    };
    Candidate {
        kind,
        model,
        rms_residual: if finite {
            (ss / m as f64).sqrt()
        } else {
            f64::NAN
        },
        max_abs_residual: if finite { max_abs } else { f64::NAN },
        bic: if finite {
            bic(wss, m, p)
        } else {
            f64::INFINITY
        },
        termination,
        valid,
        note,
        covariance: cov,
    }
}

/// Covariance s²(JᵀWJ)⁻¹ of the model coefficients with s² = weighted RSS/(m − p), J = ∂n/∂θ by
/// central differences (analytic enough for the smooth models here).
fn parameter_covariance(obs: &Observations, model: &Model, wss: f64) -> Option<Vec<f64>> {
    let theta = model.coefficients().to_vec();
    let p = theta.len();
    let m = obs.len();
    let mut jac = vec![0.0; m * p];
    for j in 0..p {
        let h = 1e-6 * theta[j].abs().max(1e-8);
        let mut up = theta.clone();
        let mut dn = theta.clone();
        up[j] += h;
        dn[j] -= h;
        let (mu, md) = (rebuild(model, up), rebuild(model, dn));
        for i in 0..m {
            let d = (mu.n_at(obs.lambda_nm[i]) - md.n_at(obs.lambda_nm[i])) / (2.0 * h);
            jac[j * m + i] = obs.sqrt_w(i) * d;
        }
    }
    covariance(&jac, m, p, wss)
}

/// The same family with other coefficients.
pub fn rebuild(model: &Model, coefficients: Vec<f64>) -> Model {
    match model {
        Model::Cauchy(_) => Model::Cauchy(coefficients),
        Model::Sellmeier(_) => Model::Sellmeier(coefficients),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bk7(l_nm: f64) -> f64 {
        let l2 = (l_nm * 1e-3_f64).powi(2);
        (1.0 + 1.03961212 * l2 / (l2 - 0.00600069867)
            + 0.231792344 * l2 / (l2 - 0.0200179144)
            + 1.01046945 * l2 / (l2 - 103.560653))
            .sqrt()
    }

    fn grid() -> Observations {
        let l: Vec<f64> = (380..=780).map(|x| x as f64).collect();
        let n = l.iter().map(|&x| bk7(x)).collect();
        Observations::new(l, n, None, false, "test").unwrap()
    }

    #[test]
    fn cauchy_fit_recovers_exact_cauchy_data() {
        let l: Vec<f64> = (400..=700).step_by(10).map(|x| x as f64).collect();
        let m = Model::Cauchy(vec![1.5046, 0.0042, 1.2e-5]);
        let n = l.iter().map(|&x| m.n_at(x)).collect();
        let obs = Observations::new(l, n, None, false, "t").unwrap();
        let c = fit_model(&obs, ModelKind::Cauchy3).unwrap();
        for (a, b) in c.model.coefficients().iter().zip(m.coefficients()) {
            assert!((a - b).abs() < 1e-10, "{a} vs {b}");
        }
        assert!(c.max_abs_residual < 1e-13);
    }

    #[test]
    fn sellmeier3_fit_reproduces_bk7_over_the_visible() {
        let c = fit_model(&grid(), ModelKind::Sellmeier3).unwrap();
        assert!(c.valid, "{c:?}");
        assert!(c.max_abs_residual < 1e-6, "{}", c.max_abs_residual);
    }

    #[test]
    fn auto_choice_takes_the_first_model_within_tolerance() {
        let r = fit_auto(&grid(), &ModelKind::ALL, 1e-4, [380.0, 780.0]).unwrap();
        assert!(r.tolerance_met);
        let chosen = r.best();
        for c in &r.candidates[..r.chosen] {
            assert!(
                !(c.valid && c.max_abs_residual <= 1e-4),
                "{:?} was smaller",
                c.kind
            );
        }
        assert!(chosen.max_abs_residual <= 1e-4);
    }

    #[test]
    fn decreasing_wavelengths_and_n_below_one_are_refused() {
        assert!(Observations::new(vec![500.0, 400.0], vec![1.5, 1.5], None, true, "x").is_err());
        assert!(Observations::new(vec![400.0, 500.0], vec![1.5, 0.9], None, true, "x").is_err());
    }
}
