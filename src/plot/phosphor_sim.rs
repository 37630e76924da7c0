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

        let mut e_chart = spectral_axes(
            &bottom,
            &AxesSpec {
                caption: Some("irradiance history E per band"),
                x_label: &x_label,
                y_label: "irradiance E",
                x_range,
                y_range: (0.0, if e_max > 0.0 { e_max * 1.12 } else { 1.0 }),
                n_ticks: (10, 5),
            },
        )?;
        for (_, colour, pts) in &e_lines {
            let pts: Vec<(f64, Option<f64>)> = pts.iter().map(|(x, y)| (*x, Some(*y))).collect();
            draw_line(&mut e_chart, &pts, *colour, 2, false)?;
        }

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

/// Writes the design chart (PNG of [`DESIGN_SIZE_PX`]): irradiance history per channel above
/// the designed outgoing radiance per channel (refined solid, grid optimum dashed), the
/// keyframe targets as points, and the relative residual of every keyframe in a caption.
///
/// # Errors
/// [`Error::InvalidArgument`] / [`Error::ShapeMismatch`] when the keyframes do not match the
/// design or the history is invalid; [`Error::Io`] when the file cannot be written (nothing is
/// left behind).
pub fn design_chart(path: &Path, c: &DesignChart<'_>) -> Result<()> {
    crate::io::atomic_write(path, &design_chart_png(c)?)
}

