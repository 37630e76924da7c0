//! Design of a phosphorescent material from keyframes (Nalbach et al. 2017, §6, Eq. 7).
//!
//! Given the irradiance history E_c(t) at one point (three channels, piecewise constant) and
//! target outgoing radiance L̂_i at keyframes t_i, find θ = (Λ ∈ ℝ³, k_e ∈ ℝ³, k_r) of one state
//! minimising Eq. 7, `f(θ) = Σ_i ‖L_o^θ(t_i) − L̂_i‖²` with
//!
//! `L_o,c(t) = ρ_c E_c(t)/π + Λ_c k_r r(t)`,  `dr/dt = (1 − r) Σ_c k_e,c E_c(t) − k_r r`, r(t₀) = 0,
//!
//! (ρ the albedo, Lambertian reflection). The structure is used: for fixed (k_e, k_r) the
//! emission is linear in Λ, so each Λ_c ≥ 0 has a closed-form least-squares value (variable
//! projection), and only the four rates remain. They are searched on a coarse log-grid (rates
//! a·2^b like the paper, plus 0 for k_e), then refined by Levenberg–Marquardt on log-rates with
//! a finite-difference Jacobian of the projected residual. r(t) is evaluated exactly (the
//! exponential update of Eq. 1 per constant segment), not by Euler steps.
//!
//! A target is reachable when the designed material reproduces every keyframe to
//! [`REACHABLE_REL`] (relative norm of the RGB residual).

// Index loops mirror the matrix notation of the maths; `!(a > b)` comparisons deliberately
// reject NaN along with out-of-range values.
#![allow(clippy::needless_range_loop, clippy::neg_cmp_op_on_partial_ord)]

use std::time::Instant;

use crate::error::{Error, Result};
use crate::fit::search::log_space;
use crate::fit::{levenberg_marquardt, LmOptions, LmReport, Residuals, Termination};

/// Relative keyframe residual up to which a target counts as reproduced (the 1 %).
pub const REACHABLE_REL: f64 = 0.01;

/// A piecewise-constant irradiance history: row k holds from `t_s[k]` to `t_s[k+1]` (the last
/// row holds on).
#[derive(Debug, Clone, PartialEq)]
pub struct IrradianceHistory {
    /// Row start times in s, strictly increasing.
    pub t_s: Vec<f64>,
    /// Irradiance per channel (≥ 0).
    pub e: Vec<[f64; 3]>,
}

/// A keyframe target.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Keyframe {
    /// Time in s (≥ the history's start).
    pub t_s: f64,
    /// Target outgoing radiance per channel.
    pub radiance: [f64; 3],
}

/// Options.
#[derive(Debug, Clone, PartialEq)]
pub struct DesignOptions {
    /// Albedo per channel (Lambertian reflection ρE/π).
    pub albedo: [f64; 3],
    /// Grid points per rate dimension (k_e also gets 0).
    pub grid_points: usize,
    /// Refine the grid optimum by least squares.
    pub refine: bool,
}

impl Default for DesignOptions {
    fn default() -> Self {
        DesignOptions {
            albedo: [0.0; 3],
            grid_points: 6,
            refine: true,
        }
    }
}

/// One stage's result.
#[derive(Debug, Clone, PartialEq)]
pub struct DesignStage {
    /// k_e per channel.
    pub k_e: [f64; 3],
    /// k_r in s⁻¹.
    pub k_r_per_s: f64,
    /// Λ per channel.
    pub lambda: [f64; 3],
    /// Eq. 7 cost.
    pub cost: f64,
    /// Modelled radiance at each keyframe.
    pub predicted: Vec<[f64; 3]>,
    /// Relative residual ‖L − L̂‖/‖L̂‖ per keyframe.
    pub relative_residual: Vec<f64>,
    /// Wall time of the stage in s.
    pub time_s: f64,
    /// Levenberg–Marquardt iterations of the refinement (0 for the grid).
    pub iterations: usize,
    /// Why the refinement stopped (`None` for the grid stage).
    pub termination: Option<Termination>,
}

/// The design.
#[derive(Debug, Clone, PartialEq)]
pub struct Design {
    /// The grid optimum.
    pub grid: DesignStage,
    /// The refined optimum (equal to the grid when refinement is off).
    pub refined: DesignStage,
    /// Grid candidates evaluated.
    pub grid_candidates: usize,
    /// Whether every keyframe is reproduced to [`REACHABLE_REL`].
    pub reachable: bool,
    /// Why not, when not.
    pub note: String,
}

struct Problem<'a> {
    hist: &'a IrradianceHistory,
    keys: Vec<Keyframe>,
    /// Target minus reflection, per keyframe.
    y: Vec<[f64; 3]>,
}

