//! A continuum shared by the three camera channels: one smooth spectrum seen through the passband
//! and a known camera.
//!
//! A broadband source under the lamp lines (the phosphor bands of a CFL, stray daylight, a
//! halogen's glow) has one spectrum S(λ) ≥ 0; behind the LVF, channel c records
//!
//! ```text
//! C_c(u) = V(u) · Σ_λ S(λ)·Q_c(λ)·g(λ − λ(u)) · Δλ,      S(λ) = Σ_k β_k·B_k(λ),  β_k ≥ 0
//! ```
//!
//! with Q_c the camera's spectral sensitivities (`lvf calibrate --camera DB:NAME`), g the
//! passband at the fitted FWHM, λ(u) the map being fitted and B_k a uniform cubic B-spline in
//! wavelength (non-negative coefficients → S ≥ 0 everywhere). The three channels share the K
//! coefficients β, against 3·(K+3) for three free per-channel splines
//! ([`crate::lvf::background`]): a channel cannot bend its continuum on its own to trade with a
//! line, and the continuum's colour at each wavelength is fixed by the camera, which a line's
//! blob (one wavelength) and a broad band (many) see differently. The camera curves must be
//! those of the image's channels (linear raw, no white balance): a channel gain or another
//! camera's curves make the shared spectrum fit worse, and at 1 % noise BIC then prefers the
//! per-channel continuum; at 5 % it cannot tell, and a wrong camera of the Jiang database moved
//! 700 nm by up to 1.35 nm with σ 0.3 (`scripts/bench/lvf_camera_choice.py`). The lamp lines'
//! colours now judge the curves first ([`crate::lvf::line_colour`]): curves that fail are not
//! used.
//!
//! Sums are on a 1 nm grid (the continuum is smooth; the passband is ≥ several nm wide).

use crate::error::{Error, Result};
use crate::lvf::background::cubic_bspline_row;
use crate::lvf::fit::Passband;
use crate::spectrum::MultiSpectrum;

/// Knot spacings of the shared spectrum tried, in units of the passband FWHM (wavelength). One
/// fine spacing, smoothed by a roughness penalty ([`SHARED_SMOOTHNESS`]) instead of chosen by
/// knot count: a spacing coarse enough to be stable bends a CFL's phosphor bands and moves the
/// map (0.75 × FWHM: −0.07 nm at 700 nm without noise), one fine enough to follow them lets noise
/// trade the continuum against the lines (0.5 × FWHM: ±0.45 nm at 1 % noise) — docs/performance.md,
/// issue 12, seventeenth session.
pub const SHARED_KNOT_FWHM: [f64; 1] = [0.35];

/// Prior roughness of the shared spectrum: its second differences at the knots are taken as
/// normal with standard deviation `smoothness` × the spectrum's RMS (from an unpenalised pilot on
/// knots 1.5 FWHM apart). With the residual variance s² of the weighted profile, the linear solve
/// adds (s²/τ²)·‖Dβ‖² to the SSE (τ = smoothness × RMS): the penalty grows with the noise. Each
/// value is a candidate; BIC (counting the effective parameters) and then the focused criterion
/// (against the roughest, the least biased) choose. 0.03 suits a CFL's phosphor bands through the
/// Jiang curves at 1 % and 5 % noise; 0.01 a flat continuum, and the CFL through Weta's curves to
/// 780 nm, where 0.03 leaves the map 0.45 nm off at 700 nm; 0.1 was tried as a third and taken
/// by BIC where the given curves are not the camera's (0.36 nm off) — docs/performance.md,
/// issue 12, seventeenth session.
pub const SHARED_SMOOTHNESS: [f64; 2] = [0.01, 0.03];

/// Fewest and most intervals of the shared spectrum's spline.
pub const SHARED_INTERVALS: (usize, usize) = (3, 40);

/// A camera's spectral sensitivities on a 1 nm grid, for the shared continuum.
#[derive(Debug, Clone, PartialEq)]
pub struct CameraResponse {
    /// Where the curves came from (file and camera name).
    pub source: String,
    /// First grid wavelength (nm); the grid is `first_nm + i`.
    pub first_nm: f64,
    /// Q_r, Q_g, Q_b at each grid wavelength (≥ 0, any common scale).
    pub q: Vec<[f64; 3]>,
}

