//! `lumifit synth lvf-capture` through the binary: the rendered band readings against the model
//! Σ_λ L(λ)·F(λ)·g(λ − λ(p))·Q_c(λ)·Δλ computed independently here, gels, auto exposure, the real
//! Lee gel table, and bad input rejected with exit code 2 and nothing written.

mod common;

use std::path::{Path, PathBuf};

use common::tolerances::lvf_capture_synth::*;
use common::{assert_rejected, lumifit, stderr, write};
use lumifit::io::filters::read_gel_table;
use lumifit::lvf::LvfGeometry;

fn tol(expected: f64) -> f64 {
    REL_TOL * expected.abs() + HALF_LSB
}

/// The default camera, read from its CSV here (not through the library), interpolated linearly
/// and zero outside its range.
struct Camera {
    nm: Vec<f64>,
    q: [Vec<f64>; 3],
}

impl Camera {
    fn load() -> Camera {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("calib/camera_default.csv");
        let text = std::fs::read_to_string(path).unwrap();
        let mut nm = Vec::new();
        let mut q = [Vec::new(), Vec::new(), Vec::new()];
        for line in text.lines().filter(|l| !l.starts_with('#')).skip(1) {
            let v: Vec<f64> = line.split(',').map(|s| s.trim().parse().unwrap()).collect();
            nm.push(v[0]);
            for c in 0..3 {
                q[c].push(v[c + 1]);
            }
        }
        Camera { nm, q }
    }

    fn at(&self, c: usize, l: f64) -> f64 {
        let n = self.nm.len();
        if l < self.nm[0] || l > self.nm[n - 1] {
            return 0.0;
        }
        let i = self.nm.iter().position(|&w| w >= l).unwrap();
        if i == 0 || self.nm[i] == l {
            return self.q[c][i];
        }
        let f = (l - self.nm[i - 1]) / (self.nm[i] - self.nm[i - 1]);
        self.q[c][i - 1] + f * (self.q[c][i] - self.q[c][i - 1])
    }
}

/// Σ_λ w(λ)·g(λ − centre)·Q_c(λ)·1 nm over 360–830 nm, g a Gaussian of peak 1.
fn model_sum(cam: &Camera, w: &dyn Fn(f64) -> f64, centre: f64, fwhm: f64) -> [f64; 3] {
    let mut s = [0.0; 3];
    for k in 0..=470 {
        let l = 360.0 + k as f64;
        let g = (-4.0 * std::f64::consts::LN_2 * (l - centre).powi(2) / (fwhm * fwhm)).exp();
        for (c, sc) in s.iter_mut().enumerate() {
            *sc += w(l) * g * cam.at(c, l);
        }
    }
    s
}

fn map_at(map: &[f64], p: f64) -> f64 {
    map.iter().rev().fold(0.0, |a, c| a * p + c)
}

/// Positions a band averages over: pixel centres p inside the ROI with |p − px| ≤ width/2 (the
/// rule `LvfGeometry::band_readings` documents).
fn band_positions(geo: &LvfGeometry, j: usize) -> Vec<f64> {
    assert_eq!(
        geo.axis,
        lumifit::lvf::Axis::X,
        "these tests render along x"
    );
    let b = &geo.bands[j];
    let (lo, len) = (geo.roi[0], geo.roi[2]);
    (lo..lo + len)
        .map(|p| p as f64)
        .filter(|p| (p - b.px).abs() <= b.width_px / 2.0)
        .collect()
}

/// The expected band readings at exposure 1: the model averaged over each band's positions.
fn expected_bands(cam: &Camera, geo: &LvfGeometry, w: &dyn Fn(f64) -> f64) -> Vec<[f64; 3]> {
    (0..geo.bands.len())
        .map(|j| {
            let win = band_positions(geo, j);
            assert!(!win.is_empty());
            let mut m = [0.0; 3];
            for &p in &win {
                let s = model_sum(cam, w, map_at(&geo.map, p), geo.fwhm_nm);
                for c in 0..3 {
                    m[c] += s[c] / win.len() as f64;
                }
            }
            m
        })
        .collect()
}

/// A hand-written lvf.json for the map of `synth lvf-hg`'s defaults (λ = 380 + 0.3·px, 25 nm):
/// 31 bands 400–700 nm, 33 px (9.9 nm) wide, so no window edge falls exactly on a pixel centre.
fn hand_lvf_json(dir: &Path) -> PathBuf {
    let bands: Vec<serde_json::Value> = (0..31)
        .map(|k| {
            let nm = 400.0 + 10.0 * k as f64;
            serde_json::json!({"nm": nm, "px": (nm - 380.0) / 0.3, "width_px": 33.0, "in_roi": true})
        })
        .collect();
    let json = serde_json::json!({
        "schema": "lumifit.lvf/1", "axis": "x", "roi": [0, 20, 1200, 120],
        "map": {"kind": "linear", "coefficients": [380.0, 0.3]}, "fwhm_nm": 25.0, "bands": bands
    });
    write(dir, "lvf.json", json.to_string())
}

