//! The reference consumer of wavelength samples: a white beam through a prism onto a screen,
//! rendered in 1-D two ways and compared by ΔE00.
//!
//! Geometry (thin beam, principal section): a ray meets the first face at incidence θ₁, refracts
//! to θ₂ = asin(sin θ₁ / n), meets the second face at θ₃ = A − θ₂ (A the apex angle) and leaves at
//! θ₄ = asin(n sin θ₃); the deviation is δ(λ) = θ₁ + θ₄ − A. A screen at distance D perpendicular
//! to the ray of the d line receives wavelength λ at x(λ) = D tan(δ(λ) − δ_d).
//!
//! The beam has a uniform (box) profile of width w on the screen. The strip is cut into pixels of
//! width p; a source of colour c centred at x adds c · |box ∩ pixel| / p, so an undispersed beam
//! gives exactly its colour in every pixel it covers.
//!
//! - **Spectral** reference: every 1 nm slice of [`SpectralSlices`] (adapted XYZ) at its own
//!   x(λ).
//! - **Sampled**: each sample's RGB weight (turned into XYZ by the working space's matrix) at
//!   x(λᵢ).
//!
//! Both are in XYZ relative to the working white (Y = 1 for the whole undispersed beam); Lab uses
//! that white; ΔE00 is taken on every pixel where either render has Y > [`LIT_Y`], and its mean and
//! maximum are reported against the spectral reference's XYZ for two weight sets:
//!
//! - **as exported** ([`PrismCase::difference`]): the non-negative, gamut-mapped weights a preset
//!   carries. This includes the gamut cost: spectral fringe colours lie outside every RGB gamut,
//!   so even one sample per nm keeps an error (the floor is reported in `docs/dispersion.md`).
//! - **sampling only** ([`PrismCase::sampling_only`]): the same wavelengths with the bands' true
//!   colours before gamut mapping (negative components allowed, as a float RGB buffer holds
//!   them). This error vanishes as N grows; `--target-de00` bounds it.

// Index loops mirror the maths; `!(a > b)` comparisons deliberately reject NaN along with
// out-of-range values.
#![allow(clippy::needless_range_loop, clippy::neg_cmp_op_on_partial_ord)]

use super::blanchette2012::SpectralSlices;
use super::RefractiveIndex;
use crate::colorimetry::delta_e::delta_e_cie2000;
use crate::colorimetry::lab::xyz_to_lab;
use crate::colorimetry::rgb::RgbSpace;
use crate::error::{Error, Result};
use crate::math::linalg::mat3_mul_vec;

/// Pixels darker than this (relative to the beam's white, Y = 1) on both renders are not counted.
pub const LIT_Y: f64 = 1e-3;

/// The prism and screen.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PrismSetup {
    /// Apex angle A in degrees.
    pub apex_deg: f64,
    /// Angle of incidence θ₁ in degrees; `None` for minimum deviation at the d line.
    pub incidence_deg: Option<f64>,
    /// Screen distance D in m.
    pub screen_distance_m: f64,
    /// Beam width w on the screen in mm.
    pub beam_width_mm: f64,
    /// Pixel width p in mm.
    pub pixel_mm: f64,
}

impl Default for PrismSetup {
    fn default() -> Self {
        PrismSetup {
            apex_deg: 60.0,
            incidence_deg: None,
            screen_distance_m: 1.0,
            beam_width_mm: 2.0,
            pixel_mm: 0.05,
        }
    }
}

/// Deviation δ in radians of a ray of index `n` (None on total internal reflection).
pub fn deviation_rad(n: f64, apex_rad: f64, incidence_rad: f64) -> Option<f64> {
    let t2 = (incidence_rad.sin() / n).asin();
    let s4 = n * (apex_rad - t2).sin();
    if !(s4.abs() <= 1.0) {
        return None;
    }
    Some(incidence_rad + s4.asin() - apex_rad)
}

/// A 1-D render: pixel centres and XYZ (0–1, working white Y = 1).
#[derive(Debug, Clone, PartialEq)]
pub struct Strip {
    /// Pixel centres on the screen in mm.
    pub x_mm: Vec<f64>,
    /// XYZ of each pixel.
    pub xyz: Vec<[f64; 3]>,
}

