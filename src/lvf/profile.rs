//! The profile along the filter axis: per camera channel, the mean over the ROI across the axis.
//!
//! A filter set up a little rotated in the image slants its iso-wavelength lines: each row (for
//! `--axis x`) sees the map shifted along the axis. The mean over the rows is then the mean of
//! shifted copies, and the strips across the axis, from which the radial fall-off is estimated,
//! differ by shifts the fall-off model takes for curvature (a 3° slant over 160 rows moved 400 and
//! 700 nm by +0.41 / −0.38 nm, noise-free, σ 0.01 nm). [`estimate_tilt`] measures the slant from
//! the strips' shifts against the mean profile, and [`extract_profile_tilted`] averages along the
//! iso-wavelength lines instead of the rows; `lvf.json` records it (`tilt`), and the downstream
//! readings through the filter ([`crate::lvf::LvfGeometry::band_readings`]) follow the same lines.

use crate::capture::RgbFrame;
use crate::error::{Error, Result};

/// The slant of the filter's iso-wavelength lines: the source pixel at (along `a`, across `b`)
/// sees the wavelength the map gives at `a + slope·(b − reference_px)`.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Tilt {
    /// Shift along the axis per pixel across it (tan of the angle between the iso-wavelength
    /// lines and the across direction).
    pub slope: f64,
    /// Coordinate across the axis (source px) whose row the profile's map describes.
    pub reference_px: f64,
    /// Standard uncertainty of `slope` (0 when given, not estimated).
    #[serde(default)]
    pub sigma: f64,
}

impl Tilt {
    /// The slant as an angle (degrees).
    pub fn degrees(&self) -> f64 {
        self.slope.atan().to_degrees()
    }
}

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
    /// The slant the ROI was averaged along ([`extract_profile_tilted`]); `None`: along the rows
    /// (columns for `--axis y`).
    pub tilt: Option<Tilt>,
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
    extract_profile_tilted(frame, roi, axis, None)
}

/// As [`extract_profile`], averaging along the slanted iso-wavelength lines of `tilt`: the
/// profile at `a` is the mean of the pixels at `a − slope·(b − reference_px)` over the positions
/// `b` across the axis, read by linear interpolation along the axis between two unsaturated
/// pixels inside the ROI (a pixel whose neighbours leave the ROI or saturate is left out, so the
/// ends average fewer pixels). `None`: exactly [`extract_profile`].
///
/// # Errors
/// As [`extract_profile`].
pub fn extract_profile_tilted(
    frame: &RgbFrame,
    roi: [usize; 4],
    axis: Axis,
    tilt: Option<&Tilt>,
) -> Result<Profile> {
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
    let scale = frame.pixel_scale as f64;
    let (along_lo, along_hi) = (along[0], along[along.len() - 1]);
    let at = |a: usize, b: usize| match axis {
        Axis::X => (a, b),
        Axis::Y => (b, a),
    };
    // the value the profile at frame position `a` takes from across position `b`
    let sample = |a: usize, b: usize| -> Option<[f64; 3]> {
        let Some(t) = tilt else {
            let (fx, fy) = at(a, b);
            if frame.saturation_bits(fx, fy) != 0 {
                return None;
            }
            return Some(frame.rgb(fx, fy).map(f64::from));
        };
        let f = a as f64 - t.slope * (frame.source_coordinate(b) - t.reference_px) / scale;
        let i0 = f.floor();
        let wt = f - i0;
        if i0 < along_lo as f64 || i0 > along_hi as f64 || (wt > 0.0 && i0 + 1.0 > along_hi as f64)
        {
            return None;
        }
        let i0 = i0 as usize;
        let (fx, fy) = at(i0, b);
        if frame.saturation_bits(fx, fy) != 0 {
            return None;
        }
        let v0 = frame.rgb(fx, fy).map(f64::from);
        if wt == 0.0 {
            return Some(v0);
        }
        let (gx, gy) = at(i0 + 1, b);
        if frame.saturation_bits(gx, gy) != 0 {
            return None;
        }
        let v1 = frame.rgb(gx, gy);
        Some(std::array::from_fn(|c| {
            v0[c] + wt * (f64::from(v1[c]) - v0[c])
        }))
    };
    for &a in along {
        let mut sum = [0.0; 3];
        let mut zero = [0usize; 3];
        let mut n = 0;
        let mut ssum = vec![[0.0; 3]; n_strips];
        let mut sn = vec![0usize; n_strips];
        for (k, &b) in across.iter().enumerate() {
            let Some(v) = sample(a, b) else {
                continue;
            };
            let s = strip_of(k);
            for c in 0..3 {
                sum[c] += v[c];
                ssum[s][c] += v[c];
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
        tilt: tilt.copied(),
    })
}

/// The slant measured from the strips ([`estimate_tilt`]).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct TiltEstimate {
    /// The fitted slant (its `reference_px` the ROI's middle across the axis).
    pub tilt: Tilt,
    /// Each strip's position across the axis (source px) and its shift along the axis against
    /// the mean profile (source px).
    pub strip_shifts: Vec<[f64; 2]>,
    /// The largest shift the slant makes inside the ROI (px, at the ROI's edge across the axis).
    pub max_shift_px: f64,
    /// Distance from `reference_px` to the ROI's edge across the axis (px).
    pub edge_px: f64,
    /// Whether the slant is worth averaging along: |slope| > [`TILT_T_MIN`] σ and a shift of at
    /// least [`TILT_MIN_SHIFT_PX`] at the ROI's edge.
    pub significant: bool,
}

