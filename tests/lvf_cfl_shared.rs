//! Issue 12: a CFL under its phosphor continuum, calibrated with the camera known
//! (`lvf calibrate --camera`): the continuum is one spectrum shared by the three channels
//! (`lumifit::lvf::shared_continuum`) instead of three free splines. Three cameras of the Jiang
//! et al. 2013 database, read in place from `../shared/data/camera/` (skip message when absent,
//! failure when `LUMIFIT_REQUIRE_DATA=1`). Geometry of docs/performance.md: 1200×160 px,
//! 372.3 nm + 0.3117 nm/px, Gaussian passband FWHM 25 nm.

use std::path::PathBuf;

use lumifit::lvf::synth::{ContinuumShape, VignettingShape};
use lumifit::lvf::{
    calibrate_whole_profile, extract_profile, render_lvf, Axis, CameraResponse, FitOptions, Lamp,
    LvfCalibration, LvfSynthSpec,
};
use lumifit::spectrum::MultiSpectrum;
mod common;
use common::tolerances::lvf_continuum::*;

use common::jiang::{camera, CAMERAS};

fn database() -> Option<Vec<u8>> {
    common::jiang::database("the shared-continuum checks")
}

fn spec(cam: MultiSpectrum, shape: ContinuumShape, vignetting: f64, seed: u64) -> LvfSynthSpec {
    common::lvf_geometry::spec(
        Lamp::cfl(),
        cam,
        0.01,
        (VignettingShape::Quadratic, vignetting),
        Some((shape, 0.10)),
        seed,
    )
}

/// The CFL calibration of a rendered image and its signed λ errors at the true 400 and 700 nm
/// positions.
fn calibrated(s: &LvfSynthSpec, opts: &FitOptions) -> (LvfCalibration, [f64; 2]) {
    let (frame, truth) = render_lvf(s).unwrap();
    let profile = extract_profile(&frame, [0, 0, s.width, s.height], Axis::X).unwrap();
    let cal = calibrate_whole_profile(&profile, &Lamp::cfl(), opts).unwrap();
    let e = [
        cal.map.eval(truth.px_at_400) - 400.0,
        cal.map.eval(truth.px_at_700) - 700.0,
    ];
    (cal, e)
}

/// A database camera's curves and the default options with them as `--camera`.
fn with_camera(db: &[u8], name: &str) -> (MultiSpectrum, FitOptions) {
    let cam = camera(db, name);
    let opts = FitOptions {
        camera: Some(CameraResponse::from_curves(&cam, name).unwrap()),
        ..FitOptions::default()
    };
    (cam, opts)
}

/// The σ hint among the warnings (without the camera, σ above `--sigma-hint`), if any.
fn sigma_hint(cal: &LvfCalibration) -> Option<&String> {
    cal.warnings
        .iter()
        .find(|w| w.starts_with("σ at 400 / 700 nm is"))
}

/// |Δλ| at 400 and 700 nm and the background model chosen.
fn errors(s: &LvfSynthSpec, opts: &FitOptions) -> ([f64; 2], String, bool) {
    let (cal, e) = calibrated(s, opts);
    let bg = cal.background.unwrap();
    (e.map(f64::abs), bg.model, bg.shared_spectrum.is_some())
}

