//! Illuminance from a photometric rectangle: the light's frame, the simple estimators (point,
//! Monte Carlo, structured sampling, most representative point) and the closed-form solution for
//! a uniform (Lambertian) emitter that the tests judge them by.
//!
//! # The light
//!
//! A rectangle of W × H m centred at `center`, emitting to the side of `normal` (n_A). Its frame:
//! u = the component of `up` perpendicular to n_A (normalised), v = n_A × u. The rectangle spans
//! center ± W/2·u ± H/2·v; the photometric axis γ = 0 is +n_A, C = 0° points along +u and
//! C = 90° along +v. A direction ω leaving the light is looked up in the grid as the luminaire
//! frame vector (ω·u, ω·v, −ω·n_A) (the grid's nadir −z is the emitting side).
//!
//! # The integral (Luksch et al. 2020, Eq. 1 and 3)
//!
//! Each element dA of the emitter radiates I(ω)/A: the file's far-field intensity spread evenly
//! over the area. The illuminance at x with normal n_x is
//!
//! E(x) = (1/A) ∫_A I(ω) (ω_i·n_x)⁺ / r² dA = ∫_Ω L_e(−ω_i) (ω_i·n_x)⁺ dω_i,
//! L_e(ω) = I(ω) / (A |ω·n_A|)   (Eq. 2),
//!
//! where ω_i points from x to the emitter and ω = −ω_i. Both sides of the rectangle emit what the
//! grid says for their directions (γ > 90° is the back side), which Eq. 2 allows with |ω·n_A|.
//!
//! # Estimators
//!
//! - `point`: the light as a point at the centre, E = I(ω) (ω_i·n_x)⁺ / d².
//! - `mc`: uniform points on the rectangle, E ≈ (1/N) Σ I(ω_j)(ω_i·n_x)⁺/r_j², unbiased, with its
//!   standard error s/√N.
//! - `structured`: Eq. 4 with the four corners and the barycentre, Ω/5 · Σ L_e G, Ω the solid
//!   angle of the rectangle (Lagarde & de Rousiers 2014 as used in §4.1).
//! - `mrp`: Ω · L_e G at Drobot's most representative point (§4.2): the half-vector between the
//!   directions to the closest point CP and the normal point NP, intersected with the light's
//!   plane, each point clamped to the rectangle. When the receiver's normal ray does not meet the
//!   plane, NP is taken far along the normal's projection onto the plane, then clamped.
//! - `cubature`, `cubature-adaptive`: [`super::luksch2020`].

use rayon::prelude::*;
use serde::Serialize;

use super::CandelaGrid;
use crate::capture::rng::SplitMix64;
use crate::error::{Error, Result};

pub(crate) type V3 = [f64; 3];

pub(crate) fn sub(a: V3, b: V3) -> V3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
pub(crate) fn add(a: V3, b: V3) -> V3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}
pub(crate) fn scale(a: V3, k: f64) -> V3 {
    [a[0] * k, a[1] * k, a[2] * k]
}
pub(crate) fn dot(a: V3, b: V3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
pub(crate) fn cross(a: V3, b: V3) -> V3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
pub(crate) fn norm(a: V3) -> f64 {
    dot(a, a).sqrt()
}
pub(crate) fn normalize(a: V3) -> V3 {
    let n = norm(a);
    if n > 0.0 {
        scale(a, 1.0 / n)
    } else {
        a
    }
}

/// A photometric rectangle in the scene.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct RectLight {
    /// Centre in m.
    pub center: V3,
    /// Unit emitting normal n_A (γ = 0).
    pub n: V3,
    /// Unit C = 0° axis u.
    pub u: V3,
    /// Unit C = 90° axis v = n × u.
    pub v: V3,
    /// Extent along u, m.
    pub width_m: f64,
    /// Extent along v, m.
    pub height_m: f64,
}

