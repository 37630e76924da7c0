//! Photo series end to end through the binary: a synthetic 37-frame decay series shot with
//! varying exposure, ISO and aperture comes back as the rendered relative radiance within noise,
//! and bad input exits with code 2 and a message naming the file and the cause.

mod common;

use common::{assert_exit2_mentions, lumifit, stderr};

use std::path::{Path, PathBuf};

use lumifit::capture::synth::uniform_frame;
use lumifit::io::image::frame_to_tiff16;

/// Relative radiance per channel of the synthetic decay at time t (s).
fn radiance(t: f64) -> [f64; 3] {
    let d = (-t / 60.0).exp();
    [0.8 * d, 0.5 * d, 0.2 * d + 0.05]
}

/// Relative noise of each rendered pixel.
const NOISE: f64 = 0.02;

/// Writes a 37-frame series (one frame every 5 s) with cycling exposure settings; returns the
/// manifest path and the settings used.
fn write_series(dir: &Path) -> (PathBuf, Vec<(f64, f64, f64, f64)>) {
    let settings = [
        (1.0, 100.0, 4.0),
        (0.5, 400.0, 5.6),
        (2.0, 200.0, 8.0),
        (0.25, 800.0, 2.8),
    ];
    let mut manifest = String::from("file,time_s,exposure_s,iso,f_number\n");
    let mut used = Vec::new();
    for i in 0..37 {
        let t = 5.0 * i as f64;
        let (e, iso, n) = settings[i % settings.len()];
        let k = e * iso / 100.0 / (n * n);
        let value = radiance(t).map(|r| r * k * 0.8);
        let frame = uniform_frame("s", 64, 48, value, NOISE, i as u64 + 1).unwrap();
        let name = format!("frame_{i:02}.tiff");
        std::fs::write(dir.join(&name), frame_to_tiff16(&frame).unwrap()).unwrap();
        manifest.push_str(&format!("{name},{t},{e},{iso},{n}\n"));
        used.push((t, e, iso, n));
    }
    let m = dir.join("series.csv");
    std::fs::write(&m, manifest).unwrap();
    (m, used)
}

