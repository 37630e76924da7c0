//! A general multi-line spectral plot with a legend beside the plotting area.
//!
//! The legend sits in its own column to the right of the axes, so it never covers a curve. Axes
//! span the union of the series' wavelength ranges and their values (always including 0).

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, VPos};

use super::{
    draw_curve, draw_err, draw_text, fit_text, needs_halo, render_png, spectral_axes, text_width,
    AxesSpec, TextSpec, INK, MUTED_INK,
};
use crate::error::{Error, Result};
use crate::spectrum::Spectrum;

/// Figure size in pixels.
const SIZE_PX: (u32, u32) = (1400, 800);
/// Height of the title band.
const TITLE_H: i32 = 64;
/// Legend column width limits in pixels.
const LEGEND_W_MIN: u32 = 170;
const LEGEND_W_MAX: u32 = 420;
/// Legend row height and font size in pixels.
const LEGEND_ROW_H: i32 = 28;
const LEGEND_FONT_PX: f64 = 16.0;

/// Writes a line plot (1400 × 800 px PNG) of several spectra to `path`.
///
/// `series` holds, per curve, the legend label, the spectrum and the 8-bit sRGB line colour.
/// Light colours get a faint dark halo so they stay visible on the white background. The legend
/// is a column right of the axes, so it never covers a curve; labels too long for it are
/// shortened with "…", and series that do not fit are summarised as "… and N more".
///
/// # Errors
/// [`Error::InvalidArgument`] when `series` is empty or holds no finite point; [`Error::Io`] when
/// the file cannot be written (nothing is left behind).
pub fn spectra_chart(
    path: &Path,
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[(String, &Spectrum, [u8; 3])],
) -> Result<()> {
    if series.is_empty() {
        return Err(Error::invalid(
            "series",
            "no spectra to plot; expected at least one",
        ));
    }
    let (x_range, y_range) = data_ranges(series)?;
    render_png(path, SIZE_PX, |root| {
        let (w, _) = root.dim_in_pixel();
        let style = TextSpec::new(28.0, INK, HPos::Center, VPos::Center);
        let title = fit_text(&root, title, style.size_px, w - 40)?;
        draw_text(&root, &title, (w as i32 / 2, TITLE_H / 2 + 4), style)?;
        let (_, body) = root.split_vertically(TITLE_H);

        let mut widest = 0;
        for (label, _, _) in series {
            widest = widest.max(text_width(&body, label, LEGEND_FONT_PX)?);
        }
        let legend_w = (widest + 80).clamp(LEGEND_W_MIN, LEGEND_W_MAX);
        let (w_body, _) = body.dim_in_pixel();
        let (plot_area, legend_area) = body.split_horizontally(w_body - legend_w);

        let mut chart = spectral_axes(
            &plot_area,
            &AxesSpec {
                caption: None,
                x_label,
                y_label,
                x_range,
                y_range,
                n_ticks: (10, 10),
            },
        )?;
        for (_, sd, colour) in series {
            let pts: Vec<(f64, f64)> = sd
                .wavelengths()
                .iter()
                .copied()
                .zip(sd.values().iter().copied())
                .collect();
            draw_curve(&mut chart, &pts, *colour, 2)?;
        }
        draw_legend(&legend_area, series)
    })
}

/// Axis ranges covering every finite point; y always includes 0 and gets 5 % headroom.
fn data_ranges(series: &[(String, &Spectrum, [u8; 3])]) -> Result<((f64, f64), (f64, f64))> {
    let (mut x0, mut x1) = (f64::INFINITY, f64::NEG_INFINITY);
    let (mut y0, mut y1) = (0.0f64, f64::NEG_INFINITY);
    for (_, sd, _) in series {
        for (&x, &y) in sd.wavelengths().iter().zip(sd.values()) {
            if x.is_finite() && y.is_finite() {
                x0 = x0.min(x);
                x1 = x1.max(x);
                y0 = y0.min(y);
                y1 = y1.max(y);
            }
        }
    }
    if !x0.is_finite() || !y1.is_finite() {
        return Err(Error::invalid(
            "series",
            "no finite data point in any spectrum",
        ));
    }
    if x1 <= x0 {
        x0 -= 1.0;
        x1 += 1.0;
    }
    let span = y1 - y0;
    if span <= 0.0 {
        y1 = y0 + 1.0;
    } else {
        y1 += 0.05 * span;
        if y0 < 0.0 {
            y0 -= 0.05 * span;
        }
    }
    Ok(((x0, x1), (y0, y1)))
}

