//! `lumifit phos …` (phosphorescence): simulate a material under an irradiance history, fit
//! decay curves (one CSV curve or a batch) into the `phosphorescence` section of a preset.

use std::path::PathBuf;
use std::sync::OnceLock;

use anyhow::Result;
use clap::{Args, Subcommand, ValueEnum};
use indicatif::{ProgressBar, ProgressStyle};
use lumifit::io::Outputs;
use lumifit::phosphor::Integrator;
use lumifit::pipeline::phos_fit::{self as job, FitDecayJob, FitDecayProgress, SimulateJob};
use lumifit::pipeline::phos_maps::{PerPixelHooks, Plan};

use super::{emit, Bar};

/// Subcommands of `lumifit phos`.
// Parsed once per run: the size of the fit-decay flags does not matter.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Subcommand)]
pub enum PhosCommand {
    /// Simulate Eq. 1 under a piecewise-constant irradiance history; write the emission CSV.
    Simulate(SimulateArgs),
    /// Fit a decay curve (or a batch of curves) with a sum of exponentials.
    FitDecay(FitDecayArgs),
    /// Error versus run time of the exact, RK4 and Euler integrators at several step sizes.
    CompareIntegrators(CompareArgs),
    /// Merge the shards of a `fit-decay --per-pixel --shard i/n` run into the full map set.
    MergeMaps(MergeMapsArgs),
}

/// `lumifit phos merge-maps`.
#[derive(Debug, Args)]
pub struct MergeMapsArgs {
    /// Shard folders (each holding shard.json and maps.f32le), in any order.
    #[arg(required = true)]
    pub shards: Vec<PathBuf>,
    /// Output folder for the full map set (as a single --per-pixel run writes it).
    #[arg(long)]
    pub out: PathBuf,
}

/// `lumifit phos compare-integrators`.
#[derive(Debug, Args)]
pub struct CompareArgs {
    /// A Table 1 material with excitation rates, or a preset JSON file.
    #[arg(long, default_value = "green_paint")]
    pub material: String,
    /// Output table CSV.
    #[arg(long)]
    pub out: PathBuf,
    /// Error-versus-time plot PNG.
    #[arg(long)]
    pub plot: Option<PathBuf>,
}

/// ODE integrator.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum IntegratorArg {
    /// Exact exponential update (default).
    Exact,
    /// Classic fourth-order Runge–Kutta.
    Rk4,
    /// Forward Euler (the paper's choice).
    Euler,
}

/// `lumifit phos simulate`.
#[derive(Debug, Args)]
pub struct SimulateArgs {
    /// A Table 1 material name (e.g. blue_paint) or a material preset JSON file.
    #[arg(long)]
    pub material: String,
    /// Irradiance history CSV `time_s` then one column per band of the material: each row's
    /// irradiance holds from its time to the next row's, the last row's time ends the history
    /// (the old `duration_s,…` layout, one row per segment, is read with a warning).
    #[arg(long)]
    pub history: PathBuf,
    /// Largest time step in s (also the output sampling).
    #[arg(long, default_value_t = 1.0)]
    pub dt: f64,
    /// Integrator.
    #[arg(long, value_enum, default_value_t = IntegratorArg::Exact)]
    pub integrator: IntegratorArg,
    /// Camera sensitivities CSV `wavelength_nm,r,g,b`; adds r,g,b columns.
    #[arg(long)]
    pub camera: Option<PathBuf>,
    /// Output CSV.
    #[arg(long)]
    pub out: PathBuf,
    /// Plot PNG: emission per band (per camera channel with --camera) over time, above the
    /// irradiance history per band; log axis chosen automatically.
    #[arg(long)]
    pub plot: Option<PathBuf>,
}

