//! `lvf calibrate --flat`: a flat-field photo through the LVF (issue 12). With the flat's source
//! spectrum and camera known, the fall-off along and across the axis is divided out and the map
//! meets the 0.15 nm at 400/700 nm on the fall-off shapes the lamp photo alone cannot
//! see (linear tilt, off-centre, cos⁴ with a blackbody continuum); a flat of another size, a
//! saturated or a dark flat is refused with exit 2, naming the file, writing nothing. The Jiang
//! camera case reads `../shared/data/camera/` in place (skip message when absent, failure when
//! `LUMIFIT_REQUIRE_DATA=1`).

use std::path::{Path, PathBuf};
use std::process::Command;

mod common;
use common::tolerances::lvf_continuum::HG_TOL_NM;

/// Error at 400/700 nm left with a flat of known spectrum on an image without continuum (1 %
/// noise: the noise-only error of the clean lamp is ≈ 0.01 nm; a tilt not divided out gives
/// ≈ 0.09 nm).
const FLAT_CLEAN_TOL_NM: f64 = 0.04;
/// Two images differing only in a fall-off that the flat divides out agree to this (noise of two
/// fits with different shot noise, ≈ 2× the clean error).
const FLAT_SAME_TOL_NM: f64 = 0.06;

fn bin() -> &'static str {
    env!("CARGO_BIN_EXE_lumifit")
}

fn run(args: &[&str]) -> std::process::Output {
    Command::new(bin())
        .args(args)
        .output()
        .expect("run lumifit")
}

