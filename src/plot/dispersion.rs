//! Dispersion charts: the prism strips (spectral reference above, wavelength samples below) with
//! the ΔE00 curve, and the residuals of every fitted model.

use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, VPos};

use super::{
    draw_curve, draw_err, draw_text, fit_text, render_png_bytes, spectral_axes, srgb_to_u8,
    AxesSpec, TextSpec, INK,
};
use crate::colorimetry::rgb::xyz_to_srgb;
use crate::dispersion::fit::{Candidate, Observations};
use crate::dispersion::prism::PrismEvaluation;
use crate::dispersion::RefractiveIndex;
use crate::error::{Error, Result};

const SIZE_PX: (u32, u32) = (1400, 900);
const TITLE_H: i32 = 56;
const STRIP_H: i32 = 120;
const LABEL_W: i32 = 300;

/// Line colours of up to eight series (colour-blind-safe Okabe–Ito order).
const COLOURS: [[u8; 3]; 8] = [
    [0, 114, 178],
    [213, 94, 0],
    [0, 158, 115],
    [204, 121, 167],
    [86, 180, 233],
    [230, 159, 0],
    [0, 0, 0],
    [240, 228, 66],
];

/// PNG of the prism comparison for case `case` of `eval`: the spectral strip, the sampled strip
/// (both as sRGB, clipped), and ΔE00 along the strip.
pub fn prism_chart_png(title: &str, eval: &PrismEvaluation, case: usize) -> Result<Vec<u8>> {
    let c = eval.cases.get(case).ok_or_else(|| {
        Error::invalid(
            "prism chart",
            "no sampled case to draw; expected at least one",
        )
    })?;
    let white = [0.3127, 0.3290];
    let to_px =
        |xyz: &[f64; 3]| -> Result<[u8; 3]> { Ok(srgb_to_u8(xyz_to_srgb(*xyz, white, true)?)) };
    let spectral: Vec<[u8; 3]> = eval.spectral.xyz.iter().map(to_px).collect::<Result<_>>()?;
    let sampled: Vec<[u8; 3]> = c.strip.xyz.iter().map(to_px).collect::<Result<_>>()?;
    let x = &eval.spectral.x_mm;
    let (x0, x1) = (x[0], x[x.len() - 1]);
    let de_max = c
        .difference
        .max
        .max(c.sampling_only.as_ref().map_or(0.0, |s| s.max))
        .max(1e-3)
        * 1.1;
    render_png_bytes(SIZE_PX, |root| {
        let (w, _) = root.dim_in_pixel();
        let style = TextSpec::new(26.0, INK, HPos::Center, VPos::Center);
        let t = fit_text(&root, title, style.size_px, w - 40)?;
        draw_text(&root, &t, (w as i32 / 2, TITLE_H / 2 + 4), style)?;
        let label = TextSpec::new(18.0, INK, HPos::Left, VPos::Center);
        let strip_w = w as i32 - LABEL_W - 40;
        for (row, (name, px)) in [("spectral (1 nm)", &spectral), (c.label.as_str(), &sampled)]
            .iter()
            .enumerate()
        {
            let top = TITLE_H + 10 + row as i32 * (STRIP_H + 16);
            let name = fit_text(&root, name, label.size_px, (LABEL_W - 20) as u32)?;
            draw_text(&root, &name, (20, top + STRIP_H / 2), label)?;
            let n = px.len().max(1) as i32;
            for (j, p) in px.iter().enumerate() {
                let a = LABEL_W + (j as i32 * strip_w) / n;
                let b = LABEL_W + ((j as i32 + 1) * strip_w) / n;
                root.draw(&Rectangle::new(
                    [(a, top), (b.max(a + 1), top + STRIP_H)],
                    RGBColor(p[0], p[1], p[2]).filled(),
                ))
                .map_err(draw_err)?;
            }
        }
        let top = TITLE_H + 10 + 2 * (STRIP_H + 16);
        let (_, lower) = root.split_vertically(top);
        let caption = match &c.sampling_only {
            Some(so) => format!(
                "ΔE00 (blue: weights as exported, mean {:.2} max {:.2}; orange: sampling only, mean {:.2} max {:.2})",
                c.difference.mean, c.difference.max, so.mean, so.max
            ),
            None => format!(
                "ΔE00 along the strip: mean {:.2}, max {:.2} over {} lit pixels",
                c.difference.mean, c.difference.max, c.difference.lit_pixels
            ),
        };
        let mut chart = spectral_axes(
            &lower,
            &AxesSpec {
                caption: Some(&caption),
                x_label: "position on the screen (mm, from the d line)",
                y_label: "ΔE00",
                x_range: (x0, x1),
                y_range: (0.0, de_max),
                n_ticks: (10, 6),
            },
        )?;
        let pts: Vec<(f64, f64)> = x
            .iter()
            .copied()
            .zip(c.difference.delta_e.iter().copied())
            .collect();
        draw_curve(&mut chart, &pts, COLOURS[0], 2)?;
        if let Some(so) = &c.sampling_only {
            let pts: Vec<(f64, f64)> = x.iter().copied().zip(so.delta_e.iter().copied()).collect();
            draw_curve(&mut chart, &pts, COLOURS[1], 2)?;
        }
        Ok(())
    })
}

