//! The shared-spectrum fit of n ≥ 2 states as one variable-projection solve (no alternation).
//!
//! For fixed log-rates θ the model W^½(Y − E a sᵀ − 1 bᵀ) (m × n_ch, b free per channel, s of
//! unit norm) is linear in a for fixed s and in s for fixed a, and its optimum over (a, s, b) is
//! exact: with u = W^½1/‖W^½1‖ the background is fitted exactly per channel, so the data and the
//! weighted exponentials are first projected off u (Ỹ, Ẽ); with Ẽ = QR the best spectrum is the
//! leading eigenvector of MᵀM (M = QᵀỸ, n × n_ch), the best amplitudes a = R⁻¹ M s, and
//!
//! `RSS(θ) = ‖(I − P)Ỹ‖² + Σ_{i≥2} σ_i²(M)`.
//!
//! The residual r(θ) = vec(Ỹ − Ẽ a sᵀ) with (a, s) optimal for θ is minimised by the crate's
//! Levenberg–Marquardt ([`crate::fit::levenberg_marquardt`], forward-difference Jacobian in θ).
//! The projection ignores a ≥ 0 and s ≥ 0; the caller checks the optimum and falls back to the
//! alternation (the reference path) when it is infeasible.

#![allow(clippy::needless_range_loop, clippy::neg_cmp_op_on_partial_ord)]

use super::*;
use crate::fit::{levenberg_marquardt, LmOptions, Qr, Residuals};
use std::cell::RefCell;

/// Relative finite-difference step in θ (forward differences: ≈ √ε, the projected residual is
/// smooth and exact to rounding).
const FD_STEP: f64 = 1e-7;

#[derive(Default)]
struct Scratch {
    /// Weighted exponentials, projected off u when a background is fitted (m × n).
    e: Vec<f64>,
    qr: Qr,
    /// QᵀỸ column by column (m each).
    qty: Vec<f64>,
    /// n × n_ch (column per channel).
    mm: Vec<f64>,
    /// n_ch × n_ch Gram matrix MᵀM.
    g: Vec<f64>,
    s: Vec<f64>,
    ms: Vec<f64>,
    a: Vec<f64>,
    f: Vec<f64>,
}

pub(super) struct Projected<'p, 'c> {
    prep: &'p Prepared<'c>,
    n: usize,
    background: bool,
    /// √w per row (ones for unit weights).
    sw: Vec<f64>,
    /// u = √w/‖√w‖ (background direction).
    u: Vec<f64>,
    /// W^½Y, projected off u when a background is fitted (m × n_ch).
    yt: Vec<f64>,
    sc: RefCell<Scratch>,
}

impl<'p, 'c> Projected<'p, 'c> {
    pub(super) fn new(prep: &'p Prepared<'c>, n: usize, background: bool, s0: &[f64]) -> Self {
        let (m, nc) = (prep.m, prep.n_ch);
        let sw: Vec<f64> = (0..m)
            .map(|i| prep.sqrt_w.as_ref().map_or(1.0, |w| w[i]))
            .collect();
        let un = sw.iter().map(|v| v * v).sum::<f64>().sqrt();
        let u: Vec<f64> = sw.iter().map(|v| v / un).collect();
        let mut yt = vec![0.0; m * nc];
        for c in 0..nc {
            let col = &mut yt[c * m..(c + 1) * m];
            for i in 0..m {
                col[i] = sw[i] * prep.y[c * m + i];
            }
            if background {
                project_off(&u, col);
            }
        }
        let sc = Scratch {
            s: s0.to_vec(),
            ..Scratch::default()
        };
        Projected {
            prep,
            n,
            background,
            sw,
            u,
            yt,
            sc: RefCell::new(sc),
        }
    }

    /// The optimal (a, s) at θ into the scratch and, if given, the residual. False when θ gives
    /// a non-finite or rank-deficient basis.
    fn solve(&self, theta: &[f64], sc: &mut Scratch, out: Option<&mut [f64]>) -> bool {
        let (m, nc, n) = (self.prep.m, self.prep.n_ch, self.n);
        let mut e = std::mem::take(&mut sc.e);
        self.prep.exp_table(theta, &mut e);
        for j in 0..n {
            let col = &mut e[j * m..(j + 1) * m];
            for i in 0..m {
                col[i] *= self.sw[i];
            }
            if self.background {
                project_off(&self.u, col);
            }
        }
        sc.e = e;
        if sc.e.iter().any(|v| !v.is_finite()) {
            return false;
        }
        sc.qr.factor(&sc.e, m, n);
        let rmax = (0..n).map(|j| sc.qr.r(j, j).abs()).fold(0.0_f64, f64::max);
        if !(rmax > 0.0) || (0..n).any(|j| !(sc.qr.r(j, j).abs() > 1e-13 * rmax)) {
            return false;
        }
        sc.qty.clear();
        sc.qty.extend_from_slice(&self.yt);
        sc.mm.clear();
        for c in 0..nc {
            sc.qr.qt_mul(&mut sc.qty[c * m..(c + 1) * m]);
            sc.mm.extend_from_slice(&sc.qty[c * m..c * m + n]);
        }
        sc.g.clear();
        for a in 0..nc {
            for b in 0..nc {
                let (ca, cb) = (&sc.mm[a * n..(a + 1) * n], &sc.mm[b * n..(b + 1) * n]);
                sc.g.push(ca.iter().zip(cb).map(|(x, y)| x * y).sum());
            }
        }
        leading_eigenvector(&sc.g, nc, &mut sc.s);
        if sc.s.iter().sum::<f64>() < 0.0 {
            sc.s.iter_mut().for_each(|x| *x = -*x);
        }
        // a = R⁻¹ M s
        sc.ms.clear();
        for j in 0..n {
            sc.ms
                .push((0..nc).map(|c| sc.mm[c * n + j] * sc.s[c]).sum::<f64>());
        }
        sc.a.resize(n, 0.0);
        sc.qr.solve_r(&sc.ms, &mut sc.a);
        if sc.a.iter().any(|v| !v.is_finite()) {
            return false;
        }
        if let Some(out) = out {
            sc.f.clear();
            for i in 0..m {
                sc.f.push((0..n).map(|j| sc.e[j * m + i] * sc.a[j]).sum::<f64>());
            }
            for c in 0..nc {
                for i in 0..m {
                    out[c * m + i] = self.yt[c * m + i] - sc.f[i] * sc.s[c];
                }
            }
        }
        true
    }