/// The shared spectrum against three free splines in u (the per-channel continuum it was built
/// to replace; the passband continuum, `lvf::passband_continuum`, left out of that run). The
/// default per-channel fit, which has the passband continuum, is printed beside: on the Canon
/// 5D Mark II it was better than the shared spectrum (0.013 / 0.112 against 0.201 / 0.310 nm)
/// until the radial fall-off kept its curvature (eighteenth session: 0.157 / 0.197 against
/// 0.004 / 0.053 nm).
#[test]
fn a_cfl_continuum_shared_through_the_known_camera_beats_three_free_splines_on_three_cameras() {
    let Some(db) = database() else { return };
    for (k, name) in CAMERAS.iter().enumerate() {
        let cam = camera(&db, name);
        let s = spec(cam.clone(), ContinuumShape::Cfl, 0.3, 200 + k as u64);
        let splines_in_u = FitOptions {
            passband_knots_fwhm: Vec::new(),
            ..FitOptions::default()
        };
        let (free, free_model, _) = errors(&s, &splines_in_u);
        let (default, default_model, _) = errors(&s, &FitOptions::default());
        let opts = FitOptions {
            camera: Some(CameraResponse::from_curves(&cam, name).unwrap()),
            ..FitOptions::default()
        };
        let (shared, model, reported) = errors(&s, &opts);
        eprintln!(
            "{name}: splines in u ({free_model}) {:.3} / {:.3} nm; default without camera ({default_model}) {:.3} / {:.3} nm; with --camera ({model}) {:.3} / {:.3} nm",
            free[0], free[1], default[0], default[1], shared[0], shared[1]
        );
        assert!(model.starts_with("shared-spectrum"), "{name}: {model}");
        assert!(reported, "{name}: the shared spectrum is not in the report");
        let worst = shared[0].max(shared[1]);
        assert!(worst <= CFL_SHARED_BOUND_NM, "{name}: {shared:?}");
        assert!(
            worst < free[0].max(free[1]),
            "{name}: shared {shared:?} not better than per-channel {free:?}"
        );
    }
}

#[test]
fn a_clean_lamp_with_the_camera_known_still_keeps_the_offset_only_model() {
    let Some(db) = database() else { return };
    let cam = camera(&db, CAMERAS[0]);
    let mut s = spec(cam.clone(), ContinuumShape::Flat, 0.0, 1);
    s.lamp = Lamp::mercury();
    s.noise = 0.0;
    s.continuum = None;
    let opts = FitOptions {
        camera: Some(CameraResponse::from_curves(&cam, CAMERAS[0]).unwrap()),
        ..FitOptions::default()
    };
    let (frame, truth) = render_lvf(&s).unwrap();
    let profile = extract_profile(&frame, [0, 0, s.width, s.height], Axis::X).unwrap();
    let cal = calibrate_whole_profile(&profile, &Lamp::mercury(), &opts).unwrap();
    let e400 = (cal.map.eval(truth.px_at_400) - 400.0).abs();
    let e700 = (cal.map.eval(truth.px_at_700) - 700.0).abs();
    assert!(e400 < CLEAN_TOL_NM && e700 < CLEAN_TOL_NM, "{e400} {e700}");
    assert_eq!(cal.background.unwrap().model, "linear");
}

#[test]
fn lvf_calibrate_with_camera_reports_the_shared_spectrum_in_lvf_json() {
    let Some(_) = database() else { return };
    let db = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/data/camera/jiang2013_camspec_all_cameras_long.csv");
    let cam = format!("{}:Nikon D700", db.display());
    // a directory of this run's own: a fixed one is shared by concurrent runs of the test
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let (img, truth, out) = (
        dir.join("cfl.tiff"),
        dir.join("t.json"),
        dir.join("lvf.json"),
    );
    let run = |args: &[&str]| {
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_lumifit"))
            .args(args)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    };
    run(&[
        "synth",
        "lvf-hg",
        "--out",
        img.to_str().unwrap(),
        "--truth",
        truth.to_str().unwrap(),
        "--lamp",
        "cfl",
        "--nm-at-start",
        "372.3",
        "--nm-per-px",
        "0.3117",
        "--fwhm",
        "25",
        "--camera",
        &cam,
        "--noise",
        "0.01",
        "--continuum",
        "0.1",
        "--continuum-spectrum",
        "cfl",
        "--seed",
        "1",
    ]);
    run(&[
        "lvf",
        "calibrate",
        img.to_str().unwrap(),
        "--axis",
        "x",
        "--lamp",
        "cfl",
        "--camera",
        &cam,
        "--out",
        out.to_str().unwrap(),
    ]);
    let j: serde_json::Value = serde_json::from_slice(&std::fs::read(&out).unwrap()).unwrap();
    let bg = &j["background"];
    assert!(
        bg["model"].as_str().unwrap().starts_with("shared-spectrum"),
        "{}",
        bg["model"]
    );
    let s = bg["shared_spectrum"]["spectrum"].as_array().unwrap();
    assert!(s.len() > 10 && s.iter().all(|p| p[1].as_f64().unwrap() >= 0.0));
    assert!(bg["shared_spectrum"]["camera"]
        .as_str()
        .unwrap()
        .ends_with("Nikon D700"));
}

