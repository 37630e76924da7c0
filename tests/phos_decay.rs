//! Simulate-then-fit round trips and the hard cases of the decay fit.
//!
//! Tolerances, in one place:
//! - `SIGMA_MULT`: a noisy fit is judged against its own reported uncertainty; 3σ keeps the
//!   false-alarm rate of a correct estimator near 0.3 % per rate while a biased or overconfident
//!   fit fails. Seeds are fixed, so the tests are deterministic.
//! - `EXACT_REL`: noise-free closed-form comparisons, limited by double rounding in exp().

use lumifit::phosphor::synth::{decay_curve, DecaySeriesSpec};
use lumifit::phosphor::{
    fit_decay, table1_materials, BandCamera, BandSet, DecayCurve, DecayFit, DecayFitOptions,
    DecayFlag, Material, PhosphorState, StatesChoice,
};
mod common;
use common::tolerances::phos_decay::*;

fn spec(seed: u64, interval_s: f64) -> DecaySeriesSpec {
    DecaySeriesSpec {
        charge_s: 5400.0,
        frames: 37,
        interval_s,
        exposure_s: 1.0,
        noise: 0.01,
        seed,
    }
}

fn curve_of(m: &Material, s: &DecaySeriesSpec) -> DecayCurve {
    let cam = BandCamera::for_bands(&m.bands, None).unwrap();
    let c = decay_curve(m, &cam, s).unwrap();
    let ch = (0..3)
        .map(|k| c.rgb.iter().map(|v| v[k]).collect())
        .collect();
    DecayCurve::new(c.t_s, ch, Some(c.sigma)).unwrap()
}

fn assert_rates(fit: &DecayFit, truth: &[f64], what: &str) {
    assert_eq!(
        fit.states.len(),
        truth.len(),
        "{what}: states {:?}",
        fit.states
    );
    for (s, k) in fit.states.iter().zip(truth) {
        let sd = s.k_sigma_per_s.expect("uncertainty");
        assert!(
            (s.k_per_s - k).abs() <= SIGMA_MULT * sd,
            "{what}: k = {} ± {sd}, truth {k}",
            s.k_per_s
        );
    }
}

fn two_state(m: &Material, ratio: f64) -> Material {
    let s = &m.states[0];
    let mut slow = s.clone();
    slow.k_r_per_s = s.k_r_per_s / ratio;
    Material {
        name: format!("{}_two_state", m.name),
        bands: m.bands.clone(),
        states: vec![s.clone(), slow],
    }
}

#[test]
fn decay_fit_recovers_the_rate_of_every_table1_material_at_one_percent_noise() {
    for (i, tm) in table1_materials().unwrap().iter().enumerate() {
        let curve = curve_of(&tm.material, &spec(100 + i as u64, 5.0));
        let fit = fit_decay(&curve, &DecayFitOptions::default()).unwrap();
        assert_rates(&fit, &[tm.material.states[0].k_r_per_s], &tm.label);
    }
}

#[test]
fn decay_fit_recovers_both_rates_of_two_state_variants_ten_times_apart() {
    for (i, tm) in table1_materials().unwrap().iter().enumerate() {
        let m = two_state(&tm.material, 10.0);
        // sample long enough that the slow state decays by e⁻² over the record
        let k_slow = m.states[1].k_r_per_s;
        let interval = (2.0 / k_slow / 36.0).max(5.0);
        let curve = curve_of(&m, &spec(200 + i as u64, interval));
        let fit = fit_decay(&curve, &DecayFitOptions::default()).unwrap();
        let truth = [m.states[0].k_r_per_s, k_slow];
        assert_rates(&fit, &truth, &m.name);
    }
}

