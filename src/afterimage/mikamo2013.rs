//! Perceptually inspired afterimage synthesis (Mikamo, Slomp, Raytchev, Tamaki & Kaneda 2013,
//! *Computers & Graphics* 37, §3).
//!
//! **Curves** (the model's transitions, model time `t_s` in seconds, 0–80 s):
//!
//! ```text
//! Y_M(t) = exp(−0.083·t − 0.978)   (t ≤ 22 s)                                  (Eq. 3)
//!          exp(−0.055·t − 1.584)   (t > 22 s)
//! (x_M, y_M)(t): Table 1 (every 4 s from 0 to 80 s), uniform Catmull-Rom between samples
//! (L_M, a_M, b_M)(t) = Lab(xyY → XYZ of (x_M, y_M, Y_M)), white D65, Yn = 1
//! τ_M(t) = L_M(t) / L_M(0)
//! ```
//!
//! Padgham's measurements start 20 s after the stimulus; the paper moves his time axis by 20 s
//! so that model time 0 is his 20 s. Table 1 is printed on the moved axis (it starts at 0 s), and
//! Eq. 3 is taken to be on the same axis (the paper says "the same applies for the luminance
//! transition"), so both are used as printed. The two branches of Eq. 3 differ by 1 % at 22 s
//! (exp(−2.804) vs exp(−2.794)); the printed coefficients are kept, not smoothed.
//!
//! Catmull-Rom end points: phantom samples P₋₁ = 2P₀ − P₁ and P₂₁ = 2P₂₀ − P₁₉ (the tangent at
//! an end is the one-sided difference). At every Table 1 time the interpolant returns the table
//! value exactly (u = 0 ⇒ q = P_i in floating point).
//!
//! **Frames** (Eq. 1–2, 4–7, §3.2, §3.7–3.9), per pixel (i, j) of the input I_on (linear sRGB):
//!
//! ```text
//! XYZ_on = M_RGB→XYZ · max(RGB, 0) / Y_on^max           (normalisation: brightest pixel Y = 1)
//! mask:   Y_on ≥ θ and Y_on > 0                           (θ = mask threshold, relative)
//! I′_on = I_on inside the mask, 0 outside
//! I^R_on = xyY(x_R, y_R, Y′_on)                            (§3.2: reference chromaticity)
//! Δa = a′_on − a^R_on,  Δb = b′_on − b^R_on               (Eq. 1–2; Lab with white D65, Yn = 1)
//! Z = (L′_on / L′_on^max)^γ                                (L′_on^max = 100 after normalisation)
//! L_A = L_M(t)·Z,  a_A = a_M(t)·Z + τ_M(t)·Δa·k,  b_A = b_M(t)·Z + τ_M(t)·Δb·k   (Eq. 4–6)
//! RGB_A = M_XYZ→RGB · XYZ(Lab_A) (M: sRGB primaries' NPM, see [`display_matrices`]); negatives clamped to 0, then scaled so that Y (hence L*) is
//!         the Y of Lab_A again                             (§3.7)
//! A = Gaussian(σ) * RGB_A                                  (§3.8, separable, edges clamped)
//! frame = A + w(t)·I_off,  w(t) = 1 − (1 − c)·e^(−t/T)     (Eq. 7 with Y_ini = c·Y_off, Y_end = Y_off)
//! ```
//!
//! Units: time in s, chromaticities CIE 1931 xy, XYZ on the 0–1 scale (display white Y = 1), Lab
//! in CIE units, frames in linear sRGB (display white = 1; values above 1 are possible and are
//! clipped only when encoded). The choices the paper leaves open (mask rule, white point and Y
//! scale, reference light, Eq. 7's constants and which image is the dark one) are argued in
//! `docs/afterimage.md`.
//!
//! No colour-science counterpart exists; the colour conversions are those of
//! [`crate::colorimetry`] (`colour.xyY_to_XYZ`, `colour.XYZ_to_Lab`, `colour.Lab_to_XYZ`,
//! `colour.XYZ_to_sRGB` with D65 and no adaptation).

use rayon::prelude::*;

use crate::colorimetry::lab::{
    intermediate_lightness_cie1976, intermediate_luminance_cie1976, xyz_to_lab,
};
use crate::colorimetry::rgb::{normalised_primary_matrix, RgbSpace, D65_XY};
use crate::colorimetry::xyy::{xy_to_xyz, xyy_to_xyz};
use crate::error::{Error, Result};
use crate::math::linalg::{mat3_inv, mat3_mul_vec, Mat3};

