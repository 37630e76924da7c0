//! Smoothness-regularised least squares, optionally non-negative, with the weight chosen by
//! generalised cross-validation (GCV).
//!
//! Solves `min ‖A x − b‖² + μ ‖D x‖²` (subject to `x ≥ 0` when asked), with D the first- or
//! second-difference operator on the unknowns' grid. This is the solver of the LVF band
//! transmissions and of spectral recovery (Nalbach et al. 2017 §4.2 after Kirk & O'Brien 2011),
//! whose systems have condition numbers around 1e6: plain least squares amplifies the noise into
//! oscillating spectra, and the smoothness penalty trades a little resolution for stability.
//!
//! **Scale.** The weight is given relative to the data: μ = λ · tr(AᵀA)/tr(DᵀD), so λ = 1 makes
//! both terms equally strong and λ is unit-free ([`Weight::Fixed`] takes λ).
//!
//! **GCV.** With the generalised eigen-decomposition of the pencil (AᵀA, DᵀD) — computed once as
//! `L⁻¹AᵀA L⁻ᵀ = V Σ Vᵀ` with `L Lᵀ = AᵀA + s DᵀD` (Cholesky), so that
//! `AᵀA + μ DᵀD = L V diag(σᵢ + λ(1 − σᵢ)) Vᵀ Lᵀ` — the solution, the residual norm and
//! `tr H` (H the hat matrix) cost O(n) per trial λ. GCV(λ) = m·RSS/(m − tr H)² is scanned on a
//! log grid from 1e-10 to 1e6 and refined by Brent's method (argmin). GCV is evaluated on the
//! unconstrained problem (as is usual); the non-negative solution at the chosen weight then comes
//! from Lawson–Hanson NNLS on the stacked system `[A; √μ D] x ≈ [b; 0]`.
//!
//! **Uncertainty.** `std` is the noise part of the error, √diag(σ̂² M⁻¹AᵀA M⁻¹) with
//! M = AᵀA + μDᵀD and σ̂² = RSS/(m − tr H): it does not include the smoothing bias, which the
//! resolution matrix R = M⁻¹AᵀA describes. `resolution_fwhm` is the full width at half maximum
//! of each row of R in samples: the narrowest feature the recovery can show at that position.

// Index loops mirror the matrix notation of the maths.
#![allow(clippy::needless_range_loop, clippy::neg_cmp_op_on_partial_ord)]

use nalgebra::{DMatrix, DVector, SymmetricEigen};

use super::nnls::nnls;
use super::qr::Qr;
use super::search::log_grid_min;
use crate::error::{Error, Result};
use crate::math::minimize::brent_min;

/// Order of the difference operator in the penalty.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Smoothness {
    /// ‖x_{i+1} − x_i‖²: penalises slope (flat solutions are free).
    First,
    /// ‖x_{i+1} − 2x_i + x_{i−1}‖²: penalises curvature (straight lines are free).
    Second,
    /// Second differences of x continued by zeros beyond the ends marked `true`: the penalty
    /// also charges a curve that does not fall smoothly to zero there (a band transmission
    /// inside its support window).
    SecondPadded {
        /// Zeros before the first unknown.
        left: bool,
        /// Zeros after the last unknown.
        right: bool,
    },
}

impl Smoothness {
    fn order(self) -> usize {
        match self {
            Smoothness::First => 1,
            Smoothness::Second | Smoothness::SecondPadded { .. } => 2,
        }
    }
}

/// How the penalty weight is chosen.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Weight {
    /// Minimise the GCV score.
    Gcv,
    /// A given relative weight λ ≥ 0 (0: no penalty, plain least squares).
    Fixed(f64),
}

/// Options of [`solve_regularized`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RegularizedOptions {
    /// Penalty operator.
    pub smoothness: Smoothness,
    /// Weight choice.
    pub weight: Weight,
    /// Constrain x ≥ 0.
    pub nonnegative: bool,
    /// GCV only: search only weights whose effective number of parameters (tr H) is at most this.
    /// A prior on how much independent information the data can carry: systematic model errors
    /// (not white noise) otherwise make GCV choose too small a weight and fit them as signal.
    pub max_effective_parameters: Option<f64>,
    /// GCV only: robust GCV with this γ ∈ (0, 1] (Lukas 2006), V·(γ + (1 − γ)·tr(H²)/m); `None`
    /// = plain GCV. Small γ guard against the vanishing weights plain GCV picks when some
    /// unknowns are barely constrained.
    pub robust_gcv: Option<f64>,
}

