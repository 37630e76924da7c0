//! Reductions of a Donaldson operator to a `K × K` matrix in a transport basis.
//!
//! * **Dual basis** (Fichet et al. 2024, Eq. 15): `P = Sᵀ · A · S̃`, `S̃ = S(SᵀS)⁻¹`. It is the
//!   exact composition *upsample → apply A → downsample*, so `A = I` gives `P = I` and light
//!   transport `c_o = P c_i` reproduces ordinary reflectance rendering when `A` is diagonal and
//!   the spectrum lies in the span of the basis.
//! * **Naive** (Hullin et al. 2010 as written in Fichet Eq. 6–7): `P = S̄ᵀ · A · S̄` with each
//!   column of `S̄` normalised to unit L2 norm on the grid (the discrete form of `s_k / ‖s_k‖`).
//!   `A = I` then gives the matrix of cosines between basis functions, not `I`. (The authors'
//!   notebook normalises one side only, by the column sum; we follow the paper's equation.)
//! * **RGB** (Eq. 16): `P_RGB = M · P_XYZ · M⁻¹` with `M` the XYZ → RGB matrix of the working
//!   space. For `K > 3` bases the 3 × 3 XYZ matrix is the projection `T · P · R`, with
//!   `R = Sᵀ S̃_xyz` (upsample XYZ with the XYZ dual basis, downsample into the basis): what a
//!   renderer that can only carry three channels gets (the UV channel is then lost).
//!
//! All three matrices are dimensionless and act on colours, not on spectra.

use nalgebra::DMatrix;

use crate::colorimetry::rgb::RgbSpace;
use crate::error::{Error, Result};
use crate::fluor::basis::Basis;
use crate::fluor::donaldson::OperatorMatrix;
use crate::math::linalg::Mat3;

/// Which reduction.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Reduction {
    /// `Sᵀ A S̃` (Fichet et al. 2024, Eq. 15).
    Dual,
    /// `S̄ᵀ A S̄` with L2-normalised functions (Eq. 7).
    Naive,
}

impl Reduction {
    /// `dual` or `naive`.
    pub fn key(self) -> &'static str {
        match self {
            Reduction::Dual => "dual",
            Reduction::Naive => "naive",
        }
    }

    /// Parses `dual` / `naive` (case-insensitive; `ours`, `fichet2024`, `hullin2010` accepted).
    pub fn from_name(name: &str) -> Result<Reduction> {
        match name.trim().to_ascii_lowercase().as_str() {
            "dual" | "ours" | "fichet2024" => Ok(Reduction::Dual),
            "naive" | "hullin2010" => Ok(Reduction::Naive),
            _ => Err(Error::UnknownName {
                kind: "reduction method",
                name: name.into(),
                expected: "dual, naive".into(),
            }),
        }
    }
}

/// A reduced matrix with what is needed to use it.
#[derive(Debug, Clone, PartialEq)]
pub struct Reduced {
    /// The reduction used.
    pub reduction: Reduction,
    /// Basis name.
    pub basis: String,
    /// Basis labels.
    pub labels: Vec<String>,
    /// `P`, `K × K`: output channel (row) from input channel (column).
    pub p: DMatrix<f64>,
    /// `T`, `3 × K`.
    pub t: DMatrix<f64>,
}

fn check_grid(a: &OperatorMatrix, basis: &Basis) -> Result<()> {
    if !basis.same_grid(&a.grid) {
        return Err(Error::invalid(
            "working grid",
            format!(
                "material '{}' is on {}–{} nm / {} nm but basis '{}' on {}–{} nm / {} nm; resample both to one grid",
                a.name, a.grid.start_nm, a.grid.end_nm, a.grid.step_nm, basis.name(), basis.grid().start_nm, basis.grid().end_nm, basis.grid().step_nm
            ),
        ));
    }
    Ok(())
}

/// `P = Sᵀ A S̃` (dual-basis reduction, Fichet et al. 2024 Eq. 15).
pub fn reduce_fichet2024(a: &OperatorMatrix, basis: &Basis) -> Result<Reduced> {
    check_grid(a, basis)?;
    let dual = basis.dual()?;
    let p = basis.functions().transpose() * (&a.a * dual);
    Ok(Reduced {
        reduction: Reduction::Dual,
        basis: basis.name().into(),
        labels: basis.labels().to_vec(),
        p,
        t: basis.transfer().clone(),
    })
}

/// `S̄`: the basis with every column scaled to unit L2 norm.
pub fn normalised_functions(basis: &Basis) -> DMatrix<f64> {
    let mut s = basis.functions().clone();
    for mut col in s.column_iter_mut() {
        let n = col.norm();
        if n > 0.0 {
            col /= n;
        }
    }
    s
}

/// `P = S̄ᵀ A S̄` (naive reduction, Eq. 7).
pub fn reduce_naive_hullin2010(a: &OperatorMatrix, basis: &Basis) -> Result<Reduced> {
    check_grid(a, basis)?;
    let sn = normalised_functions(basis);
    let p = sn.transpose() * (&a.a * &sn);
    Ok(Reduced {
        reduction: Reduction::Naive,
        basis: basis.name().into(),
        labels: basis.labels().to_vec(),
        p,
        t: basis.transfer().clone(),
    })
}

/// Reduces with `reduction`.
pub fn reduce(a: &OperatorMatrix, basis: &Basis, reduction: Reduction) -> Result<Reduced> {
    match reduction {
        Reduction::Dual => reduce_fichet2024(a, basis),
        Reduction::Naive => reduce_naive_hullin2010(a, basis),
    }
}

/// The 3 × 3 XYZ → XYZ matrix of a reduction: `P` itself for XYZ, `T P R` with `R = Sᵀ S̃_xyz`
/// otherwise (see the module docs).
pub fn xyz_matrix(reduced: &Reduced, basis: &Basis, xyz: &Basis) -> Result<Mat3> {
    if basis.k() != reduced.p.nrows() {
        return Err(Error::ShapeMismatch {
            what: format!("basis '{}' for the reduced matrix", basis.name()),
            expected: reduced.p.nrows(),
            got: basis.k(),
        });
    }
    if basis.grid() != xyz.grid() {
        return Err(Error::invalid(
            "working grid",
            "the basis and the XYZ basis must share one grid",
        ));
    }
    let r = basis.functions().transpose() * xyz.dual()?;
    let m = &reduced.t * &reduced.p * r;
    Ok([
        [m[(0, 0)], m[(0, 1)], m[(0, 2)]],
        [m[(1, 0)], m[(1, 1)], m[(1, 2)]],
        [m[(2, 0)], m[(2, 1)], m[(2, 2)]],
    ])
}

/// Eq. 16: `M · P_xyz · M⁻¹` for the RGB working space `space`.
pub fn rgb_matrix(p_xyz: &Mat3, space: &RgbSpace) -> Mat3 {
    let m = &space.matrix_xyz_to_rgb;
    let mi = &space.matrix_rgb_to_xyz;
    crate::math::linalg::mat3_mul(&crate::math::linalg::mat3_mul(m, p_xyz), mi)
}
