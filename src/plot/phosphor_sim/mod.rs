//! Charts for `phos simulate` (emission under an irradiance history) and `phos design`
//! (keyframe targets against the designed material).
//!
//! - [`simulate_chart`]: the emission L_p (Eq. 3) per band, or per camera channel when a camera
//!   is given, over time, with the lit intervals of the history shaded; below it, the irradiance
//!   history E per band (bands with identical histories drawn as one line).
//! - [`design_chart`]: the irradiance history E_c per channel; below it the designed outgoing
//!   radiance ρ_c E_c/π + Λ_c k_r r(t) per channel (solid), the grid optimum before refinement
//!   (dashed, when it differs), the keyframe targets L̂ (points) and the relative residual
//!   ‖L − L̂‖/‖L̂‖ of every keyframe in a caption.
//!
//! The emission / radiance axis is chosen automatically: log₁₀ when the plotted values span at
//! least [`LOG_AXIS_DECADES`] decades (largest value over the 5th percentile of the positive
//! values), linear otherwise; the axis description says which and the span. On a log axis the
//! floor is at most [`LOG_FLOOR_DECADES`] decades below the largest value and values ≤ 0 leave
//! gaps. Time is shown in s, min or h depending on the span.
//!
//! Files: this one holds the simulation chart and what both charts share (sizes, colours, the
//! chart descriptions); `design.rs` the design chart; `kit.rs` the plotting kit (axis choice,
//! number formats, band colours, step geometry, decimation, lines, titles, the legend).

// `!(a > b)` comparisons deliberately reject NaN along with out-of-range values.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use std::path::Path;

use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, VPos};

use super::{
    draw_err, draw_text, fit_text, needs_halo, render_png_bytes, spectral_axes, text_width,
    AxesSpec, TextSpec, INK, MUTED_INK,
};
use crate::error::{Error, Result};
use crate::phosphor::design::{
    irradiance_at, outgoing_radiance, Design, DesignStage, IrradianceHistory, Keyframe,
};
use crate::phosphor::{BandSet, Integrator, Material, Segment, Simulation};

mod design;
mod kit;

pub use design::{design_chart, design_chart_png};
use kit::*;

/// Size of the `phos simulate` chart in pixels.
pub const SIMULATE_SIZE_PX: (u32, u32) = (1400, 1000);
/// Size of the `phos design` chart in pixels.
pub const DESIGN_SIZE_PX: (u32, u32) = (1400, 1100);
/// Decades spanned by the plotted values from which the radiance axis is logarithmic.
pub const LOG_AXIS_DECADES: f64 = 2.0;
/// Deepest a log axis reaches below the largest value, in decades.
pub const LOG_FLOOR_DECADES: f64 = 6.0;

/// Height of the two-line title band.
const TITLE_H: i32 = 84;
/// Width of the legend column right of the panels.
const LEGEND_W: u32 = 340;
/// Legend row height and font size in pixels.
const LEGEND_ROW_H: i32 = 26;
const LEGEND_FONT_PX: f64 = 15.0;
/// Most points drawn per curve (longer curves are reduced to the min and max per bucket).
const MAX_POINTS: usize = 4000;
/// Uniform samples of the design curves (keyframe and history-row times are added).
const N_FINE: usize = 1200;
/// History rows up to which the design curves get exact steps at every row start.
const MAX_STEP_ROWS: usize = 20_000;
/// Height of the keyframe-residual caption of the design chart.
const CAPTION_H: i32 = 118;

const CHANNEL_COLOURS: [[u8; 3]; 3] = [[200, 40, 40], [40, 150, 60], [40, 70, 200]];
const CHANNEL_NAMES: [&str; 3] = ["R", "G", "B"];
/// Line colour of several bands or channels sharing one irradiance history.
const GROUP_COLOUR: [u8; 3] = [70, 70, 70];
/// Fill of the lit intervals in the emission panel.
const LIT_SHADE: RGBColor = RGBColor(255, 214, 110);
const LIT_ALPHA: f64 = 0.28;

/// A labelled, coloured curve (label, 8-bit sRGB line colour, values or points).
type Series<T> = (String, [u8; 3], Vec<T>);

/// What [`simulate_chart`] draws.
pub struct SimulateChart<'a> {
    /// The simulated material (name, bands).
    pub material: &'a Material,
    /// The integrator used (named in the title).
    pub integrator: Integrator,
    /// The largest time step in s (named in the title).
    pub dt_s: f64,
    /// The irradiance history, per band of the material.
    pub history: &'a [Segment],
    /// The simulation under `history` (times from 0).
    pub sim: &'a Simulation,
    /// Camera RGB per sample of `sim`; when given, the emission panel shows these three
    /// channels instead of the bands.
    pub camera_rgb: Option<&'a [[f64; 3]]>,
}