    /// Fits from θ₀. `None` when the solve fails or its optimum violates a ≥ 0 or s ≥ 0 (the
    /// caller then uses the alternation).
    pub(super) fn fit(&self, theta0: &[f64], opts: &SolverOptions) -> Option<RawFit> {
        let (m, nc, n) = (self.prep.m, self.prep.n_ch, self.n);
        if m < n + usize::from(self.background) + 1 {
            return None;
        }
        let lm = LmOptions {
            max_iter: opts.max_iter,
            ftol: opts.ftol,
            xtol: opts.xtol,
            gtol: opts.gtol,
            fd_step: FD_STEP,
            fd_central: false,
            ..LmOptions::default()
        };
        let rep = levenberg_marquardt(self, theta0, &lm);
        if !rep.rss.is_finite() || rep.termination == Termination::NonFinite {
            return None;
        }
        let mut sc = self.sc.borrow_mut();
        if !self.solve(&rep.theta, &mut sc, None) {
            return None;
        }
        if sc.s.iter().any(|v| *v < 0.0) || sc.a.iter().any(|v| *v < 0.0) {
            return None;
        }
        let (a, s) = (sc.a.clone(), sc.s.clone());
        drop(sc);
        let c: Vec<Vec<f64>> = a
            .iter()
            .map(|aj| s.iter().map(|sc| aj * sc).collect())
            .collect();
        let mut ex = Vec::with_capacity(n * m);
        self.prep.exp_table(&rep.theta, &mut ex);
        let background = if self.background {
            // b_c = Σ_i w_i (y_ci − f_i s_c) / Σ_i w_i
            let wsum: f64 = self.sw.iter().map(|v| v * v).sum();
            (0..nc)
                .map(|ch| {
                    (0..m)
                        .map(|i| {
                            let f: f64 = (0..n).map(|j| a[j] * ex[j * m + i]).sum();
                            self.sw[i] * self.sw[i] * (self.prep.y[ch * m + i] - f * s[ch])
                        })
                        .sum::<f64>()
                        / wsum
                })
                .collect()
        } else {
            Vec::new()
        };
        let mut raw = RawFit {
            theta: rep.theta,
            a,
            c,
            s,
            background,
            rss: 0.0,
            termination: rep.termination,
        };
        raw.rss = self.prep.rss_of(&raw, &ex);
        Some(raw)
    }
}

impl Residuals for Projected<'_, '_> {
    fn n_residuals(&self) -> usize {
        self.prep.m * self.prep.n_ch
    }
    fn n_params(&self) -> usize {
        self.n
    }
    fn residuals(&self, theta: &[f64], out: &mut [f64]) -> bool {
        let mut sc = self.sc.borrow_mut();
        self.solve(theta, &mut sc, Some(out))
    }
}

/// v ← (I − u uᵀ) v for a unit vector u.
fn project_off(u: &[f64], v: &mut [f64]) {
    let d: f64 = u.iter().zip(v.iter()).map(|(a, b)| a * b).sum();
    v.iter_mut().zip(u).for_each(|(x, ui)| *x -= d * ui);
}

/// Leading eigenvector of the symmetric positive semi-definite k × k matrix `g` by power
/// iteration, warm-started from `v` (unit norm on return). The data are rank one plus noise, so
/// the ratio of the two largest eigenvalues is tiny and a handful of products suffice.
fn leading_eigenvector(g: &[f64], k: usize, v: &mut Vec<f64>) {
    if v.len() != k || v.iter().all(|x| *x == 0.0) || v.iter().any(|x| !x.is_finite()) {
        v.clear();
        v.resize(k, 1.0 / (k as f64).sqrt());
    }
    let mut nv = vec![0.0; k];
    for _ in 0..500 {
        for a in 0..k {
            nv[a] = (0..k).map(|b| g[a * k + b] * v[b]).sum();
        }
        let nrm = nv.iter().map(|x| x * x).sum::<f64>().sqrt();
        if !(nrm > 0.0) || !nrm.is_finite() {
            return;
        }
        nv.iter_mut().for_each(|x| *x /= nrm);
        let d: f64 = nv.iter().zip(v.iter()).map(|(a, b)| (a - b).abs()).sum();
        v.copy_from_slice(&nv);
        if d < 1e-15 {
            return;
        }
    }
}
