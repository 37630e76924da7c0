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

/// Three channels s_c Σ_j a_j e^{−k_j t_i}, each value passed through `sample(i, c, value)`.
fn shared_samples(
    t: Vec<f64>,
    s: [f64; 3],
    amps: &[f64],
    rates: &[f64],
    sample: impl Fn(usize, usize, f64) -> f64,
) -> DecayCurve {
    let ch = (0..3)
        .map(|c| {
            t.iter()
                .enumerate()
                .map(|(i, ti)| {
                    let f: f64 = amps
                        .iter()
                        .zip(rates)
                        .map(|(a, k)| a * (-k * ti).exp())
                        .sum();
                    sample(i, c, s[c] * f)
                })
                .collect()
        })
        .collect();
    DecayCurve::new(t, ch, None).unwrap()
}

/// A shared-spectrum curve s_c (Σ_j a_j e^{−k_j t}) + b_c with a deterministic ±0.5 % ripple.
fn shared_curve(amps: &[f64], rates: &[f64], background: f64) -> DecayCurve {
    let t: Vec<f64> = (0..41).map(|i| 2.0 * i as f64).collect();
    shared_samples(t, [0.9, 0.5, 0.2], amps, rates, |i, c, v| {
        let ripple = 1.0 + 0.005 * ((7 * i + 3 * c) as f64).sin();
        v * ripple + background * (1.0 + 0.1 * c as f64)
    })
}

#[test]
fn projected_shared_spectrum_fit_reaches_the_alternations_optimum() {
    for bg in [false, true] {
        let c = shared_curve(&[2.0, 1.0], &[0.2, 0.03], if bg { 0.05 } else { 0.0 });
        let opts = DecayFitOptions {
            background: bg,
            ..DecayFitOptions::default()
        };
        let mut prep = Prepared::new(&c);
        let s0 = prep.initial_spectrum();
        let start = [(0.1_f64).ln(), (0.01_f64).ln()];
        let proj = Projected::new(&prep, 2, bg, &s0)
            .fit(&start, &opts.solver)
            .expect("the optimum is feasible");
        prep.shared_solve = SharedSolve::Alternation;
        let alt = prep.fit_from(2, &start, &opts, &s0);
        assert!(proj.termination.converged() && alt.termination.converged());
        for (p, a) in proj.theta.iter().zip(&alt.theta) {
            assert!((p - a).abs() < 1e-5, "{:?} vs {:?}", proj.theta, alt.theta);
        }
        assert!(
            proj.rss <= alt.rss * (1.0 + 1e-8),
            "rss {} vs {}",
            proj.rss,
            alt.rss
        );
        for (p, a) in proj.s.iter().zip(&alt.s) {
            assert!((p - a).abs() < 1e-5, "{:?} vs {:?}", proj.s, alt.s);
        }
        for (p, a) in proj.background.iter().zip(&alt.background) {
            assert!(
                (p - a).abs() < 1e-4,
                "{:?} vs {:?}",
                proj.background,
                alt.background
            );
        }
    }
}

#[test]
fn projected_fit_declines_an_optimum_with_a_negative_amplitude() {
    // a rise-and-decay (one negative amplitude) cannot be a non-negative sum of decays
    let c = shared_curve(&[2.0, -1.5], &[0.03, 0.2], 0.0);
    let prep = Prepared::new(&c);
    let s0 = prep.initial_spectrum();
    let start = [(0.03_f64).ln(), (0.2_f64).ln()];
    let opts = DecayFitOptions::default();
    assert!(Projected::new(&prep, 2, false, &s0)
        .fit(&start, &opts.solver)
        .is_none());
}

#[test]
fn joint_shared_spectrum_solve_reaches_the_alternations_optimum() {
    for bg in [false, true] {
        let c = shared_curve(&[2.0, 1.0], &[0.2, 0.03], if bg { 0.05 } else { 0.0 });
        let opts = DecayFitOptions {
            background: bg,
            ..DecayFitOptions::default()
        };
        let mut prep = Prepared::new(&c);
        let s0 = prep.initial_spectrum();
        let start = [(0.1_f64).ln(), (0.01_f64).ln()];
        prep.shared_solve = SharedSolve::Joint;
        let joint = prep.fit_from(2, &start, &opts, &s0);
        prep.shared_solve = SharedSolve::Alternation;
        let alt = prep.fit_from(2, &start, &opts, &s0);
        assert!(joint.termination.converged() && alt.termination.converged());
        for (p, a) in joint.theta.iter().zip(&alt.theta) {
            assert!((p - a).abs() < 1e-6, "{:?} vs {:?}", joint.theta, alt.theta);
        }
        assert!(
            (joint.rss - alt.rss).abs() <= 1e-9 * alt.rss,
            "rss {} vs {}",
            joint.rss,
            alt.rss
        );
        for (p, a) in joint.s.iter().zip(&alt.s) {
            assert!((p - a).abs() < 1e-6, "{:?} vs {:?}", joint.s, alt.s);
        }
        for (p, a) in joint.a.iter().zip(&alt.a) {
            assert!((p / a - 1.0).abs() < 1e-5, "{:?} vs {:?}", joint.a, alt.a);
        }
        for (p, a) in joint.background.iter().zip(&alt.background) {
            assert!(
                (p - a).abs() < 1e-5,
                "{:?} vs {:?}",
                joint.background,
                alt.background
            );
        }
    }
}

