//! `lumifit lvf calibrate`: LVF position → wavelength map from a lamp photo.

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::{Args, Subcommand, ValueEnum};
use lumifit::io::camera::read_camera;
use lumifit::io::series::read_frame;
use lumifit::io::sources::{file_of, resolve_lamp, resolve_passband};
use lumifit::io::Outputs;
use lumifit::lvf::fit::Direction;
use lumifit::lvf::flat::{calibrate_with_flat, FlatField, FlatSpectrum};
use lumifit::lvf::{
    calibrate_peaks, calibrate_whole_profile, Axis, BackgroundChoice, FitOptions, MapChoice,
};

use super::emit;

/// Subcommands (LVF calibration).
#[derive(Debug, Subcommand)]
pub enum LvfCommand {
    /// Calibrate the position → wavelength map from a photo of a lamp through the LVF.
    Calibrate(CalibrateArgs),
    /// Solve each band's transmission from photos of a grey target through the LVF and colour gels.
    Transmission(super::lvf_transmission::TransmissionArgs),
}

/// Filter axis.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum AxisArg {
    /// Wavelength varies along columns.
    X,
    /// Wavelength varies along rows.
    Y,
}

/// Calibration method.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum MethodArg {
    /// Fit the whole profile (default).
    WholeProfile,
    /// Naive peak picking + straight line (baseline).
    Peaks,
}

/// Map degree.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum MapArg {
    /// Linear.
    Linear,
    /// Quadratic (the background chosen among the quadratic-map fits).
    Quadratic,
    /// Chosen with the background by BIC over both degrees; quadratic only if it also passes the
    /// F-test (p < 0.001) and |a2| > 3σ against the same background with a linear map; a map of
    /// the other degree within ΔBIC 10 widens σ. For an LVF that may not be linear.
    Auto,
}

/// Direction of the wavelength gradient.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum DirectionArg {
    /// From the colour channels.
    Auto,
    /// λ increases with px.
    Increasing,
    /// λ decreases with px.
    Decreasing,
}

