//! Provenance: which tool, which command, which inputs (with SHA-256), when, how good the fit.

use std::path::Path;

use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};

use crate::error::{Error, Result};

/// How a preset was produced.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Provenance {
    /// Program that wrote the preset (`"lumifit"`).
    pub tool: String,
    /// Version of that program.
    pub tool_version: String,
    /// Command line (or pipeline name) that produced the preset.
    pub command: String,
    /// Creation time, RFC 3339 in UTC (`2025-01-31T12:00:00Z`).
    pub created_utc: String,
    /// Every input, with the SHA-256 of its bytes.
    pub inputs: Vec<InputFile>,
    /// Fit statistics from the producing pipeline (a JSON object whose content that pipeline
    /// defines: residuals, termination reason …).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fit_quality: Option<serde_json::Value>,
}

/// One input file of a preset.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct InputFile {
    /// Path as given on the command line.
    pub path: String,
    /// SHA-256 of the file's bytes, 64 lower-case hexadecimal digits.
    pub sha256: String,
}

impl Provenance {
    /// Provenance for this lumifit (`tool_version` = the crate version), created now, with the
    /// SHA-256 of each input's bytes.
    pub fn new<P: AsRef<Path>>(command: &str, inputs: &[(P, &[u8])]) -> Self {
        Provenance {
            tool: "lumifit".to_string(),
            tool_version: env!("CARGO_PKG_VERSION").to_string(),
            command: command.to_string(),
            created_utc: chrono::Utc::now().to_rfc3339_opts(chrono::SecondsFormat::Secs, true),
            inputs: inputs
                .iter()
                .map(|(path, bytes)| InputFile::new(path, bytes))
                .collect(),
            fit_quality: None,
        }
    }

    /// The same provenance with `fit_quality` set (must be a JSON object to validate).
    pub fn with_fit_quality(mut self, fit_quality: serde_json::Value) -> Self {
        self.fit_quality = Some(fit_quality);
        self
    }
}

impl InputFile {
    /// An input whose bytes are already in memory.
    pub fn new(path: impl AsRef<Path>, bytes: &[u8]) -> Self {
        InputFile {
            path: path.as_ref().display().to_string(),
            sha256: sha256_hex(bytes),
        }
    }

    /// Reads `path` and hashes its bytes.
    pub fn from_file(path: impl AsRef<Path>) -> Result<Self> {
        let path = path.as_ref();
        let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
        Ok(InputFile::new(path, &bytes))
    }
}

/// SHA-256 of `bytes` as 64 lower-case hexadecimal digits.
pub fn sha256_hex(bytes: &[u8]) -> String {
    let digest = Sha256::digest(bytes);
    let mut hex = String::with_capacity(64);
    for byte in digest {
        hex.push_str(&format!("{byte:02x}"));
    }
    hex
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sha256_hex_matches_the_published_test_vector_for_abc() {
        assert_eq!(
            sha256_hex(b"abc"),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
        );
    }

    #[test]
    fn provenance_new_records_crate_version_utc_time_and_input_hashes() {
        let p = Provenance::new("lumifit test", &[("a.csv", b"abc".as_slice())]);
        assert_eq!(p.tool, "lumifit");
        assert_eq!(p.tool_version, env!("CARGO_PKG_VERSION"));
        assert!(p.created_utc.ends_with('Z'));
        assert!(chrono::DateTime::parse_from_rfc3339(&p.created_utc).is_ok());
        assert_eq!(p.inputs[0].path, "a.csv");
        assert_eq!(p.inputs[0].sha256, sha256_hex(b"abc"));
    }
}
