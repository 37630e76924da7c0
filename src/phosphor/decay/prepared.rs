//! A curve prepared for fitting (time base, weights, stacked channels) and the n-state fit
//! from one start: for the shared spectrum the separable fit alternated with the exact spectrum
//! update (the default), or, behind doc-hidden entry points, one variable-projection solve
//! ([`Projected`]) or one round of the alternation and then one joint solve ([`Joint`]).

#![allow(clippy::needless_range_loop, clippy::neg_cmp_op_on_partial_ord)]

use super::*;

/// Internal result for n states (τ = t − t₀ time base, unit-norm spectrum).
#[derive(Debug, Clone)]
pub(super) struct RawFit {
    pub(super) theta: Vec<f64>,
    /// Amplitudes per state (shared) at τ = 0.
    pub(super) a: Vec<f64>,
    /// Per state × channel amplitudes at τ = 0.
    pub(super) c: Vec<Vec<f64>>,
    /// Unit-norm spectrum (shared model).
    pub(super) s: Vec<f64>,
    pub(super) background: Vec<f64>,
    pub(super) rss: f64,
    pub(super) termination: Termination,
}

pub(super) struct Prepared<'c> {
    pub(super) curve: &'c DecayCurve,
    pub(super) tau: Vec<f64>,
    /// [`uniform_step`] of `tau`, found once.
    pub(super) step: Option<f64>,
    pub(super) t0: f64,
    pub(super) sqrt_w: Option<Vec<f64>>,
    /// The weights w_i = 1/σ_i² (ones without σ), so that loops read them instead of squaring.
    pub(super) wv: Vec<f64>,
    /// Channels stacked, m × n_ch.
    pub(super) y: Vec<f64>,
    pub(super) n_ch: usize,
    pub(super) m: usize,
    /// How the shared-spectrum fit of n ≥ 2 states is solved ([`SharedSolve`]).
    pub(super) shared_solve: SharedSolve,
}

/// How [`Prepared::fit_from`] solves the shared-spectrum model with n ≥ 2 states.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum SharedSolve {
    /// The separable fit of Y s alternated with the exact update of s until s settles (the
    /// reference path, and the fall-back of the others).
    Alternation,
    /// One round of the alternation, then one joint solve over (θ, a, s, b) ([`Joint`]); the
    /// alternation continues where that optimum is not interior or not converged. The same
    /// decisions, but not faster than the alternation in the one measured run
    /// (docs/performance.md, issue 18 fourth round); `fit_decay_joint` turns it on.
    Joint,
    /// One variable-projection solve over the rates ([`Projected`]), the alternation only where
    /// its optimum is infeasible. Measured 2.6× slower than the alternation
    /// (docs/performance.md, issue 18 third round); `fit_decay_projected` turns it on.
    Projected,
}

impl<'c> Prepared<'c> {
    pub(super) fn new(curve: &'c DecayCurve) -> Self {
        let t0 = curve.t_s[0];
        let sqrt_w: Option<Vec<f64>> = curve
            .sigma
            .as_ref()
            .map(|s| s.iter().map(|v| 1.0 / v).collect());
        let wv = match &sqrt_w {
            Some(w) => w.iter().map(|v: &f64| v * v).collect(),
            None => vec![1.0; curve.n_rows()],
        };
        let tau: Vec<f64> = curve.t_s.iter().map(|t| t - t0).collect();
        Prepared {
            curve,
            step: uniform_step(&tau),
            tau,
            t0,
            sqrt_w,
            wv,
            y: curve.channels.concat(),
            n_ch: curve.channels.len(),
            m: curve.n_rows(),
            shared_solve: SharedSolve::Alternation,
        }
    }

    #[inline]
    pub(super) fn w(&self, i: usize) -> f64 {
        self.wv[i]
    }

