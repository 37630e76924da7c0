//! The house rules for the phosphorescence commands, tried as a careless user would: an output
//! named like an input, a plot that fails after the main output is ready, files from Excel (BOM),
//! duplicated column names, keyframes out of order, a batch in which nothing fits, sizes too
//! large to allocate. Each is exit code 2 with a message naming the input, and every existing
//! file is left byte-identical.

mod common;

use std::path::Path;

use common::{assert_rejected, lumifit, p, write};

const BOM: &str = "\u{feff}";

/// A three-channel decay curve of two states (fast 0.2 s⁻¹, slow 0.01 s⁻¹), 60 samples, with `std`.
fn curve_csv() -> String {
    let mut s = String::from("time_s,r,g,b,std\n");
    for i in 0..60 {
        let t = i as f64 * 2.0;
        let y = |a: f64, b: f64| a * (-0.2 * t).exp() + b * (-0.01 * t).exp();
        s.push_str(&format!(
            "{t},{},{},{},0.001\n",
            y(1.0, 0.5),
            y(0.6, 0.3),
            y(0.2, 0.1)
        ));
    }
    s
}

fn ok(o: &std::process::Output) -> String {
    assert!(
        o.status.success(),
        "expected success, stderr: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    String::from_utf8_lossy(&o.stdout).to_string()
}

/// Names in `dir` (temporary files of a failed command would show here).
fn listing(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().to_string())
        .collect();
    v.sort();
    v
}

#[test]
fn fit_decay_with_the_curve_as_its_output_is_refused_and_the_curve_is_untouched() {
    let d = tempfile::tempdir().unwrap();
    let c = write(d.path(), "c.csv", curve_csv());
    let before = std::fs::read(&c).unwrap();
    let cs = c.to_string_lossy().to_string();
    let o = lumifit(&["phos", "fit-decay", &cs, "--out", &cs]);
    assert_rejected(&o, &["--out", "c.csv"]);
    assert_eq!(std::fs::read(&c).unwrap(), before);
    // the same through another spelling of the path, and as the plot
    let other = format!("{}/./c.csv", d.path().display());
    let o = lumifit(&["phos", "fit-decay", &cs, "--out", &other]);
    assert_rejected(&o, &["c.csv"]);
    let o = lumifit(&[
        "phos",
        "fit-decay",
        &cs,
        "--out",
        &p(d.path(), "m.json"),
        "--plot",
        &cs,
    ]);
    assert_rejected(&o, &["--plot", "c.csv"]);
    assert_eq!(std::fs::read(&c).unwrap(), before);
    assert_eq!(listing(d.path()), ["c.csv"]);
}

#[test]
fn simulate_and_design_refuse_to_overwrite_their_inputs() {
    let d = tempfile::tempdir().unwrap();
    let h = write(
        d.path(),
        "h.csv",
        "duration_s,a,b,c,d,e,f,g,h\n10,1,1,1,1,1,1,1,1\n10,0,0,0,0,0,0,0,0\n",
    );
    let before = std::fs::read(&h).unwrap();
    let hs = h.to_string_lossy().to_string();
    let o = lumifit(&[
        "phos",
        "simulate",
        "--material",
        "green_paint",
        "--history",
        &hs,
        "--out",
        &hs,
    ]);
    assert_rejected(&o, &["--out", "h.csv"]);
    assert_eq!(std::fs::read(&h).unwrap(), before);
    let dh = write(d.path(), "dh.csv", "time_s,e_r,e_g,e_b\n0,1,1,1\n8,0,0,0\n");
    let t = write(
        d.path(),
        "t.csv",
        "time_s,l_r,l_g,l_b\n4,0.3,0.4,0.2\n9,0.05,0.1,0.03\n",
    );
    let tb = std::fs::read(&t).unwrap();
    let ts = t.to_string_lossy().to_string();
    let o = lumifit(&[
        "phos",
        "design",
        "--history",
        &dh.to_string_lossy(),
        "--targets",
        &ts,
        "--out",
        &ts,
    ]);
    assert_rejected(&o, &["--out", "t.csv"]);
    assert_eq!(std::fs::read(&t).unwrap(), tb);
}

