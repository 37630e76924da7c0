//! Whole-profile fit of an LVF lamp image by variable projection.
//!
//! Nonlinear parameters θ = (a0, a1[, a2], FWHM) with the map written in the normalised position
//! u = (px − px_mid)/half_length as λ(u) = a0 + a1·u [+ a2·u²] (well conditioned); linear
//! parameters per channel: background b + s·u and one amplitude ≥ 0 per line, solved by
//! Lawson–Hanson non-negative least squares on the normal equations for every θ. θ is refined by
//! the crate's Levenberg–Marquardt ([`fit::lm`](crate::fit::lm)) on the projected residual
//! (central-difference Jacobian), started from the
//! best few cells of a coarse grid over (a0, a1) at the guessed FWHM. The covariance of θ is
//! s²(JᵀJ)⁻¹ with s² = SSE/(N − p − k) (N samples over all channels, p nonlinear, k active
//! linear parameters) and is propagated to the coefficients in pixels.

use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::fit::stats;
use crate::fit::{levenberg_marquardt, LmOptions, Residuals};
use crate::lvf::calibration::{
    LineReport, LvfCalibration, MapKind, MapModel, MapSelection, ProfileCurves,
};
use crate::lvf::lamp::Lamp;
use crate::lvf::profile::Profile;
use crate::math::minimize::brent_min;

/// Passband shape g(Δλ).
#[derive(Debug, Clone, PartialEq)]
pub enum Passband {
    /// Gaussian with the fitted FWHM.
    Gaussian,
    /// A measured shape (offset from the centre in nm, transmission), stretched to the fitted
    /// FWHM.
    Measured {
        /// Offsets (nm), increasing.
        offset_nm: Vec<f64>,
        /// Transmission, peak-normalised.
        transmission: Vec<f64>,
        /// FWHM of the measured shape (nm).
        fwhm_nm: f64,
    },
}

impl Passband {
    /// A measured passband from offsets (nm, strictly increasing, spanning 0) and transmission.
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] when the shape has no peak inside or no half-maximum crossing on
    /// each side.
    pub fn measured(offset_nm: Vec<f64>, transmission: Vec<f64>) -> Result<Self> {
        let max = transmission.iter().cloned().fold(f64::MIN, f64::max);
        if offset_nm.len() != transmission.len()
            || offset_nm.len() < 3
            || max.is_nan()
            || max <= 0.0
        {
            return Err(Error::invalid(
                "--passband",
                "expected at least 3 rows offset_nm,transmission with a positive peak",
            ));
        }
        let t: Vec<f64> = transmission.iter().map(|v| v / max).collect();
        let imax = t.iter().position(|&v| v == 1.0).unwrap_or(0);
        let cross = |range: Box<dyn Iterator<Item = usize>>| -> Option<f64> {
            let mut prev: Option<usize> = None;
            for i in range {
                if let Some(p) = prev {
                    if (t[p] - 0.5) * (t[i] - 0.5) <= 0.0 && t[p] != t[i] {
                        let f = (0.5 - t[p]) / (t[i] - t[p]);
                        return Some(offset_nm[p] + f * (offset_nm[i] - offset_nm[p]));
                    }
                }
                prev = Some(i);
            }
            None
        };
        let left = cross(Box::new((0..=imax).rev()));
        let right = cross(Box::new(imax..t.len()));
        match (left, right) {
            (Some(l), Some(r)) if r > l => Ok(Passband::Measured {
                offset_nm,
                transmission: t,
                fwhm_nm: r - l,
            }),
            _ => Err(Error::invalid(
                "--passband",
                "the measured shape does not fall below half maximum on both sides of its peak",
            )),
        }
    }

    /// g(Δλ) for a passband of full width at half maximum `fwhm`.
    #[inline]
    pub fn eval(&self, delta_nm: f64, fwhm: f64) -> f64 {
        match self {
            Passband::Gaussian => {
                let s = fwhm / (8.0 * std::f64::consts::LN_2).sqrt();
                let z = delta_nm / s;
                if z.abs() > 8.0 {
                    0.0
                } else {
                    (-0.5 * z * z).exp()
                }
            }
            Passband::Measured {
                offset_nm,
                transmission,
                fwhm_nm,
            } => {
                let d = delta_nm * fwhm_nm / fwhm;
                let n = offset_nm.len();
                if d <= offset_nm[0] || d >= offset_nm[n - 1] {
                    return 0.0;
                }
                let i = offset_nm.partition_point(|&o| o <= d).clamp(1, n - 1);
                let f = (d - offset_nm[i - 1]) / (offset_nm[i] - offset_nm[i - 1]);
                transmission[i - 1] + f * (transmission[i] - transmission[i - 1])
            }
        }
    }
}

