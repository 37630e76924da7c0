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
use serde_json::{json, Value};

use super::OpenSection;
use crate::error::{Error, Result};
use crate::photometry::{
    summary, CandelaGrid, FileFormat, PhotometricFile, PhotometricType, Symmetry,
};

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

/// A glTF 2.0 document placing the light as one node with `KHR_lights_punctual` (a point light
/// of the equivalent isotropic intensity Φ/4π cd, for viewers without IES support) and
/// `EXT_lights_ies` (the profile as an LM-63-2019 file written by lumifit, referenced by `uri`),
/// and the bytes of that IES file.
///
/// Orientation: EXT_lights_ies aims a light down the node's −Z with the X/Y plane horizontal, so
/// the node's rotation maps −Z to the emitting normal n and +X to u (C = 0°). glTF frames are
/// right-handed, hence the node's +Y is n × … = −v, while lumifit's `--up` frame puts C = 90° on
/// v = n × u (the convention, the mirror image of LM-63's counter-clockwise C seen from
/// behind the emitter). The IES written here therefore stores I(360° − C), so that a renderer
/// following EXT_lights_ies lights the same directions lumifit's shading does. Not yet checked
/// with the Khronos glTF validator.
pub fn gltf_light(
    file: &PhotometricFile,
    light: &crate::photometry::illuminance::RectLight,
    name: &str,
    ies_uri: &str,
) -> Result<(Value, Vec<u8>)> {
    use crate::photometry::Symmetry;
    let p = &file.photometry;
    let g = &p.grid;
    if g.kind != PhotometricType::C {
        return Err(Error::invalid(
            "glTF export",
            "only Type C photometry is exported (EXT_lights_ies renderers need not support Type A)",
        ));
    }
    // mirror C → 360° − C
    let nv = g.nv();
    let mut planes: Vec<(f64, usize)> = g
        .h_deg
        .iter()
        .enumerate()
        .map(|(i, c)| ((360.0 - c).rem_euclid(360.0), i))
        .collect();
    planes.sort_by(|a, b| a.0.total_cmp(&b.0));
    let h: Vec<f64> = planes.iter().map(|x| x.0).collect();
    let cd: Vec<f64> = planes
        .iter()
        .flat_map(|&(_, i)| g.cd[i * nv..(i + 1) * nv].iter().copied())
        .collect();
    let mirrored = CandelaGrid::new(PhotometricType::C, h, g.v_deg.clone(), cd)?;
    let symmetry = match p.symmetry {
        // mirroring about C0–C180 keeps these symmetries; a full or C90–C270 file is written whole
        Symmetry::Rotational | Symmetry::C0C180 | Symmetry::Quadrant => p.symmetry,
        _ => Symmetry::None,
    };
    let mut out_file = file.clone();
    out_file.photometry.grid = mirrored;
    out_file.photometry.symmetry = symmetry;
    let ies = crate::io::ies::write_ies(
        &out_file,
        &format!(
            "lumifit {} glTF export (C mirrored for the glTF frame)",
            env!("CARGO_PKG_VERSION")
        ),
    )?;
    let s = summary(p);
    // rotation matrix columns: X = u, Y = −v, Z = −n
    let (x, y, z) = (
        light.u,
        [-light.v[0], -light.v[1], -light.v[2]],
        [-light.n[0], -light.n[1], -light.n[2]],
    );
    let q = quaternion_from_columns(x, y, z);
    let doc = json!({
        "asset": {"version": "2.0", "generator": format!("lumifit {}", env!("CARGO_PKG_VERSION"))},
        "extensionsUsed": ["KHR_lights_punctual", "EXT_lights_ies"],
        "extensions": {
            "KHR_lights_punctual": {"lights": [{"name": name, "type": "point", "color": [1.0, 1.0, 1.0], "intensity": s.flux_lm / (4.0 * std::f64::consts::PI)}]},
            "EXT_lights_ies": {"lights": [{"name": name, "uri": ies_uri}]}
        },
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{
            "name": name,
            "translation": light.center,
            "rotation": q,
            "extensions": {"KHR_lights_punctual": {"light": 0}, "EXT_lights_ies": {"light": 0, "multiplier": 1.0}},
            "extras": {"lumifit_emitter_rect_m": [light.width_m, light.height_m], "lumifit_flux_lm": s.flux_lm}
        }]
    });
    Ok((doc, ies.into_bytes()))
}

/// Unit quaternion [x, y, z, w] of the rotation whose matrix has columns `x`, `y`, `z`
/// (orthonormal, right-handed).
pub fn quaternion_from_columns(x: [f64; 3], y: [f64; 3], z: [f64; 3]) -> [f64; 4] {
    let (m00, m11, m22) = (x[0], y[1], z[2]);
    let tr = m00 + m11 + m22;
    let (qx, qy, qz, qw);
    if tr > 0.0 {
        let s = (tr + 1.0).sqrt() * 2.0;
        qw = 0.25 * s;
        qx = (y[2] - z[1]) / s;
        qy = (z[0] - x[2]) / s;
        qz = (x[1] - y[0]) / s;
    } else if m00 > m11 && m00 > m22 {
        let s = (1.0 + m00 - m11 - m22).sqrt() * 2.0;
        qw = (y[2] - z[1]) / s;
        qx = 0.25 * s;
        qy = (y[0] + x[1]) / s;
        qz = (z[0] + x[2]) / s;
    } else if m11 > m22 {
        let s = (1.0 + m11 - m00 - m22).sqrt() * 2.0;
        qw = (z[0] - x[2]) / s;
        qx = (y[0] + x[1]) / s;
        qy = 0.25 * s;
        qz = (z[1] + y[2]) / s;
    } else {
        let s = (1.0 + m22 - m00 - m11).sqrt() * 2.0;
        qw = (x[1] - y[0]) / s;
        qx = (z[0] + x[2]) / s;
        qy = (z[1] + y[2]) / s;
        qz = 0.25 * s;
    }
    [qx, qy, qz, qw]
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
