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
    /// The ROI cut across the axis into strips ([`N_STRIPS`]), for the vignetting estimate of
    /// [`crate::lvf::background::estimate_radial_falloff`].
    pub strips: Vec<Strip>,
    /// Size of the source image `[w, h]` (px): its centre is taken as the optical centre.
    pub frame_size: [usize; 2],
    /// Noise clipped at black undone in `values` ([`crate::lvf::censored`]), `None` when no
    /// pixel was clipped or the noise could not be estimated.
    pub censoring: Option<crate::lvf::censored::Censoring>,
}

/// A strip of the ROI across the axis: its mean per channel at the profile's positions.
#[derive(Debug, Clone, PartialEq)]
pub struct Strip {
    /// Mean position across the axis (source px).
    pub across_px: f64,
    /// Mean per channel at each of the profile's positions (NaN where every pixel of the strip
    /// is saturated there).
    pub values: [Vec<f64>; 3],
    /// Pixels averaged at each position.
    pub counts: Vec<usize>,
}

/// Strips across the axis (fewer when the ROI is narrower than 2 px per strip).
pub const N_STRIPS: usize = 8;

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
    let mut zeros: Vec<[usize; 3]> = Vec::new();
    let n_strips = N_STRIPS.min(across.len() / 2).max(1);
    let strip_of = |k: usize| k * n_strips / across.len();
    let mut strips: Vec<Strip> = (0..n_strips)
        .map(|s| {
            let members: Vec<f64> = across
                .iter()
                .enumerate()
                .filter(|(k, _)| strip_of(*k) == s)
                .map(|(_, &b)| frame.source_coordinate(b))
                .collect();
            Strip {
                across_px: members.iter().sum::<f64>() / members.len().max(1) as f64,
                values: Default::default(),
                counts: Vec::new(),
            }
        })
        .collect();
    let mut n_all_saturated = 0;
    for &a in along {
        let mut sum = [0.0; 3];
        let mut zero = [0usize; 3];
        let mut n = 0;
        let mut ssum = vec![[0.0; 3]; n_strips];
        let mut sn = vec![0usize; n_strips];
        for (k, &b) in across.iter().enumerate() {
            let (fx, fy) = match axis {
                Axis::X => (a, b),
                Axis::Y => (b, a),
            };
            if frame.saturation_bits(fx, fy) != 0 {
                continue;
            }
            let v = frame.rgb(fx, fy);
            let s = strip_of(k);
            for c in 0..3 {
                sum[c] += f64::from(v[c]);
                ssum[s][c] += f64::from(v[c]);
                zero[c] += usize::from(v[c] <= 0.0);
            }
            n += 1;
            sn[s] += 1;
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
        zeros.push(zero);
        for (s, st) in strips.iter_mut().enumerate() {
            for (c, col) in st.values.iter_mut().enumerate() {
                col.push(if sn[s] > 0 {
                    ssum[s][c] / sn[s] as f64
                } else {
                    f64::NAN
                });
            }
            st.counts.push(sn[s]);
        }
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
    let censoring = crate::lvf::censored::decensor(&mut values, &counts, &zeros);
    Ok(Profile {
        axis,
        roi,
        px,
        values,
        counts,
        source: frame.name.clone(),
        strips,
        frame_size: [sw, sh],
        censoring,
    })
}
