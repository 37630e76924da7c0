//! The fluorescence rows: under each illuminant, the sphere shaded with [`FluorTwin`] (the
//! snippet's reduced RGB matrix, `f32`) above the full spectral result of the measured Donaldson
//! matrix, with the ΔE00 between them.
//!
//! Protocol — the one of `fluor eval` ([`crate::fluor::evaluate`]), on the preset's own working
//! grid, observer and resampling options:
//!
//! - `e`: the illuminant on the grid ([`illuminant_on_grid`]); reference
//!   `XYZ_ref = k h S_xyzᵀ A e` and the white `XYZ_w = k h S_xyzᵀ e` (Y = 100) from
//!   [`spectral_reference`], `A` the Donaldson matrix resampled as the section records;
//! - **twin** (the picture): the light arriving in the section's RGB space,
//!   `rgb_in = M_xyz→rgb XYZ_w / 100`, shaded `rgb_out = FluorTwin::shade(rgb_in)`, back to
//!   `XYZ_twin = 100 M_rgb→xyz rgb_out`;
//! - **K-basis** (what `fluor eval` reports for the section's method): the preset's stored `T`,
//!   `P` and basis functions `S`, `XYZ_K = k T P (h Sᵀ e)` ([`reduced_xyz`]'s formula);
//! - ΔE00 ([`delta_e00`]) of each against `XYZ_ref`, Lab relative to the white's xy.
//!
//! For the XYZ basis the RGB matrix is `M P M⁻¹` exactly, so the twin's ΔE00 equals the K-basis
//! one up to `f32` rounding; for larger bases (XYZ+U, …) the RGB matrix is the projection an RGB
//! renderer can carry, and the two differ by what the UV channel held.
//!
//! Display: each panel is adapted from the illuminant's white to D65 (CAT02) and shown in sRGB,
//! so the panels compare the material, not the colour of the light.
//!
//! [`reduced_xyz`]: crate::fluor::evaluate::reduced_xyz

use nalgebra::{DMatrix, DVector};
use serde::Serialize;

use super::phosphor::{FLOOR_REFLECTANCE, LIT_EXPOSURE};
use super::{lit_scene, sig3, PreviewOptions};
use crate::colorimetry::cat::{chromatic_adaptation_matrix, Cat};
use crate::colorimetry::rgb::RgbSpace;
use crate::colorimetry::{Observer, StandardObserver};
use crate::error::{ensure_finite, Error, Result};
use crate::fluor::evaluate::{delta_e00, spectral_reference};
use crate::fluor::{illuminant_on_grid, Basis, GridIlluminant, ResampleOptions, WorkingGrid};
use crate::math::linalg::{mat3_mul, mat3_mul_vec, Mat3};
use crate::preset::shader::FluorTwin;
use crate::preset::types::FluorescenceSection;
use crate::render::{Panel, ShadeInput, Shader, SheetRow, Surface};

/// The numbers of one illuminant.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FluorIlluminant {
    /// Illuminant name.
    pub illuminant: String,
    /// XYZ of the illuminant's white (Y = 100).
    pub white_xyz: [f64; 3],
    /// Light arriving, linear RGB of the section's space (white Y = 1).
    pub rgb_in: [f64; 3],
    /// What the twin sends back.
    pub rgb_out_twin: [f64; 3],
    /// The twin's result in XYZ (Y = 100 scale).
    pub xyz_twin: [f64; 3],
    /// The preset's K×K matrix through `T P Sᵀ e` (Y = 100 scale).
    pub xyz_preset_k: [f64; 3],
    /// Spectral reference, when the Donaldson matrix was given.
    pub xyz_reference: Option<[f64; 3]>,
    /// ΔE00 twin (the picture) against the reference.
    pub delta_e00_twin: Option<f64>,
    /// ΔE00 of the preset's K×K matrix against the reference (`fluor eval`'s number).
    pub delta_e00_preset_k: Option<f64>,
    /// ΔE00 recorded in the preset for this illuminant name, if any.
    pub delta_e00_recorded: Option<f64>,
    /// Channels the twin clamped at 0 (`M · rgb_in < 0`: the result lies outside the space's
    /// gamut, and the snippet's clamp changes it).
    pub twin_clamped: Vec<&'static str>,
}

