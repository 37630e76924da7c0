//! Unlisted lamp lines fitted jointly with the map: a free-position, free-power line per blob.
//!
//! A strong line missing from the lamp list is a blob the listed lines can explain only by moving
//! the map, the FWHM and the continuum, so the fit with the list alone is already biased when its
//! residual is searched ([`crate::lvf::extra_lines`] finds the blobs). Tying the new line's
//! wavelength to that biased map and refining it by ±FWHM/2 with the map held (what this module
//! replaced) put the 490 nm test line at 530 nm. Here each candidate's wavelength λₓ is a
//! nonlinear parameter next to the map, FWHM and fall-off, θ' = (θ, λₓ₁ … λₓₖ), and the whole
//! projected problem is refined by Levenberg–Marquardt ([`crate::fit::lm`]) — the amplitudes of
//! every line, λₓ's included, stay linear and ≥ 0 (NNLS) — from several starts spread over
//! ±[`START_SPREAD_FWHM`] FWHM around the blob, with λₓ bounded to ±[`REACH_FWHM`] FWHM, so the
//! map and the new line find their joint optimum instead of the new line fitting the old map's
//! error. A candidate is kept when the BIC, λₓ counted as one more parameter, falls by at least
//! [`crate::lvf::extra_lines::MIN_BIC_GAIN`]; earlier lines stay free while the next is searched.
//!
//! The residual is searched in the fit whose continuum is coarsest (the caller's choice), so a
//! blob as narrow as a line is not taken up by a fine continuum element before it is seen.
//!
//! A candidate whose λₓ ends within [`BLEND_FWHM`] FWHM of a listed line cannot be told apart
//! from that line's blob (their amplitudes trade freely): it is not kept as a line, and the
//! caller warns and widens σ by the map's change between the two fits ([`Blended`]).

use nalgebra::DMatrix;
use rayon::prelude::*;

use crate::fit::{levenberg_marquardt, LmOptions, Residuals};
use crate::lvf::background::falloff;
use crate::lvf::extra_lines as xl;
use crate::lvf::fit::{profile_noise, Eval, Fitted, Problem};

/// Starts of λₓ at the blob's wavelength and ± this many FWHM (in steps of half of it).
pub const START_SPREAD_FWHM: f64 = 1.0;
/// λₓ is bounded to the blob's wavelength ± this many FWHM.
pub const REACH_FWHM: f64 = 2.0;
/// A fitted unlisted line closer than this many FWHM to a listed line is not separable from it.
pub const BLEND_FWHM: f64 = 0.5;

/// An unlisted line kept by [`search`].
#[derive(Debug, Clone)]
pub(crate) struct Found {
    /// Fitted wavelength (nm).
    pub nm: f64,
    /// The blob that suggested it.
    pub blob: xl::Blob,
}

/// A candidate that converged onto a listed line: not separable.
#[derive(Debug, Clone)]
pub(crate) struct Blended {
    /// Where it converged (nm).
    pub nm: f64,
    /// The listed line it merged with (nm).
    pub listed_nm: f64,
    /// The blob that suggested it.
    pub blob: xl::Blob,
    /// θ of the fit with it (layout of the searched problem).
    pub theta: Vec<f64>,
}

/// What [`search`] found: kept lines (with θ of the last fit, in the layout of the searched
/// problem) and candidates that could not be separated from a listed line.
pub(crate) struct Search {
    pub found: Vec<Found>,
    pub theta: Vec<f64>,
    pub blended: Vec<Blended>,
}

/// The projected problem with free line wavelengths appended to θ.
struct FreeLines<'p, 'a> {
    problem: &'p Problem<'a>,
    /// Lines with fixed wavelengths (the problem's own).
    fixed: Vec<f64>,
    /// Number of nonlinear parameters of `problem`.
    p: usize,
    /// Number of free wavelengths.
    k: usize,
}

impl FreeLines<'_, '_> {
    fn lines(&self, theta: &[f64]) -> Vec<f64> {
        let mut l = self.fixed.clone();
        l.extend_from_slice(&theta[self.p..]);
        l
    }

    fn eval(&self, theta: &[f64]) -> Eval {
        self.problem.eval_with(&theta[..self.p], &self.lines(theta))
    }

    fn step(&self, j: usize, theta: &[f64]) -> f64 {
        let n_map = self.problem.n_map();
        if j < n_map {
            1e-4 * theta[j].abs().max(1.0)
        } else if j == n_map {
            1e-5 * theta[j].abs().max(1.0)
        } else if j < self.p {
            1e-5
        } else {
            1e-3
        }
    }
}

