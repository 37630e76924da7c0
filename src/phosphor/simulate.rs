//! Simulation of Eq. 1 under a piecewise-constant irradiance history, emission by Eq. 3, camera
//! RGB and exposure-window integrals in closed form.
//!
//! For constant irradiance E over a step h, Eq. 1 is linear in r_i with the exact solution
//!
//! `r(t+h) = r_eq + (r − r_eq)·exp(−(a + k_r) h)`, `a = Σ_b k_e[b] E[b]`, `r_eq = a/(a + k_r)`,
//!
//! the default integrator ([`Integrator::Exact`]). Classic RK4 and forward Euler (the paper's
//! §5 choice) are options for comparison; with them a stiff step (`(a + k_r) h > 2` for Euler)
//! diverges, the exact update never does. The integral of r over a sub-interval of length T of
//! a constant segment is `r_eq T + (r₀ − r_eq)(1 − e^{−λT})/λ`, λ = a + k_r, which gives frame
//! values over exposure windows without sampling.

// Index loops mirror the matrix notation of the maths; `!(a > b)` comparisons deliberately
// reject NaN along with out-of-range values.
#![allow(clippy::needless_range_loop, clippy::neg_cmp_op_on_partial_ord)]

use crate::error::{Error, Result};
use crate::spectrum::MultiSpectrum;

use super::material::{BandSet, Material};

/// A span of constant irradiance.
#[derive(Debug, Clone, PartialEq)]
pub struct Segment {
    /// Length in s (> 0).
    pub duration_s: f64,
    /// Irradiance per band of the material (≥ 0).
    pub irradiance: Vec<f64>,
}

/// The ODE integrator.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Integrator {
    /// The exact exponential update (default).
    Exact,
    /// Classic fourth-order Runge–Kutta.
    Rk4,
    /// Forward Euler, as in the paper's renderer.
    Euler,
}

/// Samples of a simulation.
#[derive(Debug, Clone, PartialEq)]
pub struct Simulation {
    /// Sample times in s (0 first).
    pub t_s: Vec<f64>,
    /// Concentrations, per sample per state.
    pub r: Vec<Vec<f64>>,
    /// Emission L_p per sample per band (Eq. 3).
    pub emission: Vec<Vec<f64>>,
}

/// Checks a history against a material.
pub fn validate_history(material: &Material, history: &[Segment]) -> Result<()> {
    let nb = material.bands.len();
    if history.is_empty() {
        return Err(Error::invalid(
            "history",
            "no segments; expected at least one span of constant irradiance",
        ));
    }
    for (s, seg) in history.iter().enumerate() {
        if !(seg.duration_s.is_finite() && seg.duration_s > 0.0) {
            return Err(Error::invalid(
                format!("history segment {}", s + 1),
                format!(
                    "duration {} s; expected a finite duration > 0",
                    seg.duration_s
                ),
            ));
        }
        if seg.irradiance.len() != nb {
            return Err(Error::ShapeMismatch {
                what: format!(
                    "irradiance of history segment {} against the material's bands",
                    s + 1
                ),
                expected: nb,
                got: seg.irradiance.len(),
            });
        }
        if let Some(v) = seg
            .irradiance
            .iter()
            .find(|v| !(v.is_finite() && **v >= 0.0))
        {
            return Err(Error::invalid(
                format!("history segment {}", s + 1),
                format!("irradiance {v}; expected finite values ≥ 0"),
            ));
        }
        if seg.irradiance.iter().any(|v| *v > 0.0) && !material.has_excitation() {
            return Err(Error::invalid(
                "material",
                format!(
                    "'{}' has no excitation rates k_e (decay only), so it cannot be charged; \
                     use a dark history or a material with k_e",
                    material.name
                ),
            ));
        }
    }
    Ok(())
}

/// Excitation term a_i = Σ_b k_e,i[b] E[b] per state.
fn excitation(material: &Material, e: &[f64]) -> Vec<f64> {
    material
        .states
        .iter()
        .map(|s| match &s.k_e {
            Some(k) => k.iter().zip(e).map(|(k, e)| k * e).sum(),
            None => 0.0,
        })
        .collect()
}

