//! Issue 12: LVF calibration on lamp images with a continuum under the lines, vignetting of
//! several shapes and noise, over three cameras of the Jiang et al. 2013 database (read in place
//! from `../shared/data/camera/`; a skip message when absent, a failure when
//! `LUMIFIT_REQUIRE_DATA=1`), and issue 13's garbage detection: a line missing from the lamp
//! list is reported (`tests/lvf_unlisted_line.rs`), a listed line absent from the image is flagged, a wrong lamp or a frame
//! that is not a lamp photo is refused or flagged, never a silent exit 0.
//!
//! Geometry of issue 12 / docs/performance.md: 1200×160 px, 372.3 nm + 0.3117 nm/px, Gaussian
//! passband FWHM 25 nm.

use lumifit::lvf::synth::{ContinuumShape, VignettingShape};
use lumifit::lvf::{
    calibrate_whole_profile, extract_profile, render_lvf, Axis, BackgroundChoice, FitOptions, Lamp,
    LampLine, LvfCalibration, LvfSynthSpec,
};
mod common;
use common::tolerances::lvf_continuum::*;

use common::jiang::{camera, CAMERAS};

fn database() -> Option<Vec<u8>> {
    common::jiang::database("the three-camera checks")
}

use common::lvf_geometry::spec;

fn calibrate(s: &LvfSynthSpec, fit_lamp: &Lamp) -> lumifit::Result<(LvfCalibration, [f64; 2])> {
    calibrate_with(s, fit_lamp, &FitOptions::default())
}

/// The model before issue 12: linear offset b + s·u, no fall-off.
fn old_model() -> FitOptions {
    FitOptions {
        background: BackgroundChoice::Fixed {
            continuum: false,
            falloff_degree: 0,
        },
        radial_falloff: false,
        ..FitOptions::default()
    }
}

fn calibrate_with(
    s: &LvfSynthSpec,
    fit_lamp: &Lamp,
    opts: &FitOptions,
) -> lumifit::Result<(LvfCalibration, [f64; 2])> {
    let (frame, truth) = render_lvf(s).unwrap();
    let profile = extract_profile(&frame, [0, 0, s.width, s.height], Axis::X).unwrap();
    let cal = calibrate_whole_profile(&profile, fit_lamp, opts)?;
    let e = [
        cal.map.eval(truth.px_at_400) - 400.0,
        cal.map.eval(truth.px_at_700) - 700.0,
    ];
    eprintln!(
        "{} {:?} {:?}: Δλ400 {:+.3} Δλ700 {:+.3} (σ {:.3}/{:.3}) background {} warnings {:?}",
        s.lamp.name,
        s.vignetting_shape,
        s.continuum,
        e[0],
        e[1],
        cal.sigma_nm_at_400,
        cal.sigma_nm_at_700,
        cal.background
            .as_ref()
            .map_or("-".into(), |b| b.model.clone()),
        cal.warnings
    );
    Ok((cal, e))
}

#[test]
fn mercury_with_10_percent_continuum_and_0_3_vignetting_beats_the_old_model_on_three_cameras() {
    let Some(db) = database() else { return };
    let shapes = [
        (VignettingShape::Quadratic, ContinuumShape::Flat),
        (VignettingShape::Cos4, ContinuumShape::Blackbody(2700.0)),
        (VignettingShape::Quadratic, ContinuumShape::Flat),
    ];
    for (k, name) in CAMERAS.iter().enumerate() {
        let (vs, cs) = shapes[k];
        let s = spec(
            Lamp::mercury(),
            camera(&db, name),
            0.01,
            (vs, 0.3),
            Some((cs, 0.10)),
            100 + k as u64,
        );
        let (_, e) = calibrate(&s, &Lamp::mercury()).unwrap();
        let (_, old) = calibrate_with(&s, &Lamp::mercury(), &old_model()).unwrap();
        let worst = e[0].abs().max(e[1].abs());
        let worst_old = old[0].abs().max(old[1].abs());
        eprintln!("{name}: new {worst:.3} nm, old model {worst_old:.3} nm");
        assert!(worst <= HG_GRID_BOUND_NM, "{name}: {e:?}");
        assert!(
            worst < worst_old,
            "{name}: new {e:?} not better than old {old:?}"
        );
        // the issue's bound on every camera (with the 1.0 × FWHM continuum for the D700's and
        // the NEX-5N's steep red edge under the 577/579 nm doublet)
        assert!(worst <= HG_TOL_NM, "{name}: {e:?}");
    }
}

