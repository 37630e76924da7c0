//! Photo series from a manifest CSV or a directory, and the frame reader that dispatches between
//! RAW and ordinary images.
//!
//! **Manifest** (`file,time_s[,exposure_s,iso,f_number]`, header required, `#` comments): files
//! relative to the manifest's folder; times in s, strictly increasing in the listed order.
//! Exposure settings come from EXIF when present and non-zero, else from the manifest; a frame
//! with neither is an error naming the file and the field.
//!
//! **Directory**: every RAW or image file in it, sorted by EXIF capture time; time 0 is the
//! first frame, or the moment given as `t0` (seconds since 1970 in camera local time; see
//! [`crate::capture::parse_datetime`]).
//!
//! Frames are decoded in parallel (rayon); a callback reports each finished frame (for a
//! progress bar). Optional dark frames are averaged and subtracted from every frame.

use std::path::{Path, PathBuf};

use rayon::prelude::*;

use crate::capture::{Exposure, FrameInfo, PhotoSeries, RgbFrame, SeriesFrame};
use crate::error::{Error, Result};
use crate::io::exif::read_exif_bytes;
use crate::io::{image as image_io, raw};

/// Reads one RAW or image file with its EXIF.
///
/// # Errors
/// [`Error::Io`] naming the file when it cannot be read or decoded.
pub fn read_frame(path: &Path) -> Result<(RgbFrame, FrameInfo)> {
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    let (frame, mut info) = if raw::is_raw_path(path) {
        raw::read_raw_bytes(&bytes, path)?
    } else {
        image_io::read_image_bytes(&bytes, path)?
    };
    if let Some(ex) = read_exif_bytes(&bytes) {
        info.exposure_s = ex.exposure_s;
        info.iso = ex.iso;
        info.f_number = ex.f_number;
        info.capture_time_s = ex.capture_time_s;
        info.capture_time = ex.capture_time;
    }
    Ok((frame, info))
}

/// One row of a manifest.
#[derive(Debug, Clone, PartialEq)]
pub struct ManifestRow {
    /// Frame file (resolved against the manifest's folder).
    pub file: PathBuf,
    /// 1-based line in the manifest.
    pub line: usize,
    /// Time in s.
    pub time_s: f64,
    /// Exposure time in s.
    pub exposure_s: Option<f64>,
    /// ISO.
    pub iso: Option<f64>,
    /// f-number.
    pub f_number: Option<f64>,
}

/// Parses a manifest CSV; files are resolved against `base` and must exist.
///
/// # Errors
/// [`Error::Parse`] with the manifest's name and line.
pub fn parse_manifest(bytes: &[u8], source: &str, base: &Path) -> Result<Vec<ManifestRow>> {
    let text = std::str::from_utf8(bytes).map_err(|_| {
        Error::parse(
            source,
            0,
            "not a text file; expected a CSV manifest file,time_s[,exposure_s,iso,f_number]",
        )
    })?;
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim()))
        .filter(|(_, l)| !l.is_empty() && !l.starts_with('#'));
    let Some((hline, header)) = lines.next() else {
        return Err(Error::parse(
            source,
            0,
            "empty manifest; expected a header file,time_s[,exposure_s,iso,f_number]",
        ));
    };
    let cols: Vec<String> = header
        .split(',')
        .map(|s| s.trim().to_ascii_lowercase())
        .collect();
    let idx = |n: &str| cols.iter().position(|c| c == n);
    let (Some(i_file), Some(i_time)) = (idx("file"), idx("time_s")) else {
        return Err(Error::parse(
            source,
            hline,
            format!("header '{header}' lacks 'file' and 'time_s'; expected file,time_s[,exposure_s,iso,f_number]"),
        ));
    };
    let (i_exp, i_iso, i_f) = (idx("exposure_s"), idx("iso"), idx("f_number"));
    let mut rows = Vec::new();
    for (line, l) in lines {
        let fields: Vec<&str> = l.split(',').map(str::trim).collect();
        if fields.len() != cols.len() {
            return Err(Error::parse(
                source,
                line,
                format!(
                    "{} fields, expected {} as in the header",
                    fields.len(),
                    cols.len()
                ),
            ));
        }
        let num = |i: Option<usize>, name: &str| -> Result<Option<f64>> {
            let Some(i) = i else { return Ok(None) };
            let s = fields[i];
            if s.is_empty() {
                return Ok(None);
            }
            let v: f64 = s
                .parse()
                .map_err(|_| Error::parse(source, line, format!("{name} '{s}' is not a number")))?;
            if !v.is_finite() {
                return Err(Error::parse(
                    source,
                    line,
                    format!("{name} '{s}' is not finite"),
                ));
            }
            Ok(Some(v))
        };
        let time_s = num(Some(i_time), "time_s")?
            .ok_or_else(|| Error::parse(source, line, "time_s is empty"))?;
        let f = fields[i_file];
        if f.is_empty() {
            return Err(Error::parse(source, line, "file name is empty"));
        }
        let file = base.join(f);
        if !file.is_file() {
            return Err(Error::parse(
                source,
                line,
                format!("frame file '{}' does not exist", file.display()),
            ));
        }
        let positive = |v: Option<f64>, name: &str| -> Result<Option<f64>> {
            match v {
                Some(x) if x < 0.0 => Err(Error::parse(
                    source,
                    line,
                    format!("{name} {x} is negative"),
                )),
                Some(0.0) => Ok(None),
                other => Ok(other),
            }
        };
        rows.push(ManifestRow {
            file,
            line,
            time_s,
            exposure_s: positive(num(i_exp, "exposure_s")?, "exposure_s")?,
            iso: positive(num(i_iso, "iso")?, "iso")?,
            f_number: positive(num(i_f, "f_number")?, "f_number")?,
        });
    }
    if rows.is_empty() {
        return Err(Error::parse(source, 0, "the manifest lists no frames"));
    }
    Ok(rows)
}