#[test]
fn a_plot_that_fails_late_leaves_the_existing_preset_byte_identical() {
    let d = tempfile::tempdir().unwrap();
    let c = p(d.path(), "c.csv");
    write(d.path(), "c.csv", curve_csv());
    let keep = write(d.path(), "keep.json", "{\"old\": true}\n");
    // a plot below a regular file: its directory cannot be created, which is found only when
    // the outputs are committed, after the fit
    write(d.path(), "afile", "x");
    let o = lumifit(&[
        "phos",
        "fit-decay",
        &c,
        "--out",
        &keep.to_string_lossy(),
        "--plot",
        &p(d.path(), "afile/sub/p.png"),
    ]);
    assert_rejected(&o, &["afile"]);
    assert_eq!(std::fs::read(&keep).unwrap(), b"{\"old\": true}\n");
    assert_eq!(listing(d.path()), ["afile", "c.csv", "keep.json"]);
    // a plot path that is a directory is refused before any work
    std::fs::create_dir(d.path().join("pdir")).unwrap();
    let o = lumifit(&[
        "phos",
        "fit-decay",
        &c,
        "--out",
        &keep.to_string_lossy(),
        "--plot",
        &p(d.path(), "pdir"),
    ]);
    assert_rejected(&o, &["--plot", "directory"]);
    assert_eq!(std::fs::read(&keep).unwrap(), b"{\"old\": true}\n");
}

#[test]
fn synth_phos_excitation_with_images_naming_an_existing_file_writes_nothing() {
    let d = tempfile::tempdir().unwrap();
    let img = write(d.path(), "img", "not a folder");
    let o = lumifit(&[
        "synth",
        "phos-excitation",
        "--material",
        "white_paint",
        "--seed",
        "1",
        "--out",
        &p(d.path(), "ch.csv"),
        "--images",
        &img.to_string_lossy(),
    ]);
    assert_rejected(&o, &["--images", "img"]);
    assert_eq!(listing(d.path()), ["img"]);
    assert_eq!(std::fs::read(&img).unwrap(), b"not a folder");
}

#[test]
fn files_with_a_byte_order_mark_are_read_as_curves_histories_targets_and_charging_data() {
    let d = tempfile::tempdir().unwrap();
    // decay curve
    let c = write(d.path(), "c.csv", format!("{BOM}{}", curve_csv()));
    ok(&lumifit(&[
        "phos",
        "fit-decay",
        &c.to_string_lossy(),
        "--out",
        &p(d.path(), "m.json"),
    ]));
    // batch
    let mut batch = format!("{BOM}id,time_s,r,g,b\n");
    for l in curve_csv().lines().skip(1) {
        let f: Vec<&str> = l.split(',').collect();
        batch.push_str(&format!("a,{},{},{},{}\n", f[0], f[1], f[2], f[3]));
    }
    let b = write(d.path(), "b.csv", batch);
    ok(&lumifit(&[
        "phos",
        "fit-decay",
        "--batch",
        &b.to_string_lossy(),
        "--out",
        &p(d.path(), "fits.csv"),
    ]));
    // simulate history
    let h = write(
        d.path(),
        "h.csv",
        format!("{BOM}duration_s,a,b,c,d,e,f,g,h\r\n10,1,1,1,1,1,1,1,1\r\n10,0,0,0,0,0,0,0,0\r\n"),
    );
    ok(&lumifit(&[
        "phos",
        "simulate",
        "--material",
        "green_paint",
        "--history",
        &h.to_string_lossy(),
        "--out",
        &p(d.path(), "sim.csv"),
    ]));
    // design history and targets
    let mut dh = format!("{BOM}time_s,e_r,e_g,e_b\n");
    for f in 0..200 {
        let t = f as f64 * 0.1;
        let e = if t < 8.0 { 1.0 } else { 0.0 };
        dh.push_str(&format!("{t},{e},{},{}\n", 0.5 * e, 0.2 * e));
    }
    let dh = write(d.path(), "dh.csv", dh);
    let t = write(
        d.path(),
        "t.csv",
        format!("{BOM}time_s,l_r,l_g,l_b\n4,0.3,0.4,0.2\n9,0.05,0.1,0.03\n12,0.02,0.04,0.012\n"),
    );
    ok(&lumifit(&[
        "phos",
        "design",
        "--history",
        &dh.to_string_lossy(),
        "--targets",
        &t.to_string_lossy(),
        "--grid-only",
        "--out",
        &p(d.path(), "designed.json"),
    ]));
    // charging data, source spectra and camera, all three with a BOM
    ok(&lumifit(&[
        "synth",
        "phos-excitation",
        "--material",
        "white_paint",
        "--seed",
        "3",
        "--out",
        &p(d.path(), "ch.csv"),
    ]));
    for name in ["ch.csv", "ch.source.csv", "ch.camera.csv"] {
        let f = d.path().join(name);
        let text = std::fs::read_to_string(&f).unwrap();
        std::fs::write(&f, format!("{BOM}{text}")).unwrap();
    }
    ok(&lumifit(&[
        "phos",
        "fit-excitation",
        "--material",
        "white_paint",
        "--data",
        &p(d.path(), "ch.csv"),
        "--source",
        &p(d.path(), "ch.source.csv"),
        "--camera",
        &p(d.path(), "ch.camera.csv"),
        "--out",
        &p(d.path(), "ex.json"),
    ]));
}

