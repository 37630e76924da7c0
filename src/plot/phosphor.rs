//! Decay-fit chart: data and fit on a log axis with each state's contribution, and the
//! residuals below.

// Index loops mirror the matrix notation of the maths; `!(a > b)` comparisons deliberately
// reject NaN along with out-of-range values.
#![allow(clippy::needless_range_loop, clippy::neg_cmp_op_on_partial_ord)]

use std::path::Path;

use plotters::prelude::*;

use super::{draw_err, render_png_bytes, spectral_axes, AxesSpec};
use crate::error::{Error, Result};
use crate::phosphor::{DecayCurve, DecayFit};

/// Figure size in pixels.
const SIZE_PX: (u32, u32) = (1400, 1000);
/// Points of the model curves.
const N_FINE: usize = 400;

const CHANNEL_COLOURS: [RGBColor; 3] = [
    RGBColor(200, 40, 40),
    RGBColor(40, 150, 60),
    RGBColor(40, 70, 200),
];
const STATE_COLOURS: [RGBColor; 3] = [
    RGBColor(230, 140, 20),
    RGBColor(140, 60, 170),
    RGBColor(20, 150, 160),
];

/// Writes the decay chart (1400 × 1000 px PNG): top, log₁₀ of the data (points) and of the fit
/// (lines) per channel with each state's contribution summed over channels (thin lines); bottom,
/// the residuals per channel.
pub fn decay_chart(path: &Path, title: &str, curve: &DecayCurve, fit: &DecayFit) -> Result<()> {
    crate::io::atomic_write(path, &decay_chart_png(title, curve, fit)?)
}

/// The decay chart of [`decay_chart`] as PNG bytes (nothing written).
pub fn decay_chart_png(title: &str, curve: &DecayCurve, fit: &DecayFit) -> Result<Vec<u8>> {
    let t = &curve.t_s;
    let (t0, t1) = (t[0], t[t.len() - 1]);
    if !(t1 > t0) {
        return Err(Error::invalid("plot", "the curve spans no time"));
    }
    let fine: Vec<f64> = (0..N_FINE)
        .map(|i| t0 + (t1 - t0) * i as f64 / (N_FINE - 1) as f64)
        .collect();
    let pos = |v: f64| if v > 0.0 { Some(v.log10()) } else { None };
    let mut lo = f64::INFINITY;
    let mut hi = f64::NEG_INFINITY;
    for ch in &curve.channels {
        for v in ch.iter().filter_map(|v| pos(*v)) {
            lo = lo.min(v);
            hi = hi.max(v);
        }
    }
    if !lo.is_finite() {
        return Err(Error::invalid(
            "plot",
            "no positive value to draw on a log axis",
        ));
    }
    let lo = lo - 0.3;
    let hi = hi + 0.2;
    let residuals: Vec<Vec<f64>> = (0..curve.channels.len())
        .map(|c| {
            t.iter()
                .enumerate()
                .map(|(i, ti)| curve.channels[c][i] - fit.predict(*ti)[c])
                .collect()
        })
        .collect();
    let rmax = residuals
        .iter()
        .flatten()
        .fold(0.0_f64, |m, v| m.max(v.abs()))
        .max(f64::MIN_POSITIVE)
        * 1.1;
    let names = if curve.channels.len() == 3 {
        vec!["R", "G", "B"]
    } else {
        vec!["value"; curve.channels.len()]
    };
    render_png_bytes(SIZE_PX, |root| {
        let (top, bottom) = root.split_vertically(680);
        let caption = title.to_string();
        let mut chart = spectral_axes(
            &top,
            &AxesSpec {
                caption: Some(&caption),
                x_label: "time after switch-off (s)",
                y_label: "log10 value",
                x_range: (t0, t1),
                y_range: (lo, hi),
                n_ticks: (10, 8),
            },
        )?;
        for (c, ch) in curve.channels.iter().enumerate() {
            let col = CHANNEL_COLOURS[c % 3];
            let line: Vec<(f64, f64)> = fine
                .iter()
                .filter_map(|x| pos(fit.predict(*x)[c]).map(|y| (*x, y.max(lo))))
                .collect();
            chart
                .draw_series(LineSeries::new(line, col.stroke_width(2)))
                .map_err(draw_err)?
                .label(format!("{} fit", names[c]))
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], col.stroke_width(2))
                });
            chart
                .draw_series(
                    t.iter().zip(ch).filter_map(|(x, v)| {
                        pos(*v).map(|y| Circle::new((*x, y), 4, col.filled()))
                    }),
                )
                .map_err(draw_err)?;
        }
        for (i, s) in fit.states.iter().enumerate() {
            let col = STATE_COLOURS[i % 3];
            let line: Vec<(f64, f64)> = fine
                .iter()
                .filter_map(|x| {
                    pos(fit.state_contribution(i, *x).iter().sum::<f64>()).map(|y| (*x, y.max(lo)))
                })
                .collect();
            chart
                .draw_series(LineSeries::new(line, col.stroke_width(1)))
                .map_err(draw_err)?
                .label(format!(
                    "state {} (k = {:.4} /s, sum of channels)",
                    i + 1,
                    s.k_per_s
                ))
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], col.stroke_width(1))
                });
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .label_font((super::FONT, 16.0).into_font())
            .position(SeriesLabelPosition::UpperRight)
            .draw()
            .map_err(draw_err)?;
        let mut res = spectral_axes(
            &bottom,
            &AxesSpec {
                caption: Some("residuals (data − fit)"),
                x_label: "time after switch-off (s)",
                y_label: "residual",
                x_range: (t0, t1),
                y_range: (-rmax, rmax),
                n_ticks: (10, 5),
            },
        )?;
        res.draw_series(LineSeries::new(
            vec![(t0, 0.0), (t1, 0.0)],
            BLACK.stroke_width(1),
        ))
        .map_err(draw_err)?;
        for (c, r) in residuals.iter().enumerate() {
            let col = CHANNEL_COLOURS[c % 3];
            res.draw_series(
                t.iter()
                    .zip(r)
                    .map(|(x, y)| Circle::new((*x, *y), 4, col.filled())),
            )
            .map_err(draw_err)?;
        }
        Ok(())
    })
}

