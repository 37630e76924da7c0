//! `lumifit dispersion fit`, `dispersion prism` and `preset export` as a user runs them: presets
//! that validate and read back, glTF that the Khronos validator accepts, and bad input refused
//! with exit 2 naming the file and the field, with nothing written.

mod common;

use std::path::Path;

use common::{assert_rejected, lumifit, p, write};

const BK7_YAML: &str = "DATA:\n  - type: formula 2\n    wavelength_range: 0.3 2.5\n    coefficients: 0 1.03961212 0.00600069867 0.231792344 0.0200179144 1.01046945 103.560653\n";

fn ok(o: &std::process::Output) -> String {
    assert_eq!(o.status.code(), Some(0), "stderr: {}", common::stderr(o));
    String::from_utf8_lossy(&o.stdout).to_string()
}

#[test]
fn fit_of_a_bundled_glass_writes_a_preset_that_validates_and_reads_back() {
    let dir = tempfile::tempdir().unwrap();
    let out = p(dir.path(), "bk7.json");
    let summary: serde_json::Value = serde_json::from_str(&ok(&lumifit(&[
        "dispersion",
        "fit",
        "--glass",
        "N-BK7",
        "--out",
        &out,
        "--plot",
        &p(dir.path(), "fit.png"),
    ])))
    .unwrap();
    assert_eq!(summary["tolerance_met"], true);
    ok(&lumifit(&["preset", "validate", &out]));
    let preset = lumifit::preset::read_material(Path::new(&out)).unwrap();
    let d = preset.dispersion.unwrap();
    assert!(
        (d.n_d - 1.5168).abs() < 5e-5 && (d.abbe_number - 64.17).abs() < 0.05,
        "{} {}",
        d.n_d,
        d.abbe_number
    );
    assert!(d.max_abs_residual <= 1e-4);
    assert_eq!(d.samples.len(), 7);
    for c in 0..3 {
        let t: f64 = d.samples.iter().map(|s| s.rgb[c]).sum();
        assert!((t - 1.0).abs() < 1e-12);
    }
    assert!(std::fs::metadata(dir.path().join("fit.png")).unwrap().len() > 1000);
}

#[test]
fn gltf_export_carries_n_d_and_20_over_v_d_and_passes_the_khronos_validator() {
    let dir = tempfile::tempdir().unwrap();
    let preset = p(dir.path(), "sf11.json");
    ok(&lumifit(&[
        "dispersion",
        "fit",
        "--glass",
        "N-SF11",
        "--out",
        &preset,
    ]));
    let gltf = p(dir.path(), "sf11.gltf");
    ok(&lumifit(&[
        "preset", "export", &preset, "--format", "gltf", "--out", &gltf,
    ]));
    let doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&gltf).unwrap()).unwrap();
    let m = lumifit::preset::read_material(Path::new(&preset))
        .unwrap()
        .dispersion
        .unwrap();
    let ext = &doc["materials"][0]["extensions"];
    assert_eq!(ext["KHR_materials_ior"]["ior"].as_f64().unwrap(), m.n_d);
    assert!(
        (ext["KHR_materials_dispersion"]["dispersion"]
            .as_f64()
            .unwrap()
            - 20.0 / m.abbe_number)
            .abs()
            < 1e-15
    );
    let openpbr: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(dir.path().join("sf11.openpbr.json")).unwrap(),
    )
    .unwrap();
    assert_eq!(
        openpbr["transmission_dispersion_abbe_number"]
            .as_f64()
            .unwrap(),
        m.abbe_number
    );

    let Some(report) = common::khronos_validator(&[&gltf]) else {
        return;
    };
    assert!(report.contains(" 0 errors"), "{report}");
}

#[test]
fn prism_writes_the_strips_and_the_de00_table() {
    let dir = tempfile::tempdir().unwrap();
    let preset = p(dir.path(), "bk7.json");
    ok(&lumifit(&[
        "dispersion",
        "fit",
        "--glass",
        "N-BK7",
        "--out",
        &preset,
    ]));
    let (png, csv) = (p(dir.path(), "strip.png"), p(dir.path(), "de.csv"));
    ok(&lumifit(&[
        "dispersion",
        "prism",
        &preset,
        "--out",
        &png,
        "--table",
        &csv,
    ]));
    let table = std::fs::read_to_string(&csv).unwrap();
    let rows: Vec<&str> = table.lines().collect();
    assert_eq!(rows.len(), 1 + 7, "{table}");
    assert!(table.contains("Blanchette 2012 Table 2"));
    // mean ΔE00 falls as N grows (N = 3 … 21 rows are 2–6)
    let mean = |r: &str| r.split(',').nth(2).unwrap().parse::<f64>().unwrap();
    assert!(mean(rows[2]) > mean(rows[6]), "{table}");
    assert!(std::fs::metadata(&png).unwrap().len() > 1000);
}

