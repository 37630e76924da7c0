//! Rate uncertainties from the covariance of all parameters and the final report.

#![allow(clippy::needless_range_loop, clippy::neg_cmp_op_on_partial_ord)]

use super::*;

impl Prepared<'_> {
    /// e^{−k_j t_i} on the absolute times, state after state (one `exp` per state and a
    /// product per sample when the times are evenly spaced).
    pub(super) fn abs_exp_table(&self, ks: &[f64]) -> Vec<f64> {
        let mut out = Vec::with_capacity(ks.len() * self.m);
        let step = self.step;
        for k in ks {
            match step {
                Some(dt) => {
                    let r = (-k * dt).exp();
                    let mut e = (-k * self.t0).exp();
                    for _ in 0..self.m {
                        out.push(e);
                        e *= r;
                    }
                }
                None => out.extend(self.curve.t_s.iter().map(|t| (-k * t).exp())),
            }
        }
        out
    }

    /// Covariance over (k, amplitudes, spectrum, background) in absolute time; returns the
    /// standard deviations of k and of the amplitudes per state (None when singular).
    pub(super) fn uncertainties(
        &self,
        ks: &[f64],
        c_abs: &[Vec<f64>],
        a_abs: &[f64],
        spectrum: &[f64],
        opts: &DecayFitOptions,
        rss: f64,
    ) -> Option<(Vec<f64>, Vec<f64>)> {
        let (m, nc) = (self.m, self.n_ch);
        let n = ks.len();
        let shared = nc > 1 && opts.amplitudes == AmplitudeModel::SharedSpectrum;
        let rows = m * nc;
        let t = &self.curve.t_s;
        let ex = self.abs_exp_table(ks);
        let sw = |i: usize| self.sqrt_w.as_ref().map_or(1.0, |w| w[i]);
        // the weighted Jacobian, column after column (each column: channel after channel)
        let mut jac: Vec<f64> = Vec::with_capacity(rows * (2 * n + n * nc + 2 * nc));
        let mut p = 0;
        let mut k_idx = vec![None; n];
        let mut a_idx = vec![None; n];
        for j in 0..n {
            if a_abs[j] <= 0.0 {
                continue;
            }
            let e = &ex[j * m..(j + 1) * m];
            for c in 0..nc {
                jac.extend((0..m).map(|i| -t[i] * c_abs[j][c] * e[i] * sw(i)));
            }
            k_idx[j] = Some(p);
            p += 1;
            if shared || nc == 1 {
                for c in 0..nc {
                    jac.extend((0..m).map(|i| spectrum[c] * e[i] * sw(i)));
                }
                a_idx[j] = Some(p);
                p += 1;
            } else {
                for c in 0..nc {
                    if c_abs[j][c] <= 0.0 {
                        continue;
                    }
                    for c2 in 0..nc {
                        if c2 == c {
                            jac.extend((0..m).map(|i| e[i] * sw(i)));
                        } else {
                            jac.extend(std::iter::repeat_n(0.0, m));
                        }
                    }
                    p += 1;
                }
            }
        }
        if shared {
            let fix = spectrum
                .iter()
                .enumerate()
                .fold(
                    (0, f64::NEG_INFINITY),
                    |b, (i, v)| if *v > b.1 { (i, *v) } else { b },
                )
                .0;
            for c in 0..nc {
                if c == fix || spectrum[c] <= 0.0 {
                    continue;
                }
                for c2 in 0..nc {
                    if c2 == c {
                        jac.extend((0..m).map(|i| {
                            (0..n).map(|j| a_abs[j] * ex[j * m + i]).sum::<f64>() * sw(i)
                        }));
                    } else {
                        jac.extend(std::iter::repeat_n(0.0, m));
                    }
                }
                p += 1;
            }
        }
        if opts.background {
            for c in 0..nc {
                for c2 in 0..nc {
                    if c2 == c {
                        jac.extend((0..m).map(sw));
                    } else {
                        jac.extend(std::iter::repeat_n(0.0, m));
                    }
                }
                p += 1;
            }
        }
        let cov = covariance(&jac, rows, p, rss)?;
        let sd = |idx: Option<usize>| idx.map_or(0.0, |q| cov[q * p + q].max(0.0).sqrt());
        Some((
            k_idx.iter().map(|q| sd(*q)).collect(),
            a_idx.iter().map(|q| sd(*q)).collect(),
        ))
    }

    pub(super) fn finish(
        &self,
        raw: &RawFit,
        opts: &DecayFitOptions,
        candidates: Vec<Candidate>,
        mut flags: Vec<DecayFlag>,
        want_sds: bool,
    ) -> DecayFit {
        let nc = self.n_ch;
        let n = raw.theta.len();
        let mut order: Vec<usize> = (0..n).collect();
        order.sort_by(|&a, &b| raw.theta[b].total_cmp(&raw.theta[a]));
        let ks: Vec<f64> = order.iter().map(|&j| raw.theta[j].exp()).collect();
        // amplitudes back to t = 0: a(0) = a(τ=0) e^{k t0}
        let c_abs: Vec<Vec<f64>> = order
            .iter()
            .zip(&ks)
            .map(|(&j, k)| raw.c[j].iter().map(|v| v * (k * self.t0).exp()).collect())
            .collect();
        let shared = nc == 1 || opts.amplitudes == AmplitudeModel::SharedSpectrum;
        let (spectrum, a_abs): (Vec<f64>, Vec<f64>) = if shared {
            let smax = raw.s.iter().cloned().fold(0.0_f64, f64::max);
            let smax = if smax > 0.0 { smax } else { 1.0 };
            (
                raw.s.iter().map(|v| v / smax).collect(),
                order
                    .iter()
                    .zip(&ks)
                    .map(|(&j, k)| raw.a[j] * smax * (k * self.t0).exp())
                    .collect(),
            )
        } else {
            let mut tot = vec![0.0; nc];
            for cj in &c_abs {
                for (t, v) in tot.iter_mut().zip(cj) {
                    *t += v;
                }
            }
            let mx = tot.iter().cloned().fold(0.0_f64, f64::max);
            let mx = if mx > 0.0 { mx } else { 1.0 };
            (
                tot.iter().map(|v| v / mx).collect(),
                c_abs
                    .iter()
                    .map(|v| v.iter().cloned().fold(0.0_f64, f64::max))
                    .collect(),
            )
        };
        let sds = want_sds
            .then(|| self.uncertainties(&ks, &c_abs, &a_abs, &spectrum, opts, raw.rss))
            .flatten();
        if want_sds && sds.is_none() {
            flags.push(DecayFlag::SingularCovariance);
        }
        let span = self.curve.t_s[self.m - 1] - self.curve.t_s[0];
        let mut states = Vec::with_capacity(n);
        for j in 0..n {
            let k_sigma = sds.as_ref().map(|(k, _)| k[j]);
            let a_sigma = sds.as_ref().and_then(|(_, a)| (shared).then_some(a[j]));
            if let Some(sk) = k_sigma {
                if sk > 0.5 * ks[j] {
                    flags.push(DecayFlag::RatePoorlyDetermined {
                        k_per_s: ks[j],
                        sigma_per_s: sk,
                    });
                }
            }
            if ks[j] * span < 0.05 {
                flags.push(DecayFlag::QuasiConstantState { k_per_s: ks[j] });
            }
            states.push(DecayState {
                k_per_s: ks[j],
                k_sigma_per_s: k_sigma,
                amplitude: a_abs[j],
                amplitude_sigma: a_sigma,
                channel_amplitudes: c_abs[j].clone(),
            });
        }
        if !raw.termination.converged() {
            flags.push(DecayFlag::NotConverged {
                termination: raw.termination,
            });
        }
        // unweighted RMS in input units
        let mut fit = DecayFit {
            states,
            spectrum,
            background: opts.background.then(|| raw.background.clone()),
            rss: raw.rss,
            rms: 0.0,
            n_obs: self.m * nc,
            n_params: self.n_params(raw, opts),
            candidates,
            screened: None,
            flags,
            termination: raw.termination,
            amplitudes: opts.amplitudes,
        };
        let ex = self.abs_exp_table(&ks);
        let mut ss = 0.0;
        for c in 0..nc {
            let b = fit.background.as_ref().map_or(0.0, |b| b[c]);
            for (i, y) in self.curve.channels[c].iter().enumerate() {
                let p: f64 = fit
                    .states
                    .iter()
                    .enumerate()
                    .map(|(j, s)| s.channel_amplitudes[c] * ex[j * self.m + i])
                    .sum();
                let r = y - p - b;
                ss += r * r;
            }
        }
        fit.rms = (ss / fit.n_obs as f64).sqrt();
        fit
    }
}
