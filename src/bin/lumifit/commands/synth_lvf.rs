//! `lumifit synth lvf-hg`: a synthetic lamp photo through an LVF (16-bit linear TIFF) and its
//! true map; `lumifit synth lvf-capture`: a continuous spectrum (light source, or reflectance
//! under an illuminant) through an optional colour gel and the LVF.

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::{ArgGroup, Args, Subcommand};
use lumifit::io::camera::{camera_file, read_camera};
use lumifit::io::lvf_model::read_lvf_model;
use lumifit::io::sources::{file_of, resolve_lamp};
use lumifit::io::Outputs;
use lumifit::lvf::capture_synth::{render_lvf_capture, CaptureLight, Exposure, LvfCaptureSpec};
use lumifit::lvf::synth::{Continuum, ContinuumShape, VignettingShape};
use lumifit::lvf::{render_lvf, Axis, LvfSynthSpec};

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

/// Most pixels of a synthetic image: 100 megapixels (twice a full-frame camera's sensor; the
/// frames lumifit reads from RAW are half that resolution).
const MAX_PIXELS: usize = 100_000_000;
/// Bytes per pixel while rendering and encoding: the f32 RGB frame (12), its saturation mask
/// (1), the 16-bit copy (6) and the encoded TIFF (6).
const BYTES_PER_PIXEL: u128 = 25;

/// Parses `WxH` and bounds it (pixels and memory) before anything is allocated.
fn parse_size(flag: &str, s: &str) -> Result<(usize, usize)> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .and_then(|(w, h)| {
            Some((
                w.trim().parse::<usize>().ok()?,
                h.trim().parse::<usize>().ok()?,
            ))
        })
        .ok_or_else(|| anyhow::anyhow!("{flag}: '{s}' is not WxH, e.g. 1200x160"))?;
    let pixels = w.saturating_mul(h);
    lumifit::limits::check_memory(flag, s, pixels as u128, BYTES_PER_PIXEL)?;
    lumifit::limits::check_count(
        &format!("{flag} {s}"),
        pixels,
        MAX_PIXELS,
        "pixels of a synthetic image",
    )?;
    Ok((w, h))
}

/// The file of `--filter FILE.csv[:CODE]`.
fn filter_file(arg: &str) -> Option<std::path::PathBuf> {
    file_of(arg).or_else(|| arg.rsplit_once(':').and_then(|(f, _)| file_of(f)))
}

fn parse_exposure(s: &str) -> Result<Exposure> {
    if s.trim().eq_ignore_ascii_case("auto") {
        return Ok(Exposure::Auto);
    }
    match s.trim().parse::<f64>() {
        Ok(e) if e > 0.0 && e.is_finite() => Ok(Exposure::Fixed(e)),
        _ => anyhow::bail!("--exposure: '{s}'; expected 'auto' or a positive number"),
    }
}

