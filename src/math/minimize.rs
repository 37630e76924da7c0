//! One-dimensional minimisation.

/// Golden-section minimisation of a unimodal function on [a, b], to an interval narrower than
/// `tol` (at most 200 steps); returns the midpoint of the final interval.
pub fn golden_min(f: impl Fn(f64) -> f64, mut a: f64, mut b: f64, tol: f64) -> f64 {
    let r = (5f64.sqrt() - 1.0) / 2.0;
    let mut c = b - r * (b - a);
    let mut d = a + r * (b - a);
    let (mut fc, mut fd) = (f(c), f(d));
    for _ in 0..200 {
        if (b - a).abs() <= tol {
            break;
        }
        if fc < fd {
            b = d;
            d = c;
            fd = fc;
            c = b - r * (b - a);
            fc = f(c);
        } else {
            a = c;
            c = d;
            fc = fd;
            d = a + r * (b - a);
            fd = f(d);
        }
    }
    0.5 * (a + b)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_the_minimum_of_a_parabola() {
        let x = golden_min(|x| (x - 0.3).powi(2), -1.0, 2.0, 1e-9);
        assert!((x - 0.3).abs() < 1e-8, "{x}");
    }
}
