//! Horizontal text with correct glyph spacing.
//!
//! plotters 0.3.7's `ab_glyph` text path places each glyph's bitmap at the pen position and drops
//! the glyph's left side bearing, so narrow letters drift left ("yel low", "dipped" for
//! "clipped"). Here each character is drawn on its own at `pen + left side bearing`, with advances
//! and bearings read from the embedded font's `hmtx` table (character to glyph through the `cmap`
//! format-4 subtable). ab_glyph scales fonts so that `ascender − descender` spans the requested
//! pixel size; the same scale is used here. If the font tables cannot be read, text falls back to
//! plotters' own layout.
//!
//! Vertical text (y-axis descriptions) is laid out the same way along the rotated baseline. Tick
//! labels drawn by plotters' mesh keep plotters' layout; digits have near-equal bearings.

use std::sync::OnceLock;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use plotters::style::FontTransform;

use super::{draw_err, text_style, FONT_BYTES};
use crate::error::Result;

/// How a piece of text is drawn: pixel size, colour and which point of its box `(x, y)` names.
#[derive(Clone, Copy)]
pub(crate) struct TextSpec {
    /// Font size in pixels (ab_glyph convention: ascender − descender).
    pub size_px: f64,
    /// Text colour.
    pub colour: RGBColor,
    /// Anchor of the text box (in the text's own reading direction).
    pub pos: Pos,
    /// Rotated a quarter turn anticlockwise, reading bottom to top (y-axis descriptions).
    pub vertical: bool,
}

impl TextSpec {
    pub(crate) fn new(size_px: f64, colour: RGBColor, h: HPos, v: VPos) -> Self {
        TextSpec {
            size_px,
            colour,
            pos: Pos::new(h, v),
            vertical: false,
        }
    }

    /// The same text reading bottom to top.
    pub(crate) fn vertical(self) -> Self {
        TextSpec {
            vertical: true,
            ..self
        }
    }

    pub(crate) fn with_colour(self, colour: RGBColor) -> Self {
        TextSpec { colour, ..self }
    }
}

/// Horizontal metrics read from the embedded TrueType font.
struct Metrics {
    /// `ascender − descender` in font units (ab_glyph's pixel-size reference).
    height_units: f64,
    /// (advance width, left side bearing) per glyph id, font units.
    h_metrics: Vec<(u16, i16)>,
    /// cmap format 4 segments: (start, end, id delta, id range offset, offset of that field).
    segments: Vec<(u16, u16, i16, u16, usize)>,
    /// The cmap subtable's bytes (glyph id array lookups).
    cmap: &'static [u8],
}

fn be_u16(b: &[u8], at: usize) -> Option<u16> {
    Some(u16::from_be_bytes([*b.get(at)?, *b.get(at + 1)?]))
}

fn be_i16(b: &[u8], at: usize) -> Option<i16> {
    be_u16(b, at).map(|v| v as i16)
}

fn be_u32(b: &[u8], at: usize) -> Option<u32> {
    Some(u32::from_be_bytes([
        *b.get(at)?,
        *b.get(at + 1)?,
        *b.get(at + 2)?,
        *b.get(at + 3)?,
    ]))
}

