//! Shader snippets (WGSL and GLSL 4.50) that carry a preset's numbers into a renderer, and their
//! Rust twins.
//!
//! Each section becomes a small set of functions with the preset's numbers as constants:
//!
//! - **phosphorescence** — the exact per-frame update of the state concentrations r_i under a
//!   frame's irradiance E[b] (constant over the frame) and time step h (Nalbach 2017, Eq. 1):
//!
//!   `a_i = Σ_b k_e,i[b] E[b]`, `λ_i = a_i + k_r,i`, `r_eq = a_i/λ_i`,
//!   `r_i(t+h) = r_eq + (r_i − r_eq)·exp(−λ_i h)`,
//!
//!   and the emission (Eq. 3) `L[b] = Σ_i λ_i[b]·k_r,i·r_i` folded into linear RGB of the working
//!   space: `rgb = Σ_i r_i·C_i` with `C_i = k_r,i Σ_b lambda_i[b]·M[:, b]`, where M maps band b
//!   to RGB (the identity for `"rgb"` bands; for wavelength bands the CIE 1931 2° colour of a flat
//!   spectrum over the band, with the band's emission spread evenly, through the space's XYZ → RGB
//!   matrix). Up to four states are packed in a `vec4` (unused lanes have k_r = 1, k_e = 0 and
//!   stay at 0).
//! - **fluorescence** — the reduced 3×3 matrix of `fluorescence.rgb.matrix` (Fichet 2024 Eq. 16):
//!   `rgb_out = M · rgb_in`, where `rgb_in` is the light arriving in the space of
//!   `fluorescence.rgb.space` and `rgb_out` what the material sends back. M has negative entries
//!   off the diagonal; the sum can dip below zero only for lights the reduction does not
//!   represent, so the snippet clamps the result at 0 and says so.
//! - **dispersion** — the wavelength samples (λ_i in nm and their linear RGB weights in the
//!   section's working space, summing to its white) and the fitted refractive-index model:
//!   `disp_sample_count()`, `disp_sample(i) = (weight.rgb, λ)` and `disp_ior(λ_nm)`, Cauchy by
//!   Horner in λ⁻² or Sellmeier `sqrt(1 + Σ Bᵢλ²/(λ² − Cᵢ))`, λ in µm, as
//!   [`crate::dispersion::model::Model::n_um`] evaluates it.
//! - **afterimage** (`mikamo2013`) — Eq. 3, Table 1 with its Catmull-Rom interpolation, the curve
//!   Lab and, per pixel, Eq. 4–6 with the gamut correction of §3.7 (`afterimage_at(t, rgb)`, as
//!   [`crate::afterimage::mikamo2013::Synthesizer::afterimage_unblurred`] for one pixel), plus
//!   Eq. 7's background weight when the section records it. The image-level steps (normalisation
//!   by the brightest Y, mask, blur, background) are the renderer's.
//!
//! The snippets are generated from the same `f32` constants the twins ([`PhosphorTwin`],
//! [`FluorTwin`], [`DispersionTwin`], [`AfterimageTwin`]) use, so the twin computes what the shader computes, operation for operation, in
//! the same precision; the twins are tested against the library's own `f64` simulation and
//! reduction, and the snippets are parsed and validated by `naga` in `tests/shader_export.rs`.

pub mod keyframes;
mod text;
mod twin;

pub use twin::{
    AfterimageTwin, DispersionTwin, FluorTwin, IorKind, PhosphorTwin, MAX_DISPERSION_COEFFICIENTS,
    MAX_DISPERSION_SAMPLES,
};

use crate::colorimetry::rgb::RgbSpace;
use crate::colorimetry::{Observer, StandardObserver};
use crate::error::{Error, Result};

use super::types::{Bands, FluorescenceSection, MaterialPreset, PhosphorescenceSection};

/// Shading language of a snippet.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ShaderLanguage {
    /// WebGPU Shading Language.
    Wgsl,
    /// OpenGL Shading Language 4.50.
    Glsl,
}

/// Maximum number of phosphorescent states a snippet packs (one `vec4`).
pub const MAX_STATES: usize = 4;

/// Maximum number of bands of a phosphorescence snippet's irradiance array.
pub const MAX_BANDS: usize = 64;

