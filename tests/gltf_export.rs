//! `lumifit preset export --format gltf|openpbr|mtlx` as a user runs it: every material section
//! (reflectance, phosphorescence with its keyframed glow, fluorescence, dispersion, and all of them
//! in one material), with and without `--scene sphere`, as `.gltf` and `.glb`; the Khronos glTF
//! validator reports 0 errors on every file (skipped with a message when node is absent); the glow
//! keys read back from the file and linearly interpolated stay within the stated error of the
//! exact rate-equation solution at 1000 random times; bad input exits 2 and writes nothing.

// Channel loops mirror the maths (rgb[c]).
#![allow(clippy::needless_range_loop)]

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

use common::khronos_validator;
use common::tolerances::gltf_export::*;
use common::{assert_rejected, lumifit, p, stderr, write};
use lumifit::colorimetry::rgb::RgbSpace;
use lumifit::phosphor::simulate::{emission, final_state, Segment};
use lumifit::preset::export::fluorescence::rgb_matrix;
use lumifit::preset::read_material;
use lumifit::preset::shader::band_to_rgb;
use serde_json::{json, Value};

fn fixture(rel: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join(rel)
        .display()
        .to_string()
}

fn ok(o: &std::process::Output) {
    assert!(o.status.success(), "{}", stderr(o));
}

fn read_json(path: &str) -> Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

/// A material preset document with the given sections.
fn preset_with(name: &str, sections: &[(&str, Value)]) -> Value {
    let mut v = json!({
        "schema": "lumifit.material/1",
        "name": name,
        "provenance": {"tool": "lumifit", "tool_version": "0.1.0", "command": "test",
                        "created_utc": "2026-01-01T00:00:00Z", "inputs": []}
    });
    for (k, s) in sections {
        v[*k] = s.clone();
    }
    v
}

fn reflectance() -> Value {
    json!({"wavelength_nm": [400.0, 450.0, 500.0, 550.0, 600.0, 650.0, 700.0],
           "value": [0.41, 0.62, 0.81, 0.84, 0.85, 0.85, 0.86]})
}

/// Two states, both with k_e (so the preset can be charged), RGB bands.
fn phosphorescence() -> Value {
    json!({"bands": "rgb", "states": [
        {"k_r_per_s": 0.35, "k_e": [0.02, 0.9, 0.1], "lambda": [0.05, 0.8, 0.15]},
        {"k_r_per_s": 0.012, "k_e": [0.01, 0.3, 0.05], "lambda": [0.1, 0.85, 0.3]}
    ]})
}

/// Presets of every kind, written into `dir`: (stem, path).
fn presets(dir: &Path) -> Vec<(String, String)> {
    let fluor = p(dir, "fluor.json");
    ok(&lumifit(&[
        "fluor",
        "reduce",
        &fixture("fixtures/fluor/synthetic.bfc"),
        "--basis",
        "xyzu",
        "--rgb",
        "acescg",
        "--out",
        &fluor,
    ]));
    let glass = p(dir, "glass.json");
    ok(&lumifit(&[
        "dispersion",
        "fit",
        "--glass",
        "N-SF11",
        "--out",
        &glass,
    ]));
    let f = read_json(&fluor)["fluorescence"].clone();
    let d = read_json(&glass)["dispersion"].clone();
    let docs = [
        (
            "reflectance",
            preset_with("grey card", &[("reflectance", reflectance())]),
        ),
        (
            "phosphorescent",
            preset_with("glow paint", &[("phosphorescence", phosphorescence())]),
        ),
        (
            "fluorescent",
            preset_with("fluorescent sheet", &[("fluorescence", f.clone())]),
        ),
        (
            "dispersive",
            preset_with("N-SF11", &[("dispersion", d.clone())]),
        ),
        (
            "combined",
            preset_with(
                "everything",
                &[
                    ("reflectance", reflectance()),
                    ("phosphorescence", phosphorescence()),
                    ("fluorescence", f),
                    ("dispersion", d),
                ],
            ),
        ),
    ];
    let mut out = Vec::new();
    for (stem, v) in docs {
        let path = write(
            dir,
            &format!("{stem}.json"),
            serde_json::to_vec_pretty(&v).unwrap(),
        );
        ok(&lumifit(&["preset", "validate", path.to_str().unwrap()]));
        out.push((stem.to_string(), path.display().to_string()));
    }
    out.push((
        "wavelength-bands".into(),
        fixture("fixtures/presets/valid_material_wavelength_bands.json"),
    ));
    out
}

