//! Synthetic captures of a continuous spectrum through the LVF, optionally behind a colour gel:
//! the test data of the band-transmission calibration and spectral recovery (Nalbach et al.
//! 2017, §4.2), with known truth.
//!
//! Along the filter axis position p (pixels, centres at integers) passes λ(p) = Σ cᵢ·pⁱ with a
//! Gaussian passband g of the given FWHM ([`Passband::Gaussian`], peak 1). Camera channel c at
//! pixel (x, y) records
//!
//! ```text
//! v_c(x, y) = E · V(x, y) · Σ_λ L(λ) · F(λ) · g(λ − λ(p)) · Q_c(λ) · Δλ
//! ```
//!
//! summed on the 1 nm grid 360, 361, …, 830 nm (Δλ = 1 nm; [`MODEL_START_NM`]–[`MODEL_END_NM`]),
//! where
//! - L is the light reaching the filter: an emission spectrum (zero outside its sampled range),
//!   or a reflectance R times an illuminant S (both held constant beyond their sampled range, as
//!   colour-science extrapolates);
//! - F is the gel's transmission (1 without a gel; held constant beyond its range);
//! - Q_c the camera's sensitivity (zero outside its sampled range);
//! - all are interpolated linearly onto the grid;
//! - V is vignetting ([`VignettingShape`]: 1 − v·r² by default, r the distance from the image
//!   centre over the half diagonal; cos⁴, linear tilt and off-centre shapes as in [`crate::lvf::synth`]);
//! - E the exposure. [`Exposure::Auto`] sets E = 0.8 / max_{p,c} Σ_λ L₀(λ)·g(λ − λ(p))·Q_c(λ)·Δλ
//!   with L₀ the *unfiltered* light — in reflectance mode a perfect white (R = 1) under the
//!   illuminant — so captures of different patches and gels under one illuminant share one
//!   exposure and a white patch peaks at 0.8 of full scale.
//!
//! Noise follows [`crate::capture::synth::noisy_value`] with peak 0.8 (at a value of 0.8 its
//! standard deviation is `noise`·0.8); values are clipped to [0, 1] and pixels at 1 flagged
//! saturated. Deterministic for a seed.
//!
//! Rows across the axis differ only by vignetting and noise, so the noise-free sums are computed
//! once per position along the axis (cost ∝ positions × 471 × 3), not per pixel.

use crate::capture::rng::SplitMix64;
use crate::capture::synth::noisy_value;
use crate::capture::RgbFrame;
use crate::error::{Error, Result};
use crate::lvf::fit::Passband;
use crate::lvf::profile::Axis;
use crate::lvf::synth::VignettingShape;
use crate::spectrum::{MultiSpectrum, Spectrum};

/// First wavelength of the model's summation grid (nm).
pub const MODEL_START_NM: f64 = 360.0;
/// Last wavelength of the model's summation grid (nm).
pub const MODEL_END_NM: f64 = 830.0;
/// Step of the model's summation grid, Δλ (nm).
pub const MODEL_STEP_NM: f64 = 1.0;
/// Level of the brightest unfiltered position under [`Exposure::Auto`] and the noise model's
/// reference level.
pub const AUTO_PEAK: f64 = 0.8;

/// The model's summation grid: 360, 361, …, 830 nm.
pub fn model_grid() -> Vec<f64> {
    let n = ((MODEL_END_NM - MODEL_START_NM) / MODEL_STEP_NM).round() as usize + 1;
    (0..n)
        .map(|i| MODEL_START_NM + MODEL_STEP_NM * i as f64)
        .collect()
}

/// The light in front of the LVF.
#[derive(Debug, Clone, PartialEq)]
pub enum CaptureLight {
    /// A light source seen directly: spectral power L(λ), zero outside its sampled range.
    Emission(Spectrum),
    /// A surface of reflectance R(λ) lit by an illuminant S(λ); both held constant beyond their
    /// sampled ranges.
    Reflectance {
        /// Reflectance factor (usually 0–1).
        reflectance: Spectrum,
        /// Relative spectral power of the illuminant.
        illuminant: Spectrum,
    },
}