/// The display's RGB ↔ XYZ matrices: the normalised primary matrix of the sRGB primaries and
/// D65, and its exact inverse `(rgb_to_xyz, xyz_to_rgb)`. colour's published 4-decimal sRGB
/// matrices are not inverses of each other (they differ by ≈ 1e-4), which would move a
/// reference-coloured patch off the Table 1 track by that much; the model needs a round trip.
pub fn display_matrices() -> Result<(Mat3, Mat3)> {
    let space = RgbSpace::srgb()?;
    let to_xyz = normalised_primary_matrix(space.primaries_xy, space.whitepoint_xy)?;
    let to_rgb = mat3_inv(&to_xyz)?;
    Ok((to_xyz, to_rgb))
}

/// Table 1 sample times, s (every 4 s from 0 to 80 s).
pub const TABLE1_T_S: [f64; 21] = [
    0.0, 4.0, 8.0, 12.0, 16.0, 20.0, 24.0, 28.0, 32.0, 36.0, 40.0, 44.0, 48.0, 52.0, 56.0, 60.0,
    64.0, 68.0, 72.0, 76.0, 80.0,
];

/// Table 1 chromaticities (x_M, y_M) of Padgham's afterimage colour sequence, CIE 1931 xy.
pub const TABLE1_XY: [[f64; 2]; 21] = [
    [0.41, 0.42],
    [0.37, 0.48],
    [0.32, 0.54],
    [0.31, 0.55],
    [0.36, 0.47],
    [0.34, 0.38],
    [0.39, 0.33],
    [0.47, 0.27],
    [0.48, 0.25],
    [0.44, 0.24],
    [0.35, 0.15],
    [0.26, 0.06],
    [0.24, 0.06],
    [0.23, 0.07],
    [0.23, 0.08],
    [0.23, 0.10],
    [0.21, 0.10],
    [0.20, 0.09],
    [0.18, 0.08],
    [0.16, 0.07],
    [0.15, 0.06],
];

/// Sampling period of Table 1, s.
pub const TABLE1_STEP_S: f64 = 4.0;

/// Last time of the measured model, s; later times need [`TimeRange::Extrapolate`].
pub const MODEL_END_S: f64 = 80.0;

/// Reference light of §3.2 as printed in the text, (x, y) = (0.43, 0.40).
pub const REFERENCE_XY_TEXT: [f64; 2] = [0.43, 0.40];

/// Reference light as Table 1 starts, (0.41, 0.42): lumifit's default (see `docs/afterimage.md`).
pub const REFERENCE_XY_TABLE1: [f64; 2] = [0.41, 0.42];

/// Breakpoint of Eq. 3, s.
pub const EQ3_BREAK_S: f64 = 22.0;

/// Eq. 3 coefficients `(slope per s, intercept)` of `ln Y_M` for t ≤ 22 s and t > 22 s.
pub const EQ3_COEFFICIENTS: [[f64; 2]; 2] = [[-0.083, -0.978], [-0.055, -1.584]];

/// Luminance transition Y_M(t) of Eq. 3 (relative units; Y_M(0) = e^−0.978 ≈ 0.376).
pub fn luminance_y(t_s: f64) -> f64 {
    let [slope, intercept] = if t_s <= EQ3_BREAK_S {
        EQ3_COEFFICIENTS[0]
    } else {
        EQ3_COEFFICIENTS[1]
    };
    (slope * t_s + intercept).exp()
}

