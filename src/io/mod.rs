//! File input and output: every read and write of the file system goes through here.
//!
//! Outputs are written atomically ([`atomic_write`]: a temporary file beside the target, then a
//! rename), so a failed run never leaves a half-written or clobbered file. Inputs are never
//! modified.

use std::io::Write;
use std::path::{Path, PathBuf};

use crate::error::{Error, Result};

pub mod afterimage_csv;
pub mod camera;
pub mod captures;
pub mod eulumdat;
pub mod exif;
pub mod filters;
pub mod flags;
pub mod hdr_image;
pub mod ies;
pub mod image;
pub mod lvf_model;
pub mod maps;
pub mod output;
pub mod phos_formats;
pub mod raw;
pub mod receivers;
pub mod refractive_index;
pub mod series;
pub mod sources;
pub mod spectrum_csv;
pub mod tiles;

pub use output::Outputs;

/// Writes `bytes` to `path` atomically: a temporary file in the same directory, flushed and
/// synced, then renamed over the target.
pub fn atomic_write(path: &Path, bytes: &[u8]) -> Result<()> {
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    if !dir.is_dir() {
        return Err(Error::io(
            path,
            std::io::Error::new(
                std::io::ErrorKind::NotFound,
                format!("output directory '{}' does not exist", dir.display()),
            ),
        ));
    }
    let file_name = path
        .file_name()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "output".into());
    let tmp = dir.join(format!(".{file_name}.{}.tmp", std::process::id()));
    let result = (|| -> std::io::Result<()> {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    if let Err(e) = result {
        let _ = std::fs::remove_file(&tmp);
        return Err(Error::io(path, e));
    }
    Ok(())
}

/// Reads a whole file (or standard input when `path` is `-`), naming the file on error.
pub fn read_input(path: &Path) -> Result<(Vec<u8>, String)> {
    if path.as_os_str() == "-" {
        let mut buf = Vec::new();
        std::io::Read::read_to_end(&mut std::io::stdin(), &mut buf)
            .map_err(|e| Error::io("<stdin>", e))?;
        return Ok((buf, "<stdin>".to_string()));
    }
    if path.is_dir() {
        return Err(Error::io(
            path,
            std::io::Error::new(
                std::io::ErrorKind::IsADirectory,
                "is a directory; expected a file",
            ),
        ));
    }
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    Ok((bytes, path.display().to_string()))
}

/// Parses JSON text (a leading byte-order mark removed) into `T`; errors name the source, the
/// line and the column serde reports, and what was expected.
pub fn parse_json<T: serde::de::DeserializeOwned>(bytes: &[u8], source: &str) -> Result<T> {
    let text = crate::table::as_text(bytes, source, "JSON text")?;
    serde_json::from_str(text)
        .map_err(|e| Error::parse(source, e.line(), format!("column {}: {e}", e.column())))
}

/// `value` as pretty-printed JSON followed by a newline (the form every summary and report file
/// is written in); `what` names it if serialising fails.
pub fn pretty_json_line<T: serde::Serialize>(value: &T, what: &str) -> Result<String> {
    pretty_json(value, what).map(|t| t + "\n")
}

/// `value` as pretty-printed JSON (no trailing newline); a serialisation failure is
/// [`crate::error::Error::Numerical`] naming `what`.
pub fn pretty_json<T: serde::Serialize + ?Sized>(value: &T, what: &str) -> Result<String> {
    serde_json::to_string_pretty(value).map_err(|e| crate::error::Error::Numerical {
        what: what.to_string(),
        reason: e.to_string(),
    })
}

/// Reads and parses a JSON file (or `-` for standard input) into `T` (see [`parse_json`]).
pub fn read_json<T: serde::de::DeserializeOwned>(path: &Path) -> Result<T> {
    let (bytes, source) = read_input(path)?;
    parse_json(&bytes, &source)
}

/// Reads an IES LM-63 or EULUMDAT file, told apart by content (an IES file has an `IES…`
/// version line or a `TILT=` line; anything else is read as EULUMDAT). `lamp_tilt_deg` applies
/// an IES TILT table at that lamp tilt (0 = as photometered).
pub fn read_photometric(
    path: &Path,
    lamp_tilt_deg: f64,
) -> Result<crate::photometry::PhotometricFile> {
    let (bytes, source) = read_input(path)?;
    let text = crate::table::as_text(&bytes, &source, "an IES or EULUMDAT photometric file")?;
    let first = text
        .lines()
        .next()
        .unwrap_or("")
        .trim_start()
        .to_ascii_uppercase();
    let is_ies = first.starts_with("IES")
        || text
            .lines()
            .take(500)
            .any(|l| l.trim_start().to_ascii_uppercase().starts_with("TILT="));
    if is_ies {
        let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
        let loader = move |name: &str| read_input(&dir.join(name));
        ies::parse_ies(&bytes, &source, &loader, lamp_tilt_deg)
    } else {
        eulumdat::parse_ldt(&bytes, &source)
    }
}
