//! PNG charts of spectra and rendered colours, drawn with `plotters`.
//!
//! Every chart is rendered into an in-memory RGB buffer, encoded to PNG with the `image` crate and
//! only then written with [`crate::io::atomic_write`], so a failed plot never leaves a partial or
//! clobbered file behind. Text uses the embedded DejaVu Sans font (`assets/DejaVuSans.ttf`, see
//! `assets/DejaVuSans.LICENSE`) through plotters' `ab_glyph` backend; no system fonts are read.
//! Titles, legends and axis descriptions are laid out by the private `text` module, which works
//! around plotters dropping glyph side bearings.
//!
//! Charts:
//! - [`colorchecker_chart`]: a swatch grid (one stripe per illuminant) beside the reflectance
//!   spectra of the patches, each curve in its swatch colour.
//! - [`spectra_chart`]: a general multi-line spectral plot with a legend.
//!
//! Like every L3 module, `plot` consumes domain types ([`crate::spectrum::Spectrum`]); domain
//! types have no `plot()` methods.

use std::path::Path;
use std::sync::OnceLock;

use image::codecs::png::PngEncoder;
use image::{ExtendedColorType, ImageEncoder};
use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use plotters::style::{register_font, FontStyle};

use crate::error::{Error, Result};

pub mod afterimage;
mod colorchecker;
pub mod dispersion;
mod fluor;
mod lvf;
pub mod lvf_bands;
pub mod maps;
mod phosphor;
mod phosphor_excitation;
pub mod phosphor_sim;
pub mod photometry;
pub mod preview;
pub mod recovery;
mod spectra;
mod text;

pub(crate) use text::{draw_text, fit_text, text_width, TextSpec};

pub use colorchecker::{colorchecker_chart, colorchecker_chart_png, SwatchPatch};
pub use fluor::{fluor_chart, fluor_chart_png, FluorChart};
pub use lvf::{lvf_chart, lvf_chart_png};
pub use phosphor::{decay_chart, decay_chart_png, integrator_chart, integrator_chart_png};
pub use phosphor_excitation::{excitation_chart, excitation_chart_png};
pub use spectra::spectra_chart;

/// Font family name under which the embedded DejaVu Sans is registered.
pub(crate) const FONT: &str = "sans-serif";

/// The embedded font (DejaVu Sans, Bitstream Vera licence; see `assets/DejaVuSans.LICENSE`).
pub(crate) static FONT_BYTES: &[u8] = include_bytes!("../../assets/DejaVuSans.ttf");

/// Whether registering the embedded font succeeded (registered once per process).
static FONT_REGISTERED: OnceLock<bool> = OnceLock::new();

/// Registers the embedded font with plotters (once per process).
fn ensure_font() -> Result<()> {
    let ok =
        *FONT_REGISTERED.get_or_init(|| register_font(FONT, FontStyle::Normal, FONT_BYTES).is_ok());
    if ok {
        Ok(())
    } else {
        Err(Error::invalid(
            "plot",
            "the embedded DejaVu Sans font could not be parsed",
        ))
    }
}

/// Text style in the embedded font: `size_px`, `colour`, anchored at `pos`.
pub(crate) fn text_style(size_px: f64, colour: RGBColor, pos: Pos) -> TextStyle<'static> {
    let mut style = TextStyle::from((FONT, size_px).into_font()).pos(pos);
    // `TextStyle::color` ties the style's lifetime to the colour reference; set the field directly.
    style.color = colour.to_backend_color();
    style
}

/// Maps a plotters drawing error into the library error.
pub(crate) fn draw_err(e: impl std::fmt::Display) -> Error {
    Error::invalid("plot", format!("drawing failed: {e}"))
}

/// Largest accepted image side in pixels (keeps the RGB buffer well below 1 GB).
const MAX_SIDE_PX: u32 = 16_384;

