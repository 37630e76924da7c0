//! Householder QR of a small dense column-major matrix, the one factorisation the solvers use.
//!
//! `A = Q R` with `A` of size m × n (m ≥ n), stored column-major. Q is kept implicitly as
//! Householder reflectors, so `Qᵀ b`, `Q b`, least-squares solves and orthogonal projections
//! cost O(m n) each. Rank deficiency is reported by [`Qr::rank`] (diagonal of R below
//! `RANK_TOL` × the largest), never by a panic.

// Index loops mirror the matrix notation of the maths; `!(a > b)` comparisons deliberately
// reject NaN along with out-of-range values.
#![allow(clippy::needless_range_loop, clippy::neg_cmp_op_on_partial_ord)]

/// Relative size of a diagonal element of R below which a column is treated as dependent.
pub const RANK_TOL: f64 = 1e-13;

/// The factorisation (reflectors below the diagonal, R on and above it).
#[derive(Debug, Clone, Default)]
pub struct Qr {
    m: usize,
    n: usize,
    a: Vec<f64>,
    beta: Vec<f64>,
    rdiag: Vec<f64>,
}

impl Qr {
    /// Factorises the m × n column-major matrix `a` (m ≥ n; extra rows are fine, fewer are not:
    /// the caller checks).
    pub fn new(a: &[f64], m: usize, n: usize) -> Self {
        let mut qr = Qr::default();
        qr.factor(a, m, n);
        qr
    }

    /// Re-factorises in place, reusing the buffers.
    pub fn factor(&mut self, a: &[f64], m: usize, n: usize) {
        self.m = m;
        self.n = n;
        self.a.clear();
        self.a.extend_from_slice(&a[..m * n]);
        // every element is assigned below (no clearing pass: these are a few elements, and
        // the fill cost a call each)
        self.beta.resize(n, 0.0);
        self.rdiag.resize(n, 0.0);
        for j in m.min(n)..n {
            self.beta[j] = 0.0;
            self.rdiag[j] = 0.0;
        }
        for j in 0..n.min(m) {
            let col = j * m;
            let norm = column_norm(&self.a[col + j..col + m]);
            if norm == 0.0 {
                self.beta[j] = 0.0;
                self.rdiag[j] = 0.0;
                continue;
            }
            let alpha = if self.a[col + j] > 0.0 { -norm } else { norm };
            // v = x - alpha e1, stored in place; beta = 1 / (vᵀv / 2) = 1 / (norm² - alpha x0)
            let x0 = self.a[col + j];
            self.a[col + j] = x0 - alpha;
            let vtv_half = norm * norm - alpha * x0;
            let beta = 1.0 / vtv_half;
            self.beta[j] = beta;
            self.rdiag[j] = alpha;
            let (left, right) = self.a.split_at_mut((j + 1) * m);
            let v = &left[col + j..col + m];
            for ck in right.chunks_exact_mut(m).take(n - j - 1) {
                let x = &mut ck[j..m];
                let f = dot(v, x) * beta;
                axpy(-f, v, x);
            }
        }
    }

    /// Number of columns whose diagonal element of R is not negligible.
    pub fn rank(&self) -> usize {
        let max = self.rdiag.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
        self.rdiag
            .iter()
            .filter(|v| v.abs() > RANK_TOL * max && max > 0.0)
            .count()
    }

    /// Whether R has no negligible diagonal element.
    pub fn full_rank(&self) -> bool {
        self.rank() == self.n
    }

    /// `b ← Qᵀ b` (b of length m).
    pub fn qt_mul(&self, b: &mut [f64]) {
        for j in 0..self.n.min(self.m) {
            self.apply_reflector(j, b);
        }
    }

    /// `b ← Q b` (b of length m).
    pub fn q_mul(&self, b: &mut [f64]) {
        for j in (0..self.n.min(self.m)).rev() {
            self.apply_reflector(j, b);
        }
    }

    /// `b ← H_j b` with the j-th Householder reflector `H_j = I − β_j v_j v_jᵀ` (its own inverse).
    fn apply_reflector(&self, j: usize, b: &mut [f64]) {
        if self.beta[j] == 0.0 {
            return;
        }
        let m = self.m;
        let v = &self.a[j * m + j..j * m + m];
        let x = &mut b[j..m];
        let f = dot(v, x) * self.beta[j];
        axpy(-f, v, x);
    }

    /// Element (i, j) of R (i ≤ j).
    pub fn r(&self, i: usize, j: usize) -> f64 {
        if i == j {
            self.rdiag[j]
        } else {
            self.a[j * self.m + i]
        }
    }

    /// Solves `R x = (Qᵀb)[..n]` given `qtb = Qᵀ b`; dependent columns get x = 0.
    pub fn solve_r(&self, qtb: &[f64], x: &mut [f64]) {
        let n = self.n;
        let max = self.rdiag.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
        for j in (0..n).rev() {
            let d = self.rdiag[j];
            if d.abs() <= RANK_TOL * max || d == 0.0 {
                x[j] = 0.0;
                continue;
            }
            let mut s = qtb[j];
            for k in j + 1..n {
                s -= self.r(j, k) * x[k];
            }
            x[j] = s / d;
        }
    }

