//! Renderer formats of a material preset (`lumifit preset export`, docs/export.md): what the
//! command does between its flags and its printed line — read the preset, build the glow options
//! of the flags, write glTF 2.0 (`.gltf`/`.glb`, with the OpenPBR JSON beside it), OpenPBR JSON,
//! a MaterialX document or WGSL/GLSL snippets, and stage them in the caller's [`Outputs`]. A
//! `lumifit.light/1` preset goes to [`crate::pipeline::light::export_preset_gltf`]. The caller
//! commits and prints.

use std::path::PathBuf;
use std::str::FromStr;

use serde_json::json;

use crate::colorimetry::rgb::RgbSpace;
use crate::error::{Error, Result};
use crate::io::Outputs;
use crate::preset::export::{
    material_gltf, materialx_document, openpbr_parameters, Charge, EmissionScale, ExportOptions,
    GlowOptions, OpenPbrOptions, Scene,
};
use crate::preset::shader::keyframes::KeyframeTolerance;
use crate::preset::shader::{material_snippets, ShaderLanguage};
use crate::preset::{read_material, read_preset, Preset};

/// The renderer format of `--format`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ExportFormat {
    /// glTF 2.0 (`.gltf` or `.glb`) with the OpenPBR JSON beside it.
    Gltf,
    /// OpenPBR parameters (JSON).
    OpenPbr,
    /// A MaterialX 1.39 `open_pbr_surface` document.
    Mtlx,
    /// WGSL shader functions.
    Wgsl,
    /// GLSL shader functions.
    Glsl,
}

impl ExportFormat {
    /// The name on the command line and in the summary.
    pub fn name(self) -> &'static str {
        match self {
            ExportFormat::Gltf => "gltf",
            ExportFormat::OpenPbr => "openpbr",
            ExportFormat::Mtlx => "mtlx",
            ExportFormat::Wgsl => "wgsl",
            ExportFormat::Glsl => "glsl",
        }
    }
}

impl FromStr for ExportFormat {
    type Err = Error;

    fn from_str(s: &str) -> Result<Self> {
        [
            ExportFormat::Gltf,
            ExportFormat::OpenPbr,
            ExportFormat::Mtlx,
            ExportFormat::Wgsl,
            ExportFormat::Glsl,
        ]
        .into_iter()
        .find(|f| f.name() == s)
        .ok_or_else(|| Error::UnknownName {
            kind: "export format",
            name: s.to_string(),
            expected: "gltf, openpbr, mtlx, wgsl, glsl".into(),
        })
    }
}

/// The glow flags of `preset export`, as typed.
#[derive(Debug, Clone)]
pub struct GlowFlags {
    /// `--charge-s`: `saturated`, `full` or seconds.
    pub charge_s: Option<String>,
    /// `--charge-irradiance`: one value or one per band.
    pub charge_irradiance: String,
    /// `--glow-s`: length of the glow animation, s.
    pub glow_s: Option<f64>,
    /// `--key-tolerance REL[,ABS]`.
    pub key_tolerance: String,
    /// `--nits-per-unit`.
    pub nits_per_unit: Option<f64>,
    /// `--peak-luminance`, cd/m².
    pub peak_luminance: Option<f64>,
}

/// Comma-separated numbers of `flag`.
fn numbers(flag: &str, text: &str) -> Result<Vec<f64>> {
    text.split(',')
        .map(|s| {
            s.trim().parse::<f64>().map_err(|_| {
                Error::invalid(
                    flag,
                    format!(
                        "'{}' is not a number; expected comma-separated numbers",
                        s.trim()
                    ),
                )
            })
        })
        .collect()
}

