//! How much a correlated residual inflates the statistical σ of the map.
//!
//! The covariance s²(JᵀJ)⁻¹ of a least-squares fit assumes independent residuals. Where the
//! model does not follow the profile exactly (a continuum edge the spline cannot bend to, a
//! fall-off the strips do not see) the residual is a smooth misfit correlated over tens of
//! pixels, and the map's true error is many times the formal σ. For residuals with
//! autocorrelation ρ_k the variance of a mean — and, to first order, of a least-squares
//! parameter whose Jacobian column varies slowly on the residual's correlation scale — is
//! τ times the independent-sample value, with the integrated correlation length
//!
//! ```text
//! τ = 1 + 2·Σ_{k≥1} ρ_k,    ρ_k = Σ_c Σ_i r_{c,i}·r_{c,i+k} / Σ_c Σ_i r_{c,i}²
//! ```
//!
//! summed by Geyer's initial positive sequence (pairs ρ_{2m} + ρ_{2m+1} while positive; Geyer
//! 1992), pooled over the channels. White noise gives τ ≈ 1 (floored at 1); a misfit gives
//! τ ≫ 1 and the statistical σ is multiplied by √τ (the covariance by τ).

/// Largest lag summed, as a fraction of the profile length.
const MAX_LAG_FRACTION: f64 = 0.25;

/// τ (≥ 1) of a channel-major residual of `channels` channels of equal length.
pub fn correlation_length(residual: &[f64], channels: usize) -> f64 {
    let channels = channels.max(1);
    let n = residual.len() / channels;
    if n < 4 {
        return 1.0;
    }
    let rho = |k: usize| -> f64 {
        let (mut num, mut den) = (0.0, 0.0);
        for c in 0..channels {
            let r = &residual[c * n..(c + 1) * n];
            den += r.iter().map(|v| v * v).sum::<f64>();
            num += r.iter().zip(&r[k..]).map(|(a, b)| a * b).sum::<f64>();
        }
        if den > 0.0 {
            num / den
        } else {
            0.0
        }
    };
    let max_lag = ((n as f64 * MAX_LAG_FRACTION) as usize).max(2);
    // Geyer: Γ_m = ρ_{2m} + ρ_{2m+1}, τ = −1 + 2·Σ Γ_m over the initial positive run.
    let mut tau = -1.0;
    let mut m = 0;
    while 2 * m < max_lag {
        let g = rho(2 * m) + rho(2 * m + 1);
        if g <= 0.0 {
            break;
        }
        tau += 2.0 * g;
        m += 1;
    }
    tau.max(1.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::capture::rng::SplitMix64;

    #[test]
    fn white_noise_has_a_correlation_length_near_one() {
        let mut rng = SplitMix64::new(5);
        let r: Vec<f64> = (0..3 * 1200).map(|_| rng.normal()).collect();
        let t = correlation_length(&r, 3);
        assert!((1.0..1.3).contains(&t), "τ {t}");
    }

    #[test]
    fn a_moving_average_of_noise_has_its_known_correlation_length() {
        // a box average of w white samples has τ = w
        let mut rng = SplitMix64::new(6);
        let w = 20;
        let white: Vec<f64> = (0..3 * 4000 + w).map(|_| rng.normal()).collect();
        let r: Vec<f64> = (0..3 * 4000)
            .map(|i| white[i..i + w].iter().sum::<f64>())
            .collect();
        let t = correlation_length(&r, 3);
        assert!((t / w as f64 - 1.0).abs() < 0.25, "τ {t}");
    }
}