/// `lvf calibrate`.
#[derive(Debug, Args)]
pub struct CalibrateArgs {
    /// Lamp photo (RAW, PNG, TIFF, EXR).
    pub image: PathBuf,
    /// ROI x,y,w,h in the image's own pixels (for RAW: the full-resolution image); default the
    /// whole image.
    #[arg(long)]
    pub roi: Option<String>,
    /// Filter axis: x (along columns) or y (along rows).
    #[arg(long, value_enum)]
    pub axis: AxisArg,
    /// Lamp: hg, cfl, or a CSV wavelength_nm[,relative_power].
    #[arg(long, default_value = "hg")]
    pub lamp: String,
    /// Number of bands from 400 to 700 nm.
    #[arg(long, default_value_t = 31)]
    pub bands: usize,
    /// Output JSON.
    #[arg(long)]
    pub out: PathBuf,
    /// PNG plot of profile, model, lines and residuals.
    #[arg(long)]
    pub plot: Option<PathBuf>,
    /// Method.
    #[arg(long, value_enum, default_value = "whole-profile")]
    pub method: MethodArg,
    /// Map degree: linear (the paper's LVF), quadratic, or auto (for a filter that may not be
    /// linear; about twice the fitting time).
    #[arg(long, value_enum, default_value = "linear")]
    pub map: MapArg,
    /// Passband shape: `gaussian`; `gennorm` (a generalised normal exp(−ln2·|2Δλ/FWHM|^β),
    /// the exponent β chosen by BIC over 1.25–6, about nine times the fitting time; for a filter
    /// whose passband is not known to be Gaussian); `gennorm:BETA` (β given); or a CSV
    /// offset_nm,transmission (a measured shape). lvf.json reports it under `passband`
    #[arg(long, default_value = "gaussian")]
    pub passband: String,
    /// Starting FWHM of the passband (nm); also the assumed FWHM of the peaks method.
    #[arg(long, default_value_t = 25.0)]
    pub fwhm_guess: f64,
    /// Which way wavelength runs along the axis.
    #[arg(long, value_enum, default_value = "auto")]
    pub direction: DirectionArg,
    /// Terms under and over the lines: auto (chosen by BIC), linear (offset b + s·u only),
    /// continuum, falloff, continuum+falloff (a quadratic fall-off).
    #[arg(long, value_enum, default_value = "auto")]
    pub background: BackgroundArg,
    /// Do not estimate and divide out a radial fall-off from the ROI's strips across the axis.
    #[arg(long)]
    pub no_radial_falloff: bool,
    /// The slant of the filter's iso-wavelength lines in the image: auto (measured from the
    /// ROI's strips across the axis and followed when significant: > 5σ and a shift of ≥ 0.25 px
    /// at the ROI's edge), off (average along the rows, or columns for --axis y), or the angle in
    /// degrees as lvf.json's tilt.degrees reports it. lvf.json records the slant followed, and
    /// the commands that read captures through lvf.json follow it too.
    #[arg(long, default_value = "auto", value_name = "auto|off|DEGREES")]
    pub tilt: String,
    /// Keep local dark patches of single strips across the axis (dust shadows, defects) in the
    /// profile; by default each is replaced by that strip's prediction from the other strips
    /// and listed in lvf.json (diagnostics.occlusions), and `spectrum recover` / `lvf
    /// transmission` replace the same patches in the captures.
    #[arg(long)]
    pub keep_occlusions: bool,
    /// Weight each profile sample by its noise estimated from the profile (read + shot noise,
    /// `diagnostics.noise_model` in lvf.json): auto weights when --camera is given (the shared
    /// continuum spectrum can follow the continuum; the models without the camera are biased
    /// under a CFL and weighting the dim flanks amplifies that), on, or off.
    #[arg(long, value_enum, default_value = "auto")]
    pub weights: WeightsArg,
    /// Knot spacings of the continuum candidates in units of the FWHM, coarsest first
    /// (0.8–10 each; the first is also the one `--background continuum` uses).
    #[arg(long, value_delimiter = ',', default_value = "2.5,1.5,1.0")]
    pub continuum_knots: Vec<f64>,
    /// With --camera: knot spacings of the continuum spectrum shared by the three channels, in
    /// units of the FWHM (0.25–10 each), each smoothed by a roughness penalty that grows with
    /// the noise; with several, BIC and then the focused criterion choose.
    #[arg(long, value_delimiter = ',', default_value = "0.35")]
    pub shared_knots: Vec<f64>,
    /// With --camera: prior roughness values of the shared spectrum's candidates (0–10 each) —
    /// its second differences at the knots are taken as about this fraction of its RMS, so the
    /// penalty grows with the noise; BIC and then the focused criterion choose; 0: no penalty
    /// (the knot spacing alone limits the spectrum).
    #[arg(long, value_delimiter = ',', default_value = "0.01,0.03")]
    pub shared_smoothness: Vec<f64>,
    /// The accuracy you need at 400 and 700 nm (nm, > 0): without --camera, a continuum model
    /// whose σ there exceeds it draws a warning with σ's parts and what would narrow it.
    #[arg(long, default_value_t = lumifit::lvf::CONTINUUM_SIGMA_HINT_NM)]
    pub sigma_hint: f64,
    /// Flat-field photo through the LVF (broadband source, same size and framing): its smooth
    /// fall-off is divided out instead of the one modelled from the lamp photo.
    #[arg(long)]
    pub flat: Option<PathBuf>,
    /// Spectrum of the flat's source (flat, blackbody:K, cfl); with --camera the fall-off along
    /// the axis is solved too, without only its variation across the axis is used.
    #[arg(long, requires = "flat")]
    pub flat_spectrum: Option<String>,
    /// The camera's sensitivities (CSV wavelength_nm,r,g,b, DB:NAME of the Jiang
    /// database (long CSV or its camspec_database.txt), or Academy spectral-data JSON as in rawtoaces-data): adds a continuum spectrum shared by the three channels to the candidates
    /// (the image must be linear raw, channels as in the table), and is the camera
    /// --flat-spectrum is seen through. Give the image's own camera: σ assumes its curves, and
    /// at 5 % noise another camera's curves can move the map by ≈ 1 nm without raising σ (at
    /// 1 % BIC rejects them; a camera with the same sensor calibrates as well).
    #[arg(long)]
    pub camera: Option<PathBuf>,
}

/// Noise weights of the whole-profile fit.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum WeightsArg {
    /// Weighted when --camera is given.
    Auto,
    /// Always weighted.
    On,
    /// Never weighted.
    Off,
}