impl Residuals for FreeLines<'_, '_> {
    fn n_residuals(&self) -> usize {
        3 * self.problem.n_samples()
    }
    fn n_params(&self) -> usize {
        self.p + self.k
    }
    fn residuals(&self, theta: &[f64], out: &mut [f64]) -> bool {
        if !self.problem.valid(&theta[..self.p]) || theta.iter().any(|v| !v.is_finite()) {
            return false;
        }
        out.copy_from_slice(&self.eval(theta).residual);
        true
    }
    fn jacobian(&self, theta: &[f64], jac: &mut [f64]) -> bool {
        let cols = crate::lvf::fit::central_difference_columns(
            theta,
            |j| self.step(j, theta),
            |t| self.eval(t).residual,
        );
        let m = cols[0].len();
        for (j, c) in cols.iter().enumerate() {
            jac[j * m..(j + 1) * m].copy_from_slice(c);
        }
        true
    }
}

/// A joint fit of θ and free wavelengths.
pub(crate) struct Joint {
    /// θ in the layout of the problem.
    pub theta: Vec<f64>,
    /// The free wavelengths (nm).
    pub free_nm: Vec<f64>,
    /// Evaluation with all lines.
    pub eval: Eval,
    /// Jacobian over θ and the free wavelengths (m × (p + k)).
    pub jac: DMatrix<f64>,
    /// LM iterations.
    pub iterations: usize,
}

/// Refines θ and the free wavelengths `free0` (each bounded to `bounds`) jointly on `problem`
/// (whose own lines stay fixed).
pub(crate) fn refine(
    problem: &Problem,
    theta0: &[f64],
    free0: &[f64],
    bounds: &[(f64, f64)],
) -> Joint {
    let p = theta0.len();
    let k = free0.len();
    let fl = FreeLines {
        problem,
        fixed: problem.lines().to_vec(),
        p,
        k,
    };
    let mut start = theta0.to_vec();
    start.extend_from_slice(free0);
    let mut lower = vec![f64::NEG_INFINITY; p];
    let mut upper = vec![f64::INFINITY; p];
    lower.extend(bounds.iter().map(|b| b.0));
    upper.extend(bounds.iter().map(|b| b.1));
    let opts = LmOptions {
        covariance: true,
        ..LmOptions::default()
    }
    .with_bounds(lower, upper);
    let rep = levenberg_marquardt(&fl, &start, &opts);
    let eval = fl.eval(&rep.theta);
    let m = eval.residual.len();
    let jac = match rep.jacobian {
        Some(j) => DMatrix::from_column_slice(m, p + k, &j),
        None => {
            let mut j = vec![0.0; m * (p + k)];
            fl.jacobian(&rep.theta, &mut j);
            DMatrix::from_column_slice(m, p + k, &j)
        }
    };
    Joint {
        theta: rep.theta[..p].to_vec(),
        free_nm: rep.theta[p..].to_vec(),
        eval,
        jac,
        iterations: rep.iterations,
    }
}

/// BIC of a joint fit: N·ln(SSE/N) + (p + k + active linear)·ln N.
fn bic(problem: &Problem, j: &Joint) -> f64 {
    let n = (3 * problem.n_samples()) as f64;
    let k = (j.theta.len() + j.free_nm.len() + j.eval.n_active) as f64;
    n * (j.eval.sse.max(1e-300) / n).ln() + k * n.ln()
}

