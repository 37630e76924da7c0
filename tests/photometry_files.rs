//! IES LM-63 and EULUMDAT readers and writers on every file of `../shared/data/photometric/`
//! (skipped with a message when that folder is absent; a failure when `LUMIFIT_REQUIRE_DATA=1`),
//! on synthetic files, and on broken ones.

use std::path::PathBuf;

use lumifit::io::eulumdat::{parse_ldt, write_ldt};
use lumifit::io::ies::{parse_ies, write_ies};
use lumifit::io::read_photometric;
use lumifit::photometry::{
    summary, OpeningShape, PhotometricFile, PhotometricType, Symmetry, Tilt,
};
mod common;
use common::tolerances::photometry_files::*;

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

fn all_files(dir: &std::path::Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for sub in std::fs::read_dir(dir).unwrap() {
        let sub = sub.unwrap().path();
        if sub.is_dir() {
            for f in std::fs::read_dir(&sub).unwrap() {
                let f = f.unwrap().path();
                let ext = f
                    .extension()
                    .map(|e| e.to_string_lossy().to_ascii_lowercase())
                    .unwrap_or_default();
                if ext == "ies" || ext == "ldt" {
                    out.push(f);
                }
            }
        }
    }
    out.sort();
    out
}

fn read(dir: &std::path::Path, rel: &str) -> PhotometricFile {
    read_photometric(&dir.join(rel), 0.0).unwrap_or_else(|e| panic!("{rel}: {e}"))
}

fn no_tilt(_: &str) -> lumifit::Result<(Vec<u8>, String)> {
    Err(lumifit::Error::invalid("TILT", "no tilt file in this test"))
}

#[test]
fn every_file_in_the_data_folder_is_read_and_round_trips_through_both_writers() {
    let Some(dir) = data_dir() else { return };
    let files = all_files(&dir);
    assert_eq!(files.len(), 15, "PROVENANCE.md lists 15 files: {files:?}");
    for f in files {
        let name = f.display().to_string();
        let a = read_photometric(&f, 0.0).unwrap_or_else(|e| panic!("{name}: {e}"));
        let s = summary(&a.photometry);
        assert!(s.flux_lm > 0.0 && s.max_cd > 0.0, "{name}: {s:?}");
        // IES: exact
        let ies = write_ies(&a, "lumifit test").unwrap();
        let b = parse_ies(ies.as_bytes(), "written.ies", &no_tilt, 0.0)
            .unwrap_or_else(|e| panic!("{name} → IES: {e}\n{ies}"));
        assert_eq!(
            a.photometry.grid, b.photometry.grid,
            "{name}: IES round trip"
        );
        assert_eq!(a.photometry.symmetry, b.photometry.symmetry, "{name}");
        assert_eq!(
            a.photometry.lamp_flux_lm, b.photometry.lamp_flux_lm,
            "{name}"
        );
        // EULUMDAT: to a few ulp
        let ldt = write_ldt(&a, "lumifit test").unwrap();
        let c = parse_ldt(ldt.as_bytes(), "written.ldt")
            .unwrap_or_else(|e| panic!("{name} → LDT: {e}\n{ldt}"));
        assert_eq!(a.photometry.grid.h_deg, c.photometry.grid.h_deg, "{name}");
        assert_eq!(a.photometry.grid.v_deg, c.photometry.grid.v_deg, "{name}");
        for (x, y) in a.photometry.grid.cd.iter().zip(&c.photometry.grid.cd) {
            assert!(
                (x - y).abs() <= LDT_ROUNDTRIP_REL * x.abs(),
                "{name}: {x} vs {y}"
            );
        }
        // and the LDT read back writes the same IES grid again
        let d = parse_ies(
            write_ies(&c, "t").unwrap().as_bytes(),
            "w2.ies",
            &no_tilt,
            0.0,
        )
        .unwrap();
        assert_eq!(c.photometry.grid, d.photometry.grid, "{name}");
    }
}

