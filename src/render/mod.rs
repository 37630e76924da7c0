//! A small deterministic CPU ray caster: a sphere resting on a plane under one light, enough to
//! see a material. It knows no physics of materials: a [`Shader`] turns what a primary ray hit
//! into linear RGB radiance, and this module does the geometry, the light, the shadow, the
//! tone mapping and the sRGB encoding.
//!
//! # Scene and units
//!
//! - Right-handed, y up; lengths in scene units (the sphere's radius is 1). The plane is `y = 0`
//!   (a square of half-size [`Scene::floor_half_size`]), the sphere's centre `(0, R, 0)`, so the
//!   sphere touches the plane at the origin.
//! - A pinhole camera at `eye` looking at `target` with vertical field of view `vfov_deg`.
//! - One light: **directional** (`dir` points towards the light; irradiance `E₀` on a surface
//!   facing it) or **point** (position `p`, intensity `I`; irradiance `I cos θ / d²`). A shadow ray
//!   to the light tests the sphere (the only occluder). Irradiance is handed to the shader as a
//!   dimensionless **geometric factor** `g` (0 in shadow): `g = max(0, n·l)` (directional) or
//!   `I max(0, n·l) / d²` (point); the shader multiplies it with the light's colour.
//! - `ambient` is a uniform, unoccluded extra irradiance factor added to `g` (default 0.08 of the
//!   light's normal irradiance) so that the unlit side keeps its shape; it is stated on every
//!   preview.
//! - For emissive spheres the shader also gets the **view factor** of the sphere at a floor
//!   point: a Lambertian sphere of radiance `L` gives irradiance `π L (R/d)² cos θ_c` at a point
//!   whose tangent plane does not cut the sphere (exact, the sphere's solid-angle cosine
//!   integral), `d` the distance to the centre and `θ_c` the angle between the normal and the
//!   direction to the centre; [`ShadeInput::sphere_view_factor`] is `(R/d)² cos θ_c`.
//!
//! # Pixels
//!
//! Each pixel is the mean of a fixed 3 × 3 stratified sub-pixel pattern (no random numbers), rows
//! are rendered in parallel with rayon; every pixel's arithmetic is independent of the thread
//! that runs it, so the output is the same bytes on every run and every machine with IEEE-754
//! `f64`.
//!
//! # Display
//!
//! [`LinearImage::to_srgb8`]: linear RGB (of sRGB primaries) times an exposure, negative channels
//! clipped to 0, then a **hue-preserving clip** (a pixel whose largest channel exceeds 1 is scaled
//! down as a whole, so a bright fluorescent or emissive colour keeps its hue instead of turning
//! white), then the sRGB transfer function (IEC 61966-2-1) and rounding to 8 bits.

use rayon::prelude::*;

use crate::colorimetry::rgb::eotf_inverse_srgb;
use crate::error::{Error, Result};

/// A 3-vector of scene coordinates.
pub type V3 = [f64; 3];

fn add(a: V3, b: V3) -> V3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}
fn sub(a: V3, b: V3) -> V3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn scale(a: V3, s: f64) -> V3 {
    [a[0] * s, a[1] * s, a[2] * s]
}
fn dot(a: V3, b: V3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn cross(a: V3, b: V3) -> V3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
fn normalize(a: V3) -> V3 {
    let n = dot(a, a).sqrt();
    if n > 0.0 {
        scale(a, 1.0 / n)
    } else {
        a
    }
}

/// Smallest ray parameter accepted as a hit (avoids self-intersection of shadow rays).
const EPS: f64 = 1e-9;

/// A ray `o + t d` (`d` unit length).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ray {
    /// Origin.
    pub origin: V3,
    /// Unit direction.
    pub dir: V3,
}

