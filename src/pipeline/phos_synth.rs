//! Synthetic decay series (`lumifit synth phos-decay`): what the command does between its flags
//! and its printed line — resolve the material and camera, turn the charging flags into a
//! protocol, simulate 16-bit TIFF frames with their manifest and truth (or one curve CSV with its
//! manifest), and stage them with `charging.json` in the caller's [`Outputs`]. The caller
//! commits and prints.

use std::path::PathBuf;

use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::io::phos_formats::{read_band_camera, ChargingJson, CHARGING_SIDECAR};
use crate::io::series::manifest_csv;
use crate::io::Outputs;
use crate::phosphor::synth::{decay_curve_charged, DecayFrames, DecaySeriesSpec, FrameLayout};
use crate::phosphor::{BandCamera, DecayCharging, Material};
use crate::pipeline::phos as pipe;
use crate::pipeline::Progress;
use crate::preset::phosphor::resolve_material;

/// `--size WxH` in pixels.
pub fn parse_size(s: &str) -> Result<(usize, usize)> {
    let bad = || {
        Error::flag(
            format!("--size '{s}'"),
            "expected WxH in pixels, e.g. 1000x1000",
        )
    };
    let (w, h) = s.trim().split_once(['x', 'X']).ok_or_else(bad)?;
    let w: usize = w.trim().parse().map_err(|_| bad())?;
    let h: usize = h.trim().parse().map_err(|_| bad())?;
    Ok((w, h))
}

/// Frames rendered (and held in memory) at once.
pub fn frames_in_flight() -> usize {
    4 * rayon::current_num_threads()
}

/// The charging flags of `synth phos-decay`.
#[derive(Debug, Clone, Copy)]
pub struct ChargeFlags {
    /// `--charge-s` (default 5400 s; 0 is a deprecated spelling of `--saturated`).
    pub charge_s: Option<f64>,
    /// `--charge-irradiance`.
    pub charge_irradiance: f64,
    /// `--saturated`.
    pub saturated: bool,
}

/// The charging protocol from the flags: --saturated, or --charge-s (default 5400 s) at
/// --charge-irradiance; materials without k_e are saturated unless a charge is asked for.
pub fn charging_of(
    flags: &ChargeFlags,
    material: &Material,
    warn: &mut dyn FnMut(String),
) -> Result<DecayCharging> {
    if flags.saturated {
        return Ok(DecayCharging::Saturated);
    }
    match flags.charge_s {
        Some(0.0) => {
            warn(
                "warning: --charge-s 0 is deprecated for --saturated (r = 1 at switch-off); \
                 a sample that is not charged does not glow"
                    .into(),
            );
            Ok(DecayCharging::Saturated)
        }
        None if !material.has_excitation() => {
            warn(format!(
                "note: '{}' has no excitation rates k_e; simulated saturated at switch-off \
                 (--saturated)",
                material.name
            ));
            Ok(DecayCharging::Saturated)
        }
        t => {
            let c = DecayCharging::Flat {
                duration_s: t.unwrap_or(5400.0),
                irradiance: flags.charge_irradiance,
            };
            c.validate()
                .map_err(|e| Error::flag("--charge-s/--charge-irradiance", e.to_string()))?;
            Ok(c)
        }
    }
}

/// `synth phos-decay`: a phosphorescent decay series from the exact simulation.
#[derive(Debug, Clone)]
pub struct PhosDecayJob {
    /// A Table 1 name or a material preset JSON.
    pub material: String,
    /// The charging flags.
    pub charge: ChargeFlags,
    /// Number of frames.
    pub frames: usize,
    /// Time between frames, s.
    pub interval_s: f64,
    /// Exposure per frame, s (default: a fifth of the interval).
    pub exposure_s: Option<f64>,
    /// Camera CSV (default: the ideal box camera).
    pub camera: Option<PathBuf>,
    /// Relative noise per sample.
    pub noise: f64,
    /// `--size WxH` as typed.
    pub size: String,
    /// Frame layout.
    pub layout: FrameLayout,
    /// Noise seed.
    pub seed: u64,
    /// Write only the curve CSV, manifest.json and charging.json.
    pub curve_only: bool,
    /// Output directory.
    pub out: PathBuf,
}

