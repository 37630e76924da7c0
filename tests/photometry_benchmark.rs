//! The paper's benchmark (Luksch et al. 2020 §6): `light synth` → `light benchmark` on a tiny
//! configuration, the shape of the result (Fig. 10), the reference's noise against its target,
//! and the reference's honesty against the closed form.

mod common;

use std::path::PathBuf;

use common::{assert_rejected, lumifit, p};
use lumifit::photometry::benchmark::{run_case, BenchmarkSpec};
use lumifit::photometry::illuminance::{lambertian_illuminance, Receiver};
use lumifit::photometry::synthetic::{SyntheticProfile, I0_CD};

fn data_dir() -> Option<PathBuf> {
    let d = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/data/photometric");
    if d.is_dir() {
        Some(d)
    } else if std::env::var("LUMIFIT_REQUIRE_DATA").as_deref() == Ok("1") {
        panic!("LUMIFIT_REQUIRE_DATA=1 but {} is absent", d.display());
    } else {
        eprintln!(
            "skipping: {} is absent (set LUMIFIT_REQUIRE_DATA=1 to make this a failure)",
            d.display()
        );
        None
    }
}

/// Column `name` of a CSV text, by header.
fn column<'a>(csv: &'a str, name: &str) -> Vec<&'a str> {
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let k = header
        .iter()
        .position(|h| *h == name)
        .unwrap_or_else(|| panic!("no column {name} in {header:?}"));
    lines.map(|l| l.split(',').nth(k).unwrap()).collect()
}

fn nrms_of(csv: &str, method: &str, height: &str) -> f64 {
    let (m, h, e, s) = (
        column(csv, "method"),
        column(csv, "height_m"),
        column(csv, "nrms"),
        column(csv, "samples_per_point"),
    );
    (0..m.len())
        .find(|&i| m[i] == method && h[i] == height && s[i].is_empty())
        .map(|i| e[i].parse().unwrap())
        .unwrap_or_else(|| panic!("no {method} at {height}"))
}

#[test]
fn benchmark_of_a_synthetic_lambertian_has_the_shape_of_the_papers_figure_ten() {
    let dir = tempfile::tempdir().unwrap();
    let ies = p(dir.path(), "lambertian.ies");
    let o = lumifit(&["light", "synth", "--profile", "lambertian", "--out", &ies]);
    assert!(o.status.success(), "{}", common::stderr(&o));
    let out = p(dir.path(), "bench");
    let o = lumifit(&[
        "light",
        "benchmark",
        &ies,
        "--resolution",
        "16",
        "--size",
        "3",
        "--heights",
        "0.1,2.5",
        "--orientations",
        "0.5,1",
        "--out",
        &out,
    ]);
    assert!(o.status.success(), "{}", common::stderr(&o));
    let read = |f: &str| std::fs::read_to_string(dir.path().join("bench").join(f)).unwrap();
    let csv = read("nrms.csv");
    // near the light the cubature is far below point and structured sampling
    let (point, structured, cubature) = (
        nrms_of(&csv, "point", "0.1"),
        nrms_of(&csv, "structured", "0.1"),
        nrms_of(&csv, "cubature", "0.1"),
    );
    assert!(cubature < 0.25 * point, "{cubature} vs point {point}");
    assert!(
        cubature < 0.7 * structured,
        "{cubature} vs structured {structured}"
    );
    // far away every method is within a few per cent (2.5 m: point ≤ 5 %)
    assert!(nrms_of(&csv, "point", "2.5") < 0.05);
    assert!(nrms_of(&csv, "cubature-adaptive", "0.1") < 0.1 * cubature);
    // the reference's own noise is below 1/10 of the smallest NRMS it judges
    let r = read("reference.csv");
    for (noise, smallest) in column(&r, "reference_noise_nrms")
        .iter()
        .zip(column(&r, "smallest_judged_nrms"))
    {
        let (noise, smallest): (f64, f64) = (noise.parse().unwrap(), smallest.parse().unwrap());
        assert!(
            noise > 0.0 && noise < 0.1 * smallest,
            "{noise} vs {smallest}"
        );
    }
    assert!(column(&r, "converged").iter().all(|c| *c == "true"));
    // MC needs more than a handful of samples to match the cubature near the light
    let n_eq: f64 = column(&r, "mc_samples_equal")[0].parse().unwrap();
    assert!(n_eq > 16.0, "{n_eq}");
    let md = read("nrms.md");
    assert!(
        md.contains("| lambertian | 0.1 |") && md.contains("| lambertian | 2.5 |"),
        "{md}"
    );
    for h in ["0.1", "2.5"] {
        let png =
            std::fs::read(dir.path().join(format!("bench/diff-lambertian-h{h}.png"))).unwrap();
        assert_eq!(&png[1..4], b"PNG");
        let img = image::load_from_memory(&png).unwrap();
        // 7 rows (reference, 5 methods, the matching MC rung) of 16 px × 8 zoom plus margins
        assert!(
            img.height() > 7 * 128 && img.width() > 2 * 128,
            "{}×{}",
            img.width(),
            img.height()
        );
    }
    let v: serde_json::Value = serde_json::from_str(&read("summary.json")).unwrap();
    assert_eq!(v["cases"].as_array().unwrap().len(), 2);
}

