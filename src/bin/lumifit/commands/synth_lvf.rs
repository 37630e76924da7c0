//! `lumifit synth lvf-hg`: a synthetic lamp photo through an LVF (16-bit linear TIFF) and its
//! true map; `lumifit synth lvf-capture`: a continuous spectrum (light source, or reflectance
//! under an illuminant) through an optional colour gel and the LVF.

use std::path::PathBuf;

use anyhow::Result;
use clap::{ArgGroup, Args, Subcommand};
use lumifit::io::Outputs;
use lumifit::lvf::Axis;
use lumifit::pipeline::acquisition::{
    synth_capture_photo, synth_lamp_photo, CapturePhotoJob, LampPhotoJob,
};

use super::emit;
use super::lvf::AxisArg;

/// Subcommands (synthetic LVF captures; flattened into `lumifit synth`).
#[derive(Debug, Subcommand)]
pub enum LvfSynthCommand {
    /// Render a lamp (mercury by default) seen through an LVF by a camera, with noise and vignetting.
    LvfHg(LvfHgArgs),
    /// Render a continuous spectrum (a light, or a reflectance under an illuminant) seen through
    /// an optional colour gel and an LVF by a camera.
    LvfCapture(LvfCaptureArgs),
}

/// `synth lvf-capture`.
#[derive(Debug, Args)]
#[command(group(ArgGroup::new("light").required(true).args(["spectrum", "reflectance"])))]
pub struct LvfCaptureArgs {
    /// Emission spectrum CSV wavelength_nm,value (zero outside its range).
    #[arg(long)]
    pub spectrum: Option<PathBuf>,
    /// Reflectance CSV wavelength_nm,value (held constant beyond its range); needs --illuminant.
    #[arg(long, requires = "illuminant")]
    pub reflectance: Option<PathBuf>,
    /// Illuminant for --reflectance: a CIE name (D65, LED-B3 …), daylight:<K>, blackbody:<K> or a CSV.
    #[arg(long, requires = "reflectance")]
    pub illuminant: Option<String>,
    /// Colour gel in front of the LVF: FILE.csv (wavelength_nm,transmission) or FILE.csv:CODE
    /// (one gel of a table such as the Lee table).
    #[arg(long)]
    pub filter: Option<String>,
    /// The LVF: truth JSON of `synth lvf-hg --truth` or an lvf.json of `lvf calibrate` (then --size is required).
    #[arg(long)]
    pub lvf: PathBuf,
    /// Camera sensitivities: CSV wavelength_nm,r,g,b, DATABASE:NAME (a long CSV
    /// camera,wavelength_nm,r,g,b or Jiang's camspec_database.txt), or Academy spectral-data
    /// JSON as in rawtoaces-data (default: calib/camera_default.csv, Nikon 5100 NPL).
    #[arg(long)]
    pub camera: Option<PathBuf>,
    /// Relative noise at 0.8 of full scale (shot + read).
    #[arg(long, default_value_t = 0.01)]
    pub noise: f64,
    /// Vignetting: AMOUNT (quadratic 1 − v·r²) or SHAPE:AMOUNT with SHAPE quadratic, cos4,
    /// linear (tilt along the axis) or offcentre.
    #[arg(long, default_value = "0")]
    pub vignetting: String,
    /// Exposure: auto (an unfiltered white peaks at 0.8) or a factor.
    #[arg(long, default_value = "auto")]
    pub exposure: String,
    /// Image size WxH (default: the size in the --lvf truth JSON).
    #[arg(long)]
    pub size: Option<String>,
    /// Random seed.
    #[arg(long)]
    pub seed: u64,
    /// Output 16-bit linear TIFF.
    #[arg(long)]
    pub out: PathBuf,
    /// Also write the truth JSON here (it is always printed).
    #[arg(long)]
    pub truth: Option<PathBuf>,
}

