//! `lumifit lvf calibrate`: a lamp photo (and optionally a flat-field photo and the camera's
//! sensitivities) becomes an [`LvfCalibration`] and the `lvf.json` that records it: the photo is
//! read through `io`, the ROI read along the filter's slant with dust repaired
//! ([`prepare_profile`]), the flat's fall-off built ([`FlatField`]) and the profile fitted
//! ([`calibrate_whole_profile`], [`calibrate_with_flat`] or [`calibrate_peaks`]).

use std::path::{Path, PathBuf};

use crate::error::{Error, Result};
use crate::io::camera::{camera_file, read_camera, read_camera_database, Camera};
use crate::io::series::read_frame;
use crate::io::sources::{file_of, resolve_lamp, resolve_passband};
use crate::limits::check_count;
use crate::lvf::flat::{calibrate_with_flat, FlatField, FlatSpectrum};
use crate::lvf::line_colour::MISFIT_NEAR;
use crate::lvf::{
    calibrate_peaks, calibrate_whole_profile, prepare_profile, Axis, CameraResponse, FitOptions,
    LvfCalibration, Passband, TiltChoice,
};

/// Most bands between 400 and 700 nm: one per nm (an LVF passband is tens of nm wide, so more
/// bands only repeat the same light).
pub const MAX_BANDS: usize = 300;

/// How the profile is calibrated.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CalibrationMethod {
    /// The whole-profile fit (default).
    WholeProfile,
    /// Naive peak picking and a straight line (the baseline).
    Peaks,
}

/// The files and reading choices of `lvf calibrate`.
#[derive(Debug, Clone)]
pub struct CalibrateInputs {
    /// The lamp photo (RAW, PNG, TIFF, EXR).
    pub image: PathBuf,
    /// ROI `[x, y, w, h]` in the photo's own pixels; `None`: the whole photo.
    pub roi: Option<[usize; 4]>,
    /// Filter axis.
    pub axis: Axis,
    /// Lamp: `hg`, `cfl`, … or a CSV `wavelength_nm[,relative_power]`.
    pub lamp: String,
    /// Passband shape: `gaussian`, `gennorm` (exponent chosen by BIC), `gennorm:BETA` or a CSV.
    pub passband: String,
    /// Camera sensitivities (CSV, `DATABASE:NAME` or Academy JSON).
    pub camera: Option<PathBuf>,
    /// A camera database (`camera,wavelength_nm,r,g,b` or Jiang et al.'s text) whose camera the
    /// lamp lines' colours pick when `camera` is not given ([`pick_database_camera`]).
    pub camera_database: Option<PathBuf>,
    /// Flat-field photo through the LVF.
    pub flat: Option<PathBuf>,
    /// Spectrum of the flat's source (`flat`, `blackbody:K`, `cfl`); needs `camera`.
    pub flat_spectrum: Option<String>,
    /// How the ROI is read across the axis.
    pub tilt: TiltChoice,
    /// Replace local dark patches of single strips (dust) in the profile.
    pub repair_dust: bool,
}

impl CalibrateInputs {
    /// Every file the run reads: the photo, the lamp and passband when they are files, the flat,
    /// and the camera's file (for `DATABASE:NAME`, the database).
    pub fn files(&self) -> Vec<PathBuf> {
        let mut out = vec![self.image.clone()];
        out.extend(file_of(&self.lamp));
        out.extend(file_of(&self.passband));
        out.extend(self.flat.clone());
        out.extend(self.camera.iter().map(|c| camera_file(c)));
        out.extend(self.camera_database.clone());
        out
    }
}

/// A comma-separated option's values: at least one, each finite and within `range`.
fn check_list(
    flag: &str,
    values: &[f64],
    range: std::ops::RangeInclusive<f64>,
    expected: &str,
) -> Result<()> {
    if values.is_empty() || values.iter().any(|v| !(v.is_finite() && range.contains(v))) {
        return Err(Error::flag(
            flag,
            format!("{values:?}; expected one or more {expected}"),
        ));
    }
    Ok(())
}

