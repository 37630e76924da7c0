//! Readers of refractive-index data: refractiveindex.info YAML entries and measured CSV.
//!
//! **YAML** (the database format, Polyanskiy 2024): a `DATA` list whose items have a `type` —
//! `formula 1` … `formula 9` with `wavelength_range` (or the older `range`, µm) and
//! `coefficients`, or `tabulated n` / `tabulated nk` / `tabulated k` with a `data` block of rows
//! `λ_µm n [k]`. The first item that gives n is used (`tabulated k` items only give absorption and
//! are skipped). `SPECS` may say `n_absolute` and `wavelength_vacuum`; `PROPERTIES` (SCHOTT
//! entries) or `SPECS` may carry the catalogue `nd`, `Vd` and `glass_code`, which are returned so
//! tests and reports can compare with them. Tabulated rows are returned as measurements, to be
//! fitted, never interpolated.
//!
//! **CSV**: header `wavelength_nm,n[,std]` through [`crate::table::parse_numeric_csv`];
//! wavelengths strictly increasing, n ≥ 1, std > 0.
//!
//! Errors name the file, the line where it can be found, the field and what was expected.

// Index loops mirror the maths; `!(a > b)` comparisons deliberately reject NaN along with
// out-of-range values.
#![allow(clippy::needless_range_loop, clippy::neg_cmp_op_on_partial_ord)]

use yaml_rust2::{Yaml, YamlLoader};

use crate::dispersion::fit::Observations;
use crate::dispersion::formula::{Formula, FormulaKind};
use crate::dispersion::source::Source;
use crate::error::{Error, Result};

/// One refractiveindex.info entry.
#[derive(Debug, Clone, PartialEq)]
pub struct RiiEntry {
    /// n(λ): the formula, or the tabulated n as measurements (nm).
    pub source: Source,
    /// The `type` of the DATA item used, e.g. `formula 2`, `tabulated nk`.
    pub data_type: String,
    /// `SPECS: n_absolute`, if given.
    pub n_absolute: Option<bool>,
    /// `SPECS: wavelength_vacuum`, if given.
    pub wavelength_vacuum: Option<bool>,
    /// Catalogue n_d (`PROPERTIES` or `SPECS` `nd`), if given.
    pub catalogue_n_d: Option<f64>,
    /// Catalogue V_d (`Vd`), if given.
    pub catalogue_v_d: Option<f64>,
    /// Catalogue glass code, if given.
    pub glass_code: Option<String>,
    /// `REFERENCES`, if given (HTML as in the database).
    pub references: Option<String>,
}

/// 1-based line of the `nth` (0-based) line of `text` that starts (after indentation and an
/// optional `- `) with `key:`; 0 when not found.
fn line_of(text: &str, key: &str, nth: usize) -> usize {
    let pat = format!("{key}:");
    text.lines()
        .enumerate()
        .filter(|(_, l)| {
            let t = l.trim_start();
            let t = t.strip_prefix("- ").unwrap_or(t).trim_start();
            t.starts_with(&pat)
        })
        .nth(nth)
        .map_or(0, |(i, _)| i + 1)
}

fn scalar(y: &Yaml) -> Option<String> {
    match y {
        Yaml::Real(s) | Yaml::String(s) => Some(s.trim().to_string()),
        Yaml::Integer(i) => Some(i.to_string()),
        Yaml::Boolean(b) => Some(b.to_string()),
        _ => None,
    }
}

fn numbers(file: &str, line: usize, field: &str, text: &str) -> Result<Vec<f64>> {
    text.split_whitespace()
        .map(|s| {
            s.parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| {
                    Error::parse(
                        file,
                        line,
                        format!("field '{field}': '{s}' is not a finite number"),
                    )
                })
        })
        .collect()
}

