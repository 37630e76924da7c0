//! The exponential basis of the separable model (rates k = e^θ) for [`fit::varpro`](crate::fit::varpro).

#![allow(clippy::needless_range_loop, clippy::neg_cmp_op_on_partial_ord)]

use super::*;

/// Basis e^{−e^{θ_i} τ} (+ a constant column).
pub(super) struct ExpBasis<'a> {
    pub(super) tau: &'a [f64],
    /// The step when the times are evenly spaced from τ = 0: then e^{−kτ_i} = (e^{−k Δτ})^i,
    /// one `exp` per column instead of one per sample.
    pub(super) step: Option<f64>,
    pub(super) n_exp: usize,
    pub(super) background: bool,
}

/// The common step of `tau` (starting at 0) when it is evenly spaced to 1e-12 relative.
pub(super) fn uniform_step(tau: &[f64]) -> Option<f64> {
    let m = tau.len();
    if m < 2 || tau[0] != 0.0 {
        return None;
    }
    let dt = tau[m - 1] / (m - 1) as f64;
    let ok = dt > 0.0
        && tau
            .iter()
            .enumerate()
            .all(|(i, t)| (t - i as f64 * dt).abs() <= 1e-12 * tau[m - 1]);
    ok.then_some(dt)
}

impl SeparableModel for ExpBasis<'_> {
    #[inline]
    fn n_rows(&self) -> usize {
        self.tau.len()
    }
    #[inline]
    fn n_params(&self) -> usize {
        self.n_exp
    }
    #[inline]
    fn n_cols(&self) -> usize {
        self.n_exp + usize::from(self.background)
    }
    #[inline]
    fn column_param(&self, col: usize) -> Option<usize> {
        (col < self.n_exp).then_some(col)
    }
    #[inline]
    fn column_free(&self, col: usize) -> bool {
        col >= self.n_exp
    }
    #[inline]
    fn eval(&self, theta: &[f64], basis: &mut [f64], dbasis: &mut [f64]) {
        let m = self.tau.len();
        for (j, th) in theta.iter().enumerate().take(self.n_exp) {
            let k = th.exp();
            match self.step {
                Some(dt) => {
                    // the powers of r (a serial recurrence), then the derivative column from
                    // them in a separate loop without index checks, which vectorises
                    let r = (-k * dt).exp();
                    let col = &mut basis[j * m..(j + 1) * m];
                    let mut e = 1.0;
                    for b in col.iter_mut() {
                        *b = e;
                        e *= r;
                    }
                    let nk = -k;
                    for ((d, &t), &e) in dbasis[j * m..(j + 1) * m]
                        .iter_mut()
                        .zip(self.tau)
                        .zip(col.iter())
                    {
                        *d = nk * t * e;
                    }
                }
                None => {
                    for (i, &t) in self.tau.iter().enumerate() {
                        let e = (-k * t).exp();
                        basis[j * m + i] = e;
                        dbasis[j * m + i] = -k * t * e;
                    }
                }
            }
        }
        if self.background {
            let j = self.n_exp;
            basis[j * m..(j + 1) * m].iter_mut().for_each(|v| *v = 1.0);
            dbasis[j * m..(j + 1) * m].iter_mut().for_each(|v| *v = 0.0);
        }
    }
}