/// Geometry shared by both renders: incidence and where the d line lands.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Layout {
    /// Incidence used, degrees.
    pub incidence_deg: f64,
    /// Deviation of the d line, degrees.
    pub deviation_d_deg: f64,
    /// Strip start (left edge of the first pixel) in mm.
    pub x0_mm: f64,
    /// Number of pixels.
    pub n_pixels: usize,
}

fn check_setup(s: &PrismSetup) -> Result<()> {
    let checks = [
        ("--apex-deg", s.apex_deg, 0.0, 120.0),
        ("--screen-distance-m", s.screen_distance_m, 0.0, 1e3),
        ("--beam-width-mm", s.beam_width_mm, 0.0, 1e3),
        ("--pixel-mm", s.pixel_mm, 0.0, 1e3),
    ];
    for (flag, v, lo, hi) in checks {
        if !(v > lo && v <= hi) {
            return Err(Error::invalid(
                flag,
                format!("{v}; expected a value in ({lo}, {hi}]"),
            ));
        }
    }
    if let Some(i) = s.incidence_deg {
        if !(i > -90.0 && i < 90.0) {
            return Err(Error::invalid(
                "--incidence-deg",
                format!("{i}; expected an angle in (−90, 90)"),
            ));
        }
    }
    Ok(())
}

/// Positions x(λ) in mm of the slice wavelengths, and the layout of the strip.
pub fn layout(n: &dyn RefractiveIndex, slices: &SpectralSlices, s: &PrismSetup) -> Result<Layout> {
    check_setup(s)?;
    let apex = s.apex_deg.to_radians();
    let n_d = n.n_at(super::lines::D_NM);
    let incidence = match s.incidence_deg {
        Some(i) => i.to_radians(),
        None => {
            let v = n_d * (apex / 2.0).sin();
            if !(v.abs() < 1.0) {
                return Err(Error::invalid(
                    "--apex-deg",
                    format!(
                        "{}°: no minimum-deviation path for n_d = {n_d:.5} (n sin(A/2) ≥ 1); choose an apex below {:.1}°",
                        s.apex_deg,
                        2.0 * (1.0 / n_d).asin().to_degrees()
                    ),
                ));
            }
            v.asin()
        }
    };
    let dev_d = deviation_rad(n_d, apex, incidence).ok_or_else(|| {
        Error::invalid(
            "--incidence-deg",
            format!(
                "{:.2}°: the d line is totally reflected inside the prism",
                incidence.to_degrees()
            ),
        )
    })?;
    let mut lo = f64::INFINITY;
    let mut hi = f64::NEG_INFINITY;
    for &l in &slices.lambda_nm {
        let x = position_mm(n.n_at(l), apex, incidence, dev_d, s).ok_or_else(|| {
            Error::invalid(
                "--incidence-deg",
                format!(
                    "{:.2}°: {l} nm is totally reflected inside the prism; choose a larger incidence or a smaller apex",
                    incidence.to_degrees()
                ),
            )
        })?;
        lo = lo.min(x);
        hi = hi.max(x);
    }
    let half = 0.5 * s.beam_width_mm + s.pixel_mm;
    let x0 = lo - half;
    let n_pixels = ((hi + half - x0) / s.pixel_mm).ceil() as usize;
    crate::limits::check_count("--pixel-mm", n_pixels, 10_000_000, "pixels along the strip")?;
    Ok(Layout {
        incidence_deg: incidence.to_degrees(),
        deviation_d_deg: dev_d.to_degrees(),
        x0_mm: x0,
        n_pixels,
    })
}

fn position_mm(n: f64, apex: f64, incidence: f64, dev_d: f64, s: &PrismSetup) -> Option<f64> {
    let d = deviation_rad(n, apex, incidence)?;
    Some(s.screen_distance_m * 1e3 * (d - dev_d).tan())
}