/// The focused information criterion (`lvf::fit`, `focused_refinement`), with the shared
/// spectrum chosen by knot spacing as before the roughness penalty (`--shared-knots 1.5,1,0.75
/// --shared-smoothness 0 --weights off`): on the image where BIC kept the coarser shared spectrum
/// (`shared-spectrum11`) and the map was 0.305 nm off at 700 nm (Canon 5D Mark II, CFL + its
/// continuum 10 % + quadratic 0.3, 1 %, seed 1 of `scripts/bench/lvf_continuum.py` case 15), the
/// finer spacing of the same family is chosen for its smaller estimated error of λ, and the
/// report says so: `selection` names BIC's choice, which stays among the candidates with a
/// negative ΔBIC.
#[test]
fn the_focused_criterion_refines_the_shared_spectrum_and_says_so() {
    let Some(db) = database() else { return };
    let name = CAMERAS[0];
    let cam = camera(&db, name);
    let s = spec(cam.clone(), ContinuumShape::Cfl, 0.3, 1);
    let opts = FitOptions {
        camera: Some(CameraResponse::from_curves(&cam, name).unwrap()),
        shared_knots_fwhm: vec![1.5, 1.0, 0.75],
        shared_smoothness: vec![0.0],
        noise_weights: Some(false),
        ..FitOptions::default()
    };
    let (cal, e) = calibrated(&s, &opts);
    let bg = cal.background.unwrap();
    eprintln!(
        "{name}, seed 1: {:+.3} / {:+.3} nm ({}); {}",
        e[0], e[1], bg.model, bg.selection
    );
    assert!(
        e[0].abs() <= CFL_ISSUE_BOUND_NM && e[1].abs() <= CFL_ISSUE_BOUND_NM,
        "{e:?}"
    );
    assert!(
        bg.selection.starts_with("bic chose shared-spectrum"),
        "{}",
        bg.selection
    );
    let bic_choice = bg.selection["bic chose ".len()..]
        .split(';')
        .next()
        .unwrap()
        .to_string();
    assert_ne!(bic_choice, bg.model);
    let c = bg
        .candidates
        .iter()
        .find(|c| c.model == bic_choice)
        .expect("BIC's choice among the candidates");
    assert!(c.delta_bic < 0.0, "{}", c.delta_bic);
}