/// The legend column: a line sample and the label per series, top to bottom.
fn draw_legend<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    series: &[(String, &Spectrum, [u8; 3])],
) -> Result<()> {
    let (w, h) = area.dim_in_pixel();
    let (w, h) = (w as i32, h as i32);
    let x0 = 4;
    let sample_w = 34;
    let mut y = 40;
    let max_rows = ((h - 60 - y) / LEGEND_ROW_H).max(1) as usize;
    let shown = if series.len() > max_rows {
        max_rows - 1
    } else {
        series.len()
    };
    let spec = TextSpec::new(LEGEND_FONT_PX, INK, HPos::Left, VPos::Center);
    let text_x = x0 + sample_w + 10;
    for (label, _, c) in &series[..shown] {
        let sample = vec![(x0, y), (x0 + sample_w, y)];
        if needs_halo(*c) {
            let halo = RGBColor(40, 40, 40).mix(0.4).stroke_width(4);
            area.draw(&PathElement::new(sample.clone(), halo))
                .map_err(draw_err)?;
        }
        area.draw(&PathElement::new(
            sample,
            RGBColor(c[0], c[1], c[2]).stroke_width(2),
        ))
        .map_err(draw_err)?;
        let max_w = (w - text_x - 16).max(0) as u32;
        let text = fit_text(area, label, spec.size_px, max_w)?;
        draw_text(area, &text, (text_x, y), spec)?;
        y += LEGEND_ROW_H;
    }
    if shown < series.len() {
        let more = format!("… and {} more", series.len() - shown);
        draw_text(area, &more, (text_x, y), spec.with_colour(MUTED_INK))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::super::tests::{decode, is_single_colour, smooth_spectrum};
    use super::*;

    fn sample_spectra() -> Vec<Spectrum> {
        (0..5).map(|i| smooth_spectrum(i * 4)).collect()
    }

    fn series(spectra: &[Spectrum]) -> Vec<(String, &Spectrum, [u8; 3])> {
        const COLOURS: [[u8; 3]; 5] = [
            [200, 40, 40],
            [40, 140, 60],
            [40, 80, 200],
            [240, 220, 60],
            [250, 250, 250],
        ];
        spectra
            .iter()
            .zip(COLOURS)
            .map(|(sd, c)| (format!("{} (synthetic)", sd.name()), sd, c))
            .collect()
    }

    #[test]
    fn spectra_chart_writes_a_decodable_png_of_the_expected_size() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("spectra.png");
        let spectra = sample_spectra();
        spectra_chart(
            &path,
            "Synthetic reflectances",
            "wavelength (nm)",
            "reflectance factor",
            &series(&spectra),
        )
        .expect("chart renders");
        let img = decode(&path);
        assert_eq!(img.dimensions(), SIZE_PX);
        assert!(!is_single_colour(&img));
    }

    #[test]
    fn spectra_chart_into_a_missing_directory_fails_and_leaves_nothing() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("missing").join("spectra.png");
        let spectra = sample_spectra();
        let err = spectra_chart(&path, "t", "x", "y", &series(&spectra));
        assert!(matches!(err, Err(Error::Io { .. })), "{err:?}");
        assert!(!path.exists());
        assert_eq!(std::fs::read_dir(dir.path()).expect("dir").count(), 0);
    }

    #[test]
    fn spectra_chart_rejects_an_empty_series_list() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("spectra.png");
        let err = spectra_chart(&path, "t", "x", "y", &[]);
        assert!(matches!(err, Err(Error::InvalidArgument { .. })), "{err:?}");
        assert!(!path.exists());
    }

    #[test]
    fn data_ranges_include_zero_and_leave_headroom() {
        let spectra = sample_spectra();
        let ((x0, x1), (y0, y1)) = data_ranges(&series(&spectra)).expect("ranges");
        assert_eq!((x0, x1), (380.0, 780.0));
        assert_eq!(y0, 0.0);
        let max = spectra
            .iter()
            .flat_map(|sd| sd.values().iter().copied())
            .fold(f64::NEG_INFINITY, f64::max);
        assert!(y1 > max && y1 <= 1.06 * max, "y1 = {y1}, max = {max}");
    }

    /// Writes a sample to `/tmp/plot_check_spectra.png` for a visual check.
    #[test]
    #[ignore]
    fn write_visual_check_spectra_chart() {
        let spectra = sample_spectra();
        spectra_chart(
            Path::new("/tmp/plot_check_spectra.png"),
            "Synthetic reflectances",
            "wavelength (nm)",
            "reflectance factor",
            &series(&spectra),
        )
        .expect("chart renders");
    }
}
