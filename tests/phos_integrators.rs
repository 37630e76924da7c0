//! The integrators of `phos simulate` against the exact update, and the comparison command.

use std::process::Command;

use lumifit::phosphor::{final_state, simulate, table1_material, Integrator, Segment};
use lumifit::pipeline::phos::{compare_history, compare_integrators, max_relative_error};

/// The comparison's history (600 s under |E| = `scale`, 600 s dark), from the library.
fn history(scale: f64) -> Vec<Segment> {
    compare_history(&table1_material("green_paint").unwrap().material, scale)
}

fn max_error(integ: Integrator, dt: f64, scale: f64) -> f64 {
    let m = &table1_material("green_paint").unwrap().material;
    let r0 = vec![0.0; m.states.len()];
    let h = history(scale);
    let a = simulate(m, &h, &r0, dt, integ).unwrap();
    let e = simulate(m, &h, &r0, dt, Integrator::Exact).unwrap();
    a.r.iter()
        .flatten()
        .zip(e.r.iter().flatten())
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

#[test]
fn the_exact_update_ends_where_the_closed_form_final_state_does() {
    let m = &table1_material("green_paint").unwrap().material;
    let r0 = vec![0.0; m.states.len()];
    let sim = simulate(m, &history(1.0), &r0, 5.0, Integrator::Exact).unwrap();
    let r = final_state(m, &history(1.0), &r0).unwrap();
    for (a, b) in sim.r.last().unwrap().iter().zip(&r) {
        // the same exponentials evaluated step by step: rounding only
        assert!((a - b).abs() < 1e-12, "{a} vs {b}");
    }
}

#[test]
fn rk4_beats_euler_at_the_same_step_and_euler_diverges_under_bright_light() {
    let (rk4, euler) = (
        max_error(Integrator::Rk4, 1.0, 1.0),
        max_error(Integrator::Euler, 1.0, 1.0),
    );
    assert!(rk4 < euler / 100.0, "rk4 {rk4}, euler {euler}");
    let bright = max_error(Integrator::Euler, 5.0, 100.0);
    assert!(
        bright.is_nan() || bright >= 1.0,
        "Euler at h = 5 s under |E| = 100: {bright}"
    );
}

#[test]
fn compare_integrators_writes_a_table_and_a_plot() {
    let d = tempfile::tempdir().unwrap();
    let csv = d.path().join("i.csv");
    let png = d.path().join("i.png");
    let o = Command::new(env!("CARGO_BIN_EXE_lumifit"))
        .args(["phos", "compare-integrators", "--out"])
        .arg(&csv)
        .arg("--plot")
        .arg(&png)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = std::fs::read_to_string(&csv).unwrap();
    assert!(text.starts_with("case,integrator,dt_s,seconds_per_run,max_rel_error"));
    assert_eq!(text.lines().count(), 1 + 2 * 6 * 3);
    assert!(png.is_file());
}

#[test]
fn the_library_comparison_ranks_rk4_above_euler_and_flags_the_bright_euler_divergence() {
    let m = &table1_material("green_paint").unwrap().material;
    let rows = compare_integrators(m).unwrap();
    assert_eq!(rows.len(), 2 * 6 * 3);
    let err = |case: &str, integ: &str, dt: f64| {
        rows.iter()
            .find(|r| r.case == case && r.integrator == integ && r.dt_s == dt)
            .map(|r| r.error)
            .unwrap()
    };
    for r in rows.iter().filter(|r| r.integrator == "exact") {
        assert_eq!(r.error, 0.0, "{r:?}");
    }
    let (rk4, euler) = (
        err("normal |E|=1", "rk4", 1.0),
        err("normal |E|=1", "euler", 1.0),
    );
    assert!(rk4 < euler / 100.0, "rk4 {rk4}, euler {euler}");
    // Euler at h = 5 s under |E| = 100 leaves the stable region (h·k_e·|E| > 2)
    assert!(err("bright |E|=100", "euler", 5.0) >= 1.0);
    // the error measure: ∞ as soon as a value is not finite
    let reference = vec![vec![1.0, 2.0]];
    assert_eq!(max_relative_error(&[vec![1.5, 2.0]], &reference, 2.0), 0.25);
    assert_eq!(
        max_relative_error(&[vec![f64::NAN, 2.0]], &reference, 2.0),
        f64::INFINITY
    );
}
