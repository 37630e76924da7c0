//! One-dimensional interpolation and extrapolation, ported from colour-science so that reshaped
//! spectra agree with `colour.SpectralDistribution.align` to rounding.
//!
//! * [`sprague`] — the fifth-order Sprague (1880) interpolator colour uses for uniformly sampled
//!   data (`colour.SpragueInterpolator`), including its boundary extension by the published
//!   coefficients (divided by 209) and colour's evaluation order.
//! * [`CubicSpline`] — a not-a-knot cubic spline, what colour's `CubicSplineInterpolator`
//!   (`scipy.interpolate.interp1d(kind="cubic")`) computes for non-uniform data.
//! * [`linear`] — piecewise-linear interpolation (`numpy.interp`).
//!
//! Extrapolation is constant (first and last value), colour's default for spectral data.

use crate::error::{Error, Result};

/// Interpolation method for resampling sampled data.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Interpolator {
    /// colour's default: Sprague for uniform grids, not-a-knot cubic spline otherwise.
    #[default]
    Default,
    /// Sprague (1880) fifth-order interpolation; requires a uniform grid with at least 6 samples.
    Sprague,
    /// Not-a-knot cubic spline; requires at least 4 samples.
    CubicSpline,
    /// Piecewise linear.
    Linear,
}

const SPRAGUE_C: [[f64; 6]; 4] = [
    [884.0, -1960.0, 3033.0, -2648.0, 1080.0, -180.0],
    [508.0, -540.0, 488.0, -367.0, 144.0, -24.0],
    [-24.0, 144.0, -367.0, 488.0, -540.0, 508.0],
    [-180.0, 1080.0, -2648.0, 3033.0, -1960.0, 884.0],
];

const SPRAGUE_W: [[f64; 6]; 5] = [
    [2.0, -16.0, 0.0, 16.0, -2.0, 0.0],
    [-1.0, 16.0, -30.0, 16.0, -1.0, 0.0],
    [-9.0, 39.0, -70.0, 66.0, -33.0, 7.0],
    [13.0, -64.0, 126.0, -124.0, 61.0, -12.0],
    [-5.0, 25.0, -50.0, 50.0, -25.0, 5.0],
];

/// A Sprague interpolator over uniformly spaced `x` (colour's `SpragueInterpolator`).
#[derive(Debug, Clone)]
pub struct Sprague {
    xp: Vec<f64>,
    yp: Vec<f64>,
}

impl Sprague {
    /// Builds the interpolator; `x` must be uniform and hold at least 6 samples.
    pub fn new(x: &[f64], y: &[f64]) -> Result<Self> {
        if x.len() != y.len() {
            return Err(Error::ShapeMismatch {
                what: "Sprague interpolation x and y".into(),
                expected: x.len(),
                got: y.len(),
            });
        }
        if y.len() < 6 {
            return Err(Error::invalid(
                "samples",
                format!(
                    "Sprague interpolation needs at least 6 samples, got {}",
                    y.len()
                ),
            ));
        }
        let n = x.len();
        let step = x[1] - x[0];
        let mut xp = Vec::with_capacity(n + 4);
        xp.push(x[0] - step * 2.0);
        xp.push(x[0] - step);
        xp.extend_from_slice(x);
        xp.push(x[n - 1] + step);
        xp.push(x[n - 1] + step * 2.0);
        let heads = [&y[0..6], &y[0..6], &y[n - 6..], &y[n - 6..]];
        let mut ext = [0.0; 4];
        for (k, (coef, vals)) in SPRAGUE_C.iter().zip(heads.iter()).enumerate() {
            // numpy sums the element-wise products pairwise; a left fold of 6 terms rounds the same
            // way for these magnitudes to well below the 1e-9 tolerance we test.
            let s: f64 = coef.iter().zip(vals.iter()).map(|(c, v)| c * v).sum();
            ext[k] = s / 209.0;
        }
        let mut yp = Vec::with_capacity(n + 4);
        yp.push(ext[0]);
        yp.push(ext[1]);
        yp.extend_from_slice(y);
        yp.push(ext[2]);
        yp.push(ext[3]);
        Ok(Sprague { xp, yp })
    }

    /// First sample's abscissa.
    pub fn x_min(&self) -> f64 {
        self.xp[2]
    }

    /// Last sample's abscissa.
    pub fn x_max(&self) -> f64 {
        self.xp[self.xp.len() - 3]
    }

