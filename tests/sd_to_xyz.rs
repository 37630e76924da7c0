//! lumifit's spectral → XYZ against colour-science 0.4.7 (`fixtures/sd_to_xyz.json`, written by
//! `scripts/reference/colour_reference.py`): 50 random smooth spectra at 1, 5, 10 and 20 nm under
//! A, D65, FL2 and LED-B3 with three observers, by both methods, plus non-uniform spectra and
//! absolute emission with k = 683.

use std::path::PathBuf;

use lumifit::colorimetry::{
    sd_to_xyz, Illuminant, Observer, StandardObserver, XyzMethod, XyzOperator,
};
use lumifit::spectrum::Spectrum;
use serde::Deserialize;

#[derive(Deserialize)]
struct Fixture {
    colour_version: String,
    tolerance: Tolerance,
    spectra: Vec<FixtureSpectrum>,
    cases: Vec<Case>,
}

#[derive(Deserialize)]
struct Tolerance {
    relative: f64,
    absolute: f64,
}

#[derive(Deserialize)]
struct FixtureSpectrum {
    id: usize,
    wavelength_nm: Vec<f64>,
    value: Vec<f64>,
}

#[derive(Deserialize)]
struct Case {
    spectrum: usize,
    #[serde(default)]
    scale: Option<f64>,
    observer: String,
    illuminant: String,
    method: String,
    k: Option<f64>,
    xyz: [f64; 3],
}

fn load() -> Fixture {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("fixtures/sd_to_xyz.json");
    let text =
        std::fs::read_to_string(&p).expect("fixtures/sd_to_xyz.json is part of the repository");
    serde_json::from_str(&text).expect("fixture parses")
}

fn spectrum(f: &Fixture, case: &Case) -> Spectrum {
    let s = &f.spectra[case.spectrum];
    assert_eq!(s.id, case.spectrum);
    let scale = case.scale.unwrap_or(1.0);
    Spectrum::new(
        format!("fixture spectrum {}", s.id),
        s.wavelength_nm.clone(),
        s.value.iter().map(|v| v * scale).collect(),
    )
    .unwrap()
}

fn close(got: f64, want: f64, tol: &Tolerance) -> bool {
    (got - want).abs() <= tol.absolute.max(tol.relative * want.abs())
}

#[test]
fn sd_to_xyz_matches_colour_for_every_fixture_case() {
    let f = load();
    let mut worst = 0.0f64;
    let mut failures = Vec::new();
    for (i, case) in f.cases.iter().enumerate() {
        let obs = Observer::standard(StandardObserver::from_name(&case.observer).unwrap()).unwrap();
        let ill = Illuminant::standard(&case.illuminant).unwrap();
        let method = XyzMethod::from_name(&case.method).unwrap();
        let sd = spectrum(&f, case);
        let got = sd_to_xyz(&sd, obs, &ill, method, case.k).unwrap();
        for c in 0..3 {
            let want = case.xyz[c];
            let rel = (got.xyz[c] - want).abs() / want.abs().max(1e-300);
            if want.abs() > 1e-6 {
                worst = worst.max(rel);
            }
            if !close(got.xyz[c], want, &f.tolerance) {
                failures.push(format!(
                    "case {i}: spectrum {} ({} samples from {} nm), {} / {} / {}: component {c} = {} but colour {} gives {}",
                    case.spectrum,
                    sd.len(),
                    sd.wavelengths()[0],
                    case.observer,
                    case.illuminant,
                    case.method,
                    got.xyz[c],
                    f.colour_version,
                    want
                ));
            }
        }
    }
    assert!(
        failures.is_empty(),
        "{} of {} components disagree with colour:\n{}",
        failures.len(),
        f.cases.len() * 3,
        failures
            .iter()
            .take(20)
            .cloned()
            .collect::<Vec<_>>()
            .join("\n")
    );
    eprintln!(
        "sd_to_xyz: {} cases, worst relative difference {worst:.2e}",
        f.cases.len()
    );
}

#[test]
fn the_fixture_covers_the_required_grid_of_cases() {
    let f = load();
    let mut intervals = std::collections::BTreeSet::new();
    for s in &f.spectra {
        let d = s.wavelength_nm[1] - s.wavelength_nm[0];
        intervals.insert(d as i64);
    }
    for want in [1, 5, 10, 20] {
        assert!(
            intervals.contains(&want),
            "no {want} nm spectra in the fixture"
        );
    }
    for ill in ["A", "D65", "FL2", "LED-B3"] {
        for obs in ["cie1931-2", "cie1964-10", "cie2015-2"] {
            for m in ["astm-e308", "integration"] {
                let n = f
                    .cases
                    .iter()
                    .filter(|c| c.illuminant == ill && c.observer == obs && c.method == m)
                    .count();
                assert!(n >= 200, "{ill}/{obs}/{m}: only {n} cases");
            }
        }
    }
}

