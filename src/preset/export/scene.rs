//! `--scene sphere`: a UV sphere of radius 1 m at the origin, a perspective camera on +Z looking
//! at it and a `KHR_lights_punctual` directional light, so an exported material opens in any
//! viewer.
//!
//! The sphere has 64 segments × 32 rings; the pole rings have one triangle per quad (no
//! zero-area triangles), normals are the unit positions, indices `u16`. The light's illuminance is
//! π lux (glTF: directional intensity in lux), so a white Lambertian surface facing it has a
//! luminance of 1 cd/m² — the same unit as the emission (`emissiveStrength`, cd/m²), so glow and
//! reflection compare as they would in the room.

use serde_json::{json, Value};

use super::buffer::{AccessorType, BufferBuilder, ARRAY_BUFFER};

/// Longitude segments of the sphere.
pub const SEGMENTS: usize = 64;
/// Latitude rings of the sphere.
pub const RINGS: usize = 32;

/// Positions (= normals, radius 1) and triangle indices of the UV sphere.
pub fn uv_sphere() -> (Vec<[f32; 3]>, Vec<u32>) {
    let mut pos = Vec::with_capacity((RINGS + 1) * (SEGMENTS + 1));
    for i in 0..=RINGS {
        let theta = std::f64::consts::PI * i as f64 / RINGS as f64;
        for j in 0..=SEGMENTS {
            let phi = 2.0 * std::f64::consts::PI * j as f64 / SEGMENTS as f64;
            let v = [
                theta.sin() * phi.cos(),
                theta.cos(),
                -theta.sin() * phi.sin(),
            ];
            let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
            pos.push(v.map(|c| (c / n) as f32));
        }
    }
    let idx = |i: usize, j: usize| (i * (SEGMENTS + 1) + j) as u32;
    let mut tri = Vec::with_capacity(RINGS * SEGMENTS * 6);
    for i in 0..RINGS {
        for j in 0..SEGMENTS {
            let (a, b, c, d) = (idx(i, j), idx(i + 1, j), idx(i + 1, j + 1), idx(i, j + 1));
            // Counter-clockwise seen from outside.
            if i != 0 {
                tri.extend_from_slice(&[a, b, d]);
            }
            if i != RINGS - 1 {
                tri.extend_from_slice(&[d, b, c]);
            }
        }
    }
    (pos, tri)
}

/// The scene's JSON parts, with the sphere's data added to `buf`: `(nodes, meshes, cameras,
/// lights)`, the sphere node first and using `material`.
pub fn sphere_scene(
    buf: &mut BufferBuilder,
    name: &str,
    material: usize,
) -> (Vec<Value>, Value, Value, Value) {
    let (pos, tri) = uv_sphere();
    let flat: Vec<f32> = pos.iter().flatten().copied().collect();
    let p = buf.push_f32(&flat, AccessorType::Vec3, Some(ARRAY_BUFFER), true);
    let n = buf.push_f32(&flat, AccessorType::Vec3, Some(ARRAY_BUFFER), false);
    let i = buf.push_indices(&tri);
    // The light travels along d = (−1, −1, −1)/√3 (from upper right front); a directional light
    // shines along its node's −Z, so the node rotates −Z onto d: q = (a × d, 1 + a·d), normalised.
    let d = [-1.0f64, -1.0, -1.0].map(|v| v / 3f64.sqrt());
    let a = [0.0, 0.0, -1.0];
    let cross = [
        a[1] * d[2] - a[2] * d[1],
        a[2] * d[0] - a[0] * d[2],
        a[0] * d[1] - a[1] * d[0],
    ];
    let w = 1.0 + (a[0] * d[0] + a[1] * d[1] + a[2] * d[2]);
    let norm = (cross.iter().map(|c| c * c).sum::<f64>() + w * w).sqrt();
    let q = [cross[0] / norm, cross[1] / norm, cross[2] / norm, w / norm];
    let nodes = vec![
        json!({"name": name, "mesh": 0}),
        json!({"name": "camera", "camera": 0, "translation": [0.0, 0.0, 4.0]}),
        json!({"name": "light", "rotation": q, "extensions": {"KHR_lights_punctual": {"light": 0}}}),
    ];
    let meshes = json!([{
        "name": name,
        "primitives": [{"attributes": {"POSITION": p, "NORMAL": n}, "indices": i, "material": material}]
    }]);
    let cameras = json!([{
        "type": "perspective",
        "perspective": {"yfov": 0.6, "znear": 0.1, "zfar": 100.0}
    }]);
    let lights = json!({"lights": [{
        "name": "key light (π lux)",
        "type": "directional",
        "color": [1.0, 1.0, 1.0],
        "intensity": std::f64::consts::PI
    }]});
    (nodes, meshes, cameras, lights)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_sphere_has_unit_normals_no_degenerate_triangles_and_outward_winding() {
        let (pos, tri) = uv_sphere();
        for p in &pos {
            let n = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
            assert!((n - 1.0).abs() < 1e-6);
        }
        for t in tri.chunks(3) {
            let [a, b, c] = [t[0], t[1], t[2]].map(|i| pos[i as usize].map(f64::from));
            let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
            let v = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
            let n = [
                u[1] * v[2] - u[2] * v[1],
                u[2] * v[0] - u[0] * v[2],
                u[0] * v[1] - u[1] * v[0],
            ];
            let area = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
            assert!(area > 1e-6, "degenerate triangle {t:?}");
            let centre = [
                (a[0] + b[0] + c[0]) / 3.0,
                (a[1] + b[1] + c[1]) / 3.0,
                (a[2] + b[2] + c[2]) / 3.0,
            ];
            let out = n[0] * centre[0] + n[1] * centre[1] + n[2] * centre[2];
            assert!(out > 0.0, "inward triangle {t:?}");
        }
        assert_eq!(tri.len(), (2 * RINGS - 2) * SEGMENTS * 3);
    }
}
