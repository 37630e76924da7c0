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

/// Blue for "too dark", red for "too bright" (ColorBrewer RdBu ends).
const TOO_DARK: [f64; 3] = [33.0, 102.0, 172.0];
const TOO_BRIGHT: [f64; 3] = [178.0, 24.0, 43.0];

/// Diverging colour of a signed difference `t` in units of the colour range (clipped to ±1):
/// white at 0, red for t > 0 (too bright), blue for t < 0 (too dark).
pub fn difference_colour(t: f64) -> RGBColor {
    let t = if t.is_finite() {
        t.clamp(-1.0, 1.0)
    } else {
        0.0
    };
    let end = if t >= 0.0 { TOO_BRIGHT } else { TOO_DARK };
    let a = t.abs();
    let c = |k: usize| (255.0 + (end[k] - 255.0) * a).round() as u8;
    RGBColor(c(0), c(1), c(2))
}

/// Reinhard tone map of an illuminance image: L = 0.18·E/Ē (Ē the log-average of the positive
/// values), displayed as L/(1 + L) in grey.
fn tone_map(values: &[f64], log_avg: f64) -> Vec<u8> {
    values
        .iter()
        .map(|&e| {
            let l = if log_avg > 0.0 {
                0.18 * e.max(0.0) / log_avg
            } else {
                0.0
            };
            (255.0 * (l / (1.0 + l))).round() as u8
        })
        .collect()
}