#[test]
fn ies_keywords_more_lines_multiplier_units_and_absolute_photometry_are_read() {
    let Some(dir) = data_dir() else { return };
    let lab = read(&dir, "photometric-viewer_MIT/ies95_label_lines.ies");
    assert_eq!(lab.version, "LM-63-1995");
    assert_eq!(
        lab.keyword("MULTILINE"),
        Some("Test multiline metadata\nShould contain three lines\nDivided by LF characters")
    );
    assert_eq!(lab.keyword("LUMCAT"), Some("BD0150"));
    // relative photometry, multiplier 1.5: node values are 1.5 × the file's
    let m = read(
        &dir,
        "photometric-viewer_MIT/ies95_relative_photometry_with_multiplier.ies",
    );
    let raw = read(&dir, "photometric-viewer_MIT/ies95_label_lines.ies");
    let text = std::fs::read_to_string(
        dir.join("photometric-viewer_MIT/ies95_relative_photometry_with_multiplier.ies"),
    )
    .unwrap();
    assert!(text.contains(" 1.5 "), "fixture has multiplier 1.5");
    assert_eq!(m.photometry.lamp_flux_lm, Some(500.0));
    assert_eq!(m.photometry.grid.at(0, 0), 1.5 * 2200.0);
    assert_eq!(raw.photometry.grid.at(0, 0), 2200.0);
    // absolute photometry, round opening of 0.12 m
    let a = read(&dir, "photometric-viewer_MIT/ies95_absolute_photometry.ies");
    assert_eq!(a.photometry.lamp_flux_lm, None);
    assert!(summary(&a.photometry).lor.is_none());
    assert_eq!(a.photometry.opening.shape, OpeningShape::Circular);
    assert!((a.photometry.opening.width_m - 0.12).abs() < 1e-12);
    assert_eq!(a.photometry.symmetry, Symmetry::Rotational);
    // feet → metres
    let ft = read(&dir, "photometric-viewer_MIT/ies95_imperial_units.ies");
    let text = std::fs::read_to_string(dir.join("photometric-viewer_MIT/ies95_imperial_units.ies"))
        .unwrap();
    let w_ft: f64 = text
        .lines()
        .find(|l| l.starts_with("1 -1") || l.starts_with("1 "))
        .unwrap()
        .split_whitespace()
        .nth(7)
        .unwrap()
        .parse()
        .unwrap();
    assert!((ft.photometry.opening.width_m - w_ft.abs() * 0.3048).abs() < 1e-12);
}

#[test]
fn the_lm63_2002_example_has_a_tilt_table_a_spaced_header_and_quadrant_symmetry() {
    let Some(dir) = data_dir() else { return };
    let f = read(&dir, "lidrs_MIT/iesna2002_example_typec.ies");
    assert_eq!(f.version, "LM-63-2002");
    match &f.photometry.tilt {
        Tilt::Table {
            source,
            geometry,
            angles_deg,
            factors,
        } => {
            assert_eq!(
                (source.as_str(), *geometry, angles_deg.len()),
                ("INCLUDE", 1, 13)
            );
            assert_eq!(factors[1], 0.95);
        }
        t => panic!("{t:?}"),
    }
    assert_eq!(f.photometry.tilt_applied, (0.0, 1.0));
    assert_eq!(f.photometry.symmetry, Symmetry::Quadrant);
    let g = &f.photometry.grid;
    assert_eq!(
        g.h_deg,
        vec![0.0, 45.0, 90.0, 135.0, 180.0, 225.0, 270.0, 315.0]
    );
    // the 45° plane mirrored to 135°, 225°, 315°
    for c in [135.0, 225.0, 315.0] {
        assert_eq!(g.intensity(c, 22.5), g.intensity(45.0, 22.5));
    }
    assert_eq!(g.intensity(45.0, 22.5), 35000.0);
    assert_eq!(f.keyword("OTHER").unwrap().lines().count(), 2);
    // feet: 0.5 × 0.6 ft opening
    assert!((f.photometry.opening.width_m - 0.5 * 0.3048).abs() < 1e-12);
    // at a lamp tilt of 15° the TILT factor 0.95 is applied to every value
    let bytes = std::fs::read(dir.join("lidrs_MIT/iesna2002_example_typec.ies")).unwrap();
    let t = parse_ies(&bytes, "x.ies", &no_tilt, 15.0).unwrap();
    assert_eq!(t.photometry.tilt_applied, (15.0, 0.95));
    assert_eq!(t.photometry.grid.at(0, 0), 0.95 * 100000.0);
}

