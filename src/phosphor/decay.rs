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
//! The number of states is chosen by BIC among 1..=max (or fixed), then a collapse rule removes a
//! state whose amplitude is zero, and merges two rates closer than twice their combined standard
//! deviation in log k; the report's flags say what happened. Rate uncertainties are the square
//! roots of the diagonal of σ² (JᵀJ)⁻¹ over all parameters (rates, amplitudes, spectrum,
//! background) with σ² = RSS/(N − p) (scaled, like scipy's `curve_fit` default).
//!
//! §4.5: with Λ* on n_λ bands and saturation at switch-off (r_i(0) = 1), the re-radiation
//! functions are Λ_i = a_i Λ* / k_r,i ([`reradiation_functions`]).

// Index loops mirror the matrix notation of the maths; `!(a > b)` comparisons deliberately
// reject NaN along with out-of-range values.
#![allow(clippy::needless_range_loop, clippy::neg_cmp_op_on_partial_ord)]

use crate::error::{Error, Result};
use crate::fit::{
    bic, covariance, solve_separable, SeparableData, SeparableModel, SolverOptions, Termination,
};

/// Largest number of states the fit offers.
pub const MAX_STATES: usize = 3;

/// Relative cost reduction at which a fit that only seeds the next number of states stops (it
/// is continued to the full tolerance if it is ever selected).
const SEED_FTOL: f64 = 1e-6;
/// Relative step at which a seed fit stops.
const SEED_XTOL: f64 = 1e-5;

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

    fn n_rows(&self) -> usize {
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

/// Basis e^{−e^{θ_i} τ} (+ a constant column).
struct ExpBasis<'a> {
    tau: &'a [f64],
    /// The step when the times are evenly spaced from τ = 0: then e^{−kτ_i} = (e^{−k Δτ})^i,
    /// one `exp` per column instead of one per sample.
    step: Option<f64>,
    n_exp: usize,
    background: bool,
}

/// The common step of `tau` (starting at 0) when it is evenly spaced to 1e-12 relative.
fn uniform_step(tau: &[f64]) -> Option<f64> {
    let m = tau.len();
    if m < 2 || tau[0] != 0.0 {
        return None;
    }
    let dt = tau[m - 1] / (m - 1) as f64;
    let ok = dt > 0.0
        && tau
            .iter()
            .enumerate()
            .all(|(i, t)| (t - i as f64 * dt).abs() <= 1e-12 * tau[m - 1]);
    ok.then_some(dt)
}

impl SeparableModel for ExpBasis<'_> {
    fn n_rows(&self) -> usize {
        self.tau.len()
    }
    fn n_params(&self) -> usize {
        self.n_exp
    }
    fn n_cols(&self) -> usize {
        self.n_exp + usize::from(self.background)
    }
    fn column_param(&self, col: usize) -> Option<usize> {
        (col < self.n_exp).then_some(col)
    }
    fn column_free(&self, col: usize) -> bool {
        col >= self.n_exp
    }
    fn eval(&self, theta: &[f64], basis: &mut [f64], dbasis: &mut [f64]) {
        let m = self.tau.len();
        for (j, th) in theta.iter().enumerate().take(self.n_exp) {
            let k = th.exp();
            match self.step {
                Some(dt) => {
                    let r = (-k * dt).exp();
                    let mut e = 1.0;
                    for (i, &t) in self.tau.iter().enumerate() {
                        basis[j * m + i] = e;
                        dbasis[j * m + i] = -k * t * e;
                        e *= r;
                    }
                }
                None => {
                    for (i, &t) in self.tau.iter().enumerate() {
                        let e = (-k * t).exp();
                        basis[j * m + i] = e;
                        dbasis[j * m + i] = -k * t * e;
                    }
                }
            }
        }
        if self.background {
            let j = self.n_exp;
            basis[j * m..(j + 1) * m].iter_mut().for_each(|v| *v = 1.0);
            dbasis[j * m..(j + 1) * m].iter_mut().for_each(|v| *v = 0.0);
        }
    }
}

/// Internal result for n states (τ = t − t₀ time base, unit-norm spectrum).
#[derive(Debug, Clone)]
struct RawFit {
    theta: Vec<f64>,
    /// Amplitudes per state (shared) at τ = 0.
    a: Vec<f64>,
    /// Per state × channel amplitudes at τ = 0.
    c: Vec<Vec<f64>>,
    /// Unit-norm spectrum (shared model).
    s: Vec<f64>,
    background: Vec<f64>,
    rss: f64,
    termination: Termination,
}

struct Prepared<'c> {
    curve: &'c DecayCurve,
    tau: Vec<f64>,
    t0: f64,
    sqrt_w: Option<Vec<f64>>,
    /// Channels stacked, m × n_ch.
    y: Vec<f64>,
    n_ch: usize,
    m: usize,
}

impl<'c> Prepared<'c> {
    fn new(curve: &'c DecayCurve) -> Self {
        let t0 = curve.t_s[0];
        let sqrt_w = curve
            .sigma
            .as_ref()
            .map(|s| s.iter().map(|v| 1.0 / v).collect());
        Prepared {
            curve,
            tau: curve.t_s.iter().map(|t| t - t0).collect(),
            t0,
            sqrt_w,
            y: curve.channels.concat(),
            n_ch: curve.channels.len(),
            m: curve.n_rows(),
        }
    }

    fn w(&self, i: usize) -> f64 {
        self.sqrt_w.as_ref().map_or(1.0, |w| w[i] * w[i])
    }

    /// Leading right singular vector of W^{1/2} Y (non-negative, unit norm).
    fn initial_spectrum(&self) -> Vec<f64> {
        let (m, nc) = (self.m, self.n_ch);
        let mut g = vec![0.0; nc * nc];
        for a in 0..nc {
            for b in 0..nc {
                g[a * nc + b] = (0..m)
                    .map(|i| self.w(i) * self.y[a * m + i] * self.y[b * m + i])
                    .sum();
            }
        }
        let mut v: Vec<f64> = (0..nc)
            .map(|c| (0..m).map(|i| self.y[c * m + i].abs()).sum::<f64>() + 1e-300)
            .collect();
        for _ in 0..100 {
            let mut nv: Vec<f64> = (0..nc)
                .map(|a| (0..nc).map(|b| g[a * nc + b] * v[b]).sum())
                .collect();
            let n = nv.iter().map(|x| x * x).sum::<f64>().sqrt();
            if n == 0.0 || !n.is_finite() {
                break;
            }
            nv.iter_mut().for_each(|x| *x /= n);
            let d: f64 = nv.iter().zip(&v).map(|(a, b)| (a - b).abs()).sum();
            v = nv;
            if d < 1e-15 {
                break;
            }
        }
        if v.iter().sum::<f64>() < 0.0 {
            v.iter_mut().for_each(|x| *x = -*x);
        }
        v.iter_mut().for_each(|x| *x = x.max(0.0));
        let n = v.iter().map(|x| x * x).sum::<f64>().sqrt();
        if n > 0.0 {
            v.iter_mut().for_each(|x| *x /= n);
            v
        } else {
            vec![1.0 / (nc as f64).sqrt(); nc]
        }
    }