/// Renders a chart of `(width, height)` pixels with `draw` into memory, encodes it as PNG and
/// writes it atomically to `path`.
///
/// The drawing area handed to `draw` starts filled white. Nothing is written when `draw` or the
/// encoding fails.
pub(crate) fn render_png<F>(path: &Path, (width, height): (u32, u32), draw: F) -> Result<()>
where
    F: for<'a> FnOnce(DrawingArea<BitMapBackend<'a>, Shift>) -> Result<()>,
{
    let png = render_png_bytes((width, height), draw)?;
    crate::io::atomic_write(path, &png)
}

/// Like [`render_png`] but returns the encoded PNG instead of writing it.
pub(crate) fn render_png_bytes<F>((width, height): (u32, u32), draw: F) -> Result<Vec<u8>>
where
    F: for<'a> FnOnce(DrawingArea<BitMapBackend<'a>, Shift>) -> Result<()>,
{
    if width == 0 || height == 0 || width > MAX_SIDE_PX || height > MAX_SIDE_PX {
        return Err(Error::invalid(
            "plot size",
            format!("{width}×{height} px; expected 1–{MAX_SIDE_PX} px per side"),
        ));
    }
    ensure_font()?;
    let mut buf = vec![255u8; width as usize * height as usize * 3];
    {
        let backend =
            BitMapBackend::with_buffer_and_format(&mut buf, (width, height)).map_err(draw_err)?;
        let root = backend.into_drawing_area();
        root.fill(&WHITE).map_err(draw_err)?;
        draw(root.clone())?;
        root.present().map_err(draw_err)?;
    }
    let mut png = Vec::new();
    PngEncoder::new(&mut png)
        .write_image(&buf, width, height, ExtendedColorType::Rgb8)
        .map_err(|e| Error::invalid("plot", format!("PNG encoding failed: {e}")))?;
    Ok(png)
}

/// Encoded sRGB (nominally 0–1) to display bytes, clipping out-of-gamut channels.
pub(crate) fn srgb_to_u8(rgb: [f64; 3]) -> [u8; 3] {
    rgb.map(|c| (c.clamp(0.0, 1.0) * 255.0).round() as u8)
}

/// Relative luminance (0–1) of an 8-bit encoded sRGB colour, for choosing contrasting text.
pub(crate) fn luminance_u8(rgb: [u8; 3]) -> f64 {
    let lin = rgb.map(|c| {
        let v = f64::from(c) / 255.0;
        if v <= 0.04045 {
            v / 12.92
        } else {
            ((v + 0.055) / 1.055).powf(2.4)
        }
    });
    0.2126 * lin[0] + 0.7152 * lin[1] + 0.0722 * lin[2]
}

/// Black or white, whichever contrasts more with `background` (WCAG contrast crossover at
/// relative luminance ≈ 0.179).
pub(crate) fn contrasting_text(background: [u8; 3]) -> RGBColor {
    if luminance_u8(background) > 0.179 {
        RGBColor(20, 20, 20)
    } else {
        RGBColor(250, 250, 250)
    }
}

/// Dark text colour used for titles, axis descriptions and legends.
pub(crate) const INK: RGBColor = RGBColor(30, 30, 30);
/// Grey for tick labels, axes and secondary text.
pub(crate) const MUTED_INK: RGBColor = RGBColor(90, 90, 90);

/// Axis set-up shared by the spectral charts.
pub(crate) struct AxesSpec<'s> {
    /// Caption above the plotting area, if any.
    pub caption: Option<&'s str>,
    /// x-axis description (drawn under the tick labels).
    pub x_label: &'s str,
    /// y-axis description (drawn rotated left of the tick labels).
    pub y_label: &'s str,
    /// x range (data units).
    pub x_range: (f64, f64),
    /// y range (data units).
    pub y_range: (f64, f64),
    /// Approximate number of x and y tick labels.
    pub n_ticks: (usize, usize),
}

