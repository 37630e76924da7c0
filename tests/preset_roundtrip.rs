//! Preset format: writers read back, readers reject what the schema rejects, docs match the schema.

use std::path::{Path, PathBuf};

use lumifit::preset::{
    parse_preset, read_light, read_material, read_preset, to_json_string, write_preset, Bands,
    FluorescenceBasis, FluorescenceDeltaE, FluorescenceResampling, FluorescenceRgb,
    FluorescenceSection, GridNm, LightPreset, MaterialPreset, OpenSection, PhosphorescenceSection,
    PhosphorescentState, Preset, Provenance, ReflectanceSection, SCHEMA_JSON,
};
use lumifit::Error;
use serde_json::json;

#[path = "../src/bin/lumifit/commands/preset.rs"]
mod cli_preset;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn fixture(name: &str) -> PathBuf {
    root().join("fixtures/presets").join(name)
}

fn object(value: serde_json::Value) -> OpenSection {
    match value {
        serde_json::Value::Object(map) => map,
        other => panic!("test data is not an object: {other}"),
    }
}

/// A typed fluorescence section as `fluor reduce` writes it (K = 3, one illuminant), with an
/// extra field that must be kept.
fn fluorescence() -> FluorescenceSection {
    FluorescenceSection {
        method: "dual".into(),
        paper: "Fichet, Belcour & Barla 2024, CGF 43(4)".into(),
        basis: FluorescenceBasis {
            name: "xyz".into(),
            k: 3,
            labels: vec!["X".into(), "Y".into(), "Z".into()],
            observer: "cie2015-2".into(),
            grid_nm: GridNm {
                start_nm: 300.0,
                end_nm: 302.0,
                step_nm: 1.0,
            },
            functions: vec![vec![0.1, 0.2, 0.3]; 3],
        },
        matrix: vec![
            vec![1.0, 0.1, 0.0],
            vec![0.0, 0.9, 0.2],
            vec![0.0, 0.0, 1.0 / 3.0],
        ],
        transfer_xyz: vec![
            vec![1.0, 0.0, 0.0],
            vec![0.0, 1.0, 0.0],
            vec![0.0, 0.0, 1.0],
        ],
        xyz_matrix: [[1.0, 0.1, 0.0], [0.0, 0.9, 0.2], [0.0, 0.0, 0.7]],
        rgb: FluorescenceRgb {
            space: "srgb".into(),
            matrix: [[1.1, 0.0, 0.0], [0.0, 0.95, 0.1], [0.0, 0.0, 0.8]],
            projected_from_k: 3,
            equation: "M_xyz_to_rgb · P_xyz · M_xyz_to_rgb⁻¹ (Eq. 16)".into(),
        },
        resampling: FluorescenceResampling {
            clip_negatives: true,
            zero_anti_stokes: false,
            diagonal: "linear, as a reflectance".into(),
            off_diagonal: "bilinear, as a density × step".into(),
        },
        delta_e00: vec![FluorescenceDeltaE {
            illuminant: "D65".into(),
            delta_e00: 0.125,
            xyz_reference: [40.0, 42.5, 30.0],
            xyz_reduced: [40.1, 42.4, 30.2],
        }],
        worst_delta_e00: 0.125,
        extra: object(json!({"note": "kept"})),
    }
}

