//! The phosphorescence file formats: one type per format, with the reader and the writer on the
//! same type, so that what `lumifit` writes is what it reads back (a round-trip test each).
//!
//! Every CSV goes through [`crate::table::parse_numeric_csv`] (header, `#` comments, UTF-8 BOM,
//! CRLF, duplicate column names refused, NaN/inf refused with file and line) or, for the batch
//! files that carry a text `id` column, through [`crate::table::as_text`] (BOM stripped, binary
//! refused) with the same rules. Every error names the file, the line and what was expected.
//!
//! | format | type | header |
//! |---|---|---|
//! | decay curve | [`CurveCsv`] | `time_s,r,g,b[,std\|weight]` (or one value column) |
//! | batch of curves | [`BatchCsv`] | `id,time_s,r,g,b[,std]` |
//! | batch results | [`BatchResultRow`] | [`BATCH_HEADER`] |
//! | irradiance history (`phos simulate`, `phos design`) | [`HistoryCsv`] | `time_s,<one column per band>` (old `duration_s,…` read with a warning) |
//! | simulation output | [`SimulationCsv`] | `time_s,L_…,r_1…[,r,g,b]` |
//! | charging data | [`ChargingCsv`] | `band,charge_s,r,g,b[,std]` |
//! | source spectra | [`SourceSpectraCsv`] | `wavelength_nm,band1,band2,…` |
//! | design history (RGB) | [`DesignHistoryCsv`] | `time_s,e_r,e_g,e_b` |
//! | keyframe targets | [`KeyframesCsv`] | `time_s,l_r,l_g,l_b` |
//! | charging protocol of a decay series | [`ChargingJson`] | `charging.json`: `{"schema": "lumifit.charging/1", "protocol": …}` |

use std::borrow::Cow;
use std::collections::HashMap;
use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::io::read_input;
use crate::phosphor::design::{IrradianceHistory, Keyframe};
use crate::phosphor::excitation::{band_means_exact, unit_length, ChargingSample};
use crate::phosphor::{BandCamera, BandSet, DecayCharging, DecayCurve, Segment, Simulation};
use crate::spectrum::MultiSpectrum;
use crate::table::{as_text, parse_numeric_csv, NumericTable};

/// Strictly increasing times, positive `std`/`weight` columns; errors name the line.
fn check_rows(
    source: &str,
    lines: &[usize],
    time: &[f64],
    std: Option<&[f64]>,
    weight: Option<&[f64]>,
) -> Result<()> {
    for r in 1..time.len() {
        if time[r] <= time[r - 1] {
            let what = if time[r] == time[r - 1] {
                "duplicated"
            } else {
                "decreasing"
            };
            return Err(Error::parse(
                source,
                lines[r],
                format!(
                    "time {} s after {} s ({what}); times must be strictly increasing",
                    time[r],
                    time[r - 1]
                ),
            ));
        }
    }
    for (name, col) in [("std", std), ("weight", weight)] {
        if let Some(c) = col {
            if let Some(r) = c.iter().position(|v| *v <= 0.0) {
                return Err(Error::parse(
                    source,
                    lines[r],
                    format!("{name} {}; expected > 0", c[r]),
                ));
            }
        }
    }
    Ok(())
}

/// Floors per-sample σ at 1e-9 of the largest |value| (the digits a double-precision curve
/// carries): a noise-free synthetic curve's σ ≈ 1e-154 would otherwise overflow the weights 1/σ².
pub fn floor_sigma(sigma: Vec<f64>, channels: &[Vec<f64>]) -> Vec<f64> {
    let ymax = channels
        .iter()
        .flatten()
        .fold(0.0f64, |m, v| m.max(v.abs()));
    let floor = 1e-9 * ymax;
    sigma.into_iter().map(|v| v.max(floor)).collect()
}

/// Whether a per-sample σ column is given as standard deviations or as weights 1/σ².
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SigmaColumn {
    /// `std`: σ itself.
    Std,
    /// `weight`: 1/σ².
    Weight,
}

/// A decay curve CSV: `time_s`, one or three value columns (`r,g,b`), optional `std` or
/// `weight` (1/σ²). Times strictly increasing, `std`/`weight` > 0.
#[derive(Debug, Clone, PartialEq)]
pub struct CurveCsv {
    /// Times in s after switch-off.
    pub time_s: Vec<f64>,
    /// Value column names, in file order.
    pub names: Vec<String>,
    /// One vector per value column.
    pub channels: Vec<Vec<f64>>,
    /// The `std` or `weight` column as written, with its kind.
    pub sigma: Option<(SigmaColumn, Vec<f64>)>,
}

impl CurveCsv {
    /// Parses a curve CSV; errors name `source` and the line.
    pub fn parse(bytes: &[u8], source: &str) -> Result<Self> {
        let t = parse_numeric_csv(bytes, source)?;
        let Some(ti) = t.column_index("time_s") else {
            return Err(Error::parse(
                source,
                1,
                "no 'time_s' column; expected 'time_s,r,g,b' (optional 'std' or 'weight')",
            ));
        };
        let si = t.column_index("std");
        let wi = t.column_index("weight");
        if si.is_some() && wi.is_some() {
            return Err(Error::parse(
                source,
                1,
                "both 'std' and 'weight' columns; give one",
            ));
        }
        // The region curve of `series extract` (`time_s,r,g,b,r_std,g_std,b_std,n_pixels,
        // n_saturated`): the per-channel pixel spreads and the counts accompany the values.
        let ni = t.column_index("n_pixels");
        let aux = |c: usize| {
            let h = t.header[c].to_ascii_lowercase();
            h.ends_with("_std") || h == "n_pixels" || h == "n_saturated"
        };
        let chans: Vec<usize> = (0..t.header.len())
            .filter(|&c| c != ti && Some(c) != si && Some(c) != wi && !aux(c))
            .collect();
        if chans.len() != 1 && chans.len() != 3 {
            return Err(Error::parse(
                source,
                1,
                format!(
                    "{} value columns; expected 1 or 3 (r,g,b) besides time_s, std/weight and the *_std/n_pixels/n_saturated columns of series extract",
                    chans.len()
                ),
            ));
        }
        check_rows(
            source,
            &t.lines,
            &t.columns[ti],
            si.map(|i| &t.columns[i][..]),
            wi.map(|i| &t.columns[i][..]),
        )?;
        // Per-channel spreads `<channel>_std` of every value channel (and no shared std/weight):
        // the shared σ of a row is the RMS over channels of the standard error of the region
        // mean, std_c / √n_pixels (the fit weights rows, not channels).
        let per_channel: Option<Vec<usize>> = chans
            .iter()
            .map(|&c| t.column_index(&format!("{}_std", t.header[c])))
            .collect();
        let sigma = match (si, wi, per_channel) {
            (Some(i), _, _) => Some((SigmaColumn::Std, t.columns[i].clone())),
            (_, Some(i), _) => Some((SigmaColumn::Weight, t.columns[i].clone())),
            (None, None, Some(pc)) => {
                let rows = t.columns[ti].len();
                let sig: Vec<f64> = (0..rows)
                    .map(|r| {
                        let n = ni.map_or(1.0, |k| t.columns[k][r].max(1.0));
                        let ms: f64 = pc.iter().map(|&k| t.columns[k][r].powi(2)).sum::<f64>()
                            / pc.len() as f64;
                        (ms / n).sqrt()
                    })
                    .collect();
                if let Some(r) = sig.iter().position(|v| !v.is_finite() || *v <= 0.0) {
                    return Err(Error::parse(
                        source,
                        t.lines[r],
                        "the per-channel *_std columns are all 0 in this row; expected a spread > 0 (or give a 'std' column)",
                    ));
                }
                Some((SigmaColumn::Std, sig))
            }
            _ => None,
        };
        Ok(Self {
            time_s: t.columns[ti].clone(),
            names: chans.iter().map(|&c| t.header[c].clone()).collect(),
            channels: chans.iter().map(|&c| t.columns[c].clone()).collect(),
            sigma,
        })
    }

    /// The CSV text (header, one row per sample, values in Rust's shortest round-trip form).
    pub fn to_csv(&self) -> String {
        let mut csv = String::from("time_s");
        for n in &self.names {
            csv.push(',');
            csv.push_str(n);
        }
        match &self.sigma {
            Some((SigmaColumn::Std, _)) => csv.push_str(",std"),
            Some((SigmaColumn::Weight, _)) => csv.push_str(",weight"),
            None => {}
        }
        csv.push('\n');
        for i in 0..self.time_s.len() {
            csv.push_str(&format!("{}", self.time_s[i]));
            for c in &self.channels {
                csv.push_str(&format!(",{}", c[i]));
            }
            if let Some((_, s)) = &self.sigma {
                csv.push_str(&format!(",{}", s[i]));
            }
            csv.push('\n');
        }
        csv
    }

