//! Chart of a recovered spectrum: the value with a ±2σ noise band, optional reference curves, and
//! below it the effective resolution (what the bands can resolve at each wavelength).

use std::path::Path;

use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, VPos};

use super::{
    draw_curve, draw_err, draw_text, fit_text, render_png_bytes, spectral_axes, AxesSpec, TextSpec,
    INK,
};
use crate::error::{Error, Result};
use crate::recovery::Recovered;

const SIZE_PX: (u32, u32) = (1400, 950);
const TITLE_H: i32 = 60;
const VALUE_RGB: [u8; 3] = [20, 60, 170];
const BAND_RGB: RGBColor = RGBColor(180, 195, 235);
const REFERENCE_RGB: [[u8; 3]; 3] = [[200, 60, 30], [40, 140, 60], [120, 60, 160]];

/// A reference curve drawn over the recovery: (label, wavelengths nm, values).
pub type Reference<'a> = (&'a str, &'a [f64], &'a [f64]);

/// Writes the recovery chart (1400 × 950 px PNG) to `path`: `rec` with ±2σ, each reference
/// curve, and the resolution per wavelength below. `y_label` names the quantity.
///
/// # Errors
/// [`Error::InvalidArgument`] for an empty recovery or a reference whose sizes differ;
/// [`Error::Io`] on write.
pub fn recovery_chart(
    path: &Path,
    title: &str,
    y_label: &str,
    rec: &Recovered,
    references: &[Reference<'_>],
) -> Result<()> {
    crate::io::atomic_write(path, &recovery_chart_png(title, y_label, rec, references)?)
}

/// The same chart as [`recovery_chart`], encoded as PNG in memory (for staged outputs).
pub fn recovery_chart_png(
    title: &str,
    y_label: &str,
    rec: &Recovered,
    references: &[Reference<'_>],
) -> Result<Vec<u8>> {
    let wl = &rec.wavelength_nm;
    if wl.len() < 2 || rec.value.len() != wl.len() || rec.std.len() != wl.len() {
        return Err(Error::invalid(
            "plot",
            "the recovery holds no spectrum to plot",
        ));
    }
    for (name, x, y) in references {
        if x.len() != y.len() || x.is_empty() {
            return Err(Error::invalid(
                "plot",
                format!(
                    "reference '{name}': {} wavelengths for {} values",
                    x.len(),
                    y.len()
                ),
            ));
        }
    }
    let x_range = (wl[0], wl[wl.len() - 1]);
    let in_range = |x: f64| x >= x_range.0 && x <= x_range.1;
    let mut ymax = rec
        .value
        .iter()
        .zip(&rec.std)
        .map(|(v, s)| v + 2.0 * s)
        .fold(0.0f64, f64::max);
    for (_, x, y) in references {
        for (a, b) in x.iter().zip(y.iter()) {
            if in_range(*a) && b.is_finite() {
                ymax = ymax.max(*b);
            }
        }
    }
    let ymax = if ymax > 0.0 { ymax * 1.08 } else { 1.0 };
    let res: Vec<(f64, f64)> = wl
        .iter()
        .zip(&rec.resolution_nm)
        .filter(|(_, r)| r.is_finite())
        .map(|(a, b)| (*a, *b))
        .collect();
    let rmax = res.iter().map(|p| p.1).fold(0.0f64, f64::max).max(1.0) * 1.15;
    let full_title = format!(
        "{title} — λ {:.3e}{} · {} equations, {} unknowns · residual {:.2} %",
        rec.lambda,
        if rec.lambda_from_gcv { " (GCV)" } else { "" },
        rec.equations,
        rec.unknowns,
        100.0 * rec.relative_residual
    );
    render_png_bytes(SIZE_PX, |root| {
        let (w, _) = root.dim_in_pixel();
        let style = TextSpec::new(22.0, INK, HPos::Center, VPos::Center);
        let t = fit_text(&root, &full_title, style.size_px, w - 40)?;
        draw_text(&root, &t, (w as i32 / 2, TITLE_H / 2), style)?;
        let (_, body) = root.split_vertically(TITLE_H);
        let (top, bottom) = body.split_vertically(620);
        let mut chart = spectral_axes(
            &top,
            &AxesSpec {
                caption: None,
                x_label: "wavelength (nm)",
                y_label,
                x_range,
                y_range: (0.0, ymax),
                n_ticks: (13, 8),
            },
        )?;
        // ±2σ band as a polygon.
        let mut poly: Vec<(f64, f64)> = wl
            .iter()
            .zip(rec.value.iter().zip(&rec.std))
            .map(|(l, (v, s))| (*l, (v + 2.0 * s).min(ymax)))
            .collect();
        poly.extend(
            wl.iter()
                .zip(rec.value.iter().zip(&rec.std))
                .rev()
                .map(|(l, (v, s))| (*l, (v - 2.0 * s).max(0.0))),
        );
        chart
            .draw_series(std::iter::once(Polygon::new(poly, BAND_RGB.filled())))
            .map_err(draw_err)?
            .label("recovered ± 2σ (noise)")
            .legend(|(x, y)| Rectangle::new([(x, y - 6), (x + 20, y + 6)], BAND_RGB.filled()));
        for (k, (name, x, y)) in references.iter().enumerate() {
            let pts: Vec<(f64, f64)> = x
                .iter()
                .zip(y.iter())
                .filter(|(a, b)| in_range(**a) && b.is_finite())
                .map(|(a, b)| (*a, *b))
                .collect();
            let c = REFERENCE_RGB[k % REFERENCE_RGB.len()];
            draw_curve(&mut chart, &pts, c, 2)?;
            let colour = RGBColor(c[0], c[1], c[2]);
            chart
                .draw_series(std::iter::empty::<PathElement<(f64, f64)>>())
                .map_err(draw_err)?
                .label(name.to_string())
                .legend(move |(x, y)| {
                    PathElement::new([(x, y), (x + 20, y)], colour.stroke_width(3))
                });
        }
        let pts: Vec<(f64, f64)> = wl.iter().copied().zip(rec.value.iter().copied()).collect();
        draw_curve(&mut chart, &pts, VALUE_RGB, 3)?;
        let vc = RGBColor(VALUE_RGB[0], VALUE_RGB[1], VALUE_RGB[2]);
        chart
            .draw_series(pts.iter().map(|p| Circle::new(*p, 3, vc.filled())))
            .map_err(draw_err)?
            .label("recovered")
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], vc.stroke_width(3)));
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .background_style(WHITE.mix(0.85))
            .border_style(INK)
            .label_font(super::text_style(
                18.0,
                INK,
                plotters::style::text_anchor::Pos::new(HPos::Left, VPos::Center),
            ))
            .draw()
            .map_err(draw_err)?;
        let mut rchart = spectral_axes(
            &bottom,
            &AxesSpec {
                caption: None,
                x_label: "wavelength (nm)",
                y_label: "resolution FWHM (nm)",
                x_range,
                y_range: (0.0, rmax),
                n_ticks: (13, 5),
            },
        )?;
        draw_curve(&mut rchart, &res, [90, 90, 90], 2)?;
        Ok(())
    })
}
