//! The ColorChecker figure: rendered swatches under several illuminants beside the patches'
//! reflectance spectra.
//!
//! Left: a grid of six columns (four rows for the 24-patch chart) on a dark card, as the physical
//! chart is printed. Each patch is split into vertical stripes, one per illuminant in the order of
//! `illuminant_names` (left to right). Encoded sRGB outside 0–1 is clipped for display and the
//! stripe gets a corner wedge. Right: every patch's reflectance factor over 380–780 nm, each
//! curve in the patch's colour under the first illuminant.

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, VPos};

use super::{
    contrasting_text, draw_curve, draw_err, draw_text, fit_text, render_png_bytes, spectral_axes,
    srgb_to_u8, text_width, AxesSpec, TextSpec, INK, MUTED_INK,
};
use crate::error::{Error, Result};
use crate::spectrum::Spectrum;

/// One patch of a colour chart: its measured or tabulated reflectance and its colour rendered
/// under each illuminant of the figure.
#[derive(Debug, Clone, PartialEq)]
pub struct SwatchPatch {
    /// Patch name shown under the swatch (e.g. `"dark skin"`).
    pub name: String,
    /// Reflectance factor (0–1, may exceed 1 for fluorescent samples) over wavelength in nm.
    pub reflectance: Spectrum,
    /// Encoded (gamma-corrected) sRGB, nominally 0–1, one triple per illuminant in the order of
    /// the figure's illuminant names. Values outside 0–1 are out of gamut: they are clipped for
    /// display and the stripe is marked.
    pub srgb_by_illuminant: Vec<[f64; 3]>,
}

/// Figure size in pixels.
const SIZE_PX: (u32, u32) = (1600, 1000);
/// Height of the title band.
const TITLE_H: i32 = 70;
/// Width of the swatch panel (the spectra take the rest).
const LEFT_W: i32 = 910;
/// Swatch grid columns (the ColorChecker Classic is 6 × 4).
const COLUMNS: usize = 6;
/// Channel tolerance for "out of gamut": half an 8-bit step, i.e. clipping changes the displayed
/// byte.
const GAMUT_TOL: f64 = 0.5 / 255.0;
/// Wavelength axis of the spectra panel (nm).
const WL_RANGE_NM: (f64, f64) = (380.0, 780.0);

/// Card (chart background) colour and the text colour on it.
const CARD: RGBColor = RGBColor(46, 46, 48);
const CARD_TEXT: RGBColor = RGBColor(228, 228, 228);
/// Light fill of legend icons.
const ICON_FILL: RGBColor = RGBColor(236, 236, 236);

/// Writes the ColorChecker figure (1600 × 1000 px PNG) to `path`.
///
/// `illuminant_names` names the stripes of every patch, left to right; each patch needs exactly
/// one sRGB triple per illuminant. The spectra panel draws each patch's reflectance in its colour
/// under the first illuminant.
///
/// # Errors
/// [`Error::InvalidArgument`] for no illuminants, no patches or non-finite colours;
/// [`Error::ShapeMismatch`] when a patch's colours do not match the illuminants; [`Error::Io`]
/// when the file cannot be written (nothing is left behind).
pub fn colorchecker_chart(
    path: &Path,
    title: &str,
    illuminant_names: &[String],
    patches: &[SwatchPatch],
) -> Result<()> {
    crate::io::atomic_write(
        path,
        &colorchecker_chart_png(title, illuminant_names, patches)?,
    )
}

/// The same chart as [`colorchecker_chart`], encoded as PNG in memory (for staged outputs).
pub fn colorchecker_chart_png(
    title: &str,
    illuminant_names: &[String],
    patches: &[SwatchPatch],
) -> Result<Vec<u8>> {
    validate(illuminant_names, patches)?;
    render_png_bytes(SIZE_PX, |root| {
        let (w, _) = root.dim_in_pixel();
        let style = TextSpec::new(30.0, INK, HPos::Center, VPos::Center);
        let title = fit_text(&root, title, style.size_px, w - 40)?;
        draw_text(&root, &title, (w as i32 / 2, TITLE_H / 2 + 4), style)?;
        let (_, body) = root.split_vertically(TITLE_H);
        let (left, right) = body.split_horizontally(LEFT_W);
        draw_swatch_panel(&left, illuminant_names, patches)?;
        draw_spectra_panel(&right, patches)
    })
}