/// Colour transition (x_M, y_M)(t): Table 1 with uniform Catmull-Rom interpolation. Times
/// before 0 s give Table 1's first value, after 80 s its last (the extrapolation rule).
pub fn chromaticity_xy(t_s: f64) -> [f64; 2] {
    let n = TABLE1_XY.len();
    if t_s <= 0.0 || t_s.is_nan() {
        return TABLE1_XY[0];
    }
    if t_s >= MODEL_END_S {
        return TABLE1_XY[n - 1];
    }
    let s = t_s / TABLE1_STEP_S;
    let i = (s.floor() as usize).min(n - 2);
    let u = s - i as f64;
    let p = |k: isize| -> [f64; 2] {
        if k < 0 {
            [
                2.0 * TABLE1_XY[0][0] - TABLE1_XY[1][0],
                2.0 * TABLE1_XY[0][1] - TABLE1_XY[1][1],
            ]
        } else if k as usize >= n {
            [
                2.0 * TABLE1_XY[n - 1][0] - TABLE1_XY[n - 2][0],
                2.0 * TABLE1_XY[n - 1][1] - TABLE1_XY[n - 2][1],
            ]
        } else {
            TABLE1_XY[k as usize]
        }
    };
    let ii = i as isize;
    let (p0, p1, p2, p3) = (p(ii - 1), p(ii), p(ii + 1), p(ii + 2));
    let mut out = [0.0; 2];
    for c in 0..2 {
        out[c] = 0.5
            * (2.0 * p1[c]
                + (-p0[c] + p2[c]) * u
                + (2.0 * p0[c] - 5.0 * p1[c] + 4.0 * p2[c] - p3[c]) * u * u
                + (-p0[c] + 3.0 * p1[c] - 3.0 * p2[c] + p3[c]) * u * u * u);
    }
    out
}

/// Which times are accepted.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TimeRange {
    /// Only the measured 0–80 s.
    Measured,
    /// Any t ≥ 0: Eq. 3 continues, the chromaticity stays at Table 1's 80 s value.
    Extrapolate,
}

/// Checks that every time is finite and inside the accepted range; `what` names the flag.
pub fn check_times(what: &str, times_s: &[f64], range: TimeRange) -> Result<()> {
    if times_s.is_empty() {
        return Err(Error::invalid(what, "no time given; expected at least one"));
    }
    for &t in times_s {
        if !t.is_finite() || t < 0.0 {
            return Err(Error::invalid(
                what,
                format!("time {t} s; expected a finite time ≥ 0 s"),
            ));
        }
        if range == TimeRange::Measured && t > MODEL_END_S {
            return Err(Error::invalid(
                what,
                format!("time {t} s is outside the measured 0–{MODEL_END_S} s of Table 1 and Eq. 3; pass --extrapolate to hold the 80 s colour and continue Eq. 3"),
            ));
        }
    }
    Ok(())
}

/// One sample of the model's curves.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CurvePoint {
    /// Model time, s.
    pub t_s: f64,
    /// Luminance Y_M (Eq. 3, display white = 1).
    pub big_y: f64,
    /// Chromaticity x_M.
    pub x: f64,
    /// Chromaticity y_M.
    pub y: f64,
    /// CIE L\*a\*b\* of (x_M, y_M, Y_M), white D65 at Yn = 1.
    pub lab: [f64; 3],
    /// τ_M = L_M(t) / L_M(0).
    pub tau: f64,
}

/// L_M(0), the lightness of the model at t = 0.
fn l_m0() -> f64 {
    116.0 * intermediate_lightness_cie1976(luminance_y(0.0), 1.0) - 16.0
}

/// The curves at one time (no range check: see [`check_times`]).
pub fn curve_point(t_s: f64) -> Result<CurvePoint> {
    let big_y = luminance_y(t_s);
    let [x, y] = chromaticity_xy(t_s);
    let lab = xyz_to_lab(xyy_to_xyz([x, y, big_y]), D65_XY)?;
    Ok(CurvePoint {
        t_s,
        big_y,
        x,
        y,
        lab,
        tau: lab[0] / l_m0(),
    })
}

/// The curves at each time, after [`check_times`].
pub fn curves(times_s: &[f64], range: TimeRange) -> Result<Vec<CurvePoint>> {
    check_times("times", times_s, range)?;
    times_s.iter().map(|&t| curve_point(t)).collect()
}

/// A uniform grid `0, step, 2·step, …, end` (end included when it falls on the grid), computed
/// as `i·step` so that the Table 1 times are hit exactly for steps like 0.1, 0.5, 1, 2, 4.
pub fn time_grid(step_s: f64, end_s: f64) -> Result<Vec<f64>> {
    if !(step_s.is_finite() && step_s > 0.0) {
        return Err(Error::invalid(
            "step",
            format!("{step_s} s; expected a positive step"),
        ));
    }
    if !(end_s.is_finite() && end_s >= 0.0) {
        return Err(Error::invalid(
            "end",
            format!("{end_s} s; expected a time ≥ 0"),
        ));
    }
    let n = (end_s / step_s + 1e-9).floor() as usize;
    crate::limits::check_count("time grid points", n + 1, 10_000_000, "a curve grid")?;
    Ok((0..=n).map(|i| i as f64 * step_s).collect())
}