    /// e^{−e^{θ_j} τ_i} for every state j and sample i (state after state).
    fn exp_table(&self, theta: &[f64], out: &mut Vec<f64>) {
        out.clear();
        let step = uniform_step(&self.tau);
        for th in theta {
            let k = th.exp();
            match step {
                Some(dt) => {
                    let r = (-k * dt).exp();
                    let mut e = 1.0;
                    for _ in 0..self.m {
                        out.push(e);
                        e *= r;
                    }
                }
                None => out.extend(self.tau.iter().map(|t| (-k * t).exp())),
            }
        }
    }

    /// Weighted RSS of a fit, given its [`Self::exp_table`].
    fn rss_of(&self, raw: &RawFit, ex: &[f64]) -> f64 {
        let (m, nc) = (self.m, self.n_ch);
        let mut rss = 0.0;
        for c in 0..nc {
            for i in 0..m {
                let mut f = raw.background.get(c).copied().unwrap_or(0.0);
                for j in 0..raw.theta.len() {
                    f += raw.c[j][c] * ex[j * m + i];
                }
                let r = self.y[c * m + i] - f;
                rss += self.w(i) * r * r;
            }
        }
        rss
    }

    /// Fits n states from one start.
    fn fit_from(&self, n: usize, theta0: &[f64], opts: &DecayFitOptions, s0: &[f64]) -> RawFit {
        let basis = ExpBasis {
            tau: &self.tau,
            step: uniform_step(&self.tau),
            n_exp: n,
            background: opts.background,
        };
        let (m, nc) = (self.m, self.n_ch);
        let ncols = n + usize::from(opts.background);
        if nc == 1 || opts.amplitudes == AmplitudeModel::PerChannel {
            let fit = solve_separable(
                &basis,
                SeparableData {
                    y: &self.y,
                    n_rhs: nc,
                    sqrt_w: self.sqrt_w.as_deref(),
                },
                theta0,
                &opts.solver,
            );
            let c: Vec<Vec<f64>> = (0..n)
                .map(|j| (0..nc).map(|r| fit.coeffs[r * ncols + j]).collect())
                .collect();
            let background = if opts.background {
                (0..nc).map(|r| fit.coeffs[r * ncols + n]).collect()
            } else {
                Vec::new()
            };
            let (a, s) = if nc == 1 {
                (c.iter().map(|v| v[0]).collect(), vec![1.0])
            } else {
                (
                    c.iter()
                        .map(|v| v.iter().fold(0.0_f64, |x, y| x.max(*y)))
                        .collect(),
                    Vec::new(),
                )
            };
            return RawFit {
                theta: fit.theta,
                a,
                c,
                s,
                background,
                rss: fit.rss,
                termination: fit.termination,
            };
        }
        // Shared spectrum: alternate the separable fit of Y s with the update of s.
        let mut s = s0.to_vec();
        let mut theta = theta0.to_vec();
        let mut ys = vec![0.0; m];
        let mut raw = None;
        let mut ex = Vec::with_capacity(n * m);
        let ybar: Vec<f64> = {
            let wsum: f64 = (0..m).map(|i| self.w(i)).sum();
            (0..nc)
                .map(|c| (0..m).map(|i| self.w(i) * self.y[c * m + i]).sum::<f64>() / wsum)
                .collect()
        };
        for _ in 0..30 {
            for (i, v) in ys.iter_mut().enumerate() {
                *v = (0..nc).map(|c| s[c] * self.y[c * m + i]).sum();
            }
            let fit = solve_separable(
                &basis,
                SeparableData {
                    y: &ys,
                    n_rhs: 1,
                    sqrt_w: self.sqrt_w.as_deref(),
                },
                &theta,
                &opts.solver,
            );
            theta.clone_from(&fit.theta);
            let a: Vec<f64> = fit.coeffs[..n].to_vec();
            let background: Vec<f64> = if opts.background {
                let beta = fit.coeffs[n];
                let proj: f64 = ybar.iter().zip(&s).map(|(y, s)| y * s).sum();
                (0..nc)
                    .map(|c| beta * s[c] + ybar[c] - proj * s[c])
                    .collect()
            } else {
                Vec::new()
            };
            // f(τ) = Σ a_j e^{−k_j τ}; s ← (Y − 1bᵀ)ᵀ W f / fᵀ W f
            self.exp_table(&theta, &mut ex);
            let f: Vec<f64> = (0..m)
                .map(|i| (0..n).map(|j| a[j] * ex[j * m + i]).sum())
                .collect();
            let ff: f64 = (0..m).map(|i| self.w(i) * f[i] * f[i]).sum();
            let mut done = true;
            let mut new_s = s.clone();
            let mut scale = 1.0;
            if ff > 0.0 {
                for (c, ns) in new_s.iter_mut().enumerate() {
                    let b = background.get(c).copied().unwrap_or(0.0);
                    *ns = ((0..m)
                        .map(|i| self.w(i) * (self.y[c * m + i] - b) * f[i])
                        .sum::<f64>()
                        / ff)
                        .max(0.0);
                }
                let norm = new_s.iter().map(|x| x * x).sum::<f64>().sqrt();
                if norm > 0.0 {
                    new_s.iter_mut().for_each(|x| *x /= norm);
                    scale = norm;
                    let d: f64 = new_s.iter().zip(&s).map(|(a, b)| (a - b).abs()).sum();
                    done = d < 1e-11;
                }
            }
            let a_scaled: Vec<f64> = a.iter().map(|v| v * scale).collect();
            let c = a_scaled
                .iter()
                .map(|aj| new_s.iter().map(|sc| aj * sc).collect())
                .collect();
            let mut r = RawFit {
                theta: theta.clone(),
                a: a_scaled,
                c,
                s: new_s.clone(),
                background,
                rss: 0.0,
                termination: fit.termination,
            };
            r.rss = self.rss_of(&r, &ex);
            raw = Some(r);
            s = new_s;
            if done {
                break;
            }
        }
        raw.unwrap_or(RawFit {
            theta,
            a: vec![0.0; n],
            c: vec![vec![0.0; nc]; n],
            s,
            background: Vec::new(),
            rss: f64::INFINITY,
            termination: Termination::NonFinite,
        })
    }