impl CameraResponse {
    /// Resamples a three-channel camera table to 1 nm (linear interpolation, negative values
    /// clipped to 0).
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] when the table has not three channels or spans less than
    /// 50 nm.
    pub fn from_curves(curves: &MultiSpectrum, source: &str) -> Result<Self> {
        let wl = curves.wavelengths();
        if curves.n_channels() != 3 || wl.len() < 2 || wl[wl.len() - 1] - wl[0] < 50.0 {
            return Err(Error::invalid(
                "--camera",
                format!("{source}: expected three channels r,g,b spanning at least 50 nm"),
            ));
        }
        let first = wl[0].ceil();
        let last = wl[wl.len() - 1].floor();
        let n = (last - first) as usize + 1;
        let q = (0..n)
            .map(|i| {
                let nm = first + i as f64;
                std::array::from_fn(|c| {
                    let v = curves.channel(c);
                    let j = wl.partition_point(|&w| w <= nm).clamp(1, wl.len() - 1);
                    let f = (nm - wl[j - 1]) / (wl[j] - wl[j - 1]);
                    (v[j - 1] + f * (v[j] - v[j - 1])).max(0.0)
                })
            })
            .collect();
        Ok(Self {
            source: source.into(),
            first_nm: first,
            q,
        })
    }

    /// Last grid wavelength (nm).
    pub fn last_nm(&self) -> f64 {
        self.first_nm + self.q.len().saturating_sub(1) as f64
    }
}

/// The shared spectrum's basis on the camera's grid: for every grid wavelength λ_g in
/// [lo, hi], Q_c(λ_g)·B_k(λ_g) for the four non-zero B-splines.
#[derive(Debug, Clone)]
pub(crate) struct SharedBasis {
    /// Spline intervals on [lo, hi].
    pub intervals: usize,
    /// Spectrum range (nm).
    pub lo_nm: f64,
    /// See `lo_nm`.
    pub hi_nm: f64,
    /// Grid wavelengths (nm).
    grid: Vec<f64>,
    /// Index of the first of the four B-splines at each grid point.
    first_k: Vec<usize>,
    /// Q_c·B_{first_k + j} at each grid point: `[c][j]`.
    w: Vec<[[f64; 4]; 3]>,
    /// Weight λ of the roughness penalty λ‖Dβ‖² (D: second differences); 0: none.
    pub penalty: f64,
}

impl SharedBasis {
    /// The range [lo, hi] clipped to the camera table's (whole nm), or None when under 10 nm.
    /// (Clipping further to where the camera is sensitive was tried: the continuum left
    /// outside is then unmodelled and the map error at 700 nm grew.)
    pub fn range(cam: &CameraResponse, lo_nm: f64, hi_nm: f64) -> Option<(f64, f64)> {
        let lo = lo_nm.max(cam.first_nm).ceil();
        let hi = hi_nm.min(cam.last_nm()).floor();
        (hi - lo >= 10.0).then_some((lo, hi))
    }

    /// Intervals for knots at least `knot_nm` apart on [lo, hi], within [`SHARED_INTERVALS`].
    pub fn intervals_for(lo: f64, hi: f64, knot_nm: f64) -> usize {
        ((hi - lo) / knot_nm.max(1e-6))
            .floor()
            .clamp(SHARED_INTERVALS.0 as f64, SHARED_INTERVALS.1 as f64) as usize
    }

    /// The basis for a spectrum on [lo, hi] (from [`SharedBasis::range`]) with `intervals`
    /// spline intervals.
    pub fn new(cam: &CameraResponse, lo: f64, hi: f64, intervals: usize) -> Self {
        let nk = intervals + 3;
        let mut row = vec![0.0; nk];
        let (mut grid, mut first_k, mut w) = (Vec::new(), Vec::new(), Vec::new());
        let mut nm = lo;
        while nm <= hi {
            let gi = (nm - cam.first_nm).round() as usize;
            let q = cam.q[gi.min(cam.q.len() - 1)];
            let u = 2.0 * (nm - lo) / (hi - lo) - 1.0;
            cubic_bspline_row(u, intervals, &mut row);
            let k0 = row.iter().position(|v| *v > 0.0).unwrap_or(0).min(nk - 4);
            let ww: [[f64; 4]; 3] =
                std::array::from_fn(|c| std::array::from_fn(|j| q[c] * row[k0 + j]));
            grid.push(nm);
            first_k.push(k0);
            w.push(ww);
            nm += 1.0;
        }
        Self {
            intervals,
            lo_nm: lo,
            hi_nm: hi,
            grid,
            first_k,
            w,
            penalty: 0.0,
        }
    }

