//! Decay fitting (Nalbach et al. 2017, §4.4–4.5): a sum of exponentials with a spectrum shared by
//! all states, fitted by variable projection.
//!
//! After switch-off (E = 0) Eq. 1 gives r_i(t) = r_i(0) e^{−k_r,i t}, so a camera channel c sees
//!
//! `Y_c(t) = Σ_i a_i Λ*_c e^{−k_i t} + b_c`
//!
//! with one spectrum Λ* shared by all states (§4.3's constancy observation; max Λ* = 1), a_i ≥ 0,
//! k_i ≥ 0 and an optional constant background b_c. The rates are parameterised as k = e^θ and
//! fitted by [`crate::fit::solve_separable`]; for a fixed spectrum the problem is a
//! single-right-hand-side separable fit of the projection `Y Λ*/‖Λ*‖` (the rest of the residual
//! does not depend on a, k), so the spectrum is found by alternating that fit with the exact
//! least-squares update of Λ* (started from the leading right singular vector of Y). Per-channel
//! amplitudes (`a_ic` free) are an option; then it is a multi-right-hand-side separable fit.
//!
//! Starts: for n ≥ 2 states Prony's linear-prediction estimate (evenly spaced times), then the
//! (n − 1)-state fit plus a slower state; log-spaced starts only when those fits are doubtful.
//!
//! The number of states is chosen by BIC among 1..=max (or fixed; the largest candidate is
//! fitted only if one more state could gain what BIC requires, [`SCREEN_RATIO`]), then a collapse
//! rule removes a state whose amplitude is zero, and merges two rates closer than twice their
//! combined standard deviation in log k; the report's flags say what happened. Rate uncertainties are the square
//! roots of the diagonal of σ² (JᵀJ)⁻¹ over all parameters (rates, amplitudes, spectrum,
//! background) with σ² = RSS/(N − p) (scaled, like scipy's `curve_fit` default).
//!
//! §4.5: with Λ* on n_λ bands and saturation at switch-off (r_i(0) = 1), the re-radiation
//! functions are Λ_i = a_i Λ* / k_r,i ([`reradiation_functions`]).
//!
//! Modules: `types` (curve, options, report), `basis` (the exponential basis for varpro),
//! `prepared` (a curve ready to fit and the fit from one start), `starts` (Prony and log-spaced
//! starts), `screen` (the linearised gain of one more state, which decides whether the largest
//! candidate is fitted), `select` (BIC, acceptance, collapse rule, [`fit_decay`]), `uncertainty`
//! (covariance and the report), `reradiation` (§4.5).

// Index loops mirror the matrix notation of the maths; `!(a > b)` comparisons deliberately
// reject NaN along with out-of-range values.
#![allow(clippy::needless_range_loop, clippy::neg_cmp_op_on_partial_ord)]

use crate::error::{Error, Result};
use crate::fit::{
    bic, covariance, solve_separable, SeparableData, SeparableModel, SolverOptions, Termination,
};

mod basis;
mod prepared;
mod projected;
mod reradiation;
mod screen;
mod select;
mod starts;
#[cfg(test)]
mod tests;
mod types;
mod uncertainty;

pub use reradiation::{band_spectrum, reradiation_functions, reradiation_functions_rgb};
pub(crate) use select::fit_decay_values;
pub use select::{fit_decay, fit_decay_full_tolerance, fit_decay_joint, fit_decay_projected};
pub use types::*;

#[allow(unused_imports)]
use basis::*;
#[allow(unused_imports)]
use prepared::*;
#[allow(unused_imports)]
use projected::*;
#[allow(unused_imports)]
use select::*;
#[allow(unused_imports)]
use starts::*;
use types::{
    ALTERNATION_FTOL, ALTERNATION_ROUNDS, ALTERNATION_SETTLED, ALTERNATION_XTOL, SEED_FTOL,
    SEED_SPECTRUM_TOL, SEED_XTOL,
};