impl Default for RegularizedOptions {
    fn default() -> Self {
        RegularizedOptions {
            smoothness: Smoothness::Second,
            weight: Weight::Gcv,
            nonnegative: true,
            max_effective_parameters: None,
            robust_gcv: None,
        }
    }
}

/// The solution and its diagnostics.
#[derive(Debug, Clone, PartialEq)]
pub struct RegularizedSolution {
    /// The unknowns.
    pub x: Vec<f64>,
    /// Noise standard deviation of each unknown (no smoothing bias; see the module docs).
    pub std: Vec<f64>,
    /// Relative weight λ used (0 for plain least squares).
    pub lambda: f64,
    /// Absolute weight μ = λ·tr(AᵀA)/tr(DᵀD).
    pub mu: f64,
    /// GCV score at λ (NaN when the weight was given and GCV is undefined).
    pub gcv: f64,
    /// tr H: the effective number of parameters.
    pub effective_parameters: f64,
    /// Residuals b − A x.
    pub residuals: Vec<f64>,
    /// Residual sum of squares.
    pub rss: f64,
    /// Estimated noise standard deviation of one equation, √(RSS/(m − tr H)).
    pub sigma: f64,
    /// FWHM of each row of the resolution matrix, in samples (NaN where a row has no clear peak).
    pub resolution_fwhm: Vec<f64>,
    /// Condition number of A (ratio of extreme singular values; ∞ when rank-deficient).
    pub condition_number: f64,
    /// Unknowns held at zero by the constraint.
    pub n_clamped: usize,
    /// (λ, GCV) over the scan (empty for a given weight).
    pub gcv_curve: Vec<(f64, f64)>,
}

/// The penalty operator D for `n` unknowns: (n − 1) × n first differences, (n − 2) × n second
/// differences, plus one row per padded end (the second difference across the end, the
/// unknowns beyond it being zero).
pub fn penalty_operator(n: usize, smoothness: Smoothness) -> DMatrix<f64> {
    let (order, left, right) = match smoothness {
        Smoothness::First => (1, false, false),
        Smoothness::Second => (2, false, false),
        Smoothness::SecondPadded { left, right } => (2, left, right),
    };
    // Rows over the padded sequence x_pad[k] = x[k − 2] (zeros outside 0..n).
    let mut rows: Vec<Vec<(usize, f64)>> = Vec::new();
    if order == 1 {
        for i in 0..n.saturating_sub(1) {
            rows.push(vec![(i, -1.0), (i + 1, 1.0)]);
        }
    } else {
        // Row i: x_pad[i] − 2 x_pad[i+1] + x_pad[i+2] for i in 0..n+2; rows 0 and 1 reach
        // before the first unknown, rows n and n+1 after the last.
        for i in 0..n + 2 {
            if (i < 2 && !left) || (i >= n && !right) {
                continue;
            }
            let row: Vec<(usize, f64)> = [(i, 1.0), (i + 1, -2.0), (i + 2, 1.0)]
                .into_iter()
                .filter(|(k, _)| (2..n + 2).contains(k))
                .map(|(k, v)| (k - 2, v))
                .collect();
            rows.push(row);
        }
    }
    let mut d = DMatrix::zeros(rows.len(), n);
    for (r, row) in rows.iter().enumerate() {
        for &(j, v) in row {
            d[(r, j)] = v;
        }
    }
    d
}

