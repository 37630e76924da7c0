//! Afterimage charts (Mikamo et al. 2013): the curves — Y_M(t) (Fig. 2) beside the xy track on
//! the CIE 1931 chromaticity diagram (Fig. 3, 5) — and a side-by-side figure of the input, the
//! mask and frames at a few times (Fig. 7, 8).

use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, VPos};

use super::{draw_curve, draw_err, render_png_bytes, spectral_axes, AxesSpec, TextSpec, INK};
use crate::afterimage::mikamo2013::{
    display_matrices, CurvePoint, REFERENCE_XY_TABLE1, REFERENCE_XY_TEXT, TABLE1_T_S, TABLE1_XY,
};
use crate::afterimage::LinearImage;
use crate::colorimetry::observer::{Observer, StandardObserver};
use crate::colorimetry::rgb::{eotf_inverse_srgb, D65_XY};
use crate::colorimetry::xyy::xyy_to_xyz;
use crate::error::{Error, Result};
use crate::math::linalg::mat3_mul_vec;

/// Size of the curves chart, px.
const CURVES_SIZE_PX: (u32, u32) = (1700, 760);

/// Display colour (8-bit sRGB) of a chromaticity at a bright, gamut-clipped luminance.
fn swatch(xy: [f64; 2]) -> Result<[u8; 3]> {
    let (_, to_rgb) = display_matrices()?;
    let rgb = mat3_mul_vec(&to_rgb, xyy_to_xyz([xy[0], xy[1], 1.0])).map(|c| c.max(0.0));
    let m = rgb.iter().cloned().fold(0.0, f64::max).max(1e-12);
    Ok(rgb.map(|c| (eotf_inverse_srgb(c / m) * 255.0).round() as u8))
}

/// The curves chart as PNG bytes: left Y_M(t) with the Table 1 times marked, right the (x, y)
/// track on the CIE 1931 diagram with the spectral locus, the sRGB gamut, Table 1's samples,
/// the two printed reference lights and D65.
///
/// # Errors
/// Fewer than two points, or a drawing failure.
pub fn curves_chart(points: &[CurvePoint]) -> Result<Vec<u8>> {
    if points.len() < 2 {
        return Err(Error::invalid(
            "plot",
            "fewer than two curve points; expected a time grid",
        ));
    }
    let t_end = points.iter().map(|p| p.t_s).fold(0.0, f64::max);
    let y_max = points.iter().map(|p| p.big_y).fold(0.0, f64::max) * 1.08;
    let observer = Observer::standard(StandardObserver::Cie1931_2)?;
    let cmfs = observer.cmfs();
    let mut locus: Vec<(f64, f64)> = Vec::new();
    for (i, &l) in cmfs.wavelengths().iter().enumerate() {
        if !(380.0..=700.0).contains(&l) {
            continue;
        }
        let (x, y, z) = (cmfs.channel(0)[i], cmfs.channel(1)[i], cmfs.channel(2)[i]);
        let s = x + y + z;
        if s > 0.0 {
            locus.push((x / s, y / s));
        }
    }
    if let Some(&first) = locus.first() {
        locus.push(first);
    }
    let track: Vec<(f64, f64)> = points.iter().map(|p| (p.x, p.y)).collect();
    let lum: Vec<(f64, f64)> = points.iter().map(|p| (p.t_s, p.big_y)).collect();
    let mut table_swatches = Vec::new();
    for xy in TABLE1_XY {
        table_swatches.push(swatch(xy)?);
    }
    render_png_bytes(CURVES_SIZE_PX, |root| {
        let (left, right) = root.split_horizontally(900);
        {
            let spec = AxesSpec {
                caption: Some("Luminance transition Y_M(t) (Eq. 3)"),
                x_label: "time after the stimulus t (s)",
                y_label: "Y_M (relative, display white = 1)",
                x_range: (0.0, t_end.max(1.0)),
                y_range: (0.0, y_max),
                n_ticks: (9, 8),
            };
            let mut chart = spectral_axes(&left, &spec)?;
            draw_curve(&mut chart, &lum, [30, 30, 30], 2)?;
            let marks: Vec<(f64, f64)> = TABLE1_T_S
                .iter()
                .filter(|t| **t <= t_end)
                .map(|&t| (t, crate::afterimage::luminance_y(t)))
                .collect();
            chart
                .draw_series(
                    marks
                        .iter()
                        .zip(&table_swatches)
                        .map(|(&p, c)| Circle::new(p, 6, RGBColor(c[0], c[1], c[2]).filled())),
                )
                .map_err(draw_err)?;
            chart
                .draw_series(marks.iter().map(|&p| Circle::new(p, 6, INK.stroke_width(1))))
                .map_err(draw_err)?;
        }
        {
            let spec = AxesSpec {
                caption: Some("Colour transition on the CIE 1931 xy diagram (Table 1)"),
                x_label: "x",
                y_label: "y",
                x_range: (0.0, 0.8),
                y_range: (0.0, 0.9),
                n_ticks: (9, 10),
            };
            let mut chart = spectral_axes(&right, &spec)?;
            draw_curve(&mut chart, &locus, [120, 120, 120], 2)?;
            let tri = [[0.64, 0.33], [0.30, 0.60], [0.15, 0.06], [0.64, 0.33]];
            let tri: Vec<(f64, f64)> = tri.iter().map(|p| (p[0], p[1])).collect();
            draw_curve(&mut chart, &tri, [170, 170, 200], 1)?;
            draw_curve(&mut chart, &track, [30, 30, 30], 2)?;
            chart
                .draw_series(
                    TABLE1_XY
                        .iter()
                        .zip(&table_swatches)
                        .map(|(p, c)| Circle::new((p[0], p[1]), 7, RGBColor(c[0], c[1], c[2]).filled())),
                )
                .map_err(draw_err)?;
            chart
                .draw_series(
                    TABLE1_XY
                        .iter()
                        .map(|p| Circle::new((p[0], p[1]), 7, INK.stroke_width(1))),
                )
                .map_err(draw_err)?;
            for (xy, shape) in [(REFERENCE_XY_TEXT, 0), (REFERENCE_XY_TABLE1, 1), (D65_XY, 2)] {
                let p = (xy[0], xy[1]);
                match shape {
                    0 => chart
                        .draw_series(std::iter::once(Cross::new(p, 8, RED.stroke_width(2))))
                        .map(|_| ())
                        .map_err(draw_err)?,
                    1 => chart
                        .draw_series(std::iter::once(TriangleMarker::new(p, 9, BLUE.stroke_width(2))))
                        .map(|_| ())
                        .map_err(draw_err)?,
                    _ => chart
                        .draw_series(std::iter::once(Circle::new(p, 4, INK.filled())))
                        .map(|_| ())
                        .map_err(draw_err)?,
                }
            }
            // Labels: every 20 s on the track, and the legend of the markers.
            let area = chart.plotting_area();
            let style = TextSpec::new(15.0, INK, HPos::Left, VPos::Center);
            for (t, xy) in TABLE1_T_S.iter().zip(TABLE1_XY) {
                if (*t as usize) % 20 == 0 {
                    let (px, py) = area.map_coordinate(&(xy[0], xy[1]));
                    let (bx, by) = right.get_base_pixel();
                    super::draw_text(&right, &format!("{t:.0} s"), (px - bx + 10, py - by - 10), style)?;
                }
            }
            let (bx, by) = right.get_base_pixel();
            let (px, _) = area.get_pixel_range();
            let (_, py) = area.get_pixel_range();
            let x0 = px.end - bx - 300;
            let y0 = py.start - by + 20;
            for (i, line) in [
                "× reference light of §3.2 (0.43, 0.40)",
                "▲ Table 1 at 0 s (0.41, 0.42), default",
                "● D65; grey: spectral locus, sRGB gamut",
            ]
            .iter()
            .enumerate()
            {
                super::draw_text(&right, line, (x0, y0 + 22 * i as i32), style)?;
            }
        }
        Ok(())
    })
}