#[test]
fn the_stripes_file_puts_its_quadrants_where_c_and_gamma_say() {
    let Some(dir) = data_dir() else { return };
    let f = read(
        &dir,
        "luxtest_CC-BY-4.0/test_vstripes_hquadrants_nonuniform.ies",
    );
    let g = &f.photometry.grid;
    assert_eq!(f.photometry.symmetry, Symmetry::None);
    assert_eq!(g.h_deg.len(), 8, "0..359 with the 360° plane dropped");
    // per the file's description: vertical 10–19° white in C 0–179, black in C 180–359
    assert_eq!(g.intensity(45.0, 15.0), 1.0);
    assert_eq!(g.intensity(135.0, 15.0), 1.0);
    assert_eq!(g.intensity(225.0, 15.0), 0.0);
    // … where "black" is 0.25 in C 270–359
    assert_eq!(g.intensity(315.0, 15.0), 0.25);
    // black level: 0 in C 0–89, 0.25 in C 90–179
    assert_eq!(g.intensity(45.0, 25.0), 0.0);
    assert_eq!(g.intensity(135.0, 25.0), 0.25);
    // caps
    assert_eq!(g.intensity(10.0, 5.0), 0.25);
    assert_eq!(g.intensity(10.0, 175.0), 0.75);
    // direction: +y is C 90 at the horizon band 90–99 → white/black per quadrant as above
    assert_eq!(
        g.intensity_dir([
            0.5f64.sqrt(),
            0.5f64.sqrt(),
            -(15.0f64.to_radians().cos()) * 10.0
        ]),
        g.intensity(45.0, (0.1f64).atan().to_degrees())
    );
    let lin = read(&dir, "luxtest_CC-BY-4.0/test_linear_vertical.ies");
    assert!((lin.photometry.grid.intensity(123.0, 90.0) - 0.5).abs() < 1e-12);
}

#[test]
fn eulumdat_symmetries_expand_to_the_same_mirror_images() {
    let Some(dir) = data_dir() else { return };
    let pv = |n: &str| read(&dir, &format!("photometric-viewer_MIT/{n}"));
    let rot = pv("ldt_symmetry_about_vertical_axis.ldt");
    assert_eq!(rot.photometry.symmetry, Symmetry::Rotational);
    assert_eq!(rot.photometry.grid.h_deg, vec![0.0]);
    let s2 = pv("ldt_symmetry_to_c0c180.ldt");
    let s3 = pv("ldt_symmetry_to_c90c270.ldt");
    let s4 = pv("ldt_symmetry_to_c0c90c180c270.ldt");
    let s0 = pv("ldt_no_symmetry.ldt");
    for (f, n) in [(&s2, 36), (&s3, 36), (&s4, 36), (&s0, 24)] {
        assert_eq!(f.photometry.grid.h_deg.len(), n);
        assert_eq!(f.photometry.grid.kind, PhotometricType::C);
    }
    for c in [10.0, 40.0, 130.0, 200.0, 290.0] {
        for g in [0.0, 30.0, 77.5] {
            let i2 = &s2.photometry.grid;
            assert_eq!(i2.intensity(c, g), i2.intensity(360.0 - c, g));
            let i3 = &s3.photometry.grid;
            assert_eq!(i3.intensity(c, g), i3.intensity(180.0 - c, g));
            let i4 = &s4.photometry.grid;
            assert_eq!(i4.intensity(c, g), i4.intensity(360.0 - c, g));
            assert_eq!(i4.intensity(c, g), i4.intensity(180.0 - c, g));
        }
    }
    // the first stored plane of Isym 3 is C90
    let raw3 =
        std::fs::read_to_string(dir.join("photometric-viewer_MIT/ldt_symmetry_to_c90c270.ldt"))
            .unwrap();
    let first: f64 = raw3
        .lines()
        .nth(42 + 36 + 37)
        .unwrap()
        .trim()
        .parse()
        .unwrap();
    assert_eq!(
        s3.photometry.grid.intensity(90.0, 0.0),
        first * 500.0 / 1000.0 * s3.lamps[0].flux_lm / 500.0
    );
    assert!(
        s0.notes.iter().any(|n| n.contains("Dc = 90")),
        "{:?}",
        s0.notes
    );
}

