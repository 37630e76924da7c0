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

/// `synth lvf-capture` of `spectrum` through `d/lvf.json` (1200×160, seed 2) to `d/image`, then
/// `spectrum recover` of it with the same bands to `d/out`.
fn captured_and_recovered(d: &std::path::Path, spectrum: &str, image: &str, out: &str) {
    ok(&lumifit(&[
        "synth",
        "lvf-capture",
        "--spectrum",
        spectrum,
        "--lvf",
        &p(d, "lvf.json"),
        "--size",
        "1200x160",
        "--seed",
        "2",
        "--out",
        &p(d, image),
    ]));
    ok(&lumifit(&[
        "spectrum",
        "recover",
        &p(d, image),
        "--bands",
        &p(d, "lvf.json"),
        "--out",
        &p(d, out),
    ]));
}

/// `synth lvf-hg` → `lvf calibrate` in `d`: writes `hg.tiff`, `truth.json` and `lvf.json`.
fn calibrated_lamp(d: &std::path::Path) {
    calibrated_lamp_with_truth(d, "truth.json");
}

/// [`calibrated_lamp`] with the lamp's truth written to `truth` (where `truth.json` is taken).
fn calibrated_lamp_with_truth(d: &std::path::Path, truth: &str) {
    ok(&lumifit(&[
        "synth",
        "lvf-hg",
        "--out",
        &p(d, "hg.tiff"),
        "--truth",
        &p(d, truth),
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
}

#[test]
fn a_recovered_spectrum_feeds_color_xyz() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    calibrated_lamp(d);
    write(
        d,
        "light.csv",
        "wavelength_nm,value\n380,0.2\n500,0.9\n600,0.5\n780,0.3\n",
    );
    captured_and_recovered(d, &p(d, "light.csv"), "cap.tiff", "rec.csv");
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

/// Green paint of Table 1 (k_r = 0.227 s⁻¹, k_e = 0.1, 0.035, 0.006 in the first three bands)
/// with Λ the band averages of its step spectrum (as `fit-decay --spectrum` reads a spectrum;
/// see tests/phos_e2e.rs): writes `emission.csv` and `truth.json`, returns their paths.
fn green_paint_sample(d: &std::path::Path) -> (String, String) {
    const LAMBDA: [f64; 8] = [0.0, 0.0, 0.07, 0.64, 0.05, 0.0, 0.0, 0.0];
    let mut spec = String::from("wavelength_nm,value\n");
    for (b, l) in LAMBDA.iter().enumerate() {
        let lo = 400.0 + 37.5 * b as f64;
        spec.push_str(&format!("{},{l}\n{},{l}\n", lo + 0.01, lo + 37.5 - 0.01));
    }
    let emission = write(d, "emission.csv", &spec);
    let (wl, v): (Vec<f64>, Vec<f64>) = spec
        .lines()
        .skip(1)
        .map(|l| {
            let (a, b) = l.split_once(',').unwrap();
            (a.parse::<f64>().unwrap(), b.parse::<f64>().unwrap())
        })
        .unzip();
    let lumifit::phosphor::BandSet::RangesNm(ranges) =
        lumifit::phosphor::BandSet::uniform(400.0, 700.0, 8).unwrap()
    else {
        panic!("uniform bands are wavelength bands")
    };
    let shape = lumifit::phosphor::band_spectrum(&wl, &v, &ranges).unwrap();
    let lambda: Vec<f64> = shape.iter().map(|s| s * 0.64).collect();
    let mut k_e = GREEN_K_E.to_vec();
    k_e.resize(8, 0.0);
    let truth = serde_json::json!({
        "schema": "lumifit.material/1",
        "name": "green_paint_truth",
        "provenance": {
            "tool": "lumifit", "tool_version": "0.1.0", "command": "tests/chains.rs",
            "created_utc": "2026-01-01T00:00:00Z", "inputs": [],
        },
        "phosphorescence": {
            "bands": ranges,
            "states": [{ "k_r_per_s": 0.227, "k_e": k_e, "lambda": lambda }],
        },
    });
    let truth = write(d, "truth.json", serde_json::to_vec_pretty(&truth).unwrap());
    (
        emission.to_string_lossy().to_string(),
        truth.to_string_lossy().to_string(),
    )
}

/// Table 1, green paint: k_e of the first three bands.
const GREEN_K_E: [f64; 3] = [0.1, 0.035, 0.006];

fn json_file(path: &std::path::Path) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap()
}

/// `phos fit-excitation` on `material` with the charging data of `green_paint_sample`;
/// returns (k_e of the first three bands, their σ, the report).
fn fit_excitation_on(
    d: &std::path::Path,
    material: &str,
    out: &str,
) -> (Vec<f64>, Vec<f64>, serde_json::Value, String) {
    let o = lumifit(&[
        "phos",
        "fit-excitation",
        "--material",
        material,
        "--data",
        &p(d, "ch.csv"),
        "--source",
        &p(d, "ch.source.csv"),
        "--camera",
        &p(d, "ch.camera.csv"),
        "--out",
        &p(d, out),
    ]);
    ok(&o);
    let report: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let fin = json_file(&d.join(out));
    let k: Vec<f64> = fin["phosphorescence"]["states"][0]["k_e"]
        .as_array()
        .unwrap()
        .iter()
        .take(3)
        .map(|v| v.as_f64().unwrap())
        .collect();
    let s: Vec<f64> = report["bands"]
        .as_array()
        .unwrap()
        .iter()
        .map(|b| b["k_e_sigma"][0].as_f64().unwrap())
        .collect();
    (k, s, report, stderr(&o))
}

/// The 16× chain: `synth phos-decay` charges green paint 5400 s under |E| = 1, which
/// leaves r(0) = 0.18; `phos fit-decay` reads that protocol from the series' `charging.json`
/// and `phos fit-excitation` solves k_e and r(0) together, recovering Table 1 within 3σ. The
/// same chain told the sample was saturated (a lie) misses by far more than 3σ, so the test
/// can fail; without any protocol fit-decay warns and records the assumption.
#[test]
fn synth_decay_then_fit_decay_then_fit_excitation_recovers_table1_green_paint() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (emission, truth) = green_paint_sample(d);
    // Defaults: 5400 s under flat |E| = 1. Short exposures so that window means equal the
    // instantaneous values (the decay fit reads frame-start times).
    ok(&lumifit(&[
        "synth",
        "phos-decay",
        "--material",
        &truth,
        "--exposure-s",
        "0.01",
        "--seed",
        "31",
        "--curve-only",
        "--out",
        &p(d, "decay"),
    ]));
    let charging = json_file(&d.join("decay/charging.json"));
    assert_eq!(charging["protocol"], "flat", "{charging}");
    let r0 = json_file(&d.join("decay/manifest.json"))["r_at_switch_off"][0]
        .as_f64()
        .unwrap();
    assert!((r0 - 0.18).abs() < 0.01, "r(0) = {r0}");
    let fit_decay = |extra: &[&str], curve: &str, out: &str| {
        let mut args = vec![
            "phos",
            "fit-decay",
            curve,
            "--spectrum",
            &emission,
            "--bands",
            "8",
            "--states",
            "1",
        ];
        args.extend_from_slice(extra);
        let o_path = p(d, out);
        args.extend_from_slice(&["--out", &o_path]);
        let o = lumifit(&args);
        ok(&o);
        stderr(&o)
    };
    let curve = p(d, "decay/curve.csv");
    let note = fit_decay(&[], &curve, "material.json");
    assert!(note.contains("charging protocol from"), "{note}");
    let m = json_file(&d.join("material.json"));
    assert_eq!(
        m["phosphorescence"]["decay_fit"]["charging"]["protocol"], "flat",
        "{}",
        m["phosphorescence"]["decay_fit"]
    );
    ok(&lumifit(&[
        "synth",
        "phos-excitation",
        "--material",
        &truth,
        "--bands",
        "3",
        "--seed",
        "32",
        "--out",
        &p(d, "ch.csv"),
    ]));
    let (k, s, report, _) = fit_excitation_on(d, &p(d, "material.json"), "final.json");
    println!(
        "k_e {k:?} ± {s:?}; decay charging {}",
        report["decay_charging"]
    );
    for b in 0..3 {
        assert!(
            (k[b] - GREEN_K_E[b]).abs() < 3.0 * s[b],
            "band {}: k_e {} ± {} against Table 1 {}",
            b + 1,
            k[b],
            s[b],
            GREEN_K_E[b]
        );
    }
    let r_fit = report["decay_charging"]["r_at_switch_off"][0]
        .as_f64()
        .unwrap();
    assert!(
        (r_fit - r0).abs() < 0.05 * r0,
        "r(0) fitted {r_fit}, true {r0}"
    );
    // Λ corrected back to the truth (peak 0.64 of band 4, as band averages).
    let fin = json_file(&d.join("final.json"));
    let lam = fin["phosphorescence"]["states"][0]["lambda"][3]
        .as_f64()
        .unwrap();
    let lam_true = json_file(std::path::Path::new(&truth))["phosphorescence"]["states"][0]
        ["lambda"][3]
        .as_f64()
        .unwrap();
    assert!(
        (lam - lam_true).abs() < 0.05 * lam_true,
        "Λ[4] {lam} against {lam_true}"
    );
    ok(&lumifit(&["preset", "validate", &p(d, "final.json")]));
    // The control: the same data called saturated give the old, far too high rates.
    fit_decay(&["--saturated"], &curve, "lie.json");
    let (k_lie, s_lie, _, _) = fit_excitation_on(d, &p(d, "lie.json"), "final_lie.json");
    assert!(
        (k_lie[0] - GREEN_K_E[0]).abs() > 10.0 * s_lie[0] && k_lie[0] > 2.0 * GREEN_K_E[0],
        "saturated reading: k_e {k_lie:?} ± {s_lie:?}"
    );
    // No protocol at all: a loud warning, and the preset says what was assumed.
    std::fs::create_dir(d.join("bare")).unwrap();
    std::fs::copy(d.join("decay/curve.csv"), d.join("bare/curve.csv")).unwrap();
    let warn = fit_decay(&[], &p(d, "bare/curve.csv"), "unknown.json");
    assert!(
        warn.contains("WARNING") && warn.contains("--saturated"),
        "{warn}"
    );
    let u = json_file(&d.join("unknown.json"));
    assert_eq!(
        u["phosphorescence"]["decay_fit"]["charging"]["protocol"],
        "unknown"
    );
    let (_, _, _, warn) = fit_excitation_on(d, &p(d, "unknown.json"), "final_unknown.json");
    assert!(warn.contains("WARNING"), "{warn}");
}

/// An RGB decay preset has a way to wavelength bands: `fit-excitation` refuses it (exit 2,
/// nothing written) naming the missing measurement — the glow's emission spectrum — and the
/// commands that provide it; following that advice (an LVF photo of the glow → `spectrum
/// recover` → `fit-decay --spectrum`) gives a preset `fit-excitation` accepts, with Table 1's
/// band-1 rate to 20 % (the recovered spectrum is a smoothed step).
#[test]
fn an_rgb_decay_preset_reaches_wavelength_bands_through_an_lvf_photo_of_the_glow() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (emission, truth) = green_paint_sample(d);
    ok(&lumifit(&[
        "synth",
        "phos-decay",
        "--material",
        &truth,
        "--saturated",
        "--exposure-s",
        "0.01",
        "--seed",
        "41",
        "--curve-only",
        "--out",
        &p(d, "decay"),
    ]));
    let curve = p(d, "decay/curve.csv");
    ok(&lumifit(&[
        "phos",
        "fit-decay",
        &curve,
        "--out",
        &p(d, "rgb.json"),
    ]));
    ok(&lumifit(&[
        "synth",
        "phos-excitation",
        "--material",
        &truth,
        "--bands",
        "3",
        "--seed",
        "42",
        "--out",
        &p(d, "ch.csv"),
    ]));
    let excite = |material: &str, out: &str| {
        lumifit(&[
            "phos",
            "fit-excitation",
            "--material",
            material,
            "--data",
            &p(d, "ch.csv"),
            "--source",
            &p(d, "ch.source.csv"),
            "--camera",
            &p(d, "ch.camera.csv"),
            "--out",
            &p(d, out),
        ])
    };
    let o = excite(&p(d, "rgb.json"), "x.json");
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let msg = stderr(&o);
    for want in [
        "RGB bands",
        "emission spectrum",
        "spectrum recover",
        "--spectrum",
    ] {
        assert!(msg.contains(want), "missing '{want}' in: {msg}");
    }
    assert!(!d.join("x.json").exists());
    // The advice: the glow through the LVF, recovered, as the decay fit's emission spectrum.
    calibrated_lamp_with_truth(d, "hg_truth.json");
    captured_and_recovered(d, &emission, "glow.tiff", "glow.csv");
    ok(&lumifit(&[
        "phos",
        "fit-decay",
        &curve,
        "--spectrum",
        &p(d, "glow.csv"),
        "--bands",
        "8",
        "--out",
        &p(d, "wl.json"),
    ]));
    let o = excite(&p(d, "wl.json"), "final.json");
    ok(&o);
    let fin = json_file(&d.join("final.json"));
    let k = fin["phosphorescence"]["states"][0]["k_e"][0]
        .as_f64()
        .unwrap();
    println!("band-1 k_e through the recovered glow spectrum: {k} (Table 1: 0.1)");
    assert!(
        (k - GREEN_K_E[0]).abs() < 0.2 * GREEN_K_E[0],
        "k_e[1] = {k}"
    );
}