impl RectLight {
    /// The frame of the module docs from `normal` and `up`; errors when a size is not positive
    /// or `up` is parallel to `normal`.
    pub fn new(center: V3, normal: V3, up: V3, width_m: f64, height_m: f64) -> Result<Self> {
        if !(width_m > 0.0 && height_m > 0.0 && width_m.is_finite() && height_m.is_finite()) {
            return Err(Error::invalid(
                "--rect",
                format!("{width_m},{height_m}: expected two positive sizes in m"),
            ));
        }
        let nn = norm(normal);
        if !(nn > 0.0 && nn.is_finite()) {
            return Err(Error::invalid("--normal", "expected a non-zero vector"));
        }
        let n = scale(normal, 1.0 / nn);
        let up_perp = sub(up, scale(n, dot(up, n)));
        if norm(up_perp) <= 1e-9 * norm(up).max(1e-300) || norm(up) == 0.0 {
            return Err(Error::invalid(
                "--up",
                "must not be zero or parallel to --normal",
            ));
        }
        let u = normalize(up_perp);
        let v = cross(n, u);
        Ok(Self {
            center,
            n,
            u,
            v,
            width_m,
            height_m,
        })
    }

    /// Area in m².
    pub fn area(&self) -> f64 {
        self.width_m * self.height_m
    }

    /// Corners counter-clockwise about n: (−,−), (+,−), (+,+), (−,+) in (u, v).
    pub fn corners(&self) -> [V3; 4] {
        let (hw, hh) = (0.5 * self.width_m, 0.5 * self.height_m);
        [(-hw, -hh), (hw, -hh), (hw, hh), (-hw, hh)]
            .map(|(a, b)| add(self.center, add(scale(self.u, a), scale(self.v, b))))
    }

    /// The point of the light's plane at local coordinates (a, b).
    pub fn point(&self, a: f64, b: f64) -> V3 {
        add(self.center, add(scale(self.u, a), scale(self.v, b)))
    }

    /// Intensity (cd) of `grid` in the direction `omega` leaving the light (not normalised).
    pub fn intensity(&self, grid: &CandelaGrid, omega: V3) -> f64 {
        grid.intensity_dir([dot(omega, self.u), dot(omega, self.v), -dot(omega, self.n)])
    }

    /// Radiance substitute L_e (Eq. 2) for the emitter point `p` seen from `x` (cd/m²); 0 when
    /// x lies in the light's plane.
    pub fn radiance(&self, grid: &CandelaGrid, p: V3, x: V3) -> f64 {
        let omega = normalize(sub(x, p));
        let c = dot(omega, self.n).abs();
        if c <= 0.0 {
            return 0.0;
        }
        self.intensity(grid, omega) / (self.area() * c)
    }

    /// Local (a, b) of the point of the plane nearest to `x`, clamped to the rectangle.
    pub fn clamp_local(&self, p: V3) -> (f64, f64) {
        let d = sub(p, self.center);
        (
            dot(d, self.u).clamp(-0.5 * self.width_m, 0.5 * self.width_m),
            dot(d, self.v).clamp(-0.5 * self.height_m, 0.5 * self.height_m),
        )
    }
}

/// A receiving point: position (m) and unit normal.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Receiver {
    /// Position in m.
    pub p: V3,
    /// Unit normal of the receiving surface.
    pub n: V3,
}

/// Shading method, chosen at run time.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Method {
    /// Point light at the centre.
    Point,
    /// Uniform Monte Carlo over the rectangle with `samples` points, seeded.
    Mc {
        /// Samples per receiving point.
        samples: usize,
        /// Seed (each point uses seed ⊕ its index).
        seed: u64,
    },
    /// Structured sampling (Eq. 4): corners + barycentre.
    Structured,
    /// Most representative point.
    Mrp,
    /// The paper's cubature (Eq. 6–11, §5.3).
    Cubature,
    /// The cubature with adaptive subdivision to a relative tolerance.
    CubatureAdaptive {
        /// Relative tolerance (e.g. 0.01).
        tolerance: f64,
    },
}

