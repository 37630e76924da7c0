//! Camera spectral sensitivities: the one reader for `--camera FILE.csv` in every command.
//!
//! A camera table is a CSV `wavelength_nm,r,g,b` (header row, `#` comments, BOM and CRLF accepted,
//! through [`crate::table::parse_numeric_csv`], which also refuses NaN/inf and duplicate
//! columns). One set of checks for every command: exactly three channels, strictly increasing
//! wavelengths ([`MultiSpectrum::from_table`]) and no negative sensitivity (an error naming the
//! file, the line and the channel). Without a file the embedded default camera is used
//! (`calib/camera_default.csv`, Nikon 5100 NPL measurements).
//!
//! A camera may also be given in the Academy spectral-data JSON of `rawtoaces` (AMPAS,
//! `{"header": {…}, "spectral_data": {"units": …, "index": {"main": ["R","G","B"]}, "data":
//! {"main": {"380": [r, g, b], …}}}}`, e.g. `../shared/data/camera/rawtoaces-data/*.json`, measured
//! 380–780 nm), told apart from CSV by its first character `{`; [`parse_camera_json`].

use std::path::Path;

use crate::error::{Error, Result};
use crate::math::interpolation::Interpolator;
use crate::spectrum::{MultiSpectrum, Spectrum};
use crate::table::parse_numeric_csv;

/// Name under which the embedded default camera appears in messages and provenance.
pub const DEFAULT_CAMERA_NAME: &str = "calib/camera_default.csv";

/// Camera sensitivities with the name of where they came from.
#[derive(Debug, Clone)]
pub struct Camera {
    /// The three channels r, g, b on the table's wavelengths.
    pub curves: MultiSpectrum,
    /// The file name (or [`DEFAULT_CAMERA_NAME`]).
    pub source: String,
}

/// Parses a camera table (see the module docs); `source` names it in errors.
///
/// # Errors
/// [`Error::Parse`] naming the source and line for malformed CSV, a column count other than
/// four, or a negative sensitivity; the spectrum errors of [`MultiSpectrum::from_table`].
pub fn parse_camera(bytes: &[u8], source: &str) -> Result<MultiSpectrum> {
    let t = parse_numeric_csv(bytes, source)?;
    if t.columns.len() != 4 {
        return Err(Error::parse(
            source,
            t.lines.first().map_or(0, |l| l.saturating_sub(1)),
            format!(
                "{} columns; expected wavelength_nm,r,g,b (camera sensitivities)",
                t.columns.len()
            ),
        ));
    }
    for (c, col) in t.columns.iter().enumerate().skip(1) {
        if let Some(i) = col.iter().position(|v| *v < 0.0) {
            return Err(Error::parse(
                source,
                t.lines[i],
                format!(
                    "{} sensitivity {} is negative; expected values ≥ 0",
                    t.header.get(c).map_or("channel", |s| s.as_str()),
                    col[i]
                ),
            ));
        }
    }
    MultiSpectrum::from_table(&t)
}

/// Reads `--camera` (`None`: the embedded default camera).
///
/// # Errors
/// [`Error::Io`] naming the file when it cannot be read; the errors of [`parse_camera`].
pub fn read_camera(path: Option<&Path>) -> Result<Camera> {
    match path {
        None => Ok(Camera {
            curves: parse_camera(
                crate::lvf::synth::DEFAULT_CAMERA_CSV.as_bytes(),
                DEFAULT_CAMERA_NAME,
            )?,
            source: DEFAULT_CAMERA_NAME.to_string(),
        }),
        Some(p) if !p.is_file() => match database_entry(p) {
            Some((file, name)) => {
                let (bytes, source) = super::read_input(&file)?;
                Ok(Camera {
                    curves: parse_camera_database(&bytes, &source, &name)?,
                    source: format!("{source}:{name}"),
                })
            }
            None => {
                let (bytes, source) = super::read_input(p)?;
                Ok(Camera {
                    curves: parse_camera_file(&bytes, &source)?,
                    source,
                })
            }
        },
        Some(p) => {
            let (bytes, source) = super::read_input(p)?;
            Ok(Camera {
                curves: parse_camera_file(&bytes, &source)?,
                source,
            })
        }
    }
}