    /// Leading right singular vector of W^{1/2} Y (non-negative, unit norm).
    pub(super) fn initial_spectrum(&self) -> Vec<f64> {
        let (m, nc) = (self.m, self.n_ch);
        let mut g = vec![0.0; nc * nc];
        for a in 0..nc {
            for b in 0..nc {
                g[a * nc + b] = (0..m)
                    .map(|i| self.w(i) * self.y[a * m + i] * self.y[b * m + i])
                    .sum();
            }
        }
        let mut v: Vec<f64> = (0..nc)
            .map(|c| (0..m).map(|i| self.y[c * m + i].abs()).sum::<f64>() + 1e-300)
            .collect();
        for _ in 0..100 {
            let mut nv: Vec<f64> = (0..nc)
                .map(|a| (0..nc).map(|b| g[a * nc + b] * v[b]).sum())
                .collect();
            let n = nv.iter().map(|x| x * x).sum::<f64>().sqrt();
            if n == 0.0 || !n.is_finite() {
                break;
            }
            nv.iter_mut().for_each(|x| *x /= n);
            let d: f64 = nv.iter().zip(&v).map(|(a, b)| (a - b).abs()).sum();
            v = nv;
            if d < 1e-15 {
                break;
            }
        }
        if v.iter().sum::<f64>() < 0.0 {
            v.iter_mut().for_each(|x| *x = -*x);
        }
        v.iter_mut().for_each(|x| *x = x.max(0.0));
        let n = v.iter().map(|x| x * x).sum::<f64>().sqrt();
        if n > 0.0 {
            v.iter_mut().for_each(|x| *x /= n);
            v
        } else {
            vec![1.0 / (nc as f64).sqrt(); nc]
        }
    }

    /// e^{−e^{θ_j} τ_i} for every state j and sample i (state after state).
    pub(super) fn exp_table(&self, theta: &[f64], out: &mut Vec<f64>) {
        out.clear();
        let step = self.step;
        for th in theta {
            let k = th.exp();
            match step {
                Some(dt) => {
                    let r = (-k * dt).exp();
                    let mut e = 1.0;
                    for _ in 0..self.m {
                        out.push(e);
                        e *= r;
                    }
                }
                None => out.extend(self.tau.iter().map(|t| (-k * t).exp())),
            }
        }
    }

    /// Weighted RSS of a fit, given its [`Self::exp_table`].
    pub(super) fn rss_of(&self, raw: &RawFit, ex: &[f64]) -> f64 {
        let (m, nc) = (self.m, self.n_ch);
        let n = raw.theta.len();
        let mut rss = 0.0;
        let mut r = vec![0.0; m];
        for c in 0..nc {
            let b = raw.background.get(c).copied().unwrap_or(0.0);
            r.copy_from_slice(&self.y[c * m..(c + 1) * m]);
            r.iter_mut().for_each(|v| *v -= b);
            for j in 0..n {
                let cj = raw.c[j][c];
                for (v, e) in r.iter_mut().zip(&ex[j * m..(j + 1) * m]) {
                    *v -= cj * e;
                }
            }
            rss += r.iter().zip(&self.wv).map(|(v, w)| w * v * v).sum::<f64>();
        }
        rss
    }

