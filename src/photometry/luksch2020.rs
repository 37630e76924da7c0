//! Cubature over a triangle fan for photometric polygonal lights (Luksch, Prost & Wimmer 2020,
//! "Real-time Approximation of Photometric Polygonal Lights", PACMCGIT 3(1), §5), and an
//! adaptive refinement of it.
//!
//! # The paper's method (`cubature`)
//!
//! For a receiving point x with normal n_x and the rectangle A (see
//! [`super::illuminance`] for the frame):
//!
//! 1. §5.3: if x lies within ε = 10⁻⁶·max(W, H) of the light's plane it is moved to distance ε
//!    on the side its normal faces (the front side when the normal lies in the plane); the
//!    opposite shift of the lookup direction is skipped, as in the paper's final implementation.
//!    Without the shift L_e = I/(A cos θ_A) (Eq. 2) is undefined in the plane, where the solid
//!    angle vanishes and the radiance diverges.
//! 2. The polygon is clipped at the receiver's horizon plane (Sutherland–Hodgman).
//! 3. The closest point CP: x projected onto the light's plane, clamped to the clipped polygon.
//! 4. A triangle fan around CP over the clipped polygon's edges; each spherical triangle's area
//!    |Δ| from Van Oosterom & Strackee (Eq. 11, with atan2 so that |Δ| > π/2 is right and a
//!    degenerate triangle gives 0).
//! 5. E(x) = Σ_Δ (L_i + L_j + L_k)/3 · (G_i + G_j + G_k)/3 · |Δ| (Eq. 10, the product of
//!    averages), L = I/(A |ω·n_A|), G = (ω_i·n_x)⁺; the paper's L_d is ρ/π times this.
//! 6. G_Ω = Σ_Δ (G_i + G_j + G_k)/3 · |Δ| (Eq. 15) and L̄_e = E/G_Ω (Eq. 16), the
//!    energy-equivalent radiance for specular shading.
//!
//! # Beyond the paper (`cubature-adaptive`)
//!
//! A fan of four triangles is only as good as its vertices: for a uniform 1 × 1 emitter 0.1 above
//! the receiver, Eq. 10 is ≈ 28 % low directly underneath, where G varies from 1 at CP to ≈ 0.14
//! at the corners. The adaptive variant starts from the same fan and splits each triangle into
//! four at its edge midpoints (on the emitter's plane) while
//!
//! - it has not been split once yet (every fan triangle is split at least once), or
//! - its solid angle exceeds 0.25 sr, or
//! - the four children's Eq. 10 sum differs from the parent's by more than
//!   ½·`tolerance`·(|children| + E₀·|Δ|/Ω) + 10⁻¹²·E₀/Ω, E₀ the paper's estimate and Ω the
//!   clipped polygon's solid angle (so tiny, dim triangles and the slivers of a CP on an edge
//!   are not refined for nothing),
//!
//! up to depth 10. The refined sum is returned. On the Lambertian check (1 × 1 emitter at 0.1
//! over a 4 × 4 m patch, 33 × 33 points) the default tolerance 0.01 gives ≤ 0.46 % error
//! everywhere (the paper's fan: 30.5 % worst, 3.0 % median) at a mean of 268 triangles per
//! point instead of 4; cost and accuracy per height are in `docs/photometry.md`.

use super::illuminance::{
    add, clip_to_horizon, cross, dot, normalize, scale, sub, triangle_solid_angle, Receiver,
    RectLight, Shade, V3,
};
use super::CandelaGrid;

/// Relative size of the §5.3 epsilon region (times the light's larger side).
pub const SHIFT_EPSILON: f64 = 1e-6;
/// Largest solid angle (sr) an adaptive triangle may keep.
pub const MAX_TRIANGLE_SR: f64 = 0.25;
/// Every fan triangle is split at least this many times.
pub const MIN_DEPTH: u32 = 1;
/// Deepest subdivision of one fan triangle.
pub const MAX_DEPTH: u32 = 10;