#[test]
fn the_xyz_operator_equals_the_direct_computation() {
    let f = load();
    let obs = Observer::standard(StandardObserver::Cie1931_2).unwrap();
    let ill = Illuminant::standard("D65").unwrap();
    for s in f.spectra.iter().take(8) {
        let sd = Spectrum::new("s", s.wavelength_nm.clone(), s.value.clone()).unwrap();
        for method in [XyzMethod::AstmE308, XyzMethod::Integration] {
            let op = XyzOperator::new(sd.wavelengths(), obs, &ill, method, None).unwrap();
            let a = op.apply(sd.values()).unwrap();
            let b = sd_to_xyz(&sd, obs, &ill, method, None).unwrap().xyz;
            for c in 0..3 {
                assert!(
                    (a[c] - b[c]).abs() <= 1e-10 * b[c].abs().max(1.0),
                    "{method:?} {a:?} vs {b:?}"
                );
            }
        }
    }
}

#[test]
fn astm_e308_rejects_intervals_it_does_not_define() {
    let w: Vec<f64> = (0..60).map(|i| 400.0 + 3.0 * i as f64).collect();
    let sd = Spectrum::new("three-nm.csv", w, vec![0.5; 60]).unwrap();
    let obs = Observer::standard(StandardObserver::Cie1931_2).unwrap();
    let ill = Illuminant::standard("D65").unwrap();
    let e = sd_to_xyz(&sd, obs, &ill, XyzMethod::AstmE308, None)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("three-nm.csv") && e.contains("1, 5, 10 or 20"),
        "{e}"
    );
    // Integration accepts any grid.
    assert!(sd_to_xyz(&sd, obs, &ill, XyzMethod::Integration, None).is_ok());
}

#[test]
fn observers_cannot_be_mixed() {
    let ill = Illuminant::standard("D65").unwrap();
    let grid: Vec<f64> = (0..41).map(|i| 380.0 + 10.0 * i as f64).collect();
    let sd = Spectrum::new("flat", grid.clone(), vec![0.4; 41]).unwrap();
    let o2 = Observer::standard(StandardObserver::Cie1931_2).unwrap();
    let o10 = Observer::standard(StandardObserver::Cie1964_10).unwrap();
    let white10 =
        lumifit::colorimetry::illuminant_white(o10, &ill, XyzMethod::AstmE308, &grid, None)
            .unwrap();
    let t2 = sd_to_xyz(&sd, o2, &ill, XyzMethod::AstmE308, None).unwrap();
    let e = t2.lab_relative_to(&white10).unwrap_err().to_string();
    assert!(
        e.contains("observer mismatch") && e.contains("cie1931-2") && e.contains("cie1964-10"),
        "{e}"
    );
}

#[test]
fn a_perfect_reflector_has_y_100_under_every_illuminant() {
    let obs = Observer::standard(StandardObserver::Cie1964_10).unwrap();
    for name in ["A", "D65", "FL11", "HP3", "LED-B5"] {
        let ill = Illuminant::standard(name).unwrap();
        for step in [1.0, 5.0, 10.0, 20.0] {
            let grid: Vec<f64> = (0..)
                .map(|i| 400.0 + step * i as f64)
                .take_while(|&w| w <= 700.0)
                .collect();
            for method in [XyzMethod::AstmE308, XyzMethod::Integration] {
                let w =
                    lumifit::colorimetry::illuminant_white(obs, &ill, method, &grid, None).unwrap();
                assert!(
                    (w.xyz[1] - 100.0).abs() < 1e-9,
                    "{name} {step} nm {method:?}: {:?}",
                    w.xyz
                );
            }
        }
    }
}

#[test]
fn a_flat_reflector_is_neutral_relative_to_the_white_on_its_grid() {
    let obs = Observer::standard(StandardObserver::Cie1931_2).unwrap();
    let ill = Illuminant::standard("A").unwrap();
    let grid: Vec<f64> = (0..41).map(|i| 380.0 + 10.0 * i as f64).collect();
    let sd = Spectrum::new("flat", grid.clone(), vec![0.4; 41]).unwrap();
    let white = lumifit::colorimetry::illuminant_white(obs, &ill, XyzMethod::AstmE308, &grid, None)
        .unwrap();
    let lab = sd_to_xyz(&sd, obs, &ill, XyzMethod::AstmE308, None)
        .unwrap()
        .lab_relative_to(&white)
        .unwrap();
    assert!(lab[1].abs() < 1e-9 && lab[2].abs() < 1e-9, "{lab:?}");
}
