//! `lumifit afterimage curves|synth`: the afterimage model of Mikamo et al. 2013 — its curves,
//! and frames of an image's afterimage (docs/afterimage.md).

use std::path::PathBuf;

use anyhow::{bail, Result};
use clap::{Args, Subcommand};
use lumifit::io::Outputs;
use lumifit::pipeline::afterimage::{self as job, CurvesJob, FrameTimes, SynthJob};

use super::emit;

/// Subcommands (afterimages).
#[derive(Debug, Subcommand)]
pub enum AfterimageCommand {
    /// The model's transitions on a time grid: CSV `t_s,Y,x,y,L,a,b,tau` (Eq. 3, Table 1 with
    /// Catmull-Rom, Lab with white D65, τ = L/L(0)) and optionally the chart.
    Curves(CurvesArgs),
    /// Afterimage frames of an image: 16-bit sRGB PNGs (and linear EXRs), an animated preview,
    /// the curves, a preset `afterimage` section and a side-by-side figure, in one directory.
    Synth(SynthArgs),
}

/// `afterimage curves`.
#[derive(Debug, Args)]
pub struct CurvesArgs {
    /// Grid step, s.
    #[arg(long, default_value_t = 0.1)]
    pub step_s: f64,
    /// Last time, s (over 80 s needs --extrapolate).
    #[arg(long, default_value_t = 80.0)]
    pub end_s: f64,
    /// Allow times after 80 s: Eq. 3 continues, the colour stays at Table 1's 80 s value.
    #[arg(long)]
    pub extrapolate: bool,
    /// Output CSV (`-`: standard output).
    #[arg(long, default_value = "-")]
    pub out: PathBuf,
    /// Chart PNG: Y(t) and the xy track on the CIE 1931 diagram.
    #[arg(long)]
    pub plot: Option<PathBuf>,
}

/// `afterimage synth`.
#[derive(Debug, Args)]
pub struct SynthArgs {
    /// The stimulus image I_on: OpenEXR or Radiance HDR (linear), PNG/JPEG/TIFF (sRGB, decoded).
    pub image: PathBuf,
    /// Background I_off the afterimage is added to, dark-adapting by Eq. 7 (same size; display
    /// linear). Without it the afterimage is shown on black.
    #[arg(long)]
    pub background: Option<PathBuf>,
    /// Frame times: `START:STOP:STEP` (s) or a comma list `0,4,8`.
    #[arg(long, conflicts_with_all = ["fps", "duration"], required_unless_present = "fps")]
    pub times: Option<String>,
    /// Frames per second (with --duration): frames at i/F s.
    #[arg(long, requires = "duration")]
    pub fps: Option<f64>,
    /// Duration, s (with --fps).
    #[arg(long, requires = "fps")]
    pub duration: Option<f64>,
    /// γ of Z = (L_on/L_on^max)^γ.
    #[arg(long, default_value_t = 0.7, allow_hyphen_values = true)]
    pub gamma: f64,
    /// k of Eq. 5–6: how strongly the stimulus colour shows early.
    #[arg(long, default_value_t = 0.05, allow_hyphen_values = true)]
    pub k: f64,
    /// Reference light chromaticity x,y (Table 1's start; §3.2 prints 0.43,0.40).
    #[arg(long, value_name = "X,Y")]
    pub reference_xy: Option<String>,
    /// Mask rule: pixels whose largest linear RGB channel is ≥ this × the image's largest
    /// channel value make an afterimage (0–1; 0: every non-black pixel).
    #[arg(long, default_value_t = 0.5, allow_hyphen_values = true)]
    pub mask_threshold: f64,
    /// Gaussian blur σ in px (default: 0.4 % of the image diagonal; 0 turns it off).
    #[arg(long, allow_hyphen_values = true)]
    pub blur_sigma_px: Option<f64>,
    /// Eq. 7: the background at t = 0 is this fraction of I_off (needs --background).
    #[arg(long, requires = "background", allow_hyphen_values = true)]
    pub dark_constant: Option<f64>,
    /// Eq. 7: time constant T, s (needs --background).
    #[arg(long, requires = "background", allow_hyphen_values = true)]
    pub dark_time_s: Option<f64>,
    /// Allow times after 80 s (colour held at 80 s, Eq. 3 continued).
    #[arg(long)]
    pub extrapolate: bool,
    /// Also write each frame as linear 32-bit float OpenEXR (`frame_t….exr`).
    #[arg(long)]
    pub exr: bool,
    /// Output directory (created at the end; nothing is written on failure).
    #[arg(long)]
    pub out: PathBuf,
}

/// Runs one of these subcommands.
pub fn run(cmd: AfterimageCommand) -> Result<()> {
    let mut out = Outputs::new();
    match cmd {
        AfterimageCommand::Curves(a) => {
            job::run_curves(&a.config(), &mut out)?;
            out.commit()?;
            Ok(())
        }
        AfterimageCommand::Synth(a) => {
            let command = std::env::args().collect::<Vec<_>>().join(" ");
            let mut report = job::run_synth(&a.config(command)?, &mut out)?;
            report["files"] = out.commit()?.len().into();
            emit(&serde_json::to_string_pretty(&report)?)
        }
    }
}

impl CurvesArgs {
    fn config(&self) -> CurvesJob {
        CurvesJob {
            step_s: self.step_s,
            end_s: self.end_s,
            extrapolate: self.extrapolate,
            out: self.out.clone(),
            plot: self.plot.clone(),
        }
    }
}

impl SynthArgs {
    fn config(self, command: String) -> Result<SynthJob> {
        let times = match (self.times, self.fps, self.duration) {
            (Some(spec), _, _) => FrameTimes::Spec(spec),
            (None, Some(fps), Some(duration)) => FrameTimes::Fps { fps, duration },
            _ => bail!("give --times or --fps with --duration"),
        };
        Ok(SynthJob {
            image: self.image,
            background: self.background,
            times,
            gamma: self.gamma,
            k: self.k,
            reference_xy: self.reference_xy,
            mask_threshold: self.mask_threshold,
            blur_sigma_px: self.blur_sigma_px,
            dark_constant: self.dark_constant,
            dark_time_s: self.dark_time_s,
            extrapolate: self.extrapolate,
            exr: self.exr,
            out: self.out,
            command,
        })
    }
}
