//! Reading and writing preset files.

use std::path::Path;

use serde_json::Value;

use super::types::{LightPreset, MaterialPreset, Preset, PresetDocument};
use super::validate::validate_value;
use super::{LIGHT_SCHEMA, MATERIAL_SCHEMA};
use crate::error::{Error, Result};

/// Parses and validates a preset held in memory; `file` names the source in errors.
///
/// JSON syntax errors give [`Error::Parse`] with the line, and the column in the message; the rest
/// is [`validate_value`].
pub fn parse_preset(bytes: &[u8], file: &str) -> Result<Preset> {
    let text = crate::table::as_text(bytes, file, "a preset JSON file")?;
    let value: Value = serde_json::from_str(text).map_err(|e| {
        let text = e.to_string();
        let suffix = format!(" at line {} column {}", e.line(), e.column());
        let message = text.strip_suffix(&suffix).unwrap_or(&text);
        Error::parse(
            file,
            e.line(),
            format!("column {}: invalid JSON: {message}", e.column()),
        )
    })?;
    validate_value(&value, file)
}

/// Reads and validates a preset of either kind (`-` reads standard input).
pub fn read_preset(path: &Path) -> Result<Preset> {
    let (bytes, file) = crate::io::read_input(path)?;
    parse_preset(&bytes, &file)
}

/// Reads and validates a material preset; a light preset is an error naming `/schema`.
pub fn read_material(path: &Path) -> Result<MaterialPreset> {
    match read_preset(path)? {
        Preset::Material(m) => Ok(m),
        Preset::Light(l) => Err(wrong_kind(path, &l.schema, MATERIAL_SCHEMA)),
    }
}

/// Reads and validates a light preset; a material preset is an error naming `/schema`.
pub fn read_light(path: &Path) -> Result<LightPreset> {
    match read_preset(path)? {
        Preset::Light(l) => Ok(l),
        Preset::Material(m) => Err(wrong_kind(path, &m.schema, LIGHT_SCHEMA)),
    }
}

fn wrong_kind(path: &Path, found: &str, expected: &str) -> Error {
    Error::SchemaViolation {
        file: path.display().to_string(),
        details: format!("  /schema: found '{found}' but a '{expected}' preset was expected"),
    }
}

/// The preset as pretty JSON (with a final newline), after validating it as a reader would.
pub fn to_json_string<P: PresetDocument>(preset: &P) -> Result<String> {
    render(preset, "<preset>")
}

fn render<P: PresetDocument>(preset: &P, file: &str) -> Result<String> {
    let value = serde_json::to_value(preset).map_err(|e| Error::SchemaViolation {
        file: file.to_string(),
        details: format!("  (root): cannot be represented as JSON: {e}"),
    })?;
    validate_value(&value, file)?;
    let mut text = serde_json::to_string_pretty(preset).map_err(|e| Error::SchemaViolation {
        file: file.to_string(),
        details: format!("  (root): cannot be represented as JSON: {e}"),
    })?;
    text.push('\n');
    Ok(text)
}

/// Validates `preset` and writes it to `path` as pretty JSON, atomically.
///
/// An invalid preset ([`Error::SchemaViolation`] naming `path`) is not written, and neither is
/// anything when the directory is missing; an existing file at `path` is then left untouched.
pub fn write_preset<P: PresetDocument>(path: &Path, preset: &P) -> Result<()> {
    let text = render(preset, &path.display().to_string())?;
    crate::io::atomic_write(path, text.as_bytes())
}
