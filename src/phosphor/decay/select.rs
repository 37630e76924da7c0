//! The number of states: BIC selection, the acceptance and degeneracy tests, the collapse rule
//! and [`fit_decay`], the entry point.

#![allow(clippy::needless_range_loop, clippy::neg_cmp_op_on_partial_ord)]

use super::*;

impl Prepared<'_> {
    /// Whether a fit from the first start can be accepted without trying the others: converged,
    /// every state with a positive amplitude, rates distinct and in a plausible range, and a
    /// better fit than the nested model with one state fewer.
    pub(super) fn acceptable(&self, r: &RawFit, prev_rss: Option<f64>) -> bool {
        r.termination.converged()
            && r.rss.is_finite()
            && !self.degenerate(r)
            && prev_rss.is_none_or(|p| r.rss < p)
    }

    /// Whether a fit's states are degenerate — in effect a fit with fewer states: a state's
    /// amplitude is (nearly) zero, two rates coincide, or a rate is outside the plausible range
    /// by more than e³ (gone before the second sample, or constant over the record).
    pub(super) fn degenerate(&self, r: &RawFit) -> bool {
        if !r.rss.is_finite() {
            return false;
        }
        let (lo, hi) = self.log_rate_range();
        if r.theta
            .iter()
            .any(|t| !(*t >= lo - DEGENERATE_LOG_MARGIN && *t <= hi + DEGENERATE_LOG_MARGIN))
        {
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
    pub(super) fn fit_n(
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
            let th = self.log_linear_start();
            first_starts.push(vec![if opts.background {
                th
            } else {
                self.one_state_refined_start(th)
            }]);
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

    pub(super) fn n_params(&self, raw: &RawFit, opts: &DecayFitOptions) -> usize {
        self.n_params_of(raw.theta.len(), opts)
    }

    /// Number of fitted parameters of an n-state model.
    pub(super) fn n_params_of(&self, n: usize, opts: &DecayFitOptions) -> usize {
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
}

/// Collapse check of one fit: returns the flag that requires removing a state, if any.
pub(super) fn collapse_reason(raw: &RawFit, sd_logk: Option<&[f64]>) -> Option<DecayFlag> {
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
/// With the shared-spectrum model (the default), the largest optional candidate (three states
/// in the default automatic mode) seeds no other
/// fit, so it is first fitted to the seed tolerance (`SEED_FTOL`) only, and continued to the
/// full tolerance (fitted again from the same starts, exactly as without the shortcut) only when
/// its BIC comes within `PROVISIONAL_BIC_MARGIN` (2) of the best other candidate's. Otherwise it
/// is taken as not selectable: the full fit from the same start follows the same iterations
/// further and lowers the RSS by far less than the margin needs (≈ 1.8 % of the RSS for 111
/// observations) — an empirical argument, not a proof (a multi-start at the full tolerance
/// could find another minimum); `tests/decay_decisions.rs` checks it on the fixture and on an
/// independent seed. Its entry in [`DecayFit::candidates`] is then the loose fit. Neither is it
/// continued when it already wins on BIC and the collapse rule removes a state of it beyond
/// doubt (`Prepared::decisive_collapse`: singular covariance or σ(ln k) > 10): the result is
/// then the same fewer-state fit, with a `state_dropped` flag whose rate is the loose fit's.
///
/// # Errors
/// [`Error::InvalidArgument`] for an invalid number of states; [`Error::Numerical`] when no
/// decaying component is found (all amplitudes zero). Non-convergence is reported in the flags.
pub fn fit_decay(curve: &DecayCurve, opts: &DecayFitOptions) -> Result<DecayFit> {
    fit_decay_with(curve, opts, true, SharedSolve::Alternation)
}

/// [`fit_decay`] without the report's standard deviations of the selected fit (the
/// `k_sigma_per_s` / `amplitude_sigma` fields are `None`, and neither the
/// `RatePoorlyDetermined` nor the `SingularCovariance` flag is raised): the same states,
/// spectrum, RSS and decisions. For per-pixel maps, which keep only those (3 % of their time
/// went to the unused covariance).
pub(crate) fn fit_decay_values(curve: &DecayCurve, opts: &DecayFitOptions) -> Result<DecayFit> {
    fit_decay_with_report(curve, opts, true, SharedSolve::Alternation, false)
}

/// [`fit_decay`] with every shared-spectrum fit of n ≥ 2 states by one round of the
/// alternation followed by one joint Levenberg–Marquardt solve over rates, amplitudes, spectrum
/// and background (the alternation continues where that optimum is not interior). The same
/// decisions on the fixture and on an independent seed, but it was not faster than the
/// alternation alone in the one measured run (fewer separable solves, each joint iteration
/// ≈ 10× the cost of one), so it is kept behind this entry point for tests and the bench
/// (docs/performance.md, issue 18 fourth round). Not for general use.
#[doc(hidden)]
pub fn fit_decay_joint(curve: &DecayCurve, opts: &DecayFitOptions) -> Result<DecayFit> {
    fit_decay_with(curve, opts, true, SharedSolve::Joint)
}

/// [`fit_decay`] with every shared-spectrum fit of n ≥ 2 states by one variable-projection
/// solve over the rates (the alternation only where that optimum is infeasible). The same
/// decisions on the fixture, but measured slower than the default alternation, so kept behind
/// this entry point for tests and the bench (docs/performance.md, issue 18). Not for general use.
#[doc(hidden)]
pub fn fit_decay_projected(curve: &DecayCurve, opts: &DecayFitOptions) -> Result<DecayFit> {
    fit_decay_with(curve, opts, true, SharedSolve::Projected)
}

/// [`fit_decay`] with every candidate fitted to the full tolerance (no provisional fit of the
/// largest optional candidate): the algorithm before that shortcut, kept so that tests can
/// check on independent curves that the shortcut changes no decision. Not for general use.
#[doc(hidden)]
pub fn fit_decay_full_tolerance(curve: &DecayCurve, opts: &DecayFitOptions) -> Result<DecayFit> {
    fit_decay_with(curve, opts, false, SharedSolve::Alternation)
}

/// BIC margin within which a provisional (seed-tolerance) top candidate is continued to the
/// full tolerance before the selection (see [`fit_decay`]).
pub(super) const PROVISIONAL_BIC_MARGIN: f64 = 2.0;

/// σ(ln k) beyond which a provisional candidate's collapse is taken as decided without the
/// full-tolerance fit ([`Prepared::decisive_collapse`]): ten times the collapse rule's 1.
pub(super) const DECISIVE_LOG_RATE_SD: f64 = 10.0;

fn fit_decay_with(
    curve: &DecayCurve,
    opts: &DecayFitOptions,
    provisional_top: bool,
    shared_solve: SharedSolve,
) -> Result<DecayFit> {
    fit_decay_with_report(curve, opts, provisional_top, shared_solve, true)
}

fn fit_decay_with_report(
    curve: &DecayCurve,
    opts: &DecayFitOptions,
    provisional_top: bool,
    shared_solve: SharedSolve,
    sds: bool,
) -> Result<DecayFit> {
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
    let mut prep = Prepared::new(curve);
    prep.shared_solve = shared_solve;
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
    let mut screened = None;
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
        // the largest optional candidate seeds nothing: provisional, to the seed tolerance
        // (shared-spectrum model only: with per-channel amplitudes it changed the flag lists
        // of 2 + 2 of 300 curves, where the full-tolerance multi-start found another minimum)
        let provisional = provisional_top
            && n == hi
            && n > lo
            && (prep.n_ch == 1 || opts.amplitudes == AmplitudeModel::SharedSpectrum);
        // the largest optional candidate is fitted only if one more state could gain what BIC
        // requires of it (`screen`): otherwise it is recorded as screened, not fitted
        if n == hi && n > lo {
            if let Some(ratio) = raws[n - 2]
                .as_ref()
                .and_then(|p| prep.screen_ratio(p, opts))
            {
                if ratio < SCREEN_RATIO {
                    screened = Some(ScreenedCandidate {
                        n_states: n,
                        gain_ratio: ratio,
                    });
                    break;
                }
            }
        }
        let o = if n < lo || provisional {
            &seed_opts
        } else {
            opts
        };
        let r = prep.fit_monotone(
            n,
            raws[..n - 1].last().and_then(Option::as_ref),
            n > lo,
            o,
            &s0,
        );
        raws[n - 1] = Some(r);
        exact[n - 1] = n >= lo && !provisional;
    }
    let candidate = |r: &RawFit| {
        let mut k: Vec<f64> = r.theta.iter().map(|t| t.exp()).collect();
        k.sort_by(|a, b| b.total_cmp(a));
        Candidate {
            n_states: r.theta.len(),
            bic: bic(r.rss, n_obs, prep.n_params(r, opts)),
            rss: r.rss,
            k_per_s: k,
            termination: r.termination,
        }
    };
    let mut candidates: Vec<Candidate> = raws
        .iter()
        .flatten()
        .filter(|r| r.theta.len() >= lo)
        .map(candidate)
        .collect();
    if !exact[hi - 1] {
        // the provisional top candidate: continued to the full tolerance only when it could
        // come near the best of the others (NaN or no other finite BIC: continued)
        let best_other = candidates
            .iter()
            .filter(|c| c.n_states != hi && c.bic.is_finite())
            .map(|c| c.bic)
            .fold(f64::INFINITY, f64::min);
        if let Some(pos) = candidates.iter().position(|c| c.n_states == hi) {
            // … unless it already wins and the collapse rule removes it beyond doubt: then the
            // full-tolerance fit could only end in the same flag (see `decisive_collapse`)
            let wins = candidates[pos].bic < best_other;
            if wins
                && opts.collapse
                && raws[hi - 1]
                    .as_ref()
                    .is_some_and(|r| prep.decisive_collapse(r, opts))
            {
                exact[hi - 1] = true;
            } else if !(candidates[pos].bic > best_other + PROVISIONAL_BIC_MARGIN) {
                // fitted again exactly as without the shortcut (the same starts, acceptance
                // tests and multi-start at the full tolerance), not continued from the loose
                // end: a continuation skips the acceptance tests and can end elsewhere
                let r = prep.fit_monotone(hi, raws[hi - 2].as_ref(), true, opts, &s0);
                candidates[pos] = candidate(&r);
                raws[hi - 1] = Some(r);
                exact[hi - 1] = true;
            }
        }
    }
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
    let mut fit = prep.finish(raw, opts, candidates, flags, sds);
    fit.screened = screened;
    Ok(fit)
}

impl Prepared<'_> {
    /// The n-state fit from [`Self::fit_n`], kept monotone: a larger model never fits worse
    /// than the smaller one nested in it (`prev`, n − 1 states).
    pub(super) fn fit_monotone(
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
    pub(super) fn exact_fit<'r>(
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

    /// Whether the collapse rule removes a state of this (provisional) fit beyond doubt: its
    /// covariance is singular (a rate gone to the edge of the range, whose column no longer
    /// reaches the data) or a rate's σ(ln k) exceeds [`DECISIVE_LOG_RATE_SD`], ten times the
    /// rule's threshold of 1. The full-tolerance fit goes on along the same path — such a rate
    /// runs further away, typically a fast state that has become a spike at the first sample —
    /// and the rule drops a state of it too (`StateDropped`; measured on every continued
    /// candidate of the scipy script's 1000 curves, docs/performance.md, ninth round), so
    /// continuing it would cost the most iterations of the whole fit for the same decision.
    pub(super) fn decisive_collapse(&self, raw: &RawFit, opts: &DecayFitOptions) -> bool {
        if raw.theta.len() < 2 {
            return false;
        }
        match self.log_rate_sds(raw, opts) {
            None => true,
            Some(sd) => sd.iter().any(|s| !(*s <= DECISIVE_LOG_RATE_SD)),
        }
    }

    /// Standard deviations of ln k for the collapse rule (τ time base).
    pub(super) fn log_rate_sds(&self, raw: &RawFit, opts: &DecayFitOptions) -> Option<Vec<f64>> {
        if self.n_ch > 1 && opts.amplitudes == AmplitudeModel::SharedSpectrum {
            return self.log_rate_sds_projected(raw, opts);
        }
        self.log_rate_sds_full(raw, opts)
    }

    /// [`Self::log_rate_sds`] from the covariance over every parameter.
    pub(super) fn log_rate_sds_full(
        &self,
        raw: &RawFit,
        opts: &DecayFitOptions,
    ) -> Option<Vec<f64>> {
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

    /// [`Self::log_rate_sds`] of a shared-spectrum fit from the projected curve alone. In the
    /// Jacobian over (k, a, Λ*, b) of [`Self::uncertainties`] the columns of the rates lie in
    /// the space x ⊗ s (s the unit spectrum), and every other column splits into a part there
    /// (e_j ⊗ s, 1 ⊗ s) and a part in x ⊗ s⊥, orthogonal to it. So the rates' block of the
    /// covariance is that of the m-row Jacobian [−τ a_j e_j, e_j, 1] of the curve Y s, with the
    /// full model's σ² = RSS/(N − p): the same numbers from a Jacobian n_ch times shorter and
    /// without the spectrum's columns. `None` when that Jacobian is singular.
    pub(super) fn log_rate_sds_projected(
        &self,
        raw: &RawFit,
        opts: &DecayFitOptions,
    ) -> Option<Vec<f64>> {
        let (m, nc) = (self.m, self.n_ch);
        let n = raw.theta.len();
        let mut ex = Vec::with_capacity(n * m);
        self.exp_table(&raw.theta, &mut ex);
        let sw = |i: usize| self.sqrt_w.as_ref().map_or(1.0, |w| w[i]);
        let live: Vec<usize> = (0..n).filter(|j| raw.a[*j] > 0.0).collect();
        let mut jac = Vec::with_capacity(m * (2 * live.len() + 1));
        for &j in &live {
            let e = &ex[j * m..(j + 1) * m];
            jac.extend((0..m).map(|i| -self.tau[i] * raw.a[j] * e[i] * sw(i)));
        }
        for &j in &live {
            let e = &ex[j * m..(j + 1) * m];
            jac.extend((0..m).map(|i| e[i] * sw(i)));
        }
        if opts.background {
            jac.extend((0..m).map(sw));
        }
        let p1 = jac.len() / m;
        // the full model's parameter count: rates, amplitudes, the spectrum's free channels
        // (all positive ones but the largest, which is fixed at 1) and the backgrounds
        let free_spectrum = raw.s.iter().filter(|v| **v > 0.0).count().saturating_sub(1);
        let p = 2 * live.len() + free_spectrum + if opts.background { nc } else { 0 };
        let rows = m * nc;
        if rows <= p || p1 == 0 {
            return None;
        }
        let inv = crate::fit::stats::inverse_gram(&jac, m, p1)?;
        let s2 = raw.rss / (rows - p) as f64;
        let mut out = vec![0.0; n];
        for (q, &j) in live.iter().enumerate() {
            out[j] = (inv[q * p1 + q] * s2).max(0.0).sqrt() / raw.theta[j].exp();
        }
        Some(out)
    }
}
