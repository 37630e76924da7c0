//! The gel-photo problem: captures, options, diagnostics, the design matrix and the weighted
//! equations of one band.

#![allow(clippy::needless_range_loop)]

use super::*;

/// One photo through the LVF: the gel (None = open LVF) and its band readings.
#[derive(Debug, Clone, PartialEq)]
pub struct GelCapture {
    /// Label for messages (image name and gel code).
    pub label: String,
    /// Gel transmission sampled on the problem's quadrature grid; None for the open LVF.
    pub filter: Option<Vec<f64>>,
    /// Band readings of the photo ([`LvfGeometry::band_readings`]).
    pub readings: BandReadings,
}

/// Everything known about the calibration photos, sampled on one quadrature grid.
#[derive(Debug, Clone, PartialEq)]
pub struct TransmissionProblem {
    /// Uniform quadrature grid λ_q (nm); Δλ is its step.
    pub quad_nm: Vec<f64>,
    /// Source spectral power S(λ_q).
    pub source: Vec<f64>,
    /// Target reflectance R(λ_q).
    pub target: Vec<f64>,
    /// Camera sensitivities Q_c(λ_q), c = R, G, B.
    pub camera: [Vec<f64>; 3],
    /// The photos.
    pub captures: Vec<GelCapture>,
}

/// Options of [`solve_transmissions`].
#[derive(Debug, Clone, PartialEq)]
pub struct TransmissionOptions {
    /// Model.
    pub model: BandModel,
    /// Solve grid (nm, strictly increasing; 5 nm steps recommended), inside `quad_nm`'s range.
    pub grid_nm: Vec<f64>,
    /// Penalty weight of `nnls` (GCV or a relative λ).
    pub weight: Weight,
    /// Enforce T ≥ 0 in `nnls` (false turns it into smoothness-only least squares).
    pub nonnegative: bool,
    /// Support half-width in effective calibration FWHMs.
    pub support_fwhm: f64,
    /// Weight equations by the readings' standard errors.
    pub use_std: bool,
    /// Relative noise floor of the weights.
    pub noise_floor: f64,
}

impl TransmissionOptions {
    /// Defaults for `model` on `grid_nm`: GCV, non-negative, support 2.5 FWHM, weighted, floor 1e-3.
    pub fn new(model: BandModel, grid_nm: Vec<f64>) -> Self {
        TransmissionOptions {
            model,
            grid_nm,
            weight: Weight::Gcv,
            nonnegative: true,
            support_fwhm: DEFAULT_SUPPORT_FWHM,
            use_std: true,
            noise_floor: DEFAULT_NOISE_FLOOR,
        }
    }
}

/// Solver diagnostics written under `diagnostics`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TransmissionDiagnostics {
    /// Photos used.
    pub n_captures: usize,
    /// Photos through a gel.
    pub n_gels: usize,
    /// Equations per band (photos × 3 channels).
    pub equations_per_band: usize,
    /// Unknowns of the full-grid problem.
    pub grid_unknowns: usize,
    /// Condition number of the unweighted full-grid design (plain least squares over the whole
    /// grid; ∞ when singular).
    pub condition_number_full_grid: f64,
    /// Condition number of the unweighted design over the wavelengths where the gels differ
    /// (excluding the ranges where every gel is held constant), when that is a proper subset.
    pub condition_number_gel_range: Option<f64>,
    /// Median over bands of the per-band weighted condition numbers.
    pub condition_number_band_median: Option<f64>,
    /// Largest per-band condition number.
    pub condition_number_band_max: Option<f64>,
    /// Quadrature step Δλ (nm).
    pub quadrature_step_nm: f64,
    /// Support half-width (effective FWHMs) of the free-shape models.
    pub support_fwhm: f64,
    /// Prior stated in words.
    pub prior: String,
    /// Whether equations were weighted by the readings' standard errors.
    pub weighted: bool,
    /// Relative noise floor of the weights.
    pub noise_floor: f64,
    /// Non-negativity constraint (free-shape models).
    pub nonnegative: bool,
    /// Median RMS residual over bands.
    pub rms_residual_median: f64,
    /// Parametric fits that did not converge (band indices).
    pub not_converged: Vec<usize>,
    /// Parametric fits that ended on a bound of the prior (band indices): the data do not
    /// determine these bands.
    pub at_bound: Vec<usize>,
}

/// The per-row base vectors B_{(k,c),q} = Δλ·S R F_k Q_c on the quadrature grid (row-major).
pub(super) struct Design {
    pub(super) rows: usize,
    pub(super) nq: usize,
    pub(super) b: Vec<f64>,
}