/// The generalised eigen-structure of (AᵀA, DᵀD), fixed for a given A.
struct Pencil {
    /// Eigenvalues σᵢ ∈ [0, 1].
    sigma: Vec<f64>,
    /// P = L⁻ᵀ V: x = P y.
    p: DMatrix<f64>,
    /// Q = L V: R = P diag(σ/d) Qᵀ.
    q: DMatrix<f64>,
    /// z = Vᵀ L⁻¹ Aᵀ b.
    z: Vec<f64>,
    /// ‖b‖² minus the part of b inside the range of A.
    rss_floor: f64,
    /// GCV is searched only where tr H ≤ this.
    max_tr: f64,
    /// γ of robust GCV (1 = plain GCV).
    gamma: f64,
}

impl Pencil {
    fn new(a: &DMatrix<f64>, dtd: &DMatrix<f64>, s: f64, b: &DVector<f64>) -> Result<Self> {
        let g = a.transpose() * a;
        let chol = nalgebra::Cholesky::new(&g + dtd * s).ok_or_else(|| Error::Numerical {
            what: "regularised least squares".into(),
            reason: "AᵀA + DᵀD is singular: the data do not constrain the unknowns' mean or slope (the camera sees nothing over part of the grid?)".into(),
        })?;
        let l = chol.l();
        let li = l.clone().try_inverse().ok_or_else(|| Error::Numerical {
            what: "regularised least squares".into(),
            reason: "Cholesky factor not invertible".into(),
        })?;
        let k = &li * &g * li.transpose();
        let k = (&k + k.transpose()) * 0.5;
        let eig = SymmetricEigen::new(k);
        let sigma: Vec<f64> = eig.eigenvalues.iter().map(|v| v.clamp(0.0, 1.0)).collect();
        let v = eig.eigenvectors;
        let p = li.transpose() * &v;
        let q = &l * &v;
        let atb = a.transpose() * b;
        let zv = v.transpose() * (&li * atb);
        let z: Vec<f64> = zv.iter().copied().collect();
        let btb = b.dot(b);
        let inside: f64 = sigma
            .iter()
            .zip(&z)
            .filter(|(s, _)| **s > 1e-14)
            .map(|(s, z)| z * z / s)
            .sum();
        Ok(Pencil {
            sigma,
            p,
            q,
            z,
            rss_floor: (btb - inside).max(0.0),
            max_tr: f64::INFINITY,
            gamma: 1.0,
        })
    }

    fn denom(&self, i: usize, lambda: f64) -> f64 {
        self.sigma[i] + lambda * (1.0 - self.sigma[i])
    }

    /// (RSS, tr H) at relative weight λ > 0.
    fn rss_trace(&self, lambda: f64) -> (f64, f64) {
        let mut rss = self.rss_floor;
        let mut tr = 0.0;
        for i in 0..self.sigma.len() {
            let s = self.sigma[i];
            let d = self.denom(i, lambda);
            tr += s / d;
            if s > 1e-14 {
                let f = lambda * (1.0 - s) / d;
                rss += self.z[i] * self.z[i] / s * f * f;
            }
        }
        (rss, tr)
    }

    fn gcv(&self, lambda: f64, m: usize) -> f64 {
        let (rss, tr) = self.rss_trace(lambda);
        let dof = m as f64 - tr;
        if dof <= 0.5 || tr > self.max_tr {
            return f64::INFINITY;
        }
        let v = m as f64 * rss / (dof * dof);
        if self.gamma < 1.0 {
            // Robust GCV (Lukas 2006): V · (γ + (1 − γ)·tr(H²)/m); H's eigenvalues are σᵢ/dᵢ.
            let tr_h2: f64 = (0..self.sigma.len())
                .map(|i| (self.sigma[i] / self.denom(i, lambda)).powi(2))
                .sum();
            v * (self.gamma + (1.0 - self.gamma) * tr_h2 / m as f64)
        } else {
            v
        }
    }

    fn solution(&self, lambda: f64) -> Vec<f64> {
        let n = self.sigma.len();
        let y: Vec<f64> = (0..n).map(|i| self.z[i] / self.denom(i, lambda)).collect();
        (0..n)
            .map(|r| (0..n).map(|k| self.p[(r, k)] * y[k]).sum())
            .collect()
    }

