//! Statistics of a least-squares fit: covariance from the Jacobian and information criteria.
//!
//! The one implementation of each for the crate: [`lm`](super::lm), the decay fit and the LVF
//! and phosphor domains call these rather than inverting `JᵀJ` themselves.

use super::qr::Qr;

/// `(JᵀJ)⁻¹` of the (weighted) Jacobian J (`n_obs × p`, column-major), through the QR of J so
/// the condition number is not squared. `None` when J is rank deficient or has fewer rows than
/// columns.
pub fn inverse_gram(jac: &[f64], n_obs: usize, p: usize) -> Option<Vec<f64>> {
    if n_obs < p || p == 0 {
        return None;
    }
    Qr::new(jac, n_obs, p).inverse_gram()
}

/// Covariance `s² (JᵀJ)⁻¹` with a given residual variance `s²` (for example 1 when the
/// residuals are already divided by known σ, or rss/dof with another count of degrees of
/// freedom).
pub fn covariance_scaled(jac: &[f64], n_obs: usize, p: usize, s2: f64) -> Option<Vec<f64>> {
    let inv = inverse_gram(jac, n_obs, p)?;
    Some(inv.into_iter().map(|v| v * s2).collect())
}

/// Covariance `σ² (JᵀJ)⁻¹` of the parameters of a least-squares fit, with the residual variance
/// `σ² = rss / (n_obs − p)`, from the (weighted) Jacobian J (`n_obs × p`, column-major).
///
/// Computed through the QR of J, so the condition number is not squared. `None` when J is rank
/// deficient or there are no degrees of freedom left.
pub fn covariance(jac: &[f64], n_obs: usize, p: usize, rss: f64) -> Option<Vec<f64>> {
    if n_obs <= p || p == 0 {
        return None;
    }
    covariance_scaled(jac, n_obs, p, rss / (n_obs - p) as f64)
}

/// Bayesian information criterion for Gaussian residuals: `n ln(rss/n) + k ln n`.
///
/// A residual sum of exactly zero is floored at `f64::MIN_POSITIVE` so the criterion stays finite.
pub fn bic(rss: f64, n_obs: usize, n_params: usize) -> f64 {
    let n = n_obs as f64;
    n * (rss.max(f64::MIN_POSITIVE) / n).ln() + n_params as f64 * n.ln()
}