/// Background terms of the whole-profile fit.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum BackgroundArg {
    /// Chosen by BIC: offset only, or offset + continuum (the radial fall-off estimated across
    /// the axis is applied to both).
    Auto,
    /// Offset b + s·u only.
    Linear,
    /// Offset + non-negative B-spline continuum.
    Continuum,
    /// Offset + a fitted quadratic fall-off along the axis (poorly determined: along the axis
    /// a fall-off is nearly a shift of the map).
    Falloff,
    /// Offset + continuum + fitted quadratic fall-off (see falloff).
    #[value(name = "continuum+falloff")]
    ContinuumFalloff,
}

/// Runs one of these subcommands.
pub fn run(cmd: LvfCommand) -> Result<()> {
    match cmd {
        LvfCommand::Calibrate(a) => calibrate(&a),
        LvfCommand::Transmission(a) => super::lvf_transmission::run(&a),
    }
}

/// Most bands between 400 and 700 nm: one per nm (an LVF passband is tens of nm wide, so more
/// bands only repeat the same light).
const MAX_BANDS: usize = 300;

fn fixed(continuum: bool, falloff_degree: usize) -> BackgroundChoice {
    BackgroundChoice::Fixed {
        continuum,
        falloff_degree,
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
        anyhow::bail!("{flag}: {values:?}; expected one or more {expected}");
    }
    Ok(())
}

