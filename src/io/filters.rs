//! Colour-gel transmission tables (the filters placed in front of the LVF for the band
//! transmission calibration of Nalbach et al. 2017, §4.2; the paper used Roscolux gels,
//! `../shared/data/filters/` holds 263 Lee gels at 405–700 nm every 5 nm).
//!
//! Two layouts are read, told apart by the first cell of the header row:
//!
//! - **wide** (`code,name,<nm>,<nm>,…`): one gel per row, e.g. the Lee table
//!   `lee_filters_sd_lighting_filters_0.1.1.csv`; names may be quoted.
//! - **long** (`wavelength_nm,<code1>,<code2>,…`): one wavelength per row, one gel per column;
//!   a two-column file `wavelength_nm,transmission` is a single gel.
//!
//! Lines starting with `#` are comments. Transmission is a fraction (0–1); values up to 1.5 are
//! accepted (measurement noise above 1), larger ones are rejected as probably percent. Between
//! its samples a gel is interpolated linearly and beyond them it is held constant
//! ([`Gel::at`]), as colour-science extrapolates spectral distributions.

use std::path::Path;

use crate::error::{Error, Result};
use crate::spectrum::Spectrum;

/// Largest transmission accepted; above this the table is most likely in percent.
pub const MAX_TRANSMISSION: f64 = 1.5;

/// One colour gel and its spectral transmission.
#[derive(Debug, Clone, PartialEq)]
pub struct Gel {
    /// Catalogue code (`L002`) or column name.
    pub code: String,
    /// Descriptive name (`Rose Pink`); may be empty.
    pub name: String,
    /// Transmission as a fraction (0–1) over wavelength (nm).
    pub transmission: Spectrum,
}

impl Gel {
    /// Transmission at `nm`: linear interpolation between samples, the end value beyond them.
    pub fn at(&self, nm: f64) -> f64 {
        let w = self.transmission.wavelengths();
        let v = self.transmission.values();
        let n = w.len();
        if nm <= w[0] {
            return v[0];
        }
        if nm >= w[n - 1] {
            return v[n - 1];
        }
        let i = w.partition_point(|&x| x <= nm).clamp(1, n - 1);
        let f = (nm - w[i - 1]) / (w[i] - w[i - 1]);
        v[i - 1] + f * (v[i] - v[i - 1])
    }

    /// True when the measured range includes `[lo, hi]` (nm), so no extrapolation is needed there.
    pub fn covers(&self, lo: f64, hi: f64) -> bool {
        let w = self.transmission.wavelengths();
        const EPS: f64 = 1e-9;
        w[0] <= lo + EPS && w[w.len() - 1] >= hi - EPS
    }

    /// `code name` (or just the code when the name is empty), for messages and truth files.
    pub fn label(&self) -> String {
        if self.name.is_empty() || self.name == self.code {
            self.code.clone()
        } else {
            format!("{} {}", self.code, self.name)
        }
    }
}

/// One CSV row: its 1-based line number and trimmed, unquoted fields.
struct Row {
    line: usize,
    fields: Vec<String>,
}

fn read_rows(bytes: &[u8], source: &str) -> Result<Vec<Row>> {
    crate::table::as_text(bytes, source, "a CSV gel table")?;
    let mut rdr = csv::ReaderBuilder::new()
        .has_headers(false)
        .flexible(true)
        .comment(Some(b'#'))
        .trim(csv::Trim::All)
        .from_reader(bytes);
    let mut rows = Vec::new();
    for rec in rdr.records() {
        let rec = rec.map_err(|e| {
            let line = e.position().map(|p| p.line() as usize).unwrap_or_default();
            Error::parse(source, line, format!("not valid CSV: {e}"))
        })?;
        let line = rec.position().map(|p| p.line() as usize).unwrap_or(0);
        let fields: Vec<String> = rec.iter().map(str::to_string).collect();
        if fields.iter().all(|f| f.is_empty()) {
            continue;
        }
        rows.push(Row { line, fields });
    }
    Ok(rows)
}