/// Nearest `t > EPS` where `ray` meets the sphere of `centre` and `radius`, if any.
///
/// Solves `|o + t d − c|² = R²` with the numerically stable form of the quadratic.
pub fn ray_sphere(ray: &Ray, centre: V3, radius: f64) -> Option<f64> {
    let oc = sub(ray.origin, centre);
    let b = dot(oc, ray.dir);
    let c = dot(oc, oc) - radius * radius;
    let disc = b * b - c;
    if disc < 0.0 {
        return None;
    }
    let s = disc.sqrt();
    // q = −b − sign(b)·s; roots q and c/q (d is unit length, a = 1).
    let q = if b > 0.0 { -b - s } else { -b + s };
    let (t0, t1) = if q != 0.0 {
        let (x, y) = (q, c / q);
        (x.min(y), x.max(y))
    } else {
        (0.0, 0.0)
    };
    if t0 > EPS {
        Some(t0)
    } else if t1 > EPS {
        Some(t1)
    } else {
        None
    }
}

/// `t > EPS` where `ray` meets the plane `y = height`, if any (a ray parallel to it misses).
pub fn ray_plane(ray: &Ray, height: f64) -> Option<f64> {
    if ray.dir[1] == 0.0 {
        return None;
    }
    let t = (height - ray.origin[1]) / ray.dir[1];
    (t > EPS).then_some(t)
}

/// The one light of a scene.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Light {
    /// A distant light; `dir` points from the scene towards the light.
    Directional {
        /// Direction towards the light (normalised on use).
        dir: V3,
    },
    /// A point light at `position` with intensity `intensity` (irradiance `I cos θ / d²`, in
    /// units of the light's reference irradiance).
    Point {
        /// Position.
        position: V3,
        /// Intensity (reference irradiance × scene unit²).
        intensity: f64,
    },
}

/// A pinhole camera.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    /// Eye position.
    pub eye: V3,
    /// Point looked at.
    pub target: V3,
    /// Vertical field of view in degrees.
    pub vfov_deg: f64,
}

/// The scene: sphere, floor, light, camera.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Scene {
    /// Sphere radius (centre at `(0, R, 0)`).
    pub sphere_radius: f64,
    /// Half-size of the square floor around the origin.
    pub floor_half_size: f64,
    /// The light, or `None` (dark: only emission is seen).
    pub light: Option<Light>,
    /// Uniform unoccluded irradiance factor added to every surface (0 for none).
    pub ambient: f64,
    /// The camera.
    pub camera: Camera,
}

impl Default for Scene {
    fn default() -> Self {
        Scene {
            sphere_radius: 1.0,
            floor_half_size: 3.2,
            light: Some(Light::Directional {
                dir: [-0.55, 1.0, 0.7],
            }),
            ambient: 0.08,
            camera: Camera {
                eye: [0.0, 1.9, 5.2],
                target: [0.0, 0.75, 0.0],
                vfov_deg: 34.0,
            },
        }
    }
}

/// Which surface a primary ray hit.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Surface {
    /// The sphere.
    Sphere,
    /// The floor.
    Floor,
}

/// What a shader is told about a primary-ray hit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShadeInput {
    /// The surface hit.
    pub surface: Surface,
    /// Hit point.
    pub point: V3,
    /// Unit surface normal.
    pub normal: V3,
    /// Direct irradiance factor of the light (0 in shadow or with no light), plus `ambient`
    /// when there is a light.
    pub irradiance: f64,
    /// `(R/d)² cos θ_c` of the sphere seen from a floor point (0 on the sphere).
    pub sphere_view_factor: f64,
}

/// Turns a hit into linear RGB radiance (sRGB primaries), and a missed ray into the background.
pub trait Shader: Sync {
    /// Radiance leaving the hit point towards the camera.
    fn shade(&self, hit: &ShadeInput) -> [f64; 3];
    /// Radiance of rays that hit nothing.
    fn background(&self) -> [f64; 3] {
        [0.0; 3]
    }
}

/// A linear RGB image, row-major from the top row.
#[derive(Debug, Clone, PartialEq)]
pub struct LinearImage {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// `width × height` linear RGB values.
    pub pixels: Vec<[f64; 3]>,
}

/// An 8-bit sRGB image, row-major, 3 bytes per pixel.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Srgb8Image {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// `3 × width × height` bytes.
    pub bytes: Vec<u8>,
}

/// Largest panel side accepted (pixels).
pub const MAX_SIZE_PX: usize = 4096;

