//! `lumifit preset preview PRESET.json --out preview.png`: the reference preview of a preset
//! (a sphere on a floor under one light, shaded through the shader twins), see
//! [`lumifit::preset::preview`].

use std::path::PathBuf;

use anyhow::Result;
use clap::{Args, ValueEnum};
use lumifit::fluor::parse_donaldson;
use lumifit::io::{read_input, Outputs};
use lumifit::plot::preview::preview_sheet_png;
use lumifit::preset::preview::{preview, LightKind, PreviewOptions};
use lumifit::preset::read_preset;

use super::{emit, resolve_illuminant};

/// The light of the lit panels.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum LightArg {
    /// A distant light from the upper left front.
    Directional,
    /// A point light above and in front of the sphere.
    Point,
}

#[derive(Debug, Args)]
pub struct PreviewArgs {
    /// Material preset with a phosphorescence, fluorescence and/or dispersion section.
    pub preset: PathBuf,
    /// Illuminants (CIE names such as D65, A, FL2, `daylight:<K>`, `blackbody:<K>` or SPD CSV
    /// files): fluorescence gets a panel pair per illuminant; the first charges the phosphor.
    #[arg(long, value_delimiter = ',', default_values_t = ["D65".to_string(), "A".to_string(), "FL2".to_string()])]
    pub illuminant: Vec<String>,
    /// Times after switch-off of the phosphorescence glow frames, s.
    #[arg(long, value_delimiter = ',', default_values_t = [0.0, 1.0, 10.0, 80.0])]
    pub times: Vec<f64>,
    /// Charging time in s from the dark state under the first illuminant; default: saturated
    /// (the steady state of the charging light).
    #[arg(long)]
    pub charge_s: Option<f64>,
    /// Length |E| of the per-band charging irradiance (the k_e's units; the paper uses 1).
    #[arg(long, default_value_t = 1.0)]
    pub charge_irradiance: f64,
    /// Side of one panel in pixels.
    #[arg(long, default_value_t = 256)]
    pub size: usize,
    /// The light of the lit panels.
    #[arg(long, value_enum, default_value_t = LightArg::Directional)]
    pub light: LightArg,
    /// The measured Donaldson matrix (BFC-450 or CSV) the fluorescence section was reduced
    /// from: adds the spectral reference panels and the ΔE00 per illuminant.
    #[arg(long)]
    pub donaldson: Option<PathBuf>,
    /// Output PNG.
    #[arg(long)]
    pub out: PathBuf,
    /// Also write the numbers of every panel as JSON.
    #[arg(long)]
    pub report: Option<PathBuf>,
}

/// Runs the preview.
pub fn run(a: &PreviewArgs) -> Result<()> {
    let mut out = Outputs::new();
    out.input(&a.preset);
    if let Some(d) = &a.donaldson {
        out.input(d);
    }
    out.inputs(
        a.illuminant
            .iter()
            .filter_map(|n| lumifit::io::sources::file_of(n)),
    );
    out.declare("--out", &a.out)?;
    if let Some(r) = &a.report {
        out.declare("--report", r)?;
    }
    let file = a.preset.display().to_string();
    let preset = read_preset(&a.preset)?;
    let donaldson = match &a.donaldson {
        Some(p) => {
            let (bytes, source) = read_input(p)?;
            Some((parse_donaldson(&bytes, &source)?, p.display().to_string()))
        }
        None => None,
    };
    let options = PreviewOptions {
        size_px: a.size,
        illuminants: a
            .illuminant
            .iter()
            .map(|n| resolve_illuminant(n))
            .collect::<Result<_>>()?,
        times_s: a.times.clone(),
        charge_s: a.charge_s,
        charge_irradiance: a.charge_irradiance,
        light: match a.light {
            LightArg::Directional => LightKind::Directional,
            LightArg::Point => LightKind::Point,
        },
        donaldson,
    };
    let p = preview(&preset, &file, &options)?;
    out.stage(&a.out, &preview_sheet_png(&p.sheet)?)?;
    let report = serde_json::to_string_pretty(&serde_json::json!({
        "preset": file,
        "written": [a.out.display().to_string()],
        "preview": p.report,
    }))?;
    if let Some(r) = &a.report {
        out.stage_text(r, &(report.clone() + "\n"))?;
    }
    out.commit()?;
    if let Some(f) = &p.report.fluorescence {
        for i in &f.illuminants {
            if let Some(d) = i.delta_e00_twin {
                eprintln!(
                    "{}: ΔE00 twin vs spectral {:.4} (preset K-basis {:.4})",
                    i.illuminant,
                    d,
                    i.delta_e00_preset_k.unwrap_or(f64::NAN)
                );
            }
        }
    }
    emit(&report)
}