/// Fewest decimals (at most 8) that print every tick value exactly to within a millionth of the
/// tick step, so "400" not "400.0" and "0.05" not "0.1".
fn tick_decimals(ticks: &[f64]) -> usize {
    let step = ticks
        .windows(2)
        .map(|w| (w[1] - w[0]).abs())
        .filter(|d| *d > 0.0)
        .fold(f64::INFINITY, f64::min);
    if !step.is_finite() {
        return 1;
    }
    (0..=8)
        .find(|&d| {
            ticks.iter().all(|&t| {
                let printed: f64 = format!("{t:.d$}").parse().unwrap_or(f64::NAN);
                (printed - t).abs() <= 1e-6 * step
            })
        })
        .unwrap_or(8)
}

/// Width left of the y axis for tick labels and the y description.
const Y_LABEL_AREA_PX: u32 = 84;

/// Builds a Cartesian chart on `area` with a light grid, readable tick labels and the axis
/// descriptions of `spec`.
pub(crate) fn spectral_axes<'a, DB: DrawingBackend>(
    area: &'a DrawingArea<DB, Shift>,
    spec: &AxesSpec<'_>,
) -> Result<ChartContext<'a, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>> {
    let caption_h = if spec.caption.is_some() { 40 } else { 0 };
    let mut chart = ChartBuilder::on(area)
        .margin_top(12 + caption_h)
        .margin_right(36)
        .margin_bottom(12)
        .margin_left(10)
        .x_label_area_size(70)
        .y_label_area_size(Y_LABEL_AREA_PX)
        .build_cartesian_2d(
            spec.x_range.0..spec.x_range.1,
            spec.y_range.0..spec.y_range.1,
        )
        .map_err(draw_err)?;
    let coord = chart.as_coord_spec();
    let x_decimals = tick_decimals(&coord.x_spec().key_points(spec.n_ticks.0));
    let y_decimals = tick_decimals(&coord.y_spec().key_points(spec.n_ticks.1));
    let x_fmt = |x: &f64| format!("{x:.x_decimals$}");
    let y_fmt = |y: &f64| format!("{y:.y_decimals$}");
    let tick_style = text_style(15.0, MUTED_INK, Pos::new(HPos::Center, VPos::Center));
    chart
        .configure_mesh()
        .label_style(tick_style)
        .x_labels(spec.n_ticks.0)
        .y_labels(spec.n_ticks.1)
        .x_label_formatter(&x_fmt)
        .y_label_formatter(&y_fmt)
        .max_light_lines(4)
        .bold_line_style(RGBColor(212, 212, 212))
        .light_line_style(RGBColor(240, 240, 240))
        .axis_style(MUTED_INK)
        .draw()
        .map_err(draw_err)?;

    // Caption and x description with correct glyph spacing (see `text`).
    let (base_x, base_y) = area.get_base_pixel();
    let (px, py) = chart.plotting_area().get_pixel_range();
    let centre_x = (px.start + px.end) / 2 - base_x;
    if let Some(caption) = spec.caption {
        let style = TextSpec::new(22.0, INK, HPos::Center, VPos::Center);
        let caption = text::fit_text(area, caption, style.size_px, px.len() as u32)?;
        text::draw_text(area, &caption, (centre_x, py.start - base_y - 24), style)?;
    }
    let style = TextSpec::new(18.0, INK, HPos::Center, VPos::Center);
    text::draw_text(area, spec.x_label, (centre_x, py.end - base_y + 46), style)?;
    let centre_y = (py.start + py.end) / 2 - base_y;
    let desc_x = px.start - base_x - Y_LABEL_AREA_PX as i32 + 14;
    text::draw_text(area, spec.y_label, (desc_x, centre_y), style.vertical())?;
    Ok(chart)
}

/// Relative luminance above which a line colour is too faint on white without a halo.
pub(crate) const HALO_LUMINANCE: f64 = 0.5;

/// Whether a line of this colour needs a dark halo to be seen on white.
pub(crate) fn needs_halo(colour: [u8; 3]) -> bool {
    luminance_u8(colour) > HALO_LUMINANCE
}