/// `synth lvf-hg`.
#[derive(Debug, Args)]
pub struct LvfHgArgs {
    /// Output 16-bit linear TIFF.
    #[arg(long)]
    pub out: PathBuf,
    /// Output JSON with the true map.
    #[arg(long)]
    pub truth: PathBuf,
    /// Image size WxH.
    #[arg(long, default_value = "1200x160")]
    pub size: String,
    /// Filter axis.
    #[arg(long, value_enum, default_value = "x")]
    pub axis: AxisArg,
    /// λ at pixel 0 (nm).
    #[arg(long, default_value_t = 380.0)]
    pub nm_at_start: f64,
    /// Dispersion (nm per pixel; negative for a filter running red to blue).
    #[arg(long, default_value_t = 0.3, allow_hyphen_values = true)]
    pub nm_per_px: f64,
    /// Bow of the map (nm): λ at the middle of the axis minus the straight line through its ends
    /// (a quadratic map; 0: linear, as the paper's LVF). Negative bows the other way.
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub bow: f64,
    /// Slant of the filter's iso-wavelength lines (degrees): each position across the axis sees
    /// the map shifted along it by tan(tilt) px per px from the middle, where the truth's map
    /// holds (0: square to the sensor).
    #[arg(
        long,
        default_value_t = 0.0,
        allow_hyphen_values = true,
        value_name = "DEGREES"
    )]
    pub tilt: f64,
    /// Passband FWHM (nm).
    #[arg(long, default_value_t = 25.0)]
    pub fwhm: f64,
    /// Passband shape: gaussian, gennorm:BETA (exp(−ln2·|2Δλ/FWHM|^BETA)) or a CSV
    /// offset_nm,transmission, as `lvf calibrate --passband` reads it.
    #[arg(long, default_value = "gaussian")]
    pub passband: String,
    /// Lamp: hg, hg-weak (weak 405/408 nm), cfl or CSV wavelength_nm[,relative_power].
    #[arg(long, default_value = "hg")]
    pub lamp: String,
    /// Camera sensitivities CSV wavelength_nm,r,g,b, DATABASE:NAME (long format
    /// camera,wavelength_nm,r,g,b, e.g. the Jiang 2013 database, or that database's own
    /// camspec_database.txt), or Academy spectral-data JSON as
    /// in rawtoaces-data (default: calib/camera_default.csv, Nikon 5100 NPL).
    #[arg(long)]
    pub camera: Option<PathBuf>,
    /// Relative noise at the brightest pixel (shot + read).
    #[arg(long, default_value_t = 0.01)]
    pub noise: f64,
    /// Vignetting: AMOUNT (quadratic 1 − v·r²) or SHAPE:AMOUNT with SHAPE quadratic, cos4,
    /// linear (tilt along the axis) or offcentre.
    #[arg(long, default_value = "0.2")]
    pub vignetting: String,
    /// A broadband continuum under the lines: its peak through passband and camera as a fraction
    /// of the brightest line blob (0: none).
    #[arg(long, default_value_t = 0.0)]
    pub continuum: f64,
    /// Spectrum of the continuum: flat, cfl (broad phosphor bands) or blackbody:K.
    #[arg(long, default_value = "flat")]
    pub continuum_spectrum: String,
    /// A level added to every pixel after the fall-off and the noise, before clipping, as a
    /// fraction of full scale in [0, 0.2) (the brightest pixel is 0.8 before it): a black-level
    /// residue, or flare and stray light the lens does not vignette. Also in the flat field.
    #[arg(long, default_value_t = 0.0)]
    pub pedestal: f64,
    /// Also write a matching flat-field photo (16-bit TIFF): same geometry, camera, vignetting
    /// and noise, a broadband source of spectrum --flat-spectrum instead of the lamp.
    #[arg(long)]
    pub flat_out: Option<PathBuf>,
    /// Spectrum of the flat's source: flat, cfl or blackbody:K.
    #[arg(long, default_value = "flat")]
    pub flat_spectrum: String,
    /// Random seed.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
}

/// Runs one of these subcommands.
pub fn run(cmd: LvfSynthCommand) -> Result<()> {
    match cmd {
        LvfSynthCommand::LvfHg(a) => lvf_hg(&a),
        LvfSynthCommand::LvfCapture(a) => lvf_capture(&a),
    }
}

fn lvf_capture(a: &LvfCaptureArgs) -> Result<()> {
    let job = CapturePhotoJob {
        spectrum: a.spectrum.clone(),
        reflectance: a.reflectance.clone(),
        illuminant: a.illuminant.clone(),
        filter: a.filter.clone(),
        lvf: a.lvf.clone(),
        camera: a.camera.clone(),
        noise: a.noise,
        vignetting: a.vignetting.clone(),
        exposure: a.exposure.clone(),
        size: a.size.clone(),
        seed: a.seed,
    };
    let mut out = Outputs::new();
    out.inputs(job.files());
    out.declare("--out", &a.out)?;
    if let Some(t) = &a.truth {
        out.declare("--truth", t)?;
    }
    let photo = synth_capture_photo(&job)?;
    out.stage(&a.out, &photo.tiff)?;
    if let Some(t) = &a.truth {
        out.stage(t, photo.truth_json.as_bytes())?;
    }
    out.commit()?;
    emit(&photo.truth_json)
}

fn lvf_hg(a: &LvfHgArgs) -> Result<()> {
    let job = LampPhotoJob {
        size: a.size.clone(),
        axis: match a.axis {
            AxisArg::X => Axis::X,
            AxisArg::Y => Axis::Y,
        },
        nm_at_start: a.nm_at_start,
        nm_per_px: a.nm_per_px,
        bow_nm: a.bow,
        tilt_deg: a.tilt,
        fwhm_nm: a.fwhm,
        passband: a.passband.clone(),
        lamp: a.lamp.clone(),
        camera: a.camera.clone(),
        noise: a.noise,
        vignetting: a.vignetting.clone(),
        continuum: a.continuum,
        continuum_spectrum: a.continuum_spectrum.clone(),
        pedestal: a.pedestal,
        flat: a.flat_out.is_some(),
        flat_spectrum: a.flat_spectrum.clone(),
        seed: a.seed,
    };
    let mut out = Outputs::new();
    out.inputs(job.files());
    out.declare("--out", &a.out)?;
    out.declare("--truth", &a.truth)?;
    if let Some(f) = &a.flat_out {
        out.declare("--flat-out", f)?;
    }
    let photos = synth_lamp_photo(&job)?;
    out.stage(&a.out, &photos.lamp.tiff)?;
    out.stage(&a.truth, photos.lamp.truth_json.as_bytes())?;
    if let (Some(f), Some(tiff)) = (&a.flat_out, &photos.flat_tiff) {
        out.stage(f, tiff)?;
    }
    out.commit()?;
    emit(&photos.lamp.truth_json)
}