fn validate(illuminant_names: &[String], patches: &[SwatchPatch]) -> Result<()> {
    if illuminant_names.is_empty() {
        return Err(Error::invalid(
            "illuminant_names",
            "no illuminants; expected at least one stripe per patch",
        ));
    }
    if patches.is_empty() {
        return Err(Error::invalid(
            "patches",
            "no patches; expected at least one",
        ));
    }
    for p in patches {
        if p.srgb_by_illuminant.len() != illuminant_names.len() {
            return Err(Error::ShapeMismatch {
                what: format!("sRGB colours of patch '{}' vs illuminants", p.name),
                expected: illuminant_names.len(),
                got: p.srgb_by_illuminant.len(),
            });
        }
        if p.srgb_by_illuminant
            .iter()
            .flatten()
            .any(|c| !c.is_finite())
        {
            return Err(Error::invalid(
                "srgb_by_illuminant",
                format!("patch '{}' has a non-finite colour", p.name),
            ));
        }
    }
    Ok(())
}

fn out_of_gamut(rgb: [f64; 3]) -> bool {
    rgb.iter()
        .any(|c| !(-GAMUT_TOL..=1.0 + GAMUT_TOL).contains(c))
}

fn rgb(c: [u8; 3]) -> RGBColor {
    RGBColor(c[0], c[1], c[2])
}

/// The corner wedge marking a clipped stripe whose bottom-right pixel is `(x1, y1)`.
fn wedge(x1: i32, y1: i32, size: i32, colour: RGBColor) -> Polygon<(i32, i32)> {
    Polygon::new(
        vec![(x1, y1), (x1 - size, y1), (x1, y1 - size)],
        colour.filled(),
    )
}

fn draw_swatch_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    illuminant_names: &[String],
    patches: &[SwatchPatch],
) -> Result<()> {
    let (w, h) = area.dim_in_pixel();
    let (w, h) = (w as i32, h as i32);
    let n_stripes = illuminant_names.len() as i32;
    let cols = COLUMNS.min(patches.len()) as i32;
    let rows = patches.len().div_ceil(COLUMNS) as i32;

    // Geometry: a dark card holding the grid and a legend below it, centred in the panel.
    let margin_l = 40;
    let margin_r = 20;
    let pad = 20; // card padding
    let gap = 16; // between patches
    let label_h = 26; // name line under each patch
    let legend_gap = 22;
    let legend_h = 76;
    let card_w_max = w - margin_l - margin_r;
    let cell_w = (card_w_max - 2 * pad + gap) / cols;
    let cell_h_max = (h - 40 - legend_gap - legend_h - 2 * pad + gap) / rows;
    let side = (cell_w - gap).min(cell_h_max - label_h - gap).max(8);
    let cell_w = side + gap;
    let cell_h = side + label_h + gap;
    let card_w = cols * cell_w - gap + 2 * pad;
    let card_h = rows * cell_h - gap + 2 * pad;
    let block_h = card_h + legend_gap + legend_h;
    let card_x = margin_l + (card_w_max - card_w) / 2;
    let card_y = ((h - block_h) / 2).max(4);

    area.draw(&Rectangle::new(
        [(card_x, card_y), (card_x + card_w, card_y + card_h)],
        CARD.filled(),
    ))
    .map_err(draw_err)?;

    let number = TextSpec::new(16.0, INK, HPos::Left, VPos::Top);
    let name_spec = TextSpec::new(15.0, CARD_TEXT, HPos::Center, VPos::Top);
    let wedge_size = (side / (4 * n_stripes)).clamp(8, 16);

    for (k, patch) in patches.iter().enumerate() {
        let (r, c) = ((k / COLUMNS) as i32, (k % COLUMNS) as i32);
        let x0 = card_x + pad + c * cell_w;
        let y0 = card_y + pad + r * cell_h;
        let mut first_colour = [0u8; 3];
        for (i, &srgb) in patch.srgb_by_illuminant.iter().enumerate() {
            let i = i as i32;
            let sx0 = x0 + side * i / n_stripes;
            let sx1 = x0 + side * (i + 1) / n_stripes;
            let colour = srgb_to_u8(srgb);
            if i == 0 {
                first_colour = colour;
            }
            area.draw(&Rectangle::new(
                [(sx0, y0), (sx1, y0 + side)],
                rgb(colour).filled(),
            ))
            .map_err(draw_err)?;
            if out_of_gamut(srgb) {
                let mark = wedge(sx1 - 1, y0 + side - 1, wedge_size, contrasting_text(colour));
                area.draw(&mark).map_err(draw_err)?;
            }
        }
        let num_colour = contrasting_text(first_colour);
        draw_text(
            area,
            &format!("{}", k + 1),
            (x0 + 7, y0 + 7),
            number.with_colour(num_colour),
        )?;
        let name = fit_text(area, &patch.name, name_spec.size_px, (cell_w - 4) as u32)?;
        draw_text(area, &name, (x0 + side / 2, y0 + side + 7), name_spec)?;
    }

    draw_legend(
        area,
        (card_x, card_y + card_h + legend_gap),
        illuminant_names,
        wedge_size,
    )
}