/// A material preset with every section, extra fields and floats that do not print short.
fn full_material() -> MaterialPreset {
    let provenance = Provenance::new(
        "lumifit phosphor fit decay.json",
        &[
            (Path::new("decay.json"), b"decay".as_slice()),
            (Path::new("white.csv"), b"white".as_slice()),
        ],
    )
    .with_fit_quality(json!({"rms_residual": 0.1 + 0.2, "iterations": 17}));
    let mut preset = MaterialPreset::new("glow tape", provenance);
    preset.description = Some("written by the round-trip test".into());
    let mut reflectance =
        ReflectanceSection::new(vec![400.0, 550.5, 700.0], vec![0.1, 1.0 / 3.0, 0.9]);
    reflectance
        .extra
        .insert("measured_with".into(), json!("spectrophotometer"));
    preset.reflectance = Some(reflectance);
    let mut fast =
        PhosphorescentState::new(0.35, Some(vec![0.02, 0.9, 1e-300]), vec![0.05, 0.8, 0.15]);
    fast.extra.insert("quantum_yield".into(), json!(0.5));
    preset.phosphorescence = Some(PhosphorescenceSection {
        bands: Bands::Rgb,
        states: vec![
            fast,
            PhosphorescentState::new(std::f64::consts::PI / 100.0, None, vec![0.0, 1.0, 2.0]),
        ],
        extra: object(json!({"note": "kept"})),
    });
    preset.fluorescence = Some(fluorescence());
    preset.dispersion = Some(
        serde_json::from_value(json!({
            "model": {"kind": "cauchy", "coefficients": [1.5046, 0.0042], "wavelength_unit": "um"},
            "range_nm": [380.0, 780.0], "n_d": 1.5168, "abbe_number": 64.17,
            "rms_residual": 1e-4, "max_abs_residual": 2e-4,
            "samples": [{"lambda_nm": 500.0, "n": 1.52, "rgb": [1.0, 1.0, 1.0]}],
            "working_space": "srgb", "note": "kept"
        }))
        .unwrap(),
    );
    preset.afterimage = Some(object(json!({"t_s": 1.5})));
    preset.photometric = Some(object(json!({"luminous_flux_lm": 12.25})));
    preset
}

fn message(err: &Error) -> String {
    err.to_string()
}

#[test]
fn material_preset_written_then_read_back_is_equal() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("glow.json");
    let preset = full_material();
    write_preset(&path, &preset).unwrap();
    assert_eq!(read_material(&path).unwrap(), preset);
}

#[test]
fn material_with_wavelength_bands_written_then_read_back_is_equal() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bands.json");
    let mut preset = full_material();
    let section = preset.phosphorescence.as_mut().unwrap();
    section.bands = Bands::RangesNm(vec![[380.0, 490.0], [490.0, 580.0], [580.0, 780.0]]);
    write_preset(&path, &preset).unwrap();
    assert_eq!(read_material(&path).unwrap(), preset);
}

#[test]
fn light_preset_written_then_read_back_is_equal() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("lamp.json");
    let preset = LightPreset::new(
        "desk lamp",
        Provenance::new(
            "lumifit photometry fit lamp.csv",
            &[("lamp.csv", b"lamp".as_slice())],
        ),
        object(json!({"luminous_flux_lm": 806.0})),
    );
    write_preset(&path, &preset).unwrap();
    assert_eq!(read_light(&path).unwrap(), preset);
    assert_eq!(read_preset(&path).unwrap(), Preset::Light(preset));
}

#[test]
fn every_valid_fixture_reads_back_equal_after_rewriting() {
    let dir = tempfile::tempdir().unwrap();
    let mut seen = 0;
    for entry in std::fs::read_dir(root().join("fixtures/presets")).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        if !name.starts_with("valid_") {
            continue;
        }
        let preset = read_preset(&path).unwrap_or_else(|e| panic!("{name}: {e}"));
        let copy = dir.path().join(&name);
        write_preset(&copy, &preset).unwrap();
        assert_eq!(read_preset(&copy).unwrap(), preset, "{name}");
        seen += 1;
    }
    assert!(seen >= 3, "expected the valid fixtures, found {seen}");
}

#[test]
fn written_preset_is_pretty_json_with_schema_first_and_final_newline() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("glow.json");
    write_preset(&path, &full_material()).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    assert!(
        text.starts_with("{\n  \"schema\": \"lumifit.material/1\",\n  \"name\""),
        "{text}"
    );
    assert!(text.ends_with("}\n"));
}

