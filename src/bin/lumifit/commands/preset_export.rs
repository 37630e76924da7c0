//! `lumifit preset export PRESET.json --format gltf|openpbr --out FILE`: renderer formats of a
//! preset's dispersion section.

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;
use lumifit::io::Outputs;
use lumifit::preset::export::{material_gltf, openpbr_parameters, ExportOptions};
use lumifit::preset::read_material;
use serde_json::json;

use super::emit;

#[derive(Debug, Args)]
pub struct ExportArgs {
    /// Material preset with a dispersion section.
    pub preset: PathBuf,
    /// gltf: a glTF 2.0 material (KHR_materials_ior, _dispersion, _volume, _transmission) on a
    /// unit cube, plus the OpenPBR parameters as `<FILE stem>.openpbr.json` beside it;
    /// openpbr: only the OpenPBR JSON.
    #[arg(long, value_parser = ["gltf", "openpbr"])]
    pub format: String,
    /// Output file (`.gltf` or `.json`).
    #[arg(long)]
    pub out: PathBuf,
    /// KHR_materials_volume thicknessFactor in m.
    #[arg(long, default_value_t = 1.0)]
    pub thickness_m: f64,
}

/// Runs the export.
pub fn run(a: &ExportArgs) -> Result<()> {
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