/// lamp photo → `lvf calibrate` → captures of a patch and a white reference under LED-B3 →
/// `spectrum recover --illuminant LED-B3 --white … --preset` → `preset validate`: the recovered
/// reflectance becomes a material preset whose `reflectance` section follows the patch (a ramp
/// from 0.2 at 400 nm to 0.7 at 700 nm) to 0.08; without a reflectance mode `--preset` is
/// refused (exit 2, nothing written).
#[test]
fn a_recovered_reflectance_becomes_a_valid_material_preset() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    calibrated_lamp(d);
    write(
        d,
        "patch.csv",
        "wavelength_nm,value\n380,0.2\n400,0.2\n700,0.7\n780,0.7\n",
    );
    write(d, "white.csv", "wavelength_nm,value\n380,1\n780,1\n");
    for (refl, out, seed) in [
        ("patch.csv", "patch.tiff", "3"),
        ("white.csv", "white.tiff", "4"),
    ] {
        ok(&lumifit(&[
            "synth",
            "lvf-capture",
            "--reflectance",
            &p(d, refl),
            "--illuminant",
            "LED-B3",
            "--lvf",
            &p(d, "lvf.json"),
            "--size",
            "1200x160",
            "--seed",
            seed,
            "--out",
            &p(d, out),
        ]));
    }
    let o = lumifit(&[
        "spectrum",
        "recover",
        &p(d, "patch.tiff"),
        "--bands",
        &p(d, "lvf.json"),
        "--out",
        &p(d, "light.csv"),
        "--preset",
        &p(d, "light.json"),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("--illuminant"), "{}", stderr(&o));
    assert!(!d.join("light.csv").exists() && !d.join("light.json").exists());
    ok(&lumifit(&[
        "spectrum",
        "recover",
        &p(d, "patch.tiff"),
        "--bands",
        &p(d, "lvf.json"),
        "--illuminant",
        "LED-B3",
        "--white",
        &p(d, "white.tiff"),
        "--out",
        &p(d, "rec.csv"),
        "--preset",
        &p(d, "patch.json"),
        "--name",
        "ramp patch",
    ]));
    ok(&lumifit(&["preset", "validate", &p(d, "patch.json")]));
    let m = json_file(&d.join("patch.json"));
    assert_eq!(m["schema"], "lumifit.material/1");
    assert_eq!(m["name"], "ramp patch");
    let wl = m["reflectance"]["wavelength_nm"].as_array().unwrap();
    let v = m["reflectance"]["value"].as_array().unwrap();
    assert!(wl.len() > 10 && wl.len() == v.len());
    let mut worst = 0.0_f64;
    for (w, r) in wl.iter().zip(v) {
        let (w, r) = (w.as_f64().unwrap(), r.as_f64().unwrap());
        if (420.0..=680.0).contains(&w) {
            let truth = 0.2 + 0.5 * (w - 400.0) / 300.0;
            worst = worst.max((r - truth).abs());
        }
    }
    println!("worst |R − truth| over 420–680 nm: {worst:.4}");
    assert!(worst < 0.08, "worst reflectance error {worst}");
    // The preset's values are the CSV's.
    let csv = std::fs::read_to_string(d.join("rec.csv")).unwrap();
    let first: f64 = csv
        .lines()
        .nth(1)
        .unwrap()
        .split(',')
        .nth(1)
        .unwrap()
        .parse()
        .unwrap();
    assert!((first - v[0].as_f64().unwrap()).abs() <= 1e-9 * first.abs().max(1.0));
}