/// One step of length h with excitation terms `a` (per state).
fn step(material: &Material, a: &[f64], r: &mut [f64], h: f64, integrator: Integrator) {
    for (i, s) in material.states.iter().enumerate() {
        let (ai, kr) = (a[i], s.k_r_per_s);
        let f = |x: f64| (1.0 - x) * ai - kr * x;
        let x = r[i];
        r[i] = match integrator {
            Integrator::Exact => {
                let lam = ai + kr;
                let req = ai / lam;
                req + (x - req) * (-lam * h).exp()
            }
            Integrator::Euler => x + h * f(x),
            Integrator::Rk4 => {
                let k1 = f(x);
                let k2 = f(x + 0.5 * h * k1);
                let k3 = f(x + 0.5 * h * k2);
                let k4 = f(x + h * k3);
                x + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
            }
        };
    }
}

/// Emission per band (Eq. 3) for concentrations r.
pub fn emission(material: &Material, r: &[f64]) -> Vec<f64> {
    let nb = material.bands.len();
    let mut out = vec![0.0; nb];
    for (s, ri) in material.states.iter().zip(r) {
        for (o, l) in out.iter_mut().zip(&s.lambda) {
            *o += l * s.k_r_per_s * ri;
        }
    }
    out
}

/// Simulates from concentrations `r0` (one per state, in [0, 1]) with steps of at most `dt_s`;
/// steps end at every segment boundary. Returns a sample at t = 0 and after every step.
pub fn simulate(
    material: &Material,
    history: &[Segment],
    r0: &[f64],
    dt_s: f64,
    integrator: Integrator,
) -> Result<Simulation> {
    material.validate()?;
    validate_history(material, history)?;
    validate_r0(material, r0)?;
    if !(dt_s.is_finite() && dt_s > 0.0) {
        return Err(Error::invalid(
            "dt",
            format!("{dt_s} s; expected a finite step > 0"),
        ));
    }
    let total: f64 = history.iter().map(|s| s.duration_s).sum();
    if total / dt_s > 5e7 {
        return Err(Error::invalid(
            "dt",
            format!("{dt_s} s over {total} s would give more than 5e7 steps; use a larger step"),
        ));
    }
    let mut r = r0.to_vec();
    let mut sim = Simulation {
        t_s: vec![0.0],
        r: vec![r.clone()],
        emission: vec![emission(material, &r)],
    };
    let mut t0 = 0.0;
    for seg in history {
        let a = excitation(material, &seg.irradiance);
        let n = (seg.duration_s / dt_s - 1e-9).ceil().max(1.0) as usize;
        let h = seg.duration_s / n as f64;
        for k in 1..=n {
            step(material, &a, &mut r, h, integrator);
            sim.t_s.push(t0 + h * k as f64);
            sim.emission.push(emission(material, &r));
            sim.r.push(r.clone());
        }
        t0 += seg.duration_s;
    }
    Ok(sim)
}

fn validate_r0(material: &Material, r0: &[f64]) -> Result<()> {
    if r0.len() != material.states.len() {
        return Err(Error::ShapeMismatch {
            what: "initial concentrations against the states".into(),
            expected: material.states.len(),
            got: r0.len(),
        });
    }
    if let Some(v) = r0.iter().find(|v| !(**v >= 0.0 && **v <= 1.0)) {
        return Err(Error::invalid(
            "initial concentration",
            format!("{v}; expected a value in [0, 1]"),
        ));
    }
    Ok(())
}

/// Concentrations at the end of the history (exact), from `r0`.
pub fn final_state(material: &Material, history: &[Segment], r0: &[f64]) -> Result<Vec<f64>> {
    material.validate()?;
    validate_history(material, history)?;
    validate_r0(material, r0)?;
    let mut r = r0.to_vec();
    for seg in history {
        let a = excitation(material, &seg.irradiance);
        step(material, &a, &mut r, seg.duration_s, Integrator::Exact);
    }
    Ok(r)
}