fn optional_number(file: &str, text: &str, hash: &Yaml, key: &str) -> Result<Option<f64>> {
    match &hash[key] {
        Yaml::BadValue | Yaml::Null => Ok(None),
        v => {
            let s = scalar(v).unwrap_or_default();
            if s.is_empty() {
                return Ok(None);
            }
            s.parse::<f64>().map(Some).map_err(|_| {
                Error::parse(
                    file,
                    line_of(text, key, 0),
                    format!("field '{key}': '{s}' is not a number"),
                )
            })
        }
    }
}

fn optional_bool(file: &str, text: &str, hash: &Yaml, key: &str) -> Result<Option<bool>> {
    match &hash[key] {
        Yaml::BadValue | Yaml::Null => Ok(None),
        Yaml::Boolean(b) => Ok(Some(*b)),
        other => Err(Error::parse(
            file,
            line_of(text, key, 0),
            format!(
                "field 'SPECS.{key}': {}; expected true or false",
                scalar(other).unwrap_or_else(|| "a non-scalar".into())
            ),
        )),
    }
}

/// Parses a refractiveindex.info YAML entry. `file` names it in errors.
pub fn parse_rii_yaml(bytes: &[u8], file: &str) -> Result<RiiEntry> {
    let text = crate::table::as_text(bytes, file, "a refractiveindex.info YAML entry")?;
    let docs = YamlLoader::load_from_str(text).map_err(|e| {
        Error::parse(
            file,
            e.marker().line(),
            format!("YAML syntax: {}", e.info()),
        )
    })?;
    let doc = docs.first().ok_or_else(|| {
        Error::parse(
            file,
            0,
            "empty YAML document; expected a mapping with a DATA list",
        )
    })?;
    if doc.as_hash().is_none() {
        return Err(Error::parse(
            file,
            1,
            "expected a mapping with REFERENCES, DATA, … at the top level",
        ));
    }
    let data = doc["DATA"].as_vec().ok_or_else(|| {
        Error::parse(
            file,
            line_of(text, "DATA", 0),
            "field 'DATA' is missing or not a list; expected DATA: [- type: formula N …]",
        )
    })?;
    let mut chosen: Option<(Source, String)> = None;
    for (i, item) in data.iter().enumerate() {
        let line = line_of(text, "type", i);
        let ty = item["type"].as_str().map(str::trim).ok_or_else(|| {
            Error::parse(
                file,
                line,
                format!("DATA item {}: field 'type' missing; expected 'formula N' or 'tabulated n|nk|k'", i + 1),
            )
        })?;
        let mut words = ty.split_whitespace();
        let (head, tail) = (words.next().unwrap_or(""), words.next().unwrap_or(""));
        let parsed = match head {
            "formula" => {
                let number: u32 = tail.parse().map_err(|_| {
                    Error::parse(
                        file,
                        line,
                        format!("field 'type': '{ty}'; expected 'formula 1' … 'formula 9'"),
                    )
                })?;
                let kind = FormulaKind::from_number(number)
                    .map_err(|e| Error::parse(file, line, format!("field 'type': {e}")))?;
                let range_key = if item["wavelength_range"].is_badvalue() {
                    "range"
                } else {
                    "wavelength_range"
                };
                let rline = line_of(text, range_key, 0).max(line);
                let range_text = scalar(&item[range_key]).ok_or_else(|| {
                    Error::parse(
                        file,
                        line,
                        format!("DATA item {}: field 'wavelength_range' missing; expected two wavelengths in µm", i + 1),
                    )
                })?;
                let r = numbers(file, rline, "wavelength_range", &range_text)?;
                if r.len() != 2 {
                    return Err(Error::parse(
                        file,
                        rline,
                        format!("field 'wavelength_range': '{range_text}'; expected two wavelengths in µm"),
                    ));
                }
                let cline = line_of(text, "coefficients", 0).max(line);
                let ctext = scalar(&item["coefficients"]).ok_or_else(|| {
                    Error::parse(
                        file,
                        line,
                        format!("DATA item {}: field 'coefficients' missing", i + 1),
                    )
                })?;
                let c = numbers(file, cline, "coefficients", &ctext)?;
                let f = Formula::new(kind, c, [r[0], r[1]])
                    .map_err(|e| Error::parse(file, cline, e.to_string()))?;
                Some(Source::Formula(f))
            }
            "tabulated" if tail == "n" || tail == "nk" => {
                Some(Source::Table(tabulated(file, text, item, i, line)?))
            }
            "tabulated" if tail == "k" => None,
            _ => {
                return Err(Error::parse(
                    file,
                    line,
                    format!("field 'type': '{ty}'; expected 'formula 1' … 'formula 9' or 'tabulated n', 'tabulated nk', 'tabulated k'"),
                ))
            }
        };
        if chosen.is_none() {
            if let Some(s) = parsed {
                chosen = Some((s, ty.to_string()));
            }
        }
    }
    let (source, data_type) = chosen.ok_or_else(|| {
        Error::parse(
            file,
            line_of(text, "DATA", 0),
            "field 'DATA' has no item giving n; expected a 'formula N' or 'tabulated n'/'tabulated nk' item",
        )
    })?;
    let specs = &doc["SPECS"];
    let props = &doc["PROPERTIES"];
    let pick = |key: &str| -> Result<Option<f64>> {
        match optional_number(file, text, specs, key)? {
            Some(v) => Ok(Some(v)),
            None => optional_number(file, text, props, key),
        }
    };
    let glass_code = [specs, props]
        .iter()
        .find_map(|h| scalar(&h["glass_code"]))
        .filter(|s| !s.is_empty());
    Ok(RiiEntry {
        source,
        data_type,
        n_absolute: optional_bool(file, text, specs, "n_absolute")?,
        wavelength_vacuum: optional_bool(file, text, specs, "wavelength_vacuum")?,
        catalogue_n_d: pick("nd")?,
        catalogue_v_d: pick("Vd")?,
        glass_code,
        references: doc["REFERENCES"].as_str().map(|s| s.trim().to_string()),
    })
}