#[test]
fn joint_solve_declines_an_optimum_with_a_negative_amplitude_and_the_alternation_takes_over() {
    // a rise-and-decay: the joint optimum puts an amplitude on its bound, so the result is the
    // alternation's (bit for bit)
    let c = shared_curve(&[2.0, -1.5], &[0.03, 0.2], 0.0);
    let mut prep = Prepared::new(&c);
    let s0 = prep.initial_spectrum();
    let start = [(0.03_f64).ln(), (0.2_f64).ln()];
    let opts = DecayFitOptions::default();
    prep.shared_solve = SharedSolve::Joint;
    let joint = prep.fit_from(2, &start, &opts, &s0);
    prep.shared_solve = SharedSolve::Alternation;
    let alt = prep.fit_from(2, &start, &opts, &s0);
    assert_eq!(joint.theta, alt.theta);
    assert_eq!(joint.rss, alt.rss);
}

/// A shared-spectrum curve with additive pseudo-random noise of standard deviation ≈ `sd`
/// (a deterministic hash of the sample index, so the test is reproducible).
fn noisy_shared_curve(amps: &[f64], rates: &[f64], sd: f64) -> DecayCurve {
    let t: Vec<f64> = (0..37).map(|i| 5.0 * i as f64).collect();
    shared_samples(t, [0.3, 0.9, 0.4], amps, rates, |i, c, v| {
        let h = ((i * 3 + c) as f64 * 12.9898 + 4.1).sin() * 43758.5453;
        // uniform on (−0.5, 0.5) has sd 1/√12
        v + sd * 12f64.sqrt() * (h - h.floor() - 0.5)
    })
}

#[test]
fn the_screen_predicts_the_gain_of_a_third_state_and_skips_it_only_when_it_cannot_win() {
    let opts = DecayFitOptions::default();
    let n_obs = (37 * 3) as f64;
    let needed_fraction = 1.0 - (-2.0 * n_obs.ln() / n_obs).exp();
    // two states and noise: the third state only fits noise
    let c = noisy_shared_curve(&[1.0, 0.5], &[0.227, 0.0454], 0.004);
    let prep = Prepared::new(&c);
    let fixed = |n| DecayFitOptions {
        states: StatesChoice::Fixed(n),
        collapse: false,
        ..DecayFitOptions::default()
    };
    let two = fit_decay(&c, &fixed(2)).unwrap();
    let three = fit_decay(&c, &fixed(3)).unwrap();
    let s0 = prep.initial_spectrum();
    let raw2 = prep.fit_n(2, None, false, &opts, &s0);
    let ratio = prep.screen_ratio(&raw2, &opts).unwrap();
    let predicted = ratio * needed_fraction * raw2.rss;
    let actual = two.rss - three.rss;
    assert!(
        (predicted / actual - 1.0).abs() < 0.25,
        "linearised gain {predicted:e} against the fitted third state's {actual:e}"
    );
    let auto = fit_decay(&c, &opts).unwrap();
    assert_eq!(auto.states.len(), 2);
    let sc = auto
        .screened
        .expect("the three-state candidate is screened");
    assert_eq!(sc.n_states, 3);
    assert!(sc.gain_ratio < SCREEN_RATIO, "{sc:?}");
    assert!(auto.candidates.iter().all(|c| c.n_states < 3));
    // three well-separated states: the screen lets the candidate through and it is chosen
    let c3 = noisy_shared_curve(&[1.0, 0.6, 0.4], &[0.5, 0.08, 0.012], 0.002);
    let auto3 = fit_decay(&c3, &opts).unwrap();
    let prep3 = Prepared::new(&c3);
    let raw3 = prep3.fit_n(2, None, false, &opts, &prep3.initial_spectrum());
    let ratio3 = prep3.screen_ratio(&raw3, &opts).unwrap();
    assert!(ratio3 > 2.0, "{ratio3}");
    assert!(auto3.screened.is_none(), "{:?}", auto3.screened);
    assert_eq!(auto3.states.len(), 3, "{:?}", auto3.candidates);
}

#[test]
fn rate_sds_of_the_projected_curve_equal_those_of_the_full_covariance() {
    for (amps, rates, bg) in [
        (&[2.0, 1.0][..], &[0.2, 0.03][..], 0.0),
        (&[2.0, 1.0][..], &[0.2, 0.03][..], 0.05),
        (&[1.0, 0.6, 0.4][..], &[0.5, 0.08, 0.012][..], 0.0),
        (&[3.0][..], &[0.1][..], 0.02),
    ] {
        let c = shared_curve(amps, rates, bg);
        let opts = DecayFitOptions {
            background: bg != 0.0,
            ..DecayFitOptions::default()
        };
        let prep = Prepared::new(&c);
        let raw = prep.fit_n(rates.len(), None, false, &opts, &prep.initial_spectrum());
        let full = prep.log_rate_sds_full(&raw, &opts).unwrap();
        let proj = prep.log_rate_sds_projected(&raw, &opts).unwrap();
        for (f, p) in full.iter().zip(&proj) {
            assert!(
                (p / f - 1.0).abs() < 1e-8,
                "{rates:?} bg {bg}: {proj:?} vs {full:?}"
            );
        }
    }
}