/// Without the camera, at 5 % noise, BIC keeps a spline in u under a CFL (its k·ln N penalty
/// outweighs the misfit, docs/performance.md, sixth round) and the spline is biased by itself
/// (0.85–1.30 nm at 700 nm on the grid). The focused criterion compares it with the passband
/// continuum and takes that for its smaller estimated error of λ (grid: 0.40–0.57 nm).
#[test]
fn without_the_camera_a_biased_spline_in_u_gives_way_to_the_passband_continuum() {
    let Some(db) = database() else { return };
    let name = CAMERAS[0];
    let mut s = spec(camera(&db, name), ContinuumShape::Cfl, 0.3, 1);
    s.noise = 0.05;
    let (cal, e) = calibrated(&s, &FitOptions::default());
    let bg = cal.background.clone().unwrap();
    let spline = bg
        .candidates
        .iter()
        .filter(|c| c.model.starts_with("continuum"))
        .min_by(|a, b| a.bic.total_cmp(&b.bic))
        .unwrap();
    // the spline's λ where the chosen map puts 700 nm, less 700 (as before: (λ_s − λ_chosen) + e[1])
    let spline_e = spline.nm_at_700_position.unwrap() - 700.0;
    eprintln!(
        "{name}, 5 %, no camera: {:+.3} / {:+.3} nm ({}); best spline in u {} at 700 nm {:+.3}; {}",
        e[0], e[1], bg.model, spline.model, spline_e, bg.selection
    );
    assert!(bg.model.starts_with("passband-continuum"), "{}", bg.model);
    assert!(
        bg.selection.starts_with("bic chose continuum"),
        "{}",
        bg.selection
    );
    assert!(
        e[1].abs() < spline_e.abs(),
        "{e:?} vs the spline's {spline_e}"
    );
    assert!(
        e[0].abs().max(e[1].abs()) <= CFL_5PCT_NO_CAMERA_BOUND_NM,
        "{e:?}"
    );
    // σ here is far above 0.3 nm: the user is told why and what would narrow it
    let hint = sigma_hint(&cal).unwrap_or_else(|| panic!("no σ hint: {:?}", cal.warnings));
    assert!(
        hint.contains("--camera")
            && hint.contains("--camera-database")
            && hint.contains("mercury lamp")
            && hint.contains(&bg.model),
        "{hint}"
    );
    // the accuracy is the user's: asked for 2 nm, σ here (under 2 nm) draws no hint
    let sigma = cal.sigma_nm_at_400.max(cal.sigma_nm_at_700);
    assert!(sigma < 2.0, "σ {sigma}");
    let loose = FitOptions {
        sigma_hint_nm: 2.0,
        ..FitOptions::default()
    };
    let (cal, _) = calibrated(&s, &loose);
    assert!(sigma_hint(&cal).is_none(), "{:?}", cal.warnings);
}

/// The default with `--camera`: one shared spectrum on knots 0.35 FWHM apart, smoothed by a
/// roughness penalty that grows with the noise, fitted by weighted least squares (the noise
/// estimated from the profile). On the seed-1 image of the test above (1 %) and on the same image
/// at 5 % noise it meets issue 12's bounds (0.3 and 0.4 nm) without a choice of knot spacing, and
/// lvf.json's diagnostics say the fit was weighted and by which noise model.
#[test]
fn the_penalised_shared_spectrum_meets_the_cfl_bounds_at_1_and_5_percent_noise() {
    let Some(db) = database() else { return };
    let name = CAMERAS[0];
    let (cam, opts) = with_camera(&db, name);
    for (noise, bound) in [(0.01, CFL_ISSUE_BOUND_NM), (0.05, CFL_5PCT_BOUND_NM)] {
        let mut s = spec(cam.clone(), ContinuumShape::Cfl, 0.3, 1);
        s.noise = noise;
        let (cal, e) = calibrated(&s, &opts);
        let bg = cal.background.as_ref().unwrap();
        let nm = &cal.diagnostics["noise_model"];
        eprintln!(
            "{name}, {:.0} %: {:+.3} / {:+.3} nm ({}); noise model {nm}",
            100.0 * noise,
            e[0],
            e[1],
            bg.model
        );
        assert!(bg.model.starts_with("shared-spectrum"), "{}", bg.model);
        assert!(
            sigma_hint(&cal).is_none(),
            "the hint is for fits without the camera: {:?}",
            cal.warnings
        );
        assert_eq!(nm["weighted"], true, "{nm}");
        assert!(nm["shot_gain"].as_f64().unwrap() > 0.0, "{nm}");
        assert!(e[0].abs() <= bound && e[1].abs() <= bound, "{noise}: {e:?}");
    }
}

