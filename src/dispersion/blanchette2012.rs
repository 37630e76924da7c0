//! Wavelength samples with linear-RGB weights that sum to white, after Blanchette (2012), §4.1 and
//! Table 2 ("Adaptive Spectral Mapping"; Musgrave 1989): an RGB renderer splits a white ray into
//! N rays of wavelengths λᵢ, refracts each with n(λᵢ) and adds their weights wᵢ, which must add up
//! to white so that undispersed light stays white.
//!
//! Blanchette picked seven wavelengths 380–680 nm and 0–255 weights by hand ([`TABLE2`]). Here
//! they are computed:
//!
//! 1. The range (default 380–780 nm) is cut into N equal intervals; λᵢ is each interval's middle.
//! 2. Each 1 nm slice k contributes XYZ_k = S(λ_k) x̄ȳz̄(λ_k) Δλ (S the illuminant, E by default;
//!    the CIE 1931 2° observer by default), scaled so the whole range has Y = 1, chromatically
//!    adapted (Bradford) from the illuminant's white to the working space's white, and turned into
//!    linear RGB of the working space (sRGB/Rec.709 primaries by default, ACEScg as an option).
//!    Slices at the ends of the range count half (trapezoid rule), slices split by an interval
//!    edge are shared in proportion.
//! 3. The "true colour" tᵢ of sample i is the sum of its slices. Σᵢ tᵢ is the working white
//!    (1, 1, 1), but monochromatic bands lie outside every RGB gamut, so tᵢ has negative parts.
//! 4. **Gamut mapping rule** (desaturation by adding white): each band gets the least neutral
//!    amount aᵢ = max(0, −min_c t_{ic}) added to all three channels, which keeps its RGB hue and
//!    makes it non-negative; because every addition is neutral, the total stays neutral,
//!    Σ (tᵢ + aᵢ·1) = (1 + Σ aᵢ)·1, and one common scale wᵢ = (tᵢ + aᵢ·1)/(1 + Σⱼ aⱼ) brings it back
//!    to exactly (1, 1, 1). The added neutral fraction aᵢ/(1 + Σ a) is reported per sample
//!    (`neutral_added`). (Per-channel least-squares projection onto {w ≥ 0, Σ w = 1} was tried
//!    first: it zeroes whole channels of the weak end bands, leaving a 694 nm sample black.)
//!
//! The published matrices are rounded, so the white of step 2 is (1, 1, 1) only to ~1e-5; each
//! channel is rescaled by its exact total before step 4 so the sum is exact.

// Index loops mirror the maths; `!(a > b)` comparisons deliberately reject NaN along with
// out-of-range values.
#![allow(clippy::needless_range_loop, clippy::neg_cmp_op_on_partial_ord)]

use crate::colorimetry::cat::{chromatic_adaptation_matrix, Cat};
use crate::colorimetry::rgb::RgbSpace;
use crate::colorimetry::xyy::xy_to_xyz;
use crate::colorimetry::{Illuminant, Observer};
use crate::error::{Error, Result};
use crate::math::linalg::mat3_mul_vec;

/// Blanchette (2012) Table 2: wavelengths in nm and RGB on 0–255; every channel totals 893.
pub const TABLE2: [(f64, [f64; 3]); 7] = [
    (380.0, [77.0, 0.0, 204.0]),
    (430.0, [51.0, 51.0, 255.0]),
    (480.0, [0.0, 229.5, 255.0]),
    (530.0, [76.5, 255.0, 102.0]),
    (580.0, [204.0, 229.5, 77.0]),
    (630.0, [229.5, 128.0, 0.0]),
    (680.0, [255.0, 0.0, 0.0]),
];

/// Blanchette's Table 2 as weights summing to (1, 1, 1) (each value / 893), read as linear RGB
/// since the shader adds them linearly.
pub fn table2_samples() -> Vec<(f64, [f64; 3])> {
    TABLE2
        .iter()
        .map(|(l, rgb)| (*l, [rgb[0] / 893.0, rgb[1] / 893.0, rgb[2] / 893.0]))
        .collect()
}

