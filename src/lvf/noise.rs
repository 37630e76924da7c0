//! The noise of a lamp profile, for weighted least squares.
//!
//! A profile sample is the mean of the pixels across the axis at one position; each pixel has
//! read noise and shot noise, so the variance of a sample grows with its level:
//!
//! ```text
//! var(y_i) = a + b·max(μ_i, 0)        (a: read noise, b: shot-noise gain, both over the count)
//! ```
//!
//! The line blobs, where the calibration's information is, are the brightest samples: an
//! unweighted fit lets their shot noise move the map, and gives the dim flanks and the continuum
//! between the lines too little say. The fit divides every residual by its σ (normalised to the
//! profile's mean variance, so residuals keep their data scale on average).
//!
//! `a` and `b` are estimated from the profile itself, not from a camera model: the fourth
//! difference d_i = y_{i−2} − 4y_{i−1} + 6y_i − 4y_{i+1} + y_{i+2} removes any smooth signal (a
//! passband blob several pixels wide has a fourth difference far below the noise) and has
//! variance 70·var(y_i) for independent noise. The samples are sorted by level into bins; in each
//! bin the median of d²/70 (over the median of χ²₁, 0.4549, so a stray feature cannot pull it)
//! estimates the variance; `a + b·μ` is fitted to the bins by least squares weighted by the
//! estimates' own variance. Noise correlated between neighbouring samples (a demosaiced JPEG)
//! makes d smaller: the weights are then only relative, which is all the fit uses of them.

/// Fewest samples per channel for an estimate.
const MIN_SAMPLES: usize = 40;
/// Level bins of the estimate.
const BINS: usize = 16;
/// Median of χ² with one degree of freedom.
const CHI2_1_MEDIAN: f64 = 0.454_936_423_119_572_7;
/// Noise is seen when its largest σ exceeds this fraction of the profile's peak (a 16-bit image's
/// quantisation, 1.5e-5 per pixel, averages below it; 1 % noise over 160 rows is ~8e-4).
const SEEN_RELATIVE: f64 = 1e-5;
/// The read-noise term is floored at this fraction of the largest variance: a weight may not
/// grow without bound where the estimate of `a` is near zero.
const READ_FLOOR: f64 = 0.02;
/// Passes of the fit of `a + b·μ` to the bins: the first weighted by each bin's own estimate,
/// the others by the previous pass's line.
const ESTIMATE_PASSES: usize = 3;

/// The profile's noise model `var(y) = a + b·max(y, 0)`.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct NoiseModel {
    /// Variance at zero level, `a` (image units²), after the floor.
    pub read_variance: f64,
    /// Variance per unit level, `b` (image units).
    pub shot_gain: f64,
    /// Mean variance over the profile's samples; the weights are √(mean/var).
    pub mean_variance: f64,
    /// Variance at the profile's brightest sample over the variance at zero level.
    pub peak_over_dark: f64,
}

impl NoiseModel {
    /// Variance at level `y`.
    pub fn variance(&self, y: f64) -> f64 {
        self.read_variance + self.shot_gain * y.max(0.0)
    }
}

/// Estimates the noise model of a three-channel profile (one model for the three channels: the
/// raw channels share the sensor's gain). `None` when the profile has fewer than
/// [`MIN_SAMPLES`] samples per channel or no noise is seen ([`SEEN_RELATIVE`]: noise-free
/// synthetic data, where weights would follow rounding).
pub fn estimate(values: [&[f64]; 3]) -> Option<NoiseModel> {
    let mut pts: Vec<(f64, f64)> = Vec::new();
    for y in values {
        if y.len() < MIN_SAMPLES {
            return None;
        }
        for w in y.windows(5) {
            let d = w[0] - 4.0 * w[1] + 6.0 * w[2] - 4.0 * w[3] + w[4];
            let mu = w.iter().sum::<f64>() / 5.0;
            pts.push((mu, d * d / 70.0));
        }
    }
    pts.sort_by(|a, b| a.0.total_cmp(&b.0));
    let per = pts.len() / BINS;
    if per < 5 {
        return None;
    }
    let mut bins: Vec<(f64, f64, usize)> = Vec::with_capacity(BINS);
    for k in 0..BINS {
        let chunk = &pts[k * per..if k + 1 == BINS {
            pts.len()
        } else {
            (k + 1) * per
        }];
        let mut d2: Vec<f64> = chunk.iter().map(|p| p.1).collect();
        d2.sort_by(f64::total_cmp);
        let v = d2[d2.len() / 2] / CHI2_1_MEDIAN;
        let mu = chunk[chunk.len() / 2].0;
        bins.push((mu, v, chunk.len()));
    }
    let vmax = bins.iter().map(|b| b.1).fold(0.0, f64::max);
    let top = pts.last().map_or(0.0, |p| p.0.abs());
    if !(vmax.is_finite() && vmax.sqrt() > SEEN_RELATIVE * top) {
        return None;
    }
    // Weighted least squares of v = a + b·μ: an estimate from m samples has variance ≈ 2v²/m
    // (the median's efficiency aside). The first pass weighs each bin by its own estimate,
    // floored; that favours the bins whose estimate came out low and took b 6–8 % low on
    // average (40 draws of the unit test's profile: 0.936 ± 0.15 of the truth); the passes after
    // weigh by the fitted line instead (0.994 ± 0.15).
    let floor = 1e-3 * vmax;
    let (mut a, mut b) = (0.0, 0.0);
    for pass in 0..ESTIMATE_PASSES {
        let (mut s00, mut s01, mut s11, mut t0, mut t1) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for &(mu, v, m) in &bins {
            let mu = mu.max(0.0);
            let var = if pass == 0 { v } else { a + b * mu }.max(floor);
            let w = m as f64 / var.powi(2);
            s00 += w;
            s01 += w * mu;
            s11 += w * mu * mu;
            t0 += w * v;
            t1 += w * mu * v;
        }
        let det = s00 * s11 - s01 * s01;
        (a, b) = if det > 1e-12 * s00 * s11 {
            ((s11 * t0 - s01 * t1) / det, (s00 * t1 - s01 * t0) / det)
        } else {
            (t0 / s00, 0.0)
        };
        if b < 0.0 {
            // the level does not raise the noise: homoscedastic
            b = 0.0;
            a = t0 / s00;
        }
    }
    a = a.max(READ_FLOOR * vmax);
    let model = NoiseModel {
        read_variance: a,
        shot_gain: b,
        mean_variance: 0.0,
        peak_over_dark: 1.0,
    };
    let (mut sum, mut count, mut peak) = (0.0, 0usize, f64::MIN);
    for y in values {
        for &v in y {
            sum += model.variance(v);
            count += 1;
            peak = peak.max(v);
        }
    }
    Some(NoiseModel {
        mean_variance: sum / count as f64,
        peak_over_dark: model.variance(peak) / a,
        ..model
    })
}

