//! Dispersion domain: refractiveindex.info formulas against the independent numpy evaluation
//! (`scripts/reference/dispersion_reference.py` → `fixtures/dispersion/reference.json`), the
//! catalogue n_d and V_d of the SCHOTT entries, Cauchy fits against numpy's lstsq, wavelength
//! samples against the numpy construction, and the water pitfall.
//!
//! Tests that read `../shared/data/ior` print a skip message when it is absent and fail when
//! `LUMIFIT_REQUIRE_DATA=1`.

use std::path::{Path, PathBuf};

use lumifit::colorimetry::rgb::RgbSpace;
use lumifit::colorimetry::{Illuminant, Observer, StandardObserver};
use lumifit::dispersion::blanchette2012::{slices_for, wavelength_samples};
use lumifit::dispersion::derived::derived_numbers;
use lumifit::dispersion::fit::{fit_auto, fit_model};
use lumifit::dispersion::formula::{eval, Formula, FormulaKind};
use lumifit::dispersion::source::observations;
use lumifit::dispersion::{AirVacuum, ModelKind, RefractiveIndex, Source};
use lumifit::io::refractive_index::read_rii_yaml;
use serde_json::Value;
mod common;
use common::tolerances::dispersion::*;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn reference() -> Value {
    let text = std::fs::read_to_string(root().join("fixtures/dispersion/reference.json")).expect(
        "fixtures/dispersion/reference.json (run scripts/reference/dispersion_reference.py)",
    );
    serde_json::from_str(&text).unwrap()
}

fn data_dir() -> Option<PathBuf> {
    let d = root().join("../shared/data/ior");
    if d.is_dir() {
        return Some(d);
    }
    if std::env::var("LUMIFIT_REQUIRE_DATA").as_deref() == Ok("1") {
        panic!("LUMIFIT_REQUIRE_DATA=1 but {} is missing", d.display());
    }
    eprintln!(
        "SKIPPED: {} is absent; the measured-data checks did not run",
        d.display()
    );
    None
}

fn floats(v: &Value) -> Vec<f64> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect()
}

fn formula_of(dir: &Path, file: &str) -> Formula {
    match read_rii_yaml(&dir.join(file)).unwrap().source {
        Source::Formula(f) => f,
        other => panic!("{file}: expected a formula, got {other:?}"),
    }
}

#[test]
fn every_formula_entry_agrees_with_numpy_to_1e_12() {
    let Some(dir) = data_dir() else { return };
    let r = reference();
    let entries = r["formulas"].as_array().unwrap();
    assert_eq!(entries.len(), 9, "the data folder has nine formula entries");
    let mut worst: f64 = 0.0;
    for e in entries {
        let file = e["file"].as_str().unwrap();
        let f = formula_of(&dir, file);
        assert_eq!(
            f.kind.number() as i64,
            e["type"].as_i64().unwrap(),
            "{file}"
        );
        for (l, n) in floats(&e["lambda_nm"]).iter().zip(floats(&e["n"])) {
            let d = (f.n_at(*l) - n).abs();
            worst = worst.max(d);
            assert!(
                d <= FORMULA_TOL,
                "{file} at {l} nm: {} vs numpy {n}",
                f.n_at(*l)
            );
        }
    }
    eprintln!("largest |n_lumifit − n_numpy| over the nine entries: {worst:e}");
}

#[test]
fn formula_types_3_to_9_agree_with_numpy_to_1e_12() {
    for e in reference()["synthetic"].as_array().unwrap() {
        let kind = FormulaKind::from_number(e["type"].as_u64().unwrap() as u32).unwrap();
        let c = floats(&e["coefficients"]);
        for (l, n) in floats(&e["lambda_nm"]).iter().zip(floats(&e["n"])) {
            let mine = eval(kind, &c, l * 1e-3);
            assert!(
                (mine - n).abs() <= FORMULA_TOL,
                "formula {kind:?} at {l} nm: {mine} vs {n}"
            );
        }
    }
}

/// Half a unit of the last printed digit of a catalogue number.
fn half_last_digit(printed: f64) -> f64 {
    let s = format!("{printed}");
    let decimals = s.split_once('.').map_or(0, |(_, d)| d.len());
    0.5 * 10f64.powi(-(decimals as i32))
}

