//! Documented chains (docs/cli.md), each output a valid input of the natural next step (issue 13):
//!
//! - lamp photo → `lvf calibrate` → a capture of a light → `spectrum recover` → `color xyz` on the
//!   recovered CSV, whose `std` column the spectrum reader ignores;
//! - `synth phos-decay` frames → `series extract` (a region curve with per-channel spreads and
//!   pixel counts) → `phos fit-decay` on that curve.

mod common;
use common::{lumifit, p, stderr, write};

fn ok(o: &std::process::Output) {
    assert!(o.status.success(), "{}", stderr(o));
}

#[test]
fn a_recovered_spectrum_feeds_color_xyz() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    ok(&lumifit(&[
        "synth",
        "lvf-hg",
        "--out",
        &p(d, "hg.tiff"),
        "--truth",
        &p(d, "truth.json"),
        "--seed",
        "1",
    ]));
    ok(&lumifit(&[
        "lvf",
        "calibrate",
        &p(d, "hg.tiff"),
        "--roi",
        "0,0,1200,160",
        "--axis",
        "x",
        "--out",
        &p(d, "lvf.json"),
    ]));
    write(
        d,
        "light.csv",
        "wavelength_nm,value\n380,0.2\n500,0.9\n600,0.5\n780,0.3\n",
    );
    ok(&lumifit(&[
        "synth",
        "lvf-capture",
        "--spectrum",
        &p(d, "light.csv"),
        "--lvf",
        &p(d, "lvf.json"),
        "--size",
        "1200x160",
        "--seed",
        "2",
        "--out",
        &p(d, "cap.tiff"),
    ]));
    ok(&lumifit(&[
        "spectrum",
        "recover",
        &p(d, "cap.tiff"),
        "--bands",
        &p(d, "lvf.json"),
        "--out",
        &p(d, "rec.csv"),
    ]));
    let rec = std::fs::read_to_string(d.join("rec.csv")).unwrap();
    assert!(
        rec.starts_with("wavelength_nm,value,std"),
        "{}",
        &rec[..40.min(rec.len())]
    );
    let o = lumifit(&["color", "xyz", "--sd", &p(d, "rec.csv")]);
    ok(&o);
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let xyz: Vec<f64> = v["XYZ"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    assert!(xyz.iter().all(|x| x.is_finite() && *x > 0.0), "{xyz:?}");
    // A light that peaks at 500 nm recovers greenish: y above x.
    let xy = v["xyY"].as_array().unwrap();
    assert!(xy[1].as_f64().unwrap() > xy[0].as_f64().unwrap(), "{xy:?}");
}

#[test]
fn a_series_extract_curve_feeds_phos_fit_decay() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let frames = d.join("s");
    ok(&lumifit(&[
        "synth",
        "phos-decay",
        "--material",
        "green_paint",
        "--seed",
        "7",
        "--size",
        "64x64",
        "--out",
        frames.to_str().unwrap(),
    ]));
    ok(&lumifit(&[
        "series",
        "extract",
        &p(d, "s/manifest.csv"),
        "--roi",
        "0,0,64,64",
        "--out",
        &p(d, "c.csv"),
    ]));
    let o = lumifit(&[
        "phos",
        "fit-decay",
        &p(d, "c.csv"),
        "--out",
        &p(d, "m.json"),
    ]);
    ok(&o);
    let m: serde_json::Value =
        serde_json::from_slice(&std::fs::read(d.join("m.json")).unwrap()).unwrap();
    let states = m["phosphorescence"]["states"].as_array().unwrap();
    assert_eq!(states.len(), 1, "green paint has one state: {states:?}");
    let k = states[0]["k_r_per_s"].as_f64().unwrap();
    // Table 1: green paint k_r = 0.227 s⁻¹; 1 % noise over 4096 pixels pins it far tighter.
    assert!((k - 0.227).abs() < 0.03 * 0.227, "k_r = {k}");
}
