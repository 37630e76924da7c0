//! `lumifit synth lvf-hg` → `lumifit lvf calibrate` through the binary: the lvf.json contract,
//! the plot, and bad input rejected with exit code 2.

mod common;

use common::tolerances::lvf_cli::*;
use common::{lumifit, stderr};

#[test]
fn calibrate_writes_the_lvf_json_contract_and_recovers_the_synthetic_map() {
    let dir = tempfile::tempdir().unwrap();
    let p = |n: &str| dir.path().join(n).to_str().unwrap().to_string();
    let o = lumifit(&[
        "synth",
        "lvf-hg",
        "--out",
        &p("hg.tiff"),
        "--truth",
        &p("truth.json"),
        "--seed",
        "4",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
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