    /// Evaluates at `x`, which must lie within the sampled range.
    pub fn eval(&self, x: f64) -> f64 {
        // numpy.searchsorted(side="left") - 1, as colour does.
        let pos = self.xp.partition_point(|&v| v < x);
        let n = self.yp.len() as isize;
        let i = pos as isize - 1;
        let at = |k: isize| -> f64 {
            // numpy's negative indices wrap; only reachable at the first node where the weight is 0.
            let k = if k < 0 { k + n } else { k };
            self.yp[k.clamp(0, n - 1) as usize]
        };
        let iu = i.clamp(0, n - 2) as usize;
        let big_x = {
            let d = self.xp[iu + 1] - self.xp[iu];
            if d == 0.0 {
                0.0
            } else {
                (x - self.xp[iu]) / d
            }
        };
        let r_s = [at(i - 2), at(i - 1), at(i), at(i + 1), at(i + 2), at(i + 3)];
        let mut y = at(i);
        let mut xpow = 1.0;
        for w in SPRAGUE_W.iter() {
            let a: f64 = w.iter().zip(r_s.iter()).map(|(w, r)| w * r).sum::<f64>() / 24.0;
            xpow *= big_x;
            y += a * xpow;
        }
        y
    }
}

/// Sprague-interpolates `y(x)` at every point of `at` (all within range).
pub fn sprague(x: &[f64], y: &[f64], at: &[f64]) -> Result<Vec<f64>> {
    let s = Sprague::new(x, y)?;
    Ok(at.iter().map(|&v| s.eval(v)).collect())
}

/// A not-a-knot cubic spline through `(x, y)` (scipy's `interp1d(kind="cubic")`).
#[derive(Debug, Clone)]
pub struct CubicSpline {
    x: Vec<f64>,
    y: Vec<f64>,
    slopes: Vec<f64>,
}

impl CubicSpline {
    /// Fits the spline; `x` strictly increasing with at least 4 samples.
    pub fn new(x: &[f64], y: &[f64]) -> Result<Self> {
        let n = x.len();
        if n != y.len() {
            return Err(Error::ShapeMismatch {
                what: "cubic spline x and y".into(),
                expected: n,
                got: y.len(),
            });
        }
        if n < 4 {
            return Err(Error::invalid(
                "samples",
                format!("cubic spline interpolation needs at least 4 samples, got {n}"),
            ));
        }
        let dx: Vec<f64> = x.windows(2).map(|w| w[1] - w[0]).collect();
        let s: Vec<f64> = (0..n - 1).map(|i| (y[i + 1] - y[i]) / dx[i]).collect();
        // Tridiagonal system for the first derivatives (scipy.interpolate.CubicSpline layout).
        let mut lower = vec![0.0; n]; // lower[i] multiplies m[i-1]
        let mut diag = vec![0.0; n];
        let mut upper = vec![0.0; n]; // upper[i] multiplies m[i+1]
        let mut rhs = vec![0.0; n];
        for i in 1..n - 1 {
            lower[i] = dx[i];
            diag[i] = 2.0 * (dx[i - 1] + dx[i]);
            upper[i] = dx[i - 1];
            rhs[i] = 3.0 * (dx[i] * s[i - 1] + dx[i - 1] * s[i]);
        }
        let d0 = x[2] - x[0];
        diag[0] = dx[1];
        upper[0] = d0;
        rhs[0] = ((dx[0] + 2.0 * d0) * dx[1] * s[0] + dx[0] * dx[0] * s[1]) / d0;
        let dn = x[n - 1] - x[n - 3];
        lower[n - 1] = dn;
        diag[n - 1] = dx[n - 3];
        rhs[n - 1] =
            (dx[n - 2] * dx[n - 2] * s[n - 3] + (2.0 * dn + dx[n - 2]) * dx[n - 3] * s[n - 2]) / dn;
        let slopes = super::linalg::solve_tridiagonal(&lower, &diag, &upper, &rhs)?;
        Ok(CubicSpline {
            x: x.to_vec(),
            y: y.to_vec(),
            slopes,
        })
    }

    /// Evaluates the spline at `v` (within range; outside, the end cubic is continued).
    pub fn eval(&self, v: f64) -> f64 {
        let n = self.x.len();
        let i = self.x.partition_point(|&xi| xi <= v).clamp(1, n - 1) - 1;
        let h = self.x[i + 1] - self.x[i];
        let s = (self.y[i + 1] - self.y[i]) / h;
        let m0 = self.slopes[i];
        let m1 = self.slopes[i + 1];
        let t = v - self.x[i];
        let c2 = (3.0 * s - 2.0 * m0 - m1) / h;
        let c3 = (m0 + m1 - 2.0 * s) / (h * h);
        self.y[i] + t * (m0 + t * (c2 + t * c3))
    }
}

