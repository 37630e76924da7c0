//! Noise clipped at black: the profile mean of pixels whose negative noise was cut to 0.
//!
//! A camera (or a RAW decoder that subtracts the black level and clips) records a pixel of
//! noiseless value m with Gaussian read noise s as max(0, m + ε). Where the lamp profile is dark
//! (between the mercury blobs, beyond the last line) the mean over the ROI's pixels across the
//! axis is then not m but the censored mean
//!
//! ```text
//! E[max(0, m + ε)] = m·Φ(m/s) + s·φ(m/s),      ε ~ N(0, s²)
//! ```
//!
//! which is s/√(2π) ≈ 0.4·s above m = 0: a floor lifted only where the signal is within a few s
//! of black — a shape that neither the offset b + s·u nor the lines can take, so a continuum
//! absorbs it and the map pays (measured 0.003–0.014 nm against 0.001–0.005 at 1 % noise on a
//! clean Hg lamp). [`decensor`] undoes it per position and channel from what the pixels show:
//!
//! 1. the read noise s_c of channel c at black is pooled over the positions whose fraction p₀ of
//!    pixels at exactly 0 lies in [[`P0_RANGE`]]: there the two observed numbers p₀ = Φ(−m/s)
//!    and ȳ = m·Φ(m/s) + s·φ(m/s) give t = m/s = −Φ⁻¹(p₀) and s = ȳ/(t·Φ(t) + φ(t)); the median
//!    over positions is s_c (at least [`MIN_POSITIONS`] positions, else the channel is left as
//!    it is);
//! 2. at every position with pixels at 0, m solves ȳ = m·Φ(m/s_c) + s_c·φ(m/s_c) (monotonic in
//!    m; bisection). A position whose pixels are all 0 gets the m at which that is as likely as
//!    not, Φ(−m/s_c)ⁿ = ½ (m ≈ −2.6 s_c for 160 pixels): its mean is only bounded.
//!
//! This is the method-of-moments inverse of the censored (Tobit) mean with the noise pooled over
//! the profile; near black the noise is read noise, the same at every position (shot noise at
//! m ≲ 3 s adds under 10 % to the variance for the project's noise model). An image without
//! exact zeros, or a noise-free one (every pixel of a dark position at 0, so s cannot be
//! estimated), is left unchanged.

/// Fractions of pixels at 0 at which a position estimates the black-level noise.
pub const P0_RANGE: (f64, f64) = (0.15, 0.85);

/// Fewest positions per channel for a pooled noise estimate.
pub const MIN_POSITIONS: usize = 8;

/// Fewest pixels across the axis for the correction: with fewer, p₀ moves in steps of > 2 % and
/// the noise estimate is too coarse (a 24-row lamp of `tests/lvf_recovery_e2e.rs` lost accuracy
/// downstream with it); such profiles are left unchanged.
const MIN_PIXELS: usize = 50;

/// What [`decensor`] did, per channel (r, g, b).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Censoring {
    /// The black-level noise s per channel (profile units, one pixel), `null` when it could not
    /// be estimated (then that channel was not changed).
    pub black_noise: [Option<f64>; 3],
    /// Positions whose mean was replaced.
    pub positions_corrected: [usize; 3],
    /// Positions whose pixels were all at 0.
    pub positions_all_zero: [usize; 3],
    /// Largest |change| of a profile mean over the profile's peak.
    pub largest_change_relative: f64,
}

/// Standard normal density φ(t).
fn pdf(t: f64) -> f64 {
    (-0.5 * t * t).exp() / (2.0 * std::f64::consts::PI).sqrt()
}

/// Complementary error function, Numerical Recipes' Chebyshev fit (`erfcc`, fractional error
/// < 1.2·10⁻⁷ everywhere).
fn erfc(x: f64) -> f64 {
    let z = x.abs();
    let t = 1.0 / (1.0 + 0.5 * z);
    let r = t
        * (-z * z - 1.265_512_23
            + t * (1.000_023_68
                + t * (0.374_091_96
                    + t * (0.096_784_18
                        + t * (-0.186_288_06
                            + t * (0.278_868_07
                                + t * (-1.135_203_98
                                    + t * (1.488_515_87
                                        + t * (-0.822_152_23 + t * 0.170_872_77)))))))))
            .exp();
    if x >= 0.0 {
        r
    } else {
        2.0 - r
    }
}

/// Standard normal distribution function Φ(t).
fn cdf(t: f64) -> f64 {
    0.5 * erfc(-t / std::f64::consts::SQRT_2)
}