pub(super) fn validate(p: &TransmissionProblem, n_bands: usize) -> Result<f64> {
    let nq = p.quad_nm.len();
    check_grid(&p.quad_nm).map_err(|_| {
        Error::invalid(
            "quadrature grid",
            "expected at least 2 strictly increasing wavelengths",
        )
    })?;
    let step = (p.quad_nm[nq - 1] - p.quad_nm[0]) / (nq - 1) as f64;
    if p.quad_nm
        .windows(2)
        .any(|w| ((w[1] - w[0]) - step).abs() > 1e-6 * step)
    {
        return Err(Error::invalid("quadrature grid", "expected a uniform grid"));
    }
    for (what, v) in [
        ("source", &p.source),
        ("target", &p.target),
        ("camera R", &p.camera[0]),
        ("camera G", &p.camera[1]),
        ("camera B", &p.camera[2]),
    ] {
        if v.len() != nq {
            return Err(Error::ShapeMismatch {
                what: what.into(),
                expected: nq,
                got: v.len(),
            });
        }
        if let Some(i) = v.iter().position(|x| !x.is_finite() || *x < 0.0) {
            return Err(Error::invalid(
                what,
                format!(
                    "value {} at {} nm; expected finite and ≥ 0",
                    v[i], p.quad_nm[i]
                ),
            ));
        }
    }
    if p.captures.is_empty() {
        return Err(Error::invalid(
            "captures",
            "no photos; expected the open LVF and/or photos through gels",
        ));
    }
    for c in &p.captures {
        if let Some(f) = &c.filter {
            if f.len() != nq {
                return Err(Error::ShapeMismatch {
                    what: format!("gel of {}", c.label),
                    expected: nq,
                    got: f.len(),
                });
            }
            if let Some(i) = f.iter().position(|x| !x.is_finite() || *x < 0.0) {
                return Err(Error::invalid(
                    c.label.clone(),
                    format!(
                        "gel transmission {} at {} nm; expected finite and ≥ 0",
                        f[i], p.quad_nm[i]
                    ),
                ));
            }
        }
        if c.readings.rgb.len() != n_bands || c.readings.std.len() != n_bands {
            return Err(Error::invalid(
                c.label.clone(),
                format!(
                    "{} band readings; the calibration has {n_bands} bands",
                    c.readings.rgb.len()
                ),
            ));
        }
        if c.readings.rgb.iter().flatten().any(|v| !v.is_finite()) {
            return Err(Error::invalid(c.label.clone(), "non-finite band reading"));
        }
    }
    if p.captures
        .iter()
        .all(|c| c.readings.rgb.iter().flatten().all(|&v| v == 0.0))
    {
        return Err(Error::invalid(
            "captures",
            "every capture reads zero in every band; nothing to solve",
        ));
    }
    Ok(step)
}

impl Design {
    pub(super) fn new(p: &TransmissionProblem, step: f64) -> Design {
        let nq = p.quad_nm.len();
        let rows = p.captures.len() * 3;
        let mut b = vec![0.0; rows * nq];
        for (k, cap) in p.captures.iter().enumerate() {
            for c in 0..3 {
                let r = 3 * k + c;
                for q in 0..nq {
                    let f = cap.filter.as_ref().map_or(1.0, |f| f[q]);
                    b[r * nq + q] = step * p.source[q] * p.target[q] * f * p.camera[c][q];
                }
            }
        }
        Design { rows, nq, b }
    }

    /// Column-major rows × n matrix of the hat-function basis on `grid`.
    pub(super) fn on_grid(&self, quad: &[f64], grid: &[f64]) -> Vec<f64> {
        let n = grid.len();
        let mut a = vec![0.0; self.rows * n];
        for (q, &l) in quad.iter().enumerate() {
            if l < grid[0] - 1e-9 || l > grid[n - 1] + 1e-9 {
                continue;
            }
            let i = grid.partition_point(|&g| g <= l).clamp(1, n - 1);
            let f = ((l - grid[i - 1]) / (grid[i] - grid[i - 1])).clamp(0.0, 1.0);
            for r in 0..self.rows {
                let v = self.b[r * self.nq + q];
                a[(i - 1) * self.rows + r] += (1.0 - f) * v;
                a[i * self.rows + r] += f * v;
            }
        }
        a
    }
}

/// Equations of band j: readings and their σ.
pub(super) fn band_equations(
    p: &TransmissionProblem,
    j: usize,
    opts: &TransmissionOptions,
    pixel_sigma: &[f64],
) -> (Vec<f64>, Vec<f64>) {
    let y: Vec<f64> = p
        .captures
        .iter()
        .flat_map(|c| c.readings.rgb[j].to_vec())
        .collect();
    let ymax = y.iter().fold(0.0f64, |a, v| a.max(v.abs()));
    let floor = (opts.noise_floor * ymax).max(1e-300);
    if !opts.use_std {
        let n = y.len();
        return (y, vec![1.0; n]);
    }
    let sigma = p
        .captures
        .iter()
        .enumerate()
        .flat_map(|(k, c)| {
            let sp = pixel_sigma[k];
            (0..3).map(move |ch| {
                let s = c.readings.std[j][ch];
                let base = (s * s + floor * floor).sqrt();
                // Dark-reading rule: a mean of pixels clipped at zero is biased by up to
                // ≈ 0.4 σ_pixel, which averaging does not remove.
                if c.readings.rgb[j][ch] < DARK_SIGMAS * sp {
                    base.max(DARK_FRACTION * sp)
                } else {
                    base
                }
            })
        })
        .collect();
    (y, sigma)
}

/// Per-pixel noise of each capture: the median over bands and channels of se·√pixels.
pub(super) fn pixel_noise(p: &TransmissionProblem) -> Vec<f64> {
    p.captures
        .iter()
        .map(|c| {
            let mut v: Vec<f64> = c
                .readings
                .std
                .iter()
                .zip(&c.readings.pixels)
                .flat_map(|(s, &n)| s.map(|x| x * (n.max(1) as f64).sqrt()))
                .filter(|x| x.is_finite())
                .collect();
            if v.is_empty() {
                return 0.0;
            }
            v.sort_by(|a, b| a.partial_cmp(b).unwrap_or(std::cmp::Ordering::Equal));
            v[v.len() / 2]
        })
        .collect()
}