/// `lumifit phos fit-decay`.
#[derive(Debug, Args)]
pub struct FitDecayArgs {
    /// Curve CSV (`time_s` and channels `r,g,b` or one column, optional `std` or `weight`), or
    /// with --roi / --per-pixel a photo series (manifest CSV `file,time_s,…` or a folder).
    pub curve: Option<PathBuf>,
    /// Photo series (manifest CSV or folder); the same as giving it as the positional argument
    /// with --roi or --per-pixel.
    #[arg(long)]
    pub series: Option<PathBuf>,
    /// Region of interest `x,y,w,h` in source pixels: fit its mean curve (relative radiance).
    #[arg(long)]
    pub roi: Option<String>,
    /// Dark frame(s) subtracted from every frame of the series.
    #[arg(long)]
    pub dark: Vec<PathBuf>,
    /// Batch CSV `id,time_s,r,g,b[,std]` with many curves; writes one CSV row per curve.
    #[arg(long)]
    pub batch: Option<PathBuf>,
    /// Fit every pixel (or k×k block) of a series; --out is a directory of float TIFF maps.
    #[arg(long)]
    pub per_pixel: bool,
    /// Block side k for --per-pixel (k×k pixels averaged per fit).
    #[arg(long, default_value_t = 1)]
    pub block: usize,
    /// With --per-pixel: peak memory in GiB for the frames, tiles and maps (default: the
    /// LUMIFIT_MEMORY_GB budget, 16 GiB, which fits a 24 GB machine). Frames go to a scratch
    /// file when they do not fit.
    #[arg(long)]
    pub memory_gb: Option<f64>,
    /// With --per-pixel: tile side in pixels (default: about 32 MiB of samples per tile).
    #[arg(long)]
    pub tile: Option<usize>,
    /// With --per-pixel: fit only shard i of n (0-based; tile rows split into n groups) and
    /// write a partial map set (shard.json, maps.f32le) for `phos merge-maps`.
    #[arg(long)]
    pub shard: Option<String>,
    /// With --per-pixel: group the per-pixel fits into materials, `auto` (the smallest K within
    /// --material-budget) or K; writes material_<k>.json presets, materials.png (index map) and
    /// materials.json.
    #[arg(long)]
    pub materials: Option<String>,
    /// With --materials auto: budget on the 95th percentile of the relative reconstruction error
    /// of the K-material model against the per-pixel fits.
    #[arg(long, default_value_t = lumifit::phosphor::cluster::DEFAULT_BUDGET)]
    pub material_budget: f64,
    /// With --per-pixel: folder for the tile scratch file (default: the system's temporary
    /// folder); used only when the frames do not fit --memory-gb.
    #[arg(long)]
    pub scratch_dir: Option<PathBuf>,
    /// Number of states: auto (BIC over 1–3) or 1, 2, 3.
    #[arg(long, default_value = "auto")]
    pub states: String,
    /// Independent amplitudes per channel instead of one shared spectrum.
    #[arg(long)]
    pub per_channel: bool,
    /// Fit a constant background per channel.
    #[arg(long)]
    pub background: bool,
    /// Emission spectrum CSV `wavelength_nm,value` for the re-radiation functions (§4.5).
    #[arg(long)]
    pub spectrum: Option<PathBuf>,
    /// Number of uniform bands over 400–700 nm for --spectrum.
    #[arg(long, default_value_t = 8)]
    pub bands: usize,
    /// With --spectrum: camera sensitivities CSV `wavelength_nm,r,g,b` that recorded the curve,
    /// so that the re-radiation functions reproduce the measured RGB amplitudes (default: the
    /// ideal box camera B 400–500, G 500–600, R 600–700 nm used by `phos simulate`).
    #[arg(long)]
    pub camera: Option<PathBuf>,
    /// Material name written into the preset.
    #[arg(long)]
    pub name: Option<String>,
    /// The sample was saturated at switch-off (r = 1, a long charge under a strong lamp): Λ is
    /// exact. Recorded in the preset.
    #[arg(long, conflicts_with_all = ["charge_s", "charge_irradiance", "charging"])]
    pub saturated: bool,
    /// The sample was charged from dark for this many seconds under flat light before
    /// switch-off (> 0). Λ is then Λ·r(0), which `phos fit-excitation` corrects once k_e is known.
    #[arg(long, conflicts_with = "charging")]
    pub charge_s: Option<f64>,
    /// With --charge-s: |E| of the flat charging light in the units of k_e [default: 1, Table 1's].
    #[arg(long, requires = "charge_s")]
    pub charge_irradiance: Option<f64>,
    /// Exposure time of every frame in s: the curve's values are window means over
    /// [time_s, time_s + exposure], so amplitudes (and Λ) are corrected per state by
    /// kτ/(1 − e^{−kτ}) (10 % for k = 0.227 s⁻¹ and 1 s). With --roi it is read from the series
    /// when all frames share one exposure; 0 turns the correction off.
    #[arg(long)]
    pub exposure_s: Option<f64>,
    /// The charging protocol as a `charging.json` file (`lumifit.charging/1`). Without any
    /// charging flag, `charging.json` beside the curve or manifest is read (synth phos-decay writes
    /// one); with none, saturation is assumed with a warning and recorded as unknown.
    #[arg(long)]
    pub charging: Option<PathBuf>,
    /// Output: material preset JSON (curve, --roi), CSV (--batch) or directory (--per-pixel).
    #[arg(long)]
    pub out: PathBuf,
    /// Decay plot PNG (curve mode).
    #[arg(long)]
    pub plot: Option<PathBuf>,
}

