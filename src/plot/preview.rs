//! The contact sheet of a preset preview ([`crate::render::Sheet`]) as one PNG: a title, then
//! each row's heading above its panels side by side, each panel with its caption lines under
//! it, and the notes at the bottom. Text in the embedded DejaVu Sans (the `text` module); the
//! panels' pixels are copied unchanged. The same sheet always gives the same bytes.

use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, VPos};

use super::{
    draw_err, draw_text, ensure_font, fit_text, render_png_bytes, text_width, TextSpec, INK,
    MUTED_INK,
};
use crate::error::Result;
use crate::render::Sheet;

const MARGIN: u32 = 16;
const GAP: u32 = 12;
const TITLE_PX: f64 = 20.0;
const HEADING_PX: f64 = 15.0;
const CAPTION_PX: f64 = 13.0;
const NOTE_PX: f64 = 12.0;
const LINE: u32 = 17;

fn row_width(row: &crate::render::SheetRow) -> u32 {
    let w: u32 = row.panels.iter().map(|p| p.image.width as u32).sum();
    w + GAP * row.panels.len().saturating_sub(1) as u32
}

/// `text` broken at spaces into lines no wider than `max_px` at `size_px`.
fn wrap(text: &str, size_px: f64, max_px: u32) -> Result<Vec<String>> {
    ensure_font()?;
    let mut buf = vec![0u8; 3 * 4 * 4];
    let area = BitMapBackend::with_buffer(&mut buf, (4, 4)).into_drawing_area();
    let mut lines = Vec::new();
    let mut cur = String::new();
    for word in text.split_whitespace() {
        let candidate = if cur.is_empty() {
            word.to_string()
        } else {
            format!("{cur} {word}")
        };
        if !cur.is_empty() && text_width(&area, &candidate, size_px)? > max_px {
            lines.push(std::mem::replace(&mut cur, word.to_string()));
        } else {
            cur = candidate;
        }
    }
    if !cur.is_empty() {
        lines.push(cur);
    }
    Ok(lines)
}

/// The sheet as PNG bytes.
///
/// # Errors
/// A sheet larger than the plot size limit, or a drawing/encoding failure.
pub fn preview_sheet_png(sheet: &Sheet) -> Result<Vec<u8>> {
    let width = sheet.rows.iter().map(row_width).max().unwrap_or(0).max(640) + 2 * MARGIN;
    // Captions wrapped to their panel's width: (title lines, further lines) per panel.
    let mut captions: Vec<Vec<(Vec<String>, Vec<String>)>> = Vec::new();
    for row in &sheet.rows {
        let mut r = Vec::new();
        for p in &row.panels {
            let cap_w = (p.image.width as u32).max(40);
            let title = wrap(&p.title, CAPTION_PX, cap_w)?;
            let mut lines = Vec::new();
            for l in &p.lines {
                lines.extend(wrap(l, CAPTION_PX - 1.0, cap_w)?);
            }
            r.push((title, lines));
        }
        captions.push(r);
    }
    let img_height = |row: &crate::render::SheetRow| -> u32 {
        row.panels
            .iter()
            .map(|p| p.image.height as u32)
            .max()
            .unwrap_or(0)
    };
    let caption_lines = |caps: &[(Vec<String>, Vec<String>)]| -> u32 {
        caps.iter()
            .map(|(t, l)| (t.len() + l.len()) as u32)
            .max()
            .unwrap_or(0)
    };
    let mut height = MARGIN + 2 * LINE;
    for (row, caps) in sheet.rows.iter().zip(&captions) {
        height += LINE + 6 + img_height(row) + 4 + caption_lines(caps) * LINE + GAP;
    }
    let mut notes = Vec::new();
    for n in &sheet.notes {
        notes.extend(wrap(n, NOTE_PX, width - 2 * MARGIN)?);
    }
    height += notes.len() as u32 * LINE + MARGIN;
    render_png_bytes((width, height), |area| {
        let text_w = width - 2 * MARGIN;
        let title = fit_text(&area, &sheet.title, TITLE_PX, text_w)?;
        draw_text(
            &area,
            &title,
            (MARGIN as i32, MARGIN as i32),
            TextSpec::new(TITLE_PX, INK, HPos::Left, VPos::Top),
        )?;
        let mut y = MARGIN + 2 * LINE;
        for (row, caps) in sheet.rows.iter().zip(&captions) {
            let heading = fit_text(&area, &row.heading, HEADING_PX, text_w)?;
            draw_text(
                &area,
                &heading,
                (MARGIN as i32, y as i32),
                TextSpec::new(HEADING_PX, INK, HPos::Left, VPos::Top),
            )?;
            y += LINE + 6;
            let img_h = img_height(row);
            let mut x = MARGIN;
            for (p, (title_lines, cap_lines)) in row.panels.iter().zip(caps) {
                let (w, h) = (p.image.width, p.image.height);
                for py in 0..h {
                    for px in 0..w {
                        let i = 3 * (py * w + px);
                        let c = &p.image.bytes[i..i + 3];
                        area.draw_pixel(
                            ((x as usize + px) as i32, (y as usize + py) as i32),
                            &RGBColor(c[0], c[1], c[2]),
                        )
                        .map_err(draw_err)?;
                    }
                }
                let mut ty = (y + img_h + 4) as i32;
                let cap_w = (w as u32).max(40);
                let styled = title_lines
                    .iter()
                    .map(|t| (t, TextSpec::new(CAPTION_PX, INK, HPos::Left, VPos::Top)))
                    .chain(cap_lines.iter().map(|t| {
                        (
                            t,
                            TextSpec::new(CAPTION_PX - 1.0, MUTED_INK, HPos::Left, VPos::Top),
                        )
                    }));
                for (t, spec) in styled {
                    let t = fit_text(&area, t, spec.size_px, cap_w)?;
                    draw_text(&area, &t, (x as i32, ty), spec)?;
                    ty += LINE as i32;
                }
                x += w as u32 + GAP;
            }
            y += img_h + 4 + caption_lines(caps) * LINE + GAP;
        }
        for n in &notes {
            let t = fit_text(&area, n, NOTE_PX, text_w)?;
            draw_text(
                &area,
                &t,
                (MARGIN as i32, y as i32),
                TextSpec::new(NOTE_PX, MUTED_INK, HPos::Left, VPos::Top),
            )?;
            y += LINE;
        }
        Ok(())
    })
}
