//! Wavelength grids and the calibration-only bands.

#![allow(clippy::needless_range_loop)]

use super::*;

/// A uniform grid lo, lo + step, …, ≤ hi.
pub fn uniform_grid(lo: f64, hi: f64, step: f64) -> Result<Vec<f64>> {
    if !(step > 0.0 && lo.is_finite() && hi.is_finite() && hi > lo) {
        return Err(Error::invalid(
            "--grid",
            format!("{lo}:{hi}:{step}; expected LO < HI and STEP > 0"),
        ));
    }
    let n = ((hi - lo) / step + 1e-9).floor() as usize + 1;
    if !(3..=100_000).contains(&n) {
        return Err(Error::invalid(
            "--grid",
            format!("{lo}:{hi}:{step} gives {n} wavelengths; expected 3 to 100000"),
        ));
    }
    Ok((0..n).map(|i| lo + step * i as f64).collect())
}

/// Centre (window-mean λ) and effective FWHM (half-max width of the window-averaged passband
/// of the calibration's FWHM) of band `j`.
pub fn calibration_band_shape(geometry: &LvfGeometry, j: usize) -> (f64, f64) {
    let win = geometry.window(j);
    let c = win.iter().map(|&p| geometry.wavelength_at(p)).sum::<f64>() / win.len() as f64;
    let span = 3.0 * geometry.fwhm_nm
        + win
            .iter()
            .map(|&p| (geometry.wavelength_at(p) - c).abs())
            .fold(0.0, f64::max);
    let fine: Vec<f64> =
        uniform_grid(c - span, c + span, geometry.fwhm_nm / 200.0).unwrap_or_default();
    let t = geometry.parametric_band(j, &fine, geometry.fwhm_nm, 1.0);
    let w = half_max_width(&fine, &t)
        .map(|v| v.0)
        .unwrap_or(geometry.fwhm_nm);
    (c, w)
}

/// The default solve grid: `step` nm over the bands' support (calibrated centres ± `support_fwhm`
/// effective FWHMs), snapped outwards to multiples of `step`, then clipped inwards to
/// `coverage` (what source, target and camera cover) when given.
///
/// # Errors
/// [`Error::InvalidArgument`] when the clipped range holds fewer than 3 wavelengths.
pub fn default_grid(
    geometry: &LvfGeometry,
    support_fwhm: f64,
    step: f64,
    coverage: Option<(f64, f64)>,
) -> Result<Vec<f64>> {
    let mut lo = f64::INFINITY;
    let mut hi = f64::NEG_INFINITY;
    for j in 0..geometry.bands.len() {
        let (c, w) = calibration_band_shape(geometry, j);
        lo = lo.min(c - support_fwhm * w);
        hi = hi.max(c + support_fwhm * w);
    }
    let mut lo = (lo / step).floor() * step;
    let mut hi = (hi / step).ceil() * step;
    if let Some((a, b)) = coverage {
        lo = lo.max((a / step - 1e-9).ceil() * step);
        hi = hi.min((b / step + 1e-9).floor() * step);
    }
    uniform_grid(lo, hi, step).map_err(|_| {
        Error::invalid(
            "--grid",
            format!("the bands' support {lo}–{hi} nm clipped to what source, target and camera cover leaves fewer than 3 wavelengths"),
        )
    })
}

/// The `calibration` model: each band the window-averaged Gaussian of the calibration's FWHM,
/// centred by the map, peak 1, on `grid`. `std` is the effect of the FWHM's uncertainty.
///
/// # Errors
/// [`Error::InvalidArgument`] for a grid that is not strictly increasing or has fewer than 2 points.
pub fn calibration_bands(
    geometry: &LvfGeometry,
    lvf: serde_json::Value,
    grid: &[f64],
) -> Result<BandSet> {
    check_grid(grid)?;
    let f = geometry.fwhm_nm;
    let sf = geometry.fwhm_sigma_nm;
    let h = (f * 1e-4).max(1e-6);
    let bands = (0..geometry.bands.len())
        .map(|j| {
            let b = &geometry.bands[j];
            let t = geometry.parametric_band(j, grid, f, 1.0);
            let tp = geometry.parametric_band(j, grid, f + h, 1.0);
            let tm = geometry.parametric_band(j, grid, f - h, 1.0);
            let std = tp
                .iter()
                .zip(&tm)
                .map(|(a, b)| ((a - b) / (2.0 * h) * sf).abs())
                .collect();
            let (c, w) = calibration_band_shape(geometry, j);
            BandTransmission {
                nm: b.nm,
                px: b.px,
                width_px: b.width_px,
                centre_nm: c,
                centre_sigma_nm: None,
                fwhm_nm: f,
                fwhm_sigma_nm: Some(sf),
                effective_fwhm_nm: w,
                effective_fwhm_sigma_nm: Some(sf * w / f),
                peak: 1.0,
                peak_sigma: None,
                exponent: Some(1.0),
                exponent_sigma: None,
                transmission: t,
                std,
                rms_residual: None,
                lambda: None,
                condition_number: None,
                support_nm: None,
                n_clamped: None,
            }
        })
        .collect();
    Ok(BandSet {
        schema: BANDS_SCHEMA.to_string(),
        model: BandModel::Calibration,
        lvf,
        grid_nm: grid.to_vec(),
        bands,
        diagnostics: serde_json::json!({
            "note": "parametric bands from the wavelength calibration alone (centre from the map, FWHM from the lamp fit, peak 1); no gel photos",
        }),
    })
}

pub(super) fn check_grid(grid: &[f64]) -> Result<()> {
    if grid.len() < 2
        || grid.iter().any(|v| !v.is_finite())
        || grid.windows(2).any(|w| w[1] <= w[0])
    {
        return Err(Error::invalid(
            "grid",
            format!(
                "{} wavelengths; expected at least 2, finite and strictly increasing",
                grid.len()
            ),
        ));
    }
    Ok(())
}