    /// Starting rates for n states: warm starts from the (n−1)-state rates, then log-spaced.
    fn starts(&self, n: usize, prev: Option<&[f64]>, n_starts: usize) -> Vec<Vec<f64>> {
        let (lo, hi) = self.log_rate_range();
        let mut out: Vec<Vec<f64>> = Vec::new();
        if let Some(p) = prev {
            let mx = p.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
            let mn = p.iter().cloned().fold(f64::INFINITY, f64::min);
            let mut a = p.to_vec();
            a.push(mn - 1.5);
            out.push(a);
            let mut b = p.to_vec();
            b.push(mx + 1.5);
            out.push(b);
        }
        // log-spaced: n rates evenly spread over [lo, hi], shifted per start
        let g = n_starts.max(1);
        for s in 0..g {
            let shift = (s as f64 + 0.5) / g as f64 - 0.5;
            let width = (hi - lo).max(1e-3);
            let v: Vec<f64> = (0..n)
                .map(|j| {
                    let frac = (j as f64 + 0.5) / n as f64 + shift / n as f64;
                    lo + width * frac
                })
                .collect();
            out.push(v);
        }
        out.truncate(n_starts.max(1) + usize::from(prev.is_some()) * 2);
        out
    }

    /// Range of plausible ln k: from half a decay over the record to one decay per sample step.
    fn log_rate_range(&self) -> (f64, f64) {
        let span = self.tau[self.m - 1].max(f64::MIN_POSITIVE);
        let dt = self
            .tau
            .windows(2)
            .map(|w| w[1] - w[0])
            .fold(f64::INFINITY, f64::min)
            .max(span * 1e-6);
        ((0.5 / span).ln(), (1.0 / dt).ln())
    }

    /// Prony's (1795) linear-prediction estimate of n rates (θ = ln k), for evenly spaced
    /// times: a sum of n exponentials sampled every Δτ obeys y_{i+n} = Σ_j p_j y_{i+n−j}, and
    /// the roots z of z^n − Σ_j p_j z^{n−j} are e^{−k Δτ}. The p_j are fitted by weighted least
    /// squares over every channel (differences y_{i+1} − y_i remove a constant background).
    /// Biased by noise, so only a start; `None` unless the roots are real, distinct, in (0, 1)
    /// and give rates in the plausible range.
    fn prony_start(&self, n: usize, background: bool) -> Option<Vec<f64>> {
        let dt = uniform_step(&self.tau)?;
        let (m, nc) = (self.m, self.n_ch);
        let len = m - usize::from(background);
        if n == 0 || n > MAX_STATES || len < 2 * n + 2 {
            return None;
        }
        let sample = |c: usize, i: usize| {
            let y = &self.y[c * m..(c + 1) * m];
            if background {
                y[i + 1] - y[i]
            } else {
                y[i]
            }
        };
        // normal equations G p = b (n ≤ 3)
        let mut g = [[0.0_f64; MAX_STATES]; MAX_STATES];
        let mut b = [0.0_f64; MAX_STATES];
        for c in 0..nc {
            for i in n..len {
                let w = self.w(i);
                let target = sample(c, i);
                for a in 0..n {
                    let xa = sample(c, i - 1 - a);
                    b[a] += w * xa * target;
                    for bb in 0..=a {
                        g[a][bb] += w * xa * sample(c, i - 1 - bb);
                    }
                }
            }
        }
        // Cholesky of the symmetric positive definite G
        let mut l = [[0.0_f64; MAX_STATES]; MAX_STATES];
        for a in 0..n {
            for bb in 0..=a {
                let s = g[a][bb] - (0..bb).map(|k| l[a][k] * l[bb][k]).sum::<f64>();
                if a == bb {
                    if !(s > 1e-14 * g[a][a]) {
                        return None;
                    }
                    l[a][a] = s.sqrt();
                } else {
                    l[a][bb] = s / l[bb][bb];
                }
            }
        }
        let mut p = [0.0_f64; MAX_STATES];
        for a in 0..n {
            p[a] = (b[a] - (0..a).map(|k| l[a][k] * p[k]).sum::<f64>()) / l[a][a];
        }
        for a in (0..n).rev() {
            p[a] = (p[a] - (a + 1..n).map(|k| l[k][a] * p[k]).sum::<f64>()) / l[a][a];
        }
        let roots = real_roots(&p[..n])?;
        let (lo, hi) = self.log_rate_range();
        let mut theta = Vec::with_capacity(n);
        for z in roots {
            if !(z > 0.0 && z < 1.0) {
                return None;
            }
            let th = (-z.ln() / dt).ln();
            if !(th >= lo - 3.0 && th <= hi + 3.0) {
                return None;
            }
            theta.push(th);
        }
        theta.sort_by(|a, b| b.total_cmp(a));
        if theta.windows(2).any(|w| !(w[0] - w[1] > 0.05)) {
            return None;
        }
        Some(theta)
    }

    /// One-state starting rate from a log-linear fit of the channel sum (weights z², the usual
    /// correction of the log transform), clamped to the plausible range.
    fn log_linear_start(&self) -> f64 {
        let (lo, hi) = self.log_rate_range();
        let (m, nc) = (self.m, self.n_ch);
        let (mut sw, mut st, mut sz, mut stt, mut stz) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for i in 0..m {
            let z: f64 = (0..nc).map(|c| self.y[c * m + i]).sum();
            if !(z > 0.0) {
                continue;
            }
            let w = z * z * self.w(i);
            let (t, lz) = (self.tau[i], z.ln());
            sw += w;
            st += w * t;
            sz += w * lz;
            stt += w * t * t;
            stz += w * t * lz;
        }
        let den = sw * stt - st * st;
        let k = -(sw * stz - st * sz) / den;
        if k > 0.0 && k.is_finite() {
            k.ln().clamp(lo, hi)
        } else {
            0.5 * (lo + hi)
        }
    }

    /// Whether a fit from the first start can be accepted without trying the others: converged,
    /// every state with a positive amplitude, rates distinct and in a plausible range, and a
    /// better fit than the nested model with one state fewer.
    fn acceptable(&self, r: &RawFit, prev_rss: Option<f64>) -> bool {
        r.termination.converged()
            && r.rss.is_finite()
            && !self.degenerate(r)
            && prev_rss.is_none_or(|p| r.rss < p)
    }

