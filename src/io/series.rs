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

/// A manifest CSV split into records: comment (`#`) and blank lines skipped, the header's column
/// names lower-cased, every data row checked to have as many fields as the header.
#[derive(Debug, Clone)]
pub struct ManifestTable<'a> {
    /// Where the manifest came from (for messages).
    pub source: &'a str,
    /// 1-based line of the header.
    pub header_line: usize,
    /// The header as written.
    pub header: &'a str,
    /// Column names, trimmed and lower-cased.
    pub columns: Vec<String>,
    /// Data rows in order.
    pub records: Vec<ManifestRecord<'a>>,
}

/// One data row of a [`ManifestTable`].
#[derive(Debug, Clone)]
pub struct ManifestRecord<'a> {
    /// 1-based line in the manifest.
    pub line: usize,
    /// Trimmed fields.
    pub fields: Vec<&'a str>,
}

impl<'a> ManifestTable<'a> {
    /// Splits `text`; `expected` describes the header for the empty-manifest message.
    ///
    /// # Errors
    /// [`Error::Parse`] for an empty manifest or a row whose field count differs from the header's.
    pub fn parse(text: &'a str, source: &'a str, expected: &str) -> Result<Self> {
        let mut lines = text
            .lines()
            .enumerate()
            .map(|(i, l)| (i + 1, l.trim()))
            .filter(|(_, l)| !l.is_empty() && !l.starts_with('#'));
        let Some((header_line, header)) = lines.next() else {
            return Err(Error::parse(
                source,
                0,
                format!("empty manifest; expected a header {expected}"),
            ));
        };
        let columns: Vec<String> = header
            .split(',')
            .map(|s| s.trim().to_ascii_lowercase())
            .collect();
        let mut records = Vec::new();
        for (line, l) in lines {
            let fields: Vec<&str> = l.split(',').map(str::trim).collect();
            if fields.len() != columns.len() {
                return Err(Error::parse(
                    source,
                    line,
                    format!(
                        "{} fields, expected {} as in the header",
                        fields.len(),
                        columns.len()
                    ),
                ));
            }
            records.push(ManifestRecord { line, fields });
        }
        Ok(ManifestTable {
            source,
            header_line,
            header,
            columns,
            records,
        })
    }

    /// Index of the column `name` (lower case).
    pub fn column(&self, name: &str) -> Option<usize> {
        self.columns.iter().position(|c| c == name)
    }

    /// The finite number in column `i` of `r`, `None` when the column is absent or the field
    /// empty.
    ///
    /// # Errors
    /// [`Error::Parse`] naming the line and column for a non-number or a non-finite value.
    pub fn number(
        &self,
        r: &ManifestRecord<'_>,
        i: Option<usize>,
        name: &str,
    ) -> Result<Option<f64>> {
        let Some(i) = i else { return Ok(None) };
        let s = r.fields[i];
        if s.is_empty() {
            return Ok(None);
        }
        let v: f64 = s.parse().map_err(|_| {
            Error::parse(self.source, r.line, format!("{name} '{s}' is not a number"))
        })?;
        if !v.is_finite() {
            return Err(Error::parse(
                self.source,
                r.line,
                format!("{name} '{s}' is not finite"),
            ));
        }
        Ok(Some(v))
    }

    /// The optional `exposure_s`, `iso`, `f_number` columns of `r`: negative is an error, 0 or
    /// empty means "not given" (take EXIF).
    ///
    /// # Errors
    /// [`Error::Parse`] naming the line for a malformed or negative value.
    pub fn exposure(&self, r: &ManifestRecord<'_>) -> Result<[Option<f64>; 3]> {
        let mut out = [None; 3];
        for (k, name) in ["exposure_s", "iso", "f_number"].into_iter().enumerate() {
            out[k] = match self.number(r, self.column(name), name)? {
                Some(x) if x < 0.0 => {
                    return Err(Error::parse(
                        self.source,
                        r.line,
                        format!("{name} {x} is negative"),
                    ))
                }
                Some(0.0) => None,
                other => other,
            };
        }
        Ok(out)
    }
}

/// Exposure time, ISO and f-number of a frame: EXIF first, the manifest's `manifest` values as
/// fall-back; a disagreement of more than 1 % is a warning (EXIF wins). `Err(name)` names the
/// first value that neither gives.
pub fn exif_or_manifest(
    info: &FrameInfo,
    manifest: [Option<f64>; 3],
    warnings: &mut Vec<String>,
) -> std::result::Result<[f64; 3], &'static str> {
    let exif = [info.exposure_s, info.iso, info.f_number];
    let mut out = [0.0; 3];
    for (k, name) in ["exposure_s", "iso", "f_number"].into_iter().enumerate() {
        if let (Some(a), Some(b)) = (exif[k], manifest[k]) {
            if (a - b).abs() > 0.01 * a.abs().max(b.abs()) {
                warnings.push(format!(
                    "{}: {name} is {a} in EXIF but {b} in the manifest; using EXIF",
                    info.file
                ));
            }
        }
        out[k] = exif[k].or(manifest[k]).ok_or(name)?;
    }
    Ok(out)
}