/// The chart of [`design_chart`] as PNG bytes (nothing written).
pub fn design_chart_png(c: &DesignChart<'_>) -> Result<Vec<u8>> {
    let hist = c.history;
    let d = c.design;
    if c.keyframes.is_empty() {
        return Err(Error::invalid("plot", "no keyframes to draw"));
    }
    for (what, s) in [("refined", &d.refined), ("grid", &d.grid)] {
        if s.predicted.len() != c.keyframes.len() || s.relative_residual.len() != c.keyframes.len()
        {
            return Err(Error::ShapeMismatch {
                what: format!("keyframes of the {what} design against the targets"),
                expected: c.keyframes.len(),
                got: s.predicted.len(),
            });
        }
    }
    if hist.t_s.is_empty() || hist.t_s.len() != hist.e.len() {
        return Err(Error::invalid(
            "plot",
            "the history has no rows, or times and irradiances of different counts",
        ));
    }
    // The design sorts its keyframes this way; its per-keyframe vectors follow that order.
    let mut keys = c.keyframes.to_vec();
    keys.sort_by(|a, b| a.t_s.total_cmp(&b.t_s));

    let t0 = hist.t_s[0];
    let t_last = keys[keys.len() - 1].t_s.max(hist.t_s[hist.t_s.len() - 1]);
    let t_end = if t_last > t0 {
        t_last + 0.03 * (t_last - t0)
    } else {
        t0 + 1.0
    };
    let (unit_s, unit) = time_unit(t_end - t0);

    let final_stage = &d.refined;
    let show_grid = c.refined && !same_material(&d.grid, &d.refined);
    let times = design_times(hist, &keys, t0, t_end);
    let main = stage_curve(hist, c.albedo, final_stage, &times)?;
    let grid = if show_grid {
        Some(stage_curve(hist, c.albedo, &d.grid, &times)?)
    } else {
        None
    };
    let mut all: Vec<f64> = main.iter().flat_map(|(_, v)| v.iter().copied()).collect();
    if let Some(g) = &grid {
        all.extend(g.iter().flat_map(|(_, v)| v.iter().copied()));
    }
    all.extend(keys.iter().flat_map(|k| k.radiance.iter().copied()));
    let scale = YScale::choose(&all)?;
    // Targets ≤ 0 (or below the floor) cannot be drawn on a log axis.
    let hidden_targets = keys
        .iter()
        .flat_map(|k| k.radiance.iter())
        .filter(|v| scale.map(**v).is_none())
        .count();

    // Irradiance per channel as steps; the last row holds to the end.
    let mut bounds: Vec<f64> = hist.t_s.iter().map(|t| (t - t0) / unit_s).collect();
    bounds.push((t_end - t0) / unit_s);
    let groups = identical_groups(3, |a, b| hist.e.iter().all(|e| e[a] == e[b]));
    let labels: Vec<String> = CHANNEL_NAMES.iter().map(|n| format!("E_{n}")).collect();
    let colours = CHANNEL_COLOURS.to_vec();
    let e_lines: Vec<Series<(f64, f64)>> = groups
        .iter()
        .map(|g| {
            let values: Vec<f64> = hist.e.iter().map(|e| e[g[0]]).collect();
            let (label, colour) = group_style(g, &labels, &colours, "channel", false);
            (label, colour, step_points(&bounds, &values))
        })
        .collect();
    let e_max = hist
        .e
        .iter()
        .flat_map(|e| e.iter().copied())
        .fold(0.0_f64, f64::max);

    let worst = final_stage
        .relative_residual
        .iter()
        .fold(0.0_f64, |m, v| m.max(*v));
    let title = format!(
        "design '{}' from {} keyframe{} — {} (worst keyframe residual {})",
        c.name,
        keys.len(),
        plural(keys.len()),
        if d.reachable {
            "reachable"
        } else {
            "NOT reachable"
        },
        fmt_pct(worst)
    );
    let subtitle = format!(
        "{}: k_r = {} s⁻¹   k_e = ({})   Λ = ({})   albedo = ({})",
        if c.refined {
            "refined"
        } else {
            "grid optimum (no refinement)"
        },
        fmt_sig(final_stage.k_r_per_s),
        join_sig(&final_stage.k_e),
        join_sig(&final_stage.lambda),
        join_sig(&c.albedo)
    );
    let residual_entries: Vec<String> = keys
        .iter()
        .enumerate()
        .map(|(i, k)| {
            let mut s = format!(
                "t = {} {unit}: {}",
                fmt_sig((k.t_s - t0) / unit_s),
                fmt_pct(final_stage.relative_residual[i])
            );
            if show_grid {
                s.push_str(&format!(" (grid {})", fmt_pct(d.grid.relative_residual[i])));
            }
            s
        })
        .collect();
    let residual_head = format!(
        "relative keyframe residual ‖L − target‖/‖target‖ of the {} design{}:",
        if c.refined { "refined" } else { "grid-only" },
        if show_grid {
            ", grid optimum in brackets"
        } else {
            ""
        }
    );
    let mut note = d.note.clone();
    if hidden_targets > 0 {
        note.push_str(&format!(
            "; {hidden_targets} target value{} ≤ 0 or below the floor not shown on the log axis",
            plural(hidden_targets)
        ));
    }
    let x_label = if t0 == 0.0 {
        format!("time ({unit})")
    } else {
        format!("time since {} s ({unit})", fmt_sig(t0))
    };
    let x_range = (0.0, (t_end - t0) / unit_s);
    let y_label = scale.label("outgoing radiance L_o");
    let key_pts: Vec<(f64, [f64; 3])> = keys
        .iter()
        .map(|k| ((k.t_s - t0) / unit_s, k.radiance))
        .collect();
    let to_x = |pts: &[(f64, [f64; 3])], ch: usize| -> Vec<(f64, f64)> {
        pts.iter()
            .map(|(t, v)| ((t - t0) / unit_s, v[ch]))
            .collect()
    };

    render_png_bytes(DESIGN_SIZE_PX, |root| {
        draw_title(&root, &title, &subtitle)?;
        let (_, body) = root.split_vertically(TITLE_H);
        let (w_body, h_body) = body.dim_in_pixel();
        let (upper, caption) = body.split_vertically(h_body as i32 - CAPTION_H);
        let (_, h_upper) = upper.dim_in_pixel();
        let (plots, legend) = upper.split_horizontally(w_body - LEGEND_W);
        let top_h = h_upper * 30 / 100;
        let (top, bottom) = plots.split_vertically(top_h);

        let mut e_chart = spectral_axes(
            &top,
            &AxesSpec {
                caption: Some("irradiance history E per channel"),
                x_label: &x_label,
                y_label: "irradiance E",
                x_range,
                y_range: (0.0, if e_max > 0.0 { e_max * 1.12 } else { 1.0 }),
                n_ticks: (10, 4),
            },
        )?;
        for (_, colour, pts) in &e_lines {
            let pts: Vec<(f64, Option<f64>)> = pts.iter().map(|(x, y)| (*x, Some(*y))).collect();
            draw_line(&mut e_chart, &pts, *colour, 2, false)?;
        }

        let mut chart = spectral_axes(
            &bottom,
            &AxesSpec {
                caption: Some(
                    "outgoing radiance ρE/π + Λ k_r r(t) per channel, targets at the keyframes",
                ),
                x_label: &x_label,
                y_label: &y_label,
                x_range,
                y_range: (scale.lo, scale.hi),
                n_ticks: (10, 8),
            },
        )?;
        for (ch, colour) in CHANNEL_COLOURS.iter().enumerate() {
            if let Some(g) = &grid {
                draw_line(
                    &mut chart,
                    &scale.map_points(&to_x(g, ch)),
                    *colour,
                    2,
                    true,
                )?;
            }
            draw_line(
                &mut chart,
                &scale.map_points(&to_x(&main, ch)),
                *colour,
                2,
                false,
            )?;
        }
        for (ch, &[r, g, b]) in CHANNEL_COLOURS.iter().enumerate() {
            let pts: Vec<(f64, f64)> = key_pts
                .iter()
                .filter_map(|(x, v)| scale.map(v[ch]).map(|y| (*x, y.clamp(scale.lo, scale.hi))))
                .collect();
            chart
                .draw_series(
                    pts.iter()
                        .map(|p| Circle::new(*p, 7, RGBColor(r, g, b).filled())),
                )
                .map_err(draw_err)?;
            chart
                .draw_series(pts.iter().map(|p| Circle::new(*p, 7, INK.stroke_width(2))))
                .map_err(draw_err)?;
        }

        let mut e_items = vec![LegendItem::heading("irradiance E")];
        e_items.extend(
            e_lines
                .iter()
                .map(|(label, colour, _)| LegendItem::line(label, *colour, false)),
        );
        draw_legend(&legend, 40, top_h as i32 - 10, &e_items)?;
        let mut items = vec![LegendItem::heading("outgoing radiance L_o")];
        for ch in 0..3 {
            items.push(LegendItem::line(
                &format!(
                    "designed {}{}",
                    CHANNEL_NAMES[ch],
                    if c.refined { " (refined)" } else { " (grid)" }
                ),
                CHANNEL_COLOURS[ch],
                false,
            ));
        }
        if show_grid {
            items.push(LegendItem::line(
                "grid optimum, before refinement",
                GROUP_COLOUR,
                true,
            ));
        }
        items.push(LegendItem {
            mark: Mark::Dot(GROUP_COLOUR),
            label: "target at a keyframe".into(),
        });
        draw_legend(&legend, top_h as i32 + 40, h_upper as i32 - 10, &items)?;

        draw_residual_caption(&caption, &residual_head, &residual_entries, &note)
    })
}

