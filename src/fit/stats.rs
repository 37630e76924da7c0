//! Statistics of a least-squares fit: covariance from the Jacobian and information criteria.

use super::qr::Qr;

/// Covariance `σ² (JᵀJ)⁻¹` of the parameters of a least-squares fit, with the residual variance
/// `σ² = rss / (n_obs − p)`, from the (weighted) Jacobian J (`n_obs × p`, column-major).
///
/// Computed through the QR of J, so the condition number is not squared. `None` when J is rank
/// deficient or there are no degrees of freedom left.
pub fn covariance(jac: &[f64], n_obs: usize, p: usize, rss: f64) -> Option<Vec<f64>> {
    if n_obs <= p || p == 0 {
        return None;
    }
    let qr = Qr::new(jac, n_obs, p);
    let inv = qr.inverse_gram()?;
    let s2 = rss / (n_obs - p) as f64;
    Some(inv.into_iter().map(|v| v * s2).collect())
}

/// Bayesian information criterion for Gaussian residuals: `n ln(rss/n) + k ln n`.
///
/// A residual sum of exactly zero is floored at `f64::MIN_POSITIVE` so the criterion stays finite.
pub fn bic(rss: f64, n_obs: usize, n_params: usize) -> f64 {
    let n = n_obs as f64;
    n * (rss.max(f64::MIN_POSITIVE) / n).ln() + n_params as f64 * n.ln()
}
