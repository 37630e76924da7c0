//! Starting rates: Prony's linear prediction, log-spaced starts and the log-linear slope.

#![allow(clippy::needless_range_loop, clippy::neg_cmp_op_on_partial_ord)]

use super::*;

impl Prepared<'_> {
    /// Starting rates for n states: warm starts from the (n−1)-state rates, then log-spaced.
    pub(super) fn starts(&self, n: usize, prev: Option<&[f64]>, n_starts: usize) -> Vec<Vec<f64>> {
        let (lo, hi) = self.log_rate_range();
        let mut out: Vec<Vec<f64>> = Vec::new();
        if let Some(p) = prev {
            let mx = p.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
            let mn = p.iter().cloned().fold(f64::INFINITY, f64::min);
            let mut a = p.to_vec();
            a.push(mn - 1.5);
            out.push(a);
            let mut b = p.to_vec();
            b.push(mx + 1.5);
            out.push(b);
        }
        // log-spaced: n rates evenly spread over [lo, hi], shifted per start
        let g = n_starts.max(1);
        for s in 0..g {
            let shift = (s as f64 + 0.5) / g as f64 - 0.5;
            let width = (hi - lo).max(1e-3);
            let v: Vec<f64> = (0..n)
                .map(|j| {
                    let frac = (j as f64 + 0.5) / n as f64 + shift / n as f64;
                    lo + width * frac
                })
                .collect();
            out.push(v);
        }
        out.truncate(n_starts.max(1) + usize::from(prev.is_some()) * 2);
        out
    }

    /// Range of plausible ln k: from half a decay over the record to one decay per sample step.
    pub(super) fn log_rate_range(&self) -> (f64, f64) {
        let span = self.tau[self.m - 1].max(f64::MIN_POSITIVE);
        let dt = self
            .tau
            .windows(2)
            .map(|w| w[1] - w[0])
            .fold(f64::INFINITY, f64::min)
            .max(span * 1e-6);
        ((0.5 / span).ln(), (1.0 / dt).ln())
    }

    /// Prony's (1795) linear-prediction estimate of n rates (θ = ln k), for evenly spaced
    /// times: a sum of n exponentials sampled every Δτ obeys y_{i+n} = Σ_j p_j y_{i+n−j}, and
    /// the roots z of z^n − Σ_j p_j z^{n−j} are e^{−k Δτ}. The p_j are fitted by weighted least
    /// squares over every channel (differences y_{i+1} − y_i remove a constant background).
    /// Biased by noise, so only a start; `None` unless the roots are real, distinct, in (0, 1)
    /// and give rates in the plausible range.
    pub(super) fn prony_start(&self, n: usize, background: bool) -> Option<Vec<f64>> {
        let dt = self.step?;
        let (m, nc) = (self.m, self.n_ch);
        let len = m - usize::from(background);
        if n == 0 || n > MAX_STATES || len < 2 * n + 2 {
            return None;
        }
        let sample = |c: usize, i: usize| {
            let y = &self.y[c * m..(c + 1) * m];
            if background {
                y[i + 1] - y[i]
            } else {
                y[i]
            }
        };
        // normal equations G p = b (n ≤ 3)
        let mut g = [[0.0_f64; MAX_STATES]; MAX_STATES];
        let mut b = [0.0_f64; MAX_STATES];
        for c in 0..nc {
            for i in n..len {
                let w = self.w(i);
                let target = sample(c, i);
                for a in 0..n {
                    let xa = sample(c, i - 1 - a);
                    b[a] += w * xa * target;
                    for bb in 0..=a {
                        g[a][bb] += w * xa * sample(c, i - 1 - bb);
                    }
                }
            }
        }
        // Cholesky of the symmetric positive definite G
        let mut l = [[0.0_f64; MAX_STATES]; MAX_STATES];
        for a in 0..n {
            for bb in 0..=a {
                let s = g[a][bb] - (0..bb).map(|k| l[a][k] * l[bb][k]).sum::<f64>();
                if a == bb {
                    if !(s > 1e-14 * g[a][a]) {
                        return None;
                    }
                    l[a][a] = s.sqrt();
                } else {
                    l[a][bb] = s / l[bb][bb];
                }
            }
        }
        let mut p = [0.0_f64; MAX_STATES];
        for a in 0..n {
            p[a] = (b[a] - (0..a).map(|k| l[a][k] * p[k]).sum::<f64>()) / l[a][a];
        }
        for a in (0..n).rev() {
            p[a] = (p[a] - (a + 1..n).map(|k| l[k][a] * p[k]).sum::<f64>()) / l[a][a];
        }
        let roots = real_roots(&p[..n])?;
        let (lo, hi) = self.log_rate_range();
        let mut theta = Vec::with_capacity(n);
        for z in roots {
            if !(z > 0.0 && z < 1.0) {
                return None;
            }
            let th = (-z.ln() / dt).ln();
            if !(th >= lo - DEGENERATE_LOG_MARGIN && th <= hi + DEGENERATE_LOG_MARGIN) {
                return None;
            }
            theta.push(th);
        }
        theta.sort_by(|a, b| b.total_cmp(a));
        if theta.windows(2).any(|w| !(w[0] - w[1] > 0.05)) {
            return None;
        }
        Some(theta)
    }

    /// One-state starting rate from a log-linear fit of the channel sum (weights z², the usual
    /// correction of the log transform), clamped to the plausible range.
    pub(super) fn log_linear_start(&self) -> f64 {
        let (lo, hi) = self.log_rate_range();
        let (m, nc) = (self.m, self.n_ch);
        let (mut sw, mut st, mut sz, mut stt, mut stz) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for i in 0..m {
            let z: f64 = (0..nc).map(|c| self.y[c * m + i]).sum();
            if !(z > 0.0) {
                continue;
            }
            let w = z * z * self.w(i);
            let (t, lz) = (self.tau[i], z.ln());
            sw += w;
            st += w * t;
            sz += w * lz;
            stt += w * t * t;
            stz += w * t * lz;
        }
        let den = sw * stt - st * st;
        let k = -(sw * stz - st * sz) / den;
        if k > 0.0 && k.is_finite() {
            k.ln().clamp(lo, hi)
        } else {
            0.5 * (lo + hi)
        }
    }
}

