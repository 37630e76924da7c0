//! Black clipping of an LVF profile: the mean of pixels that were clipped at 0.
//!
//! A camera image (16-bit PNG/TIFF, RAW after black subtraction) stores max(0, μ + ε) with ε the
//! noise of standard deviation σ. Where the light is weak (the ends of the axis where the camera
//! is insensitive, a channel between its blobs) part of the noise is cut off, and the mean of n
//! such pixels is not μ but
//!
//! ```text
//! m(μ; σ) = μ·Φ(μ/σ) + σ·φ(μ/σ)            (the mean of a normal censored at 0)
//! ```
//!
//! with Φ, φ the standard normal CDF and density: at μ = 0 the floor is lifted by 0.40·σ, and
//! the lift is gone only above μ ≈ 2σ. The profile model (offset + lines + continuum, all linear)
//! cannot follow this lift, which depends on the signal itself and differs per channel; a
//! per-channel spline partly can, so at 5 % noise BIC preferred the per-channel continuum over
//! the physically constrained shared spectrum ([`crate::lvf::shared_continuum`]) because of the
//! clipping alone (issue 12; docs/performance.md measures it with and without a pedestal).
//!
//! The clipping is undone before the fit. Per channel, σ at the floor comes from the positions
//! where a fraction 0.1 ≤ p₀ ≤ 0.9 of the pixels is exactly 0: there p₀ = Φ(−μ/σ), so
//! z = μ/σ = −Φ⁻¹(p₀), and the mean ȳ = σ·(z·Φ(z) + φ(z)) gives σ; σ_floor is the median over
//! those positions (at least [`MIN_POSITIONS`] of them). Every sample below 4·σ_floor is then
//! replaced by μ = m⁻¹(ȳ; σ_floor) (m is increasing, m′ = Φ(μ/σ); bisection); a sample whose
//! pixels are all 0 says only that μ ≲ −σ·Φ⁻¹(1 − 1/(2n)) and is set there. A channel with no
//! zero pixels (float images, RAW without clipping) is left untouched, so an image that was not
//! clipped is never "corrected". The noise grows with the signal (shot noise), but the
//! correction matters only within ~2σ of black, where σ ≈ σ_floor.
//!
//! No colour-science counterpart.

use crate::lvf::profile::Profile;

/// Fewest positions with 0.1 ≤ p₀ ≤ 0.9 from which σ_floor is estimated.
pub const MIN_POSITIONS: usize = 5;

/// Samples at or above this many σ_floor are left as they are (the lift is < 1e-5 σ there).
const CORRECT_BELOW_SIGMA: f64 = 4.0;

/// What was undone, per channel (in `lvf.json` under `diagnostics.black_clipping`).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ClippingReport {
    /// σ at the floor per channel (image units), or 0 when the channel was not corrected.
    pub sigma_floor: [f64; 3],
    /// Positions whose mean was replaced, per channel.
    pub corrected_samples: [usize; 3],
    /// Positions with at least one pixel at exactly 0, per channel.
    pub positions_with_zeros: [usize; 3],
}

/// Standard normal CDF Φ(x) (erfc of Numerical Recipes' Chebyshev fit, |relative error| <
/// 1.2e-7).
fn normal_cdf(x: f64) -> f64 {
    let z = x.abs() / std::f64::consts::SQRT_2;
    let t = 1.0 / (1.0 + 0.5 * z);
    let poly = -z * z - 1.265_512_23
        + t * (1.000_023_68
            + t * (0.374_091_96
                + t * (0.096_784_18
                    + t * (-0.186_288_06
                        + t * (0.278_868_07
                            + t * (-1.135_203_98
                                + t * (1.488_515_87 + t * (-0.822_152_23 + t * 0.170_872_77))))))));
    let erfc = t * poly.exp();
    if x >= 0.0 {
        1.0 - 0.5 * erfc
    } else {
        0.5 * erfc
    }
}

/// Standard normal density φ(x).
fn normal_pdf(x: f64) -> f64 {
    (-0.5 * x * x).exp() / (2.0 * std::f64::consts::PI).sqrt()
}

