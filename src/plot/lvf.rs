//! LVF calibration chart: the profile per camera channel with the fitted model, the lamp lines at
//! their fitted positions, what the fit put under the lines (offset + continuum, thin light
//! curves per channel) and the fall-off V it divided out (grey, scaled to the plot's top), and
//! the residuals below; the legend line names the background model and any warnings.

use std::path::Path;

use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, VPos};

use super::{
    draw_curve, draw_err, draw_text, fit_text, render_png_bytes, spectral_axes, AxesSpec, TextSpec,
    INK,
};
use crate::error::{Error, Result};
use crate::lvf::LvfCalibration;

const SIZE_PX: (u32, u32) = (1400, 900);
const TITLE_H: i32 = 60;
/// Height of each legend line under the title (px).
const LEGEND_LINE_H: i32 = 20;
const CHANNEL_RGB: [[u8; 3]; 3] = [[200, 40, 40], [30, 150, 60], [40, 80, 210]];
const MODEL_RGB: [[u8; 3]; 3] = [[110, 10, 10], [10, 80, 25], [10, 30, 120]];
const BACKGROUND_RGB: [[u8; 3]; 3] = [[240, 150, 150], [140, 210, 150], [150, 170, 240]];
const FALLOFF_RGB: [u8; 3] = [120, 120, 120];
/// The fall-off's ± 1σ.
const FALLOFF_BAND_RGB: [u8; 3] = [185, 185, 185];

/// Writes the calibration chart (1400 × 900 px PNG) to `path`.
///
/// # Errors
/// [`Error::InvalidArgument`] when the calibration carries no profile; [`Error::Io`] on write.
pub fn lvf_chart(path: &Path, cal: &LvfCalibration) -> Result<()> {
    crate::io::atomic_write(path, &lvf_chart_png(cal)?)
}

