//! The LVF calibration on lamp images that no lumifit code made: `fixtures/lvf_reference/*.png`
//! from the independent numpy generator `scripts/reference/lvf_images.py` (issue 12's table:
//! lines only; + quadratic vignetting 0.2; + a flat continuum 4 % of the 546 nm blob; both + 1 %
//! noise; Canon 5D Mark II of the Jiang database, 1200×160 px, 372.3 nm + 0.3117 nm/px,
//! Gaussian FWHM 25 nm). Issue 12 measured 0.000/0.000, 0.225/0.202, 0.357/0.654 and ≈ 0.6/0.9
//! nm for the old model; the bound is 0.15 nm at 400 and 700 nm for each. And issue 12's hardest
//! Hg case on another camera (`d700_blackbody_cos4.png`: Nikon D700, 10 % blackbody 2700 K,
//! cos⁴ 0.3, 1 % noise), fitted without and with the camera known (`--camera`).

use std::path::PathBuf;

use lumifit::io::series::read_frame;
use lumifit::lvf::{
    calibrate_whole_profile, extract_profile, Axis, CameraResponse, FitOptions, Lamp,
};
mod common;
use common::tolerances::lvf_continuum::{HG_5PCT_BOUND_NM, HG_GRID_BOUND_NM, HG_TOL_NM};

fn check(name: &str) -> [f64; 2] {
    check_with(name, &FitOptions::default())
}

fn check_with(name: &str, opts: &FitOptions) -> [f64; 2] {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("fixtures/lvf_reference");
    let truth: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join(format!("{name}.json"))).unwrap()).unwrap();
    let (frame, _) = read_frame(&dir.join(format!("{name}.png"))).unwrap();
    let (w, h) = frame.source_size();
    let profile = extract_profile(&frame, [0, 0, w, h], Axis::X).unwrap();
    let cal = calibrate_whole_profile(&profile, &Lamp::mercury(), opts).unwrap();
    let e = [
        cal.map.eval(truth["px_at_400"].as_f64().unwrap()) - 400.0,
        cal.map.eval(truth["px_at_700"].as_f64().unwrap()) - 700.0,
    ];
    eprintln!(
        "{name}: Δλ400 {:+.4} Δλ700 {:+.4} nm (σ {:.3}/{:.3}), background {}, radial fall-off applied {}, warnings {:?}",
        e[0],
        e[1],
        cal.sigma_nm_at_400,
        cal.sigma_nm_at_700,
        cal.background.as_ref().map_or("-".into(), |b| b.model.clone()),
        cal.background.as_ref().is_some_and(|b| b.radial_falloff_applied),
        cal.warnings
    );
    e
}

#[test]
fn independent_images_lines_vignetting_continuum_and_noise_are_each_within_0_15_nm() {
    for name in ["lines", "vignetting", "continuum", "both_noise"] {
        let e = check(name);
        assert!(
            e[0].abs() <= HG_TOL_NM && e[1].abs() <= HG_TOL_NM,
            "{name}: {e:?}"
        );
    }
}

/// |Δλ| at 400/700 nm of the CFL line list (`--lamp cfl`) on a CIE FL image, with and without
/// the camera given (`--camera`: the shared continuum).
fn check_cfl(name: &str, camera: Option<&lumifit::spectrum::MultiSpectrum>) -> Option<[f64; 2]> {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("fixtures/lvf_reference");
    let truth: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join(format!("{name}.json"))).unwrap()).unwrap();
    let (frame, _) = read_frame(&dir.join(format!("{name}.png"))).unwrap();
    let (w, h) = frame.source_size();
    let profile = extract_profile(&frame, [0, 0, w, h], Axis::X).unwrap();
    let opts = FitOptions {
        camera: camera
            .map(|c| lumifit::lvf::CameraResponse::from_curves(c, "Canon 5DMarkII").unwrap()),
        ..FitOptions::default()
    };
    let cal = match calibrate_whole_profile(&profile, &Lamp::cfl(), &opts) {
        Ok(c) => c,
        Err(e) => {
            eprintln!("{name}: refused: {e}");
            return None;
        }
    };
    let e = [
        cal.map.eval(truth["px_at_400"].as_f64().unwrap()) - 400.0,
        cal.map.eval(truth["px_at_700"].as_f64().unwrap()) - 700.0,
    ];
    eprintln!(
        "{name} (camera {}): Δλ400 {:+.3} Δλ700 {:+.3} nm (σ {:.3}/{:.3}), FWHM {:.2} nm, background {}, warnings {}",
        camera.is_some(),
        e[0],
        e[1],
        cal.sigma_nm_at_400,
        cal.sigma_nm_at_700,
        cal.fwhm_nm,
        cal.background.as_ref().map_or("-".into(), |b| b.model.clone()),
        cal.warnings.len()
    );
    Some(e)
}