/// A slant is followed when it is this many standard errors from zero (the standard error from
/// the scatter of 8 strips' shifts, so a t of 6 degrees of freedom: 5 is exceeded by chance on
/// 0.25 % of square images (3: on 2.4 %); with 3, a square image at 5 % noise was followed at −0.18°, harmless
/// but needless) …
pub const TILT_T_MIN: f64 = 5.0;
/// … and shifts the ROI's edge by at least this much (px; a 1° slant over 160 rows shifts the
/// edges by 1.4 px; below a quarter pixel the rows' mean is the middle row's to ≪ 0.01 nm).
pub const TILT_MIN_SHIFT_PX: f64 = 0.25;

/// Measures the slant of the iso-wavelength lines: each strip across the axis
/// ([`Profile::strips`]) is the mean profile shifted along the axis by `slope·(b − b₀)`, times a
/// smooth factor of its own (fall-off: per channel `g₀ + g₁u + g₂u²`, plus an offset). The shift
/// of each strip is found by Brent's method on the least-squares misfit (the mean profile
/// interpolated by Sprague's quintic, each channel scaled by its peak), and the slope by a straight
/// line through the shifts against the strips' positions, with its standard error from their
/// scatter. `None` when fewer than 4 strips hold data, the profile's positions are not evenly
/// spaced (a position saturated in every row) or the profile is flat.
pub fn estimate_tilt(profile: &Profile) -> Option<TiltEstimate> {
    use crate::math::interpolation::{is_uniform, Sprague};
    let n = profile.px.len();
    if profile.strips.len() < 4 || n < 16 || !is_uniform(&profile.px) {
        return None;
    }
    // strip totals, for the leave-one-out references below
    let mut total = [vec![0.0; n], vec![0.0; n], vec![0.0; n]];
    let mut total_n = vec![0.0; n];
    for st in &profile.strips {
        for i in 0..n {
            if st.counts[i] > 0 && (0..3).all(|c| st.values[c][i].is_finite()) {
                for (t, v) in total.iter_mut().zip(&st.values) {
                    t[i] += st.counts[i] as f64 * v[i];
                }
                total_n[i] += st.counts[i] as f64;
            }
        }
    }
    let all_rows: f64 = profile.strips.iter().flat_map(|s| &s.counts).sum::<usize>() as f64;
    let peak: Vec<f64> = profile
        .values
        .iter()
        .map(|v| v.iter().fold(0.0_f64, |m, &x| m.max(x.abs())))
        .collect();
    if peak.iter().all(|&p| p <= 0.0) {
        return None;
    }
    let (lo, hi) = (profile.px[0], profile.px[n - 1]);
    let mid = 0.5 * (lo + hi);
    let half = (0.5 * (hi - lo)).max(1.0);
    let across: Vec<f64> = profile.strips.iter().map(|s| s.across_px).collect();
    // the count-weighted mean position of the strips (where the rows' mean profile sits): the
    // straightened profile's map holds there
    let reference = profile
        .strips
        .iter()
        .map(|s| s.across_px * s.counts.iter().sum::<usize>() as f64)
        .sum::<f64>()
        / all_rows.max(1.0);
    // half the ROI's extent across the axis, from the strips' spacing
    let spacing = if across.len() > 1 {
        (across[across.len() - 1] - across[0]).abs() / (across.len() - 1) as f64
    } else {
        1.0
    };
    let edge = 0.5 * (across[across.len() - 1] - across[0]).abs() + 0.5 * spacing;
    let mut shifts = Vec::new();
    let mut levers = Vec::new();
    for strip in &profile.strips {
        // The reference is the mean of the *other* strips: against the mean of all, the strip's
        // own noise (1/8 of the mean's) draws a dip in the misfit at zero shift that pulled the
        // shifts of the inner strips to 0 (3° over 40 rows at 1 % noise measured 2.2°).
        let own = |c: usize, i: usize| {
            if strip.counts[i] > 0 && strip.values[c][i].is_finite() {
                strip.counts[i] as f64 * strip.values[c][i]
            } else {
                0.0
            }
        };
        let own_n = |i: usize| {
            if strip.counts[i] > 0 && (0..3).all(|c| strip.values[c][i].is_finite()) {
                strip.counts[i] as f64
            } else {
                0.0
            }
        };
        let reference_values: [Vec<f64>; 3] = std::array::from_fn(|c| {
            (0..n)
                .map(|i| {
                    let m = total_n[i] - own_n(i);
                    if m > 0.0 {
                        (total[c][i] - own(c, i)) / m
                    } else {
                        f64::NAN
                    }
                })
                .collect()
        });
        // Both sides smoothed alike (σ = 2 samples): interpolating white noise at a fractional
        // shift lowers its variance, which drew the misfit's minima of the inner strips towards
        // half-pixel shifts; smoothed, the noise has nothing left near the sampling frequency.
        let reference_spikes = spikes(&reference_values);
        let others: Option<Vec<Sprague>> = reference_values
            .iter()
            .map(|v| Sprague::new(&profile.px, &despiked_smooth(v, &reference_spikes)).ok())
            .collect();
        let Some(interp) = others else {
            continue;
        };
        let strip_rows = strip.counts.iter().sum::<usize>() as f64;
        let reach = 2.0 + 0.25 * (strip.across_px - reference).abs();
        // positions whose shifted reference stays inside the profile for every trial shift, less
        // single-position spikes (hot pixels: 200 of them at 0.1–0.5 of full scale scattered the
        // shifts by ±0.3 px)
        let spiky = spikes(&strip.values);
        let smooth: [Vec<f64>; 3] =
            std::array::from_fn(|c| despiked_smooth(&strip.values[c], &spiky));
        let idx: Vec<usize> = (0..n)
            .filter(|&i| {
                profile.px[i] - reach >= lo
                    && profile.px[i] + reach <= hi
                    && strip.counts[i] > 0
                    && (0..3).all(|c| strip.values[c][i].is_finite())
                    && !spiky[i]
            })
            .collect();
        if idx.len() < 16 {
            continue;
        }
        let misfit = |d: f64| -> f64 {
            let mut sse = 0.0;
            for c in 0..3 {
                if peak[c] <= 0.0 {
                    continue;
                }
                // least squares of the strip on [1, P, uP, u²P] with P the shifted mean profile
                let mut g = [[0.0; 4]; 4];
                let mut r = [0.0; 4];
                let mut yy = 0.0;
                for &i in &idx {
                    let u = (profile.px[i] - mid) / half;
                    let p = interp[c].eval(profile.px[i] + d) / peak[c];
                    let col = [1.0, p, u * p, u * u * p];
                    let yv = smooth[c][i] / peak[c];
                    for a in 0..4 {
                        r[a] += col[a] * yv;
                        for b in 0..4 {
                            g[a][b] += col[a] * col[b];
                        }
                    }
                    yy += yv * yv;
                }
                let Some(beta) = crate::math::linalg::solve_dense(
                    g.iter().map(|row| row.to_vec()).collect(),
                    r.to_vec(),
                ) else {
                    return f64::INFINITY;
                };
                sse += yy - beta.iter().zip(&r).map(|(b, r)| b * r).sum::<f64>();
            }
            sse
        };
        let d = crate::math::minimize::brent_min(misfit, -reach, reach, 1e-4);
        // a shift at the bracket's end is no minimum found
        if d.abs() < reach - 1e-3 && all_rows > strip_rows {
            shifts.push([strip.across_px, d]);
            // the others' mean sits at −n/(N−n) of this strip's own shift from the rows' mean,
            // so the measured shift is slope·(b − b̄)·N/(N − n)
            levers.push(all_rows / (all_rows - strip_rows));
        }
    }
    if shifts.len() < 4 {
        return None;
    }
    let xs: Vec<f64> = shifts
        .iter()
        .zip(&levers)
        .map(|(s, l)| (s[0] - reference) * l)
        .collect();
    let m = shifts.len() as f64;
    let xm = xs.iter().sum::<f64>() / m;
    let dm = shifts.iter().map(|s| s[1]).sum::<f64>() / m;
    let sxx: f64 = xs.iter().map(|x| (x - xm).powi(2)).sum();
    if sxx <= 0.0 {
        return None;
    }
    let slope = xs
        .iter()
        .zip(&shifts)
        .map(|(x, s)| (x - xm) * (s[1] - dm))
        .sum::<f64>()
        / sxx;
    let ss: f64 = xs
        .iter()
        .zip(&shifts)
        .map(|(x, s)| (s[1] - dm - slope * (x - xm)).powi(2))
        .sum();
    let sigma = (ss / (m - 2.0) / sxx).sqrt();
    let max_shift_px = slope.abs() * edge;
    let significant = slope.abs() > TILT_T_MIN * sigma && max_shift_px >= TILT_MIN_SHIFT_PX;
    Some(TiltEstimate {
        tilt: Tilt {
            slope,
            reference_px: reference,
            sigma,
        },
        strip_shifts: shifts,
        max_shift_px,
        edge_px: edge,
        significant,
    })
}