#[test]
fn unknown_schema_version_is_rejected_naming_the_version_the_file_and_what_is_supported() {
    let path = fixture("invalid_unknown_schema_version.json");
    let err = read_preset(&path).unwrap_err();
    match &err {
        Error::UnsupportedSchema {
            file,
            found,
            expected,
        } => {
            assert!(file.ends_with("invalid_unknown_schema_version.json"));
            assert_eq!(found, "lumifit.material/2");
            assert!(
                expected.contains("lumifit.material/1") && expected.contains("lumifit.light/1")
            );
        }
        other => panic!("expected UnsupportedSchema, got {other:?}"),
    }
    let text = message(&err);
    assert!(
        text.contains("lumifit.material/2") && text.contains("invalid_unknown_schema_version.json"),
        "{text}"
    );
}

/// Each invalid fixture and a text its error must contain (the field, as a JSON pointer where
/// there is one).
const INVALID_FIXTURES: &[(&str, &str)] = &[
    ("invalid_unknown_schema_version.json", "lumifit.material/2"),
    ("invalid_missing_schema.json", "/schema: missing"),
    (
        "invalid_missing_provenance.json",
        "\"provenance\" is a required property",
    ),
    (
        "invalid_rate_wrong_type.json",
        "/phosphorescence/states/0/k_r_per_s",
    ),
    (
        "invalid_rate_not_positive.json",
        "/phosphorescence/states/1/k_r_per_s",
    ),
    (
        "invalid_lambda_per_band.json",
        "/phosphorescence/states/1/lambda: has 2 values",
    ),
    (
        "invalid_k_e_per_band.json",
        "/phosphorescence/states/0/k_e: has 4 values",
    ),
    (
        "invalid_band_range_reversed.json",
        "/phosphorescence/bands/0",
    ),
    ("invalid_bands_unknown_name.json", "/phosphorescence/bands"),
    (
        "invalid_reflectance_not_increasing.json",
        "/reflectance/wavelength_nm/2",
    ),
    (
        "invalid_reflectance_length_mismatch.json",
        "/reflectance/value",
    ),
    ("invalid_unknown_section.json", "phosphorecence"),
    ("invalid_section_not_object.json", "/fluorescence"),
    (
        "invalid_sha256_malformed.json",
        "/provenance/inputs/0/sha256",
    ),
    (
        "invalid_created_utc_not_rfc3339.json",
        "/provenance/created_utc",
    ),
    ("invalid_empty_name.json", "/name"),
    (
        "invalid_light_without_photometric.json",
        "\"photometric\" is a required property",
    ),
    ("invalid_json_syntax.json", "line 4"),
];

#[test]
fn each_invalid_fixture_is_rejected_naming_the_file_and_the_field() {
    for (name, expected) in INVALID_FIXTURES {
        let err = read_preset(&fixture(name)).expect_err(name);
        let text = message(&err);
        assert!(
            text.contains(name),
            "{name}: error does not name the file: {text}"
        );
        assert!(
            text.contains(expected),
            "{name}: expected '{expected}' in: {text}"
        );
    }
}

#[test]
fn every_invalid_fixture_is_listed_in_the_test_table() {
    for entry in std::fs::read_dir(root().join("fixtures/presets")).unwrap() {
        let name = entry.unwrap().file_name().to_string_lossy().into_owned();
        if name.starts_with("invalid_") {
            assert!(
                INVALID_FIXTURES.iter().any(|(n, _)| *n == name),
                "{name} is not checked by each_invalid_fixture_is_rejected_naming_the_file_and_the_field"
            );
        }
    }
}

#[test]
fn json_syntax_error_is_a_parse_error_with_line_and_column() {
    let err = read_preset(&fixture("invalid_json_syntax.json")).unwrap_err();
    match err {
        Error::Parse { line, message, .. } => {
            assert_eq!(line, 4);
            assert!(message.contains("column"), "{message}");
        }
        other => panic!("expected Parse, got {other:?}"),
    }
}

#[test]
fn schema_violations_are_all_listed_one_per_line() {
    let mut value: serde_json::Value =
        serde_json::from_slice(&std::fs::read(fixture("valid_material.json")).unwrap()).unwrap();
    value["name"] = json!(3);
    value["provenance"]["inputs"][0]["sha256"] = json!("nope");
    let err = lumifit::preset::validate_value(&value, "two.json").unwrap_err();
    let Error::SchemaViolation { file, details } = err else {
        panic!("expected SchemaViolation");
    };
    assert_eq!(file, "two.json");
    assert_eq!(details.lines().count(), 2, "{details}");
    assert!(
        details.contains("/name:") && details.contains("/provenance/inputs/0/sha256:"),
        "{details}"
    );
}