/// Piecewise-linear interpolation of `y(x)` at `v` (numpy.interp; clamps outside the range).
pub fn linear_at(x: &[f64], y: &[f64], v: f64) -> f64 {
    let n = x.len();
    if n == 1 || v <= x[0] {
        return y[0];
    }
    if v >= x[n - 1] {
        return y[n - 1];
    }
    let i = x.partition_point(|&xi| xi <= v) - 1;
    let t = (v - x[i]) / (x[i + 1] - x[i]);
    y[i] + t * (y[i + 1] - y[i])
}

/// Piecewise-linear interpolation at every point of `at`.
pub fn linear(x: &[f64], y: &[f64], at: &[f64]) -> Vec<f64> {
    at.iter().map(|&v| linear_at(x, y, v)).collect()
}

/// True when consecutive differences of `x` are equal to within 1e-9 relative.
///
/// colour compares the differences exactly; the tolerance only matters for grids written with
/// decimal fractions (e.g. 0.1 nm steps), which exact comparison would wrongly call non-uniform.
pub fn is_uniform(x: &[f64]) -> bool {
    if x.len() < 3 {
        return true;
    }
    let d0 = x[1] - x[0];
    x.windows(2)
        .all(|w| ((w[1] - w[0]) - d0).abs() <= 1e-9 * d0.abs().max(1e-300))
}

/// Interpolates `y(x)` at `at` with `method`, extrapolating with the first/last value outside the
/// sampled range (colour's `Extrapolator(method="Constant")`).
pub fn resample(x: &[f64], y: &[f64], at: &[f64], method: Interpolator) -> Result<Vec<f64>> {
    let n = x.len();
    if n == 0 {
        return Err(Error::invalid(
            "samples",
            "cannot interpolate an empty table",
        ));
    }
    let method = match method {
        Interpolator::Default if n >= 6 && is_uniform(x) => Interpolator::Sprague,
        Interpolator::Default if n >= 4 && !is_uniform(x) => Interpolator::CubicSpline,
        // Too few samples for the higher-order schemes: fall back to linear (colour raises).
        Interpolator::Default => Interpolator::Linear,
        m => m,
    };
    let (lo, hi) = (x[0], x[n - 1]);
    let inside = |v: f64| -> Option<f64> {
        if v < lo {
            Some(y[0])
        } else if v > hi {
            Some(y[n - 1])
        } else {
            None
        }
    };
    Ok(match method {
        Interpolator::Sprague => {
            if !is_uniform(x) {
                return Err(Error::invalid(
                    "interpolator",
                    "Sprague interpolation needs uniformly spaced wavelengths",
                ));
            }
            let s = Sprague::new(x, y)?;
            at.iter()
                .map(|&v| inside(v).unwrap_or_else(|| s.eval(v)))
                .collect()
        }
        Interpolator::CubicSpline => {
            let s = CubicSpline::new(x, y)?;
            at.iter()
                .map(|&v| inside(v).unwrap_or_else(|| s.eval(v)))
                .collect()
        }
        Interpolator::Linear | Interpolator::Default => linear(x, y, at),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sprague_reproduces_a_quintic_inside_and_the_nodes() {
        let x: Vec<f64> = (0..12).map(|i| 400.0 + 10.0 * i as f64).collect();
        let f = |v: f64| {
            let t = (v - 400.0) / 100.0;
            1.0 + t - 0.5 * t * t + 0.3 * t.powi(3)
        };
        let y: Vec<f64> = x.iter().map(|&v| f(v)).collect();
        let s = Sprague::new(&x, &y).unwrap();
        for &v in &x {
            assert!((s.eval(v) - f(v)).abs() < 1e-12);
        }
        // Interior intervals reproduce cubics exactly (Sprague is exact to degree 5 inside).
        for k in 0..80 {
            let v = 420.0 + k as f64 * 0.7;
            assert!((s.eval(v) - f(v)).abs() < 1e-9, "at {v}");
        }
    }

    #[test]
    fn not_a_knot_spline_reproduces_any_cubic() {
        let x = [0.0, 0.5, 1.7, 2.0, 3.3, 4.0, 6.1];
        let f = |v: f64| 2.0 - v + 0.25 * v * v - 0.1 * v * v * v;
        let y: Vec<f64> = x.iter().map(|&v| f(v)).collect();
        let s = CubicSpline::new(&x, &y).unwrap();
        for k in 0..=60 {
            let v = k as f64 * 0.1;
            assert!((s.eval(v) - f(v)).abs() < 1e-10, "at {v}");
        }
    }

    #[test]
    fn resampling_extrapolates_with_the_end_values() {
        let x = [1.0, 2.0, 3.0];
        let y = [5.0, 6.0, 7.0];
        let r = resample(&x, &y, &[0.0, 1.5, 4.0], Interpolator::Linear).unwrap();
        assert_eq!(r, vec![5.0, 5.5, 7.0]);
    }
}