/// A spike's second difference is at least this fraction of the channel's peak ([`spikes`]).
const SPIKE_MIN_RELATIVE: f64 = 0.005;

/// Positions of `values` (per channel) at or beside a one-position spike: where a channel's
/// second difference `y[i] − (y[i−1] + y[i+1])/2` exceeds 8 robust standard deviations of its
/// own and [`SPIKE_MIN_RELATIVE`] of the channel's peak (a line blob spans tens of positions,
/// so its second differences are noise-sized).
fn spikes(values: &[Vec<f64>; 3]) -> Vec<bool> {
    let n = values[0].len();
    let mut flag = vec![false; n];
    if n < 5 {
        return flag;
    }
    for y in values {
        let e: Vec<f64> = (1..n - 1)
            .map(|i| y[i] - 0.5 * (y[i - 1] + y[i + 1]))
            .collect();
        let mut a: Vec<f64> = e
            .iter()
            .filter(|v| v.is_finite())
            .map(|v| v.abs())
            .collect();
        if a.is_empty() {
            continue;
        }
        let mid = a.len() / 2;
        let (_, med, _) = a.select_nth_unstable_by(mid, f64::total_cmp);
        // at least 0.5 % of the channel's peak: a blob's own curvature (FWHM 15 nm at 0.3 nm/px:
        // 0.25 % of its height) is no spike, and noise-free data have no noise to scale by
        let peak = y
            .iter()
            .filter(|v| v.is_finite())
            .fold(0.0_f64, |m, v| m.max(v.abs()));
        let limit = (8.0 * *med / 0.6745).max(SPIKE_MIN_RELATIVE * peak);
        if limit <= 0.0 {
            continue;
        }
        for (k, v) in e.iter().enumerate() {
            if v.abs() > limit {
                // e[k] is position k + 1; its neighbours carry half the spike
                for f in &mut flag[k..=(k + 2).min(n - 1)] {
                    *f = true;
                }
            }
        }
    }
    flag
}