#[test]
fn read_material_rejects_a_light_preset_naming_the_schema_field() {
    let err = read_material(&fixture("valid_light.json")).unwrap_err();
    let text = message(&err);
    assert!(
        text.contains("/schema") && text.contains("lumifit.material/1"),
        "{text}"
    );
}

#[test]
fn writer_refuses_an_invalid_preset_and_leaves_the_old_file_intact() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("glow.json");
    std::fs::write(&path, b"old contents").unwrap();
    let mut preset = full_material();
    preset.phosphorescence.as_mut().unwrap().states[0]
        .lambda
        .pop();
    preset.phosphorescence.as_mut().unwrap().states[1].k_r_per_s = f64::NAN;
    let text = message(&write_preset(&path, &preset).unwrap_err());
    assert!(text.contains("glow.json"), "{text}");
    assert!(
        text.contains("/phosphorescence/states/0/lambda")
            || text.contains("/phosphorescence/states/1/k_r_per_s"),
        "{text}"
    );
    assert_eq!(std::fs::read(&path).unwrap(), b"old contents");
    assert_eq!(
        std::fs::read_dir(dir.path()).unwrap().count(),
        1,
        "temporary file left behind"
    );
}

#[test]
fn writer_into_a_missing_directory_fails_naming_the_path_and_creates_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("missing").join("glow.json");
    let err = write_preset(&path, &full_material()).unwrap_err();
    assert!(matches!(err, Error::Io { .. }), "{err:?}");
    assert!(message(&err).contains("glow.json"));
    assert!(!dir.path().join("missing").exists());
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}

#[test]
fn rewriting_replaces_the_old_file_whole_and_leaves_no_temporary_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("glow.json");
    std::fs::write(&path, vec![b'x'; 100_000]).unwrap();
    write_preset(&path, &full_material()).unwrap();
    assert_eq!(
        read_material(&path).unwrap(),
        full_material_without_time(&path)
    );
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
}

/// `full_material()` with the creation time of the file at `path` (times differ between calls).
fn full_material_without_time(path: &Path) -> MaterialPreset {
    let mut expected = full_material();
    expected.provenance.created_utc = read_material(path).unwrap().provenance.created_utc;
    expected
}

/// The ```json blocks of docs/preset-schema.md.
fn json_blocks_in_docs() -> Vec<String> {
    let text = std::fs::read_to_string(root().join("docs/preset-schema.md")).unwrap();
    let mut blocks = Vec::new();
    let mut current: Option<String> = None;
    for line in text.lines() {
        match &mut current {
            None if line.trim_end() == "```json" => current = Some(String::new()),
            Some(block) if line.trim_end() == "```" => {
                blocks.push(std::mem::take(block));
                current = None;
            }
            Some(block) => {
                block.push_str(line);
                block.push('\n');
            }
            None => {}
        }
    }
    blocks
}

#[test]
fn examples_in_preset_schema_md_are_valid_presets() {
    let blocks = json_blocks_in_docs();
    assert!(
        !blocks.is_empty(),
        "no ```json block in docs/preset-schema.md"
    );
    let mut material = false;
    for (i, block) in blocks.iter().enumerate() {
        let file = format!("docs/preset-schema.md, json block {}", i + 1);
        let preset = lumifit::preset::parse_preset(block.as_bytes(), &file)
            .unwrap_or_else(|e| panic!("{e}"));
        material |= matches!(preset, Preset::Material(_));
    }
    assert!(material, "the docs show no material preset");
}

