//! A filter set up a little rotated in the image: its iso-wavelength lines slant across the
//! axis. On independently rendered lamp images (`scripts/reference/lvf_robustness.py`) a 3° slant
//! moved λ at 400 / 700 nm by +0.41 / −0.38 nm with σ 0.01 nm, noise-free: the strips across
//! the axis, shifted against each other, read as a radial fall-off. `lvf calibrate` now measures
//! the slant from the strips (`--tilt auto`), averages along it, records it in lvf.json, and the
//! readings of captures through lvf.json follow it.

use lumifit::lvf::synth::{default_camera, ContinuumShape, VignettingShape};
use lumifit::lvf::{
    calibrate_whole_profile, extract_profile, extract_profile_straightened, render_lvf, Axis,
    FitOptions, Lamp, LvfGeometry, LvfSynthSpec,
};

mod common;
use common::{assert_rejected, lumifit, lvf_map_errors, read_json, stderr};

/// The issue-12 geometry, the default camera, quadratic vignetting 0.2, a flat continuum 4 %,
/// slanted by `tilt_deg`.
fn spec(tilt_deg: f64, noise: f64, height: usize, seed: u64) -> LvfSynthSpec {
    LvfSynthSpec {
        tilt_deg,
        height,
        ..common::lvf_geometry::spec(
            Lamp::mercury(),
            default_camera().unwrap(),
            noise,
            (VignettingShape::Quadratic, 0.2),
            Some((ContinuumShape::Flat, 0.04)),
            seed,
        )
    }
}

/// λ errors at the true 400 / 700 nm positions of the calibration of `p`.
fn error(s: &LvfSynthSpec, p: &lumifit::lvf::Profile, truth: &lumifit::lvf::LvfTruth) -> [f64; 2] {
    let cal = calibrate_whole_profile(p, &s.lamp, &FitOptions::default()).unwrap();
    assert_eq!(
        cal.tilt, p.tilt,
        "lvf.json records the slant averaged along"
    );
    [
        cal.map.eval(truth.px_at_400) - 400.0,
        cal.map.eval(truth.px_at_700) - 700.0,
    ]
}

#[test]
fn a_slanted_filter_is_measured_and_averaged_along_its_iso_wavelength_lines() {
    for (tilt, noise, height, seed) in
        [(3.0, 0.0, 160, 1), (-2.0, 0.01, 160, 3), (3.0, 0.01, 40, 4)]
    {
        let s = spec(tilt, noise, height, seed);
        let (frame, truth) = render_lvf(&s).unwrap();
        let roi = [0, 0, s.width, s.height];
        let straight = error(&s, &extract_profile(&frame, roi, Axis::X).unwrap(), &truth);
        let (p, est) = extract_profile_straightened(&frame, roi, Axis::X).unwrap();
        let deg = p.tilt.map(|t| t.degrees());
        assert_eq!(
            deg.is_some(),
            est.as_ref().is_some_and(|e| e.significant),
            "followed exactly when significant"
        );
        let followed = error(&s, &p, &truth);
        // the same image square to the sensor, averaged along the rows (the draws differ: the
        // same noise on other values; 0.08 nm is about σ at 700 nm at 1 % noise)
        let sq = spec(0.0, noise, height, seed);
        let (frame0, truth0) = render_lvf(&sq).unwrap();
        let square = error(
            &sq,
            &extract_profile(&frame0, roi, Axis::X).unwrap(),
            &truth0,
        );
        eprintln!(
            "tilt {tilt}°, noise {noise}, {height} rows: along the rows {:+.3} / {:+.3} nm, along the slant {:+.3} / {:+.3} nm, measured {deg:?}°; square {:+.3} / {:+.3} nm",
            straight[0], straight[1], followed[0], followed[1], square[0], square[1]
        );
        let deg = deg.expect("a slant this large is followed");
        assert!((deg - tilt).abs() < 0.1, "measured {deg}° for {tilt}°");
        for k in 0..2 {
            assert!(
                (followed[k] - square[k]).abs() <= 0.08,
                "along the slant {followed:?}, square {square:?}"
            );
        }
        if noise == 0.0 {
            // noise-free, the rows' mean is what moved the map (the strips read as a fall-off)
            assert!(
                straight.iter().any(|e| e.abs() > 0.15),
                "the straight average should show the slant's error: {straight:?}"
            );
        }
    }
}

#[test]
fn a_square_filter_is_averaged_along_the_rows_as_before() {
    for seed in 1..=3 {
        let s = spec(0.0, 0.01, 160, seed);
        let (frame, _) = render_lvf(&s).unwrap();
        let roi = [0, 0, s.width, s.height];
        let (p, est) = extract_profile_straightened(&frame, roi, Axis::X).unwrap();
        let est = est.expect("the strips measure a slant");
        assert!(!est.significant, "seed {seed}: {est:?}");
        assert!(est.tilt.degrees().abs() < 0.2, "seed {seed}: {est:?}");
        assert_eq!(p, extract_profile(&frame, roi, Axis::X).unwrap());
    }
}