/// A sample on the emitter: position, L_e and G.
#[derive(Clone, Copy)]
struct Sample {
    p: V3,
    l: f64,
    g: f64,
}

struct Ctx<'a> {
    light: &'a RectLight,
    grid: &'a CandelaGrid,
    x: V3,
    n: V3,
}

impl Ctx<'_> {
    fn sample(&self, p: V3) -> Sample {
        let wi = normalize(sub(p, self.x));
        Sample {
            p,
            l: self.light.radiance(self.grid, p, self.x),
            g: dot(wi, self.n).max(0.0),
        }
    }

    /// (E, G_Ω) of one triangle by Eq. 10 / Eq. 15.
    fn eq10(&self, a: &Sample, b: &Sample, c: &Sample) -> (f64, f64, f64) {
        let omega = triangle_solid_angle(sub(a.p, self.x), sub(b.p, self.x), sub(c.p, self.x));
        let lbar = (a.l + b.l + c.l) / 3.0;
        let gbar = (a.g + b.g + c.g) / 3.0;
        (lbar * gbar * omega, gbar * omega, omega)
    }
}

/// The §5.3 shift: the shading position actually used.
fn shifted_position(light: &RectLight, r: &Receiver) -> V3 {
    let eps = SHIFT_EPSILON * light.width_m.max(light.height_m);
    let d = dot(sub(r.p, light.center), light.n);
    if d.abs() >= eps {
        return r.p;
    }
    let side = if d != 0.0 {
        d.signum()
    } else {
        let s = dot(r.n, light.n);
        if s < 0.0 {
            -1.0
        } else {
            1.0
        }
    };
    add(r.p, scale(light.n, side * eps - d))
}

/// Closest point of the (convex, planar, counter-clockwise about n_A) polygon to `x`.
fn closest_point(poly: &[V3], light: &RectLight, x: V3) -> V3 {
    let q = sub(x, scale(light.n, dot(sub(x, light.center), light.n)));
    let k = poly.len();
    let inside = (0..k).all(|i| {
        dot(
            cross(sub(poly[(i + 1) % k], poly[i]), sub(q, poly[i])),
            light.n,
        ) >= 0.0
    });
    if inside {
        return q;
    }
    let mut best = poly[0];
    let mut best_d = f64::INFINITY;
    for i in 0..k {
        let (a, b) = (poly[i], poly[(i + 1) % k]);
        let ab = sub(b, a);
        let len2 = dot(ab, ab);
        let t = if len2 > 0.0 {
            (dot(sub(q, a), ab) / len2).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let p = add(a, scale(ab, t));
        let d = dot(sub(q, p), sub(q, p));
        if d < best_d {
            best_d = d;
            best = p;
        }
    }
    best
}

/// The clipped polygon and CP, or `None` when nothing of the light is above the horizon.
fn fan(light: &RectLight, r: &Receiver) -> Option<(V3, Vec<V3>, V3)> {
    let x = shifted_position(light, r);
    let poly = clip_to_horizon(&light.corners(), x, r.n);
    if poly.len() < 3 {
        return None;
    }
    let cp = closest_point(&poly, light, x);
    Some((x, poly, cp))
}

fn zero(evaluations: usize) -> Shade {
    Shade {
        e_lux: 0.0,
        e_std: None,
        le_bar: Some(0.0),
        evaluations,
    }
}

/// The paper's cubature (Eq. 10, 11, 15, 16 with horizon clipping and the §5.3 shift).
pub fn cubature(light: &RectLight, grid: &CandelaGrid, r: &Receiver) -> Shade {
    let Some((x, poly, cp)) = fan(light, r) else {
        return zero(0);
    };
    let ctx = Ctx {
        light,
        grid,
        x,
        n: r.n,
    };
    let c = ctx.sample(cp);
    let s: Vec<Sample> = poly.iter().map(|&p| ctx.sample(p)).collect();
    let (mut e, mut g) = (0.0, 0.0);
    for i in 0..s.len() {
        let (de, dg, _) = ctx.eq10(&c, &s[i], &s[(i + 1) % s.len()]);
        e += de;
        g += dg;
    }
    Shade {
        e_lux: e,
        e_std: None,
        le_bar: Some(if g > 0.0 { e / g } else { 0.0 }),
        evaluations: s.len(),
    }
}

struct Refine<'a> {
    ctx: Ctx<'a>,
    tol: f64,
    /// E₀/Ω: the absolute floor per steradian.
    floor_per_sr: f64,
    triangles: usize,
}

