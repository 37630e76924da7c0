//! Datasheet-style polar intensity plot of a photometric file: the C0–C180 and C90–C270
//! curves, nadir (γ = 0°) at the bottom, intensities in cd with rings at ¼, ½, ¾ and 1 of a
//! round scale.

use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, VPos};

use super::{draw_err, draw_text, render_png_bytes, TextSpec, INK};
use crate::error::Result;
use crate::photometry::{CandelaGrid, PhotometricType};

const SIZE_PX: (u32, u32) = (900, 960);
const C0_RGB: RGBColor = RGBColor(200, 40, 40);
const C90_RGB: RGBColor = RGBColor(40, 80, 210);

/// A round number ≥ `x` (1, 2, 2.5, 5 × 10ᵏ).
fn round_up(x: f64) -> f64 {
    if x <= 0.0 {
        return 1.0;
    }
    let e = 10f64.powf(x.log10().floor());
    for m in [1.0, 2.0, 2.5, 5.0, 10.0] {
        if m * e >= x {
            return m * e;
        }
    }
    10.0 * e
}

/// The polar chart as PNG bytes (900 × 960 px). `title` is printed above it.
pub fn polar_chart_png(grid: &CandelaGrid, title: &str) -> Result<Vec<u8>> {
    let is_c = grid.kind == PhotometricType::C;
    // signed angle t in [-180, 180]: t ≥ 0 is plane c at γ = t, t < 0 is plane c+180 at γ = −t
    let curve = |c: f64| -> Vec<(f64, f64)> {
        (-1800..=1800)
            .map(|k| {
                let t = k as f64 * 0.1;
                let i = if is_c {
                    if t >= 0.0 {
                        grid.intensity(c, t)
                    } else {
                        grid.intensity(c + 180.0, -t)
                    }
                } else {
                    // Types A/B: the vertical-angle curve at H = 0 (c = 0) and the horizontal one at V = 0
                    if c == 0.0 {
                        grid.intensity(0.0, t)
                    } else {
                        grid.intensity(t, 0.0)
                    }
                };
                (t, i)
            })
            .collect()
    };
    let curves = [(0.0, C0_RGB), (90.0, C90_RGB)].map(|(c, col)| (c, col, curve(c)));
    let max = curves
        .iter()
        .flat_map(|c| c.2.iter().map(|p| p.1))
        .fold(0.0f64, f64::max);
    let scale = round_up(max);
    let title = title.to_string();
    render_png_bytes(SIZE_PX, move |root| {
        draw_text(
            &root,
            &title,
            (450, 24),
            TextSpec::new(22.0, INK, HPos::Center, VPos::Center),
        )?;
        let area = root.margin(60, 20, 20, 20);
        let mut chart = ChartBuilder::on(&area)
            .build_cartesian_2d(-1.15f64..1.15f64, -1.15f64..1.15f64)
            .map_err(draw_err)?;
        let grey = RGBColor(200, 200, 200);
        for k in 1..=4 {
            let r = k as f64 / 4.0;
            let ring: Vec<(f64, f64)> = (0..=360)
                .map(|a| {
                    let a = (a as f64).to_radians();
                    (r * a.sin(), r * a.cos())
                })
                .collect();
            chart
                .draw_series(LineSeries::new(ring, grey))
                .map_err(draw_err)?;
            chart
                .draw_series(std::iter::once(Text::new(
                    format!("{}", scale * r),
                    (0.02, -r + 0.02),
                    (super::FONT, 14)
                        .into_font()
                        .color(&RGBColor(110, 110, 110)),
                )))
                .map_err(draw_err)?;
        }
        for k in 0..12 {
            let a = (k as f64 * 30.0).to_radians();
            chart
                .draw_series(LineSeries::new(vec![(0.0, 0.0), (a.sin(), a.cos())], grey))
                .map_err(draw_err)?;
        }
        for (deg, label) in [
            (0.0, "0°"),
            (90.0, "90°"),
            (-90.0, "90°"),
            (180.0, "180°"),
            (45.0, "45°"),
            (-45.0, "45°"),
            (135.0, "135°"),
            (-135.0, "135°"),
        ] {
            let a = f64::to_radians(deg);
            chart
                .draw_series(std::iter::once(Text::new(
                    label.to_string(),
                    (1.07 * a.sin() - 0.03, -1.07 * a.cos() + 0.02),
                    (super::FONT, 15).into_font().color(&INK),
                )))
                .map_err(draw_err)?;
        }
        for (_, col, pts) in &curves {
            let xy: Vec<(f64, f64)> = pts
                .iter()
                .map(|&(t, i)| {
                    let r = i / scale;
                    let a = t.to_radians();
                    (r * a.sin(), -r * a.cos())
                })
                .collect();
            chart
                .draw_series(LineSeries::new(xy, col.stroke_width(3)))
                .map_err(draw_err)?;
        }
        let legend = if is_c {
            ["C0–C180", "C90–C270"]
        } else {
            ["V at H = 0", "H at V = 0"]
        };
        for (k, (name, col)) in legend.iter().zip([C0_RGB, C90_RGB]).enumerate() {
            let y = 60 + 26 * k as i32;
            root.draw(&PathElement::new(
                vec![(30, y), (70, y)],
                col.stroke_width(3),
            ))
            .map_err(draw_err)?;
            draw_text(
                &root,
                name,
                (80, y),
                TextSpec::new(17.0, INK, HPos::Left, VPos::Center),
            )?;
        }
        draw_text(
            &root,
            "cd",
            (860, 60),
            TextSpec::new(17.0, INK, HPos::Right, VPos::Center),
        )?;
        Ok(())
    })
}