fn lvf_capture(a: &LvfCaptureArgs) -> Result<()> {
    let mut out = Outputs::new();
    out.inputs(a.spectrum.iter().chain(&a.reflectance).cloned());
    out.inputs(a.camera.iter().map(|c| camera_file(c)));
    out.input(&a.lvf);
    out.inputs(a.illuminant.as_deref().and_then(file_of));
    out.inputs(a.filter.as_deref().and_then(filter_file));
    out.declare("--out", &a.out)?;
    if let Some(t) = &a.truth {
        out.declare("--truth", t)?;
    }
    let exposure = parse_exposure(&a.exposure)?;
    let (vignetting_shape, vignetting) = VignettingShape::parse(&a.vignetting)?;
    let model = read_lvf_model(&a.lvf).with_context(|| format!("--lvf {}", a.lvf.display()))?;
    let (width, height) = match (&a.size, model.size) {
        (Some(s), _) => parse_size("--size", s)?,
        (None, Some((w, h))) => parse_size("--size", &format!("{w}x{h}"))?,
        (None, None) => anyhow::bail!(
            "--size: required with an lvf.json from 'lvf calibrate' ({} holds no image size); give the size of the calibrated image, e.g. --size 1200x160",
            a.lvf.display()
        ),
    };
    let light = match (&a.spectrum, &a.reflectance, &a.illuminant) {
        (Some(s), None, _) => CaptureLight::Emission(lumifit::io::spectrum_csv::read_spectrum(s)?),
        (None, Some(r), Some(i)) => CaptureLight::Reflectance {
            reflectance: lumifit::io::spectrum_csv::read_spectrum(r)?,
            illuminant: {
                let ill = super::resolve_illuminant(i)?;
                ill.spectrum().clone().with_name(ill.name())
            },
        },
        (None, Some(_), None) => anyhow::bail!("--reflectance needs --illuminant NAME|FILE.csv"),
        _ => anyhow::bail!("give exactly one of --spectrum FILE.csv or --reflectance FILE.csv"),
    };
    let (filter, filter_name) = match &a.filter {
        None => (None, None),
        Some(f) => {
            let gel = lumifit::io::filters::read_filter(f)?;
            let label = gel.label();
            (Some(gel.transmission), Some(label))
        }
    };
    let spec = LvfCaptureSpec {
        width,
        height,
        axis: model.axis,
        map: model.map,
        fwhm_nm: model.fwhm_nm,
        light,
        filter,
        filter_name,
        camera: read_camera(a.camera.as_deref())?.curves,
        noise: a.noise,
        vignetting,
        vignetting_shape,
        seed: a.seed,
        exposure,
    };
    let (frame, truth) = render_lvf_capture(&spec)?;
    let json = serde_json::to_string_pretty(&truth)?;
    out.stage(&a.out, &lumifit::io::image::frame_to_tiff16(&frame)?)?;
    if let Some(t) = &a.truth {
        out.stage(t, json.as_bytes())?;
    }
    out.commit()?;
    emit(&json)
}

fn lvf_hg(a: &LvfHgArgs) -> Result<()> {
    let mut out = Outputs::new();
    out.inputs(a.camera.iter().map(|c| camera_file(c)));
    out.inputs(lumifit::io::sources::file_of(&a.passband));
    out.inputs(file_of(&a.lamp));
    out.declare("--out", &a.out)?;
    out.declare("--truth", &a.truth)?;
    if let Some(f) = &a.flat_out {
        out.declare("--flat-out", f)?;
    }
    let (w, h) = parse_size("--size", &a.size)?;
    let (vignetting_shape, vignetting) = VignettingShape::parse(&a.vignetting)?;
    let flat_shape = ContinuumShape::parse("--flat-spectrum", &a.flat_spectrum)?;
    let continuum = if a.continuum > 0.0 {
        Some(Continuum {
            shape: ContinuumShape::parse("--continuum-spectrum", &a.continuum_spectrum)?,
            fraction: a.continuum,
        })
    } else if a.continuum == 0.0 {
        None
    } else {
        anyhow::bail!("--continuum: {}; expected a fraction ≥ 0", a.continuum)
    };
    let spec = LvfSynthSpec {
        width: w,
        height: h,
        axis: match a.axis {
            AxisArg::X => Axis::X,
            AxisArg::Y => Axis::Y,
        },
        nm_at_start: a.nm_at_start,
        nm_per_px: a.nm_per_px,
        bow_nm: a.bow,
        tilt_deg: a.tilt,
        fwhm_nm: a.fwhm,
        passband: lumifit::io::sources::resolve_passband(&a.passband)?,
        lamp: resolve_lamp(&a.lamp)?,
        camera: read_camera(a.camera.as_deref())?.curves,
        noise: a.noise,
        vignetting,
        vignetting_shape,
        continuum,
        seed: a.seed,
    };
    let (frame, truth) = render_lvf(&spec)?;
    let json = serde_json::to_string_pretty(&truth)?;
    out.stage(&a.out, &lumifit::io::image::frame_to_tiff16(&frame)?)?;
    out.stage(&a.truth, json.as_bytes())?;
    if let Some(f) = &a.flat_out {
        let flat = lumifit::lvf::flat_synth::render_lvf_flat(&spec, flat_shape)?;
        out.stage(f, &lumifit::io::image::frame_to_tiff16(&flat)?)?;
    }
    out.commit()?;
    emit(&json)
}