/// The colour of light at 1 nm steps in the working space: what every sample set and the
/// spectral reference are built from.
#[derive(Debug, Clone, PartialEq)]
pub struct SpectralSlices {
    /// Slice wavelengths in nm (1 nm apart, both range ends included).
    pub lambda_nm: Vec<f64>,
    /// Adapted XYZ of each slice (0–1 scale; the sum has Y = 1 and the working white's xy).
    pub xyz: Vec<[f64; 3]>,
    /// Linear RGB of each slice in the working space (the sum is exactly (1, 1, 1)).
    pub rgb: Vec<[f64; 3]>,
    /// Width in nm each slice stands for (1, or 0.5 at the ends).
    pub width_nm: Vec<f64>,
    /// The range in nm.
    pub range_nm: [f64; 2],
    /// The working space.
    pub space: RgbSpace,
}

/// The inputs of [`spectral_slices`]: CMFs and illuminant sampled at the slice wavelengths.
#[derive(Debug, Clone, Copy)]
pub struct SliceInputs<'a> {
    /// x̄, ȳ, z̄ at each integer wavelength of the range.
    pub cmfs: [&'a [f64]; 3],
    /// Illuminant relative power at the same wavelengths.
    pub illuminant: &'a [f64],
    /// The range in nm (integers).
    pub range_nm: [f64; 2],
}

/// Builds the 1 nm slices of the module docs, step 2.
pub fn spectral_slices(inputs: SliceInputs<'_>, space: &RgbSpace) -> Result<SpectralSlices> {
    let [lo, hi] = inputs.range_nm;
    let m = (hi - lo).round() as usize + 1;
    if !(lo.fract() == 0.0 && hi.fract() == 0.0 && hi > lo)
        || inputs.illuminant.len() != m
        || inputs.cmfs.iter().any(|c| c.len() != m)
    {
        return Err(Error::invalid(
            "--range",
            format!("{lo}–{hi} nm; expected integer nm with CMFs and illuminant at every nm"),
        ));
    }
    let lambda_nm: Vec<f64> = (0..m).map(|k| lo + k as f64).collect();
    let width_nm: Vec<f64> = (0..m)
        .map(|k| if k == 0 || k == m - 1 { 0.5 } else { 1.0 })
        .collect();
    let mut xyz: Vec<[f64; 3]> = (0..m)
        .map(|k| {
            let s = inputs.illuminant[k] * width_nm[k];
            [
                s * inputs.cmfs[0][k],
                s * inputs.cmfs[1][k],
                s * inputs.cmfs[2][k],
            ]
        })
        .collect();
    let y_total: f64 = xyz.iter().map(|v| v[1]).sum();
    if !(y_total.is_finite() && y_total > 0.0) {
        return Err(Error::invalid(
            "--illuminant",
            "the illuminant has no luminance over the range",
        ));
    }
    // the illuminant's white over the same range with the same observer
    let total = xyz
        .iter()
        .fold([0.0; 3], |a, v| [a[0] + v[0], a[1] + v[1], a[2] + v[2]]);
    let white = [total[0] / y_total, 1.0, total[2] / y_total];
    let cat = chromatic_adaptation_matrix(white, xy_to_xyz(space.whitepoint_xy), Cat::Bradford)?;
    for v in xyz.iter_mut() {
        let scaled = [v[0] / y_total, v[1] / y_total, v[2] / y_total];
        *v = mat3_mul_vec(&cat, scaled);
    }
    let mut rgb: Vec<[f64; 3]> = xyz
        .iter()
        .map(|v| mat3_mul_vec(&space.matrix_xyz_to_rgb, *v))
        .collect();
    for c in 0..3 {
        let total: f64 = rgb.iter().map(|v| v[c]).sum();
        for v in rgb.iter_mut() {
            v[c] /= total;
        }
    }
    Ok(SpectralSlices {
        lambda_nm,
        xyz,
        rgb,
        width_nm,
        range_nm: inputs.range_nm,
        space: space.clone(),
    })
}

