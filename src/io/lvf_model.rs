//! The LVF as `synth lvf-capture --lvf` reads it: a synthetic truth JSON (`lumifit.lvf-truth/1`
//! from `synth lvf-hg --truth`, `lumifit.lvf-capture-truth/1` from `synth lvf-capture`) or a
//! wavelength calibration (`lumifit.lvf/1` from `lvf calibrate`, which holds no image size).
//!
//! The truth fields read back are one serde type ([`TruthFields`]), so a rename in the writer
//! fails loudly here instead of returning nothing. A byte-order mark is accepted.

use std::path::Path;

use serde::Deserialize;

use crate::error::{Error, Result};
use crate::lvf::{Axis, LvfGeometry};

/// The LVF's geometry as the capture synthesiser needs it.
#[derive(Debug, Clone, PartialEq)]
pub struct LvfModel {
    /// Filter axis.
    pub axis: Axis,
    /// Map coefficients λ = c0 + c1·px (+ c2·px²).
    pub map: Vec<f64>,
    /// Passband FWHM (nm).
    pub fwhm_nm: f64,
    /// Image size of a synthetic truth; `None` for a calibration.
    pub size: Option<(usize, usize)>,
}

/// The `map` object of a truth JSON.
#[derive(Debug, Deserialize)]
struct TruthMap {
    coefficients: Vec<f64>,
}

/// The fields of a truth JSON that describe the LVF (other fields are ignored).
#[derive(Debug, Deserialize)]
struct TruthFields {
    axis: String,
    map: TruthMap,
    fwhm_nm: f64,
    size: [usize; 2],
}

/// Parses an LVF truth or calibration JSON (see the module docs).
///
/// # Errors
/// [`Error::Parse`] naming `source` (and the line for malformed JSON or a missing field).
pub fn parse_lvf_model(bytes: &[u8], source: &str) -> Result<LvfModel> {
    let text = crate::table::as_text(bytes, source, "an lvf.json or an LVF truth JSON")?;
    let v: serde_json::Value = serde_json::from_str(text).map_err(|e| {
        Error::parse(
            source,
            e.line(),
            format!("not JSON: {e}; expected an lvf.json or an LVF truth JSON"),
        )
    })?;
    let schema = v.get("schema").and_then(|s| s.as_str()).unwrap_or("");
    match schema {
        "lumifit.lvf/1" => {
            let g = LvfGeometry::from_json(text.as_bytes(), source)?;
            Ok(LvfModel {
                axis: g.axis,
                map: g.map,
                fwhm_nm: g.fwhm_nm,
                size: None,
            })
        }
        "lumifit.lvf-truth/1" | "lumifit.lvf-capture-truth/1" => {
            let t: TruthFields = serde_json::from_value(v).map_err(|e| {
                Error::parse(
                    source,
                    0,
                    format!("{e}; expected axis, map.coefficients, fwhm_nm and size [width, height]"),
                )
            })?;
            let bad = |field: &str, expected: &str| {
                Error::parse(source, 0, format!("field '{field}': expected {expected}"))
            };
            let axis = match t.axis.as_str() {
                "x" => Axis::X,
                "y" => Axis::Y,
                _ => return Err(bad("axis", "\"x\" or \"y\"")),
            };
            if t.map.coefficients.len() < 2 || t.map.coefficients.iter().any(|c| !c.is_finite()) {
                return Err(bad("map.coefficients", "at least 2 finite numbers"));
            }
            if !(t.fwhm_nm.is_finite() && t.fwhm_nm > 0.0) {
                return Err(bad("fwhm_nm", "a positive number"));
            }
            Ok(LvfModel {
                axis,
                map: t.map.coefficients,
                fwhm_nm: t.fwhm_nm,
                size: Some((t.size[0], t.size[1])),
            })
        }
        other => Err(Error::parse(
            source,
            0,
            format!(
                "field 'schema' is '{other}'; expected 'lumifit.lvf/1' (lvf calibrate) or 'lumifit.lvf-truth/1' (synth lvf-hg --truth)"
            ),
        )),
    }
}

/// Reads an LVF truth or calibration JSON file (see [`parse_lvf_model`]).
///
/// # Errors
/// [`Error::Io`] naming the file; the errors of [`parse_lvf_model`].
pub fn read_lvf_model(path: &Path) -> Result<LvfModel> {
    let (bytes, source) = super::read_input(path)?;
    parse_lvf_model(&bytes, &source)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_truth_with_a_bom_is_read_and_a_missing_size_is_named() {
        let t = "\u{feff}{\"schema\":\"lumifit.lvf-truth/1\",\"axis\":\"x\",\"map\":{\"coefficients\":[380,0.3]},\"fwhm_nm\":25,\"size\":[1200,160]}";
        let m = parse_lvf_model(t.as_bytes(), "t.json").unwrap();
        assert_eq!(m.axis, Axis::X);
        assert_eq!(m.size, Some((1200, 160)));
        let e = parse_lvf_model(
            br#"{"schema":"lumifit.lvf-truth/1","axis":"x","map":{"coefficients":[380,0.3]},"fwhm_nm":25}"#,
            "t.json",
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("t.json") && e.contains("size"), "{e}");
        let e = parse_lvf_model(br#"{"schema":"other"}"#, "o.json")
            .unwrap_err()
            .to_string();
        assert!(e.contains("lumifit.lvf/1"), "{e}");
    }
}
