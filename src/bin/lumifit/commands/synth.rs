//! `lumifit synth …` (synthetic data): phosphorescent decay series from the exact simulation —
//! 16-bit TIFF frames with a manifest the series loader reads, or (`--curve-only`) one curve CSV;
//! the charging protocol goes into `charging.json` beside them (read by `phos fit-decay`).

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::{Args, Subcommand, ValueEnum};
use lumifit::io::phos_formats::{read_band_camera, ChargingJson, CHARGING_SIDECAR};
use lumifit::io::series::manifest_csv;
use lumifit::io::Outputs;
use lumifit::phosphor::synth::{decay_curve_charged, DecayFrames, DecaySeriesSpec, FrameLayout};
use lumifit::phosphor::{BandCamera, DecayCharging, Material};
use lumifit::pipeline::phos as pipe;
use rayon::prelude::*;

use super::phos::{progress_bar, resolve_material};

/// Subcommands of `lumifit synth`.
#[derive(Debug, Subcommand)]
pub enum SynthCommand {
    /// A phosphorescent decay series: 16-bit TIFF frames + manifest.csv (or a curve CSV with --curve-only).
    PhosDecay(PhosDecayArgs),
}

/// `lumifit synth phos-decay`.
#[derive(Debug, Args)]
pub struct PhosDecayArgs {
    /// A Table 1 material name or a material preset JSON file.
    #[arg(long)]
    pub material: String,
    /// Charging time in s from dark under flat light (|E| = --charge-irradiance over the
    /// material's bands) before switch-off [default: 5400]; recorded in charging.json beside the
    /// output, which `phos fit-decay` reads. 0 is a deprecated spelling of --saturated.
    #[arg(long, conflicts_with = "saturated")]
    pub charge_s: Option<f64>,
    /// |E| of the flat charging light, in the units of k_e (Table 1: 1).
    #[arg(long, default_value_t = 1.0, conflicts_with = "saturated")]
    pub charge_irradiance: f64,
    /// Saturated at switch-off (r = 1, as after a long charge under a strong lamp) instead of a
    /// simulated charge; the default for materials without excitation rates.
    #[arg(long)]
    pub saturated: bool,
    /// Number of frames.
    #[arg(long, default_value_t = 37)]
    pub frames: usize,
    /// Time between frames in s.
    #[arg(long, default_value_t = 5.0)]
    pub interval_s: f64,
    /// Exposure per frame in s (default: a fifth of the interval).
    #[arg(long)]
    pub exposure_s: Option<f64>,
    /// Camera sensitivities CSV `wavelength_nm,r,g,b` (default: ideal box camera).
    #[arg(long)]
    pub camera: Option<PathBuf>,
    /// Relative noise per sample (0.01 = 1 %).
    #[arg(long, default_value_t = 0.01)]
    pub noise: f64,
    /// Frame size WxH in pixels.
    #[arg(long, default_value = "64x48")]
    pub size: String,
    /// Layout: the material everywhere, or left half the material and right half a two-state
    /// variant (its first state plus one 5× slower with half the re-radiation).
    #[arg(long, value_enum, default_value_t = LayoutArg::Uniform)]
    pub layout: LayoutArg,
    /// Seed of the noise generator.
    #[arg(long)]
    pub seed: u64,
    /// Write only the curve CSV (`time_s,r,g,b,std`), manifest.json and charging.json into the
    /// output directory.
    #[arg(long)]
    pub curve_only: bool,
    /// Output directory.
    #[arg(long)]
    pub out: PathBuf,
}

/// Frame layout.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum LayoutArg {
    /// The material everywhere.
    Uniform,
    /// Left half the material, right half its two-state variant.
    Halves,
}

fn parse_size(s: &str) -> Result<(usize, usize)> {
    let bad = || anyhow::anyhow!("--size '{s}': expected WxH in pixels, e.g. 1000x1000");
    let (w, h) = s.trim().split_once(['x', 'X']).ok_or_else(bad)?;
    let w: usize = w.trim().parse().map_err(|_| bad())?;
    let h: usize = h.trim().parse().map_err(|_| bad())?;
    Ok((w, h))
}

/// Frames rendered (and held in memory) at once.
fn frames_in_flight() -> usize {
    4 * rayon::current_num_threads()
}

/// Runs a `lumifit synth` subcommand.
pub fn run(cmd: SynthCommand) -> Result<()> {
    match cmd {
        SynthCommand::PhosDecay(a) => phos_decay(&a),
    }
}

