//! The phosphorescence row: the sphere lit by the charging light, then its glow after
//! switch-off, every number from [`PhosphorTwin`] (the snippet's `f32` update and emission).
//!
//! - **Charging irradiance** `E[b]`: the first `--illuminant`'s spectrum averaged over each
//!   wavelength band (exact integral of its piecewise-linear samples,
//!   [`crate::phosphor::excitation::band_means_exact`]); for `"rgb"` bands, the illuminant's
//!   white (CIE 1931 2°) in linear sRGB. Then scaled to length `|E| = --charge-irradiance`
//!   (default 1, the normalisation the paper's k_e are fitted for, Nalbach 2017 §4.6).
//! - **Charging history**: from the dark state `r = 0`, one frame of length `--charge-s` under
//!   `E` (the snippet's exact update); without `--charge-s` the material is **saturated**: the
//!   update's limit `h → ∞`, `r_i = a_i/(a_i + k_r,i)` (steady state under `E`). A state without
//!   `k_e` is never charged (the snippet's k_e = 0) and the report lists it; a decay-only preset
//!   (no state has `k_e`, as `phos fit-decay` writes them) starts its glow from `r_i = 1`.
//! - **Glow** at each `t` of `--times`: one update of length `t` in the dark from the charged
//!   state, emission `Σ_i r_i C_i` in linear sRGB; the sphere is a uniform Lambertian emitter of
//!   that radiance and the floor (reflectance 0.5) receives `π L (R/d)² cos θ_c` from it. One
//!   exposure for every glow frame (the brightest channel of the earliest frame at 0.85), so the
//!   panels show the decay, not a re-exposed copy.
//! - **Lit panel**: the charging light on; the sphere's base colour is the preset's
//!   `reflectance` under the illuminant (CIE 1931 2°, integration), adapted to D65 (CAT02) and
//!   shown in sRGB; without a reflectance section it is a neutral 0.8. The emission while lit is
//!   not added: the preset's emission is in the units of the fitted k_e and Λ, not in units of
//!   the reflected light.

use serde::Serialize;

use super::{lit_scene, sig3, PreviewOptions};
use crate::colorimetry::cat::{chromatic_adaptation_matrix, Cat};
use crate::colorimetry::rgb::RgbSpace;
use crate::colorimetry::tristimulus::{illuminant_white, sd_to_xyz, XyzMethod};
use crate::colorimetry::{Illuminant, Observer, StandardObserver};
use crate::error::{ensure_finite, Error, Result};
use crate::math::linalg::{mat3_mul, mat3_mul_vec};
use crate::phosphor::excitation::{band_means_exact, unit_length};
use crate::preset::shader::{PhosphorTwin, MAX_STATES};
use crate::preset::types::{Bands, MaterialPreset, PhosphorescenceSection};
use crate::render::{Panel, Scene, ShadeInput, Shader, SheetRow, Surface};
use crate::spectrum::Spectrum;

/// Exposure of the lit panels: a white Lambertian surface facing the light shows 0.7.
pub const LIT_EXPOSURE: f64 = 0.7 * std::f64::consts::PI;
/// Reflectance of the floor.
pub const FLOOR_REFLECTANCE: f64 = 0.5;
/// Brightest channel of the earliest glow frame after exposure.
pub const GLOW_PEAK: f64 = 0.85;

/// The charging light as the preview applied it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ChargeReport {
    /// Illuminant name.
    pub illuminant: String,
    /// Irradiance per band (length `|E|`).
    pub irradiance_per_band: Vec<f64>,
    /// Charging time in s from the dark state; `None` when saturated.
    pub duration_s: Option<f64>,
    /// True for the steady state (no `--charge-s`).
    pub saturated: bool,
    /// True when no state has k_e (a decay-only preset): every state starts at r = 1.
    pub decay_only: bool,
    /// States without k_e in a preset where others have one: never charged (k_e = 0).
    pub uncharged_states: Vec<usize>,
}

/// One glow frame.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct GlowFrame {
    /// Time after switch-off, s.
    pub t_s: f64,
    /// Concentration per state.
    pub r: Vec<f64>,
    /// Emitted linear sRGB radiance of the sphere (twin, f32).
    pub emission_rgb: [f64; 3],
}

/// The numbers of the phosphorescence row.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PhosphorReport {
    /// RGB space of the emission.
    pub space: String,
    /// Number of bands and states.
    pub n_bands: usize,
    /// Number of states.
    pub n_states: usize,
    /// The charging light.
    pub charge: ChargeReport,
    /// Concentrations at switch-off.
    pub r_charged: Vec<f64>,
    /// Glow frames in `--times` order.
    pub frames: Vec<GlowFrame>,
    /// Exposure applied to every glow frame.
    pub glow_exposure: f64,
    /// Linear sRGB base colour of the lit panel.
    pub albedo_linear_srgb: [f64; 3],
    /// Where the base colour came from.
    pub albedo_from: String,
    /// One line for the sheet's notes.
    pub note: String,
}