/// Checks a panel size a user typed (1 … [`MAX_SIZE_PX`], and the memory it takes).
pub fn check_size(what: &str, width: usize, height: usize) -> Result<()> {
    if width == 0 || height == 0 || width > MAX_SIZE_PX || height > MAX_SIZE_PX {
        return Err(Error::invalid(
            what,
            format!("{width}×{height} px; expected 1–{MAX_SIZE_PX} px per side"),
        ));
    }
    crate::limits::check_memory(
        what,
        &format!("{width}x{height} px"),
        (width as u128) * (height as u128),
        24 + 3,
    )
}

impl LinearImage {
    /// Display bytes: `exposure` × linear, clipped at 0, hue-preserving clip at 1, sRGB encoded.
    pub fn to_srgb8(&self, exposure: f64) -> Srgb8Image {
        let mut bytes = Vec::with_capacity(self.pixels.len() * 3);
        for p in &self.pixels {
            bytes.extend_from_slice(&display_srgb8(*p, exposure));
        }
        Srgb8Image {
            width: self.width,
            height: self.height,
            bytes,
        }
    }

    /// Largest channel value over the image (0 for an empty or black image).
    pub fn max_channel(&self) -> f64 {
        self.pixels
            .iter()
            .flat_map(|p| p.iter().copied())
            .fold(0.0, f64::max)
    }
}

/// One linear RGB value to display bytes (see the module docs).
pub fn display_srgb8(rgb: [f64; 3], exposure: f64) -> [u8; 3] {
    let c = rgb.map(|v| {
        let x = v * exposure;
        if x.is_nan() {
            0.0
        } else {
            x.max(0.0)
        }
    });
    let m = c[0].max(c[1]).max(c[2]);
    let c = if m > 1.0 { c.map(|v| v / m) } else { c };
    c.map(|v| (eotf_inverse_srgb(v.min(1.0)) * 255.0).round() as u8)
}

/// The camera ray through image position `(u, v)` (pixels from the top-left corner).
fn primary_ray(cam: &Camera, width: usize, height: usize, u: f64, v: f64) -> Ray {
    let forward = normalize(sub(cam.target, cam.eye));
    let right = normalize(cross(forward, [0.0, 1.0, 0.0]));
    let up = cross(right, forward);
    let half_h = (cam.vfov_deg.to_radians() / 2.0).tan();
    let aspect = width as f64 / height as f64;
    let x = (2.0 * u / width as f64 - 1.0) * half_h * aspect;
    let y = (1.0 - 2.0 * v / height as f64) * half_h;
    Ray {
        origin: cam.eye,
        dir: normalize(add(forward, add(scale(right, x), scale(up, y)))),
    }
}

impl Scene {
    fn sphere_centre(&self) -> V3 {
        [0.0, self.sphere_radius, 0.0]
    }

    /// The nearest hit of `ray`: surface, point, normal.
    pub fn intersect(&self, ray: &Ray) -> Option<(Surface, V3, V3)> {
        let c = self.sphere_centre();
        let ts = ray_sphere(ray, c, self.sphere_radius);
        let tp = ray_plane(ray, 0.0).filter(|&t| {
            let p = add(ray.origin, scale(ray.dir, t));
            p[0].abs() <= self.floor_half_size && p[2].abs() <= self.floor_half_size
        });
        let (surface, t) = match (ts, tp) {
            (Some(a), Some(b)) if b < a => (Surface::Floor, b),
            (Some(a), _) => (Surface::Sphere, a),
            (None, Some(b)) => (Surface::Floor, b),
            (None, None) => return None,
        };
        let p = add(ray.origin, scale(ray.dir, t));
        let n = match surface {
            Surface::Sphere => normalize(sub(p, c)),
            Surface::Floor => [0.0, 1.0, 0.0],
        };
        Some((surface, p, n))
    }

    /// Direct irradiance factor of the light at `p` with normal `n` (0 in the sphere's shadow).
    pub fn direct(&self, p: V3, n: V3) -> f64 {
        let Some(light) = self.light else {
            return 0.0;
        };
        let (l, dist, strength) = match light {
            Light::Directional { dir } => (normalize(dir), f64::INFINITY, 1.0),
            Light::Point {
                position,
                intensity,
            } => {
                let d = sub(position, p);
                let dist = dot(d, d).sqrt();
                (scale(d, 1.0 / dist), dist, intensity / (dist * dist))
            }
        };
        let cos = dot(n, l);
        if cos <= 0.0 {
            return 0.0;
        }
        let shadow = Ray {
            origin: add(p, scale(n, 1e-7)),
            dir: l,
        };
        if ray_sphere(&shadow, self.sphere_centre(), self.sphere_radius).is_some_and(|t| t < dist) {
            return 0.0;
        }
        strength * cos
    }