#[test]
fn schott_n_d_and_v_d_agree_with_their_catalogue_values_to_the_printed_digits() {
    let Some(dir) = data_dir() else { return };
    let mut checked = 0;
    for file in [
        "schott_N-BK7.yml",
        "schott_N-SF11.yml",
        "schott_F2.yml",
        "schott_N-K5.yml",
        "schott_N-BAK4.yml",
        "schott_N-BAF10.yml",
    ] {
        let entry = read_rii_yaml(&dir.join(file)).unwrap();
        let (nd, vd) = (entry.catalogue_n_d.unwrap(), entry.catalogue_v_d.unwrap());
        let Source::Formula(f) = &entry.source else {
            panic!("{file}")
        };
        let d = derived_numbers(f, [380.0, 780.0]).unwrap();
        assert!(
            (d.n_d - nd).abs() <= half_last_digit(nd),
            "{file}: n_d {} vs {nd}",
            d.n_d
        );
        assert!(
            (d.abbe_number_d - vd).abs() <= half_last_digit(vd),
            "{file}: V_d {} vs {vd}",
            d.abbe_number_d
        );
        let code = entry.glass_code.unwrap();
        assert_eq!(&code[..6], d.glass_code, "{file}");
        checked += 1;
    }
    assert_eq!(checked, 6);
}

#[test]
fn cauchy_fits_agree_with_numpy_lstsq() {
    let Some(dir) = data_dir() else { return };
    for e in reference()["cauchy"].as_array().unwrap() {
        let file = e["file"].as_str().unwrap();
        let f = formula_of(&dir, file);
        let range = floats(&e["range_nm"]);
        let (obs, _) = observations(
            &Source::Formula(f),
            [range[0], range[1]],
            AirVacuum::AsGiven,
            file,
        )
        .unwrap();
        let kind = if e["terms"].as_u64() == Some(2) {
            ModelKind::Cauchy2
        } else {
            ModelKind::Cauchy3
        };
        let c = fit_model(&obs, kind).unwrap();
        for (a, b) in c
            .model
            .coefficients()
            .iter()
            .zip(floats(&e["coefficients"]))
        {
            assert!(
                (a - b).abs() <= LSTSQ_REL_TOL * b.abs().max(1e-6),
                "{file} {kind:?}: {a} vs {b}"
            );
        }
        let (rms, max) = (e["rms"].as_f64().unwrap(), e["max_abs"].as_f64().unwrap());
        assert!(
            (c.rms_residual - rms).abs() <= 1e-9 * rms + 1e-15,
            "{file}: rms {} vs {rms}",
            c.rms_residual
        );
        assert!(
            (c.max_abs_residual - max).abs() <= 1e-9 * max + 1e-15,
            "{file}: max {} vs {max}",
            c.max_abs_residual
        );
    }
}

#[test]
fn wavelength_samples_agree_with_numpy_and_sum_to_white() {
    let observer = Observer::standard(StandardObserver::Cie1931_2).unwrap();
    let e = Illuminant::standard("E").unwrap();
    for s in reference()["samples"].as_array().unwrap() {
        let space = RgbSpace::from_name(s["space"].as_str().unwrap()).unwrap();
        let slices = slices_for(observer, &e, &space, [380.0, 780.0]).unwrap();
        let n = s["n_samples"].as_u64().unwrap() as usize;
        let set = wavelength_samples(&slices, n).unwrap();
        let want = s["rgb"].as_array().unwrap();
        let mut total = [0.0; 3];
        for (i, sample) in set.samples.iter().enumerate() {
            let w = floats(&want[i]);
            for c in 0..3 {
                assert!(
                    (sample.rgb[c] - w[c]).abs() <= SAMPLES_TOL,
                    "{} N={n} #{i}: {:?} vs {w:?}",
                    space.key,
                    sample.rgb
                );
                assert!(sample.rgb[c] >= 0.0);
                total[c] += sample.rgb[c];
            }
        }
        for t in total {
            assert!(
                (t - 1.0).abs() <= 1e-14,
                "{} N={n}: sum {total:?}",
                space.key
            );
        }
    }
}

#[test]
fn water_daimon_formula_gives_v_d_55_8_and_the_hale_table_is_fitted_not_interpolated() {
    let Some(dir) = data_dir() else { return };
    let daimon = formula_of(&dir, "H2O_Daimon-20.0C.yml");
    let d = derived_numbers(&daimon, [380.0, 780.0]).unwrap();
    assert!(
        (d.abbe_number_d - 55.8).abs() < 0.5,
        "Daimon V_d {}",
        d.abbe_number_d
    );

    let hale = read_rii_yaml(&dir.join("H2O_Hale.yml")).unwrap();
    assert_eq!(hale.data_type, "tabulated nk");
    let (obs, covered) = observations(
        &hale.source,
        [380.0, 780.0],
        AirVacuum::AsGiven,
        "H2O_Hale.yml",
    )
    .unwrap();
    assert_eq!(
        obs.len(),
        16,
        "0.400–0.775 µm in 25 nm steps inside 380–780 nm: {covered:?}"
    );
    let report = fit_auto(&obs, &ModelKind::ALL, 1e-4, covered).unwrap();
    // Hale & Querry print n to three decimals: no model meets 1e-4 and the report says so.
    assert!(!report.tolerance_met);
    let best = report.best();
    let fitted = derived_numbers(&best.model, covered).unwrap();
    let sd = lumifit::dispersion::derived::abbe_number_std(
        &best.model,
        best.covariance.as_ref().unwrap(),
    )
    .unwrap();
    // Linear interpolation of the table (the pitfall) gives 73.0; the fit is a smooth model of
    // the same table. Both disagree with Daimon by far more than the fit's own uncertainty: the
    // Hale visible values lie up to 5e-3 below Daimon's in the blue (docs/dispersion.md), so the
    // table itself carries a different dispersion — it cannot give V_d within 0.5 of Daimon.
    let linear = {
        let (l, n) = (&obs.lambda_nm, &obs.n);
        let at = |x: f64| {
            let i = l.iter().position(|&v| v > x).unwrap();
            n[i - 1] + (n[i] - n[i - 1]) * (x - l[i - 1]) / (l[i] - l[i - 1])
        };
        (at(587.5618) - 1.0) / (at(486.1327) - at(656.2725))
    };
    assert!((linear - 73.0).abs() < 0.05, "linear V_d {linear}");
    eprintln!(
        "water V_d: Daimon {:.2}; Hale fitted ({}) {:.1} ± {:.1}; Hale linear {:.1}",
        d.abbe_number_d,
        best.kind.key(),
        fitted.abbe_number_d,
        sd,
        linear
    );
    assert!((fitted.abbe_number_d - d.abbe_number_d).abs() > 3.0 * sd);
}

