//! `lumifit phos …` (phosphorescence): simulate a material under an irradiance history, fit
//! decay curves (one CSV curve or a batch) into the `phosphorescence` section of a preset.

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use clap::{Args, Subcommand, ValueEnum};
use lumifit::capture::{PhotoSeries, Roi};
use lumifit::io::phos_formats::{
    read_band_camera, read_curve, BatchCsv, BatchResultRow, HistoryCsv, SimulationCsv,
};
use lumifit::io::series::{load_series, series_files, SeriesOptions};
use lumifit::io::spectrum_csv::{read_multi_spectrum, read_spectrum};
use lumifit::io::Outputs;
use lumifit::phosphor::{
    self, fit_decay, AmplitudeModel, DecayCurve, DecayFitOptions, Integrator, StatesChoice,
};
use lumifit::pipeline::phos as pipe;
use lumifit::pipeline::phos_maps as pipe_maps;
use lumifit::plot::phosphor_sim::{simulate_chart_png, SimulateChart};
use lumifit::preset::phosphor::{decay_fit_preset, decay_flags_text, provenance_of_files};
use lumifit::preset::to_json_string;

pub use lumifit::preset::phosphor::resolve_material;

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
    match cmd {
        PhosCommand::Simulate(a) => simulate(&a),
        PhosCommand::FitDecay(a) => fit_decay_cmd(&a),
        PhosCommand::CompareIntegrators(a) => compare_integrators(&a),
        PhosCommand::MergeMaps(a) => merge_maps(&a),
    }
}

/// Registers `--plot` (when given) as an output.
fn declare_plot(out: &mut Outputs, plot: &Option<PathBuf>) -> Result<()> {
    if let Some(p) = plot {
        out.declare("--plot", p)?;
    }
    Ok(())
}