    /// The validated curve: weights become σ = 1/√w and σ is floored ([`floor_sigma`]).
    pub fn into_curve(self, source: &str) -> Result<DecayCurve> {
        let sigma = self.sigma.map(|(kind, v)| match kind {
            SigmaColumn::Std => v,
            SigmaColumn::Weight => v.iter().map(|w| 1.0 / w.sqrt()).collect(),
        });
        let sigma = sigma.map(|s| floor_sigma(s, &self.channels));
        DecayCurve::new(self.time_s, self.channels, sigma).map_err(|e| prefix(source, e))
    }
}

/// An error of a domain constructor, prefixed with the file it came from.
fn prefix(source: &str, e: Error) -> Error {
    match e {
        Error::Parse { .. } | Error::Io { .. } => e,
        other => Error::invalid(source, other.to_string()),
    }
}

/// Reads a curve CSV `time_s,<channels>[,std|weight]` into a validated [`DecayCurve`].
pub fn read_curve(path: &Path) -> Result<DecayCurve> {
    let (bytes, source) = read_input(path)?;
    CurveCsv::parse(&bytes, &source)?.into_curve(&source)
}

/// One curve of a batch file.
#[derive(Debug, Clone, PartialEq)]
pub struct BatchCurve {
    /// The curve's id (first column).
    pub id: String,
    /// Line of its first row.
    pub line: usize,
    /// Times in s.
    pub t_s: Vec<f64>,
    /// R, G, B values.
    pub rgb: [Vec<f64>; 3],
    /// Per-sample σ (when the file has a `std` column).
    pub std: Option<Vec<f64>>,
    /// Line of every row, for messages.
    pub lines: Vec<usize>,
}

impl BatchCurve {
    /// The curve as the decay fit takes it.
    pub fn to_curve(&self) -> Result<DecayCurve> {
        DecayCurve::new(self.t_s.clone(), self.rgb.to_vec(), self.std.clone())
    }
}

/// A batch CSV `id,time_s,r,g,b[,std]`: many curves, rows grouped by id (in order of first
/// appearance). Times strictly increasing within each curve.
#[derive(Debug, Clone, PartialEq)]
pub struct BatchCsv {
    /// The curves.
    pub curves: Vec<BatchCurve>,
}

/// Splits one CSV line into trimmed fields, honouring double quotes (`"a,b"`, `""`).
fn split_fields(line: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut cur = String::new();
    let mut quoted = false;
    let mut chars = line.chars().peekable();
    while let Some(c) = chars.next() {
        match c {
            '"' if quoted && chars.peek() == Some(&'"') => {
                cur.push('"');
                chars.next();
            }
            '"' => quoted = !quoted,
            ',' if !quoted => out.push(std::mem::take(&mut cur).trim().to_string()),
            c => cur.push(c),
        }
    }
    out.push(cur.trim().to_string());
    out
}

/// [`split_fields`] into a reused buffer: a line without a quote (almost every data row) is
/// split in place, without copying a field.
fn split_fields_into<'a>(line: &'a str, out: &mut Vec<Cow<'a, str>>) {
    out.clear();
    let bytes = line.as_bytes();
    if bytes.contains(&b'"') {
        out.extend(split_fields(line).into_iter().map(Cow::Owned));
        return;
    }
    // ',' is ASCII, so every cut is at a character boundary
    let mut start = 0;
    for (i, c) in bytes.iter().enumerate() {
        if *c == b',' {
            out.push(Cow::Borrowed(line[start..i].trim()));
            start = i + 1;
        }
    }
    out.push(Cow::Borrowed(line[start..].trim()));
}

/// A CSV field: quoted when it holds a comma or a quote.
fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

impl BatchCsv {
    /// Parses a batch file; errors name `source` and the line.
    pub fn parse(bytes: &[u8], source: &str) -> Result<Self> {
        let text = as_text(bytes, source, "CSV 'id,time_s,r,g,b'")?;
        let mut header: Option<Vec<String>> = None;
        let mut curves: Vec<BatchCurve> = Vec::new();
        let mut index: HashMap<String, usize> = HashMap::new();
        let mut has_std = false;
        let mut f: Vec<Cow<str>> = Vec::new();
        // rows come grouped by id: the previous row's curve is looked up first
        let mut last: Option<usize> = None;
        for (i, raw) in text.lines().enumerate() {
            let line = i + 1;
            let l = raw.trim();
            if l.is_empty() || l.starts_with('#') {
                continue;
            }
            split_fields_into(l, &mut f);
            let Some(h) = &header else {
                let h: Vec<String> = f.iter().map(|s| s.to_ascii_lowercase()).collect();
                let base = ["id", "time_s", "r", "g", "b"];
                if let Some((k, name)) = h
                    .iter()
                    .enumerate()
                    .find(|(k, n)| h[..*k].contains(n))
                    .map(|(k, n)| (k, n.clone()))
                {
                    return Err(Error::parse(
                        source,
                        line,
                        format!(
                            "column '{name}' appears twice (column {}); expected 'id,time_s,r,g,b' with an optional ',std'",
                            k + 1
                        ),
                    ));
                }
                if h.len() < 5 || h[..5] != base || (h.len() == 6 && h[5] != "std") || h.len() > 6 {
                    return Err(Error::parse(
                        source,
                        line,
                        format!("header '{l}'; expected 'id,time_s,r,g,b' with an optional ',std'"),
                    ));
                }
                has_std = h.len() == 6;
                header = Some(h);
                continue;
            };
            if f.len() != h.len() {
                return Err(Error::parse(
                    source,
                    line,
                    format!("{} fields; expected {}", f.len(), h.len()),
                ));
            }
            let mut v = [0.0; 5];
            for k in 1..h.len() {
                v[k - 1] = f[k]
                    .parse::<f64>()
                    .ok()
                    .filter(|x| x.is_finite())
                    .ok_or_else(|| {
                        Error::parse(
                            source,
                            line,
                            format!("'{}' in column '{}' is not a finite number", f[k], h[k]),
                        )
                    })?;
            }
            let idx = match last.filter(|k| curves[*k].id == f[0]) {
                Some(k) => k,
                None => match index.get(&*f[0]) {
                    Some(k) => *k,
                    None => {
                        // room for as many rows as the curve before (batches are regular)
                        let cap = curves.last().map_or(0, |c| c.t_s.len());
                        let col = || Vec::with_capacity(cap);
                        curves.push(BatchCurve {
                            id: f[0].to_string(),
                            line,
                            t_s: col(),
                            rgb: [col(), col(), col()],
                            std: has_std.then(col),
                            lines: Vec::with_capacity(cap),
                        });
                        index.insert(f[0].to_string(), curves.len() - 1);
                        curves.len() - 1
                    }
                },
            };
            last = Some(idx);
            let c = &mut curves[idx];
            c.t_s.push(v[0]);
            for k in 0..3 {
                c.rgb[k].push(v[k + 1]);
            }
            if let Some(s) = &mut c.std {
                s.push(v[4]);
            }
            c.lines.push(line);
        }
        if header.is_none() {
            return Err(Error::parse(
                source,
                0,
                "file is empty; expected header 'id,time_s,r,g,b' and data rows",
            ));
        }
        if curves.is_empty() {
            return Err(Error::parse(
                source,
                0,
                "no data rows; expected rows 'id,time_s,r,g,b' after the header",
            ));
        }
        for c in &curves {
            check_rows(source, &c.lines, &c.t_s, c.std.as_deref(), None).map_err(|e| {
                Error::invalid(
                    format!("curve '{}' (first row at line {})", c.id, c.line),
                    e.to_string(),
                )
            })?;
        }
        Ok(Self { curves })
    }

    /// Reads a batch file.
    pub fn read(path: &Path) -> Result<Self> {
        let (bytes, source) = read_input(path)?;
        Self::parse(&bytes, &source)
    }

    /// The CSV text (curves one after another).
    pub fn to_csv(&self) -> String {
        let has_std = self.curves.iter().any(|c| c.std.is_some());
        let mut csv = String::from(if has_std {
            "id,time_s,r,g,b,std\n"
        } else {
            "id,time_s,r,g,b\n"
        });
        for c in &self.curves {
            for i in 0..c.t_s.len() {
                csv.push_str(&format!(
                    "{},{},{},{},{}",
                    csv_field(&c.id),
                    c.t_s[i],
                    c.rgb[0][i],
                    c.rgb[1][i],
                    c.rgb[2][i]
                ));
                if has_std {
                    let s = c.std.as_ref().map_or(1.0, |s| s[i]);
                    csv.push_str(&format!(",{s}"));
                }
                csv.push('\n');
            }
        }
        csv
    }
}