/// Axis choice for radiance-like values.
#[derive(Debug, Clone, Copy, PartialEq)]
struct YScale {
    /// Logarithmic (values drawn as log₁₀).
    log: bool,
    /// Axis range in drawn units (log₁₀ values on a log axis).
    lo: f64,
    hi: f64,
    /// Decades from the 5th percentile of the positive values to the largest value.
    decades: f64,
    /// Log axis: the smallest value drawn (smaller ones leave gaps).
    floor: f64,
    /// Linear axis: power of ten the values are divided by (1 unless they are very large or
    /// very small, so that tick labels stay short).
    exponent: i32,
}

impl YScale {
    /// Log₁₀ axis when the finite values are all ≥ 0 and span at least [`LOG_AXIS_DECADES`]
    /// decades, otherwise linear (always including 0).
    fn choose(values: &[f64]) -> Result<YScale> {
        let finite: Vec<f64> = values.iter().copied().filter(|v| v.is_finite()).collect();
        if finite.is_empty() {
            return Err(Error::invalid("plot", "no finite value to draw"));
        }
        let max = finite.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let min = finite.iter().copied().fold(f64::INFINITY, f64::min);
        let mut pos: Vec<f64> = finite.iter().copied().filter(|v| *v > 0.0).collect();
        pos.sort_by(f64::total_cmp);
        let decades = match pos.get((pos.len().saturating_sub(1)) * 5 / 100) {
            Some(p5) => (max / p5).log10(),
            None => 0.0,
        };
        if min >= 0.0 && decades >= LOG_AXIS_DECADES {
            let floor = pos[0].max(max * 10f64.powf(-LOG_FLOOR_DECADES));
            let (lo, hi) = (floor.log10(), max.log10());
            let pad = 0.05 * (hi - lo);
            return Ok(YScale {
                log: true,
                lo: lo - pad,
                hi: hi + pad,
                decades,
                floor,
                exponent: 0,
            });
        }
        let big = max.abs().max(min.abs());
        let exponent = if big > 0.0 && !(1e-2..1e4).contains(&big) {
            big.log10().floor() as i32
        } else {
            0
        };
        let f = 10f64.powi(exponent);
        let (lo, hi) = (min.min(0.0) / f, max.max(0.0) / f);
        let span = hi - lo;
        let (lo, hi) = if span > 0.0 {
            (
                if lo < 0.0 { lo - 0.05 * span } else { lo },
                hi + 0.05 * span,
            )
        } else {
            (lo, lo + 1.0)
        };
        Ok(YScale {
            log: false,
            lo,
            hi,
            decades,
            floor: 0.0,
            exponent,
        })
    }