/// Φ⁻¹(p) for 0 < p < 1 (bisection on [`normal_cdf`], to 1e-10 in z).
fn normal_quantile(p: f64) -> f64 {
    let (mut lo, mut hi) = (-12.0f64, 12.0f64);
    for _ in 0..80 {
        let mid = 0.5 * (lo + hi);
        if normal_cdf(mid) < p {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// m(μ; σ) = μΦ(μ/σ) + σφ(μ/σ).
pub fn censored_mean(mu: f64, sigma: f64) -> f64 {
    let z = mu / sigma;
    mu * normal_cdf(z) + sigma * normal_pdf(z)
}

/// μ with m(μ; σ) = ȳ (ȳ > 0), by bisection on [−12σ, max(ȳ, 0) + 12σ].
pub fn uncensored_mean(ybar: f64, sigma: f64) -> f64 {
    let (mut lo, mut hi) = (-12.0 * sigma, ybar.max(0.0) + 12.0 * sigma);
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if censored_mean(mid, sigma) < ybar {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// The profile with black clipping undone (see the module docs), and what was done; `None`
/// when no channel had enough partly clipped positions to estimate σ_floor (nothing changed).
pub fn unclip_profile(profile: &Profile) -> Option<(Profile, ClippingReport)> {
    let n = profile.px.len();
    if profile.zeros.iter().any(|z| z.len() != n) || profile.counts.len() != n {
        return None;
    }
    let mut out = profile.clone();
    let mut report = ClippingReport {
        sigma_floor: [0.0; 3],
        corrected_samples: [0; 3],
        positions_with_zeros: std::array::from_fn(|c| {
            profile.zeros[c].iter().filter(|&&z| z > 0).count()
        }),
    };
    let mut any = false;
    for c in 0..3 {
        let mut sig: Vec<f64> = (0..n)
            .filter_map(|i| {
                let cnt = profile.counts[i] as f64;
                let p0 = profile.zeros[c][i] as f64 / cnt.max(1.0);
                let y = profile.values[c][i];
                if !(0.1..=0.9).contains(&p0) || y.is_nan() || y <= 0.0 {
                    return None;
                }
                let z = -normal_quantile(p0);
                let s = y / (z * normal_cdf(z) + normal_pdf(z));
                (s.is_finite() && s > 0.0).then_some(s)
            })
            .collect();
        if sig.len() < MIN_POSITIONS {
            continue;
        }
        sig.sort_by(f64::total_cmp);
        let sigma = sig[sig.len() / 2];
        report.sigma_floor[c] = sigma;
        for i in 0..n {
            let y = profile.values[c][i];
            if y.is_nan() || y >= CORRECT_BELOW_SIGMA * sigma {
                continue;
            }
            let cnt = profile.counts[i].max(1);
            let mu = if profile.zeros[c][i] >= cnt {
                -sigma * normal_quantile(1.0 - 0.5 / cnt as f64)
            } else {
                uncensored_mean(y, sigma)
            };
            out.values[c][i] = mu;
            report.corrected_samples[c] += 1;
        }
        any = true;
    }
    any.then_some((out, report))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_normal_cdf_and_quantile_match_tabulated_values() {
        // Φ(1) = 0.841344746, Φ(−1.96) = 0.0249978951 (Abramowitz & Stegun 26.2)
        assert!((normal_cdf(1.0) - 0.841_344_746).abs() < 2e-7);
        assert!((normal_cdf(-1.96) - 0.024_997_895_1).abs() < 2e-8);
        assert!((normal_quantile(0.975) - 1.959_963_985).abs() < 2e-6);
    }

    #[test]
    fn the_censored_mean_lifts_black_by_0_4_sigma_and_inverts() {
        assert!((censored_mean(0.0, 1.0) - 0.398_942_28).abs() < 1e-7);
        assert!((censored_mean(5.0, 1.0) - 5.0).abs() < 1e-6);
        for z in [-2.0, -0.5, 0.0, 0.3, 1.0, 2.5] {
            let mu = 0.02 * z;
            assert!((uncensored_mean(censored_mean(mu, 0.02), 0.02) - mu).abs() < 1e-9);
        }
    }

    #[test]
    fn clipped_noise_on_a_dark_profile_is_restored_to_its_true_mean() {
        // 200 positions, true mean rising 0 → 0.05, σ = 0.02, 400 pixels each, clipped at 0.
        let mut rng = crate::capture::rng::SplitMix64::new(5);
        let n = 200;
        let truth: Vec<f64> = (0..n).map(|i| 0.05 * i as f64 / n as f64).collect();
        let mut values: [Vec<f64>; 3] = Default::default();
        let mut zeros: [Vec<usize>; 3] = Default::default();
        for &mu in &truth {
            let (mut s, mut z) = (0.0, 0);
            for _ in 0..400 {
                let v = (mu + 0.02 * rng.normal()).max(0.0);
                s += v;
                z += usize::from(v == 0.0);
            }
            for c in 0..3 {
                values[c].push(s / 400.0);
                zeros[c].push(z);
            }
        }
        let profile = Profile {
            axis: crate::lvf::Axis::X,
            roi: [0, 0, n, 400],
            px: (0..n).map(|i| i as f64).collect(),
            values,
            counts: vec![400; n],
            zeros,
            source: "test".into(),
            strips: Vec::new(),
            frame_size: [n, 400],
        };
        let raw_bias: f64 = (0..n).map(|i| profile.values[0][i] - truth[i]).sum::<f64>() / n as f64;
        let (fixed, rep) = unclip_profile(&profile).unwrap();
        let bias: f64 = (0..n).map(|i| fixed.values[0][i] - truth[i]).sum::<f64>() / n as f64;
        assert!((rep.sigma_floor[0] - 0.02).abs() < 0.002, "{rep:?}");
        // averaged over μ/σ ∈ [0, 2.5] the lift m(μ) − μ is 0.10·σ = 0.002
        assert!(raw_bias > 0.0015, "clipping lifts the floor: {raw_bias}");
        // the means scatter by 0.02/√400 = 0.001 each, 7e-5 over 200 positions
        assert!(bias.abs() < 0.2 * raw_bias, "{bias} vs {raw_bias}");
    }

    #[test]
    fn a_profile_without_zero_pixels_is_left_alone() {
        let n = 50;
        let profile = Profile {
            axis: crate::lvf::Axis::X,
            roi: [0, 0, n, 10],
            px: (0..n).map(|i| i as f64).collect(),
            values: std::array::from_fn(|_| vec![0.001; n]),
            counts: vec![10; n],
            zeros: std::array::from_fn(|_| vec![0; n]),
            source: "test".into(),
            strips: Vec::new(),
            frame_size: [n, 10],
        };
        assert!(unclip_profile(&profile).is_none());
    }
}
