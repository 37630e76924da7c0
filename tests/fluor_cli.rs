//! `lumifit fluor …` as a user runs it: the `eval --json` contract, presets that read back, and
//! bad input rejected with exit code 2 and a message naming the file, the line or the field.

mod common;

use common::{assert_rejected, lumifit, stderr, write};

use std::path::Path;

fn synthetic() -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("fixtures/fluor/synthetic.bfc")
        .display()
        .to_string()
}

#[test]
fn eval_json_prints_one_array_with_the_contract_fields_for_every_combination() {
    let o = lumifit(&["fluor", "eval", &synthetic(), "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let rows = v.as_array().unwrap();
    assert_eq!(rows.len(), 7 * 5);
    for r in rows {
        let obj = r.as_object().unwrap();
        let mut keys: Vec<&str> = obj.keys().map(String::as_str).collect();
        keys.sort();
        assert_eq!(
            keys,
            [
                "delta_e00",
                "illuminant",
                "material",
                "method",
                "xyz_reduced",
                "xyz_reference"
            ]
        );
        assert_eq!(r["material"], "synthetic");
        assert!(r["delta_e00"].as_f64().unwrap() >= 0.0);
        assert_eq!(r["xyz_reference"].as_array().unwrap().len(), 3);
    }
}

#[test]
fn reduce_writes_a_material_preset_with_a_fluorescence_section_that_validates() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("m.json");
    let plot = dir.path().join("m.png");
    let o = lumifit(&[
        "fluor",
        "reduce",
        &synthetic(),
        "--basis",
        "xyzu",
        "--rgb",
        "acescg",
        "--out",
        out.to_str().unwrap(),
        "--plot",
        plot.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(plot.is_file());
    let v = lumifit(&["preset", "validate", out.to_str().unwrap()]);
    assert!(v.status.success(), "{}", stderr(&v));
    let p: serde_json::Value = serde_json::from_slice(&std::fs::read(&out).unwrap()).unwrap();
    let f = &p["fluorescence"];
    assert_eq!(f["basis"]["name"], "xyzu");
    assert_eq!(f["matrix"].as_array().unwrap().len(), 4);
    assert_eq!(f["transfer_xyz"].as_array().unwrap().len(), 3);
    assert_eq!(f["rgb"]["space"], "acescg");
    assert_eq!(f["delta_e00"].as_array().unwrap().len(), 7);
}

#[test]
fn select_reports_a_choice_or_the_best_reachable_basis() {
    let o = lumifit(&[
        "fluor",
        "select",
        &synthetic(),
        "--illuminants",
        "D65,A",
        "--target-de",
        "1000",
        "--json",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["chosen_method"], "dual-xyz");
    let o = lumifit(&[
        "fluor",
        "select",
        &synthetic(),
        "--illuminants",
        "D65",
        "--target-de",
        "0.000001",
    ]);
    assert!(o.status.success());
    assert!(String::from_utf8_lossy(&o.stdout).contains("best reachable"));
}

#[test]
fn a_bfc_with_a_wrong_row_count_exits_with_code_2() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(synthetic()).unwrap();
    let mut lines: Vec<&str> = text.lines().collect();
    lines.remove(30);
    let p = write(dir.path(), "short.BFC", lines.join("\n"));
    assert_rejected(
        &lumifit(&["fluor", "eval", p.to_str().unwrap()]),
        &["short.BFC: line", "emission"],
    );
}

#[test]
fn a_bfc_with_a_non_numeric_cell_exits_with_code_2() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(synthetic()).unwrap();
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    let mut f: Vec<String> = lines[20].split('\t').map(String::from).collect();
    f[3] = "n/a".into();
    lines[20] = f.join("\t");
    let p = write(dir.path(), "bad.BFC", lines.join("\n"));
    assert_rejected(
        &lumifit(&[
            "fluor",
            "reduce",
            p.to_str().unwrap(),
            "--out",
            dir.path().join("o.json").to_str().unwrap(),
        ]),
        &["bad.BFC: line 21", "n/a"],
    );
    assert!(!dir.path().join("o.json").exists());
}

#[test]
fn a_csv_matrix_whose_size_does_not_match_its_grid_exits_with_code_2() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(
        dir.path(),
        "m.csv",
        "emission_nm,380,390,400\n380,0.5,0,0\n390,0,0.5\n400,0,0,0.5\n",
    );
    assert_rejected(
        &lumifit(&["fluor", "eval", p.to_str().unwrap()]),
        &["m.csv: line 3", "expected 4 columns"],
    );
}

#[test]
fn an_illuminant_not_covering_the_basis_range_exits_with_code_2() {
    let dir = tempfile::tempdir().unwrap();
    let ill = write(
        dir.path(),
        "led.csv",
        "wavelength_nm,value\n420,1\n500,2\n600,2\n700,1\n",
    );
    assert_rejected(
        &lumifit(&[
            "fluor",
            "eval",
            &synthetic(),
            "--illuminants",
            ill.to_str().unwrap(),
        ]),
        &["led.csv", "390", "780"],
    );
}

#[test]
fn unknown_basis_and_method_names_exit_with_code_2_listing_the_accepted_ones() {
    assert_rejected(
        &lumifit(&["fluor", "eval", &synthetic(), "--methods", "dual-rgb"]),
        &["xyz, xyzu, xyz7u"],
    );
    assert_rejected(
        &lumifit(&[
            "fluor",
            "reduce",
            &synthetic(),
            "--basis",
            "lms",
            "--out",
            "x.json",
        ]),
        &["lms"],
    );
}
