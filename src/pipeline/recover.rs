//! Spectral recovery from one photo through the calibrated LVF (`lumifit spectrum recover`): what
//! the command does between its flags and its printed line — check the flags, recover the
//! spectrum ([`crate::pipeline::acquisition::recover_spectrum`]), and stage the CSV, the solved
//! system, the summary, the chart and the reflectance preset in the caller's [`Outputs`]. The
//! caller commits and prints.

// `!(a > b)` comparisons deliberately reject NaN along with out-of-range values.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use std::path::PathBuf;

use crate::error::{Error, Result};
use crate::fit::regularized::Weight;
use crate::io::flags::parse_rect;
use crate::io::Outputs;
use crate::pipeline::acquisition::{
    parse_recovery_grid, recover_spectrum, recovery_csv, recovery_plot_png, recovery_summary,
    RecoverInputs,
};
use crate::preset::phosphor::provenance_of_files;
use crate::preset::{to_json_string, MaterialPreset, Provenance, ReflectanceSection};
use crate::recovery::{Recovered, RecoveryOptions};

/// `--reg`: `gcv` or a finite relative weight ≥ 0.
pub fn parse_weight(reg: &str) -> Result<Weight> {
    match reg.trim().to_ascii_lowercase().as_str() {
        "gcv" => Ok(Weight::Gcv),
        s => {
            let v: f64 = s.parse().map_err(|_| {
                Error::flag("--reg", format!("'{reg}' is neither 'gcv' nor a number"))
            })?;
            if !(v >= 0.0) || !v.is_finite() {
                return Err(Error::flag(
                    "--reg",
                    format!("{v}; expected a finite relative weight ≥ 0"),
                ));
            }
            Ok(Weight::Fixed(v))
        }
    }
}

/// `spectrum recover`.
#[derive(Debug, Clone)]
pub struct RecoverJob {
    /// The photo through the LVF.
    pub image: Option<PathBuf>,
    /// Instead of a photo: readings per band (CSV).
    pub readings: Option<PathBuf>,
    /// Band transmissions (`lvf_bands.json` or `lvf.json`).
    pub bands: PathBuf,
    /// Camera sensitivities CSV.
    pub camera: Option<PathBuf>,
    /// `--roi x,y,w,h` as typed.
    pub roi: Option<String>,
    /// `--grid LO:HI:STEP` as typed.
    pub grid: Option<String>,
    /// `--reg` as typed.
    pub reg: String,
    /// Keep the non-negativity constraint.
    pub nonnegative: bool,
    /// Write the solved system to this JSON.
    pub dump_system: Option<PathBuf>,
    /// Reflectance mode: the illuminant.
    pub illuminant: Option<String>,
    /// Reflectance mode: a white reference capture.
    pub white: Option<PathBuf>,
    /// Reflectance of the white reference (number or CSV).
    pub white_reflectance: String,
    /// Exposure with --illuminant and no --white.
    pub exposure: f64,
    /// Reference spectrum CSV.
    pub compare: Option<PathBuf>,
    /// Output CSV.
    pub out: PathBuf,
    /// JSON summary file.
    pub summary: Option<PathBuf>,
    /// Chart PNG.
    pub plot: Option<PathBuf>,
    /// Reflectance preset.
    pub preset: Option<PathBuf>,
    /// Material name in the preset (default: the input's file stem).
    pub name: Option<String>,
}

/// Checks the flags, declares every output, recovers, stages them and returns the summary text
/// to print.
pub fn run_recover(job: &RecoverJob, out: &mut Outputs) -> Result<String> {
    let weight = parse_weight(&job.reg)?;
    if !(job.exposure > 0.0) || !job.exposure.is_finite() {
        return Err(Error::flag(
            "--exposure",
            format!("{}; expected a finite value > 0", job.exposure),
        ));
    }
    if job.preset.is_some() && job.illuminant.is_none() && job.white.is_none() {
        return Err(Error::message(
            "--preset writes a reflectance preset, but without --illuminant or --white the \
             recovered spectrum is the light itself; give the illuminant (--illuminant NAME|CSV) \
             or a white reference capture (--white FILE) to recover a reflectance factor",
        ));
    }
    let inputs = RecoverInputs {
        image: job.image.clone(),
        readings: job.readings.clone(),
        bands: job.bands.clone(),
        camera: job.camera.clone(),
        roi: job.roi.as_deref().map(parse_rect).transpose()?,
        grid: job
            .grid
            .as_deref()
            .map(|g| parse_recovery_grid("--grid", g))
            .transpose()?,
        illuminant: job.illuminant.clone(),
        white: job.white.clone(),
        white_reflectance: job.white_reflectance.clone(),
        exposure: job.exposure,
        compare: job.compare.clone(),
    };
    out.inputs(inputs.files());
    out.declare("--out", &job.out)?;
    for (flag, p) in [
        ("--dump-system", &job.dump_system),
        ("--summary", &job.summary),
        ("--plot", &job.plot),
        ("--preset", &job.preset),
    ] {
        if let Some(p) = p {
            out.declare(flag, p)?;
        }
    }
    let opts = RecoveryOptions {
        weight,
        nonnegative: job.nonnegative,
        ..Default::default()
    };
    let outcome = recover_spectrum(&inputs, &opts, job.dump_system.is_some())?;
    let json = |r: serde_json::Result<String>| {
        r.map_err(|e| Error::Numerical {
            what: "JSON serialisation".into(),
            reason: e.to_string(),
        })
    };
    let text = json(serde_json::to_string_pretty(&recovery_summary(
        &outcome, &inputs, &job.out,
    )))?;
    out.stage(&job.out, recovery_csv(&outcome.rec).as_bytes())?;
    if let (Some(p), Some(d)) = (&job.dump_system, &outcome.dump) {
        out.stage(p, json(serde_json::to_string(d))?.as_bytes())?;
    }
    if let Some(p) = &job.summary {
        out.stage(p, text.as_bytes())?;
    }
    if let Some(p) = &job.plot {
        out.stage(p, &recovery_plot_png(&outcome)?)?;
    }
    if let Some(p) = &job.preset {
        let name = job.name.clone().unwrap_or_else(|| {
            job.image
                .as_ref()
                .or(job.readings.as_ref())
                .and_then(|f| f.file_stem())
                .map_or("recovered".into(), |s| s.to_string_lossy().to_string())
        });
        let provenance = provenance_of_files("lumifit spectrum recover", &inputs.files())?
            .with_fit_quality(serde_json::json!({
                "regularisation": outcome.rec.lambda,
                "mode": outcome.mode,
            }));
        let preset = reflectance_preset(&outcome.rec, &name, provenance, &outcome.mode);
        out.stage_text(p, &to_json_string(&preset)?)?;
    }
    Ok(text)
}

/// The reflectance preset of a recovery: the values on the grid, and beside them (open fields)
/// σ per wavelength and what was recovered.
pub fn reflectance_preset(
    rec: &Recovered,
    name: &str,
    provenance: Provenance,
    mode: &str,
) -> MaterialPreset {
    let mut section = ReflectanceSection::new(rec.wavelength_nm.clone(), rec.value.clone());
    if rec.std.iter().all(|v| v.is_finite()) {
        section
            .extra
            .insert("std".into(), serde_json::json!(rec.std));
    }
    section.extra.insert(
        "source".into(),
        serde_json::json!(format!("lumifit spectrum recover ({mode}) through the LVF")),
    );
    MaterialPreset {
        reflectance: Some(section),
        ..MaterialPreset::new(name, provenance)
    }
}