/// Declares the directory, simulates, stages every file and returns the line to print.
/// `warn` receives warnings as whole lines; `progress` counts the rendered frames.
pub fn run_phos_decay(
    job: &PhosDecayJob,
    out: &mut Outputs,
    warn: &mut dyn FnMut(String),
    progress: &dyn Progress,
) -> Result<String> {
    let size = if job.curve_only {
        None
    } else {
        Some(parse_size(&job.size)?)
    };
    pipe::check_decay_series_size(job.frames, size, frames_in_flight())?;
    let resolved = resolve_material(&job.material)?;
    out.inputs(resolved.path()).inputs(&job.camera);
    out.declare_dir("--out", &job.out)?;
    let material = resolved.material;
    let camera = match &job.camera {
        Some(p) => read_band_camera(p, &material.bands)?,
        None => BandCamera::for_bands(&material.bands, None)?,
    };
    let charging = charging_of(&job.charge, &material, warn)?;
    let spec = DecaySeriesSpec {
        charge_s: match charging {
            DecayCharging::Flat { duration_s, .. } => duration_s,
            _ => 0.0,
        },
        frames: job.frames,
        interval_s: job.interval_s,
        exposure_s: job.exposure_s.unwrap_or(job.interval_s / 5.0),
        noise: job.noise,
        seed: job.seed,
    };
    out.stage_text(
        job.out.join(CHARGING_SIDECAR),
        &ChargingJson::new(charging.clone()).to_json(),
    )?;
    let Some((w, h)) = size else {
        let c = decay_curve_charged(&material, &camera, &spec, &charging)?;
        let path = job.out.join("curve.csv");
        out.stage_text(&path, &pipe::synth_curve_csv(&c).to_csv())?;
        let manifest = pipe::synth_curve_manifest(&material, &c, &spec);
        out.stage_text(job.out.join("manifest.json"), &pretty(&manifest)?)?;
        return Ok(format!(
            "wrote {}, manifest.json and {CHARGING_SIDECAR} ({}); values are means over exposure \
             windows of {} s from each time_s: fit with `phos fit-decay {} --exposure-s {}`",
            path.display(),
            charging.describe(),
            spec.exposure_s,
            path.display(),
            spec.exposure_s
        ));
    };
    let layout = job.layout;
    let fr = DecayFrames::new_charged(&material, layout, &camera, &spec, &charging, (w, h))?;
    progress.start(fr.len());
    let names: Vec<String> = (0..fr.len()).map(|j| format!("frame_{j:04}.tif")).collect();
    // Rendered in parallel a few at a time, staged in order (bounded memory).
    let indices: Vec<usize> = (0..fr.len()).collect();
    for chunk in indices.chunks(frames_in_flight()) {
        let tiffs: Result<Vec<Vec<u8>>> = chunk
            .par_iter()
            .map(|&j| {
                let t = pipe::decay_frame_tiff(&fr, j);
                progress.inc();
                t
            })
            .collect();
        let tiffs =
            tiffs.map_err(|e| e.context(format!("rendering frames for {}", job.out.display())))?;
        for (&j, tiff) in chunk.iter().zip(&tiffs) {
            out.stage(job.out.join(&names[j]), tiff)?;
        }
    }
    progress.finish();
    // ISO 100·gain: relative radiance is the simulation's camera RGB (the units of
    // synth phos-excitation).
    let iso = pipe::synth_frames_iso(&fr);
    let rows: Vec<(String, f64, f64, f64, f64)> = names
        .iter()
        .zip(&fr.t_s)
        .map(|(n, t)| (n.clone(), *t, fr.exposure_s, iso, 1.0))
        .collect();
    out.stage_text(job.out.join("manifest.csv"), &manifest_csv(&rows))?;
    let truth = pipe::synth_frames_truth(&material, layout, &fr, &spec)?;
    out.stage_text(job.out.join("truth.json"), &pretty(&truth)?)?;
    Ok(format!(
        "wrote {} frames {w}x{h} ({}), manifest.csv, truth.json and {CHARGING_SIDECAR} ({}) to {}",
        fr.len(),
        job.size,
        charging.describe(),
        job.out.display()
    ))
}

/// Pretty JSON; a serialisation failure is [`Error::Numerical`] ([`crate::io::pretty_json`]).
fn pretty<T: serde::Serialize>(v: &T) -> Result<String> {
    crate::io::pretty_json(v, "JSON serialisation")
}