#[test]
fn cfl_with_its_phosphor_continuum_and_vignetting_stays_within_the_measured_bound_on_three_cameras()
{
    let Some(db) = database() else { return };
    for (k, name) in CAMERAS.iter().enumerate() {
        let s = spec(
            Lamp::cfl(),
            camera(&db, name),
            0.01,
            (VignettingShape::Quadratic, 0.3),
            Some((ContinuumShape::Cfl, 0.10)),
            200 + k as u64,
        );
        let (cal, e) = calibrate(&s, &Lamp::cfl()).unwrap();
        assert!(
            e[0].abs() <= CFL_GRID_BOUND_NM && e[1].abs() <= CFL_GRID_BOUND_NM,
            "{name}: {e:?}"
        );
        // The per-line residuals describe the lines, not the search: a chain of CFL lines wider
        // than the passband (577–612 nm) and lines too weak to place used to report shifts up to
        // half the FWHM (12.6 nm) and a line RMS of 5.7 nm for a map good to 0.3 nm.
        assert!(
            cal.rms_residual_nm <= CFL_LINE_RMS_BOUND_NM,
            "{name}: line RMS {} nm",
            cal.rms_residual_nm
        );
        for l in &cal.lines {
            if let (Some(r), Some(sd)) = (l.residual_nm, l.residual_sigma_nm) {
                assert!(
                    r.abs() < 0.5 * cal.fwhm_nm - SHIFT_EDGE_MARGIN_NM
                        && sd <= SHIFT_SIGMA_FWHM * cal.fwhm_nm,
                    "{name}: {} nm reported {r:+.2} ± {sd:.2} nm",
                    l.nm
                );
            }
        }
    }
}

/// A noise-free lamp with the map exact: every line the profile places sits where the map puts
/// it (the per-line shift searched on a grid, not stopped in another basin: Hg 404.7/407.8 nm used
/// to report −2.3 to −2.5 nm on all three cameras), and a line it cannot place is `null`.
#[test]
fn a_noise_free_lamp_reports_every_placed_line_at_its_wavelength() {
    let Some(db) = database() else { return };
    for (k, name) in CAMERAS.iter().enumerate() {
        for lamp in [Lamp::mercury(), Lamp::cfl()] {
            let s = spec(
                lamp.clone(),
                camera(&db, name),
                0.0,
                (VignettingShape::Quadratic, 0.0),
                None,
                40 + k as u64,
            );
            let (cal, _) = calibrate(&s, &lamp).unwrap();
            let placed: Vec<f64> = cal.lines.iter().filter_map(|l| l.residual_nm).collect();
            assert!(placed.len() >= 4, "{name} {}: {:?}", lamp.name, cal.lines);
            for l in &cal.lines {
                if let Some(r) = l.residual_nm {
                    assert!(
                        r.abs() <= CLEAN_LINE_RESIDUAL_NM,
                        "{name}: {} nm at {r:+.4}",
                        l.nm
                    );
                }
            }
        }
    }
}

#[test]
fn a_clean_lamp_does_not_pay_for_a_continuum_and_stays_exact() {
    let Some(db) = database() else { return };
    let s = spec(
        Lamp::mercury(),
        camera(&db, CAMERAS[0]),
        0.0,
        (VignettingShape::Quadratic, 0.0),
        None,
        1,
    );
    let (cal, e) = calibrate(&s, &Lamp::mercury()).unwrap();
    assert!(
        e[0].abs() < CLEAN_TOL_NM && e[1].abs() < CLEAN_TOL_NM,
        "{e:?}"
    );
    assert_eq!(cal.background.unwrap().model, "linear");
    assert!(cal.warnings.is_empty(), "{:?}", cal.warnings);
}

/// Issue 12, "without continuum and vignetting no worse than today": at 1 % noise the image's
/// negative noise is clipped at black, which lifted the floor between the blobs by ≈ 0.4 of the
/// read noise and made BIC choose a continuum that cost 0.003–0.014 nm. With the clipping undone
/// in the profile (`lvf::censored`) the clean lamp keeps the offset-only model and the old
/// model's accuracy, on three cameras and two seeds.
#[test]
fn a_clean_lamp_at_1_percent_noise_keeps_the_simple_model_despite_black_clipping() {
    let Some(db) = database() else { return };
    for name in CAMERAS {
        for seed in [1, 2] {
            let s = spec(
                Lamp::mercury(),
                camera(&db, name),
                0.01,
                (VignettingShape::Quadratic, 0.0),
                None,
                seed,
            );
            let (cal, e) = calibrate(&s, &Lamp::mercury()).unwrap();
            let bg = cal.background.as_ref().unwrap();
            let clip = bg.black_clipping.as_ref().expect("clipped pixels undone");
            assert!(clip.positions_corrected.iter().sum::<usize>() > 0);
            assert_eq!(
                bg.model, "linear",
                "{name} seed {seed}: {:?}",
                bg.candidates
            );
            assert!(
                e[0].abs() <= CLEAN_NOISY_TOL_NM && e[1].abs() <= CLEAN_NOISY_TOL_NM,
                "{name} seed {seed}: {e:?}"
            );
        }
    }
}