/// How the exposure is chosen.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Exposure {
    /// [`AUTO_PEAK`] over the brightest unfiltered (white, in reflectance mode) position.
    Auto,
    /// A given factor E.
    Fixed(f64),
}

/// What to render.
#[derive(Debug, Clone)]
pub struct LvfCaptureSpec {
    /// Image width (px).
    pub width: usize,
    /// Image height (px).
    pub height: usize,
    /// Filter axis.
    pub axis: Axis,
    /// Map coefficients: λ(p) = Σ cᵢ·pⁱ (nm, p in px).
    pub map: Vec<f64>,
    /// Passband FWHM (nm), Gaussian.
    pub fwhm_nm: f64,
    /// The light.
    pub light: CaptureLight,
    /// Gel transmission F(λ) (fraction), if a gel is in front of the LVF.
    pub filter: Option<Spectrum>,
    /// Label of the gel for the truth (e.g. `L106 Primary Red`); the spectrum's name when `None`.
    pub filter_name: Option<String>,
    /// Camera sensitivities (3 channels).
    pub camera: MultiSpectrum,
    /// Relative noise at [`AUTO_PEAK`] (shot + read, see the module docs).
    pub noise: f64,
    /// Vignetting strength v in 1 − v·r², in [0, 1).
    pub vignetting: f64,
    /// Shape of the vignetting ([`VignettingShape`]; quadratic is 1 − v·r²).
    pub vignetting_shape: VignettingShape,
    /// Random seed.
    pub seed: u64,
    /// Exposure.
    pub exposure: Exposure,
}

/// Description of the light in the truth file.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct LightTruth {
    /// `emission` or `reflectance`.
    pub mode: &'static str,
    /// Name of the emission spectrum or of the reflectance.
    pub spectrum: String,
    /// Name of the illuminant (reflectance mode).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub illuminant: Option<String>,
}

/// The truth written beside a synthetic capture (schema `lumifit.lvf-capture-truth/1`).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct LvfCaptureTruth {
    /// Schema tag.
    pub schema: &'static str,
    /// Axis.
    pub axis: Axis,
    /// Image size `[w, h]` (px).
    pub size: [usize; 2],
    /// Map `{kind, coefficients}`: λ(p) = Σ cᵢ·pⁱ.
    pub map: serde_json::Value,
    /// Passband FWHM (nm), Gaussian.
    pub fwhm_nm: f64,
    /// The light.
    pub light: LightTruth,
    /// The gel's label, or `null` without a gel.
    pub gel: Option<String>,
    /// Camera name.
    pub camera: String,
    /// Exposure factor E used.
    pub exposure: f64,
    /// `auto` or `fixed`.
    pub exposure_mode: &'static str,
    /// Largest noise-free value in the frame (before clipping; > 1 means clipped pixels).
    pub peak_value: f64,
    /// Summation grid of the model.
    pub model_grid_nm: [f64; 3],
    /// Relative noise.
    pub noise: f64,
    /// Vignetting strength.
    pub vignetting: f64,
    /// Vignetting shape.
    pub vignetting_shape: VignettingShape,
    /// Seed.
    pub seed: u64,
}

/// Linear interpolation on `s`, `outside` (or the end value when `None`) beyond its range.
fn sample(s: &Spectrum, grid: &[f64], outside: Option<f64>) -> Vec<f64> {
    sample_raw(s.wavelengths(), s.values(), grid, outside)
}

fn sample_raw(w: &[f64], v: &[f64], grid: &[f64], outside: Option<f64>) -> Vec<f64> {
    let n = w.len();
    grid.iter()
        .map(|&x| {
            if x < w[0] || x > w[n - 1] {
                return match outside {
                    Some(o) => o,
                    None if x < w[0] => v[0],
                    None => v[n - 1],
                };
            }
            if n == 1 {
                return v[0];
            }
            let i = w.partition_point(|&t| t <= x).clamp(1, n - 1);
            let f = (x - w[i - 1]) / (w[i] - w[i - 1]);
            v[i - 1] + f * (v[i] - v[i - 1])
        })
        .collect()
}

fn check_non_negative(s: &Spectrum, what: &str) -> Result<()> {
    if let Some((w, v)) = s
        .wavelengths()
        .iter()
        .zip(s.values())
        .find(|(_, v)| **v < 0.0)
    {
        return Err(Error::invalid(
            what,
            format!("'{}' is {v} at {w} nm; expected values ≥ 0", s.name()),
        ));
    }
    Ok(())
}