/// PNG of the residuals model − data of every valid candidate over the observations.
pub fn fit_residuals_png(
    title: &str,
    obs: &Observations,
    candidates: &[Candidate],
) -> Result<Vec<u8>> {
    let valid: Vec<&Candidate> = candidates.iter().filter(|c| c.valid).collect();
    if valid.is_empty() || obs.is_empty() {
        return Err(Error::invalid("fit plot", "no valid fitted model to plot"));
    }
    let mut ymax: f64 = 1e-9;
    let series: Vec<Vec<(f64, f64)>> = valid
        .iter()
        .map(|c| {
            obs.lambda_nm
                .iter()
                .zip(&obs.n)
                .map(|(&l, &n)| {
                    let r = c.model.n_at(l) - n;
                    ymax = ymax.max(r.abs());
                    (l, r)
                })
                .collect()
        })
        .collect();
    let x0 = obs.lambda_nm[0];
    let x1 = obs.lambda_nm[obs.len() - 1];
    render_png_bytes((1400, 800), |root| {
        let (w, _) = root.dim_in_pixel();
        let style = TextSpec::new(26.0, INK, HPos::Center, VPos::Center);
        let t = fit_text(&root, title, style.size_px, w - 40)?;
        draw_text(&root, &t, (w as i32 / 2, TITLE_H / 2 + 4), style)?;
        let (_, body) = root.split_vertically(TITLE_H);
        let (plot_area, legend) = body.split_horizontally(w - 330);
        let mut chart = spectral_axes(
            &plot_area,
            &AxesSpec {
                caption: None,
                x_label: "wavelength (nm)",
                y_label: "n(model) − n(data)",
                x_range: (x0, x1),
                y_range: (-1.1 * ymax, 1.1 * ymax),
                n_ticks: (10, 8),
            },
        )?;
        let label = TextSpec::new(16.0, INK, HPos::Left, VPos::Center);
        for (i, (c, pts)) in valid.iter().zip(&series).enumerate() {
            let colour = COLOURS[i % COLOURS.len()];
            draw_curve(&mut chart, pts, colour, 2)?;
            let y = 40 + 30 * i as i32;
            legend
                .draw(&Rectangle::new(
                    [(10, y - 3), (40, y + 3)],
                    RGBColor(colour[0], colour[1], colour[2]).filled(),
                ))
                .map_err(draw_err)?;
            let text = format!("{}  max |Δn| {:.1e}", c.kind.key(), c.max_abs_residual);
            draw_text(&legend, &text, (50, y), label)?;
        }
        Ok(())
    })
}