/// The numbers of the fluorescence rows.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FluorReport {
    /// RGB space of the reduced matrix.
    pub space: String,
    /// Reduction method and basis, as `fluor eval` names it (`dual-xyz`).
    pub method: String,
    /// K of the basis.
    pub k: usize,
    /// Observer of the basis.
    pub observer: String,
    /// The Donaldson matrix of the reference side.
    pub donaldson: Option<String>,
    /// One entry per illuminant, in `--illuminant` order.
    pub illuminants: Vec<FluorIlluminant>,
    /// One line for the sheet's notes.
    pub note: String,
}

/// The preset's stored basis, reduced matrix and transfer as matrices, checked for shape.
struct Stored {
    s: DMatrix<f64>,
    p: DMatrix<f64>,
    t: DMatrix<f64>,
}

fn stored(section: &FluorescenceSection, n: usize) -> Result<Stored> {
    let b = &section.basis;
    let k = b.k;
    let shape = |what: &str, expected: usize, got: usize| -> Result<()> {
        if expected == got {
            Ok(())
        } else {
            Err(Error::ShapeMismatch {
                what: what.to_string(),
                expected,
                got,
            })
        }
    };
    shape("fluorescence.basis.functions", k, b.functions.len())?;
    for f in &b.functions {
        shape("fluorescence.basis.functions[*] (grid points)", n, f.len())?;
    }
    shape("fluorescence.matrix rows", k, section.matrix.len())?;
    for r in &section.matrix {
        shape("fluorescence.matrix columns", k, r.len())?;
    }
    shape(
        "fluorescence.transfer_xyz rows",
        3,
        section.transfer_xyz.len(),
    )?;
    for r in &section.transfer_xyz {
        shape("fluorescence.transfer_xyz columns", k, r.len())?;
    }
    Ok(Stored {
        s: DMatrix::from_fn(n, k, |i, j| b.functions[j][i]),
        p: DMatrix::from_fn(k, k, |i, j| section.matrix[i][j]),
        t: DMatrix::from_fn(3, k, |i, j| section.transfer_xyz[i][j]),
    })
}

/// The working grid, XYZ basis and resampling options the section records.
pub fn section_setup(
    section: &FluorescenceSection,
) -> Result<(WorkingGrid, Basis, ResampleOptions)> {
    let g = section.basis.grid_nm;
    let grid = WorkingGrid::new(g.start_nm, g.end_nm, g.step_nm)?;
    let obs = Observer::standard(StandardObserver::from_name(&section.basis.observer)?)?;
    let xyz = Basis::xyz(obs.cmfs(), &grid)?;
    let options = ResampleOptions {
        clip_negatives: section.resampling.clip_negatives,
        zero_anti_stokes: section.resampling.zero_anti_stokes,
    };
    Ok((grid, xyz, options))
}

/// White XYZ (Y = 100) and the scale `k h = 100 / Σ ȳ e` of `e` under the XYZ basis.
fn white_of(e: &GridIlluminant, xyz: &Basis) -> Result<([f64; 3], f64)> {
    let w = xyz.functions().transpose() * DVector::from_column_slice(&e.values);
    if w[1].is_nan() || w[1] <= 0.0 {
        return Err(Error::invalid(
            "illuminant",
            format!("'{}' has no power where ȳ is non-zero", e.name),
        ));
    }
    let scale = 100.0 / w[1];
    Ok(([w[0] * scale, w[1] * scale, w[2] * scale], scale))
}

struct FluorShader<F: Fn([f64; 3]) -> [f64; 3] + Sync> {
    /// Material response (display linear sRGB) to unit irradiance factor.
    sphere: F,
    /// Floor (display linear sRGB) at unit irradiance factor.
    floor: [f64; 3],
}