impl Refine<'_> {
    fn run(&mut self, a: Sample, b: Sample, c: Sample, depth: u32) -> (f64, f64) {
        let (e_p, g_p, omega) = self.ctx.eq10(&a, &b, &c);
        self.triangles += 1;
        if depth >= MAX_DEPTH || omega <= 0.0 {
            return (e_p, g_p);
        }
        let mid = |p: &Sample, q: &Sample| self.ctx.sample(scale(add(p.p, q.p), 0.5));
        let (ab, bc, ca) = (mid(&a, &b), mid(&b, &c), mid(&c, &a));
        let kids = [(a, ab, ca), (ab, b, bc), (ca, bc, c), (ab, bc, ca)];
        let mut e_c = 0.0;
        for k in &kids {
            e_c += self.ctx.eq10(&k.0, &k.1, &k.2).0;
        }
        // Half the tolerance against the estimate (the children's sum is kept, so its error is
        // about a third of the difference for a smooth integrand); the absolute floor stops
        // slivers (CP on an edge: |Δ| ≈ 1e-17 sr) from refining rounding noise.
        let allowed =
            0.5 * self.tol * (e_c.abs() + self.floor_per_sr * omega) + 1e-12 * self.floor_per_sr;
        if depth >= MIN_DEPTH && omega <= MAX_TRIANGLE_SR && (e_c - e_p).abs() <= allowed {
            let g_c: f64 = kids.iter().map(|k| self.ctx.eq10(&k.0, &k.1, &k.2).1).sum();
            self.triangles += 4;
            return (e_c, g_c);
        }
        let (mut e, mut g) = (0.0, 0.0);
        for k in kids {
            let (de, dg) = self.run(k.0, k.1, k.2, depth + 1);
            e += de;
            g += dg;
        }
        (e, g)
    }
}

/// The cubature refined adaptively to relative `tolerance` (module docs).
pub fn cubature_adaptive(
    light: &RectLight,
    grid: &CandelaGrid,
    r: &Receiver,
    tolerance: f64,
) -> Shade {
    let base = cubature(light, grid, r);
    let Some((x, poly, cp)) = fan(light, r) else {
        return zero(0);
    };
    let ctx = Ctx {
        light,
        grid,
        x,
        n: r.n,
    };
    let c = ctx.sample(cp);
    let s: Vec<Sample> = poly.iter().map(|&p| ctx.sample(p)).collect();
    let total_omega: f64 = (0..s.len())
        .map(|i| ctx.eq10(&c, &s[i], &s[(i + 1) % s.len()]).2)
        .sum();
    let floor_per_sr = if total_omega > 0.0 {
        base.e_lux / total_omega
    } else {
        0.0
    };
    let mut rf = Refine {
        ctx,
        tol: tolerance,
        floor_per_sr,
        triangles: 0,
    };
    let (mut e, mut g) = (0.0, 0.0);
    for i in 0..s.len() {
        let (de, dg) = rf.run(c, s[i], s[(i + 1) % s.len()], 0);
        e += de;
        g += dg;
    }
    Shade {
        e_lux: e,
        e_std: None,
        le_bar: Some(if g > 0.0 { e / g } else { 0.0 }),
        evaluations: rf.triangles,
    }
}