/// A camera file of either format: Academy spectral-data JSON when its first character (after a
/// byte-order mark and white space) is `{`, otherwise a CSV table ([`parse_camera`]).
///
/// # Errors
/// Those of [`parse_camera_json`] or [`parse_camera`].
pub fn parse_camera_file(bytes: &[u8], source: &str) -> Result<MultiSpectrum> {
    let body = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    match body.iter().find(|b| !b.is_ascii_whitespace()) {
        Some(b'{') => parse_camera_json(bytes, source),
        _ => parse_camera(bytes, source),
    }
}

#[derive(serde::Deserialize)]
struct AcademyDocument {
    spectral_data: AcademySpectralData,
}

#[derive(serde::Deserialize)]
struct AcademySpectralData {
    index: AcademyIndex,
    data: AcademyData,
}

#[derive(serde::Deserialize)]
struct AcademyIndex {
    main: Vec<String>,
}

#[derive(serde::Deserialize)]
struct AcademyData {
    main: std::collections::BTreeMap<String, Vec<f64>>,
}

/// The 1-based line of the last occurrence of `"key"` in `text` (0 when absent): where a
/// semantic error in a JSON file is reported.
fn json_key_line(text: &str, key: &str) -> usize {
    let needle = format!("\"{key}\"");
    text.rfind(&needle)
        .map_or(0, |at| text[..at].matches('\n').count() + 1)
}

/// Parses a camera in the Academy spectral-data JSON of `rawtoaces` (module docs): the channels
/// named R, G and B in `spectral_data.index.main` (any order, case-insensitive), one wavelength
/// per key of `spectral_data.data.main`, each an array of as many values as the index names.
/// The header and `units` (relative sensitivities) are not needed and not read.
///
/// # Errors
/// [`Error::Parse`] naming the source, and the line where it can be found, for malformed JSON or a
/// missing field (serde's line and column), an index that is not R, G, B, a wavelength key that is
/// not a finite number, an entry with the wrong number of values, or a negative sensitivity; the
/// spectrum errors of [`MultiSpectrum::new`] (wavelengths strictly increasing, at least two).
pub fn parse_camera_json(bytes: &[u8], source: &str) -> Result<MultiSpectrum> {
    let doc: AcademyDocument = super::parse_json(bytes, source)?;
    let text = crate::table::as_text(bytes, source, "JSON text")?;
    let names = &doc.spectral_data.index.main;
    let at = |want: &str| {
        names
            .iter()
            .position(|n| n.trim().eq_ignore_ascii_case(want))
    };
    let order = match (names.len(), at("R"), at("G"), at("B")) {
        (3, Some(r), Some(g), Some(b)) => [r, g, b],
        _ => {
            return Err(Error::parse(
                source,
                json_key_line(text, "index"),
                format!(
                    "spectral_data.index.main is {names:?}; expected the three channels \"R\", \"G\", \"B\""
                ),
            ))
        }
    };
    let mut rows: Vec<(f64, [f64; 3], &str)> =
        Vec::with_capacity(doc.spectral_data.data.main.len());
    for (key, values) in &doc.spectral_data.data.main {
        let line = json_key_line(text, key);
        let nm = key
            .trim()
            .parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| {
                Error::parse(
                    source,
                    line,
                    format!("spectral_data.data.main key \"{key}\" is not a wavelength; expected a number of nm"),
                )
            })?;
        if values.len() != 3 {
            return Err(Error::parse(
                source,
                line,
                format!(
                    "{} values at {key} nm; expected 3 (one per channel of spectral_data.index.main)",
                    values.len()
                ),
            ));
        }
        let v = order.map(|i| values[i]);
        if let Some(c) = v.iter().position(|x| *x < 0.0) {
            return Err(Error::parse(
                source,
                line,
                format!(
                    "{} sensitivity {} at {key} nm is negative; expected values ≥ 0",
                    ["R", "G", "B"][c],
                    v[c]
                ),
            ));
        }
        rows.push((nm, v, key));
    }
    rows.sort_by(|a, b| a.0.total_cmp(&b.0));
    if let Some(w) = rows.windows(2).find(|w| w[0].0 == w[1].0) {
        return Err(Error::parse(
            source,
            json_key_line(text, w[1].2),
            format!(
                "wavelength {} nm is given twice in spectral_data.data.main (keys \"{}\" and \"{}\"); expected each once",
                w[0].0, w[0].2, w[1].2
            ),
        ));
    }
    MultiSpectrum::new(
        source,
        rows.iter().map(|r| r.0).collect(),
        vec!["r".into(), "g".into(), "b".into()],
        (0..3)
            .map(|c| rows.iter().map(|r| r.1[c]).collect())
            .collect(),
    )
}

