//! The decay curve, the fit options and the report types.

#![allow(clippy::needless_range_loop, clippy::neg_cmp_op_on_partial_ord)]

use super::*;

/// Largest number of states the fit offers.
pub const MAX_STATES: usize = 3;

/// How far (in ln k) a rate may lie outside the plausible range ([`Prepared::log_rate_range`])
/// before a fit is degenerate: e³, gone before the second sample or constant over the record.
/// The one-state Newton start and the screen's grid stay within it; Prony starts beyond it are
/// declined.
pub(super) const DEGENERATE_LOG_MARGIN: f64 = 3.0;

/// The largest candidate (three states in the automatic mode) is fitted only when the
/// linearised RSS gain of one more state reaches this fraction of the gain BIC requires
/// ([`ScreenedCandidate`]). Where a candidate won on BIC its ratio was ≥ 0.89 on 90,000 pixels
/// of a synthetic series and ≥ 1.005 on the 300 benchmark curves of `tests/decay_decisions.rs`
/// (docs/performance.md, issue 18 eighth round), so 0.5 leaves a margin of 1.8×.
pub const SCREEN_RATIO: f64 = 0.5;

/// Relative cost reduction at which a fit that only seeds the next number of states stops (it
/// is continued to the full tolerance if it is ever selected).
pub(super) const SEED_FTOL: f64 = 1e-6;
/// Relative step at which a seed fit stops.
pub(super) const SEED_XTOL: f64 = 1e-5;

/// Change of the unit spectrum (sum of absolute differences) at which the alternation of a seed
/// fit (solver tolerance ≥ [`SEED_FTOL`]) ends; a result's alternation goes on to 1e-11.
pub(super) const SEED_SPECTRUM_TOL: f64 = 1e-7;

/// Relative cost reduction at which a round of the shared-spectrum alternation stops while the
/// spectrum is still moving (see [`ALTERNATION_SETTLED`]).
pub(super) const ALTERNATION_FTOL: f64 = 1e-8;
/// Relative step at which such a round stops.
pub(super) const ALTERNATION_XTOL: f64 = 1e-6;
/// Change of the unit spectrum (sum of absolute differences) below which it has settled and the
/// rounds use the full tolerance.
pub(super) const ALTERNATION_SETTLED: f64 = 1e-5;
/// Most rounds of the alternation (the last five at the full tolerance).
pub(super) const ALTERNATION_ROUNDS: usize = 30;
/// Contraction of the alternation (ratio of successive spectrum moves) below which the rest of
/// the spectrum's path is extrapolated instead of measured by one more round.
pub(super) const EXTRAPOLATE_RHO: f64 = 0.01;

/// A measured decay: times and one or more channels, optional per-sample standard deviations.
#[derive(Debug, Clone, PartialEq)]
pub struct DecayCurve {
    /// Times in s after switch-off, strictly increasing.
    pub t_s: Vec<f64>,
    /// Channel values (R, G, B or one channel), each of the length of `t_s`.
    pub channels: Vec<Vec<f64>>,
    /// Per-sample standard deviation (> 0), shared by the channels; `None` for equal weights.
    pub sigma: Option<Vec<f64>>,
}

