//! `lumifit synth …` (synthetic data): phosphorescent decay series from the exact simulation —
//! 16-bit TIFF frames with a manifest the series loader reads, or (`--curve-only`) one curve CSV;
//! the charging protocol goes into `charging.json` beside them (read by `phos fit-decay`).

use std::path::PathBuf;

use anyhow::Result;
use clap::{Args, Subcommand, ValueEnum};
use lumifit::io::Outputs;
use lumifit::phosphor::synth::FrameLayout;
use lumifit::pipeline::phos_synth::{run_phos_decay, ChargeFlags, PhosDecayJob};

use super::phos::progress_bar;
use super::Bar;

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

/// Runs a `lumifit synth` subcommand.
pub fn run(cmd: SynthCommand) -> Result<()> {
    match cmd {
        SynthCommand::PhosDecay(a) => {
            let mut out = Outputs::new();
            let bar = Bar::new(|n| {
                progress_bar(
                    n as u64,
                    "rendering [{bar:30}] {pos}/{len} frames {elapsed}",
                )
            });
            let line = run_phos_decay(&a.config(), &mut out, &mut |w| eprintln!("{w}"), &bar)?;
            out.commit()?;
            super::emit(&line)
        }
    }
}

impl PhosDecayArgs {
    fn config(&self) -> PhosDecayJob {
        PhosDecayJob {
            material: self.material.clone(),
            charge: ChargeFlags {
                charge_s: self.charge_s,
                charge_irradiance: self.charge_irradiance,
                saturated: self.saturated,
            },
            frames: self.frames,
            interval_s: self.interval_s,
            exposure_s: self.exposure_s,
            camera: self.camera.clone(),
            noise: self.noise,
            size: self.size.clone(),
            layout: match self.layout {
                LayoutArg::Uniform => FrameLayout::Uniform,
                LayoutArg::Halves => FrameLayout::Halves,
            },
            seed: self.seed,
            curve_only: self.curve_only,
            out: self.out.clone(),
        }
    }
}
