//! The `lumifit` binary as a user runs it: JSON outputs that agree with colour-science, and bad
//! input rejected with exit code 2 and a message naming the file, the line and what was expected.

mod common;

use common::{assert_rejected, lumifit, stderr, write};

use std::path::PathBuf;
use std::process::{Command, Output};

fn lumifit_stdin(args: &[&str], input: &[u8]) -> Output {
    use std::io::Write;
    let mut child = Command::new(env!("CARGO_BIN_EXE_lumifit"))
        .args(args)
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("spawn");
    child.stdin.take().unwrap().write_all(input).unwrap();
    child.wait_with_output().unwrap()
}

fn json(o: &Output) -> serde_json::Value {
    assert!(o.status.success(), "failed: {}", stderr(o));
    serde_json::from_slice(&o.stdout).expect("stdout is JSON")
}

/// A fixture spectrum with colour's expected XYZ for each observer/illuminant/method.
fn fixture_cases() -> (serde_json::Value, Vec<serde_json::Value>) {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("fixtures/sd_to_xyz.json");
    let f: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap();
    let cases = f["cases"].as_array().unwrap().clone();
    (f, cases)
}

#[test]
fn color_xyz_agrees_with_colour_for_both_methods_and_three_observers() {
    let dir = tempfile::tempdir().unwrap();
    let (f, cases) = fixture_cases();
    let mut checked = 0;
    // Spectra 0..4 cover 1, 5, 10 and 20 nm.
    for case in cases
        .iter()
        .filter(|c| c["spectrum"].as_u64().unwrap() < 4 && c["k"].is_null())
    {
        let sid = case["spectrum"].as_u64().unwrap() as usize;
        let s = &f["spectra"][sid];
        let mut csv = String::from("wavelength_nm,value\n");
        for (w, v) in s["wavelength_nm"]
            .as_array()
            .unwrap()
            .iter()
            .zip(s["value"].as_array().unwrap())
        {
            csv.push_str(&format!(
                "{},{}\n",
                w.as_f64().unwrap(),
                v.as_f64().unwrap()
            ));
        }
        let p = write(dir.path(), &format!("s{sid}.csv"), csv.as_bytes());
        let out = json(&lumifit(&[
            "color",
            "xyz",
            "--sd",
            p.to_str().unwrap(),
            "--illuminant",
            case["illuminant"].as_str().unwrap(),
            "--observer",
            case["observer"].as_str().unwrap(),
            "--method",
            case["method"].as_str().unwrap(),
        ]));
        for c in 0..3 {
            let got = out["XYZ"][c].as_f64().unwrap();
            let want = case["xyz"][c].as_f64().unwrap();
            assert!(
                (got - want).abs() <= 1e-6 * want.abs(),
                "{case}: {got} vs {want}"
            );
        }
        for key in ["xyY", "Lab", "sRGB"] {
            assert_eq!(out[key].as_array().unwrap().len(), 3, "{key}");
        }
        checked += 1;
    }
    assert!(checked >= 4 * 3 * 4 * 2, "only {checked} CLI cases");
}

#[test]
fn color_xyz_reads_standard_input_and_uses_colour_defaults() {
    let mut csv = String::from("wavelength_nm,value\n");
    for i in 0..=80 {
        csv.push_str(&format!("{},{}\n", 380 + 5 * i, 0.5));
    }
    let out = json(&lumifit_stdin(
        &["color", "xyz", "--sd", "-"],
        csv.as_bytes(),
    ));
    assert_eq!(out["observer"], "cie1931-2");
    assert_eq!(out["illuminant"], "D65");
    assert_eq!(out["method"], "astm-e308");
    // A flat 50 % reflector under D65 has Y = 50 and the white's chromaticity.
    assert!((out["XYZ"][1].as_f64().unwrap() - 50.0).abs() < 1e-9);
    assert!((out["Lab"][1].as_f64().unwrap()).abs() < 1e-9);
}

