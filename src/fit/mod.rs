//! Solvers, options and reports shared by the fitting domains (no physics).
//!
//! A domain describes its model (a basis and its derivatives, or a Jacobian); `fit` owns the
//! linear algebra, the solvers and the stopping rules:
//!
//! - [`qr`]: Householder QR for small dense problems (least squares, projections, `(JᵀJ)⁻¹`).
//! - [`nnls`]: Lawson–Hanson non-negative least squares with optionally free columns.
//! - [`varpro`]: variable projection — linear coefficients solved exactly (with
//!   non-negativity), Levenberg–Marquardt on the projected residual, termination as data.
//! - [`stats`]: parameter covariance and the Bayesian information criterion.
//!
//! A fit that does not converge is a report with a [`Termination`] reason, not an error.

pub mod nnls;
pub mod qr;
pub mod regularized;
pub mod stats;
pub mod varpro;

pub use nnls::{nnls, NnlsSolution};
pub use qr::Qr;
pub use stats::{bic, covariance};
pub use varpro::{
    solve_separable, SeparableData, SeparableFit, SeparableModel, SolverOptions, Termination,
};