/// The maximal runs of `true` in `mask`.
fn runs(mask: &[bool]) -> Vec<std::ops::Range<usize>> {
    let mut out = Vec::new();
    let mut i = 0;
    while i < mask.len() {
        if mask[i] {
            let start = i;
            while i < mask.len() && mask[i] {
                i += 1;
            }
            out.push(start..i);
        } else {
            i += 1;
        }
    }
    out
}

/// `values` with the flagged and non-finite samples replaced by the straight line between their
/// nearest good neighbours, then smoothed by a Gaussian of σ = 2 samples (±6; renormalised at
/// the ends).
fn despiked_smooth(values: &[f64], flagged: &[bool]) -> Vec<f64> {
    let n = values.len();
    let good = |i: usize| !flagged[i] && values[i].is_finite();
    let goods: Vec<usize> = (0..n).filter(|&i| good(i)).collect();
    if goods.is_empty() {
        return vec![0.0; n];
    }
    let mut filled = values.to_vec();
    for (i, f) in filled.iter_mut().enumerate() {
        if good(i) {
            continue;
        }
        let k = goods.partition_point(|&g| g < i);
        *f = match (k.checked_sub(1).map(|k| goods[k]), goods.get(k)) {
            (Some(a), Some(&b)) => {
                values[a] + (values[b] - values[a]) * (i - a) as f64 / (b - a) as f64
            }
            (Some(a), None) => values[a],
            (None, Some(&b)) => values[b],
            (None, None) => 0.0,
        };
    }
    let w: Vec<f64> = (0..=6).map(|k| (-0.125 * (k * k) as f64).exp()).collect();
    (0..n)
        .map(|i| {
            let (mut s, mut ws) = (0.0, 0.0);
            for (k, wk) in w.iter().enumerate() {
                for j in [i.checked_sub(k), (k > 0).then_some(i + k)]
                    .into_iter()
                    .flatten()
                {
                    if j < n {
                        s += wk * filled[j];
                        ws += wk;
                    }
                }
            }
            s / ws
        })
        .collect()
}

/// The profile of `roi` averaged along the filter's iso-wavelength lines: measured from the
/// strips ([`estimate_tilt`]) and, when significant, the ROI read again along the slant, measured
/// once more on the result and the two slopes added (the first is measured against a mean that
/// the slant itself blurred). Returns the profile and the estimate (`None` when the slant could
/// not be measured).
///
/// # Errors
/// As [`extract_profile`].
pub fn extract_profile_straightened(
    frame: &RgbFrame,
    roi: [usize; 4],
    axis: Axis,
) -> Result<(Profile, Option<TiltEstimate>)> {
    let straight = extract_profile(frame, roi, axis)?;
    let Some(mut est) = estimate_tilt(&straight) else {
        return Ok((straight, None));
    };
    if !est.significant {
        return Ok((straight, Some(est)));
    }
    let once = extract_profile_tilted(frame, roi, axis, Some(&est.tilt))?;
    if let Some(rest) = estimate_tilt(&once) {
        est.tilt.slope += rest.tilt.slope;
        est.tilt.sigma = rest.tilt.sigma;
        est.max_shift_px = est.tilt.slope.abs() * est.edge_px;
        est.significant = est.tilt.slope.abs() > TILT_T_MIN * est.tilt.sigma
            && est.max_shift_px >= TILT_MIN_SHIFT_PX;
        if !est.significant {
            return Ok((straight, Some(est)));
        }
    }
    let profile = extract_profile_tilted(frame, roi, axis, Some(&est.tilt))?;
    Ok((profile, Some(est)))
}

/// Largest slant (degrees, exclusive) of a filter's iso-wavelength lines that `lvf calibrate
/// --tilt` and `synth lvf-hg --tilt` take: beyond 45° the filter's axis is the other one.
pub const MAX_TILT_DEG: f64 = 45.0;

/// How the ROI is read across the axis (`lvf calibrate --tilt`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum TiltChoice {
    /// The slant measured from the strips and followed when significant
    /// ([`extract_profile_straightened`]).
    Auto,
    /// Along the rows (or columns), whatever the slant.
    Off,
    /// A slant given in degrees (|angle| < 45), about the ROI's middle across the axis.
    Degrees(f64),
}

impl std::str::FromStr for TiltChoice {
    type Err = Error;

    /// `auto`, `off` (any case) or an angle in degrees between −45 and 45.
    fn from_str(s: &str) -> Result<Self> {
        let t = s.trim();
        if t.eq_ignore_ascii_case("auto") {
            return Ok(TiltChoice::Auto);
        }
        if t.eq_ignore_ascii_case("off") {
            return Ok(TiltChoice::Off);
        }
        t.parse::<f64>()
            .ok()
            .filter(|d| d.is_finite() && d.abs() < MAX_TILT_DEG)
            .map(TiltChoice::Degrees)
            .ok_or_else(|| {
                Error::flag(
                    "--tilt",
                    format!(
                        "{t}: expected auto, off or an angle in degrees between -{MAX_TILT_DEG} and {MAX_TILT_DEG}"
                    ),
                )
            })
    }
}

/// The profile a calibration fits, as read from the image: along the slant chosen, with dust
/// repaired or not, and what was found on the way.
#[derive(Debug, Clone)]
pub struct PreparedProfile {
    /// The profile (its `tilt` the slant followed, if any).
    pub profile: Profile,
    /// The slant measured ([`TiltChoice::Auto`] only; `None` when it could not be measured).
    pub tilt_estimate: Option<TiltEstimate>,
    /// The dark patches replaced; `None` when they were not looked for.
    pub occlusions: Option<Vec<Occlusion>>,
}

