//! Parametric (Gaussian / super-Gaussian) bands: the window-averaged shape and its
//! variable-projection fit on [`fit::lm`](crate::fit::lm).

#![allow(clippy::needless_range_loop)]

use super::*;

/// The window-averaged super-Gaussian passband, peak 1, at `x` (nm).
pub(super) struct Shape<'a> {
    centres: &'a [f64],
}

impl Shape<'_> {
    fn eval(&self, l: f64, delta: f64, w: f64, e: f64) -> f64 {
        let s: f64 = self
            .centres
            .iter()
            .map(|&c| {
                let z = (2.0 * (l - c - delta) / w).abs();
                let a = std::f64::consts::LN_2 * z.powf(2.0 * e);
                if a > 40.0 {
                    0.0
                } else {
                    (-a).exp()
                }
            })
            .sum();
        s / self.centres.len() as f64
    }
}

pub(super) struct ParamFit<'a> {
    shape: Shape<'a>,
    quad: &'a [f64],
    design: &'a Design,
    yw: Vec<f64>,
    sigma: &'a [f64],
    fit_exponent: bool,
}

impl ParamFit<'_> {
    fn full(&self, th: &[f64]) -> (f64, f64, f64) {
        let e = if self.fit_exponent { th[2] } else { 1.0 };
        (th[0], th[1], e)
    }

    /// Weighted model for unit peak.
    fn unit(&self, th: &[f64]) -> Vec<f64> {
        let (d, w, e) = self.full(th);
        let t: Vec<f64> = self
            .quad
            .iter()
            .map(|&l| self.shape.eval(l, d, w, e))
            .collect();
        let nq = self.design.nq;
        (0..self.design.rows)
            .map(|r| {
                let row = &self.design.b[r * nq..(r + 1) * nq];
                row.iter().zip(&t).map(|(a, b)| a * b).sum::<f64>() / self.sigma[r]
            })
            .collect()
    }

    /// Projected residual and the peak.
    fn residual(&self, th: &[f64]) -> (Vec<f64>, f64) {
        let u = self.unit(th);
        let uu: f64 = u.iter().map(|v| v * v).sum();
        let uy: f64 = u.iter().zip(&self.yw).map(|(a, b)| a * b).sum();
        let peak = if uu > 0.0 { (uy / uu).max(0.0) } else { 0.0 };
        (
            self.yw.iter().zip(&u).map(|(y, v)| y - peak * v).collect(),
            peak,
        )
    }

    fn rss(&self, th: &[f64]) -> f64 {
        self.residual(th).0.iter().map(|r| r * r).sum()
    }
}

/// Bounds of the parametric fit (a prior): centre within ± half the calibration's FWHM of the
/// calibrated centre, FWHM within 0.5–2 times the calibration's, exponent 0.3–10.
pub(super) fn theta_bounds(np: usize, w0: f64) -> (Vec<f64>, Vec<f64>) {
    let (mut lo, mut hi) = (vec![-0.5 * w0, 0.5 * w0], vec![0.5 * w0, 2.0 * w0]);
    if np > 2 {
        lo.push(0.3);
        hi.push(10.0);
    }
    (lo, hi)
}

pub(super) fn fd_steps(th: &[f64]) -> Vec<f64> {
    th.iter().map(|v| 1e-5 * v.abs().max(1.0)).collect()
}

/// The projected residual (peak solved in closed form) as a problem for
/// [`fit::lm`](crate::fit::lm), with central differences at the steps of [`fd_steps`].
impl Residuals for ParamFit<'_> {
    fn n_residuals(&self) -> usize {
        self.yw.len()
    }
    fn n_params(&self) -> usize {
        if self.fit_exponent {
            3
        } else {
            2
        }
    }
    fn residuals(&self, th: &[f64], out: &mut [f64]) -> bool {
        out.copy_from_slice(&self.residual(th).0);
        true
    }
    fn jacobian(&self, th: &[f64], jac: &mut [f64]) -> bool {
        let m = self.yw.len();
        let h = fd_steps(th);
        for k in 0..th.len() {
            let mut tp = th.to_vec();
            let mut tm = th.to_vec();
            tp[k] += h[k];
            tm[k] -= h[k];
            let (rp, _) = self.residual(&tp);
            let (rm, _) = self.residual(&tm);
            for i in 0..m {
                jac[k * m + i] = (rp[i] - rm[i]) / (2.0 * h[k]);
            }
        }
        true
    }
}

