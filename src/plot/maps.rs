//! Previews of per-pixel parameter maps (`phos fit-decay --per-pixel`): a 16-bit greyscale PNG of
//! the map, downsampled to at most [`PREVIEW_MAX_SIDE`] px, with a grey colour bar labelled with
//! the value range and unit.
//!
//! The map area and the bar are written at 16 bits: grey level v ∈ 0–65535 stands for
//! lo + (hi − lo)·v/65535 (values outside [lo, hi] clipped), so the preview is quantitative to
//! 1/65535 of the range; blocks without a value (NaN) are drawn at 0 with a one-level checker
//! (0 and 1) so that they differ from the range's low end in the data but look black. Labels are
//! drawn by plotters (8-bit, scaled to 16 bits).

use image::ImageEncoder;
use plotters::style::text_anchor::{HPos, VPos};

use super::text::{draw_text, TextSpec};
use super::{render_png_bytes, INK};
use crate::error::{Error, Result};

/// Largest side of a preview's map area in pixels.
pub const PREVIEW_MAX_SIDE: usize = 1024;
const BAR_W: usize = 28;
const LABEL_W: usize = 150;
const GAP: usize = 16;
const TITLE_H: usize = 40;
const MIN_H: usize = 240;

/// A map to preview.
#[derive(Debug, Clone, Copy)]
pub struct MapPreview<'a> {
    /// Title, e.g. `k1 (fastest rate)`.
    pub title: &'a str,
    /// Unit, e.g. `1/s` (empty for none).
    pub unit: &'a str,
    /// Values, row-major, `width × height` (NaN = no value).
    pub values: &'a [f32],
    /// Width in blocks.
    pub width: usize,
    /// Height in blocks.
    pub height: usize,
    /// Value range of the grey scale; `None` for the 1st–99th percentile of the values.
    pub range: Option<(f64, f64)>,
}

/// A rendered preview: the 16-bit PNG and the range its grey levels stand for.
#[derive(Debug, Clone)]
pub struct RenderedPreview {
    /// PNG bytes (16-bit greyscale).
    pub png: Vec<u8>,
    /// (lo, hi): grey 0 is lo, 65535 is hi.
    pub range: (f64, f64),
    /// Downsampling factor (block side of the preview in map blocks).
    pub factor: usize,
}

fn fmt(v: f64) -> String {
    if v == 0.0 {
        "0".into()
    } else if v.abs() >= 1e4 || v.abs() < 1e-3 {
        format!("{v:.3e}")
    } else {
        format!("{v:.4}")
    }
}

