//! `lumifit preset export PRESET.json --format gltf|openpbr|mtlx|wgsl|glsl --out FILE`: renderer
//! formats of a material preset (docs/export.md): glTF 2.0 (`.gltf` or `.glb`) of every material
//! section with an optional lit sphere, OpenPBR parameters (JSON) and a MaterialX 1.39 document,
//! WGSL/GLSL snippets of its phosphorescence, fluorescence, dispersion and afterimage sections.

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;
use lumifit::colorimetry::rgb::RgbSpace;
use lumifit::io::Outputs;
use lumifit::preset::export::{
    material_gltf, materialx_document, openpbr_parameters, Charge, EmissionScale, ExportOptions,
    GlowOptions, OpenPbrOptions, Scene,
};
use lumifit::preset::read_material;
use lumifit::preset::shader::keyframes::KeyframeTolerance;
use lumifit::preset::shader::{material_snippets, ShaderLanguage};
use serde_json::json;

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
    if a.format == "gltf" {
        // a lumifit.light/1 preset: the photometric light (commands/light.rs)
        if let lumifit::preset::Preset::Light(l) = lumifit::preset::read_preset(&a.preset)? {
            let mut out = Outputs::new();
            let line =
                lumifit::pipeline::light::export_preset_gltf(&a.preset, &l, &a.out, &mut out)?;
            out.commit()?;
            return emit(&line.to_string());
        }
    }
    match a.format.as_str() {
        "wgsl" | "glsl" => snippets(a),
        "gltf" => gltf(a),
        _ => openpbr(a),
    }
}

fn numbers(flag: &str, text: &str) -> Result<Vec<f64>> {
    text.split(',')
        .map(|s| {
            s.trim().parse::<f64>().map_err(|_| {
                lumifit::Error::invalid(
                    flag,
                    format!(
                        "'{}' is not a number; expected comma-separated numbers",
                        s.trim()
                    ),
                )
                .into()
            })
        })
        .collect()
}

/// The glow options of the flags.
fn glow_options(a: &ExportArgs) -> Result<GlowOptions> {
    let charge = match a.charge_s.as_deref().map(str::trim) {
        None => None,
        Some("saturated") => Some(Charge::Saturated),
        Some("full") => Some(Charge::Full),
        Some(s) => Some(Charge::Seconds(s.parse::<f64>().map_err(|_| {
            lumifit::Error::invalid(
                "--charge-s",
                format!("'{s}'; expected seconds, 'saturated' or 'full'"),
            )
        })?)),
    };
    let tol = numbers("--key-tolerance", &a.key_tolerance)?;
    let tolerance = match tol.as_slice() {
        [rel] => KeyframeTolerance {
            rel_tol: *rel,
            abs_tol: KeyframeTolerance::default().abs_tol,
        },
        [rel, abs] => KeyframeTolerance {
            rel_tol: *rel,
            abs_tol: *abs,
        },
        _ => {
            return Err(lumifit::Error::invalid(
                "--key-tolerance",
                format!("{} values; expected REL or REL,ABS", tol.len()),
            )
            .into())
        }
    };
    Ok(GlowOptions {
        charge,
        irradiance: numbers("--charge-irradiance", &a.charge_irradiance)?,
        duration_s: a.glow_s,
        tolerance,
        scale: match a.peak_luminance {
            Some(l) => EmissionScale::PeakLuminance(l),
            None => EmissionScale::NitsPerUnit(a.nits_per_unit.unwrap_or(1.0)),
        },
    })
}