#[test]
fn the_refined_one_state_start_is_the_separable_fits_optimum() {
    // one exact state: the rate itself
    let c = curve(&[0.11], 0.0);
    let prep = Prepared::new(&c);
    let th = prep.one_state_refined_start(prep.log_linear_start());
    assert!((th.exp() / 0.11 - 1.0).abs() < 1e-9, "{}", th.exp());
    // two states seen as one (Gauss–Newton converges only linearly here): the refined start is
    // the optimum of the separable fit — stationary, kept by the fit started there, and at least
    // as good as where the fit from the log-linear start stops (its ftol leaves θ ~1e-6 off)
    let opts = DecayFitOptions::default();
    for c in [
        shared_curve(&[2.0, 1.0], &[0.2, 0.03], 0.0),
        noisy_shared_curve(&[1.0, 0.5], &[0.227, 0.0454], 0.004),
    ] {
        let prep = Prepared::new(&c);
        let s0 = prep.initial_spectrum();
        let th0 = prep.log_linear_start();
        let th = prep.one_state_refined_start(th0);
        let mut e = Vec::new();
        let (_, g1, g2) = prep.one_state_gain(th, &mut e);
        assert!(g2 < 0.0 && (g1 / g2).abs() < 1e-6, "G' {g1}, G'' {g2}");
        let from_refined = prep.fit_from(1, &[th], &opts, &s0);
        assert!(
            (from_refined.theta[0] - th).abs() < 1e-9,
            "{th} → {:?}",
            from_refined.theta
        );
        let from_log_linear = prep.fit_from(1, &[th0], &opts, &s0);
        assert!((th - from_log_linear.theta[0]).abs() < 1e-5);
        assert!(
            from_refined.rss <= from_log_linear.rss * (1.0 + 1e-12),
            "{} vs {}",
            from_refined.rss,
            from_log_linear.rss
        );
    }
}

#[test]
fn a_spike_at_the_first_sample_is_dropped_without_the_full_tolerance_refit_and_as_with_it() {
    // two states, noise, and a first sample 4 % high in every channel: a third, fast state
    // fits that sample alone and wins on BIC; its rate runs away, so the collapse rule drops it
    let t: Vec<f64> = (0..37).map(|i| 5.0 * i as f64).collect();
    let c = shared_samples(
        t,
        [0.3, 0.9, 0.4],
        &[1.0, 0.5],
        &[0.227, 0.0454],
        |i, c, v| {
            let h = ((i * 3 + c) as f64 * 12.9898 + 4.1).sin() * 43758.5453;
            let noisy = v + 0.002 * 12f64.sqrt() * (h - h.floor() - 0.5);
            if i == 0 {
                noisy * 1.04
            } else {
                noisy
            }
        },
    );
    let opts = DecayFitOptions::default();
    let prep = Prepared::new(&c);
    let s0 = prep.initial_spectrum();
    let seed = DecayFitOptions {
        solver: SolverOptions {
            ftol: SEED_FTOL,
            xtol: SEED_XTOL,
            ..opts.solver
        },
        ..opts
    };
    let two = prep.fit_n(2, None, false, &opts, &s0);
    let provisional = prep.fit_monotone(3, Some(&two), true, &seed, &s0);
    let n_obs = 37 * 3;
    assert!(
        bic(provisional.rss, n_obs, prep.n_params(&provisional, &opts))
            < bic(two.rss, n_obs, prep.n_params(&two, &opts)),
        "the spike must win on BIC for this test: {provisional:?}"
    );
    assert!(
        prep.decisive_collapse(&provisional, &opts),
        "{provisional:?}"
    );
    let auto = fit_decay(&c, &opts).unwrap();
    let full = fit_decay_full_tolerance(&c, &opts).unwrap();
    let names = |f: &DecayFit| f.flags.iter().map(|x| x.name()).collect::<Vec<_>>();
    assert_eq!(auto.states.len(), 2);
    assert_eq!(full.states.len(), 2);
    assert_eq!(names(&auto), names(&full));
    assert!(names(&auto).contains(&"state_dropped"), "{:?}", auto.flags);
    // the same two-state result; only the dropped candidate's entry is the loose fit
    for (a, b) in auto.states.iter().zip(&full.states) {
        assert!((a.k_per_s / b.k_per_s - 1.0).abs() < 1e-9, "{a:?} {b:?}");
    }
    let three = |f: &DecayFit| f.candidates.iter().find(|c| c.n_states == 3).map(|c| c.rss);
    // the automatic fit kept the provisional candidate as it was (not fitted again)
    assert_eq!(three(&auto), Some(provisional.rss));
    assert!(three(&full).unwrap() <= provisional.rss);
}
