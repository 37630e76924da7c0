//! Keyframes of the glow after switch-off, chosen so that linear interpolation between them stays
//! within a stated error of the exact rate-equation solution (for glTF `KHR_animation_pointer`
//! animations of `emissiveFactor`, which engines interpolate linearly).
//!
//! After switch-off each state decays exactly, `r_i(t) = r_i(0)·exp(−k_r,i t)`, so the emitted
//! linear RGB is `rgb(t) = Σ_i r_i(0)·e^{−k_r,i t}·C_i` (C_i as in [`super::PhosphorTwin`], in
//! f64 here). The keys are placed greedily: from the last key, the next one is the farthest time
//! (found by bisection) at which the chord stays within
//!
//! `|chord(t) − rgb(t)| ≤ rel_tol·|rgb(t)| + abs_tol·peak` for every channel,
//!
//! checked on 64 points per candidate segment against 98 % of the allowed error (a sum of at most four decaying exponentials is
//! smooth and convex per state, so the chord error has one maximum per segment; the dense check
//! is a margin, and [`GlowKeyframes::max_error`] is measured again on 1000 points per segment).

// Channel loops mirror the maths (rgb[ch]).
#![allow(clippy::needless_range_loop)]

use crate::error::{Error, Result};

/// Tolerances of the keyframe placement.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct KeyframeTolerance {
    /// Error allowed relative to the exact value at that time (e.g. 0.01).
    pub rel_tol: f64,
    /// Error allowed relative to the peak (t = 0) brightest channel, so the far tail does not
    /// need keys forever (e.g. 1e-4).
    pub abs_tol: f64,
}

impl Default for KeyframeTolerance {
    fn default() -> Self {
        KeyframeTolerance {
            rel_tol: 0.01,
            abs_tol: 1e-4,
        }
    }
}

/// Keyframes of the glow: times and linear RGB values.
#[derive(Debug, Clone, PartialEq)]
pub struct GlowKeyframes {
    /// Key times in s, from 0, strictly increasing, the last one at the duration asked for.
    pub t_s: Vec<f64>,
    /// Linear RGB at each key (exact values of the solution).
    pub rgb: Vec<[f64; 3]>,
    /// Largest error of linear interpolation measured on 1000 points per segment, as a fraction
    /// of the allowed error (≤ 1 means within tolerance).
    pub max_error: f64,
}

/// `err / allowed`: how much of its allowance an error uses (∞ for an error where none is
/// allowed, 0 for none).
pub fn error_ratio(err: f64, allowed: f64) -> f64 {
    if allowed > 0.0 {
        err / allowed
    } else if err > 0.0 {
        f64::INFINITY
    } else {
        0.0
    }
}

/// Exact glow `Σ_i r0_i e^{−k_i t} C_i`.
pub fn glow_rgb(r0: &[f64], k_r_per_s: &[f64], rgb_per_state: &[[f64; 3]], t_s: f64) -> [f64; 3] {
    let mut out = [0.0; 3];
    for ((r, k), c) in r0.iter().zip(k_r_per_s).zip(rgb_per_state) {
        let w = r * (-k * t_s).exp();
        for ch in 0..3 {
            out[ch] += w * c[ch];
        }
    }
    out
}

