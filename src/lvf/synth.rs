//! Synthetic LVF captures: a lamp seen through an LVF by a camera of given spectral
//! sensitivities, with vignetting, shot and read noise. The project's own test data and a
//! planning aid.
//!
//! Along the axis, position p (pixels, centres at integers) passes λ(p) = nm_at_start +
//! nm_per_px·p with a Gaussian passband of the given FWHM; channel c records
//! V(x, y)·Σ_l P_l·S_c(λ_l)·g(λ_l − λ(p)), scaled so that the brightest pixel is 0.8 of full
//! scale. Vignetting V = 1 − v·r² with r the distance from the image centre over the half
//! diagonal. Noise follows [`crate::capture::synth::noisy_value`] with peak 0.8: at the brightest
//! pixel its standard deviation is `noise`·0.8. Deterministic for a seed.

use crate::capture::rng::SplitMix64;
use crate::capture::synth::noisy_value;
use crate::capture::RgbFrame;
use crate::error::{Error, Result};
use crate::lvf::fit::Passband;
use crate::lvf::lamp::Lamp;
use crate::lvf::profile::Axis;
use crate::spectrum::MultiSpectrum;
use crate::table::parse_numeric_csv;

/// The default camera: Nikon 5100 (NPL) sensitivities from colour-science
/// (`calib/camera_default.csv`, see calib/README.md).
pub const DEFAULT_CAMERA_CSV: &str = include_str!("../../calib/camera_default.csv");

/// Parses a camera table `wavelength_nm,r,g,b`.
///
/// # Errors
/// [`Error::Parse`] / [`Error::InvalidArgument`] when the table is not three channels.
pub fn camera_from_csv(bytes: &[u8], source: &str) -> Result<MultiSpectrum> {
    let t = parse_numeric_csv(bytes, source)?;
    let ms = MultiSpectrum::from_table(&t)?;
    if ms.n_channels() != 3 {
        return Err(Error::parse(
            source,
            0,
            format!(
                "{} value columns; expected wavelength_nm,r,g,b",
                ms.n_channels()
            ),
        ));
    }
    Ok(ms)
}

/// The default camera (see [`DEFAULT_CAMERA_CSV`]).
///
/// # Errors
/// Only if the embedded table were corrupt.
pub fn default_camera() -> Result<MultiSpectrum> {
    camera_from_csv(DEFAULT_CAMERA_CSV.as_bytes(), "calib/camera_default.csv")
}

/// What to render.
#[derive(Debug, Clone)]
pub struct LvfSynthSpec {
    /// Image width (px).
    pub width: usize,
    /// Image height (px).
    pub height: usize,
    /// Filter axis.
    pub axis: Axis,
    /// λ at position 0 (nm).
    pub nm_at_start: f64,
    /// Dispersion (nm/px), may be negative.
    pub nm_per_px: f64,
    /// Passband FWHM (nm).
    pub fwhm_nm: f64,
    /// The lamp.
    pub lamp: Lamp,
    /// Camera sensitivities (3 channels).
    pub camera: MultiSpectrum,
    /// Relative noise at the peak.
    pub noise: f64,
    /// Vignetting strength v.
    pub vignetting: f64,
    /// Random seed.
    pub seed: u64,
}

/// The truth written beside a synthetic capture.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct LvfTruth {
    /// Schema tag.
    pub schema: &'static str,
    /// Axis.
    pub axis: Axis,
    /// Image size `[w, h]`.
    pub size: [usize; 2],
    /// True map (λ = c0 + c1·px).
    pub map: serde_json::Value,
    /// True FWHM (nm).
    pub fwhm_nm: f64,
    /// Position of 400 nm (px).
    pub px_at_400: f64,
    /// Position of 700 nm (px).
    pub px_at_700: f64,
    /// Lamp name and lines.
    pub lamp: Lamp,
    /// Camera name.
    pub camera: String,
    /// Noise level.
    pub noise: f64,
    /// Vignetting.
    pub vignetting: f64,
    /// Seed.
    pub seed: u64,
}

fn sensitivity(camera: &MultiSpectrum, c: usize, nm: f64) -> f64 {
    let wl = camera.wavelengths();
    let v = camera.channel(c);
    let n = wl.len();
    if n == 0 || nm < wl[0] || nm > wl[n - 1] {
        return 0.0;
    }
    let i = wl.partition_point(|&w| w <= nm).clamp(1, n - 1);
    let f = (nm - wl[i - 1]) / (wl[i] - wl[i - 1]);
    (v[i - 1] + f * (v[i] - v[i - 1])).max(0.0)
}

