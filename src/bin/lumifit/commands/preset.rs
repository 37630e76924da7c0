//! `lumifit preset …`: thin wrappers over [`lumifit::preset`].

use std::path::Path;

/// `lumifit preset validate FILE.json`: reads `path` (`-` for standard input) as a preset and
/// checks it against the schema.
///
/// On success returns `{"file", "schema", "name", "valid": true, "sections": [...]}`. On failure
/// the error names the file and, for a schema violation, each violation as JSON pointer and
/// message.
pub fn validate(path: &Path) -> anyhow::Result<serde_json::Value> {
    let preset = lumifit::preset::read_preset(path)?;
    let file = if path.as_os_str() == "-" {
        "<stdin>".to_string()
    } else {
        path.display().to_string()
    };
    Ok(serde_json::json!({
        "file": file,
        "schema": preset.schema(),
        "name": preset.name(),
        "valid": true,
        "sections": preset.sections(),
    }))
}
