//! The fluorescence figure: the measured Donaldson matrix as a heat map, the reduced K×K
//! matrices as annotated heat maps, and ΔE00 per illuminant and method as grouped bars.

use std::path::Path;

use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, VPos};

use super::{
    draw_err, draw_text, fit_text, render_png_bytes, spectral_axes, AxesSpec, TextSpec, INK,
    MUTED_INK,
};
use crate::error::{Error, Result};

/// What [`fluor_chart`] draws.
#[derive(Debug, Clone, PartialEq)]
pub struct FluorChart {
    /// Title (material name).
    pub title: String,
    /// Emission wavelengths (rows of `donaldson`), nm.
    pub emission_nm: Vec<f64>,
    /// Excitation wavelengths (columns of `donaldson`), nm.
    pub excitation_nm: Vec<f64>,
    /// The measured matrix, `[emission][excitation]`.
    pub donaldson: Vec<Vec<f64>>,
    /// Reduced matrices: (method name, channel labels, `[row][col]`).
    pub reduced: Vec<(String, Vec<String>, Vec<Vec<f64>>)>,
    /// ΔE00 bars: (illuminant, method, value).
    pub delta_e: Vec<(String, String, f64)>,
}

const SIZE_PX: (u32, u32) = (1800, 1000);

/// A perceptually ordered colour map (magma-like) for t in 0–1.
fn colour_map(t: f64) -> RGBColor {
    const STOPS: [(f64, [f64; 3]); 5] = [
        (0.0, [0.0, 0.0, 4.0]),
        (0.25, [81.0, 18.0, 124.0]),
        (0.5, [183.0, 55.0, 121.0]),
        (0.75, [252.0, 137.0, 97.0]),
        (1.0, [252.0, 253.0, 191.0]),
    ];
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let i = STOPS.iter().position(|s| s.0 >= t).unwrap_or(4).max(1);
    let (a, b) = (STOPS[i - 1], STOPS[i]);
    let u = (t - a.0) / (b.0 - a.0);
    let c = |k: usize| (a.1[k] + u * (b.1[k] - a.1[k])).round() as u8;
    RGBColor(c(0), c(1), c(2))
}

/// Diverging map for signed reduced matrices: blue (negative) – white – red (positive).
fn diverging(v: f64, vmax: f64) -> RGBColor {
    let t = if vmax > 0.0 {
        (v / vmax).clamp(-1.0, 1.0)
    } else {
        0.0
    };
    let w = |x: f64| (255.0 * (1.0 - x)).round() as u8;
    if t >= 0.0 {
        RGBColor(255, w(t * 0.85), w(t * 0.85))
    } else {
        RGBColor(w(-t * 0.85), w(-t * 0.85), 255)
    }
}

const METHOD_COLOURS: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
];

/// Writes the fluorescence figure (1800 × 1000 px PNG) to `path`.
///
/// # Errors
/// [`Error::InvalidArgument`] for an empty or ragged matrix or non-finite values; [`Error::Io`]
/// when the file cannot be written (nothing is left behind).
pub fn fluor_chart(path: &Path, chart: &FluorChart) -> Result<()> {
    crate::io::atomic_write(path, &fluor_chart_png(chart)?)
}

/// The same chart as [`fluor_chart`], encoded as PNG in memory (for staged outputs).
pub fn fluor_chart_png(chart: &FluorChart) -> Result<Vec<u8>> {
    let (ne, nx) = (chart.emission_nm.len(), chart.excitation_nm.len());
    if ne < 2
        || nx < 2
        || chart.donaldson.len() != ne
        || chart.donaldson.iter().any(|r| r.len() != nx)
    {
        return Err(Error::invalid(
            "plot",
            "the Donaldson matrix must be non-empty and match its wavelength axes",
        ));
    }
    if chart.delta_e.iter().any(|d| !d.2.is_finite()) {
        return Err(Error::invalid("plot", "ΔE00 values must be finite"));
    }
    render_png_bytes(SIZE_PX, |root| {
        let title = TextSpec::new(28.0, INK, HPos::Center, VPos::Center);
        let t = fit_text(
            &root,
            &format!("Fluorescence: {}", chart.title),
            28.0,
            SIZE_PX.0 - 40,
        )?;
        draw_text(&root, &t, (SIZE_PX.0 as i32 / 2, 28), title)?;
        let body = root.margin(60, 10, 10, 10);
        let (left, rest) = body.split_horizontally(640);
        let (middle, right) = rest.split_horizontally(420);
        draw_donaldson(&left, chart)?;
        draw_reduced(&middle, chart)?;
        draw_bars(&right, chart)
    })
}

fn draw_donaldson<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    c: &FluorChart,
) -> Result<()> {
    let (ne, nx) = (c.emission_nm.len(), c.excitation_nm.len());
    let vmax = c
        .donaldson
        .iter()
        .flatten()
        .copied()
        .fold(0.0_f64, f64::max);
    let half_x = (c.excitation_nm[1] - c.excitation_nm[0]) / 2.0;
    let half_e = (c.emission_nm[1] - c.emission_nm[0]) / 2.0;
    let spec = AxesSpec {
        caption: Some("Donaldson matrix (colour ∝ value^0.3)"),
        x_label: "excitation (nm)",
        y_label: "emission (nm)",
        x_range: (
            c.excitation_nm[0] - half_x,
            c.excitation_nm[nx - 1] + half_x,
        ),
        y_range: (c.emission_nm[0] - half_e, c.emission_nm[ne - 1] + half_e),
        n_ticks: (6, 6),
    };
    let mut ch = spectral_axes(area, &spec)?;
    let mut cells = Vec::with_capacity(ne * nx);
    for (r, e) in c.emission_nm.iter().enumerate() {
        for (k, x) in c.excitation_nm.iter().enumerate() {
            let v = c.donaldson[r][k].max(0.0);
            let t = if vmax > 0.0 {
                (v / vmax).powf(0.3)
            } else {
                0.0
            };
            cells.push(Rectangle::new(
                [(x - half_x, e - half_e), (x + half_x, e + half_e)],
                colour_map(t).filled(),
            ));
        }
    }
    ch.draw_series(cells).map_err(draw_err)?;
    Ok(())
}