    /// The same basis with the roughness penalty λ‖Dβ‖² (see [`SHARED_SMOOTHNESS`]).
    pub fn with_penalty(mut self, penalty: f64) -> Self {
        self.penalty = if penalty.is_finite() {
            penalty.max(0.0)
        } else {
            0.0
        };
        self
    }

    /// RMS of the spectrum Σ β_k B_k over its range (1 nm grid).
    pub fn spectrum_rms(&self, beta: &[f64]) -> f64 {
        let n = self.grid.len().max(1) as f64;
        (self
            .grid
            .iter()
            .map(|&nm| self.spectrum(beta, nm).powi(2))
            .sum::<f64>()
            / n)
            .sqrt()
    }

    /// Number of coefficients β.
    pub fn n(&self) -> usize {
        self.intervals + 3
    }

    /// Φ_{k,c}(i) = Σ_g g(λ_g − λ_i)·Q_c(λ_g)·B_k(λ_g) for samples at wavelengths `lams`, each
    /// times `scale[i]` (the fall-off); layout `[c][i][k]` (3 × n × K).
    pub fn columns(&self, lams: &[f64], scale: &[f64], fwhm: f64, passband: &Passband) -> Vec<f64> {
        self.columns_of(3, lams, scale, fwhm, passband)
    }

    /// [`SharedBasis::columns`] for the first `channels` channels only (layout `[c][i][k]`,
    /// `channels` × n × K).
    pub fn columns_of(
        &self,
        channels: usize,
        lams: &[f64],
        scale: &[f64],
        fwhm: f64,
        passband: &Passband,
    ) -> Vec<f64> {
        match channels.min(3) {
            0 => Vec::new(),
            1 => self.columns_c::<1>(lams, scale, fwhm, passband),
            2 => self.columns_c::<2>(lams, scale, fwhm, passband),
            _ => self.columns_c::<3>(lams, scale, fwhm, passband),
        }
    }

    /// [`SharedBasis::columns_of`] for `C` channels: per sample, the passband on the grid in one
    /// uniform run, and the products summed in registers over each knot interval (where the
    /// four non-zero B-splines are the same) before they are added to the output.
    fn columns_c<const C: usize>(
        &self,
        lams: &[f64],
        scale: &[f64],
        fwhm: f64,
        passband: &Passband,
    ) -> Vec<f64> {
        let nk = self.n();
        let n = lams.len();
        let mut out = vec![0.0; C * n * nk];
        // 4 FWHM, or less where the passband is exactly 0 beyond (8σ for the Gaussian)
        let reach = (4.0 * fwhm).min(passband.support_nm(fwhm));
        // the grid is whole nm from lo (see `new`): g(λ_g − λ_i) on it is one uniform run
        let step = if self.grid.len() > 1 {
            self.grid[1] - self.grid[0]
        } else {
            1.0
        };
        let mut g = Vec::new();
        for (i, &li) in lams.iter().enumerate() {
            let a = self.grid.partition_point(|&g| g < li - reach);
            let b = self.grid.partition_point(|&g| g <= li + reach);
            if a >= b {
                continue;
            }
            let s = scale.get(i).copied().unwrap_or(1.0);
            g.resize(b - a, 0.0);
            passband.eval_uniform(self.grid[a] - li, step, fwhm, &mut g);
            let mut flush = |k0: usize, acc: &[[f64; 4]; C]| {
                for (c, ac) in acc.iter().enumerate() {
                    let base = (c * n + i) * nk + k0;
                    for (o, v) in out[base..base + 4].iter_mut().zip(ac) {
                        *o += s * v;
                    }
                }
            };
            let mut k_run = self.first_k[a];
            let mut acc = [[0.0; 4]; C];
            for (gi, &t) in (a..b).zip(&g) {
                let k0 = self.first_k[gi];
                if k0 != k_run {
                    flush(k_run, &acc);
                    acc = [[0.0; 4]; C];
                    k_run = k0;
                }
                let w = &self.w[gi];
                for (ac, wc) in acc.iter_mut().zip(w) {
                    for (a, wj) in ac.iter_mut().zip(wc) {
                        *a += t * wj;
                    }
                }
            }
            flush(k_run, &acc);
        }
        out
    }