/// Parses a transmission value, naming the position on error.
fn transmission(s: &str, source: &str, line: usize, col: usize, what: &str) -> Result<f64> {
    let v: f64 = s.parse().ok().filter(|v: &f64| v.is_finite()).ok_or_else(|| {
        Error::parse(
            source,
            line,
            format!("column {col} ({what}): '{s}' is not a number; expected a transmission fraction 0–1"),
        )
    })?;
    if v < 0.0 {
        return Err(Error::parse(
            source,
            line,
            format!("column {col} ({what}): transmission {v} is negative; expected a fraction 0–1"),
        ));
    }
    if v > MAX_TRANSMISSION {
        return Err(Error::parse(
            source,
            line,
            format!(
                "column {col} ({what}): transmission {v} exceeds {MAX_TRANSMISSION}; expected a fraction 0–1 (is the table in percent? divide by 100)"
            ),
        ));
    }
    Ok(v)
}

fn wavelength(s: &str, source: &str, line: usize, col: usize) -> Result<f64> {
    s.parse::<f64>()
        .ok()
        .filter(|v| v.is_finite() && *v > 0.0)
        .ok_or_else(|| {
            Error::parse(
                source,
                line,
                format!(
                    "column {col}: '{s}' is not a wavelength; expected a positive number of nm"
                ),
            )
        })
}

fn check_increasing(
    wl: &[f64],
    source: &str,
    line_of: impl Fn(usize) -> (usize, String),
) -> Result<()> {
    if let Some(i) = wl.windows(2).position(|w| w[1] <= w[0]) {
        let (line, place) = line_of(i + 1);
        return Err(Error::parse(
            source,
            line,
            format!(
                "{place}: wavelength {} nm follows {} nm; expected strictly increasing wavelengths",
                wl[i + 1],
                wl[i]
            ),
        ));
    }
    Ok(())
}

fn check_unique(gels: &[Gel], code: &str, source: &str, line: usize, place: &str) -> Result<()> {
    if gels.iter().any(|g| g.code == code) {
        return Err(Error::parse(
            source,
            line,
            format!("{place}: gel code '{code}' appears twice; expected unique codes"),
        ));
    }
    Ok(())
}

fn is_long_header(first: &str) -> bool {
    let f = first.to_ascii_lowercase();
    f.starts_with("wavelength") || f == "nm" || f == "lambda_nm" || f == "lambda"
}

/// Parses a gel table held in memory; `source` names it in errors. See the module docs for the
/// two layouts.
///
/// # Errors
/// [`Error::Parse`] naming the source, line and column: an unknown header, a row of the wrong
/// width, a non-numeric value, a negative transmission, one above [`MAX_TRANSMISSION`] (percent
/// instead of fraction), a duplicate code, wavelengths not strictly increasing, or no gel at all.
pub fn parse_gel_table(bytes: &[u8], source: &str) -> Result<Vec<Gel>> {
    if bytes.iter().all(|b| b.is_ascii_whitespace()) {
        return Err(Error::parse(
            source,
            0,
            "file is empty; expected a gel table 'code,name,<nm>,…' or 'wavelength_nm,<code>,…'",
        ));
    }
    let rows = read_rows(bytes, source)?;
    let Some((head, data)) = rows.split_first() else {
        return Err(Error::parse(
            source,
            0,
            "no header row; expected 'code,name,<nm>,…' or 'wavelength_nm,<code>,…'",
        ));
    };
    let first = head.fields[0].as_str();
    let gels = if first.eq_ignore_ascii_case("code") {
        parse_wide(head, data, source)?
    } else if is_long_header(first) {
        parse_long(head, data, source)?
    } else {
        return Err(Error::parse(
            source,
            head.line,
            format!(
                "header starts with '{first}'; expected 'code,name,<nm>,…' (one gel per row) or 'wavelength_nm,<code>,…' (one gel per column)"
            ),
        ));
    };
    if gels.is_empty() {
        return Err(Error::parse(
            source,
            head.line,
            "the table holds no gel; expected at least one data row (wide) or gel column (long)",
        ));
    }
    Ok(gels)
}