/// Checks the options `lvf calibrate` takes from the user, naming each one's flag: the FWHM guess
/// (1–200 nm), the knot spacings and smoothness values, the σ hint and the number of bands.
///
/// # Errors
/// [`Error::Flag`] naming the flag and what was expected; [`Error::InvalidArgument`] for
/// `--bands` beyond [`MAX_BANDS`].
pub fn check_calibrate_options(opts: &FitOptions) -> Result<()> {
    if !(opts.fwhm_guess_nm.is_finite() && opts.fwhm_guess_nm > 1.0 && opts.fwhm_guess_nm < 200.0) {
        return Err(Error::flag(
            "--fwhm-guess",
            format!("{} nm; expected 1–200", opts.fwhm_guess_nm),
        ));
    }
    check_list(
        "--continuum-knots",
        &opts.continuum_knots_fwhm,
        0.8..=10.0,
        "spacings of 0.8–10 FWHM, e.g. 2.5,1.5",
    )?;
    check_list(
        "--shared-knots",
        &opts.shared_knots_fwhm,
        0.25..=10.0,
        "spacings of 0.25–10 FWHM, e.g. 0.35 or 1.5,1.0,0.75",
    )?;
    check_list(
        "--shared-smoothness",
        &opts.shared_smoothness,
        0.0..=10.0,
        "values of 0 (no penalty) to 10, e.g. 0.01,0.03",
    )?;
    if !(opts.sigma_hint_nm.is_finite() && opts.sigma_hint_nm > 0.0) {
        return Err(Error::flag(
            "--sigma-hint",
            format!(
                "{} nm; expected a positive accuracy in nm, e.g. 0.3",
                opts.sigma_hint_nm
            ),
        ));
    }
    if !(opts.split_prior_tau.is_finite() && (0.0..=5.0).contains(&opts.split_prior_tau)) {
        return Err(Error::flag(
            "--split-prior",
            format!(
                "{}; expected the prior's width in natural log units, 0 (splits free) to 5, e.g. 0.3",
                opts.split_prior_tau
            ),
        ));
    }
    check_count(
        "--bands",
        opts.n_bands,
        MAX_BANDS,
        "one band per nm from 400 to 700 nm",
    )
}

/// A lamp photo calibrated: the calibration, the `lvf.json` document (the calibration with the
/// reading's diagnostics and the fit's time) and the fit's wall time.
#[derive(Debug, Clone)]
pub struct LampCalibration {
    /// The calibration.
    pub calibration: LvfCalibration,
    /// `lvf.json`: [`LvfCalibration`] serialised, with `diagnostics.fit_seconds`, `.tilt` and
    /// `.occlusions` added.
    pub json: serde_json::Value,
    /// Wall time of the fit alone (s).
    pub seconds: f64,
}