#[test]
fn eulumdat_absolute_photometry_and_lamp_sets_scale_by_the_first_set() {
    let Some(dir) = data_dir() else { return };
    let a = read(&dir, "photometric-viewer_MIT/ldt_absolute.ldt");
    assert_eq!(a.photometry.lamp_flux_lm, None);
    assert_eq!(a.photometry.declared_luminaire_flux_lm, Some(500.0));
    assert_eq!(a.photometry.grid.at(0, 0), 2200.0 * 500.0 / 1000.0);
    let m = read(&dir, "photometric-viewer_MIT/ldt_multiple_lamp_sets.ldt");
    assert_eq!(m.lamps.len(), 3);
    assert_eq!(m.lamps[1].count, 2);
    assert_eq!(m.lamps[1].flux_lm, 1200.0);
    assert_eq!(m.photometry.lamp_flux_lm, Some(500.0));
    assert_eq!(m.direct_ratios.len(), 10);
    // real vendor data: flux integrated from the grid against LORL × lamp flux
    let v = read(&dir, "lidrs_MIT/example.ldt");
    let s = summary(&v.photometry);
    let declared =
        v.photometry.lamp_flux_lm.unwrap() * v.photometry.declared_lor_percent.unwrap() / 100.0;
    assert!(
        (s.flux_lm / declared - 1.0).abs() < 0.02,
        "integrated {} lm vs declared {declared} lm",
        s.flux_lm
    );
    assert_eq!(v.photometry.grid.v_deg.len(), 37);
    assert_eq!(v.photometry.grid.h_deg.len(), 20);
}

// ---------------------------------------------------------------- synthetic and broken files

const GOOD_IES: &str = "IESNA:LM-63-2002\n[TEST] t\nTILT=NONE\n1 1000 1 3 1 1 2 0.5 0.5 0\n1 1 10\n0 45 90\n0\n100 70 0\n";

fn ies_err(text: &str) -> String {
    parse_ies(text.as_bytes(), "bad.ies", &no_tilt, 0.0)
        .unwrap_err()
        .to_string()
}

#[test]
fn a_good_synthetic_ies_reads_and_its_lambertian_flux_is_pi_i0() {
    let f = parse_ies(GOOD_IES.as_bytes(), "good.ies", &no_tilt, 0.0).unwrap();
    assert_eq!(f.photometry.grid.at(0, 1), 70.0);
    // Lambertian I = I0 cos γ at 1° steps: Φ = π I0 to the piecewise-linear error (h²/12 ≈ 2.5e-5)
    let v: Vec<String> = (0..=90).map(|k| k.to_string()).collect();
    let cd: Vec<String> = (0..=90)
        .map(|k| format!("{}", 1000.0 * (k as f64).to_radians().cos()))
        .collect();
    let text = format!(
        "IES:LM-63-2019\nTILT=NONE\n1 -1 1 91 1 1 2 1 1 0\n1 1.00001 0\n{}\n0\n{}\n",
        v.join(" "),
        cd.join(" ")
    );
    let f = parse_ies(text.as_bytes(), "lambert.ies", &no_tilt, 0.0).unwrap();
    let flux = summary(&f.photometry).flux_lm;
    assert!(
        (flux / (std::f64::consts::PI * 1000.0) - 1.0).abs() < 5e-5,
        "{flux}"
    );
    // 2019: the file-generation field is not a multiplier
    assert_eq!(f.photometry.grid.at(0, 0), 1000.0);
    // a BOM and CRLF line ends read alike
    let crlf = format!("\u{feff}{}", GOOD_IES.replace('\n', "\r\n"));
    let g = parse_ies(crlf.as_bytes(), "crlf.ies", &no_tilt, 0.0).unwrap();
    assert_eq!(
        g.photometry.grid,
        parse_ies(GOOD_IES.as_bytes(), "g", &no_tilt, 0.0)
            .unwrap()
            .photometry
            .grid
    );
}

