//! Phosphorescence: rate-equation model, simulation and decay fitting (Nalbach, Seidel & Ritschel
//! 2017, "Practical capture and reproduction of phosphorescent appearance").
//!
//! - [`material`]: Eq. 1 and 3 — states with re-radiation rate k_r (s⁻¹), excitation rates k_e
//!   and re-radiation functions Λ per band; the 11 materials of Table 1.
//! - [`simulate`]: Eq. 1 under piecewise-constant irradiance (exact exponential update by
//!   default; RK4 and the paper's forward Euler for comparison), Eq. 3 emission, camera RGB and
//!   closed-form exposure-window integrals.
//! - [`decay`]: §4.4–4.5 — sum-of-exponentials decay fit with a shared spectrum by variable
//!   projection, BIC model selection, collapse rule, covariance; re-radiation functions.
//! - [`synth`]: synthetic decay curves from the exact simulation with shot and read noise.
//!
//! No colour-science counterpart exists. The paper's Eq. 4 writes k_ε for k_r and Eq. 6 sums from
//! i = 0; both are read as k_r and i = 1 here.

pub mod charging;
pub mod cluster;
pub mod decay;
pub mod design;
pub mod excitation;
pub mod maps;
pub mod material;
pub mod simulate;
pub mod synth;

pub use charging::DecayCharging;
pub use decay::{
    band_spectrum, fit_decay, reradiation_functions, reradiation_functions_rgb, AmplitudeModel,
    Candidate, DecayCurve, DecayFit, DecayFitOptions, DecayFlag, DecayState, StatesChoice,
};
pub use material::{table1_material, table1_materials, BandSet, Material, PhosphorState};
pub use simulate::{
    emission, final_state, simulate, window_integrals, BandCamera, Integrator, Segment, Simulation,
};
