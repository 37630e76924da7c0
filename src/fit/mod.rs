//! Solvers, options and reports shared by the fitting domains (no physics).
//!
//! A domain describes its model (a basis and its derivatives, or a Jacobian); `fit` owns the
//! linear algebra, the solvers and the stopping rules:
//!
//! - [`lm`]: the one general nonlinear least-squares solver — Levenberg–Marquardt with box
//!   bounds, analytic or finite-difference Jacobian, MINPACK stopping tests, covariance on
//!   request. Every domain fit that is not separable goes through it.
//! - [`termination`]: why a fit stopped ([`Termination`]) and the stopping tests shared by `lm`
//!   and `varpro`.
//! - [`search`]: the log-spaced grid search used to start a fit or pick a weight.
//! - [`qr`]: Householder QR for small dense problems (least squares, projections, `(JᵀJ)⁻¹`).
//! - [`nnls`]: Lawson–Hanson non-negative least squares with optionally free columns.
//! - [`varpro`]: variable projection — linear coefficients solved exactly (with
//!   non-negativity), Levenberg–Marquardt on the projected residual, termination as data.
//! - [`stats`]: parameter covariance and the Bayesian information criterion.
//!
//! A fit that does not converge is a report with a [`Termination`] reason, not an error.

pub mod lm;
pub mod nnls;
pub mod qr;
pub mod regularized;
pub mod search;
pub mod stats;
pub mod termination;
pub mod varpro;

pub use lm::{levenberg_marquardt, LmOptions, LmReport, Residuals};

pub use nnls::{nnls, NnlsSolution};
pub use qr::Qr;
pub use stats::{bic, covariance};
pub use termination::Termination;
pub use varpro::{solve_separable, SeparableData, SeparableFit, SeparableModel, SolverOptions};