fn parse_wide(head: &Row, data: &[Row], source: &str) -> Result<Vec<Gel>> {
    let h = &head.fields;
    if h.len() < 3 || !h[1].eq_ignore_ascii_case("name") {
        return Err(Error::parse(
            source,
            head.line,
            "wide gel table: expected a header 'code,name,<nm>,<nm>,…' with at least one wavelength",
        ));
    }
    let wl = h[2..]
        .iter()
        .enumerate()
        .map(|(k, s)| wavelength(s, source, head.line, k + 3))
        .collect::<Result<Vec<f64>>>()?;
    check_increasing(&wl, source, |i| {
        (head.line, format!("header column {}", i + 3))
    })?;
    let mut gels: Vec<Gel> = Vec::with_capacity(data.len());
    for row in data {
        if row.fields.len() != h.len() {
            return Err(Error::parse(
                source,
                row.line,
                format!(
                    "expected {} columns (code, name and {} wavelengths), found {}",
                    h.len(),
                    wl.len(),
                    row.fields.len()
                ),
            ));
        }
        let code = row.fields[0].clone();
        if code.is_empty() {
            return Err(Error::parse(
                source,
                row.line,
                "column 1 (code) is empty; expected a gel code",
            ));
        }
        check_unique(&gels, &code, source, row.line, "column 1 (code)")?;
        let values = row.fields[2..]
            .iter()
            .enumerate()
            .map(|(k, s)| {
                transmission(
                    s,
                    source,
                    row.line,
                    k + 3,
                    &format!("{code} at {} nm", h[k + 2]),
                )
            })
            .collect::<Result<Vec<f64>>>()?;
        let transmission = Spectrum::new(format!("{source}:{code}"), wl.clone(), values)?;
        gels.push(Gel {
            code,
            name: row.fields[1].clone(),
            transmission,
        });
    }
    Ok(gels)
}

fn parse_long(head: &Row, data: &[Row], source: &str) -> Result<Vec<Gel>> {
    let h = &head.fields;
    if h.len() < 2 {
        return Err(Error::parse(
            source,
            head.line,
            "long gel table: expected a header 'wavelength_nm,<code>,…' with at least one gel column",
        ));
    }
    let mut codes: Vec<&str> = Vec::with_capacity(h.len() - 1);
    for (k, c) in h[1..].iter().enumerate() {
        if c.is_empty() {
            return Err(Error::parse(
                source,
                head.line,
                format!("header column {} is empty; expected a gel code", k + 2),
            ));
        }
        if codes.contains(&c.as_str()) {
            return Err(Error::parse(
                source,
                head.line,
                format!(
                    "header column {}: gel code '{c}' appears twice; expected unique codes",
                    k + 2
                ),
            ));
        }
        codes.push(c);
    }
    let mut wl = Vec::with_capacity(data.len());
    let mut cols: Vec<Vec<f64>> = vec![Vec::with_capacity(data.len()); codes.len()];
    for row in data {
        if row.fields.len() != h.len() {
            return Err(Error::parse(
                source,
                row.line,
                format!(
                    "expected {} columns ({}), found {}",
                    h.len(),
                    h.join(","),
                    row.fields.len()
                ),
            ));
        }
        wl.push(wavelength(&row.fields[0], source, row.line, 1)?);
        for (k, col) in cols.iter_mut().enumerate() {
            col.push(transmission(
                &row.fields[k + 1],
                source,
                row.line,
                k + 2,
                codes[k],
            )?);
        }
    }
    if wl.is_empty() {
        return Err(Error::parse(
            source,
            head.line,
            "the table has a header but no data rows; expected one row per wavelength",
        ));
    }
    check_increasing(&wl, source, |i| (data[i].line, "column 1".to_string()))?;
    let stem = Path::new(source)
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    codes
        .iter()
        .zip(cols)
        .map(|(code, values)| {
            // A two-column file 'wavelength_nm,transmission' is one gel named after the file.
            let generic = codes.len() == 1
                && ["transmission", "transmittance", "value", "t"]
                    .iter()
                    .any(|g| code.eq_ignore_ascii_case(g));
            let code = if generic && !stem.is_empty() {
                stem.clone()
            } else {
                code.to_string()
            };
            Ok(Gel {
                transmission: Spectrum::new(format!("{source}:{code}"), wl.clone(), values)?,
                name: String::new(),
                code,
            })
        })
        .collect()
}

/// Reads a gel table file (either layout; see the module docs).
///
/// # Errors
/// [`Error::Io`] when the file cannot be read; the [`parse_gel_table`] errors.
pub fn read_gel_table(path: &Path) -> Result<Vec<Gel>> {
    let (bytes, source) = super::read_input(path)?;
    parse_gel_table(&bytes, &source)
}