fn s(p: &Path) -> String {
    p.to_string_lossy().to_string()
}

/// Runs `synth lvf-capture` with `args` (plus --out/--truth into `dir/name.*`, seed 1); returns
/// the truth JSON.
fn capture(dir: &Path, name: &str, args: &[&str]) -> serde_json::Value {
    let out = s(&dir.join(format!("{name}.tiff")));
    let truth = s(&dir.join(format!("{name}.json")));
    let mut all = vec![
        "synth",
        "lvf-capture",
        "--seed",
        "1",
        "--out",
        &out,
        "--truth",
        &truth,
    ];
    all.extend_from_slice(args);
    let o = lumifit(&all);
    assert!(o.status.success(), "{}", stderr(&o));
    let printed: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let written: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&truth).unwrap()).unwrap();
    assert_eq!(printed, written, "printed and written truth agree");
    assert_eq!(written["schema"], "lumifit.lvf-capture-truth/1");
    written
}

fn readings(dir: &Path, name: &str, geo: &LvfGeometry) -> Vec<[f64; 3]> {
    let (frame, _) = lumifit::io::image::read_image(&dir.join(format!("{name}.tiff"))).unwrap();
    geo.band_readings(&frame).unwrap().rgb
}

fn geometry(path: &Path) -> LvfGeometry {
    LvfGeometry::from_json(&std::fs::read(path).unwrap(), &s(path)).unwrap()
}