/// Issue 12's CFL on lamp spectra that no lumifit code made: CIE FL10, FL11 and FL12 (tri-band
/// fluorescent, `scripts/reference/lvf_images.py`). Known failure: the map is off by 1.9–4.7 nm
/// at 400/700 nm, and FL10 (strongest blue Eu²⁺ band) is misidentified by ≈ 100 nm (fixed by rescoring the identifications, see
/// `cie_fl_images_are_identified_within_the_cfl_lists_floor`); the phosphor
/// "lines" of these spectra are multiplets several nm wide and the free per-line amplitudes and
/// per-channel continuum trade with the map. Run with `--ignored` to measure.
#[test]
#[ignore = "known failure (issue 12): the CFL calibration is off by 1.9–4.7 nm on the CIE FL images (the floor of the CFL list on these tables)"]
fn independent_cfl_images_from_the_cie_fl_tables_are_each_within_1_nm() {
    use common::tolerances::lvf_continuum::CFL_REFERENCE_TOL_NM;
    let db = common::jiang::database("the CFL reference images with --camera");
    let cam = db
        .as_ref()
        .map(|d| common::jiang::camera(d, "Canon 5DMarkII"));
    let mut worst = 0.0f64;
    for name in ["cfl_fl10", "cfl_fl11", "cfl_fl12", "cfl_fl11_noise"] {
        for c in [None, cam.as_ref()] {
            let e = check_cfl(name, c).map_or(f64::INFINITY, |e| e[0].abs().max(e[1].abs()));
            worst = worst.max(e);
        }
    }
    assert!(worst <= CFL_REFERENCE_TOL_NM, "worst {worst} nm");
}

/// Which blob is which CFL line, on every CIE FL image: the offset-only fit prefers FL10's
/// identification shifted by ≈ 100 nm (the broad Eu²⁺ blue band is not drawn); each distinct
/// identification is refined with the background candidates and BIC picks the right one
/// (ΔBIC ≈ 14,000). The bound is the list's floor on these tables, not issue 12's 0.3 nm.
#[test]
fn cie_fl_images_are_identified_within_the_cfl_lists_floor() {
    use common::tolerances::lvf_continuum::CFL_LIST_FLOOR_NM;
    for name in ["cfl_fl10", "cfl_fl11", "cfl_fl12", "cfl_fl11_noise"] {
        let e = check_cfl(name, None).unwrap_or([f64::INFINITY; 2]);
        assert!(
            e[0].abs() <= CFL_LIST_FLOOR_NM && e[1].abs() <= CFL_LIST_FLOOR_NM,
            "{name}: {e:?}"
        );
    }
}

