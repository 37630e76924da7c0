//! The synthetic lamp image of issue 12 (1200×160 px, λ = 372.3 nm + 0.3117 nm/px, Gaussian
//! passband FWHM 25 nm), shared by the LVF tests that measure against the bounds.

use lumifit::lvf::synth::{Continuum, ContinuumShape, VignettingShape};
use lumifit::lvf::{Axis, Lamp, LvfSynthSpec};
use lumifit::spectrum::MultiSpectrum;

/// The issue-12 image of `lamp` through `camera`: noise fraction, vignetting (shape, amount),
/// optional continuum (shape, fraction of the brightest blob), noise seed.
pub fn spec(
    lamp: Lamp,
    camera: MultiSpectrum,
    noise: f64,
    vignetting: (VignettingShape, f64),
    continuum: Option<(ContinuumShape, f64)>,
    seed: u64,
) -> LvfSynthSpec {
    LvfSynthSpec {
        width: 1200,
        height: 160,
        axis: Axis::X,
        nm_at_start: 372.3,
        nm_per_px: 0.3117,
        bow_nm: 0.0,
        passband: lumifit::lvf::Passband::Gaussian,
        fwhm_nm: 25.0,
        lamp,
        camera,
        noise,
        vignetting: vignetting.1,
        vignetting_shape: vignetting.0,
        continuum: continuum.map(|(shape, fraction)| Continuum { shape, fraction }),
        seed,
    }
}