impl DecayCurve {
    /// Builds and validates a curve: at least 3 samples, strictly increasing finite times,
    /// finite values, positive σ, and data that are neither all zero nor constant.
    pub fn new(t_s: Vec<f64>, channels: Vec<Vec<f64>>, sigma: Option<Vec<f64>>) -> Result<Self> {
        let m = t_s.len();
        if channels.is_empty() {
            return Err(Error::invalid(
                "curve",
                "no channels; expected at least one",
            ));
        }
        if m < 3 {
            return Err(Error::invalid(
                "curve",
                format!("{m} samples; expected at least 3"),
            ));
        }
        for (i, w) in t_s.windows(2).enumerate() {
            if !(w[1] > w[0]) {
                return Err(Error::invalid(
                    format!("time of sample {}", i + 2),
                    format!(
                        "{} s after {} s; times must be strictly increasing (no duplicates)",
                        w[1], w[0]
                    ),
                ));
            }
        }
        if let Some(t) = t_s.iter().find(|t| !t.is_finite()) {
            return Err(Error::invalid(
                "time",
                format!("{t}; expected finite times"),
            ));
        }
        for (c, ch) in channels.iter().enumerate() {
            if ch.len() != m {
                return Err(Error::ShapeMismatch {
                    what: format!("channel {} against the times", c + 1),
                    expected: m,
                    got: ch.len(),
                });
            }
            if let Some(v) = ch.iter().find(|v| !v.is_finite()) {
                return Err(Error::invalid(
                    format!("channel {}", c + 1),
                    format!("{v}; expected finite values"),
                ));
            }
        }
        if let Some(s) = &sigma {
            if s.len() != m {
                return Err(Error::ShapeMismatch {
                    what: "standard deviations against the times".into(),
                    expected: m,
                    got: s.len(),
                });
            }
            if let Some(v) = s.iter().find(|v| !(v.is_finite() && **v > 0.0)) {
                return Err(Error::invalid(
                    "std",
                    format!("{v}; expected standard deviations > 0"),
                ));
            }
        }
        if channels.iter().all(|ch| ch.iter().all(|v| *v == 0.0)) {
            return Err(Error::invalid(
                "curve",
                "all values are zero; there is no decay to fit",
            ));
        }
        if channels.iter().all(|ch| ch.iter().all(|v| *v == ch[0])) {
            return Err(Error::invalid(
                "curve",
                "every channel is constant; there is no decay to fit",
            ));
        }
        Ok(DecayCurve {
            t_s,
            channels,
            sigma,
        })
    }

    pub(super) fn n_rows(&self) -> usize {
        self.t_s.len()
    }
}

/// How many states to fit.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StatesChoice {
    /// 1..=max states, chosen by BIC.
    Auto {
        /// Largest number tried (≤ [`MAX_STATES`]).
        max: usize,
    },
    /// Exactly this many offered (the collapse rule may still remove states, with a flag).
    Fixed(usize),
}

/// How amplitudes relate across channels.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AmplitudeModel {
    /// One spectrum Λ* shared by all states (the paper's model).
    SharedSpectrum,
    /// Independent amplitudes per state and channel.
    PerChannel,
}

/// Options of [`fit_decay`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DecayFitOptions {
    /// Number of states.
    pub states: StatesChoice,
    /// Amplitude model.
    pub amplitudes: AmplitudeModel,
    /// Fit a constant background per channel (unconstrained in sign).
    pub background: bool,
    /// Starting points per number of states (log-spaced rates plus warm starts).
    pub n_starts: usize,
    /// Apply the collapse rule (zero amplitudes, indistinguishable rates).
    pub collapse: bool,
    /// Stopping rules of the nonlinear solver.
    pub solver: SolverOptions,
}

impl Default for DecayFitOptions {
    fn default() -> Self {
        DecayFitOptions {
            states: StatesChoice::Auto { max: MAX_STATES },
            amplitudes: AmplitudeModel::SharedSpectrum,
            background: false,
            n_starts: 3,
            collapse: true,
            solver: SolverOptions::default(),
        }
    }
}

/// One fitted state.
#[derive(Debug, Clone, PartialEq)]
pub struct DecayState {
    /// Rate k in s⁻¹.
    pub k_per_s: f64,
    /// Standard deviation of k (None when the covariance is singular).
    pub k_sigma_per_s: Option<f64>,
    /// Amplitude a at t = 0 in the input's units per unit spectrum (shared model), or the
    /// largest per-channel amplitude (per-channel model).
    pub amplitude: f64,
    /// Standard deviation of the amplitude.
    pub amplitude_sigma: Option<f64>,
    /// Amplitude per channel at t = 0 (a·Λ*_c in the shared model).
    pub channel_amplitudes: Vec<f64>,
}