/// How the mask I′_on is made (§3.2 leaves it open).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MaskRule {
    /// A pixel belongs to the mask when its luminance, relative to the image's brightest pixel,
    /// is at least this (0–1; 0 keeps every non-black pixel).
    pub threshold: f64,
}

/// Dark adaptation of the background (Eq. 7).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DarkAdaptation {
    /// c: at t = 0 the background is c·I_off (0–1).
    pub constant: f64,
    /// T of Eq. 7, s (> 0).
    pub time_s: f64,
}

impl DarkAdaptation {
    /// Weight w(t) = 1 − (1 − c)·e^(−t/T) applied to the background's linear RGB.
    pub fn weight(&self, t_s: f64) -> f64 {
        1.0 - (1.0 - self.constant) * (-t_s / self.time_s).exp()
    }
}

/// Parameters of the frame synthesis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SynthParams {
    /// γ of Z (≥ 0).
    pub gamma: f64,
    /// k of Eq. 5–6 (≥ 0).
    pub k: f64,
    /// Reference light chromaticity (x_R, y_R).
    pub reference_xy: [f64; 2],
    /// Mask rule.
    pub mask: MaskRule,
    /// Standard deviation of the Gaussian blur, px (0: no blur).
    pub blur_sigma_px: f64,
    /// Dark adaptation; used only with a background.
    pub dark: DarkAdaptation,
    /// Which times are accepted.
    pub range: TimeRange,
}

impl Default for SynthParams {
    fn default() -> Self {
        SynthParams {
            gamma: 0.7,
            k: 0.05,
            reference_xy: REFERENCE_XY_TABLE1,
            mask: MaskRule { threshold: 0.5 },
            blur_sigma_px: 0.0,
            dark: DarkAdaptation {
                constant: 0.05,
                time_s: 20.0,
            },
            range: TimeRange::Measured,
        }
    }
}

impl SynthParams {
    /// Checks every parameter; errors name the flag.
    pub fn validate(&self) -> Result<()> {
        let nonneg = |flag: &str, v: f64| {
            if v.is_finite() && v >= 0.0 {
                Ok(())
            } else {
                Err(Error::invalid(
                    flag,
                    format!("{v}; expected a finite value ≥ 0"),
                ))
            }
        };
        nonneg("--gamma", self.gamma)?;
        nonneg("--k", self.k)?;
        nonneg("--blur-sigma-px", self.blur_sigma_px)?;
        if self.blur_sigma_px > 1000.0 {
            return Err(Error::invalid(
                "--blur-sigma-px",
                format!("{} px; expected at most 1000 px", self.blur_sigma_px),
            ));
        }
        let t = self.mask.threshold;
        if !(t.is_finite() && (0.0..=1.0).contains(&t)) {
            return Err(Error::invalid(
                "--mask-threshold",
                format!("{t}; expected a relative luminance in 0–1"),
            ));
        }
        let [x, y] = self.reference_xy;
        if !(x.is_finite() && y.is_finite() && x > 0.0 && y > 0.0 && x + y < 1.0) {
            return Err(Error::invalid(
                "--reference-xy",
                format!("({x}, {y}); expected a chromaticity with x > 0, y > 0, x + y < 1"),
            ));
        }
        let c = self.dark.constant;
        if !(c.is_finite() && (0.0..=1.0).contains(&c)) {
            return Err(Error::invalid(
                "--dark-constant",
                format!("{c}; expected a factor in 0–1"),
            ));
        }
        let tt = self.dark.time_s;
        if !(tt.is_finite() && tt > 0.0) {
            return Err(Error::invalid(
                "--dark-time-s",
                format!("{tt} s; expected a time constant > 0 s"),
            ));
        }
        Ok(())
    }
}

/// A linear RGB image in memory (sRGB primaries, interleaved, row-major).
#[derive(Debug, Clone, PartialEq)]
pub struct LinearImage {
    /// Width, px.
    pub width: usize,
    /// Height, px.
    pub height: usize,
    /// `3·width·height` values.
    pub rgb: Vec<f32>,
}