fn hg_truth(dir: &Path) -> PathBuf {
    let truth = dir.join("hg_truth.json");
    let o = lumifit(&[
        "synth",
        "lvf-hg",
        "--out",
        &s(&dir.join("hg.tiff")),
        "--truth",
        &s(&truth),
        "--seed",
        "7",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    truth
}

fn assert_bands_match(got: &[[f64; 3]], want: &[[f64; 3]], what: &str) {
    assert_eq!(got.len(), want.len());
    let max_abs = got
        .iter()
        .zip(want)
        .flat_map(|(g, w)| (0..3).map(move |c| (g[c] - w[c]).abs()))
        .fold(0.0, f64::max);
    let max_rel_bright = got
        .iter()
        .zip(want)
        .flat_map(|(g, w)| (0..3).map(move |c| (g[c], w[c])))
        .filter(|(_, w)| *w > 0.05)
        .map(|(g, w)| ((g - w) / w).abs())
        .fold(0.0, f64::max);
    println!(
        "{what}: max |read − model| = {max_abs:.2e} (half 16-bit step {HALF_LSB:.2e}); max relative where model > 0.05: {max_rel_bright:.2e}"
    );
    for (j, (g, w)) in got.iter().zip(want).enumerate() {
        for c in 0..3 {
            assert!(
                (g[c] - w[c]).abs() <= tol(w[c]),
                "{what}: band {j} channel {c}: read {} expected {} (diff {:.2e})",
                g[c],
                w[c],
                g[c] - w[c]
            );
        }
    }
}

#[test]
fn noise_free_flat_spectrum_reads_the_model_sum_in_every_band() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let truth = hg_truth(d);
    let lvf = hand_lvf_json(d);
    let flat = write(d, "flat.csv", "wavelength_nm,value\n300,2\n900,2\n");
    let t = capture(
        d,
        "flat",
        &["--spectrum", &s(&flat), "--lvf", &s(&truth), "--noise", "0"],
    );
    assert_eq!(t["size"], serde_json::json!([1200, 160]));
    assert_eq!(t["light"]["mode"], "emission");
    let cam = Camera::load();
    let light = |_: f64| 2.0;
    // Auto exposure, computed independently: 0.8 over the brightest position and channel.
    let max = (0..1200)
        .flat_map(|p| model_sum(&cam, &light, 380.0 + 0.3 * p as f64, 25.0))
        .fold(0.0, f64::max);
    let exposure = t["exposure"].as_f64().unwrap();
    assert!(
        ((exposure - 0.8 / max) / exposure).abs() < 1e-9,
        "exposure {exposure} vs {}",
        0.8 / max
    );
    let geo = geometry(&lvf);
    let want: Vec<[f64; 3]> = expected_bands(&cam, &geo, &light)
        .iter()
        .map(|v| v.map(|x| x * exposure))
        .collect();
    assert_bands_match(&readings(d, "flat", &geo), &want, "hand-written lvf.json");
}

#[test]
fn a_capture_through_a_calibrated_lvf_json_matches_the_calibrated_model() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    hg_truth(d);
    let lvf = d.join("lvf_cal.json");
    let o = lumifit(&[
        "lvf",
        "calibrate",
        &s(&d.join("hg.tiff")),
        "--roi",
        "0,0,1200,160",
        "--axis",
        "x",
        "--out",
        &s(&lvf),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let flat = write(d, "flat.csv", "wavelength_nm,value\n300,1\n900,1\n");
    // Without --size an lvf.json (which holds no image size) is rejected.
    let o = lumifit(&[
        "synth",
        "lvf-capture",
        "--spectrum",
        &s(&flat),
        "--lvf",
        &s(&lvf),
        "--seed",
        "1",
        "--out",
        &s(&d.join("nosize.tiff")),
    ]);
    assert_rejected(&o, &["--size"]);
    assert!(!d.join("nosize.tiff").exists());
    let t = capture(
        d,
        "cal",
        &[
            "--spectrum",
            &s(&flat),
            "--lvf",
            &s(&lvf),
            "--size",
            "1200x160",
            "--noise",
            "0",
            "--exposure",
            "0.002",
        ],
    );
    assert_eq!(t["exposure_mode"], "fixed");
    let geo = geometry(&lvf);
    let cam = Camera::load();
    let want: Vec<[f64; 3]> = expected_bands(&cam, &geo, &|_| 1.0)
        .iter()
        .map(|v| v.map(|x| x * 0.002))
        .collect();
    assert_bands_match(&readings(d, "cal", &geo), &want, "calibrated lvf.json");
}

#[test]
fn a_gel_halves_the_reading_where_its_transmission_is_half() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let truth = hg_truth(d);
    let geo = geometry(&hand_lvf_json(d));
    let flat = write(d, "flat.csv", "wavelength_nm,value\n300,1\n900,1\n");
    // Long layout, two gels; 'step' passes everything below 440 nm and half above 560 nm.
    let gels = write(
        d,
        "gels.csv",
        "# test gels\nwavelength_nm,clear,step\n405,1,1\n440,1,1\n560,1,0.5\n700,1,0.5\n",
    );
    let open = capture(
        d,
        "open",
        &["--spectrum", &s(&flat), "--lvf", &s(&truth), "--noise", "0"],
    );
    let gel = capture(
        d,
        "gel",
        &[
            "--spectrum",
            &s(&flat),
            "--lvf",
            &s(&truth),
            "--noise",
            "0",
            "--filter",
            &format!("{}:step", s(&gels)),
        ],
    );
    assert_eq!(gel["gel"], "step");
    assert_eq!(open["gel"], serde_json::Value::Null);
    assert_eq!(
        open["exposure"], gel["exposure"],
        "the gel does not change the exposure"
    );
    let (a, b) = (readings(d, "open", &geo), readings(d, "gel", &geo));
    for j in 0..geo.bands.len() {
        for c in 0..3 {
            let nm = geo.bands[j].nm;
            if nm >= 640.0 {
                // ≥ 75 nm (3 FWHM) from the ramp: only the 0.5 plateau is seen.
                assert!(
                    (b[j][c] - 0.5 * a[j][c]).abs() <= tol(0.5 * a[j][c]) + HALF_LSB,
                    "band {nm} nm channel {c}: {} vs {}",
                    b[j][c],
                    a[j][c]
                );
            } else if nm <= 400.0 {
                assert!(
                    b[j][c] > 0.99 * a[j][c] - 2.0 * HALF_LSB,
                    "band {nm} nm channel {c}"
                );
            }
        }
    }
    // In between the reading falls monotonically in the green channel as the ramp sets in.
    let g: Vec<f64> = (0..geo.bands.len()).map(|j| b[j][1] / a[j][1]).collect();
    assert!(g[10] > g[20] && g[20] > 0.5 - 1e-3, "{g:?}");
}

#[test]
fn auto_exposure_puts_a_white_patch_at_0_8_and_grey_at_0_18_of_it() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let truth = hg_truth(d);
    let geo = geometry(&hand_lvf_json(d));
    let white = write(d, "white.csv", "wavelength_nm,value\n380,1\n780,1\n");
    let grey = write(d, "grey.csv", "wavelength_nm,value\n380,0.18\n780,0.18\n");
    let args = |r: &Path| {
        vec![
            "--reflectance".to_string(),
            s(r),
            "--illuminant".into(),
            "D65".into(),
            "--lvf".into(),
            s(&truth),
            "--noise".into(),
            "0".into(),
        ]
    };
    let wa = args(&white);
    let ga = args(&grey);
    let tw = capture(
        d,
        "white",
        &wa.iter().map(String::as_str).collect::<Vec<_>>(),
    );
    let tg = capture(
        d,
        "grey",
        &ga.iter().map(String::as_str).collect::<Vec<_>>(),
    );
    assert_eq!(tw["light"]["illuminant"], "D65");
    assert!((tw["peak_value"].as_f64().unwrap() - 0.8).abs() < 1e-12);
    assert_eq!(tw["exposure"], tg["exposure"]);
    let (frame, _) = lumifit::io::image::read_image(&d.join("white.tiff")).unwrap();
    let max = frame.data().iter().cloned().fold(0.0f32, f32::max) as f64;
    assert!(
        (max - 0.8).abs() <= HALF_LSB + 1e-7,
        "brightest pixel {max}"
    );
    let (w, g) = (readings(d, "white", &geo), readings(d, "grey", &geo));
    for j in 0..w.len() {
        for c in 0..3 {
            assert!(
                (g[j][c] - 0.18 * w[j][c]).abs() <= tol(0.18 * w[j][c]) + 0.18 * HALF_LSB,
                "band {j} channel {c}: grey {} white {}",
                g[j][c],
                w[j][c]
            );
        }
    }
}

