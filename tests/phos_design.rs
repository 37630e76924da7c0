//! Design from keyframes (Nalbach et al. 2017 §6, Eq. 7): targets generated from known
//! parameters are reproduced, unreachable targets give the best compromise with per-keyframe
//! residuals, and bad input is rejected.

use lumifit::phosphor::design::{
    design_from_keyframes, outgoing_radiance, DesignOptions, IrradianceHistory, Keyframe,
    REACHABLE_REL,
};

/// 200 frames of 0.1 s: light of changing colour and strength for 8 s, then darkness, then a
/// dim blue light.
fn history() -> IrradianceHistory {
    let mut t = Vec::new();
    let mut e = Vec::new();
    for f in 0..200 {
        let ts = f as f64 * 0.1;
        t.push(ts);
        e.push(if ts < 8.0 {
            [1.0 + 0.5 * (ts).sin(), 0.8, 0.3 + 0.2 * (0.5 * ts).cos()]
        } else if ts < 15.0 {
            [0.0, 0.0, 0.0]
        } else {
            [0.0, 0.0, 0.2]
        });
    }
    IrradianceHistory { t_s: t, e }
}

const ALBEDO: [f64; 3] = [0.6, 0.5, 0.4];
const KEY_TIMES: [f64; 4] = [4.0, 9.0, 13.0, 19.5];

fn targets(k_e: [f64; 3], k_r: f64, lambda: [f64; 3]) -> Vec<Keyframe> {
    let h = history();
    let l = outgoing_radiance(&h, ALBEDO, k_e, k_r, lambda, &KEY_TIMES).unwrap();
    KEY_TIMES
        .iter()
        .zip(l)
        .map(|(t, radiance)| Keyframe { t_s: *t, radiance })
        .collect()
}

#[test]
fn design_reproduces_every_keyframe_generated_from_known_parameters_within_one_percent() {
    for (k_e, k_r, lambda) in [
        ([0.05, 0.02, 0.01], 0.3, [0.5, 2.0, 1.0]),
        ([0.2, 0.0, 0.1], 0.05, [3.0, 0.2, 0.1]),
        ([0.01, 0.03, 0.3], 1.2, [0.1, 0.4, 0.9]),
    ] {
        let keys = targets(k_e, k_r, lambda);
        let d = design_from_keyframes(
            &history(),
            &keys,
            &DesignOptions {
                albedo: ALBEDO,
                ..DesignOptions::default()
            },
        )
        .unwrap();
        eprintln!(
            "design {k_e:?} k_r {k_r}: grid cost {:.4e}, refined cost {:.4e}, worst keyframe residual {:.3e}",
            d.grid.cost,
            d.refined.cost,
            d.refined.relative_residual.iter().fold(0.0_f64, |a, v| a.max(*v))
        );
        assert!(d.reachable, "{k_e:?} {k_r}: {}", d.note);
        for r in &d.refined.relative_residual {
            assert!(*r <= REACHABLE_REL, "residual {r} for {k_e:?} {k_r}");
        }
        assert!(d.refined.cost <= d.grid.cost);
    }
}

#[test]
fn unreachable_targets_give_the_best_compromise_and_a_residual_per_keyframe() {
    // Glow that grows in darkness (9 s → 13 s) is impossible for Eq. 1.
    let mut keys = targets([0.05, 0.02, 0.01], 0.3, [0.5, 2.0, 1.0]);
    keys[2].radiance = keys[1].radiance.map(|v| v * 3.0 + 0.5);
    let d = design_from_keyframes(
        &history(),
        &keys,
        &DesignOptions {
            albedo: ALBEDO,
            ..DesignOptions::default()
        },
    )
    .unwrap();
    eprintln!(
        "unreachable: refined cost {:.6e}, residuals {:?}",
        d.refined.cost, d.refined.relative_residual
    );
    assert!(!d.reachable);
    assert!(d.note.contains("not reachable"), "{}", d.note);
    assert_eq!(d.refined.relative_residual.len(), 4);
    assert!(d
        .refined
        .relative_residual
        .iter()
        .any(|r| *r > REACHABLE_REL));
}

#[test]
fn a_keyframe_before_the_history_starts_is_rejected() {
    let keys = vec![Keyframe {
        t_s: -1.0,
        radiance: [1.0, 1.0, 1.0],
    }];
    let e = design_from_keyframes(&history(), &keys, &DesignOptions::default()).unwrap_err();
    assert!(e.to_string().contains("before the history starts"), "{e}");
}
