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

/// A folder holding two copies of the synthetic matrix (`a.bfc`, `b.BFC`) and a text file that
/// is not a matrix (ignored by the folder expansion).
fn two_matrix_folder(dir: &Path) -> std::path::PathBuf {
    let m = dir.join("matrices");
    std::fs::create_dir(&m).unwrap();
    std::fs::copy(synthetic(), m.join("a.bfc")).unwrap();
    std::fs::copy(synthetic(), m.join("b.BFC")).unwrap();
    std::fs::write(m.join("README.txt"), "not a matrix").unwrap();
    m
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// Every non-empty line of a `fluor` CSV table has `fields` comma-separated fields.
fn assert_pure_csv(text: &str, header: &str, fields: usize) -> usize {
    let mut lines = text.lines().filter(|l| !l.is_empty());
    assert_eq!(lines.next(), Some(header), "{text}");
    let rows: Vec<&str> = lines.collect();
    for l in &rows {
        assert_eq!(
            l.split(',').count(),
            fields,
            "not a table row: '{l}' in\n{text}"
        );
        let v: f64 = l.rsplit(',').next().unwrap().parse().unwrap();
        assert!(v.is_finite() && v >= 0.0, "{l}");
    }
    rows.len()
}

#[test]
fn reduce_over_a_folder_writes_one_valid_preset_each_and_one_table_with_the_summary_on_stderr() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let m = two_matrix_folder(d);
    let presets = d.join("presets");
    let table = d.join("t.csv");
    let o = lumifit(&[
        "fluor",
        "reduce",
        s(&m),
        "--out-dir",
        s(&presets),
        "--table",
        s(&table),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        o.stdout.is_empty(),
        "{}",
        String::from_utf8_lossy(&o.stdout)
    );
    let err = stderr(&o);
    assert!(err.contains("a.json") && err.contains("b.json"), "{err}");
    for name in ["a.json", "b.json"] {
        let p = presets.join(name);
        let v = lumifit(&["preset", "validate", s(&p)]);
        assert!(v.status.success(), "{name}: {}", stderr(&v));
        let j: serde_json::Value = serde_json::from_slice(&std::fs::read(&p).unwrap()).unwrap();
        assert!(j["fluorescence"].is_object(), "{j}");
    }
    let text = std::fs::read_to_string(&table).unwrap();
    let n = assert_pure_csv(&text, "material,file,illuminant,method,delta_e00", 5);
    assert_eq!(
        n,
        2 * 7,
        "two matrices × seven default illuminants:\n{text}"
    );
}

#[test]
fn reduce_refuses_one_out_for_several_matrices_and_a_bad_matrix_in_a_batch_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let m = two_matrix_folder(d);
    let out = d.join("one.json");
    assert_rejected(
        &lumifit(&["fluor", "reduce", s(&m), "--out", s(&out)]),
        &["2 matrices", "--out-dir"],
    );
    assert!(!out.exists());
    let text = std::fs::read_to_string(synthetic()).unwrap();
    let mut lines: Vec<&str> = text.lines().collect();
    lines.remove(30);
    write(&m, "c.bfc", lines.join("\n"));
    let presets = d.join("presets");
    assert_rejected(
        &lumifit(&["fluor", "reduce", s(&m), "--out-dir", s(&presets)]),
        &["c.bfc: line", "emission"],
    );
    assert!(!presets.exists(), "nothing written when one matrix is bad");
    // Two matrices with the same stem would overwrite each other's preset.
    let other = d.join("other");
    std::fs::create_dir(&other).unwrap();
    std::fs::copy(synthetic(), other.join("a.csv")).unwrap();
    assert_rejected(
        &lumifit(&[
            "fluor",
            "reduce",
            s(&m.join("a.bfc")),
            s(&other.join("a.csv")),
            "--out-dir",
            s(&presets),
        ]),
        &["a.json", "rename"],
    );
}

#[test]
fn eval_writes_a_pure_csv_table_and_presets_and_keeps_the_summary_on_stderr() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let m = two_matrix_folder(d);
    // Standard output carries the table only.
    let o = lumifit(&["fluor", "eval", s(&m)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let n = assert_pure_csv(
        &String::from_utf8_lossy(&o.stdout),
        "material,illuminant,method,delta_e00",
        4,
    );
    assert_eq!(n, 2 * 7 * 5);
    assert!(
        stderr(&o).contains("summary over materials"),
        "{}",
        stderr(&o)
    );
    // --out and --out-dir: the table in the file, one preset per matrix, nothing on stdout.
    let table = d.join("eval.csv");
    let presets = d.join("p");
    let o = lumifit(&[
        "fluor",
        "eval",
        s(&m),
        "--methods",
        "dual-xyzu,dual-xyz",
        "--out",
        s(&table),
        "--out-dir",
        s(&presets),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(o.stdout.is_empty());
    let text = std::fs::read_to_string(&table).unwrap();
    assert_eq!(
        assert_pure_csv(&text, "material,illuminant,method,delta_e00", 4),
        2 * 7 * 2
    );
    for name in ["a.json", "b.json"] {
        let p = presets.join(name);
        let v = lumifit(&["preset", "validate", s(&p)]);
        assert!(v.status.success(), "{name}: {}", stderr(&v));
        let j: serde_json::Value = serde_json::from_slice(&std::fs::read(&p).unwrap()).unwrap();
        // Reduced with the first of --methods.
        let basis = &j["fluorescence"]["basis"]["name"];
        assert_eq!(basis, "xyzu", "{name}: basis {basis}");
        assert_eq!(j["fluorescence"]["method"], "dual");
    }
}

#[test]
fn sweep_and_select_write_to_out() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let sweep = d.join("sweep.csv");
    let o = lumifit(&["fluor", "sweep", &synthetic(), "--out", s(&sweep)]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(o.stdout.is_empty());
    let text = std::fs::read_to_string(&sweep).unwrap();
    assert!(text.starts_with("excitation_nm,method,X_ref"), "{text}");
    assert!(text.lines().count() > 10);
    let sel = d.join("select.json");
    let o = lumifit(&["fluor", "select", &synthetic(), "--json", "--out", s(&sel)]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(o.stdout.is_empty());
    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(&sel).unwrap()).unwrap();
    assert_eq!(v["material"], "synthetic");
    // An output that is the input is refused before any work.
    let o = lumifit(&["fluor", "sweep", &synthetic(), "--out", &synthetic()]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
}