/// Picks gel `code` (case-insensitive) from `gels`; the error lists a few available codes.
///
/// # Errors
/// [`Error::InvalidArgument`] when no gel has that code.
pub fn pick_gel(gels: Vec<Gel>, code: &str, source: &str) -> Result<Gel> {
    let n = gels.len();
    let sample: Vec<String> = gels.iter().take(8).map(|g| g.code.clone()).collect();
    gels.into_iter()
        .find(|g| g.code.eq_ignore_ascii_case(code))
        .ok_or_else(|| {
            Error::invalid(
                "--filter",
                format!(
                    "{source}: no gel with code '{code}'; the table has {n} gels, e.g. {}{}",
                    sample.join(", "),
                    if n > sample.len() { ", …" } else { "" }
                ),
            )
        })
}

/// `FILE.csv` or `FILE.csv:CODE` split into the table's path and the gel's code (none when the
/// whole argument names an existing file).
fn split_filter_arg(arg: &str) -> (&Path, Option<&str>) {
    let whole = Path::new(arg);
    match arg.rsplit_once(':') {
        Some((file, code)) if !whole.exists() && !file.is_empty() && !code.is_empty() => {
            (Path::new(file), Some(code))
        }
        _ => (whole, None),
    }
}

/// The table file `--filter FILE.csv[:CODE]` reads, when it is a file (for the output-path
/// check, which lists every file a run reads).
pub fn filter_file(arg: &str) -> Option<std::path::PathBuf> {
    let (path, _) = split_filter_arg(arg);
    path.is_file().then(|| path.to_path_buf())
}

