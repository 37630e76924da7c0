//! The shared-spectrum fit of n ≥ 2 states in one solve instead of the alternation: by
//! variable projection over the rates ([`Projected`], issue 18 third round) or as one joint
//! least-squares problem over every parameter ([`Joint`], fourth round). Both reach the
//! alternation's decisions and both measured no faster than it, so neither is the default
//! (docs/performance.md, issue 18).
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

/// The shared-spectrum n-state model as one joint least-squares problem over every parameter:
/// x = (θ₁…θ_n, a₁…a_n, s_c for c ≠ ref, b_c), with the spectrum's gauge fixed by s_ref = 1
/// (ref the largest channel of the start), a ≥ 0 and s ≥ 0 as box bounds, and the residual
///
/// `r_ci = √w_i (y_ci − s_c Σ_j a_j e^{−e^{θ_j} τ_i} − b_c)`
///
/// with its analytic Jacobian:
/// ∂r_ci/∂θ_j = √w_i s_c a_j k_j τ_i e_ji, ∂r_ci/∂a_j = −√w_i s_c e_ji,
/// ∂r_ci/∂s_c = −√w_i Σ_j a_j e_ji, ∂r_ci/∂b_c = −√w_i.
///
/// Solved by the crate's bounded Levenberg–Marquardt ([`crate::fit::levenberg_marquardt`]). The
/// alternation of [`Prepared::fit_from`] converges linearly (each round re-solves the rates for
/// a fixed spectrum); near its end point this problem converges like Gauss–Newton, so with
/// [`SharedSolve::Joint`] the alternation's first round is followed by this solve, and the rest
/// of the alternation runs only when the joint optimum is not interior (a state or a channel at
/// zero) or not converged. It takes 4 iterations per solve on the fixture, but each factors a
/// 111 × 9…11 Jacobian (≈ 10× one iteration of the alternation's 37-row solves), so it saves
/// separable solves without saving time.
pub(super) struct Joint<'p, 'c> {
    prep: &'p Prepared<'c>,
    n: usize,
    background: bool,
    /// The channel whose spectrum value is fixed at 1.
    refc: usize,
    /// e^{−kτ} table of the last evaluation.
    ex: RefCell<Vec<f64>>,
}

impl<'p, 'c> Joint<'p, 'c> {
    pub(super) fn new(prep: &'p Prepared<'c>, n: usize, background: bool, s: &[f64]) -> Self {
        let refc = (0..s.len())
            .max_by(|&a, &b| s[a].total_cmp(&s[b]))
            .unwrap_or(0);
        Joint {
            prep,
            n,
            background,
            refc,
            ex: RefCell::new(Vec::with_capacity(n * prep.m)),
        }
    }

    fn sw(&self, i: usize) -> f64 {
        self.prep.sqrt_w.as_ref().map_or(1.0, |w| w[i])
    }

    /// Spectrum value of channel c in the parameter vector x.
    fn s_of(&self, x: &[f64], c: usize) -> f64 {
        let n = self.n;
        match c.cmp(&self.refc) {
            std::cmp::Ordering::Equal => 1.0,
            std::cmp::Ordering::Less => x[2 * n + c],
            std::cmp::Ordering::Greater => x[2 * n + c - 1],
        }
    }

    fn n_ch(&self) -> usize {
        self.prep.n_ch
    }