/// Per-band charging irradiance of `ill` for `bands`, length `length`.
pub fn charging_irradiance(bands: &Bands, ill: &Illuminant, length: f64) -> Result<Vec<f64>> {
    if !(length.is_finite() && length >= 0.0) {
        return Err(Error::invalid(
            "--charge-irradiance",
            format!("{length}; expected a finite value ≥ 0"),
        ));
    }
    let raw = match bands {
        Bands::RangesNm(ranges) => {
            let sd = ill.spectrum();
            band_means_exact(sd.wavelengths(), sd.values(), ranges)?
        }
        Bands::Rgb => {
            let obs = Observer::standard(StandardObserver::Cie1931_2)?;
            let w = illuminant_white(
                obs,
                ill,
                XyzMethod::Integration,
                ill.spectrum().wavelengths(),
                None,
            )?;
            let srgb = RgbSpace::srgb()?;
            mat3_mul_vec(&srgb.matrix_xyz_to_rgb, w.xyz.map(|v| v / 100.0))
                .map(|v| v.max(0.0))
                .to_vec()
        }
    };
    let unit = unit_length(&raw).map_err(|e| {
        Error::invalid(
            format!("--illuminant {}", ill.name()),
            format!("{e} (no light of this illuminant in the preset's bands)"),
        )
    })?;
    Ok(unit.into_iter().map(|v| v * length).collect())
}

/// Linear sRGB base colour of the preset's reflectance under `ill`, adapted to D65, and where
/// it came from.
fn albedo(preset: &MaterialPreset, ill: &Illuminant) -> Result<([f64; 3], String)> {
    let Some(r) = &preset.reflectance else {
        return Ok(([0.8; 3], "no reflectance section: neutral 0.8".to_string()));
    };
    let obs = Observer::standard(StandardObserver::Cie1931_2)?;
    let sd = Spectrum::new("reflectance", r.wavelength_nm.clone(), r.value.clone())?;
    let xyz = sd_to_xyz(&sd, obs, ill, XyzMethod::Integration, None)?;
    let white = illuminant_white(obs, ill, XyzMethod::Integration, &r.wavelength_nm, None)?;
    let srgb = RgbSpace::srgb()?;
    let d65 = mat3_mul_vec(&srgb.matrix_rgb_to_xyz, [1.0; 3]);
    let cat = chromatic_adaptation_matrix(white.xyz.map(|v| v / 100.0), d65, Cat::Cat02)?;
    let m = mat3_mul(&srgb.matrix_xyz_to_rgb, &cat);
    let rgb = mat3_mul_vec(&m, xyz.xyz.map(|v| v / 100.0));
    ensure_finite("the base colour", "the reflectance section", &rgb)?;
    Ok((
        rgb,
        format!("reflectance under {}, CAT02 to D65", ill.name()),
    ))
}

struct LitShader {
    albedo: [f64; 3],
}

impl Shader for LitShader {
    fn shade(&self, hit: &ShadeInput) -> [f64; 3] {
        let k = hit.irradiance / std::f64::consts::PI;
        match hit.surface {
            Surface::Sphere => self.albedo.map(|a| a * k),
            Surface::Floor => [FLOOR_REFLECTANCE * k; 3],
        }
    }
    fn background(&self) -> [f64; 3] {
        [0.01; 3]
    }
}

struct GlowShader {
    radiance: [f64; 3],
}

impl Shader for GlowShader {
    fn shade(&self, hit: &ShadeInput) -> [f64; 3] {
        match hit.surface {
            Surface::Sphere => self.radiance,
            // ρ/π · π L F
            Surface::Floor => self
                .radiance
                .map(|l| FLOOR_REFLECTANCE * l * hit.sphere_view_factor),
        }
    }
}

