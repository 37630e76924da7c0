//! Small dense and banded linear algebra used across domains.

use crate::error::{Error, Result};

/// A 3×3 matrix stored row-major.
pub type Mat3 = [[f64; 3]; 3];

/// Solves a tridiagonal system with partial pivoting (LAPACK `gtsv`).
///
/// `lower[i]` multiplies `x[i-1]` in row `i` (`lower[0]` unused), `upper[i]` multiplies `x[i+1]`
/// (`upper[n-1]` unused).
pub fn solve_tridiagonal(
    lower: &[f64],
    diag: &[f64],
    upper: &[f64],
    rhs: &[f64],
) -> Result<Vec<f64>> {
    let n = diag.len();
    if lower.len() != n || upper.len() != n || rhs.len() != n {
        return Err(Error::ShapeMismatch {
            what: "tridiagonal system".into(),
            expected: n,
            got: rhs.len(),
        });
    }
    // dl: sub-diagonal (n-1), d: diagonal, du: super-diagonal (n-1), du2: fill-in (n-2).
    let mut dl: Vec<f64> = lower[1..].to_vec();
    let mut d = diag.to_vec();
    let mut du: Vec<f64> = upper[..n - 1].to_vec();
    let mut du2 = vec![0.0; n.saturating_sub(2)];
    let mut b = rhs.to_vec();
    for i in 0..n - 1 {
        if d[i].abs() >= dl[i].abs() {
            if d[i] == 0.0 {
                return Err(singular());
            }
            let fact = dl[i] / d[i];
            d[i + 1] -= fact * du[i];
            b[i + 1] -= fact * b[i];
            dl[i] = 0.0;
        } else {
            // swap rows i and i+1
            let fact = d[i] / dl[i];
            d[i] = dl[i];
            let tmp = d[i + 1];
            d[i + 1] = du[i] - fact * tmp;
            if i + 1 < n - 1 {
                dl[i] = du[i + 1];
                du[i + 1] = -fact * dl[i];
            }
            du[i] = tmp;
            let tb = b[i];
            b[i] = b[i + 1];
            b[i + 1] = tb - fact * b[i + 1];
            if i < n - 2 {
                du2[i] = dl[i];
            }
        }
        if d[i] == 0.0 {
            return Err(singular());
        }
    }
    if d[n - 1] == 0.0 {
        return Err(singular());
    }
    let mut x = vec![0.0; n];
    x[n - 1] = b[n - 1] / d[n - 1];
    if n > 1 {
        x[n - 2] = (b[n - 2] - du[n - 2] * x[n - 1]) / d[n - 2];
    }
    for i in (0..n.saturating_sub(2)).rev() {
        x[i] = (b[i] - du[i] * x[i + 1] - du2[i] * x[i + 2]) / d[i];
    }
    Ok(x)
}

/// Solves a small dense system `A x = b` by Gaussian elimination with partial pivoting
/// (normal equations of the little Gauss–Newton / LM steps in the domains). `None` when `A` is
/// singular or the solution is not finite.
pub fn solve_dense(mut a: Vec<Vec<f64>>, mut b: Vec<f64>) -> Option<Vec<f64>> {
    let n = b.len();
    for col in 0..n {
        let piv = (col..n).max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs()))?;
        if a[piv][col].abs().is_nan() || a[piv][col].abs() <= 1e-300 {
            return None;
        }
        a.swap(col, piv);
        b.swap(col, piv);
        for row in col + 1..n {
            let f = a[row][col] / a[col][col];
            let (top, bottom) = a.split_at_mut(row);
            for (rc, pc) in bottom[0][col..n].iter_mut().zip(&top[col][col..n]) {
                *rc -= f * pc;
            }
            b[row] -= f * b[col];
        }
    }
    let mut x = vec![0.0; n];
    for row in (0..n).rev() {
        let s: f64 = (row + 1..n).map(|c| a[row][c] * x[c]).sum();
        x[row] = (b[row] - s) / a[row][row];
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
}

fn singular() -> Error {
    Error::Numerical {
        what: "tridiagonal solve".into(),
        reason: "matrix is singular".into(),
    }
}

/// `m · v` for a 3×3 matrix.
pub fn mat3_mul_vec(m: &Mat3, v: [f64; 3]) -> [f64; 3] {
    [
        m[0][0] * v[0] + m[0][1] * v[1] + m[0][2] * v[2],
        m[1][0] * v[0] + m[1][1] * v[1] + m[1][2] * v[2],
        m[2][0] * v[0] + m[2][1] * v[1] + m[2][2] * v[2],
    ]
}

/// `a · b` for 3×3 matrices.
pub fn mat3_mul(a: &Mat3, b: &Mat3) -> Mat3 {
    let mut r = [[0.0; 3]; 3];
    for (i, row) in r.iter_mut().enumerate() {
        for (j, cell) in row.iter_mut().enumerate() {
            *cell = (0..3).map(|k| a[i][k] * b[k][j]).sum();
        }
    }
    r
}

/// Inverse of a 3×3 matrix, or an error when it is singular.
pub fn mat3_inv(m: &Mat3) -> Result<Mat3> {
    let inv = nalgebra::Matrix3::from_row_slice(&[
        m[0][0], m[0][1], m[0][2], m[1][0], m[1][1], m[1][2], m[2][0], m[2][1], m[2][2],
    ])
    .try_inverse()
    .ok_or_else(|| Error::Numerical {
        what: "3×3 inverse".into(),
        reason: "matrix is singular".into(),
    })?;
    let mut r = [[0.0; 3]; 3];
    for (i, row) in r.iter_mut().enumerate() {
        for (j, cell) in row.iter_mut().enumerate() {
            *cell = inv[(i, j)];
        }
    }
    Ok(r)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dense_solve_pivots_and_reports_singular_systems() {
        let x = solve_dense(vec![vec![0.0, 2.0], vec![3.0, 1.0]], vec![4.0, 5.0]).unwrap();
        assert!((x[0] - 1.0).abs() < 1e-15 && (x[1] - 2.0).abs() < 1e-15);
        assert!(solve_dense(vec![vec![1.0, 2.0], vec![2.0, 4.0]], vec![1.0, 2.0]).is_none());
    }

    #[test]
    fn tridiagonal_solve_handles_a_zero_leading_pivot() {
        // [[0,1,0],[1,2,1],[0,1,3]] x = [1, 4, 4] → x = [1, 1, 1]
        let x = solve_tridiagonal(
            &[0.0, 1.0, 1.0],
            &[0.0, 2.0, 3.0],
            &[1.0, 1.0, 0.0],
            &[1.0, 4.0, 4.0],
        )
        .unwrap();
        for v in x {
            assert!((v - 1.0).abs() < 1e-14);
        }
    }
}
