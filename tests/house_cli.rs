//! The house rules of the output path and of bad input, tried as a careless user would on the
//! acquisition, colour, fluorescence, series and preset commands: one test per class.
//!
//! - an output equal to an input is refused (exit 2) and the input stays byte-identical;
//! - a command that fails late (an output whose directory cannot be created) leaves its main
//!   output untouched and no temporary file behind;
//! - a UTF-8 byte-order mark (what Excel writes) is accepted in manifests, `--captures`,
//!   Donaldson CSVs and preset JSON;
//! - overflow is exit 2 naming the input, never `null` with exit 0;
//! - absurd sizes are refused with the number and the limit before anything is allocated;
//! - a directory named as a frame is reported as a directory;
//! - a truncated real DNG gives one clean message, no decoder panic text.

mod common;

use std::path::{Path, PathBuf};

use common::{assert_rejected, lumifit, p, stderr, write};

const BOM: &str = "\u{feff}";

/// A synthetic mercury-lamp photo through an LVF (600×80 px) and its calibration, in `dir`.
fn lamp_photo_and_calibration(dir: &Path) -> (String, String) {
    let (img, truth, lvf) = (p(dir, "hg.tif"), p(dir, "truth.json"), p(dir, "lvf.json"));
    let o = lumifit(&[
        "synth", "lvf-hg", "--out", &img, "--truth", &truth, "--size", "600x80",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = lumifit(&[
        "lvf",
        "calibrate",
        &img,
        "--roi",
        "0,20,600,40",
        "--axis",
        "x",
        "--out",
        &lvf,
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    (img, lvf)
}

/// Two 16-bit TIFF frames and a manifest `m.csv` listing them (with exposure columns).
fn two_frame_series(dir: &Path, manifest_prefix: &str) -> PathBuf {
    for name in ["f0.tif", "f1.tif"] {
        let o = lumifit(&[
            "synth",
            "lvf-hg",
            "--out",
            &p(dir, name),
            "--truth",
            &p(dir, &format!("{name}.json")),
            "--size",
            "64x16",
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
    }
    write(
        dir,
        "m.csv",
        format!(
            "{manifest_prefix}file,time_s,exposure_s,iso,f_number\r\nf0.tif,0,1,100,2.8\r\nf1.tif,1,1,100,2.8\r\n"
        ),
    )
}

fn fluor_fixture() -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("fixtures/fluor/synthetic.bfc")
        .to_string_lossy()
        .to_string()
}

/// A Donaldson CSV on 300–780 nm at 10 nm: `diagonal` on the diagonal, `stokes` below it.
fn donaldson_csv(diagonal: &str, stokes: &str) -> String {
    let w: Vec<u32> = (300..=780).step_by(10).collect();
    let mut s = String::from("emission_nm");
    for x in &w {
        s.push_str(&format!(",{x}"));
    }
    s.push('\n');
    for e in &w {
        s.push_str(&e.to_string());
        for x in &w {
            let v = if e == x {
                diagonal
            } else if e > x {
                stokes
            } else {
                "0"
            };
            s.push(',');
            s.push_str(v);
        }
        s.push('\n');
    }
    s
}

/// Exit 2 naming "is the input", and `input` byte-identical to `before`.
fn assert_input_kept(o: &std::process::Output, input: &Path, before: &[u8]) {
    assert_rejected(o, &["is the input"]);
    assert_eq!(
        std::fs::read(input).unwrap(),
        before,
        "{} was modified",
        input.display()
    );
}

#[test]
fn an_output_equal_to_an_input_is_refused_and_the_input_is_kept_byte_identical() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();

    // fluor reduce x.BFC --out x.BFC
    let bfc = write(d, "x.BFC", std::fs::read(fluor_fixture()).unwrap());
    let before = std::fs::read(&bfc).unwrap();
    let o = lumifit(&["fluor", "reduce", &p(d, "x.BFC"), "--out", &p(d, "x.BFC")]);
    assert_input_kept(&o, &bfc, &before);

    // series extract m.csv --roi 0,0,8,8 --out f0.png: a frame of the manifest is an input too
    let manifest = two_frame_series(d, "");
    let frame = d.join("f0.tif");
    let before = std::fs::read(&frame).unwrap();
    let o = lumifit(&[
        "series",
        "extract",
        &manifest.to_string_lossy(),
        "--roi",
        "0,0,8,8",
        "--out",
        &p(d, "f0.tif"),
    ]);
    assert_input_kept(&o, &frame, &before);

    // color table --sds s.csv --out s.csv
    let sds = write(d, "s.csv", "wavelength_nm,a,b\n380,0.5,0.2\n780,0.5,0.9\n");
    let before = std::fs::read(&sds).unwrap();
    let o = lumifit(&[
        "color",
        "table",
        "--sds",
        &p(d, "s.csv"),
        "--out",
        &p(d, "s.csv"),
    ]);
    assert_input_kept(&o, &sds, &before);

    // lvf calibrate hg.tif --out hg.tif, and spectrum recover with --plot on the band file
    let (img, lvf) = lamp_photo_and_calibration(d);
    let before = std::fs::read(&img).unwrap();
    let o = lumifit(&[
        "lvf",
        "calibrate",
        &img,
        "--roi",
        "0,20,600,40",
        "--axis",
        "x",
        "--out",
        &img,
    ]);
    assert_input_kept(&o, Path::new(&img), &before);
    let before = std::fs::read(&lvf).unwrap();
    let o = lumifit(&[
        "spectrum",
        "recover",
        &img,
        "--bands",
        &lvf,
        "--out",
        &p(d, "rec.csv"),
        "--plot",
        &lvf,
    ]);
    assert_input_kept(&o, Path::new(&lvf), &before);
    assert!(!d.join("rec.csv").exists(), "the main output was written");
}

#[test]
fn a_late_failure_leaves_the_main_output_untouched_and_no_temporary_file() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // A plot or summary path under a regular file: its directory cannot be created, which is
    // only found out when the outputs are committed, after all the work.
    write(d, "afile", "not a directory");
    let keep = write(d, "keep.json", "old contents");
    let o = lumifit(&[
        "fluor",
        "reduce",
        &fluor_fixture(),
        "--out",
        &p(d, "keep.json"),
        "--plot",
        &p(d, "afile/p.png"),
    ]);
    assert_rejected(&o, &["afile"]);
    assert_eq!(std::fs::read(&keep).unwrap(), b"old contents");

    let (img, _) = lamp_photo_and_calibration(d);
    let o = lumifit(&[
        "lvf",
        "calibrate",
        &img,
        "--roi",
        "0,20,600,40",
        "--axis",
        "x",
        "--out",
        &p(d, "keep.json"),
        "--plot",
        &p(d, "afile/lvf.png"),
    ]);
    assert_rejected(&o, &["afile"]);
    assert_eq!(std::fs::read(&keep).unwrap(), b"old contents");

    let kept_csv = write(d, "keep.csv", "old recovery");
    let o = lumifit(&[
        "spectrum",
        "recover",
        &img,
        "--bands",
        &p(d, "lvf.json"),
        "--out",
        &p(d, "keep.csv"),
        "--summary",
        &p(d, "afile/summary.json"),
    ]);
    assert_rejected(&o, &["afile"]);
    assert_eq!(std::fs::read(&kept_csv).unwrap(), b"old recovery");

    let leftovers: Vec<String> = std::fs::read_dir(d)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().to_string())
        .filter(|n| n.ends_with(".tmp"))
        .collect();
    assert!(leftovers.is_empty(), "temporary files left: {leftovers:?}");
}

#[test]
fn a_byte_order_mark_is_accepted_in_manifests_captures_donaldson_csvs_and_presets() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();

    let manifest = two_frame_series(d, BOM);
    let o = lumifit(&[
        "series",
        "extract",
        &manifest.to_string_lossy(),
        "--roi",
        "0,0,8,8",
        "--out",
        &p(d, "curve.csv"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let curve = std::fs::read_to_string(d.join("curve.csv")).unwrap();
    assert_eq!(curve.lines().count(), 3, "{curve}");

    let (_, lvf) = lamp_photo_and_calibration(d);
    write(d, "grey.csv", "wavelength_nm,value\n380,0.5\n780,0.5\n");
    let o = lumifit(&[
        "synth",
        "lvf-capture",
        "--reflectance",
        &p(d, "grey.csv"),
        "--illuminant",
        "D65",
        "--lvf",
        &p(d, "truth.json"),
        "--seed",
        "3",
        "--out",
        &p(d, "c0.tiff"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    write(
        d,
        "caps.csv",
        format!("{BOM}image,filter\r\nc0.tiff,none\r\n"),
    );
    let o = lumifit(&[
        "lvf",
        "transmission",
        "--lvf",
        &lvf,
        "--captures",
        &p(d, "caps.csv"),
        "--source",
        "D65",
        "--target",
        &p(d, "grey.csv"),
        "--model",
        "gaussian",
        "--out",
        &p(d, "bands.json"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let bands: serde_json::Value =
        serde_json::from_slice(&std::fs::read(d.join("bands.json")).unwrap()).unwrap();
    assert_eq!(bands["schema"], "lumifit.lvf-bands/1");
    // A photo listed in the captures is an input too.
    let photo = d.join("c0.tiff");
    let before = std::fs::read(&photo).unwrap();
    let o = lumifit(&[
        "lvf",
        "transmission",
        "--lvf",
        &lvf,
        "--captures",
        &p(d, "caps.csv"),
        "--source",
        "D65",
        "--target",
        &p(d, "grey.csv"),
        "--model",
        "gaussian",
        "--out",
        &p(d, "c0.tiff"),
    ]);
    assert_input_kept(&o, &photo, &before);

    write(
        d,
        "bom.csv",
        format!("{BOM}{}", donaldson_csv("0.8", "0.001")),
    );
    let o = lumifit(&[
        "fluor",
        "reduce",
        &p(d, "bom.csv"),
        "--out",
        &p(d, "bom.json"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));

    let preset = std::fs::read_to_string(d.join("bom.json")).unwrap();
    write(d, "bom_preset.json", format!("{BOM}{preset}"));
    let o = lumifit(&["preset", "validate", &p(d, "bom_preset.json")]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["valid"], true);
}

#[test]
fn overflow_is_exit_2_naming_the_input_never_a_null() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write(
        d,
        "huge.csv",
        "wavelength_nm,value\n380,1e308\n390,1e308\n400,1e308\n410,1e308\n",
    );
    let o = lumifit(&[
        "color",
        "xyz",
        "--sd",
        &p(d, "huge.csv"),
        "--method",
        "integration",
    ]);
    assert_rejected(&o, &["huge.csv", "not finite"]);
    assert!(
        o.stdout.is_empty(),
        "printed: {}",
        String::from_utf8_lossy(&o.stdout)
    );
    // On a 5 nm grid the overflow happens while interpolating to the CMF grid: still named as an
    // overflow of that spectrum, not as a NaN the input never had.
    let grid: String = (400..=700)
        .step_by(5)
        .map(|w| format!("{w},1e308\n"))
        .collect();
    write(d, "huge5.csv", format!("wavelength_nm,value\n{grid}"));
    let o = lumifit(&[
        "color",
        "xyz",
        "--sd",
        &p(d, "huge5.csv"),
        "--method",
        "integration",
    ]);
    assert_rejected(&o, &["huge5.csv", "not finite", "overflow"]);

    let o = lumifit(&[
        "color",
        "delta-e",
        "--lab1",
        "1e308,2,3",
        "--lab2",
        "-1e308,0,0",
    ]);
    assert_rejected(&o, &["delta_e", "1e308", "not finite"]);
    assert!(o.stdout.is_empty());

    write(d, "huge_d.csv", donaldson_csv("1e308", "1e307"));
    let o = lumifit(&[
        "fluor",
        "reduce",
        &p(d, "huge_d.csv"),
        "--out",
        &p(d, "p.json"),
    ]);
    assert_rejected(&o, &["huge_d.csv", "not finite"]);
    assert!(!d.join("p.json").exists(), "a preset was written");
    let o = lumifit(&["fluor", "eval", &p(d, "huge_d.csv"), "--json"]);
    assert_rejected(&o, &["huge_d.csv", "not finite"]);
    assert!(o.stdout.is_empty());

    // A preset whose numbers were written as null is not valid.
    let o = lumifit(&[
        "fluor",
        "reduce",
        &fluor_fixture(),
        "--out",
        &p(d, "ok.json"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(d.join("ok.json")).unwrap();
    let mut v: serde_json::Value = serde_json::from_str(&text).unwrap();
    v["fluorescence"]["matrix"][0][0] = serde_json::Value::Null;
    v["fluorescence"]["worst_delta_e00"] = serde_json::Value::Null;
    write(d, "nulls.json", v.to_string());
    let o = lumifit(&["preset", "validate", &p(d, "nulls.json")]);
    assert_rejected(
        &o,
        &[
            "nulls.json",
            "/fluorescence/matrix/0/0",
            "/fluorescence/worst_delta_e00",
            "null",
        ],
    );
}

#[test]
fn absurd_sizes_are_refused_with_the_number_and_the_limit() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let o = lumifit(&[
        "synth",
        "lvf-hg",
        "--out",
        &p(d, "a.tif"),
        "--truth",
        &p(d, "a.json"),
        "--size",
        "20000x20000",
    ]);
    assert_rejected(&o, &["--size", "20000x20000", "limit"]);
    assert!(!d.join("a.tif").exists());

    let (img, lvf) = lamp_photo_and_calibration(d);
    let o = lumifit(&[
        "lvf",
        "calibrate",
        &img,
        "--roi",
        "0,20,600,40",
        "--axis",
        "x",
        "--bands",
        "100000000",
        "--out",
        &p(d, "o.json"),
    ]);
    assert_rejected(&o, &["--bands", "100000000", "300"]);

    let started = std::time::Instant::now();
    let o = lumifit(&[
        "lvf",
        "transmission",
        "--lvf",
        &lvf,
        "--model",
        "calibration",
        "--grid",
        "400:700:0.1",
        "--out",
        &p(d, "b.json"),
    ]);
    assert_rejected(&o, &["--grid", "3001", "301"]);
    assert!(
        started.elapsed().as_secs() < 30,
        "the refusal took {:?}",
        started.elapsed()
    );

    let o = lumifit(&[
        "spectrum",
        "recover",
        &img,
        "--bands",
        &lvf,
        "--grid",
        "400:700:0.001",
        "--out",
        &p(d, "r.csv"),
    ]);
    assert_rejected(&o, &["--grid", "2000"]);
}

#[test]
fn a_directory_named_as_a_frame_is_reported_as_a_directory() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::create_dir(d.join("sub")).unwrap();
    write(
        d,
        "m.csv",
        "file,time_s,exposure_s,iso,f_number\nsub,0,1,100,2.8\n",
    );
    let o = lumifit(&["series", "inspect", &p(d, "m.csv")]);
    assert_rejected(&o, &["m.csv", "line 2", "sub", "is a directory"]);

    let (_, lvf) = lamp_photo_and_calibration(d);
    write(d, "caps.csv", "image,filter\nsub,none\n");
    write(d, "grey.csv", "wavelength_nm,value\n380,0.5\n780,0.5\n");
    let o = lumifit(&[
        "lvf",
        "transmission",
        "--lvf",
        &lvf,
        "--captures",
        &p(d, "caps.csv"),
        "--source",
        "D65",
        "--target",
        &p(d, "grey.csv"),
        "--out",
        &p(d, "b.json"),
    ]);
    assert_rejected(&o, &["caps.csv", "line 2", "is a directory"]);
}

#[test]
fn a_truncated_real_dng_is_one_clean_error_without_panic_text() {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data/raw");
    let src = data.join("tinydng_colorchart_rawler_uncompressed16.dng");
    if !src.is_file() {
        assert!(
            std::env::var("LUMIFIT_REQUIRE_DATA").as_deref() != Ok("1"),
            "LUMIFIT_REQUIRE_DATA=1 but {} is absent",
            src.display()
        );
        eprintln!("skipped: {} is absent", src.display());
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let bytes = std::fs::read(&src).unwrap();
    for keep in [1_000usize, bytes.len() / 2] {
        let cut = write(dir.path(), "cut.dng", &bytes[..keep]);
        let o = lumifit(&[
            "lvf",
            "calibrate",
            &cut.to_string_lossy(),
            "--roi",
            "0,0,10,10",
            "--axis",
            "x",
            "--out",
            &p(dir.path(), "o.json"),
        ]);
        assert_rejected(&o, &["cut.dng", "cannot decode"]);
        let e = stderr(&o);
        assert!(!e.contains("panic"), "panic text on stderr: {e}");
        assert_eq!(
            e.lines().filter(|l| l.starts_with("error:")).count(),
            1,
            "{e}"
        );
        assert!(!dir.path().join("o.json").exists());
    }
}