    /// The drawn value of `v` (None: not drawable, a gap).
    fn map(&self, v: f64) -> Option<f64> {
        if !v.is_finite() {
            None
        } else if self.log {
            (v >= self.floor).then(|| v.log10())
        } else {
            Some(v / 10f64.powi(self.exponent))
        }
    }

    /// Reduces a long curve to [`MAX_POINTS`] and maps its values.
    fn map_points(&self, pts: &[(f64, f64)]) -> Vec<(f64, Option<f64>)> {
        decimate(pts, MAX_POINTS)
            .into_iter()
            .map(|(x, y)| (x, self.map(y)))
            .collect()
    }

    /// Axis description saying which axis was chosen and why.
    fn label(&self, what: &str) -> String {
        if self.log && self.decades > LOG_FLOOR_DECADES {
            format!(
                "log10 {what} (auto: spans {:.0} decades, top {LOG_FLOOR_DECADES} shown)",
                self.decades
            )
        } else if self.log {
            format!("log10 {what} (auto: spans {:.1} decades)", self.decades)
        } else if self.exponent != 0 {
            format!(
                "{what} / 1e{} (auto linear: spans {:.1} decades)",
                self.exponent, self.decades
            )
        } else {
            format!("{what} (auto linear: spans {:.1} decades)", self.decades)
        }
    }
}

/// Time unit for a span in s: (seconds per unit, unit name).
fn time_unit(span_s: f64) -> (f64, &'static str) {
    if span_s <= 1200.0 {
        (1.0, "s")
    } else if span_s <= 72_000.0 {
        (60.0, "min")
    } else {
        (3600.0, "h")
    }
}

fn integrator_name(i: Integrator) -> &'static str {
    match i {
        Integrator::Exact => "exact exponential",
        Integrator::Rk4 => "RK4",
        Integrator::Euler => "forward Euler",
    }
}

fn plural(n: usize) -> &'static str {
    if n == 1 {
        ""
    } else {
        "s"
    }
}

/// Four significant digits, trailing zeros dropped; exponent form outside 10⁻³…10⁵.
fn fmt_sig(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let e = v.abs().log10().floor() as i32;
    if (-3..5).contains(&e) {
        let d = (3 - e).max(0) as usize;
        let s = format!("{v:.d$}");
        if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            s
        }
    } else {
        format!("{v:.3e}")
    }
}

fn join_sig(v: &[f64]) -> String {
    v.iter().map(|x| fmt_sig(*x)).collect::<Vec<_>>().join(", ")
}

/// A relative value as a percentage (exponent form below 0.01 %).
fn fmt_pct(r: f64) -> String {
    if !r.is_finite() {
        return "∞".into();
    }
    let p = r * 100.0;
    if p == 0.0 {
        "0 %".into()
    } else if p >= 0.01 {
        format!("{p:.2} %")
    } else {
        format!("{p:.1e} %")
    }
}

/// Legend labels of the bands: R, G, B or the wavelength range.
fn band_labels(bands: &BandSet) -> Vec<String> {
    match bands {
        BandSet::Rgb => CHANNEL_NAMES.iter().map(|s| s.to_string()).collect(),
        BandSet::RangesNm(r) => r
            .iter()
            .map(|[lo, hi]| format!("{}–{} nm", fmt_sig(*lo), fmt_sig(*hi)))
            .collect(),
    }
}