impl Method {
    /// The CLI name.
    pub fn name(&self) -> &'static str {
        match self {
            Method::Point => "point",
            Method::Mc { .. } => "mc",
            Method::Structured => "structured",
            Method::Mrp => "mrp",
            Method::Cubature => "cubature",
            Method::CubatureAdaptive { .. } => "cubature-adaptive",
        }
    }
}

/// Illuminance at one point.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Shade {
    /// Illuminance on the receiving surface, lux.
    pub e_lux: f64,
    /// Standard error of `e_lux` (Monte Carlo only).
    pub e_std: Option<f64>,
    /// Energy-equivalent radiance L̄_e (Eq. 16), cd/m² (cubature methods only).
    pub le_bar: Option<f64>,
    /// Spherical triangles evaluated (cubature methods), or samples.
    pub evaluations: usize,
}

/// Solid angle of the planar triangle (a, b, c) seen from the origin (vectors need not be
/// normalised): Van Oosterom & Strackee (1983), Eq. 11 of the paper, with atan2 so Ω > π is
/// right and degenerate triangles give 0.
pub fn triangle_solid_angle(a: V3, b: V3, c: V3) -> f64 {
    let (la, lb, lc) = (norm(a), norm(b), norm(c));
    if la == 0.0 || lb == 0.0 || lc == 0.0 {
        return 0.0;
    }
    let num = dot(a, cross(b, c)).abs();
    let den = la * lb * lc + dot(a, b) * lc + dot(a, c) * lb + dot(b, c) * la;
    2.0 * num.atan2(den)
}

/// Solid angle of a convex polygon seen from `x` (fan from its first vertex).
pub fn polygon_solid_angle(poly: &[V3], x: V3) -> f64 {
    if poly.len() < 3 {
        return 0.0;
    }
    let a = sub(poly[0], x);
    (1..poly.len() - 1)
        .map(|i| triangle_solid_angle(a, sub(poly[i], x), sub(poly[i + 1], x)))
        .sum()
}

/// Clips a convex polygon to the half-space (p − x)·n ≥ 0 (Sutherland–Hodgman).
pub fn clip_to_horizon(poly: &[V3], x: V3, n: V3) -> Vec<V3> {
    let mut out = Vec::with_capacity(poly.len() + 1);
    let k = poly.len();
    for i in 0..k {
        let (p, q) = (poly[i], poly[(i + 1) % k]);
        let (dp, dq) = (dot(sub(p, x), n), dot(sub(q, x), n));
        if dp >= 0.0 {
            out.push(p);
        }
        if (dp >= 0.0) != (dq >= 0.0) {
            let t = dp / (dp - dq);
            out.push(add(p, scale(sub(q, p), t)));
        }
    }
    out
}

/// ∫_Ω (ω·n)⁺ dω over a convex polygon seen from `x` (Lambert's formula after clipping at the
/// horizon of (x, n)): ½ Σ_edges θ_k (n · normalize(a_k × a_{k+1})), absolute value.
pub fn projected_solid_angle(poly: &[V3], x: V3, n: V3) -> f64 {
    let clipped = clip_to_horizon(poly, x, n);
    let k = clipped.len();
    if k < 3 {
        return 0.0;
    }
    let mut s = 0.0;
    for i in 0..k {
        let a = normalize(sub(clipped[i], x));
        let b = normalize(sub(clipped[(i + 1) % k], x));
        let c = cross(a, b);
        let cn = norm(c);
        if cn == 0.0 {
            continue;
        }
        let theta = cn.atan2(dot(a, b));
        s += theta * dot(n, c) / cn;
    }
    0.5 * s.abs()
}

