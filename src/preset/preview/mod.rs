//! The reference preview of a preset (`lumifit preset preview`): a sphere on a floor under one
//! light ([`crate::render`]), shaded **through the same equations the shader snippets encode**
//! — the Rust twins of [`super::shader`] in `f32` — so the picture shows what a renderer that
//! loads the exported numbers shows.
//!
//! One row of panels per section the preset has:
//!
//! - **phosphorescence** ([`phosphor`]): the sphere lit by the charging light, then the glow at
//!   each time after switch-off, stepped with [`PhosphorTwin::step`](super::shader::PhosphorTwin::step)
//!   from the charging state and shaded with its `emission_rgb`; the floor is lit by the glowing
//!   sphere (exact view factor of a sphere). One exposure for every glow frame, so the decay is
//!   seen as it is.
//! - **fluorescence** ([`fluor`]): under each illuminant, the sphere shaded with
//!   [`FluorTwin::shade`](super::shader::FluorTwin::shade) (the reduced RGB matrix) beside the
//!   full spectral result of the Donaldson matrix (`S_xyzᵀ A e` through
//!   [`crate::fluor::evaluate::spectral_reference`], the function `fluor eval` uses), with the
//!   ΔE00 between the two in the protocol of `fluor eval`.
//! - **dispersion** ([`prism`]): a white beam through a 60° prism of the preset's n(λ) onto a
//!   screen, rendered with the preset's wavelength samples beside the 1 nm spectral reference
//!   ([`crate::dispersion::prism`]), with the ΔE00 along the screen.
//!
//! - **photometric light** ([`light`], a `lumifit.light/1` preset): the light hung above the
//!   scene, the illuminance of the library's cubature on the sphere and the floor, and the
//!   floor's illuminance from above in false colour.
//!
//! A material without any of these sections is an error naming the file and what was expected.

pub mod fluor;
pub mod light;
pub mod phosphor;
pub mod prism;

use serde::Serialize;

use crate::colorimetry::Illuminant;
use crate::error::{Error, Result};
use crate::fluor::DonaldsonMatrix;
use crate::render::{Light, Scene, Sheet};

use super::types::{LightPreset, MaterialPreset, Preset};

/// Which light the lit panels use.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LightKind {
    /// A distant light from the upper left front.
    Directional,
    /// A point light 3 units above and in front of the sphere.
    Point,
}

/// What to render.
#[derive(Debug, Clone)]
pub struct PreviewOptions {
    /// Side of one panel in pixels.
    pub size_px: usize,
    /// Illuminants: the first charges the phosphor and lights its lit panel; fluorescence gets a
    /// panel pair per illuminant; dispersion uses the section's own illuminant.
    pub illuminants: Vec<Illuminant>,
    /// Times after switch-off of the glow frames, s.
    pub times_s: Vec<f64>,
    /// Charging duration in s from the dark state; `None`: saturated (steady state).
    pub charge_s: Option<f64>,
    /// Length |E| of the per-band charging irradiance vector (the paper's normalisation is 1).
    pub charge_irradiance: f64,
    /// The light of the lit panels.
    pub light: LightKind,
    /// The measured Donaldson matrix of the fluorescence section (for the spectral reference),
    /// with the name it is reported under.
    pub donaldson: Option<(DonaldsonMatrix, String)>,
}

impl Default for PreviewOptions {
    fn default() -> Self {
        PreviewOptions {
            size_px: 256,
            illuminants: Vec::new(),
            times_s: vec![0.0, 1.0, 10.0, 80.0],
            charge_s: None,
            charge_irradiance: 1.0,
            light: LightKind::Directional,
            donaldson: None,
        }
    }
}

/// Largest number of glow frames or illuminants (one row of panels each).
pub const MAX_PANELS_PER_ROW: usize = 8;

/// What the preview computed, for `--report` (every number a panel shows).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PreviewReport {
    /// The preset's name.
    pub name: String,
    /// The sections rendered, in row order.
    pub rendered: Vec<&'static str>,
    /// The sections present but not rendered (no preview for them yet).
    pub not_rendered: Vec<&'static str>,
    /// Panel side in pixels.
    pub size_px: usize,
    /// The light of the lit panels.
    pub light: &'static str,
    /// Uniform ambient irradiance factor of the lit panels.
    pub ambient: f64,
    /// The phosphorescence row.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub phosphorescence: Option<phosphor::PhosphorReport>,
    /// The fluorescence rows.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fluorescence: Option<fluor::FluorReport>,
    /// The dispersion row.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub dispersion: Option<prism::PrismReport>,
    /// The photometric light row (light presets).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub photometric: Option<light::LightReport>,
}

/// A rendered preview: the sheet of panels and the report.
#[derive(Debug, Clone, PartialEq)]
pub struct Preview {
    /// The panels, ready for [`crate::plot`]'s preview sheet.
    pub sheet: Sheet,
    /// The numbers.
    pub report: PreviewReport,
}

/// The scene of the lit panels.
pub(crate) fn lit_scene(light: LightKind) -> Scene {
    let mut s = Scene::default();
    if light == LightKind::Point {
        // intensity 9 at distance ≈ 3: irradiance ≈ 1 at the sphere, as the directional light
        s.light = Some(Light::Point {
            position: [-1.6, 3.2, 2.0],
            intensity: 9.0,
        });
    }
    s
}