/// Line colours of the bands: the channel colours, or the hue of each band's centre wavelength.
fn band_colours(bands: &BandSet) -> Vec<[u8; 3]> {
    match bands {
        BandSet::Rgb => CHANNEL_COLOURS.to_vec(),
        BandSet::RangesNm(r) => r
            .iter()
            .map(|[lo, hi]| wavelength_colour(0.5 * (lo + hi)))
            .collect(),
    }
}

/// A display colour for a wavelength: the usual piecewise-linear spectral hue (violet below
/// 440 nm to red above 645 nm, grey outside 380–780 nm), darkened so that every hue stays
/// readable as a line on white (relative luminance at most 0.3).
fn wavelength_colour(nm: f64) -> [u8; 3] {
    let rgb = match nm {
        x if (380.0..440.0).contains(&x) => [(440.0 - x) / 60.0, 0.0, 1.0],
        x if (440.0..490.0).contains(&x) => [0.0, (x - 440.0) / 50.0, 1.0],
        x if (490.0..510.0).contains(&x) => [0.0, 1.0, (510.0 - x) / 20.0],
        x if (510.0..580.0).contains(&x) => [(x - 510.0) / 70.0, 1.0, 0.0],
        x if (580.0..645.0).contains(&x) => [1.0, (645.0 - x) / 65.0, 0.0],
        x if (645.0..=780.0).contains(&x) => [1.0, 0.0, 0.0],
        _ => return [120, 120, 120],
    };
    let c = super::srgb_to_u8(rgb);
    let lum = super::luminance_u8(c);
    if lum <= 0.3 {
        return c;
    }
    // Scale the linear values (sRGB decode ≈ power 2.2) so the luminance becomes 0.3.
    let k = (0.3 / lum).powf(1.0 / 2.2);
    c.map(|v| (f64::from(v) * k).round() as u8)
}

/// Groups of indices `0..n` whose histories are identical (`same`), in index order.
fn identical_groups(n: usize, same: impl Fn(usize, usize) -> bool) -> Vec<Vec<usize>> {
    let mut groups: Vec<Vec<usize>> = Vec::new();
    for i in 0..n {
        match groups.iter_mut().find(|g| same(g[0], i)) {
            Some(g) => g.push(i),
            None => groups.push(vec![i]),
        }
    }
    groups
}

/// Label and colour of a group of bands or channels sharing one irradiance line.
fn group_style(
    g: &[usize],
    labels: &[String],
    colours: &[[u8; 3]],
    noun: &str,
    numbered: bool,
) -> (String, [u8; 3]) {
    if g.len() == 1 {
        let label = if numbered {
            format!("{noun} {}: {}", g[0] + 1, labels[g[0]])
        } else {
            labels[g[0]].clone()
        };
        return (label, colours[g[0]]);
    }
    let contiguous = g.windows(2).all(|w| w[1] == w[0] + 1);
    let label = if numbered && contiguous {
        format!("{noun}s {}–{} (same E)", g[0] + 1, g[g.len() - 1] + 1)
    } else if numbered {
        format!(
            "{noun}s {} (same E)",
            g.iter()
                .map(|i| (i + 1).to_string())
                .collect::<Vec<_>>()
                .join(", ")
        )
    } else {
        g.iter()
            .map(|i| labels[*i].clone())
            .collect::<Vec<_>>()
            .join(" = ")
    };
    (label, GROUP_COLOUR)
}

/// Points of a piecewise-constant function: `values[k]` from `bounds[k]` to `bounds[k+1]`.
fn step_points(bounds: &[f64], values: &[f64]) -> Vec<(f64, f64)> {
    let mut out = Vec::with_capacity(2 * values.len());
    for (k, v) in values.iter().enumerate() {
        if k + 1 < bounds.len() {
            out.push((bounds[k], *v));
            out.push((bounds[k + 1], *v));
        }
    }
    decimate(&out, MAX_POINTS)
}

/// Intervals (in drawn time units) where the light is on, neighbours closer than 1/1500 of the
/// span merged.
fn lit_intervals(bounds: &[f64], lit: &[bool], span: f64) -> Vec<(f64, f64)> {
    let gap = span / 1500.0;
    let mut out: Vec<(f64, f64)> = Vec::new();
    for (k, on) in lit.iter().enumerate() {
        if !*on || k + 1 >= bounds.len() {
            continue;
        }
        let (a, b) = (bounds[k], bounds[k + 1]);
        match out.last_mut() {
            Some(last) if a - last.1 <= gap => last.1 = b,
            _ => out.push((a, b)),
        }
    }
    out
}