/// Keys from 0 to `duration_s` for the decay of concentrations `r0` (see the module docs).
pub fn glow_keyframes(
    r0: &[f64],
    k_r_per_s: &[f64],
    rgb_per_state: &[[f64; 3]],
    duration_s: f64,
    tol: KeyframeTolerance,
) -> Result<GlowKeyframes> {
    if !(duration_s.is_finite() && duration_s > 0.0) {
        return Err(Error::invalid(
            "duration",
            format!("{duration_s} s; expected a finite duration > 0"),
        ));
    }
    if !(tol.rel_tol > 0.0 && tol.abs_tol >= 0.0 && tol.rel_tol.is_finite()) {
        return Err(Error::invalid(
            "tolerance",
            format!(
                "rel {} abs {}; expected rel > 0 and abs ≥ 0",
                tol.rel_tol, tol.abs_tol
            ),
        ));
    }
    let f = |t: f64| glow_rgb(r0, k_r_per_s, rgb_per_state, t);
    let peak = f(0.0).iter().fold(0.0f64, |m, v| m.max(v.abs()));
    // Ratio of the chord error to the allowed error over [a, b], on `n` inner points.
    let ratio = |a: f64, b: f64, n: usize| -> f64 {
        let (fa, fb) = (f(a), f(b));
        let mut worst = 0.0f64;
        for j in 1..n {
            let s = j as f64 / n as f64;
            let t = a + s * (b - a);
            let exact = f(t);
            for ch in 0..3 {
                let chord = fa[ch] + s * (fb[ch] - fa[ch]);
                let allowed = tol.rel_tol * exact[ch].abs() + tol.abs_tol * peak;
                let err = (chord - exact[ch]).abs();
                worst = worst.max(error_ratio(err, allowed));
            }
        }
        worst
    };
    const MAX_KEYS: usize = 100_000;
    let mut t_s = vec![0.0];
    let mut a = 0.0;
    while a < duration_s {
        // 2 % margin: the 64-point maximum can sit just below the true one.
        let fits = |b: f64| ratio(a, b, 64) <= 0.98;
        let mut b = duration_s;
        if !fits(b) {
            // Bisection on the segment end between a (fits trivially) and b (does not).
            let (mut lo, mut hi) = (a, b);
            for _ in 0..60 {
                let mid = 0.5 * (lo + hi);
                if fits(mid) {
                    lo = mid;
                } else {
                    hi = mid;
                }
                if hi - lo <= 1e-9 * duration_s {
                    break;
                }
            }
            b = lo;
            if b <= a {
                return Err(Error::Numerical {
                    what: "glow keyframes".into(),
                    reason: format!("no segment from t = {a} s meets the tolerance"),
                });
            }
        }
        t_s.push(b);
        a = b;
        if t_s.len() > MAX_KEYS {
            return Err(Error::invalid(
                "tolerance",
                format!(
                    "more than {MAX_KEYS} keys would be needed; loosen rel_tol/abs_tol or shorten the duration"
                ),
            ));
        }
    }
    let max_error = t_s
        .windows(2)
        .map(|w| ratio(w[0], w[1], 1000))
        .fold(0.0f64, f64::max);
    let rgb = t_s.iter().map(|&t| f(t)).collect();
    Ok(GlowKeyframes {
        t_s,
        rgb,
        max_error,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_single_exponential_needs_few_keys_and_stays_within_tolerance() {
        let c = [[1.0, 0.5, 0.2]];
        let k = glow_keyframes(&[1.0], &[0.2], &c, 60.0, KeyframeTolerance::default()).unwrap();
        assert!(k.max_error <= 1.0, "{}", k.max_error);
        assert!(k.t_s.len() > 3 && k.t_s.len() < 200, "{} keys", k.t_s.len());
        assert_eq!(*k.t_s.last().unwrap(), 60.0);
        // Interior keys are denser early (steep) than late (flat).
        assert!(k.t_s[1] - k.t_s[0] < k.t_s[k.t_s.len() - 1] - k.t_s[k.t_s.len() - 2]);
    }

    #[test]
    fn a_tighter_tolerance_needs_more_keys() {
        let c = [[1.0, 0.8, 0.1], [0.2, 0.9, 0.4]];
        let loose = glow_keyframes(
            &[1.0, 0.6],
            &[0.227, 0.0454],
            &c,
            120.0,
            KeyframeTolerance {
                rel_tol: 0.05,
                abs_tol: 1e-3,
            },
        )
        .unwrap();
        let tight = glow_keyframes(
            &[1.0, 0.6],
            &[0.227, 0.0454],
            &c,
            120.0,
            KeyframeTolerance {
                rel_tol: 0.001,
                abs_tol: 1e-5,
            },
        )
        .unwrap();
        assert!(tight.t_s.len() > loose.t_s.len());
        assert!(tight.max_error <= 1.0 && loose.max_error <= 1.0);
    }

    #[test]
    fn linear_interpolation_of_the_keys_is_within_tolerance_at_1000_random_times() {
        let (r0, k) = ([0.9, 0.7, 0.3], [0.5, 0.05, 0.005]);
        let c = [[0.9, 0.3, 0.1], [0.2, 1.0, 0.3], [0.1, 0.4, 1.0]];
        let tol = KeyframeTolerance::default();
        let keys = glow_keyframes(&r0, &k, &c, 600.0, tol).unwrap();
        let peak = glow_rgb(&r0, &k, &c, 0.0)
            .iter()
            .fold(0.0f64, |m, v| m.max(*v));
        let mut state = 0x1234_5678_u64;
        for _ in 0..1000 {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let t = 600.0 * ((state >> 11) as f64 / (1u64 << 53) as f64);
            let j = keys
                .t_s
                .partition_point(|&x| x <= t)
                .clamp(1, keys.t_s.len() - 1);
            let (a, b) = (keys.t_s[j - 1], keys.t_s[j]);
            let s = (t - a) / (b - a);
            let exact = glow_rgb(&r0, &k, &c, t);
            for ch in 0..3 {
                let lerp = keys.rgb[j - 1][ch] + s * (keys.rgb[j][ch] - keys.rgb[j - 1][ch]);
                let allowed = tol.rel_tol * exact[ch].abs() + tol.abs_tol * peak;
                assert!(
                    (lerp - exact[ch]).abs() <= allowed,
                    "t = {t}: {lerp} vs {}",
                    exact[ch]
                );
            }
        }
    }
}