/// `FILE.csv:NAME` with an existing FILE.csv: one camera of a database table.
/// The file `--camera` names: the path itself when it is a file, else the database of
/// `DATABASE:NAME` when that is a file, else the path as given (for the output-path check, which
/// must list every file a run reads).
pub fn camera_file(p: &Path) -> std::path::PathBuf {
    if p.is_file() {
        return p.to_path_buf();
    }
    database_entry(p).map_or_else(|| p.to_path_buf(), |(file, _)| file)
}

fn database_entry(p: &Path) -> Option<(std::path::PathBuf, String)> {
    let s = p.to_str()?;
    let (file, name) = s.rsplit_once(':')?;
    let file = Path::new(file);
    (file.is_file() && !name.trim().is_empty())
        .then(|| (file.to_path_buf(), name.trim().to_string()))
}

/// One camera of a database table in long format `camera,wavelength_nm,r,g,b` (the Jiang et al.
/// 2013 database as exported in `../shared/data/camera/`): the rows whose first field equals
/// `name` (case-insensitive), through the same checks as [`parse_camera`]. `--camera
/// FILE.csv:NAME` reads it. The database as Jiang et al. distribute it (`camspec_database.txt`:
/// a name line, then the R, G and B rows of 33 values, 400–720 nm in 10 nm steps) is read too.
///
/// # Errors
/// [`Error::Parse`] naming the source and line for a bad header or number, or when no row is
/// named `name` (the message lists the names there are).
pub fn parse_camera_database(bytes: &[u8], source: &str, name: &str) -> Result<MultiSpectrum> {
    let text = crate::table::as_text(
        bytes,
        source,
        "a camera database camera,wavelength_nm,r,g,b",
    )?;
    let first = text
        .lines()
        .map(str::trim)
        .find(|t| !t.is_empty() && !t.starts_with('#'));
    if first.is_some_and(|t| !t.to_ascii_lowercase().starts_with("camera")) && jiang_text(text) {
        return parse_jiang_database(text, source, name);
    }
    let mut header_seen = false;
    let mut names: Vec<String> = Vec::new();
    let mut csv = String::from("wavelength_nm,r,g,b\n");
    let mut n = 0;
    for (i, line) in text.lines().enumerate() {
        let t = line.trim();
        if t.is_empty() || t.starts_with('#') {
            continue;
        }
        let fields: Vec<&str> = t.split(',').map(str::trim).collect();
        if !header_seen {
            let ok = fields.len() == 5 && fields[0].eq_ignore_ascii_case("camera");
            if !ok {
                return Err(Error::parse(
                    source,
                    i + 1,
                    format!("header '{t}'; expected camera,wavelength_nm,r,g,b"),
                ));
            }
            header_seen = true;
            continue;
        }
        if fields.len() != 5 {
            return Err(Error::parse(
                source,
                i + 1,
                format!(
                    "{} fields; expected camera,wavelength_nm,r,g,b",
                    fields.len()
                ),
            ));
        }
        if !names.iter().any(|n| n == fields[0]) {
            names.push(fields[0].to_string());
        }
        if fields[0].eq_ignore_ascii_case(name) {
            for f in &fields[1..] {
                if f.parse::<f64>().map_or(true, |v| !v.is_finite()) {
                    return Err(Error::parse(
                        source,
                        i + 1,
                        format!("'{f}' is not a finite number"),
                    ));
                }
            }
            csv.push_str(&fields[1..].join(","));
            csv.push('\n');
            n += 1;
        }
    }
    if n == 0 {
        return Err(Error::parse(
            source,
            0,
            format!(
                "no camera named '{name}'; the table holds: {}",
                names.join(", ")
            ),
        ));
    }
    parse_camera(csv.as_bytes(), &format!("{source}:{name}"))
}