/// How to load a series.
#[derive(Debug, Clone, Default)]
pub struct SeriesOptions {
    /// Time 0 for directory series, seconds since 1970 (camera local time); default: first frame.
    pub t0_s: Option<f64>,
    /// Dark frames, averaged and subtracted from every frame.
    pub darks: Vec<PathBuf>,
}

/// Resolves the exposure of a frame: EXIF first, manifest as fall-back.
fn resolve_exposure(info: &mut FrameInfo, row: Option<&ManifestRow>) -> Result<Exposure> {
    let mut pick = |exif: Option<f64>, manifest: Option<f64>, name: &str| -> Result<f64> {
        if let (Some(a), Some(b)) = (exif, manifest) {
            if (a - b).abs() > 0.01 * a.abs().max(b.abs()) {
                info.warnings.push(format!(
                    "{}: {name} is {a} in EXIF but {b} in the manifest; using EXIF",
                    info.file
                ));
            }
        }
        exif.or(manifest).ok_or_else(|| {
            Error::invalid(
                name,
                format!(
                    "{}: {name} is missing (or zero) in EXIF and not given in a manifest; list the frames in a manifest CSV with columns file,time_s,exposure_s,iso,f_number",
                    info.file
                ),
            )
        })
    };
    let t = pick(
        info.exposure_s,
        row.and_then(|r| r.exposure_s),
        "exposure_s",
    )?;
    let iso = pick(info.iso, row.and_then(|r| r.iso), "iso")?;
    let n = pick(info.f_number, row.and_then(|r| r.f_number), "f_number")?;
    Exposure::new(t, iso, n)
}

/// A loaded series and the non-fatal remarks gathered while loading.
#[derive(Debug, Clone)]
pub struct LoadedSeries {
    /// The series (dark subtracted when darks were given).
    pub series: PhotoSeries,
    /// Warnings (8-bit inputs, EXIF/manifest disagreements, …), one line each.
    pub warnings: Vec<String>,
}

/// Files of a directory that look like frames (RAW or image extensions), sorted by name.
fn directory_frames(dir: &Path) -> Result<Vec<PathBuf>> {
    const IMAGE_EXT: &[&str] = &["png", "tif", "tiff", "exr"];
    let mut out = Vec::new();
    for entry in std::fs::read_dir(dir).map_err(|e| Error::io(dir, e))? {
        let p = entry.map_err(|e| Error::io(dir, e))?.path();
        let ext = p
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase())
            .unwrap_or_default();
        if p.is_file() && (raw::is_raw_path(&p) || IMAGE_EXT.contains(&ext.as_str())) {
            out.push(p);
        }
    }
    out.sort();
    if out.is_empty() {
        return Err(Error::invalid(
            "series",
            format!(
                "{}: no RAW, PNG, TIFF or EXR files in this folder",
                dir.display()
            ),
        ));
    }
    Ok(out)
}

/// Loads a series from a manifest CSV or a directory (see the module docs). `progress` is called
/// once per decoded frame, from worker threads.
///
/// # Errors
/// Any frame's read error (naming the file), missing exposure settings, sizes that differ,
/// duplicated or decreasing times.
pub fn load_series(
    path: &Path,
    options: &SeriesOptions,
    progress: &(dyn Fn() + Sync),
) -> Result<LoadedSeries> {
    let rows: Vec<(PathBuf, Option<ManifestRow>)> = if path.is_dir() {
        directory_frames(path)?
            .into_iter()
            .map(|p| (p, None))
            .collect()
    } else {
        let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
        let base = path.parent().unwrap_or(Path::new("."));
        parse_manifest(&bytes, &path.display().to_string(), base)?
            .into_iter()
            .map(|r| (r.file.clone(), Some(r)))
            .collect()
    };
    let decoded: Vec<Result<(RgbFrame, FrameInfo)>> = rows
        .par_iter()
        .map(|(p, _)| {
            let r = read_frame(p);
            progress();
            r
        })
        .collect();
    let mut frames = Vec::with_capacity(rows.len());
    let mut warnings = Vec::new();
    for ((_, row), d) in rows.iter().zip(decoded) {
        let (frame, mut info) = d?;
        let exposure = resolve_exposure(&mut info, row.as_ref())?;
        warnings.extend(info.warnings.iter().cloned());
        let time_s = match row {
            Some(r) => r.time_s,
            None => info.capture_time_s.ok_or_else(|| {
                Error::invalid(
                    "capture time",
                    format!(
                        "{}: no EXIF capture time, so the folder cannot be ordered; list the frames in a manifest CSV file,time_s[,…]",
                        info.file
                    ),
                )
            })?,
        };
        frames.push(SeriesFrame {
            time_s,
            exposure,
            frame,
            info,
        });
    }
    if path.is_dir() {
        frames.sort_by(|a, b| a.time_s.total_cmp(&b.time_s));
        let t0 = options
            .t0_s
            .unwrap_or_else(|| frames.first().map_or(0.0, |f| f.time_s));
        for f in &mut frames {
            f.time_s -= t0;
        }
    }
    let mut series = PhotoSeries::new(frames)?;
    if !options.darks.is_empty() {
        let darks = options
            .darks
            .iter()
            .map(|p| read_frame(p).map(|(f, _)| f))
            .collect::<Result<Vec<_>>>()?;
        let dark = RgbFrame::mean_of(&darks)?;
        series.subtract_dark(&dark)?;
    }
    Ok(LoadedSeries { series, warnings })
}