    /// Whether a fit's states are degenerate — in effect a fit with fewer states: a state's
    /// amplitude is (nearly) zero, two rates coincide, or a rate is outside the plausible range
    /// by more than e³ (gone before the second sample, or constant over the record).
    fn degenerate(&self, r: &RawFit) -> bool {
        if !r.rss.is_finite() {
            return false;
        }
        let (lo, hi) = self.log_rate_range();
        if r.theta.iter().any(|t| !(*t >= lo - 3.0 && *t <= hi + 3.0)) {
            return true;
        }
        let amp = |j: usize| {
            r.c[j]
                .iter()
                .cloned()
                .fold(r.a.get(j).copied().unwrap_or(0.0), f64::max)
        };
        let n = r.theta.len();
        let amax = (0..n).map(amp).fold(0.0_f64, f64::max);
        (0..n).any(|j| !(amp(j) > 1e-6 * amax))
            || (0..n).any(|i| (i + 1..n).any(|j| !((r.theta[i] - r.theta[j]).abs() > 0.05)))
    }

    /// Fits n states: good starts first, the multi-start only when their fits are doubtful.
    ///
    /// `optional`: the n-state model is only a BIC candidate next to the (n − 1)-state fit
    /// `prev`. Then a fit from the good starts that is hopeless — degenerate (see
    /// [`Self::degenerate`]) and either losing to `prev` on BIC or removed by the collapse
    /// rule — ends the search early, without the log-spaced multi-start: for three states
    /// when the two-state fit extended by a slower state (and Prony's estimate, if any) is
    /// hopeless; for two states when the one-state fit extended by a slower and by a faster
    /// state both are. The data then show no further state and the candidate could not be
    /// the result.
    fn fit_n(
        &self,
        n: usize,
        prev: Option<(&[f64], f64)>,
        optional: bool,
        opts: &DecayFitOptions,
        s0: &[f64],
    ) -> RawFit {
        // Good starts first (log-linear for one state; Prony's estimate, then the nested fit
        // plus a slower state, otherwise); the multi-start below runs only when those fits are
        // doubtful.
        let mut first_starts: Vec<Vec<f64>> = Vec::with_capacity(2);
        if n == 1 {
            first_starts.push(vec![self.log_linear_start()]);
        } else {
            if let Some(st) = self.prony_start(n, opts.background) {
                first_starts.push(st);
            }
            if let Some((p, _)) = prev.filter(|(p, _)| p.len() + 1 == n) {
                let mn = p.iter().cloned().fold(f64::INFINITY, f64::min);
                let mut a = p.to_vec();
                a.push(mn - 1.5);
                first_starts.push(a);
            }
        }
        let mut first: Option<RawFit> = None;
        for st in &first_starts {
            let r = self.fit_from(n, st, opts, s0);
            if self.acceptable(&r, prev.map(|p| p.1)) {
                return r;
            }
            if first.as_ref().is_none_or(|f| r.rss < f.rss) {
                first = Some(r);
            }
        }
        if let (true, Some((p, prev_rss))) = (optional, prev) {
            let n_obs = self.m * self.n_ch;
            let prev_bic = bic(prev_rss, n_obs, self.n_params_of(p.len(), opts));
            let hopeless = |f: &RawFit| {
                self.degenerate(f)
                    && (bic(f.rss, n_obs, self.n_params_of(n, opts)) >= prev_bic
                        || (opts.collapse
                            && collapse_reason(f, self.log_rate_sds(f, opts).as_deref()).is_some()))
            };
            if first.as_ref().is_some_and(hopeless) {
                if n >= 3 {
                    if let Some(f) = first.take() {
                        return f;
                    }
                }
                // two states: the one-state fit is a compromise between the two rates, so the
                // other warm start (plus a faster state) must fail too
                let mx = p.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
                let mut faster = p.to_vec();
                faster.push(mx + 1.5);
                let r = self.fit_from(n, &faster, opts, s0);
                first_starts.push(faster);
                if self.acceptable(&r, Some(prev_rss)) {
                    return r;
                }
                let r_hopeless = hopeless(&r);
                if first.as_ref().is_none_or(|f| r.rss < f.rss) {
                    first = Some(r);
                }
                if r_hopeless {
                    if let Some(f) = first.take() {
                        return f;
                    }
                }
            }
        }
        // the doubtful first fit competes on RSS at the end but does not count as agreement
        let mut best: Option<RawFit> = None;
        let mut agree = 0;
        for start in self.starts(n, prev.map(|p| p.0), opts.n_starts) {
            if first_starts.contains(&start) {
                continue;
            }
            let r = self.fit_from(n, &start, opts, s0);
            match &best {
                // two converged starts that reach the same minimum: stop searching
                Some(b)
                    if r.termination.converged()
                        && b.termination.converged()
                        && (r.rss - b.rss).abs() <= 1e-9 * b.rss.max(f64::MIN_POSITIVE) =>
                {
                    agree += 1;
                }
                _ => {}
            }
            if best.as_ref().is_none_or(|b| r.rss < b.rss) {
                best = Some(r);
            }
            if agree >= 1 {
                break;
            }
        }
        match (best, first) {
            (Some(b), Some(f)) => {
                if f.rss < b.rss {
                    f
                } else {
                    b
                }
            }
            (Some(b), None) | (None, Some(b)) => b,
            (None, None) => self.fit_from(n, &vec![0.0; n], opts, s0),
        }
    }

    fn n_params(&self, raw: &RawFit, opts: &DecayFitOptions) -> usize {
        self.n_params_of(raw.theta.len(), opts)
    }

    /// Number of fitted parameters of an n-state model.
    fn n_params_of(&self, n: usize, opts: &DecayFitOptions) -> usize {
        let nc = self.n_ch;
        let lin = if nc == 1 {
            n
        } else if opts.amplitudes == AmplitudeModel::PerChannel {
            n * nc
        } else {
            n + nc - 1
        };
        n + lin + if opts.background { nc } else { 0 }
    }

    /// e^{−k_j t_i} on the absolute times, state after state (one `exp` per state and a
    /// product per sample when the times are evenly spaced).
    fn abs_exp_table(&self, ks: &[f64]) -> Vec<f64> {
        let mut out = Vec::with_capacity(ks.len() * self.m);
        let step = uniform_step(&self.tau);
        for k in ks {
            match step {
                Some(dt) => {
                    let r = (-k * dt).exp();
                    let mut e = (-k * self.t0).exp();
                    for _ in 0..self.m {
                        out.push(e);
                        e *= r;
                    }
                }
                None => out.extend(self.curve.t_s.iter().map(|t| (-k * t).exp())),
            }
        }
        out
    }