fn splat(strip: &mut [[f64; 3]], lay: &Layout, s: &PrismSetup, x: f64, c: [f64; 3]) {
    let a = x - 0.5 * s.beam_width_mm;
    let b = x + 0.5 * s.beam_width_mm;
    let first = (((a - lay.x0_mm) / s.pixel_mm).floor().max(0.0)) as usize;
    let last = ((((b - lay.x0_mm) / s.pixel_mm).ceil()).max(0.0) as usize).min(strip.len());
    for (j, px) in strip.iter_mut().enumerate().take(last).skip(first) {
        let p0 = lay.x0_mm + j as f64 * s.pixel_mm;
        let ov = (b.min(p0 + s.pixel_mm) - a.max(p0)).max(0.0) / s.pixel_mm;
        for k in 0..3 {
            px[k] += c[k] * ov;
        }
    }
}

fn empty(lay: &Layout, s: &PrismSetup) -> Strip {
    Strip {
        x_mm: (0..lay.n_pixels)
            .map(|j| lay.x0_mm + (j as f64 + 0.5) * s.pixel_mm)
            .collect(),
        xyz: vec![[0.0; 3]; lay.n_pixels],
    }
}

/// The spectral reference render (1 nm slices).
pub fn render_spectral(
    n: &dyn RefractiveIndex,
    slices: &SpectralSlices,
    s: &PrismSetup,
    lay: &Layout,
) -> Strip {
    let mut strip = empty(lay, s);
    let apex = s.apex_deg.to_radians();
    let inc = lay.incidence_deg.to_radians();
    let dev_d = lay.deviation_d_deg.to_radians();
    for (k, &l) in slices.lambda_nm.iter().enumerate() {
        if let Some(x) = position_mm(n.n_at(l), apex, inc, dev_d, s) {
            splat(&mut strip.xyz, lay, s, x, slices.xyz[k]);
        }
    }
    strip
}

/// The render with wavelength samples `(λ nm, linear RGB weight)` of `space`.
pub fn render_samples(
    n: &dyn RefractiveIndex,
    samples: &[(f64, [f64; 3])],
    space: &RgbSpace,
    s: &PrismSetup,
    lay: &Layout,
) -> Result<Strip> {
    let mut strip = empty(lay, s);
    let apex = s.apex_deg.to_radians();
    let inc = lay.incidence_deg.to_radians();
    let dev_d = lay.deviation_d_deg.to_radians();
    for &(l, rgb) in samples {
        let x = position_mm(n.n_at(l), apex, inc, dev_d, s).ok_or_else(|| {
            Error::invalid(
                "samples",
                format!("{l} nm is totally reflected inside the prism"),
            )
        })?;
        splat(
            &mut strip.xyz,
            lay,
            s,
            x,
            mat3_mul_vec(&space.matrix_rgb_to_xyz, rgb),
        );
    }
    Ok(strip)
}

/// ΔE00 along the strip.
#[derive(Debug, Clone, PartialEq)]
pub struct StripDifference {
    /// ΔE00 per pixel (0 where neither render is lit).
    pub delta_e: Vec<f64>,
    /// Mean over lit pixels.
    pub mean: f64,
    /// Maximum.
    pub max: f64,
    /// Number of lit pixels.
    pub lit_pixels: usize,
}

/// ΔE00 (CIE 2000, graphic-arts weights) between two renders of the same layout.
pub fn compare(a: &Strip, b: &Strip, white_xy: [f64; 2]) -> Result<StripDifference> {
    let mut de = vec![0.0; a.xyz.len()];
    let mut sum = 0.0;
    let mut max: f64 = 0.0;
    let mut lit = 0;
    for j in 0..a.xyz.len().min(b.xyz.len()) {
        if a.xyz[j][1].max(b.xyz[j][1]) <= LIT_Y {
            continue;
        }
        let d = delta_e_cie2000(
            xyz_to_lab(a.xyz[j], white_xy)?,
            xyz_to_lab(b.xyz[j], white_xy)?,
            false,
        );
        de[j] = d;
        sum += d;
        max = max.max(d);
        lit += 1;
    }
    Ok(StripDifference {
        delta_e: de,
        mean: if lit > 0 { sum / lit as f64 } else { 0.0 },
        max,
        lit_pixels: lit,
    })
}