/// Every camera of a database table (the formats of [`parse_camera_database`]), in the table's
/// order, each named `FILE:NAME` as `--camera FILE:NAME` would name it.
///
/// # Errors
/// [`Error::Io`] naming the file when it cannot be read; [`Error::Parse`] when the table holds no
/// camera; those of [`parse_camera_database`] for any camera in it.
pub fn read_camera_database(path: &Path) -> Result<Vec<(String, Camera)>> {
    let (bytes, source) = super::read_input(path)?;
    let text = crate::table::as_text(
        &bytes,
        &source,
        "a camera database camera,wavelength_nm,r,g,b",
    )?;
    let rows: Vec<&str> = text
        .lines()
        .map(str::trim)
        .filter(|t| !t.is_empty() && !t.starts_with('#'))
        .collect();
    let long = rows
        .first()
        .is_some_and(|t| t.to_ascii_lowercase().starts_with("camera"))
        || !jiang_text(text);
    let mut names: Vec<String> = Vec::new();
    if long {
        for t in rows.iter().skip(1) {
            let name = t.split(',').next().unwrap_or("").trim();
            if !name.is_empty() && !names.iter().any(|n| n == name) {
                names.push(name.to_string());
            }
        }
    } else {
        for w in rows.windows(2) {
            if numeric_row(w[0]).is_none() && numeric_row(w[1]).is_some() {
                names.push(w[0].to_string());
            }
        }
    }
    if names.is_empty() {
        return Err(Error::parse(
            &source,
            0,
            "no camera; expected a database camera,wavelength_nm,r,g,b (or Jiang et al.'s text database)",
        ));
    }
    names
        .into_iter()
        .map(|name| {
            let curves = parse_camera_database(&bytes, &source, &name)?;
            let source = format!("{source}:{name}");
            Ok((name, Camera { curves, source }))
        })
        .collect()
}

/// Jiang et al.'s database as distributed (`camspec_database.txt`): blocks of a camera name
/// line and three lines (R, G, B) of whitespace-separated sensitivities, possibly after a few
/// lines of preamble. Told apart from the long CSV by a name line followed by a numeric line.
fn jiang_text(text: &str) -> bool {
    let lines: Vec<&str> = text
        .lines()
        .map(str::trim)
        .filter(|t| !t.is_empty())
        .collect();
    lines
        .windows(2)
        .any(|w| numeric_row(w[0]).is_none() && numeric_row(w[1]).is_some_and(|r| r.len() > 3))
}

/// The line's whitespace-separated fields as finite numbers, or None.
fn numeric_row(t: &str) -> Option<Vec<f64>> {
    let v: Option<Vec<f64>> = t
        .split_whitespace()
        .map(|f| f.parse::<f64>().ok().filter(|x| x.is_finite()))
        .collect();
    v.filter(|v| !v.is_empty())
}

/// The wavelength grid of a Jiang text database: from a preamble line `400nm-720nm, step 10nm`
/// when there is one, else the database's published 400–720 nm in 10 nm steps.
fn jiang_grid(text: &str) -> (f64, f64, f64) {
    for t in text.lines().take(20) {
        let t = t.trim().to_ascii_lowercase().replace(' ', "");
        if let Some((range, step)) = t.split_once(",step") {
            let num = |s: &str| s.trim_end_matches("nm").parse::<f64>().ok();
            if let (Some((a, b)), Some(st)) = (range.split_once('-'), num(step)) {
                if let (Some(a), Some(b)) = (num(a), num(b)) {
                    if b > a && st > 0.0 {
                        return (a, b, st);
                    }
                }
            }
        }
    }
    (400.0, 720.0, 10.0)
}