#[test]
fn every_schema_field_is_documented_in_preset_schema_md() {
    fn property_names(value: &serde_json::Value, out: &mut Vec<String>) {
        match value {
            serde_json::Value::Object(map) => {
                if let Some(serde_json::Value::Object(props)) = map.get("properties") {
                    out.extend(props.keys().cloned());
                }
                map.values().for_each(|v| property_names(v, out));
            }
            serde_json::Value::Array(items) => items.iter().for_each(|v| property_names(v, out)),
            _ => {}
        }
    }
    let schema: serde_json::Value = serde_json::from_str(SCHEMA_JSON).unwrap();
    let mut names = Vec::new();
    property_names(&schema, &mut names);
    let docs = std::fs::read_to_string(root().join("docs/preset-schema.md")).unwrap();
    for name in names {
        assert!(
            docs.contains(&format!("`{name}`")),
            "`{name}` is not documented"
        );
    }
}

#[test]
fn schema_file_is_a_valid_draft_2020_12_json_schema() {
    let schema: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(root().join("docs/preset-schema.json")).unwrap(),
    )
    .unwrap();
    assert_eq!(
        schema["$schema"],
        "https://json-schema.org/draft/2020-12/schema"
    );
    jsonschema::meta::validate(&schema).unwrap();
    jsonschema::draft202012::new(&schema).unwrap();
    assert_eq!(schema, lumifit::preset::schema_value().unwrap());
}

#[test]
fn cli_validate_reports_schema_and_sections_of_a_valid_preset() {
    let path = fixture("valid_material.json");
    let report = cli_preset::validate(&path).unwrap();
    assert_eq!(report["valid"], true);
    assert_eq!(report["schema"], "lumifit.material/1");
    assert_eq!(
        report["sections"],
        json!(["reflectance", "phosphorescence"])
    );
    assert_eq!(report["file"], path.display().to_string());
}

#[test]
fn cli_validate_error_names_the_file_and_each_violation() {
    let err = cli_preset::validate(&fixture("invalid_k_e_per_band.json")).unwrap_err();
    let text = format!("{err:#}");
    assert!(text.contains("invalid_k_e_per_band.json"), "{text}");
    assert!(text.contains("/phosphorescence/states/0/k_e"), "{text}");
}

#[test]
fn a_fluorescence_section_written_then_read_back_is_equal() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("fluor.json");
    let mut preset = MaterialPreset::new(
        "fluorescent paper",
        Provenance::new(
            "lumifit fluor reduce p.BFC",
            &[("p.BFC", b"bfc".as_slice())],
        ),
    );
    preset.fluorescence = Some(fluorescence());
    write_preset(&path, &preset).unwrap();
    assert_eq!(read_material(&path).unwrap(), preset);
}

#[test]
fn a_fluorescence_section_with_a_null_or_missing_number_is_refused() {
    let mut preset = MaterialPreset::new(
        "fluorescent paper",
        Provenance::new(
            "lumifit fluor reduce p.BFC",
            &[("p.BFC", b"bfc".as_slice())],
        ),
    );
    preset.fluorescence = Some(fluorescence());
    let text = to_json_string(&preset).unwrap();
    // A non-finite entry is what serde writes as null: the reader must refuse it.
    let nulled = text.replacen("0.9,", "null,", 1);
    assert_ne!(nulled, text);
    let e = parse_preset(nulled.as_bytes(), "nulled.json").unwrap_err();
    assert!(
        message(&e).contains("nulled.json") && message(&e).contains("fluorescence"),
        "{e}"
    );
    let mut v: serde_json::Value = serde_json::from_str(&text).unwrap();
    v["fluorescence"]
        .as_object_mut()
        .unwrap()
        .remove("xyz_matrix");
    let e = parse_preset(v.to_string().as_bytes(), "missing.json").unwrap_err();
    assert!(message(&e).contains("xyz_matrix"), "{e}");
    // A writer refuses a non-finite number instead of writing null.
    let mut bad = preset.clone();
    bad.fluorescence.as_mut().unwrap().worst_delta_e00 = f64::INFINITY;
    assert!(to_json_string(&bad).is_err());
}

#[test]
fn a_preset_with_a_byte_order_mark_is_read() {
    let text = to_json_string(&full_material()).unwrap();
    let with_bom = format!("\u{feff}{text}");
    assert_eq!(
        parse_preset(with_bom.as_bytes(), "bom.json").unwrap(),
        Preset::Material(full_material())
    );
}
