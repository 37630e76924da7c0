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
use crate::fit::qr::{axpy, dot};

/// Number of log-spaced rates at which the gain of a further state is evaluated.
pub(super) const SCREEN_GRID: usize = 17;

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
        let ones;
        let sw: &[f64] = match &self.sqrt_w {
            Some(w) => w,
            None => {
                ones = vec![1.0; m];
                &ones
            }
        };
        let beta: f64 = dot(&prev.background, &prev.s);
        let mut ex = Vec::with_capacity(n * m);
        self.exp_table(&prev.theta, &mut ex);
        // weighted projected residual r = √w (Y s − β − f)
        let mut r = vec![-beta; m];
        for (c, sc) in prev.s.iter().enumerate() {
            axpy(*sc, &self.y[c * m..(c + 1) * m], &mut r);
        }
        for (j, aj) in prev.a.iter().enumerate() {
            axpy(-aj, &ex[j * m..(j + 1) * m], &mut r);
        }
        r.iter_mut().zip(sw).for_each(|(v, w)| *v *= w);
        // tangent columns √w e_j, √w a_j τ e_j (and √w with a background), orthonormalised
        // by modified Gram–Schmidt, twice; one flat array of columns
        let mut q: Vec<f64> = Vec::with_capacity((2 * n + 1) * m);
        let mut v = vec![0.0; m];
        let n_cols = 2 * n + usize::from(opts.background);
        for col in 0..n_cols {
            let (j, kind) = (col / 2, col % 2);
            for i in 0..m {
                v[i] = if col == 2 * n {
                    sw[i]
                } else if kind == 0 {
                    sw[i] * ex[j * m + i]
                } else {
                    sw[i] * prev.a[j] * self.tau[i] * ex[j * m + i]
                };
            }
            let n0 = dot(&v, &v).sqrt();
            for _ in 0..2 {
                for u in q.chunks_exact(m) {
                    axpy(-dot(u, &v), u, &mut v);
                }
            }
            let nv = dot(&v, &v).sqrt();
            if nv > 1e-10 * n0 && nv > 0.0 {
                q.extend(v.iter().map(|x| x / nv));
            }
        }
        for u in q.chunks_exact(m) {
            axpy(-dot(u, &r), u, &mut r);
        }
        // for each rate of the grid, with e_i = e^{−kτ_i} and r ⊥ the tangent space:
        // rᵀP⊥φ = Σ r_i √w_i e_i and ‖P⊥φ‖² = Σ w_i e_i² − Σ_u (Σ u_i √w_i e_i)²
        let mut g = Vec::with_capacity(q.len() + m);
        g.extend(r.iter().zip(sw).map(|(a, b)| a * b));
        for u in q.chunks_exact(m) {
            g.extend(u.iter().zip(sw).map(|(a, b)| a * b));
        }
        let (lo, hi) = self.log_rate_range();
        let (lo, hi) = (lo - DEGENERATE_LOG_MARGIN, hi + DEGENERATE_LOG_MARGIN);
        let mut best = 0.0_f64;
        let mut e = Vec::with_capacity(m);
        let mut we = vec![0.0; m];
        for k in 0..SCREEN_GRID {
            let theta = lo + (hi - lo) * k as f64 / (SCREEN_GRID - 1) as f64;
            self.exp_table(&[theta], &mut e);
            we.iter_mut()
                .zip(&e)
                .zip(&self.wv)
                .for_each(|((o, ei), w)| *o = w * ei);
            let pp = dot(&we, &e);
            let mut chunks = g.chunks_exact(m);
            let rp = chunks.next().map_or(0.0, |gr| dot(gr, &e));
            let proj: f64 = chunks.map(|gu| dot(gu, &e).powi(2)).sum();
            let perp = pp - proj;
            if perp > 1e-9 * pp {
                best = best.max(rp * rp / perp);
            }
        }
        let n_obs = (m * nc) as f64;
        let dk = (self.n_params_of(n + 1, opts) - self.n_params_of(n, opts)) as f64;
        let needed = prev.rss * (1.0 - (-dk * n_obs.ln() / n_obs).exp());
        Some(best / needed)
    }
}