fn check_options(o: &PreviewOptions) -> Result<()> {
    crate::render::check_size("--size", o.size_px, o.size_px)?;
    if o.size_px < 32 {
        return Err(Error::invalid(
            "--size",
            format!("{} px; expected at least 32 px per panel", o.size_px),
        ));
    }
    crate::limits::check_count(
        "--times",
        o.times_s.len(),
        MAX_PANELS_PER_ROW,
        "glow frames in one row",
    )?;
    crate::limits::check_count(
        "--illuminant",
        o.illuminants.len(),
        MAX_PANELS_PER_ROW,
        "illuminants in one row",
    )?;
    if o.illuminants.is_empty() {
        return Err(Error::invalid(
            "--illuminant",
            "no illuminant; expected at least one (e.g. D65)",
        ));
    }
    Ok(())
}

/// The preview of `preset` (read from `file`, which errors name).
///
/// # Errors
/// A light preset, or a material preset with none of phosphorescence, fluorescence, dispersion
/// (naming `file` and the sections it has); bad options; numbers that overflow.
pub fn preview(preset: &Preset, file: &str, options: &PreviewOptions) -> Result<Preview> {
    match preset {
        Preset::Material(m) => preview_material(m, file, options),
        Preset::Light(l) => preview_light(l, file, options),
    }
}

/// The preview of a light preset (see [`light`]).
pub fn preview_light(
    preset: &LightPreset,
    file: &str,
    options: &PreviewOptions,
) -> Result<Preview> {
    check_options(options)?;
    let (row, r) = light::light_row(preset, file, options)?;
    Ok(Preview {
        sheet: Sheet {
            title: format!("{} — lumifit preset preview", preset.name),
            rows: vec![row],
            notes: vec![
                r.note.clone(),
                "Sphere (radius 1 m, reflectance 0.8) on a floor (0.5); radiance ρE/π; one exposure; sRGB."
                    .into(),
            ],
        },
        report: PreviewReport {
            name: preset.name.clone(),
            rendered: vec!["photometric"],
            not_rendered: Vec::new(),
            size_px: options.size_px,
            light: "the preset's photometric light",
            ambient: 0.0,
            phosphorescence: None,
            fluorescence: None,
            dispersion: None,
            photometric: Some(r),
        },
    })
}

/// The preview of a material preset (see [`preview`]).
pub fn preview_material(
    preset: &MaterialPreset,
    file: &str,
    options: &PreviewOptions,
) -> Result<Preview> {
    if preset.phosphorescence.is_none()
        && preset.fluorescence.is_none()
        && preset.dispersion.is_none()
    {
        let present = preset.sections();
        return Err(Error::invalid(
            format!("{file}: sections"),
            format!(
                "no section the preview renders; expected phosphorescence, fluorescence or \
                 dispersion; the preset has: {}",
                if present.is_empty() {
                    "none".to_string()
                } else {
                    present.join(", ")
                }
            ),
        ));
    }
    check_options(options)?;
    let mut rows = Vec::new();
    let mut rendered = Vec::new();
    let mut notes = Vec::new();
    let mut report = PreviewReport {
        name: preset.name.clone(),
        rendered: Vec::new(),
        not_rendered: Vec::new(),
        size_px: options.size_px,
        light: match options.light {
            LightKind::Directional => "directional",
            LightKind::Point => "point",
        },
        ambient: lit_scene(options.light).ambient,
        phosphorescence: None,
        fluorescence: None,
        dispersion: None,
        photometric: None,
    };
    if let Some(section) = &preset.phosphorescence {
        let (row, r) = phosphor::phosphor_row(preset, section, options)
            .map_err(|e| Error::invalid(format!("{file}: phosphorescence"), e.to_string()))?;
        rows.push(row);
        notes.push(r.note.clone());
        report.phosphorescence = Some(r);
        rendered.push("phosphorescence");
    }
    if let Some(section) = &preset.fluorescence {
        let (mut frows, r) = fluor::fluor_rows(section, options)
            .map_err(|e| Error::invalid(format!("{file}: fluorescence"), e.to_string()))?;
        rows.append(&mut frows);
        notes.push(r.note.clone());
        report.fluorescence = Some(r);
        rendered.push("fluorescence");
    }
    if let Some(section) = &preset.dispersion {
        let (row, r) = prism::prism_row(section, options)
            .map_err(|e| Error::invalid(format!("{file}: dispersion"), e.to_string()))?;
        rows.push(row);
        notes.push(r.note.clone());
        report.dispersion = Some(r);
        rendered.push("dispersion");
    }
    if preset.phosphorescence.is_some() || preset.fluorescence.is_some() {
        notes.push(format!(
            "Sphere (radius 1) on a grey floor (reflectance 0.5), {} light, ambient {} of its \
         irradiance; 3×3 samples per pixel; hue-preserving clip, sRGB.",
            report.light, report.ambient
        ));
    }
    report.not_rendered = preset
        .sections()
        .into_iter()
        .filter(|s| !rendered.contains(s))
        .collect();
    report.rendered = rendered;
    Ok(Preview {
        sheet: Sheet {
            title: format!("{} — lumifit preset preview", preset.name),
            rows,
            notes,
        },
        report,
    })
}

/// Three significant digits, compact (`0.0123`, `1.23e-5`).
pub(crate) fn sig3(v: f64) -> String {
    if v == 0.0 {
        "0".into()
    } else if v.abs() >= 1e-3 && v.abs() < 1e4 {
        let d = (2 - v.abs().log10().floor() as i32).max(0) as usize;
        format!("{v:.d$}")
    } else {
        format!("{v:.2e}")
    }
}