fn lee_table() -> Option<PathBuf> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/data/filters/lee_filters_sd_lighting_filters_0.1.1.csv");
    if p.is_file() {
        Some(p)
    } else {
        println!("note: {} is absent; Lee table test skipped", p.display());
        None
    }
}

#[test]
fn the_lee_table_reads_in_place_as_263_gels_covering_405_to_700_nm() {
    let Some(path) = lee_table() else { return };
    let gels = read_gel_table(&path).unwrap();
    assert_eq!(gels.len(), 263);
    assert!(gels.iter().all(|g| g.covers(405.0, 700.0)));
    assert!(gels.iter().all(|g| !g.covers(400.0, 700.0)));
    let rose = gels.iter().find(|g| g.code == "L002").unwrap();
    assert_eq!(rose.name, "Rose Pink");
    // First and last values of the L002 row; constant beyond the measured range.
    assert_eq!(rose.at(405.0), 0.65319);
    assert_eq!(rose.at(380.0), 0.65319);
    assert_eq!(rose.at(700.0), 0.89906);
    let g = lumifit::io::filters::read_filter(&format!("{}:l106", s(&path))).unwrap();
    assert_eq!(g.code, "L106");
}

#[test]
fn bad_input_exits_2_naming_the_file_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let truth = hg_truth(d);
    let flat = write(d, "flat.csv", "wavelength_nm,value\n300,1\n900,1\n");
    let out = d.join("out.tiff");
    let run = |extra: &[&str]| {
        let mut a = vec!["synth", "lvf-capture", "--seed", "1"];
        let o = s(&out);
        a.extend_from_slice(&["--out", &o]);
        a.extend_from_slice(extra);
        let r = lumifit(&a);
        assert!(!out.exists(), "no output on failure: {}", stderr(&r));
        r
    };
    let pct = write(
        d,
        "percent.csv",
        "code,name,400,410,420\nP1,pink,65.3,67.1,70.2\n",
    );
    let o = run(&[
        "--spectrum",
        &s(&flat),
        "--lvf",
        &s(&truth),
        "--filter",
        &format!("{}:P1", s(&pct)),
    ]);
    assert_rejected(&o, &["percent.csv", "line 2", "column 3", "percent"]);
    let gels = write(
        d,
        "gels.csv",
        "code,name,400,410\nA1,a,0.5,0.5\nB2,b,0.4,0.4\n",
    );
    let o = run(&[
        "--spectrum",
        &s(&flat),
        "--lvf",
        &s(&truth),
        "--filter",
        &format!("{}:Z9", s(&gels)),
    ]);
    assert_rejected(&o, &["gels.csv", "'Z9'", "A1, B2"]);
    let o = run(&["--reflectance", &s(&flat), "--lvf", &s(&truth)]);
    assert_rejected(&o, &["--illuminant"]);
    let other = write(d, "other.json", r#"{"schema": "lumifit.material/1"}"#);
    let o = run(&["--spectrum", &s(&flat), "--lvf", &s(&other)]);
    assert_rejected(&o, &["other.json", "schema", "lumifit.material/1"]);
    let broken = write(
        d,
        "broken.json",
        r#"{"schema": "lumifit.lvf-truth/1", "axis": "x"}"#,
    );
    let o = run(&["--spectrum", &s(&flat), "--lvf", &s(&broken)]);
    assert_rejected(&o, &["broken.json", "map.coefficients"]);
    let neg = write(d, "neg.csv", "wavelength_nm,value\n400,1\n500,-1\n");
    let o = run(&["--spectrum", &s(&neg), "--lvf", &s(&truth)]);
    assert_rejected(&o, &["neg.csv", "500 nm"]);
    let o = run(&[
        "--spectrum",
        &s(&flat),
        "--lvf",
        &s(&truth),
        "--exposure",
        "bright",
    ]);
    assert_rejected(&o, &["--exposure", "bright"]);
}
