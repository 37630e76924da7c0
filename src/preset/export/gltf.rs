//! glTF 2.0 and OpenPBR exports of a preset's `dispersion` section.
//!
//! **glTF**: one material (and, so viewers show something, one unit cube mesh and node using it)
//! with
//! - `KHR_materials_ior`: `ior` = n_d;
//! - `KHR_materials_dispersion`: `dispersion` = 20 / V_d — the extension's definition, which
//!   implies the two-term Cauchy curve n = A + B/λ² through n_d with Abbe number V_d (the preset's
//!   `derived.gltf_cauchy` gives its A, B and its error against the full model);
//! - `KHR_materials_transmission`: `transmissionFactor` 1 (a clear dielectric);
//! - `KHR_materials_volume`: `thicknessFactor` (default 1 m, the cube's size), optional
//!   `attenuationDistance`/`attenuationColor` left at their defaults (no absorption).
//!
//! glTF cannot carry the full n(λ): a renderer that reads these extensions sees only the Cauchy
//! curve. **OpenPBR** likewise takes `specular_ior` = n_d, `transmission_weight` 1,
//! `transmission_dispersion_abbe_number` = V_d and `transmission_dispersion_scale` 1.

use serde_json::{json, Value};

use crate::error::{ensure_finite, Error, Result};
use crate::preset::dispersion::DispersionSection;
use crate::preset::MaterialPreset;

/// Options of the glTF export.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ExportOptions {
    /// `KHR_materials_volume.thicknessFactor` in metres (> 0).
    pub thickness_m: f64,
}

impl Default for ExportOptions {
    fn default() -> Self {
        ExportOptions { thickness_m: 1.0 }
    }
}

fn section<'a>(preset: &'a MaterialPreset, file: &str) -> Result<&'a DispersionSection> {
    preset.dispersion.as_ref().ok_or_else(|| {
        Error::invalid(
            format!("{file}: dispersion"),
            "the preset has no dispersion section; write one with `lumifit dispersion fit`",
        )
    })
}

/// Standard base64 (RFC 4648 §4, with padding) for the embedded buffer's data URI.
fn base64(bytes: &[u8]) -> String {
    const A: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::with_capacity(bytes.len().div_ceil(3) * 4);
    for chunk in bytes.chunks(3) {
        let b = [
            chunk[0],
            *chunk.get(1).unwrap_or(&0),
            *chunk.get(2).unwrap_or(&0),
        ];
        let v = (u32::from(b[0]) << 16) | (u32::from(b[1]) << 8) | u32::from(b[2]);
        for k in 0..4 {
            if k <= chunk.len() {
                out.push(A[((v >> (18 - 6 * k)) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

/// A unit cube (positions only, 36 non-indexed vertices) centred on the origin, as little-endian
/// f32, with its min and max.
fn cube() -> (Vec<u8>, [f32; 3], [f32; 3]) {
    const F: [[usize; 4]; 6] = [
        [0, 1, 3, 2],
        [4, 6, 7, 5],
        [0, 4, 5, 1],
        [2, 3, 7, 6],
        [0, 2, 6, 4],
        [1, 5, 7, 3],
    ];
    let corner = |i: usize| -> [f32; 3] {
        [
            if i & 4 != 0 { 0.5 } else { -0.5 },
            if i & 2 != 0 { 0.5 } else { -0.5 },
            if i & 1 != 0 { 0.5 } else { -0.5 },
        ]
    };
    let mut bytes = Vec::with_capacity(36 * 12);
    for f in F {
        for idx in [f[0], f[1], f[2], f[0], f[2], f[3]] {
            for v in corner(idx) {
                bytes.extend_from_slice(&v.to_le_bytes());
            }
        }
    }
    (bytes, [-0.5; 3], [0.5; 3])
}

/// The glTF 2.0 document (JSON) of `preset`'s dispersion section; `file` names the preset in
/// errors.
pub fn material_gltf(preset: &MaterialPreset, file: &str, opts: ExportOptions) -> Result<Value> {
    let d = section(preset, file)?;
    if !(opts.thickness_m.is_finite() && opts.thickness_m > 0.0) {
        return Err(Error::invalid(
            "--thickness-m",
            format!("{}; expected a positive thickness in m", opts.thickness_m),
        ));
    }
    let dispersion = 20.0 / d.abbe_number;
    ensure_finite("glTF dispersion (20 / V_d)", file, &[d.n_d, dispersion])?;
    let (bytes, min, max) = cube();
    let uri = format!("data:application/octet-stream;base64,{}", base64(&bytes));
    Ok(json!({
        "asset": {
            "version": "2.0",
            "generator": format!("lumifit {} preset export", env!("CARGO_PKG_VERSION")),
        },
        "extensionsUsed": [
            "KHR_materials_dispersion",
            "KHR_materials_ior",
            "KHR_materials_transmission",
            "KHR_materials_volume"
        ],
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0, "name": preset.name}],
        "meshes": [{
            "name": preset.name,
            "primitives": [{"attributes": {"POSITION": 0}, "material": 0}]
        }],
        "buffers": [{"byteLength": bytes.len(), "uri": uri}],
        "bufferViews": [{"buffer": 0, "byteLength": bytes.len(), "target": 34962}],
        "accessors": [{
            "bufferView": 0,
            "componentType": 5126,
            "count": 36,
            "type": "VEC3",
            "min": min,
            "max": max
        }],
        "materials": [{
            "name": preset.name,
            "pbrMetallicRoughness": {
                "baseColorFactor": [1.0, 1.0, 1.0, 1.0],
                "metallicFactor": 0.0,
                "roughnessFactor": 0.0
            },
            "extensions": {
                "KHR_materials_ior": {"ior": d.n_d},
                "KHR_materials_dispersion": {"dispersion": dispersion},
                "KHR_materials_transmission": {"transmissionFactor": 1.0},
                "KHR_materials_volume": {"thicknessFactor": opts.thickness_m}
            },
            "extras": {
                "lumifit": {
                    "abbe_number": d.abbe_number,
                    "dispersion_model": d.model.kind,
                    "range_nm": d.range_nm
                }
            }
        }]
    }))
}

/// OpenPBR parameters of `preset`'s dispersion section, as JSON.
pub fn openpbr_parameters(preset: &MaterialPreset, file: &str) -> Result<Value> {
    let d = section(preset, file)?;
    ensure_finite("OpenPBR parameters", file, &[d.n_d, d.abbe_number])?;
    Ok(json!({
        "format": "OpenPBR Surface 1.1 parameters",
        "material": preset.name,
        "specular_ior": d.n_d,
        "transmission_weight": 1.0,
        "transmission_dispersion_abbe_number": d.abbe_number,
        "transmission_dispersion_scale": 1.0,
        "note": "OpenPBR keeps only n_d and V_d: the two-term Cauchy curve through n_d; see the preset's dispersion.derived.gltf_cauchy for its error"
    }))
}

#[cfg(test)]
mod tests {
    #[test]
    fn base64_matches_rfc4648_examples() {
        assert_eq!(super::base64(b"f"), "Zg==");
        assert_eq!(super::base64(b"fo"), "Zm8=");
        assert_eq!(super::base64(b"foo"), "Zm9v");
        assert_eq!(super::base64(b"foobar"), "Zm9vYmFy");
    }
}