/// Parses a manifest CSV; files are resolved against `base` and must exist.
///
/// # Errors
/// [`Error::Parse`] with the manifest's name and line.
pub fn parse_manifest(bytes: &[u8], source: &str, base: &Path) -> Result<Vec<ManifestRow>> {
    const HEADER: &str = "file,time_s[,exposure_s,iso,f_number]";
    let text = crate::table::as_text(bytes, source, &format!("a CSV manifest {HEADER}"))?;
    let t = ManifestTable::parse(text, source, HEADER)?;
    let (Some(i_file), Some(i_time)) = (t.column("file"), t.column("time_s")) else {
        return Err(Error::parse(
            source,
            t.header_line,
            format!(
                "header '{}' lacks 'file' and 'time_s'; expected {HEADER}",
                t.header
            ),
        ));
    };
    let mut rows = Vec::new();
    for r in &t.records {
        let line = r.line;
        let time_s = t
            .number(r, Some(i_time), "time_s")?
            .ok_or_else(|| Error::parse(source, line, "time_s is empty"))?;
        let f = r.fields[i_file];
        if f.is_empty() {
            return Err(Error::parse(source, line, "file name is empty"));
        }
        let file = base.join(f);
        if file.is_dir() {
            return Err(Error::parse(
                source,
                line,
                format!(
                    "frame '{}' is a directory; expected an image or RAW file",
                    file.display()
                ),
            ));
        }
        if !file.is_file() {
            return Err(Error::parse(
                source,
                line,
                format!("frame file '{}' does not exist", file.display()),
            ));
        }
        let [exposure_s, iso, f_number] = t.exposure(r)?;
        rows.push(ManifestRow {
            file,
            line,
            time_s,
            exposure_s,
            iso,
            f_number,
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
    let manifest = row.map_or([None; 3], |r| [r.exposure_s, r.iso, r.f_number]);
    let mut warnings = Vec::new();
    let picked = exif_or_manifest(info, manifest, &mut warnings);
    info.warnings.extend(warnings);
    let [t, iso, n] = picked.map_err(|name| {
        Error::invalid(
            name,
            format!(
                "{}: {name} is missing (or zero) in EXIF and not given in a manifest; list the frames in a manifest CSV with columns file,time_s,exposure_s,iso,f_number",
                info.file
            ),
        )
    })?;
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

/// A mask image as a region: pixels with any non-zero channel are inside.
///
/// # Errors
/// The errors of [`read_frame`].
pub fn read_mask(path: &Path) -> Result<crate::capture::Roi> {
    let (frame, _) = read_frame(path)?;
    let inside = frame
        .data()
        .chunks(3)
        .map(|p| p.iter().any(|v| *v > 0.0))
        .collect();
    Ok(crate::capture::Roi::Mask {
        width: frame.width,
        height: frame.height,
        inside,
        name: path.display().to_string(),
    })
}

/// Header of a region curve CSV (`series extract`).
pub const CURVE_HEADER: &str = "time_s,r,g,b,r_std,g_std,b_std,n_pixels,n_saturated";

/// A region curve as CSV ([`CURVE_HEADER`], one row per frame).
pub fn curve_csv(curve: &[crate::capture::CurveSample]) -> String {
    let mut csv = format!("{CURVE_HEADER}\n");
    for s in curve {
        csv.push_str(&format!(
            "{},{},{},{},{},{},{},{},{}\n",
            s.time_s,
            s.mean[0],
            s.mean[1],
            s.mean[2],
            s.std[0],
            s.std[1],
            s.std[2],
            s.n_pixels,
            s.n_saturated
        ));
    }
    csv
}

/// The frame files of a series (a manifest CSV or a folder), without decoding them: what a
/// command registers as its inputs before declaring outputs.
///
/// # Errors
/// The manifest's parse errors (naming the file and line), or a folder without frames.
pub fn series_frame_files(path: &Path) -> Result<Vec<PathBuf>> {
    if path.is_dir() {
        return directory_frames(path);
    }
    let (bytes, source) = super::read_input(path)?;
    let base = path.parent().unwrap_or(Path::new("."));
    Ok(parse_manifest(&bytes, &source, base)?
        .into_iter()
        .map(|r| r.file)
        .collect())
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
