//! `lumifit light …` as a user runs it: inspect (text, JSON, polar plot), convert, illuminance,
//! and refusals with exit code 2.

mod common;

use common::{assert_rejected, lumifit, p, write};

const LAMBERT_IES: &str = "IES:LM-63-2019\n[TEST] t\nTILT=NONE\n1 -1 1 7 1 1 2 1 1 0\n1 1.00001 0\n0 15 30 45 60 75 90\n0\n1000 965.9258262890683 866.0254037844387 707.1067811865476 500.0000000000001 258.8190451025207 0\n";

#[test]
fn inspect_prints_flux_beam_and_tilt_and_writes_a_polar_plot() {
    let dir = tempfile::tempdir().unwrap();
    let f = write(dir.path(), "lambert.ies", LAMBERT_IES);
    let o = lumifit(&[
        "light",
        "inspect",
        f.to_str().unwrap(),
        "--json",
        "--plot",
        &p(dir.path(), "plots/polar.png"),
    ]);
    assert!(o.status.success(), "{}", common::stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let flux = v["flux_from_grid_lm"].as_f64().unwrap();
    // piecewise-linear cos on 15° steps integrates to π·I0 within 1 %
    assert!(
        (flux / (std::f64::consts::PI * 1000.0) - 1.0).abs() < 0.01,
        "{flux}"
    );
    assert_eq!(v["max_cd"], 1000.0);
    assert!(v["lor"].is_null(), "absolute photometry has no LOR");
    // beam angle of cos γ: 2·60° = 120°
    let beam = v["beam_field"][0]["beam_deg"].as_f64().unwrap();
    assert!((beam - 120.0).abs() < 0.5, "{beam}");
    assert_eq!(v["tilt"]["kind"], "none");
    let png = std::fs::read(dir.path().join("plots/polar.png")).unwrap();
    assert_eq!(&png[1..4], b"PNG");
    let text = lumifit(&["light", "inspect", f.to_str().unwrap()]);
    let t = String::from_utf8_lossy(&text.stdout);
    assert!(
        t.contains("beam 120.") && t.contains("lm from the grid"),
        "{t}"
    );
}

#[test]
fn convert_round_trips_through_eulumdat_and_ies() {
    let dir = tempfile::tempdir().unwrap();
    let f = write(dir.path(), "lambert.ies", LAMBERT_IES);
    let ldt = p(dir.path(), "l.ldt");
    assert!(
        lumifit(&["light", "convert", f.to_str().unwrap(), "--out", &ldt])
            .status
            .success()
    );
    let ies = p(dir.path(), "back.ies");
    assert!(lumifit(&["light", "convert", &ldt, "--out", &ies])
        .status
        .success());
    let a = lumifit::io::read_photometric(&f, 0.0).unwrap();
    let b = lumifit::io::read_photometric(std::path::Path::new(&ies), 0.0).unwrap();
    for (x, y) in a.photometry.grid.cd.iter().zip(&b.photometry.grid.cd) {
        assert!((x - y).abs() <= 4.0 * f64::EPSILON * x, "{x} {y}");
    }
    let o = lumifit(&[
        "light",
        "convert",
        f.to_str().unwrap(),
        "--out",
        f.to_str().unwrap(),
    ]);
    assert_rejected(&o, &["--out", "is the input"]);
    let o = lumifit(&[
        "light",
        "convert",
        f.to_str().unwrap(),
        "--out",
        &p(dir.path(), "x.txt"),
    ]);
    assert_rejected(&o, &[".ies or .ldt"]);
}

#[test]
fn illuminance_writes_the_points_with_e_and_the_methods_columns() {
    let dir = tempfile::tempdir().unwrap();
    let f = write(dir.path(), "lambert.ies", LAMBERT_IES);
    let pts = write(
        dir.path(),
        "pts.csv",
        "x,y,z,nx,ny,nz\n0,0,0,0,0,1\n0.5,0.2,0,0,0,2\n3,0,0,0,0,1\n",
    );
    for (m, extra) in [
        ("cubature", "Le_bar"),
        ("mc", "E_std"),
        ("point", ""),
        ("cubature-adaptive", "Le_bar"),
        ("structured", ""),
        ("mrp", ""),
    ] {
        let out = p(dir.path(), &format!("e_{m}.csv"));
        let o = lumifit(&[
            "light",
            "illuminance",
            f.to_str().unwrap(),
            "--rect",
            "1,1",
            "--center",
            "0,0,1",
            "--normal",
            "0,0,-1",
            "--up",
            "1,0,0",
            "--points",
            pts.to_str().unwrap(),
            "--method",
            m,
            "--out",
            &out,
        ]);
        assert!(o.status.success(), "{m}: {}", common::stderr(&o));
        let csv = std::fs::read_to_string(&out).unwrap();
        let header = csv.lines().next().unwrap();
        assert!(
            header.starts_with("x,y,z,nx,ny,nz,E_lux") && header.contains(extra),
            "{m}: {header}"
        );
        assert_eq!(csv.lines().count(), 4);
        // the second point's normal (0,0,2) is normalised
        assert!(
            csv.lines().nth(2).unwrap().starts_with("0.5,0.2,0,0,0,1,"),
            "{csv}"
        );
    }
}

#[test]
fn illuminance_refuses_bad_points_flags_and_files_with_exit_2() {
    let dir = tempfile::tempdir().unwrap();
    let f = write(dir.path(), "lambert.ies", LAMBERT_IES);
    let pts = write(dir.path(), "pts.csv", "x,y,z,nx,ny,nz\n0,0,0,0,0,1\n");
    let base = |extra: &[&str]| {
        let mut a = vec![
            "light",
            "illuminance",
            f.to_str().unwrap(),
            "--center",
            "0,0,1",
            "--normal",
            "0,0,-1",
            "--up",
            "1,0,0",
            "--points",
            pts.to_str().unwrap(),
        ];
        a.extend_from_slice(extra);
        a.iter().map(|s| s.to_string()).collect::<Vec<_>>()
    };
    let run = |extra: &[&str]| {
        let a = base(extra);
        lumifit(&a.iter().map(String::as_str).collect::<Vec<_>>())
    };
    let out = p(dir.path(), "e.csv");
    assert_rejected(
        &run(&["--rect", "1,1", "--samples", "10", "--out", &out]),
        &["--samples", "mc"],
    );
    assert_rejected(&run(&["--rect", "0,1", "--out", &out]), &["--rect"]);
    assert_rejected(
        &run(&[
            "--rect",
            "1,1",
            "--method",
            "mc",
            "--samples",
            "0",
            "--out",
            &out,
        ]),
        &["--samples"],
    );
    // without --rect the file's opening is used: 1 × 1 m here; a point opening is refused
    assert!(run(&["--out", &out]).status.success());
    std::fs::remove_file(&out).unwrap();
    let point = write(
        dir.path(),
        "point.ies",
        LAMBERT_IES.replace("2 1 1 0\n", "2 0 0 0\n"),
    );
    let o = lumifit(&[
        "light",
        "illuminance",
        point.to_str().unwrap(),
        "--center",
        "0,0,1",
        "--normal",
        "0,0,-1",
        "--up",
        "1,0,0",
        "--points",
        pts.to_str().unwrap(),
        "--out",
        &out,
    ]);
    assert_rejected(&o, &["--rect", "luminous opening"]);
    assert_rejected(
        &run(&["--rect", "1,1", "--out", pts.to_str().unwrap()]),
        &["is the input"],
    );
    let bad_pts = write(dir.path(), "bad.csv", "x,y,z,nx,ny\n0,0,0,0,0\n");
    let o = lumifit(&[
        "light",
        "illuminance",
        f.to_str().unwrap(),
        "--rect",
        "1,1",
        "--center",
        "0,0,1",
        "--normal",
        "0,0,-1",
        "--up",
        "1,0,0",
        "--points",
        bad_pts.to_str().unwrap(),
        "--out",
        &out,
    ]);
    assert_rejected(&o, &["bad.csv", "nz"]);
    assert!(
        !std::path::Path::new(&out).exists(),
        "nothing written on failure"
    );
    let broken = write(
        dir.path(),
        "broken.ies",
        LAMBERT_IES.replace("1000 965", "1000 -965"),
    );
    let o = lumifit(&["light", "inspect", broken.to_str().unwrap()]);
    assert_rejected(&o, &["broken.ies", "line 8", "negative"]);
    let ldt = write(dir.path(), "bad.ldt", "co\n1\n9\n");
    assert_rejected(
        &lumifit(&["light", "inspect", ldt.to_str().unwrap()]),
        &["bad.ldt", "line 3", "Isym"],
    );
}

#[test]
fn every_data_file_inspects_with_exit_0() {
    let d = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/data/photometric");
    if !d.is_dir() {
        assert!(
            std::env::var("LUMIFIT_REQUIRE_DATA").as_deref() != Ok("1"),
            "LUMIFIT_REQUIRE_DATA=1 but {} is absent",
            d.display()
        );
        eprintln!("skipping: {} is absent", d.display());
        return;
    }
    let mut n = 0;
    for sub in std::fs::read_dir(&d).unwrap() {
        let sub = sub.unwrap().path();
        if !sub.is_dir() {
            continue;
        }
        for f in std::fs::read_dir(&sub).unwrap() {
            let f = f.unwrap().path();
            let ext = f
                .extension()
                .map(|e| e.to_string_lossy().to_ascii_lowercase())
                .unwrap_or_default();
            if ext == "ies" || ext == "ldt" {
                let o = lumifit(&["light", "inspect", f.to_str().unwrap(), "--json"]);
                assert!(
                    o.status.success(),
                    "{}: {}",
                    f.display(),
                    common::stderr(&o)
                );
                n += 1;
            }
        }
    }
    assert_eq!(n, 15);
}

#[test]
fn light_preset_holds_the_full_grid_and_the_source_hash_and_validates() {
    let dir = tempfile::tempdir().unwrap();
    let f = write(dir.path(), "lambert.ies", LAMBERT_IES);
    let out = p(dir.path(), "light.json");
    let o = lumifit(&[
        "light",
        "preset",
        f.to_str().unwrap(),
        "--rect",
        "0.6,0.3",
        "--out",
        &out,
    ]);
    assert!(o.status.success(), "{}", common::stderr(&o));
    assert!(lumifit(&["preset", "validate", &out]).status.success());
    let preset = lumifit::preset::read_light(std::path::Path::new(&out)).unwrap();
    let grid = lumifit::preset::photometric::grid_from_section(&preset.photometric, &out).unwrap();
    let file = lumifit::io::read_photometric(&f, 0.0).unwrap();
    assert_eq!(
        grid, file.photometry.grid,
        "the preset's grid is the file's, bit for bit"
    );
    assert_eq!(
        preset.photometric["emitter_rect_m"],
        serde_json::json!([0.6, 0.3])
    );
    let sha = lumifit::preset::sha256_hex(LAMBERT_IES.as_bytes());
    assert_eq!(preset.provenance.inputs[0].sha256, sha);
    let o = lumifit(&[
        "light",
        "preset",
        f.to_str().unwrap(),
        "--rect",
        "-1,1",
        "--out",
        &p(dir.path(), "x.json"),
    ]);
    assert_rejected(&o, &["--rect"]);
}

#[test]
fn light_preset_gltf_of_every_type_c_data_file_passes_the_khronos_validator_and_its_ies_reads_back()
{
    let d = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/data/photometric");
    if !d.is_dir() {
        assert!(
            std::env::var("LUMIFIT_REQUIRE_DATA").as_deref() != Ok("1"),
            "LUMIFIT_REQUIRE_DATA=1 but {} is absent",
            d.display()
        );
        eprintln!("skipping: {} is absent", d.display());
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let mut gltfs = Vec::new();
    for sub in std::fs::read_dir(&d).unwrap() {
        let sub = sub.unwrap().path();
        if !sub.is_dir() {
            continue;
        }
        for f in std::fs::read_dir(&sub).unwrap() {
            let f = f.unwrap().path();
            let ext = f
                .extension()
                .map(|e| e.to_string_lossy().to_ascii_lowercase())
                .unwrap_or_default();
            if ext != "ies" && ext != "ldt" {
                continue;
            }
            let stem = f.file_stem().unwrap().to_string_lossy().to_string();
            let gltf = dir.path().join(format!("{stem}.gltf"));
            let o = lumifit(&[
                "light",
                "preset",
                f.to_str().unwrap(),
                "--out",
                &p(dir.path(), &format!("{stem}.json")),
                "--gltf",
                gltf.to_str().unwrap(),
                "--rect",
                "0.5,0.5",
            ]);
            if !o.status.success() {
                // Only Type A/B photometry is refused (EXT_lights_ies is Type C), and nothing is written.
                let e = common::stderr(&o);
                assert!(e.contains("only Type C"), "{}: {e}", f.display());
                assert!(!gltf.exists());
                continue;
            }
            // The IES written beside the glTF is read back by lumifit with the same flux (the
            // export mirrors C, which keeps the integral).
            let ies = dir.path().join(format!("{stem}.ies"));
            let flux = |path: &std::path::Path| -> f64 {
                let o = lumifit(&["light", "inspect", path.to_str().unwrap(), "--json"]);
                assert!(
                    o.status.success(),
                    "{}: {}",
                    path.display(),
                    common::stderr(&o)
                );
                let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
                v["flux_from_grid_lm"]
                    .as_f64()
                    .expect("flux_from_grid_lm in light inspect --json")
            };
            let (a, b) = (flux(&f), flux(&ies));
            assert!(
                (a - b).abs() <= 1e-6 * a.abs().max(1e-9),
                "{stem}: {a} vs {b} lm"
            );
            gltfs.push(gltf);
        }
    }
    assert!(gltfs.len() >= 10, "only {} files exported", gltfs.len());
    let Some(report) = common::khronos_validator(&gltfs) else {
        return;
    };
    assert_eq!(
        report.matches(" 0 errors, 0 warnings").count(),
        gltfs.len(),
        "{report}"
    );
}

#[test]
fn preset_export_gltf_of_a_light_preset_writes_the_same_node_as_light_preset_and_passes_the_validator(
) {
    let dir = tempfile::tempdir().unwrap();
    let ies = p(dir.path(), "asym.ies");
    let o = lumifit(&["light", "synth", "--profile", "asymmetric", "--out", &ies]);
    assert!(o.status.success(), "{}", common::stderr(&o));
    // light preset --gltf in its default frame …
    let json = p(dir.path(), "asym.json");
    let direct = dir.path().join("direct/light.gltf");
    std::fs::create_dir_all(direct.parent().unwrap()).unwrap();
    let o = lumifit(&[
        "light",
        "preset",
        &ies,
        "--out",
        &json,
        "--gltf",
        direct.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", common::stderr(&o));
    // … and preset export of that preset
    let exported = dir.path().join("export/light.gltf");
    let o = lumifit(&[
        "preset",
        "export",
        &json,
        "--format",
        "gltf",
        "--out",
        exported.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", common::stderr(&o));
    let read = |p: &std::path::Path| -> serde_json::Value {
        serde_json::from_slice(&std::fs::read(p).unwrap()).unwrap()
    };
    let (a, b) = (read(&direct), read(&exported));
    assert_eq!(
        a["nodes"], b["nodes"],
        "node (placement, rotation, extensions)"
    );
    assert_eq!(a["extensions"], b["extensions"]);
    // the IES beside it holds the same (mirrored) grid as the one light preset wrote
    let ga = lumifit::io::read_photometric(&dir.path().join("direct/light.ies"), 0.0).unwrap();
    let gb = lumifit::io::read_photometric(&dir.path().join("export/light.ies"), 0.0).unwrap();
    assert_eq!(ga.photometry.grid, gb.photometry.grid);
    // a broken light preset is refused naming the field, nothing written
    let mut v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    v["photometric"]["emitter_rect_m"] = serde_json::json!([0.0, 1.0]);
    let bad = common::write(dir.path(), "bad.json", serde_json::to_string(&v).unwrap());
    let out = dir.path().join("bad/x.gltf");
    let o = lumifit(&[
        "preset",
        "export",
        bad.to_str().unwrap(),
        "--format",
        "gltf",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_rejected(&o, &["bad.json", "emitter_rect_m"]);
    assert!(!out.exists() && !dir.path().join("bad/x.ies").exists());
    let Some(report) = common::khronos_validator(&[&exported]) else {
        return;
    };
    assert_eq!(
        report.matches(" 0 errors, 0 warnings").count(),
        1,
        "{report}"
    );
}

#[test]
fn illuminance_interp_bicubic_follows_the_cosine_between_fifteen_degree_nodes() {
    // LAMBERT_IES stores 1000 cos γ at 15° steps. A receiver seen at γ = 7.5° from the light's
    // centre: `point` reads I(7.5°) once. Bilinear gives the chord (0.86 % low); the cubic
    // Hermite follows cos γ to within 1e-4 (its error is O(h⁴)).
    let dir = tempfile::tempdir().unwrap();
    let f = write(dir.path(), "lambert.ies", LAMBERT_IES);
    let g = 7.5f64.to_radians();
    let x = g.tan();
    let pts = write(
        dir.path(),
        "pts.csv",
        format!("x,y,z,nx,ny,nz\n{x},0,0,0,0,1\n"),
    );
    let mut e = Vec::new();
    for interp in ["bilinear", "bicubic"] {
        let out = p(dir.path(), &format!("e_{interp}.csv"));
        let o = lumifit(&[
            "light",
            "illuminance",
            f.to_str().unwrap(),
            "--rect",
            "1,1",
            "--center",
            "0,0,1",
            "--normal",
            "0,0,-1",
            "--up",
            "1,0,0",
            "--points",
            pts.to_str().unwrap(),
            "--method",
            "point",
            "--interp",
            interp,
            "--out",
            &out,
        ]);
        assert!(o.status.success(), "{}", common::stderr(&o));
        let text = std::fs::read_to_string(&out).unwrap();
        let row = text.lines().nth(1).unwrap();
        e.push(row.split(',').nth(6).unwrap().parse::<f64>().unwrap());
    }
    let r2 = 1.0 + x * x;
    let exact = 1000.0 * g.cos() * g.cos() / r2;
    let (bl, bc) = (e[0] / exact - 1.0, e[1] / exact - 1.0);
    assert!(bl < -0.008, "bilinear {bl}");
    assert!(bc.abs() < 1e-4, "bicubic {bc}");
    let o = lumifit(&[
        "light",
        "illuminance",
        f.to_str().unwrap(),
        "--rect",
        "1,1",
        "--center",
        "0,0,1",
        "--normal",
        "0,0,-1",
        "--up",
        "1,0,0",
        "--points",
        pts.to_str().unwrap(),
        "--interp",
        "spline",
        "--out",
        &p(dir.path(), "x.csv"),
    ]);
    assert_rejected(&o, &["--interp"]);
}