/// The lit panel and the glow panels, and their numbers.
pub fn phosphor_row(
    preset: &MaterialPreset,
    section: &PhosphorescenceSection,
    o: &PreviewOptions,
) -> Result<(SheetRow, PhosphorReport)> {
    for &t in &o.times_s {
        if !(t.is_finite() && t >= 0.0) {
            return Err(Error::invalid(
                "--times",
                format!("{t} s; expected finite times ≥ 0 after switch-off"),
            ));
        }
    }
    if o.times_s.is_empty() {
        return Err(Error::invalid(
            "--times",
            "no time; expected e.g. 0,1,10,80",
        ));
    }
    if let Some(c) = o.charge_s {
        if !(c.is_finite() && c > 0.0) {
            return Err(Error::invalid(
                "--charge-s",
                format!("{c} s; expected a finite charging time > 0"),
            ));
        }
    }
    let ill = &o.illuminants[0];
    let srgb = RgbSpace::srgb()?;
    let twin = PhosphorTwin::from_section(section, &srgb)?;
    let e = charging_irradiance(&section.bands, ill, o.charge_irradiance)?;
    let e32: Vec<f32> = e.iter().map(|&v| v as f32).collect();
    let dark = vec![0.0f32; twin.n_bands];
    let decay_only = section.states.iter().all(|s| s.k_e.is_none());
    let r_charged = if decay_only {
        std::array::from_fn(|i| if i < twin.n_states { 1.0 } else { 0.0 })
    } else {
        twin.step(
            [0.0; MAX_STATES],
            &e32,
            o.charge_s.map_or(f32::INFINITY, |c| c as f32),
        )
    };
    let uncharged: Vec<usize> = section
        .states
        .iter()
        .enumerate()
        .filter(|(_, s)| !decay_only && s.k_e.is_none())
        .map(|(i, _)| i)
        .collect();
    let frames: Vec<GlowFrame> = o
        .times_s
        .iter()
        .map(|&t| {
            let r = twin.step(r_charged, &dark, t as f32);
            GlowFrame {
                t_s: t,
                r: r[..twin.n_states].iter().map(|&v| f64::from(v)).collect(),
                emission_rgb: twin.emission_rgb(r).map(f64::from),
            }
        })
        .collect();
    let all: Vec<f64> = frames
        .iter()
        .flat_map(|f| f.emission_rgb.iter().chain(&f.r).copied())
        .collect();
    ensure_finite("the glow", "the phosphorescence section", &all)?;
    let earliest = frames
        .iter()
        .min_by(|a, b| a.t_s.total_cmp(&b.t_s))
        .map_or(0.0, |f| f.emission_rgb.iter().copied().fold(0.0, f64::max));
    let glow_exposure = if earliest > 0.0 {
        GLOW_PEAK / earliest
    } else {
        1.0
    };

    let size = o.size_px;
    let (albedo, albedo_from) = albedo(preset, ill)?;
    let lit = lit_scene(o.light).render(size, size, &LitShader { albedo })?;
    let charge_text = match o.charge_s {
        _ if decay_only => "decay only (no k_e): r = 1 at switch-off".to_string(),
        Some(c) => format!("charged {} s, |E| = {}", sig3(c), sig3(o.charge_irradiance)),
        None => format!("saturated, |E| = {}", sig3(o.charge_irradiance)),
    };
    let mut panels = vec![Panel {
        image: lit.to_srgb8(LIT_EXPOSURE),
        title: format!("lit by {}", ill.name()),
        lines: vec![
            charge_text.clone(),
            if preset.reflectance.is_some() {
                "base colour: reflectance".into()
            } else {
                "base colour: grey 0.8".into()
            },
        ],
    }];
    let dark_scene = Scene {
        light: None,
        ..lit_scene(o.light)
    };
    for f in &frames {
        let img = dark_scene.render(
            size,
            size,
            &GlowShader {
                radiance: f.emission_rgb,
            },
        )?;
        let [r, g, b] = f.emission_rgb;
        panels.push(Panel {
            image: img.to_srgb8(glow_exposure),
            title: format!("t = {} s", f.t_s),
            lines: vec![format!("L = {} {} {}", sig3(r), sig3(g), sig3(b))],
        });
    }
    let mut note = format!(
        "Phosphorescence: PhosphorTwin (f32, the WGSL/GLSL update) charged by {} ({}), then dark; \
         glow frames share one exposure (×{}); L in linear sRGB, units of the preset's k_e and Λ.",
        ill.name(),
        charge_text,
        sig3(glow_exposure)
    );
    if !uncharged.is_empty() {
        note.push_str(&format!(
            " States {uncharged:?} have no k_e and stay dark (the snippet's k_e = 0)."
        ));
    }
    let report = PhosphorReport {
        space: srgb.key.clone(),
        n_bands: twin.n_bands,
        n_states: twin.n_states,
        charge: ChargeReport {
            illuminant: ill.name().to_string(),
            irradiance_per_band: e,
            duration_s: o.charge_s,
            saturated: o.charge_s.is_none() && !decay_only,
            decay_only,
            uncharged_states: uncharged,
        },
        r_charged: r_charged[..twin.n_states]
            .iter()
            .map(|&v| f64::from(v))
            .collect(),
        frames,
        glow_exposure,
        albedo_linear_srgb: albedo,
        albedo_from,
        note,
    };
    Ok((
        SheetRow {
            heading: format!(
                "Phosphorescence ({} states, {} bands): lit, then glow after switch-off",
                twin.n_states, twin.n_bands
            ),
            panels,
        },
        report,
    ))
}
