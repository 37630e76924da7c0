//! The driver over all bands and the free-shape (NNLS / least-squares) solve of one band.

#![allow(clippy::needless_range_loop)]

use super::*;

/// Solves every band's transmission.
///
/// # Errors
/// [`Error::InvalidArgument`] / [`Error::ShapeMismatch`] for inconsistent or invalid data (sizes,
/// negative spectra, band counts, all-zero captures, a grid outside the quadrature range, a
/// support window with fewer than 3 grid points); the [`solve_regularized`] errors;
/// `calibration` is rejected here (use [`calibration_bands`]).
pub fn solve_transmissions(
    geometry: &LvfGeometry,
    lvf: serde_json::Value,
    problem: &TransmissionProblem,
    opts: &TransmissionOptions,
) -> Result<BandSet> {
    let nb = geometry.bands.len();
    let step = validate(problem, nb)?;
    let grid = &opts.grid_nm;
    check_grid(grid)?;
    let (q0, q1) = (
        problem.quad_nm[0],
        problem.quad_nm[problem.quad_nm.len() - 1],
    );
    if grid[0] < q0 - 1e-9 || grid[grid.len() - 1] > q1 + 1e-9 {
        return Err(Error::invalid(
            "grid",
            format!(
                "{}–{} nm reaches beyond the quadrature grid {q0}–{q1} nm",
                grid[0],
                grid[grid.len() - 1]
            ),
        ));
    }
    if opts.support_fwhm.is_nan()
        || opts.support_fwhm <= 0.0
        || opts.noise_floor.is_nan()
        || opts.noise_floor < 0.0
    {
        return Err(Error::invalid(
            "options",
            "support_fwhm must be > 0 and noise_floor ≥ 0",
        ));
    }
    let design = Design::new(problem, step);
    let a_full = design.on_grid(&problem.quad_nm, grid);
    let m = design.rows;
    let n = grid.len();
    let cond_full = condition_number(&a_full, m, n);
    // Wavelengths where the gels differ from their end values (outside, all are held constant).
    let gel_range = gel_varying_range(problem);
    let cond_gel = gel_range.and_then(|(lo, hi)| {
        let cols: Vec<usize> = (0..n)
            .filter(|&i| grid[i] >= lo - 1e-9 && grid[i] <= hi + 1e-9)
            .collect();
        if cols.len() == n || cols.len() < 3 {
            return None;
        }
        let sub: Vec<f64> = cols
            .iter()
            .flat_map(|&i| a_full[i * m..(i + 1) * m].to_vec())
            .collect();
        Some(condition_number(&sub, m, cols.len()))
    });
    let pixel_sigma = pixel_noise(problem);
    let mut bands = Vec::with_capacity(nb);
    let mut not_converged = Vec::new();
    let mut at_bound = Vec::new();
    for j in 0..nb {
        let (y, sigma) = band_equations(problem, j, opts, &pixel_sigma);
        let band = match opts.model {
            BandModel::Nnls | BandModel::Lstsq => {
                free_band(geometry, j, grid, &a_full, m, &y, &sigma, opts)?
            }
            BandModel::Gaussian | BandModel::SuperGaussian => {
                let (b, ok, bound) = parametric_band(
                    geometry,
                    j,
                    grid,
                    problem,
                    &design,
                    &y,
                    &sigma,
                    opts.model == BandModel::SuperGaussian,
                )?;
                if !ok {
                    not_converged.push(j);
                }
                if bound {
                    at_bound.push(j);
                }
                b
            }
            BandModel::Calibration => {
                return Err(Error::invalid(
                    "model",
                    "the calibration model needs no photos; use calibration_bands",
                ))
            }
        };
        bands.push(band);
    }
    let conds: Vec<f64> = bands.iter().filter_map(|b| b.condition_number).collect();
    let mut rms: Vec<f64> = bands.iter().filter_map(|b| b.rms_residual).collect();
    rms.sort_by(|a, b| a.partial_cmp(b).unwrap_or(std::cmp::Ordering::Equal));
    let median = |v: &[f64]| -> Option<f64> {
        if v.is_empty() {
            None
        } else {
            let mut s = v.to_vec();
            s.sort_by(|a, b| a.partial_cmp(b).unwrap_or(std::cmp::Ordering::Equal));
            Some(s[s.len() / 2])
        }
    };
    let free = matches!(opts.model, BandModel::Nnls | BandModel::Lstsq);
    let diag = TransmissionDiagnostics {
        n_captures: problem.captures.len(),
        n_gels: problem
            .captures
            .iter()
            .filter(|c| c.filter.is_some())
            .count(),
        equations_per_band: m,
        grid_unknowns: n,
        condition_number_full_grid: cond_full,
        condition_number_gel_range: cond_gel,
        condition_number_band_median: median(&conds),
        condition_number_band_max: conds.iter().cloned().reduce(f64::max),
        quadrature_step_nm: step,
        support_fwhm: opts.support_fwhm,
        prior: if free {
            format!("T_j = 0 outside its calibrated centre ± {} × its effective calibration FWHM (support_nm per band){}", opts.support_fwhm, match opts.model {
                BandModel::Nnls if opts.nonnegative => "; T_j ≥ 0; second-difference smoothness",
                BandModel::Nnls => "; second-difference smoothness (no sign constraint)",
                _ => "; no penalty, no sign constraint (plain least squares)",
            })
        } else {
            "passband shape g(x) = exp(−ln2·|2x/w|^(2e)) averaged over the band's window, peak ≥ 0"
                .to_string()
        },
        weighted: opts.use_std,
        noise_floor: opts.noise_floor,
        nonnegative: opts.model == BandModel::Nnls && opts.nonnegative,
        rms_residual_median: median(&rms).unwrap_or(f64::NAN),
        not_converged,
        at_bound,
    };
    Ok(BandSet {
        schema: BANDS_SCHEMA.to_string(),
        model: opts.model,
        lvf,
        grid_nm: grid.clone(),
        bands,
        diagnostics: serde_json::to_value(&diag)
            .map_err(|e| Error::invalid("diagnostics", e.to_string()))?,
    })
}