/// A line in the lamp list that the image does not show (a fake 520 nm line, in the dark gap
/// between 436 and 546 nm, and one at 470 nm): the map is not pulled towards it, and it is
/// reported absent.
#[test]
fn a_listed_line_the_image_does_not_show_does_not_bias_the_map_and_is_reported_absent() {
    let Some(db) = database() else { return };
    let mut fit_lamp = Lamp::mercury();
    for nm in [470.0, 520.0] {
        fit_lamp.lines.push(LampLine {
            nm,
            relative_power: 0.5,
        });
    }
    fit_lamp.lines.sort_by(|a, b| a.nm.total_cmp(&b.nm));
    for (k, name) in CAMERAS.iter().enumerate() {
        let s = spec(
            Lamp::mercury(),
            camera(&db, name),
            0.01,
            (VignettingShape::Quadratic, 0.2),
            Some((ContinuumShape::Flat, 0.04)),
            30 + k as u64,
        );
        let (cal, e) = calibrate(&s, &fit_lamp).unwrap();
        let (_, e_true) = calibrate(&s, &Lamp::mercury()).unwrap();
        for nm in ["470 nm", "520 nm"] {
            assert!(
                cal.warnings
                    .iter()
                    .any(|w| w.contains(&format!("lamp line {nm}")) && w.contains("absent")),
                "{name}: {nm} not reported absent: {:?}",
                cal.warnings
            );
        }
        assert!(
            e[0].abs() <= HG_TOL_NM && e[1].abs() <= HG_TOL_NM,
            "{name}: {e:?}"
        );
        // no further from the fit with the right list than the fit's own reported σ
        let sig = [cal.sigma_nm_at_400, cal.sigma_nm_at_700];
        for i in 0..2 {
            assert!(
                (e[i] - e_true[i]).abs() <= sig[i],
                "{name}: {e:?} against {e_true:?} with the right list (σ {sig:?})"
            );
        }
    }
}

/// A clean CFL (no continuum, no fall-off, 1 % noise) on the Canon 5D Mark II and the SONY
/// NEX-5N: its violet mercury lines are 1 % of the green Tb³⁺ line but clearly seen in the blue
/// channel, and 650.8 nm is seen in the red. The absent-line check is per channel and by
/// significance, so none of them is reported absent (it used to be: "404.656 nm … absent"),
/// while a fake line listed in the dark gap at 520 nm still is. The Nikon D700 is left out: its
/// blue channel does not see 405 nm, and saying so is right.
#[test]
fn a_clean_cfl_reports_no_seen_line_absent_but_still_flags_a_fake_one() {
    let Some(db) = database() else { return };
    let mut fit_lamp = Lamp::cfl();
    fit_lamp.lines.push(LampLine {
        nm: 520.0,
        relative_power: 0.5,
    });
    fit_lamp.lines.sort_by(|a, b| a.nm.total_cmp(&b.nm));
    for (k, name) in [CAMERAS[0], CAMERAS[2]].iter().enumerate() {
        let s = spec(
            Lamp::cfl(),
            camera(&db, name),
            0.01,
            (VignettingShape::Quadratic, 0.0),
            None,
            1 + k as u64,
        );
        let (cal, _) = calibrate(&s, &fit_lamp).unwrap();
        let absent: Vec<&String> = cal
            .warnings
            .iter()
            .filter(|w| w.contains("absent"))
            .collect();
        for nm in ["404.656 nm", "407.783 nm", "650.8"] {
            assert!(
                !absent
                    .iter()
                    .any(|w| w.contains(&format!("lamp line {nm}"))),
                "{name}: {nm} falsely reported absent: {absent:?}"
            );
        }
        assert!(
            absent.iter().any(|w| w.contains("lamp line 520 nm")),
            "{name}: the fake 520 nm line is not reported absent: {:?}",
            cal.warnings
        );
    }
}