impl GlowFlags {
    /// The glow options of the flags.
    pub fn options(&self) -> Result<GlowOptions> {
        let charge = match self.charge_s.as_deref().map(str::trim) {
            None => None,
            Some("saturated") => Some(Charge::Saturated),
            Some("full") => Some(Charge::Full),
            Some(s) => Some(Charge::Seconds(s.parse::<f64>().map_err(|_| {
                Error::invalid(
                    "--charge-s",
                    format!("'{s}'; expected seconds, 'saturated' or 'full'"),
                )
            })?)),
        };
        let tol = numbers("--key-tolerance", &self.key_tolerance)?;
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
                return Err(Error::invalid(
                    "--key-tolerance",
                    format!("{} values; expected REL or REL,ABS", tol.len()),
                ))
            }
        };
        Ok(GlowOptions {
            charge,
            irradiance: numbers("--charge-irradiance", &self.charge_irradiance)?,
            duration_s: self.glow_s,
            tolerance,
            scale: match self.peak_luminance {
                Some(l) => EmissionScale::PeakLuminance(l),
                None => EmissionScale::NitsPerUnit(self.nits_per_unit.unwrap_or(1.0)),
            },
        })
    }
}

/// `preset export`.
#[derive(Debug, Clone)]
pub struct ExportJob {
    /// The preset.
    pub preset: PathBuf,
    /// The format.
    pub format: ExportFormat,
    /// Output file (`-`: standard output, except for glTF).
    pub out: PathBuf,
    /// glTF: what the document holds besides the material.
    pub scene: Scene,
    /// `--space` as typed.
    pub space: String,
    /// KHR_materials_volume thicknessFactor, m.
    pub thickness_m: f64,
    /// The glow flags.
    pub glow: GlowFlags,
}

/// What `preset export` prints: the summary (none when the output went to standard output) and
/// a line for standard error about the glow keys.
#[derive(Debug, Clone, Default)]
pub struct ExportReport {
    /// The JSON summary for standard output (pretty, or one line for a light preset).
    pub summary: Option<String>,
    /// The glow line for standard error.
    pub note: Option<String>,
}

/// Reads the preset, declares and stages the output(s) and returns what to print.
pub fn run_export(job: &ExportJob, out: &mut Outputs) -> Result<ExportReport> {
    if job.format == ExportFormat::Gltf {
        // a lumifit.light/1 preset: the photometric light (pipeline::light)
        if let Preset::Light(l) = read_preset(&job.preset)? {
            let line = crate::pipeline::light::export_preset_gltf(&job.preset, &l, &job.out, out)?;
            return Ok(ExportReport {
                summary: Some(line.to_string()),
                note: None,
            });
        }
    }
    match job.format {
        ExportFormat::Wgsl | ExportFormat::Glsl => snippets(job, out),
        ExportFormat::Gltf => gltf(job, out),
        ExportFormat::OpenPbr | ExportFormat::Mtlx => openpbr(job, out),
    }
}

/// `--format gltf`: `.gltf` or `.glb`, and the OpenPBR JSON beside it.
fn gltf(job: &ExportJob, out: &mut Outputs) -> Result<ExportReport> {
    out.input(&job.preset);
    let file = job.preset.display().to_string();
    let stem = job
        .out
        .file_stem()
        .map_or_else(|| "material".into(), |s| s.to_string_lossy().into_owned());
    if job.out.as_os_str() == "-" {
        return Err(Error::invalid(
            "--out",
            "'-' with --format gltf; a glTF is written to a file (its OpenPBR JSON goes beside it); --format openpbr or mtlx can write to standard output",
        ));
    }
    let openpbr_path = job.out.with_file_name(format!("{stem}.openpbr.json"));
    out.declare("--out", &job.out)?;
    out.declare("--out (OpenPBR beside it)", &openpbr_path)?;
    if !job.space.trim().eq_ignore_ascii_case("srgb") {
        return Err(Error::invalid(
            "--space",
            format!(
                "'{}' with --format gltf; glTF 2.0 colours are linear sRGB (Rec. 709 primaries), so glTF is always written in srgb",
                job.space
            ),
        ));
    }
    let glow = job.glow.options()?;
    let preset = read_material(&job.preset)?;
    let opts = ExportOptions {
        thickness_m: job.thickness_m,
        scene: job.scene,
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
    let binary = job
        .out
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("glb"));
    if binary {
        out.stage(&job.out, &doc.to_glb()?)?;
    } else {
        out.stage_text(&job.out, &doc.to_gltf()?)?;
    }
    out.stage_text(&openpbr_path, &(pretty(&openpbr)? + "\n"))?;
    let written: Vec<String> = out
        .staged_paths()
        .iter()
        .map(|p| p.display().to_string())
        .collect();
    let mut summary = json!({
        "preset": file,
        "format": if binary { "glb" } else { "gltf" },
        "sections": doc.sections,
        "written": written,
    });
    let mut note = None;
    if let Some(g) = &doc.glow {
        note = Some(format!(
            "glow: {} keys over {} s ({} charge), linear interpolation within {}·|exact| + {}·peak (worst {:.3} of that), {:.4} cd/m² at switch-off",
            g.keys.t_s.len(),
            g.duration_s,
            g.charge.describe(),
            g.tolerance.rel_tol,
            g.tolerance.abs_tol,
            g.keys.max_error,
            g.luminance(g.rgb_at(0.0)),
        ));
        summary["emission"] =
            doc.json["asset"]["extras"]["lumifit"]["sections_detail"]["emission"].clone();
    }
    Ok(ExportReport {
        summary: Some(pretty(&summary)?),
        note,
    })
}