/// Runs a `lumifit phos` subcommand.
pub fn run(cmd: PhosCommand) -> Result<()> {
    let mut out = Outputs::new();
    let mut warn = |w: String| eprintln!("{w}");
    let text = match cmd {
        PhosCommand::Simulate(a) => job::run_simulate(&a.config(), &mut out, &mut warn)?,
        PhosCommand::FitDecay(a) => fit_decay(a.config(), &mut out)?,
        PhosCommand::CompareIntegrators(a) => {
            job::run_compare_integrators(&a.material, &a.out, &a.plot, &mut out)?
        }
        PhosCommand::MergeMaps(a) => job::run_merge_maps(&a.shards, &a.out, &mut out)?,
    };
    out.commit()?;
    emit(&text)
}

/// A progress bar on standard error with `template` (plain bar when the template is refused).
pub fn progress_bar(len: u64, template: &str) -> ProgressBar {
    let bar = ProgressBar::new(len);
    bar.set_style(
        ProgressStyle::with_template(template).unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    bar
}

/// A spinner on standard error with `template`.
fn spinner(template: &str) -> ProgressBar {
    let bar = ProgressBar::new_spinner();
    bar.set_style(
        ProgressStyle::with_template(template).unwrap_or_else(|_| ProgressStyle::default_spinner()),
    );
    bar
}

/// `fit-decay` with its bars: a spinner while a series decodes, a bar over the curves of a
/// batch, and for --per-pixel a decoding spinner, the plan line and a bar over rows of blocks.
fn fit_decay(job: FitDecayJob, out: &mut Outputs) -> Result<String> {
    let decode = Bar::new(|_| spinner("decoding {pos} frames {elapsed}"));
    let curves = Bar::new(|n| {
        progress_bar(
            n as u64,
            "{bar:40} {pos}/{len} curves ({per_sec}, eta {eta})",
        )
    });
    let (decode_cell, fit_cell) = (OnceLock::new(), OnceLock::new());
    let decode_bar =
        || decode_cell.get_or_init(|| spinner("decoding {pos} frames into tiles {elapsed}"));
    let fit_bar = || {
        fit_cell.get_or_init(|| {
            progress_bar(
                0,
                "fitting [{bar:30}] {pos}/{len} rows of blocks ({per_sec}, eta {eta})",
            )
        })
    };
    let planned = |p: &Plan| {
        decode_bar().suspend(|| eprintln!("{}", job::plan_line(p)));
        fit_bar().set_length(p.fit_units);
    };
    let hooks = PerPixelHooks {
        planned: &planned,
        decoded: &|| decode_bar().inc(1),
        fitted: &|| {
            if fit_bar().position() == 0 && !decode_bar().is_finished() {
                decode_bar().finish_and_clear();
            }
            fit_bar().inc(1)
        },
    };
    let progress = FitDecayProgress {
        decode: &decode,
        curves: &curves,
        per_pixel: &hooks,
        per_pixel_done: &|| {
            decode_bar().finish_and_clear();
            fit_bar().finish_and_clear();
        },
    };
    Ok(job::run_fit_decay(&job, out, &progress, &mut |w| {
        eprintln!("{w}")
    })?)
}

impl SimulateArgs {
    fn config(&self) -> SimulateJob {
        SimulateJob {
            material: self.material.clone(),
            history: self.history.clone(),
            dt: self.dt,
            integrator: match self.integrator {
                IntegratorArg::Exact => Integrator::Exact,
                IntegratorArg::Rk4 => Integrator::Rk4,
                IntegratorArg::Euler => Integrator::Euler,
            },
            camera: self.camera.clone(),
            out: self.out.clone(),
            plot: self.plot.clone(),
        }
    }
}

impl FitDecayArgs {
    fn config(self) -> FitDecayJob {
        FitDecayJob {
            curve: self.curve,
            series: self.series,
            roi: self.roi,
            dark: self.dark,
            batch: self.batch,
            per_pixel: self.per_pixel,
            block: self.block,
            memory_gb: self.memory_gb,
            tile: self.tile,
            shard: self.shard,
            materials: self.materials,
            material_budget: self.material_budget,
            scratch_dir: self.scratch_dir,
            states: self.states,
            per_channel: self.per_channel,
            background: self.background,
            spectrum: self.spectrum,
            bands: self.bands,
            camera: self.camera,
            name: self.name,
            saturated: self.saturated,
            charge_s: self.charge_s,
            charge_irradiance: self.charge_irradiance,
            exposure_s: self.exposure_s,
            charging: self.charging,
            out: self.out,
            plot: self.plot,
        }
    }
}