/// Exposure-integrated emission per band, `∫_{t0}^{t1} L_p(t) dt` for each window, in closed
/// form (exact for piecewise-constant irradiance; windows past the end of the history continue
/// in darkness).
pub fn window_integrals(
    material: &Material,
    history: &[Segment],
    r0: &[f64],
    windows_s: &[(f64, f64)],
) -> Result<Vec<Vec<f64>>> {
    material.validate()?;
    validate_history(material, history)?;
    validate_r0(material, r0)?;
    let nb = material.bands.len();
    let ns = material.states.len();
    let dark = Segment {
        duration_s: f64::INFINITY,
        irradiance: vec![0.0; nb],
    };
    // Start state and excitation of every segment (the dark tail last).
    let mut segs: Vec<(f64, f64, Vec<f64>, Vec<f64>)> = Vec::with_capacity(history.len() + 1);
    let mut r = r0.to_vec();
    let mut t = 0.0;
    for seg in history.iter().chain(std::iter::once(&dark)) {
        let a = excitation(material, &seg.irradiance);
        segs.push((t, t + seg.duration_s, r.clone(), a.clone()));
        if seg.duration_s.is_finite() {
            step(material, &a, &mut r, seg.duration_s, Integrator::Exact);
        }
        t += seg.duration_s;
    }
    let mut out = Vec::with_capacity(windows_s.len());
    for (w, &(t0, t1)) in windows_s.iter().enumerate() {
        if !(t0.is_finite() && t1.is_finite() && t0 >= 0.0 && t1 > t0) {
            return Err(Error::invalid(
                format!("exposure window {}", w + 1),
                format!("[{t0}, {t1}] s; expected 0 ≤ start < end"),
            ));
        }
        let mut int_r = vec![0.0; ns];
        for (s0, s1, rs, a) in &segs {
            let lo = t0.max(*s0);
            let hi = t1.min(*s1);
            if hi <= lo {
                continue;
            }
            for i in 0..ns {
                let lam = a[i] + material.states[i].k_r_per_s;
                let req = a[i] / lam;
                let r_lo = req + (rs[i] - req) * (-lam * (lo - s0)).exp();
                let len = hi - lo;
                int_r[i] += req * len + (r_lo - req) * (-(-lam * len).exp_m1()) / lam;
            }
        }
        out.push(emission(material, &int_r));
    }
    Ok(out)
}

/// A linear camera: RGB = M · (emission per band), M of 3 rows × n bands.
#[derive(Debug, Clone, PartialEq)]
pub struct BandCamera {
    /// Rows R, G, B; one weight per band.
    pub matrix: [Vec<f64>; 3],
}

impl BandCamera {
    /// RGB of a per-band emission vector.
    pub fn rgb(&self, bands: &[f64]) -> [f64; 3] {
        let mut out = [0.0; 3];
        for (c, row) in self.matrix.iter().enumerate() {
            out[c] = row.iter().zip(bands).map(|(m, b)| m * b).sum();
        }
        out
    }

    /// The camera for a band set: identity for RGB bands; for wavelength bands, the mean of
    /// each channel's sensitivity over the band (the band's emission is treated as integrated
    /// over the band, spread evenly). Without sensitivities, an ideal box camera: B 400–500,
    /// G 500–600, R 600–700 nm, weight = the fraction of the band inside the box.
    pub fn for_bands(bands: &BandSet, sensitivities: Option<&MultiSpectrum>) -> Result<Self> {
        let ranges = match bands {
            BandSet::Rgb => {
                if sensitivities.is_some() {
                    return Err(Error::invalid(
                        "camera",
                        "the material's bands are already camera RGB; a camera applies to \
                         wavelength bands only",
                    ));
                }
                return Ok(BandCamera {
                    matrix: [
                        vec![1.0, 0.0, 0.0],
                        vec![0.0, 1.0, 0.0],
                        vec![0.0, 0.0, 1.0],
                    ],
                });
            }
            BandSet::RangesNm(r) => r,
        };
        let mut matrix = [Vec::new(), Vec::new(), Vec::new()];
        match sensitivities {
            None => {
                let boxes = [[600.0, 700.0], [500.0, 600.0], [400.0, 500.0]];
                for (c, [blo, bhi]) in boxes.iter().enumerate() {
                    for [lo, hi] in ranges {
                        let ov = (hi.min(*bhi) - lo.max(*blo)).max(0.0);
                        matrix[c].push(ov / (hi - lo));
                    }
                }
            }
            Some(ms) => {
                if ms.n_channels() != 3 {
                    return Err(Error::ShapeMismatch {
                        what: format!("channels of camera '{}' (expected r, g, b)", ms.name()),
                        expected: 3,
                        got: ms.n_channels(),
                    });
                }
                let wl = ms.wavelengths();
                for c in 0..3 {
                    let y = ms.channel(c);
                    for [lo, hi] in ranges {
                        let n = ((hi - lo).ceil() as usize).clamp(8, 4096);
                        let mut s = 0.0;
                        for k in 0..=n {
                            let x = lo + (hi - lo) * k as f64 / n as f64;
                            let v = if x < wl[0] || x > wl[wl.len() - 1] {
                                0.0
                            } else {
                                crate::math::interpolation::linear_at(wl, y, x)
                            };
                            s += if k == 0 || k == n { 0.5 * v } else { v };
                        }
                        matrix[c].push(s / n as f64);
                    }
                }
            }
        }
        Ok(BandCamera { matrix })
    }
}