/// Header of the batch output (a contract).
pub const BATCH_HEADER: &str =
    "id,n_states,k1_per_s,k2_per_s,k3_per_s,a1,a2,a3,spectrum_r,spectrum_g,spectrum_b,rms,flags";

/// One row of the batch output: a fitted curve, or an empty row whose `flags` hold
/// `error: …`. Field names are the columns of [`BATCH_HEADER`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BatchResultRow {
    /// The curve's id.
    pub id: String,
    /// Number of fitted states.
    pub n_states: Option<usize>,
    /// Fastest rate, s⁻¹.
    pub k1_per_s: Option<f64>,
    /// Second rate, s⁻¹.
    pub k2_per_s: Option<f64>,
    /// Third rate, s⁻¹.
    pub k3_per_s: Option<f64>,
    /// Amplitude of state 1.
    pub a1: Option<f64>,
    /// Amplitude of state 2.
    pub a2: Option<f64>,
    /// Amplitude of state 3.
    pub a3: Option<f64>,
    /// Shared spectrum, red.
    pub spectrum_r: Option<f64>,
    /// Shared spectrum, green.
    pub spectrum_g: Option<f64>,
    /// Shared spectrum, blue.
    pub spectrum_b: Option<f64>,
    /// Root-mean-square residual.
    pub rms: Option<f64>,
    /// Fit flags joined by `;`, or `error: …` for a curve that could not be fitted.
    pub flags: String,
}

impl BatchResultRow {
    /// Whether the row records a failed curve.
    pub fn is_error(&self) -> bool {
        self.flags.starts_with("error:")
    }

    /// A failed curve: empty values, `flags` = `error: <message>`.
    pub fn failed(id: &str, message: &str) -> Self {
        Self {
            id: id.to_string(),
            n_states: None,
            k1_per_s: None,
            k2_per_s: None,
            k3_per_s: None,
            a1: None,
            a2: None,
            a3: None,
            spectrum_r: None,
            spectrum_g: None,
            spectrum_b: None,
            rms: None,
            flags: format!("error: {}", message.replace('"', "'")),
        }
    }

    /// The row as one CSV line (no newline), numbers in Rust's shortest round-trip form.
    pub fn to_csv_line(&self) -> String {
        let o = |v: Option<f64>| v.map_or(String::new(), |x| format!("{x}"));
        let flags = if self.is_error() {
            format!("\"{}\"", self.flags)
        } else {
            csv_field(&self.flags)
        };
        [
            csv_field(&self.id),
            self.n_states.map_or(String::new(), |n| n.to_string()),
            o(self.k1_per_s),
            o(self.k2_per_s),
            o(self.k3_per_s),
            o(self.a1),
            o(self.a2),
            o(self.a3),
            o(self.spectrum_r),
            o(self.spectrum_g),
            o(self.spectrum_b),
            o(self.rms),
            flags,
        ]
        .join(",")
    }

    /// The whole output file: [`BATCH_HEADER`] and one line per row.
    pub fn to_csv(rows: &[Self]) -> String {
        let mut text = String::from(BATCH_HEADER);
        text.push('\n');
        for r in rows {
            text.push_str(&r.to_csv_line());
            text.push('\n');
        }
        text
    }

    /// Reads a batch output back (BOM and `#` comments allowed); errors name `source` and line.
    pub fn parse(bytes: &[u8], source: &str) -> Result<Vec<Self>> {
        let text = as_text(bytes, source, &format!("CSV '{BATCH_HEADER}'"))?;
        let mut rdr = csv::ReaderBuilder::new()
            .comment(Some(b'#'))
            .trim(csv::Trim::All)
            .from_reader(text.as_bytes());
        let header = rdr
            .headers()
            .map_err(|e| Error::parse(source, 1, e.to_string()))?
            .iter()
            .collect::<Vec<_>>()
            .join(",");
        if header != BATCH_HEADER {
            return Err(Error::parse(
                source,
                1,
                format!("header '{header}'; expected '{BATCH_HEADER}'"),
            ));
        }
        rdr.deserialize()
            .map(|r| {
                r.map_err(|e| {
                    let line = e.position().map_or(0, |p| p.line() as usize);
                    Error::parse(source, line, format!("expected a batch result row: {e}"))
                })
            })
            .collect()
    }
}

/// The layout a history CSV was written in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum HistoryLayout {
    /// `time_s,<bands>`: the documented layout (breakpoints; see [`HistoryCsv`]).
    Times,
    /// `duration_s,<bands>`: the old layout of `phos simulate` (one row per segment), accepted
    /// for one release with a deprecation warning.
    Durations,
}

/// An irradiance history (`docs/conventions.md`, "irradiance histories"): `time_s` then one
/// column per band (`e_r,e_g,e_b` for RGB). Row k's irradiance holds from its time to the next
/// row's time; the last row's time ends the history (`phos simulate` stops there) and its
/// irradiance holds after it (`phos design` evaluates later keyframes under it). Times strictly
/// increasing, irradiance ≥ 0.
///
/// The old `duration_s,<bands>` layout (one row per segment of that duration, the history
/// starting at 0 s) is read with the same meaning: rows start at the running sum of the
/// durations and a last row at the total time, dark, ends the history.
#[derive(Debug, Clone, PartialEq)]
pub struct HistoryCsv {
    /// Band column names (as written; `e_r,e_g,e_b` in any order are put in that order).
    pub names: Vec<String>,
    /// Row start times in s.
    pub t_s: Vec<f64>,
    /// Irradiance per row, one value per band.
    pub irradiance: Vec<Vec<f64>>,
    /// The layout the file was written in.
    pub layout: HistoryLayout,
    /// Line of every row in the file (for a `duration_s` file: the last row has the line of
    /// the last segment).
    pub lines: Vec<usize>,
}

/// The RGB band columns of a history.
pub const HISTORY_COLUMNS: [&str; 3] = ["e_r", "e_g", "e_b"];

impl HistoryCsv {
    /// Parses a history for a material of `n_bands` bands; errors name `source`, the line and,
    /// for a header, the column.
    pub fn parse(bytes: &[u8], source: &str, n_bands: usize) -> Result<Self> {
        let t = parse_numeric_csv(bytes, source)?;
        let ti = t.column_index("time_s");
        let di = t.column_index("duration_s");
        let layout = match (ti, di) {
            (Some(a), Some(b)) => {
                return Err(Error::parse(
                    source,
                    1,
                    format!(
                        "both 'time_s' (column {}) and 'duration_s' (column {}); a history gives \
                         either row start times 'time_s' (the documented layout) or segment \
                         durations 'duration_s' (deprecated), not both",
                        a + 1,
                        b + 1
                    ),
                ))
            }
            (Some(0), None) => HistoryLayout::Times,
            (None, Some(0)) => HistoryLayout::Durations,
            (Some(c), None) | (None, Some(c)) => {
                return Err(Error::parse(
                    source,
                    1,
                    format!(
                        "'{}' in column {}; expected it in column 1, then one irradiance column \
                         per band",
                        t.header[c],
                        c + 1
                    ),
                ))
            }
            (None, None) => {
                return Err(Error::parse(
                    source,
                    1,
                    format!(
                        "column 1 is '{}'; expected a history 'time_s' then one irradiance \
                         column per band (e.g. 'time_s,e_r,e_g,e_b')",
                        t.header.first().map_or("", |s| s.as_str())
                    ),
                ))
            }
        };
        if t.header.len() != n_bands + 1 {
            return Err(Error::parse(
                source,
                1,
                format!(
                    "{} irradiance columns; expected one column per band ({n_bands} bands: the \
                     material's for phos simulate, e_r,e_g,e_b for phos design)",
                    t.header.len() - 1
                ),
            ));
        }
        if t.n_rows() == 0 {
            return Err(Error::parse(
                source,
                0,
                "no rows; expected at least one data row",
            ));
        }
        // RGB columns by name when all three are there, in any order; otherwise in file order.
        let mut cols: Vec<usize> = (1..=n_bands).collect();
        if n_bands == 3 {
            let by_name: Option<Vec<usize>> =
                HISTORY_COLUMNS.iter().map(|c| t.column_index(c)).collect();
            if let Some(b) = by_name {
                cols = b;
            }
        }
        let mut irradiance = Vec::with_capacity(t.n_rows() + 1);
        for r in 0..t.n_rows() {
            let e: Vec<f64> = cols.iter().map(|&c| t.columns[c][r]).collect();
            if let Some(k) = e.iter().position(|v| *v < 0.0) {
                return Err(Error::parse(
                    source,
                    t.lines[r],
                    format!(
                        "irradiance {} in column '{}'; expected values ≥ 0",
                        e[k], t.header[cols[k]]
                    ),
                ));
            }
            irradiance.push(e);
        }
        let first = &t.header[0];
        let mut lines = t.lines.clone();
        let t_s = match layout {
            HistoryLayout::Times => {
                let ts = t.columns[0].clone();
                for r in 1..ts.len() {
                    if ts[r] <= ts[r - 1] {
                        let what = if ts[r] == ts[r - 1] {
                            "duplicated"
                        } else {
                            "decreasing"
                        };
                        return Err(Error::parse(
                            source,
                            t.lines[r],
                            format!(
                                "{first} {} s after {} s ({what}); expected strictly increasing \
                                 row start times",
                                ts[r],
                                ts[r - 1]
                            ),
                        ));
                    }
                }
                ts
            }
            HistoryLayout::Durations => {
                let mut ts = Vec::with_capacity(t.n_rows() + 1);
                let mut now = 0.0;
                for r in 0..t.n_rows() {
                    let d = t.columns[0][r];
                    if d <= 0.0 {
                        return Err(Error::parse(
                            source,
                            t.lines[r],
                            format!("{first} {d} s; expected a duration > 0"),
                        ));
                    }
                    ts.push(now);
                    now += d;
                }
                ts.push(now);
                irradiance.push(vec![0.0; n_bands]);
                lines.push(*t.lines.last().unwrap_or(&0));
                ts
            }
        };
        Ok(Self {
            names: cols.iter().map(|&c| t.header[c].clone()).collect(),
            t_s,
            irradiance,
            layout,
            lines,
        })
    }