    /// Covariance over (k, amplitudes, spectrum, background) in absolute time; returns the
    /// standard deviations of k and of the amplitudes per state (None when singular).
    fn uncertainties(
        &self,
        ks: &[f64],
        c_abs: &[Vec<f64>],
        a_abs: &[f64],
        spectrum: &[f64],
        opts: &DecayFitOptions,
        rss: f64,
    ) -> Option<(Vec<f64>, Vec<f64>)> {
        let (m, nc) = (self.m, self.n_ch);
        let n = ks.len();
        let shared = nc > 1 && opts.amplitudes == AmplitudeModel::SharedSpectrum;
        let rows = m * nc;
        let t = &self.curve.t_s;
        let ex = self.abs_exp_table(ks);
        let sw = |i: usize| self.sqrt_w.as_ref().map_or(1.0, |w| w[i]);
        // the weighted Jacobian, column after column (each column: channel after channel)
        let mut jac: Vec<f64> = Vec::with_capacity(rows * (2 * n + n * nc + 2 * nc));
        let mut p = 0;
        let mut k_idx = vec![None; n];
        let mut a_idx = vec![None; n];
        for j in 0..n {
            if a_abs[j] <= 0.0 {
                continue;
            }
            let e = &ex[j * m..(j + 1) * m];
            for c in 0..nc {
                jac.extend((0..m).map(|i| -t[i] * c_abs[j][c] * e[i] * sw(i)));
            }
            k_idx[j] = Some(p);
            p += 1;
            if shared || nc == 1 {
                for c in 0..nc {
                    jac.extend((0..m).map(|i| spectrum[c] * e[i] * sw(i)));
                }
                a_idx[j] = Some(p);
                p += 1;
            } else {
                for c in 0..nc {
                    if c_abs[j][c] <= 0.0 {
                        continue;
                    }
                    for c2 in 0..nc {
                        if c2 == c {
                            jac.extend((0..m).map(|i| e[i] * sw(i)));
                        } else {
                            jac.extend(std::iter::repeat_n(0.0, m));
                        }
                    }
                    p += 1;
                }
            }
        }
        if shared {
            let fix = spectrum
                .iter()
                .enumerate()
                .fold(
                    (0, f64::NEG_INFINITY),
                    |b, (i, v)| if *v > b.1 { (i, *v) } else { b },
                )
                .0;
            for c in 0..nc {
                if c == fix || spectrum[c] <= 0.0 {
                    continue;
                }
                for c2 in 0..nc {
                    if c2 == c {
                        jac.extend((0..m).map(|i| {
                            (0..n).map(|j| a_abs[j] * ex[j * m + i]).sum::<f64>() * sw(i)
                        }));
                    } else {
                        jac.extend(std::iter::repeat_n(0.0, m));
                    }
                }
                p += 1;
            }
        }
        if opts.background {
            for c in 0..nc {
                for c2 in 0..nc {
                    if c2 == c {
                        jac.extend((0..m).map(sw));
                    } else {
                        jac.extend(std::iter::repeat_n(0.0, m));
                    }
                }
                p += 1;
            }
        }
        let cov = covariance(&jac, rows, p, rss)?;
        let sd = |idx: Option<usize>| idx.map_or(0.0, |q| cov[q * p + q].max(0.0).sqrt());
        Some((
            k_idx.iter().map(|q| sd(*q)).collect(),
            a_idx.iter().map(|q| sd(*q)).collect(),
        ))
    }

    fn finish(
        &self,
        raw: &RawFit,
        opts: &DecayFitOptions,
        candidates: Vec<Candidate>,
        mut flags: Vec<DecayFlag>,
    ) -> DecayFit {
        let nc = self.n_ch;
        let n = raw.theta.len();
        let mut order: Vec<usize> = (0..n).collect();
        order.sort_by(|&a, &b| raw.theta[b].total_cmp(&raw.theta[a]));
        let ks: Vec<f64> = order.iter().map(|&j| raw.theta[j].exp()).collect();
        // amplitudes back to t = 0: a(0) = a(τ=0) e^{k t0}
        let c_abs: Vec<Vec<f64>> = order
            .iter()
            .zip(&ks)
            .map(|(&j, k)| raw.c[j].iter().map(|v| v * (k * self.t0).exp()).collect())
            .collect();
        let shared = nc == 1 || opts.amplitudes == AmplitudeModel::SharedSpectrum;
        let (spectrum, a_abs): (Vec<f64>, Vec<f64>) = if shared {
            let smax = raw.s.iter().cloned().fold(0.0_f64, f64::max);
            let smax = if smax > 0.0 { smax } else { 1.0 };
            (
                raw.s.iter().map(|v| v / smax).collect(),
                order
                    .iter()
                    .zip(&ks)
                    .map(|(&j, k)| raw.a[j] * smax * (k * self.t0).exp())
                    .collect(),
            )
        } else {
            let mut tot = vec![0.0; nc];
            for cj in &c_abs {
                for (t, v) in tot.iter_mut().zip(cj) {
                    *t += v;
                }
            }
            let mx = tot.iter().cloned().fold(0.0_f64, f64::max);
            let mx = if mx > 0.0 { mx } else { 1.0 };
            (
                tot.iter().map(|v| v / mx).collect(),
                c_abs
                    .iter()
                    .map(|v| v.iter().cloned().fold(0.0_f64, f64::max))
                    .collect(),
            )
        };
        let sds = self.uncertainties(&ks, &c_abs, &a_abs, &spectrum, opts, raw.rss);
        if sds.is_none() {
            flags.push(DecayFlag::SingularCovariance);
        }
        let span = self.curve.t_s[self.m - 1] - self.curve.t_s[0];
        let mut states = Vec::with_capacity(n);
        for j in 0..n {
            let k_sigma = sds.as_ref().map(|(k, _)| k[j]);
            let a_sigma = sds.as_ref().and_then(|(_, a)| (shared).then_some(a[j]));
            if let Some(sk) = k_sigma {
                if sk > 0.5 * ks[j] {
                    flags.push(DecayFlag::RatePoorlyDetermined {
                        k_per_s: ks[j],
                        sigma_per_s: sk,
                    });
                }
            }
            if ks[j] * span < 0.05 {
                flags.push(DecayFlag::QuasiConstantState { k_per_s: ks[j] });
            }
            states.push(DecayState {
                k_per_s: ks[j],
                k_sigma_per_s: k_sigma,
                amplitude: a_abs[j],
                amplitude_sigma: a_sigma,
                channel_amplitudes: c_abs[j].clone(),
            });
        }
        if !raw.termination.converged() {
            flags.push(DecayFlag::NotConverged {
                termination: raw.termination,
            });
        }
        // unweighted RMS in input units
        let mut fit = DecayFit {
            states,
            spectrum,
            background: opts.background.then(|| raw.background.clone()),
            rss: raw.rss,
            rms: 0.0,
            n_obs: self.m * nc,
            n_params: self.n_params(raw, opts),
            candidates,
            flags,
            termination: raw.termination,
            amplitudes: opts.amplitudes,
        };
        let ex = self.abs_exp_table(&ks);
        let mut ss = 0.0;
        for c in 0..nc {
            let b = fit.background.as_ref().map_or(0.0, |b| b[c]);
            for (i, y) in self.curve.channels[c].iter().enumerate() {
                let p: f64 = fit
                    .states
                    .iter()
                    .enumerate()
                    .map(|(j, s)| s.channel_amplitudes[c] * ex[j * self.m + i])
                    .sum();
                let r = y - p - b;
                ss += r * r;
            }
        }
        fit.rms = (ss / fit.n_obs as f64).sqrt();
        fit
    }
}