/// Reads `roi` of `frame` for a calibration: across the axis as `tilt` says, then, when
/// `repair_dust`, local dark patches of single strips replaced ([`repair_occlusions`]).
///
/// # Errors
/// As [`extract_profile`].
pub fn prepare_profile(
    frame: &RgbFrame,
    roi: [usize; 4],
    axis: Axis,
    tilt: TiltChoice,
    repair_dust: bool,
) -> Result<PreparedProfile> {
    let (mut profile, tilt_estimate) = match tilt {
        TiltChoice::Auto => extract_profile_straightened(frame, roi, axis)?,
        TiltChoice::Off => (extract_profile(frame, roi, axis)?, None),
        TiltChoice::Degrees(deg) => {
            let [x, y, w, h] = roi;
            let reference_px = match axis {
                Axis::X => y as f64 + 0.5 * (h as f64 - 1.0),
                Axis::Y => x as f64 + 0.5 * (w as f64 - 1.0),
            };
            let tilt = Tilt {
                slope: deg.to_radians().tan(),
                reference_px,
                sigma: 0.0,
            };
            (extract_profile_tilted(frame, roi, axis, Some(&tilt))?, None)
        }
    };
    let occlusions = repair_dust.then(|| repair_occlusions(&mut profile));
    Ok(PreparedProfile {
        profile,
        tilt_estimate,
        occlusions,
    })
}

impl PreparedProfile {
    /// What lvf.json's `diagnostics` records of the reading: `occlusions` (when looked for) and
    /// `tilt` (when measured), each with a note saying how it was found.
    pub fn diagnostics(&self) -> serde_json::Map<String, serde_json::Value> {
        let mut d = serde_json::Map::new();
        if let Some(patches) = &self.occlusions {
            d.insert(
                "occlusions".into(),
                serde_json::json!({
                    "patches": patches,
                    "note": format!("local dark patches of single strips across the axis (a strip's relative residual against the other strips' mean times its own smooth level, combined over the channels weighted by (prediction / local robust scale)², below −{OCCLUSION_SIGMA} σ and −{} % over ≥ 3 positions, widened by 3), replaced by that prediction; a patch darkening every strip alike is not seen", 100.0 * OCCLUSION_DEPTH),
                }),
            );
        }
        if let Some(e) = &self.tilt_estimate {
            d.insert(
                "tilt".into(),
                serde_json::json!({
                    "slope": e.tilt.slope,
                    "degrees": e.tilt.degrees(),
                    "sigma": e.tilt.sigma,
                    "reference_px": e.tilt.reference_px,
                    "max_shift_px": e.max_shift_px,
                    "followed": self.profile.tilt.is_some(),
                    "strip_shifts_px": e.strip_shifts,
                    "note": format!("each strip across the axis fitted as the other strips' mean profile shifted along the axis (times its own smooth fall-off); the slope of those shifts against the strips' positions, followed when > {TILT_T_MIN}σ and the ROI's edge moves ≥ {TILT_MIN_SHIFT_PX} px (strip_shifts_px: the first pass, against the rows' mean)"),
                }),
            );
        }
        d
    }
}

/// A local dark patch in one strip across the axis (dust on the filter or the sensor, a
/// defect) that [`repair_occlusions`] replaced.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Occlusion {
    /// The strip's mean position across the axis (source px).
    pub across_px: f64,
    /// First and last position along the axis (source px).
    pub along_px: [f64; 2],
    /// Deepest relative dip of the strip against its prediction from the others.
    pub depth: f64,
}

/// A strip is dark there when its relative residual, combined over the channels, falls below
/// this many of its standard deviations (from the residual's local robust scale) …
pub const OCCLUSION_SIGMA: f64 = 5.0;
/// … and below this fraction.
pub const OCCLUSION_DEPTH: f64 = 0.02;
/// A channel counts where the strip's prediction exceeds this fraction of its peak.
pub const OCCLUSION_MIN_LEVEL: f64 = 0.02;

impl Occlusion {
    /// One line for the user: where the patch is, how deep, what was done.
    pub fn describe(&self) -> String {
        format!(
            "a dark patch (dust or a defect?) in the strip at {:.0} px across the axis, px {:.0}–{:.0} along it, {:.0} % deep: replaced by the strip's prediction from the others",
            self.across_px,
            self.along_px[0],
            self.along_px[1],
            100.0 * self.depth
        )
    }
}

/// Positions either side of a known patch on which [`repair_known_patches`] measures the strip's
/// ratio to the other strips.
pub const PATCH_FLANK: usize = 15;