#[test]
fn every_export_kind_with_and_without_the_sphere_passes_the_khronos_validator_with_zero_errors() {
    let dir = tempfile::tempdir().unwrap();
    let mut files = Vec::new();
    for (stem, preset) in presets(dir.path()) {
        for (suffix, scene) in [("", None), ("-sphere", Some("sphere"))] {
            for ext in ["gltf", "glb"] {
                let out = dir.path().join(format!("{stem}{suffix}.{ext}"));
                let mut args = vec![
                    "preset",
                    "export",
                    &preset,
                    "--format",
                    "gltf",
                    "--out",
                    out.to_str().unwrap(),
                ];
                if let Some(s) = scene {
                    args.extend(["--scene", s]);
                }
                let o = lumifit(&args);
                ok(&o);
                let summary: Value = serde_json::from_slice(&o.stdout).unwrap();
                assert!(!summary["sections"].as_array().unwrap().is_empty());
                files.push(out);
            }
        }
    }
    assert_eq!(files.len(), 6 * 2 * 2);
    let Some(report) = khronos_validator(&files) else {
        return;
    };
    println!("{report}");
    let summaries: Vec<&str> = report.lines().filter(|l| l.contains(" errors, ")).collect();
    assert_eq!(summaries.len(), files.len(), "{report}");
    for line in summaries {
        assert!(line.contains(": 0 errors, "), "{line}");
        assert!(line.contains(" 0 warnings,"), "a warning: {report}");
    }
}

/// Minimal base64 decoder (RFC 4648 with padding) for reading the buffer back.
fn unbase64(s: &str) -> Vec<u8> {
    let val = |c: u8| -> u32 {
        match c {
            b'A'..=b'Z' => u32::from(c - b'A'),
            b'a'..=b'z' => u32::from(c - b'a') + 26,
            b'0'..=b'9' => u32::from(c - b'0') + 52,
            b'+' => 62,
            b'/' => 63,
            _ => panic!("not base64: {c}"),
        }
    };
    let mut out = Vec::new();
    for chunk in s.as_bytes().chunks(4) {
        let n = chunk.iter().filter(|&&c| c != b'=').count();
        let mut v = 0u32;
        for (i, &c) in chunk.iter().enumerate() {
            if c != b'=' {
                v |= val(c) << (18 - 6 * i);
            }
        }
        out.extend_from_slice(&v.to_be_bytes()[1..n]);
    }
    out
}

/// The f32 values of accessor `i` of a `.gltf` with an embedded buffer.
fn accessor_f32(doc: &Value, bin: &[u8], i: usize) -> Vec<f32> {
    let a = &doc["accessors"][i];
    assert_eq!(a["componentType"], 5126);
    let view = &doc["bufferViews"][a["bufferView"].as_u64().unwrap() as usize];
    let off = view["byteOffset"].as_u64().unwrap_or(0) as usize
        + a["byteOffset"].as_u64().unwrap_or(0) as usize;
    let n = a["count"].as_u64().unwrap() as usize
        * match a["type"].as_str().unwrap() {
            "SCALAR" => 1,
            "VEC3" => 3,
            t => panic!("{t}"),
        };
    (0..n)
        .map(|k| f32::from_le_bytes(bin[off + 4 * k..off + 4 * k + 4].try_into().unwrap()))
        .collect()
}

fn gltf_buffer(doc: &Value) -> Vec<u8> {
    let uri = doc["buffers"][0]["uri"].as_str().unwrap();
    let b64 = uri
        .strip_prefix("data:application/octet-stream;base64,")
        .unwrap();
    let bin = unbase64(b64);
    assert_eq!(
        bin.len() as u64,
        doc["buffers"][0]["byteLength"].as_u64().unwrap()
    );
    bin
}