/// A progress bar on standard error with `template` (plain bar when the template is refused).
pub fn progress_bar(len: u64, template: &str) -> indicatif::ProgressBar {
    let bar = indicatif::ProgressBar::new(len);
    bar.set_style(
        indicatif::ProgressStyle::with_template(template)
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    bar
}

fn simulate(a: &SimulateArgs) -> Result<()> {
    let resolved = resolve_material(&a.material)?;
    let mut out = Outputs::new();
    out.inputs(resolved.path())
        .input(&a.history)
        .inputs(&a.camera);
    out.declare("--out", &a.out)?;
    declare_plot(&mut out, &a.plot)?;
    let material = resolved.material;
    let (hist_csv, hist_source) = HistoryCsv::read(&a.history, material.bands.len())?;
    if let Some(w) = hist_csv.deprecation(&hist_source) {
        eprintln!("warning: {w}");
    }
    let history = hist_csv.to_segments(&hist_source)?;
    let integrator = match a.integrator {
        IntegratorArg::Exact => Integrator::Exact,
        IntegratorArg::Rk4 => Integrator::Rk4,
        IntegratorArg::Euler => Integrator::Euler,
    };
    let camera = match &a.camera {
        Some(p) => Some(read_band_camera(p, &material.bands)?),
        None => None,
    };
    let input = format!(
        "{} (--integrator {:?}, --dt {} s)",
        a.history.display(),
        a.integrator,
        a.dt
    );
    let (sim, rgb) = pipe::simulate_checked(
        &material,
        &history,
        a.dt,
        integrator,
        camera.as_ref(),
        &input,
    )?;
    if let Some(p) = &a.plot {
        let chart = SimulateChart {
            material: &material,
            integrator,
            dt_s: a.dt,
            history: &history,
            sim: &sim,
            camera_rgb: rgb.as_deref(),
        };
        let png = simulate_chart_png(&chart).with_context(|| format!("--plot {}", p.display()))?;
        out.stage(p, &png)?;
    }
    let table = SimulationCsv::new(&material.bands, &sim, rgb.as_deref());
    out.stage_text(&a.out, &table.to_csv())?;
    out.commit()?;
    super::emit(&format!(
        "wrote {} samples of {} ({} states, {} bands) to {}{}",
        sim.t_s.len(),
        material.name,
        material.states.len(),
        material.bands.len(),
        a.out.display(),
        a.plot
            .as_ref()
            .map(|p| format!(" and the plot to {}", p.display()))
            .unwrap_or_default()
    ))
}

fn parse_states(s: &str) -> Result<StatesChoice> {
    match s.trim() {
        "auto" => Ok(StatesChoice::Auto {
            max: phosphor::decay::MAX_STATES,
        }),
        "1" => Ok(StatesChoice::Fixed(1)),
        "2" => Ok(StatesChoice::Fixed(2)),
        "3" => Ok(StatesChoice::Fixed(3)),
        other => bail!("--states: '{other}'; expected auto, 1, 2 or 3"),
    }
}

fn options(a: &FitDecayArgs) -> Result<DecayFitOptions> {
    Ok(DecayFitOptions {
        states: parse_states(&a.states)?,
        amplitudes: if a.per_channel {
            AmplitudeModel::PerChannel
        } else {
            AmplitudeModel::SharedSpectrum
        },
        background: a.background,
        ..DecayFitOptions::default()
    })
}

fn fit_decay_cmd(a: &FitDecayArgs) -> Result<()> {
    let opts = options(a)?;
    let charging_given = a.saturated
        || a.charge_s.is_some()
        || a.charge_irradiance.is_some()
        || a.charging.is_some()
        || a.exposure_s.is_some();
    if charging_given && (a.per_pixel || a.batch.is_some()) {
        bail!(
            "--saturated/--charge-s/--charge-irradiance/--charging/--exposure-s apply to one curve \
             (a curve CSV or --roi), whose preset records them; not to --batch or --per-pixel"
        );
    }
    if a.per_pixel || a.roi.is_some() || a.series.is_some() {
        let series = match (&a.series, &a.curve) {
            (Some(_), Some(_)) => {
                bail!("give the series either as the argument or with --series, not both")
            }
            (Some(s), None) | (None, Some(s)) => s,
            (None, None) => bail!("no series: give a manifest CSV or a folder of frames"),
        };
        if a.batch.is_some() {
            bail!("--batch cannot be combined with a photo series");
        }
        return match (a.per_pixel, &a.roi) {
            (true, Some(_)) => {
                bail!("give either --roi (one curve) or --per-pixel (maps), not both")
            }
            (true, None) => per_pixel(series, a, &opts),
            (false, Some(r)) => roi_fit(series, r, a, &opts),
            (false, None) => bail!("a photo series needs --roi x,y,w,h or --per-pixel"),
        };
    }
    match (&a.curve, &a.batch) {
        (Some(_), Some(_)) => bail!("give either a curve CSV or --batch, not both"),
        (None, None) => bail!("nothing to fit: give a curve CSV or --batch FILE.csv"),
        (None, Some(b)) => batch(b, a, &opts),
        (Some(c), None) => single(c, a, &opts),
    }
}

/// Inputs and outputs of a one-curve fit: `inputs` (the curve, or the series and its frames and
/// darks), the spectrum and camera; then `--out` and `--plot`.
fn fit_outputs(inputs: &[PathBuf], a: &FitDecayArgs) -> Result<Outputs> {
    let mut out = Outputs::new();
    out.inputs(inputs)
        .inputs(&a.spectrum)
        .inputs(&a.camera)
        .inputs(&a.charging);
    out.declare("--out", &a.out)?;
    declare_plot(&mut out, &a.plot)?;
    Ok(out)
}

fn single(path: &Path, a: &FitDecayArgs, opts: &DecayFitOptions) -> Result<()> {
    let out = fit_outputs(&[path.to_path_buf()], a)?;
    let curve = read_curve(path)?;
    fit_and_write(out, path, curve, a, opts, None, None)
}

fn load_series_with_bar(path: &Path, darks: &[PathBuf]) -> Result<PhotoSeries> {
    let bar = indicatif::ProgressBar::new_spinner();
    bar.set_style(
        indicatif::ProgressStyle::with_template("decoding {pos} frames {elapsed}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_spinner()),
    );
    let options = SeriesOptions {
        t0_s: None,
        darks: darks.to_vec(),
    };
    let loaded = load_series(path, &options, &|| bar.inc(1));
    bar.finish_and_clear();
    let loaded = loaded.with_context(|| format!("loading series {}", path.display()))?;
    for w in &loaded.warnings {
        eprintln!("warning: {w}");
    }
    Ok(loaded.series)
}

fn roi_fit(series_path: &Path, roi: &str, a: &FitDecayArgs, opts: &DecayFitOptions) -> Result<()> {
    let mut inputs = series_files(series_path)?;
    inputs.extend(a.dark.iter().cloned());
    let out = fit_outputs(&inputs, a)?;
    let roi = Roi::parse_rect(roi)?;
    let series = load_series_with_bar(series_path, &a.dark)?;
    let curve = pipe::roi_curve(&series, &roi, &series_path.display().to_string())?;
    let exposure = pipe::series_exposure_s(&series);
    if exposure.is_none() && a.exposure_s.is_none() {
        eprintln!(
            "warning: {}: the frames' exposures differ, so the amplitudes are not corrected for \
             exposure windows; give --exposure-s to correct for one exposure time",
            series_path.display()
        );
    }
    fit_and_write(
        out,
        series_path,
        curve,
        a,
        opts,
        Some(roi.describe()),
        exposure,
    )
}

fn fit_and_write(
    mut out: Outputs,
    path: &Path,
    curve: DecayCurve,
    a: &FitDecayArgs,
    opts: &DecayFitOptions,
    roi: Option<String>,
    series_exposure_s: Option<f64>,
) -> Result<()> {
    let fit = fit_decay(&curve, opts).with_context(|| format!("{}: decay fit", path.display()))?;
    let source = path.display().to_string();
    let sd = a.spectrum.as_ref().map(|p| read_spectrum(p)).transpose()?;
    let sens = a
        .camera
        .as_ref()
        .map(|p| read_multi_spectrum(p))
        .transpose()?;
    let sp_source = a.spectrum.as_ref().map(|p| p.display().to_string());
    let spectrum = sd.as_ref().map(|sd| pipe::EmissionSpectrum {
        wavelengths_nm: sd.wavelengths(),
        values: sd.values(),
        source: sp_source.as_deref().unwrap_or("--spectrum"),
        n_bands: a.bands,
    });
    let label = a
        .camera
        .as_ref()
        .map_or(pipe::BOX_CAMERA_LABEL.to_string(), |p| {
            p.display().to_string()
        });
    let camera = pipe::RecordingCamera {
        sensitivities: sens.as_ref(),
        label: &label,
    };
    let mut dp = pipe::decay_preset(&fit, &curve, &source, spectrum, camera)?;
    let (charging, origin) = pipe::decay_charging_for(path, &charging_flags(a))?;
    match &origin {
        pipe::ChargingOrigin::File(f) => eprintln!(
            "note: charging protocol from {}: {}",
            f.display(),
            charging.describe()
        ),
        pipe::ChargingOrigin::Unknown => eprintln!(
            "WARNING: {}: the charging protocol is unknown, so saturation at switch-off (r = 1) \
             is assumed and Λ may be far too low (a sample charged 90 min under |E| = 1 light \
             can sit at r = 0.18); give --saturated, --charge-s S [--charge-irradiance E] or \
             --charging FILE.json. The assumption is recorded in the preset.",
            path.display()
        ),
        pipe::ChargingOrigin::Flags => {}
    }
    dp.record.assumption = pipe::charging_assumption(&charging);
    dp.record.charging = Some(charging);
    match a.exposure_s.or(series_exposure_s) {
        Some(0.0) => {}
        Some(tau) => {
            let f = pipe::correct_for_exposure(&mut dp, tau)?;
            if a.exposure_s.is_none() {
                eprintln!(
                    "note: amplitudes corrected for the series' exposure of {tau} s (×{f:.4?} per state)"
                );
            }
        }
        None => {}
    }
    if let Some(r) = &roi {
        dp.record.roi = Some(r.clone());
        dp.record.series = Some(source.clone());
        dp.record.units =
            Some("relative radiance: frame value / (exposure_s * ISO/100 / f_number^2)".into());
    }
    let mut files: Vec<&Path> = Vec::new();
    if path.is_file() {
        files.push(path);
    }
    files.extend(a.spectrum.as_deref());
    if let pipe::ChargingOrigin::File(f) = &origin {
        files.push(f);
    }
    if a.spectrum.is_some() {
        files.extend(a.camera.as_deref());
    }
    let provenance = provenance_of_files("lumifit phos fit-decay", &files)?.with_fit_quality(
        serde_json::json!({
            "rms": fit.rms, "n_states": fit.states.len(), "flags": decay_flags_text(&fit)
        }),
    );
    let name = a.name.clone().unwrap_or_else(|| {
        path.file_stem()
            .map_or("material".into(), |s| s.to_string_lossy().to_string())
    });
    let preset = decay_fit_preset(&name, provenance, dp.bands, dp.states, &dp.record)?;
    out.stage_text(&a.out, &to_json_string(&preset)?)?;
    if let Some(p) = &a.plot {
        let title = format!("{name}: decay fit, {} state(s)", fit.states.len());
        out.stage(p, &lumifit::plot::decay_chart_png(&title, &curve, &fit)?)?;
    }
    out.commit()?;
    super::emit(&serde_json::to_string_pretty(&dp.record)?)
}

fn charging_flags(a: &FitDecayArgs) -> pipe::ChargingFlags {
    pipe::ChargingFlags {
        saturated: a.saturated,
        charge_s: a.charge_s,
        charge_irradiance: a.charge_irradiance,
        file: a.charging.clone(),
    }
}

fn batch(path: &Path, a: &FitDecayArgs, opts: &DecayFitOptions) -> Result<()> {
    let mut out = Outputs::new();
    out.input(path);
    out.declare("--out", &a.out)?;
    let curves = BatchCsv::read(path)?;
    let bar = progress_bar(
        curves.curves.len() as u64,
        "{bar:40} {pos}/{len} curves ({per_sec}, eta {eta})",
    );
    let start = std::time::Instant::now();
    let rows = pipe::fit_batch(&curves, opts, &path.display().to_string(), &|| bar.inc(1));
    bar.finish_and_clear();
    let rows = rows?;
    let secs = start.elapsed().as_secs_f64();
    out.stage_text(&a.out, &BatchResultRow::to_csv(&rows))?;
    out.commit()?;
    super::emit(&format!(
        "fitted {} curves in {:.3} s ({:.0} curves/s, {} threads) → {}",
        rows.len(),
        secs,
        rows.len() as f64 / secs.max(1e-9),
        rayon::current_num_threads(),
        a.out.display()
    ))
}

fn per_pixel_config(a: &FitDecayArgs) -> Result<pipe_maps::PerPixelConfig> {
    let memory_mib = match a.memory_gb {
        None => lumifit::limits::memory_budget_mib(),
        Some(g) if g.is_finite() && g > 0.0 => (g * 1024.0) as u64,
        Some(g) => bail!("--memory-gb {g}: expected a positive number of GiB"),
    };
    Ok(pipe_maps::PerPixelConfig {
        block: a.block,
        tile: a.tile,
        memory_mib,
        scratch_dir: a.scratch_dir.clone().unwrap_or_else(std::env::temp_dir),
        shard: a
            .shard
            .as_deref()
            .map(pipe_maps::Shard::parse)
            .transpose()?,
        darks: a.dark.clone(),
        threads: rayon::current_num_threads(),
    })
}

fn materials_count(a: &FitDecayArgs) -> Result<Option<lumifit::phosphor::cluster::MaterialCount>> {
    use lumifit::phosphor::cluster::{MaterialCount, MAX_MATERIALS};
    let Some(m) = a.materials.as_deref() else {
        return Ok(None);
    };
    if !(a.material_budget.is_finite() && a.material_budget > 0.0) {
        bail!(
            "--material-budget {}: expected a positive fraction, e.g. 0.02",
            a.material_budget
        );
    }
    Ok(Some(match m.trim() {
        "auto" => MaterialCount::Auto {
            max: MAX_MATERIALS,
            budget: a.material_budget,
        },
        k => MaterialCount::Fixed(k.parse().ok().filter(|k| *k > 0).ok_or_else(|| {
            anyhow::anyhow!("--materials '{k}': expected auto or a number of materials ≥ 1")
        })?),
    }))
}

fn per_pixel(series_path: &Path, a: &FitDecayArgs, opts: &DecayFitOptions) -> Result<()> {
    if a.spectrum.is_some() || a.plot.is_some() {
        bail!("--spectrum and --plot apply to one curve; with --per-pixel the maps are the output");
    }
    let cfg = per_pixel_config(a)?;
    let count = materials_count(a)?;
    if count.is_some() && cfg.shard.is_some() {
        bail!("--materials needs the whole map: run it without --shard");
    }
    let mut out = Outputs::new();
    out.inputs(series_files(series_path)?).inputs(&a.dark);
    out.declare_dir("--out", &a.out)?;
    let decode_bar = indicatif::ProgressBar::new_spinner();
    decode_bar.set_style(
        indicatif::ProgressStyle::with_template("decoding {pos} frames into tiles {elapsed}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_spinner()),
    );
    let fit_bar = progress_bar(
        0,
        "fitting [{bar:30}] {pos}/{len} rows of blocks ({per_sec}, eta {eta})",
    );
    let planned = |p: &pipe_maps::Plan| {
        decode_bar.suspend(|| {
            eprintln!(
                "per-pixel plan: {}×{} px, {} frames, tiles of {} px ({} tiles, {} here), samples as {:?} in {} ({:.0} MiB), {} frame(s) decoded at once; peak estimate {:.0} MiB of the {} MiB budget",
                p.frame_size[0], p.frame_size[1], p.frames, p.tile_px, p.tiles,
                p.tiles_held[1] - p.tiles_held[0], p.encoding, p.storage, p.store_mib,
                p.frames_in_flight, p.peak_estimate_mib, p.budget_mib
            )
        });
        fit_bar.set_length(p.fit_units);
    };
    let hooks = pipe_maps::PerPixelHooks {
        planned: &planned,
        decoded: &|| decode_bar.inc(1),
        fitted: &|| {
            if fit_bar.position() == 0 && !decode_bar.is_finished() {
                decode_bar.finish_and_clear();
            }
            fit_bar.inc(1)
        },
    };
    let run = pipe_maps::fit_per_pixel(series_path, opts, &cfg, &hooks);
    decode_bar.finish_and_clear();
    fit_bar.finish_and_clear();
    let run = run.with_context(|| format!("{}: per-pixel fit", series_path.display()))?;
    for w in &run.warnings {
        eprintln!("warning: {w}");
    }
    if run.reencoded {
        eprintln!("note: a frame is not on the 16-bit grid, so the tiles hold f32 samples and every frame was decoded twice");
    }
    let series = series_path.display().to_string();
    let mut names = Vec::new();
    let mut materials = serde_json::Value::Null;
    if let Some(count) = count {
        let name = a.name.clone().unwrap_or_else(|| "scene".into());
        let (files, report) =
            pipe_maps::material_files(&run.maps, &run.times.t_s, count, series_path, &name)?;
        for (name, bytes) in files {
            out.stage(a.out.join(&name), &bytes)?;
            names.push(name);
        }
        materials = report;
    }
    if cfg.shard.is_some() {
        for (name, bytes) in pipe_maps::shard_files(&run, &series)? {
            out.stage(a.out.join(&name), &bytes)?;
            names.push(name);
        }
    } else {
        pipe::each_pixel_map_file(&run.maps, &mut |name, bytes| {
            out.stage(a.out.join(name), &bytes)?;
            names.push(name.to_string());
            Ok(())
        })?;
        let name = a.name.clone().unwrap_or_else(|| "per-pixel maps".into());
        let (extras, _) = pipe_maps::map_extras(&run.maps, &name, &[series_path.to_path_buf()])?;
        for (name, bytes) in extras {
            out.stage(a.out.join(&name), &bytes)?;
            names.push(name);
        }
    }
    let blocks = run.maps.width * run.maps.height;
    let timing = serde_json::json!({
        "decode_s": run.decode_s,
        "fit_s": run.fit_s,
        "blocks_per_s": blocks as f64 / run.fit_s.max(1e-9),
        "threads": cfg.threads,
        "peak_rss_mib": pipe_maps::peak_rss_mib(),
    });
    let summary = pipe_maps::per_pixel_summary(
        &series,
        &run.maps,
        run.plan.frames,
        run.plan.frame_size,
        &names,
        timing,
        serde_json::to_value(&run.plan)?,
    );
    let mut summary = summary;
    if !materials.is_null() {
        summary["materials"] = materials;
    }
    let text = serde_json::to_string_pretty(&summary)?;
    out.stage_text(a.out.join("summary.json"), &text)?;
    out.commit()?;
    super::emit(&text)
}

fn merge_maps(a: &MergeMapsArgs) -> Result<()> {
    let mut out = Outputs::new();
    for d in &a.shards {
        out.input(d.join(pipe_maps::SHARD_MANIFEST))
            .input(d.join(pipe_maps::SHARD_DATA));
    }
    out.declare_dir("--out", &a.out)?;
    let merged = pipe_maps::merge_shards(&a.shards)?;
    let mut names = Vec::new();
    pipe::each_pixel_map_file(&merged.maps, &mut |name, bytes| {
        out.stage(a.out.join(name), &bytes)?;
        names.push(name.to_string());
        Ok(())
    })?;
    let manifests: Vec<PathBuf> = a
        .shards
        .iter()
        .map(|d| d.join(pipe_maps::SHARD_MANIFEST))
        .collect();
    let (extras, _) = pipe_maps::map_extras(&merged.maps, "per-pixel maps", &manifests)?;
    for (name, bytes) in extras {
        out.stage(a.out.join(&name), &bytes)?;
        names.push(name);
    }
    let m0 = &merged.manifests[0];
    let timing = serde_json::json!({
        "shard_seconds": merged.manifests.iter().map(|m| m.seconds).collect::<Vec<_>>(),
    });
    let summary = pipe_maps::per_pixel_summary(
        &m0.series,
        &merged.maps,
        m0.frames,
        m0.frame_size,
        &names,
        timing,
        serde_json::json!({
            "shards": merged.manifests.len(),
            "fingerprint": m0.fingerprint,
            "shard_plans": merged.manifests.iter().map(|m| m.plan.clone()).collect::<Vec<_>>(),
        }),
    );
    let text = serde_json::to_string_pretty(&summary)?;
    out.stage_text(a.out.join("summary.json"), &text)?;
    out.commit()?;
    super::emit(&text)
}

fn compare_integrators(a: &CompareArgs) -> Result<()> {
    let resolved = resolve_material(&a.material)?;
    let mut out = Outputs::new();
    out.inputs(resolved.path());
    out.declare("--out", &a.out)?;
    declare_plot(&mut out, &a.plot)?;
    let material = resolved.material;
    let rows = pipe::compare_integrators(&material)?;
    let csv = pipe::integrators_csv(&rows);
    out.stage_text(&a.out, &csv)?;
    if let Some(p) = &a.plot {
        let title = format!(
            "{}: max relative emission error vs run time (exact = 0)",
            material.name
        );
        let series = pipe::integrator_chart_series(&rows);
        out.stage(p, &lumifit::plot::integrator_chart_png(&title, &series)?)?;
    }
    out.commit()?;
    super::emit(&csv)
}
