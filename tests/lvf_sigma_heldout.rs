//! Issue 12, hand-run (ignored) measurements behind the reported σ of the LVF map — not the
//! tuning set of `tests/lvf_sigma_coverage.rs` but a larger, held-out one (other seeds, all
//! eight noisy Hg shapes of the grid in `scripts/bench/lvf_continuum.py`, three cameras of the
//! Jiang database read in place), and the trace of the clean lamp's 0.003–0.004 nm error at
//! 400 nm. Run with
//!
//! ```sh
//! cargo test --release --test lvf_sigma_heldout -- --ignored --nocapture --test-threads 1
//! ```
//!
//! Both print tables; the held-out one asserts nothing beyond the fits succeeding (its numbers
//! are quoted in docs/performance.md), the trace asserts nothing (it is a measurement).

use lumifit::capture::rng::SplitMix64;
use lumifit::capture::synth::noisy_value;
use lumifit::capture::RgbFrame;
use lumifit::lvf::synth::{ContinuumShape, VignettingShape};
use lumifit::lvf::{
    calibrate_whole_profile, extract_profile, render_lvf, Axis, FitOptions, Lamp, LvfCalibration,
};
mod common;
use common::jiang::{camera, CAMERAS};

type Shape = (
    &'static str,
    fn() -> Lamp,
    f64,
    VignettingShape,
    f64,
    Option<ContinuumShape>,
);

/// The eight noisy Hg shapes of the grid (cases 3–10 of `scripts/bench/lvf_continuum.py`).
fn shapes() -> Vec<Shape> {
    use ContinuumShape::*;
    use VignettingShape::*;
    vec![
        (
            "both 4 % + quad 0.2, 1 %",
            Lamp::mercury,
            0.01,
            Quadratic,
            0.2,
            Some(Flat),
        ),
        ("clean 1 %", Lamp::mercury, 0.01, Quadratic, 0.0, None),
        (
            "flat 10 % + quad 0.3, 1 %",
            Lamp::mercury,
            0.01,
            Quadratic,
            0.3,
            Some(Flat),
        ),
        (
            "bb 10 % + cos4 0.3, 1 %",
            Lamp::mercury,
            0.01,
            Cos4,
            0.3,
            Some(Blackbody(2700.0)),
        ),
        (
            "flat 10 % + tilt 0.3, 1 %",
            Lamp::mercury,
            0.01,
            Linear,
            0.3,
            Some(Flat),
        ),
        (
            "flat 10 % + offc 0.3, 1 %",
            Lamp::mercury,
            0.01,
            Offcentre,
            0.3,
            Some(Flat),
        ),
        (
            "flat 10 % + quad 0.3, 5 %",
            Lamp::mercury,
            0.05,
            Quadratic,
            0.3,
            Some(Flat),
        ),
        (
            "weak, 10 % + quad 0.3, 1 %",
            Lamp::mercury_weak_violet,
            0.01,
            Quadratic,
            0.3,
            Some(Flat),
        ),
    ]
}

fn fit(frame: &RgbFrame, w: usize, h: usize, lamp: &Lamp) -> LvfCalibration {
    let profile = extract_profile(frame, [0, 0, w, h], Axis::X).unwrap();
    calibrate_whole_profile(&profile, lamp, &FitOptions::default()).unwrap()
}

fn errors(cal: &LvfCalibration, px400: f64, px700: f64) -> [f64; 2] {
    [cal.map.eval(px400) - 400.0, cal.map.eval(px700) - 700.0]
}

fn old_sigma(cal: &LvfCalibration) -> [f64; 2] {
    let s = &cal.diagnostics["statistical_sigma"]["correlation_length_scaled_nm_at_400_700"];
    let st = [s[0].as_f64().unwrap_or(0.0), s[1].as_f64().unwrap_or(0.0)];
    [
        st[0].hypot(cal.sigma_systematic_nm_at_400),
        st[1].hypot(cal.sigma_systematic_nm_at_700),
    ]
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    if v.is_empty() {
        return f64::NAN;
    }
    let k = v.len() / 2;
    if v.len() % 2 == 1 {
        v[k]
    } else {
        0.5 * (v[k - 1] + v[k])
    }
}