    /// `(R/d)² cos θ_c` at floor point `p` with normal `n` (see the module docs).
    pub fn sphere_view_factor(&self, p: V3, n: V3) -> f64 {
        let to_c = sub(self.sphere_centre(), p);
        let d2 = dot(to_c, to_c);
        let cos = dot(n, to_c) / d2.sqrt();
        if cos <= 0.0 {
            0.0
        } else {
            self.sphere_radius * self.sphere_radius / d2 * cos
        }
    }

    /// The shader input of a primary ray, if it hits.
    pub fn shade_input(&self, ray: &Ray) -> Option<ShadeInput> {
        let (surface, point, normal) = self.intersect(ray)?;
        let irradiance = if self.light.is_some() {
            self.direct(point, normal) + self.ambient
        } else {
            0.0
        };
        let sphere_view_factor = match surface {
            Surface::Floor => self.sphere_view_factor(point, normal),
            Surface::Sphere => 0.0,
        };
        Some(ShadeInput {
            surface,
            point,
            normal,
            irradiance,
            sphere_view_factor,
        })
    }

    /// Renders `width × height` pixels with `shader`, rows in parallel.
    ///
    /// # Errors
    /// A size outside 1 … [`MAX_SIZE_PX`] or above the memory budget.
    pub fn render(&self, width: usize, height: usize, shader: &dyn Shader) -> Result<LinearImage> {
        check_size("--size", width, height)?;
        const N: usize = 3;
        let mut pixels = vec![[0.0; 3]; width * height];
        pixels
            .par_chunks_mut(width)
            .enumerate()
            .for_each(|(y, row)| {
                for (x, px) in row.iter_mut().enumerate() {
                    let mut acc = [0.0; 3];
                    for sy in 0..N {
                        for sx in 0..N {
                            let u = x as f64 + (sx as f64 + 0.5) / N as f64;
                            let v = y as f64 + (sy as f64 + 0.5) / N as f64;
                            let ray = primary_ray(&self.camera, width, height, u, v);
                            let c = match self.shade_input(&ray) {
                                Some(hit) => shader.shade(&hit),
                                None => shader.background(),
                            };
                            acc = add(acc, c);
                        }
                    }
                    *px = scale(acc, 1.0 / (N * N) as f64);
                }
            });
        Ok(LinearImage {
            width,
            height,
            pixels,
        })
    }
}

/// A rendered panel with its caption: a title line and further lines of numbers.
#[derive(Debug, Clone, PartialEq)]
pub struct Panel {
    /// The picture.
    pub image: Srgb8Image,
    /// First caption line.
    pub title: String,
    /// Further caption lines (numbers the picture stands for).
    pub lines: Vec<String>,
}

/// One row of panels under a heading.
#[derive(Debug, Clone, PartialEq)]
pub struct SheetRow {
    /// Heading above the row.
    pub heading: String,
    /// Panels, left to right.
    pub panels: Vec<Panel>,
}

