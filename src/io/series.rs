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
    // `image` is accepted as the first column's name too (the charging and captures CSVs use
    // it; docs/conventions.md).
    let i_file = t.column("file").or_else(|| t.column("image"));
    let (Some(i_file), Some(i_time)) = (i_file, t.column("time_s")) else {
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
pub fn resolve_exposure(info: &mut FrameInfo, row: Option<&ManifestRow>) -> Result<Exposure> {
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

/// A frame's time in s: the manifest's `time_s`, or the EXIF capture time of a frame listed by
/// folder (an error naming the file when it has none).
pub fn frame_time_s(info: &FrameInfo, row: Option<&ManifestRow>) -> Result<f64> {
    match row {
        Some(r) => Ok(r.time_s),
        None => info.capture_time_s.ok_or_else(|| {
            Error::invalid(
                "capture time",
                format!(
                    "{}: no EXIF capture time, so the folder cannot be ordered; list the frames in a manifest CSV file,time_s[,…]",
                    info.file
                ),
            )
        }),
    }
}

/// Files of a directory that look like frames (RAW or image extensions), sorted by name.
pub fn directory_frames(dir: &Path) -> Result<Vec<PathBuf>> {
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
        let time_s = frame_time_s(&info, row.as_ref())?;
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

/// Every file a photo series reads (the manifest or folder first, then each frame), for
/// registering inputs before any output is declared. Errors as [`load_series`]'s listing.
pub fn series_files(path: &Path) -> Result<Vec<PathBuf>> {
    let mut out = vec![path.to_path_buf()];
    if path.is_dir() {
        out.extend(directory_frames(path)?);
    } else {
        let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
        let base = path.parent().unwrap_or(Path::new("."));
        out.extend(
            parse_manifest(&bytes, &path.display().to_string(), base)?
                .into_iter()
                .map(|r| r.file),
        );
    }
    Ok(out)
}

/// A series manifest `file,time_s,exposure_s,iso,f_number` (what [`parse_manifest`] reads):
/// rows of (file, time in s, exposure in s, ISO, f-number).
pub fn manifest_csv(rows: &[(String, f64, f64, f64, f64)]) -> String {
    let mut csv = String::from("file,time_s,exposure_s,iso,f_number\n");
    for (f, t, e, iso, n) in rows {
        csv.push_str(&format!("{f},{t},{e},{iso},{n}\n"));
    }
    csv
}

// ---------------------------------------------------------------------------------------------
// Charging series (`phos fit-excitation --series`): the same manifest reader, other columns.
// ---------------------------------------------------------------------------------------------

/// Header of a charging manifest.
pub const CHARGING_MANIFEST_HEADER: &str = "image,band,charge_s[,exposure_s,iso,f_number]";

/// One row of a charging manifest `image,band,charge_s[,exposure_s,iso,f_number]`.
#[derive(Debug, Clone, PartialEq)]
pub struct ChargingRow {
    /// The image, resolved against the manifest's folder.
    pub image: PathBuf,
    /// Line in the manifest.
    pub line: usize,
    /// Excitation band, 0-based (1-based in the file).
    pub band: usize,
    /// Charging time in s.
    pub charge_s: f64,
    /// Exposure time in s, if listed.
    pub exposure_s: Option<f64>,
    /// ISO, if listed.
    pub iso: Option<f64>,
    /// f-number, if listed.
    pub f_number: Option<f64>,
}

/// Parses a charging manifest (through [`ManifestTable`], the one manifest reader); images are
/// resolved against `base` and must exist; bands are 1…`n_bands`.
pub fn parse_charging_manifest(
    bytes: &[u8],
    source: &str,
    base: &Path,
    n_bands: usize,
) -> Result<Vec<ChargingRow>> {
    const H: &str = CHARGING_MANIFEST_HEADER;
    let text = crate::table::as_text(bytes, source, &format!("a CSV manifest {H}"))?;
    let t = ManifestTable::parse(text, source, H)?;
    let (Some(i_img), Some(i_band), Some(i_t)) =
        (t.column("image"), t.column("band"), t.column("charge_s"))
    else {
        return Err(Error::parse(
            source,
            t.header_line,
            format!(
                "header '{}' lacks 'image', 'band' or 'charge_s'; expected {H}",
                t.header
            ),
        ));
    };
    let mut rows = Vec::new();
    for r in &t.records {
        let line = r.line;
        let band = t
            .number(r, Some(i_band), "band")?
            .ok_or_else(|| Error::parse(source, line, "band is empty"))?;
        if band.fract() != 0.0 || band < 1.0 || band > n_bands as f64 {
            return Err(Error::parse(
                source,
                line,
                format!(
                    "band {band}; expected an integer from 1 to {n_bands} (the material's bands)"
                ),
            ));
        }
        let charge_s = t
            .number(r, Some(i_t), "charge_s")?
            .ok_or_else(|| Error::parse(source, line, "charge_s is empty"))?;
        if charge_s < 0.0 {
            return Err(Error::parse(
                source,
                line,
                format!("charge_s {charge_s}; expected a charging time ≥ 0 s"),
            ));
        }
        let name = r.fields[i_img];
        if name.is_empty() {
            return Err(Error::parse(source, line, "image name is empty"));
        }
        let image = base.join(name);
        if !image.is_file() {
            return Err(Error::parse(
                source,
                line,
                format!(
                    "image '{}' does not exist (paths are relative to the manifest's folder)",
                    image.display()
                ),
            ));
        }
        let [exposure_s, iso, f_number] = t.exposure(r)?;
        rows.push(ChargingRow {
            image,
            line,
            band: band as usize - 1,
            charge_s,
            exposure_s,
            iso,
            f_number,
        });
    }
    if rows.is_empty() {
        return Err(Error::parse(
            source,
            0,
            format!("the manifest lists no images; expected rows {H}"),
        ));
    }
    Ok(rows)
}

/// A charging manifest as written by `synth phos-excitation --images`: a comment line, the
/// header with all exposure columns, one row per (image, band).
pub fn charging_manifest_csv(comment: &str, rows: &[(String, usize, f64, f64)]) -> String {
    let mut csv = format!("# {comment}\nimage,band,charge_s,exposure_s,iso,f_number\n");
    for (name, band, t, exposure_s) in rows {
        csv.push_str(&format!("{name},{},{t},{exposure_s},100,1\n", band + 1));
    }
    csv
}

/// One band's ROI with where it was defined (for messages).
#[derive(Debug, Clone, PartialEq)]
pub struct BandRoi {
    /// The rectangle.
    pub roi: crate::capture::Roi,
    /// `--roi` or `FILE line N`.
    pub origin: String,
}

/// ROIs per band, `band,x,y,w,h` (bands 1-based and unique, source pixels).
#[derive(Debug, Clone, PartialEq)]
pub struct BandRois(pub std::collections::BTreeMap<usize, BandRoi>);

impl BandRois {
    /// Parses `band,x,y,w,h` for a material of `n_bands` bands.
    pub fn parse(bytes: &[u8], source: &str, n_bands: usize) -> Result<Self> {
        use crate::capture::Roi;
        let t = crate::table::parse_numeric_csv(bytes, source)?;
        let mut ci = [0usize; 5];
        for (k, name) in ["band", "x", "y", "w", "h"].iter().enumerate() {
            ci[k] = t.column_index(name).ok_or_else(|| {
                Error::parse(
                    source,
                    1,
                    format!("no '{name}' column; expected header 'band,x,y,w,h' (source pixels)"),
                )
            })?;
        }
        let mut out = std::collections::BTreeMap::new();
        for i in 0..t.n_rows() {
            let line = t.lines[i];
            let v = ci.map(|c| t.columns[c][i]);
            if v.iter().any(|x| x.fract() != 0.0 || *x < 0.0) {
                return Err(Error::parse(
                    source,
                    line,
                    format!(
                        "{},{},{},{},{}: expected non-negative integers band,x,y,w,h",
                        v[0], v[1], v[2], v[3], v[4]
                    ),
                ));
            }
            if v[0] < 1.0 || v[0] > n_bands as f64 {
                return Err(Error::parse(
                    source,
                    line,
                    format!(
                        "band {}; expected an integer from 1 to {n_bands} (the material's bands)",
                        v[0]
                    ),
                ));
            }
            if v[3] < 1.0 || v[4] < 1.0 {
                return Err(Error::parse(
                    source,
                    line,
                    "width and height must be at least 1 pixel",
                ));
            }
            let band = v[0] as usize - 1;
            let roi = Roi::Rect {
                x: v[1] as usize,
                y: v[2] as usize,
                w: v[3] as usize,
                h: v[4] as usize,
            };
            let origin = format!("{source} line {line}");
            if let Some(prev) = out.insert(band, BandRoi { roi, origin }) {
                return Err(Error::parse(
                    source,
                    line,
                    format!(
                        "band {} already has an ROI ({}); expected one ROI per band",
                        band + 1,
                        prev.origin
                    ),
                ));
            }
        }
        if out.is_empty() {
            return Err(Error::parse(
                source,
                0,
                "no ROI rows; expected band,x,y,w,h rows",
            ));
        }
        Ok(Self(out))
    }

    /// One rectangle for every band (`--roi`).
    pub fn same_for_all(roi: crate::capture::Roi, n_bands: usize) -> Self {
        Self(
            (0..n_bands)
                .map(|b| {
                    (
                        b,
                        BandRoi {
                            roi: roi.clone(),
                            origin: "--roi".into(),
                        },
                    )
                })
                .collect(),
        )
    }

    /// The CSV text `band,x,y,w,h` (rectangles only).
    pub fn to_csv(&self) -> String {
        let mut csv = String::from("band,x,y,w,h\n");
        for (b, r) in &self.0 {
            if let crate::capture::Roi::Rect { x, y, w, h } = r.roi {
                csv.push_str(&format!("{},{x},{y},{w},{h}\n", b + 1));
            }
        }
        csv
    }
}

/// Where the ROIs of a charging series come from.
#[derive(Debug, Clone)]
pub enum RoiSource<'a> {
    /// `--roi x,y,w,h` for every band.
    One(&'a str),
    /// `--rois FILE.csv` with `band,x,y,w,h`.
    PerBand(&'a Path),
}

/// Charging samples read from a photo series, with what is needed for provenance and report.
#[derive(Debug, Clone)]
pub struct ChargingSeries {
    /// One sample per manifest row, in manifest order.
    pub samples: Vec<crate::phosphor::excitation::ChargingSample>,
    /// Every file read (manifest, ROI file, images, dark frames), for provenance.
    pub inputs: Vec<PathBuf>,
    /// Per-sample details for the report (image, line, ROI, pixels, exposure factor).
    pub report: serde_json::Value,
    /// Non-fatal remarks from the readers (8-bit images, EXIF/manifest disagreements).
    pub warnings: Vec<String>,
}

/// The files a charging series reads, before decoding anything: the manifest, the ROI file,
/// every image (each once) and the dark frames. For registering inputs before any work.
pub fn charging_series_inputs(
    manifest: &Path,
    rois: &RoiSource<'_>,
    darks: &[PathBuf],
    n_bands: usize,
) -> Result<Vec<PathBuf>> {
    let bytes = std::fs::read(manifest).map_err(|e| Error::io(manifest, e))?;
    let base = manifest.parent().unwrap_or(Path::new("."));
    let rows = parse_charging_manifest(&bytes, &manifest.display().to_string(), base, n_bands)?;
    let mut out = vec![manifest.to_path_buf()];
    if let RoiSource::PerBand(p) = rois {
        out.push(p.to_path_buf());
    }
    for r in rows {
        if !out.contains(&r.image) {
            out.push(r.image);
        }
    }
    out.extend(darks.iter().cloned());
    Ok(out)
}

/// Loads the charging samples of a manifest with its ROIs: per row, the image minus the mean of
/// the dark frames, the ROI mean over the band's ROI divided by the exposure factor
/// *t*·ISO/100/*N*² (EXIF first, manifest as fall-back), σ = the largest channel's standard
/// error of that mean. A saturated pixel in an ROI is an error naming the image. Everything is
/// checked before anything is returned.
pub fn load_charging_series(
    manifest: &Path,
    rois: RoiSource<'_>,
    darks: &[PathBuf],
    n_bands: usize,
) -> Result<ChargingSeries> {
    use crate::capture::{roi_stats, Roi};
    use crate::phosphor::excitation::ChargingSample;
    use std::collections::HashMap;
    let (bytes, source) = crate::io::read_input(manifest)?;
    let base = manifest.parent().unwrap_or(Path::new("."));
    let rows = parse_charging_manifest(&bytes, &source, base, n_bands)?;
    let mut inputs = vec![manifest.to_path_buf()];
    let per_band = match rois {
        RoiSource::One(s) => BandRois::same_for_all(Roi::parse_rect(s)?, n_bands),
        RoiSource::PerBand(p) => {
            inputs.push(p.to_path_buf());
            let (b, s) = crate::io::read_input(p)?;
            BandRois::parse(&b, &s, n_bands)?
        }
    };
    for r in &rows {
        if !per_band.0.contains_key(&r.band) {
            let file = match rois {
                RoiSource::PerBand(p) => p.display().to_string(),
                RoiSource::One(_) => "--roi".into(),
            };
            return Err(Error::parse(
                &source,
                r.line,
                format!(
                    "band {} has no ROI in {file}; expected a row '{},x,y,w,h' for it",
                    r.band + 1,
                    r.band + 1
                ),
            ));
        }
    }
    // Decode each image once (an image usually holds every band), in parallel.
    let mut unique: Vec<PathBuf> = Vec::new();
    let mut index: HashMap<PathBuf, usize> = HashMap::new();
    for r in &rows {
        if !index.contains_key(&r.image) {
            index.insert(r.image.clone(), unique.len());
            unique.push(r.image.clone());
        }
    }
    let decoded: Vec<Result<(RgbFrame, FrameInfo)>> =
        unique.par_iter().map(|p| read_frame(p)).collect();
    let mut frames = Vec::with_capacity(decoded.len());
    let mut warnings = Vec::new();
    for d in decoded {
        let (f, info) = d?;
        warnings.extend(info.warnings.iter().cloned());
        frames.push((f, info));
    }
    inputs.extend(unique.iter().cloned());
    if !darks.is_empty() {
        let dark_frames = darks
            .iter()
            .map(|p| read_frame(p).map(|(f, _)| f))
            .collect::<Result<Vec<_>>>()?;
        let dark = RgbFrame::mean_of(&dark_frames)?;
        for (f, _) in &mut frames {
            f.subtract(&dark)?;
        }
        inputs.extend(darks.iter().cloned());
    }
    let mut samples = Vec::with_capacity(rows.len());
    let mut details = Vec::with_capacity(rows.len());
    for r in &rows {
        let (frame, info) = &frames[index[&r.image]];
        let br = &per_band.0[&r.band];
        let where_ = || {
            format!(
                "{source}: line {}: {} (band {}, ROI from {})",
                r.line,
                r.image.display(),
                r.band + 1,
                br.origin
            )
        };
        let [t, iso, n] = exif_or_manifest(info, [r.exposure_s, r.iso, r.f_number], &mut warnings)
            .map_err(|name| {
                Error::parse(
                    &source,
                    r.line,
                    format!(
                        "{}: {name} is missing (or zero) in EXIF and not given in the manifest; add the column {name}",
                        r.image.display()
                    ),
                )
            })?;
        let exp = Exposure::new(t, iso, n).map_err(|e| {
            Error::invalid(
                format!("{source}: line {}: {}", r.line, r.image.display()),
                e.to_string(),
            )
        })?;
        let st = roi_stats(frame, &br.roi).map_err(|e| Error::invalid(where_(), e.to_string()))?;
        if st.n_saturated > 0 {
            return Err(Error::invalid(
                format!("{source}: line {}: {}", r.line, r.image.display()),
                format!(
                    "{} of {} pixels in the ROI {} of band {} are saturated; the mean would be \
                     biased low — use a shorter exposure or another region",
                    st.n_saturated,
                    st.n_pixels,
                    br.roi.describe(),
                    r.band + 1
                ),
            ));
        }
        let k = exp.factor();
        let n = st.n_pixels as f64;
        let se = st.std.iter().fold(0.0_f64, |m, s| m.max(*s)) / n.sqrt() / k;
        let rgb = st.mean.map(|m| m / k);
        details.push(serde_json::json!({
            "image": r.image.display().to_string(),
            "manifest_line": r.line,
            "band": r.band + 1,
            "charge_s": r.charge_s,
            "roi": br.roi.describe(),
            "n_pixels": st.n_pixels,
            "exposure_factor": k,
            "rgb": rgb,
            "std": se,
        }));
        samples.push(ChargingSample {
            band: r.band,
            charge_s: r.charge_s,
            rgb,
            sigma: (se > 0.0).then_some(se),
        });
    }
    Ok(ChargingSeries {
        samples,
        inputs,
        report: serde_json::json!({
            "manifest": manifest.display().to_string(),
            "darks": darks.iter().map(|p| p.display().to_string()).collect::<Vec<_>>(),
            "units": "relative radiance: (ROI mean − dark) / (exposure_s * ISO/100 / f_number^2); std = largest channel's standard error of the ROI mean",
            "samples": details,
        }),
        warnings,
    })
}

#[cfg(test)]
mod charging_tests {
    use super::*;

    #[test]
    fn charging_manifest_rows_skip_comments_and_read_optional_exposure_columns() {
        let d = tempfile::tempdir().unwrap();
        std::fs::write(d.path().join("a.tif"), b"x").unwrap();
        let text = "\u{feff}# note\nimage,band,charge_s,exposure_s\na.tif,2,16,\na.tif,1,4,0.5\n";
        let rows = parse_charging_manifest(text.as_bytes(), "m.csv", d.path(), 3).unwrap();
        assert_eq!(rows.len(), 2);
        assert_eq!((rows[0].line, rows[0].band, rows[0].charge_s), (3, 1, 16.0));
        assert_eq!(rows[0].exposure_s, None);
        assert_eq!(rows[1].exposure_s, Some(0.5));
        let err =
            parse_charging_manifest(b"image,band,charge_s\na.tif,4,1\n", "m.csv", d.path(), 3)
                .unwrap_err()
                .to_string();
        assert!(
            err.contains("m.csv: line 2") && err.contains("band 4"),
            "{err}"
        );
        let err = parse_charging_manifest(b"image,band\na.tif,1\n", "m.csv", d.path(), 3)
            .unwrap_err()
            .to_string();
        assert!(err.contains("charge_s"), "{err}");
    }

    #[test]
    fn a_written_series_manifest_reads_back() {
        let d = tempfile::tempdir().unwrap();
        std::fs::write(d.path().join("f.tif"), b"x").unwrap();
        let text = manifest_csv(&[("f.tif".into(), 2.5, 0.5, 100.0, 1.0)]);
        let rows = parse_manifest(text.as_bytes(), "m.csv", d.path()).unwrap();
        assert_eq!(rows.len(), 1);
        assert_eq!(rows[0].time_s, 2.5);
        assert_eq!(rows[0].exposure_s, Some(0.5));
    }

    #[test]
    fn a_written_charging_manifest_and_its_rois_read_back() {
        let d = tempfile::tempdir().unwrap();
        std::fs::write(d.path().join("c.tif"), b"x").unwrap();
        let text = charging_manifest_csv("synthetic", &[("c.tif".into(), 1, 8.0, 0.25)]);
        let rows = parse_charging_manifest(text.as_bytes(), "m.csv", d.path(), 2).unwrap();
        assert_eq!(
            (
                rows[0].band,
                rows[0].charge_s,
                rows[0].exposure_s,
                rows[0].iso,
                rows[0].f_number
            ),
            (1, 8.0, Some(0.25), Some(100.0), Some(1.0))
        );
        let rois = BandRois::same_for_all(
            crate::capture::Roi::Rect {
                x: 8,
                y: 8,
                w: 16,
                h: 16,
            },
            2,
        );
        let back = BandRois::parse(rois.to_csv().as_bytes(), "r.csv", 2).unwrap();
        assert_eq!(
            back.0.values().map(|b| b.roi.clone()).collect::<Vec<_>>(),
            rois.0.values().map(|b| b.roi.clone()).collect::<Vec<_>>()
        );
    }
}