    /// S(λ) = Σ β_k B_k(λ) (0 outside [lo, hi]).
    pub fn spectrum(&self, beta: &[f64], nm: f64) -> f64 {
        if nm < self.lo_nm || nm > self.hi_nm {
            return 0.0;
        }
        let mut row = vec![0.0; self.n()];
        let u = 2.0 * (nm - self.lo_nm) / (self.hi_nm - self.lo_nm) - 1.0;
        cubic_bspline_row(u, self.intervals, &mut row);
        row.iter().zip(beta).map(|(r, b)| r * b).sum()
    }
}

/// What the shared continuum found (in `lvf.json` under `background.shared_spectrum`).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct SharedSpectrumReport {
    /// The camera curves used.
    pub camera: String,
    /// Range of the spectrum (nm).
    pub range_nm: [f64; 2],
    /// Spline intervals on that range.
    pub intervals: usize,
    /// The B-spline coefficients β ≥ 0 (image units per nm per unit sensitivity).
    pub coefficients: Vec<f64>,
    /// S(λ) sampled every 5 nm: `[nm, value]`.
    pub spectrum: Vec<[f64; 2]>,
}

impl SharedBasis {
    /// The report of a fitted β.
    pub fn report(&self, camera: &str, beta: &[f64]) -> SharedSpectrumReport {
        let mut spectrum = Vec::new();
        let mut nm = (self.lo_nm / 5.0).ceil() * 5.0;
        while nm <= self.hi_nm {
            spectrum.push([nm, self.spectrum(beta, nm)]);
            nm += 5.0;
        }
        SharedSpectrumReport {
            camera: camera.into(),
            range_nm: [self.lo_nm, self.hi_nm],
            intervals: self.intervals,
            coefficients: beta.to_vec(),
            spectrum,
        }
    }
}

/// What [`solve_joint`] returns: per channel the coefficients of `phi`, the shared β, per
/// channel the continuum curve, and the effective number of linear parameters.
pub(crate) type JointSolution = ([nalgebra::DVector<f64>; 3], Vec<f64>, [Vec<f64>; 3], f64);