    /// diag(M⁻¹AᵀA M⁻¹) / σ̂² factor and the resolution FWHM per row.
    fn covariance_diag(&self, lambda: f64) -> Vec<f64> {
        let n = self.sigma.len();
        (0..n)
            .map(|r| {
                (0..n)
                    .map(|k| {
                        let d = self.denom(k, lambda);
                        self.p[(r, k)].powi(2) * self.sigma[k] / (d * d)
                    })
                    .sum()
            })
            .collect()
    }

    fn resolution_row(&self, lambda: f64, r: usize) -> Vec<f64> {
        let n = self.sigma.len();
        let w: Vec<f64> = (0..n)
            .map(|k| self.p[(r, k)] * self.sigma[k] / self.denom(k, lambda))
            .collect();
        (0..n)
            .map(|c| (0..n).map(|k| w[k] * self.q[(c, k)]).sum())
            .collect()
    }
}

/// Full width at half maximum (in samples) of `row` around its value at `centre`'s nearest
/// maximum; NaN when the row never falls below half its peak on one side.
pub fn fwhm_samples(row: &[f64], centre: usize) -> f64 {
    let n = row.len();
    if n == 0 {
        return f64::NAN;
    }
    // Climb to the local maximum nearest the centre.
    let mut i = centre.min(n - 1);
    loop {
        if i + 1 < n && row[i + 1] > row[i] {
            i += 1;
        } else if i > 0 && row[i - 1] > row[i] {
            i -= 1;
        } else {
            break;
        }
    }
    let peak = row[i];
    if !(peak > 0.0) {
        return f64::NAN;
    }
    let half = peak / 2.0;
    let mut left = None;
    for j in (0..i).rev() {
        if row[j] <= half {
            left = Some(j as f64 + (half - row[j]) / (row[j + 1] - row[j]));
            break;
        }
    }
    let mut right = None;
    for j in i + 1..n {
        if row[j] <= half {
            right = Some(j as f64 - (half - row[j]) / (row[j - 1] - row[j]));
            break;
        }
    }
    match (left, right) {
        (Some(l), Some(r)) => r - l,
        _ => f64::NAN,
    }
}

/// Ratio of the extreme singular values of the column-major m × n matrix `a` (∞ when it is
/// rank-deficient or has fewer rows than columns; NaN when empty).
pub fn condition_number(a: &[f64], m: usize, n: usize) -> f64 {
    if m == 0 || n == 0 {
        return f64::NAN;
    }
    let sv = DMatrix::from_column_slice(m, n, a).singular_values();
    let smax = sv.iter().cloned().fold(0.0, f64::max);
    let smin = sv.iter().cloned().fold(f64::INFINITY, f64::min);
    if m >= n && smin > smax * 1e-15 {
        smax / smin
    } else {
        f64::INFINITY
    }
}