#[test]
fn duplicated_column_names_are_refused_in_every_phos_input() {
    let d = tempfile::tempdir().unwrap();
    let out = p(d.path(), "o.json");
    let c = write(
        d.path(),
        "c.csv",
        "time_s,r,r,b\n0,3,2,1\n1,2,1,1\n2,1,1,1\n",
    );
    let o = lumifit(&["phos", "fit-decay", &c.to_string_lossy(), "--out", &out]);
    assert_rejected(&o, &["c.csv", "line 1", "'r'"]);
    let b = write(d.path(), "b.csv", "id,time_s,r,r,b\nx,0,1,1,1\n");
    let o = lumifit(&[
        "phos",
        "fit-decay",
        "--batch",
        &b.to_string_lossy(),
        "--out",
        &out,
    ]);
    assert_rejected(&o, &["b.csv", "line 1", "'r'"]);
    let h = write(d.path(), "h.csv", "duration_s,r,r,b\n10,1,1,1\n");
    let o = lumifit(&[
        "phos",
        "simulate",
        "--material",
        "green_paint",
        "--history",
        &h.to_string_lossy(),
        "--out",
        &p(d.path(), "s.csv"),
    ]);
    assert_rejected(&o, &["h.csv", "line 1", "'r'"]);
    let dh = write(d.path(), "dh.csv", "time_s,e_r,e_g,e_b\n0,1,1,1\n8,0,0,0\n");
    let t = write(d.path(), "t.csv", "time_s,l_r,l_r,l_b\n4,1,1,1\n");
    let o = lumifit(&[
        "phos",
        "design",
        "--history",
        &dh.to_string_lossy(),
        "--targets",
        &t.to_string_lossy(),
        "--out",
        &out,
    ]);
    assert_rejected(&o, &["t.csv", "line 1", "'l_r'"]);
    assert!(!d.path().join("o.json").exists() && !d.path().join("s.csv").exists());
}

#[test]
fn keyframes_whose_times_decrease_are_refused_naming_file_and_line() {
    let d = tempfile::tempdir().unwrap();
    let dh = write(d.path(), "dh.csv", "time_s,e_r,e_g,e_b\n0,1,1,1\n8,0,0,0\n");
    let t = write(
        d.path(),
        "t.csv",
        "time_s,l_r,l_g,l_b\n4,0.3,0.4,0.2\n# a comment line\n12,0.02,0.04,0.012\n9,0.05,0.1,0.03\n",
    );
    let o = lumifit(&[
        "phos",
        "design",
        "--history",
        &dh.to_string_lossy(),
        "--targets",
        &t.to_string_lossy(),
        "--out",
        &p(d.path(), "o.json"),
    ]);
    assert_rejected(&o, &["t.csv", "line 5", "decreasing"]);
    assert!(!d.path().join("o.json").exists());
}

#[test]
fn a_batch_in_which_every_curve_fails_exits_2_and_writes_nothing() {
    let d = tempfile::tempdir().unwrap();
    // two curves of two samples each: a decay fit needs at least three
    let b = write(
        d.path(),
        "b.csv",
        "id,time_s,r,g,b\nx,0,1,1,1\nx,1,0.5,0.5,0.5\ny,0,2,2,2\ny,1,1,1,1\n",
    );
    let fits = d.path().join("fits.csv");
    let o = lumifit(&[
        "phos",
        "fit-decay",
        "--batch",
        &b.to_string_lossy(),
        "--out",
        &fits.to_string_lossy(),
    ]);
    assert_rejected(&o, &["b.csv", "none of the 2 curves", "'x'"]);
    assert!(!fits.exists());
    // one good curve beside a bad one is a success with an error row
    let mut text = String::from("id,time_s,r,g,b\nx,0,1,1,1\nx,1,0.5,0.5,0.5\n");
    for l in curve_csv().lines().skip(1) {
        let f: Vec<&str> = l.split(',').collect();
        text.push_str(&format!("good,{},{},{},{}\n", f[0], f[1], f[2], f[3]));
    }
    let b = write(d.path(), "b2.csv", text);
    ok(&lumifit(&[
        "phos",
        "fit-decay",
        "--batch",
        &b.to_string_lossy(),
        "--out",
        &fits.to_string_lossy(),
    ]));
    let out = std::fs::read_to_string(&fits).unwrap();
    let rows: Vec<&str> = out.lines().collect();
    assert_eq!(rows.len(), 3, "{out}");
    assert!(
        rows[1].starts_with("x,") && rows[1].contains("\"error: "),
        "{out}"
    );
    assert!(rows[2].starts_with("good,2,"), "{out}");
}