fn calibrate(a: &CalibrateArgs) -> Result<()> {
    if !(a.fwhm_guess.is_finite() && a.fwhm_guess > 1.0 && a.fwhm_guess < 200.0) {
        anyhow::bail!("--fwhm-guess: {} nm; expected 1–200", a.fwhm_guess);
    }
    check_list(
        "--continuum-knots",
        &a.continuum_knots,
        0.8..=10.0,
        "spacings of 0.8–10 FWHM, e.g. 2.5,1.5",
    )?;
    check_list(
        "--shared-knots",
        &a.shared_knots,
        0.25..=10.0,
        "spacings of 0.25–10 FWHM, e.g. 0.35 or 1.5,1.0,0.75",
    )?;
    check_list(
        "--shared-smoothness",
        &a.shared_smoothness,
        0.0..=10.0,
        "values of 0 (no penalty) to 10, e.g. 0.01,0.03",
    )?;
    if !(a.sigma_hint.is_finite() && a.sigma_hint > 0.0) {
        anyhow::bail!(
            "--sigma-hint: {} nm; expected a positive accuracy in nm, e.g. 0.3",
            a.sigma_hint
        );
    }
    lumifit::limits::check_count(
        "--bands",
        a.bands,
        MAX_BANDS,
        "one band per nm from 400 to 700 nm",
    )?;
    let mut out = Outputs::new();
    out.input(&a.image);
    out.inputs(file_of(&a.lamp));
    out.inputs(file_of(&a.passband));
    out.inputs(a.flat.clone());
    out.inputs(a.camera.iter().map(|c| super::synth_lvf::camera_file(c)));
    out.declare("--out", &a.out)?;
    if let Some(p) = &a.plot {
        out.declare("--plot", p)?;
    }
    let lamp = resolve_lamp(&a.lamp)?;
    let exponent_search = a.passband.eq_ignore_ascii_case("gennorm");
    let passband = if exponent_search {
        lumifit::lvf::Passband::Gaussian
    } else {
        resolve_passband(&a.passband)?
    };
    let camera_table = match &a.camera {
        Some(p) => Some(read_camera(Some(p))?),
        None => None,
    };
    let camera = match &camera_table {
        Some(cam) => Some(lumifit::lvf::CameraResponse::from_curves(
            &cam.curves,
            &cam.source,
        )?),
        None => None,
    };
    let (frame, info) = read_frame(&a.image)?;
    let roi = match &a.roi {
        Some(r) => super::parse_rect(r)?,
        None => {
            let (w, h) = frame.source_size();
            [0, 0, w, h]
        }
    };
    for w in &info.warnings {
        eprintln!("warning: {w}");
    }
    let axis = match a.axis {
        AxisArg::X => Axis::X,
        AxisArg::Y => Axis::Y,
    };
    let tilt: lumifit::lvf::TiltChoice = a.tilt.parse().map_err(|_| {
        anyhow::anyhow!(
            "--tilt {}: expected auto, off or an angle in degrees between -45 and 45",
            a.tilt.trim()
        )
    })?;
    let prepared = lumifit::lvf::prepare_profile(&frame, roi, axis, tilt, !a.keep_occlusions)?;
    for o in prepared.occlusions.iter().flatten() {
        eprintln!(
            "note: {}: {} (--keep-occlusions keeps it)",
            a.image.display(),
            o.describe()
        );
    }
    let profile = &prepared.profile;
    let flat = match &a.flat {
        None => None,
        Some(path) => {
            let spectrum = match (&a.flat_spectrum, &camera_table) {
                (None, _) => None,
                (Some(_), None) => anyhow::bail!(
                    "--flat-spectrum needs --camera (the flat's spectrum is seen through the camera's sensitivities): give a CSV wavelength_nm,r,g,b or DATABASE:NAME"
                ),
                (Some(s), Some(cam)) => Some(
                    FlatSpectrum::parse(s, &cam.curves, &cam.source)
                        .map_err(|e| anyhow::anyhow!("--flat-spectrum: {e}"))?,
                ),
            };
            let (flat_frame, flat_info) = read_frame(path)?;
            for w in &flat_info.warnings {
                eprintln!("warning: {}: {w}", path.display());
            }
            let f = FlatField::new(
                &flat_frame,
                frame.source_size(),
                roi,
                axis,
                profile.tilt.as_ref(),
                spectrum,
            )?;
            Some(f)
        }
    };
    let opts = FitOptions {
        map: match a.map {
            MapArg::Linear => MapChoice::Linear,
            MapArg::Quadratic => MapChoice::Quadratic,
            MapArg::Auto => MapChoice::Auto,
        },
        passband,
        fwhm_guess_nm: a.fwhm_guess,
        direction: match a.direction {
            DirectionArg::Auto => Direction::Auto,
            DirectionArg::Increasing => Direction::Increasing,
            DirectionArg::Decreasing => Direction::Decreasing,
        },
        n_bands: a.bands,
        background: match a.background {
            BackgroundArg::Auto => BackgroundChoice::Auto,
            BackgroundArg::Linear => fixed(false, 0),
            BackgroundArg::Continuum => fixed(true, 0),
            BackgroundArg::Falloff => fixed(false, 2),
            BackgroundArg::ContinuumFalloff => fixed(true, 2),
        },
        radial_falloff: !a.no_radial_falloff,
        noise_weights: match a.weights {
            WeightsArg::Auto => None,
            WeightsArg::On => Some(true),
            WeightsArg::Off => Some(false),
        },
        continuum_knots_fwhm: a.continuum_knots.clone(),
        shared_knots_fwhm: a.shared_knots.clone(),
        shared_smoothness: a.shared_smoothness.clone(),
        sigma_hint_nm: a.sigma_hint,
        passband_exponent_search: exponent_search,
        camera,
        fixed_falloff: None,
        ..FitOptions::default()
    };
    let t = std::time::Instant::now();
    let cal = match (a.method, &flat) {
        (MethodArg::WholeProfile, None) => calibrate_whole_profile(profile, &lamp, &opts),
        (MethodArg::WholeProfile, Some(f)) => calibrate_with_flat(profile, &lamp, &opts, f),
        (MethodArg::Peaks, None) => calibrate_peaks(profile, &lamp, &opts),
        (MethodArg::Peaks, Some(_)) => {
            anyhow::bail!("--flat works with --method whole-profile only (peak picking has no fall-off model)")
        }
    }
    .with_context(|| format!("calibrating {}", a.image.display()))?;
    let seconds = t.elapsed().as_secs_f64();
    for w in &cal.warnings {
        eprintln!("warning: {}: {w}", a.image.display());
    }
    let mut json = serde_json::to_value(&cal)?;
    json["diagnostics"]["fit_seconds"] = serde_json::json!(seconds);
    for (k, v) in prepared.diagnostics() {
        json["diagnostics"][k] = v;
    }
    out.stage(&a.out, serde_json::to_string_pretty(&json)?.as_bytes())?;
    if let Some(p) = &a.plot {
        out.stage(p, &lumifit::plot::lvf_chart_png(&cal)?)?;
    }
    out.commit()?;
    emit(&serde_json::to_string_pretty(&serde_json::json!({
        "out": a.out.display().to_string(),
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
        "fit_seconds": seconds,
    }))?)
}
