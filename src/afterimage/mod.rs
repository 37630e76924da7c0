//! Afterimages: the luminance and colour transitions of positive afterimages and frames that
//! show them over an image (Mikamo et al. 2013). Pure maths; images come in and go out through
//! [`crate::io`].
//!
//! - [`mikamo2013`]: Eq. 3 and Table 1 (curves), Eq. 1–2 and 4–6 (frames), §3.7 gamut
//!   correction, §3.8 blur, Eq. 7 dark adaptation.

pub mod mikamo2013;

pub use mikamo2013::{
    check_times, chromaticity_xy, curve_point, curves, luminance_y, time_grid, CurvePoint,
    DarkAdaptation, LinearImage, MaskRule, SynthParams, Synthesizer, TimeRange,
};
