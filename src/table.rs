//! A numeric CSV table: a header row, then rows of finite numbers.
//!
//! This is the one parser behind every tabular input of lumifit (spectra, CMFs, illuminants,
//! camera sensitivities) and behind the reference tables embedded from `calib/`, which is why it
//! lives at layer 0. Lines starting with `#` are comments; blank lines are skipped. Every error
//! names the source, the 1-based line and what was expected.

use crate::error::{Error, Result};

/// A parsed numeric table: column names and column-major values.
#[derive(Debug, Clone, PartialEq)]
pub struct NumericTable {
    /// Where the table came from (file name, `<stdin>`, `calib/...`), used in error messages.
    pub source: String,
    /// Column names from the header row, trimmed.
    pub header: Vec<String>,
    /// One vector per column, all of the same length.
    pub columns: Vec<Vec<f64>>,
    /// 1-based line number of each data row in the source, for error messages downstream.
    pub lines: Vec<usize>,
}

impl NumericTable {
    /// Number of data rows.
    pub fn n_rows(&self) -> usize {
        self.lines.len()
    }

    /// Index of the column named `name` (case-insensitive).
    pub fn column_index(&self, name: &str) -> Option<usize> {
        self.header
            .iter()
            .position(|h| h.eq_ignore_ascii_case(name))
    }
}

/// The UTF-8 byte-order mark that spreadsheet programs (Excel) put at the start of a CSV.
pub const UTF8_BOM: &[u8] = b"\xEF\xBB\xBF";

/// `bytes` without a leading UTF-8 byte-order mark.
pub fn strip_bom(bytes: &[u8]) -> &[u8] {
    bytes.strip_prefix(UTF8_BOM).unwrap_or(bytes)
}

/// The bytes as UTF-8 text without NUL bytes (a leading byte-order mark removed), or a parse
/// error naming the line where binary content starts and saying what was `expected` (e.g. "CSV
/// text with a header row"). Every text reader of lumifit goes through here, so BOM and CRLF
/// files are read alike everywhere.
pub fn as_text<'a>(bytes: &'a [u8], source: &str, expected: &str) -> Result<&'a str> {
    let bytes = strip_bom(bytes);
    let text = std::str::from_utf8(bytes).map_err(|e| {
        let line = 1 + bytes[..e.valid_up_to()]
            .iter()
            .filter(|&&b| b == b'\n')
            .count();
        Error::parse(
            source,
            line,
            format!("not a text file (invalid UTF-8); expected {expected}"),
        )
    })?;
    if let Some(pos) = text.find('\0') {
        let line = 1 + text[..pos].matches('\n').count();
        return Err(Error::parse(
            source,
            line,
            format!("not a text file (contains NUL bytes); expected {expected}"),
        ));
    }
    Ok(text)
}