/// Closed-form illuminance of a uniform emitter of radiance `l` (cd/m², both sides emitting
/// alike) at receiver `r`: E = L ∫ (ω·n)⁺ dω.
pub fn lambertian_illuminance(light: &RectLight, l: f64, r: &Receiver) -> f64 {
    l * projected_solid_angle(&light.corners(), r.p, r.n)
}

fn point_method(light: &RectLight, grid: &CandelaGrid, r: &Receiver) -> Shade {
    let d = sub(r.p, light.center);
    let d2 = dot(d, d);
    let e = if d2 > 0.0 {
        let omega = scale(d, 1.0 / d2.sqrt());
        let cos_x = (-dot(omega, r.n)).max(0.0);
        light.intensity(grid, omega) * cos_x / d2
    } else {
        0.0
    };
    Shade {
        e_lux: e,
        e_std: None,
        le_bar: None,
        evaluations: 1,
    }
}

/// The Monte Carlo integrand of E at the emitter point of local coordinates (a, b):
/// I(ω) (ω_i·n_x)⁺ / r², whose mean over the rectangle is E (lux).
pub fn area_sample(light: &RectLight, grid: &CandelaGrid, r: &Receiver, a: f64, b: f64) -> f64 {
    let p = light.point(a, b);
    let d = sub(r.p, p);
    let d2 = dot(d, d);
    if d2 > 0.0 {
        let omega = scale(d, 1.0 / d2.sqrt());
        light.intensity(grid, omega) * (-dot(omega, r.n)).max(0.0) / d2
    } else {
        0.0
    }
}

fn mc_method(
    light: &RectLight,
    grid: &CandelaGrid,
    r: &Receiver,
    samples: usize,
    seed: u64,
) -> Shade {
    let mut rng = SplitMix64::new(seed);
    let (mut s, mut s2) = (0.0, 0.0);
    for _ in 0..samples {
        let a = (rng.uniform() - 0.5) * light.width_m;
        let b = (rng.uniform() - 0.5) * light.height_m;
        let f = area_sample(light, grid, r, a, b);
        s += f;
        s2 += f * f;
    }
    let n = samples as f64;
    let mean = s / n;
    let var = if samples > 1 {
        ((s2 - n * mean * mean) / (n - 1.0)).max(0.0)
    } else {
        0.0
    };
    Shade {
        e_lux: mean,
        e_std: Some((var / n).sqrt()),
        le_bar: None,
        evaluations: samples,
    }
}

/// L_e(−ω_i)(ω_i·n_x)⁺ for the emitter point `p` seen from receiver `r`.
fn integrand(light: &RectLight, grid: &CandelaGrid, r: &Receiver, p: V3) -> f64 {
    let wi = normalize(sub(p, r.p));
    let g = dot(wi, r.n).max(0.0);
    if g == 0.0 {
        return 0.0;
    }
    light.radiance(grid, p, r.p) * g
}

fn structured_method(light: &RectLight, grid: &CandelaGrid, r: &Receiver) -> Shade {
    let corners = light.corners();
    let omega = polygon_solid_angle(&corners, r.p);
    let mut s = integrand(light, grid, r, light.center);
    for c in corners {
        s += integrand(light, grid, r, c);
    }
    Shade {
        e_lux: omega * s / 5.0,
        e_std: None,
        le_bar: None,
        evaluations: 5,
    }
}

/// Drobot's most representative point (local coordinates on the rectangle).
pub fn most_representative_point(light: &RectLight, r: &Receiver) -> V3 {
    let cp = {
        let (a, b) = light.clamp_local(r.p);
        light.point(a, b)
    };
    let size = light.width_m.max(light.height_m);
    let denom = dot(r.n, light.n);
    let t = if denom.abs() > 1e-12 {
        dot(sub(light.center, r.p), light.n) / denom
    } else {
        -1.0
    };
    let np_raw = if t > 0.0 {
        add(r.p, scale(r.n, t))
    } else {
        // the normal ray misses the plane: go far along the normal's projection onto the plane
        let proj = sub(r.n, scale(light.n, dot(r.n, light.n)));
        add(cp, scale(normalize(proj), 1e3 * size))
    };
    let np = {
        let (a, b) = light.clamp_local(np_raw);
        light.point(a, b)
    };
    let h = normalize(add(normalize(sub(cp, r.p)), normalize(sub(np, r.p))));
    let denom = dot(h, light.n);
    let hit = if denom.abs() > 1e-12 {
        let t = dot(sub(light.center, r.p), light.n) / denom;
        if t > 0.0 {
            add(r.p, scale(h, t))
        } else {
            cp
        }
    } else {
        cp
    };
    let (a, b) = light.clamp_local(hit);
    light.point(a, b)
}