impl LinearImage {
    /// An image from interleaved values; errors name `what`.
    pub fn new(what: &str, width: usize, height: usize, rgb: Vec<f32>) -> Result<Self> {
        if width == 0 || height == 0 {
            return Err(Error::invalid(
                what,
                format!("{width}×{height} px; expected a non-empty image"),
            ));
        }
        if rgb.len() != 3 * width * height {
            return Err(Error::ShapeMismatch {
                what: what.to_string(),
                expected: 3 * width * height,
                got: rgb.len(),
            });
        }
        Ok(LinearImage { width, height, rgb })
    }

    /// Number of pixels.
    pub fn pixels(&self) -> usize {
        self.width * self.height
    }
}

/// Bytes per pixel held at once, for [`crate::limits::check_memory`]: the decoded input (f32 RGB
/// plus the decoder's own buffer, ≤ 28 B), Z, Δa, Δb and the mask (13 B), one frame and its blur
/// scratch (24 B), the background (12 B) and the 16-bit encoding buffer (6 B).
pub const BYTES_PER_PIXEL: u128 = 12 + 28 + 13 + 24 + 12 + 6;

/// The per-pixel quantities that do not depend on t, and the frame synthesis.
#[derive(Debug, Clone)]
pub struct Synthesizer {
    width: usize,
    height: usize,
    params: SynthParams,
    /// Z per pixel (0 outside the mask).
    z: Vec<f32>,
    /// Δa, Δb per pixel (0 outside the mask).
    da: Vec<f32>,
    db: Vec<f32>,
    mask: Vec<bool>,
    y_max: f64,
    background: Option<LinearImage>,
    kernel: Vec<f32>,
    to_xyz: Mat3,
    to_rgb: Mat3,
    white: [f64; 3],
}

/// Per-pixel luminance row of the sRGB → XYZ matrix.
fn luminance_of(m: &Mat3, rgb: [f64; 3]) -> f64 {
    m[1][0] * rgb[0] + m[1][1] * rgb[1] + m[1][2] * rgb[2]
}

impl Synthesizer {
    /// Prepares the synthesis from the input I_on and an optional background I_off (same size).
    ///
    /// The input is normalised so that its brightest pixel has Y = 1 before any Lab conversion
    /// (so frames do not depend on the input's scale); negative input components are taken as 0.
    ///
    /// # Errors
    /// Invalid parameters; a background of another size; an all-black input (`L_on^max = 0`),
    /// named `input_name`.
    pub fn new(
        input: &LinearImage,
        input_name: &str,
        background: Option<LinearImage>,
        params: SynthParams,
    ) -> Result<Self> {
        params.validate()?;
        let (to_xyz, to_rgb) = display_matrices()?;
        if let Some(bg) = &background {
            if bg.width != input.width || bg.height != input.height {
                return Err(Error::invalid(
                    "--background",
                    format!(
                        "{}×{} px; expected the size of the input, {}×{} px",
                        bg.width, bg.height, input.width, input.height
                    ),
                ));
            }
        }
        let px = |i: usize| -> [f64; 3] {
            [0, 1, 2].map(|c| f64::from(input.rgb[3 * i + c]).max(0.0))
        };
        let y_max = (0..input.pixels())
            .into_par_iter()
            .map(|i| luminance_of(&to_xyz, px(i)))
            .reduce(|| 0.0, f64::max);
        if !(y_max > 0.0) || !y_max.is_finite() {
            return Err(Error::invalid(
                input_name,
                "every pixel is black (L_on^max = 0, or not finite); expected an image with a bright region to make an afterimage of",
            ));
        }
        let white = xy_to_xyz(D65_XY);
        let [xr, yr] = params.reference_xy;
        let n = input.pixels();
        let mut z = vec![0f32; n];
        let mut da = vec![0f32; n];
        let mut db = vec![0f32; n];
        let mut mask = vec![false; n];
        let threshold = params.mask.threshold;
        let gamma = params.gamma;
        z.par_iter_mut()
            .zip(da.par_iter_mut())
            .zip(db.par_iter_mut())
            .zip(mask.par_iter_mut())
            .enumerate()
            .for_each(|(i, (((z, da), db), m))| {
                let rgb = px(i).map(|v| v / y_max);
                let xyz = mat3_mul_vec(&to_xyz, rgb);
                let y = xyz[1];
                if !(y > 0.0 && y >= threshold) {
                    return;
                }
                *m = true;
                let lab_on = lab_fast(xyz, white);
                let lab_r = lab_fast([xr * y / yr, y, (1.0 - xr - yr) * y / yr], white);
                // L′_on^max = 100: the brightest pixel has Y = 1 = Yn.
                *z = (lab_on[0] / 100.0).max(0.0).powf(gamma) as f32;
                *da = (lab_on[1] - lab_r[1]) as f32;
                *db = (lab_on[2] - lab_r[2]) as f32;
            });
        Ok(Synthesizer {
            width: input.width,
            height: input.height,
            params,
            z,
            da,
            db,
            mask,
            y_max,
            background,
            kernel: gaussian_kernel(params.blur_sigma_px),
            to_xyz,
            to_rgb,
            white,
        })
    }