fn draw_reduced<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    c: &FluorChart,
) -> Result<()> {
    let n = c.reduced.len().max(1);
    let (w, h) = area.dim_in_pixel();
    let slot_h = (h as i32 - 10) / n as i32;
    let head = TextSpec::new(18.0, INK, HPos::Center, VPos::Center);
    for (i, (name, labels, m)) in c.reduced.iter().enumerate() {
        let k = m.len();
        if k == 0 || m.iter().any(|r| r.len() != k) {
            return Err(Error::invalid(
                "plot",
                format!("reduced matrix '{name}' is not square"),
            ));
        }
        let y0 = i as i32 * slot_h;
        draw_text(area, name, (w as i32 / 2, y0 + 12), head)?;
        let side = ((slot_h - 36).min(w as i32 - 60)).max(10);
        let cell = side / k as i32;
        let x0 = (w as i32 - cell * k as i32) / 2 + 10;
        let vmax = m.iter().flatten().map(|v| v.abs()).fold(0.0_f64, f64::max);
        let font = (cell as f64 * 0.3).clamp(7.0, 14.0);
        for (r, row) in m.iter().enumerate() {
            for (col, &value) in row.iter().enumerate() {
                let (px, py) = (x0 + col as i32 * cell, y0 + 26 + r as i32 * cell);
                area.draw(&Rectangle::new(
                    [(px, py), (px + cell - 1, py + cell - 1)],
                    diverging(value, vmax).filled(),
                ))
                .map_err(draw_err)?;
                if cell >= 22 {
                    let s = TextSpec::new(font, INK, HPos::Center, VPos::Center);
                    draw_text(
                        area,
                        &format!("{value:.2}"),
                        (px + cell / 2, py + cell / 2),
                        s,
                    )?;
                }
            }
            if let Some(l) = labels.get(r) {
                let s = TextSpec::new(12.0, MUTED_INK, HPos::Right, VPos::Center);
                draw_text(area, l, (x0 - 4, y0 + 26 + r as i32 * cell + cell / 2), s)?;
            }
        }
    }
    Ok(())
}

fn draw_bars<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    c: &FluorChart,
) -> Result<()> {
    let mut ills: Vec<&str> = Vec::new();
    let mut methods: Vec<&str> = Vec::new();
    for (i, m, _) in &c.delta_e {
        if !ills.contains(&i.as_str()) {
            ills.push(i);
        }
        if !methods.contains(&m.as_str()) {
            methods.push(m);
        }
    }
    let ymax = c.delta_e.iter().map(|d| d.2).fold(1.0_f64, f64::max) * 1.1;
    let spec = AxesSpec {
        caption: Some("ΔE00, reduced vs spectral, per illuminant"),
        x_label: "illuminant",
        y_label: "ΔE00",
        x_range: (0.0, ills.len().max(1) as f64),
        y_range: (0.0, ymax),
        n_ticks: (0, 8),
    };
    let mut ch = spectral_axes(area, &spec)?;
    let nm = methods.len().max(1) as f64;
    let bw = 0.8 / nm;
    for (mi, m) in methods.iter().enumerate() {
        let col = METHOD_COLOURS[mi % METHOD_COLOURS.len()];
        let bars: Vec<_> = c
            .delta_e
            .iter()
            .filter(|d| d.1 == *m)
            .filter_map(|d| ills.iter().position(|i| *i == d.0).map(|ii| (ii, d.2)))
            .map(|(ii, v)| {
                let x = ii as f64 + 0.1 + mi as f64 * bw;
                Rectangle::new([(x, 0.0), (x + bw * 0.9, v)], col.filled())
            })
            .collect();
        ch.draw_series(bars).map_err(draw_err)?;
    }
    // Illuminant names under the groups and a legend in the top-right corner.
    let (px, py) = ch.plotting_area().get_pixel_range();
    let (bx, by) = area.get_base_pixel();
    let gw = (px.end - px.start) as f64 / ills.len().max(1) as f64;
    for (i, name) in ills.iter().enumerate() {
        let s = TextSpec::new(15.0, MUTED_INK, HPos::Center, VPos::Top);
        draw_text(
            area,
            name,
            (
                px.start - bx + (gw * (i as f64 + 0.5)) as i32,
                py.end - by + 6,
            ),
            s,
        )?;
    }
    for (mi, m) in methods.iter().enumerate() {
        let col = METHOD_COLOURS[mi % METHOD_COLOURS.len()];
        let (x, y) = (px.end - bx - 170, py.start - by + 12 + mi as i32 * 22);
        area.draw(&Rectangle::new([(x, y - 7), (x + 14, y + 7)], col.filled()))
            .map_err(draw_err)?;
        draw_text(
            area,
            m,
            (x + 20, y),
            TextSpec::new(15.0, INK, HPos::Left, VPos::Center),
        )?;
    }
    Ok(())
}
