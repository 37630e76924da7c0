//! Why an iterative fit stopped, and the MINPACK-style stopping tests shared by the solvers
//! ([`lm`](super::lm) and [`varpro`](super::varpro)).
//!
//! The tests are written once here so that both solvers call a fit "converged" for the same
//! reasons (Moré, Garbow & Hillstrom, *User Guide for MINPACK-1*, ANL-80-74, §2.3):
//!
//! - cost: the actual and the predicted relative reductions of ½‖r‖² are both at most `ftol`;
//! - step: ‖δ‖ ≤ `xtol`·(‖θ‖ + `xtol`);
//! - gradient: the largest cosine between the residual and a Jacobian column is at most `gtol`.

/// Why the iteration stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Termination {
    /// The relative reduction of the cost fell below `ftol`.
    CostConverged,
    /// The step fell below `xtol` relative to the parameters.
    StepConverged,
    /// The projected gradient vanished (within `gtol`).
    GradientConverged,
    /// `max_iter` iterations were used.
    MaxIterations,
    /// The damping grew without finding a reducing step.
    NoProgress,
    /// The cost or model became non-finite.
    NonFinite,
}

impl Termination {
    /// True for the converged reasons.
    pub fn converged(self) -> bool {
        matches!(
            self,
            Termination::CostConverged
                | Termination::StepConverged
                | Termination::GradientConverged
        )
    }
}

/// Euclidean norm.
#[inline]
pub(crate) fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

/// MINPACK's step test: ‖δ‖ ≤ xtol·(‖θ‖ + xtol).
#[inline]
pub(crate) fn step_converged(step_norm: f64, theta_norm: f64, xtol: f64) -> bool {
    step_norm <= xtol * (theta_norm + xtol)
}

/// MINPACK's cost test on an accepted step: the actual relative reduction `(rss − rss_new)/rss`
/// and the predicted one `2·pred/rss_new` (pred the predicted reduction of ½‖r‖²) are both at
/// most `ftol`.
#[inline]
pub(crate) fn cost_converged(rss: f64, rss_new: f64, pred: f64, ftol: f64) -> bool {
    let rel = (rss - rss_new) / rss.max(f64::MIN_POSITIVE);
    rel <= ftol && 2.0 * pred / rss_new.max(f64::MIN_POSITIVE) <= ftol
}

/// The same test on a rejected step: the predicted reduction and the actual change are both
/// below `ftol` relative to the cost, so the cost is at its minimum to the requested precision
/// (the "increase" is rounding).
#[inline]
pub(crate) fn cost_stalled(rss: f64, rss_trial: f64, pred: f64, ftol: f64) -> bool {
    let scale = rss.max(f64::MIN_POSITIVE);
    let actual = 0.5 * (rss - rss_trial);
    rss_trial.is_finite() && 2.0 * pred / scale <= ftol && 2.0 * actual.abs() / scale <= ftol
}