    /// Fits from the end of an alternation round (rates θ, amplitudes a, unit spectrum s,
    /// background b). `None` unless the joint optimum is converged and interior (every a > 0,
    /// every s > 0); the caller then continues the alternation.
    pub(super) fn fit(
        &self,
        theta: &[f64],
        a: &[f64],
        s: &[f64],
        background: &[f64],
        opts: &SolverOptions,
    ) -> Option<RawFit> {
        let (n, nc) = (self.n, self.n_ch());
        let sref = s[self.refc];
        if !(sref > 0.0) {
            return None;
        }
        let mut x0 = Vec::with_capacity(self.n_params_joint());
        x0.extend_from_slice(theta);
        x0.extend(a.iter().map(|v| v * sref));
        x0.extend((0..nc).filter(|&c| c != self.refc).map(|c| s[c] / sref));
        if self.background {
            x0.extend_from_slice(background);
        }
        let p = x0.len();
        let mut lower = vec![f64::NEG_INFINITY; p];
        lower[n..p - if self.background { nc } else { 0 }]
            .iter_mut()
            .for_each(|v| *v = 0.0);
        let lm = LmOptions {
            max_iter: opts.max_iter,
            ftol: opts.ftol,
            xtol: opts.xtol,
            gtol: opts.gtol,
            ..LmOptions::default()
        }
        .with_bounds(lower, vec![f64::INFINITY; p]);
        let rep = levenberg_marquardt(self, &x0, &lm);
        if !rep.termination.converged() || !rep.rss.is_finite() {
            return None;
        }
        let x = &rep.theta;
        let sv: Vec<f64> = (0..nc).map(|c| self.s_of(x, c)).collect();
        if x[n..2 * n].iter().any(|v| !(*v > 0.0)) || sv.iter().any(|v| !(*v > 0.0)) {
            return None;
        }
        let norm = sv.iter().map(|v| v * v).sum::<f64>().sqrt();
        let s_unit: Vec<f64> = sv.iter().map(|v| v / norm).collect();
        let a_out: Vec<f64> = x[n..2 * n].iter().map(|v| v * norm).collect();
        let c = a_out
            .iter()
            .map(|aj| s_unit.iter().map(|sc| aj * sc).collect())
            .collect();
        let mut raw = RawFit {
            theta: x[..n].to_vec(),
            a: a_out,
            c,
            s: s_unit,
            background: if self.background {
                x[p - nc..].to_vec()
            } else {
                Vec::new()
            },
            rss: 0.0,
            termination: rep.termination,
        };
        let mut ex = Vec::with_capacity(n * self.prep.m);
        self.prep.exp_table(&raw.theta, &mut ex);
        raw.rss = self.prep.rss_of(&raw, &ex);
        Some(raw)
    }

    fn n_params_joint(&self) -> usize {
        2 * self.n + self.n_ch() - 1 + if self.background { self.n_ch() } else { 0 }
    }
}

impl Residuals for Joint<'_, '_> {
    fn n_residuals(&self) -> usize {
        self.prep.m * self.prep.n_ch
    }
    fn n_params(&self) -> usize {
        self.n_params_joint()
    }
    fn residuals(&self, x: &[f64], out: &mut [f64]) -> bool {
        let (m, nc, n) = (self.prep.m, self.n_ch(), self.n);
        let mut ex = self.ex.borrow_mut();
        self.prep.exp_table(&x[..n], &mut ex);
        let a = &x[n..2 * n];
        let b0 = self.n_params_joint() - if self.background { nc } else { 0 };
        for i in 0..m {
            let mut f = 0.0;
            for j in 0..n {
                f += a[j] * ex[j * m + i];
            }
            let sw = self.sw(i);
            for c in 0..nc {
                let b = if self.background { x[b0 + c] } else { 0.0 };
                out[c * m + i] = sw * (self.prep.y[c * m + i] - self.s_of(x, c) * f - b);
            }
        }
        out.iter().all(|v| v.is_finite())
    }
    fn jacobian(&self, x: &[f64], jac: &mut [f64]) -> bool {
        let (m, nc, n) = (self.prep.m, self.n_ch(), self.n);
        let rows = m * nc;
        let mut ex = self.ex.borrow_mut();
        self.prep.exp_table(&x[..n], &mut ex);
        let a = &x[n..2 * n];
        jac.iter_mut().for_each(|v| *v = 0.0);
        let s: Vec<f64> = (0..nc).map(|c| self.s_of(x, c)).collect();
        let k: Vec<f64> = x[..n].iter().map(|t| t.exp()).collect();
        for i in 0..m {
            let sw = self.sw(i);
            let tau = self.prep.tau[i];
            let mut f = 0.0;
            for j in 0..n {
                let e = ex[j * m + i];
                f += a[j] * e;
                let k = k[j];
                for c in 0..nc {
                    jac[j * rows + c * m + i] = sw * s[c] * a[j] * k * tau * e;
                    jac[(n + j) * rows + c * m + i] = -sw * s[c] * e;
                }
            }
            let mut q = 2 * n;
            for c in 0..nc {
                if c != self.refc {
                    jac[q * rows + c * m + i] = -sw * f;
                    q += 1;
                }
            }
            if self.background {
                for c in 0..nc {
                    jac[(q + c) * rows + c * m + i] = -sw;
                }
            }
        }
        jac.iter().all(|v| v.is_finite())
    }
}