/// Polynomial degree of the map requested.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MapChoice {
    /// Linear map.
    Linear,
    /// Quadratic map.
    Quadratic,
    /// Quadratic only if justified: F-test p < 0.001 against linear and |a2| > 3σ.
    Auto,
}

/// Which way wavelength runs along the axis.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Direction {
    /// From the camera channels: blue light's centroid lies on the short-wavelength side.
    Auto,
    /// λ increases with px.
    Increasing,
    /// λ decreases with px.
    Decreasing,
}

/// Options of the calibration.
#[derive(Debug, Clone, PartialEq)]
pub struct FitOptions {
    /// Map degree.
    pub map: MapChoice,
    /// Passband shape.
    pub passband: Passband,
    /// Starting FWHM (nm) for the coarse search.
    pub fwhm_guess_nm: f64,
    /// Direction of the wavelength gradient.
    pub direction: Direction,
    /// Number of bands from 400 to 700 nm.
    pub n_bands: usize,
}

impl Default for FitOptions {
    fn default() -> Self {
        Self {
            map: MapChoice::Linear,
            passband: Passband::Gaussian,
            fwhm_guess_nm: 25.0,
            direction: Direction::Auto,
            n_bands: 31,
        }
    }
}

/// Lawson–Hanson NNLS on normal equations G x = h, with the first `n_free` variables
/// unconstrained. Columns with zero norm stay at zero.
pub(crate) fn nnls_gram(g: &DMatrix<f64>, h: &DVector<f64>, n_free: usize) -> DVector<f64> {
    let k = h.len();
    let scale = (0..k).map(|i| g[(i, i)]).fold(0.0, f64::max).max(1e-300);
    let ridge = 1e-12 * scale;
    let solve = |passive: &[usize]| -> Option<DVector<f64>> {
        let m = passive.len();
        let mut a = DMatrix::zeros(m, m);
        let mut b = DVector::zeros(m);
        for (i, &pi) in passive.iter().enumerate() {
            b[i] = h[pi];
            for (j, &pj) in passive.iter().enumerate() {
                a[(i, j)] = g[(pi, pj)];
            }
            a[(i, i)] += ridge;
        }
        let z = a.cholesky()?.solve(&b);
        let mut full = DVector::zeros(k);
        for (i, &pi) in passive.iter().enumerate() {
            full[pi] = z[i];
        }
        Some(full)
    };
    let mut passive: Vec<usize> = (0..n_free.min(k)).filter(|&i| g[(i, i)] > 0.0).collect();
    let mut x = if passive.is_empty() {
        DVector::zeros(k)
    } else {
        solve(&passive).unwrap_or_else(|| DVector::zeros(k))
    };
    let tol = 1e-12 * scale.sqrt() * h.norm().max(1e-300);
    for _ in 0..3 * k + 10 {
        let w = h - g * &x;
        let cand = (n_free..k)
            .filter(|j| !passive.contains(j) && g[(*j, *j)] > 0.0)
            .max_by(|&a, &b| w[a].total_cmp(&w[b]));
        let Some(j) = cand.filter(|&j| w[j] > tol) else {
            break;
        };
        passive.push(j);
        let mut guard = 0;
        loop {
            guard += 1;
            let Some(z) = solve(&passive) else {
                passive.retain(|&p| p != j);
                return x;
            };
            let bad: Vec<usize> = passive
                .iter()
                .copied()
                .filter(|&p| p >= n_free && z[p] <= 0.0)
                .collect();
            if bad.is_empty() || guard > 3 * k + 10 {
                x = z;
                break;
            }
            let mut alpha = 1.0f64;
            for &p in &bad {
                let d = x[p] - z[p];
                if d > 0.0 {
                    alpha = alpha.min(x[p] / d);
                }
            }
            x = &x + (z - &x) * alpha;
            passive.retain(|&p| p < n_free || x[p] > 1e-15 * scale.sqrt());
            for i in 0..k {
                if !passive.contains(&i) {
                    x[i] = 0.0;
                }
            }
        }
    }
    x
}