    /// Image width, px.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Image height, px.
    pub fn height(&self) -> usize {
        self.height
    }

    /// The parameters in use.
    pub fn params(&self) -> &SynthParams {
        &self.params
    }

    /// The mask I′_on (true: the pixel makes an afterimage).
    pub fn mask(&self) -> &[bool] {
        &self.mask
    }

    /// Y_on^max of the input before normalisation (the input's scale).
    pub fn input_y_max(&self) -> f64 {
        self.y_max
    }

    /// Z per pixel.
    pub fn z(&self) -> &[f32] {
        &self.z
    }

    /// The unblurred, gamut-corrected afterimage at t (Eq. 4–6 and §3.7), linear sRGB,
    /// interleaved; 0 outside the mask.
    pub fn afterimage_unblurred(&self, t_s: f64) -> Result<Vec<f32>> {
        check_times("time", &[t_s], self.params.range)?;
        let cp = curve_point(t_s)?;
        let [l_m, a_m, b_m] = cp.lab;
        let tk = cp.tau * self.params.k;
        let mut out = vec![0f32; 3 * self.width * self.height];
        out.par_chunks_mut(3 * self.width)
            .enumerate()
            .for_each(|(row, dst)| {
                let base = row * self.width;
                for x in 0..self.width {
                    let i = base + x;
                    if !self.mask[i] {
                        continue;
                    }
                    let z = f64::from(self.z[i]);
                    let lab = [
                        l_m * z,
                        a_m * z + tk * f64::from(self.da[i]),
                        b_m * z + tk * f64::from(self.db[i]),
                    ];
                    let rgb = gamut_correct(lab, self.white, &self.to_rgb, &self.to_xyz);
                    for c in 0..3 {
                        dst[3 * x + c] = rgb[c] as f32;
                    }
                }
            });
        Ok(out)
    }

    /// The frame at t: the blurred afterimage plus the dark-adapting background, linear sRGB.
    pub fn frame(&self, t_s: f64) -> Result<LinearImage> {
        let mut a = self.afterimage_unblurred(t_s)?;
        if self.kernel.len() > 1 {
            blur_rgb(&mut a, self.width, self.height, &self.kernel);
        }
        if let Some(bg) = &self.background {
            let w = self.params.dark.weight(t_s) as f32;
            a.par_iter_mut()
                .zip(bg.rgb.par_iter())
                .for_each(|(v, b)| *v += w * b.max(0.0));
        }
        LinearImage::new("frame", self.width, self.height, a)
    }
}

/// Lab of XYZ with a precomputed white (the same functions as [`xyz_to_lab`], without the
/// per-call validation of the white).
fn lab_fast(xyz: [f64; 3], white: [f64; 3]) -> [f64; 3] {
    let fx = intermediate_lightness_cie1976(xyz[0], white[0]);
    let fy = intermediate_lightness_cie1976(xyz[1], white[1]);
    let fz = intermediate_lightness_cie1976(xyz[2], white[2]);
    [116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz)]
}

/// XYZ of Lab with a precomputed white (as [`crate::colorimetry::lab::lab_to_xyz`]).
fn xyz_fast(lab: [f64; 3], white: [f64; 3]) -> [f64; 3] {
    let fy = (lab[0] + 16.0) / 116.0;
    let fx = lab[1] / 500.0 + fy;
    let fz = fy - lab[2] / 200.0;
    [
        intermediate_luminance_cie1976(fx, white[0]),
        intermediate_luminance_cie1976(fy, white[1]),
        intermediate_luminance_cie1976(fz, white[2]),
    ]
}

