//! Acquisition glue: the LVF domain (`lvf`: geometry, band files, band-transmission solve) joined
//! with the spectral-recovery domain (`recovery`, which knows no LVF) and the readers of `io`.
//!
//! - [`calibrate_lamp`] (`lumifit lvf calibrate`): a lamp photo, optionally a flat-field photo
//!   and the camera's sensitivities become an [`crate::lvf::LvfCalibration`] and its `lvf.json`.
//! - [`synth_lamp_photo`], [`synth_capture_photo`] (`lumifit synth lvf-hg`, `synth
//!   lvf-capture`): synthetic photos through an LVF, encoded with their truth.
//! - [`band_transmissions`] (`lumifit lvf transmission`): `lvf.json`, `captures.csv`, the gel
//!   table, the light source, the target and the camera become one
//!   [`TransmissionProblem`] on a 1 nm quadrature grid, solved by
//!   [`crate::lvf::transmission::solve_transmissions`] (Nalbach et al. 2017 §4.2).
//! - [`recover_spectrum`] (`lumifit spectrum recover`): a band file (`lvf_bands.json`, or the
//!   `lvf.json` alone with parametric Gaussian bands) and the camera become a
//!   [`SensingModel`]; a photo or a readings CSV gives the band readings; the light or a
//!   reflectance factor is recovered by [`crate::recovery::recover`].
//!
//! Every file is read here (through `io`), never by the binary, and every input file a run will
//! read is listed beforehand ([`TransmissionJob::files`], [`RecoverInputs::files`]) so the
//! command can refuse an output that would replace one of them.

use std::path::Path;

use crate::error::{Error, Result};

mod calibrate;
mod recover;
mod synth;
mod transmission;

pub use calibrate::{
    calibrate_lamp, calibration_summary, check_calibrate_options, CalibrateInputs,
    CalibrationMethod, LampCalibration, MAX_BANDS,
};
pub use recover::{
    parse_recovery_grid, read_band_readings, read_band_source, recover_spectrum, recovery_csv,
    recovery_plot_png, recovery_summary, BandSource, Comparison, RecoverInputs, RecoverOutcome,
    Rgb, MAX_RECOVERY_GRID_STEPS,
};
pub use synth::{
    parse_exposure, parse_synth_size, synth_capture_photo, synth_lamp_photo, CapturePhotoJob,
    LampPhotoJob, LampPhotos, SynthPhoto, MAX_SYNTH_PIXELS,
};
pub use transmission::{
    band_transmissions, parse_transmission_grid, transmission_summary, TransmissionConfig,
    TransmissionInputs, TransmissionJob, COVERAGE_LEVEL,
};

pub(super) fn range(w: &[f64]) -> (f64, f64) {
    (w[0], w[w.len() - 1])
}

/// Reads a JSON file as text (BOM removed) and its source name.
pub(super) fn read_json_text(path: &Path, expected: &str) -> Result<(String, String)> {
    let (bytes, src) = crate::io::read_input(path)?;
    let text = crate::table::as_text(&bytes, &src, expected)?.to_string();
    Ok((text, src))
}

pub(super) fn json_value(text: &str, src: &str) -> Result<serde_json::Value> {
    serde_json::from_str(text).map_err(|e| {
        Error::parse(
            src,
            e.line(),
            format!("column {}: not JSON: {e}", e.column()),
        )
    })
}