/// The identification report in lvf.json: FL10's offset-only best (the wrong identification)
/// and the rescored winner are both listed, the winner more than ΔBIC 10 ahead of every other
/// identification (so no ambiguity warning), and the chosen ends are those of the map.
#[test]
fn the_line_identification_report_lists_the_rescored_starts() {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("fixtures/lvf_reference");
    let (frame, _) = read_frame(&dir.join("cfl_fl10.png")).unwrap();
    let (w, h) = frame.source_size();
    let profile = extract_profile(&frame, [0, 0, w, h], Axis::X).unwrap();
    let cal = calibrate_whole_profile(&profile, &Lamp::cfl(), &FitOptions::default()).unwrap();
    let id = &cal.diagnostics["line_identification"];
    let starts = id["starts"].as_array().unwrap();
    let others: Vec<f64> = starts
        .iter()
        .filter(|s| !s["same_identification"].as_bool().unwrap())
        .map(|s| s["delta_bic"].as_f64().unwrap())
        .collect();
    assert!(starts.len() >= 3 && !others.is_empty(), "{id}");
    assert!(others.iter().all(|&d| d > 10.0), "{id}");
    assert!(id["runner_up_delta_bic"].as_f64().unwrap() > 1000.0, "{id}");
    assert!(!starts[0]["same_identification"].as_bool().unwrap(), "{id}");
    assert!(!cal
        .warnings
        .iter()
        .any(|w| w.contains("matched to the blobs another way")));
    let ends = &id["chosen_lambda_at_ends_nm"];
    let (lo, hi) = (ends[0].as_f64().unwrap(), ends[1].as_f64().unwrap());
    let (a, b) = (
        cal.map.eval(profile.px[0]),
        cal.map.eval(*profile.px.last().unwrap()),
    );
    assert!(
        (lo.min(hi) - a.min(b)).abs() < 3.0 && (lo.max(hi) - a.max(b)).abs() < 3.0,
        "{lo} {hi} vs {a} {b}"
    );
}

/// The Nikon D700's red channel rises fivefold between 570 and 580 nm, under the 577/579 nm
/// doublet: a continuum seen through it has an edge as sharp as a line blob there, which the
/// per-channel spline (knots ≥ 1.5 FWHM apart) cannot follow. With the camera known the shared
/// continuum spectrum carries the edge in Q_c itself.
#[test]
fn independent_nikon_d700_image_with_a_blackbody_continuum_and_cos4_fall_off() {
    let Some(db) = common::jiang::database("the Nikon D700 reference image") else {
        return;
    };
    let cam = common::jiang::camera(&db, "Nikon D700");
    let blind = check("d700_blackbody_cos4");
    let known = check_with(
        "d700_blackbody_cos4",
        &FitOptions {
            camera: Some(CameraResponse::from_curves(&cam, "Nikon D700").unwrap()),
            ..FitOptions::default()
        },
    );
    eprintln!("Nikon D700 reference: without camera {blind:?}, with --camera {known:?}");
    for e in [blind, known] {
        assert!(
            e[0].abs() <= HG_GRID_BOUND_NM && e[1].abs() <= HG_GRID_BOUND_NM,
            "{e:?}"
        );
    }
}

/// Issue 12's 5 % noise bound on an independent Hg image (`scripts/reference/lvf_robustness.py
/// --cases 30 --seeds 9 --write fixtures/lvf_reference`: 5 % flat continuum, quadratic
/// vignetting 0.2, 5 % noise, Canon 5D Mark II), calibrated by the binary with its defaults. The
/// focused criterion used to replace BIC's spline in u (continuum5, +0.14 nm at 700 nm) by the
/// passband continuum (+0.69 nm), which BIC put 374 behind; it now compares the two only within
/// ΔBIC 200 (`FOCUSED_ACROSS_MAX_DELTA_BIC`, docs/performance.md, issue 12, twenty-fourth
/// session).
#[test]
fn an_independent_5_percent_hg_draw_meets_the_5_percent_bound() {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("fixtures/lvf_reference");
    let name = "robustness_case30_seed9";
    let truth = common::read_json(dir.join(format!("{name}.json")));
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("lvf.json");
    let o = common::lumifit(&[
        "lvf",
        "calibrate",
        dir.join(format!("{name}.png")).to_str().unwrap(),
        "--axis",
        "x",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", common::stderr(&o));
    let cal = common::read_json(&out);
    let e = common::lvf_map_errors(&cal, &truth);
    let bg = &cal["background"];
    eprintln!(
        "{name}: {:+.3} / {:+.3} nm, {}, {}",
        e[0], e[1], bg["model"], bg["selection"]
    );
    assert!(
        e[0].abs() <= HG_5PCT_BOUND_NM && e[1].abs() <= HG_5PCT_BOUND_NM,
        "{e:?} ({})",
        bg["model"]
    );
}
