//! A synthetic flat-field photo matching a synthetic lamp photo ([`crate::lvf::synth`]): the
//! same geometry, camera, passband, vignetting and noise model, with a broadband source of
//! spectrum S instead of the lamp. Channel c records
//!
//! ```text
//! V(x, y) · Σ_λ S(λ)·Q_c(λ)·g(λ − λ(p))·1 nm        (λ on the 1 nm grid 360–830 nm)
//! ```
//!
//! scaled so that the brightest pixel is 0.8 of full scale, noise as the lamp's (same relative
//! level at the peak), its own seed stream. Used by `synth lvf-hg --flat-out` and the tests of
//! [`crate::lvf::flat`].

use crate::capture::rng::SplitMix64;
use crate::capture::synth::noisy_value;
use crate::capture::RgbFrame;
use crate::error::{Error, Result};
use crate::lvf::fit::Passband;
use crate::lvf::profile::Axis;
use crate::lvf::synth::{sensitivity, ContinuumShape, LvfSynthSpec};

/// Added to the lamp's seed so that the flat's noise is independent of the lamp's.
pub const FLAT_SEED_OFFSET: u64 = 0x5f1a_7f1e_1d00;

/// Renders the flat field of `spec` (its lamp and continuum are ignored) with source spectrum
/// `shape`.
///
/// # Errors
/// [`Error::InvalidArgument`] when the source is not seen by the camera in the rendered range.
pub fn render_lvf_flat(spec: &LvfSynthSpec, shape: ContinuumShape) -> Result<RgbFrame> {
    let along = match spec.axis {
        Axis::X => spec.width,
        Axis::Y => spec.height,
    };
    let g = Passband::Gaussian;
    let grid: Vec<f64> = (360..=830).map(f64::from).collect();
    let w: Vec<[f64; 3]> = grid
        .iter()
        .map(|&l| std::array::from_fn(|c| shape.value(l) * sensitivity(&spec.camera, c, l)))
        .collect();
    let profile: Vec<[f64; 3]> = (0..along)
        .map(|p| {
            let lc = spec.nm_at_start + spec.nm_per_px * p as f64;
            let mut s = [0.0; 3];
            for (l, wl) in grid.iter().zip(&w) {
                let gi = g.eval(l - lc, spec.fwhm_nm);
                if gi > 0.0 {
                    for c in 0..3 {
                        s[c] += wl[c] * gi;
                    }
                }
            }
            s
        })
        .collect();
    let vig = |x: usize, y: usize| {
        spec.vignetting_shape
            .at(spec.vignetting, spec.axis, x, y, spec.width, spec.height)
    };
    let at = |x: usize, y: usize| match spec.axis {
        Axis::X => x,
        Axis::Y => y,
    };
    let mut max = 0.0f64;
    for y in 0..spec.height {
        for x in 0..spec.width {
            for v in profile[at(x, y)] {
                max = max.max(v * vig(x, y));
            }
        }
    }
    if max.is_nan() || max <= 0.0 {
        return Err(Error::invalid(
            "--flat-spectrum",
            "the flat's source is not seen by the camera in the rendered wavelength range",
        ));
    }
    const PEAK: f64 = 0.8;
    let scale = PEAK / max;
    let mut rng = SplitMix64::new(spec.seed.wrapping_add(FLAT_SEED_OFFSET));
    let n = spec.width * spec.height;
    let mut data = Vec::with_capacity(3 * n);
    let mut sat = vec![0u8; n];
    for y in 0..spec.height {
        for x in 0..spec.width {
            let v = vig(x, y);
            for (c, pc) in profile[at(x, y)].iter().enumerate() {
                let s = (noisy_value(pc * v * scale, spec.noise, PEAK, &mut rng) + spec.pedestal)
                    .clamp(0.0, 1.0);
                if s >= 1.0 {
                    sat[y * spec.width + x] |= 1 << c;
                }
                data.push(s as f32);
            }
        }
    }
    RgbFrame::new(
        "synthetic LVF flat field",
        spec.width,
        spec.height,
        1,
        data,
        sat,
    )
}