/// Calibrates the LVF from `inputs`' lamp photo. `opts` gives the fit's options but for the
/// passband and the camera, which come from `inputs` (`opts.passband`,
/// `opts.passband_exponent_search` and `opts.camera` are replaced). Each warning and note is
/// handed to `notify` as it arises (`warning: …`, `note: …`), the photo's reader's first.
///
/// # Errors
/// Those of [`check_calibrate_options`]; the readers' (photo, flat, lamp, passband, camera)
/// naming the file; [`Error::Flag`] for `--flat-spectrum` without `--camera`, a bad
/// `--flat-spectrum` or `--flat` with the peaks method; the calibration's, in the context of
/// the photo's name.
pub fn calibrate_lamp(
    inputs: &CalibrateInputs,
    method: CalibrationMethod,
    mut opts: FitOptions,
    notify: &mut dyn FnMut(String),
) -> Result<LampCalibration> {
    check_calibrate_options(&opts)?;
    if inputs.flat.is_some() && method == CalibrationMethod::Peaks {
        return Err(Error::flag(
            "--flat",
            "works with --method whole-profile only (peak picking has no fall-off model)",
        ));
    }
    if inputs.flat_spectrum.is_some() && inputs.camera.is_none() {
        return Err(Error::flag(
            "--flat-spectrum",
            "needs --camera (the flat's spectrum is seen through the camera's sensitivities): give a CSV wavelength_nm,r,g,b or DATABASE:NAME",
        ));
    }
    if inputs.camera_database.is_some() && inputs.camera.is_some() {
        return Err(Error::flag(
            "--camera-database",
            "give --camera or --camera-database, not both: --camera names your camera's curves, --camera-database lets the lamp lines' colours pick a camera of the database",
        ));
    }
    if inputs.camera_database.is_some() && method == CalibrationMethod::Peaks {
        return Err(Error::flag(
            "--camera-database",
            "works with --method whole-profile only (peak picking fits no continuum)",
        ));
    }
    let database = inputs
        .camera_database
        .as_deref()
        .map(|p| read_camera_database(p).map(|cams| (p.display().to_string(), cams)))
        .transpose()?;
    let lamp = resolve_lamp(&inputs.lamp)?;
    opts.passband_exponent_search = inputs.passband.trim().eq_ignore_ascii_case("gennorm");
    opts.passband = if opts.passband_exponent_search {
        Passband::Gaussian
    } else {
        resolve_passband(&inputs.passband)?
    };
    let camera_table = inputs
        .camera
        .as_deref()
        .map(|p| read_camera(Some(p)))
        .transpose()?;
    opts.camera = camera_table
        .as_ref()
        .map(|cam| CameraResponse::from_curves(&cam.curves, &cam.source))
        .transpose()?;
    let image_name = inputs.image.display().to_string();
    let (frame, info) = read_frame(&inputs.image)?;
    for w in &info.warnings {
        notify(format!("warning: {w}"));
    }
    let roi = inputs.roi.unwrap_or_else(|| {
        let (w, h) = frame.source_size();
        [0, 0, w, h]
    });
    let prepared = prepare_profile(&frame, roi, inputs.axis, inputs.tilt, inputs.repair_dust)?;
    for o in prepared.occlusions.iter().flatten() {
        notify(format!(
            "note: {image_name}: {} (--keep-occlusions keeps it)",
            o.describe()
        ));
    }
    let profile = &prepared.profile;
    let flat = match &inputs.flat {
        None => None,
        Some(path) => {
            let spectrum = match (&inputs.flat_spectrum, &camera_table) {
                (Some(s), Some(cam)) => Some(FlatSpectrum::parse(s, &cam.curves, &cam.source)?),
                _ => None,
            };
            let (flat_frame, flat_info) = read_frame(path)?;
            for w in &flat_info.warnings {
                notify(format!("warning: {}: {w}", path.display()));
            }
            Some(FlatField::new(
                &flat_frame,
                frame.source_size(),
                roi,
                inputs.axis,
                profile.tilt.as_ref(),
                spectrum,
            )?)
        }
    };
    let t = std::time::Instant::now();
    let fit = |o: &FitOptions| {
        match (method, &flat) {
            (CalibrationMethod::WholeProfile, None) => calibrate_whole_profile(profile, &lamp, o),
            (CalibrationMethod::WholeProfile, Some(f)) => calibrate_with_flat(profile, &lamp, o, f),
            (CalibrationMethod::Peaks, _) => calibrate_peaks(profile, &lamp, o),
        }
        .map_err(|e| e.context(format!("calibrating {image_name}")))
    };
    let mut calibration = fit(&opts)?;
    let mut database_report = None;
    if let Some((name, cams)) = &database {
        let (c, report) = pick_database_camera(name, cams, calibration, &opts, &fit, notify)?;
        calibration = c;
        database_report = Some(report);
    }
    let seconds = t.elapsed().as_secs_f64();
    for w in &calibration.warnings {
        notify(format!("warning: {image_name}: {w}"));
    }
    let mut json = serde_json::to_value(&calibration)
        .map_err(|e| Error::message(format!("lvf.json of {image_name}: not serialisable: {e}")))?;
    json["diagnostics"]["fit_seconds"] = serde_json::json!(seconds);
    for (k, v) in prepared.diagnostics() {
        json["diagnostics"][k] = v;
    }
    if let Some(r) = database_report {
        json["diagnostics"]["camera_database"] = r;
    }
    Ok(LampCalibration {
        calibration,
        json,
        seconds,
    })
}

/// How many cameras of a `--camera-database`, the best by the colours of the lines fitted
/// without curves, are fitted with their curves ([`pick_database_camera`]).
pub const DATABASE_TRIES: usize = 3;

