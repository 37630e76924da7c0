//! Excitation-fit chart: one panel per band with the measured RGB (points), the simulated
//! charging curve (lines) and the equilibrium level (dashed), over log₁₀ of the charging time.

use std::path::Path;

use plotters::prelude::*;

use super::{draw_err, render_png_bytes, spectral_axes, AxesSpec};
use crate::error::{Error, Result};
use crate::phosphor::excitation::{band_curve, ExcitationFit};
use crate::phosphor::{BandCamera, Material};

/// Width of the figure in pixels; each band panel is [`PANEL_PX`] high.
const WIDTH_PX: u32 = 1200;
/// Height of one band panel in pixels.
const PANEL_PX: u32 = 360;
/// Points of the model curves.
const N_FINE: usize = 300;

const CHANNEL_COLOURS: [RGBColor; 3] = [
    RGBColor(200, 40, 40),
    RGBColor(40, 150, 60),
    RGBColor(40, 70, 200),
];

/// Writes the excitation chart (PNG): per fitted band, data, simulated charging curve and
/// equilibrium level per camera channel.
pub fn excitation_chart(
    path: &Path,
    title: &str,
    material: &Material,
    camera: &BandCamera,
    fit: &ExcitationFit,
) -> Result<()> {
    crate::io::atomic_write(path, &excitation_chart_png(title, material, camera, fit)?)
}

/// The chart of [`excitation_chart`] as PNG bytes (nothing written).
pub fn excitation_chart_png(
    title: &str,
    material: &Material,
    camera: &BandCamera,
    fit: &ExcitationFit,
) -> Result<Vec<u8>> {
    if fit.bands.is_empty() {
        return Err(Error::invalid("plot", "no fitted band to draw"));
    }
    let n = fit.bands.len() as u32;
    render_png_bytes((WIDTH_PX, PANEL_PX * n), |root| {
        let panels = root.split_evenly((n as usize, 1));
        for (panel, b) in panels.iter().zip(&fit.bands) {
            let tmin = b
                .charge_s
                .iter()
                .cloned()
                .filter(|t| *t > 0.0)
                .fold(f64::INFINITY, f64::min);
            let tmax = b.charge_s.iter().cloned().fold(0.0_f64, f64::max);
            let (x0, x1) = if tmin.is_finite() && tmax > tmin {
                (tmin.log10() - 0.1, tmax.log10() + 0.1)
            } else {
                (-1.0, 3.0)
            };
            let fine: Vec<f64> = (0..N_FINE)
                .map(|i| x0 + (x1 - x0) * i as f64 / (N_FINE - 1) as f64)
                .collect();
            let times: Vec<f64> = fine.iter().map(|x| 10f64.powf(*x)).collect();
            let curve = band_curve(material, camera, b, fit.switch_off_delay_s, &times);
            let ymax = b
                .data
                .iter()
                .chain(&curve)
                .chain(std::iter::once(&b.equilibrium))
                .flat_map(|v| v.iter())
                .fold(0.0_f64, |m, v| m.max(*v))
                .max(f64::MIN_POSITIVE)
                * 1.1;
            let ymin = b
                .data
                .iter()
                .flat_map(|v| v.iter())
                .fold(0.0_f64, |m, v| m.min(*v));
            let caption = format!(
                "{title} — band {}: k_e = {:.4e} ± {:.1e}{}",
                b.band + 1,
                b.k_e.first().copied().unwrap_or(0.0),
                b.k_e_sigma.first().copied().unwrap_or(0.0),
                if b.product_only {
                    " (unsaturated: only k_e·Λ determined)"
                } else {
                    ""
                }
            );
            let mut chart = spectral_axes(
                panel,
                &AxesSpec {
                    caption: Some(&caption),
                    x_label: "log10 charging time (s)",
                    y_label: "camera RGB after switch-off",
                    x_range: (x0, x1),
                    y_range: (ymin, ymax),
                    n_ticks: (8, 5),
                },
            )?;
            for c in 0..3 {
                let col = CHANNEL_COLOURS[c];
                chart
                    .draw_series(LineSeries::new(
                        fine.iter().zip(&curve).map(|(x, y)| (*x, y[c])),
                        col.stroke_width(2),
                    ))
                    .map_err(draw_err)?;
                let eq = b.equilibrium[c];
                chart
                    .draw_series(DashedLineSeries::new(
                        vec![(x0, eq), (x1, eq)],
                        8,
                        6,
                        col.stroke_width(1),
                    ))
                    .map_err(draw_err)?;
                chart
                    .draw_series(
                        b.charge_s
                            .iter()
                            .zip(&b.data)
                            .filter(|(t, _)| **t > 0.0)
                            .map(|(t, y)| Circle::new((t.log10(), y[c]), 4, col.filled())),
                    )
                    .map_err(draw_err)?;
            }
        }
        Ok(())
    })
}
