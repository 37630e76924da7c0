//! One-dimensional minimisation, on argmin's Brent solver.
//!
//! [`brent_min`] runs `argmin::solver::brent::BrentOpt` (Brent 1973: golden section with
//! parabolic interpolation) through argmin's `Executor`; the crate keeps no 1-D minimiser of its
//! own.

use argmin::core::{CostFunction, Executor};
use argmin::solver::brent::BrentOpt;

struct Cost<F: Fn(f64) -> f64>(F);

impl<F: Fn(f64) -> f64> CostFunction for Cost<F> {
    type Param = f64;
    type Output = f64;
    fn cost(&self, x: &f64) -> Result<f64, argmin::core::Error> {
        let v = (self.0)(*x);
        // Brent interpolates parabolas through the values: a NaN or an infinity would poison
        // them, so a non-finite value counts as very large but finite
        Ok(if v.is_finite() { v } else { 1e300 })
    }
}

/// Minimises a unimodal function on [a, b] by Brent's method to an interval of about `tol`
/// (absolute, plus 1e-10 relative to the minimiser; at most 200 steps); returns the best point
/// found. Falls back to the midpoint only if argmin reports an error (it cannot for this cost).
pub fn brent_min(f: impl Fn(f64) -> f64, a: f64, b: f64, tol: f64) -> f64 {
    let (a, b) = if a <= b { (a, b) } else { (b, a) };
    if b.partial_cmp(&a) != Some(std::cmp::Ordering::Greater) {
        return a;
    }
    let solver = BrentOpt::new(a, b).set_tolerance(1e-10, 0.25 * tol.max(0.0));
    Executor::new(Cost(f), solver)
        .configure(|s| s.max_iters(200))
        .run()
        .ok()
        .and_then(|r| r.state.best_param)
        .unwrap_or(0.5 * (a + b))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_the_minimum_of_a_parabola() {
        let x = brent_min(|x| (x - 0.3).powi(2), -1.0, 2.0, 1e-9);
        assert!((x - 0.3).abs() < 1e-8, "{x}");
    }

    #[test]
    fn minimum_at_an_end_of_the_interval_and_reversed_bounds() {
        let x = brent_min(|x| x, 2.0, -1.0, 1e-6);
        assert!((x + 1.0).abs() < 1e-5, "{x}");
        // a function that is NaN on part of the interval
        let x = brent_min(
            |x| if x < 0.0 { f64::NAN } else { (x - 0.5).powi(2) },
            -1.0,
            1.0,
            1e-8,
        );
        assert!((x - 0.5).abs() < 1e-6, "{x}");
    }
}
