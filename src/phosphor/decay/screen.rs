//! Screening of the largest candidate: the linearised (Gauss–Newton) RSS gain of adding one
//! state to the fit with one state fewer, against the gain BIC requires of it.
//!
//! With one spectrum s shared by all states the residual splits into Y(I − s sᵀ), which a new
//! state cannot change, and the projected curve z = Y s − β − f (β = bᵀs). The tangent directions
//! of the spectrum orthogonal to s are orthogonal to every state's direction e^{−kτ} ⊗ s, so to
//! first order one more state at rate k gains (rᵀP⊥φ_k)² / ‖P⊥φ_k‖² on the projected curve alone,
//! where φ_k = √w e^{−kτ} and P⊥ removes the fit's own tangent space (e_j, a_j τ e_j, the
//! constant with a background). That is a prediction of the gain, not a bound; the threshold
//! [`SCREEN_RATIO`] keeps a measured margin below the smallest ratio of a candidate that won.

#![allow(clippy::needless_range_loop)]

use super::*;

/// Number of log-spaced rates at which the gain of a further state is evaluated.
pub(super) const SCREEN_GRID: usize = 17;
/// How far (in ln k) beyond the plausible rates the grid reaches: e³, where a rate makes a fit
/// degenerate ([`Prepared::degenerate`]).
pub(super) const SCREEN_MARGIN: f64 = 3.0;

impl Prepared<'_> {
    /// The largest linearised RSS reduction of adding one state to `prev` (an n − 1-state
    /// shared-spectrum fit), over a log-spaced grid of rates, divided by the reduction BIC
    /// requires of the n-state model. `None` when the screen does not apply (per-channel
    /// amplitudes, a non-finite fit).
    pub(super) fn screen_ratio(&self, prev: &RawFit, opts: &DecayFitOptions) -> Option<f64> {
        if self.n_ch > 1 && opts.amplitudes == AmplitudeModel::PerChannel {
            return None;
        }
        if !prev.rss.is_finite() || prev.rss <= 0.0 || prev.s.len() != self.n_ch {
            return None;
        }
        let (m, nc) = (self.m, self.n_ch);
        let n = prev.theta.len();
        let sw = |i: usize| self.sqrt_w.as_ref().map_or(1.0, |w| w[i]);
        let beta: f64 = prev
            .background
            .iter()
            .zip(&prev.s)
            .map(|(b, s)| b * s)
            .sum();
        let mut ex = Vec::with_capacity(n * m);
        self.exp_table(&prev.theta, &mut ex);
        // weighted projected residual r = √w (Y s − β − f)
        let mut r = vec![0.0; m];
        for i in 0..m {
            let z: f64 = (0..nc).map(|c| prev.s[c] * self.y[c * m + i]).sum();
            let f: f64 = (0..n).map(|j| prev.a[j] * ex[j * m + i]).sum();
            r[i] = sw(i) * (z - beta - f);
        }
        // tangent columns: e_j, a_j τ e_j, and 1 with a background; orthonormalised
        let mut q: Vec<Vec<f64>> = Vec::with_capacity(2 * n + 1);
        let push = |mut v: Vec<f64>, q: &mut Vec<Vec<f64>>| {
            let n0 = v.iter().map(|x| x * x).sum::<f64>().sqrt();
            for _ in 0..2 {
                for u in q.iter() {
                    let d: f64 = u.iter().zip(&v).map(|(a, b)| a * b).sum();
                    v.iter_mut().zip(u).for_each(|(x, a)| *x -= d * a);
                }
            }
            let nv = v.iter().map(|x| x * x).sum::<f64>().sqrt();
            if nv > 1e-10 * n0 && nv > 0.0 {
                v.iter_mut().for_each(|x| *x /= nv);
                q.push(v);
            }
        };
        for j in 0..n {
            push((0..m).map(|i| sw(i) * ex[j * m + i]).collect(), &mut q);
            push(
                (0..m)
                    .map(|i| sw(i) * prev.a[j] * self.tau[i] * ex[j * m + i])
                    .collect(),
                &mut q,
            );
        }
        if opts.background {
            push((0..m).map(sw).collect(), &mut q);
        }
        for u in &q {
            let d: f64 = u.iter().zip(&r).map(|(a, b)| a * b).sum();
            r.iter_mut().zip(u).for_each(|(x, a)| *x -= d * a);
        }
        // for each rate of the grid, with e_i = e^{−kτ_i} and r ⊥ the tangent space:
        // rᵀP⊥φ = Σ r_i √w_i e_i and ‖P⊥φ‖² = Σ w_i e_i² − Σ_u (Σ u_i √w_i e_i)²
        let p = q.len();
        let mut g = Vec::with_capacity((p + 1) * m);
        g.extend((0..m).map(|i| r[i] * sw(i)));
        for u in &q {
            g.extend((0..m).map(|i| u[i] * sw(i)));
        }
        let (lo, hi) = self.log_rate_range();
        let (lo, hi) = (lo - SCREEN_MARGIN, hi + SCREEN_MARGIN);
        let mut best = 0.0_f64;
        let mut e = vec![0.0; m];
        let mut d = vec![0.0; p + 1];
        for k in 0..SCREEN_GRID {
            let rate = (lo + (hi - lo) * k as f64 / (SCREEN_GRID - 1) as f64).exp();
            match self.step {
                Some(dt) => {
                    let x = (-rate * dt).exp();
                    let mut v = 1.0;
                    for ei in e.iter_mut() {
                        *ei = v;
                        v *= x;
                    }
                }
                None => e
                    .iter_mut()
                    .zip(&self.tau)
                    .for_each(|(ei, t)| *ei = (-rate * t).exp()),
            }
            let pp: f64 = e.iter().zip(&self.wv).map(|(ei, w)| w * ei * ei).sum();
            for (dj, gj) in d.iter_mut().zip(g.chunks_exact(m)) {
                *dj = gj.iter().zip(&e).map(|(a, b)| a * b).sum();
            }
            let perp = pp - d[1..].iter().map(|v| v * v).sum::<f64>();
            if perp > 1e-9 * pp {
                best = best.max(d[0] * d[0] / perp);
            }
        }
        let n_obs = (m * nc) as f64;
        let dk = (self.n_params_of(n + 1, opts) - self.n_params_of(n, opts)) as f64;
        let needed = prev.rss * (1.0 - (-dk * n_obs.ln() / n_obs).exp());
        Some(best / needed)
    }
}