/// The roots of z^n − p₁ z^{n−1} − … − p_n (n ≤ 3) when all are real, else `None`.
fn real_roots(p: &[f64]) -> Option<Vec<f64>> {
    match *p {
        [p1] => Some(vec![p1]),
        [p1, p2] => {
            let disc = p1 * p1 + 4.0 * p2;
            if !(disc >= 0.0) {
                return None;
            }
            let q = 0.5 * (p1 + p1.signum() * disc.sqrt());
            // the stable pair: q and −p₂/q (product of the roots is −p₂)
            if q == 0.0 {
                return Some(vec![0.0, 0.0]);
            }
            Some(vec![q, -p2 / q])
        }
        [p1, p2, p3] => {
            // z³ + A z² + B z + C with A = −p₁, B = −p₂, C = −p₃ (trigonometric method)
            let (a, b, c) = (-p1, -p2, -p3);
            let q = (a * a - 3.0 * b) / 9.0;
            let r = (2.0 * a * a * a - 9.0 * a * b + 27.0 * c) / 54.0;
            if !(q > 0.0 && r * r < q * q * q) {
                return None;
            }
            let phi = (r / (q * q * q).sqrt()).clamp(-1.0, 1.0).acos();
            let sq = -2.0 * q.sqrt();
            let tau = std::f64::consts::TAU;
            Some(vec![
                sq * (phi / 3.0).cos() - a / 3.0,
                sq * ((phi + tau) / 3.0).cos() - a / 3.0,
                sq * ((phi - tau) / 3.0).cos() - a / 3.0,
            ])
        }
        _ => None,
    }
}

/// Collapse check of one fit: returns the flag that requires removing a state, if any.
fn collapse_reason(raw: &RawFit, sd_logk: Option<&[f64]>) -> Option<DecayFlag> {
    let n = raw.theta.len();
    if n <= 1 {
        return None;
    }
    let amax = raw.a.iter().cloned().fold(0.0_f64, f64::max);
    for j in 0..n {
        let aj = if raw.c[j].is_empty() {
            raw.a[j]
        } else {
            raw.c[j].iter().cloned().fold(0.0, f64::max)
        };
        if aj <= 1e-12 * amax.max(f64::MIN_POSITIVE) || aj == 0.0 {
            return Some(DecayFlag::StateDropped {
                k_per_s: raw.theta[j].exp(),
            });
        }
    }
    // a state the data cannot determine at all: singular covariance, or σ(ln k) > 1
    let weakest = || {
        (0..n)
            .min_by(|&i, &j| {
                let ai: f64 = raw.c[i].iter().sum::<f64>().max(raw.a[i]);
                let aj: f64 = raw.c[j].iter().sum::<f64>().max(raw.a[j]);
                ai.total_cmp(&aj)
            })
            .unwrap_or(0)
    };
    match sd_logk {
        None => {
            return Some(DecayFlag::StateDropped {
                k_per_s: raw.theta[weakest()].exp(),
            })
        }
        Some(s) => {
            if let Some(j) = (0..n)
                .filter(|&j| s[j] > 1.0 || !s[j].is_finite())
                .max_by(|&a, &b| s[a].total_cmp(&s[b]))
            {
                return Some(DecayFlag::StateDropped {
                    k_per_s: raw.theta[j].exp(),
                });
            }
        }
    }
    for i in 0..n {
        for j in i + 1..n {
            let d = (raw.theta[i] - raw.theta[j]).abs();
            let tol = match sd_logk {
                Some(s) => 2.0 * (s[i] * s[i] + s[j] * s[j]).sqrt(),
                None => 0.0,
            }
            .max(1e-3);
            if d < tol || !d.is_finite() {
                return Some(DecayFlag::RatesMerged {
                    k_per_s: [raw.theta[i].exp(), raw.theta[j].exp()],
                });
            }
        }
    }
    None
}