/// Parses CSV text into a [`NumericTable`]. `source` names the input in errors.
pub fn parse_numeric_csv(bytes: &[u8], source: &str) -> Result<NumericTable> {
    if bytes.is_empty() || bytes.iter().all(|b| b.is_ascii_whitespace()) {
        return Err(Error::parse(
            source,
            0,
            "file is empty; expected a header row such as 'wavelength_nm,value' and data rows",
        ));
    }
    let text = as_text(bytes, source, "CSV text with a header row")?;
    let mut header: Option<Vec<String>> = None;
    let mut columns: Vec<Vec<f64>> = Vec::new();
    let mut lines = Vec::new();
    for (idx, raw) in text.lines().enumerate() {
        let line_no = idx + 1;
        let line = raw.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let fields: Vec<&str> = line
            .split(',')
            .map(|f| f.trim().trim_matches('"'))
            .collect();
        match &header {
            None => {
                if fields.iter().all(|f| f.parse::<f64>().is_ok()) {
                    return Err(Error::parse(
                        source,
                        line_no,
                        format!(
                            "expected a header row naming the columns (e.g. 'wavelength_nm,value'), found numbers '{line}'"
                        ),
                    ));
                }
                if fields.len() < 2 || fields.iter().any(|f| f.is_empty()) {
                    return Err(Error::parse(
                        source,
                        line_no,
                        format!(
                            "expected a header row with at least two named columns, found '{line}'"
                        ),
                    ));
                }
                for (i, f) in fields.iter().enumerate() {
                    if let Some(j) = fields[..i].iter().position(|g| g.eq_ignore_ascii_case(f)) {
                        return Err(Error::parse(
                            source,
                            line_no,
                            format!(
                                "column '{f}' appears twice (columns {} and {}); expected unique column names",
                                j + 1,
                                i + 1
                            ),
                        ));
                    }
                }
                columns = vec![Vec::new(); fields.len()];
                header = Some(fields.iter().map(|s| s.to_string()).collect());
            }
            Some(h) => {
                if fields.len() != h.len() {
                    return Err(Error::parse(
                        source,
                        line_no,
                        format!(
                            "expected {} columns ({}), found {}",
                            h.len(),
                            h.join(","),
                            fields.len()
                        ),
                    ));
                }
                for (c, f) in fields.iter().enumerate() {
                    let v: f64 = f.parse().map_err(|_| {
                        Error::parse(
                            source,
                            line_no,
                            format!("column '{}': expected a number, found '{f}'", h[c]),
                        )
                    })?;
                    if !v.is_finite() {
                        return Err(Error::parse(
                            source,
                            line_no,
                            format!("column '{}': expected a finite number, found '{f}'", h[c]),
                        ));
                    }
                    columns[c].push(v);
                }
                lines.push(line_no);
            }
        }
    }
    let header = header.ok_or_else(|| {
        Error::parse(
            source,
            0,
            "no header row; expected 'wavelength_nm,value' and data rows",
        )
    })?;
    if lines.is_empty() {
        return Err(Error::parse(
            source,
            0,
            "header but no data rows; expected at least one row of numbers",
        ));
    }
    Ok(NumericTable {
        source: source.to_string(),
        header,
        columns,
        lines,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_a_table_with_comments_and_blank_lines() {
        let t =
            parse_numeric_csv(b"# c\nwavelength_nm,value\n\n400,1.5\n410,2\n", "t.csv").unwrap();
        assert_eq!(t.header, vec!["wavelength_nm", "value"]);
        assert_eq!(t.columns[1], vec![1.5, 2.0]);
        assert_eq!(t.lines, vec![4, 5]);
    }

    #[test]
    fn a_missing_column_names_the_line() {
        let e = parse_numeric_csv(b"wavelength_nm,value\n400,1\n410\n", "t.csv").unwrap_err();
        assert!(e.to_string().contains("t.csv: line 3"), "{e}");
    }

    #[test]
    fn a_byte_order_mark_and_crlf_lines_are_read_like_plain_text() {
        let t =
            parse_numeric_csv(b"\xEF\xBB\xBFwavelength_nm,value\r\n400,1\r\n", "t.csv").unwrap();
        assert_eq!(t.header, vec!["wavelength_nm", "value"]);
        assert_eq!(t.columns[1], vec![1.0]);
    }

    #[test]
    fn duplicated_column_names_are_refused_with_the_line() {
        let e = parse_numeric_csv(b"time_s,r,r,b\n0,1,2,3\n", "h.csv").unwrap_err();
        let s = e.to_string();
        assert!(
            s.contains("h.csv: line 1") && s.contains("'r' appears twice"),
            "{s}"
        );
    }

    #[test]
    fn infinity_is_refused_like_nan() {
        let e = parse_numeric_csv(b"wavelength_nm,value\n400,inf\n", "t.csv").unwrap_err();
        assert!(e.to_string().contains("finite"), "{e}");
    }

    #[test]
    fn nan_and_binary_are_rejected() {
        let e = parse_numeric_csv(b"wavelength_nm,value\n400,nan\n", "t.csv").unwrap_err();
        assert!(e.to_string().contains("line 2") && e.to_string().contains("finite"));
        let e = parse_numeric_csv(&[0x89, 0x50, 0x4e, 0x47, 0xff, 0x00], "b.png").unwrap_err();
        assert!(e.to_string().contains("not a text file"));
    }
}