#[test]
fn broken_ies_files_are_refused_naming_file_line_and_field() {
    let truncated = &GOOD_IES[..GOOD_IES.len() - 4];
    let e = ies_err(truncated);
    assert!(
        e.contains("bad.ies") && e.contains("candela value") && e.contains("truncated"),
        "{e}"
    );
    let e = ies_err(&GOOD_IES.replace("100 70 0", "100 70 0 5"));
    assert!(e.contains("bad.ies: line 8") && e.contains("count"), "{e}");
    let e = ies_err(&GOOD_IES.replace("0 45 90", "0 90 45"));
    assert!(
        e.contains("line 6") && e.contains("vertical angles") && e.contains("increasing"),
        "{e}"
    );
    let e = ies_err(&GOOD_IES.replace("100 70 0", "100 -70 0"));
    assert!(e.contains("line 8") && e.contains("negative"), "{e}");
    let e = ies_err(&GOOD_IES.replace("TILT=NONE\n", "TILT=INCLUDE\n1\n3\n0 90 180\n1 1\n"));
    assert!(
        e.contains("bad.ies: line 8") && e.contains("TILT") && e.contains("count"),
        "{e}"
    );
    let e = ies_err(&GOOD_IES.replace("1 1 2 0.5", "1 4 2 0.5"));
    assert!(
        e.contains("line 4") && e.contains("photometric type"),
        "{e}"
    );
    let e = ies_err(&GOOD_IES.replace("TILT=NONE\n", ""));
    assert!(e.contains("TILT"), "{e}");
    let e = ies_err(
        "IESNA:LM-63-2002\nTILT=NONE\n1 1000 1 2 2 1 2 0 0 0\n1 1 1\n0 90\n0 120\n1 1 1 1\n",
    );
    assert!(
        e.contains("horizontal angles 0–120") && e.contains("layout"),
        "{e}"
    );
    let e = parse_ies(b"IESNA:LM-63-2002\n\0\x01binary", "bin.ies", &no_tilt, 0.0)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("bin.ies") && e.contains("not a text file"),
        "{e}"
    );
}