/// At most about `max_points` points: per bucket of consecutive points, the lowest and highest
/// (in time order), so spikes and steps survive. Non-finite points are kept as gaps.
fn decimate(pts: &[(f64, f64)], max_points: usize) -> Vec<(f64, f64)> {
    if pts.len() <= max_points || max_points < 4 {
        return pts.to_vec();
    }
    let per = pts.len().div_ceil(max_points / 2);
    let mut out = Vec::with_capacity(max_points + 2);
    for chunk in pts.chunks(per) {
        let finite = |p: &&(f64, f64)| p.1.is_finite();
        if chunk.iter().any(|p| !p.1.is_finite()) {
            out.push((chunk[0].0, f64::NAN));
        }
        let lo = chunk
            .iter()
            .enumerate()
            .filter(|(_, p)| finite(p))
            .min_by(|a, b| a.1 .1.total_cmp(&b.1 .1));
        let hi = chunk
            .iter()
            .enumerate()
            .filter(|(_, p)| finite(p))
            .max_by(|a, b| a.1 .1.total_cmp(&b.1 .1));
        if let (Some((i, _)), Some((j, _))) = (lo, hi) {
            let (a, b) = (i.min(j), i.max(j));
            out.push(chunk[a]);
            if b != a {
                out.push(chunk[b]);
            }
        }
    }
    if let (Some(last), Some(kept)) = (pts.last(), out.last()) {
        if last != kept {
            out.push(*last);
        }
    }
    out
}

type Chart<'a, DB> = ChartContext<'a, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// Draws a curve with gaps at `None`; points outside the x range are dropped and y is clamped
/// to the axis (plotters does not clip). Light colours get a dark halo.
fn draw_line<DB: DrawingBackend>(
    chart: &mut Chart<'_, DB>,
    pts: &[(f64, Option<f64>)],
    colour: [u8; 3],
    width: u32,
    dashed: bool,
) -> Result<()> {
    let xr = chart.x_range();
    let yr = chart.y_range();
    let mut run: Vec<(f64, f64)> = Vec::new();
    for &(x, y) in pts {
        match y {
            Some(y) if x.is_finite() && x >= xr.start && x <= xr.end => {
                run.push((x, y.clamp(yr.start, yr.end)));
            }
            _ => {
                draw_run(chart, &run, colour, width, dashed)?;
                run.clear();
            }
        }
    }
    draw_run(chart, &run, colour, width, dashed)
}

fn draw_run<DB: DrawingBackend>(
    chart: &mut Chart<'_, DB>,
    run: &[(f64, f64)],
    colour: [u8; 3],
    width: u32,
    dashed: bool,
) -> Result<()> {
    if run.len() < 2 {
        return Ok(());
    }
    let line = RGBColor(colour[0], colour[1], colour[2]);
    if dashed {
        chart
            .draw_series(DashedLineSeries::new(
                run.iter().copied(),
                10,
                7,
                line.stroke_width(width),
            ))
            .map_err(draw_err)?;
        return Ok(());
    }
    if needs_halo(colour) {
        let halo = RGBColor(40, 40, 40).mix(0.4).stroke_width(width + 2);
        chart
            .draw_series(LineSeries::new(run.iter().copied(), halo))
            .map_err(draw_err)?;
    }
    chart
        .draw_series(LineSeries::new(
            run.iter().copied(),
            line.stroke_width(width),
        ))
        .map_err(draw_err)?;
    Ok(())
}

/// Shades the lit intervals over the whole y range.
fn shade<DB: DrawingBackend>(
    chart: &mut Chart<'_, DB>,
    lit: &[(f64, f64)],
    (lo, hi): (f64, f64),
) -> Result<()> {
    chart
        .draw_series(
            lit.iter().map(|(a, b)| {
                Rectangle::new([(*a, lo), (*b, hi)], LIT_SHADE.mix(LIT_ALPHA).filled())
            }),
        )
        .map_err(draw_err)?;
    Ok(())
}