#[test]
fn captures_are_read_along_the_slant_lvf_json_records() {
    // noise-free frames, slanted and square: read through the slanted frame's own calibration,
    // the slanted frame's band readings are the square frame's read along its rows (the middle
    // row's); along the rows the slanted frame's readings are blurred by the slant
    let slanted = spec(3.0, 0.0, 160, 1);
    let square = spec(0.0, 0.0, 160, 1);
    let (frame, _) = render_lvf(&slanted).unwrap();
    let (frame0, _) = render_lvf(&square).unwrap();
    let roi = [0, 0, slanted.width, slanted.height];
    let (p, _) = extract_profile_straightened(&frame, roi, Axis::X).unwrap();
    let cal = calibrate_whole_profile(&p, &slanted.lamp, &FitOptions::default()).unwrap();
    let g = LvfGeometry::from_calibration(&cal, "slanted");
    assert!(g.tilt.is_some());
    let square_rows = LvfGeometry {
        tilt: None,
        ..g.clone()
    };
    let along = g.band_readings(&frame).unwrap();
    let reference = square_rows.band_readings(&frame0).unwrap();
    let rows = square_rows.band_readings(&frame).unwrap();
    let worst = |r: &lumifit::lvf::BandReadings| {
        r.rgb
            .iter()
            .zip(&reference.rgb)
            .flat_map(|(a, b)| (0..3).map(move |c| (a[c] - b[c]).abs() / b[c].abs().max(1e-3)))
            .fold(0.0, f64::max)
    };
    let (w_along, w_rows) = (worst(&along), worst(&rows));
    eprintln!("band readings against the square frame: along the slant {w_along:.2e}, along the rows {w_rows:.2e} (relative)");
    assert!(w_along < 0.02, "{w_along}");
    assert!(w_along < 0.5 * w_rows, "{w_along} vs {w_rows}");
}

/// `lvf calibrate IMAGE --axis x EXTRA… --out OUT`, which must succeed; lvf.json as written.
fn calibrate(image: &str, extra: &[&str], out: &str) -> serde_json::Value {
    let mut args = vec!["lvf", "calibrate", image, "--axis", "x"];
    args.extend_from_slice(extra);
    args.extend_from_slice(&["--out", out]);
    let o = lumifit(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    read_json(out)
}

#[test]
fn synth_renders_a_slant_that_calibrate_records_and_the_geometry_reads_back() {
    let dir = tempfile::tempdir().unwrap();
    let p = |n: &str| dir.path().join(n).to_str().unwrap().to_string();
    common::synth_hg(dir.path(), &["--tilt", "2.5", "--size", "1200x80"], 3);
    let truth = read_json(p("truth.json"));
    assert_eq!(truth["tilt_deg"], 2.5);
    let cal = calibrate(&p("hg.tiff"), &[], &p("lvf.json"));
    let deg = cal["diagnostics"]["tilt"]["degrees"].as_f64().unwrap();
    assert!((deg - 2.5).abs() < 0.1, "{deg}");
    assert_eq!(cal["diagnostics"]["tilt"]["followed"], true);
    let slope = cal["tilt"]["slope"].as_f64().unwrap();
    assert!((slope.atan().to_degrees() - 2.5).abs() < 0.1);
    let e = lvf_map_errors(&cal, &truth);
    assert!(e.iter().all(|e| e.abs() < 0.15), "{e:?}");
    let g = LvfGeometry::from_json(&std::fs::read(p("lvf.json")).unwrap(), "lvf.json").unwrap();
    assert_eq!(g.tilt.map(|t| t.slope), Some(slope));
    // --tilt off keeps the rows; a bad angle exits 2 naming the flag and writes nothing
    let off = calibrate(&p("hg.tiff"), &["--tilt", "off"], &p("off.json"));
    assert!(off.get("tilt").is_none());
    for bad in ["sideways", "60"] {
        let o = lumifit(&[
            "lvf",
            "calibrate",
            &p("hg.tiff"),
            "--axis",
            "x",
            "--tilt",
            bad,
            "--out",
            &p("bad.json"),
        ]);
        assert_rejected(&o, &["--tilt"]);
        assert!(!std::path::Path::new(&p("bad.json")).exists());
    }
    let o = lumifit(&[
        "synth",
        "lvf-hg",
        "--tilt",
        "50",
        "--out",
        &p("t.tiff"),
        "--truth",
        &p("t.json"),
    ]);
    assert_rejected(&o, &["--tilt"]);
}
