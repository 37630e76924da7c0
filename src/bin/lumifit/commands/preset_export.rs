//! `lumifit preset export PRESET.json --format gltf|openpbr|wgsl|glsl --out FILE`: renderer
//! formats of a preset: glTF/OpenPBR of its dispersion section, WGSL/GLSL snippets of its
//! phosphorescence and fluorescence sections.

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;
use lumifit::io::Outputs;
use lumifit::preset::export::{material_gltf, openpbr_parameters, ExportOptions};
use lumifit::preset::read_material;
use lumifit::preset::shader::{material_snippets, ShaderLanguage};
use serde_json::json;

use super::emit;

#[derive(Debug, Args)]
pub struct ExportArgs {
    /// Material preset (gltf/openpbr: with a dispersion section; wgsl/glsl: with a
    /// phosphorescence and/or fluorescence section).
    pub preset: PathBuf,
    /// gltf: a glTF 2.0 material (KHR_materials_ior, _dispersion, _volume, _transmission) on a
    /// unit cube, plus the OpenPBR parameters as `<FILE stem>.openpbr.json` beside it;
    /// openpbr: only the OpenPBR JSON; wgsl / glsl: shader functions with the preset's numbers
    /// as constants (phosphorescence: exact per-frame state update and emission; fluorescence:
    /// the reduced RGB matrix), see docs/export.md.
    #[arg(long, value_parser = ["gltf", "openpbr", "wgsl", "glsl"])]
    pub format: String,
    /// Output file (`.gltf`, `.json`, `.wgsl` or `.glsl`; `-` for standard output with wgsl/glsl).
    #[arg(long)]
    pub out: PathBuf,
    /// wgsl/glsl: linear RGB space of the phosphorescent emission (srgb, rec2020, acescg,
    /// display-p3).
    #[arg(long, default_value = "srgb")]
    pub space: String,
    /// KHR_materials_volume thicknessFactor in m.
    #[arg(long, default_value_t = 1.0)]
    pub thickness_m: f64,
}

/// Runs the export.
pub fn run(a: &ExportArgs) -> Result<()> {
    if a.format == "gltf" {
        // a lumifit.light/1 preset: the photometric light (commands/light.rs)
        if let lumifit::preset::Preset::Light(l) = lumifit::preset::read_preset(&a.preset)? {
            return super::light::export_preset_gltf(&a.preset, &l, &a.out);
        }
    }
    if a.format == "wgsl" || a.format == "glsl" {
        return snippets(a);
    }
    let mut out = Outputs::new();
    out.input(&a.preset);
    let file = a.preset.display().to_string();
    let openpbr_path = if a.format == "gltf" {
        let stem = a
            .out
            .file_stem()
            .map_or_else(|| "material".into(), |s| s.to_string_lossy().into_owned());
        a.out.with_file_name(format!("{stem}.openpbr.json"))
    } else {
        a.out.clone()
    };
    out.declare("--out", &a.out)?;
    if a.format == "gltf" {
        out.declare("--out (OpenPBR beside it)", &openpbr_path)?;
    }
    let preset = read_material(&a.preset)?;
    let openpbr = openpbr_parameters(&preset, &file)?;
    if a.format == "gltf" {
        let doc = material_gltf(
            &preset,
            &file,
            ExportOptions {
                thickness_m: a.thickness_m,
            },
        )?;
        out.stage_text(&a.out, &(serde_json::to_string_pretty(&doc)? + "\n"))?;
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
    emit(&serde_json::to_string_pretty(&json!({
        "preset": file,
        "format": a.format,
        "written": written,
        "openpbr": openpbr,
    }))?)
}

/// `--format wgsl|glsl`: every snippet the preset carries, in one file.
fn snippets(a: &ExportArgs) -> Result<()> {
    let mut out = Outputs::new();
    out.input(&a.preset);
    out.declare("--out", &a.out)?;
    let file = a.preset.display().to_string();
    let space = lumifit::colorimetry::rgb::RgbSpace::from_name(&a.space)?;
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