#[test]
fn extract_returns_the_rendered_radiance_within_noise_across_exposure_settings() {
    let dir = tempfile::tempdir().unwrap();
    let (manifest, used) = write_series(dir.path());
    let out = dir.path().join("curve.csv");
    let o = lumifit(&[
        "series",
        "extract",
        manifest.to_str().unwrap(),
        "--roi",
        "8,8,48,32",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(&out).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next(),
        Some("time_s,r,g,b,r_std,g_std,b_std,n_pixels,n_saturated")
    );
    let mut n = 0;
    for (row, (t, ..)) in lines.zip(&used) {
        let v: Vec<f64> = row.split(',').map(|s| s.parse().unwrap()).collect();
        assert_eq!(v[0], *t);
        assert_eq!(v[7], 48.0 * 32.0);
        let truth = radiance(*t).map(|r| r * 0.8);
        for c in 0..3 {
            // Mean of 1536 pixels: standard error = std/sqrt(n); allow 5 standard errors plus
            // 16-bit quantisation (1/65535 over the exposure factor).
            let se = v[4 + c] / (v[7]).sqrt();
            assert!(
                (v[1 + c] - truth[c]).abs() < 5.0 * se + 1e-4,
                "t={t} c={c}: {} vs {} (se {se})",
                v[1 + c],
                truth[c]
            );
        }
        n += 1;
    }
    assert_eq!(n, 37);
}

#[test]
fn inspect_lists_every_frame_with_its_settings() {
    let dir = tempfile::tempdir().unwrap();
    let (manifest, _) = write_series(dir.path());
    let o = lumifit(&["series", "inspect", manifest.to_str().unwrap(), "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let rows = v.as_array().unwrap();
    assert_eq!(rows.len(), 37);
    assert_eq!(rows[1]["iso"], 400.0);
    assert_eq!(rows[2]["f_number"], 8.0);
}

#[test]
fn bad_series_inputs_exit_2_naming_the_file_and_cause() {
    let dir = tempfile::tempdir().unwrap();
    let (manifest, _) = write_series(dir.path());
    let d = dir.path();
    let out = d.join("c.csv");
    let out = out.to_str().unwrap();
    // ROI outside the frame.
    let o = lumifit(&[
        "series",
        "extract",
        manifest.to_str().unwrap(),
        "--roi",
        "60,0,10,10",
        "--out",
        out,
    ]);
    assert_exit2_mentions(&o, &["extends outside", "frame_00.tiff"]);
    // Manifest naming a missing file.
    std::fs::write(
        d.join("missing.csv"),
        "file,time_s,exposure_s,iso,f_number\nnope.tiff,0,1,100,4\n",
    )
    .unwrap();
    let o = lumifit(&[
        "series",
        "extract",
        d.join("missing.csv").to_str().unwrap(),
        "--roi",
        "0,0,4,4",
        "--out",
        out,
    ]);
    assert_exit2_mentions(
        &o,
        &["missing.csv", "line 2", "nope.tiff", "does not exist"],
    );
    // Duplicated times.
    std::fs::write(
        d.join("dup.csv"),
        "file,time_s,exposure_s,iso,f_number\nframe_00.tiff,0,1,100,4\nframe_01.tiff,0,1,100,4\n",
    )
    .unwrap();
    let o = lumifit(&["series", "inspect", d.join("dup.csv").to_str().unwrap()]);
    assert_exit2_mentions(&o, &["duplicated", "frame_01.tiff"]);
    // Missing exposure in EXIF and manifest.
    std::fs::write(d.join("noexp.csv"), "file,time_s\nframe_00.tiff,0\n").unwrap();
    let o = lumifit(&["series", "inspect", d.join("noexp.csv").to_str().unwrap()]);
    assert_exit2_mentions(&o, &["frame_00.tiff", "exposure_s", "missing"]);
    // A non-image file and a truncated RAW.
    std::fs::write(d.join("notes.tiff"), "this is not an image").unwrap();
    std::fs::write(
        d.join("bad.csv"),
        "file,time_s,exposure_s,iso,f_number\nnotes.tiff,0,1,100,4\n",
    )
    .unwrap();
    let o = lumifit(&["series", "inspect", d.join("bad.csv").to_str().unwrap()]);
    assert_exit2_mentions(&o, &["notes.tiff", "not a readable image"]);
    std::fs::write(d.join("cut.dng"), b"II*\0\x08\0\0\0\x01\0").unwrap();
    std::fs::write(
        d.join("cut.csv"),
        "file,time_s,exposure_s,iso,f_number\ncut.dng,0,1,100,4\n",
    )
    .unwrap();
    let o = lumifit(&["series", "inspect", d.join("cut.csv").to_str().unwrap()]);
    assert_exit2_mentions(&o, &["cut.dng", "cannot decode", "workaround"]);
    // All-dark and all-saturated regions.
    let dark = uniform_frame("d", 16, 16, [0.0; 3], 0.0, 1).unwrap();
    std::fs::write(d.join("dark.tiff"), frame_to_tiff16(&dark).unwrap()).unwrap();
    let sat = uniform_frame("s", 16, 16, [1.0; 3], 0.0, 1).unwrap();
    std::fs::write(d.join("sat.tiff"), frame_to_tiff16(&sat).unwrap()).unwrap();
    for (name, needle) in [
        ("dark", "dark in every frame"),
        ("sat", "entirely saturated"),
    ] {
        let m = d.join(format!("{name}.csv"));
        std::fs::write(
            &m,
            format!("file,time_s,exposure_s,iso,f_number\n{name}.tiff,0,1,100,4\n"),
        )
        .unwrap();
        let o = lumifit(&[
            "series",
            "extract",
            m.to_str().unwrap(),
            "--roi",
            "0,0,8,8",
            "--out",
            out,
        ]);
        assert_exit2_mentions(&o, &[needle]);
    }
}

#[test]
fn truncated_real_dng_is_a_clear_error_not_a_crash() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/data/raw/tinydng_colorchart_rawler_uncompressed16.dng");
    let Ok(bytes) = std::fs::read(&src) else {
        eprintln!("skipped: {} is absent", src.display());
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let cut = dir.path().join("half.dng");
    std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
    match lumifit::io::series::read_frame(&cut) {
        Err(e) => {
            let m = e.to_string();
            assert!(m.contains("half.dng"), "{m}");
        }
        Ok(_) => {
            eprintln!("note: the decoder read a half-truncated DNG (it zero-fills missing data)")
        }
    }
}
