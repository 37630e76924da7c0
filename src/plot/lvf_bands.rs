//! Chart of solved LVF band transmissions: every band's T_j(λ) (coloured by its nominal
//! wavelength, ± std shaded for the free-shape models) above, and per band the fitted centre
//! minus nominal and the FWHM below.

use std::path::Path;

use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, VPos};

use super::{
    draw_curve, draw_err, draw_text, fit_text, render_png_bytes, spectral_axes, AxesSpec, TextSpec,
    INK,
};
use crate::error::{Error, Result};
use crate::lvf::transmission::{BandModel, BandSet};

const SIZE_PX: (u32, u32) = (1400, 1000);
const TITLE_H: i32 = 60;
const CENTRE_RGB: [u8; 3] = [40, 80, 210];
const FWHM_RGB: [u8; 3] = [200, 90, 20];

/// A dark-enough colour for a band at `nm` (violet → red), readable on white.
fn band_colour(nm: f64) -> [u8; 3] {
    // Piecewise-linear hue ramp over 400–700 nm, kept below ~75 % luminance.
    let stops: [(f64, [f64; 3]); 7] = [
        (400.0, [110.0, 0.0, 160.0]),
        (450.0, [30.0, 40.0, 220.0]),
        (490.0, [0.0, 140.0, 190.0]),
        (530.0, [20.0, 150.0, 40.0]),
        (575.0, [180.0, 160.0, 0.0]),
        (610.0, [230.0, 100.0, 0.0]),
        (700.0, [170.0, 0.0, 0.0]),
    ];
    let x = nm.clamp(stops[0].0, stops[6].0);
    let i = stops
        .iter()
        .rposition(|s| s.0 <= x)
        .unwrap_or(0)
        .min(stops.len() - 2);
    let (a, b) = (stops[i], stops[i + 1]);
    let f = (x - a.0) / (b.0 - a.0);
    std::array::from_fn(|k| (a.1[k] + f * (b.1[k] - a.1[k])).round() as u8)
}

/// Writes the band chart (1400 × 1000 px PNG) to `path`.
///
/// # Errors
/// [`Error::InvalidArgument`] for an empty set; [`Error::Io`] on write.
pub fn lvf_bands_chart(path: &Path, set: &BandSet) -> Result<()> {
    crate::io::atomic_write(path, &lvf_bands_chart_png(set)?)
}

