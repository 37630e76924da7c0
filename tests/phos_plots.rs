//! `--plot` of `phos simulate` and `phos design`, run as a user would: the PNG exists, decodes,
//! has the chart's size and is a drawing (many colours, the curve colours present), and a plot
//! path in a missing directory fails with exit 2 before anything is written.

mod common;

use std::collections::HashSet;
use std::path::Path;

use common::{assert_rejected, lumifit, p, stderr, write};
use lumifit::plot::phosphor_sim::{DESIGN_SIZE_PX, SIMULATE_SIZE_PX};

/// Fewest distinct colours a chart with axes, text, curves and a legend has (a blank or
/// single-fill image has 1).
const MIN_DISTINCT_COLOURS: usize = 12;

/// Line colours of the R, G, B camera / design channels (src/plot/phosphor_sim.rs).
const CHANNEL_COLOURS: [[u8; 3]; 3] = [[200, 40, 40], [40, 150, 60], [40, 70, 200]];

fn decode(path: &Path) -> image::RgbImage {
    let bytes = std::fs::read(path).expect("the plot file exists");
    image::load_from_memory_with_format(&bytes, image::ImageFormat::Png)
        .expect("the plot decodes as PNG")
        .to_rgb8()
}

fn colours(img: &image::RgbImage) -> HashSet<[u8; 3]> {
    img.pixels().map(|p| p.0).collect()
}

/// Pixels of exactly `colour` (lines are drawn without anti-aliasing).
fn count(img: &image::RgbImage, colour: [u8; 3]) -> usize {
    img.pixels().filter(|p| p.0 == colour).count()
}

fn ok(o: &std::process::Output) -> String {
    assert!(o.status.success(), "{}", stderr(o));
    String::from_utf8_lossy(&o.stdout).to_string()
}

fn names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .expect("dir")
        .map(|e| e.expect("entry").file_name().to_string_lossy().to_string())
        .collect();
    v.sort();
    v
}

const HISTORY_8: &str = "duration_s,e1,e2,e3,e4,e5,e6,e7,e8\n\
                         300,1,1,1,0,0,0,0,0\n\
                         120,0,0,0,0,0,0,0,0\n\
                         200,0.5,0.5,0.5,0.5,0.5,0.5,0.5,0.5\n\
                         600,0,0,0,0,0,0,0,0\n";

/// A 20 s history of 0.2 s rows (light for 8 s, then dark) and four keyframes.
fn design_inputs(dir: &Path) -> (String, String) {
    let mut h = String::from("time_s,e_r,e_g,e_b\n");
    for f in 0..100 {
        let t = f as f64 * 0.2;
        let e = if t < 8.0 { 1.0 } else { 0.0 };
        h.push_str(&format!("{t},{e},{},{}\n", 0.5 * e, 0.2 * e));
    }
    write(dir, "h.csv", h);
    write(
        dir,
        "t.csv",
        "time_s,l_r,l_g,l_b\n4,0.3,0.4,0.2\n9,0.05,0.1,0.03\n12,0.02,0.04,0.012\n19,0.004,0.008,0.0024\n",
    );
    (p(dir, "h.csv"), p(dir, "t.csv"))
}

#[test]
fn simulate_plot_is_a_png_of_the_chart_size_with_every_band_drawn() {
    let d = tempfile::tempdir().unwrap();
    let h = write(d.path(), "h.csv", HISTORY_8);
    let png = p(d.path(), "em.png");
    let out = ok(&lumifit(&[
        "phos",
        "simulate",
        "--material",
        "blue_paint",
        "--history",
        &h.to_string_lossy(),
        "--dt",
        "2",
        "--out",
        &p(d.path(), "em.csv"),
        "--plot",
        &png,
    ]));
    assert!(out.contains("em.png"), "{out}");
    assert!(d.path().join("em.csv").exists());
    let img = decode(Path::new(&png));
    assert_eq!(img.dimensions(), SIMULATE_SIZE_PX);
    let c = colours(&img);
    assert!(c.len() >= MIN_DISTINCT_COLOURS, "{} colours", c.len());
}

