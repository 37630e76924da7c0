//! Excitation-rate fit (Nalbach et al. 2017 §4.6): charging data synthesised from the Table 1
//! materials by the exact simulation give back k_e; unsaturated charging is reported.

use lumifit::phosphor::excitation::{
    apply_excitation, box_source, charging_rgb, fit_excitation, synth_charging, ExcitationOptions,
    StateSharing,
};
use lumifit::phosphor::{table1_materials, BandCamera, Material, PhosphorState};
mod common;
use common::tolerances::phos_excitation::*;

/// Charging times of the paper's doubling protocol (s).
const TIMES: [f64; 10] = [1.0, 2.0, 4.0, 8.0, 16.0, 32.0, 64.0, 128.0, 256.0, 512.0];

fn sources(m: &Material, n: usize) -> Vec<(usize, Vec<f64>)> {
    (0..n).map(|j| (j, box_source(m.bands.len(), j))).collect()
}

#[test]
fn excitation_fit_recovers_table1_rates_within_the_reported_uncertainty_at_one_percent_noise() {
    let mut checked = 0;
    for (seed, tm) in table1_materials().unwrap().iter().enumerate() {
        let m = &tm.material;
        if !m.has_excitation() {
            continue;
        }
        let cam = BandCamera::for_bands(&m.bands, None).unwrap();
        let src = sources(m, 3);
        let data = synth_charging(m, &cam, &src, &TIMES, 0.6, 0.01, seed as u64 + 1).unwrap();
        let fit = fit_excitation(m, &cam, &src, &data, &ExcitationOptions::default()).unwrap();
        let truth = m.states[0].k_e.as_ref().unwrap();
        for b in &fit.bands {
            let (k, s) = (b.k_e[0], b.k_e_sigma[0]);
            eprintln!(
                "{} band {}: k_e {k:.6e} ± {s:.3e} (truth {:.6e}, {:+.2} σ, {} iterations)",
                m.name,
                b.band + 1,
                truth[b.band],
                (k - truth[b.band]) / s,
                b.iterations
            );
            assert!(
                (k - truth[b.band]).abs() <= SIGMAS * s + 1e-12,
                "{} band {}: {k} ± {s} vs {}",
                m.name,
                b.band + 1,
                truth[b.band]
            );
            checked += 1;
        }
        let updated = apply_excitation(m, &fit);
        assert_eq!(updated.states[0].k_e.as_ref().unwrap().len(), 8);
    }
    assert_eq!(checked, 24);
}

#[test]
fn charging_that_never_approaches_saturation_is_reported_as_product_only() {
    // Orange paint, band 3: k_e = 0.0003 s⁻¹ against k_r = 0.015 s⁻¹, so r never exceeds 0.02.
    let m = &lumifit::phosphor::table1_material("orange_paint")
        .unwrap()
        .material;
    let cam = BandCamera::for_bands(&m.bands, None).unwrap();
    let src = sources(m, 3);
    let data = synth_charging(m, &cam, &src, &TIMES, 0.6, 0.01, 3).unwrap();
    let fit = fit_excitation(m, &cam, &src, &data, &ExcitationOptions::default()).unwrap();
    assert!(fit.bands[2].product_only, "r_max {}", fit.bands[2].r_max);
    assert!(!fit.bands[0].product_only && !fit.bands[1].product_only);
}

fn two_state(k_e: [f64; 2]) -> Material {
    let bands = lumifit::phosphor::BandSet::uniform(400.0, 700.0, 8).unwrap();
    let st = |k_r: f64, k: f64, l: f64| PhosphorState {
        k_r_per_s: k_r,
        k_e: Some(vec![k, k, k, 0.0, 0.0, 0.0, 0.0, 0.0]),
        lambda: vec![0.1 * l, l, 0.5 * l, 0.0, 0.0, 0.0, 0.0, 0.0],
    };
    Material {
        name: "two".into(),
        bands,
        states: vec![st(0.2, k_e[0], 1.0), st(0.01, k_e[1], 2.0)],
    }
}