/// Legend under the card: which stripe is which illuminant, and what the corner wedge means.
fn draw_legend<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    (x, y): (i32, i32),
    illuminant_names: &[String],
    wedge_size: i32,
) -> Result<()> {
    let (w, _) = area.dim_in_pixel();
    let text = TextSpec::new(16.0, INK, HPos::Left, VPos::Center);
    let icon = 28;
    let n = illuminant_names.len() as i32;
    let row1 = y + icon / 2;

    let outline = |ix0: i32, iy0: i32| -> Result<()> {
        area.draw(&Rectangle::new(
            [(ix0, iy0), (ix0 + icon, iy0 + icon)],
            MUTED_INK.stroke_width(1),
        ))
        .map_err(draw_err)
    };

    let lead = "Stripes, left to right:";
    draw_text(area, lead, (x, row1), text.with_colour(MUTED_INK))?;
    let mut cx = x + text_width(area, lead, text.size_px)? as i32 + 16;
    for (i, name) in illuminant_names.iter().enumerate() {
        let i = i as i32;
        // icon: a patch with the i-th stripe dark
        let (ix0, iy0) = (cx, row1 - icon / 2);
        let sx0 = ix0 + icon * i / n;
        let sx1 = ix0 + icon * (i + 1) / n;
        area.draw(&Rectangle::new(
            [(ix0, iy0), (ix0 + icon, iy0 + icon)],
            ICON_FILL.filled(),
        ))
        .map_err(draw_err)?;
        area.draw(&Rectangle::new(
            [(sx0, iy0), (sx1, iy0 + icon)],
            CARD.filled(),
        ))
        .map_err(draw_err)?;
        outline(ix0, iy0)?;
        let label = fit_text(area, name, text.size_px, 220)?;
        draw_text(area, &label, (ix0 + icon + 9, row1), text)?;
        cx = ix0 + icon + 9 + text_width(area, &label, text.size_px)? as i32 + 28;
        if cx > w as i32 - 80 {
            break;
        }
    }

    let row2 = row1 + icon + 14;
    let (ix0, iy0) = (x, row2 - icon / 2);
    area.draw(&Rectangle::new(
        [(ix0, iy0), (ix0 + icon, iy0 + icon)],
        ICON_FILL.filled(),
    ))
    .map_err(draw_err)?;
    outline(ix0, iy0)?;
    area.draw(&wedge(ix0 + icon - 1, iy0 + icon - 1, wedge_size, INK))
        .map_err(draw_err)?;
    draw_text(
        area,
        "corner mark: colour outside the sRGB gamut, clipped for display",
        (ix0 + icon + 9, row2),
        text,
    )
}

