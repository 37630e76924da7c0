//! `lumifit series inspect|extract`: photo series (manifest CSV or folder) to per-frame metadata
//! and region curves in relative radiance.

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::{Args, Subcommand};
use lumifit::capture::{parse_datetime, Roi};
use lumifit::io::series::{
    curve_csv, load_series, read_mask, series_frame_files, LoadedSeries, SeriesOptions,
};
use lumifit::io::Outputs;

use super::emit;

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
    match cmd {
        SeriesCommand::Inspect(a) => inspect(&a),
        SeriesCommand::Extract(a) => extract(&a),
    }
}

/// Registers the series' manifest, frames and darks as inputs; returns the number of frames.
/// The series to read: a folder that holds a `manifest.csv` means that manifest (its times and
/// exposures), as `synth phos-decay --out DIR` writes it; any other folder is read by EXIF time.
fn series_path(a: &SeriesArgs) -> PathBuf {
    let m = a.series.join("manifest.csv");
    if a.series.is_dir() && m.is_file() {
        m
    } else {
        a.series.clone()
    }
}

fn register(a: &SeriesArgs, out: &mut Outputs) -> Result<usize> {
    let path = series_path(a);
    let frames = series_frame_files(&path)?;
    out.input(&path).inputs(&frames).inputs(&a.dark);
    Ok(frames.len())
}

fn load(a: &SeriesArgs, n_frames: usize) -> Result<LoadedSeries> {
    let t0_s = match &a.t0 {
        None => None,
        Some(s) => Some(parse_datetime(s).ok_or_else(|| {
            anyhow::anyhow!("--t0: '{s}' is not a capture time; expected YYYY:MM:DD HH:MM:SS[.sss]")
        })?),
    };
    let options = SeriesOptions {
        t0_s,
        darks: a.dark.clone(),
    };
    let bar = super::progress_bar(n_frames, "decoding", "frames");
    let path = series_path(a);
    let loaded = load_series(&path, &options, &|| bar.inc(1));
    bar.finish_and_clear();
    let loaded = loaded.with_context(|| format!("loading series {}", path.display()))?;
    for w in &loaded.warnings {
        eprintln!("warning: {w}");
    }
    Ok(loaded)
}

fn inspect(a: &InspectArgs) -> Result<()> {
    let n = register(&a.series, &mut Outputs::new())?;
    let loaded = load(&a.series, n)?;
    let rows: Vec<serde_json::Value> = loaded
        .series
        .frames()
        .iter()
        .map(|f| {
            serde_json::json!({
                "file": f.info.file,
                "time_s": f.time_s,
                "exposure_s": f.exposure.exposure_s,
                "iso": f.exposure.iso,
                "f_number": f.exposure.f_number,
                "capture_time": f.info.capture_time,
                "encoding": f.info.encoding,
                "size": [f.frame.source_size().0, f.frame.source_size().1],
                "black_level": f.info.black_level,
                "white_level": f.info.white_level,
                "white_level_measured": f.info.white_level_measured,
                "saturated_fraction": f.frame.saturated_fraction(),
            })
        })
        .collect();
    if a.json {
        return emit(&serde_json::to_string_pretty(&rows)?);
    }
    let mut out =
        String::from("file\ttime_s\texposure_s\tiso\tf_number\tblack\twhite\tsaturated_fraction\n");
    for f in loaded.series.frames() {
        let black = f
            .info
            .black_level
            .map(|b| format!("{}", b[0]))
            .unwrap_or_else(|| "-".into());
        let white = f
            .info
            .white_level
            .map(|w| format!("{w}"))
            .unwrap_or_else(|| "-".into());
        out.push_str(&format!(
            "{}\t{}\t{}\t{}\t{}\t{}\t{}\t{:.6}\n",
            f.info.file,
            f.time_s,
            f.exposure.exposure_s,
            f.exposure.iso,
            f.exposure.f_number,
            black,
            white,
            f.frame.saturated_fraction()
        ));
    }
    emit(out.trim_end())
}

fn extract(a: &ExtractArgs) -> Result<()> {
    let mut out = Outputs::new();
    let n = register(&a.series, &mut out)?;
    out.inputs(&a.mask);
    out.declare("--out", &a.out)?;
    let roi = match (&a.roi, &a.mask) {
        (Some(r), _) => Some(Roi::parse_rect(r)?),
        (None, Some(m)) => Some(read_mask(m)?),
        (None, None) => None,
    };
    let loaded = load(&a.series, n)?;
    let roi = match roi {
        Some(r) => r,
        None => {
            let Some(first) = loaded.series.frames().first() else {
                anyhow::bail!("{}: no frames", a.series.series.display());
            };
            let (w, h) = first.frame.source_size();
            Roi::Rect { x: 0, y: 0, w, h }
        }
    };
    let curve = loaded.series.extract(&roi)?;
    out.stage(&a.out, curve_csv(&curve).as_bytes())?;
    out.commit()?;
    emit(&serde_json::to_string_pretty(&serde_json::json!({
        "out": a.out.display().to_string(),
        "frames": curve.len(),
        "roi": roi.describe(),
    }))?)
}