    /// The history of `segments` from 0 s (a last, dark row at the total time ends it).
    pub fn from_segments(names: Vec<String>, segments: &[Segment]) -> Self {
        let mut t_s = Vec::with_capacity(segments.len() + 1);
        let mut irradiance = Vec::with_capacity(segments.len() + 1);
        let mut now = 0.0;
        for s in segments {
            t_s.push(now);
            irradiance.push(s.irradiance.clone());
            now += s.duration_s;
        }
        t_s.push(now);
        irradiance.push(vec![0.0; names.len()]);
        let lines = (2..2 + t_s.len()).collect();
        Self {
            names,
            t_s,
            irradiance,
            layout: HistoryLayout::Times,
            lines,
        }
    }

    /// The segments `phos simulate` integrates, from 0 s to the last row's time: a history that
    /// starts after 0 s is preceded by a dark segment (exact: the material starts dark).
    ///
    /// # Errors
    /// [`Error::Parse`] naming `source` and the line for a history of one row (no end time) or
    /// one that starts before 0 s.
    pub fn to_segments(&self, source: &str) -> Result<Vec<Segment>> {
        let n = self.t_s.len();
        if n < 2 {
            return Err(Error::parse(
                source,
                self.lines.first().copied().unwrap_or(0),
                "one row, so the history has no end; expected a last row at the time the \
                 history ends (e.g. 'time_s,…' rows '0,1,…' and '60,0,…' for 60 s of light)",
            ));
        }
        if self.t_s[0] < 0.0 {
            return Err(Error::parse(
                source,
                self.lines[0],
                format!(
                    "time_s {} s; expected a history that starts at 0 s or later (the \
                     simulation starts dark at 0 s)",
                    self.t_s[0]
                ),
            ));
        }
        let mut segs = Vec::with_capacity(n);
        if self.t_s[0] > 0.0 {
            segs.push(Segment {
                duration_s: self.t_s[0],
                irradiance: vec![0.0; self.names.len()],
            });
        }
        for k in 0..n - 1 {
            segs.push(Segment {
                duration_s: self.t_s[k + 1] - self.t_s[k],
                irradiance: self.irradiance[k].clone(),
            });
        }
        Ok(segs)
    }

    /// The RGB history `phos design` takes.
    ///
    /// # Errors
    /// [`Error::ShapeMismatch`] when the history does not have three bands.
    pub fn to_rgb(&self) -> Result<IrradianceHistory> {
        if self.names.len() != 3 {
            return Err(Error::ShapeMismatch {
                what: "history bands (e_r,e_g,e_b)".into(),
                expected: 3,
                got: self.names.len(),
            });
        }
        Ok(IrradianceHistory {
            t_s: self.t_s.clone(),
            e: self.irradiance.iter().map(|e| [e[0], e[1], e[2]]).collect(),
        })
    }

    /// The deprecation warning of a file in the old layout (`None` for the documented one).
    pub fn deprecation(&self, source: &str) -> Option<String> {
        (self.layout == HistoryLayout::Durations).then(|| {
            format!(
                "{source}: the 'duration_s' history layout is deprecated and will be removed in \
                 the next release; write 'time_s,{}' with each row's start time and a last row \
                 at the end time (read here as times {:?} s; docs/conventions.md)",
                self.names.join(","),
                self.t_s
            )
        })
    }

    /// Reads a history file for a material of `n_bands` bands, with its deprecation warning.
    pub fn read(path: &Path, n_bands: usize) -> Result<(Self, String)> {
        let (bytes, source) = read_input(path)?;
        Ok((Self::parse(&bytes, &source, n_bands)?, source))
    }

    /// The CSV text in the documented layout `time_s,<bands>`.
    pub fn to_csv(&self) -> String {
        let mut csv = String::from("time_s");
        for n in &self.names {
            csv.push(',');
            csv.push_str(n);
        }
        csv.push('\n');
        for (t, e) in self.t_s.iter().zip(&self.irradiance) {
            csv.push_str(&format!("{t}"));
            for v in e {
                csv.push_str(&format!(",{v}"));
            }
            csv.push('\n');
        }
        csv
    }
}

/// The output of `phos simulate`: `time_s`, the emission per band (`L_r,L_g,L_b` or
/// `L_<lo>_<hi>nm`), the excited fraction per state (`r_1…`) and, with a camera, `r,g,b`.
#[derive(Debug, Clone, PartialEq)]
pub struct SimulationCsv {
    /// Column names after `time_s`.
    pub header: Vec<String>,
    /// Sample times in s.
    pub t_s: Vec<f64>,
    /// One row of values per time, in header order.
    pub rows: Vec<Vec<f64>>,
}

impl SimulationCsv {
    /// The table of a simulation of a material with `bands`, with optional camera RGB.
    pub fn new(bands: &BandSet, sim: &Simulation, rgb: Option<&[[f64; 3]]>) -> Self {
        let mut header: Vec<String> = match bands {
            BandSet::Rgb => vec!["L_r".into(), "L_g".into(), "L_b".into()],
            BandSet::RangesNm(r) => r.iter().map(|[lo, hi]| format!("L_{lo}_{hi}nm")).collect(),
        };
        let n_states = sim.r.first().map_or(0, Vec::len);
        header.extend((0..n_states).map(|i| format!("r_{}", i + 1)));
        if rgb.is_some() {
            header.extend(["r".into(), "g".into(), "b".into()]);
        }
        let rows = (0..sim.t_s.len())
            .map(|k| {
                let mut row = sim.emission[k].clone();
                row.extend(&sim.r[k]);
                if let Some(rgb) = rgb {
                    row.extend(rgb[k]);
                }
                row
            })
            .collect();
        Self {
            header,
            t_s: sim.t_s.clone(),
            rows,
        }
    }

    /// The CSV text.
    pub fn to_csv(&self) -> String {
        let mut csv = String::from("time_s");
        for h in &self.header {
            csv.push(',');
            csv.push_str(h);
        }
        csv.push('\n');
        for (t, row) in self.t_s.iter().zip(&self.rows) {
            csv.push_str(&format!("{t}"));
            for v in row {
                csv.push_str(&format!(",{v}"));
            }
            csv.push('\n');
        }
        csv
    }

    /// Reads the table back (any `time_s,…` numeric table).
    pub fn parse(bytes: &[u8], source: &str) -> Result<Self> {
        let t = parse_numeric_csv(bytes, source)?;
        if t.column_index("time_s") != Some(0) {
            return Err(Error::parse(
                source,
                1,
                "expected the header to start with 'time_s'",
            ));
        }
        Ok(Self {
            header: t.header[1..].to_vec(),
            t_s: t.columns[0].clone(),
            rows: (0..t.n_rows())
                .map(|r| t.columns[1..].iter().map(|c| c[r]).collect())
                .collect(),
        })
    }
}

/// Charging data `band,charge_s,r,g,b[,std]` (band 1-based in the file, 0-based in memory).
#[derive(Debug, Clone, PartialEq)]
pub struct ChargingCsv {
    /// The samples in file order.
    pub samples: Vec<ChargingSample>,
}