#[test]
fn target_de00_picks_the_smallest_n_that_reaches_it() {
    let dir = tempfile::tempdir().unwrap();
    let preset = p(dir.path(), "bk7.json");
    ok(&lumifit(&[
        "dispersion",
        "fit",
        "--glass",
        "N-BK7",
        "--out",
        &preset,
    ]));
    let args = ["--beam-width-mm", "2"];
    let run = |extra: &[&str]| -> serde_json::Value {
        let mut a = vec!["dispersion", "prism", preset.as_str(), "--out"];
        let png = p(dir.path(), "s.png");
        a.push(&png);
        a.extend_from_slice(&args);
        a.extend_from_slice(extra);
        serde_json::from_str(&ok(&lumifit(&a))).unwrap()
    };
    let s = run(&["--target-de00", "2"]);
    let n = s["smallest_n_for_target"].as_u64().unwrap() as usize;
    assert!(s["cases"][0]["max_de00_sampling_only"].as_f64().unwrap() <= 2.0);
    assert!(n > 1);
    let fewer = (n - 1).to_string();
    let t = run(&["--samples", &fewer]);
    assert!(
        t["cases"][0]["max_de00_sampling_only"].as_f64().unwrap() > 2.0,
        "N = {n} is not the smallest"
    );
}

#[test]
fn bad_inputs_exit_2_naming_file_and_field_and_write_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let out = d.join("m.json");
    std::fs::write(&out, b"keep").unwrap();
    let cases: Vec<(&str, String, Vec<&str>)> = vec![
        (
            "nodata.yml",
            "REFERENCES: none\nCOMMENTS: no data\n".into(),
            vec!["nodata.yml", "DATA"],
        ),
        (
            "f12.yml",
            BK7_YAML.replace("formula 2", "formula 12"),
            vec!["f12.yml", "line 2", "type", "formula 12"],
        ),
        (
            "ir.yml",
            BK7_YAML.replace("0.3 2.5", "1.0 2.5"),
            vec!["ir.yml", "wavelength_range"],
        ),
        (
            "order.csv",
            "wavelength_nm,n\n400,1.53\n600,1.52\n500,1.525\n700,1.51\n".into(),
            vec!["order.csv", "line 4", "wavelength_nm", "increasing"],
        ),
        (
            "below1.csv",
            "wavelength_nm,n\n400,1.53\n500,0.98\n600,1.52\n700,1.51\n".into(),
            vec!["below1.csv", "line 3", "'n'"],
        ),
    ];
    for (name, text, fragments) in cases {
        let input = write(d, name, text);
        let o = lumifit(&[
            "dispersion",
            "fit",
            input.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ]);
        assert_rejected(&o, &fragments);
        assert_eq!(
            std::fs::read(&out).unwrap(),
            b"keep",
            "{name}: output touched"
        );
    }
    let o = lumifit(&[
        "dispersion",
        "fit",
        "--glass",
        "unobtainium",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_rejected(&o, &["unobtainium", "N-BK7"]);
    let o = lumifit(&[
        "dispersion",
        "fit",
        "--glass",
        "N-BK7",
        "--range",
        "380:780",
        "--samples",
        "0",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_rejected(&o, &["--samples"]);
    assert_eq!(std::fs::read(&out).unwrap(), b"keep");
    // a preset without a dispersion section cannot be exported
    let bare = write(
        d,
        "bare.json",
        r#"{"schema":"lumifit.material/1","name":"x","provenance":{"tool":"lumifit","tool_version":"0","command":"t","created_utc":"2025-01-01T00:00:00Z","inputs":[]}}"#,
    );
    let o = lumifit(&[
        "preset",
        "export",
        bare.to_str().unwrap(),
        "--format",
        "gltf",
        "--out",
        &p(d, "x.gltf"),
    ]);
    assert_rejected(&o, &["bare.json", "dispersion"]);
    assert!(!d.join("x.gltf").exists() && !d.join("x.openpbr.json").exists());
    // the output may not be the input
    let yml = write(d, "bk7.yml", BK7_YAML);
    let o = lumifit(&[
        "dispersion",
        "fit",
        yml.to_str().unwrap(),
        "--out",
        yml.to_str().unwrap(),
    ]);
    assert_rejected(&o, &["--out"]);
    assert_eq!(std::fs::read_to_string(&yml).unwrap(), BK7_YAML);
}