fn good_ldt() -> String {
    let mut l: Vec<String> = [
        "co", "1", "1", "1", "0", "3", "45", "r", "n", "num", "f.ldt", "d", "100", "100", "10",
        "100", "100", "0", "0", "0", "0", "100", "90", "1", "0", "1", "1", "LED", "1000", "3000",
        "80", "10",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    l.extend((0..10).map(|_| "0.5".to_string()));
    l.extend(
        ["0", "0", "45", "90", "300", "200", "100"]
            .iter()
            .map(|s| s.to_string()),
    );
    l.join("\n") + "\n"
}

#[test]
fn broken_eulumdat_files_are_refused_naming_file_line_and_field() {
    let good = good_ldt();
    let f = parse_ldt(good.as_bytes(), "ok.ldt").unwrap();
    assert_eq!(f.photometry.grid.at(0, 0), 300.0);
    let set_line = |n: usize, v: &str| {
        let mut lines: Vec<&str> = good.lines().collect();
        lines[n - 1] = v;
        lines.join("\n") + "\n"
    };
    let e = parse_ldt(set_line(3, "7").as_bytes(), "bad.ldt")
        .unwrap_err()
        .to_string();
    assert!(e.contains("bad.ldt: line 3") && e.contains("Isym"), "{e}");
    let e = parse_ldt(set_line(48, "-3").as_bytes(), "bad.ldt")
        .unwrap_err()
        .to_string();
    assert!(e.contains("line 48") && e.contains("negative"), "{e}");
    let e = parse_ldt(set_line(46, "30").as_bytes(), "bad.ldt")
        .unwrap_err()
        .to_string();
    assert!(e.contains("γ angles") && e.contains("increasing"), "{e}");
    let e = parse_ldt(
        good.lines()
            .take(40)
            .collect::<Vec<_>>()
            .join("\n")
            .as_bytes(),
        "cut.ldt",
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("cut.ldt") && e.contains("truncated"), "{e}");
    let e = parse_ldt(format!("{good}7\n").as_bytes(), "bad.ldt")
        .unwrap_err()
        .to_string();
    assert!(e.contains("line 50") && e.contains("count"), "{e}");
    let e = parse_ldt(
        set_line(4, "3")
            .replacen("\n1\n3\n", "\n2\n3\n", 1)
            .as_bytes(),
        "bad.ldt",
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("bad.ldt"), "{e}");
}

#[test]
fn mutated_files_never_panic_the_readers() {
    // A proptest-style generator: 100,000 mutations (byte flips, deletions, duplications,
    // digit swaps) of a good IES and a good EULUMDAT file; every one must return Ok or Err.
    let ies = GOOD_IES.as_bytes().to_vec();
    let ldt = good_ldt().into_bytes();
    let mut state = 0x1234_5678_9abc_def0u64;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    };
    let alphabet = b"0123456789-.eE ,\n[]TILT=NONE+";
    for round in 0..100_000 {
        let base = if round % 2 == 0 { &ies } else { &ldt };
        let mut m = base.clone();
        for _ in 0..1 + next() % 4 {
            if m.is_empty() {
                break;
            }
            let i = (next() % m.len() as u64) as usize;
            match next() % 4 {
                0 => m[i] = alphabet[(next() % alphabet.len() as u64) as usize],
                1 => {
                    m.remove(i);
                }
                2 => {
                    let b = m[i];
                    m.insert(i, b);
                }
                _ => m.truncate(i),
            }
        }
        let r = std::panic::catch_unwind(|| {
            let _ = parse_ies(&m, "m.ies", &no_tilt, 0.0);
            let _ = parse_ldt(&m, "m.ldt");
        });
        assert!(
            r.is_ok(),
            "panic on mutation {round}: {:?}",
            String::from_utf8_lossy(&m)
        );
    }
}

fn rotate(q: [f64; 4], v: [f64; 3]) -> [f64; 3] {
    // v' = v + 2w (q×v) + 2 q×(q×v)
    let (x, y, z, w) = (q[0], q[1], q[2], q[3]);
    let c1 = [
        y * v[2] - z * v[1],
        z * v[0] - x * v[2],
        x * v[1] - y * v[0],
    ];
    let c2 = [
        y * c1[2] - z * c1[1],
        z * c1[0] - x * c1[2],
        x * c1[1] - y * c1[0],
    ];
    [
        v[0] + 2.0 * (w * c1[0] + c2[0]),
        v[1] + 2.0 * (w * c1[1] + c2[1]),
        v[2] + 2.0 * (w * c1[2] + c2[2]),
    ]
}

