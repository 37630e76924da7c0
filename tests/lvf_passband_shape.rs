//! The LVF's passband shape. An interference filter's passband is rarely Gaussian; taken as one,
//! a generalised-normal passband exp(−ln2·|2Δλ/FWHM|^β) of β = 2.5 left structure the
//! per-channel continuum took up, and the map was 1.7 nm off at 700 nm on a lamp image with a
//! continuum (8 nm without one). `lvf calibrate --passband gennorm` fits β; with the default
//! Gaussian a profile that keeps structure is checked at β = 1.75 and 2.25, and a warning names
//! the shape. Geometry of docs/performance.md (1200×160 px, 372.3 nm + 0.3117 nm/px, FWHM 25 nm),
//! the project's default camera, 10 % flat continuum, quadratic fall-off 0.3, 1 % noise.

use lumifit::lvf::synth::{default_camera, ContinuumShape, VignettingShape};
use lumifit::lvf::{render_lvf, FitOptions, Lamp, LvfCalibration, LvfSynthSpec, Passband};

mod common;
use common::lvf_geometry::calibrated;

/// The issue-12 geometry with `passband`: Hg, default camera, 10 % flat continuum, quadratic
/// fall-off 0.3, 1 % noise.
fn spec(passband: Passband, seed: u64) -> LvfSynthSpec {
    LvfSynthSpec {
        passband,
        ..common::lvf_geometry::spec(
            Lamp::mercury(),
            default_camera().unwrap(),
            0.01,
            (VignettingShape::Quadratic, 0.3),
            Some((ContinuumShape::Flat, 0.10)),
            seed,
        )
    }
}

fn fitted_shape() -> FitOptions {
    FitOptions {
        passband_exponent_search: true,
        ..FitOptions::default()
    }
}

fn shape_warning(cal: &LvfCalibration) -> Option<&String> {
    cal.warnings
        .iter()
        .find(|w| w.starts_with("the passband may not be Gaussian"))
}

#[test]
fn a_non_gaussian_passband_is_fitted_by_its_exponent_and_warned_of_when_taken_as_gaussian() {
    for (beta, seed) in [(2.5, 4), (1.6, 5)] {
        let s = spec(Passband::GenNormal { beta }, seed);
        let (gauss, eg) = calibrated(&s, &FitOptions::default());
        let (cal, e) = calibrated(&s, &fitted_shape());
        let fitted = cal.passband["beta"].as_f64().unwrap();
        eprintln!(
            "β {beta}: taken as Gaussian {:+.3} / {:+.3} nm (σ {:.3} / {:.3}), fitted β {fitted:.3}: {:+.3} / {:+.3} nm (σ {:.3} / {:.3}, {}); FWHM {:.2}",
            eg[0],
            eg[1],
            gauss.sigma_nm_at_400,
            gauss.sigma_nm_at_700,
            e[0],
            e[1],
            cal.sigma_nm_at_400,
            cal.sigma_nm_at_700,
            cal.background.as_ref().unwrap().model,
            cal.fwhm_nm
        );
        // taken as Gaussian: the map is off and the shape is named first among the warnings
        assert!(eg[0].abs().max(eg[1].abs()) > 0.3, "{eg:?}");
        assert_eq!(
            gauss.warnings.first(),
            shape_warning(&gauss),
            "{:?}",
            gauss.warnings
        );
        // fitted: the exponent, the FWHM and the map within the Hg bound
        assert_eq!(cal.passband["shape"], "gennorm");
        assert!((fitted - beta).abs() < 0.1, "β {fitted} for {beta}");
        assert!((cal.fwhm_nm - 25.0).abs() < 0.3, "{}", cal.fwhm_nm);
        assert!(e.iter().all(|x| x.abs() <= 0.15), "{e:?}");
        assert!(shape_warning(&cal).is_none());
        // every exponent tried is reported with its BIC
        assert!(cal.passband["exponent_search"].as_array().unwrap().len() >= 10);
    }
}

#[test]
fn a_gaussian_passband_is_found_gaussian_and_not_warned_of() {
    let s = spec(Passband::Gaussian, 6);
    let (gauss, eg) = calibrated(&s, &FitOptions::default());
    let (cal, e) = calibrated(&s, &fitted_shape());
    let fitted = cal.passband["beta"].as_f64().unwrap_or(2.0);
    eprintln!(
        "Gaussian: default {:+.3} / {:+.3} nm, fitted β {fitted:.3}: {:+.3} / {:+.3} nm",
        eg[0], eg[1], e[0], e[1]
    );
    assert_eq!(gauss.passband["shape"], "gaussian");
    assert!(shape_warning(&gauss).is_none(), "{:?}", gauss.warnings);
    assert!((fitted - 2.0).abs() < 0.1, "β {fitted}");
    assert!(e.iter().chain(&eg).all(|x| x.abs() <= 0.15), "{e:?} {eg:?}");
}

#[test]
fn the_synthetic_truth_records_the_passband_shape() {
    let (_, truth) = render_lvf(&spec(Passband::GenNormal { beta: 3.0 }, 1)).unwrap();
    assert_eq!(truth.passband["shape"], "gennorm");
    assert_eq!(truth.passband["beta"], 3.0);
}