/// [`spectral_slices`] for an observer and an illuminant (resampled to 1 nm with their own
/// interpolators; CMFs with colour's default) over `range_nm`.
pub fn slices_for(
    observer: &Observer,
    illuminant: &Illuminant,
    space: &RgbSpace,
    range_nm: [f64; 2],
) -> Result<SpectralSlices> {
    let [lo, hi] = range_nm;
    if !(lo.fract() == 0.0 && hi.fract() == 0.0 && lo >= 300.0 && hi <= 900.0 && hi - lo >= 10.0) {
        return Err(Error::invalid(
            "--range",
            format!("{lo}:{hi} nm; expected whole nm within 300–900 nm, at least 10 nm wide"),
        ));
    }
    let wl: Vec<f64> = (0..=((hi - lo) as usize)).map(|k| lo + k as f64).collect();
    let cmfs = observer
        .cmfs()
        .resample(&wl, crate::math::interpolation::Interpolator::Default)?;
    let ill = illuminant
        .spectrum()
        .values_at(&wl, illuminant.interpolator())?;
    spectral_slices(
        SliceInputs {
            cmfs: [cmfs.channel(0), cmfs.channel(1), cmfs.channel(2)],
            illuminant: &ill,
            range_nm,
        },
        space,
    )
}

/// One wavelength sample.
#[derive(Debug, Clone, PartialEq)]
pub struct WavelengthSample {
    /// The sample's wavelength (its interval's middle), nm.
    pub lambda_nm: f64,
    /// The interval it stands for, nm.
    pub interval_nm: [f64; 2],
    /// The weight, linear RGB of the working space (≥ 0; the weights sum to white).
    pub rgb: [f64; 3],
    /// The interval's true colour before gamut mapping (may be negative).
    pub target_rgb: [f64; 3],
    /// The neutral added to the band by gamut mapping, as a fraction of the total white.
    pub neutral_added: f64,
}

/// N samples and how far gamut mapping moved them.
#[derive(Debug, Clone, PartialEq)]
pub struct SampleSet {
    /// The samples, by increasing wavelength.
    pub samples: Vec<WavelengthSample>,
    /// The common scale 1/(1 + Σ aᵢ) gamut mapping applied (1 when every band is in gamut).
    pub scale: f64,
}

/// N samples over the slices' range (module docs, steps 1–4).
pub fn wavelength_samples(slices: &SpectralSlices, n_samples: usize) -> Result<SampleSet> {
    let [lo, hi] = slices.range_nm;
    if n_samples == 0 || n_samples > slices.lambda_nm.len() {
        return Err(Error::invalid(
            "--samples",
            format!(
                "{n_samples}; expected 1 to {} (one per nm of the range at most)",
                slices.lambda_nm.len()
            ),
        ));
    }
    let step = (hi - lo) / n_samples as f64;
    let mut target = vec![[0.0; 3]; n_samples];
    for (k, &l) in slices.lambda_nm.iter().enumerate() {
        let a = (l - 0.5).max(lo);
        let b = (l + 0.5).min(hi);
        let width = b - a;
        let first = (((a - lo) / step).floor() as usize).min(n_samples - 1);
        let last = (((b - lo) / step).ceil() as usize).clamp(first + 1, n_samples);
        for (i, t) in target.iter_mut().enumerate().take(last).skip(first) {
            let e0 = lo + step * i as f64;
            let e1 = e0 + step;
            let ov = (b.min(e1) - a.max(e0)).max(0.0) / width;
            for c in 0..3 {
                t[c] += slices.rgb[k][c] * ov;
            }
        }
    }
    let added: Vec<f64> = target
        .iter()
        .map(|t| (-t[0].min(t[1]).min(t[2])).max(0.0))
        .collect();
    let scale = 1.0 / (1.0 + added.iter().sum::<f64>());
    let mut weights: Vec<[f64; 3]> = target
        .iter()
        .zip(&added)
        .map(|(t, a)| [(t[0] + a) * scale, (t[1] + a) * scale, (t[2] + a) * scale])
        .collect();
    // absorb the last rounding so every channel sums to exactly 1
    for c in 0..3 {
        let total: f64 = weights.iter().map(|w| w[c]).sum();
        for w in weights.iter_mut() {
            w[c] /= total;
        }
    }
    let samples = (0..n_samples)
        .map(|i| {
            let e0 = lo + step * i as f64;
            WavelengthSample {
                lambda_nm: e0 + 0.5 * step,
                interval_nm: [e0, e0 + step],
                rgb: weights[i],
                target_rgb: target[i],
                neutral_added: added[i] * scale,
            }
        })
        .collect();
    Ok(SampleSet { samples, scale })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table2_sums_to_white() {
        let s = table2_samples();
        for c in 0..3 {
            let t: f64 = s.iter().map(|x| x.1[c]).sum();
            assert!((t - 1.0).abs() < 1e-12);
        }
    }
}
