//! The `photometric` section of a `lumifit.light/1` preset: the full candela grid, the flux, the
//! emitter rectangle and the frame, so that a renderer can shade the light as lumifit does
//! (`docs/photometry.md`). The source file's SHA-256 is in the preset's provenance.
//!
//! Fields (units in the names): `format`, `version`, `photometric_type` (`A`/`B`/`C`),
//! `symmetry`, `horizontal_deg`, `vertical_deg`, `candela_cd` (one row per horizontal angle, the
//! full circle after symmetry expansion for Type C), `flux_lm` (integrated from the grid),
//! `lamp_flux_lm` (null: absolute photometry), `max_cd`, `emitter_rect_m` ([W along C0, H along
//! C90]), `frame` (a sentence), `tilt_factor_applied` — the serde type [`PhotometricSection`].

use serde::{Deserialize, Serialize};
use serde_json::Value;

use super::OpenSection;
use crate::error::{Error, Result};
use crate::photometry::{
    summary, CandelaGrid, FileFormat, PhotometricFile, PhotometricType, Symmetry,
};
#[cfg(test)]
use serde_json::json;

/// The frame sentence every section carries.
const FRAME: &str = "gamma = 0 along the emitting normal; C = 0 along u (the part of up perpendicular to the normal), C = 90 along v = normal × u; each point of the rectangle radiates I/A";

/// The `photometric` section: one type for the writer ([`photometric_section`]) and the reader
/// ([`grid_from_section`]), so a renamed field is an error naming it, never a silent miss.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PhotometricSection {
    /// Source file format.
    pub format: FileFormat,
    /// Source format version (`LM-63-2002`, `EULUMDAT` …).
    pub version: String,
    /// Goniometer system.
    pub photometric_type: PhotometricType,
    /// Symmetry the source declared.
    pub symmetry: Symmetry,
    /// Horizontal angles C (or H) in degrees.
    pub horizontal_deg: Vec<f64>,
    /// Vertical angles γ (or V) in degrees.
    pub vertical_deg: Vec<f64>,
    /// Candela, one row per horizontal angle (full circle after symmetry expansion for Type C).
    pub candela_cd: Vec<Vec<f64>>,
    /// Luminous flux integrated from the grid.
    pub flux_lm: f64,
    /// Declared lamp flux; `None` for absolute photometry.
    pub lamp_flux_lm: Option<f64>,
    /// Largest candela value.
    pub max_cd: f64,
    /// Emitter rectangle [W along C0, H along C90] in m.
    pub emitter_rect_m: [f64; 2],
    /// The frame convention, as a sentence.
    pub frame: String,
    /// TILT factor applied to the grid.
    pub tilt_factor_applied: f64,
    /// Further fields, kept as read.
    #[serde(flatten)]
    pub extra: OpenSection,
}

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
    let section = PhotometricSection {
        format: file.format,
        version: file.version.clone(),
        photometric_type: g.kind,
        symmetry: p.symmetry,
        horizontal_deg: g.h_deg.clone(),
        vertical_deg: g.v_deg.clone(),
        candela_cd: (0..g.h_deg.len())
            .map(|i| g.cd[i * nv..(i + 1) * nv].to_vec())
            .collect(),
        flux_lm: s.flux_lm,
        lamp_flux_lm: p.lamp_flux_lm,
        max_cd: s.max_cd,
        emitter_rect_m: [width_m, height_m],
        frame: FRAME.to_string(),
        tilt_factor_applied: p.tilt_applied.1,
        extra: OpenSection::new(),
    };
    match serde_json::to_value(&section) {
        Ok(Value::Object(m)) => Ok(m),
        _ => Err(Error::invalid("photometric section", "not a JSON object")),
    }
}

/// The typed section of a preset's `photometric` object; errors name the file and the field.
pub fn read_section(section: &OpenSection, file: &str) -> Result<PhotometricSection> {
    serde_json::from_value(Value::Object(section.clone())).map_err(|e| Error::SchemaViolation {
        file: file.to_string(),
        details: format!("  /photometric: {e}"),
    })
}