impl ChargingCsv {
    /// Parses charging data for a material of `n_bands` bands.
    pub fn parse(bytes: &[u8], source: &str, n_bands: usize) -> Result<Self> {
        let t = parse_numeric_csv(bytes, source)?;
        let col = |name: &str| {
            t.column_index(name).ok_or_else(|| {
                Error::parse(
                    source,
                    1,
                    format!(
                        "no '{name}' column; expected header 'band,charge_s,r,g,b' (optional 'std')"
                    ),
                )
            })
        };
        let (cb, ct, cr, cg, cbl) = (
            col("band")?,
            col("charge_s")?,
            col("r")?,
            col("g")?,
            col("b")?,
        );
        let cs = t.column_index("std");
        let mut samples = Vec::with_capacity(t.n_rows());
        for i in 0..t.n_rows() {
            let line = t.lines[i];
            let b = t.columns[cb][i];
            if b.fract() != 0.0 || b < 1.0 || b > n_bands as f64 {
                return Err(Error::parse(
                    source,
                    line,
                    format!(
                        "band {b}; expected an integer from 1 to {n_bands} (the material's bands)"
                    ),
                ));
            }
            let ts = t.columns[ct][i];
            if ts < 0.0 {
                return Err(Error::parse(
                    source,
                    line,
                    format!("charge_s {ts}; expected a charging time ≥ 0 s"),
                ));
            }
            let sigma = match cs {
                Some(c) => {
                    let s = t.columns[c][i];
                    if s <= 0.0 {
                        return Err(Error::parse(source, line, format!("std {s}; expected > 0")));
                    }
                    Some(s)
                }
                None => None,
            };
            samples.push(ChargingSample {
                band: b as usize - 1,
                charge_s: ts,
                rgb: [t.columns[cr][i], t.columns[cg][i], t.columns[cbl][i]],
                sigma,
            });
        }
        if samples.is_empty() {
            return Err(Error::parse(
                source,
                0,
                "no data rows; expected band,charge_s,r,g,b rows",
            ));
        }
        Ok(Self { samples })
    }

    /// Reads a charging-data file.
    pub fn read(path: &Path, n_bands: usize) -> Result<Vec<ChargingSample>> {
        let (bytes, source) = read_input(path)?;
        Ok(Self::parse(&bytes, &source, n_bands)?.samples)
    }

    /// The CSV text `band,charge_s,r,g,b,std` (a sample without σ is written with std 1).
    pub fn to_csv(&self) -> String {
        let mut csv = String::from("band,charge_s,r,g,b,std\n");
        for s in &self.samples {
            let [r, g, b] = s.rgb;
            csv.push_str(&format!(
                "{},{},{r},{g},{b},{}\n",
                s.band + 1,
                s.charge_s,
                s.sigma.unwrap_or(1.0)
            ));
        }
        csv
    }
}

/// Source spectra of a charging experiment: `wavelength_nm,band1,band2,…`, wavelengths strictly
/// increasing; the column of band j (1-based) is named `band<j>`, `band_<j>` or `<j>`.
#[derive(Debug, Clone, PartialEq)]
pub struct SourceSpectraCsv {
    /// Wavelengths in nm.
    pub wavelength_nm: Vec<f64>,
    /// (band, 0-based; spectrum) per column.
    pub bands: Vec<(usize, Vec<f64>)>,
    /// Where it came from, for messages.
    pub source: String,
    header: Vec<String>,
}

/// Half-width of the ramps of the box sources of [`SourceSpectraCsv::boxes`], in nm.
const BOX_EDGE_NM: f64 = 1e-6;

impl SourceSpectraCsv {
    /// Parses the file (every column named as a band is kept).
    pub fn parse(bytes: &[u8], source: &str) -> Result<Self> {
        let t: NumericTable = parse_numeric_csv(bytes, source)?;
        let Some(wi) = t.column_index("wavelength_nm") else {
            return Err(Error::parse(
                source,
                1,
                "no 'wavelength_nm' column; expected 'wavelength_nm,band1,band2,…'",
            ));
        };
        let wl = &t.columns[wi];
        for r in 1..wl.len() {
            if wl[r] <= wl[r - 1] {
                return Err(Error::parse(
                    source,
                    t.lines[r],
                    format!(
                        "wavelength {} nm after {} nm; expected strictly increasing",
                        wl[r],
                        wl[r - 1]
                    ),
                ));
            }
        }
        let mut bands = Vec::new();
        for (c, h) in t.header.iter().enumerate() {
            let h = h.to_ascii_lowercase();
            let num = h
                .strip_prefix("band_")
                .or_else(|| h.strip_prefix("band"))
                .unwrap_or(&h);
            if let Ok(j) = num.parse::<usize>() {
                if j >= 1 && c != wi {
                    bands.push((j - 1, t.columns[c].clone()));
                }
            }
        }
        Ok(Self {
            wavelength_nm: wl.clone(),
            bands,
            source: source.to_string(),
            header: t.header,
        })
    }

    /// Reads a source-spectra file.
    pub fn read(path: &Path) -> Result<Self> {
        let (bytes, source) = read_input(path)?;
        Self::parse(&bytes, &source)
    }

    /// Box sources with sharp edges (ramps of 1e-6 nm), one per band of the first `n` ranges.
    pub fn boxes(ranges: &[[f64; 2]], n: usize) -> Self {
        let eps = BOX_EDGE_NM;
        let mut grid: Vec<f64> = Vec::new();
        for [lo, hi] in ranges {
            grid.extend([lo - eps, *lo, lo + eps, hi - eps, *hi, hi + eps]);
        }
        grid.sort_by(f64::total_cmp);
        grid.dedup_by(|x, y| (*x - *y).abs() < eps * 0.1);
        let bands = ranges
            .iter()
            .take(n)
            .enumerate()
            .map(|(j, [lo, hi])| {
                let v = grid
                    .iter()
                    .map(|w| {
                        if *w >= lo + eps * 0.5 && *w <= hi - eps * 0.5 {
                            1.0
                        } else {
                            0.0
                        }
                    })
                    .collect();
                (j, v)
            })
            .collect::<Vec<_>>();
        let mut header = vec!["wavelength_nm".to_string()];
        header.extend(bands.iter().map(|(j, _)| format!("band{}", j + 1)));
        Self {
            wavelength_nm: grid,
            bands,
            source: "<box sources>".into(),
            header,
        }
    }

    /// The CSV text `wavelength_nm,band1,…`.
    pub fn to_csv(&self) -> String {
        let mut csv = String::from("wavelength_nm");
        for (j, _) in &self.bands {
            csv.push_str(&format!(",band{}", j + 1));
        }
        csv.push('\n');
        for (i, w) in self.wavelength_nm.iter().enumerate() {
            csv.push_str(&format!("{w}"));
            for (_, v) in &self.bands {
                csv.push_str(&format!(",{}", v[i]));
            }
            csv.push('\n');
        }
        csv
    }

    /// Unit-length per-band irradiance (band means over `ranges`) of the sources that charged
    /// each of `bands` (0-based).
    pub fn unit_irradiance(
        &self,
        ranges: &[[f64; 2]],
        bands: &[usize],
    ) -> Result<Vec<(usize, Vec<f64>)>> {
        let source = &self.source;
        let mut out = Vec::new();
        for &j in bands {
            let Some((_, col)) = self.bands.iter().find(|(b, _)| *b == j) else {
                return Err(Error::parse(
                    source,
                    1,
                    format!(
                        "no column for band {} (header: {}); expected a column 'band{}' with the \
                         source spectrum that charged that band",
                        j + 1,
                        self.header.join(","),
                        j + 1
                    ),
                ));
            };
            let ctx = |e: Error| Error::invalid(format!("{source}: band{}", j + 1), e.to_string());
            let means = band_means_exact(&self.wavelength_nm, col, ranges).map_err(ctx)?;
            let unit = unit_length(&means).map_err(ctx)?;
            out.push((j, unit));
        }
        Ok(out)
    }
}

/// The ideal box camera (B 400–500, G 500–600, R 600–700 nm) as `wavelength_nm,r,g,b` at 1 nm
/// over 380–720 nm, the default camera of `synth phos-excitation`.
pub fn box_camera_csv() -> String {
    let mut cam = String::from("wavelength_nm,r,g,b\n");
    for k in 0..=340 {
        let w = 380.0 + k as f64;
        let v = |lo: f64, hi: f64| if w >= lo && w < hi { 1 } else { 0 };
        cam.push_str(&format!(
            "{w},{},{},{}\n",
            v(600.0, 700.0),
            v(500.0, 600.0),
            v(400.0, 500.0)
        ));
    }
    cam
}