/// Writes the integrator comparison (1200 × 800 px PNG): log₁₀ error against log₁₀ run time,
/// one line with points per named series; errors are clamped to [10⁻¹⁶, 10⁶] for drawing
/// (a diverged run sits on the top edge).
pub fn integrator_chart(
    path: &Path,
    title: &str,
    series: &[(String, Vec<(f64, f64)>)],
) -> Result<()> {
    crate::io::atomic_write(path, &integrator_chart_png(title, series)?)
}

/// The chart of [`integrator_chart`] as PNG bytes (nothing written).
pub fn integrator_chart_png(title: &str, series: &[(String, Vec<(f64, f64)>)]) -> Result<Vec<u8>> {
    let clamp = |(t, e): (f64, f64)| -> Option<(f64, f64)> {
        if !(t > 0.0) {
            return None;
        }
        let e = if e.is_finite() {
            e.clamp(1e-16, 1e6)
        } else {
            1e6
        };
        Some((t.log10(), e.log10()))
    };
    let pts: Vec<Vec<(f64, f64)>> = series
        .iter()
        .map(|(_, v)| v.iter().filter_map(|p| clamp(*p)).collect())
        .collect();
    let all: Vec<(f64, f64)> = pts.iter().flatten().cloned().collect();
    if all.is_empty() {
        return Err(Error::invalid("plot", "no positive run time to draw"));
    }
    let (mut x0, mut x1, mut y0, mut y1) = (
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    );
    for (x, y) in &all {
        x0 = x0.min(*x);
        x1 = x1.max(*x);
        y0 = y0.min(*y);
        y1 = y1.max(*y);
    }
    let colours = [
        STATE_COLOURS[0],
        STATE_COLOURS[1],
        CHANNEL_COLOURS[0],
        CHANNEL_COLOURS[2],
        CHANNEL_COLOURS[1],
        STATE_COLOURS[2],
    ];
    render_png_bytes((1200, 800), |root| {
        let caption = title.to_string();
        let mut chart = spectral_axes(
            &root,
            &AxesSpec {
                caption: Some(&caption),
                x_label: "log10 run time per simulation (s)",
                y_label: "log10 max relative emission error",
                x_range: (x0 - 0.2, x1 + 0.2),
                y_range: (y0 - 0.5, y1 + 0.5),
                n_ticks: (8, 8),
            },
        )?;
        for (i, ((name, _), p)) in series.iter().zip(&pts).enumerate() {
            let col = colours[i % colours.len()];
            chart
                .draw_series(LineSeries::new(p.clone(), col.stroke_width(2)))
                .map_err(draw_err)?
                .label(name.clone())
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], col.stroke_width(2))
                });
            chart
                .draw_series(
                    p.iter()
                        .map(|(x, y)| Circle::new((*x, *y), 4, col.filled())),
                )
                .map_err(draw_err)?;
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .label_font((super::FONT, 16.0).into_font())
            .position(SeriesLabelPosition::LowerLeft)
            .draw()
            .map_err(draw_err)?;
        Ok(())
    })
}