#[test]
fn gltf_export_aims_the_node_down_its_normal_and_writes_an_ies_that_lights_the_same_directions() {
    use lumifit::photometry::illuminance::RectLight;
    // an asymmetric profile: 100 cd towards C 0–90, 10 cd elsewhere, full circle
    let text = "IES:LM-63-2019\n[TEST] t\nTILT=NONE\n1 -1 1 2 5 1 2 0.6 0.3 0\n1 1.00001 0\n0 90\n0 90 180 270 360\n100 100 50 50 10 10 10 10 100 100\n";
    let f = parse_ies(text.as_bytes(), "asym.ies", &no_tilt, 0.0).unwrap();
    let light =
        RectLight::new([1.0, 2.0, 3.0], [0.0, 0.6, -0.8], [1.0, 0.0, 0.0], 0.6, 0.3).unwrap();
    let (doc, ies) =
        lumifit::preset::export::light::gltf_light(&f, &light, "asym", "asym.ies").unwrap();
    assert_eq!(doc["asset"]["version"], "2.0");
    assert_eq!(doc["nodes"][0]["extensions"]["EXT_lights_ies"]["light"], 0);
    assert_eq!(
        doc["extensions"]["EXT_lights_ies"]["lights"][0]["uri"],
        "asym.ies"
    );
    let q: Vec<f64> = doc["nodes"][0]["rotation"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    let q = [q[0], q[1], q[2], q[3]];
    let close = |a: [f64; 3], b: [f64; 3]| (0..3).all(|i| (a[i] - b[i]).abs() < 1e-12);
    assert!(close(rotate(q, [0.0, 0.0, -1.0]), light.n), "−Z → n");
    assert!(close(rotate(q, [1.0, 0.0, 0.0]), light.u), "+X → u");
    // the written IES, read in the node's frame, gives lumifit's intensity for every world direction
    let back = parse_ies(&ies, "export.ies", &no_tilt, 0.0).unwrap();
    for d in [[0.3, 0.5, -0.8], [-0.6, 0.1, -0.2], [0.2, -0.9, 0.1]] {
        let local = [0, 1, 2].map(|k| {
            let axis = rotate(q, [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]][k]);
            axis[0] * d[0] + axis[1] * d[1] + axis[2] * d[2]
        });
        let want = light.intensity(&f.photometry.grid, d);
        let got = back.photometry.grid.intensity_dir(local);
        assert!(
            (want - got).abs() < 1e-9 * want.max(1.0),
            "{d:?}: lumifit {want} vs glTF {got}"
        );
    }
}

#[test]
fn tilt_from_a_file_beside_the_ies_is_applied_and_a_missing_one_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let ies = GOOD_IES.replace("TILT=NONE", "TILT=lamp.tlt");
    std::fs::write(dir.path().join("a.ies"), &ies).unwrap();
    let e = read_photometric(&dir.path().join("a.ies"), 0.0)
        .unwrap_err()
        .to_string();
    assert!(e.contains("lamp.tlt"), "{e}");
    std::fs::write(dir.path().join("lamp.tlt"), "1\n3\n0 45 90\n1 0.8 0.5\n").unwrap();
    let f = read_photometric(&dir.path().join("a.ies"), 22.5).unwrap();
    assert_eq!(f.photometry.tilt_applied, (22.5, 0.9));
    assert_eq!(f.photometry.grid.at(0, 0), 100.0 * 0.9);
    match &f.photometry.tilt {
        Tilt::Table { source, .. } => assert_eq!(source, "lamp.tlt"),
        t => panic!("{t:?}"),
    }
}

#[test]
fn type_b_with_lateral_symmetry_is_mirrored_and_aimed_at_nadir() {
    // Type B, H 0–90 (mirrored to −H), V −90…90
    let text = "IESNA:LM-63-2002\nTILT=NONE\n1 -1 1 3 2 2 2 0 0 0\n1 1 0\n-90 0 90\n0 90\n5 100 7 0 20 0\n";
    let f = parse_ies(text.as_bytes(), "b.ies", &no_tilt, 0.0).unwrap();
    let g = &f.photometry.grid;
    assert_eq!(g.kind, PhotometricType::B);
    assert_eq!(f.photometry.symmetry, Symmetry::LateralAB);
    assert_eq!(g.h_deg, vec![-90.0, 0.0, 90.0]);
    assert_eq!(g.intensity(-90.0, 0.0), g.intensity(90.0, 0.0));
    // H = V = 0 is the photometric axis, nadir −z
    assert_eq!(g.intensity_dir([0.0, 0.0, -1.0]), 100.0);
    // V = 90 turns towards +x in the plane H = 0; H = 90 is the polar axis +y
    assert_eq!(g.intensity_dir([1.0, 0.0, 0.0]), 7.0);
    assert_eq!(g.intensity_dir([0.0, 1.0, 0.0]), 20.0);
    assert!(summary(&f.photometry).flux_lm > 0.0);
    let back = parse_ies(
        write_ies(&f, "t").unwrap().as_bytes(),
        "b2.ies",
        &no_tilt,
        0.0,
    )
    .unwrap();
    assert_eq!(back.photometry.grid, f.photometry.grid);
    assert!(write_ldt(&f, "t")
        .unwrap_err()
        .to_string()
        .contains("Type C only"));
}