fn phos_decay(a: &PhosDecayArgs) -> Result<()> {
    let size = if a.curve_only {
        None
    } else {
        Some(parse_size(&a.size)?)
    };
    pipe::check_decay_series_size(a.frames, size, frames_in_flight())?;
    let resolved = resolve_material(&a.material)?;
    let mut out = Outputs::new();
    out.inputs(resolved.path()).inputs(&a.camera);
    out.declare_dir("--out", &a.out)?;
    let material = resolved.material;
    let camera = match &a.camera {
        Some(p) => read_band_camera(p, &material.bands)?,
        None => BandCamera::for_bands(&material.bands, None)?,
    };
    let charging = charging_of(a, &material)?;
    let spec = DecaySeriesSpec {
        charge_s: match charging {
            DecayCharging::Flat { duration_s, .. } => duration_s,
            _ => 0.0,
        },
        frames: a.frames,
        interval_s: a.interval_s,
        exposure_s: a.exposure_s.unwrap_or(a.interval_s / 5.0),
        noise: a.noise,
        seed: a.seed,
    };
    out.stage_text(
        a.out.join(CHARGING_SIDECAR),
        &ChargingJson::new(charging.clone()).to_json(),
    )?;
    let Some((w, h)) = size else {
        let c = decay_curve_charged(&material, &camera, &spec, &charging)?;
        let path = a.out.join("curve.csv");
        out.stage_text(&path, &pipe::synth_curve_csv(&c).to_csv())?;
        let manifest = pipe::synth_curve_manifest(&material, &c, &spec);
        out.stage_text(
            a.out.join("manifest.json"),
            &serde_json::to_string_pretty(&manifest)?,
        )?;
        out.commit()?;
        return super::emit(&format!(
            "wrote {}, manifest.json and {CHARGING_SIDECAR} ({}); values are means over exposure \
             windows of {} s from each time_s: fit with `phos fit-decay {} --exposure-s {}`",
            path.display(),
            charging.describe(),
            spec.exposure_s,
            path.display(),
            spec.exposure_s
        ));
    };
    frames(out, a, &material, &camera, &spec, &charging, (w, h))
}

/// The charging protocol from the flags: --saturated, or --charge-s (default 5400 s) at
/// --charge-irradiance; materials without k_e are saturated unless a charge is asked for.
fn charging_of(a: &PhosDecayArgs, material: &Material) -> Result<DecayCharging> {
    if a.saturated {
        return Ok(DecayCharging::Saturated);
    }
    match a.charge_s {
        Some(0.0) => {
            eprintln!(
                "warning: --charge-s 0 is deprecated for --saturated (r = 1 at switch-off); \
                 a sample that is not charged does not glow"
            );
            Ok(DecayCharging::Saturated)
        }
        None if !material.has_excitation() => {
            eprintln!(
                "note: '{}' has no excitation rates k_e; simulated saturated at switch-off \
                 (--saturated)",
                material.name
            );
            Ok(DecayCharging::Saturated)
        }
        t => {
            let c = DecayCharging::Flat {
                duration_s: t.unwrap_or(5400.0),
                irradiance: a.charge_irradiance,
            };
            c.validate()
                .map_err(|e| anyhow::anyhow!("--charge-s/--charge-irradiance: {e}"))?;
            Ok(c)
        }
    }
}

fn frames(
    mut out: Outputs,
    a: &PhosDecayArgs,
    material: &Material,
    camera: &BandCamera,
    spec: &DecaySeriesSpec,
    charging: &DecayCharging,
    (w, h): (usize, usize),
) -> Result<()> {
    let layout = match a.layout {
        LayoutArg::Uniform => FrameLayout::Uniform,
        LayoutArg::Halves => FrameLayout::Halves,
    };
    let fr = DecayFrames::new_charged(material, layout, camera, spec, charging, (w, h))?;
    let bar = progress_bar(
        fr.len() as u64,
        "rendering [{bar:30}] {pos}/{len} frames {elapsed}",
    );
    let names: Vec<String> = (0..fr.len()).map(|j| format!("frame_{j:04}.tif")).collect();
    // Rendered in parallel a few at a time, staged in order (bounded memory).
    let indices: Vec<usize> = (0..fr.len()).collect();
    for chunk in indices.chunks(frames_in_flight()) {
        let tiffs: lumifit::Result<Vec<Vec<u8>>> = chunk
            .par_iter()
            .map(|&j| {
                let t = pipe::decay_frame_tiff(&fr, j);
                bar.inc(1);
                t
            })
            .collect();
        let tiffs = tiffs.with_context(|| format!("rendering frames for {}", a.out.display()))?;
        for (&j, tiff) in chunk.iter().zip(&tiffs) {
            out.stage(a.out.join(&names[j]), tiff)?;
        }
    }
    bar.finish_and_clear();
    // ISO 100·gain: relative radiance is the simulation's camera RGB (the units of
    // synth phos-excitation).
    let iso = pipe::synth_frames_iso(&fr);
    let rows: Vec<(String, f64, f64, f64, f64)> = names
        .iter()
        .zip(&fr.t_s)
        .map(|(n, t)| (n.clone(), *t, fr.exposure_s, iso, 1.0))
        .collect();
    out.stage_text(a.out.join("manifest.csv"), &manifest_csv(&rows))?;
    let truth = pipe::synth_frames_truth(material, layout, &fr, spec)?;
    out.stage_text(
        a.out.join("truth.json"),
        &serde_json::to_string_pretty(&truth)?,
    )?;
    out.commit()?;
    super::emit(&format!(
        "wrote {} frames {w}x{h} ({}), manifest.csv, truth.json and {CHARGING_SIDECAR} ({}) to {}",
        fr.len(),
        a.size,
        charging.describe(),
        a.out.display()
    ))
}