/// Replaces patches found on another image of the same setup (the lamp photo's
/// [`repair_occlusions`], recorded in lvf.json): dust on the filter shadows every photo through
/// it at the same pixels. For each patch, the strip nearest its `across_px` (within half the
/// strips' spacing) is, per channel, the other strips' mean times the strip's own ratio to it,
/// fitted as a straight line over [`PATCH_FLANK`] positions either side of the patch, inside
/// `along_px`; the profile's mean is corrected by the same amount. Channels without a usable
/// ratio (fewer than 3 flank positions where the others' mean exceeds [`OCCLUSION_MIN_LEVEL`]
/// of its peak) are left as they are. Returns how many patches were replaced.
pub fn repair_known_patches(profile: &mut Profile, patches: &[Occlusion]) -> usize {
    let n = profile.px.len();
    let ns = profile.strips.len();
    if ns < 2 || n < 3 {
        return 0;
    }
    let spacing =
        (profile.strips[ns - 1].across_px - profile.strips[0].across_px).abs() / (ns - 1) as f64;
    let ok = |st: &Strip, i: usize| st.counts[i] > 0 && (0..3).all(|c| st.values[c][i].is_finite());
    let mut done = 0;
    for patch in patches {
        let Some(k) = (0..ns)
            .filter(|&k| (profile.strips[k].across_px - patch.across_px).abs() <= 0.5 * spacing)
            .min_by(|&a, &b| {
                let d = |k: usize| (profile.strips[k].across_px - patch.across_px).abs();
                d(a).total_cmp(&d(b))
            })
        else {
            continue;
        };
        let inside: Vec<usize> = (0..n)
            .filter(|&i| {
                profile.px[i] >= patch.along_px[0] - 0.5 && profile.px[i] <= patch.along_px[1] + 0.5
            })
            .collect();
        let (Some(&first), Some(&last)) = (inside.first(), inside.last()) else {
            continue;
        };
        let flank: Vec<usize> = (first.saturating_sub(PATCH_FLANK)..first)
            .chain(last + 1..(last + 1 + PATCH_FLANK).min(n))
            .collect();
        // the other strips' mean per channel at position i
        let others = |c: usize, i: usize| -> Option<f64> {
            let (mut sum, mut m) = (0.0, 0.0);
            for (j, st) in profile.strips.iter().enumerate() {
                if j != k && ok(st, i) {
                    sum += st.counts[i] as f64 * st.values[c][i];
                    m += st.counts[i] as f64;
                }
            }
            (m > 0.0).then(|| sum / m)
        };
        let mut replaced = false;
        let mut new_vals: Vec<(usize, usize, f64)> = Vec::new();
        for c in 0..3 {
            let peak = (0..n)
                .filter_map(|i| others(c, i))
                .fold(0.0_f64, |a, b| a.max(b.abs()));
            if peak <= 0.0 {
                continue;
            }
            // (px, ratio) on the flanks
            let pts: Vec<(f64, f64)> = flank
                .iter()
                .filter(|&&i| ok(&profile.strips[k], i))
                .filter_map(|&i| {
                    let o = others(c, i)?;
                    (o > OCCLUSION_MIN_LEVEL * peak)
                        .then(|| (profile.px[i], profile.strips[k].values[c][i] / o))
                })
                .collect();
            if pts.len() < 3 {
                continue;
            }
            let m = pts.len() as f64;
            let xm = pts.iter().map(|p| p.0).sum::<f64>() / m;
            let ym = pts.iter().map(|p| p.1).sum::<f64>() / m;
            let sxx: f64 = pts.iter().map(|p| (p.0 - xm).powi(2)).sum();
            let slope = if sxx > 0.0 {
                pts.iter().map(|p| (p.0 - xm) * (p.1 - ym)).sum::<f64>() / sxx
            } else {
                0.0
            };
            for &i in &inside {
                if let Some(o) = others(c, i) {
                    new_vals.push((c, i, (ym + slope * (profile.px[i] - xm)) * o));
                }
            }
            replaced = true;
        }
        for (c, i, v) in new_vals {
            let st = &mut profile.strips[k];
            if st.counts[i] == 0 || !st.values[c][i].is_finite() {
                continue;
            }
            let w = st.counts[i] as f64 / profile.counts[i].max(1) as f64;
            profile.values[c][i] += w * (v - st.values[c][i]);
            st.values[c][i] = v;
        }
        done += usize::from(replaced);
    }
    done
}

