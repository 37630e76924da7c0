//! Band transmission calibration from gel photos (filled next).