/// Fits the decay model to a curve (see the module docs).
///
/// # Errors
/// [`Error::InvalidArgument`] for an invalid number of states; [`Error::Numerical`] when no
/// decaying component is found (all amplitudes zero). Non-convergence is reported in the flags.
pub fn fit_decay(curve: &DecayCurve, opts: &DecayFitOptions) -> Result<DecayFit> {
    let (lo, hi) = match opts.states {
        StatesChoice::Auto { max } => (1, max),
        StatesChoice::Fixed(n) => (n, n),
    };
    if lo == 0 || hi > MAX_STATES || hi < lo {
        return Err(Error::invalid(
            "states",
            format!("{lo}–{hi}; expected 1 to {MAX_STATES}"),
        ));
    }
    let prep = Prepared::new(curve);
    let n_obs = prep.m * prep.n_ch;
    let s0 = prep.initial_spectrum();
    // Fit 1..=hi: lower counts seed the higher ones and are the collapse rule's fall-back.
    // Counts below `lo` are not results unless the collapse rule falls back to them: when a
    // Prony start gives an acceptable fit of `lo` states directly they are not fitted at all,
    // otherwise they are fitted to a loose tolerance; either way they are fitted (or refined)
    // to the full tolerance only if selected.
    let seed_opts = DecayFitOptions {
        solver: SolverOptions {
            ftol: SEED_FTOL.max(opts.solver.ftol),
            xtol: SEED_XTOL.max(opts.solver.xtol),
            ..opts.solver
        },
        ..*opts
    };
    let mut raws: Vec<Option<RawFit>> = vec![None; hi];
    let mut exact = vec![false; hi];
    let mut first = 1;
    if lo >= 2 {
        if let Some(st) = prep.prony_start(lo, opts.background) {
            let r = prep.fit_from(lo, &st, opts, &s0);
            if prep.acceptable(&r, None) {
                raws[lo - 1] = Some(r);
                exact[lo - 1] = true;
                first = lo + 1;
            }
        }
    }
    for n in first..=hi {
        let o = if n < lo { &seed_opts } else { opts };
        let r = prep.fit_monotone(
            n,
            raws[..n - 1].last().and_then(Option::as_ref),
            n > lo,
            o,
            &s0,
        );
        raws[n - 1] = Some(r);
        exact[n - 1] = n >= lo;
    }
    let candidates: Vec<Candidate> = raws
        .iter()
        .flatten()
        .filter(|r| r.theta.len() >= lo)
        .map(|r| {
            let mut k: Vec<f64> = r.theta.iter().map(|t| t.exp()).collect();
            k.sort_by(|a, b| b.total_cmp(a));
            Candidate {
                n_states: r.theta.len(),
                bic: bic(r.rss, n_obs, prep.n_params(r, opts)),
                rss: r.rss,
                k_per_s: k,
                termination: r.termination,
            }
        })
        .collect();
    let mut chosen = candidates
        .iter()
        .filter(|c| c.bic.is_finite())
        .min_by(|a, b| a.bic.total_cmp(&b.bic))
        .map_or(hi, |c| c.n_states);
    let mut flags = Vec::new();
    if opts.collapse {
        while chosen > 1 {
            let raw = prep.exact_fit(&mut raws, &mut exact, chosen, opts, &s0);
            let sd_logk = prep.log_rate_sds(raw, opts);
            match collapse_reason(raw, sd_logk.as_deref()) {
                Some(flag) => {
                    flags.push(flag);
                    chosen -= 1;
                }
                None => break,
            }
        }
    }
    let raw = prep.exact_fit(&mut raws, &mut exact, chosen, opts, &s0);
    if raw.a.iter().all(|a| *a <= 0.0) && raw.c.iter().flatten().all(|a| *a <= 0.0) {
        return Err(Error::Numerical {
            what: "decay fit".into(),
            reason: "no decaying component found: every amplitude is zero (is the curve \
                     rising or flat rather than decaying?)"
                .into(),
        });
    }
    Ok(prep.finish(raw, opts, candidates, flags))
}

impl Prepared<'_> {
    /// The n-state fit from [`Self::fit_n`], kept monotone: a larger model never fits worse
    /// than the smaller one nested in it (`prev`, n − 1 states).
    fn fit_monotone(
        &self,
        n: usize,
        prev: Option<&RawFit>,
        optional: bool,
        opts: &DecayFitOptions,
        s0: &[f64],
    ) -> RawFit {
        let mut r = self.fit_n(n, prev.map(|p| (&p.theta[..], p.rss)), optional, opts, s0);
        if let Some(p) = prev {
            if r.rss > p.rss * (1.0 + 1e-9) {
                let mut alt = p.theta.clone();
                alt.push(p.theta.iter().cloned().fold(f64::INFINITY, f64::min) - 3.0);
                let r2 = self.fit_from(n, &alt, opts, s0);
                if r2.rss < r.rss {
                    r = r2;
                }
            }
        }
        r
    }

    /// The n-state fit to the full tolerance of `opts`: fitted now (with the counts below it
    /// that seed it) if it was skipped, continued from its end if it was a loose seed fit.
    fn exact_fit<'r>(
        &self,
        raws: &'r mut [Option<RawFit>],
        exact: &mut [bool],
        n: usize,
        opts: &DecayFitOptions,
        s0: &[f64],
    ) -> &'r RawFit {
        for k in 1..=n {
            if raws[n - 1].is_none() && raws[k - 1].is_none() {
                let prev = raws[..k - 1].last().and_then(Option::as_ref);
                let r = self.fit_monotone(k, prev, false, opts, s0);
                raws[k - 1] = Some(r);
                exact[k - 1] = true;
            }
        }
        // (always filled by the loop above; the fall-back only keeps this total)
        let raw = raws[n - 1].get_or_insert_with(|| self.fit_monotone(n, None, false, opts, s0));
        if !exact[n - 1] {
            exact[n - 1] = true;
            let r = self.fit_from(raw.theta.len(), &raw.theta, opts, s0);
            if r.rss <= raw.rss || !raw.rss.is_finite() {
                *raw = r;
            }
        }
        raw
    }

    /// Standard deviations of ln k for the collapse rule (τ time base).
    fn log_rate_sds(&self, raw: &RawFit, opts: &DecayFitOptions) -> Option<Vec<f64>> {
        let ks: Vec<f64> = raw.theta.iter().map(|t| t.exp()).collect();
        let c_abs: Vec<Vec<f64>> = raw
            .c
            .iter()
            .zip(&ks)
            .map(|(c, k)| c.iter().map(|v| v * (k * self.t0).exp()).collect())
            .collect();
        let shared = self.n_ch == 1 || opts.amplitudes == AmplitudeModel::SharedSpectrum;
        let (spec, a_abs): (Vec<f64>, Vec<f64>) = if shared {
            let smax = raw
                .s
                .iter()
                .cloned()
                .fold(0.0_f64, f64::max)
                .max(f64::MIN_POSITIVE);
            (
                raw.s.iter().map(|v| v / smax).collect(),
                raw.a
                    .iter()
                    .zip(&ks)
                    .map(|(a, k)| a * smax * (k * self.t0).exp())
                    .collect(),
            )
        } else {
            (
                vec![1.0; self.n_ch],
                c_abs
                    .iter()
                    .map(|v| v.iter().cloned().fold(0.0_f64, f64::max))
                    .collect(),
            )
        };
        let (sk, _) = self.uncertainties(&ks, &c_abs, &a_abs, &spec, opts, raw.rss)?;
        Some(sk.iter().zip(&ks).map(|(s, k)| s / k).collect())
    }
}