/// The camera of a material's bands from sensitivities `wavelength_nm,r,g,b` (bytes of the file
/// `source`); errors name the file.
pub fn parse_band_camera(bytes: &[u8], source: &str, bands: &BandSet) -> Result<BandCamera> {
    let ms = MultiSpectrum::from_table(&parse_numeric_csv(bytes, source)?)?;
    BandCamera::for_bands(bands, Some(&ms)).map_err(|e| prefix(source, e))
}

/// Reads camera sensitivities `wavelength_nm,r,g,b` for a material's bands.
pub fn read_band_camera(path: &Path, bands: &BandSet) -> Result<BandCamera> {
    let (bytes, source) = read_input(path)?;
    parse_band_camera(&bytes, &source, bands)
}

/// Times, RGB rows and line numbers of a `time_s,a,b,c` CSV.
struct RgbRows {
    t_s: Vec<f64>,
    rgb: Vec<[f64; 3]>,
    lines: Vec<usize>,
}

fn parse_rgb_rows(bytes: &[u8], source: &str, cols: [&str; 3], what: &str) -> Result<RgbRows> {
    let t = parse_numeric_csv(bytes, source)?;
    let expected = format!("time_s,{},{},{}", cols[0], cols[1], cols[2]);
    let ti = t.column_index("time_s").ok_or_else(|| {
        Error::parse(
            source,
            1,
            format!("no 'time_s' column; expected {what} '{expected}'"),
        )
    })?;
    let mut ci = [0; 3];
    for (k, c) in cols.iter().enumerate() {
        ci[k] = t.column_index(c).ok_or_else(|| {
            Error::parse(
                source,
                1,
                format!("no '{c}' column; expected {what} '{expected}'"),
            )
        })?;
    }
    if t.n_rows() == 0 {
        return Err(Error::parse(
            source,
            0,
            format!("no data rows; expected {what} rows"),
        ));
    }
    Ok(RgbRows {
        t_s: t.columns[ti].clone(),
        rgb: (0..t.n_rows())
            .map(|i| ci.map(|c| t.columns[c][i]))
            .collect(),
        lines: t.lines.clone(),
    })
}

fn rgb_rows_csv(cols: [&str; 3], t_s: &[f64], rgb: &[[f64; 3]]) -> String {
    let mut csv = format!("time_s,{},{},{}\n", cols[0], cols[1], cols[2]);
    for (t, [a, b, c]) in t_s.iter().zip(rgb) {
        csv.push_str(&format!("{t},{a},{b},{c}\n"));
    }
    csv
}

/// The irradiance history of `phos design`: a [`HistoryCsv`] of three bands `e_r,e_g,e_b`
/// (`time_s,e_r,e_g,e_b`, constant from each row's time to the next, the last row holds on; the
/// deprecated `duration_s` layout is read with the same meaning and a dark last row).
#[derive(Debug, Clone, PartialEq)]
pub struct DesignHistoryCsv {
    /// The history.
    pub history: IrradianceHistory,
}

const TARGET_COLUMNS: [&str; 3] = ["l_r", "l_g", "l_b"];

impl DesignHistoryCsv {
    /// Parses a design history (either layout; see [`HistoryCsv::deprecation`]).
    pub fn parse(bytes: &[u8], source: &str) -> Result<Self> {
        Ok(Self {
            history: HistoryCsv::parse(bytes, source, 3)?.to_rgb()?,
        })
    }

    /// Reads a design history, with the deprecation warning of the old layout.
    pub fn read(path: &Path) -> Result<(IrradianceHistory, Option<String>)> {
        let (h, source) = HistoryCsv::read(path, 3)?;
        Ok((h.to_rgb()?, h.deprecation(&source)))
    }

    /// The CSV text (`time_s,e_r,e_g,e_b`).
    pub fn to_csv(&self) -> String {
        rgb_rows_csv(HISTORY_COLUMNS, &self.history.t_s, &self.history.e)
    }
}

/// Keyframe targets of `phos design`: `time_s,l_r,l_g,l_b` (outgoing radiance); times never
/// decrease and none lies before the history's start.
#[derive(Debug, Clone, PartialEq)]
pub struct KeyframesCsv {
    /// The keyframes in file order.
    pub keyframes: Vec<Keyframe>,
}

impl KeyframesCsv {
    /// Parses keyframe targets; `history` (with its file name) bounds the times from below.
    pub fn parse(
        bytes: &[u8],
        source: &str,
        history: Option<(&IrradianceHistory, &str)>,
    ) -> Result<Self> {
        let r = parse_rgb_rows(bytes, source, TARGET_COLUMNS, "keyframe targets")?;
        let start = history.map(|(h, hs)| (h.t_s.first().copied().unwrap_or(0.0), hs));
        for i in 0..r.t_s.len() {
            if let Some((start, hs)) = start.filter(|(s, _)| r.t_s[i] < *s) {
                return Err(Error::parse(
                    source,
                    r.lines[i],
                    format!(
                        "keyframe at {} s is before the history starts ({} s in {}); expected \
                         keyframes within the history",
                        r.t_s[i], start, hs
                    ),
                ));
            }
            if i > 0 && r.t_s[i] < r.t_s[i - 1] {
                return Err(Error::parse(
                    source,
                    r.lines[i],
                    format!(
                        "keyframe at {} s after one at {} s (decreasing); expected keyframe \
                         times in increasing order",
                        r.t_s[i],
                        r.t_s[i - 1]
                    ),
                ));
            }
        }
        Ok(Self {
            keyframes: r
                .t_s
                .iter()
                .zip(&r.rgb)
                .map(|(t, l)| Keyframe {
                    t_s: *t,
                    radiance: *l,
                })
                .collect(),
        })
    }

    /// Reads keyframe targets for `history` (read from the file named `history_source`).
    pub fn read(
        path: &Path,
        history: &IrradianceHistory,
        history_source: &str,
    ) -> Result<Vec<Keyframe>> {
        let (bytes, source) = read_input(path)?;
        Ok(Self::parse(&bytes, &source, Some((history, history_source)))?.keyframes)
    }

    /// The CSV text.
    pub fn to_csv(&self) -> String {
        let t: Vec<f64> = self.keyframes.iter().map(|k| k.t_s).collect();
        let l: Vec<[f64; 3]> = self.keyframes.iter().map(|k| k.radiance).collect();
        rgb_rows_csv(TARGET_COLUMNS, &t, &l)
    }
}

/// Schema tag of [`ChargingJson`].
pub const CHARGING_SCHEMA: &str = "lumifit.charging/1";

/// File name of the charging sidecar beside a decay series (its manifest or curve CSV).
pub const CHARGING_SIDECAR: &str = "charging.json";

/// `charging.json`: how the sample of a decay series was charged before switch-off, written by
/// `synth phos-decay` beside its manifest and curve and read by `phos fit-decay`:
///
/// ```json
/// {"schema": "lumifit.charging/1", "protocol": "flat", "duration_s": 5400, "irradiance": 1}
/// {"schema": "lumifit.charging/1", "protocol": "saturated"}
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ChargingJson {
    /// Always [`CHARGING_SCHEMA`].
    pub schema: String,
    /// The protocol (`protocol` tag and its fields).
    #[serde(flatten)]
    pub charging: DecayCharging,
}

impl ChargingJson {
    /// The sidecar of `charging`.
    pub fn new(charging: DecayCharging) -> Self {
        Self {
            schema: CHARGING_SCHEMA.into(),
            charging,
        }
    }

    /// Parses a sidecar from `bytes`; errors name `source`, the line and what was expected.
    ///
    /// # Errors
    /// [`Error::Parse`] for bad JSON or an unknown protocol, [`Error::InvalidArgument`] for
    /// another schema or a duration/irradiance that is not > 0.
    pub fn parse(bytes: &[u8], source: &str) -> Result<Self> {
        let v: serde_json::Value = crate::io::parse_json(bytes, source)?;
        let schema = v.get("schema").and_then(|s| s.as_str()).unwrap_or("");
        if schema != CHARGING_SCHEMA {
            return Err(Error::invalid(
                format!("{source}: schema"),
                format!("'{schema}'; expected \"{CHARGING_SCHEMA}\""),
            ));
        }
        let c: Self = serde_json::from_value(v).map_err(|e| {
            Error::invalid(
                format!("{source}: protocol"),
                format!(
                    "{e}; expected \"protocol\": \"saturated\", \"unknown\" or \"flat\" \
                     with \"duration_s\" and \"irradiance\""
                ),
            )
        })?;
        c.charging
            .validate()
            .map_err(|e| Error::invalid(source.to_string(), e.to_string()))?;
        Ok(c)
    }

    /// Reads a sidecar file.
    ///
    /// # Errors
    /// As [`ChargingJson::parse`]; I/O errors name the path.
    pub fn read(path: &Path) -> Result<Self> {
        let (bytes, source) = read_input(path)?;
        Self::parse(&bytes, &source)
    }