/// One filter from a command-line argument: `FILE.csv` holding a single gel (two columns
/// `wavelength_nm,transmission`, or a table with one gel), or `FILE.csv:CODE` picking gel `CODE`
/// from a table. An argument naming an existing file is always taken as a file.
///
/// # Errors
/// The [`read_gel_table`] errors; [`Error::InvalidArgument`] for an unknown code (listing a few
/// available ones) or for a multi-gel table given without a code.
pub fn read_filter(arg: &str) -> Result<Gel> {
    let (path, code) = split_filter_arg(arg);
    let gels = read_gel_table(path)?;
    let source = path.display().to_string();
    match code {
        Some(code) => pick_gel(gels, code, &source),
        None if gels.len() == 1 => Ok(gels.into_iter().next().ok_or_else(|| {
            Error::invalid("--filter", format!("{source}: the table holds no gel"))
        })?),
        None => {
            let sample: Vec<&str> = gels.iter().take(5).map(|g| g.code.as_str()).collect();
            Err(Error::invalid(
                "--filter",
                format!(
                    "{source} holds {} gels; pick one with FILE.csv:CODE, e.g. {source}:{}",
                    gels.len(),
                    sample.first().copied().unwrap_or("CODE")
                ),
            ))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const WIDE: &str =
        "# comment\ncode,name,400,410,420\nL1,\"Rose, Pink\",0.5,0.6,0.7\nL2,Blue,0.1,0.2,0.3\n";
    const LONG: &str = "wavelength_nm,A,B\n400,0.5,0.1\n410,0.6,0.2\n420,0.7,0.3\n";

    #[test]
    fn wide_and_long_layouts_read_the_same_gels() {
        let w = parse_gel_table(WIDE.as_bytes(), "w.csv").unwrap();
        let l = parse_gel_table(LONG.as_bytes(), "l.csv").unwrap();
        assert_eq!(w.len(), 2);
        assert_eq!(l.len(), 2);
        assert_eq!(w[0].name, "Rose, Pink");
        assert_eq!(w[0].code, "L1");
        assert_eq!(l[1].code, "B");
        assert_eq!(w[0].transmission.values(), l[0].transmission.values());
        assert_eq!(w[1].transmission.wavelengths(), &[400.0, 410.0, 420.0]);
    }

    #[test]
    fn interpolation_is_linear_inside_and_constant_outside() {
        let g = &parse_gel_table(WIDE.as_bytes(), "w.csv").unwrap()[0];
        assert!((g.at(405.0) - 0.55).abs() < 1e-12);
        assert_eq!(g.at(300.0), 0.5);
        assert_eq!(g.at(900.0), 0.7);
        assert!(g.covers(400.0, 420.0));
        assert!(!g.covers(395.0, 420.0));
        assert!(!g.covers(400.0, 421.0));
        assert_eq!(g.label(), "L1 Rose, Pink");
    }

    #[test]
    fn two_column_file_is_one_gel_named_after_the_file() {
        let g = parse_gel_table(
            b"wavelength_nm,transmission\n400,0.2\n500,0.4\n",
            "dir/red.csv",
        )
        .unwrap();
        assert_eq!(g.len(), 1);
        assert_eq!(g[0].code, "red");
    }

    fn err(text: &str) -> String {
        parse_gel_table(text.as_bytes(), "t.csv")
            .unwrap_err()
            .to_string()
    }

    #[test]
    fn percent_values_are_rejected_with_a_hint() {
        let e = err("code,name,400,410\nL1,x,50,60\n");
        assert!(
            e.contains("t.csv") && e.contains("line 2") && e.contains("column 3"),
            "{e}"
        );
        assert!(e.contains("percent"), "{e}");
        let e = err("wavelength_nm,A\n400,0.5\n410,65\n");
        assert!(
            e.contains("line 3") && e.contains("column 2") && e.contains("percent"),
            "{e}"
        );
    }

    #[test]
    fn bad_values_codes_and_wavelengths_are_named() {
        let e = err("code,name,400,410\nL1,x,0.5,abc\n");
        assert!(
            e.contains("line 2") && e.contains("column 4") && e.contains("'abc'"),
            "{e}"
        );
        let e = err("code,name,400,410\nL1,x,0.5,-0.1\n");
        assert!(e.contains("negative"), "{e}");
        let e = err("code,name,400,410\nL1,x,0.5,0.1\nL1,y,0.5,0.1\n");
        assert!(
            e.contains("line 3") && e.contains("'L1' appears twice"),
            "{e}"
        );
        let e = err("wavelength_nm,A,A\n400,0.5,0.5\n");
        assert!(e.contains("appears twice"), "{e}");
        let e = err("code,name,410,400\nL1,x,0.5,0.1\n");
        assert!(e.contains("line 1") && e.contains("increasing"), "{e}");
        let e = err("wavelength_nm,A\n400,0.5\n400,0.5\n");
        assert!(e.contains("line 3") && e.contains("increasing"), "{e}");
        let e = err("code,name,400,410\nL1,x,0.5\n");
        assert!(e.contains("expected 4 columns"), "{e}");
        let e = err("foo,bar\n1,2\n");
        assert!(e.contains("'foo'") && e.contains("wavelength_nm"), "{e}");
    }

    #[test]
    fn empty_tables_are_rejected() {
        assert!(err("").contains("empty"));
        assert!(err("# only a comment\n").contains("no header"));
        assert!(err("code,name,400,410\n").contains("no gel"));
        assert!(err("wavelength_nm,A\n").contains("no data rows"));
    }

    #[test]
    fn unknown_code_lists_available_ones() {
        let gels = parse_gel_table(WIDE.as_bytes(), "w.csv").unwrap();
        let e = pick_gel(gels.clone(), "L9", "w.csv")
            .unwrap_err()
            .to_string();
        assert!(e.contains("'L9'") && e.contains("L1, L2"), "{e}");
        assert_eq!(pick_gel(gels, "l2", "w.csv").unwrap().code, "L2");
    }

    #[test]
    fn read_filter_picks_by_code_or_takes_a_single_gel() {
        let dir = tempfile::tempdir().unwrap();
        let t = dir.path().join("table.csv");
        std::fs::write(&t, WIDE).unwrap();
        let one = dir.path().join("one.csv");
        std::fs::write(&one, "wavelength_nm,transmission\n400,0.2\n500,0.4\n").unwrap();
        let g = read_filter(&format!("{}:L2", t.display())).unwrap();
        assert_eq!(g.name, "Blue");
        assert_eq!(read_filter(&one.display().to_string()).unwrap().code, "one");
        let e = read_filter(&t.display().to_string())
            .unwrap_err()
            .to_string();
        assert!(e.contains("holds 2 gels") && e.contains(":L1"), "{e}");
    }
}
