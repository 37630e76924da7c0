//! `lumifit phos fit-excitation`, `lumifit phos design` and `lumifit synth phos-excitation`:
//! excitation rates from charging experiments (Nalbach et al. 2017 §4.6) and materials designed
//! from keyframes (§6).

use std::path::PathBuf;

use anyhow::{bail, Result};
use clap::{ArgGroup, Args, Subcommand, ValueEnum};
use lumifit::io::Outputs;
use lumifit::phosphor::excitation::StateSharing;
use lumifit::pipeline::phos_excitation::{
    self as job, ChargingInput, DesignJob, FitExcitationJob, SeriesRois, SynthExcitationJob,
};

use super::emit;

/// Excitation-rate fitting and design from keyframes (flattened into `lumifit phos`).
#[derive(Debug, Subcommand)]
pub enum PhosExcitationCommand {
    /// Fit excitation rates k_e per band from charging experiments; adds k_e to the preset.
    FitExcitation(FitExcitationArgs),
    /// Design a one-state RGB material from keyframes of outgoing radiance (§6, Eq. 7).
    Design(DesignArgs),
}

/// Charging-experiment generators (flattened into `lumifit synth`).
#[derive(Debug, Subcommand)]
pub enum SynthExcitationCommand {
    /// Charging data `band,charge_s,r,g,b,std` from the exact simulation (plus the source and
    /// camera CSVs it used, beside the output).
    PhosExcitation(SynthExcitationArgs),
}

/// Sharing of k_e between states.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum SharingArg {
    /// Per state only when the charging curves identify it.
    Auto,
    /// One k_e per band for all states.
    Shared,
    /// One k_e per band and state.
    PerState,
}

/// `lumifit phos fit-excitation`.
#[derive(Debug, Args)]
#[command(group(ArgGroup::new("charging").required(true).args(["data", "series"])))]
#[command(group(ArgGroup::new("series_rois").args(["roi", "rois"])))]
pub struct FitExcitationArgs {
    /// Material preset JSON with k_r and Λ from the decay fit (or a Table 1 name).
    #[arg(long)]
    pub material: String,
    /// Charging data CSV `band,charge_s,r,g,b[,std]` (band 1-based).
    #[arg(long)]
    pub data: Option<PathBuf>,
    /// Instead of --data: photographs listed in a manifest CSV
    /// `image,band,charge_s[,exposure_s,iso,f_number]` (paths relative to the manifest; RAW,
    /// 16-bit TIFF/PNG, float TIFF/EXR), measured in --roi or --rois.
    #[arg(long, requires = "series_rois")]
    pub series: Option<PathBuf>,
    /// With --series: one region `x,y,w,h` (source pixels) for every band.
    #[arg(long, requires = "series")]
    pub roi: Option<String>,
    /// With --series: regions per band, CSV `band,x,y,w,h` (one ROI per band under the LVF).
    #[arg(long, requires = "series")]
    pub rois: Option<PathBuf>,
    /// With --series: dark frame(s), averaged and subtracted from every image.
    #[arg(long, requires = "series")]
    pub dark: Vec<PathBuf>,
    /// Source spectra CSV `wavelength_nm,band1,band2,…` (one column per excitation band).
    #[arg(long)]
    pub source: PathBuf,
    /// Camera sensitivities CSV `wavelength_nm,r,g,b`.
    #[arg(long)]
    pub camera: PathBuf,
    /// Delay between switch-off and measurement in s.
    #[arg(long, default_value_t = 0.6)]
    pub switch_off_delay_s: f64,
    /// k_e shared by the states or per state.
    #[arg(long, value_enum, default_value_t = SharingArg::Auto)]
    pub states: SharingArg,
    /// Output material preset JSON.
    #[arg(long)]
    pub out: PathBuf,
    /// Plot PNG: per band, data, simulated charging curve and equilibrium level.
    #[arg(long)]
    pub plot: Option<PathBuf>,
}

/// `lumifit phos design`.
#[derive(Debug, Args)]
pub struct DesignArgs {
    /// Irradiance history CSV `time_s,e_r,e_g,e_b` (constant from each row's time to the next,
    /// the last row holds on); the same file feeds `phos simulate`, which ends at the last row.
    #[arg(long)]
    pub history: PathBuf,
    /// Keyframe targets CSV `time_s,l_r,l_g,l_b` (outgoing radiance = albedo·E/π + L_p).
    #[arg(long)]
    pub targets: PathBuf,
    /// Albedo per channel `r,g,b`.
    #[arg(long, default_value = "0,0,0")]
    pub albedo: String,
    /// Grid points per rate dimension.
    #[arg(long, default_value_t = 6)]
    pub grid_points: usize,
    /// Report the grid optimum only (no least-squares refinement).
    #[arg(long)]
    pub grid_only: bool,
    /// Material name written into the preset.
    #[arg(long, default_value = "designed")]
    pub name: String,
    /// Output material preset JSON.
    #[arg(long)]
    pub out: PathBuf,
    /// Plot PNG: irradiance history, designed outgoing radiance per channel (grid optimum
    /// dashed), targets at the keyframes and every keyframe's residual.
    #[arg(long)]
    pub plot: Option<PathBuf>,
}