/// `--camera-database`: the camera whose curves the lamp lines' colours ask for, when the user
/// has none of their own. The lines fitted without curves (`without`) rank every camera of the
/// database by the median of the lines' own colour misfits
/// ([`crate::lvf::line_colour::LineColourCheck::median_line_misfit`]; the amplitude-weighted
/// misfit put the image's sibling 5th–15th of 27 on three D700 images under a flat continuum,
/// led by a few lines whose amplitude a channel's continuum had taken); the
/// [`DATABASE_TRIES`] best are fitted with their curves, and of those whose lines' colours then
/// match as closely as the image's own curves do (misfit ≤
/// [`crate::lvf::line_colour::MISFIT_NEAR`], not merely within `MISFIT_MAX`) the one with the
/// smallest misfit is kept, if its shared continuum spectrum was chosen (otherwise the curves
/// changed only the noise weights). None such: `without` is kept. Measured (docs/performance.md,
/// issue 12, `scripts/bench/lvf_camera_database.py`): curves in the near zone — the same model
/// measured elsewhere, a sibling — moved a CFL's 700 nm by 0.6–0.7 nm at 5 % noise where the fit
/// without curves was within 0.12 nm, so only a clean match is used. The database is consulted
/// only when the fit without curves misses the accuracy the user asked for (σ at 400 or 700 nm
/// over `opts.sigma_hint_nm`, `--sigma-hint`): a sibling's curves bias the map by 0.1–0.4 nm,
/// which is no gain where the fit without curves is already that good. A camera used is not the
/// image's, so the fit without curves counts in σ's model-choice systematic (the larger of the
/// two at 400 and 700 nm). The colours in a fit without curves are rough (each
/// channel's continuum trades with its lines: misfits 0.05–0.1 for cameras that pass at
/// ≤ 0.01 with curves), so they only rank, and the check with curves decides. Returns the
/// calibration kept and `diagnostics.camera_database`.
///
/// # Errors
/// Those of `fit`.
pub fn pick_database_camera(
    database: &str,
    cameras: &[(String, Camera)],
    without: LvfCalibration,
    opts: &FitOptions,
    fit: &dyn Fn(&FitOptions) -> Result<LvfCalibration>,
    notify: &mut dyn FnMut(String),
) -> Result<(LvfCalibration, serde_json::Value)> {
    let hint = opts.sigma_hint_nm;
    if without.sigma_nm_at_400.max(without.sigma_nm_at_700) <= hint {
        notify(format!(
            "note: --camera-database not consulted: the fit without curves has σ {:.3} / {:.3} nm at 400 / 700 nm, within --sigma-hint {hint} nm",
            without.sigma_nm_at_400, without.sigma_nm_at_700
        ));
        let report = serde_json::json!({
            "database": database,
            "cameras": cameras.len(),
            "consulted": false,
            "sigma_hint_nm": hint,
            "ranked": [],
            "tried": [],
            "chosen": null,
            "note": "not consulted: the fit without curves meets --sigma-hint at 400 and 700 nm",
        });
        return Ok((without, report));
    }
    let nm: Vec<f64> = without.lines.iter().map(|l| l.nm).collect();
    let amp: Vec<[f64; 3]> = without.lines.iter().map(|l| l.amplitude).collect();
    // (median line misfit, misfit, name, curves)
    let mut ranked: Vec<(f64, f64, &str, CameraResponse)> = Vec::new();
    for (name, cam) in cameras {
        // a table too short for the shared spectrum is no candidate
        let Ok(resp) = CameraResponse::from_curves(&cam.curves, &cam.source) else {
            continue;
        };
        if let Some(c) = crate::lvf::line_colour::check(&resp, &nm, &amp, without.fwhm_nm) {
            ranked.push((c.median_line_misfit(), c.misfit, name, resp));
        }
    }
    ranked.sort_by(|a, b| a.0.total_cmp(&b.0));
    let ranking: Vec<serde_json::Value> = ranked
        .iter()
        .take(2 * DATABASE_TRIES)
        .map(|(med, m, name, _)| {
            serde_json::json!({
                "camera": name,
                "median_line_misfit_without_curves": med,
                "misfit_without_curves": m,
            })
        })
        .collect();
    let n_try = ranked.len().min(DATABASE_TRIES);
    let mut tried = Vec::new();
    let mut best: Option<(f64, &str, LvfCalibration)> = None;
    for (k, (med0, m0, name, resp)) in ranked.iter().take(n_try).enumerate() {
        notify(format!(
            "note: --camera-database: fitting with the curves of '{name}' ({}/{n_try})",
            k + 1
        ));
        let mut o = opts.clone();
        o.camera = Some(resp.clone());
        let cal = fit(&o)?;
        let cc = &cal.diagnostics["camera_check"];
        let misfit = cc["misfit"].as_f64();
        let consistent = cc["consistent"].as_bool() == Some(true);
        let matches = consistent && misfit.is_some_and(|m| m <= MISFIT_NEAR);
        // curves that drew nothing (the shared spectrum not chosen) only changed the weights
        let shared = cal
            .background
            .as_ref()
            .is_some_and(|b| b.shared_spectrum.is_some());
        tried.push(serde_json::json!({
            "camera": name,
            "median_line_misfit_without_curves": med0,
            "misfit_without_curves": m0,
            "misfit": misfit,
            "consistent": consistent,
            "matches": matches,
            "shared_spectrum_chosen": shared,
        }));
        if let (true, true, Some(m)) = (matches, shared, misfit) {
            if best.as_ref().is_none_or(|b| m < b.0) {
                best = Some((m, name, cal));
            }
        }
    }
    let chosen = best.as_ref().map(|b| b.1.to_string());
    // the fit without curves at the chosen map's 400 / 700 nm positions, minus 400 / 700
    let without_at = best.as_ref().map(|(_, _, cal)| {
        [400.0, 700.0].map(|nm| {
            cal.map
                .inverse(nm)
                .map_or(0.0, |px| without.map.eval(px) - nm)
        })
    });
    let report = serde_json::json!({
        "database": database,
        "cameras": cameras.len(),
        "consulted": true,
        "sigma_hint_nm": hint,
        "without_curves_minus_chosen_nm_at_400_700": without_at,
        "ranked": ranking,
        "tried": tried,
        "chosen": chosen,
        "misfit_max": MISFIT_NEAR,
        "note": "no --camera: every camera of the database ranked by the median of the lamp lines' own colour misfits in the fit without curves (rough: each channel's continuum trades with its lines), the best few fitted with their curves, and of those whose lines' colours then match as closely as an image's own curves do (misfit <= misfit_max, diagnostics.camera_check) and whose shared continuum spectrum was chosen the smallest misfit kept; none such: the fit without curves. Consulted only when the fit without curves has σ over sigma_hint_nm at 400 or 700 nm. A database camera is not yours: where its curves differ from your camera's the map moves, so the fit without curves counts in the chosen map's model-choice systematic (without_curves_minus_chosen_nm_at_400_700)",
    });
    match best {
        Some((m, name, mut cal)) => {
            let d = without_at.unwrap_or([0.0; 2]);
            cal.sigma_systematic_nm_at_400 = cal.sigma_systematic_nm_at_400.max(d[0].abs());
            cal.sigma_systematic_nm_at_700 = cal.sigma_systematic_nm_at_700.max(d[1].abs());
            cal.combine_sigma();
            cal.warnings.insert(
                0,
                format!(
                    "no --camera: the lamp lines' colours match '{name}' of {database} best (misfit {m:.3} ≤ {:.3}); its curves draw the continuum spectrum shared by the three channels. A database camera is not yours: where its curves differ the map moves (a sibling's: 0.1–0.4 nm at 700 nm), so σ counts the fit without curves ({:+.3} / {:+.3} nm from this map at 400 / 700 nm); give your camera's own curves with --camera when you have them",
                    MISFIT_NEAR,
                    d[0],
                    d[1]
                ),
            );
            Ok((cal, report))
        }
        None => {
            let mut cal = without;
            let best_tried = ranked
                .first()
                .map_or("none".to_string(), |r| format!("'{}'", r.2));
            cal.warnings.insert(
                0,
                format!(
                    "--camera-database: no camera of {database} matches the lamp lines' colours with its curves to misfit {MISFIT_NEAR} and draws the continuum with them ({n_try} tried, the closest by colour {best_tried}; diagnostics.camera_database): calibrated without camera curves"
                ),
            );
            Ok((cal, report))
        }
    }
}

/// What `lvf calibrate` prints: the output's name, the method, map, FWHM, residuals, σ at 400 /
/// 700 nm, the background and fall-off chosen, the warnings and the fit's time.
pub fn calibration_summary(c: &LampCalibration, out: &Path) -> serde_json::Value {
    let cal = &c.calibration;
    serde_json::json!({
        "out": out.display().to_string(),
        "method": cal.method,
        "map": cal.map.coefficients,
        "fwhm_nm": cal.fwhm_nm,
        "rms_residual_nm": cal.rms_residual_nm,
        "sigma_nm_at_400": cal.sigma_nm_at_400,
        "sigma_nm_at_700": cal.sigma_nm_at_700,
        "rms_residual_relative": cal.rms_residual_relative,
        "background": cal.background.as_ref().map(|b| b.model.clone()),
        "falloff": cal.background.as_ref().map(|b| b.falloff_source.clone()),
        "warnings": cal.warnings,
        "fit_seconds": c.seconds,
    })
}
