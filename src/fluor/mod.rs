//! Fluorescence: reduction of measured Donaldson (bispectral) matrices to small matrices that a
//! tristimulus (RGB/XYZ) renderer can transport — Fichet, Belcour & Barla, "Non-Orthogonal
//! Reduction for Rendering Fluorescent Materials in Non-Spectral Engines", CGF 43(4), 2024.
//!
//! # Conventions (stated once; `docs/fluorescence.md` repeats them with the evaluation)
//!
//! * **Orientation**: `D[emission, excitation]`, rows = emission (380–780 nm in BFC-450 files),
//!   columns = excitation (300–780 nm), as stored in the file. Reduced matrices `P[k, l]` map
//!   input channel `l` to output channel `k` (`c_o = P c_i`).
//! * **Units**: the diagonal is the reflectance factor (dimensionless); off-diagonal entries are
//!   the bispectral luminescent radiance factor per excitation band of the file's step (10 nm).
//! * **Working grid**: 300–780 nm at 1 nm by default ([`WorkingGrid`]); every spectral quantity is
//!   sampled there and integrals are sums times the step `h`.
//! * **Resampling** ([`DonaldsonMatrix::to_operator`]): negatives clipped (default); diagonal
//!   interpolated linearly *as a reflectance*; off-diagonal part interpolated bilinearly *as a
//!   density* (divided by the native step, times `h`); zero outside the measured grid; optional
//!   zeroing of anti-Stokes entries (excitation ≥ emission off the diagonal).
//! * **Bases** ([`Basis`]): XYZ (any observer; CIE 2006 2° by default, as the paper), XYZ+U,
//!   the 7-basis split of Appendix A, or any basis CSV; each with its transfer matrix `T` to XYZ.
//! * **Reductions** ([`reduce`]): dual basis `P = Sᵀ A S̃`, `S̃ = S(SᵀS)⁻¹` (Eq. 15; the
//!   paper's footnote has the product the wrong way round), and the naive `S̄ᵀ A S̄` (Eq. 7);
//!   RGB by Eq. 16.
//! * **Evaluation** ([`evaluate`]): one bounce, spectral reference `S_xyzᵀ A e` against
//!   `T P Sᵀ e`, white `Y = 100`, Lab relative to the illuminant's white, CIEDE2000.
//!
//! The module is pure: parsers take bytes and a source name; opening files is the caller's job.
//!
//! colour-science has no counterpart (it does not model bispectral reflectance).

pub mod basis;
pub mod donaldson;
pub mod evaluate;
pub mod reduce;

pub use basis::Basis;
pub use donaldson::{
    parse_bfc, parse_donaldson, parse_donaldson_csv, DonaldsonMatrix, OperatorMatrix,
    ResampleOptions, WorkingGrid,
};
pub use evaluate::{
    evaluate, illuminant_on_grid, select_basis, sweep, BasisKind, EvalRow, GridIlluminant, Method,
    Selection, DEFAULT_ILLUMINANTS, DEFAULT_METHODS,
};
pub use reduce::{
    reduce, reduce_fichet2024, reduce_naive_hullin2010, rgb_matrix, xyz_matrix, Reduced, Reduction,
};
