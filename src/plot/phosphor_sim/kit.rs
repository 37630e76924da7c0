//! The plotting kit of the phosphor charts: axis choice, time units, number formats, band
//! colours, step and lit-interval geometry, decimation, lines, shading, titles and the legend.

// `!(a > b)` comparisons deliberately reject NaN along with out-of-range values.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use super::*;

/// Axis choice for radiance-like values.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct YScale {
    /// Logarithmic (values drawn as log₁₀).
    pub(super) log: bool,
    /// Axis range in drawn units (log₁₀ values on a log axis).
    pub(super) lo: f64,
    pub(super) hi: f64,
    /// Decades from the 5th percentile of the positive values to the largest value.
    pub(super) decades: f64,
    /// Log axis: the smallest value drawn (smaller ones leave gaps).
    pub(super) floor: f64,
    /// Linear axis: power of ten the values are divided by (1 unless they are very large or
    /// very small, so that tick labels stay short).
    pub(super) exponent: i32,
}

impl YScale {
    /// Log₁₀ axis when the finite values are all ≥ 0 and span at least [`LOG_AXIS_DECADES`]
    /// decades, otherwise linear (always including 0).
    pub(super) fn choose(values: &[f64]) -> Result<YScale> {
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
    pub(super) fn map(&self, v: f64) -> Option<f64> {
        if !v.is_finite() {
            None
        } else if self.log {
            (v >= self.floor).then(|| v.log10())
        } else {
            Some(v / 10f64.powi(self.exponent))
        }
    }

    /// Reduces a long curve to [`MAX_POINTS`] and maps its values.
    pub(super) fn map_points(&self, pts: &[(f64, f64)]) -> Vec<(f64, Option<f64>)> {
        decimate(pts, MAX_POINTS)
            .into_iter()
            .map(|(x, y)| (x, self.map(y)))
            .collect()
    }

    /// Axis description saying which axis was chosen and why.
    pub(super) fn label(&self, what: &str) -> String {
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
pub(super) fn time_unit(span_s: f64) -> (f64, &'static str) {
    if span_s <= 1200.0 {
        (1.0, "s")
    } else if span_s <= 72_000.0 {
        (60.0, "min")
    } else {
        (3600.0, "h")
    }
}

pub(super) fn integrator_name(i: Integrator) -> &'static str {
    match i {
        Integrator::Exact => "exact exponential",
        Integrator::Rk4 => "RK4",
        Integrator::Euler => "forward Euler",
    }
}

pub(super) fn plural(n: usize) -> &'static str {
    if n == 1 {
        ""
    } else {
        "s"
    }
}

/// Four significant digits, trailing zeros dropped; exponent form outside 10⁻³…10⁵.
pub(super) fn fmt_sig(v: f64) -> String {
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

pub(super) fn join_sig(v: &[f64]) -> String {
    v.iter().map(|x| fmt_sig(*x)).collect::<Vec<_>>().join(", ")
}

/// A relative value as a percentage (exponent form below 0.01 %).
pub(super) fn fmt_pct(r: f64) -> String {
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
pub(super) fn band_labels(bands: &BandSet) -> Vec<String> {
    match bands {
        BandSet::Rgb => CHANNEL_NAMES.iter().map(|s| s.to_string()).collect(),
        BandSet::RangesNm(r) => r
            .iter()
            .map(|[lo, hi]| format!("{}–{} nm", fmt_sig(*lo), fmt_sig(*hi)))
            .collect(),
    }
}

/// Line colours of the bands: the channel colours, or the hue of each band's centre wavelength.
pub(super) fn band_colours(bands: &BandSet) -> Vec<[u8; 3]> {
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
pub(super) fn wavelength_colour(nm: f64) -> [u8; 3] {
    let rgb = match nm {
        x if (380.0..440.0).contains(&x) => [(440.0 - x) / 60.0, 0.0, 1.0],
        x if (440.0..490.0).contains(&x) => [0.0, (x - 440.0) / 50.0, 1.0],
        x if (490.0..510.0).contains(&x) => [0.0, 1.0, (510.0 - x) / 20.0],
        x if (510.0..580.0).contains(&x) => [(x - 510.0) / 70.0, 1.0, 0.0],
        x if (580.0..645.0).contains(&x) => [1.0, (645.0 - x) / 65.0, 0.0],
        x if (645.0..=780.0).contains(&x) => [1.0, 0.0, 0.0],
        _ => return [120, 120, 120],
    };
    let c = crate::plot::srgb_to_u8(rgb);
    let lum = crate::plot::luminance_u8(c);
    if lum <= 0.3 {
        return c;
    }
    // Scale the linear values (sRGB decode ≈ power 2.2) so the luminance becomes 0.3.
    let k = (0.3 / lum).powf(1.0 / 2.2);
    c.map(|v| (f64::from(v) * k).round() as u8)
}

/// Groups of indices `0..n` whose histories are identical (`same`), in index order.
pub(super) fn identical_groups(n: usize, same: impl Fn(usize, usize) -> bool) -> Vec<Vec<usize>> {
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
pub(super) fn group_style(
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
pub(super) fn step_points(bounds: &[f64], values: &[f64]) -> Vec<(f64, f64)> {
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
pub(super) fn lit_intervals(bounds: &[f64], lit: &[bool], span: f64) -> Vec<(f64, f64)> {
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
pub(super) fn decimate(pts: &[(f64, f64)], max_points: usize) -> Vec<(f64, f64)> {
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

pub(super) type Chart<'a, DB> = ChartContext<'a, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// Draws a curve with gaps at `None`; points outside the x range are dropped and y is clamped
/// to the axis (plotters does not clip). Light colours get a dark halo.
/// The irradiance-history panel both charts draw: E per channel or band as step lines on
/// `area`, the y axis from 0 to 12 % above the largest value (1 when all are 0).
pub(super) fn irradiance_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    caption: &str,
    x_label: &str,
    x_range: (f64, f64),
    e_max: f64,
    lines: &[Series<(f64, f64)>],
    n_y_ticks: usize,
) -> Result<()> {
    let mut chart = spectral_axes(
        area,
        &AxesSpec {
            caption: Some(caption),
            x_label,
            y_label: "irradiance E",
            x_range,
            y_range: (0.0, if e_max > 0.0 { e_max * 1.12 } else { 1.0 }),
            n_ticks: (10, n_y_ticks),
        },
    )?;
    for (_, colour, pts) in lines {
        let pts: Vec<(f64, Option<f64>)> = pts.iter().map(|(x, y)| (*x, Some(*y))).collect();
        draw_line(&mut chart, &pts, *colour, 2, false)?;
    }
    Ok(())
}

pub(super) fn draw_line<DB: DrawingBackend>(
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

pub(super) fn draw_run<DB: DrawingBackend>(
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
pub(super) fn shade<DB: DrawingBackend>(
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
pub(super) fn draw_title<DB: DrawingBackend>(
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
pub(super) enum Mark {
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
pub(super) struct LegendItem {
    pub(super) mark: Mark,
    pub(super) label: String,
}

impl LegendItem {
    pub(super) fn heading(label: &str) -> Self {
        LegendItem {
            mark: Mark::None,
            label: label.into(),
        }
    }

    pub(super) fn line(label: &str, colour: [u8; 3], dashed: bool) -> Self {
        LegendItem {
            mark: Mark::Line(colour, dashed),
            label: label.into(),
        }
    }
}

/// Draws legend rows from `y0` down to at most `y_max` (the rest as "… and N more").
pub(super) fn draw_legend<DB: DrawingBackend>(
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
