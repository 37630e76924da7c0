//! Curve helpers: linear interpolation, half-maximum width and centroid of a sampled band.

#![allow(clippy::needless_range_loop)]

use super::*;

/// Linear interpolation of (x, y) at `l`; None outside [x0, xn].
pub(super) fn lerp(x: &[f64], y: &[f64], l: f64) -> Option<f64> {
    let n = x.len();
    if n == 0 || l < x[0] - 1e-9 || l > x[n - 1] + 1e-9 {
        return None;
    }
    if n == 1 {
        return Some(y[0]);
    }
    let i = x.partition_point(|&v| v <= l).clamp(1, n - 1);
    let f = ((l - x[i - 1]) / (x[i] - x[i - 1])).clamp(0.0, 1.0);
    Some(y[i - 1] + f * (y[i] - y[i - 1]))
}

pub(super) fn interp_band(
    x: &[f64],
    y: &[f64],
    grid: &[f64],
    j: usize,
    nm: f64,
) -> Result<Vec<f64>> {
    let peak = y.iter().cloned().fold(0.0, f64::max);
    let n = x.len();
    let zero_lo = y[0].abs() <= 1e-6 * peak;
    let zero_hi = y[n - 1].abs() <= 1e-6 * peak;
    grid.iter()
        .map(|&l| match lerp(x, y, l) {
            Some(v) => Ok(v),
            None if l < x[0] && zero_lo => Ok(0.0),
            None if l > x[n - 1] && zero_hi => Ok(0.0),
            None => Err(Error::invalid(
                "--grid",
                format!(
                    "{l} nm is outside the band transmissions' grid {}–{} nm and band {} ({nm} nm) is not zero at that end; choose a grid inside {}–{} nm or re-solve the bands on a wider grid",
                    x[0], x[n - 1], j + 1, x[0], x[n - 1]
                ),
            )),
        })
        .collect()
}

/// Half-maximum width and mid-point of a sampled curve (linear interpolation of the crossings
/// next to the global maximum); None when a side never falls to half.
pub fn half_max_width(x: &[f64], y: &[f64]) -> Option<(f64, f64)> {
    let (imax, &peak) = y
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.partial_cmp(b.1).unwrap_or(std::cmp::Ordering::Equal))?;
    if peak.is_nan() || peak <= 0.0 {
        return None;
    }
    let half = peak / 2.0;
    let mut left = None;
    for i in (0..imax).rev() {
        if y[i] <= half {
            let f = (half - y[i]) / (y[i + 1] - y[i]);
            left = Some(x[i] + f * (x[i + 1] - x[i]));
            break;
        }
    }
    let mut right = None;
    for i in imax + 1..y.len() {
        if y[i] <= half {
            let f = (half - y[i]) / (y[i - 1] - y[i]);
            right = Some(x[i] - f * (x[i] - x[i - 1]));
            break;
        }
    }
    let (l, r) = (left?, right?);
    Some((r - l, (r + l) / 2.0))
}

/// Centroid Σλ·T / ΣT of a sampled curve on a uniform grid and its standard uncertainty from
/// independent per-sample std (NaN when ΣT ≤ 0).
pub(super) fn centroid(x: &[f64], t: &[f64], std: &[f64]) -> (f64, f64) {
    let s: f64 = t.iter().sum();
    if s.is_nan() || s <= 0.0 {
        return (f64::NAN, f64::NAN);
    }
    let c = x.iter().zip(t).map(|(l, v)| l * v).sum::<f64>() / s;
    let var: f64 = x
        .iter()
        .zip(std)
        .map(|(l, sd)| ((l - c) / s * sd).powi(2))
        .sum();
    (c, var.sqrt())
}
