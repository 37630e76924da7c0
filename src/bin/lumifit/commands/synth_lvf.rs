//! `lumifit synth lvf-hg`: a synthetic lamp photo through an LVF (16-bit linear TIFF) and its
//! true map; `lumifit synth lvf-capture`: a continuous spectrum (light source, or reflectance
//! under an illuminant) through an optional colour gel and the LVF.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use clap::{ArgGroup, Args, Subcommand};
use lumifit::lvf::capture_synth::{render_lvf_capture, CaptureLight, Exposure, LvfCaptureSpec};
use lumifit::lvf::synth::{camera_from_csv, default_camera};
use lumifit::lvf::{render_lvf, Axis, LvfGeometry, LvfSynthSpec};
use lumifit::spectrum::MultiSpectrum;

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
    /// Camera sensitivities CSV wavelength_nm,r,g,b (default: calib/camera_default.csv, Nikon 5100 NPL).
    #[arg(long)]
    pub camera: Option<PathBuf>,
    /// Relative noise at 0.8 of full scale (shot + read).
    #[arg(long, default_value_t = 0.01)]
    pub noise: f64,
    /// Vignetting strength v in 1 − v·r².
    #[arg(long, default_value_t = 0.0)]
    pub vignetting: f64,
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
    /// Passband FWHM (nm).
    #[arg(long, default_value_t = 25.0)]
    pub fwhm: f64,
    /// Lamp: hg, cfl or CSV wavelength_nm[,relative_power].
    #[arg(long, default_value = "hg")]
    pub lamp: String,
    /// Camera sensitivities CSV wavelength_nm,r,g,b (default: calib/camera_default.csv, Nikon 5100 NPL).
    #[arg(long)]
    pub camera: Option<PathBuf>,
    /// Relative noise at the brightest pixel (shot + read).
    #[arg(long, default_value_t = 0.01)]
    pub noise: f64,
    /// Vignetting strength v in 1 − v·r².
    #[arg(long, default_value_t = 0.2)]
    pub vignetting: f64,
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

fn parse_size(flag: &str, s: &str) -> Result<(usize, usize)> {
    s.split_once(['x', 'X'])
        .and_then(|(w, h)| {
            Some((
                w.trim().parse::<usize>().ok()?,
                h.trim().parse::<usize>().ok()?,
            ))
        })
        .ok_or_else(|| anyhow::anyhow!("{flag}: '{s}' is not WxH, e.g. 1200x160"))
}

fn read_camera(path: Option<&Path>) -> Result<MultiSpectrum> {
    Ok(match path {
        None => default_camera()?,
        Some(p) => {
            let (bytes, src) = lumifit::io::read_input(p)?;
            camera_from_csv(&bytes, &src)?
        }
    })
}

/// The LVF's geometry as the capture synthesiser needs it.
struct LvfModel {
    axis: Axis,
    map: Vec<f64>,
    fwhm_nm: f64,
    size: Option<(usize, usize)>,
}