/// Title (bold size) and a muted second line, centred in the title band.
fn draw_title<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
    subtitle: &str,
) -> Result<()> {
    let (w, _) = root.dim_in_pixel();
    let style = TextSpec::new(24.0, INK, HPos::Center, VPos::Center);
    let t = fit_text(root, title, style.size_px, w - 40)?;
    draw_text(root, &t, (w as i32 / 2, 28), style)?;
    let style = TextSpec::new(17.0, MUTED_INK, HPos::Center, VPos::Center);
    let s = fit_text(root, subtitle, style.size_px, w - 40)?;
    draw_text(root, &s, (w as i32 / 2, 62), style)
}

/// How a legend row is marked.
enum Mark {
    /// No mark: a heading.
    None,
    /// A line sample (dashed or solid).
    Line([u8; 3], bool),
    /// A filled point with a dark outline.
    Dot([u8; 3]),
    /// A filled box.
    Swatch(RGBAColor),
}

/// One legend row.
struct LegendItem {
    mark: Mark,
    label: String,
}

impl LegendItem {
    fn heading(label: &str) -> Self {
        LegendItem {
            mark: Mark::None,
            label: label.into(),
        }
    }

    fn line(label: &str, colour: [u8; 3], dashed: bool) -> Self {
        LegendItem {
            mark: Mark::Line(colour, dashed),
            label: label.into(),
        }
    }
}

/// Draws legend rows from `y0` down to at most `y_max` (the rest as "… and N more").
fn draw_legend<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    y0: i32,
    y_max: i32,
    items: &[LegendItem],
) -> Result<()> {
    let (w, _) = area.dim_in_pixel();
    let x0 = 6;
    let sample_w = 34;
    let text_x = x0 + sample_w + 10;
    let max_rows = ((y_max - y0) / LEGEND_ROW_H).max(1) as usize;
    let shown = if items.len() > max_rows {
        max_rows - 1
    } else {
        items.len()
    };
    let spec = TextSpec::new(LEGEND_FONT_PX, INK, HPos::Left, VPos::Center);
    let mut y = y0;
    for item in &items[..shown] {
        match item.mark {
            Mark::None => {
                let t = fit_text(area, &item.label, 16.0, w - 2 * x0 as u32)?;
                draw_text(
                    area,
                    &t,
                    (x0, y),
                    TextSpec::new(16.0, MUTED_INK, HPos::Left, VPos::Center),
                )?;
                y += LEGEND_ROW_H;
                continue;
            }
            Mark::Line(c, dashed) => {
                let style = RGBColor(c[0], c[1], c[2]).stroke_width(2);
                if dashed {
                    for k in 0..3 {
                        let a = x0 + k * 13;
                        area.draw(&PathElement::new(vec![(a, y), (a + 8, y)], style))
                            .map_err(draw_err)?;
                    }
                } else {
                    if needs_halo(c) {
                        let halo = RGBColor(40, 40, 40).mix(0.4).stroke_width(4);
                        area.draw(&PathElement::new(vec![(x0, y), (x0 + sample_w, y)], halo))
                            .map_err(draw_err)?;
                    }
                    area.draw(&PathElement::new(vec![(x0, y), (x0 + sample_w, y)], style))
                        .map_err(draw_err)?;
                }
            }
            Mark::Dot(c) => {
                let centre = (x0 + sample_w / 2, y);
                area.draw(&Circle::new(centre, 7, RGBColor(c[0], c[1], c[2]).filled()))
                    .map_err(draw_err)?;
                area.draw(&Circle::new(centre, 7, INK.stroke_width(2)))
                    .map_err(draw_err)?;
            }
            Mark::Swatch(c) => {
                area.draw(&Rectangle::new(
                    [(x0, y - 8), (x0 + sample_w, y + 8)],
                    c.filled(),
                ))
                .map_err(draw_err)?;
            }
        }
        let max_w = (w as i32 - text_x - 10).max(0) as u32;
        let t = fit_text(area, &item.label, spec.size_px, max_w)?;
        draw_text(area, &t, (text_x, y), spec)?;
        y += LEGEND_ROW_H;
    }
    if shown < items.len() {
        let more = format!("… and {} more", items.len() - shown);
        draw_text(area, &more, (text_x, y), spec.with_colour(MUTED_INK))?;
    }
    Ok(())
}