#[test]
#[ignore = "hand-run measurement (≈ 2–4 min): held-out σ coverage, 3 seeds × 8 shapes × 3 cameras"]
fn held_out_sigma_coverage_over_seeds_shapes_and_cameras() {
    let Some(db) = common::jiang::database("the held-out σ coverage set") else {
        return;
    };
    let seeds: Vec<u64> = std::env::var("LVF_HELDOUT_SEEDS")
        .ok()
        .map(|s| s.split(',').filter_map(|x| x.trim().parse().ok()).collect())
        .unwrap_or_else(|| vec![9001, 9002, 9003]);
    // (new within 1σ, within 2σ, old within 1σ, within 2σ, total); ratios σ/|e|
    let (mut n1, mut n2, mut o1, mut o2, mut total) = (0, 0, 0, 0, 0);
    let (mut ratio_new, mut ratio_old) = (Vec::new(), Vec::new());
    let mut misses = Vec::new();
    for (ci, name) in CAMERAS.iter().enumerate() {
        for (ki, (label, lamp, noise, vs, v, cont)) in shapes().into_iter().enumerate() {
            for &seed in &seeds {
                let s = common::lvf_geometry::spec(
                    lamp(),
                    camera(&db, name),
                    noise,
                    (vs, v),
                    cont.map(|c| (c, 0.10)),
                    seed * 100 + (10 * ci + ki) as u64,
                );
                let (frame, truth) = render_lvf(&s).unwrap();
                let cal = fit(&frame, s.width, s.height, &lamp());
                let e = errors(&cal, truth.px_at_400, truth.px_at_700);
                let sig = [cal.sigma_nm_at_400, cal.sigma_nm_at_700];
                let old = old_sigma(&cal);
                for i in 0..2 {
                    total += 1;
                    n1 += usize::from(e[i].abs() <= sig[i]);
                    n2 += usize::from(e[i].abs() <= 2.0 * sig[i]);
                    o1 += usize::from(e[i].abs() <= old[i]);
                    o2 += usize::from(e[i].abs() <= 2.0 * old[i]);
                    ratio_new.push(sig[i] / e[i].abs().max(1e-6));
                    ratio_old.push(old[i] / e[i].abs().max(1e-6));
                    if e[i].abs() > 2.0 * sig[i] {
                        misses.push(format!(
                            "{name}, {label}, seed {seed}, {} nm: |e| {:.4} = {:.1}σ (σ {:.4})",
                            [400, 700][i],
                            e[i].abs(),
                            e[i].abs() / sig[i],
                            sig[i]
                        ));
                    }
                }
                eprintln!(
                    "{name:15} {label:28} seed {seed}: e {:+.4} / {:+.4}  σ {:.4} / {:.4} (stat {:.4} / {:.4}, sys {:.4} / {:.4})  old σ {:.4} / {:.4}  L {}  {}",
                    e[0],
                    e[1],
                    sig[0],
                    sig[1],
                    cal.sigma_statistical_nm_at_400,
                    cal.sigma_statistical_nm_at_700,
                    cal.sigma_systematic_nm_at_400,
                    cal.sigma_systematic_nm_at_700,
                    old[0],
                    old[1],
                    cal.diagnostics["statistical_sigma"]["hac_bandwidth_lags"],
                    cal.background.as_ref().map_or("-".into(), |b| b.model.clone())
                );
            }
        }
    }
    let pc = |k: usize| 100.0 * k as f64 / total as f64;
    eprintln!("misses at 2σ:\n  {}", misses.join("\n  "));
    eprintln!(
        "held-out, {total} (image, position) pairs: new σ |e| ≤ σ {:.1} %, ≤ 2σ {:.1} %, median σ/|e| {:.2}; old σ {:.1} % / {:.1} %, median σ/|e| {:.2}",
        pc(n1),
        pc(n2),
        median(ratio_new),
        pc(o1),
        pc(o2),
        median(ratio_old)
    );
    assert!(total > 0);
}