/// A scratch directory of this process's own (a fixed name is shared by concurrent runs of the
/// test binary, which then remove each other's files).
fn scratch(name: &str) -> PathBuf {
    let d = PathBuf::from(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("lvf_flat_{name}_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("scratch dir");
    d
}

fn default_camera() -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("calib/camera_default.csv")
        .display()
        .to_string()
}

/// Synthesises lamp + matching flat, calibrates with the flat; returns (err400, err700,
/// σ400, σ700, lvf.json).
fn lamp_and_flat(
    d: &Path,
    camera: &str,
    vignetting: &str,
    fraction: &str,
    continuum: &str,
    flat_spectrum: &str,
) -> (f64, f64, f64, f64, serde_json::Value) {
    let (img, truth, flat, out) = (
        d.join("l.tiff"),
        d.join("t.json"),
        d.join("f.tiff"),
        d.join("o.json"),
    );
    let s = |p: &Path| p.display().to_string();
    let r = run(&[
        "synth",
        "lvf-hg",
        "--out",
        &s(&img),
        "--truth",
        &s(&truth),
        "--lamp",
        "hg",
        "--nm-at-start",
        "372.3",
        "--nm-per-px",
        "0.3117",
        "--fwhm",
        "25",
        "--camera",
        camera,
        "--noise",
        "0.01",
        "--vignetting",
        vignetting,
        "--continuum",
        fraction,
        "--continuum-spectrum",
        continuum,
        "--seed",
        "3",
        "--flat-out",
        &s(&flat),
        "--flat-spectrum",
        flat_spectrum,
    ]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let r = run(&[
        "lvf",
        "calibrate",
        &s(&img),
        "--axis",
        "x",
        "--lamp",
        "hg",
        "--out",
        &s(&out),
        "--flat",
        &s(&flat),
        "--flat-spectrum",
        flat_spectrum,
        "--camera",
        camera,
    ]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let t = common::read_json(&truth);
    let c = common::read_json(&out);
    let [e4, e7] = common::lvf_map_errors(&c, &t);
    let s4 = c["sigma_nm_at_400"].as_f64().unwrap();
    let s7 = c["sigma_nm_at_700"].as_f64().unwrap();
    (e4, e7, s4, s7, c)
}

fn database() -> Option<PathBuf> {
    let db = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/data/camera/jiang2013_camspec_all_cameras_long.csv");
    if db.is_file() {
        return Some(db);
    }
    assert!(
        std::env::var("LUMIFIT_REQUIRE_DATA").as_deref() != Ok("1"),
        "LUMIFIT_REQUIRE_DATA=1 but {} is missing",
        db.display()
    );
    eprintln!(
        "SKIPPED: {} is absent; the Jiang-camera flat-field checks did not run",
        db.display()
    );
    None
}

const SHAPES: [(&str, &str); 3] = [
    ("linear:0.3", "flat"),
    ("offcentre:0.3", "flat"),
    ("cos4:0.3", "blackbody:2700"),
];

/// Without a continuum the fall-off is the only systematic: the flat must remove it (a linear
/// tilt of 0.3 biases the map by ≈ 0.3·σ_g²/span ≈ 0.09 nm when it is not divided out).
#[test]
fn flat_field_with_known_spectrum_removes_tilt_offcentre_and_cos4() {
    let cam = default_camera();
    for (vig, _) in SHAPES {
        let d = scratch(&vig.replace(':', "_"));
        let (e4, e7, s4, s7, c) = lamp_and_flat(&d, &cam, vig, "0", "flat", "blackbody:3000");
        println!(
            "default camera, {vig}, 1 % noise, flat field (blackbody 3000 K): error {e4:+.4} / {e7:+.4} nm, reported σ {s4:.4} / {s7:.4} nm"
        );
        let src = c["background"]["falloff_source"].as_str().unwrap();
        assert!(src.starts_with("flat-field "), "{src}");
        assert!(
            c["background"]["flat_field"]
                .as_str()
                .unwrap()
                .ends_with("f.tiff"),
            "{}",
            c["background"]["flat_field"]
        );
        assert!(
            e4.abs() <= FLAT_CLEAN_TOL_NM && e7.abs() <= FLAT_CLEAN_TOL_NM,
            "{vig}: {e4} / {e7}"
        );
        // σ is not asserted here: on a clean image it is statistical (≈ 0.004 nm) and does not
        // cover the ≈ 0.01 nm the continuum candidate adds (see docs/capture.md)
        let _ = std::fs::remove_dir_all(&d);
    }
}

/// Issue 12's case (continuum 10 %, fall-off 0.3 of any shape, 1 % noise) on the Canon 5D
/// Mark II: the bound is met on the shapes the lamp photo alone cannot see.
#[test]
fn flat_field_meets_the_bound_on_hard_shapes_with_a_continuum() {
    let Some(db) = database() else { return };
    let cam = format!("{}:Canon 5DMarkII", db.display());
    for (vig, cont) in SHAPES {
        let d = scratch(&format!("canon_{}", vig.replace(':', "_")));
        let (e4, e7, s4, s7, _) = lamp_and_flat(&d, &cam, vig, "0.1", cont, "blackbody:3000");
        println!("Canon 5D Mark II, {vig} + 10 % {cont}, flat field: error {e4:+.4} / {e7:+.4} nm, σ {s4:.4} / {s7:.4}");
        assert!(
            e4.abs() <= HG_TOL_NM && e7.abs() <= HG_TOL_NM,
            "{vig}: {e4} / {e7}"
        );
        // with a continuum the model-choice spread is part of σ, and it covers the error
        assert!(e4.abs() <= s4 && e7.abs() <= s7, "{vig}: σ {s4} / {s7}");
        let _ = std::fs::remove_dir_all(&d);
    }
}

/// The Nikon D700's miss is the continuum's, not the fall-off's: with the fall-off divided out
/// by the flat, the error equals that of the same image without vignetting (and that one misses
/// 0.15 nm at 700 nm: a 10 % blackbody continuum through the D700 is not drawn well enough by
/// the per-channel spline).
#[test]
fn with_a_flat_the_nikon_d700_error_is_that_of_no_vignetting() {
    let Some(db) = database() else { return };
    let cam = format!("{}:Nikon D700", db.display());
    let d = scratch("d700");
    let (e4, e7, _, _, _) = lamp_and_flat(
        &d,
        &cam,
        "cos4:0.3",
        "0.1",
        "blackbody:2700",
        "blackbody:3000",
    );
    let (n4, n7, _, _, _) = lamp_and_flat(&d, &cam, "0", "0.1", "blackbody:2700", "blackbody:3000");
    println!("Nikon D700, 10 % blackbody 2700 K: cos4 0.3 with flat {e4:+.4} / {e7:+.4} nm; no vignetting {n4:+.4} / {n7:+.4} nm");
    assert!(
        (e4 - n4).abs() <= FLAT_SAME_TOL_NM && (e7 - n7).abs() <= FLAT_SAME_TOL_NM,
        "{e4} {e7} vs {n4} {n7}"
    );
    let _ = std::fs::remove_dir_all(&d);
}

/// Writes a uniform 16-bit TIFF of `value` (0–1) of the given size.
fn uniform_tiff(path: &Path, w: usize, h: usize, value: f32) {
    let frame =
        lumifit::capture::RgbFrame::new("uniform", w, h, 1, vec![value; 3 * w * h], vec![0; w * h])
            .unwrap();
    std::fs::write(path, lumifit::io::image::frame_to_tiff16(&frame).unwrap()).unwrap();
}

#[test]
fn a_flat_of_another_size_saturated_or_dark_is_refused_naming_the_file() {
    let d = scratch("errors");
    let s = |p: &Path| p.display().to_string();
    let (img, truth) = (d.join("l.tiff"), d.join("t.json"));
    let r = run(&[
        "synth",
        "lvf-hg",
        "--out",
        &s(&img),
        "--truth",
        &s(&truth),
        "--noise",
        "0.01",
        "--size",
        "600x80",
    ]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let cases = [
        ("small.tiff", 500usize, 80usize, 0.5f32, "600×80"),
        ("saturated.tiff", 600, 80, 1.0, "saturated"),
        ("dark.tiff", 600, 80, 0.004, "too dark"),
    ];
    for (name, w, h, v, expect) in cases {
        let flat = d.join(name);
        uniform_tiff(&flat, w, h, v);
        let out = d.join("o.json");
        let r = run(&[
            "lvf",
            "calibrate",
            &s(&img),
            "--axis",
            "x",
            "--out",
            &s(&out),
            "--flat",
            &s(&flat),
        ]);
        let err = String::from_utf8_lossy(&r.stderr);
        assert_eq!(r.status.code(), Some(2), "{name}: {err}");
        assert!(err.contains(name) && err.contains(expect), "{name}: {err}");
        assert!(!out.exists(), "{name}: nothing may be written");
        println!("{name}: {}", err.trim());
    }
    // a flat spectrum without the camera that sees it
    let flat = d.join("ok.tiff");
    uniform_tiff(&flat, 600, 80, 0.5);
    let out = d.join("o.json");
    let r = run(&[
        "lvf",
        "calibrate",
        &s(&img),
        "--axis",
        "x",
        "--out",
        &s(&out),
        "--flat",
        &s(&flat),
        "--flat-spectrum",
        "blackbody:3000",
    ]);
    let err = String::from_utf8_lossy(&r.stderr);
    assert_eq!(r.status.code(), Some(2), "{err}");
    assert!(err.contains("--camera"), "{err}");
    assert!(!out.exists());
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn without_its_spectrum_a_flat_is_used_across_the_axis_and_says_so() {
    let d = scratch("radial");
    let s = |p: &Path| p.display().to_string();
    let (img, truth, flat, out) = (
        d.join("l.tiff"),
        d.join("t.json"),
        d.join("f.tiff"),
        d.join("o.json"),
    );
    let r = run(&[
        "synth",
        "lvf-hg",
        "--out",
        &s(&img),
        "--truth",
        &s(&truth),
        "--noise",
        "0.01",
        "--vignetting",
        "quadratic:0.3",
        "--nm-at-start",
        "372.3",
        "--nm-per-px",
        "0.3117",
        "--flat-out",
        &s(&flat),
    ]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let r = run(&[
        "lvf",
        "calibrate",
        &s(&img),
        "--axis",
        "x",
        "--out",
        &s(&out),
        "--flat",
        &s(&flat),
    ]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let c: serde_json::Value = serde_json::from_slice(&std::fs::read(&out).unwrap()).unwrap();
    let t: serde_json::Value = serde_json::from_slice(&std::fs::read(&truth).unwrap()).unwrap();
    let src = c["background"]["falloff_source"].as_str().unwrap();
    assert!(
        src.starts_with("flat-field ") && src.contains("across-axis only"),
        "{src}"
    );
    let [e4, e7] = common::lvf_map_errors(&c, &t);
    println!("quadratic 0.3 (radial), flat without spectrum: error {e4:+.4} / {e7:+.4} nm");
    // a radial fall-off is what the across-axis estimate sees
    assert!(
        e4.abs() <= HG_TOL_NM && e7.abs() <= HG_TOL_NM,
        "{e4} / {e7}"
    );
    let _ = std::fs::remove_dir_all(&d);
}