/// A contact sheet of rows of panels, with a title and notes under it.
#[derive(Debug, Clone, PartialEq)]
pub struct Sheet {
    /// Title at the top.
    pub title: String,
    /// Rows, top to bottom.
    pub rows: Vec<SheetRow>,
    /// Notes at the bottom (what the pictures assume).
    pub notes: Vec<String>,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ray_sphere_hits_the_near_side_and_misses_beside_it() {
        let r = Ray {
            origin: [0.0, 1.0, 5.0],
            dir: [0.0, 0.0, -1.0],
        };
        let t = ray_sphere(&r, [0.0, 1.0, 0.0], 1.0).unwrap();
        assert!((t - 4.0).abs() < 1e-12);
        let beside = Ray {
            origin: [1.0001, 1.0, 5.0],
            dir: [0.0, 0.0, -1.0],
        };
        assert!(ray_sphere(&beside, [0.0, 1.0, 0.0], 1.0).is_none());
        // from inside: the far side
        let inside = Ray {
            origin: [0.0, 1.0, 0.0],
            dir: [0.0, 0.0, -1.0],
        };
        assert!((ray_sphere(&inside, [0.0, 1.0, 0.0], 1.0).unwrap() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn ray_plane_hits_below_and_misses_parallel_or_behind() {
        let down = Ray {
            origin: [0.0, 2.0, 0.0],
            dir: normalize([0.0, -1.0, 1.0]),
        };
        let t = ray_plane(&down, 0.0).unwrap();
        assert!((t - 2.0 * 2f64.sqrt()).abs() < 1e-12);
        let flat = Ray {
            origin: [0.0, 2.0, 0.0],
            dir: [1.0, 0.0, 0.0],
        };
        assert!(ray_plane(&flat, 0.0).is_none());
        let up = Ray {
            origin: [0.0, 2.0, 0.0],
            dir: [0.0, 1.0, 0.0],
        };
        assert!(ray_plane(&up, 0.0).is_none());
    }

    #[test]
    fn the_floor_under_the_sphere_is_in_shadow_of_an_overhead_light() {
        let s = Scene {
            light: Some(Light::Directional {
                dir: [0.0, 1.0, 0.0],
            }),
            ..Scene::default()
        };
        assert_eq!(s.direct([0.0, 0.0, 0.5], [0.0, 1.0, 0.0]), 0.0);
        assert!((s.direct([0.0, 0.0, 2.0], [0.0, 1.0, 0.0]) - 1.0).abs() < 1e-12);
        // a point light at height 4 above (2, 0, 2): I/d² at the foot
        let p = Scene {
            light: Some(Light::Point {
                position: [2.0, 4.0, 2.0],
                intensity: 16.0,
            }),
            ..Scene::default()
        };
        assert!((p.direct([2.0, 0.0, 2.0], [0.0, 1.0, 0.0]) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn sphere_view_factor_matches_the_solid_angle_cosine_integral() {
        // Irradiance from a uniform sphere of radiance 1 at a floor point at horizontal
        // distance ρ from the contact point, integrated numerically over the visible cap.
        let s = Scene::default();
        for rho in [0.5f64, 1.0, 2.5] {
            let p = [rho, 0.0, 0.0];
            let exact = std::f64::consts::PI * s.sphere_view_factor(p, [0.0, 1.0, 0.0]);
            // numerical: sum over directions of the upper hemisphere that hit the sphere
            let (nt, np) = (800, 1600);
            let mut e = 0.0;
            for i in 0..nt {
                let th = (i as f64 + 0.5) / nt as f64 * std::f64::consts::FRAC_PI_2;
                for j in 0..np {
                    let ph = (j as f64 + 0.5) / np as f64 * 2.0 * std::f64::consts::PI;
                    let d = [th.sin() * ph.cos(), th.cos(), th.sin() * ph.sin()];
                    let r = Ray { origin: p, dir: d };
                    if ray_sphere(&r, [0.0, 1.0, 0.0], 1.0).is_some() {
                        e += th.cos()
                            * th.sin()
                            * (std::f64::consts::FRAC_PI_2 / nt as f64)
                            * (2.0 * std::f64::consts::PI / np as f64);
                    }
                }
            }
            assert!(
                (e - exact).abs() < 2e-3 * exact,
                "ρ = {rho}: numeric {e}, closed form {exact}"
            );
        }
    }

    #[test]
    fn display_clip_keeps_hue_and_encodes_srgb() {
        assert_eq!(display_srgb8([0.0, 0.0, 0.0], 1.0), [0, 0, 0]);
        assert_eq!(display_srgb8([1.0, 1.0, 1.0], 1.0), [255, 255, 255]);
        // 0.5 linear → 0.7354 encoded → 188
        assert_eq!(display_srgb8([0.5, 0.5, 0.5], 1.0), [188, 188, 188]);
        // over-exposed orange keeps its ratio 1 : 0.5 : 0 rather than turning white
        assert_eq!(display_srgb8([4.0, 2.0, -1.0], 1.0), [255, 188, 0]);
    }
}