/// Fig. 9-style figure of one profile and height: row 1 the MC reference (tone-mapped), then
/// one row of false-colour differences (E − E_ref) per method, one column per orientation.
/// Differences are in units of the largest reference illuminance of the height and saturate at
/// ±`range` (e.g. 0.1 = ±10 % of the peak); a colour bar says so. Each row label carries the
/// method's NRMS.
pub fn benchmark_difference_png(
    case: &crate::photometry::benchmark::CaseResult,
    spec: &crate::photometry::benchmark::BenchmarkSpec,
    range: f64,
) -> Result<Vec<u8>> {
    use crate::error::Error;
    let n = spec.resolution_px;
    if !(range > 0.0 && range.is_finite()) {
        return Err(Error::invalid(
            "--diff-range",
            "expected a positive fraction",
        ));
    }
    let Some(reference) = case.images.first() else {
        return Err(Error::invalid("benchmark figure", "no reference image"));
    };
    let cols = reference.images.len();
    if n == 0 || cols == 0 || reference.images.iter().any(|i| i.len() != n * n) {
        return Err(Error::invalid(
            "benchmark figure",
            "images do not match the resolution",
        ));
    }
    let zoom = (160 / n).clamp(1, 8);
    let tile = (n * zoom) as i32;
    let (left, top, gap, right, bottom) = (190i32, 78i32, 6i32, 175i32, 16i32);
    let rows = case.images.len() as i32;
    let width = left + cols as i32 * (tile + gap) + right;
    let height = top + rows * (tile + gap) + bottom;
    let peak = reference
        .images
        .iter()
        .flatten()
        .fold(0.0f64, |m, &v| m.max(v));
    let positives: Vec<f64> = reference
        .images
        .iter()
        .flatten()
        .copied()
        .filter(|&v| v > 0.0)
        .collect();
    let log_avg = if positives.is_empty() {
        0.0
    } else {
        (positives.iter().map(|v| v.ln()).sum::<f64>() / positives.len() as f64).exp()
    };
    let nrms_of = |label: &str| -> Option<f64> {
        if let Some(k) = label.strip_prefix("mc ") {
            let k: usize = k.parse().ok()?;
            return case
                .mc_ladder
                .iter()
                .find(|m| m.samples == Some(k))
                .map(|m| m.nrms);
        }
        case.methods
            .iter()
            .find(|m| m.method == label)
            .map(|m| m.nrms)
    };
    let title = format!(
        "{} — h = {} m: E − E_ref in % of the peak {:.4} lx (red too bright, blue too dark)",
        case.profile, case.height_m, peak
    );
    let orientations: Vec<String> = spec
        .orientations_rad
        .iter()
        .map(|t| {
            let f = t / std::f64::consts::PI;
            match (f * 8.0).round() as i64 {
                k if ((f * 8.0) - k as f64).abs() < 1e-9 => match k {
                    8 => "θ = π".to_string(),
                    4 => "θ = π/2".to_string(),
                    6 => "θ = 3π/4".to_string(),
                    k => format!("θ = {k}π/8"),
                },
                _ => format!("θ = {f:.3}π"),
            }
        })
        .collect();
    let labels: Vec<(String, String)> = case
        .images
        .iter()
        .map(|m| {
            let second = if m.label == "reference" {
                format!("{:.0} samples/pt", case.reference.samples_per_point_mean)
            } else {
                nrms_of(&m.label)
                    .map(|e| format!("NRMS {:.2} %", 100.0 * e))
                    .unwrap_or_default()
            };
            (m.label.clone(), second)
        })
        .collect();
    let images = case.images.clone();
    render_png_bytes((width as u32, height as u32), move |root| {
        draw_text(
            &root,
            &title,
            (width / 2, 22),
            TextSpec::new(17.0, INK, HPos::Center, VPos::Center),
        )?;
        for (c, o) in orientations.iter().enumerate() {
            let x = left + c as i32 * (tile + gap) + tile / 2;
            draw_text(
                &root,
                o,
                (x, top - 18),
                TextSpec::new(15.0, INK, HPos::Center, VPos::Center),
            )?;
        }
        for (r, m) in images.iter().enumerate() {
            let y0 = top + r as i32 * (tile + gap);
            draw_text(
                &root,
                &labels[r].0,
                (left - 12, y0 + tile / 2 - 10),
                TextSpec::new(16.0, INK, HPos::Right, VPos::Center),
            )?;
            draw_text(
                &root,
                &labels[r].1,
                (left - 12, y0 + tile / 2 + 12),
                TextSpec::new(13.0, INK, HPos::Right, VPos::Center),
            )?;
            for (c, img) in m.images.iter().enumerate() {
                let x0 = left + c as i32 * (tile + gap);
                root.draw(&Rectangle::new(
                    [(x0 - 1, y0 - 1), (x0 + tile, y0 + tile)],
                    RGBColor(190, 190, 190),
                ))
                .map_err(draw_err)?;
                let grey = (r == 0).then(|| tone_map(img, log_avg));
                for (k, &e) in img.iter().enumerate() {
                    let colour = match &grey {
                        Some(g) => RGBColor(g[k], g[k], g[k]),
                        None => {
                            let d = e - reference.images[c][k];
                            let t = if peak > 0.0 { d / (peak * range) } else { 0.0 };
                            difference_colour(t)
                        }
                    };
                    let (py, px) = ((k / n) * zoom, (k % n) * zoom);
                    for dy in 0..zoom {
                        for dx in 0..zoom {
                            root.draw_pixel(
                                (x0 + (px + dx) as i32, y0 + (py + dy) as i32),
                                &colour,
                            )
                            .map_err(draw_err)?;
                        }
                    }
                }
            }
        }
        // colour bar beside the difference rows
        let bx = left + cols as i32 * (tile + gap) + 20;
        let (by0, by1) = (top + tile + gap, top + rows * (tile + gap) - gap);
        let span = (by1 - by0).max(1);
        for y in by0..by1 {
            let t = 1.0 - 2.0 * f64::from(y - by0) / f64::from(span);
            root.draw(&Rectangle::new(
                [(bx, y), (bx + 22, y + 1)],
                difference_colour(t).filled(),
            ))
            .map_err(draw_err)?;
        }
        root.draw(&Rectangle::new([(bx, by0), (bx + 22, by1)], INK))
            .map_err(draw_err)?;
        let pct = 100.0 * range;
        for (t, label) in [
            (1.0, format!("+{pct:.0} % too bright")),
            (0.0, "0".to_string()),
            (-1.0, format!("−{pct:.0} % too dark")),
        ] {
            let y = by0 + ((1.0 - t) / 2.0 * f64::from(span)).round() as i32;
            draw_text(
                &root,
                &label,
                (bx + 28, y.clamp(by0 + 6, by1 - 6)),
                TextSpec::new(13.0, INK, HPos::Left, VPos::Center),
            )?;
        }
        Ok(())
    })
}