/// λ(p) of a polynomial map.
fn map_at(map: &[f64], p: f64) -> f64 {
    map.iter().rev().fold(0.0, |acc, c| acc * p + c)
}

/// Per-position sums Σ_λ w(λ)·g(λ − λ(p))·Q_c(λ)·Δλ for the weights `w` on the model grid.
fn position_sums(
    grid: &[f64],
    weighted: &[[f64; 3]],
    centres: &[f64],
    fwhm_nm: f64,
) -> Vec<[f64; 3]> {
    let g = Passband::Gaussian;
    // The Gaussian is cut at 8σ by Passband::eval; skip the grid outside that window.
    let reach = 8.0 * fwhm_nm / (8.0 * std::f64::consts::LN_2).sqrt() + MODEL_STEP_NM;
    centres
        .iter()
        .map(|&lc| {
            let a = grid.partition_point(|&l| l < lc - reach);
            let b = grid.partition_point(|&l| l <= lc + reach);
            let mut s = [0.0; 3];
            for i in a..b {
                let gi = g.eval(grid[i] - lc, fwhm_nm) * MODEL_STEP_NM;
                if gi == 0.0 {
                    continue;
                }
                for (c, sc) in s.iter_mut().enumerate() {
                    *sc += weighted[i][c] * gi;
                }
            }
            s
        })
        .collect()
}

/// Noise-free, unvignetted per-position sums at exposure 1 (see [`noise_free_profile`]).
#[derive(Debug, Clone, PartialEq)]
pub struct NoiseFreeProfile {
    /// Σ_λ L(λ)·F(λ)·g(λ − λ(p))·Q_c(λ)·Δλ at positions p = 0, 1, … along the axis.
    pub filtered: Vec<[f64; 3]>,
    /// The same for the unfiltered light L₀ (a perfect white in reflectance mode): the
    /// auto-exposure reference.
    pub reference: Vec<[f64; 3]>,
}

/// The noise-free, unvignetted sums Σ_λ L(λ)·F(λ)·g(λ − λ(p))·Q_c(λ)·Δλ (exposure 1) at each
/// position p = 0, 1, … along the axis, and the same for the unfiltered light L₀ (the
/// auto-exposure reference; see the module docs).
///
/// # Errors
/// [`Error::InvalidArgument`] for a camera without 3 channels, negative light, gel or camera
/// values.
pub fn noise_free_profile(spec: &LvfCaptureSpec) -> Result<NoiseFreeProfile> {
    if spec.camera.n_channels() != 3 {
        return Err(Error::invalid(
            "--camera",
            format!(
                "'{}' has {} channels; expected 3 (r, g, b)",
                spec.camera.name(),
                spec.camera.n_channels()
            ),
        ));
    }
    for c in 0..3 {
        if let Some((i, v)) = spec
            .camera
            .channel(c)
            .iter()
            .enumerate()
            .find(|(_, v)| **v < 0.0)
        {
            return Err(Error::invalid(
                "--camera",
                format!(
                    "'{}' channel '{}' is {v} at {} nm; expected sensitivities ≥ 0",
                    spec.camera.name(),
                    spec.camera.labels()[c],
                    spec.camera.wavelengths()[i]
                ),
            ));
        }
    }
    let grid = model_grid();
    let (light, white) = match &spec.light {
        CaptureLight::Emission(l) => {
            check_non_negative(l, "--spectrum")?;
            let v = sample(l, &grid, Some(0.0));
            (v.clone(), v)
        }
        CaptureLight::Reflectance {
            reflectance,
            illuminant,
        } => {
            check_non_negative(reflectance, "--reflectance")?;
            check_non_negative(illuminant, "--illuminant")?;
            let s = sample(illuminant, &grid, None);
            let r = sample(reflectance, &grid, None);
            (s.iter().zip(&r).map(|(s, r)| s * r).collect(), s)
        }
    };
    let filter = match &spec.filter {
        Some(f) => {
            check_non_negative(f, "--filter")?;
            sample(f, &grid, None)
        }
        None => vec![1.0; grid.len()],
    };
    let q: Vec<Vec<f64>> = (0..3)
        .map(|c| {
            sample_raw(
                spec.camera.wavelengths(),
                spec.camera.channel(c),
                &grid,
                Some(0.0),
            )
        })
        .collect();
    let weigh = |l: &[f64], f: &[f64]| -> Vec<[f64; 3]> {
        (0..grid.len())
            .map(|i| std::array::from_fn(|c| l[i] * f[i] * q[c][i]))
            .collect()
    };
    let along = match spec.axis {
        Axis::X => spec.width,
        Axis::Y => spec.height,
    };
    let centres: Vec<f64> = (0..along).map(|p| map_at(&spec.map, p as f64)).collect();
    let filtered = position_sums(&grid, &weigh(&light, &filter), &centres, spec.fwhm_nm);
    let reference = position_sums(
        &grid,
        &weigh(&white, &vec![1.0; grid.len()]),
        &centres,
        spec.fwhm_nm,
    );
    Ok(NoiseFreeProfile {
        filtered,
        reference,
    })
}

