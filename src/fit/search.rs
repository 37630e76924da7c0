//! Log-spaced grid search: the one implementation used to start a fit (the phosphor excitation
//! rate, the design rates) and to bracket a regularisation weight before a 1-D refinement
//! ([`math::minimize`](crate::math::minimize)).

/// `n` points from `lo` to `hi` (both > 0, inclusive), equally spaced in log:
/// `lo·(hi/lo)^(i/(n−1))`. One point gives `[lo]`, none gives `[]`.
pub fn log_space(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    match n {
        0 => Vec::new(),
        1 => vec![lo],
        _ => (0..n)
            .map(|i| lo * (hi / lo).powf(i as f64 / (n - 1) as f64))
            .collect(),
    }
}

/// The result of [`log_grid_min`].
#[derive(Debug, Clone, PartialEq)]
pub struct GridSearch {
    /// The grid points.
    pub points: Vec<f64>,
    /// f at every point.
    pub values: Vec<f64>,
    /// Index of the smallest value (the first one on ties; 0 when every value is NaN).
    pub best: usize,
}

impl GridSearch {
    /// The point with the smallest value.
    pub fn x(&self) -> f64 {
        self.points[self.best]
    }

    /// The smallest value.
    pub fn value(&self) -> f64 {
        self.values[self.best]
    }

    /// The neighbours of the best point (the bracket for a 1-D refinement), clamped to the grid.
    pub fn bracket(&self) -> (f64, f64) {
        let n = self.points.len();
        (
            self.points[self.best.saturating_sub(1)],
            self.points[(self.best + 1).min(n - 1)],
        )
    }
}

/// Evaluates `f` on [`log_space`]`(lo, hi, n)` and returns every value with the best point.
///
/// # Panics
/// When `n` is 0 (a programming error).
pub fn log_grid_min(lo: f64, hi: f64, n: usize, mut f: impl FnMut(f64) -> f64) -> GridSearch {
    assert!(n > 0, "a grid search needs at least one point");
    let points = log_space(lo, hi, n);
    let values: Vec<f64> = points.iter().map(|&x| f(x)).collect();
    let mut best = 0;
    for (i, v) in values.iter().enumerate() {
        if *v < values[best] || values[best].is_nan() {
            best = i;
        }
    }
    GridSearch {
        points,
        values,
        best,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_space_is_geometric_and_hits_both_ends() {
        let x = log_space(1e-6, 1e3, 91);
        assert_eq!(x.len(), 91);
        assert_eq!(x[0], 1e-6);
        assert!((x[90] / 1e3 - 1.0).abs() < 1e-14);
        assert!((x[10] / 1e-5 - 1.0).abs() < 1e-13, "{}", x[10]);
        assert!(log_space(2.0, 3.0, 0).is_empty());
        assert_eq!(log_space(2.0, 3.0, 1), vec![2.0]);
    }

    #[test]
    fn grid_minimum_and_bracket_of_a_parabola_in_log() {
        let g = log_grid_min(1e-3, 1e3, 61, |x| (x.log10() - 0.5).powi(2));
        assert!((g.x().log10() - 0.5).abs() < 0.051, "{}", g.x());
        let (a, b) = g.bracket();
        assert!(a < 10f64.powf(0.5) && b > 10f64.powf(0.5));
        // NaN values are never the minimum unless all are
        let g = log_grid_min(1.0, 10.0, 3, |x| if x < 5.0 { f64::NAN } else { x });
        assert_eq!(g.best, 2);
    }
}
