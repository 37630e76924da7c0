//! The dispersion row: a thin white beam through a prism of the preset's n(λ) onto a screen 1 m
//! away (apex 60°, minimum deviation at the d line, beam 2 mm: [`PrismSetup::default`]),
//! rendered twice by [`crate::dispersion::prism`]:
//!
//! - **spectral**: every 1 nm slice of the section's illuminant and observer at its own
//!   deviation (the reference, out-of-gamut colours included);
//! - **samples**: the preset's wavelength samples, each with its RGB weight, at the deviation of
//!   its wavelength — what an RGB renderer that traces one ray per sample shows.
//!
//! The screen strip (XYZ relative to the working white) is adapted to D65 (CAT02), shown in
//! linear sRGB with one exposure for both panels (the spectral strip's brightest channel at 1),
//! and stretched to the panel width (each column the mean of the strip pixels it covers). The
//! ΔE00 mean and maximum along the lit part of the strip are those of `dispersion prism`.

use serde::Serialize;

use super::{sig3, PreviewOptions};
use crate::colorimetry::cat::{chromatic_adaptation_matrix, Cat};
use crate::colorimetry::rgb::RgbSpace;
use crate::colorimetry::{Observer, StandardObserver};
use crate::dispersion::blanchette2012::slices_for;
use crate::dispersion::prism::{evaluate, PrismSetup, Strip};
use crate::error::{ensure_finite, Result};
use crate::math::linalg::{mat3_mul, mat3_mul_vec, Mat3};
use crate::preset::dispersion::DispersionSection;
use crate::render::{display_srgb8, Panel, SheetRow, Srgb8Image};

/// The numbers of the dispersion row.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PrismReport {
    /// Number of wavelength samples of the preset.
    pub n_samples: usize,
    /// Illuminant of the spectral reference.
    pub illuminant: String,
    /// Observer of the spectral reference.
    pub observer: String,
    /// Prism apex, degrees.
    pub apex_deg: f64,
    /// Incidence (minimum deviation at the d line), degrees.
    pub incidence_deg: f64,
    /// Deviation of the d line, degrees.
    pub deviation_d_deg: f64,
    /// Width of the lit screen strip, mm.
    pub strip_mm: f64,
    /// Mean ΔE00 of the samples' render against the spectral one over lit pixels.
    pub mean_delta_e00: f64,
    /// Maximum ΔE00.
    pub max_delta_e00: f64,
    /// One line for the sheet's notes.
    pub note: String,
}

fn strip_image(
    strip: &Strip,
    to_display: &Mat3,
    exposure: f64,
    (width, height): (usize, usize),
) -> Srgb8Image {
    let n = strip.xyz.len().max(1);
    let cols: Vec<[u8; 3]> = (0..width)
        .map(|c| {
            let a = c * n / width;
            let b = ((c + 1) * n / width).max(a + 1).min(n);
            let mut acc = [0.0; 3];
            for px in &strip.xyz[a.min(n - 1)..b] {
                for k in 0..3 {
                    acc[k] += px[k];
                }
            }
            let m = (b - a.min(n - 1)).max(1) as f64;
            display_srgb8(mat3_mul_vec(to_display, acc.map(|v| v / m)), exposure)
        })
        .collect();
    let margin = height / 6;
    let mut bytes = Vec::with_capacity(width * height * 3);
    for y in 0..height {
        for c in &cols {
            if y < margin || y >= height - margin {
                bytes.extend_from_slice(&[8, 8, 8]);
            } else {
                bytes.extend_from_slice(c);
            }
        }
    }
    Srgb8Image {
        width,
        height,
        bytes,
    }
}

/// The spectral and sampled screen panels, and their numbers.
pub fn prism_row(
    section: &DispersionSection,
    o: &PreviewOptions,
) -> Result<(SheetRow, PrismReport)> {
    let model = section.to_model()?;
    let space = RgbSpace::from_name(&section.working_space)?;
    let ill_name = section
        .extra
        .get("illuminant")
        .and_then(|v| v.as_str())
        .unwrap_or("E");
    let illuminant = crate::io::sources::resolve_illuminant("dispersion.illuminant", ill_name)?;
    let obs_name = section
        .extra
        .get("observer")
        .and_then(|v| v.as_str())
        .unwrap_or("cie1931-2");
    let observer = Observer::standard(StandardObserver::from_name(obs_name)?)?;
    let range = [section.range_nm[0].ceil(), section.range_nm[1].floor()];
    let slices = slices_for(observer, &illuminant, &space, range)?;
    let setup = PrismSetup::default();
    let samples: Vec<(f64, [f64; 3])> = section
        .samples
        .iter()
        .map(|s| (s.lambda_nm, s.rgb))
        .collect();
    let eval = evaluate(
        &model,
        &slices,
        &setup,
        vec![("preset samples".into(), samples, None)],
    )?;
    let case = &eval.cases[0];
    ensure_finite(
        "the prism ΔE00",
        "the dispersion section",
        &[case.difference.mean, case.difference.max],
    )?;

    let srgb = RgbSpace::srgb()?;
    let white = mat3_mul_vec(&space.matrix_rgb_to_xyz, [1.0; 3]);
    let d65 = mat3_mul_vec(&srgb.matrix_rgb_to_xyz, [1.0; 3]);
    let to_display = mat3_mul(
        &srgb.matrix_xyz_to_rgb,
        &chromatic_adaptation_matrix(white, d65, Cat::Cat02)?,
    );
    let peak = eval
        .spectral
        .xyz
        .iter()
        .map(|x| {
            let c = mat3_mul_vec(&to_display, *x);
            c[0].max(c[1]).max(c[2])
        })
        .fold(0.0, f64::max);
    let exposure = if peak > 0.0 { 1.0 / peak } else { 1.0 };
    let size = (2 * o.size_px, (o.size_px / 2).max(16));
    let strip_mm = eval.layout.n_pixels as f64 * setup.pixel_mm;
    let geometry = format!(
        "60° prism, incidence {:.2}°, screen 1 m, {} mm shown",
        eval.layout.incidence_deg,
        sig3(strip_mm)
    );
    let panels = vec![
        Panel {
            image: strip_image(&eval.spectral, &to_display, exposure, size),
            title: format!("spectral (1 nm, {ill_name}, {obs_name})"),
            lines: vec![geometry.clone()],
        },
        Panel {
            image: strip_image(&case.strip, &to_display, exposure, size),
            title: format!("preset samples (N = {})", section.samples.len()),
            lines: vec![format!(
                "ΔE00 mean {}, max {}",
                sig3(case.difference.mean),
                sig3(case.difference.max)
            )],
        },
    ];
    let note = format!(
        "Dispersion: white beam through the preset's n(λ) ({}, n_d {}, V_d {}); screen strips \
         adapted to D65, one exposure.",
        section.model.kind,
        sig3(section.n_d),
        sig3(section.abbe_number)
    );
    Ok((
        SheetRow {
            heading: "Dispersion: the spectral split on a screen, reference (left) beside the preset's samples"
                .into(),
            panels,
        },
        PrismReport {
            n_samples: section.samples.len(),
            illuminant: ill_name.to_string(),
            observer: obs_name.to_string(),
            apex_deg: setup.apex_deg,
            incidence_deg: eval.layout.incidence_deg,
            deviation_d_deg: eval.layout.deviation_d_deg,
            strip_mm,
            mean_delta_e00: case.difference.mean,
            max_delta_e00: case.difference.max,
            note,
        },
    ))
}
