//! `lumifit synth …` (synthetic data): phosphorescent decay series from the exact simulation.

use std::path::PathBuf;

use anyhow::{bail, Result};
use clap::{Args, Subcommand};
use lumifit::io::{atomic_write, spectrum_csv::read_multi_spectrum};
use lumifit::phosphor::synth::{decay_curve, DecaySeriesSpec};
use lumifit::phosphor::BandCamera;

use super::phos::resolve_material;

/// Subcommands of `lumifit synth`.
#[derive(Debug, Subcommand)]
pub enum SynthCommand {
    /// A phosphorescent decay series (curve CSV with --curve-only; frames not implemented yet).
    PhosDecay(PhosDecayArgs),
}

/// `lumifit synth phos-decay`.
#[derive(Debug, Args)]
pub struct PhosDecayArgs {
    /// A Table 1 material name or a material preset JSON file.
    #[arg(long)]
    pub material: String,
    /// Charging time in s under flat light (|E| = 1) before switch-off.
    #[arg(long, default_value_t = 5400.0)]
    pub charge_s: f64,
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
    /// Frame size WxH (frames only; not implemented yet).
    #[arg(long)]
    pub size: Option<String>,
    /// Layout of the frames (frames only; not implemented yet).
    #[arg(long)]
    pub layout: Option<String>,
    /// Seed of the noise generator.
    #[arg(long)]
    pub seed: u64,
    /// Write only the curve CSV (`time_s,r,g,b,std`) into the output directory.
    #[arg(long)]
    pub curve_only: bool,
    /// Output directory.
    #[arg(long)]
    pub out: PathBuf,
}

/// Runs a `lumifit synth` subcommand.
pub fn run(cmd: SynthCommand) -> Result<()> {
    match cmd {
        SynthCommand::PhosDecay(a) => phos_decay(&a),
    }
}

fn phos_decay(a: &PhosDecayArgs) -> Result<()> {
    if !a.curve_only {
        bail!("16-bit TIFF frames are not implemented yet; use --curve-only for the curve CSV");
    }
    let material = resolve_material(&a.material)?;
    let camera = match &a.camera {
        Some(p) => BandCamera::for_bands(&material.bands, Some(&read_multi_spectrum(p)?))?,
        None => BandCamera::for_bands(&material.bands, None)?,
    };
    let spec = DecaySeriesSpec {
        charge_s: a.charge_s,
        frames: a.frames,
        interval_s: a.interval_s,
        exposure_s: a.exposure_s.unwrap_or(a.interval_s / 5.0),
        noise: a.noise,
        seed: a.seed,
    };
    let c = decay_curve(&material, &camera, &spec)?;
    std::fs::create_dir_all(&a.out).map_err(|e| lumifit::Error::io(&a.out, e))?;
    let mut csv = String::from("time_s,r,g,b,std\n");
    for i in 0..c.t_s.len() {
        let [r, g, b] = c.rgb[i];
        csv.push_str(&format!("{},{r},{g},{b},{}\n", c.t_s[i], c.sigma[i]));
    }
    let path = a.out.join("curve.csv");
    atomic_write(&path, csv.as_bytes())?;
    let manifest = serde_json::json!({
        "generator": "lumifit synth phos-decay",
        "material": material.name,
        "rates_per_s": material.states.iter().map(|s| s.k_r_per_s).collect::<Vec<_>>(),
        "r_at_switch_off": c.r0,
        "saturation_assumed": c.saturation_assumed,
        "charge_s": spec.charge_s, "frames": spec.frames, "interval_s": spec.interval_s,
        "exposure_s": spec.exposure_s, "noise": spec.noise, "seed": spec.seed,
        "time_s": "start of each exposure window after switch-off; values are window means",
        "curve": "curve.csv",
    });
    atomic_write(
        &a.out.join("manifest.json"),
        serde_json::to_string_pretty(&manifest)?.as_bytes(),
    )?;
    super::emit(&format!("wrote {} and manifest.json", path.display()))
}