fn table(font: &'static [u8], tag: &[u8; 4]) -> Option<&'static [u8]> {
    let n = be_u16(font, 4)? as usize;
    (0..n).find_map(|i| {
        let rec = 12 + 16 * i;
        if font.get(rec..rec + 4)? != tag {
            return None;
        }
        let off = be_u32(font, rec + 8)? as usize;
        let len = be_u32(font, rec + 12)? as usize;
        font.get(off..off.checked_add(len)?)
    })
}

impl Metrics {
    fn parse(font: &'static [u8]) -> Option<Metrics> {
        let hhea = table(font, b"hhea")?;
        let hmtx = table(font, b"hmtx")?;
        let maxp = table(font, b"maxp")?;
        let cmap = table(font, b"cmap")?;
        // ttf-parser (used by ab_glyph) takes OS/2 typographic metrics when USE_TYPO_METRICS is set.
        let (mut ascender, mut descender) = (be_i16(hhea, 4)?, be_i16(hhea, 6)?);
        if let Some(os2) = table(font, b"OS/2") {
            if be_u16(os2, 62).is_some_and(|sel| sel & (1 << 7) != 0) {
                ascender = be_i16(os2, 68)?;
                descender = be_i16(os2, 70)?;
            }
        }
        let height_units = f64::from(ascender) - f64::from(descender);
        let n_hmetrics = be_u16(hhea, 34)? as usize;
        let n_glyphs = be_u16(maxp, 4)? as usize;
        if height_units <= 0.0 || n_hmetrics == 0 {
            return None;
        }
        let mut h_metrics = Vec::with_capacity(n_glyphs.max(n_hmetrics));
        for g in 0..n_hmetrics {
            h_metrics.push((be_u16(hmtx, 4 * g)?, be_i16(hmtx, 4 * g + 2)?));
        }
        let last_advance = h_metrics[n_hmetrics - 1].0;
        for g in n_hmetrics..n_glyphs {
            let lsb = be_i16(hmtx, 4 * n_hmetrics + 2 * (g - n_hmetrics))?;
            h_metrics.push((last_advance, lsb));
        }

        // Unicode BMP subtable: (3, 1) or (0, 3), format 4.
        let n_sub = be_u16(cmap, 2)? as usize;
        let sub = (0..n_sub).find_map(|i| {
            let rec = 4 + 8 * i;
            let (platform, encoding) = (be_u16(cmap, rec)?, be_u16(cmap, rec + 2)?);
            let off = be_u32(cmap, rec + 4)? as usize;
            let unicode_bmp = (platform == 3 && encoding == 1) || (platform == 0 && encoding == 3);
            (unicode_bmp && be_u16(cmap, off)? == 4).then_some(off)
        })?;
        let sub_len = be_u16(cmap, sub + 2)? as usize;
        let cmap = cmap.get(sub..sub + sub_len)?;
        let seg_count = be_u16(cmap, 6)? as usize / 2;
        let ends = 14;
        let starts = ends + 2 * seg_count + 2;
        let deltas = starts + 2 * seg_count;
        let ranges = deltas + 2 * seg_count;
        let segments = (0..seg_count)
            .map(|s| {
                Some((
                    be_u16(cmap, starts + 2 * s)?,
                    be_u16(cmap, ends + 2 * s)?,
                    be_i16(cmap, deltas + 2 * s)?,
                    be_u16(cmap, ranges + 2 * s)?,
                    ranges + 2 * s,
                ))
            })
            .collect::<Option<Vec<_>>>()?;
        Some(Metrics {
            height_units,
            h_metrics,
            segments,
            cmap,
        })
    }

    fn glyph_id(&self, c: char) -> usize {
        let Ok(code) = u16::try_from(u32::from(c)) else {
            return 0;
        };
        let Some(&(start, _, delta, range_offset, field_at)) = self
            .segments
            .iter()
            .find(|&&(start, end, ..)| code <= end && code >= start)
        else {
            return 0;
        };
        if range_offset == 0 {
            return usize::from(code.wrapping_add(delta as u16));
        }
        let at = field_at + range_offset as usize + 2 * usize::from(code - start);
        match be_u16(self.cmap, at) {
            Some(0) | None => 0,
            Some(g) => usize::from(g.wrapping_add(delta as u16)),
        }
    }

    /// (advance, left side bearing) of `c` in font units.
    fn h_metrics(&self, c: char) -> (f64, f64) {
        let g = self.glyph_id(c);
        let (adv, lsb) = self.h_metrics.get(g).copied().unwrap_or((0, 0));
        (f64::from(adv), f64::from(lsb))
    }
}

fn metrics() -> Option<&'static Metrics> {
    static METRICS: OnceLock<Option<Metrics>> = OnceLock::new();
    METRICS.get_or_init(|| Metrics::parse(FONT_BYTES)).as_ref()
}

/// Width of `text` in pixels at `size_px`.
pub(crate) fn text_width<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    text: &str,
    size_px: f64,
) -> Result<u32> {
    match metrics() {
        Some(m) => {
            let scale = size_px / m.height_units;
            let units: f64 = text.chars().map(|c| m.h_metrics(c).0).sum();
            Ok((units * scale).ceil() as u32)
        }
        None => {
            let style = text_style(size_px, BLACK, Pos::new(HPos::Left, VPos::Top));
            Ok(area.estimate_text_size(text, &style).map_err(draw_err)?.0)
        }
    }
}