/// One tile of the side-by-side figure.
pub struct FigureTile<'a> {
    /// Title above the tile.
    pub title: String,
    /// Linear sRGB image (shown clipped and sRGB-encoded).
    pub image: &'a LinearImage,
}

/// The side-by-side figure (Fig. 7/8): tiles left to right, each scaled to `tile_width_px`,
/// titled. PNG bytes.
///
/// # Errors
/// No tile, tiles of different aspect, or a drawing failure.
pub fn side_by_side_figure(tiles: &[FigureTile<'_>], tile_width_px: u32) -> Result<Vec<u8>> {
    let first = tiles
        .first()
        .ok_or_else(|| Error::invalid("plot", "no tile; expected at least one image"))?;
    let (w0, h0) = (first.image.width, first.image.height);
    let tw = tile_width_px.max(16);
    let th = ((f64::from(tw) * h0 as f64 / w0 as f64).round() as u32).max(1);
    let pad = 12u32;
    let title_h = 34u32;
    let width = pad + tiles.len() as u32 * (tw + pad);
    let height = title_h + th + 2 * pad;
    render_png_bytes((width, height), |root| {
        root.fill(&RGBColor(245, 245, 245)).map_err(draw_err)?;
        for (k, tile) in tiles.iter().enumerate() {
            let img = tile.image;
            let x0 = (pad + k as u32 * (tw + pad)) as i32;
            let y0 = (title_h + pad) as i32;
            let style = TextSpec::new(17.0, INK, HPos::Center, VPos::Center);
            let title = super::fit_text(&root, &tile.title, style.size_px, tw)?;
            super::draw_text(&root, &title, (x0 + tw as i32 / 2, (title_h / 2 + pad / 2) as i32), style)?;
            for ty in 0..th {
                let sy = ((ty as usize * img.height) / th as usize).min(img.height - 1);
                for tx in 0..tw {
                    let sx = ((tx as usize * img.width) / tw as usize).min(img.width - 1);
                    let i = 3 * (sy * img.width + sx);
                    let c = [0, 1, 2].map(|j| {
                        (eotf_inverse_srgb(f64::from(img.rgb[i + j]).clamp(0.0, 1.0)) * 255.0)
                            .round() as u8
                    });
                    root.draw_pixel((x0 + tx as i32, y0 + ty as i32), &RGBColor(c[0], c[1], c[2]))
                        .map_err(draw_err)?;
                }
            }
        }
        Ok(())
    })
}