/// Draws one spectral curve into a chart. Light colours (white, yellow, pale greys; relative
/// luminance above [`HALO_LUMINANCE`]) get a faint dark halo so that they stay visible on a white
/// background. Points outside the x range are
/// dropped (plotters does not clip lines to the plotting area).
pub(crate) fn draw_curve<DB: DrawingBackend>(
    chart: &mut ChartContext<'_, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>,
    points: &[(f64, f64)],
    colour: [u8; 3],
    width: u32,
) -> Result<()> {
    let x_range = chart.x_range();
    let y_range = chart.y_range();
    let pts: Vec<(f64, f64)> = points
        .iter()
        .copied()
        .filter(|(x, y)| x.is_finite() && y.is_finite())
        .filter(|(x, _)| *x >= x_range.start && *x <= x_range.end)
        .map(|(x, y)| (x, y.clamp(y_range.start, y_range.end)))
        .collect();
    if pts.len() < 2 {
        return Ok(());
    }
    if needs_halo(colour) {
        let halo = RGBColor(40, 40, 40).mix(0.4).stroke_width(width + 2);
        chart
            .draw_series(LineSeries::new(pts.iter().copied(), halo))
            .map_err(draw_err)?;
    }
    let line = RGBColor(colour[0], colour[1], colour[2]).stroke_width(width);
    chart
        .draw_series(LineSeries::new(pts, line))
        .map_err(draw_err)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spectrum::Spectrum;

    /// Decodes a chart file as PNG into 8-bit RGB.
    pub(super) fn decode(path: &Path) -> image::RgbImage {
        let bytes = std::fs::read(path).expect("chart file exists");
        image::load_from_memory_with_format(&bytes, image::ImageFormat::Png)
            .expect("chart decodes as PNG")
            .to_rgb8()
    }

    pub(super) fn is_single_colour(img: &image::RgbImage) -> bool {
        let first = img.get_pixel(0, 0);
        img.pixels().all(|p| p == first)
    }

    /// A smooth synthetic reflectance: a logistic step plus a Gaussian bump.
    pub(super) fn smooth_spectrum(i: usize) -> Spectrum {
        let wl: Vec<f64> = (0..=80).map(|k| 380.0 + 5.0 * k as f64).collect();
        let fi = i as f64;
        let centre = 420.0 + 14.0 * fi;
        let base = 0.04 + 0.035 * (fi % 6.0);
        let values = wl
            .iter()
            .map(|&l| {
                let step = 0.5 / (1.0 + (-(l - (450.0 + 12.0 * fi)) / 25.0).exp());
                let bump = 0.35 * (-((l - centre) / 40.0).powi(2)).exp();
                (base + step * ((i % 3) as f64 / 2.0) + bump).min(0.98)
            })
            .collect();
        Spectrum::new(format!("patch {}", i + 1), wl, values).expect("valid synthetic spectrum")
    }

    #[test]
    fn render_png_writes_nothing_when_the_drawing_fails() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("fail.png");
        let err = render_png(&path, (100, 80), |_root| Err(Error::invalid("x", "boom")));
        assert!(err.is_err());
        assert_eq!(std::fs::read_dir(dir.path()).expect("dir").count(), 0);
    }

    #[test]
    fn render_png_rejects_an_empty_image_size() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("empty.png");
        assert!(render_png(&path, (0, 10), |_root| Ok(())).is_err());
        assert!(!path.exists());
    }

    #[test]
    fn tick_decimals_print_round_ticks_without_trailing_zeros() {
        assert_eq!(tick_decimals(&[400.0, 450.0, 500.0]), 0);
        assert_eq!(tick_decimals(&[0.0, 0.1, 0.2, 0.30000000000000004]), 1);
        assert_eq!(tick_decimals(&[0.0, 0.05, 0.1]), 2);
        assert_eq!(tick_decimals(&[0.0, 0.25, 0.5]), 2);
    }

    #[test]
    fn contrasting_text_is_dark_on_light_and_light_on_dark() {
        assert_eq!(contrasting_text([240, 240, 240]), RGBColor(20, 20, 20));
        assert_eq!(contrasting_text([30, 30, 90]), RGBColor(250, 250, 250));
    }
}
