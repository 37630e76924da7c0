//! `lumifit synth lvf-hg`: a synthetic lamp photo through an LVF (16-bit linear TIFF) and its
//! true map.

use std::path::PathBuf;

use anyhow::Result;
use clap::{Args, Subcommand};
use lumifit::lvf::synth::{camera_from_csv, default_camera};
use lumifit::lvf::{render_lvf, Axis, LvfSynthSpec};

use super::emit;
use super::lvf::AxisArg;

/// Subcommands (synthetic LVF captures; flattened into `lumifit synth`).
#[derive(Debug, Subcommand)]
pub enum LvfSynthCommand {
    /// Render a lamp (mercury by default) seen through an LVF by a camera, with noise and vignetting.
    LvfHg(LvfHgArgs),
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
    }
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
    let camera = match &a.camera {
        None => default_camera()?,
        Some(p) => {
            let (bytes, src) = lumifit::io::read_input(p)?;
            camera_from_csv(&bytes, &src)?
        }
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