/// Solves the regularised problem for column-major `a` (m × n) and `b` (m).
///
/// # Errors
/// [`Error::InvalidArgument`] for inconsistent sizes, non-finite input, an all-zero `b`, a
/// negative weight, or plain least squares (λ = 0) with fewer equations than unknowns;
/// [`Error::Numerical`] when the data leave a smooth component of x undetermined.
pub fn solve_regularized(
    a: &[f64],
    m: usize,
    n: usize,
    b: &[f64],
    opts: &RegularizedOptions,
) -> Result<RegularizedSolution> {
    let order = opts.smoothness.order();
    if n <= order || a.len() != m * n || b.len() != m || m == 0 {
        return Err(Error::invalid(
            "regularised least squares",
            format!("A is {m}×{n} with {} values and b has {}; expected n > {order}, m·n values and m entries", a.len(), b.len()),
        ));
    }
    if a.iter().chain(b).any(|v| !v.is_finite()) {
        return Err(Error::invalid(
            "regularised least squares",
            "A or b holds NaN or infinite values",
        ));
    }
    if b.iter().all(|&v| v == 0.0) {
        return Err(Error::invalid(
            "regularised least squares",
            "every reading is zero; there is nothing to solve for",
        ));
    }
    if let Weight::Fixed(l) = opts.weight {
        if !(l >= 0.0) || !l.is_finite() {
            return Err(Error::invalid(
                "regularisation weight",
                format!("{l}: expected a finite value ≥ 0"),
            ));
        }
    }
    let am = DMatrix::from_column_slice(m, n, a);
    let bv = DVector::from_column_slice(b);
    let condition_number = condition_number(a, m, n);

    if opts.weight == Weight::Fixed(0.0) {
        return plain(a, m, n, b, opts.nonnegative, condition_number);
    }

    let d = penalty_operator(n, opts.smoothness);
    let dtd = d.transpose() * &d;
    let g_trace: f64 = (0..n).map(|j| am.column(j).norm_squared()).sum();
    let s = g_trace / dtd.trace();
    let mut pencil = Pencil::new(&am, &dtd, s, &bv)?;
    if let Some(t) = opts.max_effective_parameters {
        if !(t > order as f64) {
            return Err(Error::invalid(
                "maximum effective parameters",
                format!("{t}: expected more than the penalty's null space ({order})"),
            ));
        }
        pencil.max_tr = t;
    }
    if let Some(g) = opts.robust_gcv {
        if !(g > 0.0 && g <= 1.0) {
            return Err(Error::invalid(
                "robust GCV γ",
                format!("{g}: expected 0 < γ ≤ 1"),
            ));
        }
        pencil.gamma = g;
    }

    let mut gcv_curve = Vec::new();
    let lambda = match opts.weight {
        Weight::Fixed(l) => l,
        Weight::Gcv => {
            let grid = log_grid_min(1e-10, 1e6, 161, |lam| pencil.gcv(lam, m));
            gcv_curve.extend(grid.points.iter().copied().zip(grid.values.iter().copied()));
            if !grid.value().is_finite() {
                return Err(Error::Numerical {
                    what: "GCV weight choice".into(),
                    reason: format!("{m} equations for {n} unknowns leave no degrees of freedom for cross-validation within the allowed effective parameters; give the weight explicitly"),
                });
            }
            let (a, b) = grid.bracket();
            let e = brent_min(|e| pencil.gcv(10f64.powf(e), m), a.log10(), b.log10(), 1e-4);
            10f64.powf(e)
        }
    };
    let mu = lambda * s;
    let x_free = pencil.solution(lambda);
    let mut x = x_free.clone();
    let mut n_clamped = 0;
    if opts.nonnegative && x_free.iter().any(|&v| v < 0.0) {
        // Stacked system [A; √μ D] x ≈ [b; 0], column-major.
        let rows = m + d.nrows();
        let sq = mu.sqrt();
        let mut stacked = Vec::with_capacity(rows * n);
        for j in 0..n {
            stacked.extend_from_slice(&a[j * m..(j + 1) * m]);
            for i in 0..d.nrows() {
                stacked.push(sq * d[(i, j)]);
            }
        }
        let mut rhs = b.to_vec();
        rhs.resize(rows, 0.0);
        let sol = nnls(&stacked, rows, n, &rhs, &vec![false; n]);
        n_clamped = sol.x.iter().filter(|&&v| v == 0.0).count();
        x = sol.x;
    }
    let residuals: Vec<f64> = (0..m)
        .map(|i| b[i] - (0..n).map(|j| a[j * m + i] * x[j]).sum::<f64>())
        .collect();
    let rss: f64 = residuals.iter().map(|r| r * r).sum();
    let (_, tr) = pencil.rss_trace(lambda);
    let dof = (m as f64 - tr).max(1.0);
    let sigma2 = rss / dof;
    let std = pencil
        .covariance_diag(lambda)
        .iter()
        .map(|v| (sigma2 * v).max(0.0).sqrt())
        .collect();
    let resolution_fwhm = (0..n)
        .map(|r| fwhm_samples(&pencil.resolution_row(lambda, r), r))
        .collect();
    Ok(RegularizedSolution {
        x,
        std,
        lambda,
        mu,
        gcv: if m as f64 - tr > 0.5 {
            let (rss_u, _) = pencil.rss_trace(lambda);
            m as f64 * rss_u / (m as f64 - tr).powi(2)
        } else {
            f64::NAN
        },
        effective_parameters: tr,
        residuals,
        rss,
        sigma: sigma2.sqrt(),
        resolution_fwhm,
        condition_number,
        n_clamped,
        gcv_curve,
    })
}