#[test]
fn sizes_too_large_for_memory_are_refused_with_the_flag_and_the_numbers() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("series");
    let o = lumifit(&[
        "synth",
        "phos-decay",
        "--material",
        "green_paint",
        "--seed",
        "1",
        "--size",
        "200000x200000",
        "--out",
        &out.to_string_lossy(),
    ]);
    assert_rejected(&o, &["--size", "200000x200000", "MiB"]);
    let o = lumifit(&[
        "synth",
        "phos-decay",
        "--material",
        "green_paint",
        "--seed",
        "1",
        "--curve-only",
        "--frames",
        "100000000000000",
        "--out",
        &out.to_string_lossy(),
    ]);
    assert_rejected(&o, &["--frames", "MiB"]);
    assert!(!out.exists());
    let h = write(
        d.path(),
        "h.csv",
        "duration_s,a,b,c,d,e,f,g,h\n1e9,1,1,1,1,1,1,1,1\n",
    );
    let o = lumifit(&[
        "phos",
        "simulate",
        "--material",
        "green_paint",
        "--history",
        &h.to_string_lossy(),
        "--dt",
        "1e-6",
        "--out",
        &p(d.path(), "s.csv"),
    ]);
    assert_rejected(&o, &["--dt", "MiB"]);
    assert_eq!(listing(d.path()), ["h.csv"]);
}

#[test]
fn a_simulation_that_overflows_is_an_error_naming_the_history_not_a_csv_of_nan() {
    let d = tempfile::tempdir().unwrap();
    // Euler at h = 10 s under |E| = 100 per band leaves its stable region: |1 − h·Σk| ≈ 50 per
    // step over 300 steps overflows f64
    let h = write(
        d.path(),
        "bright.csv",
        "duration_s,a,b,c,d,e,f,g,h\n3000,100,100,100,100,100,100,100,100\n60,0,0,0,0,0,0,0,0\n",
    );
    let keep = write(d.path(), "sim.csv", "old\n");
    let o = lumifit(&[
        "phos",
        "simulate",
        "--material",
        "green_paint",
        "--history",
        &h.to_string_lossy(),
        "--integrator",
        "euler",
        "--dt",
        "10",
        "--out",
        &keep.to_string_lossy(),
    ]);
    assert_rejected(&o, &["not finite", "bright.csv", "Euler"]);
    assert_eq!(std::fs::read(&keep).unwrap(), b"old\n");
    // the exact update of the same history is finite and written
    ok(&lumifit(&[
        "phos",
        "simulate",
        "--material",
        "green_paint",
        "--history",
        &h.to_string_lossy(),
        "--dt",
        "10",
        "--out",
        &keep.to_string_lossy(),
    ]));
    assert!(std::fs::read_to_string(&keep)
        .unwrap()
        .starts_with("time_s,"));
}

#[test]
fn a_series_fit_refuses_to_write_over_one_of_its_frames() {
    let d = tempfile::tempdir().unwrap();
    let s = d.path().join("s");
    ok(&lumifit(&[
        "synth",
        "phos-decay",
        "--material",
        "green_paint",
        "--seed",
        "2",
        "--size",
        "8x8",
        "--frames",
        "6",
        "--out",
        &s.to_string_lossy(),
    ]));
    let frame = s.join("frame_0000.tif");
    let before = std::fs::read(&frame).unwrap();
    let manifest = s.join("manifest.csv").to_string_lossy().to_string();
    let o = lumifit(&[
        "phos",
        "fit-decay",
        &manifest,
        "--roi",
        "0,0,4,4",
        "--out",
        &frame.to_string_lossy(),
    ]);
    assert_rejected(&o, &["--out", "frame_0000.tif"]);
    let o = lumifit(&[
        "phos",
        "fit-decay",
        &s.to_string_lossy(),
        "--per-pixel",
        "--out",
        &s.to_string_lossy(),
    ]);
    assert_rejected(&o, &["--out"]);
    assert_eq!(std::fs::read(&frame).unwrap(), before);
}
