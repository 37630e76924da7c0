//! Synthetic phosphorescence frames (`synth phos-decay`) read back through the series loader and
//! fitted from a region of interest (`phos fit-decay SERIES --roi`), and bad input rejected with
//! exit code 2.

use std::path::Path;
use std::process::{Command, Output};

use lumifit::io::series::{load_series, SeriesOptions};
use lumifit::phosphor::synth::{two_state_variant, DecayFrames, DecaySeriesSpec, FrameLayout};
use lumifit::phosphor::{table1_material, BandCamera};
mod common;
use common::tolerances::phos_series::*;

fn lumifit(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_lumifit"))
        .args(args)
        .output()
        .expect("the lumifit binary runs")
}

fn ok(o: &Output) {
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

fn rejected(o: &Output, fragments: &[&str]) {
    let e = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "stderr: {e}");
    assert!(!e.contains("panicked"), "panic: {e}");
    for f in fragments {
        assert!(e.contains(f), "stderr lacks '{f}': {e}");
    }
}

fn s(p: &Path) -> String {
    p.to_string_lossy().to_string()
}

fn synth_halves(dir: &Path) -> String {
    let out = dir.join("frames");
    ok(&lumifit(&[
        "synth",
        "phos-decay",
        "--material",
        "green_paint",
        "--size",
        "24x10",
        "--layout",
        "halves",
        "--seed",
        "5",
        "--out",
        &s(&out),
    ]));
    s(&out.join("manifest.csv"))
}

fn rates(json: &Path) -> Vec<f64> {
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(json).unwrap()).unwrap();
    v["phosphorescence"]["states"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s["k_r_per_s"].as_f64().unwrap())
        .collect()
}

#[test]
fn synthetic_frames_load_as_a_series_whose_roi_curve_matches_the_simulation() {
    let d = tempfile::tempdir().unwrap();
    let manifest = synth_halves(d.path());
    let loaded = load_series(Path::new(&manifest), &SeriesOptions::default(), &|| {}).unwrap();
    assert_eq!(loaded.series.len(), 37);
    // the relative radiance of the left half is the noiseless simulated curve: frames hold
    // gain × curve × exposure and the manifest's ISO is 100 × gain (pipeline::synth_frames_iso)
    let m = &table1_material("green_paint").unwrap().material;
    let cam = BandCamera::for_bands(&m.bands, None).unwrap();
    let spec = DecaySeriesSpec {
        charge_s: 5400.0,
        frames: 37,
        interval_s: 5.0,
        exposure_s: 1.0,
        noise: 0.01,
        seed: 5,
    };
    let fr = DecayFrames::new(m, FrameLayout::Halves, &cam, &spec, 24, 10).unwrap();
    let roi = lumifit::capture::Roi::parse_rect("0,0,12,10").unwrap();
    let curve = loaded.series.extract(&roi).unwrap();
    for (j, sample) in curve.iter().take(3).enumerate() {
        let want = fr.clean_value(0, j)[1] / fr.exposure_s / fr.gain;
        let got = sample.mean[1];
        // 120 pixels at 1 % noise: the mean is within 0.5 % of the clean value
        assert!(
            (got / want - 1.0).abs() < 0.005,
            "frame {j}: {got} vs {want}"
        );
    }
}

#[test]
fn roi_fit_of_each_half_recovers_one_and_two_rates() {
    let d = tempfile::tempdir().unwrap();
    let manifest = synth_halves(d.path());
    let left = d.path().join("left.json");
    ok(&lumifit(&[
        "phos",
        "fit-decay",
        &manifest,
        "--roi",
        "0,0,12,10",
        "--background",
        "--out",
        &s(&left),
    ]));
    let k = rates(&left);
    assert_eq!(k.len(), 1, "{k:?}");
    assert!((k[0] / 0.227 - 1.0).abs() < ROI_RATE_TOL, "{k:?}");
    let right = d.path().join("right.json");
    ok(&lumifit(&[
        "phos",
        "fit-decay",
        "--series",
        &manifest,
        "--roi",
        "12,0,12,10",
        "--out",
        &s(&right),
    ]));
    let k = rates(&right);
    let v = two_state_variant(&table1_material("green_paint").unwrap().material).unwrap();
    assert_eq!(k.len(), 2, "{k:?}");
    for (got, st) in k.iter().zip(&v.states) {
        assert!((got / st.k_r_per_s - 1.0).abs() < ROI_RATE_TOL, "{k:?}");
    }
}

#[test]
fn a_roi_outside_the_frames_is_rejected_naming_the_roi() {
    let d = tempfile::tempdir().unwrap();
    let manifest = synth_halves(d.path());
    let o = lumifit(&[
        "phos",
        "fit-decay",
        &manifest,
        "--roi",
        "20,0,10,10",
        "--out",
        &s(&d.path().join("x.json")),
    ]);
    rejected(&o, &["20,0,10,10"]);
}

#[test]
fn a_manifest_with_a_bad_time_is_rejected_naming_file_and_line() {
    let d = tempfile::tempdir().unwrap();
    let manifest = synth_halves(d.path());
    let text = std::fs::read_to_string(&manifest).unwrap();
    let bad = text.replacen(",10,1,", ",ten,1,", 1);
    std::fs::write(&manifest, bad).unwrap();
    let o = lumifit(&[
        "phos",
        "fit-decay",
        &manifest,
        "--roi",
        "0,0,4,4",
        "--out",
        &s(&d.path().join("x.json")),
    ]);
    rejected(&o, &["manifest.csv", "line 4", "ten"]);
}

#[test]
fn a_bad_frame_size_is_rejected_with_the_expected_form() {
    let d = tempfile::tempdir().unwrap();
    let o = lumifit(&[
        "synth",
        "phos-decay",
        "--material",
        "green_paint",
        "--size",
        "24by10",
        "--seed",
        "1",
        "--out",
        &s(&d.path().join("f")),
    ]);
    rejected(&o, &["--size", "WxH"]);
}

#[test]
fn per_pixel_fit_writes_float_maps_and_a_summary() {
    let d = tempfile::tempdir().unwrap();
    let manifest = synth_halves(d.path());
    let out = d.path().join("maps");
    ok(&lumifit(&[
        "phos",
        "fit-decay",
        &manifest,
        "--per-pixel",
        "--block",
        "2",
        "--out",
        &s(&out),
    ]));
    for f in [
        "k1_per_s.tif",
        "a1.tif",
        "n_states.tif",
        "rms.tif",
        "spectrum_rgb.tif",
    ] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(v["map_size"], serde_json::json!([12, 5]));
    assert_eq!(
        v["fitted"].as_u64().unwrap() + v["failed"].as_u64().unwrap(),
        60
    );
    let (k1, _) = lumifit::io::image::read_image(&out.join("k1_per_s.tif")).unwrap();
    assert_eq!((k1.width, k1.height), (12, 5));
}
