//! `lumifit phos` and `lumifit synth phos-decay` as a user runs them: round trip through files,
//! and bad input rejected with exit code 2 and a message naming the file and the line.

mod common;

use common::{assert_rejected, lumifit, p, stderr};

use std::path::Path;

#[test]
fn synth_then_fit_decay_writes_a_preset_a_plot_and_a_batch_csv() {
    let d = tempfile::tempdir().unwrap();
    let out = p(d.path(), "synth");
    let o = lumifit(&[
        "synth",
        "phos-decay",
        "--material",
        "green_paint",
        "--seed",
        "3",
        "--curve-only",
        "--out",
        &out,
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let curve = p(d.path(), "synth/curve.csv");
    let json = p(d.path(), "m.json");
    let png = p(d.path(), "m.png");
    let o = lumifit(&["phos", "fit-decay", &curve, "--out", &json, "--plot", &png]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let k = v["phosphorescence"]["states"][0]["k_r_per_s"]
        .as_f64()
        .unwrap();
    assert!((k / 0.227 - 1.0).abs() < 0.05, "k = {k}");
    assert_eq!(v["phosphorescence"]["bands"], "rgb");
    assert!(Path::new(&png).exists());
    // batch: two copies of the curve under two ids
    let text = std::fs::read_to_string(&curve).unwrap();
    let mut batch = String::from("id,time_s,r,g,b\n");
    for id in ["a", "b"] {
        for l in text.lines().skip(1) {
            let f: Vec<&str> = l.split(',').collect();
            batch.push_str(&format!("{id},{},{},{},{}\n", f[0], f[1], f[2], f[3]));
        }
    }
    let bpath = p(d.path(), "batch.csv");
    std::fs::write(&bpath, batch).unwrap();
    let fits = p(d.path(), "fits.csv");
    let o = lumifit(&["phos", "fit-decay", "--batch", &bpath, "--out", &fits]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let res = std::fs::read_to_string(&fits).unwrap();
    assert!(res.starts_with("id,n_states,k1_per_s,k2_per_s,k3_per_s,a1,a2,a3,spectrum_r,spectrum_g,spectrum_b,rms,flags\n"));
    assert_eq!(res.lines().count(), 3);
}

#[test]
fn a_curve_with_decreasing_times_is_rejected_naming_the_file_and_line() {
    let d = tempfile::tempdir().unwrap();
    let f = p(d.path(), "bad.csv");
    std::fs::write(&f, "time_s,r,g,b\n0,3,2,1\n5,2,1,0.5\n4,1,0.5,0.2\n").unwrap();
    let o = lumifit(&["phos", "fit-decay", &f, "--out", &p(d.path(), "o.json")]);
    assert_rejected(&o, &["bad.csv", "line 4", "strictly increasing"]);
    std::fs::write(&f, "time_s,r,g,b\n0,3,2,1\n5,2,x,0.5\n").unwrap();
    let o = lumifit(&["phos", "fit-decay", &f, "--out", &p(d.path(), "o.json")]);
    assert_rejected(&o, &["bad.csv", "line 3"]);
}

#[test]
fn a_batch_with_a_wrong_header_or_duplicated_times_is_rejected_with_the_line() {
    let d = tempfile::tempdir().unwrap();
    let f = p(d.path(), "batch.csv");
    std::fs::write(&f, "id,t,r,g,b\n").unwrap();
    let o = lumifit(&[
        "phos",
        "fit-decay",
        "--batch",
        &f,
        "--out",
        &p(d.path(), "o.csv"),
    ]);
    assert_rejected(&o, &["batch.csv", "line 1", "id,time_s,r,g,b"]);
    std::fs::write(&f, "id,time_s,r,g,b\na,0,3,2,1\na,0,2,1,1\n").unwrap();
    let o = lumifit(&[
        "phos",
        "fit-decay",
        "--batch",
        &f,
        "--out",
        &p(d.path(), "o.csv"),
    ]);
    assert_rejected(&o, &["batch.csv", "line 3", "duplicated"]);
}

#[test]
fn per_pixel_without_a_series_is_rejected() {
    let d = tempfile::tempdir().unwrap();
    let o = lumifit(&[
        "phos",
        "fit-decay",
        "--per-pixel",
        "--out",
        &p(d.path(), "maps"),
    ]);
    assert_rejected(&o, &["no series"]);
}

#[test]
fn simulate_writes_emission_and_rejects_a_history_with_the_wrong_band_count() {
    let d = tempfile::tempdir().unwrap();
    let h = p(d.path(), "h.csv");
    std::fs::write(
        &h,
        "duration_s,e1,e2,e3,e4,e5,e6,e7,e8\n600,1,1,1,1,1,1,1,1\n180,0,0,0,0,0,0,0,0\n",
    )
    .unwrap();
    let out = p(d.path(), "em.csv");
    let o = lumifit(&[
        "phos",
        "simulate",
        "--material",
        "blue_paint",
        "--history",
        &h,
        "--dt",
        "5",
        "--out",
        &out,
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(
        std::fs::read_to_string(&out).unwrap().lines().count(),
        1 + 1 + 120 + 36
    );
    std::fs::write(&h, "duration_s,e1,e2\n600,1,1\n").unwrap();
    let o = lumifit(&[
        "phos",
        "simulate",
        "--material",
        "blue_paint",
        "--history",
        &h,
        "--out",
        &out,
    ]);
    assert_rejected(&o, &["h.csv", "line 1", "8 bands"]);
}

#[test]
fn a_noise_free_curve_is_fitted_exactly_despite_its_vanishing_std() {
    // synth writes σ ≈ 1e-154 for a noise-free curve; the weights 1/σ² must not overflow.
    let d = tempfile::tempdir().unwrap();
    let dir = p(d.path(), "nf");
    let o = lumifit(&[
        "synth",
        "phos-decay",
        "--material",
        "white_paint",
        "--noise",
        "0",
        "--curve-only",
        "--seed",
        "1",
        "--out",
        &dir,
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = p(d.path(), "nf.json");
    let o = lumifit(&[
        "phos",
        "fit-decay",
        &format!("{dir}/curve.csv"),
        "--out",
        &out,
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let k = v["states"][0]["k_r_per_s"].as_f64().unwrap();
    assert_eq!(v["states"].as_array().unwrap().len(), 1);
    assert!((k - 0.047).abs() < 1e-9, "k_r {k}");
}

#[test]
fn both_history_layouts_simulate_identically_and_the_old_one_warns() {
    let d = tempfile::tempdir().unwrap();
    let new = p(d.path(), "new.csv");
    let old = p(d.path(), "old.csv");
    std::fs::write(&new, "time_s,e1,e2,e3,e4,e5,e6,e7,e8\n0,1,1,1,1,0,0,0,0\n600,0,0,0,0,0,0,0,0\n780,0,0,0,0,0,0,0,0\n").unwrap();
    std::fs::write(
        &old,
        "duration_s,e1,e2,e3,e4,e5,e6,e7,e8\n600,1,1,1,1,0,0,0,0\n180,0,0,0,0,0,0,0,0\n",
    )
    .unwrap();
    let run = |h: &str, out: &str| {
        lumifit(&[
            "phos",
            "simulate",
            "--material",
            "blue_paint",
            "--history",
            h,
            "--dt",
            "5",
            "--out",
            out,
        ])
    };
    let (a, b) = (p(d.path(), "a.csv"), p(d.path(), "b.csv"));
    let o = run(&new, &a);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!stderr(&o).contains("deprecated"), "{}", stderr(&o));
    let o = run(&old, &b);
    assert!(o.status.success(), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(
        e.contains("warning:")
            && e.contains("old.csv")
            && e.contains("'duration_s' history layout is deprecated"),
        "{e}"
    );
    let (ta, tb) = (std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
    assert_eq!(
        ta, tb,
        "the two layouts of one history must simulate byte-identically"
    );
    assert_eq!(
        String::from_utf8(ta).unwrap().lines().count(),
        1 + 1 + 120 + 36
    );
    // A history that starts at 60 s: 60 s of dark first (the material starts dark), then the same.
    let late = p(d.path(), "late.csv");
    std::fs::write(
        &late,
        "time_s,e1,e2,e3,e4,e5,e6,e7,e8\n60,1,1,1,1,0,0,0,0\n660,0,0,0,0,0,0,0,0\n",
    )
    .unwrap();
    let c = p(d.path(), "c.csv");
    let o = run(&late, &c);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(&c).unwrap();
    let row60 = text.lines().find(|l| l.starts_with("60,")).unwrap();
    assert!(
        row60
            .split(',')
            .skip(1)
            .all(|v| v.parse::<f64>().unwrap() == 0.0),
        "{row60}"
    );
}

#[test]
fn bad_histories_are_exit_2_naming_file_line_and_column_and_write_nothing() {
    let d = tempfile::tempdir().unwrap();
    let out = p(d.path(), "em.csv");
    let e8 = "e1,e2,e3,e4,e5,e6,e7,e8";
    let cases: Vec<(String, Vec<&str>)> = vec![
        (
            format!("time_s,{e8}\n0,1,1,1,1,1,1,1,1\n600,0,0,0,0,0,0,0,0\n300,0,0,0,0,0,0,0,0\n"),
            vec!["line 4", "decreasing"],
        ),
        (
            format!("duration_s,{e8}\n600,1,1,1,1,1,1,1,1\n-60,0,0,0,0,0,0,0,0\n"),
            vec!["line 3", "expected a duration > 0"],
        ),
        (
            format!("time_s,{e8},duration_s\n0,1,1,1,1,1,1,1,1,1\n"),
            vec!["line 1", "column 10", "not both"],
        ),
        (
            "time_s,e1,e2,e3\n0,1,1,1\n60,0,0,0\n".to_string(),
            vec!["line 1", "3 irradiance columns", "8 bands"],
        ),
        (
            format!("time_s,{e8}\n0,1,1,1,-1,1,1,1,1\n60,0,0,0,0,0,0,0,0\n"),
            vec!["line 2", "column 'e4'"],
        ),
        (
            format!("time_s,{e8}\n0,1,1,1,1,1,1,1,1\n"),
            vec!["line 2", "no end"],
        ),
    ];
    for (csv, want) in cases {
        let h = p(d.path(), "h.csv");
        std::fs::write(&h, &csv).unwrap();
        let o = lumifit(&[
            "phos",
            "simulate",
            "--material",
            "blue_paint",
            "--history",
            &h,
            "--out",
            &out,
        ]);
        let mut frags = vec!["h.csv"];
        frags.extend(want);
        assert_rejected(&o, &frags);
        assert!(!Path::new(&out).exists(), "{csv}: nothing may be written");
    }
}

#[test]
fn phos_design_refuses_bad_histories_naming_file_line_and_column() {
    let d = tempfile::tempdir().unwrap();
    let t = p(d.path(), "t.csv");
    std::fs::write(&t, "time_s,l_r,l_g,l_b\n30,0.1,0.2,0.3\n").unwrap();
    let out = p(d.path(), "m.json");
    let cases: [(&str, &[&str]); 4] = [
        (
            "time_s,e_r,e_g\n0,1,1\n",
            &["line 1", "2 irradiance columns", "3 bands"],
        ),
        (
            "time_s,e_r,e_g,e_b\n0,1,1,1\n60,0,0,0\n60,0,0,0\n",
            &["line 4", "duplicated"],
        ),
        (
            "duration_s,e_r,e_g,e_b\n60,1,1,1\n-1,0,0,0\n",
            &["line 3", "duration > 0"],
        ),
        (
            "duration_s,e_r,e_g,time_s\n60,1,1,1\n",
            &["line 1", "not both"],
        ),
    ];
    for (csv, want) in cases {
        let h = p(d.path(), "h.csv");
        std::fs::write(&h, csv).unwrap();
        let o = lumifit(&[
            "phos",
            "design",
            "--history",
            &h,
            "--targets",
            &t,
            "--out",
            &out,
        ]);
        let mut frags = vec!["h.csv"];
        frags.extend_from_slice(want);
        assert_rejected(&o, &frags);
        assert!(!Path::new(&out).exists(), "{csv}: nothing may be written");
    }
}
