//! The `photometric` section of a `lumifit.light/1` preset: the full candela grid, the flux, the
//! emitter rectangle and the frame, so that a renderer can shade the light as lumifit does
//! (`docs/photometry.md`). The source file's SHA-256 is in the preset's provenance.
//!
//! Fields (units in the names): `format`, `version`, `photometric_type` (`A`/`B`/`C`),
//! `symmetry`, `horizontal_deg`, `vertical_deg`, `candela_cd` (one row per horizontal angle, the
//! full circle after symmetry expansion for Type C), `flux_lm` (integrated from the grid),
//! `lamp_flux_lm` (null: absolute photometry), `max_cd`, `emitter_rect_m` ([W along C0, H along
//! C90]), `frame` (a sentence), `tilt_factor_applied`.

use serde_json::{json, Value};

use super::OpenSection;
use crate::error::{Error, Result};
use crate::photometry::{summary, CandelaGrid, PhotometricFile, PhotometricType};

/// The section for `file` shaded as a `width_m` × `height_m` rectangle.
pub fn photometric_section(
    file: &PhotometricFile,
    width_m: f64,
    height_m: f64,
) -> Result<OpenSection> {
    if !(width_m > 0.0 && height_m > 0.0 && width_m.is_finite() && height_m.is_finite()) {
        return Err(Error::invalid(
            "--rect",
            format!("{width_m},{height_m}: expected two positive sizes in m"),
        ));
    }
    let p = &file.photometry;
    let g = &p.grid;
    let s = summary(p);
    crate::error::ensure_finite(
        "photometric section",
        "candela grid",
        &[s.flux_lm, s.max_cd],
    )?;
    let nv = g.nv();
    let rows: Vec<Value> = (0..g.h_deg.len())
        .map(|i| json!(g.cd[i * nv..(i + 1) * nv]))
        .collect();
    let v = json!({
        "format": file.format,
        "version": file.version,
        "photometric_type": g.kind,
        "symmetry": p.symmetry,
        "horizontal_deg": g.h_deg,
        "vertical_deg": g.v_deg,
        "candela_cd": rows,
        "flux_lm": s.flux_lm,
        "lamp_flux_lm": p.lamp_flux_lm,
        "max_cd": s.max_cd,
        "emitter_rect_m": [width_m, height_m],
        "frame": "gamma = 0 along the emitting normal; C = 0 along u (the part of up perpendicular to the normal), C = 90 along v = normal × u; each point of the rectangle radiates I/A",
        "tilt_factor_applied": p.tilt_applied.1,
    });
    match v {
        Value::Object(m) => Ok(m),
        _ => Err(Error::invalid("photometric section", "not a JSON object")),
    }
}

/// The candela grid of a section written by [`photometric_section`] (for round trips and for
/// consumers that shade from the preset).
pub fn grid_from_section(section: &OpenSection, file: &str) -> Result<CandelaGrid> {
    let bad = |what: &str| Error::SchemaViolation {
        file: file.to_string(),
        details: format!("  /photometric/{what}: missing or not the expected type"),
    };
    let nums = |key: &str| -> Result<Vec<f64>> {
        section
            .get(key)
            .and_then(Value::as_array)
            .ok_or_else(|| bad(key))?
            .iter()
            .map(|x| x.as_f64().ok_or_else(|| bad(key)))
            .collect()
    };
    let kind = match section.get("photometric_type").and_then(Value::as_str) {
        Some("A") => PhotometricType::A,
        Some("B") => PhotometricType::B,
        Some("C") => PhotometricType::C,
        _ => return Err(bad("photometric_type")),
    };
    let h = nums("horizontal_deg")?;
    let v = nums("vertical_deg")?;
    let rows = section
        .get("candela_cd")
        .and_then(Value::as_array)
        .ok_or_else(|| bad("candela_cd"))?;
    let mut cd = Vec::with_capacity(h.len() * v.len());
    for r in rows {
        for x in r.as_array().ok_or_else(|| bad("candela_cd"))? {
            cd.push(x.as_f64().ok_or_else(|| bad("candela_cd"))?);
        }
    }
    CandelaGrid::new(kind, h, v, cd).map_err(|e| Error::SchemaViolation {
        file: file.to_string(),
        details: format!("  /photometric: {e}"),
    })
}