/// The keyframe-residual caption: a heading, the entries wrapped over at most three lines
/// (the rest summarised), and the design's note.
fn draw_residual_caption<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    head: &str,
    entries: &[String],
    note: &str,
) -> Result<()> {
    let (w, _) = area.dim_in_pixel();
    let x0 = 24;
    let max_w = w - 2 * x0 as u32;
    let size = 15.0;
    let spec = TextSpec::new(size, INK, HPos::Left, VPos::Center);
    draw_text(area, head, (x0, 14), spec.with_colour(MUTED_INK))?;
    let sep = "    ";
    let width = |parts: &[String], extra: &str| -> Result<u32> {
        text_width(area, &format!("{}{extra}", parts.join(sep)), size)
    };
    // Greedy fill of at most three lines, one entry list per line.
    let mut lines: Vec<Vec<String>> = vec![Vec::new()];
    let mut placed = 0;
    for e in entries {
        let last = lines.len() - 1;
        let mut trial = lines[last].clone();
        trial.push(e.clone());
        if lines[last].is_empty() || width(&trial, "")? <= max_w {
            lines[last] = trial;
        } else if lines.len() < 3 {
            lines.push(vec![e.clone()]);
        } else {
            break;
        }
        placed += 1;
    }
    if placed < entries.len() {
        // Make room on the last line for the summary of what is left out.
        let last = lines.len() - 1;
        loop {
            let more = format!("{sep}… and {} more", entries.len() - placed);
            if lines[last].is_empty() || width(&lines[last], &more)? <= max_w {
                break;
            }
            lines[last].pop();
            placed -= 1;
        }
        lines[last].push(format!("… and {} more", entries.len() - placed));
    }
    let lines: Vec<String> = lines.iter().map(|l| l.join(sep)).collect();
    for (i, l) in lines.iter().enumerate() {
        draw_text(area, l, (x0, 38 + 22 * i as i32), spec)?;
    }
    let n = fit_text(area, note, size, max_w)?;
    let y = 38 + 22 * lines.len() as i32 + 4;
    draw_text(area, &n, (x0, y), spec.with_colour(MUTED_INK))
}

/// Whether two stages describe the same material (rates and Λ).
fn same_material(a: &DesignStage, b: &DesignStage) -> bool {
    a.k_e == b.k_e && a.k_r_per_s == b.k_r_per_s && a.lambda == b.lambda
}

/// Sample times of the design curves: uniform, plus keyframes and history rows (up to
/// [`MAX_STEP_ROWS`]), sorted and deduplicated.
fn design_times(hist: &IrradianceHistory, keys: &[Keyframe], t0: f64, t_end: f64) -> Vec<f64> {
    let mut times: Vec<f64> = (0..N_FINE)
        .map(|i| t0 + (t_end - t0) * i as f64 / (N_FINE - 1) as f64)
        .collect();
    times.extend(keys.iter().map(|k| k.t_s));
    if hist.t_s.len() <= MAX_STEP_ROWS {
        times.extend(hist.t_s.iter().copied());
    }
    times.retain(|t| t.is_finite() && *t >= t0 && *t <= t_end);
    times.sort_by(f64::total_cmp);
    times.dedup();
    times
}

/// Outgoing radiance of a stage at `times` (s), with both one-sided values at every history
/// row start so that the reflected light steps instead of ramping.
fn stage_curve(
    hist: &IrradianceHistory,
    albedo: [f64; 3],
    s: &DesignStage,
    times: &[f64],
) -> Result<Vec<(f64, [f64; 3])>> {
    let lp = outgoing_radiance(hist, [0.0; 3], s.k_e, s.k_r_per_s, s.lambda, times)?;
    let refl = |e: [f64; 3], p: [f64; 3]| -> [f64; 3] {
        [0, 1, 2].map(|c| albedo[c] * e[c] / std::f64::consts::PI + p[c])
    };
    let mut out = Vec::with_capacity(times.len() + hist.t_s.len());
    for (t, p) in times.iter().zip(lp) {
        if let Ok(k) = hist.t_s.binary_search_by(|x| x.total_cmp(t)) {
            if k > 0 {
                out.push((*t, refl(hist.e[k - 1], p)));
            }
        }
        out.push((*t, refl(irradiance_at(hist, *t), p)));
    }
    Ok(out)
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