/// The range where at least one gel differs from its end values; None without gels.
pub(super) fn gel_varying_range(p: &TransmissionProblem) -> Option<(f64, f64)> {
    let mut lo = f64::INFINITY;
    let mut hi = f64::NEG_INFINITY;
    for c in &p.captures {
        let Some(f) = &c.filter else { continue };
        let n = f.len();
        let first = f
            .iter()
            .position(|&v| v != f[0])
            .map(|i| i.saturating_sub(1));
        let last = f
            .iter()
            .rposition(|&v| v != f[n - 1])
            .map(|i| (i + 1).min(n - 1));
        if let (Some(a), Some(b)) = (first, last) {
            lo = lo.min(p.quad_nm[a]);
            hi = hi.max(p.quad_nm[b]);
        }
    }
    (lo < hi).then_some((lo, hi))
}

#[allow(clippy::too_many_arguments)]
pub(super) fn free_band(
    geometry: &LvfGeometry,
    j: usize,
    grid: &[f64],
    a_full: &[f64],
    m: usize,
    y: &[f64],
    sigma: &[f64],
    opts: &TransmissionOptions,
) -> Result<BandTransmission> {
    let b = &geometry.bands[j];
    let (c_cal, w_cal) = calibration_band_shape(geometry, j);
    let (lo, hi) = (
        c_cal - opts.support_fwhm * w_cal,
        c_cal + opts.support_fwhm * w_cal,
    );
    let cols: Vec<usize> = (0..grid.len())
        .filter(|&i| grid[i] >= lo && grid[i] <= hi)
        .collect();
    if cols.len() < 3 {
        return Err(Error::invalid(
            "grid",
            format!("band {} ({} nm): its support {lo:.1}–{hi:.1} nm holds {} grid points; expected ≥ 3 (widen or refine the grid)", j + 1, b.nm, cols.len()),
        ));
    }
    let nc = cols.len();
    let mut a = Vec::with_capacity(m * nc);
    for &i in &cols {
        for r in 0..m {
            a.push(a_full[i * m + r] / sigma[r]);
        }
    }
    let yw: Vec<f64> = y.iter().zip(sigma).map(|(v, s)| v / s).collect();
    // λ = 0 (or the lstsq model) is plain least squares: QR / NNLS without a penalty.
    let plain = opts.model == BandModel::Lstsq || opts.weight == Weight::Fixed(0.0);
    // Second differences padded with zeros beyond the support edges (an edge set by the grid
    // instead of the support is not padded); robust GCV, see the module docs.
    let ro = RegularizedOptions {
        smoothness: Smoothness::SecondPadded {
            left: grid[cols[0]] > grid[0],
            right: grid[cols[nc - 1]] < grid[grid.len() - 1],
        },
        weight: if plain {
            Weight::Fixed(0.0)
        } else {
            opts.weight
        },
        nonnegative: opts.model == BandModel::Nnls && opts.nonnegative,
        max_effective_parameters: None,
        robust_gcv: Some(ROBUST_GCV_GAMMA),
    };
    let sol = solve_regularized(&a, m, nc, &yw, &ro).map_err(|e| band_error(e, j, b.nm))?;
    let mut t = vec![0.0; grid.len()];
    let mut sd = vec![0.0; grid.len()];
    for (k, &i) in cols.iter().enumerate() {
        t[i] = sol.x[k];
        sd[i] = if sol.std[k].is_finite() {
            sol.std[k]
        } else {
            f64::MAX.sqrt()
        };
    }
    let raw: Vec<f64> = sol
        .residuals
        .iter()
        .zip(sigma)
        .map(|(r, s)| r * s)
        .collect();
    let rms = (raw.iter().map(|r| r * r).sum::<f64>() / raw.len() as f64).sqrt();
    let (centre, centre_sigma) = centroid(grid, &t, &sd);
    let hm = half_max_width(grid, &t);
    let peak = t.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    let width = hm.map(|v| v.0).unwrap_or(f64::NAN);
    Ok(BandTransmission {
        nm: b.nm,
        px: b.px,
        width_px: b.width_px,
        centre_nm: finite_or(centre, c_cal),
        centre_sigma_nm: centre_sigma.is_finite().then_some(centre_sigma),
        fwhm_nm: finite_or(width, 0.0),
        fwhm_sigma_nm: None,
        effective_fwhm_nm: finite_or(width, 0.0),
        effective_fwhm_sigma_nm: None,
        peak,
        peak_sigma: None,
        exponent: None,
        exponent_sigma: None,
        transmission: t,
        std: sd,
        rms_residual: Some(rms),
        lambda: Some(sol.lambda),
        condition_number: Some(sol.condition_number),
        support_nm: Some([grid[cols[0]], grid[cols[nc - 1]]]),
        n_clamped: Some(sol.n_clamped),
    })
}

pub(super) fn band_error(e: Error, j: usize, nm: f64) -> Error {
    match e {
        Error::InvalidArgument { field, message } => Error::InvalidArgument {
            field,
            message: format!("band {} ({nm} nm): {message}", j + 1),
        },
        other => other,
    }
}

pub(super) fn finite_or(v: f64, alt: f64) -> f64 {
    if v.is_finite() {
        v
    } else {
        alt
    }
}