/// Searches the residual of `fit` (a fit of `problem`, the lamp list alone) for unlisted lines
/// and fits each with a free wavelength jointly with the map (see the module docs).
pub(crate) fn search(problem: &Problem, fit: &Fitted) -> Search {
    let n = problem.n_samples();
    let y = problem.data();
    // the matched filter works in image units; the SSE is of the weighted residual
    let noise: [f64; 3] = std::array::from_fn(|c| profile_noise(y[c]));
    let noise_w: [f64; 3] = std::array::from_fn(|c| profile_noise(&problem.whitened(c)));
    let noise_rms = (noise_w.iter().map(|s| s * s).sum::<f64>() / 3.0).sqrt();
    let peak = (0..3)
        .flat_map(|c| y[c].iter().copied())
        .fold(f64::MIN, f64::max)
        .max(1e-300);
    let listed: Vec<f64> = problem.lines().to_vec();
    let mut found: Vec<Found> = Vec::new();
    let mut blended: Vec<Blended> = Vec::new();
    let mut theta = fit.theta.clone();
    let mut eval_res = fit.eval.residual.clone();
    let mut sse = fit.eval.sse;
    let mut bic_cur = problem.bic(fit);
    while found.len() < xl::MAX_EXTRA {
        let over = (sse / (3 * n) as f64).sqrt() / noise_rms.max(1e-12 * peak);
        if over <= xl::SEARCH_OVER_NOISE {
            break;
        }
        let u = problem.u();
        let lams: Vec<f64> = u.iter().map(|&u| problem.lambda(&theta, u)).collect();
        let fwhm = problem.fwhm(&theta);
        let v = problem.falloff_coefficients(&theta);
        let vfix = problem.vfix();
        let scale: Vec<f64> = (0..n)
            .map(|i| falloff(v, u[i]) * vfix.get(i).copied().unwrap_or(1.0))
            .collect();
        let g = |d: f64| problem.passband().eval(d, fwhm);
        let score = xl::matched_filter(
            &lams,
            &scale,
            &problem.unweighted(&eval_res),
            &g,
            2.0 * fwhm,
            noise,
            peak,
        );
        let mut skip: Vec<f64> = listed.clone();
        skip.extend(found.iter().map(|f| f.nm));
        skip.extend(blended.iter().map(|b| b.nm));
        let candidates = xl::blobs(&score, &lams, fwhm, &skip);
        if candidates.is_empty() {
            break;
        }
        let (lo, hi) = (
            lams.iter().cloned().fold(f64::INFINITY, f64::min),
            lams.iter().cloned().fold(f64::NEG_INFINITY, f64::max),
        );
        let prev: Vec<f64> = found.iter().map(|f| f.nm).collect();
        let mut best: Option<(Joint, f64, xl::Blob)> = None;
        let mut new_blended: Vec<Blended> = Vec::new();
        for b in candidates {
            let reach = REACH_FWHM * fwhm;
            let bound = ((b.nm - reach).max(lo), (b.nm + reach).min(hi));
            let n_starts = (2.0 * START_SPREAD_FWHM / 0.5).round() as i32;
            let starts: Vec<f64> = (0..=n_starts)
                .map(|s| b.nm + (s as f64 * 0.5 - START_SPREAD_FWHM) * fwhm)
                .filter(|l| *l > bound.0 && *l < bound.1)
                .collect();
            let fits: Vec<Joint> = starts
                .par_iter()
                .map(|&l0| {
                    let mut free0 = prev.clone();
                    free0.push(l0);
                    let mut bounds: Vec<(f64, f64)> = prev
                        .iter()
                        .map(|&l| (l - 0.5 * fwhm, l + 0.5 * fwhm))
                        .collect();
                    bounds.push(bound);
                    refine(problem, &theta, &free0, &bounds)
                })
                .collect();
            let Some(j) = fits
                .into_iter()
                .min_by(|a, b| a.eval.sse.total_cmp(&b.eval.sse))
            else {
                continue;
            };
            let lx = j.free_nm[j.free_nm.len() - 1];
            let b2 = bic(problem, &j);
            if b2 >= bic_cur - xl::MIN_BIC_GAIN {
                continue;
            }
            let fwhm_j = problem.fwhm(&j.theta);
            if let Some(&l) = listed
                .iter()
                .find(|&&l| (l - lx).abs() < BLEND_FWHM * fwhm_j)
            {
                new_blended.push(Blended {
                    nm: lx,
                    listed_nm: l,
                    blob: b,
                    theta: j.theta.clone(),
                });
                continue;
            }
            if best.as_ref().is_none_or(|x| b2 < x.1) {
                best = Some((j, b2, b));
            }
        }
        let Some((j, b2, blob)) = best else {
            blended.extend(new_blended);
            break;
        };
        for (f, nm) in found.iter_mut().zip(&j.free_nm) {
            f.nm = *nm;
        }
        found.push(Found {
            nm: j.free_nm[j.free_nm.len() - 1],
            blob,
        });
        theta = j.theta;
        eval_res = j.eval.residual;
        sse = j.eval.sse;
        bic_cur = b2;
    }
    Search {
        found,
        theta,
        blended,
    }
}

/// A listed line (with the lines blended with it) is displaced when freeing its wavelength
/// lowers the BIC by [`crate::lvf::extra_lines::MIN_BIC_GAIN`] (then the map's σ is widened by
/// how far freeing it moves the map); it is warned about when it also moves by more than this
/// many of its standard errors, more than [`DISPLACED_MIN_NM`], and moves the map at 400 or 700
/// nm by more than the map's σ before widening (under a continuum the model does not draw
/// exactly, as a CFL's, lines shift by a fraction of the map's σ without an unlisted line) …
pub const DISPLACED_SIGMA: f64 = 3.0;
/// … and by more than this (nm; below it the shift is within the 0.15 nm map bound
/// anyway and a continuum's misfit can explain it).
pub const DISPLACED_MIN_NM: f64 = 0.3;
/// At most this many line groups (the brightest) are checked.
pub const DISPLACED_MAX_GROUPS: usize = 6;