/// What [`design_chart`] draws.
pub struct DesignChart<'a> {
    /// Name of the designed material (title).
    pub name: &'a str,
    /// The irradiance history the design was made for.
    pub history: &'a IrradianceHistory,
    /// The keyframe targets, in any order (sorted by time as in the design).
    pub keyframes: &'a [Keyframe],
    /// Albedo per channel used by the design.
    pub albedo: [f64; 3],
    /// The design result.
    pub design: &'a Design,
    /// Whether the grid optimum was refined (false for `--grid-only`: only the grid curve).
    pub refined: bool,
}

/// Writes the simulation chart (PNG of [`SIMULATE_SIZE_PX`]): emission per band or camera
/// channel over time above the irradiance history per band.
///
/// # Errors
/// [`Error::InvalidArgument`] / [`Error::ShapeMismatch`] when the simulation, history and
/// camera values do not fit together or nothing finite is left to draw; [`Error::Io`] when the
/// file cannot be written (nothing is left behind).
pub fn simulate_chart(path: &Path, c: &SimulateChart<'_>) -> Result<()> {
    crate::io::atomic_write(path, &simulate_chart_png(c)?)
}

/// The chart of [`simulate_chart`] as PNG bytes (nothing written).
pub fn simulate_chart_png(c: &SimulateChart<'_>) -> Result<Vec<u8>> {
    let sim = c.sim;
    let n = sim.t_s.len();
    let nb = c.material.bands.len();
    if n < 2 {
        return Err(Error::invalid(
            "plot",
            "the simulation has fewer than two samples; nothing to draw over time",
        ));
    }
    if sim.emission.len() != n || sim.emission.iter().any(|e| e.len() != nb) {
        return Err(Error::ShapeMismatch {
            what: "emission samples against the times and bands".into(),
            expected: n * nb,
            got: sim.emission.iter().map(Vec::len).sum(),
        });
    }
    if c.history.is_empty() || c.history.iter().any(|s| s.irradiance.len() != nb) {
        return Err(Error::invalid(
            "plot",
            format!("the history needs at least one segment with {nb} irradiance values"),
        ));
    }
    let total_s: f64 = c.history.iter().map(|s| s.duration_s).sum();
    let t_end = total_s.max(sim.t_s[n - 1]);
    if !(t_end > 0.0 && t_end.is_finite()) {
        return Err(Error::invalid("plot", "the history spans no time"));
    }
    let (unit_s, unit) = time_unit(t_end);
    let times: Vec<f64> = sim.t_s.iter().map(|t| t / unit_s).collect();

    // Emission series: per camera channel, or per band.
    let band_labels = band_labels(&c.material.bands);
    let band_colours = band_colours(&c.material.bands);
    let (what, series): (&str, Vec<Series<f64>>) = match c.camera_rgb {
        Some(rgb) => {
            if rgb.len() != n {
                return Err(Error::ShapeMismatch {
                    what: "camera RGB samples against the simulation times".into(),
                    expected: n,
                    got: rgb.len(),
                });
            }
            (
                "camera RGB of the emission",
                (0..3)
                    .map(|ch| {
                        (
                            format!("camera {}", CHANNEL_NAMES[ch]),
                            CHANNEL_COLOURS[ch],
                            rgb.iter().map(|v| v[ch]).collect(),
                        )
                    })
                    .collect(),
            )
        }
        None => (
            "emission L_p per band",
            (0..nb)
                .map(|b| {
                    (
                        band_labels[b].clone(),
                        band_colours[b],
                        sim.emission.iter().map(|e| e[b]).collect(),
                    )
                })
                .collect(),
        ),
    };
    let all: Vec<f64> = series.iter().flat_map(|s| s.2.iter().copied()).collect();
    let scale = YScale::choose(&all)?;
    let y_label = scale.label(if c.camera_rgb.is_some() {
        "camera RGB"
    } else {
        "emission L_p"
    });

    // Irradiance: bands with identical histories share one line.
    let groups = identical_groups(nb, |a, b| {
        c.history.iter().all(|s| s.irradiance[a] == s.irradiance[b])
    });
    let mut bounds = Vec::with_capacity(c.history.len() + 1);
    let mut t = 0.0;
    bounds.push(0.0);
    for s in c.history {
        t += s.duration_s;
        bounds.push(t / unit_s);
    }
    let e_max = c
        .history
        .iter()
        .flat_map(|s| s.irradiance.iter().copied())
        .fold(0.0_f64, f64::max);
    let lit = lit_intervals(
        &bounds,
        &c.history
            .iter()
            .map(|s| s.irradiance.iter().any(|v| *v > 0.0))
            .collect::<Vec<_>>(),
        t_end / unit_s,
    );
    let e_lines: Vec<Series<(f64, f64)>> = groups
        .iter()
        .map(|g| {
            let values: Vec<f64> = c.history.iter().map(|s| s.irradiance[g[0]]).collect();
            let (label, colour) = group_style(g, &band_labels, &band_colours, "band", true);
            (label, colour, step_points(&bounds, &values))
        })
        .collect();

    let title = format!(
        "{}: emission under the irradiance history — {} integrator, dt ≤ {} s",
        c.material.name,
        integrator_name(c.integrator),
        fmt_sig(c.dt_s)
    );
    let subtitle = format!(
        "{} state{}, {} band{}, {} segment{} over {} s; lit intervals (E > 0) shaded",
        c.material.states.len(),
        plural(c.material.states.len()),
        nb,
        plural(nb),
        c.history.len(),
        plural(c.history.len()),
        fmt_sig(total_s)
    );
    let x_label = format!("time ({unit})");
    let x_range = (0.0, t_end / unit_s);

    render_png_bytes(SIMULATE_SIZE_PX, |root| {
        draw_title(&root, &title, &subtitle)?;
        let (_, body) = root.split_vertically(TITLE_H);
        let (w_body, h_body) = body.dim_in_pixel();
        let (plots, legend) = body.split_horizontally(w_body - LEGEND_W);
        let top_h = h_body * 62 / 100;
        let (top, bottom) = plots.split_vertically(top_h);

        let mut chart = spectral_axes(
            &top,
            &AxesSpec {
                caption: Some(what),
                x_label: &x_label,
                y_label: &y_label,
                x_range,
                y_range: (scale.lo, scale.hi),
                n_ticks: (10, 8),
            },
        )?;
        shade(&mut chart, &lit, (scale.lo, scale.hi))?;
        for (_, colour, values) in &series {
            let pts: Vec<(f64, f64)> = times.iter().copied().zip(values.iter().copied()).collect();
            draw_line(&mut chart, &scale.map_points(&pts), *colour, 2, false)?;
        }

        irradiance_panel(
            &bottom,
            "irradiance history E per band",
            &x_label,
            x_range,
            e_max,
            &e_lines,
            5,
        )?;

        let mut top_items: Vec<LegendItem> = vec![LegendItem::heading(what)];
        top_items.extend(series.iter().map(|(label, colour, values)| {
            if values.iter().all(|v| *v == 0.0) {
                LegendItem::line(&format!("{label}: zero throughout"), *colour, false)
            } else if values
                .iter()
                .any(|v| scale.map(*v).is_some_and(|y| y > scale.lo))
            {
                LegendItem::line(label, *colour, false)
            } else {
                LegendItem::line(&format!("{label}: below the axis"), *colour, false)
            }
        }));
        top_items.push(LegendItem {
            mark: Mark::Swatch(LIT_SHADE.mix(LIT_ALPHA + 0.2).to_rgba()),
            label: "light on (E > 0)".into(),
        });
        draw_legend(&legend, 40, top_h as i32 - 20, &top_items)?;
        let mut e_items = vec![LegendItem::heading("irradiance E")];
        e_items.extend(
            e_lines
                .iter()
                .map(|(label, colour, _)| LegendItem::line(label, *colour, false)),
        );
        draw_legend(&legend, top_h as i32 + 40, h_body as i32 - 20, &e_items)?;
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::super::tests::{decode, is_single_colour};
    use super::*;
    use crate::phosphor::design::{design_from_keyframes, DesignOptions};
    use crate::phosphor::{simulate, table1_material};

    #[test]
    fn y_scale_is_logarithmic_only_when_the_values_span_two_decades() {
        let lin = YScale::choose(&[0.0, 0.5, 1.0, 2.0, 3.0]).expect("scale");
        assert!(!lin.log);
        assert_eq!(lin.lo, 0.0);
        let values: Vec<f64> = (0..100).map(|i| (-0.1 * i as f64).exp()).collect();
        let log = YScale::choose(&values).expect("scale");
        assert!(log.log && log.decades > 3.0, "{log:?}");
        assert!(log.hi > 0.0 && log.lo < -3.5);
        assert!(log.label("x").contains("log10"));
        // Negative values rule out a log axis however wide the span.
        let mut neg = values.clone();
        neg.push(-0.1);
        assert!(!YScale::choose(&neg).expect("scale").log);
        assert!(YScale::choose(&[f64::NAN]).is_err());
        // A log axis stops LOG_FLOOR_DECADES below the largest value; lower values are gaps.
        let deep: Vec<f64> = (0..60).map(|i| 10f64.powi(-i)).collect();
        let s = YScale::choose(&deep).expect("scale");
        assert!(
            s.log && s.map(1e-5).is_some() && s.map(1e-7).is_none(),
            "{s:?}"
        );
        assert!(s.label("x").contains("top 6 shown"), "{}", s.label("x"));
        // Huge linear values get a power of ten in the label instead of long tick labels.
        let big = YScale::choose(&[-3e12, 0.0, 5e12]).expect("scale");
        assert!(!big.log && big.exponent == 12 && big.map(5e12) == Some(5.0));
        assert!(big.label("x").contains("/ 1e12"));
    }

    #[test]
    fn decimate_keeps_extremes_and_the_last_point() {
        let pts: Vec<(f64, f64)> = (0..100_000)
            .map(|i| (i as f64, if i == 54_321 { 9.0 } else { (i % 7) as f64 }))
            .collect();
        let d = decimate(&pts, 1000);
        assert!(d.len() <= 1002, "{}", d.len());
        assert!(d.contains(&(54_321.0, 9.0)));
        assert_eq!(d.last(), pts.last());
        assert!(d.windows(2).all(|w| w[1].0 > w[0].0));
    }

    #[test]
    fn identical_histories_share_a_group() {
        let e = [[1.0, 1.0, 0.0], [0.0, 0.0, 2.0]];
        let g = identical_groups(3, |a, b| e.iter().all(|v| v[a] == v[b]));
        assert_eq!(g, vec![vec![0, 1], vec![2]]);
    }

    #[test]
    fn wavelength_colours_follow_the_spectrum_and_stay_dark_enough() {
        let blue = wavelength_colour(450.0);
        let red = wavelength_colour(680.0);
        assert!(blue[2] > blue[0] && red[0] > red[2]);
        for nm in (400..=700).step_by(10) {
            assert!(super::super::luminance_u8(wavelength_colour(nm as f64)) <= 0.31);
        }
    }

    #[test]
    fn fmt_sig_prints_four_significant_digits() {
        assert_eq!(fmt_sig(0.3), "0.3");
        assert_eq!(fmt_sig(437.5), "437.5");
        assert_eq!(fmt_sig(0.0123456), "0.01235");
        assert_eq!(fmt_sig(2.5e-7), "2.500e-7");
        assert_eq!(fmt_pct(0.0123), "1.23 %");
        assert_eq!(fmt_pct(1e-14), "1.0e-12 %");
    }

    #[test]
    fn simulate_chart_draws_bands_and_rejects_mismatched_camera_rgb() {
        let m = &table1_material("blue_paint").expect("table 1").material;
        let history = vec![
            Segment {
                duration_s: 300.0,
                irradiance: vec![1.0; 8],
            },
            Segment {
                duration_s: 200.0,
                irradiance: vec![0.0; 8],
            },
        ];
        let sim = simulate(m, &history, &[0.0], 2.0, Integrator::Exact).expect("simulation");
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("sim.png");
        let chart = SimulateChart {
            material: m,
            integrator: Integrator::Exact,
            dt_s: 2.0,
            history: &history,
            sim: &sim,
            camera_rgb: None,
        };
        simulate_chart(&path, &chart).expect("chart");
        let img = decode(&path);
        assert_eq!(img.dimensions(), SIMULATE_SIZE_PX);
        assert!(!is_single_colour(&img));
        let short = vec![[0.0; 3]; 3];
        let bad = SimulateChart {
            camera_rgb: Some(&short),
            ..chart
        };
        let other = dir.path().join("bad.png");
        assert!(matches!(
            simulate_chart(&other, &bad),
            Err(Error::ShapeMismatch { .. })
        ));
        assert!(!other.exists());
    }

    #[test]
    fn design_chart_draws_and_rejects_keyframes_that_do_not_match_the_design() {
        let hist = IrradianceHistory {
            t_s: (0..100).map(|i| i as f64 * 0.2).collect(),
            e: (0..100)
                .map(|i| if i < 40 { [1.0, 0.6, 0.3] } else { [0.0; 3] })
                .collect(),
        };
        let keys = [
            Keyframe {
                t_s: 4.0,
                radiance: [0.3, 0.25, 0.1],
            },
            Keyframe {
                t_s: 10.0,
                radiance: [0.05, 0.04, 0.01],
            },
            Keyframe {
                t_s: 16.0,
                radiance: [0.01, 0.008, 0.002],
            },
        ];
        let opts = DesignOptions {
            albedo: [0.5; 3],
            ..DesignOptions::default()
        };
        let d = design_from_keyframes(&hist, &keys, &opts).expect("design");
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("design.png");
        let chart = DesignChart {
            name: "test",
            history: &hist,
            keyframes: &keys,
            albedo: opts.albedo,
            design: &d,
            refined: true,
        };
        design_chart(&path, &chart).expect("chart");
        let img = decode(&path);
        assert_eq!(img.dimensions(), DESIGN_SIZE_PX);
        assert!(!is_single_colour(&img));
        let bad = DesignChart {
            keyframes: &keys[..2],
            ..chart
        };
        let other = dir.path().join("bad.png");
        assert!(design_chart(&other, &bad).is_err());
        assert!(!other.exists());
    }
}
