//! `lumifit series inspect|extract`: photo series (manifest CSV or folder) to per-frame metadata
//! and region curves in relative radiance.

use std::path::PathBuf;

use anyhow::Result;
use clap::{Args, Subcommand};
use lumifit::io::Outputs;
use lumifit::pipeline::series::{run_extract, run_inspect, ExtractJob, SeriesSource};

use super::{emit, progress_bar, Bar};

/// Subcommands (photo series).
#[derive(Debug, Subcommand)]
pub enum SeriesCommand {
    /// One row per frame: file, time, exposure, ISO, f-number, black/white level, saturated fraction.
    Inspect(InspectArgs),
    /// Region curve in relative radiance: time_s,r,g,b,r_std,g_std,b_std,n_pixels,n_saturated.
    Extract(ExtractArgs),
}

/// Where the series comes from.
#[derive(Debug, Args)]
pub struct SeriesArgs {
    /// Manifest CSV (file,time_s[,exposure_s,iso,f_number]; the first column may also be named
    /// image) or a folder: its manifest.csv when it has one, else its frames ordered by EXIF
    /// capture time.
    pub series: PathBuf,
    /// Time 0 for a folder series, as a capture time `YYYY:MM:DD HH:MM:SS[.sss]` (default: first frame).
    #[arg(long)]
    pub t0: Option<String>,
    /// Dark frame(s), averaged and subtracted from every frame (repeat the flag for several).
    #[arg(long)]
    pub dark: Vec<PathBuf>,
}

/// `series inspect`.
#[derive(Debug, Args)]
pub struct InspectArgs {
    #[command(flatten)]
    pub series: SeriesArgs,
    /// Print JSON instead of a table.
    #[arg(long)]
    pub json: bool,
}

/// `series extract`.
#[derive(Debug, Args)]
pub struct ExtractArgs {
    #[command(flatten)]
    pub series: SeriesArgs,
    /// Rectangle x,y,w,h in the source image's pixels (for RAW: the full-resolution image);
    /// default: the whole frame.
    #[arg(long, conflicts_with = "mask")]
    pub roi: Option<String>,
    /// Mask image of the source image's size; non-zero pixels are inside.
    #[arg(long)]
    pub mask: Option<PathBuf>,
    /// Output CSV.
    #[arg(long)]
    pub out: PathBuf,
}

/// Runs one of these subcommands.
pub fn run(cmd: SeriesCommand) -> Result<()> {
    let bar = Bar::new(|n| progress_bar(n, "decoding", "frames"));
    let mut warn = |w: String| eprintln!("{w}");
    match cmd {
        SeriesCommand::Inspect(a) => {
            emit(&run_inspect(&a.series.source(), a.json, &bar, &mut warn)?)
        }
        SeriesCommand::Extract(a) => {
            let job = ExtractJob {
                source: a.series.source(),
                roi: a.roi,
                mask: a.mask,
                out: a.out,
            };
            let mut out = Outputs::new();
            let summary = run_extract(&job, &mut out, &bar, &mut warn)?;
            out.commit()?;
            emit(&serde_json::to_string_pretty(&summary)?)
        }
    }
}

impl SeriesArgs {
    fn source(&self) -> SeriesSource {
        SeriesSource {
            series: self.series.clone(),
            t0: self.t0.clone(),
            dark: self.dark.clone(),
        }
    }
}
