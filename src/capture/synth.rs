//! Synthetic frames for tests and planning: a uniform patch of known linear value with shot and
//! read noise, as a camera at given settings would record it.
//!
//! Noise model (shared with the LVF synthesiser): a pixel of noiseless value *v* (0–1 of full
//! scale) gets Gaussian noise of variance σ² = *n*² · *p* · (0.9 *v* + 0.1 *p*), where *n* is the
//! relative noise level and *p* the reference (peak) level: at *v* = *p* the standard deviation is
//! *n*·*p*, 90 % of the variance being shot noise (∝ *v*) and 10 % read noise. Values are clipped
//! to [0, 1]; pixels at 1 are flagged saturated.

use crate::capture::frame::RgbFrame;
use crate::capture::rng::SplitMix64;
use crate::error::{Error, Result};

/// Adds the documented shot + read noise to a noiseless value.
pub fn noisy_value(v: f64, noise: f64, peak: f64, rng: &mut SplitMix64) -> f64 {
    if noise <= 0.0 {
        return v;
    }
    let var = noise * noise * peak * (0.9 * v.max(0.0) + 0.1 * peak);
    v + var.sqrt() * rng.normal()
}

/// A `width × height` frame whose noiseless value is `value` (linear, 0–1) everywhere, with
/// relative noise `noise` at level `value` (see the module docs), clipped to [0, 1].
///
/// # Errors
/// [`Error::InvalidArgument`] for non-finite or negative inputs.
pub fn uniform_frame(
    name: &str,
    width: usize,
    height: usize,
    value: [f64; 3],
    noise: f64,
    seed: u64,
) -> Result<RgbFrame> {
    if !(noise.is_finite() && noise >= 0.0) || value.iter().any(|v| !v.is_finite() || *v < 0.0) {
        return Err(Error::invalid(
            "synthetic frame",
            "value and noise must be finite and non-negative",
        ));
    }
    let mut rng = SplitMix64::new(seed);
    let peak = value.iter().cloned().fold(0.0, f64::max).max(1e-6);
    let n = width * height;
    let mut data = Vec::with_capacity(3 * n);
    let mut sat = vec![0u8; n];
    for (i, s) in sat.iter_mut().enumerate() {
        let _ = i;
        for (c, &v) in value.iter().enumerate() {
            let x = noisy_value(v, noise, peak, &mut rng).clamp(0.0, 1.0);
            if x >= 1.0 {
                *s |= 1 << c;
            }
            data.push(x as f32);
        }
    }
    RgbFrame::new(name, width, height, 1, data, sat)
}