/// Levenberg–Marquardt ([`fit::lm`](crate::fit::lm)) within the bounds of [`theta_bounds`];
/// returns θ and whether it converged.
pub(super) fn fit_band_shape(f: &ParamFit, th: Vec<f64>, w0: f64) -> (Vec<f64>, bool) {
    let (lo, hi) = theta_bounds(th.len(), w0);
    let rep = levenberg_marquardt(f, &th, &LmOptions::default().with_bounds(lo, hi));
    (rep.theta, rep.termination.converged())
}

#[allow(clippy::too_many_arguments)]
pub(super) fn parametric_band(
    geometry: &LvfGeometry,
    j: usize,
    grid: &[f64],
    problem: &TransmissionProblem,
    design: &Design,
    y: &[f64],
    sigma: &[f64],
    super_gaussian: bool,
) -> Result<(BandTransmission, bool, bool)> {
    let b = &geometry.bands[j];
    let win = geometry.window(j);
    let centres: Vec<f64> = win.iter().map(|&p| geometry.wavelength_at(p)).collect();
    let c_mean = centres.iter().sum::<f64>() / centres.len() as f64;
    let w0 = geometry.fwhm_nm;
    let f = ParamFit {
        shape: Shape { centres: &centres },
        quad: &problem.quad_nm,
        design,
        yw: y.iter().zip(sigma).map(|(v, s)| v / s).collect(),
        sigma,
        fit_exponent: super_gaussian,
    };
    // Coarse start: centre shifts ± 0.4 FWHM, widths 0.6–1.6 × the calibration's.
    let mut best = (f64::INFINITY, vec![0.0, w0]);
    for di in -8..=8 {
        for wi in 0..6 {
            let th = vec![0.05 * w0 * di as f64, w0 * (0.6 + 0.2 * wi as f64)];
            let v = f.rss(&[th[0], th[1], 1.0][..if super_gaussian { 3 } else { 2 }]);
            if v < best.0 {
                best = (v, th);
            }
        }
    }
    let mut start = best.1.clone();
    if super_gaussian {
        start.push(1.0);
    }
    let (th, converged) = fit_band_shape(&f, start, w0);
    let at_bound = {
        let [lo_d, hi_d, lo_w, hi_w] = [-0.5 * w0, 0.5 * w0, 0.5 * w0, 2.0 * w0];
        th[0] <= lo_d + 1e-6
            || th[0] >= hi_d - 1e-6
            || th[1] <= lo_w + 1e-6
            || th[1] >= hi_w - 1e-6
            || (th.len() > 2 && (th[2] <= 0.3 + 1e-6 || th[2] >= 10.0 - 1e-6))
    };
    let (r, peak) = f.residual(&th);
    let m = r.len();
    let np = th.len();
    let rss: f64 = r.iter().map(|v| v * v).sum();
    // Covariance of (θ, peak) from the full Jacobian of the weighted model.
    let u = f.unit(&th);
    let h = fd_steps(&th);
    let mut jac = DMatrix::zeros(m, np + 1);
    for k in 0..np {
        let mut tp = th.clone();
        let mut tm = th.clone();
        tp[k] += h[k];
        tm[k] -= h[k];
        let up = f.unit(&tp);
        let um = f.unit(&tm);
        for i in 0..m {
            jac[(i, k)] = peak * (up[i] - um[i]) / (2.0 * h[k]);
        }
    }
    for i in 0..m {
        jac[(i, np)] = u[i];
    }
    let s2 = rss / (m as f64 - (np + 1) as f64).max(1.0);
    let cov = stats::covariance_scaled(jac.as_slice(), m, np + 1, s2)
        .map(|c| DMatrix::from_column_slice(np + 1, np + 1, &c))
        .unwrap_or_else(|| DMatrix::from_element(np + 1, np + 1, f64::NAN));
    let sd = |k: usize| {
        let v = cov[(k, k)];
        (v >= 0.0 && v.is_finite()).then(|| v.sqrt().abs())
    };
    let (d, w, e) = f.full(&th);
    let band_on = |d: f64, w: f64, e: f64, pk: f64, x: &[f64]| -> Vec<f64> {
        x.iter().map(|&l| pk * f.shape.eval(l, d, w, e)).collect()
    };
    // Effective width on a fine grid and its sensitivity to (w, e).
    let span = 4.0 * w * 1.0f64.max(1.0 / e)
        + centres
            .iter()
            .map(|c| (c - c_mean).abs())
            .fold(0.0, f64::max);
    let fine = uniform_grid(
        c_mean + d - span,
        c_mean + d + span,
        FINE_STEP_NM.min(w / 100.0),
    )?;
    let eff = |w: f64, e: f64| {
        half_max_width(&fine, &band_on(d, w, e, 1.0, &fine))
            .map(|v| v.0)
            .unwrap_or(f64::NAN)
    };
    let eff_w = eff(w, e);
    let mut geff = vec![0.0; np + 1];
    geff[1] = (eff(w + 10.0 * h[1], e) - eff(w - 10.0 * h[1], e)) / (20.0 * h[1]);
    if super_gaussian {
        geff[2] = (eff(w, e + 10.0 * h[2]) - eff(w, e - 10.0 * h[2])) / (20.0 * h[2]);
    }
    let quad_form = |g: &[f64]| -> Option<f64> {
        let mut v = 0.0;
        for a in 0..g.len() {
            for b in 0..g.len() {
                v += g[a] * cov[(a, b)] * g[b];
            }
        }
        (v >= 0.0 && v.is_finite()).then(|| v.sqrt().abs())
    };
    let eff_sigma = quad_form(&geff);
    // Transmission on the grid and its std by the delta method.
    let t = band_on(d, w, e, peak, grid);
    let std: Vec<f64> = grid
        .iter()
        .map(|&l| {
            let mut g = vec![0.0; np + 1];
            for k in 0..np {
                let mut tp = th.clone();
                let mut tm = th.clone();
                tp[k] += h[k];
                tm[k] -= h[k];
                let (dp, wp, ep) = f.full(&tp);
                let (dm, wm, em) = f.full(&tm);
                g[k] = peak * (f.shape.eval(l, dp, wp, ep) - f.shape.eval(l, dm, wm, em))
                    / (2.0 * h[k]);
            }
            g[np] = f.shape.eval(l, d, w, e);
            quad_form(&g).unwrap_or(0.0)
        })
        .collect();
    let raw: Vec<f64> = r.iter().zip(sigma).map(|(v, s)| v * s).collect();
    let rms = (raw.iter().map(|v| v * v).sum::<f64>() / m as f64).sqrt();
    Ok((
        BandTransmission {
            nm: b.nm,
            px: b.px,
            width_px: b.width_px,
            centre_nm: c_mean + d,
            centre_sigma_nm: sd(0),
            fwhm_nm: w,
            fwhm_sigma_nm: sd(1),
            effective_fwhm_nm: finite_or(eff_w, w),
            effective_fwhm_sigma_nm: eff_sigma,
            peak,
            peak_sigma: sd(np),
            exponent: Some(e),
            exponent_sigma: if super_gaussian { sd(2) } else { None },
            transmission: t,
            std,
            rms_residual: Some(rms),
            lambda: None,
            condition_number: Some(condition_number(jac.as_slice(), m, np + 1)),
            support_nm: None,
            n_clamped: None,
        },
        converged,
        at_bound,
    ))
}
