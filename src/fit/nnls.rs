//! Non-negative least squares with optionally free columns (Lawson & Hanson 1974, ch. 23).
//!
//! Solves `min ‖A x − b‖₂` subject to `x_j ≥ 0` for every constrained column j; free columns
//! (for example a background that may be negative) are always in the passive set. A is m × n
//! column-major with small n (the solvers use n ≤ a few); every least-squares sub-problem is
//! solved by Householder QR, never by normal equations, so ill-conditioned exponential bases
//! keep their digits.

// Index loops mirror the matrix notation of the maths; `!(a > b)` comparisons deliberately
// reject NaN along with out-of-range values.
#![allow(clippy::needless_range_loop, clippy::neg_cmp_op_on_partial_ord)]

use super::qr::Qr;

/// Result of [`nnls`].
#[derive(Debug, Clone, PartialEq)]
pub struct NnlsSolution {
    /// The coefficients (n), zero where the constraint is active.
    pub x: Vec<f64>,
    /// Which columns are in the passive (unconstrained-at-solution) set.
    pub passive: Vec<bool>,
    /// Residual sum of squares ‖A x − b‖².
    pub rss: f64,
}

/// Maximum Lawson–Hanson outer iterations, as a multiple of n (the book's bound is 3n).
const MAX_ITER_PER_COL: usize = 3;

/// Reusable buffers of [`nnls_in`]: the solvers call NNLS thousands of times on tiny problems,
/// where allocating the sub-problem buffers cost more than the arithmetic.
#[derive(Debug, Clone, Default)]
pub(crate) struct NnlsWorkspace {
    sub: Vec<f64>,
    qr: Qr,
    qtb: Vec<f64>,
    zk: Vec<f64>,
    cols: Vec<usize>,
    z: Vec<f64>,
    r: Vec<f64>,
    pub(crate) x: Vec<f64>,
    pub(crate) passive: Vec<bool>,
}

fn lstsq_subset(
    a: &[f64],
    m: usize,
    cols: &[usize],
    b: &[f64],
    out: &mut [f64],
    ws: &mut (Vec<f64>, &mut Qr, Vec<f64>, Vec<f64>),
) {
    let k = cols.len();
    let (sub, qr, qtb, z) = ws;
    sub.clear();
    for &c in cols {
        sub.extend_from_slice(&a[c * m..(c + 1) * m]);
    }
    qr.factor(sub, m, k);
    qtb.clear();
    qtb.extend_from_slice(&b[..m]);
    qr.qt_mul(qtb);
    z.clear();
    z.resize(k, 0.0);
    qr.solve_r(qtb, z);
    for (i, &c) in cols.iter().enumerate() {
        out[c] = z[i];
    }
}

fn residual(a: &[f64], m: usize, n: usize, x: &[f64], b: &[f64], r: &mut [f64]) {
    r.copy_from_slice(&b[..m]);
    for j in 0..n {
        if x[j] != 0.0 {
            let col = &a[j * m..(j + 1) * m];
            for i in 0..m {
                r[i] -= col[i] * x[j];
            }
        }
    }
}

/// Solves the NNLS problem; `free[j]` marks columns without the sign constraint.
///
/// Fast path: the unconstrained solution is returned when it is already feasible (it is then
/// the NNLS solution, the problem being convex).
pub fn nnls(a: &[f64], m: usize, n: usize, b: &[f64], free: &[bool]) -> NnlsSolution {
    let mut ws = NnlsWorkspace::default();
    let rss = nnls_in(a, m, n, b, free, true, &mut ws);
    NnlsSolution {
        x: ws.x,
        passive: ws.passive,
        rss,
    }
}