/// Plain (unregularised) least squares, optionally non-negative, by Householder QR.
fn plain(
    a: &[f64],
    m: usize,
    n: usize,
    b: &[f64],
    nonnegative: bool,
    condition_number: f64,
) -> Result<RegularizedSolution> {
    if m < n {
        return Err(Error::invalid(
            "least squares",
            format!("{m} equations for {n} unknowns: plain least squares needs at least as many equations; use a smoothness weight"),
        ));
    }
    let qr = Qr::new(a, m, n);
    let (x, passive) = if nonnegative {
        let sol = nnls(a, m, n, b, &vec![false; n]);
        (sol.x, sol.passive)
    } else {
        let mut qtb = b.to_vec();
        qr.qt_mul(&mut qtb);
        let mut x = vec![0.0; n];
        qr.solve_r(&qtb, &mut x);
        (x, vec![true; n])
    };
    let residuals: Vec<f64> = (0..m)
        .map(|i| b[i] - (0..n).map(|j| a[j * m + i] * x[j]).sum::<f64>())
        .collect();
    let rss: f64 = residuals.iter().map(|r| r * r).sum();
    let dof = (m as f64 - n as f64).max(1.0);
    let sigma2 = rss / dof;
    let std = match qr.inverse_gram() {
        Some(inv) => (0..n)
            .map(|j| (sigma2 * inv[j * n + j]).max(0.0).sqrt())
            .collect(),
        None => vec![f64::INFINITY; n],
    };
    Ok(RegularizedSolution {
        n_clamped: passive.iter().filter(|p| !**p).count(),
        x,
        std,
        lambda: 0.0,
        mu: 0.0,
        gcv: f64::NAN,
        effective_parameters: n as f64,
        residuals,
        rss,
        sigma: sigma2.sqrt(),
        resolution_fwhm: vec![1.0; n],
        condition_number,
        gcv_curve: Vec::new(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A small Gaussian generator (SplitMix64 + Box–Muller); `capture::rng` is in the same layer.
    struct Rng(u64);
    impl Rng {
        fn uniform(&mut self) -> f64 {
            self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
        }
        fn normal(&mut self) -> f64 {
            let u = self.uniform().max(1e-300);
            (-2.0 * u.ln()).sqrt() * (2.0 * std::f64::consts::PI * self.uniform()).cos()
        }
    }

    /// A blurred-sampling problem like spectral recovery: 31 Gaussian bands × 3 smooth channels
    /// observing 61 unknowns.
    fn problem(noise: f64, seed: u64) -> (Vec<f64>, usize, usize, Vec<f64>, Vec<f64>) {
        let n = 61;
        let grid: Vec<f64> = (0..n).map(|i| 400.0 + 5.0 * i as f64).collect();
        let truth: Vec<f64> = grid
            .iter()
            .map(|l| 0.2 + 0.6 * (-((l - 560.0) / 60.0).powi(2)).exp())
            .collect();
        let chan = |c: usize, l: f64| {
            let centre = [600.0, 540.0, 460.0][c];
            (-((l - centre) / 50.0).powi(2)).exp()
        };
        let mut rows = Vec::new();
        for j in 0..31 {
            let centre = 400.0 + 10.0 * j as f64;
            for c in 0..3 {
                rows.push(
                    grid.iter()
                        .map(|&l| {
                            let s = 25.0 / 2.3548;
                            (-0.5 * ((l - centre) / s).powi(2)).exp() * chan(c, l) * 5.0
                        })
                        .collect::<Vec<f64>>(),
                );
            }
        }
        let m = rows.len();
        let mut a = vec![0.0; m * n];
        for (i, r) in rows.iter().enumerate() {
            for j in 0..n {
                a[j * m + i] = r[j];
            }
        }
        let mut rng = Rng(seed);
        let clean: Vec<f64> = rows
            .iter()
            .map(|r| r.iter().zip(&truth).map(|(a, t)| a * t).sum::<f64>())
            .collect();
        let peak = clean.iter().cloned().fold(0.0, f64::max);
        let b = clean
            .iter()
            .map(|v| v + noise * peak * rng.normal())
            .collect();
        (a, m, n, b, truth)
    }

    fn rms(x: &[f64], t: &[f64]) -> f64 {
        (x.iter().zip(t).map(|(a, b)| (a - b).powi(2)).sum::<f64>() / x.len() as f64).sqrt()
    }

    #[test]
    fn gcv_beats_plain_least_squares_on_an_ill_conditioned_problem() {
        let (a, m, n, b, truth) = problem(0.01, 3);
        let reg = solve_regularized(&a, m, n, &b, &RegularizedOptions::default()).unwrap();
        let plain = solve_regularized(
            &a,
            m,
            n,
            &b,
            &RegularizedOptions {
                weight: Weight::Fixed(0.0),
                nonnegative: false,
                ..Default::default()
            },
        )
        .unwrap();
        eprintln!(
            "cond {:.3e} λ {:.3e} rms reg {:.4} plain {:.4} trH {:.1}",
            reg.condition_number,
            reg.lambda,
            rms(&reg.x, &truth),
            rms(&plain.x, &truth),
            reg.effective_parameters
        );
        assert!(reg.condition_number > 1e4, "cond {}", reg.condition_number);
        let (e_reg, e_plain) = (rms(&reg.x, &truth), rms(&plain.x, &truth));
        assert!(e_reg < 0.05, "regularised rms {e_reg}");
        assert!(
            e_plain > 5.0 * e_reg,
            "plain {e_plain} vs regularised {e_reg}"
        );
        assert!(reg.lambda > 0.0 && reg.effective_parameters < n as f64);
        // The reported noise std is of the right order: the error is a few std at most.
        let mean_std = reg.std.iter().sum::<f64>() / n as f64;
        assert!(
            mean_std > 0.0 && e_reg < 20.0 * mean_std,
            "rms {e_reg} std {mean_std}"
        );
    }

    #[test]
    fn noise_free_data_are_reproduced_closely_and_gcv_picks_a_small_weight() {
        let (a, m, n, b, truth) = problem(0.0, 1);
        let reg = solve_regularized(&a, m, n, &b, &RegularizedOptions::default()).unwrap();
        assert!(rms(&reg.x, &truth) < 2e-3, "rms {}", rms(&reg.x, &truth));
        let noisy = solve_regularized(
            &a,
            m,
            n,
            &problem(0.03, 1).3,
            &RegularizedOptions::default(),
        )
        .unwrap();
        assert!(
            noisy.lambda > reg.lambda,
            "{} vs {}",
            noisy.lambda,
            reg.lambda
        );
    }

    #[test]
    fn nonnegativity_is_enforced_and_reported() {
        let (a, m, n, _, _) = problem(0.0, 1);
        // A spectrum that is zero over half the grid: the unconstrained solution rings below zero.
        let truth: Vec<f64> = (0..n)
            .map(|i| if (20..30).contains(&i) { 1.0 } else { 0.0 })
            .collect();
        let b: Vec<f64> = (0..m)
            .map(|i| (0..n).map(|j| a[j * m + i] * truth[j]).sum())
            .collect();
        let free = solve_regularized(
            &a,
            m,
            n,
            &b,
            &RegularizedOptions {
                nonnegative: false,
                ..Default::default()
            },
        )
        .unwrap();
        let nn = solve_regularized(&a, m, n, &b, &RegularizedOptions::default()).unwrap();
        assert!(free.x.iter().any(|&v| v < -1e-3));
        assert!(nn.x.iter().all(|&v| v >= 0.0));
        assert!(nn.n_clamped > 0);
        assert!(rms(&nn.x, &truth) <= rms(&free.x, &truth) + 1e-12);
    }

    #[test]
    fn resolution_widens_with_the_weight() {
        let (a, m, n, b, _) = problem(0.01, 2);
        let fw = |l: f64| {
            let s = solve_regularized(
                &a,
                m,
                n,
                &b,
                &RegularizedOptions {
                    weight: Weight::Fixed(l),
                    ..Default::default()
                },
            )
            .unwrap();
            s.resolution_fwhm[30]
        };
        let (narrow, wide) = (fw(1e-6), fw(1e-2));
        assert!(
            narrow.is_finite() && wide.is_finite() && wide > narrow,
            "{narrow} vs {wide}"
        );
    }

    #[test]
    fn bad_input_is_rejected() {
        let (a, m, n, b, _) = problem(0.01, 2);
        let o = RegularizedOptions::default();
        assert!(solve_regularized(&a, m, n, &vec![0.0; m], &o).is_err());
        assert!(solve_regularized(&a, m, n - 1, &b, &o).is_err());
        let mut bad = b.clone();
        bad[3] = f64::NAN;
        assert!(solve_regularized(&a, m, n, &bad, &o).is_err());
        assert!(solve_regularized(
            &a,
            m,
            n,
            &b,
            &RegularizedOptions {
                weight: Weight::Fixed(-1.0),
                ..o
            }
        )
        .is_err());
        // Plain least squares with too few equations.
        let (a2, m2) = (&a[..], m);
        let sub: Vec<f64> = (0..n)
            .flat_map(|j| a2[j * m2..j * m2 + 30].to_vec())
            .collect();
        let e = solve_regularized(
            &sub,
            30,
            n,
            &b[..30],
            &RegularizedOptions {
                weight: Weight::Fixed(0.0),
                ..o
            },
        );
        assert!(e.is_err());
    }

    #[test]
    fn penalty_operators_have_the_documented_rows() {
        let d1 = penalty_operator(4, Smoothness::First);
        assert_eq!(d1.nrows(), 3);
        assert_eq!((d1[(0, 0)], d1[(0, 1)]), (-1.0, 1.0));
        let d2 = penalty_operator(4, Smoothness::Second);
        assert_eq!(d2.nrows(), 2);
        assert_eq!((d2[(1, 1)], d2[(1, 2)], d2[(1, 3)]), (1.0, -2.0, 1.0));
        // Padded on the left: rows x₀ and −2x₀ + x₁ come first (zeros before x₀).
        let p = penalty_operator(
            4,
            Smoothness::SecondPadded {
                left: true,
                right: false,
            },
        );
        assert_eq!(p.nrows(), 4);
        assert_eq!((p[(0, 0)], p[(0, 1)]), (1.0, 0.0));
        assert_eq!((p[(1, 0)], p[(1, 1)]), (-2.0, 1.0));
        let both = penalty_operator(
            4,
            Smoothness::SecondPadded {
                left: true,
                right: true,
            },
        );
        assert_eq!(both.nrows(), 6);
        assert_eq!((both[(5, 3)], both[(4, 3)], both[(4, 2)]), (1.0, -2.0, 1.0));
    }

    #[test]
    fn robust_gcv_chooses_at_least_the_plain_gcv_weight() {
        let (a, m, n, b, truth) = problem(0.01, 5);
        let plain = solve_regularized(&a, m, n, &b, &RegularizedOptions::default()).unwrap();
        let robust = solve_regularized(
            &a,
            m,
            n,
            &b,
            &RegularizedOptions {
                robust_gcv: Some(0.1),
                ..Default::default()
            },
        )
        .unwrap();
        // tr(H²)/m grows as λ falls, so the robust score penalises small weights more.
        assert!(
            robust.lambda >= plain.lambda * 0.999,
            "{} vs {}",
            robust.lambda,
            plain.lambda
        );
        assert!(rms(&robust.x, &truth) < 0.05);
        assert!(solve_regularized(
            &a,
            m,
            n,
            &b,
            &RegularizedOptions {
                robust_gcv: Some(0.0),
                ..Default::default()
            }
        )
        .is_err());
    }

    #[test]
    fn fwhm_of_a_triangle() {
        let row = [0.0, 0.25, 0.5, 0.75, 1.0, 0.75, 0.5, 0.25, 0.0];
        assert!((fwhm_samples(&row, 4) - 4.0).abs() < 1e-12);
        assert!(fwhm_samples(&[1.0, 1.0, 1.0], 1).is_nan());
    }
}
