//! The `phos design` chart: irradiance history, designed outgoing radiance, keyframe targets
//! and residuals.

// `!(a > b)` comparisons deliberately reject NaN along with out-of-range values.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use super::*;

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

        irradiance_panel(
            &top,
            "irradiance history E per channel",
            &x_label,
            x_range,
            e_max,
            &e_lines,
            4,
        )?;

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

/// The keyframe-residual caption: a heading, the entries wrapped over at most three lines
/// (the rest summarised), and the design's note.
pub(super) fn draw_residual_caption<DB: DrawingBackend>(
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
pub(super) fn same_material(a: &DesignStage, b: &DesignStage) -> bool {
    a.k_e == b.k_e && a.k_r_per_s == b.k_r_per_s && a.lambda == b.lambda
}

/// Sample times of the design curves: uniform, plus keyframes and history rows (up to
/// [`MAX_STEP_ROWS`]), sorted and deduplicated.
pub(super) fn design_times(
    hist: &IrradianceHistory,
    keys: &[Keyframe],
    t0: f64,
    t_end: f64,
) -> Vec<f64> {
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
pub(super) fn stage_curve(
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