fn mrp_method(light: &RectLight, grid: &CandelaGrid, r: &Receiver) -> Shade {
    let omega = polygon_solid_angle(&light.corners(), r.p);
    let p = most_representative_point(light, r);
    Shade {
        e_lux: omega * integrand(light, grid, r, p),
        e_std: None,
        le_bar: None,
        evaluations: 1,
    }
}

/// Illuminance at one receiver by `method`.
pub fn shade(
    light: &RectLight,
    grid: &CandelaGrid,
    r: &Receiver,
    method: Method,
    index: usize,
) -> Shade {
    match method {
        Method::Point => point_method(light, grid, r),
        Method::Mc { samples, seed } => mc_method(
            light,
            grid,
            r,
            samples,
            seed ^ (index as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15),
        ),
        Method::Structured => structured_method(light, grid, r),
        Method::Mrp => mrp_method(light, grid, r),
        Method::Cubature => super::luksch2020::cubature(light, grid, r),
        Method::CubatureAdaptive { tolerance } => {
            super::luksch2020::cubature_adaptive(light, grid, r, tolerance)
        }
    }
}

/// Illuminance at every receiver, in parallel over points (rayon). Validates the receivers'
/// normals and the method's parameters first.
pub fn illuminance(
    light: &RectLight,
    grid: &CandelaGrid,
    receivers: &[Receiver],
    method: Method,
) -> Result<Vec<Shade>> {
    match method {
        Method::Mc { samples: 0, .. } => {
            return Err(Error::invalid("--samples", "expected at least 1 sample"))
        }
        Method::CubatureAdaptive { tolerance } if !(tolerance > 0.0 && tolerance < 1.0) => {
            return Err(Error::invalid(
                "--tolerance",
                format!("{tolerance}: expected a relative tolerance in (0, 1)"),
            ))
        }
        _ => {}
    }
    if let Some(i) = receivers
        .iter()
        .position(|r| !(norm(r.n) - 1.0).abs().lt(&1e-6))
    {
        return Err(Error::invalid(
            "points",
            format!("row {}: normal is not a unit vector", i + 1),
        ));
    }
    Ok(receivers
        .par_iter()
        .enumerate()
        .map(|(i, r)| shade(light, grid, r, method, i))
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn solid_angle_of_a_square_seen_from_its_axis_matches_the_closed_form() {
        // square of side 2a at distance d: Ω = 4 asin(a² / (a² + d²))
        let light = RectLight::new([0.0; 3], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0], 2.0, 2.0).unwrap();
        let x = [0.0, 0.0, -0.5];
        let want = 4.0 * (1.0f64 / (1.0 + 0.25)).asin();
        assert!((polygon_solid_angle(&light.corners(), x) - want).abs() < 1e-12);
    }

    #[test]
    fn projected_solid_angle_of_a_large_square_overhead_tends_to_pi() {
        let light =
            RectLight::new([0.0, 0.0, 1.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0], 1e4, 1e4).unwrap();
        let r = Receiver {
            p: [0.0; 3],
            n: [0.0, 0.0, 1.0],
        };
        assert!(
            (projected_solid_angle(&light.corners(), r.p, r.n) - std::f64::consts::PI).abs() < 1e-3
        );
    }
}
