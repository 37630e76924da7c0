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
        "color", "convert", "--from", "xyz", "--to", "lab", "--value", "20,30,40",
    ]));
    assert_eq!(lab["xyz_scale"], 100.0);
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
    for (i, want) in [20.0, 30.0, 40.0].iter().enumerate() {
        assert!((back["value"][i].as_f64().unwrap() - want).abs() < 1e-10);
    }
}

#[test]
fn convert_takes_xyz_on_the_scale_color_xyz_prints_and_names_the_other() {
    // Y = 30 on the 0–100 scale of `color xyz`: L* = 116·0.3^(1/3) − 16 = 61.6542 (the issue's
    // 344 came from reading it on the 0–1 scale).
    let o = lumifit(&[
        "color", "convert", "--from", "xyz", "--to", "lab", "--value", "20,30,40",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).is_empty(), "{}", stderr(&o));
    let l = json(&o)["value"][0].as_f64().unwrap();
    assert!((l - 61.6542).abs() < 1e-3, "L* = {l}");
    // The same colour on colour's 0–1 scale gives the same L*.
    let v = json(&lumifit(&[
        "color",
        "convert",
        "--from",
        "xyz",
        "--to",
        "lab",
        "--value",
        "0.2,0.3,0.4",
        "--scale",
        "1",
    ]));
    assert!((v["value"][0].as_f64().unwrap() - l).abs() < 1e-9);
    // The old mistake is named: 0–100 numbers with --scale 1, or 0–1 numbers without it.
    let o = lumifit(&[
        "color", "convert", "--from", "xyz", "--to", "lab", "--value", "20,30,40", "--scale", "1",
    ]);
    assert!(stderr(&o).contains("drop --scale 1"), "{}", stderr(&o));
    let o = lumifit(&[
        "color",
        "convert",
        "--from",
        "xyz",
        "--to",
        "lab",
        "--value",
        "0.2,0.3,0.4",
    ]);
    assert!(stderr(&o).contains("add --scale 1"), "{}", stderr(&o));
    // xyY's Y is on the same scale, in and out.
    let v = json(&lumifit(&[
        "color", "convert", "--from", "lab", "--to", "xyy", "--value", "100,0,0",
    ]));
    assert!(
        (v["value"][2].as_f64().unwrap() - 100.0).abs() < 1e-9,
        "{v}"
    );
    // A negative Y is refused.
    let o = lumifit(&[
        "color",
        "convert",
        "--from",
        "xyz",
        "--to",
        "lab",
        "--value",
        "20,-30,40",
    ]);
    assert_rejected(&o, &["--value", "negative"]);
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

#[test]
fn old_flag_spellings_still_work_for_one_release_and_warn() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(
        dir.path(),
        "flat.csv",
        "wavelength_nm,value\n380,0.5\n500,0.5\n780,0.5\n",
    );
    let new = lumifit(&[
        "color",
        "xyz",
        "--spectrum",
        p.to_str().unwrap(),
        "--method",
        "integration",
    ]);
    assert!(new.status.success(), "{}", stderr(&new));
    assert!(!stderr(&new).contains("deprecated"), "{}", stderr(&new));
    let old = lumifit(&[
        "color",
        "xyz",
        "--sd",
        p.to_str().unwrap(),
        "--method",
        "integration",
    ]);
    assert!(old.status.success(), "{}", stderr(&old));
    assert_eq!(json(&old)["XYZ"], json(&new)["XYZ"]);
    let e = stderr(&old);
    assert!(
        e.contains("--sd is deprecated") && e.contains("use --spectrum"),
        "{e}"
    );
    let table = dir.path().join("t.csv");
    let o = lumifit(&[
        "color",
        "table",
        "--sds",
        p.to_str().unwrap(),
        "--method",
        "integration",
        "--out",
        table.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("use --spectra"), "{}", stderr(&o));
}

#[test]
fn a_series_folder_means_its_manifest_and_extract_defaults_to_the_whole_frame() {
    let dir = tempfile::tempdir().unwrap();
    let s = dir.path().join("s");
    let o = lumifit(&[
        "synth",
        "phos-decay",
        "--material",
        "green_paint",
        "--size",
        "8x6",
        "--frames",
        "4",
        "--seed",
        "1",
        "--out",
        s.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    // The folder holds manifest.csv: its times (0, 5, 10, 15 s) are used, not EXIF order.
    let o = lumifit(&["series", "inspect", s.to_str().unwrap(), "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let times: Vec<f64> = json(&o)
        .as_array()
        .unwrap()
        .iter()
        .map(|r| r["time_s"].as_f64().unwrap())
        .collect();
    assert_eq!(times, [0.0, 5.0, 10.0, 15.0]);
    // No --roi: the whole 8×6 frame.
    let c = dir.path().join("c.csv");
    let o = lumifit(&[
        "series",
        "extract",
        s.to_str().unwrap(),
        "--out",
        c.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(&c).unwrap();
    let row: Vec<&str> = text.lines().nth(1).unwrap().split(',').collect();
    assert_eq!(row[7], "48", "n_pixels of the whole frame: {text}");
    // A manifest whose first column is named `image` (as the charging CSVs) reads the same.
    let m = std::fs::read_to_string(s.join("manifest.csv")).unwrap();
    assert!(m.starts_with("file,"), "{m}");
    std::fs::write(s.join("manifest.csv"), m.replacen("file,", "image,", 1)).unwrap();
    let c2 = dir.path().join("c2.csv");
    let o = lumifit(&[
        "series",
        "extract",
        &format!("{}/manifest.csv", s.display()),
        "--out",
        c2.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(std::fs::read_to_string(&c2).unwrap(), text);
}
