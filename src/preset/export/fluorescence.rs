//! The `extras.lumifit_fluorescence` block of a glTF material (and of the OpenPBR JSON): no
//! renderer format has a field for fluorescence, so the reduced matrices travel as data a
//! lumifit-aware renderer reads, and the material's plain base colour is what others show.
//!
//! Schema `lumifit.gltf.fluorescence/1` (documented in `docs/export.md`):
//! - `rgb_matrix_linear_srgb`: 3×3 row-major, `rgb_out = max(M · rgb_in, 0)` on linear sRGB
//!   (glTF's space) — Fichet 2024 Eq. 16 applied to `xyz_matrix` with sRGB's matrices from
//!   `calib/colourspaces.json`: `M = M_xyz→srgb · P_xyz · M_srgb→xyz`;
//! - `rgb`: the preset's own `{space, matrix}` (the space it was reduced to);
//! - `xyz_matrix`: P projected to XYZ; `reduced_matrix` (K×K) and `transfer_xyz` (3×K) with the
//!   `basis` (name, K, labels, observer, grid, functions) for spectral or K-channel renderers;
//! - `base_color`: `{linear_srgb, source}` — the colour written to `baseColorFactor`;
//! - `worst_delta_e00` and `delta_e00` (per illuminant) of the reduction, from the preset.

use serde_json::{json, Value};

use crate::colorimetry::rgb::RgbSpace;
use crate::error::{ensure_finite, Result};
use crate::math::linalg::{mat3_mul, mat3_mul_vec, Mat3};
use crate::preset::FluorescenceSection;

use super::base_colour::{clip_unit, BaseColour};

/// Schema identifier of the block.
pub const FLUORESCENCE_BLOCK_SCHEMA: &str = "lumifit.gltf.fluorescence/1";

/// The reduced XYZ matrix moved to linear RGB of `space` (Eq. 16 with the space's matrices).
pub fn rgb_matrix(section: &FluorescenceSection, space: &RgbSpace) -> Mat3 {
    mat3_mul(
        &mat3_mul(&space.matrix_xyz_to_rgb, &section.xyz_matrix),
        &space.matrix_rgb_to_xyz,
    )
}

/// The block and the base colour to write (`factor`, clipped to [0, 1]): the reflectance's colour
/// when the preset has one (the Donaldson matrix's diagonal is that reflectance), else
/// `M · (1, 1, 1)` — white light of the space through the reduced matrix, re-emission included.
pub fn fluorescence_block(
    section: &FluorescenceSection,
    reflectance: Option<&BaseColour>,
    space: &RgbSpace,
    file: &str,
) -> Result<(Value, [f64; 3])> {
    let m = rgb_matrix(section, space);
    ensure_finite("fluorescence matrix in linear sRGB", file, &m.concat())?;
    let (base, source, clipped) = match reflectance {
        Some(b) => (
            b.factor,
            "the reflectance section (CIE 1931 2°, D65), without re-emission",
            b.clipped,
        ),
        None => {
            let (c, clipped) = clip_unit(mat3_mul_vec(&m, [1.0; 3]));
            (
                c,
                "M · (1, 1, 1): white light of the space through the reduced matrix, re-emission included (the preset has no reflectance section)",
                clipped,
            )
        }
    };
    let block = json!({
        "schema": FLUORESCENCE_BLOCK_SCHEMA,
        "paper": section.paper,
        "method": section.method,
        "equation": "rgb_out = max(M · rgb_in, 0): rgb_in the light arriving, rgb_out reflection plus re-emission, both linear",
        "rgb_matrix_linear_srgb": m,
        "rgb": {"space": section.rgb.space, "matrix": section.rgb.matrix},
        "xyz_matrix": section.xyz_matrix,
        "reduced_matrix": section.matrix,
        "transfer_xyz": section.transfer_xyz,
        "basis": {
            "name": section.basis.name,
            "k": section.basis.k,
            "labels": section.basis.labels,
            "observer": section.basis.observer,
            "grid_nm": {
                "start_nm": section.basis.grid_nm.start_nm,
                "end_nm": section.basis.grid_nm.end_nm,
                "step_nm": section.basis.grid_nm.step_nm,
            },
            "functions": section.basis.functions,
        },
        "base_color": {"linear_srgb": base, "source": source, "clipped": clipped},
        "worst_delta_e00": section.worst_delta_e00,
        "delta_e00": section.delta_e00.iter().map(|d| json!({"illuminant": d.illuminant, "delta_e00": d.delta_e00})).collect::<Vec<_>>(),
    });
    Ok((block, base))
}