fn exp_curve(t: &[f64], comps: &[(f64, f64)], noise: f64, bg: f64, seed: u64) -> DecayCurve {
    let mut g = lumifit::phosphor::synth::Gaussian::new(seed);
    let spec = [0.3, 1.0, 0.6];
    let mut ch = vec![Vec::new(), Vec::new(), Vec::new()];
    let mut sig = Vec::new();
    for &ti in t {
        let f: f64 = comps.iter().map(|(a, k)| a * (-k * ti).exp()).sum::<f64>() + bg;
        let s = (noise * f).max(1e-12);
        sig.push(s);
        for c in 0..3 {
            ch[c].push(spec[c] * f + s * g.normal());
        }
    }
    DecayCurve::new(t.to_vec(), ch, Some(sig)).unwrap()
}

fn times(n: usize, dt: f64) -> Vec<f64> {
    (0..n).map(|i| i as f64 * dt).collect()
}

#[test]
fn rates_within_twenty_percent_give_one_state_or_a_flag_never_two_confident_wrong_rates() {
    for seed in 0..10 {
        let c = exp_curve(
            &times(37, 5.0),
            &[(1.0, 0.06), (1.0, 0.05)],
            0.01,
            0.0,
            seed,
        );
        let fit = fit_decay(&c, &DecayFitOptions::default()).unwrap();
        if fit.states.len() == 2 && fit.flags.is_empty() {
            assert_rates(&fit, &[0.06, 0.05], "20 % apart");
        }
    }
}

#[test]
fn amplitudes_a_thousand_to_one_are_both_recovered() {
    let c = exp_curve(&times(37, 5.0), &[(1000.0, 0.2), (1.0, 0.02)], 0.01, 0.0, 7);
    let fit = fit_decay(&c, &DecayFitOptions::default()).unwrap();
    assert_rates(&fit, &[0.2, 0.02], "1000:1");
    let ratio = fit.states[0].amplitude / fit.states[1].amplitude;
    assert!(
        (ratio / 1000.0 - 1.0).abs() < 0.1,
        "amplitude ratio {ratio}"
    );
}

#[test]
fn a_component_too_slow_to_decay_is_flagged_as_background_like() {
    let c = exp_curve(&times(37, 5.0), &[(1.0, 0.1), (0.2, 1e-4)], 0.01, 0.0, 3);
    let fit = fit_decay(&c, &DecayFitOptions::default()).unwrap();
    let fast = &fit.states[0];
    assert!((fast.k_per_s - 0.1).abs() <= SIGMA_MULT * fast.k_sigma_per_s.unwrap());
    assert_eq!(fit.states.len(), 2, "{:?}", fit.flags);
    assert!(
        fit.flags
            .iter()
            .any(|f| matches!(f, DecayFlag::QuasiConstantState { .. })),
        "flags {:?}",
        fit.flags
    );
    // with a background offered, the fast rate is still right
    let opts = DecayFitOptions {
        background: true,
        ..DecayFitOptions::default()
    };
    let fit = fit_decay(&c, &opts).unwrap();
    assert!(
        (fit.states[0].k_per_s - 0.1).abs() <= SIGMA_MULT * fit.states[0].k_sigma_per_s.unwrap()
    );
}

#[test]
fn a_pure_single_exponential_offered_three_states_collapses_to_one() {
    let c = exp_curve(&times(37, 5.0), &[(1.0, 0.05)], 0.01, 0.0, 11);
    let opts = DecayFitOptions {
        states: StatesChoice::Fixed(3),
        ..DecayFitOptions::default()
    };
    let fit = fit_decay(&c, &opts).unwrap();
    assert_rates(&fit, &[0.05], "single offered three");
    assert!(
        fit.flags.iter().any(|f| matches!(
            f,
            DecayFlag::StateDropped { .. } | DecayFlag::RatesMerged { .. }
        )),
        "the report says what was collapsed: {:?}",
        fit.flags
    );
    let auto = fit_decay(&c, &DecayFitOptions::default()).unwrap();
    assert_eq!(auto.states.len(), 1, "BIC picks one state");
}

