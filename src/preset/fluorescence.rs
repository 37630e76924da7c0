//! Assembly of the fluorescence section from a reduction (`lumifit fluor reduce`): the reduced
//! matrix, its XYZ and RGB projections and the ΔE00 table become one typed
//! [`FluorescenceSection`]. Every number is checked to be finite first, so an overflowing
//! Donaldson matrix is an error naming the input, never a preset full of `null`.

use nalgebra::DMatrix;

use super::types::{
    FluorescenceBasis, FluorescenceDeltaE, FluorescenceResampling, FluorescenceRgb,
    FluorescenceSection, GridNm, OpenSection,
};
use crate::colorimetry::rgb::RgbSpace;
use crate::error::{ensure_finite, Result};
use crate::fluor::{Basis, EvalRow, Reduced, ResampleOptions, WorkingGrid};
use crate::math::linalg::Mat3;

/// The paper the reduction follows, as recorded in the section.
pub const FLUORESCENCE_PAPER: &str = "Fichet, Belcour & Barla 2024, CGF 43(4)";

/// The RGB projection recorded with the section (Fichet 2024 Eq. 16).
pub const RGB_EQUATION: &str = "M_xyz_to_rgb · P_xyz · M_xyz_to_rgb⁻¹ (Eq. 16)";

fn rows_of(m: &DMatrix<f64>) -> Vec<Vec<f64>> {
    (0..m.nrows())
        .map(|r| (0..m.ncols()).map(|c| m[(r, c)]).collect())
        .collect()
}

/// What a reduction produced, to be written as a section.
#[derive(Debug, Clone, Copy)]
pub struct ReductionRecord<'a> {
    /// The reduced matrix and its transfer to XYZ.
    pub reduced: &'a Reduced,
    /// The basis it is expressed in.
    pub basis: &'a Basis,
    /// Observer name (CLI form) of the basis.
    pub observer: &'a str,
    /// The working grid.
    pub grid: &'a WorkingGrid,
    /// P projected to XYZ.
    pub xyz_matrix: &'a Mat3,
    /// P projected to `space`.
    pub rgb_matrix: &'a Mat3,
    /// The RGB working space.
    pub space: &'a RgbSpace,
    /// Resampling options used.
    pub options: ResampleOptions,
    /// ΔE00 per illuminant.
    pub rows: &'a [EvalRow],
}

/// The fluorescence section of a reduction. `input` names the Donaldson matrix in errors.
///
/// # Errors
/// [`crate::Error::NonFinite`] naming `input` when any matrix entry or ΔE00 is not finite.
pub fn fluorescence_section(r: &ReductionRecord<'_>, input: &str) -> Result<FluorescenceSection> {
    let p = rows_of(&r.reduced.p);
    let t = rows_of(&r.reduced.t);
    ensure_finite("the reduced matrix P", input, &p.concat())?;
    ensure_finite("the transfer matrix T", input, &t.concat())?;
    ensure_finite("the XYZ matrix", input, &r.xyz_matrix.concat())?;
    ensure_finite("the RGB matrix", input, &r.rgb_matrix.concat())?;
    for row in r.rows {
        ensure_finite(
            &format!("ΔE00 under {}", row.illuminant),
            input,
            &[
                &[row.delta_e00][..],
                &row.xyz_reference[..],
                &row.xyz_reduced[..],
            ]
            .concat(),
        )?;
    }
    let worst = r.rows.iter().map(|x| x.delta_e00).fold(0.0, f64::max);
    let basis = r.basis;
    Ok(FluorescenceSection {
        method: r.reduced.reduction.key().to_string(),
        paper: FLUORESCENCE_PAPER.to_string(),
        basis: FluorescenceBasis {
            name: basis.name().to_string(),
            k: basis.k(),
            labels: basis.labels().to_vec(),
            observer: r.observer.to_string(),
            grid_nm: GridNm {
                start_nm: r.grid.start_nm,
                end_nm: r.grid.end_nm,
                step_nm: r.grid.step_nm,
            },
            functions: (0..basis.k())
                .map(|k| basis.functions().column(k).iter().copied().collect())
                .collect(),
        },
        matrix: p,
        transfer_xyz: t,
        xyz_matrix: *r.xyz_matrix,
        rgb: FluorescenceRgb {
            space: r.space.key.clone(),
            matrix: *r.rgb_matrix,
            projected_from_k: basis.k(),
            equation: RGB_EQUATION.to_string(),
        },
        resampling: FluorescenceResampling {
            clip_negatives: r.options.clip_negatives,
            zero_anti_stokes: r.options.zero_anti_stokes,
            diagonal: "linear, as a reflectance".to_string(),
            off_diagonal: "bilinear, as a density × step".to_string(),
        },
        delta_e00: r
            .rows
            .iter()
            .map(|x| FluorescenceDeltaE {
                illuminant: x.illuminant.clone(),
                delta_e00: x.delta_e00,
                xyz_reference: x.xyz_reference,
                xyz_reduced: x.xyz_reduced,
            })
            .collect(),
        worst_delta_e00: worst,
        extra: OpenSection::new(),
    })
}