/// Weak violet lines (405/408 nm at 1/20 of their power) under a 10 % flat continuum and
/// quadratic vignetting 0.3, 1 % noise, on every camera. The SONY NEX-5N rises 7–10× in all
/// three channels between 400 and 410 nm, right under those lines: the continuum there is an
/// edge σ_g wide that the spline in u could not draw, and with the violet lines too weak to
/// anchor the blue end the misfit moved the map by 0.115 / 0.240 nm. The continuum seen through
/// the passband (`lvf::passband_continuum`) draws it (0.003 / 0.007 nm on the grid; seed 7:
/// ≤ 0.037 nm on all three), so the issue's 0.15 nm is asserted.
#[test]
fn weak_violet_mercury_lines_calibrate_within_the_issue_bound_on_three_cameras() {
    let Some(db) = database() else { return };
    for name in CAMERAS {
        let s = spec(
            Lamp::mercury_weak_violet(),
            camera(&db, name),
            0.01,
            (VignettingShape::Quadratic, 0.3),
            Some((ContinuumShape::Flat, 0.10)),
            7,
        );
        let (_, e) = calibrate(&s, &Lamp::mercury()).unwrap();
        assert!(
            e[0].abs() <= HG_TOL_NM && e[1].abs() <= HG_TOL_NM,
            "{name}: {e:?}"
        );
    }
}

/// An off-centre fall-off 0.3 (centre at ¾ width, ⅓ height) without a flat, 10 % flat
/// continuum, 1 % noise, every camera. The strips across the axis see the fall-off's curvature
/// but not its centre along the axis: what remains is a tilt t of ln V, which shifts every blob
/// by σ_g²·t ≈ 0.08 nm (docs/performance.md) — inside the issue's 0.15 nm, so that is asserted
/// (seed 5: up to 0.146 nm, Canon 5D Mark II at 700 nm — met, narrowly); the NEX-5N's 0.171 nm
/// before the passband continuum was the continuum misfit on top.
#[test]
fn an_off_centre_fall_off_without_a_flat_stays_within_the_issue_bound_on_three_cameras() {
    let Some(db) = database() else { return };
    for name in CAMERAS {
        let s = spec(
            Lamp::mercury(),
            camera(&db, name),
            0.01,
            (VignettingShape::Offcentre, 0.3),
            Some((ContinuumShape::Flat, 0.10)),
            5,
        );
        let (_, e) = calibrate(&s, &Lamp::mercury()).unwrap();
        assert!(
            e[0].abs() <= HG_TOL_NM && e[1].abs() <= HG_TOL_NM,
            "{name}: {e:?}"
        );
    }
}

#[test]
fn a_listed_line_absent_from_the_image_is_flagged() {
    let Some(db) = database() else { return };
    let mut lamp = Lamp::mercury();
    lamp.lines.retain(|l| (l.nm - 435.833).abs() > 0.1);
    let s = spec(
        lamp,
        camera(&db, CAMERAS[2]),
        0.01,
        (VignettingShape::Quadratic, 0.0),
        None,
        4,
    );
    let (cal, e) = calibrate(&s, &Lamp::mercury()).unwrap();
    assert!(
        cal.warnings.iter().any(|w| w.contains("435.833")),
        "{:?}",
        cal.warnings
    );
    // the remaining lines still determine the map
    assert!(
        e[0].abs() <= ABSENT_LINE_BOUND_NM && e[1].abs() <= ABSENT_LINE_BOUND_NM,
        "{e:?}"
    );
}

#[test]
fn a_cfl_fitted_with_the_mercury_list_is_refused_or_flagged() {
    let Some(db) = database() else { return };
    let s = spec(
        Lamp::cfl(),
        camera(&db, CAMERAS[0]),
        0.01,
        (VignettingShape::Quadratic, 0.2),
        Some((ContinuumShape::Cfl, 0.05)),
        5,
    );
    match calibrate(&s, &Lamp::mercury()) {
        Err(e) => eprintln!("refused: {e}"),
        Ok((cal, _)) => assert!(
            // a warning of the mismatch, not only the hint that a continuum widened σ
            cal.warnings
                .iter()
                .any(|w| !w.starts_with("σ at 400 / 700 nm is"))
                || !cal.unexplained_lines.is_empty(),
            "a CFL calibrated as mercury without a warning: {:?}",
            cal.warnings
        ),
    }
}