/// The 3 × B matrix that turns per-band emission into linear RGB of `space`: identity for RGB
/// bands; for wavelength bands the mean of the CIE 1931 2° CMFs over each band (a flat spectrum
/// of unit integrated power over the band) through the space's XYZ → RGB matrix.
pub fn band_to_rgb(bands: &Bands, space: &RgbSpace) -> Result<Vec<[f64; 3]>> {
    match bands {
        Bands::Rgb => Ok(vec![[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]),
        Bands::RangesNm(ranges) => {
            let obs = Observer::standard(StandardObserver::Cie1931_2)?;
            let cmfs = obs.cmfs();
            let wl = cmfs.wavelengths();
            let m = space.matrix_xyz_to_rgb;
            ranges
                .iter()
                .map(|&[lo, hi]| {
                    // Mean CMF over [lo, hi] by the trapezoid rule on the CMF grid, clipped to
                    // the band (1 nm steps in lumifit's tables).
                    let mut xyz = [0.0; 3];
                    let mut width = 0.0;
                    for i in 0..wl.len().saturating_sub(1) {
                        let (a, b) = (wl[i].max(lo), wl[i + 1].min(hi));
                        if b <= a {
                            continue;
                        }
                        let t = |x: f64, c: usize| {
                            let f = (x - wl[i]) / (wl[i + 1] - wl[i]);
                            cmfs.channel(c)[i] * (1.0 - f) + cmfs.channel(c)[i + 1] * f
                        };
                        for (c, v) in xyz.iter_mut().enumerate() {
                            *v += 0.5 * (t(a, c) + t(b, c)) * (b - a);
                        }
                        width += b - a;
                    }
                    if width <= 0.0 {
                        return Err(Error::invalid(
                            "phosphorescence.bands",
                            format!(
                                "band [{lo}, {hi}] nm lies outside the CIE 1931 CMFs ({}–{} nm)",
                                wl[0],
                                wl[wl.len() - 1]
                            ),
                        ));
                    }
                    let band = hi - lo;
                    let xyz = xyz.map(|v| v / band);
                    Ok([0, 1, 2].map(|r| (0..3).map(|c| m[r][c] * xyz[c]).sum()))
                })
                .collect()
        }
    }
}

/// The snippet of a phosphorescence section (see the module docs for the equations).
pub fn phosphorescence_snippet(
    name: &str,
    section: &PhosphorescenceSection,
    space: &RgbSpace,
    language: ShaderLanguage,
) -> Result<String> {
    let twin = PhosphorTwin::from_section(section, space)?;
    Ok(text::phosphorescence(language, name, &space.key, &twin))
}

/// The snippet of a fluorescence section (its `rgb.matrix`).
pub fn fluorescence_snippet(
    name: &str,
    section: &FluorescenceSection,
    language: ShaderLanguage,
) -> Result<String> {
    let twin = FluorTwin::from_section(section)?;
    Ok(text::fluorescence(language, name, &twin))
}

/// The snippet of a dispersion section: its wavelength samples and refractive index model.
pub fn dispersion_snippet(
    name: &str,
    section: &super::dispersion::DispersionSection,
    language: ShaderLanguage,
) -> Result<String> {
    let twin = DispersionTwin::from_section(section)?;
    Ok(text::dispersion(language, name, &twin))
}

/// The snippet of an afterimage section (`method` `mikamo2013`).
pub fn afterimage_snippet(
    name: &str,
    section: &super::afterimage::AfterimageSection,
    language: ShaderLanguage,
) -> Result<String> {
    let twin = AfterimageTwin::from_section(section)?;
    Ok(text::afterimage(language, name, &twin))
}

/// Every snippet a material preset can carry, one after the other: phosphorescence (emission
/// in linear `space`), fluorescence (in the space its matrix was reduced to), dispersion
/// (weights in the section's working space) and afterimage (linear sRGB, the model's display). `file` names the
/// preset in the error when it has none of these sections.
pub fn material_snippets(
    preset: &MaterialPreset,
    file: &str,
    space: &RgbSpace,
    language: ShaderLanguage,
) -> Result<String> {
    let mut parts = Vec::new();
    if let Some(p) = &preset.phosphorescence {
        parts.push(phosphorescence_snippet(&preset.name, p, space, language)?);
    }
    if let Some(f) = &preset.fluorescence {
        parts.push(fluorescence_snippet(&preset.name, f, language)?);
    }
    if let Some(d) = &preset.dispersion {
        parts.push(dispersion_snippet(&preset.name, d, language)?);
    }
    if let Some(a) = &preset.afterimage {
        let section = super::afterimage::AfterimageSection::from_section(a, file)?;
        parts.push(afterimage_snippet(&preset.name, &section, language)?);
    }
    if parts.is_empty() {
        let present: Vec<&str> = [("reflectance", preset.reflectance.is_some())]
            .iter()
            .filter(|(_, has)| *has)
            .map(|(n, _)| *n)
            .collect();
        return Err(Error::invalid(
            format!("{file}: sections"),
            format!(
                "no section a shader snippet carries (phosphorescence, fluorescence, dispersion, afterimage); the preset has: {}",
                if present.is_empty() { "none".to_string() } else { present.join(", ") }
            ),
        ));
    }
    let header = match language {
        ShaderLanguage::Wgsl => "",
        ShaderLanguage::Glsl => "// Include in a GLSL 4.50 shader (after its #version line).\n",
    };
    Ok(format!("{header}{}", parts.join("\n")))
}

/// A float literal that parses back to exactly `v` in both languages (shortest round-trip form,
/// always with a decimal point or exponent so it is a float, not an integer).
pub(crate) fn lit(v: f32) -> String {
    let s = format!("{v:?}");
    if s.contains('.') || s.contains('e') || s.contains("inf") || s.contains("NaN") {
        s
    } else {
        format!("{s}.0")
    }
}

/// A comment-safe preset name (no line breaks or comment terminators).
pub(crate) fn comment_name(name: &str) -> String {
    name.chars()
        .map(|c| if c.is_control() { ' ' } else { c })
        .collect::<String>()
        .replace("*/", "* /")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn float_literals_round_trip_and_are_floats() {
        for v in [0.1f32, 1.0, 1e-7, 3.4e38, -2.5, 0.0] {
            let s = lit(v);
            assert!(s.contains('.') || s.contains('e'), "{s}");
            assert_eq!(s.parse::<f32>().unwrap().to_bits(), v.to_bits(), "{s}");
        }
    }

    #[test]
    fn rgb_bands_map_to_the_identity_and_wavelength_bands_to_their_colour() {
        let srgb = RgbSpace::srgb().unwrap();
        let id = band_to_rgb(&Bands::Rgb, &srgb).unwrap();
        assert_eq!(id[1], [0.0, 1.0, 0.0]);
        let m = band_to_rgb(
            &Bands::RangesNm(vec![[440.0, 460.0], [600.0, 620.0]]),
            &srgb,
        )
        .unwrap();
        assert!(m[0][2] > m[0][0], "a blue band is blue: {:?}", m[0]);
        assert!(m[1][0] > m[1][2], "an orange band is red: {:?}", m[1]);
        assert!(band_to_rgb(&Bands::RangesNm(vec![[900.0, 950.0]]), &srgb).is_err());
    }
}