/// A listed line group that the other lines put elsewhere: an unlisted line blended with it
/// (closer than the passband can separate) or a wrong list entry.
#[derive(Debug, Clone)]
pub(crate) struct Displaced {
    /// The group's lines (nm) and their centroid, weighted by the fitted amplitudes.
    pub listed_nm: Vec<f64>,
    pub centroid_nm: f64,
    /// Where the group sits when its wavelength is free (nm) and its standard error.
    pub fitted_nm: f64,
    pub sigma_nm: f64,
    /// BIC of the fit as given minus that with the group free.
    pub delta_bic: f64,
    /// θ of the fit with the group free (layout of the checked problem).
    pub theta: Vec<f64>,
}

/// Frees, one at a time, the wavelength of each listed line group of the fit `theta` of
/// `problem` (its first `n_listed` lines; groups of lines closer than FWHM/2 move together,
/// as one line at their amplitude-weighted centroid) jointly with the map, and returns the
/// groups whose freeing lowers the BIC by [`crate::lvf::extra_lines::MIN_BIC_GAIN`] (see
/// [`Displaced`]; the caller applies [`DISPLACED_SIGMA`] and [`DISPLACED_MIN_NM`] for a warning). The check the blend of an unlisted
/// line with a listed one needs: such a blend is one blob whose centre is off the listed
/// wavelength, which the map absorbs when the listed line is bright (the weaker lines then sit
/// off instead), and which no residual search can separate.
pub(crate) fn displaced_groups(
    problem: &Problem,
    theta: &[f64],
    n_listed: usize,
) -> Vec<Displaced> {
    let fit_eval = problem.eval(theta);
    let n = problem.n_samples();
    let n_obs = 3 * n;
    let ln_n = (n_obs as f64).ln();
    let bic_of =
        |sse: f64, k: usize| n_obs as f64 * (sse.max(1e-300) / n_obs as f64).ln() + k as f64 * ln_n;
    let bic0 = bic_of(fit_eval.sse, theta.len() + fit_eval.n_active);
    let fwhm = problem.fwhm(theta);
    let lines = problem.lines().to_vec();
    let u = problem.u();
    let lams: Vec<f64> = u.iter().map(|&u| problem.lambda(theta, u)).collect();
    let lo = lams.iter().cloned().fold(f64::INFINITY, f64::min);
    let hi = lams.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    let amp = |i: usize| -> f64 {
        (0..3)
            .map(|c| fit_eval.alpha[c][crate::lvf::fit::N_BG + i])
            .sum::<f64>()
    };
    let listed: Vec<usize> = (0..n_listed.min(lines.len()))
        .filter(|&i| lines[i] > lo && lines[i] < hi)
        .collect();
    let in_nm: Vec<f64> = listed.iter().map(|&i| lines[i]).collect();
    let mut groups: Vec<(Vec<usize>, f64, f64)> = crate::lvf::fit::group_lines(&in_nm, 0.5 * fwhm)
        .into_iter()
        .filter_map(|g| {
            let idx: Vec<usize> = g.iter().map(|&k| listed[k]).collect();
            let a: f64 = idx.iter().map(|&i| amp(i)).sum();
            (a > 0.0).then(|| {
                let c = idx.iter().map(|&i| amp(i) * lines[i]).sum::<f64>() / a;
                (idx, c, a)
            })
        })
        .collect();
    // the map needs two other groups to stay determined
    if groups.len() < 3 {
        return Vec::new();
    }
    groups.sort_by(|a, b| b.2.total_cmp(&a.2));
    groups.truncate(DISPLACED_MAX_GROUPS);
    groups
        .par_iter()
        .filter_map(|(idx, c, _)| {
            let rest: Vec<f64> = (0..lines.len())
                .filter(|i| !idx.contains(i))
                .map(|i| lines[i])
                .collect();
            let pr = problem.with_lines(rest);
            let j = refine(&pr, theta, &[*c], &[(c - fwhm, c + fwhm)]);
            let k = j.theta.len() + 1 + j.eval.n_active;
            let delta_bic = bic0 - bic_of(j.eval.sse, k);
            let q = j.jac.ncols();
            let dof = n_obs.saturating_sub(k).max(1) as f64;
            let cov =
                crate::fit::stats::covariance_scaled(j.jac.as_slice(), n_obs, q, j.eval.sse / dof)?;
            let sigma = cov[(q - 1) * q + (q - 1)].max(0.0).sqrt();
            (delta_bic >= xl::MIN_BIC_GAIN).then(|| Displaced {
                listed_nm: idx.iter().map(|&i| lines[i]).collect(),
                centroid_nm: *c,
                fitted_nm: j.free_nm[0],
                sigma_nm: sigma,
                delta_bic,
                theta: j.theta,
            })
        })
        .collect()
}