/// Renders the preview of one map.
///
/// # Errors
/// [`Error::ShapeMismatch`] when the values do not hold the map; drawing and encoding errors.
pub fn map_preview_png(m: &MapPreview<'_>) -> Result<RenderedPreview> {
    if m.values.len() != m.width * m.height || m.width == 0 || m.height == 0 {
        return Err(Error::ShapeMismatch {
            what: format!("map preview '{}'", m.title),
            expected: m.width * m.height,
            got: m.values.len(),
        });
    }
    let factor = m.width.max(m.height).div_ceil(PREVIEW_MAX_SIDE).max(1);
    let (pw, ph) = (m.width.div_ceil(factor), m.height.div_ceil(factor));
    // mean of the finite values of each factor × factor cell
    let mut small = vec![f64::NAN; pw * ph];
    for py in 0..ph {
        for px in 0..pw {
            let (mut s, mut n) = (0.0, 0usize);
            for y in py * factor..((py + 1) * factor).min(m.height) {
                for x in px * factor..((px + 1) * factor).min(m.width) {
                    let v = f64::from(m.values[y * m.width + x]);
                    if v.is_finite() {
                        s += v;
                        n += 1;
                    }
                }
            }
            if n > 0 {
                small[py * pw + px] = s / n as f64;
            }
        }
    }
    let (lo, hi) = match m.range {
        Some(r) => r,
        None => {
            let mut f: Vec<f64> = small.iter().cloned().filter(|v| v.is_finite()).collect();
            f.sort_by(f64::total_cmp);
            if f.is_empty() {
                (0.0, 1.0)
            } else {
                let q = |p: f64| f[((f.len() - 1) as f64 * p).round() as usize];
                (q(0.01), q(0.99))
            }
        }
    };
    let (lo, hi) = if hi > lo {
        (lo, hi)
    } else {
        let d = lo.abs() * 0.01 + 1e-12;
        (lo - d, lo + d)
    };
    let h = ph.max(MIN_H);
    let (w_all, h_all) = (pw + GAP + BAR_W + LABEL_W, h + TITLE_H);
    let bar_x = pw + GAP;
    let title = if m.unit.is_empty() {
        m.title.to_string()
    } else {
        format!("{} [{}]", m.title, m.unit)
    };
    let chart = render_png_bytes((w_all as u32, h_all as u32), |root| {
        let spec = TextSpec::new(18.0, INK, HPos::Left, VPos::Center);
        draw_text(&root, &title, (8, (TITLE_H / 2) as i32), spec)?;
        let lx = (bar_x + BAR_W + 8) as i32;
        let top = TITLE_H as i32;
        let bottom = (TITLE_H + ph - 1) as i32;
        let spec = TextSpec::new(15.0, INK, HPos::Left, VPos::Center);
        draw_text(&root, &fmt(hi), (lx, top + 8), spec)?;
        draw_text(&root, &fmt(0.5 * (lo + hi)), (lx, (top + bottom) / 2), spec)?;
        draw_text(&root, &fmt(lo), (lx, bottom - 8), spec)?;
        if factor > 1 {
            let s = format!("1 px = {factor}×{factor}");
            draw_text(&root, &s, (lx, bottom + 24), spec)?;
        }
        Ok(())
    })?;
    let rgb = image::load_from_memory(&chart)
        .map_err(|e| Error::invalid("map preview", e.to_string()))?
        .to_rgb8();
    let mut px: Vec<u16> = rgb
        .pixels()
        .map(|p| {
            let l = 0.2126 * f64::from(p[0]) + 0.7152 * f64::from(p[1]) + 0.0722 * f64::from(p[2]);
            (l * 257.0).round().clamp(0.0, 65535.0) as u16
        })
        .collect();
    let level = |v: f64| (((v - lo) / (hi - lo)).clamp(0.0, 1.0) * 65535.0).round() as u16;
    for y in 0..ph {
        for x in 0..pw {
            let v = small[y * pw + x];
            px[(TITLE_H + y) * w_all + x] = if v.is_finite() {
                level(v)
            } else {
                ((x + y) % 2) as u16
            };
        }
    }
    for y in 0..ph {
        let v = hi - (hi - lo) * y as f64 / (ph.max(2) - 1) as f64;
        for x in bar_x..bar_x + BAR_W {
            px[(TITLE_H + y) * w_all + x] = level(v);
        }
    }
    let bytes: Vec<u8> = px.iter().flat_map(|v| v.to_ne_bytes()).collect(); // the encoder takes native order
    let mut png = Vec::new();
    image::codecs::png::PngEncoder::new(&mut png)
        .write_image(
            &bytes,
            w_all as u32,
            h_all as u32,
            image::ExtendedColorType::L16,
        )
        .map_err(|e| Error::invalid("map preview", format!("PNG encoding failed: {e}")))?;
    Ok(RenderedPreview {
        png,
        range: (lo, hi),
        factor,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_preview_is_16_bit_and_its_grey_levels_map_back_to_the_values() {
        let (w, h) = (40, 30);
        let values: Vec<f32> = (0..w * h)
            .map(|i| {
                if i == 0 {
                    f32::NAN
                } else {
                    (i % w) as f32 * 0.01
                }
            })
            .collect();
        let r = map_preview_png(&MapPreview {
            title: "k1",
            unit: "1/s",
            values: &values,
            width: w,
            height: h,
            range: Some((0.0, 0.39)),
        })
        .unwrap();
        let img = image::load_from_memory(&r.png).unwrap();
        assert_eq!(img.color(), image::ColorType::L16);
        let g = img.to_luma16();
        for x in 1..w {
            let v = f64::from(g.get_pixel(x as u32, (TITLE_H + 5) as u32)[0]) / 65535.0 * 0.39;
            assert!((v - x as f64 * 0.01).abs() < 1e-4, "x {x}: {v}");
        }
        assert!(g.get_pixel(0, TITLE_H as u32)[0] <= 1);
    }
}