impl Problem<'_> {
    /// r at every keyframe (keys sorted by time).
    fn r_at_keys(&self, k_e: &[f64; 3], k_r: f64) -> Vec<f64> {
        let h = self.hist;
        let n = h.t_s.len();
        let mut out = Vec::with_capacity(self.keys.len());
        let mut r = 0.0;
        let mut seg = 0;
        let mut t = h.t_s[0];
        for key in &self.keys {
            // advance whole segments that end before the key
            while seg + 1 < n && h.t_s[seg + 1] <= key.t_s {
                r = step(r, k_e, &h.e[seg], k_r, h.t_s[seg + 1] - t);
                seg += 1;
                t = h.t_s[seg];
            }
            let rk = step(r, k_e, &h.e[seg], k_r, key.t_s - t);
            out.push(rk);
            r = rk;
            t = key.t_s;
        }
        out
    }

    /// Λ by projection and the residuals.
    fn evaluate(&self, k_e: &[f64; 3], k_r: f64) -> ([f64; 3], Vec<[f64; 3]>, f64) {
        let r = self.r_at_keys(k_e, k_r);
        let q: Vec<f64> = r.iter().map(|v| v * k_r).collect();
        let qq: f64 = q.iter().map(|v| v * v).sum();
        let mut lambda = [0.0; 3];
        for c in 0..3 {
            let qy: f64 = q.iter().zip(&self.y).map(|(a, y)| a * y[c]).sum();
            lambda[c] = if qq > 0.0 { (qy / qq).max(0.0) } else { 0.0 };
        }
        let mut cost = 0.0;
        let res: Vec<[f64; 3]> = q
            .iter()
            .zip(&self.y)
            .map(|(qi, y)| {
                let mut d = [0.0; 3];
                for c in 0..3 {
                    d[c] = lambda[c] * qi - y[c];
                    cost += d[c] * d[c];
                }
                d
            })
            .collect();
        (lambda, res, cost)
    }

    fn stage(&self, k_e: [f64; 3], k_r: f64, time_s: f64) -> DesignStage {
        let (lambda, res, cost) = self.evaluate(&k_e, k_r);
        let predicted: Vec<[f64; 3]> = res
            .iter()
            .zip(&self.keys)
            .map(|(d, k)| [0, 1, 2].map(|c| k.radiance[c] + d[c]))
            .collect();
        let relative_residual = res
            .iter()
            .zip(&self.keys)
            .map(|(d, k)| {
                let nd = d.iter().map(|v| v * v).sum::<f64>().sqrt();
                let nt = k.radiance.iter().map(|v| v * v).sum::<f64>().sqrt();
                if nt > 0.0 {
                    nd / nt
                } else if nd > 0.0 {
                    f64::INFINITY
                } else {
                    0.0
                }
            })
            .collect();
        DesignStage {
            k_e,
            k_r_per_s: k_r,
            lambda,
            cost,
            predicted,
            relative_residual,
            time_s,
            iterations: 0,
            termination: None,
        }
    }
}

/// Exact update of Eq. 1 over `h` seconds of constant irradiance `e`.
fn step(r: f64, k_e: &[f64; 3], e: &[f64; 3], k_r: f64, h: f64) -> f64 {
    if h <= 0.0 {
        return r;
    }
    let a = k_e[0] * e[0] + k_e[1] * e[1] + k_e[2] * e[2];
    let lam = a + k_r;
    if !(lam > 0.0) {
        return r;
    }
    let req = a / lam;
    req + (r - req) * (-lam * h).exp()
}