#[test]
fn sellmeier3_fit_of_each_schott_glass_is_within_1e_6_of_its_formula() {
    let Some(dir) = data_dir() else { return };
    for file in ["schott_N-BK7.yml", "schott_N-SF11.yml", "schott_F2.yml"] {
        let f = formula_of(&dir, file);
        let (obs, _) = observations(
            &Source::Formula(f),
            [380.0, 780.0],
            AirVacuum::AsGiven,
            file,
        )
        .unwrap();
        let c = fit_model(&obs, ModelKind::Sellmeier3).unwrap();
        assert!(c.valid && c.max_abs_residual < 1e-6, "{file}: {c:?}");
    }
}

#[test]
fn air_to_vacuum_conversion_raises_n_by_the_air_index() {
    let Some(dir) = data_dir() else { return };
    let f = formula_of(&dir, "schott_N-BK7.yml");
    let src = Source::Formula(f.clone());
    let (rel, _) = observations(&src, [450.0, 700.0], AirVacuum::AsGiven, "bk7").unwrap();
    let (abs, _) = observations(&src, [450.0, 700.0], AirVacuum::AirToVacuum, "bk7").unwrap();
    // at the same nominal wavelength, n_abs(λ_vac) = n_rel(λ_air) · n_air ≈ n_rel + 4.2e-4
    let i = rel.lambda_nm.iter().position(|&l| l == 600.0).unwrap();
    let d = abs.n[i] - rel.n[i];
    assert!(d > 3.9e-4 && d < 4.5e-4, "{d}");
}

#[test]
fn measured_csv_with_std_gives_v_d_within_three_of_its_standard_deviations() {
    // N-BK7 from the bundled catalogue, sampled every 10 nm with a deterministic ±2e-5 pattern
    // (uniform on a fixed grid: mean 0, std 1.2e-5) as "measurement noise"; std column 1.2e-5.
    let bk7 = lumifit::dispersion::catalogue::glass("N-BK7")
        .unwrap()
        .formula;
    let truth = derived_numbers(&bk7, [380.0, 780.0]).unwrap().abbe_number_d;
    let mut csv = String::from("wavelength_nm,n,std\n");
    for (i, l) in (380..=780).step_by(10).enumerate() {
        let noise = 2e-5 * ((((i * 7919) % 41) as f64) / 20.0 - 1.0);
        csv.push_str(&format!("{l},{:.8},1.2e-5\n", bk7.n_at(l as f64) + noise));
    }
    let obs = lumifit::io::refractive_index::parse_n_csv(csv.as_bytes(), "bk7.csv").unwrap();
    assert!(obs.std.is_some() && obs.measured);
    let (obs, covered) = observations(
        &Source::Table(obs),
        [380.0, 780.0],
        AirVacuum::AsGiven,
        "bk7.csv",
    )
    .unwrap();
    let report = fit_auto(&obs, &ModelKind::ALL, 1e-4, covered).unwrap();
    let best = report.best();
    assert!(report.tolerance_met, "{:?}", best);
    let vd = derived_numbers(&best.model, covered).unwrap().abbe_number_d;
    let cov = best
        .covariance
        .as_ref()
        .unwrap_or_else(|| panic!("no covariance: {best:?}"));
    let sd = lumifit::dispersion::derived::abbe_number_std(&best.model, cov).unwrap();
    assert!(sd > 0.0 && sd < 1.0, "σ(V_d) {sd}");
    assert!((vd - truth).abs() <= 3.0 * sd, "V_d {vd} ± {sd} vs {truth}");
}
