//! `lumifit synth lvf-hg` → `lumifit lvf calibrate` through the binary: the lvf.json contract,
//! the plot, and bad input rejected with exit code 2.

mod common;

use common::tolerances::lvf_cli::*;
use common::{lumifit, stderr};

#[test]
fn calibrate_writes_the_lvf_json_contract_and_recovers_the_synthetic_map() {
    let dir = tempfile::tempdir().unwrap();
    let p = |n: &str| dir.path().join(n).to_str().unwrap().to_string();
    common::synth_default_lamp(dir.path(), "4");
    let o = lumifit(&[
        "lvf",
        "calibrate",
        &p("hg.tiff"),
        "--roi",
        "0,0,1200,160",
        "--axis",
        "x",
        "--lamp",
        "hg",
        "--out",
        &p("lvf.json"),
        "--plot",
        &p("lvf.png"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let cal: serde_json::Value =
        serde_json::from_slice(&std::fs::read(p("lvf.json")).unwrap()).unwrap();
    let truth: serde_json::Value =
        serde_json::from_slice(&std::fs::read(p("truth.json")).unwrap()).unwrap();
    assert_eq!(cal["axis"], "x");
    assert_eq!(cal["roi"], serde_json::json!([0, 0, 1200, 160]));
    assert_eq!(cal["map"]["kind"], "linear");
    let c: Vec<f64> = cal["map"]["coefficients"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    for key in [
        "fwhm_nm",
        "rms_residual_nm",
        "sigma_nm_at_400",
        "sigma_nm_at_700",
    ] {
        assert!(cal[key].as_f64().is_some(), "{key}");
    }
    let bands = cal["bands"].as_array().unwrap();
    assert_eq!(bands.len(), 31);
    for (k, b) in bands.iter().enumerate() {
        assert_eq!(b["nm"].as_f64().unwrap(), 400.0 + 10.0 * k as f64);
        let px = b["px"].as_f64().unwrap();
        assert!(
            (c[0] + c[1] * px - b["nm"].as_f64().unwrap()).abs() < 1e-6,
            "λ(px) = Σ cᵢ pxⁱ"
        );
        assert!(b["width_px"].as_f64().unwrap() > 0.0);
    }
    for (nm, key) in [(400.0, "px_at_400"), (700.0, "px_at_700")] {
        let px = truth[key].as_f64().unwrap();
        assert!((c[0] + c[1] * px - nm).abs() < TOL_NM);
    }
    let png = std::fs::read(p("lvf.png")).unwrap();
    assert_eq!(&png[1..4], b"PNG");
}

#[test]
fn lamp_image_without_lines_and_roi_outside_exit_2_with_the_cause() {
    let dir = tempfile::tempdir().unwrap();
    let p = |n: &str| dir.path().join(n).to_str().unwrap().to_string();
    // A lamp rendered entirely outside the passband range: an image of pure noise.
    let flat = lumifit::capture::synth::uniform_frame("flat", 200, 40, [0.1; 3], 0.01, 3).unwrap();
    std::fs::write(
        p("flat.tiff"),
        lumifit::io::image::frame_to_tiff16(&flat).unwrap(),
    )
    .unwrap();
    let o = lumifit(&[
        "lvf",
        "calibrate",
        &p("flat.tiff"),
        "--roi",
        "0,0,200,40",
        "--axis",
        "x",
        "--out",
        &p("o.json"),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("no lamp lines") && stderr(&o).contains("flat.tiff"),
        "{}",
        stderr(&o)
    );
    let o = lumifit(&[
        "lvf",
        "calibrate",
        &p("flat.tiff"),
        "--roi",
        "150,0,100,40",
        "--axis",
        "x",
        "--out",
        &p("o.json"),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("extends outside"), "{}", stderr(&o));
    assert!(!dir.path().join("o.json").exists(), "no output on failure");
}

/// The list options of the shared continuum (`--shared-knots`, `--shared-smoothness`) and of the
/// splines in u (`--continuum-knots`) refuse a value out of range with exit 2, naming the flag and
/// the range, before reading the image; nothing is written.
#[test]
fn out_of_range_knot_and_smoothness_lists_exit_2_naming_the_flag() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("o.json");
    for (flag, value, range) in [
        ("--shared-knots", "0.35,0.1", "0.25–10 FWHM"),
        ("--shared-smoothness", "-0.01", "0 (no penalty) to 10"),
        ("--continuum-knots", "0.5", "0.8–10 FWHM"),
        ("--sigma-hint", "0", "positive accuracy"),
    ] {
        let o = lumifit(&[
            "lvf",
            "calibrate",
            "no-such-image.tiff",
            "--axis",
            "x",
            &format!("{flag}={value}"),
            "--out",
            out.to_str().unwrap(),
        ]);
        assert_eq!(o.status.code(), Some(2), "{flag}: {}", stderr(&o));
        assert!(
            stderr(&o).contains(flag) && stderr(&o).contains(range),
            "{flag}: {}",
            stderr(&o)
        );
        assert!(!out.exists(), "{flag}: no output on a refused option");
    }
}

/// `synth lvf-hg --pedestal` out of [0, 0.2) is refused naming the flag, exit 2, nothing
/// written; within it, the level is under every pixel (the darkest pixel of a noise-free image
/// is the pedestal) and `lvf calibrate` reports it with the fall-off.
#[test]
fn synth_pedestal_is_checked_and_lvf_calibrate_reports_it() {
    let dir = tempfile::tempdir().unwrap();
    let p = |n: &str| common::p(dir.path(), n);
    for bad in ["-0.01", "0.2", "NaN"] {
        let o = lumifit(&[
            "synth",
            "lvf-hg",
            "--size",
            "300x40",
            "--out",
            &p("hg.tiff"),
            "--truth",
            &p("truth.json"),
            &format!("--pedestal={bad}"),
        ]);
        common::assert_rejected(&o, &["--pedestal", "[0, 0.2)"]);
        assert!(!dir.path().join("hg.tiff").exists() && !dir.path().join("truth.json").exists());
    }
    let (img, _) = common::synth_hg(
        dir.path(),
        &[
            "--lamp",
            "cfl",
            "--noise",
            "0",
            "--vignetting",
            "0.3",
            "--continuum",
            "0.1",
            "--continuum-spectrum",
            "cfl",
            "--pedestal",
            "0.04",
        ],
        1,
    );
    let pixels = image::open(&img).unwrap().to_rgb16();
    let darkest = pixels.pixels().flat_map(|px| px.0).min().unwrap();
    let darkest = darkest as f64 / 65535.0;
    assert!(
        (0.04 - 1e-4..0.045).contains(&darkest),
        "darkest pixel {darkest}"
    );
    let o = lumifit(&[
        "lvf",
        "calibrate",
        &img,
        "--axis",
        "x",
        "--lamp",
        "cfl",
        "--out",
        &p("lvf.json"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let cal = common::read_json(p("lvf.json"));
    let ped = &cal["background"]["radial_falloff"]["pedestal"];
    for c in 0..3 {
        let level = ped[c][0]
            .as_f64()
            .unwrap_or_else(|| panic!("no pedestal: {ped}"));
        assert!((level - 0.04).abs() < 0.004, "channel {c}: {level}");
    }
}

/// A bad `--flat-spectrum` is refused naming that flag (it was named `--continuum-spectrum`, the
/// synthesiser's flag, by both commands), exit 2, nothing written: by `synth lvf-hg --flat-out`
/// before anything is rendered, and by `lvf calibrate --flat`.
#[test]
fn a_bad_flat_spectrum_is_refused_naming_its_own_flag() {
    let dir = tempfile::tempdir().unwrap();
    let p = |n: &str| common::p(dir.path(), n);
    let o = lumifit(&[
        "synth",
        "lvf-hg",
        "--size",
        "300x40",
        "--out",
        &p("hg.tiff"),
        "--truth",
        &p("truth.json"),
        "--flat-out",
        &p("flat.tiff"),
        "--flat-spectrum",
        "blackbody:100",
    ]);
    common::assert_rejected(&o, &["--flat-spectrum", "blackbody:100", "500 ≤ K ≤ 50000"]);
    assert!(
        !stderr(&o).contains("--continuum-spectrum"),
        "{}",
        stderr(&o)
    );
    for f in ["hg.tiff", "truth.json", "flat.tiff"] {
        assert!(
            !dir.path().join(f).exists(),
            "{f} written on a refused flag"
        );
    }
    let (img, _) = common::synth_hg(
        dir.path(),
        &["--size", "300x40", "--flat-out", &p("flat.tiff")],
        1,
    );
    let o = lumifit(&[
        "lvf",
        "calibrate",
        &img,
        "--axis",
        "x",
        "--flat",
        &p("flat.tiff"),
        "--flat-spectrum",
        "halogen",
        "--camera",
        "calib/camera_default.csv",
        "--out",
        &p("lvf.json"),
    ]);
    common::assert_rejected(&o, &["--flat-spectrum", "'halogen'", "blackbody:K"]);
    assert!(
        !stderr(&o).contains("--continuum-spectrum"),
        "{}",
        stderr(&o)
    );
    assert!(
        !dir.path().join("lvf.json").exists(),
        "no output on failure"
    );
}

/// Issue 13 ("garbage is detected"): `lvf calibrate` on a frame that is not a lamp photo (a
/// broadband blackbody through the LVF) and on a CFL image with `--lamp hg` must not exit 0
/// silently: either exit 2 with a message, or warnings on stderr and in lvf.json. Without
/// `--roi` the whole image is used.
#[test]
fn calibrate_on_a_non_lamp_frame_or_the_wrong_lamp_is_refused_or_warned() {
    let dir = tempfile::tempdir().unwrap();
    let p = |n: &str| dir.path().join(n).to_str().unwrap().to_string();
    let o = lumifit(&[
        "synth",
        "lvf-hg",
        "--out",
        &p("cfl.tiff"),
        "--truth",
        &p("truth.json"),
        "--lamp",
        "cfl",
        "--continuum",
        "0.05",
        "--continuum-spectrum",
        "cfl",
        "--seed",
        "8",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    // a blackbody through the same LVF: broadband, no lines
    let bb: String = (360..=830)
        .step_by(5)
        .map(|nm| {
            let l = nm as f64 * 1e-9;
            let v = 1.0 / (l.powi(5) * ((1.4388e-2 / (l * 3000.0)).exp() - 1.0));
            format!("{nm},{}\n", v / 1e30)
        })
        .collect();
    std::fs::write(p("bb.csv"), format!("wavelength_nm,value\n{bb}")).unwrap();
    let o = lumifit(&[
        "synth",
        "lvf-capture",
        "--spectrum",
        &p("bb.csv"),
        "--lvf",
        &p("truth.json"),
        "--seed",
        "9",
        "--out",
        &p("bb.tiff"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    for (img, lamp) in [("cfl.tiff", "hg"), ("bb.tiff", "hg")] {
        let out = p(&format!("{img}.json"));
        let o = lumifit(&[
            "lvf",
            "calibrate",
            &p(img),
            "--axis",
            "x",
            "--lamp",
            lamp,
            "--out",
            &out,
        ]);
        let err = stderr(&o);
        if o.status.success() {
            let cal: serde_json::Value =
                serde_json::from_slice(&std::fs::read(&out).unwrap()).unwrap();
            // a warning of the mismatch, not only the hint that a continuum widened σ
            let n = cal["warnings"].as_array().map_or(0, |w| {
                w.iter()
                    .filter(|m| {
                        !m.as_str()
                            .is_some_and(|m| m.starts_with("σ at 400 / 700 nm is"))
                    })
                    .count()
            });
            assert!(
                n > 0 && err.contains("warning"),
                "{img} with --lamp {lamp}: exit 0 without a warning: {cal}"
            );
        } else {
            assert_eq!(o.status.code(), Some(2), "{img}: {err}");
            assert!(
                err.contains(img),
                "{img}: the message names the image: {err}"
            );
            assert!(
                !std::path::Path::new(&out).exists(),
                "{img}: nothing written"
            );
        }
        eprintln!("{img} --lamp {lamp}: exit {:?}: {err}", o.status.code());
    }
}

/// The defaults `--help` shows for the continuum lists are the library's constants (they are
/// written twice: as clap default strings and as `FitOptions::default()`'s).
#[test]
fn the_help_defaults_of_the_continuum_lists_are_the_library_constants() {
    let o = lumifit(&["lvf", "calibrate", "--help"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let help = String::from_utf8_lossy(&o.stdout).to_string();
    // the `[default: …]` after a flag's name
    let default_of = |flag: &str| -> Vec<f64> {
        let at = help
            .find(&format!("--{flag} <"))
            .unwrap_or_else(|| panic!("--{flag} not in --help"));
        let rest = &help[at..];
        let d = rest.find("[default: ").expect("a default") + "[default: ".len();
        let end = rest[d..].find(']').unwrap();
        rest[d..d + end]
            .split(',')
            .map(|v| v.trim().parse().unwrap())
            .collect()
    };
    use lumifit::lvf::background::CONTINUUM_KNOT_FWHM;
    use lumifit::lvf::shared_continuum::{SHARED_KNOT_FWHM, SHARED_SMOOTHNESS};
    assert_eq!(default_of("continuum-knots"), CONTINUUM_KNOT_FWHM.to_vec());
    assert_eq!(default_of("shared-knots"), SHARED_KNOT_FWHM.to_vec());
    assert_eq!(default_of("shared-smoothness"), SHARED_SMOOTHNESS.to_vec());
    assert_eq!(
        default_of("sigma-hint"),
        vec![lumifit::lvf::CONTINUUM_SIGMA_HINT_NM]
    );
    let defaults = lumifit::lvf::FitOptions::default();
    assert_eq!(defaults.shared_smoothness, SHARED_SMOOTHNESS.to_vec());
}

#[test]
fn a_passband_shape_rendered_by_synth_is_fitted_by_calibrate_and_carried_by_lvf_json() {
    let dir = tempfile::tempdir().unwrap();
    let p = |n: &str| dir.path().join(n).to_str().unwrap().to_string();
    common::synth_hg(
        dir.path(),
        &["--passband", "gennorm:2.5", "--size", "1200x40"],
        4,
    );
    let truth = common::read_json(p("truth.json"));
    assert_eq!(truth["passband"]["beta"], 2.5);
    let o = lumifit(&[
        "lvf",
        "calibrate",
        &p("hg.tiff"),
        "--axis",
        "x",
        "--passband",
        "gennorm",
        "--out",
        &p("lvf.json"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let cal: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(p("lvf.json")).unwrap()).unwrap();
    assert_eq!(cal["passband"]["shape"], "gennorm");
    let beta = cal["passband"]["beta"].as_f64().unwrap();
    assert!((beta - 2.5).abs() < 0.15, "β {beta}");
    let lam = |px: f64| {
        let c = cal["map"]["coefficients"].as_array().unwrap();
        c.iter()
            .enumerate()
            .map(|(i, v)| v.as_f64().unwrap() * px.powi(i as i32))
            .sum::<f64>()
    };
    for (k, nm) in [("px_at_400", 400.0), ("px_at_700", 700.0)] {
        let e = lam(truth[k].as_f64().unwrap()) - nm;
        assert!(e.abs() < 0.15, "{k}: {e}");
    }
    // the next command reads the shape back: lvf.json feeds the geometry of the captures
    let g =
        lumifit::lvf::LvfGeometry::from_json(&std::fs::read(p("lvf.json")).unwrap(), "lvf.json")
            .unwrap();
    assert_eq!(g.passband, lumifit::lvf::Passband::GenNormal { beta });
    // an exponent out of range: exit 2, named, nothing written
    for args in [
        vec![
            "lvf",
            "calibrate",
            &p("hg.tiff"),
            "--axis",
            "x",
            "--passband",
            "gennorm:0",
            "--out",
        ],
        vec![
            "synth",
            "lvf-hg",
            "--passband",
            "gennorm:x",
            "--truth",
            &p("t2.json"),
            "--out",
        ],
    ] {
        let mut a = args.clone();
        let out = p("never.json");
        a.push(&out);
        let o = lumifit(&a);
        assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
        assert!(stderr(&o).contains("--passband"), "{}", stderr(&o));
        assert!(!std::path::Path::new(&out).exists());
        assert!(!std::path::Path::new(&p("t2.json")).exists());
    }
}

/// A mercury table rounded to whole nanometres moves the map (436 and 546 nm alone fix it; the
/// doublets' free splits cannot contradict them) and nothing in the profile shows it: the table
/// is checked against the NIST wavelengths and a warning names each line, on stderr and in
/// lvf.json. The same image with `--lamp hg` draws no such warning.
#[test]
fn a_mercury_table_off_the_nist_wavelengths_is_warned_line_by_line() {
    let dir = tempfile::tempdir().unwrap();
    let p = |n: &str| dir.path().join(n).to_str().unwrap().to_string();
    common::synth_default_lamp(dir.path(), "4");
    std::fs::write(
        p("hg_rounded.csv"),
        "wavelength_nm,relative_power\n405,0.40\n408,0.04\n436,1.00\n546,0.90\n577,0.20\n579,0.22\n",
    )
    .unwrap();
    let calibrate = |lamp: &str, out: &str| {
        let o = lumifit(&[
            "lvf",
            "calibrate",
            &p("hg.tiff"),
            "--axis",
            "x",
            "--lamp",
            lamp,
            "--out",
            &p(out),
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        let cal: serde_json::Value =
            serde_json::from_slice(&std::fs::read(p(out)).unwrap()).unwrap();
        let warned: Vec<String> = cal["warnings"]
            .as_array()
            .unwrap()
            .iter()
            .filter_map(|w| w.as_str())
            .filter(|w| w.contains("NIST air wavelengths"))
            .map(String::from)
            .collect();
        (stderr(&o), warned)
    };
    let (err, warned) = calibrate(&p("hg_rounded.csv"), "rounded.json");
    assert_eq!(warned.len(), 1, "{warned:?}");
    for named in [
        "436 nm (+0.167 nm from 435.833)",
        "546 nm (-0.074 nm from 546.074)",
    ] {
        assert!(warned[0].contains(named), "{named}: {}", warned[0]);
        assert!(err.contains(named), "{named}: {err}");
    }
    let (_, warned) = calibrate("hg", "exact.json");
    assert!(warned.is_empty(), "{warned:?}");
}