impl Prepared<'_> {
    /// G(θ) = Σ_c max(u_c, 0)² / D with u_c = Σ_i w_i e_i y_ci and D = Σ_i w_i e_i²,
    /// e_i = e^{−e^θ τ_i}, and its first two derivatives in θ: the weighted sum of squares a
    /// single state with non-negative amplitudes per channel explains (RSS = Σ‖y_c‖²_W − G).
    pub(super) fn one_state_gain(&self, theta: f64, e: &mut Vec<f64>) -> (f64, f64, f64) {
        let (m, nc) = (self.m, self.n_ch);
        self.exp_table(&[theta], e);
        let k = theta.exp();
        let (mut d, mut d1, mut d2) = (0.0, 0.0, 0.0);
        for i in 0..m {
            let (w, kt) = (self.w(i), k * self.tau[i]);
            let (e0, e1, e2) = (e[i], -kt * e[i], (kt * kt - kt) * e[i]);
            d += w * e0 * e0;
            d1 += 2.0 * w * e0 * e1;
            d2 += 2.0 * w * (e1 * e1 + e0 * e2);
        }
        if !(d > 0.0) {
            return (0.0, 0.0, 0.0);
        }
        let (mut g, mut g1, mut g2) = (0.0, 0.0, 0.0);
        for c in 0..nc {
            let y = &self.y[c * m..(c + 1) * m];
            let (mut u, mut u1, mut u2) = (0.0, 0.0, 0.0);
            for i in 0..m {
                let (wy, kt) = (self.w(i) * y[i], k * self.tau[i]);
                u += wy * e[i];
                u1 -= wy * kt * e[i];
                u2 += wy * (kt * kt - kt) * e[i];
            }
            if u <= 0.0 {
                continue;
            }
            g += u * u / d;
            g1 += 2.0 * u * u1 / d - u * u * d1 / (d * d);
            g2 += 2.0 * u1 * u1 / d + 2.0 * u * u2 / d
                - 4.0 * u * u1 * d1 / (d * d)
                - u * u * d2 / (d * d)
                + 2.0 * u * u * d1 * d1 / (d * d * d);
        }
        (g, g1, g2)
    }

    /// A one-state start (no background) refined by safeguarded Newton steps on the
    /// variable-projection objective [`Self::one_state_gain`]: the one-parameter problem
    /// converges quadratically this way, where Gauss–Newton, with the misfit of one state to a
    /// curve of several, converges only linearly. Steps are at most 1 in ln k, halved until G
    /// grows, and the rate stays within e³ of the plausible range; the separable fit then
    /// starts from the result.
    pub(super) fn one_state_refined_start(&self, theta0: f64) -> f64 {
        let (lo, hi) = self.log_rate_range();
        let (lo, hi) = (lo - DEGENERATE_LOG_MARGIN, hi + DEGENERATE_LOG_MARGIN);
        let mut e = Vec::with_capacity(self.m);
        let mut th = theta0;
        let (mut g, mut g1, mut g2) = self.one_state_gain(th, &mut e);
        for _ in 0..ONE_STATE_NEWTON_STEPS {
            let mut step = if g2 < 0.0 { -g1 / g2 } else { g1.signum() };
            step = step.clamp(-1.0, 1.0);
            if !step.is_finite() {
                break;
            }
            if g2 < 0.0 && step.abs() < ONE_STATE_NEWTON_TOL {
                // inside the quadratic basin: the last step is below what G can resolve
                th = (th + step).clamp(lo, hi);
                break;
            }
            let mut accepted = false;
            for _ in 0..10 {
                let t = (th + step).clamp(lo, hi);
                let next = self.one_state_gain(t, &mut e);
                if next.0 >= g {
                    th = t;
                    (g, g1, g2) = next;
                    accepted = true;
                    break;
                }
                step *= 0.5;
            }
            if !accepted {
                break;
            }
        }
        th
    }
}