/// The keys of the two pointer channels: (times, emissiveFactor, emissiveStrength).
fn glow_keys(doc: &Value) -> (Vec<f64>, Vec<[f64; 3]>, Vec<f64>) {
    let bin = gltf_buffer(doc);
    let anim = &doc["animations"][0];
    let mut factor = None;
    let mut strength = None;
    let mut input = None;
    for ch in anim["channels"].as_array().unwrap() {
        assert_eq!(ch["target"]["path"], "pointer");
        let pointer = ch["target"]["extensions"]["KHR_animation_pointer"]["pointer"]
            .as_str()
            .unwrap();
        let sampler = &anim["samplers"][ch["sampler"].as_u64().unwrap() as usize];
        let light = pointer.starts_with("/extensions/KHR_lights_punctual");
        assert_eq!(
            sampler["interpolation"],
            if light { "STEP" } else { "LINEAR" }
        );
        let i = sampler["input"].as_u64().unwrap() as usize;
        assert!(
            input.is_none_or(|j| j == i),
            "both channels share the times"
        );
        input = Some(i);
        let out = accessor_f32(doc, &bin, sampler["output"].as_u64().unwrap() as usize);
        match pointer {
            "/materials/0/emissiveFactor" => factor = Some(out),
            "/materials/0/extensions/KHR_materials_emissive_strength/emissiveStrength" => {
                strength = Some(out)
            }
            "/extensions/KHR_lights_punctual/lights/0/intensity" => {
                // --scene sphere: the light is switched off for the whole glow.
                assert!(out.iter().all(|v| *v == 0.0));
                assert_eq!(
                    doc["extensions"]["KHR_lights_punctual"]["lights"][0]["type"],
                    "directional"
                );
                continue;
            }
            other => panic!("unexpected pointer {other}"),
        }
    }
    let t: Vec<f64> = accessor_f32(doc, &bin, input.unwrap())
        .into_iter()
        .map(f64::from)
        .collect();
    let f: Vec<[f64; 3]> = factor
        .unwrap()
        .chunks(3)
        .map(|c| [0, 1, 2].map(|k| f64::from(c[k])))
        .collect();
    let s: Vec<f64> = strength.unwrap().into_iter().map(f64::from).collect();
    assert_eq!(f.len(), t.len());
    assert_eq!(s.len(), t.len());
    (t, f, s)
}

/// Linear interpolation of both channels at `t`, multiplied as a glTF engine does.
fn engine_emission(keys: &(Vec<f64>, Vec<[f64; 3]>, Vec<f64>), t: f64) -> [f64; 3] {
    let (ts, f, s) = keys;
    let j = ts.partition_point(|&x| x <= t).clamp(1, ts.len() - 1);
    let u = (t - ts[j - 1]) / (ts[j] - ts[j - 1]);
    let g = s[j - 1] + u * (s[j] - s[j - 1]);
    [0, 1, 2].map(|c| (f[j - 1][c] + u * (f[j][c] - f[j - 1][c])) * g)
}

#[test]
fn the_glow_keys_read_back_from_the_gltf_are_within_the_stated_error_of_the_exact_glow_at_1000_random_times(
) {
    let dir = tempfile::tempdir().unwrap();
    let preset = write(
        dir.path(),
        "glow.json",
        serde_json::to_vec(&preset_with(
            "glow paint",
            &[("phosphorescence", phosphorescence())],
        ))
        .unwrap(),
    );
    let out = p(dir.path(), "glow.gltf");
    let (rel, abs, charge_s, irradiance, nits) = (0.005, 1e-4, 30.0, 2.0, 40.0);
    let o = lumifit(&[
        "preset",
        "export",
        preset.to_str().unwrap(),
        "--format",
        "gltf",
        "--out",
        &out,
        "--charge-s",
        "30",
        "--charge-irradiance",
        "2",
        "--nits-per-unit",
        "40",
        "--glow-s",
        "400",
        "--key-tolerance",
        "0.005,1e-4",
    ]);
    ok(&o);
    let err = stderr(&o);
    let doc = read_json(&out);
    let n_keys = doc["asset"]["extras"]["lumifit"]["sections_detail"]["emission"]["keys"]
        .as_u64()
        .unwrap();
    assert!(err.contains(&format!("glow: {n_keys} keys")), "{err}");
    let keys = glow_keys(&doc);
    assert_eq!(keys.0.len() as u64, n_keys);
    assert_eq!(keys.0[0], 0.0);
    assert_eq!(*keys.0.last().unwrap(), 400.0);

    // The exact solution, from the phosphor domain: charge from empty, then free decay (Eq. 1),
    // emission by Eq. 3, RGB bands (identity), times the stated scale.
    let m = lumifit::preset::phosphor::material_from_preset(
        &read_material(&preset).unwrap(),
        "glow.json",
    )
    .unwrap();
    let r0 = final_state(
        &m,
        &[Segment {
            duration_s: charge_s,
            irradiance: vec![irradiance; 3],
        }],
        &[0.0, 0.0],
    )
    .unwrap();
    let to_rgb = band_to_rgb(&lumifit::preset::Bands::Rgb, &RgbSpace::srgb().unwrap()).unwrap();
    let exact = |t: f64| -> [f64; 3] {
        let r: Vec<f64> = r0
            .iter()
            .zip(&m.states)
            .map(|(r, s)| r * (-s.k_r_per_s * t).exp())
            .collect();
        let e = emission(&m, &r);
        [0, 1, 2].map(|c| {
            nits * e
                .iter()
                .zip(&to_rgb)
                .map(|(v, col)| v * col[c])
                .sum::<f64>()
        })
    };
    let peak = exact(0.0).iter().fold(0.0f64, |a, &v| a.max(v));
    let mut state = 0x9E37_79B9_7F4A_7C15_u64;
    let mut worst = 0.0f64;
    for _ in 0..1000 {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        let t = 400.0 * ((state >> 11) as f64 / (1u64 << 53) as f64);
        let (e, x) = (engine_emission(&keys, t), exact(t));
        for c in 0..3 {
            let allowed = rel * x[c].abs() + abs * peak;
            worst = worst.max((e[c] - x[c]).abs() / allowed);
        }
    }
    println!(
        "glow: {n_keys} keys over 400 s; worst error at 1000 random times {worst:.3} of rel {rel}·|exact| + abs {abs}·peak"
    );
    assert!(worst <= 1.0, "worst {worst}");
    // The static material shows the glow at switch-off.
    let m0 = &doc["materials"][0];
    let s0 = m0["extensions"]["KHR_materials_emissive_strength"]["emissiveStrength"]
        .as_f64()
        .unwrap();
    let f0 = m0["emissiveFactor"].as_array().unwrap();
    for c in 0..3 {
        let v = f0[c].as_f64().unwrap() * s0;
        assert!((v - exact(0.0)[c]).abs() <= F32_REL * peak, "{v}");
    }
}