/// `--format gltf`: `.gltf` or `.glb`, and the OpenPBR JSON beside it.
fn gltf(a: &ExportArgs) -> Result<()> {
    let mut out = Outputs::new();
    out.input(&a.preset);
    let file = a.preset.display().to_string();
    let stem = a
        .out
        .file_stem()
        .map_or_else(|| "material".into(), |s| s.to_string_lossy().into_owned());
    if a.out.as_os_str() == "-" {
        return Err(lumifit::Error::invalid(
            "--out",
            "'-' with --format gltf; a glTF is written to a file (its OpenPBR JSON goes beside it); --format openpbr or mtlx can write to standard output",
        )
        .into());
    }
    let openpbr_path = a.out.with_file_name(format!("{stem}.openpbr.json"));
    out.declare("--out", &a.out)?;
    out.declare("--out (OpenPBR beside it)", &openpbr_path)?;
    if !a.space.trim().eq_ignore_ascii_case("srgb") {
        return Err(lumifit::Error::invalid(
            "--space",
            format!(
                "'{}' with --format gltf; glTF 2.0 colours are linear sRGB (Rec. 709 primaries), so glTF is always written in srgb",
                a.space
            ),
        )
        .into());
    }
    let glow = glow_options(a)?;
    let preset = read_material(&a.preset)?;
    let opts = ExportOptions {
        thickness_m: a.thickness_m,
        scene: if a.scene.is_some() {
            Scene::Sphere
        } else {
            Scene::None
        },
        glow: glow.clone(),
    };
    let doc = material_gltf(&preset, &file, &opts)?;
    let openpbr = openpbr_parameters(
        &preset,
        &file,
        &OpenPbrOptions {
            space: RgbSpace::srgb()?,
            glow,
        },
    )?;
    let binary = a
        .out
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("glb"));
    if binary {
        out.stage(&a.out, &doc.to_glb()?)?;
    } else {
        out.stage_text(&a.out, &doc.to_gltf()?)?;
    }
    out.stage_text(
        &openpbr_path,
        &(serde_json::to_string_pretty(&openpbr)? + "\n"),
    )?;
    let written: Vec<String> = out
        .staged_paths()
        .iter()
        .map(|p| p.display().to_string())
        .collect();
    out.commit()?;
    let mut summary = json!({
        "preset": file,
        "format": if binary { "glb" } else { "gltf" },
        "sections": doc.sections,
        "written": written,
    });
    if let Some(g) = &doc.glow {
        eprintln!(
            "glow: {} keys over {} s ({} charge), linear interpolation within {}·|exact| + {}·peak (worst {:.3} of that), {:.4} cd/m² at switch-off",
            g.keys.t_s.len(),
            g.duration_s,
            g.charge.describe(),
            g.tolerance.rel_tol,
            g.tolerance.abs_tol,
            g.keys.max_error,
            g.luminance(g.rgb_at(0.0)),
        );
        summary["emission"] =
            doc.json["asset"]["extras"]["lumifit"]["sections_detail"]["emission"].clone();
    }
    emit(&serde_json::to_string_pretty(&summary)?)
}

/// `--format openpbr|mtlx`.
fn openpbr(a: &ExportArgs) -> Result<()> {
    let mut out = Outputs::new();
    out.input(&a.preset);
    out.declare("--out", &a.out)?;
    let file = a.preset.display().to_string();
    let opts = OpenPbrOptions {
        space: RgbSpace::from_name(&a.space)?,
        glow: glow_options(a)?,
    };
    let preset = read_material(&a.preset)?;
    let text = if a.format == "mtlx" {
        materialx_document(&preset, &file, &opts)?
    } else {
        serde_json::to_string_pretty(&openpbr_parameters(&preset, &file, &opts)?)? + "\n"
    };
    out.stage_text(&a.out, &text)?;
    out.commit()?;
    if a.out.as_os_str() == "-" {
        return Ok(());
    }
    emit(&serde_json::to_string_pretty(&json!({
        "preset": file,
        "format": a.format,
        "written": [a.out.display().to_string()],
    }))?)
}

/// `--format wgsl|glsl`: every snippet the preset carries, in one file.
fn snippets(a: &ExportArgs) -> Result<()> {
    let mut out = Outputs::new();
    out.input(&a.preset);
    out.declare("--out", &a.out)?;
    let file = a.preset.display().to_string();
    let space = RgbSpace::from_name(&a.space)?;
    let language = if a.format == "wgsl" {
        ShaderLanguage::Wgsl
    } else {
        ShaderLanguage::Glsl
    };
    let preset = read_material(&a.preset)?;
    let text = material_snippets(&preset, &file, &space, language)?;
    out.stage_text(&a.out, &text)?;
    let to_stdout = a.out.as_os_str() == "-";
    out.commit()?;
    if to_stdout {
        return Ok(());
    }
    let sections: Vec<&str> = [
        preset.phosphorescence.as_ref().map(|_| "phosphorescence"),
        preset.fluorescence.as_ref().map(|_| "fluorescence"),
        preset.dispersion.as_ref().map(|_| "dispersion"),
        preset.afterimage.as_ref().map(|_| "afterimage"),
    ]
    .into_iter()
    .flatten()
    .collect();
    emit(&serde_json::to_string_pretty(&json!({
        "preset": file,
        "format": a.format,
        "written": [a.out.display().to_string()],
        "sections": sections,
    }))?)
}