/// Reads `--lvf`: a synthetic truth (`lumifit.lvf-truth/1`, `lumifit.lvf-capture-truth/1`) or a
/// calibration (`lumifit.lvf/1`).
fn read_lvf_model(path: &Path) -> Result<LvfModel> {
    let (bytes, src) = lumifit::io::read_input(path)?;
    let v: serde_json::Value = serde_json::from_slice(&bytes).map_err(|e| {
        lumifit::Error::parse(
            &src,
            e.line(),
            format!("not JSON: {e}; expected an lvf.json or an LVF truth JSON"),
        )
    })?;
    let schema = v.get("schema").and_then(|s| s.as_str()).unwrap_or("");
    match schema {
        "lumifit.lvf/1" => {
            let g = LvfGeometry::from_json(&bytes, &src)?;
            Ok(LvfModel {
                axis: g.axis,
                map: g.map,
                fwhm_nm: g.fwhm_nm,
                size: None,
            })
        }
        "lumifit.lvf-truth/1" | "lumifit.lvf-capture-truth/1" => {
            let bad = |field: &str, expected: &str| {
                lumifit::Error::parse(&src, 0, format!("field '{field}': expected {expected}"))
            };
            let axis = match v.get("axis").and_then(|a| a.as_str()) {
                Some("x") => Axis::X,
                Some("y") => Axis::Y,
                _ => return Err(bad("axis", "\"x\" or \"y\"").into()),
            };
            let map: Vec<f64> = v
                .get("map")
                .and_then(|m| m.get("coefficients"))
                .and_then(|c| c.as_array())
                .map(|a| a.iter().filter_map(|x| x.as_f64()).collect())
                .unwrap_or_default();
            if map.len() < 2 {
                return Err(bad("map.coefficients", "at least 2 numbers").into());
            }
            let fwhm_nm = v
                .get("fwhm_nm")
                .and_then(|f| f.as_f64())
                .filter(|f| *f > 0.0 && f.is_finite())
                .ok_or_else(|| bad("fwhm_nm", "a positive number"))?;
            let size = v
                .get("size")
                .and_then(|s| s.as_array())
                .filter(|a| a.len() == 2)
                .and_then(|a| Some((a[0].as_u64()? as usize, a[1].as_u64()? as usize)))
                .ok_or_else(|| bad("size", "[width, height]"))?;
            Ok(LvfModel {
                axis,
                map,
                fwhm_nm,
                size: Some(size),
            })
        }
        other => Err(lumifit::Error::parse(
            &src,
            0,
            format!(
                "field 'schema' is '{other}'; expected 'lumifit.lvf/1' (lvf calibrate) or 'lumifit.lvf-truth/1' (synth lvf-hg --truth)"
            ),
        )
        .into()),
    }
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

/// Fails unless the directory that will hold `path` exists, so nothing is written on error.
fn check_out_dir(flag: &str, path: &Path) -> Result<()> {
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    if !dir.is_dir() {
        anyhow::bail!(
            "{flag}: output directory '{}' does not exist",
            dir.display()
        );
    }
    Ok(())
}

fn lvf_capture(a: &LvfCaptureArgs) -> Result<()> {
    check_out_dir("--out", &a.out)?;
    if let Some(t) = &a.truth {
        check_out_dir("--truth", t)?;
        if t == &a.out {
            anyhow::bail!("--truth and --out name the same file '{}'", t.display());
        }
    }
    let exposure = parse_exposure(&a.exposure)?;
    let model = read_lvf_model(&a.lvf).with_context(|| format!("--lvf {}", a.lvf.display()))?;
    let (width, height) = match (&a.size, model.size) {
        (Some(s), _) => parse_size("--size", s)?,
        (None, Some(s)) => s,
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
        camera: read_camera(a.camera.as_deref())?,
        noise: a.noise,
        vignetting: a.vignetting,
        seed: a.seed,
        exposure,
    };
    let (frame, truth) = render_lvf_capture(&spec)?;
    let tiff = lumifit::io::image::frame_to_tiff16(&frame)?;
    let json = serde_json::to_string_pretty(&truth)?;
    lumifit::io::atomic_write(&a.out, &tiff)?;
    if let Some(t) = &a.truth {
        lumifit::io::atomic_write(t, json.as_bytes())?;
    }
    emit(&json)
}

fn lvf_hg(a: &LvfHgArgs) -> Result<()> {
    let (w, h) = a
        .size
        .split_once(['x', 'X'])
        .and_then(|(w, h)| {
            Some((
                w.trim().parse::<usize>().ok()?,
                h.trim().parse::<usize>().ok()?,
            ))
        })
        .ok_or_else(|| anyhow::anyhow!("--size: '{}' is not WxH, e.g. 1200x160", a.size))?;
    let camera = read_camera(a.camera.as_deref())?;
    let spec = LvfSynthSpec {
        width: w,
        height: h,
        axis: match a.axis {
            AxisArg::X => Axis::X,
            AxisArg::Y => Axis::Y,
        },
        nm_at_start: a.nm_at_start,
        nm_per_px: a.nm_per_px,
        fwhm_nm: a.fwhm,
        lamp: super::lvf::resolve_lamp(&a.lamp)?,
        camera,
        noise: a.noise,
        vignetting: a.vignetting,
        seed: a.seed,
    };
    let (frame, truth) = render_lvf(&spec)?;
    let tiff = lumifit::io::image::frame_to_tiff16(&frame)?;
    lumifit::io::atomic_write(&a.out, &tiff)?;
    let json = serde_json::to_string_pretty(&truth)?;
    lumifit::io::atomic_write(&a.truth, json.as_bytes())?;
    emit(&json)
}