/// The joint linear solve of the three channels with a shared continuum: per channel the
/// columns of `phi` (the first `n_free` free in sign, the rest ≥ 0), shared the K columns
/// `cols` (`[c][i][k]`, ≥ 0). Returns per channel the coefficients of `phi`, the shared β, and
/// per channel the continuum curve Σ_k β_k Φ_{k,c}, and the effective number of linear
/// parameters. With `weights` (per channel and sample, or empty) every row of the least-squares
/// problem is multiplied by its weight; `penalty` λ adds λ‖Dβ‖² (second differences of β).
pub(crate) fn solve_joint(
    phi: &nalgebra::DMatrix<f64>,
    y: [&[f64]; 3],
    cols: &[f64],
    nk: usize,
    n_free: usize,
    weights: &[Vec<f64>; 3],
    penalty: f64,
) -> JointSolution {
    use nalgebra::{DMatrix, DVector};
    let (n, m) = phi.shape();
    // unknowns: the free columns of each channel first, then the constrained ones, then β
    let mc = m - n_free;
    let total = 3 * m + nk;
    let idx = |c: usize, j: usize| {
        if j < n_free {
            c * n_free + j
        } else {
            3 * n_free + c * mc + (j - n_free)
        }
    };
    let beta0 = 3 * m;
    let unweighted = weights.iter().all(Vec::is_empty);
    let ptp_plain = unweighted.then(|| phi.transpose() * phi);
    let mut g = DMatrix::zeros(total, total);
    let mut h = DVector::zeros(total);
    for c in 0..3 {
        let w = |i: usize| weights[c].get(i).copied().unwrap_or(1.0);
        let (phi, yc) = crate::lvf::fit::weighted_rows(phi, y[c], &weights[c]);
        let ptp = match &ptp_plain {
            Some(p) => std::borrow::Cow::Borrowed(p),
            None => std::borrow::Cow::Owned(phi.transpose() * phi.as_ref()),
        };
        let s = DMatrix::from_fn(n, nk, |i, k| w(i) * cols[(c * n + i) * nk + k]);
        let pts = phi.transpose() * &s;
        let sts = s.transpose() * &s;
        let pty = phi.transpose() * &yc;
        let sty = s.transpose() * &yc;
        for a in 0..m {
            h[idx(c, a)] = pty[a];
            for b in 0..m {
                g[(idx(c, a), idx(c, b))] = ptp[(a, b)];
            }
            for k in 0..nk {
                g[(idx(c, a), beta0 + k)] = pts[(a, k)];
                g[(beta0 + k, idx(c, a))] = pts[(a, k)];
            }
        }
        for k in 0..nk {
            h[beta0 + k] += sty[k];
            for l in 0..nk {
                g[(beta0 + k, beta0 + l)] += sts[(k, l)];
            }
        }
    }
    // the data's Gram alone, for the effective number of parameters
    let g_data = (penalty > 0.0).then(|| g.clone());
    if penalty > 0.0 {
        const D: [f64; 3] = [1.0, -2.0, 1.0];
        for r in 0..nk.saturating_sub(2) {
            for (a, da) in D.iter().enumerate() {
                for (b, db) in D.iter().enumerate() {
                    g[(beta0 + r + a, beta0 + r + b)] += penalty * da * db;
                }
            }
        }
    }
    let x = crate::lvf::fit::nnls_gram(&g, &h, 3 * n_free);
    // effective number of linear parameters: tr((G + λP)⁻¹ G) over the active set (its count
    // when there is no penalty)
    let active: Vec<usize> = (0..total)
        .filter(|&i| x[i] != 0.0 || (i < 3 * n_free && g[(i, i)] > 0.0))
        .collect();
    let dof = match &g_data {
        None => x.iter().filter(|v| **v != 0.0).count() as f64,
        Some(gd) => {
            let ga = DMatrix::from_fn(active.len(), active.len(), |i, j| g[(active[i], active[j])]);
            let gda = DMatrix::from_fn(active.len(), active.len(), |i, j| {
                gd[(active[i], active[j])]
            });
            match ga.cholesky() {
                Some(ch) => ch.solve(&gda).trace(),
                None => x.iter().filter(|v| **v != 0.0).count() as f64,
            }
        }
    };
    let alpha: [DVector<f64>; 3] =
        std::array::from_fn(|c| DVector::from_fn(m, |j, _| x[idx(c, j)]));
    let beta: Vec<f64> = (0..nk).map(|k| x[beta0 + k]).collect();
    let curve: [Vec<f64>; 3] = std::array::from_fn(|c| {
        (0..n)
            .map(|i| (0..nk).map(|k| cols[(c * n + i) * nk + k] * beta[k]).sum())
            .collect()
    });
    (alpha, beta, curve, dof)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn flat_camera() -> CameraResponse {
        CameraResponse {
            source: "test".into(),
            first_nm: 380.0,
            q: (0..=400)
                .map(|i| [1.0, 0.5, if i < 200 { 1.0 } else { 0.0 }])
                .collect(),
        }
    }

    #[test]
    fn a_flat_spectrum_through_a_gaussian_passband_gives_the_passband_area_times_q() {
        let cam = flat_camera();
        let (lo, hi) = SharedBasis::range(&cam, 370.0, 800.0).unwrap();
        assert_eq!((lo, hi), (380.0, 780.0));
        let b = SharedBasis::new(&cam, lo, hi, SharedBasis::intervals_for(lo, hi, 40.0));
        assert_eq!(b.intervals, 10);
        let beta = vec![1.0; b.n()];
        // S = 1 everywhere (partition of unity); at 500 nm the 25 nm Gaussian's area is
        // 25·√(π/ln 16) = 26.61 nm.
        let cols = b.columns(&[500.0], &[1.0], 25.0, &Passband::Gaussian);
        let nk = b.n();
        let c0: f64 = (0..nk).map(|k| cols[k] * beta[k]).sum();
        let c1: f64 = (0..nk).map(|k| cols[nk + k] * beta[k]).sum();
        let area = 25.0 * (std::f64::consts::PI / 16f64.ln()).sqrt();
        assert!((c0 - area).abs() < 1e-3 * area, "{c0} vs {area}");
        assert!((c1 - 0.5 * area).abs() < 1e-3 * area, "{c1}");
        assert!((b.spectrum(&beta, 600.0) - 1.0).abs() < 1e-12);
        assert_eq!(b.spectrum(&beta, 300.0), 0.0);
    }
}