/// A CFL under its phosphor continuum with quadratic vignetting 0.3, noise-free, without the
/// camera: the lines are where the list says, so none is reported displaced. The check used to
/// run in the best spline-in-u fit even when the data rejected it (26,800 BIC worse than the
/// passband continuum chosen): its misfit moved 436 and 405/408 nm by 0.6 and 3 nm when freed,
/// two false warnings, and σ at 700 nm grew to 1.77 nm for an error of 0.08.
#[test]
fn a_noise_free_cfl_under_its_continuum_reports_no_displaced_line() {
    let Some(db) = database() else { return };
    let mut s = spec(camera(&db, CAMERAS[0]), ContinuumShape::Cfl, 0.3, 1);
    s.noise = 0.0;
    let (cal, e) = calibrated(&s, &FitOptions::default());
    eprintln!(
        "{}, noise-free, no camera: {:+.3} / {:+.3} nm, σ {:.3} / {:.3} (systematic {:.3} / {:.3}), warnings {:?}",
        CAMERAS[0],
        e[0],
        e[1],
        cal.sigma_nm_at_400,
        cal.sigma_nm_at_700,
        cal.sigma_systematic_nm_at_400,
        cal.sigma_systematic_nm_at_700,
        cal.warnings
    );
    let displaced: Vec<&String> = cal
        .warnings
        .iter()
        .filter(|w| w.contains("is not where the other lines put it"))
        .collect();
    assert!(displaced.is_empty(), "{displaced:?}");
    let report = cal.diagnostics["displaced_lines"].as_array().unwrap();
    assert!(report.iter().all(|d| d["warned"] == false), "{report:?}");
    assert!(e[0].abs().max(e[1].abs()) <= CFL_ISSUE_BOUND_NM, "{e:?}");
}

/// A blend's residual is its centroid's move. A CFL's 542.4 / 546.1 nm lines, unresolved, can
/// trade their amplitudes' split for a rigid shift: on these 5 % draws (Canon, the camera known,
/// maps within 0.06 nm at 546 nm) the shift search put the green blob −1.73 ± 0.46 (seed 1) and
/// −1.66 ± 0.36 nm (seed 5) off and the line RMS, weighted by amplitude, at 1.42 and 1.37 nm;
/// its centroid moves by −0.06 nm.
#[test]
fn a_blends_residual_is_its_centroid_move_not_a_traded_split() {
    let Some(db) = database() else { return };
    let name = CAMERAS[0];
    let (cam, opts) = with_camera(&db, name);
    for seed in [1, 5] {
        let mut s = spec(cam.clone(), ContinuumShape::Cfl, 0.3, seed);
        s.noise = 0.05;
        let (cal, e) = calibrated(&s, &opts);
        let green: Vec<(f64, f64)> = cal
            .lines
            .iter()
            .filter(|l| (542.0..547.0).contains(&l.nm))
            .filter_map(|l| l.residual_nm.zip(l.residual_sigma_nm))
            .collect();
        eprintln!(
            "seed {seed}: map {:+.3} / {:+.3} nm, 542.4/546.1 nm {green:?}, line RMS {:.3} nm",
            e[0], e[1], cal.rms_residual_nm
        );
        assert_eq!(green.len(), 2, "the green blend is placed: {:?}", cal.lines);
        for (r, sd) in green {
            assert!(
                r.abs() <= 0.3 && sd < 0.3,
                "seed {seed}: {r:+.3} ± {sd:.3} nm"
            );
        }
        assert!(
            cal.rms_residual_nm <= 0.3,
            "seed {seed}: line RMS {} nm",
            cal.rms_residual_nm
        );
    }
}

/// Without the camera a continuum drawn per channel can trade with a line; the displaced-line
/// warning names that cause beside an unlisted line or a wrong list entry. On this 5 % draw
/// (Nikon D700, seed 2, the list correct) 436 and 405/408 nm were warned as displaced with only
/// the list's causes named.
#[test]
fn without_the_camera_a_displaced_line_warning_names_the_per_channel_continuum() {
    let Some(db) = database() else { return };
    let name = "Nikon D700";
    let mut s = spec(camera(&db, name), ContinuumShape::Cfl, 0.3, 2);
    s.noise = 0.05;
    let (cal, e) = calibrated(&s, &FitOptions::default());
    let displaced: Vec<&String> = cal
        .warnings
        .iter()
        .filter(|w| w.contains("is not where the other lines put it"))
        .collect();
    eprintln!("{name}, 5 %, seed 2, no camera: {e:?}; {displaced:#?}");
    assert!(!displaced.is_empty(), "{:?}", cal.warnings);
    for w in displaced {
        assert!(
            w.contains("or the continuum drawn per channel (") && w.contains("no --camera"),
            "{w}"
        );
    }
}