impl<F: Fn([f64; 3]) -> [f64; 3] + Sync> Shader for FluorShader<F> {
    fn shade(&self, hit: &ShadeInput) -> [f64; 3] {
        let k = hit.irradiance / std::f64::consts::PI;
        match hit.surface {
            Surface::Sphere => (self.sphere)([hit.irradiance; 3]).map(|v| v / std::f64::consts::PI),
            Surface::Floor => self.floor.map(|v| v * k),
        }
    }
    fn background(&self) -> [f64; 3] {
        [0.01; 3]
    }
}

/// The twin row and (with a Donaldson matrix) the reference row, and their numbers.
pub fn fluor_rows(
    section: &FluorescenceSection,
    o: &PreviewOptions,
) -> Result<(Vec<SheetRow>, FluorReport)> {
    let twin = FluorTwin::from_section(section)?;
    let space = RgbSpace::from_name(&twin.space)?;
    let srgb = RgbSpace::srgb()?;
    let d65 = mat3_mul_vec(&srgb.matrix_rgb_to_xyz, [1.0; 3]);
    let (grid, xyz, options) = section_setup(section)?;
    let n = grid.wavelengths().len();
    let st = stored(section, n)?;
    let op = o
        .donaldson
        .as_ref()
        .map(|(d, _)| d.to_operator(&grid, options));
    let scene = lit_scene(o.light);
    let size = o.size_px;
    let (mut twin_panels, mut ref_panels, mut rows) = (Vec::new(), Vec::new(), Vec::new());
    for ill in &o.illuminants {
        let e = illuminant_on_grid(ill, &xyz)?;
        let (white, scale) = white_of(&e, &xyz)?;
        let reference = match &op {
            Some(a) => Some(spectral_reference(a, &e, &xyz)?),
            None => None,
        };
        let rgb_in = mat3_mul_vec(&space.matrix_xyz_to_rgb, white.map(|v| v / 100.0));
        let rgb_in32 = rgb_in.map(|v| v as f32);
        let rgb_out = twin.shade(rgb_in32).map(f64::from);
        let twin_clamped: Vec<&'static str> = ["R", "G", "B"]
            .into_iter()
            .zip(twin.matrix)
            .filter(|(_, m)| m[0] * rgb_in32[0] + m[1] * rgb_in32[1] + m[2] * rgb_in32[2] < 0.0)
            .map(|(c, _)| c)
            .collect();
        let xyz_twin = mat3_mul_vec(&space.matrix_rgb_to_xyz, rgb_out).map(|v| v * 100.0);
        let down = st.s.transpose() * DVector::from_column_slice(&e.values);
        let xk = &st.t * (&st.p * down) * scale;
        let xyz_preset_k = [xk[0], xk[1], xk[2]];
        let (mut de_twin, mut de_k) = (None, None);
        if let Some(r) = &reference {
            de_twin = Some(delta_e00(r.xyz, xyz_twin, r.white_xy)?);
            de_k = Some(delta_e00(r.xyz, xyz_preset_k, r.white_xy)?);
        }
        let recorded = section
            .delta_e00
            .iter()
            .find(|d| d.illuminant.eq_ignore_ascii_case(ill.name()))
            .map(|d| d.delta_e00);
        let mut check: Vec<f64> = [rgb_in, rgb_out, xyz_twin, xyz_preset_k].concat();
        check.extend(reference.iter().flat_map(|r| r.xyz));
        check.extend(de_twin.iter().chain(&de_k));
        ensure_finite(
            &format!("the preview under {}", ill.name()),
            "the fluorescence section",
            &check,
        )?;

        // Display: XYZ adapted from this white to D65, in linear sRGB.
        let cat: Mat3 = chromatic_adaptation_matrix(white.map(|v| v / 100.0), d65, Cat::Cat02)?;
        let xyz_to_display = mat3_mul(&srgb.matrix_xyz_to_rgb, &cat);
        let space_to_display = mat3_mul(&xyz_to_display, &space.matrix_rgb_to_xyz);
        let floor = mat3_mul_vec(
            &xyz_to_display,
            white.map(|v| FLOOR_REFLECTANCE * v / 100.0),
        );
        let twin_ref = &twin;
        let img = scene.render(
            size,
            size,
            &FluorShader {
                sphere: move |g: [f64; 3]| {
                    let lit = [rgb_in[0] * g[0], rgb_in[1] * g[1], rgb_in[2] * g[2]];
                    let out = twin_ref.shade(lit.map(|v| v as f32)).map(f64::from);
                    mat3_mul_vec(&space_to_display, out)
                },
                floor,
            },
        )?;
        let mut lines = vec![match (de_twin, de_k) {
            (Some(d), Some(k)) => format!("ΔE00 vs spectral {} (K×K {})", sig3(d), sig3(k)),
            _ => match recorded {
                Some(r) => format!("recorded ΔE00 {}", sig3(r)),
                None => "no reference".to_string(),
            },
        }];
        if !twin_clamped.is_empty() {
            lines.push(format!(
                "clamped {} < 0 (out of {} gamut)",
                twin_clamped.join(","),
                twin.space
            ));
        }
        twin_panels.push(Panel {
            image: img.to_srgb8(LIT_EXPOSURE),
            title: format!("{} — twin (RGB matrix)", e.name),
            lines,
        });
        if let Some(r) = &reference {
            let xyz_ref = r.xyz.map(|v| v / 100.0);
            let img = scene.render(
                size,
                size,
                &FluorShader {
                    sphere: move |g: [f64; 3]| {
                        mat3_mul_vec(
                            &xyz_to_display,
                            [xyz_ref[0] * g[0], xyz_ref[1] * g[1], xyz_ref[2] * g[2]],
                        )
                    },
                    floor,
                },
            )?;
            ref_panels.push(Panel {
                image: img.to_srgb8(LIT_EXPOSURE),
                title: format!("{} — spectral", e.name),
                lines: vec![match recorded {
                    Some(r) => format!("Donaldson ⊗ {}; recorded ΔE00 {}", e.name, sig3(r)),
                    None => format!("Donaldson ⊗ {}", e.name),
                }],
            });
        }
        rows.push(FluorIlluminant {
            illuminant: e.name.clone(),
            white_xyz: white,
            rgb_in,
            rgb_out_twin: rgb_out,
            xyz_twin,
            xyz_preset_k,
            xyz_reference: reference.as_ref().map(|r| r.xyz),
            delta_e00_twin: de_twin,
            delta_e00_preset_k: de_k,
            delta_e00_recorded: recorded,
            twin_clamped,
        });
    }
    let method = format!("{}-{}", section.method, section.basis.name);
    let donaldson = o.donaldson.as_ref().map(|(_, n)| n.clone());
    let mut sheet_rows = vec![SheetRow {
        heading: format!(
            "Fluorescence: FluorTwin (reduced {} matrix, {}, f32) under each illuminant",
            twin.space, method
        ),
        panels: twin_panels,
    }];
    let note = match &donaldson {
        Some(d) => {
            sheet_rows.push(SheetRow {
                heading: format!(
                    "Spectral reference: Donaldson matrix {} ⊗ illuminant → XYZ",
                    std::path::Path::new(d)
                        .file_name()
                        .map_or(d.clone(), |f| f.to_string_lossy().into_owned())
                ),
                panels: ref_panels,
            });
            format!(
                "Fluorescence: ΔE00 in the protocol of fluor eval ({} observer, {}–{} nm / {} nm); \
                 panels adapted to D65 (CAT02).",
                section.basis.observer, grid.start_nm, grid.end_nm, grid.step_nm
            )
        }
        None => "Fluorescence: no Donaldson matrix given (--donaldson), so no spectral reference; \
                 ΔE00 shown are the preset's recorded ones."
            .to_string(),
    };
    Ok((
        sheet_rows,
        FluorReport {
            space: twin.space.clone(),
            method,
            k: section.basis.k,
            observer: section.basis.observer.clone(),
            donaldson,
            illuminants: rows,
            note,
        },
    ))
}