    /// Fits n states from one start.
    pub(super) fn fit_from(
        &self,
        n: usize,
        theta0: &[f64],
        opts: &DecayFitOptions,
        s0: &[f64],
    ) -> RawFit {
        let basis = ExpBasis {
            tau: &self.tau,
            step: self.step,
            n_exp: n,
            background: opts.background,
        };
        let (m, nc) = (self.m, self.n_ch);
        let ncols = n + usize::from(opts.background);
        // One state: the shared-spectrum model a·Λ*_c e^{−kτ} is the per-channel model with
        // c_c = a Λ*_c ≥ 0 (any non-negative row is a multiple of a unit spectrum), so it is one
        // multi-right-hand-side solve, with no alternation: Λ* = c/‖c‖, a = ‖c‖.
        let one_shared = n == 1 && nc > 1 && opts.amplitudes == AmplitudeModel::SharedSpectrum;
        if nc == 1 || one_shared || opts.amplitudes == AmplitudeModel::PerChannel {
            let fit = solve_separable(
                &basis,
                SeparableData {
                    y: &self.y,
                    n_rhs: nc,
                    sqrt_w: self.sqrt_w.as_deref(),
                },
                theta0,
                &opts.solver,
            );
            let c: Vec<Vec<f64>> = (0..n)
                .map(|j| (0..nc).map(|r| fit.coeffs[r * ncols + j]).collect())
                .collect();
            let background = if opts.background {
                (0..nc).map(|r| fit.coeffs[r * ncols + n]).collect()
            } else {
                Vec::new()
            };
            let (a, s) = if nc == 1 {
                (c.iter().map(|v| v[0]).collect(), vec![1.0])
            } else if one_shared {
                let norm = c[0].iter().map(|v| v * v).sum::<f64>().sqrt();
                if norm > 0.0 {
                    (vec![norm], c[0].iter().map(|v| v / norm).collect())
                } else {
                    (vec![0.0], s0.to_vec())
                }
            } else {
                (
                    c.iter()
                        .map(|v| v.iter().fold(0.0_f64, |x, y| x.max(*y)))
                        .collect(),
                    Vec::new(),
                )
            };
            return RawFit {
                theta: fit.theta,
                a,
                c,
                s,
                background,
                rss: fit.rss,
                termination: fit.termination,
            };
        }
        // Shared spectrum: one variable-projection solve over the rates when its optimum is
        // feasible (a ≥ 0, s ≥ 0) …
        if self.shared_solve == SharedSolve::Projected {
            if let Some(r) = Projected::new(self, n, opts.background, s0).fit(theta0, &opts.solver)
            {
                return r;
            }
        }
        // … otherwise alternate the separable fit of Y s with the update of s.
        let mut s = s0.to_vec();
        let mut theta = theta0.to_vec();
        let mut ys = vec![0.0; m];
        let mut last: Option<(Vec<f64>, f64, Vec<f64>, Termination)> = None;
        let mut ex = Vec::with_capacity(n * m);
        let ybar: Vec<f64> = {
            let wsum: f64 = (0..m).map(|i| self.w(i)).sum();
            (0..nc)
                .map(|c| (0..m).map(|i| self.w(i) * self.y[c * m + i]).sum::<f64>() / wsum)
                .collect()
        };
        // While the spectrum still moves, the fit of Y s for that spectrum is only a step of
        // the alternation: it stops at a loose tolerance; once the spectrum has settled the
        // rounds use the full tolerance, and only a round at the full tolerance can end it.
        let loose = SolverOptions {
            ftol: ALTERNATION_FTOL.max(opts.solver.ftol),
            xtol: ALTERNATION_XTOL.max(opts.solver.xtol),
            ..opts.solver
        };
        // The spectrum is converged as far as the fit's own tolerance asks: to 1e-11 for a
        // result, to SEED_SPECTRUM_TOL for a seed fit (which is refined if it is selected).
        let spectrum_tol = if opts.solver.ftol >= SEED_FTOL {
            SEED_SPECTRUM_TOL
        } else {
            1e-11
        };
        let mut tight = false;
        let mut prev_d = f64::INFINITY;
        for round in 0..ALTERNATION_ROUNDS {
            tight |= round + 5 >= ALTERNATION_ROUNDS;
            for (i, v) in ys.iter_mut().enumerate() {
                *v = (0..nc).map(|c| s[c] * self.y[c * m + i]).sum();
            }
            let fit = solve_separable(
                &basis,
                SeparableData {
                    y: &ys,
                    n_rhs: 1,
                    sqrt_w: self.sqrt_w.as_deref(),
                },
                &theta,
                if tight { &opts.solver } else { &loose },
            );
            theta.clone_from(&fit.theta);
            let a: Vec<f64> = fit.coeffs[..n].to_vec();
            let background: Vec<f64> = if opts.background {
                let beta = fit.coeffs[n];
                let proj: f64 = ybar.iter().zip(&s).map(|(y, s)| y * s).sum();
                (0..nc)
                    .map(|c| beta * s[c] + ybar[c] - proj * s[c])
                    .collect()
            } else {
                Vec::new()
            };
            // f(τ) = Σ a_j e^{−k_j τ}; s ← (Y − 1bᵀ)ᵀ W f / fᵀ W f
            self.exp_table(&theta, &mut ex);
            let f: Vec<f64> = (0..m)
                .map(|i| (0..n).map(|j| a[j] * ex[j * m + i]).sum())
                .collect();
            let ff: f64 = (0..m).map(|i| self.w(i) * f[i] * f[i]).sum();
            let mut done = true;
            let mut new_s = s.clone();
            let mut scale = 1.0;
            if ff > 0.0 {
                for (c, ns) in new_s.iter_mut().enumerate() {
                    let b = background.get(c).copied().unwrap_or(0.0);
                    *ns = ((0..m)
                        .map(|i| self.w(i) * (self.y[c * m + i] - b) * f[i])
                        .sum::<f64>()
                        / ff)
                        .max(0.0);
                }
                let norm = new_s.iter().map(|x| x * x).sum::<f64>().sqrt();
                if norm > 0.0 {
                    new_s.iter_mut().for_each(|x| *x /= norm);
                    scale = norm;
                    let d: f64 = new_s.iter().zip(&s).map(|(a, b)| (a - b).abs()).sum();
                    // Converged when the spectrum has stopped moving — or, once the rounds
                    // contract strongly (ρ = d/d_prev ≤ EXTRAPOLATE_RHO, typically 1e-3), when
                    // the rest of its path, d·ρ/(1 − ρ) by the geometric series of the next
                    // moves, is below the tolerance: the round that would measure it is skipped.
                    let rho = d / prev_d;
                    done = tight
                        && (d < spectrum_tol
                            || (rho <= EXTRAPOLATE_RHO && d * rho / (1.0 - rho) < spectrum_tol));
                    prev_d = d;
                    tight |= d < ALTERNATION_SETTLED;
                }
            }
            // after the first round: one joint solve from its end, when that end is interior
            if round == 0
                && self.shared_solve == SharedSolve::Joint
                && a.iter().all(|v| *v * scale > 0.0)
                && new_s.iter().all(|v| *v > 0.0)
            {
                let r = self.shared_raw(
                    &theta,
                    &a,
                    scale,
                    &new_s,
                    background.clone(),
                    fit.termination,
                    &ex,
                );
                if let Some(j) = Joint::new(self, n, opts.background, &r.s).fit(
                    &r.theta,
                    &r.a,
                    &r.s,
                    &r.background,
                    &opts.solver,
                ) {
                    if j.rss <= r.rss {
                        return j;
                    }
                }
            }
            // only the last round's fit is returned: it is assembled (and its RSS computed)
            // after the loop, from that round's θ, amplitudes, spectrum and exp table
            last = Some((a, scale, background, fit.termination));
            s = new_s;
            if done {
                break;
            }
        }
        if let Some((a, scale, background, termination)) = last {
            return self.shared_raw(&theta, &a, scale, &s, background, termination, &ex);
        }
        RawFit {
            theta,
            a: vec![0.0; n],
            c: vec![vec![0.0; nc]; n],
            s,
            background: Vec::new(),
            rss: f64::INFINITY,
            termination: Termination::NonFinite,
        }
    }

    /// The shared-spectrum fit of one alternation round: amplitudes a·scale, spectrum s,
    /// c_j = a_j·scale·s, and its RSS from `ex`, the exp table of θ.
    #[allow(clippy::too_many_arguments)]
    fn shared_raw(
        &self,
        theta: &[f64],
        a: &[f64],
        scale: f64,
        s: &[f64],
        background: Vec<f64>,
        termination: Termination,
        ex: &[f64],
    ) -> RawFit {
        let a_scaled: Vec<f64> = a.iter().map(|v| v * scale).collect();
        let c = a_scaled
            .iter()
            .map(|aj| s.iter().map(|sc| aj * sc).collect())
            .collect();
        let mut r = RawFit {
            theta: theta.to_vec(),
            a: a_scaled,
            c,
            s: s.to_vec(),
            background,
            rss: 0.0,
            termination,
        };
        r.rss = self.rss_of(&r, ex);
        r
    }
}