fn validate(spec: &LvfCaptureSpec) -> Result<()> {
    let ok_size = |v: usize| (1..=20_000).contains(&v);
    if !ok_size(spec.width) || !ok_size(spec.height) {
        return Err(Error::invalid(
            "--size",
            format!(
                "{}x{}: each side must be 1–20000 px",
                spec.width, spec.height
            ),
        ));
    }
    if !(spec.fwhm_nm > 0.0 && spec.fwhm_nm.is_finite()) {
        return Err(Error::invalid(
            "FWHM",
            format!("{} nm; expected a positive number of nm", spec.fwhm_nm),
        ));
    }
    if spec.map.len() < 2 || spec.map.iter().any(|c| !c.is_finite()) || spec.map[1] == 0.0 {
        return Err(Error::invalid(
            "map",
            format!(
                "coefficients {:?}; expected at least 2 finite numbers with a non-zero slope",
                spec.map
            ),
        ));
    }
    if !(spec.noise >= 0.0 && spec.noise.is_finite()) {
        return Err(Error::invalid(
            "--noise",
            format!("{}; expected ≥ 0", spec.noise),
        ));
    }
    if !(0.0..1.0).contains(&spec.vignetting) {
        return Err(Error::invalid(
            "--vignetting",
            format!("{}; expected a value in [0, 1)", spec.vignetting),
        ));
    }
    if let Exposure::Fixed(e) = spec.exposure {
        if !(e > 0.0 && e.is_finite()) {
            return Err(Error::invalid(
                "--exposure",
                format!("{e}; expected 'auto' or a positive number"),
            ));
        }
    }
    Ok(())
}