/// Φ⁻¹(p) for p in (0, 1), by bisection on [`cdf`] (to 1e-10 in t).
fn quantile(p: f64) -> f64 {
    let (mut lo, mut hi) = (-12.0, 12.0);
    for _ in 0..80 {
        let mid = 0.5 * (lo + hi);
        if cdf(mid) < p {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// t·Φ(t) + φ(t): the censored mean of N(t, 1) clipped at 0.
fn censored_mean_unit(t: f64) -> f64 {
    t * cdf(t) + pdf(t)
}

/// The m whose clipped mean with noise s is `mean` (bisection; `mean` > 0).
fn invert(mean: f64, s: f64) -> f64 {
    let r = mean / s;
    let (mut lo, mut hi) = (-38.0, r + 1.0);
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if censored_mean_unit(mid) < r {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi) * s
}

/// Replaces the profile means of positions with clipped pixels by the uncensored mean (see the
/// module docs). `values[c][i]` is the mean of `counts[i]` pixels of which `zeros[i][c]` were at
/// exactly 0. Returns `None` (nothing changed) when no channel had clipped pixels and an
/// estimable noise.
pub fn decensor(
    values: &mut [Vec<f64>; 3],
    counts: &[usize],
    zeros: &[[usize; 3]],
) -> Option<Censoring> {
    let peak = values
        .iter()
        .flatten()
        .cloned()
        .fold(0.0f64, f64::max)
        .max(1e-300);
    let mut rep = Censoring {
        black_noise: [None; 3],
        positions_corrected: [0; 3],
        positions_all_zero: [0; 3],
        largest_change_relative: 0.0,
    };
    for c in 0..3 {
        let mut s_est: Vec<f64> = Vec::new();
        for (i, (&n, z)) in counts.iter().zip(zeros).enumerate() {
            if n < MIN_PIXELS {
                continue;
            }
            let p0 = z[c] as f64 / n as f64;
            let y = values[c][i];
            if p0 < P0_RANGE.0 || p0 > P0_RANGE.1 || y <= 0.0 {
                continue;
            }
            let t = -quantile(p0);
            let s = y / censored_mean_unit(t);
            if s.is_finite() && s > 0.0 {
                s_est.push(s);
            }
        }
        if s_est.len() < MIN_POSITIONS {
            continue;
        }
        s_est.sort_by(f64::total_cmp);
        let s = s_est[s_est.len() / 2];
        rep.black_noise[c] = Some(s);
        for (i, (&n, z)) in counts.iter().zip(zeros).enumerate() {
            if z[c] == 0 || n < MIN_PIXELS {
                continue;
            }
            let y = values[c][i];
            let m = if z[c] >= n || y <= 0.0 {
                rep.positions_all_zero[c] += 1;
                // Φ(−m/s)ⁿ = ½
                -s * quantile(0.5f64.powf(1.0 / n as f64))
            } else {
                invert(y, s)
            };
            rep.largest_change_relative = rep.largest_change_relative.max((m - y).abs() / peak);
            values[c][i] = m;
            rep.positions_corrected[c] += 1;
        }
    }
    rep.black_noise.iter().any(Option::is_some).then_some(rep)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::capture::rng::SplitMix64;

    #[test]
    fn normal_functions_match_tabulated_values() {
        // Φ(1) = 0.841344746, Φ(−2) = 0.022750132, Φ⁻¹(0.975) = 1.959963985
        assert!((cdf(1.0) - 0.841_344_746).abs() < 2e-7);
        assert!((cdf(-2.0) - 0.022_750_132).abs() < 2e-8);
        assert!((quantile(0.975) - 1.959_963_985).abs() < 1e-6);
        // the clipped mean of N(0, 1) is 1/√(2π)
        assert!((censored_mean_unit(0.0) - 0.398_942_280).abs() < 1e-7);
    }

    #[test]
    fn inversion_recovers_the_uncensored_mean() {
        for m in [-2.0, -0.5, 0.0, 0.3, 1.0, 4.0] {
            let y = m * cdf(m / 0.7) + 0.7 * pdf(m / 0.7);
            assert!((invert(y, 0.7) - m).abs() < 1e-6, "m {m}");
        }
    }

    /// Pixels max(0, m + ε) with known m and s: the decensored profile is unbiased where the plain
    /// mean is lifted by ≈ 0.4 s, and positions far above black are untouched.
    #[test]
    fn clipped_pixels_are_decensored_to_their_true_mean() {
        let s = 0.01;
        let n = 160;
        let truth: Vec<f64> = (0..200).map(|i| -0.01 + 0.0003 * i as f64).collect();
        let mut rng = SplitMix64::new(11);
        let mut values: [Vec<f64>; 3] = Default::default();
        let mut zeros = Vec::new();
        for &m in &truth {
            let mut z = [0usize; 3];
            for c in 0..3 {
                let mut sum = 0.0;
                for _ in 0..n {
                    let v = (m + s * rng.normal()).max(0.0);
                    if v <= 0.0 {
                        z[c] += 1;
                    }
                    sum += v;
                }
                values[c].push(sum / n as f64);
            }
            zeros.push(z);
        }
        let before: f64 = values[0][25..45].iter().sum::<f64>() / 20.0;
        let counts = vec![n; truth.len()];
        let rep = decensor(&mut values, &counts, &zeros).expect("noise estimable");
        let est = rep.black_noise[0].unwrap();
        assert!((est / s - 1.0).abs() < 0.05, "s {est}");
        // around m = 0 (positions 25–44, m from −0.25 s to 0.35 s) the plain mean is ≈ 0.4 s high; decensored within 3 SE
        let truth_mean: f64 = truth[25..45].iter().sum::<f64>() / 20.0;
        let after: f64 = values[0][25..45].iter().sum::<f64>() / 20.0;
        assert!(
            before - truth_mean > 0.3 * s,
            "lift {}",
            before - truth_mean
        );
        let se = s / ((20 * n) as f64).sqrt() * 2.0;
        assert!(
            (after - truth_mean).abs() < 3.0 * se,
            "{after} vs {truth_mean}"
        );
        // far above black (m ≈ 5 s) nothing is clipped, nothing changes
        assert!(zeros[199].iter().all(|&z| z == 0));
    }

    #[test]
    fn a_noise_free_profile_is_left_unchanged() {
        let mut values: [Vec<f64>; 3] = [vec![0.0, 0.0, 0.5], vec![0.0, 0.2, 0.0], vec![0.1; 3]];
        let before = values.clone();
        let zeros = vec![[160, 160, 0], [160, 0, 0], [0, 160, 0]];
        assert!(decensor(&mut values, &[160; 3], &zeros).is_none());
        assert_eq!(values, before);
    }
}
