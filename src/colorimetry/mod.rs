//! Colorimetry: observers, illuminants, spectral → XYZ, colour spaces, colour differences, CCT.
//!
//! Conventions follow colour-science's "reference" domain-range scale: tristimulus values from
//! spectra are on the 0–100 scale (as `colour.sd_to_XYZ`), while the colour-space conversions
//! (`xyz_to_lab`, `xyz_to_rgb`, …) take XYZ on the 0–1 scale (as `colour.XYZ_to_Lab`).

pub mod blackbody;
pub mod cat;
pub mod cct;
pub mod daylight;
pub mod delta_e;
pub mod illuminant;
pub mod lab;
pub mod observer;
pub mod rgb;
pub mod summary;
pub mod tristimulus;
pub mod xyy;

pub use illuminant::Illuminant;
pub use observer::{Observer, StandardObserver};
pub use tristimulus::{illuminant_white, sd_to_xyz, Tristimulus, XyzMethod, XyzOperator};