/// One camera of Jiang et al.'s text database ([`jiang_text`]): the block whose name line
/// equals `name` (case-insensitive), its three rows on the grid of [`jiang_grid`], through the
/// same checks as [`parse_camera`].
///
/// # Errors
/// [`Error::Parse`] naming the source and line when a block's row is not numeric or has another
/// count than the grid, or when no block is named `name` (the message lists the names there are).
fn parse_jiang_database(text: &str, source: &str, name: &str) -> Result<MultiSpectrum> {
    let (lo, hi, step) = jiang_grid(text);
    let count = ((hi - lo) / step).round() as usize + 1;
    let lines: Vec<(usize, &str)> = text
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim()))
        .filter(|(_, t)| !t.is_empty())
        .collect();
    let mut names = Vec::new();
    let mut found: Option<[Vec<f64>; 3]> = None;
    let mut i = 0;
    while i < lines.len() {
        let (_, t) = lines[i];
        let starts_block = numeric_row(t).is_none()
            && lines
                .get(i + 1)
                .is_some_and(|(_, n)| numeric_row(n).is_some());
        if !starts_block {
            i += 1;
            continue;
        }
        names.push(t.to_string());
        let mut rows: [Vec<f64>; 3] = Default::default();
        for (c, row) in rows.iter_mut().enumerate() {
            let Some(&(ln, r)) = lines.get(i + 1 + c) else {
                return Err(Error::parse(
                    source,
                    lines[i].0,
                    format!("camera '{t}': {} rows; expected three (R, G, B)", c),
                ));
            };
            let Some(v) = numeric_row(r) else {
                return Err(Error::parse(
                    source,
                    ln,
                    format!("camera '{t}', channel {}: not a row of numbers; expected {count} sensitivities ({lo}–{hi} nm, step {step})", ["R", "G", "B"][c]),
                ));
            };
            if v.len() != count {
                return Err(Error::parse(
                    source,
                    ln,
                    format!(
                        "camera '{t}', channel {}: {} values; expected {count} ({lo}–{hi} nm, step {step})",
                        ["R", "G", "B"][c],
                        v.len()
                    ),
                ));
            }
            *row = v;
        }
        if found.is_none() && t.eq_ignore_ascii_case(name) {
            found = Some(rows);
        }
        i += 4;
    }
    let Some(rows) = found else {
        return Err(Error::parse(
            source,
            0,
            format!(
                "no camera named '{name}'; the database holds: {}",
                names.join(", ")
            ),
        ));
    };
    let mut csv = String::from("wavelength_nm,r,g,b\n");
    let [r, g, b] = &rows;
    for (k, ((r, g), b)) in r.iter().zip(g).zip(b).enumerate() {
        csv.push_str(&format!("{},{r},{g},{b}\n", lo + step * k as f64));
    }
    parse_camera(csv.as_bytes(), &format!("{source}:{name}"))
}