#[test]
fn zero_or_constant_data_and_bad_times_are_rejected() {
    let t = times(10, 1.0);
    assert!(DecayCurve::new(t.clone(), vec![vec![0.0; 10]], None).is_err());
    assert!(DecayCurve::new(t.clone(), vec![vec![2.5; 10]; 3], None).is_err());
    let mut dup = t.clone();
    dup[4] = dup[3];
    let e = DecayCurve::new(dup, vec![(0..10).map(|i| 10.0 - i as f64).collect()], None);
    assert!(e.unwrap_err().to_string().contains("strictly increasing"));
    let mut dec = t.clone();
    dec[5] = 1.0;
    assert!(DecayCurve::new(dec, vec![(0..10).map(|i| 10.0 - i as f64).collect()], None).is_err());
    // rising data is not an input error: the fit reports what it can, without panicking
    let rising = DecayCurve::new(t, vec![(0..10).map(|i| i as f64).collect()], None).unwrap();
    let _ = fit_decay(&rising, &DecayFitOptions::default());
}

#[test]
fn exact_simulation_matches_the_closed_form_solution_of_eq1() {
    let m = Material {
        name: "test".into(),
        bands: BandSet::uniform(400.0, 700.0, 2).unwrap(),
        states: vec![PhosphorState {
            k_r_per_s: 0.1,
            k_e: Some(vec![0.2, 0.05]),
            lambda: vec![1.0, 2.0],
        }],
    };
    let h = [lumifit::phosphor::Segment {
        duration_s: 30.0,
        irradiance: vec![1.0, 2.0],
    }];
    let sim =
        lumifit::phosphor::simulate(&m, &h, &[0.0], 0.7, lumifit::phosphor::Integrator::Exact)
            .unwrap();
    let a: f64 = 0.2 + 0.1;
    let (lam, req) = (a + 0.1, a / (a + 0.1));
    for (t, r) in sim.t_s.iter().zip(&sim.r) {
        let want = req * (1.0 - (-lam * t).exp());
        assert!(
            (r[0] - want).abs() <= EXACT_REL * want.max(1e-300) + 1e-15,
            "t={t}"
        );
    }
    // window integral equals a fine trapezoid of the emission
    let w = lumifit::phosphor::window_integrals(&m, &h, &[0.0], &[(3.0, 40.0)]).unwrap();
    let n = 200_000;
    let mut s = 0.0;
    for i in 0..=n {
        let t = 3.0 + 37.0 * i as f64 / n as f64;
        let r = if t <= 30.0 {
            req * (1.0 - (-lam * t).exp())
        } else {
            req * (1.0 - (-lam * 30.0).exp()) * (-0.1 * (t - 30.0)).exp()
        };
        s += if i == 0 || i == n { 0.5 * r } else { r };
    }
    let want = s * 37.0 / n as f64 * 0.1; // Λ[0] k_r ∫r
    assert!(
        (w[0][0] - want).abs() < 1e-8 * want,
        "{} vs {want}",
        w[0][0]
    );
}

#[test]
fn forward_euler_diverges_under_bright_excitation_where_the_exact_update_does_not() {
    let m = Material {
        name: "bright".into(),
        bands: BandSet::Rgb,
        states: vec![PhosphorState {
            k_r_per_s: 0.05,
            k_e: Some(vec![1.0, 0.0, 0.0]),
            lambda: vec![1.0, 1.0, 1.0],
        }],
    };
    let h = [lumifit::phosphor::Segment {
        duration_s: 100.0,
        irradiance: vec![1.0, 0.0, 0.0],
    }];
    use lumifit::phosphor::Integrator::*;
    let euler = lumifit::phosphor::simulate(&m, &h, &[0.0], 5.0, Euler).unwrap();
    let exact = lumifit::phosphor::simulate(&m, &h, &[0.0], 5.0, Exact).unwrap();
    let last = |s: &lumifit::phosphor::Simulation| s.r.last().unwrap()[0];
    assert!(
        last(&euler).abs() > 1.0,
        "Euler with (a+k)h = 5.25 leaves [0, 1]"
    );
    assert!((last(&exact) - 1.0 / 1.05).abs() < 1e-12);
}
