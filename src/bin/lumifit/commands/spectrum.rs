//! `lumifit spectrum recover`: the spectrum of the light (or a reflectance factor) from one photo
//! through the calibrated LVF.

use std::path::PathBuf;

use anyhow::Result;
use clap::{ArgGroup, Args, Subcommand};
use lumifit::io::Outputs;
use lumifit::pipeline::recover::{run_recover, RecoverJob};

use super::emit;

/// `lumifit spectrum …`.
#[derive(Debug, Subcommand)]
pub enum SpectrumCommand {
    /// Recover a spectrum (or a reflectance factor) from one photo through the calibrated LVF.
    ///
    /// Each band of the LVF gives three camera readings; the spectrum on the grid is the
    /// non-negative, smoothness-regularised least-squares solution (weight by generalised
    /// cross-validation unless --reg gives it). Writes `wavelength_nm,value,std` and prints a
    /// JSON summary with the effective resolution per wavelength.
    Recover(RecoverArgs),
}

/// `spectrum recover`.
#[derive(Debug, Args)]
#[command(group(ArgGroup::new("input").required(true).args(["image", "readings"])))]
pub struct RecoverArgs {
    /// The photo through the LVF (TIFF, PNG or camera RAW; linear).
    pub image: Option<PathBuf>,
    /// Instead of a photo: readings per band, CSV `band,r,g,b[,std_r,std_g,std_b]` (band 1-based).
    #[arg(long)]
    pub readings: Option<PathBuf>,
    /// Band transmissions: `lvf_bands.json` from `lvf transmission`, or the `lvf.json` of the
    /// wavelength calibration alone (then each band is the calibrated Gaussian passband averaged
    /// over its pixel window, peak 1).
    #[arg(long)]
    pub bands: PathBuf,
    /// Camera sensitivities: CSV `wavelength_nm,r,g,b`, `DATABASE:NAME` (a long CSV or Jiang's
    /// `camspec_database.txt`), or Academy
    /// spectral-data JSON as in rawtoaces-data (default: calib/camera_default.csv, Nikon 5100 NPL).
    #[arg(long)]
    pub camera: Option<PathBuf>,
    /// Region `x,y,w,h` (source pixels) to average across the filter; default: the calibration's
    /// ROI.
    #[arg(long)]
    pub roi: Option<String>,
    /// Recovery grid `LO:HI:STEP` in nm (default 400:700:5, clipped to the band file's grid).
    #[arg(long)]
    pub grid: Option<String>,
    /// Penalty weight: `gcv` or a relative value λ ≥ 0 (0 = plain non-negative least squares).
    #[arg(long, default_value = "gcv")]
    pub reg: String,
    /// Drop the non-negativity constraint (`--reg 0 --no-nonneg` is plain least squares; for
    /// comparisons — the system is badly conditioned and the result oscillates).
    #[arg(long)]
    pub no_nonneg: bool,
    /// Write the weighted system actually solved to this JSON (A column-major, b, λ, μ, the
    /// difference order, the solution x and the solve time), so another solver can solve the
    /// identical problem.
    #[arg(long)]
    pub dump_system: Option<PathBuf>,
    /// Reflectance mode: the illuminant (CIE name, daylight:<K>, blackbody:<K> or CSV); the
    /// output is a reflectance factor.
    #[arg(long)]
    pub illuminant: Option<String>,
    /// Reflectance mode: a capture of a white reference under the same light and exposure. With
    /// --illuminant it fixes the exposure; alone, its recovered spectrum is the illuminant.
    #[arg(long)]
    pub white: Option<PathBuf>,
    /// Reflectance of the white reference: a number or CSV `wavelength_nm,value`.
    #[arg(long, default_value = "1.0")]
    pub white_reflectance: String,
    /// With --illuminant and no --white: readings = exposure · Σ R·S·T·Q·Δλ.
    #[arg(long, default_value_t = 1.0)]
    pub exposure: f64,
    /// Reference spectrum CSV drawn on the plot and compared in the summary (RMS).
    #[arg(long)]
    pub compare: Option<PathBuf>,
    /// Output CSV `wavelength_nm,value,std`.
    #[arg(long)]
    pub out: PathBuf,
    /// Also write the JSON summary to this file.
    #[arg(long)]
    pub summary: Option<PathBuf>,
    /// Plot PNG: recovered spectrum ± 2σ (with --compare) and the resolution per wavelength.
    #[arg(long)]
    pub plot: Option<PathBuf>,
    /// Reflectance mode (--illuminant or --white): also write a material preset
    /// (`lumifit.material/1`) with the recovered reflectance as its `reflectance` section (the
    /// per-wavelength σ beside it as `std`), validated before it is written.
    #[arg(long)]
    pub preset: Option<PathBuf>,
    /// Material name in the --preset (default: the photo's file stem).
    #[arg(long, requires = "preset")]
    pub name: Option<String>,
}

/// Runs a `spectrum` subcommand.
pub fn run(cmd: SpectrumCommand) -> Result<()> {
    match cmd {
        SpectrumCommand::Recover(a) => {
            let mut out = Outputs::new();
            let text = run_recover(&a.config(), &mut out)?;
            out.commit()?;
            emit(&text)
        }
    }
}

impl RecoverArgs {
    fn config(self) -> RecoverJob {
        RecoverJob {
            image: self.image,
            readings: self.readings,
            bands: self.bands,
            camera: self.camera,
            roi: self.roi,
            grid: self.grid,
            reg: self.reg,
            nonnegative: !self.no_nonneg,
            dump_system: self.dump_system,
            illuminant: self.illuminant,
            white: self.white,
            white_reflectance: self.white_reflectance,
            exposure: self.exposure,
            compare: self.compare,
            out: self.out,
            summary: self.summary,
            plot: self.plot,
            preset: self.preset,
            name: self.name,
        }
    }
}
