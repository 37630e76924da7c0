//! A documented chain (docs/cli.md): lamp photo → `lvf calibrate` → a capture of a light →
//! `spectrum recover` → `color xyz` on the recovered CSV, whose `std` column the spectrum reader
//! ignores (issue 13: every output a valid input of the natural next step).

mod common;
use common::{lumifit, p, stderr, write};

fn ok(o: &std::process::Output) {
    assert!(o.status.success(), "{}", stderr(o));
}

#[test]
fn a_recovered_spectrum_feeds_color_xyz() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    ok(&lumifit(&[
        "synth",
        "lvf-hg",
        "--out",
        &p(d, "hg.tiff"),
        "--truth",
        &p(d, "truth.json"),
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
    write(
        d,
        "light.csv",
        "wavelength_nm,value\n380,0.2\n500,0.9\n600,0.5\n780,0.3\n",
    );
    ok(&lumifit(&[
        "synth",
        "lvf-capture",
        "--spectrum",
        &p(d, "light.csv"),
        "--lvf",
        &p(d, "lvf.json"),
        "--size",
        "1200x160",
        "--seed",
        "2",
        "--out",
        &p(d, "cap.tiff"),
    ]));
    ok(&lumifit(&[
        "spectrum",
        "recover",
        &p(d, "cap.tiff"),
        "--bands",
        &p(d, "lvf.json"),
        "--out",
        &p(d, "rec.csv"),
    ]));
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
