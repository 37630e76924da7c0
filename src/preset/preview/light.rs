//! The photometric row of a `lumifit.light/1` preset: the light's rectangle hung
//! [`MOUNT_HEIGHT_M`] above the floor, aimed straight down (`--normal 0,-1,0 --up 0,0,1`, the
//! defaults of `light preset`), and the illuminance it gives computed by the library's cubature
//! (Luksch et al. 2020, [`crate::photometry::luksch2020`]) from the preset's own candela grid.
//!
//! - **scene**: the sphere (radius 1 m) on the floor, every visible point shaded with the
//!   illuminance on its own surface (`E` in lux, receiver normal = surface normal), radiance
//!   `ρ E / π` (sphere ρ = 0.8, floor 0.5); a point whose straight line to the light's centre
//!   crosses the sphere is in shadow (a point-light shadow: the rectangle is small next to
//!   the distances). One exposure: the brightest floor point under the light at 0.8.
//! - **plan**: the floor seen from above, 8 m × 8 m around the foot of the light, false colour
//!   of `E / E_max` (no sphere, no shadow), with the lux of the scale's ends; the colour bar is
//!   the third panel.

use serde::Serialize;

use super::{sig3, PreviewOptions};
use crate::error::{ensure_finite, Result};
use crate::photometry::illuminance::{shade, Method, Receiver, RectLight};
use crate::photometry::CandelaGrid;
use crate::preset::photometric::{grid_from_section, read_section};
use crate::preset::types::LightPreset;
use crate::render::{
    ray_sphere, Panel, Ray, Scene, ShadeInput, Shader, SheetRow, Srgb8Image, Surface,
};

/// Height of the light's centre above the floor, m.
pub const MOUNT_HEIGHT_M: f64 = 4.0;
/// Half-size of the plan view, m.
pub const PLAN_HALF_M: f64 = 4.0;

/// The numbers of the photometric row.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LightReport {
    /// Flux of the candela grid, lm.
    pub flux_lm: f64,
    /// Largest intensity, cd.
    pub max_cd: f64,
    /// Emitter rectangle, m.
    pub emitter_rect_m: [f64; 2],
    /// Height of the light above the floor, m.
    pub mount_height_m: f64,
    /// Illuminance at the foot of the light (no sphere), lux.
    pub e_foot_lux: f64,
    /// Largest illuminance on the plan, lux.
    pub e_max_plan_lux: f64,
    /// Half-size of the plan, m.
    pub plan_half_size_m: f64,
    /// The shading method.
    pub method: String,
    /// One line for the sheet's notes.
    pub note: String,
}

fn e_lux(light: &RectLight, grid: &CandelaGrid, p: [f64; 3], n: [f64; 3]) -> f64 {
    shade(light, grid, &Receiver { p, n }, Method::Cubature, 0).e_lux
}

struct PhotometricShader<'a> {
    light: &'a RectLight,
    grid: &'a CandelaGrid,
}

impl Shader for PhotometricShader<'_> {
    fn shade(&self, hit: &ShadeInput) -> [f64; 3] {
        let to = [
            self.light.center[0] - hit.point[0],
            self.light.center[1] - hit.point[1],
            self.light.center[2] - hit.point[2],
        ];
        let d = (to[0] * to[0] + to[1] * to[1] + to[2] * to[2]).sqrt();
        let ray = Ray {
            origin: [
                hit.point[0] + 1e-7 * hit.normal[0],
                hit.point[1] + 1e-7 * hit.normal[1],
                hit.point[2] + 1e-7 * hit.normal[2],
            ],
            dir: [to[0] / d, to[1] / d, to[2] / d],
        };
        if ray_sphere(&ray, [0.0, 1.0, 0.0], 1.0).is_some_and(|t| t < d) {
            return [0.0; 3];
        }
        let rho = match hit.surface {
            Surface::Sphere => 0.8,
            Surface::Floor => 0.5,
        };
        let l = rho * e_lux(self.light, self.grid, hit.point, hit.normal) / std::f64::consts::PI;
        [l; 3]
    }
    fn background(&self) -> [f64; 3] {
        [0.0; 3]
    }
}

/// A perceptually ordered dark-blue → teal → yellow ramp (viridis-like stops), `t` in [0, 1].
pub fn false_colour(t: f64) -> [u8; 3] {
    const STOPS: [[f64; 3]; 5] = [
        [0.267, 0.005, 0.329],
        [0.230, 0.322, 0.546],
        [0.128, 0.567, 0.551],
        [0.369, 0.789, 0.383],
        [0.993, 0.906, 0.144],
    ];
    let t = if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) };
    let x = t * 4.0;
    let i = (x.floor() as usize).min(3);
    let f = x - i as f64;
    let c: [f64; 3] = std::array::from_fn(|k| STOPS[i][k] * (1.0 - f) + STOPS[i + 1][k] * f);
    c.map(|v| (v * 255.0).round() as u8)
}