impl Camera {
    /// The three channels sampled linearly on `grid_nm`, which must lie inside the table's range.
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] naming the camera's range and the grid's when the grid reaches
    /// beyond the table.
    pub fn on_grid(&self, grid_nm: &[f64]) -> Result<[Vec<f64>; 3]> {
        let wl = self.curves.wavelengths();
        let (lo, hi) = (wl[0], wl[wl.len() - 1]);
        let (g0, g1) = match (grid_nm.first(), grid_nm.last()) {
            (Some(a), Some(b)) => (*a, *b),
            _ => return Err(Error::invalid("--grid", "empty wavelength grid")),
        };
        if g0 < lo - 1e-9 || g1 > hi + 1e-9 {
            return Err(Error::invalid(
                "--camera",
                format!(
                    "{}: covers {lo}–{hi} nm; the grid needs {g0}–{g1} nm (pass --grid inside the camera's range)",
                    self.source
                ),
            ));
        }
        let channel = |c: usize| -> Result<Vec<f64>> {
            let sd = Spectrum::new("camera", wl.to_vec(), self.curves.channel(c).to_vec())?;
            sd.values_at(grid_nm, Interpolator::Linear)
        };
        Ok([channel(0)?, channel(1)?, channel(2)?])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `--camera-database`: every camera of a long CSV or of Jiang et al.'s text, in the file's
    /// order; a table without a camera is refused naming the file.
    #[test]
    fn a_whole_database_is_read_in_its_order_in_either_format() {
        let dir = tempfile::tempdir().unwrap();
        let long = dir.path().join("db.csv");
        std::fs::write(
            &long,
            "camera,wavelength_nm,r,g,b\n# comment\nCam B,400,0.1,0.2,0.3\nCam B,460,0.3,0.2,0.1\nCam A,400,0.2,0.2,0.2\nCam A,460,0.1,0.1,0.1\n",
        )
        .unwrap();
        let cams = read_camera_database(&long).unwrap();
        let names: Vec<&str> = cams.iter().map(|(n, _)| n.as_str()).collect();
        assert_eq!(names, ["Cam B", "Cam A"]);
        assert_eq!(cams[1].1.curves.channel(0), &[0.2, 0.1]);
        assert!(
            cams[0].1.source.ends_with("db.csv:Cam B"),
            "{}",
            cams[0].1.source
        );
        let txt = dir.path().join("db.txt");
        std::fs::write(
            &txt,
            "400nm-440nm, step 10nm\n\nCam C\n0.1 0.2 0.3 0.4 0.5\n0.2 0.3 0.4 0.5 0.6\n0.3 0.4 0.5 0.6 0.7\nCam D\n1 2 3 4 5\n2 3 4 5 6\n3 4 5 6 7\n",
        )
        .unwrap();
        let cams = read_camera_database(&txt).unwrap();
        let names: Vec<&str> = cams.iter().map(|(n, _)| n.as_str()).collect();
        assert_eq!(names, ["Cam C", "Cam D"]);
        assert_eq!(cams[1].1.curves.channel(2), &[3.0, 4.0, 5.0, 6.0, 7.0]);
        let empty = dir.path().join("empty.csv");
        std::fs::write(&empty, "camera,wavelength_nm,r,g,b\n").unwrap();
        let e = read_camera_database(&empty).unwrap_err().to_string();
        assert!(e.contains("empty.csv") && e.contains("no camera"), "{e}");
    }

    /// Jiang et al.'s text database (a preamble, then name + R, G, B rows) reads the named
    /// camera on its stated grid; the long CSV of the same numbers gives the same curves; a short
    /// row and an unknown name are refused naming the line / the names there are.
    #[test]
    fn the_jiang_text_database_reads_like_its_long_csv() {
        let row = |f: f64| {
            (0..5)
                .map(|k| format!("{}", f * (k + 1) as f64))
                .collect::<Vec<_>>()
                .join("\t")
        };
        let txt = format!(
            "\nhttp://example/db.html\n400nm-440nm, step 10nm\n---------\n\nCam A\n{}\n{}\n{}\n\nCam B\n{}\n{}\n{}\n",
            row(0.1),
            row(0.2),
            row(0.3),
            row(0.01),
            row(0.02),
            row(0.03)
        );
        let b = parse_camera_database(txt.as_bytes(), "db.txt", "cam b").unwrap();
        assert_eq!(b.wavelengths(), &[400.0, 410.0, 420.0, 430.0, 440.0]);
        assert!((b.channel(2)[4] - 0.15).abs() < 1e-15, "{:?}", b.channel(2));
        let mut long = String::from("camera,wavelength_nm,r,g,b\n");
        for k in 0..5 {
            let v = |f: f64| f * (k + 1) as f64;
            long.push_str(&format!(
                "Cam B,{},{},{},{}\n",
                400 + 10 * k,
                v(0.01),
                v(0.02),
                v(0.03)
            ));
        }
        let l = parse_camera_database(long.as_bytes(), "db.csv", "Cam B").unwrap();
        assert_eq!(l.wavelengths(), b.wavelengths());
        for c in 0..3 {
            assert_eq!(l.channel(c), b.channel(c));
        }
        let e = parse_camera_database(txt.as_bytes(), "db.txt", "Cam C")
            .unwrap_err()
            .to_string();
        assert!(e.contains("db.txt") && e.contains("Cam A, Cam B"), "{e}");
        let short = txt.replacen(&row(0.2), "0.1\t0.2\t0.3", 1);
        let e = parse_camera_database(short.as_bytes(), "db.txt", "Cam A")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("db.txt") && e.contains("line 8") && e.contains("3 values; expected 5"),
            "{e}"
        );
    }

    #[test]
    fn the_default_camera_has_three_non_negative_channels() {
        let cam = read_camera(None).unwrap();
        assert_eq!(cam.curves.n_channels(), 3);
        assert_eq!(cam.source, DEFAULT_CAMERA_NAME);
    }

    #[test]
    fn a_negative_sensitivity_is_refused_with_its_line_and_channel() {
        let csv = b"wavelength_nm,r,g,b\n400,0.1,0.2,0.3\n410,0.1,-0.2,0.3\n";
        let e = parse_camera(csv, "cam.csv").unwrap_err().to_string();
        assert!(
            e.contains("cam.csv") && e.contains("line 3") && e.contains("g"),
            "{e}"
        );
    }

    #[test]
    fn a_byte_order_mark_is_accepted_and_two_channels_are_refused() {
        let csv = b"\xEF\xBB\xBFwavelength_nm,r,g,b\n400,0.1,0.2,0.3\n410,0.1,0.2,0.3\n";
        assert_eq!(parse_camera(csv, "bom.csv").unwrap().n_channels(), 3);
        let e = parse_camera(b"wavelength_nm,r,g\n400,1,1\n410,1,1\n", "two.csv")
            .unwrap_err()
            .to_string();
        assert!(e.contains("expected wavelength_nm,r,g,b"), "{e}");
    }

    #[test]
    fn a_grid_beyond_the_camera_is_refused() {
        let cam = read_camera(None).unwrap();
        assert!(cam.on_grid(&[100.0, 200.0]).is_err());
        let g = cam.on_grid(&[450.0, 550.0, 650.0]).unwrap();
        assert_eq!(g[1].len(), 3);
    }

    const ACADEMY: &str = r#"{
  "header": {"manufacturer": "Test", "model": "Cam"},
  "spectral_data": {
    "units": "relative",
    "index": {"main": ["B", "G", "R"]},
    "data": {"main": {
      "400": [0.5, 0.2, 0.1],
      "1000": [0.0, 0.1, 0.9],
      "405.5": [0.6, 0.3, 0.1]
    }}
  }
}"#;

    #[test]
    fn an_academy_json_camera_is_read_in_wavelength_order_with_its_channels_named() {
        let cam = parse_camera_file(ACADEMY.as_bytes(), "cam.json").unwrap();
        assert_eq!(cam.wavelengths(), &[400.0, 405.5, 1000.0]);
        // index B, G, R: the first value of each entry is blue
        assert_eq!(cam.channel(0), &[0.1, 0.1, 0.9]);
        assert_eq!(cam.channel(2), &[0.5, 0.6, 0.0]);
        // the same bytes behind a byte-order mark and white space
        let bom = [b"\xEF\xBB\xBF \n".as_slice(), ACADEMY.as_bytes()].concat();
        assert_eq!(
            parse_camera_file(&bom, "bom.json").unwrap().channel(1),
            cam.channel(1)
        );
    }

    #[test]
    fn a_bad_academy_json_camera_is_refused_naming_the_line_and_what_was_expected() {
        let cases = [
            (
                ACADEMY.replace("[0.6, 0.3, 0.1]", "[0.6, -0.3, 0.1]"),
                "line 9",
                "negative",
            ),
            (
                ACADEMY.replace("[0.6, 0.3, 0.1]", "[0.6, 0.3]"),
                "line 9",
                "expected 3",
            ),
            (
                ACADEMY.replace("\"405.5\"", "\"blue\""),
                "line 9",
                "not a wavelength",
            ),
            (
                ACADEMY.replace("[\"B\", \"G\", \"R\"]", "[\"X\", \"Y\", \"Z\"]"),
                "line 5",
                "\"R\", \"G\", \"B\"",
            ),
            (
                ACADEMY.replace("\"405.5\"", "\"400.0\""),
                "line 9",
                "given twice",
            ),
            (
                ACADEMY.replace("\"data\"", "\"dat\""),
                "cam.json",
                "missing field `data`",
            ),
            (ACADEMY.replace("0.9]", "0.9"), "line 9", "expected f64"),
        ];
        for (text, place, what) in cases {
            let e = parse_camera_file(text.as_bytes(), "cam.json")
                .unwrap_err()
                .to_string();
            assert!(
                e.contains("cam.json") && e.contains(place) && e.contains(what),
                "{e}"
            );
        }
    }
}
