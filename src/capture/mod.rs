//! Captured frames, regions of interest and photo series in memory (no file system).
//!
//! A [`RgbFrame`] holds linear camera RGB: 0 is the black level, 1 the white level, and each
//! pixel carries a per-channel saturation flag (saturated photosites are masked, never
//! averaged). Frames decoded from a Bayer RAW are half resolution (2×2 superpixels: R, mean of
//! the two G, B); they remember this as `pixel_scale = 2`, so that regions of interest are always
//! given in the *source* image's pixels (the coordinates a user reads off a developed image).
//!
//! Relative radiance of a frame value *v* shot with exposure time *t* (s), sensitivity ISO and
//! f-number *N* is *v* / (*t* · ISO/100 / *N*²) ([`Exposure::factor`]).
//!
//! Readers that fill these types live in the `io` module (layer 3); this module does no I/O.

pub mod frame;
pub mod rng;
pub mod roi;
pub mod series;
pub mod synth;

pub use frame::{civil_to_seconds, parse_datetime, Exposure, FrameInfo, RgbFrame};
pub use roi::{roi_stats, Roi, RoiStats};
pub use series::{CurveSample, PhotoSeries, SeriesFrame};