/// [`nnls`] in reusable buffers (solution in `ws.x`, `ws.passive`; returns the RSS), with the
/// same arithmetic. `try_unconstrained: false` skips the fast path, for a caller that has
/// already found the unconstrained solution infeasible by the same QR arithmetic.
pub(crate) fn nnls_in(
    a: &[f64],
    m: usize,
    n: usize,
    b: &[f64],
    free: &[bool],
    try_unconstrained: bool,
    ws: &mut NnlsWorkspace,
) -> f64 {
    let NnlsWorkspace {
        sub,
        qr,
        qtb,
        zk,
        cols,
        z,
        r,
        x,
        passive,
    } = ws;
    let mut lw = (
        std::mem::take(sub),
        qr,
        std::mem::take(qtb),
        std::mem::take(zk),
    );
    x.clear();
    x.resize(n, 0.0);
    r.clear();
    r.resize(m, 0.0);
    passive.clear();
    let rss = 'solve: {
        if m >= n && try_unconstrained {
            cols.clear();
            cols.extend(0..n);
            lstsq_subset(a, m, cols, b, x, &mut lw);
            if x.iter().zip(free).all(|(v, f)| *f || *v >= 0.0) {
                residual(a, m, n, x, b, r);
                passive.resize(n, true);
                break 'solve r.iter().map(|v| v * v).sum();
            }
        }
        // Lawson–Hanson active set.
        x.iter_mut().for_each(|v| *v = 0.0);
        passive.extend_from_slice(&free[..n]);
        z.clear();
        z.resize(n, 0.0);
        if passive.iter().any(|p| *p) {
            cols.clear();
            cols.extend((0..n).filter(|&j| passive[j]));
            lstsq_subset(a, m, cols, b, x, &mut lw);
        }
        let scale = b
            .iter()
            .fold(0.0_f64, |s, v| s.max(v.abs()))
            .max(f64::MIN_POSITIVE);
        let tol = 1e-12 * scale;
        let mut outer = 0;
        loop {
            residual(a, m, n, x, b, r);
            // gradient w = Aᵀ r
            let mut best = None;
            let mut best_w = tol;
            for j in 0..n {
                if passive[j] {
                    continue;
                }
                let col = &a[j * m..(j + 1) * m];
                let norm = col
                    .iter()
                    .map(|v| v * v)
                    .sum::<f64>()
                    .sqrt()
                    .max(f64::MIN_POSITIVE);
                let w: f64 = col.iter().zip(r.iter()).map(|(c, ri)| c * ri).sum::<f64>() / norm;
                if w > best_w {
                    best_w = w;
                    best = Some(j);
                }
            }
            let Some(enter) = best else { break };
            outer += 1;
            if outer > MAX_ITER_PER_COL * n + 1 {
                break;
            }
            passive[enter] = true;
            loop {
                cols.clear();
                cols.extend((0..n).filter(|&j| passive[j]));
                z.iter_mut().for_each(|v| *v = 0.0);
                lstsq_subset(a, m, cols, b, z, &mut lw);
                let infeasible = |j: &usize| !free[*j] && z[*j] <= 0.0;
                if !cols.iter().any(infeasible) {
                    x.copy_from_slice(z);
                    break;
                }
                let mut alpha = 1.0_f64;
                for j in cols.iter().copied().filter(infeasible) {
                    let d = x[j] - z[j];
                    if d > 0.0 {
                        alpha = alpha.min(x[j] / d);
                    }
                }
                for j in 0..n {
                    x[j] += alpha * (z[j] - x[j]);
                    if !free[j] && passive[j] && x[j] <= tol * 1e-3 {
                        passive[j] = false;
                        x[j] = 0.0;
                    }
                }
                if cols.len() == 1 && !passive[cols[0]] {
                    break;
                }
            }
        }
        residual(a, m, n, x, b, r);
        r.iter().map(|v| v * v).sum()
    };
    *sub = lw.0;
    *qtb = lw.2;
    *zk = lw.3;
    rss
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nnls_clamps_a_coefficient_that_least_squares_would_make_negative() {
        // b = 1·c0 − 0.5·c1 exactly; NNLS must set x1 = 0 and refit x0.
        let c0 = [1.0, 1.0, 1.0, 1.0];
        let c1 = [0.0, 1.0, 2.0, 3.0];
        let a: Vec<f64> = c0.iter().chain(c1.iter()).copied().collect();
        let b: Vec<f64> = (0..4).map(|i| c0[i] - 0.5 * c1[i]).collect();
        let s = nnls(&a, 4, 2, &b, &[false, false]);
        assert_eq!(s.x[1], 0.0);
        assert!((s.x[0] - b.iter().sum::<f64>() / 4.0).abs() < 1e-12);
        let f = nnls(&a, 4, 2, &b, &[false, true]);
        assert!((f.x[1] + 0.5).abs() < 1e-12, "free column keeps its sign");
    }
}