    /// `v ← (I − Q₁Q₁ᵀ) v`: the part of v orthogonal to the column space.
    pub fn project_out(&self, v: &mut [f64]) {
        self.qt_mul(v);
        for x in v.iter_mut().take(self.n.min(self.m)) {
            *x = 0.0;
        }
        self.q_mul(v);
    }

    /// `(RᵀR)⁻¹` (n × n, column-major), or `None` when R is rank deficient.
    pub fn inverse_gram(&self) -> Option<Vec<f64>> {
        let n = self.n;
        if !self.full_rank() {
            return None;
        }
        // Rinv upper triangular.
        let mut rinv = vec![0.0; n * n];
        for j in 0..n {
            rinv[j * n + j] = 1.0 / self.rdiag[j];
            for i in (0..j).rev() {
                let mut s = 0.0;
                for k in i + 1..=j {
                    s += self.r(i, k) * rinv[j * n + k];
                }
                rinv[j * n + i] = -s / self.rdiag[i];
            }
        }
        // (RᵀR)⁻¹ = R⁻¹ R⁻ᵀ
        let mut out = vec![0.0; n * n];
        for i in 0..n {
            for j in 0..n {
                let mut s = 0.0;
                for k in i.max(j)..n {
                    s += rinv[k * n + i] * rinv[k * n + j];
                }
                out[j * n + i] = s;
            }
        }
        Some(out)
    }
}

/// ‖x‖: the plain sum of squares when it is safely inside the range of f64 (the common case,
/// one pass), otherwise the sum of squares scaled by the largest element (no overflow or
/// underflow).
#[inline]
fn column_norm(x: &[f64]) -> f64 {
    let ss = dot(x, x);
    if ss.is_finite() && ss > 1e-280 && ss < 1e280 {
        return ss.sqrt();
    }
    let amax = x.iter().fold(0.0_f64, |s, v| s.max(v.abs()));
    if amax > 0.0 && amax.is_finite() {
        let inv = 1.0 / amax;
        amax * x.iter().map(|v| (v * inv) * (v * inv)).sum::<f64>().sqrt()
    } else {
        amax
    }
}

/// xᵀy with four independent partial sums (so the loop vectorises; the summation order is
/// fixed, so the result is deterministic).
#[inline]
pub(crate) fn dot(x: &[f64], y: &[f64]) -> f64 {
    let n = x.len().min(y.len());
    let (x, y) = (&x[..n], &y[..n]);
    let mut acc = [0.0_f64; 4];
    let xc = x.chunks_exact(4);
    let yc = y.chunks_exact(4);
    let (xr, yr) = (xc.remainder(), yc.remainder());
    for (a, b) in xc.zip(yc) {
        for l in 0..4 {
            acc[l] += a[l] * b[l];
        }
    }
    let mut tail = 0.0;
    for (a, b) in xr.iter().zip(yr) {
        tail += a * b;
    }
    (acc[0] + acc[1]) + (acc[2] + acc[3]) + tail
}

/// y ← y + α x.
#[inline]
pub(crate) fn axpy(alpha: f64, x: &[f64], y: &mut [f64]) {
    for (yi, xi) in y.iter_mut().zip(x) {
        *yi += alpha * xi;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn least_squares_solve_reproduces_an_exact_linear_combination() {
        // columns 1, t, t² on 5 points; y = 2 − t + 0.5 t²
        let t = [0.0, 1.0, 2.0, 3.0, 4.0];
        let mut a = Vec::new();
        for p in 0..3 {
            a.extend(t.iter().map(|x: &f64| x.powi(p)));
        }
        let y: Vec<f64> = t.iter().map(|x| 2.0 - x + 0.5 * x * x).collect();
        let qr = Qr::new(&a, 5, 3);
        let mut qtb = y.clone();
        qr.qt_mul(&mut qtb);
        let mut x = [0.0; 3];
        qr.solve_r(&qtb, &mut x);
        for (got, want) in x.iter().zip([2.0, -1.0, 0.5]) {
            assert!((got - want).abs() < 1e-12, "{got} vs {want}");
        }
        let mut r = y.clone();
        qr.project_out(&mut r);
        assert!(r.iter().all(|v| v.abs() < 1e-12));
    }

    #[test]
    fn column_norm_survives_sums_of_squares_outside_the_range_of_f64() {
        // (3, 4)·s has norm 5 s; for s = 1e200 the plain sum of squares overflows and for
        // s = 1e-200 it underflows, so these take the scaled path
        for s in [1e200, 1e-200, 1.0] {
            let qr = Qr::new(&[3.0 * s, 4.0 * s], 2, 1);
            assert!((qr.r(0, 0).abs() / (5.0 * s) - 1.0).abs() < 1e-15, "{s}");
        }
        // four-lane dot product against the plain sum, odd length
        let x: Vec<f64> = (0..37).map(|i| (i as f64 * 0.37).sin()).collect();
        let plain: f64 = x.iter().map(|v| v * v).sum();
        assert!((dot(&x, &x) / plain - 1.0).abs() < 1e-14);
    }
}