/// Finds and replaces local dark patches of single strips: dust on the filter casts a soft
/// shadow a few tens of pixels wide, which the mean over the ROI draws as a dip under whatever
/// line lies there (three specks 35 % deep moved 400 / 700 nm by −0.61 / +0.69 nm,
/// `scripts/reference/lvf_robustness.py` case 36). Each strip is predicted from the mean of the
/// others times its own smooth level (per channel a + (g₀ + g₁u + g₂u²)·mean, both smoothed as
/// in [`estimate_tilt`]); where its relative residual, combined over the channels (dust is
/// grey; each channel weighted by (prediction / local robust scale of its residual)²), lies
/// below −[`OCCLUSION_SIGMA`] of its σ and −[`OCCLUSION_DEPTH`] over ≥ 3 positions
/// (widened by 3 either side), the strip's values are replaced by that prediction and the
/// profile's mean corrected by the same amount. The fit is repeated once without the flagged
/// positions. Needs ≥ 4 strips; a patch that darkens every strip alike is not seen.
pub fn repair_occlusions(profile: &mut Profile) -> Vec<Occlusion> {
    let n = profile.px.len();
    let ns = profile.strips.len();
    let mut found = Vec::new();
    if ns < 4 || n < 16 {
        return found;
    }
    let (lo, hi) = (profile.px[0], profile.px[n - 1]);
    let mid = 0.5 * (lo + hi);
    let half = (0.5 * (hi - lo)).max(1.0);
    let ok = |st: &Strip, i: usize| st.counts[i] > 0 && (0..3).all(|c| st.values[c][i].is_finite());
    let mut total = [vec![0.0; n], vec![0.0; n], vec![0.0; n]];
    let mut total_n = vec![0.0; n];
    for st in &profile.strips {
        for i in (0..n).filter(|&i| ok(st, i)) {
            for (t, v) in total.iter_mut().zip(&st.values) {
                t[i] += st.counts[i] as f64 * v[i];
            }
            total_n[i] += st.counts[i] as f64;
        }
    }
    let peak: Vec<f64> = profile
        .values
        .iter()
        .map(|v| v.iter().fold(0.0_f64, |m, &x| m.max(x.abs())))
        .collect();
    // (strip, position, predicted values) to replace
    let mut replace: Vec<(usize, usize, [f64; 3])> = Vec::new();
    for (k, st) in profile.strips.iter().enumerate() {
        let own_n: Vec<f64> = (0..n)
            .map(|i| if ok(st, i) { st.counts[i] as f64 } else { 0.0 })
            .collect();
        let others: [Vec<f64>; 3] = std::array::from_fn(|c| {
            (0..n)
                .map(|i| {
                    let m = total_n[i] - own_n[i];
                    if m > 0.0 {
                        (total[c][i] - own_n[i] * st.values[c][i].max(f64::MIN)) / m
                    } else {
                        f64::NAN
                    }
                })
                .collect()
        });
        let none = vec![false; n];
        let others_s: [Vec<f64>; 3] = std::array::from_fn(|c| despiked_smooth(&others[c], &none));
        let own_s: [Vec<f64>; 3] = std::array::from_fn(|c| despiked_smooth(&st.values[c], &none));
        let mut flagged = vec![false; n];
        let mut pred = [vec![0.0; n], vec![0.0; n], vec![0.0; n]];
        for _pass in 0..2 {
            // per channel the smoothed residual, its local robust scale (±50 positions, flagged
            // ones left out) and the prediction; combined over the channels as a relative dip
            // weighted by (prediction / scale)² — dust is grey, and a dim channel's relative
            // residual is noisy
            let mut wsum = vec![0.0; n];
            let mut esum = vec![0.0; n];
            for c in 0..3 {
                if peak[c] <= 0.0 {
                    continue;
                }
                let mut g = vec![vec![0.0; 4]; 4];
                let mut r = vec![0.0; 4];
                let cols = |i: usize| {
                    let u = (profile.px[i] - mid) / half;
                    let m = others_s[c][i];
                    [1.0, m, u * m, u * u * m]
                };
                for i in (0..n).filter(|&i| !flagged[i] && ok(st, i) && others_s[c][i].is_finite())
                {
                    let x = cols(i);
                    for a in 0..4 {
                        r[a] += x[a] * own_s[c][i];
                        for b in 0..4 {
                            g[a][b] += x[a] * x[b];
                        }
                    }
                }
                let Some(beta) = crate::math::linalg::solve_dense(g, r) else {
                    continue;
                };
                for (i, pi) in pred[c].iter_mut().enumerate() {
                    *pi = cols(i).iter().zip(&beta).map(|(x, b)| x * b).sum();
                }
                let res: Vec<f64> = (0..n)
                    .map(|i| {
                        if ok(st, i) {
                            own_s[c][i] - pred[c][i]
                        } else {
                            f64::NAN
                        }
                    })
                    .collect();
                for i in 0..n {
                    let f = pred[c][i];
                    if f.is_nan() || f <= OCCLUSION_MIN_LEVEL * peak[c] || !res[i].is_finite() {
                        continue;
                    }
                    let mut win: Vec<f64> = (i.saturating_sub(50)..(i + 51).min(n))
                        .filter(|&j| !flagged[j] && res[j].is_finite())
                        .map(|j| res[j].abs())
                        .collect();
                    if win.len() < 10 {
                        continue;
                    }
                    let m = win.len() / 2;
                    let (_, med, _) = win.select_nth_unstable_by(m, f64::total_cmp);
                    let scale = (*med / 0.6745).max(1e-12 * peak[c]);
                    let w = (f / scale).powi(2);
                    wsum[i] += w;
                    esum[i] += w * res[i] / f;
                }
            }
            // the combined relative dip and its standard deviation
            let dark: Vec<bool> = (0..n)
                .map(|i| {
                    wsum[i] > 0.0 && {
                        let e = esum[i] / wsum[i];
                        e < -OCCLUSION_DEPTH && e < -OCCLUSION_SIGMA / wsum[i].sqrt()
                    }
                })
                .collect();

            let mut next = vec![false; n];
            for r in runs(&dark).into_iter().filter(|r| r.len() >= 3) {
                for f in &mut next[r.start.saturating_sub(3)..(r.end + 3).min(n)] {
                    *f = true;
                }
            }
            if next == flagged {
                break;
            }
            flagged = next;
        }
        // runs of flagged positions: report and replace
        for r in runs(&flagged) {
            let mut depth = 0.0_f64;
            for i in r.clone().filter(|&i| ok(st, i)) {
                let mut d = 0.0;
                let mut m = 0;
                for c in (0..3).filter(|&c| pred[c][i] > OCCLUSION_MIN_LEVEL * peak[c]) {
                    d += (pred[c][i] - st.values[c][i]) / pred[c][i];
                    m += 1;
                }
                if m > 0 {
                    depth = depth.max(d / m as f64);
                }
                replace.push((k, i, [pred[0][i], pred[1][i], pred[2][i]]));
            }
            found.push(Occlusion {
                across_px: st.across_px,
                along_px: [profile.px[r.start], profile.px[r.end - 1]],
                depth,
            });
        }
    }
    for (k, i, p) in replace {
        let st = &mut profile.strips[k];
        let w = st.counts[i] as f64 / profile.counts[i].max(1) as f64;
        for ((pv, sv), pc) in profile.values.iter_mut().zip(st.values.iter_mut()).zip(p) {
            pv[i] += w * (pc - sv[i]);
            sv[i] = pc;
        }
    }
    found
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A frame of Gaussian blobs (σ 30 px) along x whose iso-lines slant by `slope`, optionally
    /// binned 2×2 (`scale`), with saturated pixels where the value reaches 1.
    fn slanted(w: usize, h: usize, slope: f64, scale: usize) -> RgbFrame {
        let (fw, fh) = (w / scale, h / scale);
        let b0 = (h as f64 - 1.0) / 2.0;
        let mut data = Vec::new();
        let mut sat = Vec::new();
        for fy in 0..fh {
            for fx in 0..fw {
                let (x, y) = (
                    (fx * scale) as f64 + (scale as f64 - 1.0) / 2.0,
                    (fy * scale) as f64 + (scale as f64 - 1.0) / 2.0,
                );
                let a = x + slope * (y - b0);
                let g = |c: f64| (-0.5 * ((a - c) / 30.0).powi(2)).exp();
                // several blobs per channel, as lamp lines through a camera
                let px = [
                    0.02 + 0.7 * g(150.0) + 0.2 * g(300.0) + 0.1 * g(480.0),
                    0.02 + 0.1 * g(150.0) + 0.7 * g(300.0) + 0.3 * g(480.0),
                    0.02 + 0.05 * g(150.0) + 0.3 * g(300.0) + 0.7 * g(480.0),
                ];
                sat.push(u8::from(px.iter().any(|&p| p >= 1.0)));
                data.extend(px.iter().map(|&p| p as f32));
            }
        }
        RgbFrame::new("slanted", fw, fh, scale, data, sat).unwrap()
    }

    /// `--tilt` takes auto / off in any case and angles strictly inside ±45°; anything else
    /// is an error naming what was given.
    #[test]
    fn tilt_choice_parses_auto_off_and_angles_only() {
        assert_eq!(" Auto ".parse::<TiltChoice>().unwrap(), TiltChoice::Auto);
        assert_eq!("OFF".parse::<TiltChoice>().unwrap(), TiltChoice::Off);
        assert_eq!(
            "-44.5".parse::<TiltChoice>().unwrap(),
            TiltChoice::Degrees(-44.5)
        );
        assert_eq!("3".parse::<TiltChoice>().unwrap(), TiltChoice::Degrees(3.0));
        for bad in ["45", "-90", "nan", "inf", "three", ""] {
            let e = bad.parse::<TiltChoice>().unwrap_err().to_string();
            assert!(e.contains("expected auto, off"), "{bad}: {e}");
        }
    }
    #[test]
    fn the_slope_of_a_slanted_frame_is_measured_and_followed_also_when_binned() {
        for scale in [1, 2] {
            let f = slanted(600, 96, 0.05, scale);
            let (p, est) = extract_profile_straightened(&f, [0, 0, 600, 96], Axis::X).unwrap();
            let est = est.unwrap();
            assert!(est.significant);
            assert!((est.tilt.slope - 0.05).abs() < 1e-3, "{scale}: {est:?}");
            assert!((est.tilt.reference_px - 47.5).abs() < 1e-9);
            // along the slant the profile is the reference row's: the square frame's
            let centroid = |p: &Profile| {
                let (num, den) =
                    p.px.iter()
                        .zip(&p.values[1])
                        .filter(|(x, _)| (200.0..400.0).contains(*x))
                        .fold((0.0, 0.0), |(n, d), (x, v)| (n + x * v, d + v));
                num / den
            };
            let sq = slanted(600, 96, 0.0, scale);
            let (p0, e0) = extract_profile_straightened(&sq, [0, 0, 600, 96], Axis::X).unwrap();
            assert!(
                (centroid(&p) - centroid(&p0)).abs() < 0.02,
                "{scale}: {} vs {}",
                centroid(&p),
                centroid(&p0)
            );
            let rows = extract_profile(&f, [0, 0, 600, 96], Axis::X).unwrap();
            eprintln!("binning {scale}: slope {:.5} ± {:.1e}; centroid along the slant {:.4}, along the rows {:.4}, square {:.4}", est.tilt.slope, est.tilt.sigma, centroid(&p), centroid(&rows), centroid(&p0));
            // a square frame is read along the rows, exactly as extract_profile
            assert!(!e0.unwrap().significant);
            assert_eq!(p0, extract_profile(&sq, [0, 0, 600, 96], Axis::X).unwrap());
        }
    }

    #[test]
    fn spikes_are_flagged_and_bridged_but_a_blob_is_not() {
        // a blob with white noise (xorshift, uniform ±0.5e-3)
        let mut state = 0x2545_f491_4f6c_dd1d_u64;
        let mut noise = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let blob: Vec<f64> = (0..200)
            .map(|i| (-0.5 * ((i as f64 - 100.0) / 20.0).powi(2)).exp() + 1e-3 * noise())
            .collect();
        let mut v = blob.clone();
        v[60] += 0.5;
        let flags = spikes(&[v.clone(), blob.clone(), blob.clone()]);
        // the spike and, as its neighbours' second differences carry half of it, two either side
        assert!(flags[59] && flags[60] && flags[61]);
        assert!(
            flags
                .iter()
                .enumerate()
                .all(|(i, &f)| !f || (58..=62).contains(&i)),
            "{flags:?}"
        );
        let clean = spikes(&[blob.clone(), blob.clone(), blob.clone()]);
        assert!(clean.iter().all(|&f| !f));
        let s = despiked_smooth(&v, &flags);
        let s0 = despiked_smooth(&blob, &clean);
        assert!((s[60] - s0[60]).abs() < 0.01, "{} vs {}", s[60], s0[60]);
        let flat = despiked_smooth(&[2.0; 30], &[false; 30]);
        assert!(flat.iter().all(|x| (x - 2.0).abs() < 1e-12));
    }
}