/// Renders the capture (linear, 0–1, `pixel_scale` 1) and its truth.
///
/// # Errors
/// [`Error::InvalidArgument`] for sizes outside 16–20000 px, non-positive FWHM, negative noise or
/// vignetting outside [0, 1), or a lamp none of whose lines the camera sees in the range.
pub fn render_lvf(spec: &LvfSynthSpec) -> Result<(RgbFrame, LvfTruth)> {
    let ok_size = |v: usize| (16..=20_000).contains(&v);
    if !ok_size(spec.width) || !ok_size(spec.height) {
        return Err(Error::invalid(
            "--size",
            format!(
                "{}x{}: each side must be 16–20000 px",
                spec.width, spec.height
            ),
        ));
    }
    if !(spec.fwhm_nm > 0.0 && spec.fwhm_nm.is_finite()) {
        return Err(Error::invalid("--fwhm", "must be a positive number of nm"));
    }
    if !(spec.noise >= 0.0 && spec.noise.is_finite()) {
        return Err(Error::invalid("--noise", "must be ≥ 0"));
    }
    if !(0.0..1.0).contains(&spec.vignetting) {
        return Err(Error::invalid("--vignetting", "must be in [0, 1)"));
    }
    if !(spec.nm_per_px.is_finite() && spec.nm_per_px != 0.0 && spec.nm_at_start.is_finite()) {
        return Err(Error::invalid("--nm-per-px", "must be finite and non-zero"));
    }
    let along = match spec.axis {
        Axis::X => spec.width,
        Axis::Y => spec.height,
    };
    let g = Passband::Gaussian;
    let profile: Vec<[f64; 3]> = (0..along)
        .map(|p| {
            let lam = spec.nm_at_start + spec.nm_per_px * p as f64;
            std::array::from_fn(|c| {
                spec.lamp
                    .lines
                    .iter()
                    .map(|l| {
                        l.relative_power
                            * sensitivity(&spec.camera, c, l.nm)
                            * g.eval(l.nm - lam, spec.fwhm_nm)
                    })
                    .sum()
            })
        })
        .collect();
    let (cx, cy) = (
        (spec.width as f64 - 1.0) / 2.0,
        (spec.height as f64 - 1.0) / 2.0,
    );
    let r2max = cx * cx + cy * cy;
    let vig = |x: usize, y: usize| {
        let (dx, dy) = (x as f64 - cx, y as f64 - cy);
        1.0 - spec.vignetting * (dx * dx + dy * dy) / r2max.max(1e-12)
    };
    let mut max = 0.0f64;
    for y in 0..spec.height {
        for x in 0..spec.width {
            let p = match spec.axis {
                Axis::X => x,
                Axis::Y => y,
            };
            for v in profile[p] {
                max = max.max(v * vig(x, y));
            }
        }
    }
    if max <= 0.0 {
        return Err(Error::invalid(
            "synthetic LVF",
            "no lamp line falls inside the rendered wavelength range and the camera's sensitivity",
        ));
    }
    const PEAK: f64 = 0.8;
    let scale = PEAK / max;
    let mut rng = SplitMix64::new(spec.seed);
    let n = spec.width * spec.height;
    let mut data = Vec::with_capacity(3 * n);
    let mut sat = vec![0u8; n];
    for y in 0..spec.height {
        for x in 0..spec.width {
            let p = match spec.axis {
                Axis::X => x,
                Axis::Y => y,
            };
            let v = vig(x, y);
            for (c, pc) in profile[p].iter().enumerate() {
                let s = noisy_value(pc * v * scale, spec.noise, PEAK, &mut rng).clamp(0.0, 1.0);
                if s >= 1.0 {
                    sat[y * spec.width + x] |= 1 << c;
                }
                data.push(s as f32);
            }
        }
    }
    let frame = RgbFrame::new("synthetic LVF", spec.width, spec.height, 1, data, sat)?;
    let truth = LvfTruth {
        schema: "lumifit.lvf-truth/1",
        axis: spec.axis,
        size: [spec.width, spec.height],
        map: serde_json::json!({"kind": "linear", "coefficients": [spec.nm_at_start, spec.nm_per_px]}),
        fwhm_nm: spec.fwhm_nm,
        px_at_400: (400.0 - spec.nm_at_start) / spec.nm_per_px,
        px_at_700: (700.0 - spec.nm_at_start) / spec.nm_per_px,
        lamp: spec.lamp.clone(),
        camera: spec.camera.name().to_string(),
        noise: spec.noise,
        vignetting: spec.vignetting,
        seed: spec.seed,
    };
    Ok((frame, truth))
}