/// The clean lamp (no continuum, no vignetting): error at 400/700 nm over seeds at 0.5, 1 and
/// 2 % noise, with the synthesiser's clipping at black and, on the same noise, without clipping
/// (a pedestal of 0.05 added before the noise, so nothing reaches 0 and `lvf::censored` has
/// nothing to undo). Mean error (bias) against the spread over seeds and the reported σ.
#[test]
#[ignore = "hand-run trace (≈ 5 min) of the clean lamp's error at 400 nm"]
fn clean_lamp_error_against_noise_seed_and_clipping() {
    let Some(db) = common::jiang::database("the clean-lamp trace") else {
        return;
    };
    let n_seeds: u64 = std::env::var("LVF_TRACE_SEEDS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(6);
    for (ci, name) in CAMERAS.iter().enumerate() {
        let base = common::lvf_geometry::spec(
            Lamp::mercury(),
            camera(&db, name),
            0.0,
            (VignettingShape::Quadratic, 0.0),
            None,
            1,
        );
        let (clean, truth) = render_lvf(&base).unwrap();
        let (w, h) = (base.width, base.height);
        let e0 = errors(
            &fit(&clean, w, h, &Lamp::mercury()),
            truth.px_at_400,
            truth.px_at_700,
        );
        eprintln!("{name}: noise-free error {:+.5} / {:+.5} nm", e0[0], e0[1]);
        for noise in [0.005, 0.01, 0.02] {
            for pedestal in [0.0, 0.05] {
                let (mut es, mut sig, mut old) = (Vec::new(), [0.0; 2], [0.0; 2]);
                for seed in 0..n_seeds {
                    let mut rng = SplitMix64::new(7000 + 100 * ci as u64 + seed);
                    let mut data = Vec::with_capacity(3 * w * h);
                    for y in 0..h {
                        for x in 0..w {
                            for v in clean.rgb(x, y) {
                                let s = noisy_value(f64::from(v), noise, 0.8, &mut rng);
                                let s = if pedestal > 0.0 { s + pedestal } else { s };
                                data.push(s.clamp(0.0, 1.0) as f32);
                            }
                        }
                    }
                    let frame = RgbFrame::new("trace", w, h, 1, data, vec![0; w * h]).unwrap();
                    let cal = fit(&frame, w, h, &Lamp::mercury());
                    es.push(errors(&cal, truth.px_at_400, truth.px_at_700));
                    let o = old_sigma(&cal);
                    sig[0] += cal.sigma_nm_at_400 / n_seeds as f64;
                    sig[1] += cal.sigma_nm_at_700 / n_seeds as f64;
                    old[0] += o[0] / n_seeds as f64;
                    old[1] += o[1] / n_seeds as f64;
                }
                let stat = |i: usize| {
                    let m = es.iter().map(|e| e[i]).sum::<f64>() / es.len() as f64;
                    let sd = (es.iter().map(|e| (e[i] - m).powi(2)).sum::<f64>()
                        / (es.len() - 1).max(1) as f64)
                        .sqrt();
                    (m, sd)
                };
                let (m4, s4) = stat(0);
                let (m7, s7) = stat(1);
                eprintln!(
                    "  noise {:.1} %, pedestal {pedestal:.2}: 400 nm mean {m4:+.4} sd {s4:.4} (σ new {:.4}, old {:.4}) | 700 nm mean {m7:+.4} sd {s7:.4} (σ new {:.4}, old {:.4})",
                    100.0 * noise,
                    sig[0],
                    old[0],
                    sig[1],
                    old[1]
                );
            }
        }
    }
}