#[test]
fn delta_e_prints_json() {
    let out = json(&lumifit(&[
        "color",
        "delta-e",
        "--lab1",
        "50,2.6772,-79.7751",
        "--lab2",
        "50,0,-82.7485",
    ]));
    // Sharma et al. (2005) pair 1: ΔE00 = 2.0425.
    assert!(
        (out["delta_e"].as_f64().unwrap() - 2.0425).abs() < 5e-5,
        "{out}"
    );
}

#[test]
fn convert_round_trips_lab_through_xyz() {
    let lab = json(&lumifit(&[
        "color",
        "convert",
        "--from",
        "xyz",
        "--to",
        "lab",
        "--value",
        "0.2,0.3,0.4",
    ]));
    let v: Vec<String> = lab["value"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.to_string())
        .collect();
    let back = json(&lumifit(&[
        "color",
        "convert",
        "--from",
        "lab",
        "--to",
        "xyz",
        "--value",
        &v.join(","),
    ]));
    for (i, want) in [0.2, 0.3, 0.4].iter().enumerate() {
        assert!((back["value"][i].as_f64().unwrap() - want).abs() < 1e-12);
    }
}

#[test]
fn decreasing_wavelengths_are_rejected_naming_file_and_line() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(
        dir.path(),
        "bad.csv",
        b"wavelength_nm,value\n400,0.1\n410,0.2\n405,0.3\n",
    );
    let o = lumifit(&["color", "xyz", "--sd", p.to_str().unwrap()]);
    assert_rejected(&o, &["bad.csv", "line 4", "strictly increasing"]);
}

#[test]
fn a_nan_is_rejected_naming_file_line_and_column() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(
        dir.path(),
        "nan.csv",
        b"wavelength_nm,value\n400,0.1\n410,NaN\n",
    );
    let o = lumifit(&["color", "xyz", "--sd", p.to_str().unwrap()]);
    assert_rejected(
        &o,
        &["nan.csv", "line 3", "column 'value'", "finite number"],
    );
}

#[test]
fn a_missing_column_is_rejected_naming_file_and_line() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(
        dir.path(),
        "short.csv",
        b"wavelength_nm,value\n400,0.1\n410\n",
    );
    let o = lumifit(&["color", "xyz", "--sd", p.to_str().unwrap()]);
    assert_rejected(&o, &["short.csv", "line 3", "expected 2 columns"]);
}

#[test]
fn unknown_illuminant_and_observer_are_rejected_with_the_accepted_names() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(
        dir.path(),
        "ok.csv",
        b"wavelength_nm,value\n400,0.1\n410,0.2\n",
    );
    let o = lumifit(&[
        "color",
        "xyz",
        "--sd",
        p.to_str().unwrap(),
        "--illuminant",
        "D66",
    ]);
    assert_rejected(&o, &["unknown illuminant 'D66'", "D65", "LED-B3"]);
    let o = lumifit(&[
        "color",
        "xyz",
        "--sd",
        p.to_str().unwrap(),
        "--observer",
        "cie1931-3",
    ]);
    assert_rejected(&o, &["cie1931-3", "cie1931-2"]);
}

#[test]
fn an_empty_file_is_rejected() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(dir.path(), "empty.csv", b"");
    let o = lumifit(&["color", "xyz", "--sd", p.to_str().unwrap()]);
    assert_rejected(&o, &["empty.csv", "empty", "header row"]);
}

#[test]
fn a_binary_file_is_rejected() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(
        dir.path(),
        "image.png",
        [
            0x89, b'P', b'N', b'G', 0x0d, 0x0a, 0x1a, 0x0a, 0, 0, 0, 0x0d, 0xff, 0xfe,
        ],
    );
    let o = lumifit(&["color", "xyz", "--sd", p.to_str().unwrap()]);
    assert_rejected(&o, &["image.png", "line 1", "not a text file"]);
}