fn tabulated(file: &str, text: &str, item: &Yaml, i: usize, line: usize) -> Result<Observations> {
    let block = item["data"].as_str().ok_or_else(|| {
        Error::parse(
            file,
            line,
            format!(
                "DATA item {}: field 'data' missing; expected rows 'λ_µm n [k]'",
                i + 1
            ),
        )
    })?;
    let first = line_of(text, "data", 0) + 1;
    let mut l = Vec::new();
    let mut n = Vec::new();
    for (j, row) in block.lines().enumerate() {
        let row_line = first + j;
        if row.trim().is_empty() {
            continue;
        }
        let v = numbers(file, row_line, "data", row)?;
        if v.len() < 2 {
            return Err(Error::parse(
                file,
                row_line,
                format!("field 'data': '{}'; expected 'λ_µm n [k]'", row.trim()),
            ));
        }
        let lambda_nm = v[0] * 1e3;
        if let Some(&prev) = l.last() {
            if lambda_nm <= prev {
                return Err(Error::parse(
                    file,
                    row_line,
                    format!("field 'data': wavelength {} µm after {} µm; expected strictly increasing wavelengths", v[0], prev * 1e-3),
                ));
            }
        }
        if !(v[1] >= 1.0) {
            return Err(Error::parse(
                file,
                row_line,
                format!("field 'data': n = {} at {} µm; expected n ≥ 1 (lumifit fits transparent dielectrics)", v[1], v[0]),
            ));
        }
        l.push(lambda_nm);
        n.push(v[1]);
    }
    Observations::new(l, n, None, true, file)
}

/// Reads a refractiveindex.info YAML file.
pub fn read_rii_yaml(path: &std::path::Path) -> Result<RiiEntry> {
    let (bytes, source) = super::read_input(path)?;
    parse_rii_yaml(&bytes, &source)
}