fn validate(hist: &IrradianceHistory, keys: &[Keyframe], opts: &DesignOptions) -> Result<()> {
    if hist.t_s.is_empty() || hist.t_s.len() != hist.e.len() {
        return Err(Error::invalid(
            "history",
            "no rows (or times and irradiances of different counts); expected rows time_s,e_r,e_g,e_b",
        ));
    }
    for k in 0..hist.t_s.len() {
        if !hist.t_s[k].is_finite() || (k > 0 && !(hist.t_s[k] > hist.t_s[k - 1])) {
            return Err(Error::invalid(
                "history",
                format!(
                    "row {}: time {} s; times must be finite and strictly increasing",
                    k + 1,
                    hist.t_s[k]
                ),
            ));
        }
        if hist.e[k].iter().any(|v| !(v.is_finite() && *v >= 0.0)) {
            return Err(Error::invalid(
                "history",
                format!(
                    "row {}: irradiance {:?}; expected finite values ≥ 0",
                    k + 1,
                    hist.e[k]
                ),
            ));
        }
    }
    if keys.is_empty() {
        return Err(Error::invalid(
            "targets",
            "no keyframes; expected at least one",
        ));
    }
    for (i, k) in keys.iter().enumerate() {
        if !(k.t_s.is_finite() && k.t_s >= hist.t_s[0]) {
            return Err(Error::invalid(
                "targets",
                format!(
                    "keyframe {} at {} s is before the history starts ({} s); expected times within the history",
                    i + 1,
                    k.t_s,
                    hist.t_s[0]
                ),
            ));
        }
        if k.radiance.iter().any(|v| !v.is_finite()) {
            return Err(Error::invalid(
                "targets",
                format!("keyframe {}: radiance is not finite", i + 1),
            ));
        }
    }
    if opts.albedo.iter().any(|v| !(v.is_finite() && *v >= 0.0)) {
        return Err(Error::invalid(
            "albedo",
            format!("{:?}; expected three finite values ≥ 0", opts.albedo),
        ));
    }
    if !(2..=64).contains(&opts.grid_points) {
        return Err(Error::invalid(
            "grid points",
            format!("{}; expected 2 to 64", opts.grid_points),
        ));
    }
    Ok(())
}

/// Irradiance at time t (the row holding at t).
pub fn irradiance_at(hist: &IrradianceHistory, t_s: f64) -> [f64; 3] {
    let k = hist.t_s.partition_point(|x| *x <= t_s).saturating_sub(1);
    hist.e[k]
}

/// Outgoing radiance at times `t_s` (sorted) of a material (k_e, k_r, Λ) with albedo.
pub fn outgoing_radiance(
    hist: &IrradianceHistory,
    albedo: [f64; 3],
    k_e: [f64; 3],
    k_r_per_s: f64,
    lambda: [f64; 3],
    t_s: &[f64],
) -> Result<Vec<[f64; 3]>> {
    let keys: Vec<Keyframe> = t_s
        .iter()
        .map(|t| Keyframe {
            t_s: *t,
            radiance: [0.0; 3],
        })
        .collect();
    let opts = DesignOptions {
        albedo,
        ..DesignOptions::default()
    };
    validate(hist, &keys, &opts)?;
    if t_s.windows(2).any(|w| w[1] < w[0]) {
        return Err(Error::invalid("times", "expected sorted times"));
    }
    let prob = Problem {
        hist,
        keys,
        y: vec![[0.0; 3]; t_s.len()],
    };
    let r = prob.r_at_keys(&k_e, k_r_per_s);
    Ok(t_s
        .iter()
        .zip(r)
        .map(|(t, ri)| {
            let e = irradiance_at(hist, *t);
            [0, 1, 2].map(|c| albedo[c] * e[c] / std::f64::consts::PI + lambda[c] * k_r_per_s * ri)
        })
        .collect())
}