/// The defaults end to end, as frames: `synth phos-decay` with every default (5400 s at |E| = 1,
/// 1 s exposures every 5 s, 64×48 frames with shot and read noise) → `phos fit-decay --roi` (the
/// protocol from `charging.json`, the exposure from the manifest) → `phos fit-excitation`
/// recovers Table 1's green paint within 3σ; and the curve-only series with its 1 s windows
/// needs `--exposure-s 1` (without it, Λ is 10 % low and band 1 misses by more than 3σ).
#[test]
fn default_synthetic_frames_fit_back_to_table1_through_the_default_commands() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (emission, truth) = green_paint_sample(d);
    ok(&lumifit(&[
        "synth",
        "phos-decay",
        "--material",
        &truth,
        "--seed",
        "33",
        "--out",
        &p(d, "frames"),
    ]));
    ok(&lumifit(&[
        "synth",
        "phos-excitation",
        "--material",
        &truth,
        "--bands",
        "3",
        "--seed",
        "34",
        "--out",
        &p(d, "ch.csv"),
    ]));
    let o = lumifit(&[
        "phos",
        "fit-decay",
        &p(d, "frames/manifest.csv"),
        "--roi",
        "0,0,64,48",
        "--spectrum",
        &emission,
        "--bands",
        "8",
        "--states",
        "1",
        "--background",
        "--out",
        &p(d, "mf.json"),
    ]);
    ok(&o);
    let note = stderr(&o);
    assert!(
        note.contains("charging protocol from") && note.contains("exposure of 1 s"),
        "{note}"
    );
    let (k, s, _, _) = fit_excitation_on(d, &p(d, "mf.json"), "final_frames.json");
    println!("frames: k_e {k:?} ± {s:?}");
    for b in 0..3 {
        assert!(
            (k[b] - GREEN_K_E[b]).abs() < 3.0 * s[b],
            "frames, band {}: k_e {} ± {} against Table 1 {}",
            b + 1,
            k[b],
            s[b],
            GREEN_K_E[b]
        );
    }
    // The curve-only series of the same defaults.
    ok(&lumifit(&[
        "synth",
        "phos-decay",
        "--material",
        &truth,
        "--seed",
        "35",
        "--curve-only",
        "--out",
        &p(d, "curve"),
    ]));
    for (extra, name) in [(&["--exposure-s", "1"][..], "with"), (&[][..], "without")] {
        let mut args = vec![
            "phos",
            "fit-decay",
            "--spectrum",
            &emission,
            "--bands",
            "8",
            "--states",
            "1",
        ];
        let curve = p(d, "curve/curve.csv");
        let out = p(d, &format!("m_{name}.json"));
        args.extend_from_slice(&[&curve, "--out", &out]);
        args.extend_from_slice(extra);
        ok(&lumifit(&args));
        let (k, s, _, _) = fit_excitation_on(d, &out, &format!("f_{name}.json"));
        println!("curve {name} --exposure-s: k_e {k:?} ± {s:?}");
        let within = (0..3).all(|b| (k[b] - GREEN_K_E[b]).abs() < 3.0 * s[b]);
        assert_eq!(
            within,
            name == "with",
            "{name} --exposure-s: k_e {k:?} ± {s:?}"
        );
    }
}