/// Most Newton steps of [`Prepared::one_state_refined_start`].
const ONE_STATE_NEWTON_STEPS: usize = 20;
/// A Newton step (in ln k) below which [`Prepared::one_state_refined_start`] takes it and stops.
const ONE_STATE_NEWTON_TOL: f64 = 1e-6;

/// The roots of z^n − p₁ z^{n−1} − … − p_n (n ≤ 3) when all are real, else `None`.
pub(super) fn real_roots(p: &[f64]) -> Option<Vec<f64>> {
    match *p {
        [p1] => Some(vec![p1]),
        [p1, p2] => {
            let disc = p1 * p1 + 4.0 * p2;
            if !(disc >= 0.0) {
                return None;
            }
            let q = 0.5 * (p1 + p1.signum() * disc.sqrt());
            // the stable pair: q and −p₂/q (product of the roots is −p₂)
            if q == 0.0 {
                return Some(vec![0.0, 0.0]);
            }
            Some(vec![q, -p2 / q])
        }
        [p1, p2, p3] => {
            // z³ + A z² + B z + C with A = −p₁, B = −p₂, C = −p₃ (trigonometric method)
            let (a, b, c) = (-p1, -p2, -p3);
            let q = (a * a - 3.0 * b) / 9.0;
            let r = (2.0 * a * a * a - 9.0 * a * b + 27.0 * c) / 54.0;
            if !(q > 0.0 && r * r < q * q * q) {
                return None;
            }
            let phi = (r / (q * q * q).sqrt()).clamp(-1.0, 1.0).acos();
            let sq = -2.0 * q.sqrt();
            let tau = std::f64::consts::TAU;
            Some(vec![
                sq * (phi / 3.0).cos() - a / 3.0,
                sq * ((phi + tau) / 3.0).cos() - a / 3.0,
                sq * ((phi - tau) / 3.0).cos() - a / 3.0,
            ])
        }
        _ => None,
    }
}