/// The weights √(mean variance / var(ŷ_i)) per channel and sample, with ŷ the 5-sample running
/// mean of the profile (so that a sample's own noise does not set its weight).
pub fn weights(model: &NoiseModel, values: [&[f64]; 3]) -> [Vec<f64>; 3] {
    std::array::from_fn(|c| {
        let y = values[c];
        let n = y.len();
        (0..n)
            .map(|i| {
                let lo = i.saturating_sub(2);
                let hi = (i + 3).min(n);
                let mu = y[lo..hi].iter().sum::<f64>() / (hi - lo) as f64;
                (model.mean_variance / model.variance(mu)).sqrt()
            })
            .collect()
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::capture::rng::SplitMix64;

    fn profile(a: f64, b: f64, seed: u64) -> [Vec<f64>; 3] {
        let mut rng = SplitMix64::new(seed);
        std::array::from_fn(|c| {
            (0..1200)
                .map(|i| {
                    let x = i as f64;
                    let mu = 0.05
                        + 0.8 * (-0.5 * ((x - 300.0 - 200.0 * c as f64) / 34.0).powi(2)).exp()
                        + 0.4 * (-0.5 * ((x - 900.0) / 34.0).powi(2)).exp();
                    mu + (a + b * mu).sqrt() * rng.normal()
                })
                .collect()
        })
    }

    #[test]
    fn read_and_shot_noise_are_recovered_from_the_profile_alone() {
        let (a, b) = (1e-7, 2e-6);
        let p = profile(a, b, 3);
        let m = estimate([&p[0], &p[1], &p[2]]).unwrap();
        // one draw scatters by ≈ 15 % (the mean over draws is the next test's)
        assert!((m.shot_gain / b - 1.0).abs() < 0.3, "{m:?}");
        assert!((m.read_variance / a - 1.0).abs() < 0.5, "{m:?}");
        let w = weights(&m, [&p[0], &p[1], &p[2]]);
        // the peak of channel 0 (x = 300) weighs less than the dark flank
        assert!(w[0][300] < 0.5 * w[0][50], "{} {}", w[0][300], w[0][50]);
    }

    #[test]
    fn the_shot_gain_is_unbiased_over_draws() {
        let (a, b) = (1e-7, 2e-6);
        let n = 40;
        let ratios: Vec<f64> = (1..=n)
            .map(|seed| {
                let p = profile(a, b, seed);
                estimate([&p[0], &p[1], &p[2]]).unwrap().shot_gain / b
            })
            .collect();
        let mean = ratios.iter().sum::<f64>() / n as f64;
        let sd = (ratios.iter().map(|r| (r - mean).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt();
        // the standard error of the mean is sd/√40 ≈ 0.024; weighting the bins by their own
        // estimates alone (one pass) gave a mean 6–8 % low
        assert!((mean - 1.0).abs() < 0.05, "mean {mean}, sd {sd}");
        assert!(sd < 0.25, "mean {mean}, sd {sd}");
    }

    #[test]
    fn homoscedastic_noise_gives_equal_weights() {
        let p = profile(4e-7, 0.0, 5);
        let m = estimate([&p[0], &p[1], &p[2]]).unwrap();
        assert!(m.shot_gain * 0.85 < 0.2 * m.read_variance, "{m:?}");
        let w = weights(&m, [&p[0], &p[1], &p[2]]);
        let (lo, hi) = w
            .iter()
            .flatten()
            .fold((f64::MAX, f64::MIN), |(l, h), &v| (l.min(v), h.max(v)));
        assert!(hi / lo < 1.25, "{lo} {hi}");
    }

    #[test]
    fn noise_free_and_short_profiles_give_no_model() {
        let p: Vec<f64> = (0..1200).map(|i| (i as f64 / 100.0).sin() + 2.0).collect();
        assert!(estimate([&p, &p, &p]).is_none());
        let short = vec![1.0; 20];
        assert!(estimate([&short, &short, &short]).is_none());
    }
}