/// Pretty JSON; a serialisation failure is [`Error::Numerical`] ([`crate::io::pretty_json`]).
fn pretty<T: serde::Serialize>(v: &T) -> Result<String> {
    crate::io::pretty_json(v, "JSON serialisation")
}

/// `--format openpbr|mtlx`.
fn openpbr(job: &ExportJob, out: &mut Outputs) -> Result<ExportReport> {
    out.input(&job.preset);
    out.declare("--out", &job.out)?;
    let file = job.preset.display().to_string();
    let opts = OpenPbrOptions {
        space: RgbSpace::from_name(&job.space)?,
        glow: job.glow.options()?,
    };
    let preset = read_material(&job.preset)?;
    let text = if job.format == ExportFormat::Mtlx {
        materialx_document(&preset, &file, &opts)?
    } else {
        pretty(&openpbr_parameters(&preset, &file, &opts)?)? + "\n"
    };
    out.stage_text(&job.out, &text)?;
    single_file_report(job, &file, None)
}

/// `--format wgsl|glsl`: every snippet the preset carries, in one file.
fn snippets(job: &ExportJob, out: &mut Outputs) -> Result<ExportReport> {
    out.input(&job.preset);
    out.declare("--out", &job.out)?;
    let file = job.preset.display().to_string();
    let space = RgbSpace::from_name(&job.space)?;
    let language = if job.format == ExportFormat::Wgsl {
        ShaderLanguage::Wgsl
    } else {
        ShaderLanguage::Glsl
    };
    let preset = read_material(&job.preset)?;
    let text = material_snippets(&preset, &file, &space, language)?;
    out.stage_text(&job.out, &text)?;
    let sections: Vec<&str> = [
        preset.phosphorescence.as_ref().map(|_| "phosphorescence"),
        preset.fluorescence.as_ref().map(|_| "fluorescence"),
        preset.dispersion.as_ref().map(|_| "dispersion"),
        preset.afterimage.as_ref().map(|_| "afterimage"),
    ]
    .into_iter()
    .flatten()
    .collect();
    single_file_report(job, &file, Some(sections))
}

/// The report of an export to one file (`--out FILE`; none for stdout): preset, format, the
/// file written and, for shader snippets, the sections the file holds.
fn single_file_report(
    job: &ExportJob,
    file: &str,
    sections: Option<Vec<&str>>,
) -> Result<ExportReport> {
    if job.out.as_os_str() == "-" {
        return Ok(ExportReport {
            summary: None,
            note: None,
        });
    }
    let mut summary = json!({
        "preset": file,
        "format": job.format.name(),
        "written": [job.out.display().to_string()],
    });
    if let Some(s) = sections {
        summary["sections"] = json!(s);
    }
    Ok(ExportReport {
        summary: Some(pretty(&summary)?),
        note: None,
    })
}
