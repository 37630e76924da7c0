//! glTF 2.0 export of a photometric light (`lumifit light preset --gltf` and `lumifit preset
//! export LIGHT.json --format gltf`): one node with `KHR_lights_punctual` and `EXT_lights_ies`,
//! the IES written by lumifit beside it. One builder for both commands.

use serde_json::{json, Value};

use crate::error::{Error, Result};
use crate::photometry::{summary, CandelaGrid, PhotometricFile, PhotometricType};

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
/// following EXT_lights_ies lights the same directions lumifit's shading does. The documents
/// pass the Khronos glTF validator (`scripts/validate_gltf.sh`, tests in `photometry_cli`).
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
