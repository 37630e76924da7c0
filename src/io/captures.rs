//! `captures.csv` of `lvf transmission`: one photo per line, `image,filter`.
//!
//! Paths are relative to the CSV's folder; `filter` is a code of the gel table, or `none`/empty
//! for the open LVF. A header row starting with `image` is optional, `#` comments and blank lines
//! are skipped, a byte-order mark and CRLF line ends are accepted ([`crate::table::as_text`]).
//! Every image must be an existing file (a folder is reported as a folder), so all inputs are
//! known — and can be protected from being overwritten — before any photo is decoded.

use std::path::{Path, PathBuf};

use crate::error::{Error, Result};

/// One line of a captures CSV.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CaptureLine {
    /// 1-based line number in the CSV.
    pub line: usize,
    /// The photo, resolved against the CSV's folder.
    pub image: PathBuf,
    /// Gel code, `None` for the open LVF.
    pub filter: Option<String>,
}

const EXPECTED: &str = "a CSV 'image,filter' (one photo per line)";

/// Parses a captures CSV; images are resolved against `base` and must be existing files.
///
/// # Errors
/// [`Error::Parse`] naming `source` and the line: not text, an empty image path, an image that
/// does not exist or is a directory, no captures at all.
pub fn parse_captures(bytes: &[u8], source: &str, base: &Path) -> Result<Vec<CaptureLine>> {
    let text = crate::table::as_text(bytes, source, EXPECTED)?;
    let mut out = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let line = raw.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let mut cells = line.split(',').map(|c| c.trim().trim_matches('"'));
        let image = cells.next().unwrap_or("");
        let filter = cells.next().unwrap_or("");
        if out.is_empty() && image.eq_ignore_ascii_case("image") {
            continue;
        }
        if image.is_empty() {
            return Err(Error::parse(
                source,
                i + 1,
                "empty image path; expected 'image,filter'",
            ));
        }
        let path = base.join(image);
        if path.is_dir() {
            return Err(Error::parse(
                source,
                i + 1,
                format!(
                    "image {} is a directory; expected an image file",
                    path.display()
                ),
            ));
        }
        if !path.is_file() {
            return Err(Error::parse(
                source,
                i + 1,
                format!("image {} does not exist", path.display()),
            ));
        }
        let filter = if filter.is_empty() || filter.eq_ignore_ascii_case("none") {
            None
        } else {
            Some(filter.to_string())
        };
        out.push(CaptureLine {
            line: i + 1,
            image: path,
            filter,
        });
    }
    if out.is_empty() {
        return Err(Error::parse(
            source,
            0,
            "no captures; expected lines 'image,filter'",
        ));
    }
    Ok(out)
}

/// Reads a captures CSV (see [`parse_captures`]); images are relative to the CSV's folder.
///
/// # Errors
/// [`Error::Io`] naming the file when it cannot be read; the errors of [`parse_captures`].
pub fn read_captures(path: &Path) -> Result<Vec<CaptureLine>> {
    let (bytes, source) = super::read_input(path)?;
    parse_captures(&bytes, &source, path.parent().unwrap_or(Path::new(".")))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_bom_header_comments_and_crlf_are_accepted() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("a.tif"), b"x").unwrap();
        std::fs::write(dir.path().join("b.tif"), b"x").unwrap();
        let csv = b"\xEF\xBB\xBFimage,filter\r\n# open\r\na.tif,none\r\nb.tif,L101\r\n";
        let lines = parse_captures(csv, "c.csv", dir.path()).unwrap();
        assert_eq!(lines.len(), 2);
        assert_eq!(lines[0].filter, None);
        assert_eq!(lines[1].filter.as_deref(), Some("L101"));
        assert_eq!(lines[1].line, 4);
    }

    #[test]
    fn a_directory_named_as_an_image_is_reported_as_a_directory() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::create_dir(dir.path().join("sub")).unwrap();
        let e = parse_captures(b"sub,none\n", "c.csv", dir.path())
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("c.csv: line 1") && e.contains("is a directory"),
            "{e}"
        );
        let e = parse_captures(b"missing.tif,none\n", "c.csv", dir.path())
            .unwrap_err()
            .to_string();
        assert!(e.contains("does not exist"), "{e}");
    }
}