/// Re-radiation functions of §4.5: Λ_i = a_i Λ* / k_r,i for every state, with `spectrum` the
/// emission spectrum Λ* on the target bands (max 1), assuming saturation (r_i(0) = 1) at
/// switch-off. Returns (k_r, Λ_i) per state.
pub fn reradiation_functions(fit: &DecayFit, spectrum: &[f64]) -> Vec<(f64, Vec<f64>)> {
    fit.states
        .iter()
        .map(|s| {
            (
                s.k_per_s,
                spectrum
                    .iter()
                    .map(|l| s.amplitude * l / s.k_per_s)
                    .collect(),
            )
        })
        .collect()
}

/// Per-channel re-radiation functions on the data's own channels (bands "rgb"):
/// Λ_i[c] = a_ic / k_r,i.
pub fn reradiation_functions_rgb(fit: &DecayFit) -> Vec<(f64, Vec<f64>)> {
    fit.states
        .iter()
        .map(|s| {
            (
                s.k_per_s,
                s.channel_amplitudes.iter().map(|a| a / s.k_per_s).collect(),
            )
        })
        .collect()
}

/// Band averages of a sampled spectrum over `bands_nm`, normalised to a maximum of 1
/// (trapezoidal, linear interpolation; zero outside the sampled range).
pub fn band_spectrum(
    wavelengths_nm: &[f64],
    values: &[f64],
    bands_nm: &[[f64; 2]],
) -> Result<Vec<f64>> {
    if wavelengths_nm.len() < 2 || wavelengths_nm.len() != values.len() {
        return Err(Error::invalid(
            "spectrum",
            "expected at least two samples with one value each",
        ));
    }
    let n0 = wavelengths_nm.len();
    let mut out = Vec::with_capacity(bands_nm.len());
    for [lo, hi] in bands_nm {
        let n = ((hi - lo).ceil() as usize).clamp(8, 4096);
        let mut s = 0.0;
        for k in 0..=n {
            let x = lo + (hi - lo) * k as f64 / n as f64;
            let v = if x < wavelengths_nm[0] || x > wavelengths_nm[n0 - 1] {
                0.0
            } else {
                crate::math::interpolation::linear_at(wavelengths_nm, values, x)
            };
            s += if k == 0 || k == n { 0.5 * v } else { v };
        }
        out.push(s / n as f64);
    }
    let mx = out.iter().cloned().fold(0.0_f64, f64::max);
    if !(mx > 0.0) {
        return Err(Error::invalid(
            "spectrum",
            "the emission spectrum is zero over every band; expected a positive emission",
        ));
    }
    Ok(out.into_iter().map(|v| (v / mx).max(0.0)).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Noise-free sums of exponentials: Prony's estimate is exact up to rounding.
    const PRONY_EXACT: f64 = 1e-6;

    fn curve(rates: &[f64], background: f64) -> DecayCurve {
        let t: Vec<f64> = (0..37).map(|i| 10.0 + 5.0 * i as f64).collect();
        let ch = (0..3)
            .map(|c| {
                t.iter()
                    .map(|ti| {
                        rates
                            .iter()
                            .enumerate()
                            .map(|(j, k)| (1.0 + j as f64 + 0.3 * c as f64) * (-k * ti).exp())
                            .sum::<f64>()
                            + background
                    })
                    .collect()
            })
            .collect();
        DecayCurve::new(t, ch, None).unwrap()
    }

    #[test]
    fn prony_start_recovers_the_rates_of_noise_free_sums_of_exponentials() {
        for (rates, bg) in [
            (&[0.2, 0.03][..], 0.0),
            (&[0.2, 0.03][..], 0.05),
            (&[0.5, 0.1, 0.02][..], 0.0),
        ] {
            let c = curve(rates, bg);
            let prep = Prepared::new(&c);
            let theta = prep.prony_start(rates.len(), bg != 0.0).unwrap();
            for (th, k) in theta.iter().zip(rates) {
                assert!(
                    (th.exp() / k - 1.0).abs() < PRONY_EXACT,
                    "{theta:?} vs {rates:?}"
                );
            }
        }
    }

    #[test]
    fn prony_start_declines_growth_and_complex_roots() {
        // a rising curve: the root is above 1
        let t: Vec<f64> = (0..20).map(|i| i as f64).collect();
        let rising = DecayCurve::new(
            t.clone(),
            vec![t.iter().map(|x| (0.05 * x).exp()).collect()],
            None,
        )
        .unwrap();
        assert!(Prepared::new(&rising).prony_start(1, false).is_none());
        // a damped oscillation, e^{(−0.1 ± 1.3i) t} / 2: complex roots
        let osc = DecayCurve::new(
            t.clone(),
            vec![t
                .iter()
                .map(|x| (-0.1 * x).exp() * (1.3 * x).cos())
                .collect()],
            None,
        )
        .unwrap();
        assert!(Prepared::new(&osc).prony_start(2, false).is_none());
    }

    #[test]
    fn cubic_roots_are_the_three_real_roots() {
        // (z − 0.9)(z − 0.5)(z − 0.1) = z³ − 1.5 z² + 0.59 z − 0.045
        let mut r = real_roots(&[1.5, -0.59, 0.045]).unwrap();
        r.sort_by(f64::total_cmp);
        for (got, want) in r.iter().zip([0.1, 0.5, 0.9]) {
            assert!((got - want).abs() < 1e-12, "{r:?}");
        }
        // z³ − z² + z − 1 = (z − 1)(z² + 1): two complex roots
        assert!(real_roots(&[1.0, -1.0, 1.0]).is_none());
    }

    #[test]
    fn fixed_two_state_fit_matches_the_fit_through_the_nested_one_state_seed() {
        let c = curve(&[0.2, 0.03], 0.0);
        let opts = DecayFitOptions {
            states: StatesChoice::Fixed(2),
            collapse: false,
            ..DecayFitOptions::default()
        };
        let fast = fit_decay(&c, &opts).unwrap();
        // the same minimum reached the long way: the one-state fit, then its nested start
        let prep = Prepared::new(&c);
        let s0 = prep.initial_spectrum();
        let one = prep.fit_n(1, None, false, &opts, &s0);
        let mut st = one.theta.clone();
        st.push(one.theta[0] - 1.5);
        let slow = prep.fit_from(2, &st, &opts, &s0);
        let mut k: Vec<f64> = slow.theta.iter().map(|t| t.exp()).collect();
        k.sort_by(|a, b| b.total_cmp(a));
        for (s, k) in fast.states.iter().zip(&k) {
            assert!((s.k_per_s / k - 1.0).abs() < 1e-8, "{} vs {k}", s.k_per_s);
        }
    }
}