/// Parses a CSV `wavelength_nm,n[,std]` of measurements.
pub fn parse_n_csv(bytes: &[u8], file: &str) -> Result<Observations> {
    let t = crate::table::parse_numeric_csv(bytes, file)?;
    let col = |name: &str| t.column_index(name);
    let (li, ni) = match (col("wavelength_nm"), col("n")) {
        (Some(a), Some(b)) => (a, b),
        _ => {
            return Err(Error::parse(
                file,
                1,
                format!(
                    "header '{}'; expected columns wavelength_nm,n and optionally std",
                    t.header.join(",")
                ),
            ))
        }
    };
    let si = col("std");
    let rows = t.n_rows();
    for r in 0..rows {
        let line = t.lines[r];
        let l = t.columns[li][r];
        if !(l > 0.0) {
            return Err(Error::parse(
                file,
                line,
                format!("field 'wavelength_nm': {l}; expected a positive wavelength in nm"),
            ));
        }
        if r > 0 && l <= t.columns[li][r - 1] {
            return Err(Error::parse(
                file,
                line,
                format!(
                    "field 'wavelength_nm': {l} after {}; expected strictly increasing wavelengths",
                    t.columns[li][r - 1]
                ),
            ));
        }
        let n = t.columns[ni][r];
        if !(n >= 1.0) {
            return Err(Error::parse(
                file,
                line,
                format!("field 'n': {n}; expected a refractive index ≥ 1"),
            ));
        }
        if let Some(s) = si {
            let v = t.columns[s][r];
            if !(v > 0.0) {
                return Err(Error::parse(
                    file,
                    line,
                    format!("field 'std': {v}; expected a positive standard deviation"),
                ));
            }
        }
    }
    Observations::new(
        t.columns[li].clone(),
        t.columns[ni].clone(),
        si.map(|s| t.columns[s].clone()),
        true,
        file,
    )
}

/// Reads a CSV of measurements.
pub fn read_n_csv(path: &std::path::Path) -> Result<Observations> {
    let (bytes, source) = super::read_input(path)?;
    parse_n_csv(&bytes, &source)
}

#[cfg(test)]
mod tests {
    use super::*;

    const BK7: &str = "DATA:\n  - type: formula 2\n    wavelength_range: 0.3 2.5\n    coefficients: 0 1.03961212 0.00600069867 0.231792344 0.0200179144 1.01046945 103.560653\nPROPERTIES:\n    nd: 1.5168\n    Vd: 64.17\n    glass_code: 517642.251\n";

    #[test]
    fn a_formula_entry_reads_with_its_catalogue_numbers() {
        let e = parse_rii_yaml(BK7.as_bytes(), "bk7.yml").unwrap();
        assert_eq!(e.catalogue_n_d, Some(1.5168));
        assert_eq!(e.glass_code.as_deref(), Some("517642.251"));
        assert!(matches!(e.source, Source::Formula(_)));
    }

    #[test]
    fn unknown_formula_and_missing_data_name_the_field_and_line() {
        let bad = BK7.replace("formula 2", "formula 12");
        let msg = parse_rii_yaml(bad.as_bytes(), "x.yml")
            .unwrap_err()
            .to_string();
        assert!(
            msg.contains("x.yml: line 2") && msg.contains("type"),
            "{msg}"
        );
        let msg = parse_rii_yaml(b"REFERENCES: none\n", "y.yml")
            .unwrap_err()
            .to_string();
        assert!(msg.contains("y.yml") && msg.contains("DATA"), "{msg}");
    }

    #[test]
    fn csv_with_decreasing_wavelengths_is_refused_with_its_line() {
        let msg = parse_n_csv(b"wavelength_nm,n\n500,1.5\n400,1.51\n", "m.csv")
            .unwrap_err()
            .to_string();
        assert!(
            msg.contains("m.csv: line 3") && msg.contains("increasing"),
            "{msg}"
        );
        let msg = parse_n_csv(b"wavelength_nm,n\n500,0.5\n", "m.csv")
            .unwrap_err()
            .to_string();
        assert!(msg.contains("n ≥ 1") || msg.contains("≥ 1"), "{msg}");
    }
}