/// Designs a one-state RGB material whose outgoing radiance meets the keyframes (Eq. 7).
pub fn design_from_keyframes(
    hist: &IrradianceHistory,
    keyframes: &[Keyframe],
    opts: &DesignOptions,
) -> Result<Design> {
    validate(hist, keyframes, opts)?;
    let mut keys = keyframes.to_vec();
    keys.sort_by(|a, b| a.t_s.total_cmp(&b.t_s));
    let y: Vec<[f64; 3]> = keys
        .iter()
        .map(|k| {
            let e = irradiance_at(hist, k.t_s);
            [0, 1, 2].map(|c| k.radiance[c] - opts.albedo[c] * e[c] / std::f64::consts::PI)
        })
        .collect();
    let prob = Problem { hist, keys, y };
    // Grid ranges from the time scales of the problem: rates from 1/(20 T) to 20/Δt_min.
    let t_end = prob.keys.last().map_or(hist.t_s[0], |k| k.t_s);
    let span = (t_end - hist.t_s[0]).max(1e-6);
    let dt_min = hist
        .t_s
        .windows(2)
        .map(|w| w[1] - w[0])
        .fold(span, f64::min)
        .max(span * 1e-4);
    let (lo, hi) = (0.05 / span, 20.0 / dt_min);
    let n = opts.grid_points;
    let rates = log_space(lo, hi, n);
    let e_max: [f64; 3] = [0, 1, 2].map(|c| hist.e.iter().fold(0.0_f64, |m, e| m.max(e[c])));
    let ke_grid: Vec<Vec<f64>> = (0..3)
        .map(|c| {
            let mut g = vec![0.0];
            if e_max[c] > 0.0 {
                g.extend(rates.iter().map(|r| r / e_max[c]));
            }
            g
        })
        .collect();
    let start = Instant::now();
    let mut best = (f64::INFINITY, [0.0; 3], rates[0]);
    let mut count = 0usize;
    for &k_r in &rates {
        for &k0 in &ke_grid[0] {
            for &k1 in &ke_grid[1] {
                for &k2 in &ke_grid[2] {
                    let ke = [k0, k1, k2];
                    let (_, _, cost) = prob.evaluate(&ke, k_r);
                    count += 1;
                    if cost < best.0 {
                        best = (cost, ke, k_r);
                    }
                }
            }
        }
    }
    let grid_time = start.elapsed().as_secs_f64();
    let grid = prob.stage(best.1, best.2, grid_time);
    let refined = if opts.refine {
        let start = Instant::now();
        let (ke, kr, rep) = refine(&prob, best.1, best.2, &e_max, lo);
        let mut s = prob.stage(ke, kr, start.elapsed().as_secs_f64());
        s.iterations = rep.iterations;
        s.termination = Some(rep.termination);
        if s.cost <= grid.cost {
            s
        } else {
            DesignStage {
                time_s: s.time_s,
                ..grid.clone()
            }
        }
    } else {
        grid.clone()
    };
    let worst = refined
        .relative_residual
        .iter()
        .fold(0.0_f64, |m, v| m.max(*v));
    let reachable = worst <= REACHABLE_REL;
    let note = if reachable {
        format!(
            "every keyframe reproduced to {:.2e} (≤ {REACHABLE_REL})",
            worst
        )
    } else {
        let lower = prob.y.iter().any(|y| y.iter().any(|v| *v < 0.0));
        format!(
            "not reachable: worst keyframe residual {:.2} % > {:.0} %{}; the best compromise \
             (least Eq. 7 cost) is reported",
            worst * 100.0,
            REACHABLE_REL * 100.0,
            if lower {
                " — some target lies below the reflected light, which phosphorescence cannot subtract"
            } else {
                ""
            }
        )
    };
    Ok(Design {
        grid,
        refined,
        grid_candidates: count,
        reachable,
        note,
    })
}

/// The refinement as a least-squares problem for [`fit::lm`](crate::fit::lm): parameters
/// u = ln(k_e) of the channels with light, then ln k_r; residuals the Eq. 7 residuals of
/// every keyframe and channel (Λ projected out by [`Problem::evaluate`]).
struct LogRates<'a, 'p> {
    prob: &'a Problem<'p>,
    active: Vec<usize>,
}

impl LogRates<'_, '_> {
    fn unpack(&self, u: &[f64]) -> ([f64; 3], f64) {
        let mut ke = [0.0; 3];
        for (i, &c) in self.active.iter().enumerate() {
            ke[c] = u[i].exp();
        }
        (ke, u[self.active.len()].exp())
    }
}

impl Residuals for LogRates<'_, '_> {
    fn n_residuals(&self) -> usize {
        3 * self.prob.keys.len()
    }
    fn n_params(&self) -> usize {
        self.active.len() + 1
    }
    fn residuals(&self, u: &[f64], out: &mut [f64]) -> bool {
        let (ke, kr) = self.unpack(u);
        for (o, v) in out
            .iter_mut()
            .zip(self.prob.evaluate(&ke, kr).1.into_iter().flatten())
        {
            *o = v;
        }
        true
    }
}

/// LM on u = ln(rates) of the channels with light, and ln k_r (finite-difference Jacobian,
/// ln-rates bounded to ±700 so the rates stay finite); returns the rates and the report.
fn refine(
    prob: &Problem,
    ke0: [f64; 3],
    kr0: f64,
    e_max: &[f64; 3],
    rate_floor: f64,
) -> ([f64; 3], f64, LmReport) {
    let active: Vec<usize> = (0..3).filter(|c| e_max[*c] > 0.0).collect();
    let mut u: Vec<f64> = active
        .iter()
        .map(|&c| (ke0[c].max(rate_floor * 1e-3 / e_max[c])).ln())
        .collect();
    u.push(kr0.ln());
    let np = u.len();
    let problem = LogRates { prob, active };
    // steps of at most ±3 in ln-rate (a factor 20): far from the data's time scales the cost
    // is flat in a rate, and an unlimited step would land on such a plateau
    let opts = LmOptions {
        max_step: Some(vec![3.0; np]),
        ..LmOptions::default().with_bounds(vec![-700.0; np], vec![700.0; np])
    };
    let u0: Vec<f64> = u.iter().map(|v| v.clamp(-700.0, 700.0)).collect();
    let rep = levenberg_marquardt(&problem, &u0, &opts);
    let (ke, kr) = problem.unpack(&rep.theta);
    (ke, kr, rep)
}