    /// The sidecar as pretty JSON text.
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).unwrap_or_default() + "\n"
    }

    /// The sidecar beside `input` (a curve CSV, a manifest CSV or a series folder), if one exists.
    pub fn beside(input: &Path) -> Option<std::path::PathBuf> {
        let dir = if input.is_dir() {
            input.to_path_buf()
        } else {
            input.parent().map(Path::to_path_buf).unwrap_or_default()
        };
        let p = dir.join(CHARGING_SIDECAR);
        p.is_file().then_some(p)
    }
}

#[cfg(test)]
mod tests {

    #[test]
    fn a_series_extract_curve_reads_with_its_spreads_as_standard_errors() {
        let csv = "time_s,r,g,b,r_std,g_std,b_std,n_pixels,n_saturated\n\
                   0,1,2,3,0.3,0.4,0.5,100,0\n10,0.5,1,1.5,0.3,0.4,0.5,25,0\n";
        let c = CurveCsv::parse(csv.as_bytes(), "c.csv").unwrap();
        assert_eq!(c.names, vec!["r", "g", "b"]);
        let (kind, sig) = c.sigma.clone().unwrap();
        assert_eq!(kind, SigmaColumn::Std);
        let rms = ((0.09f64 + 0.16 + 0.25) / 3.0).sqrt();
        assert!((sig[0] - rms / 10.0).abs() < 1e-15 && (sig[1] - rms / 5.0).abs() < 1e-15);
        // An explicit std column still wins, and an unknown extra column is still refused.
        let e = CurveCsv::parse(b"time_s,r,g,b,x\n0,1,1,1,1\n", "d.csv").unwrap_err();
        assert!(e.to_string().contains("4 value columns"), "{e}");
    }

    use super::*;

    const BOM: &str = "\u{feff}";

    #[test]
    fn a_curve_round_trips_through_its_csv_with_std_and_with_weight() {
        for kind in [SigmaColumn::Std, SigmaColumn::Weight] {
            let c = CurveCsv {
                time_s: vec![0.0, 0.5, 1.25],
                names: vec!["r".into(), "g".into(), "b".into()],
                channels: vec![
                    vec![3.0, 2.0, 1.0],
                    vec![0.1, 0.05, 1e-7],
                    vec![7.0, 6.5, 6.0],
                ],
                sigma: Some((kind, vec![0.25, 0.125, 1.0 / 3.0])),
            };
            let back = CurveCsv::parse(c.to_csv().as_bytes(), "c.csv").unwrap();
            assert_eq!(back, c);
        }
    }

    #[test]
    fn a_curve_with_a_bom_and_crlf_is_read_and_a_duplicated_column_is_refused() {
        let text = format!("{BOM}time_s,r,g,b\r\n0,3,2,1\r\n1,2,1,0.5\r\n2,1,0.5,0.2\r\n");
        let c = CurveCsv::parse(text.as_bytes(), "c.csv").unwrap();
        assert_eq!(c.time_s, vec![0.0, 1.0, 2.0]);
        let e = CurveCsv::parse(b"time_s,r,r,b\n0,1,2,3\n", "c.csv")
            .unwrap_err()
            .to_string();
        assert!(e.contains("c.csv") && e.contains("'r'"), "{e}");
    }

    #[test]
    fn a_decreasing_curve_time_names_the_line() {
        let e = CurveCsv::parse(b"time_s,v\n0,3\n2,2\n1,1\n", "c.csv")
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 4") && e.contains("decreasing"), "{e}");
    }

    #[test]
    fn a_batch_round_trips_including_quoted_ids() {
        let b = BatchCsv {
            curves: vec![
                BatchCurve {
                    id: "a,\"1\"".into(),
                    line: 2,
                    t_s: vec![0.0, 1.0],
                    rgb: [vec![1.0, 0.5], vec![2.0, 1.0], vec![3.0, 1.5]],
                    std: Some(vec![0.1, 0.2]),
                    lines: vec![2, 3],
                },
                BatchCurve {
                    id: "b".into(),
                    line: 4,
                    t_s: vec![0.0, 2.0],
                    rgb: [vec![1.0, 0.25], vec![2.0, 0.5], vec![3.0, 0.75]],
                    std: Some(vec![0.1, 0.1]),
                    lines: vec![4, 5],
                },
            ],
        };
        let text = format!("{BOM}{}", b.to_csv());
        assert_eq!(BatchCsv::parse(text.as_bytes(), "b.csv").unwrap(), b);
    }

    #[test]
    fn interleaved_ids_spaces_and_quotes_parse_as_the_general_splitter_reads_them() {
        // rows of one id need not be adjacent; fields are trimmed; a quoted row takes the
        // general path, an unquoted one the in-place split: both give the same fields
        let text = "id,time_s,r,g,b\n a , 0 ,1,2,3\nb,0,4,5,6\n\"a\",1, 0.5 ,1,1.5\nb,2,2,2.5,3\n";
        let b = BatchCsv::parse(text.as_bytes(), "b.csv").unwrap();
        assert_eq!(b.curves.len(), 2);
        let (a, bb) = (&b.curves[0], &b.curves[1]);
        assert_eq!((a.id.as_str(), bb.id.as_str()), ("a", "b"));
        assert_eq!(a.t_s, vec![0.0, 1.0]);
        assert_eq!(a.rgb[0], vec![1.0, 0.5]);
        assert_eq!(a.lines, vec![2, 4]);
        assert_eq!(bb.t_s, vec![0.0, 2.0]);
        assert_eq!(bb.rgb[2], vec![6.0, 3.0]);
        let mut f = Vec::new();
        for line in [" a , 0 ,1,,3 ", "\"x,y\", 1 ,\"\"\"q\"\"\",2"] {
            split_fields_into(line, &mut f);
            let want = split_fields(line);
            assert_eq!(
                f.iter().map(|c| c.to_string()).collect::<Vec<_>>(),
                want,
                "{line}"
            );
        }
    }