/// The separable least-squares problem on one profile.
pub(crate) struct Problem<'a> {
    u: Vec<f64>,
    y: [&'a [f64]; 3],
    lines: Vec<f64>,
    passband: &'a Passband,
    px_mid: f64,
    half: f64,
}

/// Evaluation of θ: residuals (channel-major), linear coefficients per channel, SSE.
pub(crate) struct Eval {
    residual: Vec<f64>,
    alpha: [DVector<f64>; 3],
    sse: f64,
    n_active: usize,
}

const N_BG: usize = 2;

impl<'a> Problem<'a> {
    fn new(px: &[f64], y: [&'a [f64]; 3], lines: Vec<f64>, passband: &'a Passband) -> Self {
        let lo = px.iter().cloned().fold(f64::INFINITY, f64::min);
        let hi = px.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
        let px_mid = 0.5 * (lo + hi);
        let half = (0.5 * (hi - lo)).max(0.5);
        Self {
            u: px.iter().map(|p| (p - px_mid) / half).collect(),
            y,
            lines,
            passband,
            px_mid,
            half,
        }
    }

    fn lambda(theta: &[f64], u: f64) -> f64 {
        let mut l = theta[0] + theta[1] * u;
        if theta.len() == 4 {
            l += theta[2] * u * u;
        }
        l
    }

    fn fwhm(theta: &[f64]) -> f64 {
        theta[theta.len() - 1]
    }

    /// Design matrix for θ with the given line wavelengths.
    fn design(&self, theta: &[f64], lines: &[f64]) -> DMatrix<f64> {
        let n = self.u.len();
        let k = N_BG + lines.len();
        let fwhm = Self::fwhm(theta);
        let mut phi = DMatrix::zeros(n, k);
        for (i, &u) in self.u.iter().enumerate() {
            let lam = Self::lambda(theta, u);
            phi[(i, 0)] = 1.0;
            phi[(i, 1)] = u;
            for (j, &l) in lines.iter().enumerate() {
                phi[(i, N_BG + j)] = self.passband.eval(l - lam, fwhm);
            }
        }
        phi
    }

    fn eval_with(&self, theta: &[f64], lines: &[f64]) -> Eval {
        let phi = self.design(theta, lines);
        let g = phi.transpose() * &phi;
        let n = self.u.len();
        let mut residual = Vec::with_capacity(3 * n);
        let mut sse = 0.0;
        let mut n_active = 0;
        let alpha: [DVector<f64>; 3] = std::array::from_fn(|c| {
            let y = DVector::from_column_slice(self.y[c]);
            let h = phi.transpose() * &y;
            let a = nnls_gram(&g, &h, N_BG);
            n_active += a.iter().filter(|v| **v != 0.0).count();
            let r = y - &phi * &a;
            sse += r.norm_squared();
            residual.extend(r.iter());
            a
        });
        Eval {
            residual,
            alpha,
            sse,
            n_active,
        }
    }

    fn eval(&self, theta: &[f64]) -> Eval {
        self.eval_with(theta, &self.lines)
    }

    fn valid(theta: &[f64]) -> bool {
        let f = Self::fwhm(theta);
        theta.iter().all(|v| v.is_finite()) && f > 1.0 && f < 200.0 && theta[1].abs() > 1e-3
    }

    fn jacobian(&self, theta: &[f64]) -> DMatrix<f64> {
        let p = theta.len();
        let cols: Vec<Vec<f64>> = (0..p)
            .into_par_iter()
            .map(|j| {
                let h = 1e-4 * theta[j].abs().max(1.0) * if j == p - 1 { 0.1 } else { 1.0 };
                let mut tp = theta.to_vec();
                let mut tm = theta.to_vec();
                tp[j] += h;
                tm[j] -= h;
                let rp = self.eval(&tp).residual;
                let rm = self.eval(&tm).residual;
                rp.iter()
                    .zip(&rm)
                    .map(|(a, b)| (a - b) / (2.0 * h))
                    .collect()
            })
            .collect();
        let m = cols[0].len();
        DMatrix::from_fn(m, p, |i, j| cols[j][i])
    }

    /// Levenberg–Marquardt ([`fit::lm`](crate::fit::lm)) on the projected residual. Returns θ,
    /// its evaluation, the final Jacobian and the number of iterations.
    fn levenberg_marquardt(&self, theta0: &[f64]) -> (Vec<f64>, Eval, DMatrix<f64>, usize) {
        let p = theta0.len();
        let opts = LmOptions {
            covariance: true,
            ..LmOptions::default()
        };
        let rep = levenberg_marquardt(&Projected { problem: self, p }, theta0, &opts);
        let eval = self.eval(&rep.theta);
        let m = eval.residual.len();
        let jac = match rep.jacobian {
            Some(j) => DMatrix::from_column_slice(m, p, &j),
            None => self.jacobian(&rep.theta),
        };
        (rep.theta, eval, jac, rep.iterations)
    }
}

/// The projected problem of θ (p = 3 or 4 nonlinear parameters) for [`fit::lm`](crate::fit::lm):
/// residuals of all three channels with the linear coefficients solved by NNLS; θ outside
/// 1 < FWHM < 200 nm or with a vanishing slope is outside the domain. The Jacobian is the
/// problem's own central differences (one rayon task per column, steps scaled per parameter).
struct Projected<'p, 'a> {
    problem: &'p Problem<'a>,
    p: usize,
}

impl Residuals for Projected<'_, '_> {
    fn n_residuals(&self) -> usize {
        3 * self.problem.u.len()
    }
    fn n_params(&self) -> usize {
        self.p
    }
    fn residuals(&self, theta: &[f64], out: &mut [f64]) -> bool {
        if !Problem::valid(theta) {
            return false;
        }
        out.copy_from_slice(&self.problem.eval(theta).residual);
        true
    }
    fn jacobian(&self, theta: &[f64], jac: &mut [f64]) -> bool {
        jac.copy_from_slice(self.problem.jacobian(theta).as_slice());
        true
    }
}

/// λ increases with px? From the centroids of the blue and red channels' positive signal.
impl Direction {
    /// Whether wavelength increases with position: as given, or detected from the profile
    /// (`Auto`, see [`detect_direction`]).
    pub(crate) fn is_increasing(self, profile: &Profile) -> Result<bool> {
        match self {
            Direction::Auto => detect_direction(profile),
            Direction::Increasing => Ok(true),
            Direction::Decreasing => Ok(false),
        }
    }
}

pub(crate) fn detect_direction(profile: &Profile) -> Result<bool> {
    let centroid = |c: usize| {
        let v = &profile.values[c];
        let mut sorted = v.clone();
        sorted.sort_by(f64::total_cmp);
        let base = sorted[sorted.len() / 10];
        let (mut sw, mut swx) = (0.0, 0.0);
        for (x, y) in profile.px.iter().zip(v) {
            let w = (y - base).max(0.0);
            sw += w;
            swx += w * x;
        }
        (sw > 0.0).then(|| swx / sw)
    };
    let len = profile.px.last().unwrap_or(&0.0) - profile.px.first().unwrap_or(&0.0);
    match (centroid(2), centroid(0)) {
        (Some(b), Some(r)) if (r - b).abs() > 0.02 * len.abs() => Ok(r > b),
        _ => Err(Error::invalid(
            "--direction",
            format!(
                "{}: cannot tell from the colour channels which end of the filter is blue (the blue and red light are not separated); give --direction increasing|decreasing",
                profile.source
            ),
        )),
    }
}

/// Checks that the profile shows lines at all: the largest channel range must exceed 20 times
/// the point-to-point noise.
pub(crate) fn check_signal(profile: &Profile) -> Result<()> {
    let mut best = 0.0f64;
    for v in &profile.values {
        let mut s = v.clone();
        s.sort_by(f64::total_cmp);
        let range = s[s.len() - 1] - s[s.len() / 10];
        let diffs: Vec<f64> = v.windows(2).map(|w| (w[1] - w[0]).abs()).collect();
        let mut d = diffs.clone();
        d.sort_by(f64::total_cmp);
        let noise = d.get(d.len() / 2).copied().unwrap_or(0.0) / 0.954; // median |Δ| of white noise = 0.954 σ
        let ratio = if noise > 0.0 {
            range / noise
        } else if range > 0.0 {
            f64::INFINITY
        } else {
            0.0
        };
        best = best.max(ratio);
    }
    if best < 20.0 {
        return Err(Error::invalid(
            "lamp image",
            format!(
                "{}: no lamp lines in ROI {:?} (signal range is only {best:.1}× the noise); check the ROI, the exposure and that the lamp was on",
                profile.source, profile.roi
            ),
        ));
    }
    Ok(())
}

fn downsample(profile: &Profile, max_points: usize) -> (Vec<f64>, [Vec<f64>; 3]) {
    let n = profile.px.len();
    let bin = n.div_ceil(max_points).max(1);
    let mut px = Vec::new();
    let mut ys: [Vec<f64>; 3] = Default::default();
    for chunk in (0..n).collect::<Vec<_>>().chunks(bin) {
        let k = chunk.len() as f64;
        px.push(chunk.iter().map(|&i| profile.px[i]).sum::<f64>() / k);
        for (c, y) in ys.iter_mut().enumerate() {
            y.push(chunk.iter().map(|&i| profile.values[c][i]).sum::<f64>() / k);
        }
    }
    (px, ys)
}

/// Lines grouped when closer than `gap` nm (consecutive).
pub(crate) fn group_lines(lines: &[f64], gap: f64) -> Vec<Vec<usize>> {
    let mut groups: Vec<Vec<usize>> = Vec::new();
    for (i, &l) in lines.iter().enumerate() {
        match groups.last_mut() {
            Some(g) if l - lines[*g.last().unwrap_or(&i)] < gap => g.push(i),
            _ => groups.push(vec![i]),
        }
    }
    groups
}

/// Whole-profile calibration of an LVF lamp profile (see the module docs).
///
/// # Errors
/// [`Error::InvalidArgument`] when the profile shows no lines or the direction cannot be told;
/// [`Error::Numerical`] when no fit explains the profile.
pub fn calibrate_whole_profile(
    profile: &Profile,
    lamp: &Lamp,
    opts: &FitOptions,
) -> Result<LvfCalibration> {
    check_signal(profile)?;
    let increasing = opts.direction.is_increasing(profile)?;
    let sign = if increasing { 1.0 } else { -1.0 };
    let lines: Vec<f64> = lamp.lines.iter().map(|l| l.nm).collect();

    // Coarse grid on a downsampled profile.
    let (cpx, cys) = downsample(profile, 240);
    let coarse = Problem::new(
        &cpx,
        [&cys[0], &cys[1], &cys[2]],
        lines.clone(),
        &opts.passband,
    );
    let a0s: Vec<f64> = (0..=200).map(|i| 350.0 + 2.0 * i as f64).collect();
    let mut a1s = Vec::new();
    let mut a1 = 15.0;
    while a1 < 900.0 {
        a1s.push(a1);
        a1 *= 1.03;
    }
    let fwhm0 = opts.fwhm_guess_nm;
    let mut grid: Vec<(f64, f64, f64)> = a0s
        .par_iter()
        .flat_map_iter(|&a0| {
            let coarse = &coarse;
            a1s.iter().map(move |&a1| {
                let th = [a0, sign * a1, fwhm0];
                (coarse.eval(&th).sse, a0, a1)
            })
        })
        .collect();
    grid.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut starts: Vec<(f64, f64)> = Vec::new();
    for &(_, a0, a1) in &grid {
        if starts
            .iter()
            .all(|&(b0, b1)| (a0 - b0).abs() > 8.0 || (a1 / b1).ln().abs() > 0.08)
        {
            starts.push((a0, a1));
        }
        if starts.len() >= 6 {
            break;
        }
    }

    // Refine on the full profile.
    let full = Problem::new(
        &profile.px,
        [&profile.values[0], &profile.values[1], &profile.values[2]],
        lines.clone(),
        &opts.passband,
    );
    let mut best: Option<(Vec<f64>, Eval, DMatrix<f64>, usize)> = None;
    for &(a0, a1) in &starts {
        let fit = full.levenberg_marquardt(&[a0, sign * a1, fwhm0]);
        if best.as_ref().is_none_or(|b| fit.1.sse < b.1.sse) {
            best = Some(fit);
        }
    }
    let Some(linear) = best else {
        return Err(Error::Numerical {
            what: "LVF whole-profile fit".into(),
            reason: "no starting point".into(),
        });
    };
    let n_obs = 3 * profile.px.len();

    // Map degree.
    let (chosen, selection) = match opts.map {
        MapChoice::Linear => (
            linear,
            MapSelection {
                requested: "linear".into(),
                f_statistic: None,
                quadratic_t: None,
                reason: "linear map requested".into(),
            },
        ),
        MapChoice::Quadratic | MapChoice::Auto => {
            let t = &linear.0;
            let quad = full.levenberg_marquardt(&[t[0], t[1], 0.0, t[2]]);
            if opts.map == MapChoice::Quadratic {
                (
                    quad,
                    MapSelection {
                        requested: "quadratic".into(),
                        f_statistic: None,
                        quadratic_t: None,
                        reason: "quadratic map requested".into(),
                    },
                )
            } else {
                let dof2 = n_obs.saturating_sub(4 + quad.1.n_active).max(1) as f64;
                let f = (linear.1.sse - quad.1.sse) / (quad.1.sse / dof2).max(1e-300);
                let cov = covariance(&quad.2, quad.1.sse, dof2);
                let t_a2 = cov
                    .as_ref()
                    .map(|c| quad.0[2] / c[(2, 2)].max(1e-300).sqrt())
                    .unwrap_or(0.0);
                // F(1, ∞) at p = 0.001 is 10.83.
                if f > 10.83 && t_a2.abs() > 3.0 {
                    (
                        quad,
                        MapSelection {
                            requested: "auto".into(),
                            f_statistic: Some(f),
                            quadratic_t: Some(t_a2),
                            reason: "quadratic: F-test p < 0.001 and |a2| > 3σ".into(),
                        },
                    )
                } else {
                    (
                        linear,
                        MapSelection {
                            requested: "auto".into(),
                            f_statistic: Some(f),
                            quadratic_t: Some(t_a2),
                            reason: "linear: the quadratic term is not justified (needs F > 10.83 and |a2| > 3σ)".into(),
                        },
                    )
                }
            }
        }
    };
    let (theta, eval, jac, iterations) = chosen;
    let p = theta.len();
    let dof = n_obs.saturating_sub(p + eval.n_active).max(1) as f64;
    let cov_theta = covariance(&jac, eval.sse, dof).ok_or_else(|| Error::Numerical {
        what: "LVF whole-profile fit".into(),
        reason: format!(
            "{}: the map is not determined by the profile (singular Jacobian); does the ROI show at least two separated lamp lines?",
            profile.source
        ),
    })?;
    let fwhm = theta[p - 1];

    // Map in pixels: λ = Σ a_k ((px − m)/h)^k  →  Σ c_i px^i, c = T a.
    let (m, h) = (full.px_mid, full.half);
    let deg = p - 1; // number of map coefficients
    let mut t = DMatrix::zeros(deg, deg);
    t[(0, 0)] = 1.0;
    t[(0, 1)] = -m / h;
    t[(1, 1)] = 1.0 / h;
    if deg == 3 {
        t[(0, 2)] = m * m / (h * h);
        t[(1, 2)] = -2.0 * m / (h * h);
        t[(2, 2)] = 1.0 / (h * h);
    }
    let a = DVector::from_iterator(deg, theta[..deg].iter().copied());
    let c = &t * a;
    let cov_a = cov_theta.view((0, 0), (deg, deg)).into_owned();
    let cov_c = &t * cov_a * t.transpose();
    let map = MapModel {
        kind: if deg == 3 {
            MapKind::Quadratic
        } else {
            MapKind::Linear
        },
        coefficients: c.iter().copied().collect(),
        covariance: (0..deg)
            .map(|i| (0..deg).map(|j| cov_c[(i, j)]).collect())
            .collect(),
    };

    // Per-line residuals: shift each group of blended lines (closer than half the FWHM) alone.
    let lam_lo = full
        .u
        .iter()
        .map(|&u| Problem::lambda(&theta, u))
        .fold(f64::INFINITY, f64::min);
    let lam_hi = full
        .u
        .iter()
        .map(|&u| Problem::lambda(&theta, u))
        .fold(f64::NEG_INFINITY, f64::max);
    let in_range: Vec<usize> = (0..lines.len())
        .filter(|&i| lines[i] >= lam_lo - 0.5 * fwhm && lines[i] <= lam_hi + 0.5 * fwhm)
        .collect();
    let in_lines: Vec<f64> = in_range.iter().map(|&i| lines[i]).collect();
    // Lines closer than half the FWHM are not resolved: each such group is represented by one
    // line at its centroid weighted by the lamp's nominal relative powers (the fitted split of
    // amplitude between unresolved lines is arbitrary), and shifted as a whole.
    let groups = group_lines(&in_lines, 0.5 * fwhm);
    let centroids: Vec<f64> = groups
        .iter()
        .map(|g| {
            let w: Vec<f64> = g
                .iter()
                .map(|&k| lamp.lines[in_range[k]].relative_power.max(1e-12))
                .collect();
            let sw: f64 = w.iter().sum();
            g.iter()
                .zip(&w)
                .map(|(&k, wk)| in_lines[k] * wk)
                .sum::<f64>()
                / sw
        })
        .collect();
    let mut shifts = vec![0.0; in_lines.len()];
    let mut group_res = Vec::new();
    for (gi, g) in groups.iter().enumerate() {
        // A group with no amplitude in any channel is not observed.
        let amp: f64 = g
            .iter()
            .map(|&k| {
                (0..3)
                    .map(|c| eval.alpha[c][N_BG + in_range[k]])
                    .sum::<f64>()
            })
            .sum();
        if amp <= 0.0 {
            continue;
        }
        let cost = |d: f64| {
            let mut l = centroids.clone();
            l[gi] += d;
            full.eval_with(&theta, &l).sse
        };
        let d = brent_min(cost, -0.5 * fwhm, 0.5 * fwhm, 1e-4);
        for &k in g {
            shifts[k] = d;
        }
        group_res.push(d);
    }
    let rms = if group_res.is_empty() {
        0.0
    } else {
        (group_res.iter().map(|d| d * d).sum::<f64>() / group_res.len() as f64).sqrt()
    };
    let line_reports: Vec<LineReport> = in_range
        .iter()
        .enumerate()
        .map(|(k, &i)| LineReport {
            nm: lines[i],
            px: map.inverse(lines[i]).unwrap_or(f64::NAN),
            residual_nm: shifts[k],
            amplitude: std::array::from_fn(|c| eval.alpha[c][N_BG + i]),
        })
        .collect();

    let n = profile.px.len();
    let curves = ProfileCurves {
        px: profile.px.clone(),
        data: profile.values.clone(),
        model: std::array::from_fn(|c| {
            (0..n)
                .map(|i| profile.values[c][i] - eval.residual[c * n + i])
                .collect()
        }),
    };
    let mut cal = LvfCalibration {
        schema: crate::lvf::calibration::LVF_SCHEMA,
        method: "whole-profile".into(),
        source: profile.source.clone(),
        axis: profile.axis,
        roi: profile.roi,
        lamp: lamp.name.clone(),
        map,
        fwhm_nm: fwhm,
        fwhm_sigma_nm: cov_theta[(p - 1, p - 1)].max(0.0).sqrt(),
        rms_residual_nm: rms,
        sigma_nm_at_400: 0.0,
        sigma_nm_at_700: 0.0,
        lines: line_reports,
        bands: Vec::new(),
        map_selection: selection,
        wavelength_increases_with_px: increasing,
        diagnostics: serde_json::json!({
            "iterations": iterations,
            "profile_points": n,
            "profile_rms": (eval.sse / n_obs as f64).sqrt(),
            "coarse_starts": starts.len(),
            "active_linear_parameters": eval.n_active,
        }),
        curves,
    };
    cal.set_bands(opts.n_bands)?;
    Ok(cal)
}

/// s²(JᵀJ)⁻¹ with s² = SSE/dof ([`fit::stats`](crate::fit::stats), through the QR of J), or
/// None when J is rank deficient.
fn covariance(jac: &DMatrix<f64>, sse: f64, dof: f64) -> Option<DMatrix<f64>> {
    let (m, p) = jac.shape();
    let c = stats::covariance_scaled(jac.as_slice(), m, p, sse / dof)?;
    Some(DMatrix::from_column_slice(p, p, &c))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nnls_keeps_amplitudes_non_negative_and_backgrounds_free() {
        // y = -1 (background) + 2·col2; col3 would want a negative weight.
        let n = 20;
        let phi = DMatrix::from_fn(n, 3, |i, j| match j {
            0 => 1.0,
            1 => (i as f64 / 4.0).sin().abs(),
            _ => i as f64 / n as f64,
        });
        let y = DVector::from_fn(n, |i, _| -1.0 + 2.0 * phi[(i, 1)] - 0.5 * phi[(i, 2)]);
        let g = phi.transpose() * &phi;
        let h = phi.transpose() * &y;
        let x = nnls_gram(&g, &h, 1);
        assert!(x[0] < 0.0, "background stays free: {x}");
        assert!(x[1] > 0.0 && x[2] >= 0.0, "{x}");
        assert_eq!(x[2], 0.0);
    }

    #[test]
    fn gaussian_passband_is_half_at_half_the_fwhm() {
        let g = Passband::Gaussian;
        assert!((g.eval(12.5, 25.0) - 0.5).abs() < 1e-12);
        let m = Passband::measured(
            vec![-20.0, -10.0, 0.0, 10.0, 20.0],
            vec![0.0, 0.5, 1.0, 0.5, 0.0],
        )
        .unwrap();
        match &m {
            Passband::Measured { fwhm_nm, .. } => assert!((fwhm_nm - 20.0).abs() < 1e-12),
            _ => unreachable!(),
        }
        assert!((m.eval(20.0, 40.0) - 0.5).abs() < 1e-12);
    }
}