#[test]
fn a_missing_file_is_rejected_naming_it() {
    let o = lumifit(&["color", "xyz", "--sd", "/nonexistent/spectrum.csv"]);
    assert_rejected(&o, &["/nonexistent/spectrum.csv"]);
}

#[test]
fn malformed_lab_values_are_rejected_naming_the_flag() {
    let o = lumifit(&["color", "delta-e", "--lab1", "50,a,0", "--lab2", "50,0,0"]);
    assert_rejected(&o, &["--lab1", "component 2"]);
}

#[test]
fn color_table_writes_one_row_per_spectrum_and_nothing_on_error() {
    let dir = tempfile::tempdir().unwrap();
    let mut csv = String::from("wavelength_nm,flat,ramp\n");
    for i in 0..=40 {
        csv.push_str(&format!("{},{},{}\n", 380 + 10 * i, 0.5, i as f64 / 40.0));
    }
    let p = write(dir.path(), "many.csv", csv.as_bytes());
    let out = dir.path().join("xyz.csv");
    let o = lumifit(&[
        "color",
        "table",
        "--sds",
        p.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    let summary = json(&o);
    assert_eq!(summary["spectra"], 2);
    let text = std::fs::read_to_string(&out).unwrap();
    assert_eq!(text.lines().count(), 3);
    assert!(text.starts_with("name,X,Y,Z,x,y,L,a,b\nflat,"));
    // Bad input: the previous output stays as it was.
    let bad = write(dir.path(), "bad.csv", b"wavelength_nm,a\n400,1\n390,1\n");
    let o = lumifit(&[
        "color",
        "table",
        "--sds",
        bad.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_rejected(&o, &["bad.csv", "line 3"]);
    assert_eq!(std::fs::read_to_string(&out).unwrap(), text);
}

#[test]
fn demo_writes_table_chart_and_presets_that_validate() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("demo");
    let o = lumifit(&["demo", "--out", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let table = std::fs::read_to_string(out.join("colorchecker_colorimetry.csv")).unwrap();
    assert_eq!(table.lines().count(), 1 + 48);
    let png = std::fs::read(out.join("colorchecker.png")).unwrap();
    assert_eq!(&png[1..4], b"PNG");
    let presets: Vec<_> = std::fs::read_dir(out.join("presets")).unwrap().collect();
    assert_eq!(presets.len(), 24);
    let first = out.join("presets").join("01_dark_skin.json");
    let v = json(&lumifit(&["preset", "validate", first.to_str().unwrap()]));
    assert_eq!(v["valid"], true);
}

#[test]
fn daylight_and_blackbody_illuminants_are_built_from_a_temperature() {
    let dir = tempfile::tempdir().unwrap();
    let mut csv = String::from("wavelength_nm,value\n");
    for i in 0..=40 {
        csv.push_str(&format!("{},0.5\n", 380 + 10 * i));
    }
    let p = write(dir.path(), "flat.csv", csv.as_bytes());
    let d = json(&lumifit(&[
        "color",
        "xyz",
        "--sd",
        p.to_str().unwrap(),
        "--illuminant",
        "daylight:6504",
    ]));
    // D6504 is close to D65: the white's chromaticity is near (0.3127, 0.3290).
    let w = d["white_XYZ"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect::<Vec<_>>();
    let s: f64 = w.iter().sum();
    assert!(
        (w[0] / s - 0.3127).abs() < 2e-3 && (w[1] / s - 0.3290).abs() < 2e-3,
        "{w:?}"
    );
    let b = json(&lumifit(&[
        "color",
        "xyz",
        "--sd",
        p.to_str().unwrap(),
        "--illuminant",
        "blackbody:2856",
    ]));
    assert!((b["XYZ"][1].as_f64().unwrap() - 50.0).abs() < 1e-9);
    let o = lumifit(&[
        "color",
        "xyz",
        "--sd",
        p.to_str().unwrap(),
        "--illuminant",
        "daylight:2000",
    ]);
    assert_rejected(&o, &["2000 K", "4000–25000 K"]);
}