/// Something the report must say about the fit.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
#[serde(tag = "flag", rename_all = "snake_case")]
pub enum DecayFlag {
    /// A state's amplitude went to zero; it was removed.
    StateDropped {
        /// Its rate before removal, s⁻¹.
        k_per_s: f64,
    },
    /// Two rates the data cannot tell apart were merged into one state.
    RatesMerged {
        /// The two rates, s⁻¹.
        k_per_s: [f64; 2],
    },
    /// A rate's standard deviation exceeds half of the rate.
    RatePoorlyDetermined {
        /// The rate, s⁻¹.
        k_per_s: f64,
        /// Its standard deviation, s⁻¹.
        sigma_per_s: f64,
    },
    /// A state decays by less than 5 % over the record: it acts like a background.
    QuasiConstantState {
        /// The rate, s⁻¹.
        k_per_s: f64,
    },
    /// The parameter covariance is singular; uncertainties are missing.
    SingularCovariance,
    /// The solver did not report convergence.
    NotConverged {
        /// Why it stopped.
        termination: Termination,
    },
}

impl DecayFlag {
    /// A short machine-readable name.
    pub fn name(&self) -> &'static str {
        match self {
            DecayFlag::StateDropped { .. } => "state_dropped",
            DecayFlag::RatesMerged { .. } => "rates_merged",
            DecayFlag::RatePoorlyDetermined { .. } => "rate_poorly_determined",
            DecayFlag::QuasiConstantState { .. } => "quasi_constant_state",
            DecayFlag::SingularCovariance => "singular_covariance",
            DecayFlag::NotConverged { .. } => "not_converged",
        }
    }
}

/// The fit for one number of states, before selection.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Candidate {
    /// Number of states.
    pub n_states: usize,
    /// Bayesian information criterion.
    pub bic: f64,
    /// Weighted residual sum of squares.
    pub rss: f64,
    /// Rates, decreasing, s⁻¹.
    pub k_per_s: Vec<f64>,
    /// Solver termination.
    pub termination: Termination,
}

/// A candidate that was not fitted because the screen showed it could not win on BIC: the
/// largest Gauss–Newton (linearised) RSS reduction of adding one state to the fit with one state
/// fewer, over a log-spaced grid of rates, was only `gain_ratio` (< [`SCREEN_RATIO`]) of the
/// reduction BIC requires for the extra parameters.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct ScreenedCandidate {
    /// Number of states of the candidate not fitted.
    pub n_states: usize,
    /// Linearised gain of one more state / the gain BIC requires.
    pub gain_ratio: f64,
}

/// Result of [`fit_decay`].
#[derive(Debug, Clone, PartialEq)]
pub struct DecayFit {
    /// States sorted by decreasing rate.
    pub states: Vec<DecayState>,
    /// Shared spectrum per channel, max 1 (per-channel model: of the summed amplitudes).
    pub spectrum: Vec<f64>,
    /// Background per channel, when fitted.
    pub background: Option<Vec<f64>>,
    /// Weighted residual sum of squares.
    pub rss: f64,
    /// Root-mean-square residual (unweighted, input units).
    pub rms: f64,
    /// Number of observations (samples × channels).
    pub n_obs: usize,
    /// Number of fitted parameters.
    pub n_params: usize,
    /// Every candidate fitted, by number of states.
    pub candidates: Vec<Candidate>,
    /// The largest candidate when it was screened out instead of fitted: one more state could
    /// not gain what BIC requires of it (see [`ScreenedCandidate`]); `None` when every candidate
    /// was fitted.
    pub screened: Option<ScreenedCandidate>,
    /// What the report must say.
    pub flags: Vec<DecayFlag>,
    /// Termination of the selected fit.
    pub termination: Termination,
    /// Amplitude model used.
    pub amplitudes: AmplitudeModel,
}

impl DecayFit {
    /// The model at time t per channel.
    pub fn predict(&self, t_s: f64) -> Vec<f64> {
        let nc = self.spectrum.len();
        (0..nc)
            .map(|c| {
                self.states
                    .iter()
                    .map(|s| s.channel_amplitudes[c] * (-s.k_per_s * t_s).exp())
                    .sum::<f64>()
                    + self.background.as_ref().map_or(0.0, |b| b[c])
            })
            .collect()
    }

    /// Contribution of state `i` at time t per channel.
    pub fn state_contribution(&self, i: usize, t_s: f64) -> Vec<f64> {
        self.states.get(i).map_or_else(Vec::new, |s| {
            s.channel_amplitudes
                .iter()
                .map(|a| a * (-s.k_per_s * t_s).exp())
                .collect()
        })
    }
}
