//! Issue 12: a mercury lamp's unresolved pairs (404.7/407.8 and 577.0/579.1 nm) with free
//! amplitudes can put their blobs anywhere within their span, so only 435.8 and 546.1 nm fix the
//! map and 700 nm is extrapolated from them. A prior on each pair's split around the lamp table's
//! ratio (`FitOptions::split_prior_tau`, default `SPLIT_PRIOR_TAU`) narrows that — also when the
//! lamp splits its pairs otherwise than the table. Geometry of issue 12
//! (`tests/common/lvf_geometry.rs`); Canon 5D Mark II of the Jiang et al. 2013 database, read in
//! place (skip message when absent, failure when `LUMIFIT_REQUIRE_DATA=1`); 10 % flat continuum,
//! quadratic vignetting 0.3, 1 % noise, seeds 1–4.

use lumifit::lvf::synth::{ContinuumShape, VignettingShape};
use lumifit::lvf::{
    calibrate_whole_profile, extract_profile, render_lvf, Axis, FitOptions, Lamp, LampLine,
    LvfCalibration, SPLIT_PRIOR_TAU,
};
mod common;
use common::jiang::camera;
use common::lvf_geometry::spec;
use common::tolerances::lvf_split_prior::*;

const SEEDS: [u64; 4] = [1, 2, 3, 4];

/// Root mean square of the error at 700 nm over [`SEEDS`] of the Canon image of `render`,
/// calibrated with `--lamp hg` and split-prior width `tau`; the last calibration.
fn rms_700(db: &[u8], render: &Lamp, tau: f64) -> (f64, LvfCalibration) {
    let mut sum = 0.0;
    let mut last = None;
    for seed in SEEDS {
        let s = spec(
            render.clone(),
            camera(db, "Canon 5DMarkII"),
            0.01,
            (VignettingShape::Quadratic, 0.3),
            Some((ContinuumShape::Flat, 0.10)),
            seed,
        );
        let (frame, truth) = render_lvf(&s).unwrap();
        let profile = extract_profile(&frame, [0, 0, s.width, s.height], Axis::X).unwrap();
        let opts = FitOptions {
            split_prior_tau: tau,
            ..FitOptions::default()
        };
        let cal = calibrate_whole_profile(&profile, &Lamp::mercury(), &opts).unwrap();
        let e = cal.map.eval(truth.px_at_700) - 700.0;
        eprintln!("{} τ {tau} seed {seed}: {e:+.3} nm at 700", render.name);
        sum += e * e;
        last = Some(cal);
    }
    ((sum / SEEDS.len() as f64).sqrt(), last.unwrap())
}

#[test]
fn the_split_prior_narrows_the_map_also_when_the_lamp_splits_otherwise() {
    let Some(db) = common::jiang::database("the split-prior checks") else {
        return;
    };
    // the table's own splits, and a lamp that splits 5 : 1 and 2 : 3 instead of 10 : 1 and 20 : 22
    let mut other = Lamp::mercury();
    other.name = "hg, other splits".into();
    for l in other.lines.iter_mut() {
        let LampLine { nm, relative_power } = l;
        if (*nm - 407.783).abs() < 1e-6 {
            *relative_power = 0.08;
        }
        if (*nm - 579.066).abs() < 1e-6 {
            *relative_power = 0.30;
        }
    }
    for render in [Lamp::mercury(), other] {
        let (free, _) = rms_700(&db, &render, 0.0);
        let (prior, cal) = rms_700(&db, &render, SPLIT_PRIOR_TAU);
        eprintln!(
            "{}: rms at 700 nm free {free:.3}, with the prior {prior:.3}",
            render.name
        );
        assert!(prior <= PRIOR_RMS_700_NM, "{}: {prior}", render.name);
        assert!(
            prior <= GAIN * free,
            "{}: {prior} against {free}",
            render.name
        );
        let pairs = cal.diagnostics["split_prior"]["pairs"].as_array().unwrap();
        assert_eq!(pairs.len(), 2, "{}", cal.diagnostics["split_prior"]);
    }
}

/// Only a mercury lamp's pairs get the prior: a CFL's table is a published figure's peak labels,
/// not line powers (docs/capture.md), and `split_prior_tau` 0 frees the pairs.
#[test]
fn the_split_prior_is_for_mercury_tables_only_and_zero_frees_the_pairs() {
    let Some(db) = common::jiang::database("the split-prior checks") else {
        return;
    };
    let calibrated = |lamp: Lamp, continuum: ContinuumShape, tau: f64| {
        let s = spec(
            lamp.clone(),
            camera(&db, "Canon 5DMarkII"),
            0.01,
            (VignettingShape::Quadratic, 0.3),
            Some((continuum, 0.10)),
            1,
        );
        let (frame, _) = render_lvf(&s).unwrap();
        let profile = extract_profile(&frame, [0, 0, s.width, s.height], Axis::X).unwrap();
        let opts = FitOptions {
            split_prior_tau: tau,
            ..FitOptions::default()
        };
        calibrate_whole_profile(&profile, &lamp, &opts).unwrap()
    };
    let cal = calibrated(Lamp::cfl(), ContinuumShape::Cfl, SPLIT_PRIOR_TAU);
    assert!(cal.diagnostics.get("split_prior").is_none());
    let cal = calibrated(Lamp::mercury(), ContinuumShape::Flat, 0.0);
    assert!(cal.diagnostics.get("split_prior").is_none());
}