#[test]
fn peak_luminance_sets_the_luminance_at_switch_off_in_cd_per_m2() {
    let dir = tempfile::tempdir().unwrap();
    let out = p(dir.path(), "tape.gltf");
    ok(&lumifit(&[
        "preset",
        "export",
        &fixture("fixtures/presets/valid_material.json"),
        "--format",
        "gltf",
        "--out",
        &out,
        "--peak-luminance",
        "0.75",
    ]));
    let doc = read_json(&out);
    let keys = glow_keys(&doc);
    let srgb = RgbSpace::srgb().unwrap();
    let y = |rgb: [f64; 3]| -> f64 { (0..3).map(|c| srgb.matrix_rgb_to_xyz[1][c] * rgb[c]).sum() };
    let y0 = y(engine_emission(&keys, 0.0));
    assert!((y0 - 0.75).abs() <= F32_REL * 0.75, "{y0}");
    // A decay-only state in the preset: charged 'full' (every state at 1) by default.
    let e = &doc["asset"]["extras"]["lumifit"]["sections_detail"]["emission"];
    assert_eq!(e["charge"], "full");
    // The glow decays.
    assert!(y(engine_emission(&keys, 100.0)) < 0.5 * y0);
}

#[test]
fn a_glb_holds_the_same_document_and_buffer_as_the_gltf() {
    let dir = tempfile::tempdir().unwrap();
    let (gltf, glb) = (p(dir.path(), "t.gltf"), p(dir.path(), "t.glb"));
    for out in [&gltf, &glb] {
        ok(&lumifit(&[
            "preset",
            "export",
            &fixture("fixtures/presets/valid_material.json"),
            "--format",
            "gltf",
            "--scene",
            "sphere",
            "--out",
            out,
        ]));
    }
    let mut text = read_json(&gltf);
    let bin = gltf_buffer(&text);
    text["buffers"][0].as_object_mut().unwrap().remove("uri");
    let g = std::fs::read(&glb).unwrap();
    let u32_at = |i: usize| u32::from_le_bytes(g[i..i + 4].try_into().unwrap()) as usize;
    assert_eq!(&g[0..4], b"glTF");
    assert_eq!(u32_at(4), 2);
    assert_eq!(u32_at(8), g.len());
    let json_len = u32_at(12);
    assert_eq!(&g[16..20], b"JSON");
    let json: Value = serde_json::from_slice(&g[20..20 + json_len]).unwrap();
    // The generator's tool version and every number agree; only the uri differs.
    assert_eq!(json, text);
    let b = 20 + json_len;
    assert_eq!(&g[b + 4..b + 8], b"BIN\0");
    assert_eq!(&g[b + 8..b + 8 + bin.len()], &bin[..]);
    // The sphere's position accessor has min/max of the unit sphere.
    let pos = &json["accessors"][json["meshes"][0]["primitives"][0]["attributes"]["POSITION"]
        .as_u64()
        .unwrap() as usize];
    for (lo, hi) in pos["min"]
        .as_array()
        .unwrap()
        .iter()
        .zip(pos["max"].as_array().unwrap())
    {
        assert!(
            (lo.as_f64().unwrap() + 1.0).abs() < 1e-6 && (hi.as_f64().unwrap() - 1.0).abs() < 1e-6
        );
    }
}