#[test]
fn synth_camera_then_simulate_plot_draws_the_camera_channels() {
    let d = tempfile::tempdir().unwrap();
    // `synth phos-excitation` writes an ideal box camera beside its output.
    ok(&lumifit(&[
        "synth",
        "phos-excitation",
        "--material",
        "green_paint",
        "--seed",
        "1",
        "--out",
        &p(d.path(), "ch.csv"),
    ]));
    let h = write(d.path(), "h.csv", HISTORY_8);
    let png = p(d.path(), "rgb.png");
    ok(&lumifit(&[
        "phos",
        "simulate",
        "--material",
        "green_paint",
        "--history",
        &h.to_string_lossy(),
        "--camera",
        &p(d.path(), "ch.camera.csv"),
        "--out",
        &p(d.path(), "rgb.csv"),
        "--plot",
        &png,
    ]));
    let img = decode(Path::new(&png));
    assert_eq!(img.dimensions(), SIMULATE_SIZE_PX);
    assert!(colours(&img).len() >= MIN_DISTINCT_COLOURS);
    // Green paint glows green and blue through the box camera: long curves, not just the
    // legend samples (34 × 2 px each).
    for ch in [1, 2] {
        let n = count(&img, CHANNEL_COLOURS[ch]);
        assert!(n > 1000, "channel {ch}: {n} px");
    }
}

#[test]
fn design_plot_draws_curves_targets_and_works_with_grid_only() {
    let d = tempfile::tempdir().unwrap();
    let (h, t) = design_inputs(d.path());
    for (name, extra) in [("refined", None), ("grid", Some("--grid-only"))] {
        let png = p(d.path(), &format!("{name}.png"));
        let json = p(d.path(), &format!("{name}.json"));
        let mut args: Vec<&str> = vec![
            "phos",
            "design",
            "--history",
            &h,
            "--targets",
            &t,
            "--albedo",
            "0.5,0.5,0.5",
            "--out",
            &json,
            "--plot",
            &png,
        ];
        args.extend(extra);
        ok(&lumifit(&args));
        assert!(Path::new(&json).exists());
        let img = decode(Path::new(&png));
        assert_eq!(img.dimensions(), DESIGN_SIZE_PX, "{name}");
        assert!(colours(&img).len() >= MIN_DISTINCT_COLOURS, "{name}");
        for (ch, colour) in CHANNEL_COLOURS.iter().enumerate() {
            let n = count(&img, *colour);
            assert!(n > 1000, "{name}, channel {ch}: {n} px");
        }
    }
}

#[test]
fn a_plot_whose_directory_cannot_be_created_fails_with_exit_2_and_writes_nothing() {
    let d = tempfile::tempdir().unwrap();
    let h = write(d.path(), "h8.csv", HISTORY_8);
    // below a regular file no directory can be made: found at commit, after the simulation
    write(d.path(), "file", "x");
    let bad = p(d.path(), "file/dir/em.png");
    let o = lumifit(&[
        "phos",
        "simulate",
        "--material",
        "blue_paint",
        "--history",
        &h.to_string_lossy(),
        "--out",
        &p(d.path(), "em.csv"),
        "--plot",
        &bad,
    ]);
    assert_rejected(&o, &["file/dir"]);

    let (h, t) = design_inputs(d.path());
    let o = lumifit(&[
        "phos",
        "design",
        "--history",
        &h,
        "--targets",
        &t,
        "--out",
        &p(d.path(), "m.json"),
        "--plot",
        &p(d.path(), "file/design.png"),
    ]);
    assert_rejected(&o, &["file"]);
    // Only the inputs are there: no CSV, no preset, no stray temporary file.
    assert_eq!(names(d.path()), ["file", "h.csv", "h8.csv", "t.csv"]);
}

#[test]
fn a_plot_into_a_missing_directory_creates_it_with_the_output_as_every_command_does() {
    let d = tempfile::tempdir().unwrap();
    let h = write(d.path(), "h8.csv", HISTORY_8);
    let o = lumifit(&[
        "phos",
        "simulate",
        "--material",
        "blue_paint",
        "--history",
        &h.to_string_lossy(),
        "--out",
        &p(d.path(), "out/em.csv"),
        "--plot",
        &p(d.path(), "new/dir/em.png"),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(d.path().join("out/em.csv").is_file());
    assert!(d.path().join("new/dir/em.png").is_file());
}
