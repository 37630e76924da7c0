//! `lumifit preset export PRESET.json --format gltf|openpbr|mtlx|wgsl|glsl --out FILE`: renderer
//! formats of a material preset (docs/export.md): glTF 2.0 (`.gltf` or `.glb`) of every material
//! section with an optional lit sphere, OpenPBR parameters (JSON) and a MaterialX 1.39 document,
//! WGSL/GLSL snippets of its phosphorescence, fluorescence, dispersion and afterimage sections.

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;
use lumifit::io::Outputs;
use lumifit::pipeline::preset_export::{run_export, ExportJob, GlowFlags};
use lumifit::preset::export::Scene;

use super::emit;

#[derive(Debug, Args)]
pub struct ExportArgs {
    /// Material preset.
    pub preset: PathBuf,
    /// gltf: a glTF 2.0 material of the reflectance, phosphorescence (emission and its decay as
    /// KHR_animation_pointer keys), fluorescence (extras) and dispersion sections, `.gltf` or
    /// `.glb` by the file name, plus the OpenPBR JSON as `<FILE stem>.openpbr.json` beside it;
    /// openpbr: only the OpenPBR JSON; mtlx: a MaterialX 1.39 open_pbr_surface document;
    /// wgsl / glsl: shader functions with the preset's numbers as constants. See docs/export.md.
    #[arg(long, value_parser = ["gltf", "openpbr", "mtlx", "wgsl", "glsl"])]
    pub format: String,
    /// Output file (`.gltf`/`.glb`, `.json`, `.mtlx`, `.wgsl` or `.glsl`; `-` for standard
    /// output with openpbr, mtlx, wgsl and glsl).
    #[arg(long)]
    pub out: PathBuf,
    /// gltf: add a UV sphere with the material, a camera and a directional light of π lux.
    #[arg(long, value_parser = ["sphere"])]
    pub scene: Option<String>,
    /// Linear RGB space of the colours: wgsl/glsl emission, openpbr/mtlx colours (srgb, acescg,
    /// display-p3; wgsl/glsl also rec2020). glTF is always linear sRGB.
    #[arg(long, default_value = "srgb")]
    pub space: String,
    /// KHR_materials_volume thicknessFactor in m (dispersion).
    #[arg(long, default_value_t = 1.0)]
    pub thickness_m: f64,
    /// Charging before switch-off: `saturated` (equilibrium under --charge-irradiance), `full`
    /// (every state at 1, the preset's reference state) or seconds of charging from empty.
    /// Default: saturated when every state has k_e, else full.
    #[arg(long)]
    pub charge_s: Option<String>,
    /// Irradiance while charging, one value for all bands or one per band, in the units the
    /// preset's k_e were fitted against.
    #[arg(long, default_value = "1")]
    pub charge_irradiance: String,
    /// Length of the glow animation in s (default: ln 1000 / slowest k_r).
    #[arg(long)]
    pub glow_s: Option<f64>,
    /// Error allowed to linear interpolation of the glow keys: `REL[,ABS]`, the error at time t
    /// being at most REL·|exact(t)| + ABS·peak in every channel.
    #[arg(long, default_value = "0.01,1e-4")]
    pub key_tolerance: String,
    /// cd/m² per unit of the preset's emission (glTF emission is luminance).
    #[arg(long, conflicts_with = "peak_luminance")]
    pub nits_per_unit: Option<f64>,
    /// Luminance of the glow at switch-off in cd/m² (sets the scale instead of --nits-per-unit).
    #[arg(long)]
    pub peak_luminance: Option<f64>,
}

/// Runs the export.
pub fn run(a: &ExportArgs) -> Result<()> {
    let mut out = Outputs::new();
    let report = run_export(&a.config()?, &mut out)?;
    out.commit()?;
    if let Some(note) = report.note {
        eprintln!("{note}");
    }
    match report.summary {
        Some(s) => emit(&s),
        None => Ok(()),
    }
}

impl ExportArgs {
    fn config(&self) -> Result<ExportJob> {
        Ok(ExportJob {
            preset: self.preset.clone(),
            format: self.format.parse()?,
            out: self.out.clone(),
            scene: if self.scene.is_some() {
                Scene::Sphere
            } else {
                Scene::None
            },
            space: self.space.clone(),
            thickness_m: self.thickness_m,
            glow: GlowFlags {
                charge_s: self.charge_s.clone(),
                charge_irradiance: self.charge_irradiance.clone(),
                glow_s: self.glow_s,
                key_tolerance: self.key_tolerance.clone(),
                nits_per_unit: self.nits_per_unit,
                peak_luminance: self.peak_luminance,
            },
        })
    }
}