/// The scene, the plan and the colour bar, and their numbers.
pub fn light_row(
    preset: &LightPreset,
    file: &str,
    o: &PreviewOptions,
) -> Result<(SheetRow, LightReport)> {
    let section = read_section(&preset.photometric, file)?;
    let grid = grid_from_section(&preset.photometric, file)?;
    let [w, h] = section.emitter_rect_m;
    let light = RectLight::new(
        [0.0, MOUNT_HEIGHT_M, 0.0],
        [0.0, -1.0, 0.0],
        [0.0, 0.0, 1.0],
        w,
        h,
    )?;
    let up = [0.0, 1.0, 0.0];
    let e_foot = e_lux(&light, &grid, [0.0; 3], up);
    let size = o.size_px;
    // plan: one receiver per pixel centre, rows in parallel through the scene renderer's pool
    let plan: Vec<f64> = {
        use rayon::prelude::*;
        (0..size * size)
            .into_par_iter()
            .map(|k| {
                let (i, j) = (k % size, k / size);
                let x = -PLAN_HALF_M + (i as f64 + 0.5) * 2.0 * PLAN_HALF_M / size as f64;
                let z = -PLAN_HALF_M + (j as f64 + 0.5) * 2.0 * PLAN_HALF_M / size as f64;
                e_lux(&light, &grid, [x, 0.0, z], up)
            })
            .collect()
    };
    ensure_finite("the illuminance", file, &plan)?;
    let e_max = plan.iter().copied().fold(0.0, f64::max);
    let scale = if e_max > 0.0 { 1.0 / e_max } else { 1.0 };
    let mut bytes = Vec::with_capacity(size * size * 3);
    for e in &plan {
        bytes.extend_from_slice(&false_colour(e * scale));
    }
    let bar_w = (size / 5).max(12);
    let mut bar = Vec::with_capacity(bar_w * size * 3);
    for y in 0..size {
        let c = false_colour(1.0 - (y as f64 + 0.5) / size as f64);
        for _ in 0..bar_w {
            bar.extend_from_slice(&c);
        }
    }
    let scene = Scene {
        light: None,
        ..Scene::default()
    };
    let img = scene.render(
        size,
        size,
        &PhotometricShader {
            light: &light,
            grid: &grid,
        },
    )?;
    // the brightest floor point (no sphere there) shows 0.8
    let floor_peak = 0.5 * e_max / std::f64::consts::PI;
    let exposure = if floor_peak > 0.0 {
        0.8 / floor_peak
    } else {
        1.0
    };
    let scene_img = img.to_srgb8(exposure);
    let panels = vec![
        Panel {
            image: scene_img,
            title: format!("lit from {} m", sig3(MOUNT_HEIGHT_M)),
            lines: vec![format!("foot {} lx, shadow to the centre", sig3(e_foot))],
        },
        Panel {
            image: Srgb8Image {
                width: size,
                height: size,
                bytes,
            },
            title: format!("floor from above, {0} m × {0} m", sig3(2.0 * PLAN_HALF_M)),
            lines: vec![format!("E max {} lx (top of the bar)", sig3(e_max))],
        },
        Panel {
            image: Srgb8Image {
                width: bar_w,
                height: size,
                bytes: bar,
            },
            title: "E".into(),
            lines: vec!["0 to max".into()],
        },
    ];
    let note = format!(
        "Photometric light: {} lm, max {} cd, emitter {} m × {} m at {} m, aimed down; \
         illuminance by the cubature of Luksch 2020 from the preset's candela grid.",
        sig3(section.flux_lm),
        sig3(section.max_cd),
        sig3(w),
        sig3(h),
        sig3(MOUNT_HEIGHT_M)
    );
    Ok((
        SheetRow {
            heading: "Photometric light: the scene it lights, and the illuminance on the floor"
                .into(),
            panels,
        },
        LightReport {
            flux_lm: section.flux_lm,
            max_cd: section.max_cd,
            emitter_rect_m: section.emitter_rect_m,
            mount_height_m: MOUNT_HEIGHT_M,
            e_foot_lux: e_foot,
            e_max_plan_lux: e_max,
            plan_half_size_m: PLAN_HALF_M,
            method: "cubature (Luksch 2020)".into(),
            note,
        },
    ))
}