/// `lumifit synth phos-excitation`.
#[derive(Debug, Args)]
pub struct SynthExcitationArgs {
    /// A Table 1 material name or a material preset JSON file (with k_e).
    #[arg(long)]
    pub material: String,
    /// Number of excitation bands (the first N bands of the material).
    #[arg(long, default_value_t = 3)]
    pub bands: usize,
    /// Charging times in s, comma-separated.
    #[arg(long, default_value = "1,2,4,8,16,32,64,128,256,512")]
    pub charge_times: String,
    /// Delay between switch-off and measurement in s.
    #[arg(long, default_value_t = 0.6)]
    pub switch_off_delay_s: f64,
    /// Relative noise (0.01 = 1 %).
    #[arg(long, default_value_t = 0.01)]
    pub noise: f64,
    /// Camera sensitivities CSV `wavelength_nm,r,g,b` (default: an ideal box camera, written
    /// beside the output as `<out>.camera.csv`).
    #[arg(long)]
    pub camera: Option<PathBuf>,
    /// Seed of the noise generator.
    #[arg(long)]
    pub seed: u64,
    /// Output CSV; `<stem>.source.csv` (and `<stem>.camera.csv`) are written beside it.
    #[arg(long)]
    pub out: PathBuf,
    /// Also render the same samples as photographs into this folder: one 16-bit TIFF per
    /// charging time with one patch per band (as under the LVF), `manifest.csv`, `rois.csv` and
    /// `dark.tif` — the input of `phos fit-excitation --series DIR/manifest.csv --rois
    /// DIR/rois.csv --dark DIR/dark.tif`.
    #[arg(long)]
    pub images: Option<PathBuf>,
}

/// Runs a `lumifit phos` excitation/design subcommand.
pub fn run(cmd: PhosExcitationCommand) -> Result<()> {
    let mut out = Outputs::new();
    let mut warn = |w: String| eprintln!("{w}");
    let report = match cmd {
        PhosExcitationCommand::FitExcitation(a) => {
            job::run_fit_excitation(&a.config()?, &mut out, &mut warn)?
        }
        PhosExcitationCommand::Design(a) => job::run_design(&a.config(), &mut out, &mut warn)?,
    };
    out.commit()?;
    emit(&serde_json::to_string_pretty(&report)?)
}

/// Runs a `lumifit synth` charging-experiment generator.
pub fn run_synth(cmd: SynthExcitationCommand) -> Result<()> {
    match cmd {
        SynthExcitationCommand::PhosExcitation(a) => {
            let mut out = Outputs::new();
            let line = job::run_synth_excitation(&a.config(), &mut out)?;
            out.commit()?;
            emit(&line)
        }
    }
}

impl FitExcitationArgs {
    fn config(&self) -> Result<FitExcitationJob> {
        let data = match (&self.data, &self.series, &self.roi, &self.rois) {
            (Some(d), None, _, _) => ChargingInput::Csv(d.clone()),
            (None, Some(m), roi, rois) => ChargingInput::Series {
                manifest: m.clone(),
                rois: match (roi, rois) {
                    (Some(r), None) => SeriesRois::One(r.clone()),
                    (None, Some(f)) => SeriesRois::PerBand(f.clone()),
                    _ => bail!("--series needs either --roi x,y,w,h or --rois FILE.csv"),
                },
                dark: self.dark.clone(),
            },
            _ => bail!(
                "give the charging data either as --data FILE.csv or as --series MANIFEST.csv"
            ),
        };
        Ok(FitExcitationJob {
            material: self.material.clone(),
            data,
            source: self.source.clone(),
            camera: self.camera.clone(),
            switch_off_delay_s: self.switch_off_delay_s,
            sharing: match self.states {
                SharingArg::Auto => StateSharing::Auto,
                SharingArg::Shared => StateSharing::Shared,
                SharingArg::PerState => StateSharing::PerState,
            },
            out: self.out.clone(),
            plot: self.plot.clone(),
        })
    }
}

impl DesignArgs {
    fn config(&self) -> DesignJob {
        DesignJob {
            history: self.history.clone(),
            targets: self.targets.clone(),
            albedo: self.albedo.clone(),
            grid_points: self.grid_points,
            grid_only: self.grid_only,
            name: self.name.clone(),
            out: self.out.clone(),
            plot: self.plot.clone(),
        }
    }
}

impl SynthExcitationArgs {
    fn config(&self) -> SynthExcitationJob {
        SynthExcitationJob {
            material: self.material.clone(),
            bands: self.bands,
            charge_times: self.charge_times.clone(),
            switch_off_delay_s: self.switch_off_delay_s,
            noise: self.noise,
            camera: self.camera.clone(),
            seed: self.seed,
            out: self.out.clone(),
            images: self.images.clone(),
        }
    }
}
