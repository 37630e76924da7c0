//! Photo series (`lumifit series inspect|extract`): what each command does between its flags and
//! its printed line — find the series (a manifest, or a folder read by EXIF time), register its
//! frames, decode them with darks subtracted, and return the per-frame metadata or stage the
//! region curve in the caller's [`Outputs`]. The caller commits and prints.

use std::path::PathBuf;

use serde_json::{json, Value};

use crate::capture::{parse_datetime, Roi};
use crate::error::{Error, Result};
use crate::io::series::{
    curve_csv, load_series, read_mask, series_frame_files, LoadedSeries, SeriesOptions,
};
use crate::io::Outputs;
use crate::pipeline::Progress;

/// Where a series comes from.
#[derive(Debug, Clone)]
pub struct SeriesSource {
    /// Manifest CSV or folder.
    pub series: PathBuf,
    /// `--t0` capture time as typed (folder series).
    pub t0: Option<String>,
    /// Dark frames, averaged and subtracted.
    pub dark: Vec<PathBuf>,
}

impl SeriesSource {
    /// The series to read: a folder that holds a `manifest.csv` means that manifest (its times
    /// and exposures), as `synth phos-decay --out DIR` writes it; any other folder is read by
    /// EXIF time.
    pub fn path(&self) -> PathBuf {
        let m = self.series.join("manifest.csv");
        if self.series.is_dir() && m.is_file() {
            m
        } else {
            self.series.clone()
        }
    }

    /// Registers the manifest, frames and darks as inputs; returns the number of frames.
    pub fn register(&self, out: &mut Outputs) -> Result<usize> {
        let path = self.path();
        let frames = series_frame_files(&path)?;
        out.input(&path).inputs(&frames).inputs(&self.dark);
        Ok(frames.len())
    }

    /// Decodes the `n_frames` frames (counted by `progress`); warnings go to `warn`.
    pub fn load(
        &self,
        n_frames: usize,
        progress: &dyn Progress,
        warn: &mut dyn FnMut(String),
    ) -> Result<LoadedSeries> {
        let t0_s = match &self.t0 {
            None => None,
            Some(s) => Some(parse_datetime(s).ok_or_else(|| {
                Error::flag(
                    "--t0",
                    format!("'{s}' is not a capture time; expected YYYY:MM:DD HH:MM:SS[.sss]"),
                )
            })?),
        };
        let options = SeriesOptions {
            t0_s,
            darks: self.dark.clone(),
        };
        progress.start(n_frames);
        let path = self.path();
        let loaded = load_series(&path, &options, &|| progress.inc());
        progress.finish();
        let loaded = loaded.map_err(|e| e.context(format!("loading series {}", path.display())))?;
        for w in &loaded.warnings {
            warn(format!("warning: {w}"));
        }
        Ok(loaded)
    }
}

/// `series inspect`: one row per frame, as JSON (`json`) or a tab-separated table; returns the
/// text to print.
pub fn run_inspect(
    src: &SeriesSource,
    json: bool,
    progress: &dyn Progress,
    warn: &mut dyn FnMut(String),
) -> Result<String> {
    let n = src.register(&mut Outputs::new())?;
    let loaded = src.load(n, progress, warn)?;
    if json {
        let rows: Vec<Value> = loaded
            .series
            .frames()
            .iter()
            .map(|f| {
                json!({
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
        return serde_json::to_string_pretty(&rows).map_err(|e| Error::Numerical {
            what: "JSON serialisation".into(),
            reason: e.to_string(),
        });
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
    Ok(out.trim_end().to_string())
}

/// `series extract`: the region curve of a series.
#[derive(Debug, Clone)]
pub struct ExtractJob {
    /// The series.
    pub source: SeriesSource,
    /// `--roi x,y,w,h` as typed (default: the whole frame).
    pub roi: Option<String>,
    /// Mask image (non-zero pixels inside).
    pub mask: Option<PathBuf>,
    /// Output CSV.
    pub out: PathBuf,
}

/// Registers the series and mask, declares the CSV, extracts, stages it and returns the
/// summary to print.
pub fn run_extract(
    job: &ExtractJob,
    out: &mut Outputs,
    progress: &dyn Progress,
    warn: &mut dyn FnMut(String),
) -> Result<Value> {
    let n = job.source.register(out)?;
    out.inputs(&job.mask);
    out.declare("--out", &job.out)?;
    let roi = match (&job.roi, &job.mask) {
        (Some(r), _) => Some(Roi::parse_rect(r)?),
        (None, Some(m)) => Some(read_mask(m)?),
        (None, None) => None,
    };
    let loaded = job.source.load(n, progress, warn)?;
    let roi = match roi {
        Some(r) => r,
        None => {
            let Some(first) = loaded.series.frames().first() else {
                return Err(Error::message(format!(
                    "{}: no frames",
                    job.source.series.display()
                )));
            };
            let (w, h) = first.frame.source_size();
            Roi::Rect { x: 0, y: 0, w, h }
        }
    };
    let curve = loaded.series.extract(&roi)?;
    out.stage(&job.out, curve_csv(&curve).as_bytes())?;
    Ok(json!({
        "out": job.out.display().to_string(),
        "frames": curve.len(),
        "roi": roi.describe(),
    }))
}
