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

fn lstsq_subset(a: &[f64], m: usize, cols: &[usize], b: &[f64], out: &mut [f64]) {
    let k = cols.len();
    let mut sub = Vec::with_capacity(m * k);
    for &c in cols {
        sub.extend_from_slice(&a[c * m..(c + 1) * m]);
    }
    let qr = Qr::new(&sub, m, k);
    let mut qtb = b.to_vec();
    qr.qt_mul(&mut qtb);
    let mut z = vec![0.0; k];
    qr.solve_r(&qtb, &mut z);
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
    let all: Vec<usize> = (0..n).collect();
    let mut x = vec![0.0; n];
    let mut r = vec![0.0; m];
    if m >= n {
        lstsq_subset(a, m, &all, b, &mut x);
        if x.iter().zip(free).all(|(v, f)| *f || *v >= 0.0) {
            residual(a, m, n, &x, b, &mut r);
            let rss = r.iter().map(|v| v * v).sum();
            return NnlsSolution {
                x,
                passive: vec![true; n],
                rss,
            };
        }
    }
    // Lawson–Hanson active set.
    x.iter_mut().for_each(|v| *v = 0.0);
    let mut passive: Vec<bool> = free.to_vec();
    let mut z = vec![0.0; n];
    if passive.iter().any(|p| *p) {
        let cols: Vec<usize> = (0..n).filter(|&j| passive[j]).collect();
        lstsq_subset(a, m, &cols, b, &mut x);
    }
    let scale = b
        .iter()
        .fold(0.0_f64, |s, v| s.max(v.abs()))
        .max(f64::MIN_POSITIVE);
    let tol = 1e-12 * scale;
    let mut outer = 0;
    loop {
        residual(a, m, n, &x, b, &mut r);
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
            let w: f64 = col.iter().zip(&r).map(|(c, ri)| c * ri).sum::<f64>() / norm;
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
            let cols: Vec<usize> = (0..n).filter(|&j| passive[j]).collect();
            z.iter_mut().for_each(|v| *v = 0.0);
            lstsq_subset(a, m, &cols, b, &mut z);
            let infeasible: Vec<usize> = cols
                .iter()
                .copied()
                .filter(|&j| !free[j] && z[j] <= 0.0)
                .collect();
            if infeasible.is_empty() {
                x.copy_from_slice(&z);
                break;
            }
            let mut alpha = 1.0_f64;
            for &j in &infeasible {
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
    residual(a, m, n, &x, b, &mut r);
    let rss = r.iter().map(|v| v * v).sum();
    NnlsSolution { x, passive, rss }
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