/// The same chart as [`lvf_chart`], encoded as PNG in memory (for staged outputs).
pub fn lvf_chart_png(cal: &LvfCalibration) -> Result<Vec<u8>> {
    let c = &cal.curves;
    if c.px.len() < 2 {
        return Err(Error::invalid(
            "plot",
            "the calibration holds no profile to plot",
        ));
    }
    let x_range = (
        c.px[0].min(c.px[c.px.len() - 1]),
        c.px[0].max(c.px[c.px.len() - 1]),
    );
    let ymax = c.data.iter().flatten().cloned().fold(f64::MIN, f64::max);
    let ymin = c
        .data
        .iter()
        .flatten()
        .cloned()
        .fold(f64::MAX, f64::min)
        .min(0.0);
    let has_model = c.model.iter().all(|m| m.len() == c.px.len());
    let resid: [Vec<f64>; 3] = std::array::from_fn(|k| {
        if has_model {
            c.data[k]
                .iter()
                .zip(&c.model[k])
                .map(|(d, m)| d - m)
                .collect()
        } else {
            Vec::new()
        }
    });
    let rmax = resid
        .iter()
        .flatten()
        .fold(0.0f64, |a, v| a.max(v.abs()))
        .max(1e-9);
    let title = format!(
        "LVF calibration ({}, {}): λ(px) = {} ; FWHM {:.2} nm ; line RMS {:.3} nm",
        cal.method,
        cal.lamp,
        cal.map
            .coefficients
            .iter()
            .enumerate()
            .map(|(i, v)| if i == 0 {
                format!("{v:.3}")
            } else {
                format!("{v:+.6}·px^{i}")
            })
            .collect::<Vec<_>>()
            .join(" "),
        cal.fwhm_nm,
        cal.rms_residual_nm
    );
    render_png_bytes(SIZE_PX, |root| {
        let (w, _) = root.dim_in_pixel();
        let style = TextSpec::new(22.0, INK, HPos::Center, VPos::Center);
        let t = fit_text(&root, &title, style.size_px, w - 40)?;
        draw_text(&root, &t, (w as i32 / 2, TITLE_H / 2 - 10), style)?;
        // two legend lines: what is drawn, then the warnings (each cut to the width on its own,
        // so that a long warning does not hide the fall-off's numbers)
        let legend = match &cal.background {
            Some(b) => format!(
                "thin light: offset + continuum ({}, peak {:.1} % of the profile) · grey: fall-off V × peak{} ({})",
                b.model,
                100.0 * b.continuum_peak_relative,
                if c.falloff_sigma.is_empty() {
                    ""
                } else {
                    ", ± 1σ thin light grey"
                },
                if c.falloff.iter().any(|v| *v != 1.0) {
                    format!(
                        "{}, V at the ends {:.3} / {:.3}",
                        // the source without its explanation in parentheses
                        b.falloff_source.split(" (").next().unwrap_or("modelled"),
                        c.falloff.first().copied().unwrap_or(1.0),
                        c.falloff.last().copied().unwrap_or(1.0)
                    )
                } else {
                    "none applied".to_string()
                },
            ),
            None => "peak picking: no background model".to_string(),
        };
        let warnings = match cal.warnings.len() {
            0 => "no warnings".to_string(),
            n => format!(
                "{n} warning(s) (all in lvf.json and on stderr), the first: {}",
                cal.warnings[0]
            ),
        };
        let lstyle = TextSpec::new(15.0, INK, HPos::Center, VPos::Center);
        for (k, text) in [legend, warnings].iter().enumerate() {
            let lt = fit_text(&root, text, lstyle.size_px, w - 40)?;
            draw_text(
                &root,
                &lt,
                (w as i32 / 2, TITLE_H - 8 + LEGEND_LINE_H * k as i32),
                lstyle,
            )?;
        }
        let (_, body) = root.split_vertically(TITLE_H + 8 + LEGEND_LINE_H);
        let (top, bottom) = body.split_vertically(560 - LEGEND_LINE_H);
        let mut chart = spectral_axes(
            &top,
            &AxesSpec {
                caption: None,
                x_label: "position along the filter (px)",
                y_label: "linear signal",
                x_range,
                y_range: (ymin, ymax * 1.08),
                n_ticks: (12, 8),
            },
        )?;
        for line in &cal.lines {
            if line.px.is_finite() && line.px >= x_range.0 && line.px <= x_range.1 {
                chart
                    .draw_series(LineSeries::new(
                        [(line.px, ymin), (line.px, ymax * 1.08)],
                        RGBColor(150, 150, 150).stroke_width(1),
                    ))
                    .map_err(draw_err)?;
            }
        }
        for (bg, rgb) in c.background.iter().zip(BACKGROUND_RGB) {
            if bg.len() == c.px.len() {
                let pts: Vec<(f64, f64)> = c.px.iter().copied().zip(bg.iter().copied()).collect();
                draw_curve(&mut chart, &pts, rgb, 2)?;
            }
        }
        if c.falloff.len() == c.px.len() {
            let pts: Vec<(f64, f64)> =
                c.px.iter()
                    .copied()
                    .zip(c.falloff.iter().map(|v| v * ymax))
                    .collect();
            draw_curve(&mut chart, &pts, FALLOFF_RGB, 2)?;
            if c.falloff_sigma.len() == c.px.len() {
                for sign in [-1.0, 1.0] {
                    let pts: Vec<(f64, f64)> =
                        c.px.iter()
                            .zip(c.falloff.iter().zip(&c.falloff_sigma))
                            .map(|(&x, (v, s))| (x, v * (sign * s).exp() * ymax))
                            .collect();
                    draw_curve(&mut chart, &pts, FALLOFF_BAND_RGB, 1)?;
                }
            }
        }
        for k in 0..3 {
            let pts: Vec<(f64, f64)> =
                c.px.iter()
                    .copied()
                    .zip(c.data[k].iter().copied())
                    .collect();
            draw_curve(&mut chart, &pts, CHANNEL_RGB[k], 1)?;
            if has_model {
                let pts: Vec<(f64, f64)> =
                    c.px.iter()
                        .copied()
                        .zip(c.model[k].iter().copied())
                        .collect();
                draw_curve(&mut chart, &pts, MODEL_RGB[k], 2)?;
            }
        }
        if has_model {
            let mut rchart = spectral_axes(
                &bottom,
                &AxesSpec {
                    caption: None,
                    x_label: "position along the filter (px)",
                    y_label: "residual",
                    x_range,
                    y_range: (-1.1 * rmax, 1.1 * rmax),
                    n_ticks: (12, 5),
                },
            )?;
            for k in 0..3 {
                let pts: Vec<(f64, f64)> =
                    c.px.iter().copied().zip(resid[k].iter().copied()).collect();
                draw_curve(&mut rchart, &pts, CHANNEL_RGB[k], 1)?;
            }
        }
        Ok(())
    })
}
