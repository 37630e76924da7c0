//! `lumifit lvf calibrate`: LVF position → wavelength map from a lamp photo.

use std::path::PathBuf;

use anyhow::Result;
use clap::{Args, Subcommand, ValueEnum};
use lumifit::io::Outputs;
use lumifit::lvf::fit::Direction;
use lumifit::lvf::{Axis, BackgroundChoice, FitOptions, MapChoice};
use lumifit::pipeline::acquisition::{
    calibrate_lamp, calibration_summary, CalibrateInputs, CalibrationMethod,
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
    /// Lamp: hg, hg-weak, cfl, or a CSV wavelength_nm[,relative_power]. A mercury table is
    /// checked against the NIST air wavelengths (a warning names each line more than 0.02 nm
    /// off: the profile cannot catch it).
    #[arg(long, default_value = "hg")]
    pub lamp: String,
    /// Width (1σ, natural log) of the prior on how a mercury lamp's unresolved pairs
    /// (404.7/407.8 and 577.0/579.1 nm) split their blob, around the lamp table's powers; 0
    /// frees the splits. Free, a pair can put its blob anywhere within its span and only 435.8
    /// and 546.1 nm fix the map. Not used with the shared continuum spectrum of --camera.
    #[arg(long, default_value_t = lumifit::lvf::SPLIT_PRIOR_TAU)]
    pub split_prior: f64,
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
    /// the exponent β chosen by BIC over 1.25–6, about seventeen times the fitting time; for a filter
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
    /// --flat-spectrum is seen through. Give the image's own camera: the lamp lines' colours
    /// judge the curves (diagnostics.camera_check), and curves more than 3 % off them are not
    /// used for the continuum (a warning names the lines); between 1.5 and 3 % σ counts the
    /// map without them (a close other camera, the Nikon D80's on a D700 image, or the same
    /// model measured elsewhere land there).
    #[arg(long)]
    pub camera: Option<PathBuf>,
    /// Without your camera's curves: a camera database (long CSV camera,wavelength_nm,r,g,b such
    /// as ../shared/data/camera/jiang2013_camspec_all_cameras_long.csv, or Jiang et al.'s
    /// camspec_database.txt). The lamp is fitted without curves; only when that fit's σ at 400
    /// or 700 nm exceeds --sigma-hint, the database's cameras are ranked by the lines' colours,
    /// the three best fitted with their curves, and the one whose curves then match the colours
    /// as closely as an image's own curves do (misfit ≤ 0.015) is used as --camera would be,
    /// with the fit without curves counted in σ (a warning names the camera;
    /// diagnostics.camera_database); none matching, the fit without curves is kept. Up to four
    /// fits' time. A database camera is not yours: it helps when the database holds your
    /// camera's sensor or a close sibling (docs/capture.md).
    #[arg(long, conflicts_with = "camera")]
    pub camera_database: Option<PathBuf>,
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

fn fixed(continuum: bool, falloff_degree: usize) -> BackgroundChoice {
    BackgroundChoice::Fixed {
        continuum,
        falloff_degree,
    }
}

fn calibrate(a: &CalibrateArgs) -> Result<()> {
    let opts = FitOptions {
        map: match a.map {
            MapArg::Linear => MapChoice::Linear,
            MapArg::Quadratic => MapChoice::Quadratic,
            MapArg::Auto => MapChoice::Auto,
        },
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
        split_prior_tau: a.split_prior,
        fixed_falloff: None,
        ..FitOptions::default()
    };
    let inputs = CalibrateInputs {
        image: a.image.clone(),
        roi: a.roi.as_deref().map(super::parse_rect).transpose()?,
        axis: match a.axis {
            AxisArg::X => Axis::X,
            AxisArg::Y => Axis::Y,
        },
        lamp: a.lamp.clone(),
        passband: a.passband.clone(),
        camera: a.camera.clone(),
        camera_database: a.camera_database.clone(),
        flat: a.flat.clone(),
        flat_spectrum: a.flat_spectrum.clone(),
        tilt: a.tilt.parse()?,
        repair_dust: !a.keep_occlusions,
    };
    let method = match a.method {
        MethodArg::WholeProfile => CalibrationMethod::WholeProfile,
        MethodArg::Peaks => CalibrationMethod::Peaks,
    };
    let mut out = Outputs::new();
    out.inputs(inputs.files());
    out.declare("--out", &a.out)?;
    if let Some(p) = &a.plot {
        out.declare("--plot", p)?;
    }
    let c = calibrate_lamp(&inputs, method, opts, &mut |m| eprintln!("{m}"))?;
    out.stage(&a.out, serde_json::to_string_pretty(&c.json)?.as_bytes())?;
    if let Some(p) = &a.plot {
        out.stage(p, &lumifit::plot::lvf_chart_png(&c.calibration)?)?;
    }
    out.commit()?;
    emit(&serde_json::to_string_pretty(&calibration_summary(
        &c, &a.out,
    ))?)
}