#[test]
fn reflectance_becomes_the_linear_srgb_base_colour_of_lumifit_colorimetry() {
    let dir = tempfile::tempdir().unwrap();
    let flat = write(
        dir.path(),
        "grey.json",
        serde_json::to_vec(&preset_with(
            "18 % grey",
            &[(
                "reflectance",
                json!({"wavelength_nm": [380.0, 780.0], "value": [0.18, 0.18]}),
            )],
        ))
        .unwrap(),
    );
    let out = p(dir.path(), "grey.gltf");
    ok(&lumifit(&[
        "preset",
        "export",
        flat.to_str().unwrap(),
        "--format",
        "gltf",
        "--out",
        &out,
    ]));
    let doc = read_json(&out);
    let bc = doc["materials"][0]["pbrMetallicRoughness"]["baseColorFactor"]
        .as_array()
        .unwrap();
    for c in 0..3 {
        assert!(
            (bc[c].as_f64().unwrap() - 0.18).abs() < FLAT_GREY_ABS,
            "{bc:?}"
        );
    }
    assert_eq!(bc[3], 1.0);
    // The same spectrum through `lumifit color xyz`'s gamma-encoded sRGB, decoded, agrees.
    let csv = write(
        dir.path(),
        "r.csv",
        "wavelength_nm,value\n400,0.41\n450,0.62\n500,0.81\n550,0.84\n600,0.85\n650,0.85\n700,0.86\n",
    );
    let refl = write(
        dir.path(),
        "r.json",
        serde_json::to_vec(&preset_with("r", &[("reflectance", reflectance())])).unwrap(),
    );
    let out = p(dir.path(), "r.gltf");
    ok(&lumifit(&[
        "preset",
        "export",
        refl.to_str().unwrap(),
        "--format",
        "gltf",
        "--out",
        &out,
    ]));
    let bc: Vec<f64> = read_json(&out)["materials"][0]["pbrMetallicRoughness"]["baseColorFactor"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    let o = lumifit(&[
        "color",
        "xyz",
        "--sd",
        csv.to_str().unwrap(),
        "--method",
        "integration",
    ]);
    ok(&o);
    let c: Value = serde_json::from_slice(&o.stdout).unwrap();
    let c = if c.is_array() { c[0].clone() } else { c };
    let srgb = c["sRGB"].as_array().unwrap();
    for k in 0..3 {
        let lin = lumifit::colorimetry::rgb::eotf_srgb(srgb[k].as_f64().unwrap());
        assert!((lin - bc[k]).abs() < 1e-9, "{lin} vs {}", bc[k]);
    }
}

#[test]
fn the_fluorescence_block_carries_the_reduced_matrices_and_the_srgb_matrix_of_eq_16() {
    let dir = tempfile::tempdir().unwrap();
    let all = presets(dir.path());
    let path = &all.iter().find(|(s, _)| s == "fluorescent").unwrap().1;
    let out = p(dir.path(), "f.gltf");
    ok(&lumifit(&[
        "preset", "export", path, "--format", "gltf", "--out", &out,
    ]));
    let doc = read_json(&out);
    let block = &doc["materials"][0]["extras"]["lumifit_fluorescence"];
    assert_eq!(block["schema"], "lumifit.gltf.fluorescence/1");
    let section = read_material(Path::new(path))
        .unwrap()
        .fluorescence
        .unwrap();
    assert_eq!(block["reduced_matrix"], json!(section.matrix));
    assert_eq!(block["basis"]["k"], section.basis.k);
    assert_eq!(block["rgb"]["space"], "acescg");
    // M_srgb · v = XYZ→sRGB(P_xyz · sRGB→XYZ(v)) for any v.
    let m: Vec<Vec<f64>> = serde_json::from_value(block["rgb_matrix_linear_srgb"].clone()).unwrap();
    let srgb = RgbSpace::srgb().unwrap();
    let expect = rgb_matrix(&section, &srgb);
    for v in [[1.0, 0.0, 0.0], [0.2, 0.7, 0.1], [0.3, 0.3, 0.9]] {
        let xyz: [f64; 3] =
            std::array::from_fn(|r| (0..3).map(|c| srgb.matrix_rgb_to_xyz[r][c] * v[c]).sum());
        let px: [f64; 3] =
            std::array::from_fn(|r| (0..3).map(|c| section.xyz_matrix[r][c] * xyz[c]).sum());
        let back: [f64; 3] =
            std::array::from_fn(|r| (0..3).map(|c| srgb.matrix_xyz_to_rgb[r][c] * px[c]).sum());
        for r in 0..3 {
            let mv: f64 = (0..3).map(|c| m[r][c] * v[c]).sum();
            assert!((mv - back[r]).abs() < MATRIX_TOL, "{mv} vs {}", back[r]);
            assert!((m[r][0] - expect[r][0]).abs() < MATRIX_TOL);
        }
    }
    // No reflectance section: the base colour is white light through the matrix, and says so.
    let bc = &doc["materials"][0]["pbrMetallicRoughness"]["baseColorFactor"];
    assert_eq!(bc[0], block["base_color"]["linear_srgb"][0]);
    assert!(block["base_color"]["source"]
        .as_str()
        .unwrap()
        .contains("M · (1, 1, 1)"));
}

#[test]
fn openpbr_and_materialx_carry_base_colour_emission_luminance_and_dispersion() {
    let dir = tempfile::tempdir().unwrap();
    let all = presets(dir.path());
    let combined = &all.iter().find(|(s, _)| s == "combined").unwrap().1;
    let json_out = p(dir.path(), "c.openpbr.json");
    ok(&lumifit(&[
        "preset",
        "export",
        combined,
        "--format",
        "openpbr",
        "--out",
        &json_out,
        "--peak-luminance",
        "2",
    ]));
    let o = read_json(&json_out);
    assert_eq!(o["color_space"], "lin_rec709");
    assert!((o["emission_luminance"].as_f64().unwrap() - 2.0).abs() < 1e-12);
    let c = o["emission_color"].as_array().unwrap();
    let srgb = RgbSpace::srgb().unwrap();
    let y: f64 = (0..3)
        .map(|k| srgb.matrix_rgb_to_xyz[1][k] * c[k].as_f64().unwrap())
        .sum();
    assert!(
        (y - 1.0).abs() < 1e-12,
        "emission_color has luminance 1: {y}"
    );
    assert!(o["specular_ior"].as_f64().unwrap() > 1.7);
    assert!(o["lumifit_fluorescence"].is_object());
    let mtlx = p(dir.path(), "c.mtlx");
    ok(&lumifit(&[
        "preset",
        "export",
        combined,
        "--format",
        "mtlx",
        "--out",
        &mtlx,
        "--space",
        "acescg",
        "--peak-luminance",
        "2",
    ]));
    let text = std::fs::read_to_string(&mtlx).unwrap();
    // `--out -` writes the same document to standard output, and nothing else.
    let stdout = lumifit(&[
        "preset",
        "export",
        combined,
        "--format",
        "mtlx",
        "--out",
        "-",
        "--space",
        "acescg",
        "--peak-luminance",
        "2",
    ]);
    ok(&stdout);
    assert_eq!(String::from_utf8(stdout.stdout).unwrap(), text);
    let xml = roxmltree::Document::parse(&text).expect("well-formed XML");
    let root = xml.root_element();
    assert_eq!(root.tag_name().name(), "materialx");
    assert_eq!(root.attribute("version"), Some("1.39"));
    assert_eq!(root.attribute("colorspace"), Some("acescg"));
    let shader = root
        .children()
        .find(|n| n.has_tag_name("open_pbr_surface"))
        .unwrap();
    let input = |name: &str| {
        shader
            .children()
            .find(|n| n.attribute("name") == Some(name))
            .unwrap_or_else(|| panic!("no input {name}"))
    };
    let nits: f64 = input("emission_luminance")
        .attribute("value")
        .unwrap()
        .parse()
        .unwrap();
    assert!((nits - 2.0).abs() < 1e-12, "{nits}");
    assert_eq!(input("base_color").attribute("type"), Some("color3"));
    assert_eq!(
        input("transmission_dispersion_abbe_number")
            .attribute("value")
            .unwrap()
            .parse::<f64>()
            .unwrap(),
        o["transmission_dispersion_abbe_number"].as_f64().unwrap()
    );
    let material = root
        .children()
        .find(|n| n.has_tag_name("surfacematerial"))
        .unwrap();
    let link = material.children().find(|n| n.is_element()).unwrap();
    assert_eq!(link.attribute("nodename"), shader.attribute("name"));

    // The MaterialX library's own validator, when its Python bindings are installed.
    let script = fixture("scripts/gltf/validate_mtlx.py");
    match Command::new("python3").arg(&script).arg(&mtlx).output() {
        Ok(o) if o.status.code() == Some(3) => {
            eprintln!("SKIPPED: {}", String::from_utf8_lossy(&o.stderr).trim())
        }
        Ok(o) => assert!(
            o.status.success(),
            "MaterialX validate: {}{}",
            String::from_utf8_lossy(&o.stdout),
            String::from_utf8_lossy(&o.stderr)
        ),
        Err(_) => eprintln!("SKIPPED: python3 is not installed; MaterialX validation did not run"),
    }
}

#[test]
fn bad_input_exits_2_names_the_file_or_flag_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let out = p(dir.path(), "x.gltf");
    let tape = fixture("fixtures/presets/valid_material.json");
    let bare = fixture("fixtures/presets/valid_minimal_material.json");
    let run = |extra: &[&str], preset: &str| {
        let mut a = vec![
            "preset", "export", preset, "--format", "gltf", "--out", &out,
        ];
        a.extend_from_slice(extra);
        lumifit(&a)
    };
    assert_rejected(
        &run(&[], &bare),
        &["valid_minimal_material.json", "no section"],
    );
    // The tape's second state has no k_e: it cannot be charged for a time.
    assert_rejected(&run(&["--charge-s", "10"], &tape), &["--charge-s", "k_e"]);
    assert_rejected(
        &run(&["--charge-s", "soon"], &tape),
        &["--charge-s", "soon"],
    );
    assert_rejected(
        &run(&["--space", "acescg"], &tape),
        &["--space", "linear sRGB"],
    );
    assert_rejected(
        &run(&["--key-tolerance", "0.01,x"], &tape),
        &["--key-tolerance", "'x'"],
    );
    assert_rejected(&run(&["--key-tolerance", "0"], &tape), &["tolerance"]);
    assert_rejected(&run(&["--glow-s=-1"], &tape), &["--glow-s"]);
    assert_rejected(
        &run(&["--peak-luminance", "0"], &tape),
        &["--peak-luminance"],
    );
    let o = lumifit(&["preset", "export", &tape, "--format", "gltf", "--out", "-"]);
    assert_rejected(&o, &["--out", "standard output"]);
    assert!(o.stdout.is_empty());
    assert!(!Path::new(&out).exists(), "nothing written");
    assert!(!dir.path().join("x.openpbr.json").exists());
    // An output equal to the input is refused and the input left as it was.
    let copy = write(dir.path(), "tape.json", std::fs::read(&tape).unwrap());
    let before = std::fs::read(&copy).unwrap();
    let o = lumifit(&[
        "preset",
        "export",
        copy.to_str().unwrap(),
        "--format",
        "openpbr",
        "--out",
        copy.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert_eq!(std::fs::read(&copy).unwrap(), before);
    // MaterialX has no linear Rec. 2020 name.
    let m = p(dir.path(), "x.mtlx");
    assert_rejected(
        &lumifit(&[
            "preset", "export", &tape, "--format", "mtlx", "--space", "rec2020", "--out", &m,
        ]),
        &["--space", "rec2020"],
    );
    assert!(!Path::new(&m).exists());
}

#[test]
fn three_js_loads_the_export_headless_and_its_animation_mixer_plays_the_glow_within_the_stated_error(
) {
    if Command::new("node").arg("--version").output().is_err() {
        eprintln!("SKIPPED: node is not installed; three.js did not load the export");
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let preset = write(
        dir.path(),
        "glow.json",
        serde_json::to_vec(&preset_with(
            "glow paint",
            &[
                ("reflectance", reflectance()),
                ("phosphorescence", phosphorescence()),
            ],
        ))
        .unwrap(),
    );
    let out = p(dir.path(), "glow.glb");
    ok(&lumifit(&[
        "preset",
        "export",
        preset.to_str().unwrap(),
        "--format",
        "gltf",
        "--scene",
        "sphere",
        "--out",
        &out,
        "--glow-s",
        "300",
    ]));
    // The exact glow (saturated charge under irradiance 1: r_eq = a/(a + k_r)).
    let m = lumifit::preset::phosphor::material_from_preset(&read_material(&preset).unwrap(), "g")
        .unwrap();
    let r0: Vec<f64> = m
        .states
        .iter()
        .map(|s| {
            let a: f64 = s.k_e.as_ref().unwrap().iter().sum();
            a / (a + s.k_r_per_s)
        })
        .collect();
    let exact = |t: f64| -> [f64; 3] {
        let r: Vec<f64> = r0
            .iter()
            .zip(&m.states)
            .map(|(r, s)| r * (-s.k_r_per_s * t).exp())
            .collect();
        let e = emission(&m, &r);
        [e[0], e[1], e[2]]
    };
    let times: Vec<f64> = (0..50).map(|i| 300.0 * (i as f64 / 49.0).powi(2)).collect();
    let arg = times
        .iter()
        .map(|t| format!("{t}"))
        .collect::<Vec<_>>()
        .join(",");
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("scripts/gltf/load_three.sh");
    let o = Command::new("bash")
        .arg(script)
        .arg(&out)
        .arg(&arg)
        .output()
        .unwrap();
    assert!(o.status.success(), "three.js: {}", stderr(&o));
    let v: Value = serde_json::from_slice(&o.stdout).unwrap();
    let mat = &v["materials"][0];
    assert_eq!(mat["type"], "MeshStandardMaterial");
    assert_eq!(v["lights"][0]["type"], "DirectionalLight");
    let tracks = v["animations"][0]["tracks"].as_array().unwrap();
    assert_eq!(
        tracks.len(),
        3,
        "the three pointer channels became tracks: {v}"
    );
    assert!((v["lights"][0]["intensity"].as_f64().unwrap() - std::f64::consts::PI).abs() < 1e-12);
    let peak = exact(0.0).iter().fold(0.0f64, |a, &x| a.max(x));
    let (rel, abs) = (0.01, 1e-4); // the default --key-tolerance
    let mut worst = 0.0f64;
    for e in v["emission"].as_array().unwrap() {
        let t = e["t_s"].as_f64().unwrap();
        assert_eq!(
            e["light_intensity"], 0.0,
            "the light is off after switch-off"
        );
        let x = exact(t);
        for c in 0..3 {
            let got = e["rgb"][c].as_f64().unwrap();
            worst = worst.max((got - x[c]).abs() / (rel * x[c].abs() + abs * peak));
        }
    }
    println!(
        "three.js r{}: emission at 50 times, worst {worst:.3} of the key tolerance",
        v["three"]
    );
    assert!(worst <= 1.0, "worst {worst}");
}

#[test]
fn a_glow_over_wavelength_bands_outside_srgb_is_clipped_per_state_and_the_export_says_so() {
    let dir = tempfile::tempdir().unwrap();
    let out = p(dir.path(), "w.gltf");
    let preset = fixture("fixtures/presets/valid_material_wavelength_bands.json");
    ok(&lumifit(&[
        "preset", "export", &preset, "--format", "gltf", "--out", &out,
    ]));
    let doc = read_json(&out);
    let e = &doc["asset"]["extras"]["lumifit"]["sections_detail"]["emission"];
    // The states' colours through sRGB's matrix, unclipped: every clipped state has a negative
    // channel, and every state with one is listed.
    let sec = read_material(Path::new(&preset))
        .unwrap()
        .phosphorescence
        .unwrap();
    let m = band_to_rgb(&sec.bands, &RgbSpace::srgb().unwrap()).unwrap();
    let negative: Vec<u64> = sec
        .states
        .iter()
        .enumerate()
        .filter(|(_, s)| {
            (0..3).any(|c| {
                s.lambda
                    .iter()
                    .zip(&m)
                    .map(|(l, col)| l * col[c])
                    .sum::<f64>()
                    < 0.0
            })
        })
        .map(|(i, _)| i as u64)
        .collect();
    assert!(
        !negative.is_empty(),
        "the fixture's green band lies outside sRGB"
    );
    let listed: Vec<u64> = e["gamut_clipped_states"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_u64().unwrap())
        .collect();
    assert_eq!(listed, negative);
    // What is written stays a valid emission: every factor channel in [0, 1].
    let (_, f, s) = glow_keys(&doc);
    assert!(f.iter().flatten().all(|v| (0.0..=1.0).contains(v)));
    assert!(s.iter().all(|v| *v > 0.0));
}

#[test]
fn every_measured_fluorescent_material_reduces_and_exports_to_gltf_that_passes_the_validator() {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data/fluorescence");
    if !data.is_dir() {
        assert!(
            std::env::var("LUMIFIT_REQUIRE_DATA").as_deref() != Ok("1"),
            "LUMIFIT_REQUIRE_DATA=1 but {} is absent",
            data.display()
        );
        eprintln!(
            "SKIPPED: {} is absent (measured fluorescence data)",
            data.display()
        );
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let mut files = Vec::new();
    for sub in ["rit_gonzalez_bfc", "labsphere_3m_postit"] {
        let mut bfcs: Vec<PathBuf> = std::fs::read_dir(data.join(sub))
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.extension().is_some_and(|x| x.eq_ignore_ascii_case("bfc")))
            .collect();
        bfcs.sort();
        for bfc in bfcs {
            let stem = bfc.file_stem().unwrap().to_string_lossy().to_string();
            let preset = p(dir.path(), &format!("{stem}.json"));
            ok(&lumifit(&[
                "fluor",
                "reduce",
                bfc.to_str().unwrap(),
                "--out",
                &preset,
            ]));
            let out = dir.path().join(format!("{stem}.glb"));
            ok(&lumifit(&[
                "preset",
                "export",
                &preset,
                "--format",
                "gltf",
                "--scene",
                "sphere",
                "--out",
                out.to_str().unwrap(),
            ]));
            files.push(out);
        }
    }
    assert!(files.len() >= 10, "only {} measured files", files.len());
    let Some(report) = khronos_validator(&files) else {
        return;
    };
    println!("{report}");
    let lines: Vec<&str> = report.lines().filter(|l| l.contains(" errors, ")).collect();
    assert_eq!(lines.len(), files.len(), "{report}");
    assert!(
        lines.iter().all(|l| l.contains(": 0 errors, 0 warnings,")),
        "{report}"
    );
}