#[test]
fn two_states_share_k_e_unless_the_charging_curve_shows_state_specific_excitation() {
    let times: Vec<f64> = (0..16).map(|i| 0.5 * 2f64.powf(i as f64 * 0.75)).collect();
    let opts = ExcitationOptions::default();
    // Shared truth: the fit keeps one rate.
    let m = two_state([0.05, 0.05]);
    let cam = BandCamera::for_bands(&m.bands, None).unwrap();
    let src = sources(&m, 1);
    let data = synth_charging(&m, &cam, &src, &times, 0.6, 0.01, 11).unwrap();
    let fit = fit_excitation(&m, &cam, &src, &data, &opts).unwrap();
    assert!(fit.bands[0].shared, "{}", fit.bands[0].sharing_reason);
    // Very different rates per state: the per-state model is chosen and says why.
    let m = two_state([0.5, 0.002]);
    let data = synth_charging(&m, &cam, &src, &times, 0.6, 0.01, 12).unwrap();
    let fit = fit_excitation(&m, &cam, &src, &data, &opts).unwrap();
    assert!(!fit.bands[0].shared, "{}", fit.bands[0].sharing_reason);
    assert!(fit.bands[0].sharing_reason.contains("BIC"));
    let forced = ExcitationOptions {
        sharing: StateSharing::Shared,
        ..opts
    };
    let fit = fit_excitation(&m, &cam, &src, &data, &forced).unwrap();
    assert!(fit.bands[0].shared);
}

#[test]
fn a_band_without_a_source_spectrum_and_negative_charge_times_are_rejected() {
    let m = &lumifit::phosphor::table1_material("blue_paint")
        .unwrap()
        .material;
    let cam = BandCamera::for_bands(&m.bands, None).unwrap();
    let src = sources(m, 3);
    let data = synth_charging(m, &cam, &src, &TIMES, 0.6, 0.0, 1).unwrap();
    let e = fit_excitation(m, &cam, &src[..2], &data, &ExcitationOptions::default()).unwrap_err();
    assert!(e.to_string().contains("band 3"), "{e}");
    let mut bad = data.clone();
    bad[0].charge_s = -1.0;
    let e = fit_excitation(m, &cam, &src, &bad, &ExcitationOptions::default()).unwrap_err();
    assert!(e.to_string().contains("-1"), "{e}");
}

#[test]
fn noise_free_charging_data_are_fitted_to_rounding() {
    // Exact data: the closed form of the fit and the simulator agree to 1e-6 relative
    // (LM stops on a relative step of 1e-10; the rest is the conditioning of the plateau).
    let m = &lumifit::phosphor::table1_material("pink_paint")
        .unwrap()
        .material;
    let cam = BandCamera::for_bands(&m.bands, None).unwrap();
    let src = sources(m, 3);
    let data = synth_charging(m, &cam, &src, &TIMES, 0.6, 0.0, 1).unwrap();
    let fit = fit_excitation(m, &cam, &src, &data, &ExcitationOptions::default()).unwrap();
    let truth = m.states[0].k_e.as_ref().unwrap();
    for b in &fit.bands {
        eprintln!(
            "noise-free band {}: relative k_e error {:.3e}",
            b.band + 1,
            (b.k_e[0] - truth[b.band]) / truth[b.band]
        );
        assert!(((b.k_e[0] - truth[b.band]) / truth[b.band]).abs() < 1e-6);
    }
    let y = charging_rgb(m, &cam, &src[0].1, 0.0, 0.6).unwrap();
    assert_eq!(y, [0.0; 3]);
}

#[test]
fn the_preset_after_excitation_fitting_reproduces_the_charging_curves_of_the_fig7_protocol() {
    // Fig. 7 c: charging curves per band, measured after the switch-off delay. The material
    // with fitted k_e, simulated under the same protocol, must match the noise-free input to
    // 1 % of each band's peak (the data carry 1 % noise on 30 samples, so the fitted curve is
    // several times closer than one noise σ).
    let m = &lumifit::phosphor::table1_material("blue_paint")
        .unwrap()
        .material;
    let cam = BandCamera::for_bands(&m.bands, None).unwrap();
    let src = sources(m, 3);
    let data = synth_charging(m, &cam, &src, &TIMES, 0.6, 0.01, 21).unwrap();
    let fit = fit_excitation(m, &cam, &src, &data, &ExcitationOptions::default()).unwrap();
    let mut fitted = m.clone();
    fitted.states[0].k_e = None;
    let fitted = apply_excitation(&fitted, &fit);
    fitted.validate().unwrap();
    for (j, s) in &src {
        let clean: Vec<[f64; 3]> = TIMES
            .iter()
            .map(|t| charging_rgb(m, &cam, s, *t, 0.6).unwrap())
            .collect();
        let peak = clean.iter().flatten().fold(0.0_f64, |a, v| a.max(*v));
        for (t, c) in TIMES.iter().zip(&clean) {
            let y = charging_rgb(&fitted, &cam, s, *t, 0.6).unwrap();
            for k in 0..3 {
                assert!(
                    (y[k] - c[k]).abs() <= 0.01 * peak,
                    "band {} t {t}: {} vs {}",
                    j + 1,
                    y[k],
                    c[k]
                );
            }
        }
    }
}