fn draw_spectra_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    patches: &[SwatchPatch],
) -> Result<()> {
    let y_max = patches
        .iter()
        .flat_map(|p| p.reflectance.values().iter().copied())
        .filter(|v| v.is_finite())
        .fold(1.0f64, f64::max);
    let y_max = if y_max > 1.0 {
        (y_max * 10.0).ceil() / 10.0
    } else {
        1.0
    };
    let mut chart = spectral_axes(
        area,
        &AxesSpec {
            caption: Some("Reflectance spectra"),
            x_label: "wavelength (nm)",
            y_label: "reflectance factor",
            x_range: WL_RANGE_NM,
            y_range: (0.0, y_max),
            n_ticks: (9, 11),
        },
    )?;
    for p in patches {
        let pts: Vec<(f64, f64)> = p
            .reflectance
            .wavelengths()
            .iter()
            .copied()
            .zip(p.reflectance.values().iter().copied())
            .collect();
        let colour = srgb_to_u8(p.srgb_by_illuminant[0]);
        draw_curve(&mut chart, &pts, colour, 2)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::super::tests::{decode, is_single_colour, smooth_spectrum};
    use super::*;

    /// Made-up colours: a hue wheel for the first 18 patches, a grey ramp for the last 6; the
    /// second illuminant is warmer. Patch 3 is pushed out of gamut under both.
    fn synthetic_patches() -> Vec<SwatchPatch> {
        const NAMES: [&str; 24] = [
            "dark skin",
            "light skin",
            "blue sky",
            "foliage",
            "blue flower",
            "bluish green",
            "orange",
            "purplish blue",
            "moderate red",
            "purple",
            "yellow green",
            "orange yellow",
            "blue",
            "green",
            "red",
            "yellow",
            "magenta",
            "cyan",
            "white 9.5 (.05 D)",
            "neutral 8 (.23 D)",
            "neutral 6.5 (.44 D)",
            "neutral 5 (.70 D)",
            "neutral 3.5 (1.05 D)",
            "black 2 (1.5 D)",
        ];
        NAMES
            .iter()
            .enumerate()
            .map(|(i, name)| {
                let d65 = if i < 18 {
                    let h = i as f64 / 18.0 * std::f64::consts::TAU;
                    [
                        0.5 + 0.4 * h.cos(),
                        0.5 + 0.4 * (h - 2.1).cos(),
                        0.5 + 0.4 * (h + 2.1).cos(),
                    ]
                } else {
                    let g = 0.95 - 0.16 * (i - 18) as f64;
                    [g, g, g]
                };
                let mut a = [d65[0] * 1.15, d65[1] * 0.95, d65[2] * 0.6];
                let mut d65 = d65;
                if i == 2 {
                    d65[2] = 1.08;
                    a[0] = -0.05;
                }
                SwatchPatch {
                    name: name.to_string(),
                    reflectance: smooth_spectrum(i),
                    srgb_by_illuminant: vec![d65, a],
                }
            })
            .collect()
    }

    fn illuminants() -> Vec<String> {
        vec!["D65".to_string(), "A".to_string()]
    }

    #[test]
    fn colorchecker_chart_writes_a_decodable_png_of_the_expected_size() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("cc.png");
        colorchecker_chart(
            &path,
            "ColorChecker under D65 and A",
            &illuminants(),
            &synthetic_patches(),
        )
        .expect("chart renders");
        let img = decode(&path);
        assert_eq!(img.dimensions(), SIZE_PX);
        assert!(!is_single_colour(&img));
    }

    #[test]
    fn colorchecker_chart_into_a_missing_directory_fails_and_leaves_nothing() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("missing").join("cc.png");
        let err = colorchecker_chart(&path, "t", &illuminants(), &synthetic_patches());
        assert!(matches!(err, Err(Error::Io { .. })), "{err:?}");
        assert!(!path.exists());
        assert_eq!(std::fs::read_dir(dir.path()).expect("dir").count(), 0);
    }

    #[test]
    fn colorchecker_chart_rejects_patches_with_the_wrong_number_of_colours() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("cc.png");
        let mut patches = synthetic_patches();
        patches[5].srgb_by_illuminant.pop();
        let err = colorchecker_chart(&path, "t", &illuminants(), &patches);
        assert!(matches!(err, Err(Error::ShapeMismatch { .. })), "{err:?}");
        assert!(!path.exists());
    }

    #[test]
    fn out_of_gamut_ignores_rounding_noise_but_flags_real_excursions() {
        assert!(!out_of_gamut([1.0 + 1e-9, 0.0, -1e-9]));
        assert!(out_of_gamut([1.05, 0.5, 0.5]));
        assert!(out_of_gamut([0.5, -0.02, 0.5]));
    }

    #[test]
    fn colorchecker_chart_handles_three_illuminants_and_a_partial_last_row() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("cc3.png");
        three_illuminant_chart(&path);
        assert_eq!(decode(&path).dimensions(), SIZE_PX);
    }

    fn three_illuminant_chart(path: &Path) {
        let names = vec!["D65".to_string(), "A".to_string(), "F11 (TL84)".to_string()];
        let patches: Vec<SwatchPatch> = synthetic_patches()
            .into_iter()
            .take(8)
            .map(|mut p| {
                let c = p.srgb_by_illuminant[0];
                p.srgb_by_illuminant
                    .push([c[0] * 0.9, c[1] * 1.05, c[2] * 0.8]);
                p
            })
            .collect();
        colorchecker_chart(
            path,
            "Eight patches under three illuminants",
            &names,
            &patches,
        )
        .expect("chart renders");
    }

    /// Writes the demo-like chart to `/tmp/plot_check.png` for a visual check:
    /// `cargo test --release --lib plot -- --ignored`.
    #[test]
    #[ignore]
    fn write_visual_check_chart() {
        colorchecker_chart(
            Path::new("/tmp/plot_check.png"),
            "X-Rite ColorChecker Classic — rendered under D65 and A (CIE 1931 2°)",
            &illuminants(),
            &synthetic_patches(),
        )
        .expect("chart renders");
        three_illuminant_chart(Path::new("/tmp/plot_check_3ill.png"));
    }
}