    #[test]
    fn a_batch_with_a_duplicated_column_is_refused_with_the_line() {
        let e = BatchCsv::parse(b"# c\nid,time_s,r,r,b\nx,0,1,2,3\n", "b.csv")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("b.csv: line 2") && e.contains("'r' appears twice"),
            "{e}"
        );
    }

    #[test]
    fn batch_results_round_trip_through_the_csv_reader() {
        let rows = vec![
            BatchResultRow {
                id: "c,1".into(),
                n_states: Some(2),
                k1_per_s: Some(0.5),
                k2_per_s: Some(1e-3),
                k3_per_s: None,
                a1: Some(2.0),
                a2: Some(0.25),
                a3: None,
                spectrum_r: Some(1.0),
                spectrum_g: Some(0.5),
                spectrum_b: Some(0.125),
                rms: Some(1.5e-4),
                flags: "rate_poorly_determined;singular_covariance".into(),
            },
            BatchResultRow::failed("d", "curve \"d\": fewer than 3 samples"),
        ];
        let text = BatchResultRow::to_csv(&rows);
        assert!(text.starts_with(BATCH_HEADER));
        let back = BatchResultRow::parse(text.as_bytes(), "out.csv").unwrap();
        assert_eq!(back, rows);
        assert!(back[1].is_error() && !back[0].is_error());
    }

    #[test]
    fn a_history_round_trips_and_refuses_a_wrong_band_count() {
        let segments = vec![
            Segment {
                duration_s: 60.0,
                irradiance: vec![1.0, 0.5],
            },
            Segment {
                duration_s: 0.25,
                irradiance: vec![0.0, 0.0],
            },
        ];
        let h = HistoryCsv::from_segments(vec!["e1".into(), "e2".into()], &segments);
        let text = format!("{BOM}{}", h.to_csv());
        assert!(
            text.contains("time_s,e1,e2\n0,1,0.5\n60,0,0\n60.25,0,0\n"),
            "{text}"
        );
        let back = HistoryCsv::parse(text.as_bytes(), "h.csv", 2).unwrap();
        assert_eq!(back.t_s, h.t_s);
        assert_eq!(back.irradiance, h.irradiance);
        assert_eq!(back.layout, HistoryLayout::Times);
        assert_eq!(back.deprecation("h.csv"), None);
        assert_eq!(back.to_segments("h.csv").unwrap(), segments);
        let e = HistoryCsv::parse(text.as_bytes(), "h.csv", 3)
            .unwrap_err()
            .to_string();
        assert!(e.contains("h.csv: line 1") && e.contains("3 bands"), "{e}");
    }

    #[test]
    fn the_old_duration_layout_reads_as_the_same_breakpoints_with_a_warning() {
        let old = b"duration_s,e1,e2\n60,1,0.5\n0.25,0,0\n";
        let h = HistoryCsv::parse(old, "old.csv", 2).unwrap();
        assert_eq!(h.layout, HistoryLayout::Durations);
        assert_eq!(h.t_s, vec![0.0, 60.0, 60.25]);
        assert_eq!(
            h.irradiance,
            vec![vec![1.0, 0.5], vec![0.0, 0.0], vec![0.0, 0.0]]
        );
        let w = h.deprecation("old.csv").unwrap();
        assert!(
            w.contains("old.csv") && w.contains("deprecated") && w.contains("time_s,e1,e2"),
            "{w}"
        );
        // Written back in the documented layout and read again: the same segments.
        let new = HistoryCsv::parse(h.to_csv().as_bytes(), "new.csv", 2).unwrap();
        assert_eq!(
            new.to_segments("new.csv").unwrap(),
            h.to_segments("old.csv").unwrap()
        );
        assert_eq!(
            h.to_segments("old.csv").unwrap(),
            vec![
                Segment {
                    duration_s: 60.0,
                    irradiance: vec![1.0, 0.5]
                },
                Segment {
                    duration_s: 0.25,
                    irradiance: vec![0.0, 0.0]
                },
            ]
        );
    }

    #[test]
    fn a_history_that_starts_late_is_preceded_by_dark_and_rgb_columns_go_by_name() {
        let h = HistoryCsv::parse(b"time_s,e_b,e_r,e_g\n10,3,1,2\n30,0,0,0\n", "h.csv", 3).unwrap();
        assert_eq!(h.names, vec!["e_r", "e_g", "e_b"]);
        let s = h.to_segments("h.csv").unwrap();
        assert_eq!(s.len(), 2);
        assert_eq!(
            (s[0].duration_s, s[0].irradiance.clone()),
            (10.0, vec![0.0; 3])
        );
        assert_eq!(
            (s[1].duration_s, s[1].irradiance.clone()),
            (20.0, vec![1.0, 2.0, 3.0])
        );
        let rgb = h.to_rgb().unwrap();
        assert_eq!(rgb.t_s, vec![10.0, 30.0]);
        assert_eq!(rgb.e, vec![[1.0, 2.0, 3.0], [0.0; 3]]);
    }

    #[test]
    fn bad_histories_name_the_file_line_and_column() {
        let cases: [(&[u8], &str); 8] = [
            (b"time_s,e1\n0,1\n5,0\n3,0\n", "line 4"),
            (b"time_s,e1\n0,1\n0,0\n", "duplicated"),
            (b"duration_s,e1\n60,1\n-5,0\n", "line 3"),
            (b"duration_s,e1\n60,1\n0,0\n", "expected a duration > 0"),
            (b"time_s,e1,duration_s\n0,1,1\n", "column 3"),
            (b"e1,time_s\n1,0\n", "column 2"),
            (b"time_s,e1\n0,-1\n1,0\n", "column 'e1'"),
            (b"t,e1\n0,1\n", "column 1 is 't'"),
        ];
        for (csv, want) in cases {
            let e = HistoryCsv::parse(
                csv,
                "h.csv",
                if csv.starts_with(b"time_s,e1,d") {
                    2
                } else {
                    1
                },
            )
            .unwrap_err()
            .to_string();
            assert!(e.contains("h.csv") && e.contains(want), "{want}: {e}");
        }
        let e = HistoryCsv::parse(b"time_s,e1\n0,1\n", "h.csv", 1)
            .unwrap()
            .to_segments("h.csv")
            .unwrap_err()
            .to_string();
        assert!(e.contains("h.csv: line 2") && e.contains("no end"), "{e}");
        let e = HistoryCsv::parse(b"time_s,e1\n-1,1\n2,0\n", "h.csv", 1)
            .unwrap()
            .to_segments("h.csv")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("h.csv: line 2") && e.contains("0 s or later"),
            "{e}"
        );
    }

    #[test]
    fn charging_data_round_trip() {
        let d = ChargingCsv {
            samples: vec![
                ChargingSample {
                    band: 0,
                    charge_s: 1.0,
                    rgb: [0.5, 0.25, 0.125],
                    sigma: Some(0.01),
                },
                ChargingSample {
                    band: 2,
                    charge_s: 512.0,
                    rgb: [1.5, 1e-9, 0.0],
                    sigma: Some(2e-3),
                },
            ],
        };
        let text = format!("{BOM}{}", d.to_csv());
        assert_eq!(ChargingCsv::parse(text.as_bytes(), "d.csv", 3).unwrap(), d);
        let e = ChargingCsv::parse(text.as_bytes(), "d.csv", 2)
            .unwrap_err()
            .to_string();
        assert!(e.contains("d.csv: line 3") && e.contains("band 3"), "{e}");
    }

    #[test]
    fn box_sources_round_trip_and_give_one_unit_band_each() {
        let ranges = [[400.0, 450.0], [450.0, 500.0], [500.0, 550.0]];
        let s = SourceSpectraCsv::boxes(&ranges, 2);
        let back = SourceSpectraCsv::parse(s.to_csv().as_bytes(), "s.csv").unwrap();
        assert_eq!(back.wavelength_nm, s.wavelength_nm);
        assert_eq!(back.bands, s.bands);
        let unit = back.unit_irradiance(&ranges, &[0, 1]).unwrap();
        for (j, v) in &unit {
            let norm = v.iter().map(|x| x * x).sum::<f64>().sqrt();
            assert!((norm - 1.0).abs() < 1e-12, "{norm}");
            let top = v.iter().cloned().fold(0.0, f64::max);
            assert_eq!(v.iter().position(|x| *x == top), Some(*j));
        }
        let e = back.unit_irradiance(&ranges, &[2]).unwrap_err().to_string();
        assert!(e.contains("no column for band 3"), "{e}");
    }

    #[test]
    fn design_history_and_keyframes_round_trip() {
        let h = DesignHistoryCsv {
            history: IrradianceHistory {
                t_s: vec![0.0, 10.0, 20.5],
                e: vec![[1.0, 1.0, 1.0], [0.0, 0.5, 0.0], [0.0, 0.0, 0.0]],
            },
        };
        let text = format!("{BOM}{}", h.to_csv());
        assert_eq!(
            DesignHistoryCsv::parse(text.as_bytes(), "h.csv").unwrap(),
            h
        );
        let k = KeyframesCsv {
            keyframes: vec![
                Keyframe {
                    t_s: 5.0,
                    radiance: [0.1, 0.2, 0.3],
                },
                Keyframe {
                    t_s: 25.0,
                    radiance: [0.01, 0.02, 0.03],
                },
            ],
        };
        let text = format!("{BOM}{}", k.to_csv());
        assert_eq!(
            KeyframesCsv::parse(text.as_bytes(), "k.csv", Some((&h.history, "h.csv"))).unwrap(),
            k
        );
    }

    #[test]
    fn keyframes_that_go_back_in_time_are_refused_with_the_line() {
        let e = KeyframesCsv::parse(
            b"time_s,l_r,l_g,l_b\n10,1,1,1\n# later\n5,1,1,1\n",
            "k.csv",
            None,
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("k.csv: line 4") && e.contains("decreasing"),
            "{e}"
        );
    }

    #[test]
    fn a_simulation_table_round_trips() {
        let s = SimulationCsv {
            header: vec!["L_r".into(), "r_1".into()],
            t_s: vec![0.0, 1.0],
            rows: vec![vec![0.5, 0.25], vec![0.125, 1e-300]],
        };
        assert_eq!(
            SimulationCsv::parse(s.to_csv().as_bytes(), "s.csv").unwrap(),
            s
        );
    }

    #[test]
    fn a_charging_sidecar_reads_back_and_bad_ones_name_the_file_and_field() {
        let c = ChargingJson::new(DecayCharging::Flat {
            duration_s: 5400.0,
            irradiance: 1.0,
        });
        let text = c.to_json();
        assert_eq!(ChargingJson::parse(text.as_bytes(), "c.json").unwrap(), c);
        let e = ChargingJson::parse(
            br#"{"schema": "lumifit.charging/1", "protocol": "flat", "duration_s": 0, "irradiance": 1}"#,
            "c.json",
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("c.json") && e.contains("duration_s"), "{e}");
        let e = ChargingJson::parse(
            br#"{"schema": "lumifit.charging/1", "protocol": "sunny"}"#,
            "c.json",
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("c.json: protocol") && e.contains("saturated"),
            "{e}"
        );
        let e = ChargingJson::parse(br#"{"protocol": "saturated"}"#, "c.json")
            .unwrap_err()
            .to_string();
        assert!(e.contains("schema"), "{e}");
    }
}
