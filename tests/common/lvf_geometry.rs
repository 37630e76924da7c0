//! The synthetic lamp image of issue 12 (1200×160 px, λ = 372.3 nm + 0.3117 nm/px, Gaussian
//! passband FWHM 25 nm), shared by the LVF tests that measure against the bounds.

use lumifit::lvf::synth::{Continuum, ContinuumShape, VignettingShape};
use lumifit::lvf::{
    calibrate_whole_profile, extract_profile, render_lvf, Axis, FitOptions, Lamp, LvfCalibration,
    LvfSynthSpec,
};
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
        tilt_deg: 0.0,
        passband: lumifit::lvf::Passband::Gaussian,
        fwhm_nm: 25.0,
        lamp,
        camera,
        noise,
        vignetting: vignetting.1,
        vignetting_shape: vignetting.0,
        continuum: continuum.map(|(shape, fraction)| Continuum { shape, fraction }),
        pedestal: 0.0,
        seed,
    }
}

/// The calibration of a rendered image (its own lamp, the whole image as ROI) and its signed λ
/// errors at the true 400 and 700 nm positions.
pub fn calibrated(s: &LvfSynthSpec, opts: &FitOptions) -> (LvfCalibration, [f64; 2]) {
    let (frame, truth) = render_lvf(s).unwrap();
    let profile = extract_profile(&frame, [0, 0, s.width, s.height], Axis::X).unwrap();
    let cal = calibrate_whole_profile(&profile, &s.lamp, opts).unwrap();
    let e = [
        cal.map.eval(truth.px_at_400) - 400.0,
        cal.map.eval(truth.px_at_700) - 700.0,
    ];
    (cal, e)
}
