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

/// The one XYZ scale of the command line: Y = 100 for the reference white (what
/// [`sd_to_xyz`] returns for a reflectance, and what `color xyz`/`color table` print).
/// Conversions between colour spaces work on colour's "reference" scale 0–1; a command that
/// takes XYZ divides by the scale it was given (`--scale 100|1`) and names it in its output.
pub const XYZ_SCALE: f64 = 100.0;

/// Checks a luminance `y` typed on `scale` (100 or 1) for a `representation` (`xyz`, `xyy`):
/// a negative Y is refused; a Y that looks like the other scale returns a warning that says
/// which flag fixes it.
///
/// # Errors
/// [`crate::Error::InvalidArgument`] (field `--value`) for a negative Y.
pub fn xyz_scale_warnings(representation: &str, y: f64, scale: f64) -> crate::Result<Vec<String>> {
    if y < 0.0 {
        return Err(crate::Error::invalid(
            "--value",
            format!("Y = {y} of {representation} is negative; tristimulus values are ≥ 0"),
        ));
    }
    let mut w = Vec::new();
    if scale == 1.0 && y > 1.5 {
        w.push(format!(
            "Y = {y} on the 0–1 scale is {:.0}× the reference white; values from `color xyz` \
             are on the 0–100 scale: drop --scale 1",
            y
        ));
    } else if scale == 100.0 && y > 0.0 && y <= 1.5 {
        w.push(format!(
            "Y = {y} on the 0–100 scale is {:.2} % of the reference white (very dark); if the \
             value is on colour's 0–1 scale, add --scale 1",
            y
        ));
    }
    Ok(w)
}