/// The same chart as [`lvf_bands_chart`], encoded as PNG in memory (for staged outputs).
pub fn lvf_bands_chart_png(set: &BandSet) -> Result<Vec<u8>> {
    let g = &set.grid_nm;
    if g.len() < 2 || set.bands.is_empty() {
        return Err(Error::invalid(
            "plot",
            "the band set holds no transmissions",
        ));
    }
    let shade = matches!(set.model, BandModel::Nnls | BandModel::Lstsq);
    // The y range follows the typical band (1.5 × the 80th percentile of the peaks), so one
    // undetermined band at the edge of the grid does not flatten the others; curves are clipped.
    let mut peaks: Vec<f64> = set
        .bands
        .iter()
        .map(|b| {
            b.transmission
                .iter()
                .zip(&b.std)
                .map(|(t, s)| if shade { t + s.min(t.abs()) } else { *t })
                .filter(|v| v.is_finite())
                .fold(0.0f64, f64::max)
        })
        .collect();
    peaks.sort_by(|a, b| a.partial_cmp(b).unwrap_or(std::cmp::Ordering::Equal));
    let ymax = (1.5 * peaks[(peaks.len() * 4 / 5).min(peaks.len() - 1)]).max(1e-12);
    let ymin = set
        .bands
        .iter()
        .flat_map(|b| b.transmission.iter().copied())
        .filter(|v| v.is_finite())
        .fold(0.0f64, f64::min)
        .max(-ymax);
    let x_range = (g[0], g[g.len() - 1]);
    let nm: Vec<f64> = set.bands.iter().map(|b| b.nm).collect();
    let dc: Vec<f64> = set.bands.iter().map(|b| b.centre_nm - b.nm).collect();
    let sc: Vec<f64> = set
        .bands
        .iter()
        .map(|b| b.centre_sigma_nm.unwrap_or(0.0))
        .collect();
    let fw: Vec<f64> = set.bands.iter().map(|b| b.effective_fwhm_nm).collect();
    let finite_abs_max = |v: &[f64], s: &[f64]| {
        v.iter()
            .zip(s)
            .map(|(a, b)| a.abs() + b.min(5.0))
            .filter(|x| x.is_finite())
            .fold(0.0f64, f64::max)
    };
    let dmax = finite_abs_max(&dc, &sc).clamp(0.5, 20.0);
    let fmax = fw
        .iter()
        .cloned()
        .filter(|x| x.is_finite())
        .fold(0.0f64, f64::max);
    let fmin = fw
        .iter()
        .cloned()
        .filter(|x| x.is_finite() && *x > 0.0)
        .fold(f64::INFINITY, f64::min);
    let (fmin, fmax) = if fmin.is_finite() && fmax > 0.0 {
        ((fmin - 2.0).max(0.0), fmax + 2.0)
    } else {
        (0.0, 50.0)
    };
    let nm_range = (nm[0] - 10.0, nm[nm.len() - 1] + 10.0);
    let title = format!(
        "LVF band transmissions: model {}, {} bands, grid {}–{} nm{}",
        set.model.name(),
        set.bands.len(),
        g[0],
        g[g.len() - 1],
        set.diagnostics
            .get("condition_number_band_median")
            .and_then(|v| v.as_f64())
            .map(|c| format!(", median band condition number {c:.2e}"))
            .unwrap_or_default()
    );
    render_png_bytes(SIZE_PX, |root| {
        let (w, _) = root.dim_in_pixel();
        let style = TextSpec::new(22.0, INK, HPos::Center, VPos::Center);
        let t = fit_text(&root, &title, style.size_px, w - 40)?;
        draw_text(&root, &t, (w as i32 / 2, TITLE_H / 2), style)?;
        let (_, body) = root.split_vertically(TITLE_H);
        let (top, bottom) = body.split_vertically(560);
        let mut chart = spectral_axes(
            &top,
            &AxesSpec {
                caption: None,
                x_label: "wavelength (nm)",
                y_label: "transmission T_j (relative)",
                x_range,
                y_range: (ymin, ymax * 1.05),
                n_ticks: (14, 8),
            },
        )?;
        for b in &set.bands {
            let c = band_colour(b.nm);
            if shade {
                let upper: Vec<(f64, f64)> = g
                    .iter()
                    .zip(b.transmission.iter().zip(&b.std))
                    .map(|(&x, (t, s))| (x, (t + s).min(ymax * 1.05)))
                    .collect();
                let lower: Vec<(f64, f64)> = g
                    .iter()
                    .zip(b.transmission.iter().zip(&b.std))
                    .rev()
                    .map(|(&x, (t, s))| (x, (t - s).max(ymin)))
                    .collect();
                let poly: Vec<(f64, f64)> = upper.into_iter().chain(lower).collect();
                if poly.iter().all(|(x, y)| x.is_finite() && y.is_finite()) {
                    chart
                        .draw_series(std::iter::once(Polygon::new(
                            poly,
                            RGBColor(c[0], c[1], c[2]).mix(0.18).filled(),
                        )))
                        .map_err(draw_err)?;
                }
            }
            let pts: Vec<(f64, f64)> = g
                .iter()
                .copied()
                .zip(b.transmission.iter().copied())
                .collect();
            draw_curve(&mut chart, &pts, c, 2)?;
        }
        let (left, right) = bottom.split_horizontally(700);
        let mut cchart = spectral_axes(
            &left,
            &AxesSpec {
                caption: Some("fitted centre − nominal (± σ)"),
                x_label: "nominal band wavelength (nm)",
                y_label: "Δ centre (nm)",
                x_range: nm_range,
                y_range: (-1.1 * dmax, 1.1 * dmax),
                n_ticks: (8, 6),
            },
        )?;
        cchart
            .draw_series(LineSeries::new(
                [(nm_range.0, 0.0), (nm_range.1, 0.0)],
                RGBColor(150, 150, 150).stroke_width(1),
            ))
            .map_err(draw_err)?;
        let col = RGBColor(CENTRE_RGB[0], CENTRE_RGB[1], CENTRE_RGB[2]);
        for ((&x, &d), &s) in nm.iter().zip(&dc).zip(&sc) {
            if !d.is_finite() {
                continue;
            }
            let lim = 1.1 * dmax;
            if s > 0.0 && s.is_finite() {
                cchart
                    .draw_series(LineSeries::new(
                        [(x, (d - s).clamp(-lim, lim)), (x, (d + s).clamp(-lim, lim))],
                        col.stroke_width(2),
                    ))
                    .map_err(draw_err)?;
            }
            cchart
                .draw_series(std::iter::once(Circle::new(
                    (x, d.clamp(-lim, lim)),
                    4,
                    col.filled(),
                )))
                .map_err(draw_err)?;
        }
        let mut fchart = spectral_axes(
            &right,
            &AxesSpec {
                caption: Some("effective band FWHM"),
                x_label: "nominal band wavelength (nm)",
                y_label: "FWHM (nm)",
                x_range: nm_range,
                y_range: (fmin, fmax),
                n_ticks: (8, 6),
            },
        )?;
        let fcol = RGBColor(FWHM_RGB[0], FWHM_RGB[1], FWHM_RGB[2]);
        for (b, &f) in set.bands.iter().zip(&fw) {
            if !f.is_finite() || f <= 0.0 || f < fmin || f > fmax {
                continue;
            }
            if let Some(s) = b
                .effective_fwhm_sigma_nm
                .filter(|s| s.is_finite() && *s > 0.0)
            {
                fchart
                    .draw_series(LineSeries::new(
                        [(b.nm, (f - s).max(fmin)), (b.nm, (f + s).min(fmax))],
                        fcol.stroke_width(2),
                    ))
                    .map_err(draw_err)?;
            }
            fchart
                .draw_series(std::iter::once(Circle::new((b.nm, f), 4, fcol.filled())))
                .map_err(draw_err)?;
        }
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn band_colours_run_from_violet_to_red() {
        let v = band_colour(400.0);
        let r = band_colour(700.0);
        assert!(v[2] > v[0] && r[0] > r[2]);
        assert_eq!(band_colour(380.0), v);
    }
}
