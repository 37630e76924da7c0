//! The profile along the filter axis: per camera channel, the mean over the ROI across the axis.

use crate::capture::RgbFrame;
use crate::error::{Error, Result};

/// Direction of the filter's wavelength gradient in the image.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Axis {
    /// Wavelength varies along columns (x).
    X,
    /// Wavelength varies along rows (y).
    Y,
}

/// A profile along the axis.
#[derive(Debug, Clone, PartialEq)]
pub struct Profile {
    /// The axis.
    pub axis: Axis,
    /// ROI `[x, y, w, h]` in source pixels.
    pub roi: [usize; 4],
    /// Position of each sample along the axis, in source pixels.
    pub px: Vec<f64>,
    /// Mean per channel at each position (saturated pixels left out).
    pub values: [Vec<f64>; 3],
    /// Number of pixels averaged at each position.
    pub counts: Vec<usize>,
    /// Name of the image.
    pub source: String,
}

/// Averages `frame` over the ROI `[x, y, w, h]` (source pixels) across `axis`.
///
/// # Errors
/// [`Error::InvalidArgument`] when the ROI leaves the frame, holds fewer than 8 positions along
/// the axis, or more than half of its positions are entirely saturated.
pub fn extract_profile(frame: &RgbFrame, roi: [usize; 4], axis: Axis) -> Result<Profile> {
    let [x, y, w, h] = roi;
    let (sw, sh) = frame.source_size();
    if w == 0 || h == 0 || x + w > sw || y + h > sh {
        return Err(Error::invalid(
            "ROI",
            format!(
                "{x},{y},{w},{h} extends outside {} ({sw}×{sh} pixels); expected x+w ≤ {sw}, y+h ≤ {sh}",
                frame.name
            ),
        ));
    }
    let inside =
        |c: f64, lo: usize, len: usize| c >= lo as f64 - 0.5 && c < (lo + len) as f64 - 0.5;
    let xs: Vec<usize> = (0..frame.width)
        .filter(|&i| inside(frame.source_coordinate(i), x, w))
        .collect();
    let ys: Vec<usize> = (0..frame.height)
        .filter(|&i| inside(frame.source_coordinate(i), y, h))
        .collect();
    let (along, across) = match axis {
        Axis::X => (&xs, &ys),
        Axis::Y => (&ys, &xs),
    };
    if along.len() < 8 || across.is_empty() {
        return Err(Error::invalid(
            "ROI",
            format!(
                "{x},{y},{w},{h} of {} covers {} positions along the axis; at least 8 are needed",
                frame.name,
                along.len()
            ),
        ));
    }
    let mut px = Vec::new();
    let mut values: [Vec<f64>; 3] = Default::default();
    let mut counts = Vec::new();
    let mut n_all_saturated = 0;
    for &a in along {
        let mut sum = [0.0; 3];
        let mut n = 0;
        for &b in across {
            let (fx, fy) = match axis {
                Axis::X => (a, b),
                Axis::Y => (b, a),
            };
            if frame.saturation_bits(fx, fy) != 0 {
                continue;
            }
            let v = frame.rgb(fx, fy);
            for c in 0..3 {
                sum[c] += f64::from(v[c]);
            }
            n += 1;
        }
        if n == 0 {
            n_all_saturated += 1;
            continue;
        }
        px.push(frame.source_coordinate(a));
        for c in 0..3 {
            values[c].push(sum[c] / n as f64);
        }
        counts.push(n);
    }
    if 2 * n_all_saturated > along.len() || px.len() < 8 {
        return Err(Error::invalid(
            "ROI",
            format!(
                "{x},{y},{w},{h} of {} is saturated at {n_all_saturated} of {} positions; use a shorter exposure",
                frame.name,
                along.len()
            ),
        ));
    }
    Ok(Profile {
        axis,
        roi,
        px,
        values,
        counts,
        source: frame.name.clone(),
    })
}