/// One rendered case: a label, its samples, its strip and its difference to the reference.
#[derive(Debug, Clone, PartialEq)]
pub struct PrismCase {
    /// What the samples are (`N = 7`, `Blanchette Table 2`, `preset`).
    pub label: String,
    /// The samples `(λ nm, linear RGB)`.
    pub samples: Vec<(f64, [f64; 3])>,
    /// The sampled render.
    pub strip: Strip,
    /// ΔE00 of the weights as given against the spectral render.
    pub difference: StripDifference,
    /// ΔE00 of the bands' true (unmapped) colours at the same wavelengths, when known.
    pub sampling_only: Option<StripDifference>,
}

/// The spectral reference and every sampled case on one layout.
#[derive(Debug, Clone, PartialEq)]
pub struct PrismEvaluation {
    /// The layout.
    pub layout: Layout,
    /// The spectral reference (XYZ, out-of-gamut colours included).
    pub spectral: Strip,
    /// The sampled cases, in the order given.
    pub cases: Vec<PrismCase>,
}

/// A case to render: a label, the weights `(λ nm, linear RGB)`, and optionally the bands' true
/// colours at the same wavelengths.
pub type CaseInput = (String, Vec<(f64, [f64; 3])>, Option<Vec<[f64; 3]>>);

/// Renders the spectral reference and each case, and compares them.
pub fn evaluate(
    n: &dyn RefractiveIndex,
    slices: &SpectralSlices,
    setup: &PrismSetup,
    cases: Vec<CaseInput>,
) -> Result<PrismEvaluation> {
    let lay = layout(n, slices, setup)?;
    let spectral = render_spectral(n, slices, setup, &lay);
    let white = slices.space.whitepoint_xy;
    let mut out = Vec::with_capacity(cases.len());
    for (label, samples, targets) in cases {
        let strip = render_samples(n, &samples, &slices.space, setup, &lay)?;
        let difference = compare(&spectral, &strip, white)?;
        let sampling_only = match targets {
            Some(t) => {
                let ideal: Vec<(f64, [f64; 3])> =
                    samples.iter().zip(t).map(|(s, c)| (s.0, c)).collect();
                let strip = render_samples(n, &ideal, &slices.space, setup, &lay)?;
                Some(compare(&spectral, &strip, white)?)
            }
            None => None,
        };
        out.push(PrismCase {
            label,
            samples,
            strip,
            difference,
            sampling_only,
        });
    }
    Ok(PrismEvaluation {
        layout: lay,
        spectral,
        cases: out,
    })
}

/// The smallest N ≤ `max_n` whose computed samples ([`super::blanchette2012`]) give a maximum
/// ΔE00 ≤ `target` along the strip from sampling alone (the bands' true colours, see the module
/// docs), with that N's difference; `None` when no N up to `max_n` reaches it.
pub fn smallest_n_for(
    n: &dyn RefractiveIndex,
    slices: &SpectralSlices,
    setup: &PrismSetup,
    target: f64,
    max_n: usize,
) -> Result<Option<(usize, StripDifference)>> {
    if !(target.is_finite() && target > 0.0) {
        return Err(Error::invalid(
            "--target-de00",
            format!("{target}; expected a positive ΔE00 such as 1"),
        ));
    }
    let lay = layout(n, slices, setup)?;
    let spectral = render_spectral(n, slices, setup, &lay);
    for k in 1..=max_n.min(slices.lambda_nm.len()) {
        let set = super::blanchette2012::wavelength_samples(slices, k)?;
        let samples: Vec<(f64, [f64; 3])> = set
            .samples
            .iter()
            .map(|s| (s.lambda_nm, s.target_rgb))
            .collect();
        let strip = render_samples(n, &samples, &slices.space, setup, &lay)?;
        let d = compare(&spectral, &strip, slices.space.whitepoint_xy)?;
        if d.max <= target {
            return Ok(Some((k, d)));
        }
    }
    Ok(None)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn minimum_deviation_is_symmetric() {
        // A = 60°, n = 1.5: θ₁ = asin(1.5 sin 30°) = 48.59°, δ_min = 2θ₁ − A = 37.18°
        let a = 60f64.to_radians();
        let t1 = (1.5 * (a / 2.0).sin()).asin();
        let d = deviation_rad(1.5, a, t1).unwrap();
        assert!((d - (2.0 * t1 - a)).abs() < 1e-12);
        assert!(deviation_rad(2.5, a, 0.1).is_none());
    }
}