/// The candela grid of a section written by [`photometric_section`] (for round trips and for
/// consumers that shade from the preset).
pub fn grid_from_section(section: &OpenSection, file: &str) -> Result<CandelaGrid> {
    let s = read_section(section, file)?;
    let cd: Vec<f64> = s.candela_cd.into_iter().flatten().collect();
    CandelaGrid::new(s.photometric_type, s.horizontal_deg, s.vertical_deg, cd).map_err(|e| {
        Error::SchemaViolation {
            file: file.to_string(),
            details: format!("  /photometric: {e}"),
        }
    })
}

/// A photometric file rebuilt from a section (for the IES/EULUMDAT writers and the glTF
/// export of a preset): the grid, symmetry, lamp flux and a rectangular opening of the emitter
/// rectangle (length along C0 = W, width along C90 = H), no TILT (its factor is already in the
/// grid), `name` as the `[TEST]` keyword.
pub fn file_from_section(section: &OpenSection, file: &str, name: &str) -> Result<PhotometricFile> {
    use crate::photometry::{LampSet, LuminousOpening, OpeningShape, Photometry, Tilt};
    let s = read_section(section, file)?;
    let grid = grid_from_section(section, file)?;
    let [w, h] = s.emitter_rect_m;
    if !(w > 0.0 && h > 0.0 && w.is_finite() && h.is_finite()) {
        return Err(Error::SchemaViolation {
            file: file.to_string(),
            details: format!(
                "  /photometric/emitter_rect_m: [{w}, {h}]; expected two positive sizes in m"
            ),
        });
    }
    Ok(PhotometricFile {
        format: s.format,
        version: s.version,
        keywords: vec![("TEST".into(), format!("lumifit.light/1 preset '{name}'"))],
        lamps: vec![LampSet {
            count: 1,
            kind: String::new(),
            flux_lm: s.lamp_flux_lm.unwrap_or(-1.0),
            colour_temperature: String::new(),
            colour_rendering: String::new(),
            watts: 0.0,
        }],
        direct_ratios: Vec::new(),
        ldt_type_indicator: 0,
        input_watts: 0.0,
        notes: Vec::new(),
        photometry: Photometry {
            grid,
            symmetry: s.symmetry,
            lamp_flux_lm: s.lamp_flux_lm,
            declared_luminaire_flux_lm: None,
            declared_lor_percent: None,
            declared_dff_percent: None,
            opening: LuminousOpening {
                length_m: w,
                width_m: h,
                height_m: 0.0,
                shape: OpeningShape::Rectangular,
            },
            tilt: Tilt::None,
            tilt_applied: (0.0, 1.0),
        },
    })
}

#[cfg(test)]
mod section_tests {
    use super::*;

    fn section() -> OpenSection {
        let v = json!({
            "format": "ies", "version": "LM-63-2019", "photometric_type": "C",
            "symmetry": "none", "horizontal_deg": [0.0, 90.0, 180.0, 270.0],
            "vertical_deg": [0.0, 90.0], "candela_cd": [[100.0, 0.0], [100.0, 0.0], [100.0, 0.0], [100.0, 0.0]],
            "flux_lm": 150.0, "lamp_flux_lm": null, "max_cd": 100.0,
            "emitter_rect_m": [1.0, 1.0], "frame": FRAME, "tilt_factor_applied": 1.0
        });
        v.as_object().unwrap().clone()
    }

    #[test]
    fn a_section_reads_back_into_its_grid() {
        let g = grid_from_section(&section(), "l.json").unwrap();
        assert_eq!(g.h_deg.len(), 4);
        assert_eq!(g.cd[0], 100.0);
    }

    #[test]
    fn a_renamed_field_is_an_error_naming_it() {
        let mut s = section();
        let cd = s.remove("candela_cd").unwrap();
        s.insert("candela".into(), cd);
        let e = grid_from_section(&s, "l.json").unwrap_err().to_string();
        assert!(e.contains("l.json") && e.contains("candela_cd"), "{e}");
    }
}