/// §3.7: Lab → linear sRGB; negative components clamped to 0; the clamped colour scaled so that
/// its Y — hence its L\* — is that of the Lab colour again (chromaticity of the clamped colour
/// kept). A colour whose clamped Y is 0 stays black.
pub fn gamut_correct(lab: [f64; 3], white: [f64; 3], to_rgb: &Mat3, to_xyz: &Mat3) -> [f64; 3] {
    let xyz = xyz_fast(lab, white);
    let target_y = xyz[1].max(0.0);
    let rgb = mat3_mul_vec(to_rgb, xyz);
    if rgb.iter().all(|&c| c >= 0.0) {
        return rgb;
    }
    let clamped = rgb.map(|c| c.max(0.0));
    let y = luminance_of(to_xyz, clamped);
    if y > 0.0 {
        let s = target_y / y;
        clamped.map(|c| c * s)
    } else {
        [0.0; 3]
    }
}

/// [`gamut_correct`] of one Lab colour (white D65) → corrected linear sRGB.
pub fn lab_to_display_rgb(lab: [f64; 3]) -> Result<[f64; 3]> {
    let (to_xyz, to_rgb) = display_matrices()?;
    Ok(gamut_correct(lab, xy_to_xyz(D65_XY), &to_rgb, &to_xyz))
}

/// Normalised Gaussian weights at −r…r with r = ceil(3σ) (a single 1 for σ = 0).
pub fn gaussian_kernel(sigma_px: f64) -> Vec<f32> {
    if !(sigma_px > 0.0) {
        return vec![1.0];
    }
    let r = (3.0 * sigma_px).ceil() as i64;
    let w: Vec<f64> = (-r..=r)
        .map(|i| (-(i as f64).powi(2) / (2.0 * sigma_px * sigma_px)).exp())
        .collect();
    let s: f64 = w.iter().sum();
    w.iter().map(|v| (v / s) as f32).collect()
}

/// Separable Gaussian blur of an interleaved RGB buffer, edges clamped (replicated).
pub fn blur_rgb(rgb: &mut [f32], width: usize, height: usize, kernel: &[f32]) {
    let r = kernel.len() / 2;
    let mut tmp = vec![0f32; rgb.len()];
    // Horizontal pass: rgb → tmp.
    tmp.par_chunks_mut(3 * width)
        .zip(rgb.par_chunks(3 * width))
        .for_each(|(dst, src)| {
            for x in 0..width {
                let mut acc = [0f32; 3];
                for (k, w) in kernel.iter().enumerate() {
                    let xx = (x + k).saturating_sub(r).min(width - 1);
                    for c in 0..3 {
                        acc[c] += w * src[3 * xx + c];
                    }
                }
                dst[3 * x..3 * x + 3].copy_from_slice(&acc);
            }
        });
    // Vertical pass: tmp → rgb.
    let row_len = 3 * width;
    rgb.par_chunks_mut(row_len)
        .enumerate()
        .for_each(|(y, dst)| {
            dst.iter_mut().for_each(|v| *v = 0.0);
            for (k, w) in kernel.iter().enumerate() {
                let yy = (y + k).saturating_sub(r).min(height - 1);
                let src = &tmp[yy * row_len..(yy + 1) * row_len];
                for (d, s) in dst.iter_mut().zip(src) {
                    *d += w * s;
                }
            }
        });
}

/// CIE 1931 xy and Y of a linear sRGB colour (for tests and summaries); black gives D65.
pub fn rgb_to_xyy(rgb: [f64; 3]) -> Result<[f64; 3]> {
    let (to_xyz, _) = display_matrices()?;
    let xyz = mat3_mul_vec(&to_xyz, rgb);
    Ok(crate::colorimetry::xyy::xyz_to_xyy(xyz, D65_XY))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn catmull_rom_hits_every_table_sample_exactly() {
        for (t, xy) in TABLE1_T_S.iter().zip(TABLE1_XY) {
            assert_eq!(chromaticity_xy(*t), xy, "t = {t}");
        }
    }

    #[test]
    fn tau_is_one_at_zero_and_falls() {
        let p0 = curve_point(0.0).unwrap();
        assert_eq!(p0.tau, 1.0);
        let p = curve_point(40.0).unwrap();
        assert!(p.tau < 0.5 && p.tau > 0.0);
    }

    #[test]
    fn kernel_is_normalised_and_symmetric() {
        let k = gaussian_kernel(2.5);
        assert_eq!(k.len(), 2 * 8 + 1);
        let s: f32 = k.iter().sum();
        assert!((s - 1.0).abs() < 1e-6);
        assert_eq!(k[0], k[k.len() - 1]);
    }
}