/// Renders the capture (linear 0–1, `pixel_scale` 1) and its truth. See the module docs for the
/// model.
///
/// # Errors
/// [`Error::InvalidArgument`] for sizes outside 1–20000 px, a non-positive FWHM, a map without a
/// slope, negative noise, vignetting outside [0, 1), a non-positive fixed exposure, negative
/// spectra or sensitivities, or (auto exposure) a light the camera does not see through the
/// filter's range.
pub fn render_lvf_capture(spec: &LvfCaptureSpec) -> Result<(RgbFrame, LvfCaptureTruth)> {
    validate(spec)?;
    let NoiseFreeProfile {
        filtered: profile,
        reference,
    } = noise_free_profile(spec)?;
    let exposure = match spec.exposure {
        Exposure::Fixed(e) => e,
        Exposure::Auto => {
            let max = reference
                .iter()
                .flat_map(|v| v.iter())
                .cloned()
                .fold(0.0, f64::max);
            if !(max > 0.0 && max.is_finite()) {
                return Err(Error::invalid(
                    "--exposure",
                    "auto: the unfiltered light gives no signal anywhere along the filter (no power where the camera is sensitive inside the map's wavelength range); give --exposure VALUE or check --spectrum/--illuminant and --lvf",
                ));
            }
            AUTO_PEAK / max
        }
    };
    let vig = |x: usize, y: usize| {
        spec.vignetting_shape
            .at(spec.vignetting, spec.axis, x, y, spec.width, spec.height)
    };
    let mut rng = SplitMix64::new(spec.seed);
    let n = spec.width * spec.height;
    let mut data = Vec::with_capacity(3 * n);
    let mut sat = vec![0u8; n];
    let mut peak = 0.0f64;
    for y in 0..spec.height {
        for x in 0..spec.width {
            let p = match spec.axis {
                Axis::X => x,
                Axis::Y => y,
            };
            let v = vig(x, y) * exposure;
            for (c, pc) in profile[p].iter().enumerate() {
                let clean = pc * v;
                peak = peak.max(clean);
                let s = noisy_value(clean, spec.noise, AUTO_PEAK, &mut rng).clamp(0.0, 1.0);
                if s >= 1.0 {
                    sat[y * spec.width + x] |= 1 << c;
                }
                data.push(s as f32);
            }
        }
    }
    let frame = RgbFrame::new(
        "synthetic LVF capture",
        spec.width,
        spec.height,
        1,
        data,
        sat,
    )?;
    let light = match &spec.light {
        CaptureLight::Emission(l) => LightTruth {
            mode: "emission",
            spectrum: l.name().to_string(),
            illuminant: None,
        },
        CaptureLight::Reflectance {
            reflectance,
            illuminant,
        } => LightTruth {
            mode: "reflectance",
            spectrum: reflectance.name().to_string(),
            illuminant: Some(illuminant.name().to_string()),
        },
    };
    let kind = match spec.map.len() {
        2 => "linear",
        3 => "quadratic",
        _ => "polynomial",
    };
    let truth = LvfCaptureTruth {
        schema: "lumifit.lvf-capture-truth/1",
        axis: spec.axis,
        size: [spec.width, spec.height],
        map: serde_json::json!({"kind": kind, "coefficients": spec.map}),
        fwhm_nm: spec.fwhm_nm,
        light,
        gel: spec.filter.as_ref().map(|f| {
            spec.filter_name
                .clone()
                .unwrap_or_else(|| f.name().to_string())
        }),
        camera: spec.camera.name().to_string(),
        exposure,
        exposure_mode: match spec.exposure {
            Exposure::Auto => "auto",
            Exposure::Fixed(_) => "fixed",
        },
        peak_value: peak,
        model_grid_nm: [MODEL_START_NM, MODEL_END_NM, MODEL_STEP_NM],
        noise: spec.noise,
        vignetting: spec.vignetting,
        vignetting_shape: spec.vignetting_shape,
        seed: spec.seed,
    };
    Ok((frame, truth))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn flat(name: &str, v: f64) -> Spectrum {
        Spectrum::new(name, vec![300.0, 900.0], vec![v, v]).unwrap()
    }

    fn box_camera() -> MultiSpectrum {
        let w: Vec<f64> = (0..=470).map(|i| 360.0 + i as f64).collect();
        let ch = |lo: f64, hi: f64| -> Vec<f64> {
            w.iter()
                .map(|&l| if (lo..hi).contains(&l) { 1.0 } else { 0.0 })
                .collect()
        };
        MultiSpectrum::new(
            "box",
            w.clone(),
            vec!["r".into(), "g".into(), "b".into()],
            vec![ch(600.0, 700.0), ch(500.0, 600.0), ch(400.0, 500.0)],
        )
        .unwrap()
    }

    fn spec(light: CaptureLight) -> LvfCaptureSpec {
        LvfCaptureSpec {
            width: 400,
            height: 8,
            axis: Axis::X,
            map: vec![380.0, 1.0],
            fwhm_nm: 20.0,
            light,
            filter: None,
            filter_name: None,
            camera: box_camera(),
            noise: 0.0,
            vignetting: 0.0,
            vignetting_shape: VignettingShape::Quadratic,
            seed: 1,
            exposure: Exposure::Auto,
        }
    }

    #[test]
    fn a_flat_light_integrates_the_whole_gaussian_inside_a_box_channel() {
        let mut s = spec(CaptureLight::Emission(flat("flat", 2.0)));
        s.exposure = Exposure::Fixed(0.01);
        let (frame, truth) = render_lvf_capture(&s).unwrap();
        // At λ = 550 nm (p = 170) the 20 nm Gaussian lies inside the green box: sum = 2·area.
        let area =
            20.0 / (8.0 * std::f64::consts::LN_2).sqrt() * (2.0 * std::f64::consts::PI).sqrt();
        let g = frame.rgb(170, 3)[1] as f64 / 0.01;
        assert!(
            ((g - 2.0 * area).abs() / (2.0 * area)) < 1e-5,
            "{g} vs {}",
            2.0 * area
        );
        assert_eq!(truth.exposure, 0.01);
        assert_eq!(truth.exposure_mode, "fixed");
    }

    #[test]
    fn auto_exposure_puts_white_at_the_peak_and_grey_in_proportion() {
        let ill = flat("E", 1.0);
        let white = render_lvf_capture(&spec(CaptureLight::Reflectance {
            reflectance: flat("white", 1.0),
            illuminant: ill.clone(),
        }))
        .unwrap();
        let grey = render_lvf_capture(&spec(CaptureLight::Reflectance {
            reflectance: flat("grey", 0.18),
            illuminant: ill,
        }))
        .unwrap();
        assert!((white.1.peak_value - AUTO_PEAK).abs() < 1e-12);
        assert_eq!(white.1.exposure, grey.1.exposure);
        let (w, g) = (white.0.rgb(170, 0)[1], grey.0.rgb(170, 0)[1]);
        assert!((g / w - 0.18).abs() < 1e-6, "{g} / {w}");
    }

    #[test]
    fn a_gel_scales_the_reading_and_not_the_exposure() {
        let mut s = spec(CaptureLight::Emission(flat("flat", 1.0)));
        let open = render_lvf_capture(&s).unwrap();
        s.filter = Some(flat("half", 0.5));
        let gel = render_lvf_capture(&s).unwrap();
        assert_eq!(open.1.exposure, gel.1.exposure);
        assert_eq!(gel.1.gel.as_deref(), Some("half"));
        let (a, b) = (open.0.rgb(100, 4)[2], gel.0.rgb(100, 4)[2]);
        assert!((b / a - 0.5).abs() < 1e-6, "{b} / {a}");
    }

    #[test]
    fn emission_is_zero_outside_its_range_and_reflectance_is_extended() {
        let narrow = Spectrum::new("narrow", vec![540.0, 560.0], vec![1.0, 1.0]).unwrap();
        let p = noise_free_profile(&spec(CaptureLight::Emission(narrow.clone())))
            .unwrap()
            .filtered;
        assert_eq!(p[70][2], 0.0); // 450 nm, blue box: no light there
        let q = noise_free_profile(&spec(CaptureLight::Reflectance {
            reflectance: narrow,
            illuminant: flat("E", 1.0),
        }))
        .unwrap()
        .filtered;
        assert!(q[70][2] > 0.0);
    }

    #[test]
    fn bad_specs_are_rejected_with_the_field_named() {
        let mut s = spec(CaptureLight::Emission(flat("flat", 1.0)));
        s.fwhm_nm = 0.0;
        assert!(render_lvf_capture(&s)
            .unwrap_err()
            .to_string()
            .contains("FWHM"));
        let mut s = spec(CaptureLight::Emission(flat("neg", -1.0)));
        assert!(render_lvf_capture(&s)
            .unwrap_err()
            .to_string()
            .contains("'neg'"));
        s.light = CaptureLight::Emission(
            Spectrum::new("uv", vec![200.0, 250.0], vec![1.0, 1.0]).unwrap(),
        );
        let e = render_lvf_capture(&s).unwrap_err().to_string();
        assert!(e.contains("--exposure"), "{e}");
        s.exposure = Exposure::Fixed(-1.0);
        assert!(render_lvf_capture(&s)
            .unwrap_err()
            .to_string()
            .contains("--exposure"));
    }

    #[test]
    fn noise_is_deterministic_for_a_seed() {
        let mut s = spec(CaptureLight::Emission(flat("flat", 1.0)));
        s.noise = 0.01;
        let a = render_lvf_capture(&s).unwrap().0;
        let b = render_lvf_capture(&s).unwrap().0;
        assert_eq!(a, b);
        s.seed = 2;
        assert_ne!(a, render_lvf_capture(&s).unwrap().0);
    }
}