/// A decay preset whose Λ is 30× the charging curves' units (another camera scale, written into
/// both Λ and the decay-fit amplitudes, so the Λ check cannot see it) cannot be reconciled by any
/// r(0) ≤ 1 of its flat charge: `fit-excitation` exits 2 naming the units, nothing written.
#[test]
fn fit_excitation_refuses_a_decay_preset_in_other_units_than_its_charging_curves() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (emission, truth) = green_paint_sample(d);
    ok(&lumifit(&[
        "synth",
        "phos-decay",
        "--material",
        &truth,
        "--exposure-s",
        "0.01",
        "--seed",
        "51",
        "--curve-only",
        "--out",
        &p(d, "decay"),
    ]));
    ok(&lumifit(&[
        "phos",
        "fit-decay",
        &p(d, "decay/curve.csv"),
        "--spectrum",
        &emission,
        "--bands",
        "8",
        "--states",
        "1",
        "--out",
        &p(d, "m.json"),
    ]));
    ok(&lumifit(&[
        "synth",
        "phos-excitation",
        "--material",
        &truth,
        "--bands",
        "3",
        "--seed",
        "52",
        "--out",
        &p(d, "ch.csv"),
    ]));
    let mut m = json_file(&d.join("m.json"));
    let scale = |v: &mut serde_json::Value| {
        for x in v.as_array_mut().unwrap() {
            *x = serde_json::json!(x.as_f64().unwrap() * 30.0);
        }
    };
    scale(&mut m["phosphorescence"]["states"][0]["lambda"]);
    scale(&mut m["phosphorescence"]["decay_fit"]["states"][0]["channel_amplitudes"]);
    write(d, "m30.json", serde_json::to_vec_pretty(&m).unwrap());
    let o = lumifit(&[
        "phos",
        "fit-excitation",
        "--material",
        &p(d, "m30.json"),
        "--data",
        &p(d, "ch.csv"),
        "--source",
        &p(d, "ch.source.csv"),
        "--camera",
        &p(d, "ch.camera.csv"),
        "--out",
        &p(d, "x.json"),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(
        e.contains("disagree in scale") && e.contains("camera units"),
        "{e}"
    );
    assert!(!d.join("x.json").exists());
}

/// The CSV columns `name` of `text` at the rows whose `time_s` is `t`.
fn csv_row_at(text: &str, t: f64, names: &[&str]) -> Vec<f64> {
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let idx: Vec<usize> = names
        .iter()
        .map(|n| header.iter().position(|h| h == n).unwrap())
        .collect();
    let row: Vec<f64> = lines
        .map(|l| {
            l.split(',')
                .map(|v| v.parse::<f64>().unwrap())
                .collect::<Vec<_>>()
        })
        .find(|r| r[0] == t)
        .unwrap_or_else(|| panic!("no row at {t} s"));
    idx.iter().map(|&i| row[i]).collect()
}

/// `phos design` on a history and targets → the designed preset → `phos simulate` under the very
/// history file the design read: the simulated emission at every keyframe reproduces the target
/// within the design's own reported residual for that keyframe (docs/cli.md, chain=phos). The
/// targets are L = Λ k_r r(t) of Λ = (0.5, 1, 0.2), k_r = 0.02 s⁻¹, Σ k_e E = 0.03 s⁻¹ for 60 s.
#[test]
fn the_history_phos_design_reads_feeds_phos_simulate_and_reproduces_the_targets() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write(
        d,
        "history.csv",
        "time_s,e_r,e_g,e_b\n0,1,1,1\n60,0,0,0\n240,0,0,0\n",
    );
    let targets = "time_s,l_r,l_g,l_b\n30,0.00466122,0.00932244,0.00186449\n\
                   60,0.00570128,0.0114026,0.00228051\n90,0.00312893,0.00625785,0.00125157\n\
                   120,0.00171719,0.00343438,0.000686877\n180,0.000517208,0.00103442,0.000206883\n\
                   240,0.00015578,0.00031156,6.23121e-05\n";
    write(d, "targets.csv", targets);
    let o = lumifit(&[
        "phos",
        "design",
        "--history",
        &p(d, "history.csv"),
        "--targets",
        &p(d, "targets.csv"),
        "--out",
        &p(d, "designed.json"),
    ]);
    ok(&o);
    let report: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(report["reachable"], true, "{report}");
    let o = lumifit(&[
        "phos",
        "simulate",
        "--material",
        &p(d, "designed.json"),
        "--history",
        &p(d, "history.csv"),
        "--dt",
        "1",
        "--out",
        &p(d, "simulation.csv"),
    ]);
    ok(&o);
    assert!(!stderr(&o).contains("deprecated"), "{}", stderr(&o));
    let sim = std::fs::read_to_string(d.join("simulation.csv")).unwrap();
    let keys = report["refined"]["keyframes"].as_array().unwrap();
    assert_eq!(keys.len(), 6);
    for k in keys {
        let t = k["time_s"].as_f64().unwrap();
        let target: Vec<f64> = (0..3).map(|c| k["target"][c].as_f64().unwrap()).collect();
        let reported = k["relative_residual"].as_f64().unwrap();
        let l = csv_row_at(&sim, t, &["L_r", "L_g", "L_b"]);
        let norm = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
        let diff: Vec<f64> = l.iter().zip(&target).map(|(a, b)| a - b).collect();
        let rel = norm(&diff) / norm(&target);
        assert!(
            rel <= reported * (1.0 + 1e-6) + 1e-12,
            "t = {t} s: simulated {l:?} vs target {target:?}: relative error {rel:e} > the design's {reported:e}"
        );
        assert!(rel < 1e-4, "t = {t} s: {rel:e}");
    }
    // The old layout of the same history: the same design and the same simulation, with a warning.
    write(
        d,
        "old.csv",
        "duration_s,e_r,e_g,e_b\n60,1,1,1\n180,0,0,0\n",
    );
    let o = lumifit(&[
        "phos",
        "simulate",
        "--material",
        &p(d, "designed.json"),
        "--history",
        &p(d, "old.csv"),
        "--dt",
        "1",
        "--out",
        &p(d, "old_sim.csv"),
    ]);
    ok(&o);
    assert!(stderr(&o).contains("deprecated"), "{}", stderr(&o));
    assert_eq!(sim, std::fs::read_to_string(d.join("old_sim.csv")).unwrap());
    let o = lumifit(&[
        "phos",
        "design",
        "--history",
        &p(d, "old.csv"),
        "--targets",
        &p(d, "targets.csv"),
        "--out",
        &p(d, "designed_old.json"),
    ]);
    ok(&o);
    assert!(stderr(&o).contains("deprecated"), "{}", stderr(&o));
    let old: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    for f in ["k_e", "k_r_per_s", "lambda", "keyframes"] {
        assert_eq!(old["refined"][f], report["refined"][f], "{f}");
    }
}
