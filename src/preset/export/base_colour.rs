//! The base colour of a material from its reflectance section, through the project's colorimetry.
//!
//! `XYZ = sd_to_xyz(ρ, CIE 1931 2°, D65, integration)` on the 0–100 scale, divided by the Y of
//! the perfect reflector under D65 on the same grid (so a flat ρ = 1 gives Y = 1), then
//! `rgb = xyz_to_rgb(XYZ, D65 white, space, CAT02, linear)` — `colour.XYZ_to_RGB` without the
//! transfer function. For sRGB (glTF's space: linear Rec. 709 primaries, D65 white) the
//! adaptation is the identity; for ACEScg it adapts D65 to the space's white.
//!
//! glTF and OpenPBR want a base colour in [0, 1]: channels outside (an out-of-gamut colour, or a
//! reflectance above 1) are clipped, and the unclipped value is kept to say so.

use crate::colorimetry::cat::Cat;
use crate::colorimetry::rgb::{xyz_to_rgb, RgbSpace};
use crate::colorimetry::summary::sd_colour;
use crate::colorimetry::xyy::xyz_to_xy;
use crate::colorimetry::{Illuminant, Observer, StandardObserver, XyzMethod};
use crate::error::{ensure_finite, Result};
use crate::preset::ReflectanceSection;
use crate::spectrum::Spectrum;

/// What the colorimetry stated above is called in the exports.
pub const COLORIMETRY: &str = "CIE 1931 2° observer, D65 illuminant, integration (lumifit colorimetry::sd_to_xyz), CAT02 to the space's white";

/// A reflectance's colour in a linear RGB working space.
#[derive(Debug, Clone, PartialEq)]
pub struct BaseColour {
    /// Linear RGB before clipping.
    pub linear_rgb: [f64; 3],
    /// Linear RGB clipped to [0, 1] (the value written).
    pub factor: [f64; 3],
    /// True when clipping changed a channel.
    pub clipped: bool,
    /// XYZ relative to the D65 white (Y = 1 for the perfect reflector).
    pub xyz: [f64; 3],
    /// The working space's key (`srgb`, `acescg`, …).
    pub space: String,
}

/// Clips linear RGB to [0, 1], saying whether anything changed.
pub fn clip_unit(rgb: [f64; 3]) -> ([f64; 3], bool) {
    let c = rgb.map(|v| v.clamp(0.0, 1.0));
    (c, c != rgb)
}

/// The base colour of `section` in linear `space` (see the module docs); `file` names the preset
/// in errors.
pub fn reflectance_to_base_colour(
    section: &ReflectanceSection,
    space: &RgbSpace,
    file: &str,
) -> Result<BaseColour> {
    let sd = Spectrum::new(
        format!("{file}: reflectance"),
        section.wavelength_nm.clone(),
        section.value.clone(),
    )?;
    let observer = Observer::standard(StandardObserver::Cie1931_2)?;
    let d65 = Illuminant::standard("D65")?;
    let c = sd_colour(&sd, observer, &d65, XyzMethod::Integration, None, file)?;
    let xyz = c.xyz.map(|v| v / c.white_xyz[1]);
    let white_xy = xyz_to_xy(c.white_xyz, crate::colorimetry::rgb::D65_XY);
    let rgb = xyz_to_rgb(xyz, white_xy, space, Some(Cat::Cat02), false)?;
    ensure_finite("base colour (linear RGB)", file, &rgb)?;
    let (factor, clipped) = clip_unit(rgb);
    Ok(BaseColour {
        linear_rgb: rgb,
        factor,
        clipped,
        xyz,
        space: space.key.clone(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn flat(v: f64) -> ReflectanceSection {
        ReflectanceSection::new(vec![380.0, 780.0], vec![v, v])
    }

    #[test]
    fn a_flat_reflectance_is_neutral_grey_of_its_value_in_linear_srgb() {
        let srgb = RgbSpace::srgb().unwrap();
        let c = reflectance_to_base_colour(&flat(0.18), &srgb, "t").unwrap();
        for ch in c.linear_rgb {
            // D65 white and sRGB's white differ only by the rounding of xy (1e-4 in the matrix).
            assert!((ch - 0.18).abs() < 2e-3, "{:?}", c.linear_rgb);
        }
        assert!(!c.clipped);
        assert!((c.xyz[1] - 0.18).abs() < 1e-12);
    }

    #[test]
    fn a_reflectance_above_one_is_clipped_and_says_so() {
        let srgb = RgbSpace::srgb().unwrap();
        let c = reflectance_to_base_colour(&flat(1.3), &srgb, "t").unwrap();
        assert!(c.clipped);
        assert_eq!(c.factor, [1.0; 3]);
    }

    #[test]
    fn a_red_reflectance_is_red() {
        let srgb = RgbSpace::srgb().unwrap();
        let s =
            ReflectanceSection::new(vec![400.0, 550.0, 600.0, 700.0], vec![0.05, 0.05, 0.8, 0.9]);
        let c = reflectance_to_base_colour(&s, &srgb, "t").unwrap();
        assert!(c.factor[0] > 3.0 * c.factor[1] && c.factor[0] > 3.0 * c.factor[2]);
    }
}