/// Draws `text` horizontally with its anchor (`spec.pos`) at `(x, y)`.
pub(crate) fn draw_text<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    text: &str,
    (x, y): (i32, i32),
    spec: TextSpec,
) -> Result<()> {
    let rotate = |style: TextStyle<'static>| {
        if spec.vertical {
            let font = style.font.clone().transform(FontTransform::Rotate270);
            TextStyle { font, ..style }
        } else {
            style
        }
    };
    let Some(m) = metrics() else {
        let style = rotate(text_style(spec.size_px, spec.colour, spec.pos));
        return area.draw(&Text::new(text, (x, y), style)).map_err(draw_err);
    };
    let scale = spec.size_px / m.height_units;
    let width: f64 = text.chars().map(|c| m.h_metrics(c).0).sum::<f64>() * scale;
    // Offset of the text start from the anchor along the reading direction.
    let start = -match spec.pos.h_pos {
        HPos::Left => 0.0,
        HPos::Center => width / 2.0,
        HPos::Right => width,
    };
    let style = rotate(text_style(
        spec.size_px,
        spec.colour,
        Pos::new(HPos::Left, spec.pos.v_pos),
    ));
    let mut pen = start;
    let mut buf = [0u8; 4];
    for c in text.chars() {
        let (adv, lsb) = m.h_metrics(c);
        if !c.is_whitespace() {
            // ab_glyph rasterises from floor(lsb) and plotters puts that pixel at the given point.
            let along = (pen.round() + (lsb * scale).floor()) as i32;
            let at = if spec.vertical {
                (x, y - along)
            } else {
                (x + along, y)
            };
            area.draw(&Text::new(&*c.encode_utf8(&mut buf), at, style.clone()))
                .map_err(draw_err)?;
        }
        pen += adv * scale;
    }
    Ok(())
}

/// Shortens `text` with a trailing ellipsis until it fits `max_width_px` at `size_px`.
pub(crate) fn fit_text<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    text: &str,
    size_px: f64,
    max_width_px: u32,
) -> Result<String> {
    if text_width(area, text, size_px)? <= max_width_px {
        return Ok(text.to_string());
    }
    let mut chars: Vec<char> = text.chars().collect();
    while !chars.is_empty() {
        chars.pop();
        let candidate = chars.iter().collect::<String>().trim_end().to_string() + "…";
        if text_width(area, &candidate, size_px)? <= max_width_px {
            return Ok(candidate);
        }
    }
    Ok(String::new())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn embedded_font_metrics_parse_and_map_ascii_to_glyphs() {
        let m = metrics().expect("DejaVu Sans tables parse");
        assert!(m.height_units > 2000.0);
        let a = m.glyph_id('a');
        assert!(a > 0 && a != m.glyph_id('b'));
        // 'l' is narrower than 'm' and has a positive left side bearing
        let (adv_l, lsb_l) = m.h_metrics('l');
        let (adv_m, _) = m.h_metrics('m');
        assert!(adv_l < adv_m && lsb_l > 0.0);
        assert!(m.glyph_id('—') > 0 && m.glyph_id('°') > 0 && m.glyph_id('…') > 0);
    }

    #[test]
    fn text_widths_agree_with_plotters_layout_of_the_same_font() {
        // plotters sums the same advances (plus kerning, absent for this string)
        super::super::ensure_font().expect("font");
        let mut buf = vec![0u8; 3 * 4 * 4];
        let area = BitMapBackend::with_buffer(&mut buf, (4, 4)).into_drawing_area();
        let text = "0123456789";
        let ours = text_width(&area, text, 100.0).expect("width");
        let style = text_style(100.0, BLACK, Pos::new(HPos::Left, VPos::Top));
        let theirs = area.estimate_text_size(text, &style).expect("estimate").0;
        assert!(ours.abs_diff(theirs) <= 1, "ours {ours}, plotters {theirs}");
    }
}