#[test]
fn the_reference_agrees_with_lamberts_closed_form_within_its_reported_noise() {
    // A uniform emitter: the closed form is exact, so the reference's measured error must be
    // of the size of the noise it reports (a lying standard error fails here either way).
    let grid = SyntheticProfile::Lambertian.file().unwrap().photometry.grid;
    let spec = BenchmarkSpec {
        heights_m: vec![0.25],
        orientations_rad: vec![std::f64::consts::PI, 0.75 * std::f64::consts::PI],
        image_size_m: 3.0,
        resolution_px: 20,
        ..BenchmarkSpec::default()
    };
    let case = run_case("lambertian", &grid, &spec, 0.25).unwrap();
    let reference = &case.images[0].images;
    let receivers = lumifit::photometry::benchmark::ground_receivers(&spec);
    let (mut num, mut den) = (0.0, 0.0);
    for (o, &theta) in spec.orientations_rad.iter().enumerate() {
        let light = lumifit::photometry::benchmark::scene_light(&spec, 0.25, theta).unwrap();
        for (r, e_ref) in receivers.iter().zip(&reference[o]) {
            // the grid is I0 cos γ sampled at 1°: radiance I0/A, A = 1
            // the profile has no back side: receivers behind the light's plane get nothing
            let d: f64 = (0..3)
                .map(|k| (r.p[k] - light.center[k]) * light.n[k])
                .sum();
            let exact = if d > 0.0 {
                lambertian_illuminance(&light, I0_CD, &Receiver { p: r.p, n: r.n })
            } else {
                0.0
            };
            num += (e_ref - exact).powi(2);
            den += exact * exact;
        }
    }
    let err = (num / den).sqrt();
    let noise = case.reference.noise_nrms;
    // the 1° linear interpolation of cos γ is ≤ 4e-5 relative; the rest is MC noise
    assert!(
        err < 3.0 * noise + 1e-4,
        "error {err} vs reported noise {noise}"
    );
    assert!(
        err > 0.2 * noise,
        "error {err} far below reported noise {noise}"
    );
}

#[test]
fn benchmark_of_a_real_file_converges_and_keeps_the_cubature_below_point_near_the_light() {
    let Some(d) = data_dir() else { return };
    let f = d.join("lidrs_MIT/example.ldt");
    let dir = tempfile::tempdir().unwrap();
    let out = p(dir.path(), "b");
    let o = lumifit(&[
        "light",
        "benchmark",
        f.to_str().unwrap(),
        "--resolution",
        "12",
        "--heights",
        "0.1",
        "--orientations",
        "0.75,1",
        "--out",
        &out,
    ]);
    assert!(o.status.success(), "{}", common::stderr(&o));
    let csv = std::fs::read_to_string(dir.path().join("b/nrms.csv")).unwrap();
    assert!(nrms_of(&csv, "cubature", "0.1") < 0.5 * nrms_of(&csv, "point", "0.1"));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["all_references_converged"], true);
    assert!(dir.path().join("b/diff-example-h0.1.png").is_file());
}

#[test]
fn benchmark_refuses_bad_input_with_exit_2_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let bad = common::write(
        dir.path(),
        "bad.ies",
        "IES:LM-63-2019\nTILT=NONE\n1 -1 1 3\n",
    );
    let out = p(dir.path(), "out");
    let o = lumifit(&["light", "benchmark", bad.to_str().unwrap(), "--out", &out]);
    assert_rejected(&o, &["bad.ies"]);
    assert!(!dir.path().join("out").exists());
    let ies = p(dir.path(), "l.ies");
    assert!(
        lumifit(&["light", "synth", "--profile", "spot", "--out", &ies])
            .status
            .success()
    );
    for (flag, value, says) in [
        ("--heights", "0.1,-1", "--heights"),
        ("--orientations", "1.5", "--orientations"),
        ("--resolution", "100000", "--resolution"),
        ("--size", "0", "--size"),
    ] {
        let o = lumifit(&["light", "benchmark", &ies, flag, value, "--out", &out]);
        assert_rejected(&o, &[says]);
        assert!(!dir.path().join("out").exists(), "{flag} {value}");
    }
    let o = lumifit(&[
        "light",
        "synth",
        "--profile",
        "disco",
        "--out",
        &p(dir.path(), "x.ies"),
    ]);
    assert_rejected(&o, &["--profile", "disco", "lambertian"]);
}

#[test]
fn every_synthetic_profile_is_written_by_the_ies_writer_and_reads_back_exactly() {
    let dir = tempfile::tempdir().unwrap();
    for prof in SyntheticProfile::ALL {
        let out = dir.path().join(format!("{}.ies", prof.name()));
        let o = lumifit(&[
            "light",
            "synth",
            "--profile",
            prof.name(),
            "--out",
            out.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", common::stderr(&o));
        let back = lumifit::io::read_photometric(&out, 0.0).unwrap();
        assert_eq!(
            back.photometry.grid,
            prof.file().unwrap().photometry.grid,
            "{}",
            prof.name()
        );
    }
}
