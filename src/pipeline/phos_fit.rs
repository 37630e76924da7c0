//! Phosphorescence commands (`lumifit phos simulate|fit-decay|compare-integrators|merge-maps`):
//! what each does between its flags and its printed line — resolve the material, simulate Eq. 1
//! or fit decay curves (one CSV curve, a region of a photo series, a batch, or every pixel of a
//! series), assemble the preset, the maps or the table with its chart, and stage every output in
//! the caller's [`Outputs`]. The caller commits and prints.
//!
//! Warnings and notes go to the caller's `warn` as whole lines at the moment they arise;
//! progress goes to a [`Progress`] or [`PerPixelHooks`] the caller draws.

use std::path::{Path, PathBuf};

use serde_json::{json, Value};

use crate::capture::Roi;
use crate::error::{Error, Result};
use crate::io::phos_formats::{
    read_band_camera, read_curve, BatchCsv, BatchResultRow, HistoryCsv, SimulationCsv,
};
use crate::io::series::{load_series, series_files, SeriesOptions};
use crate::io::spectrum_csv::{read_multi_spectrum, read_spectrum};
use crate::io::Outputs;
use crate::phosphor::cluster::{MaterialCount, MAX_MATERIALS};
use crate::phosphor::{
    self, fit_decay, AmplitudeModel, DecayCurve, DecayFitOptions, Integrator, StatesChoice,
};
use crate::pipeline::phos as pipe;
use crate::pipeline::phos_maps::{self as pipe_maps, PerPixelHooks, Plan};
use crate::pipeline::Progress;
use crate::plot::phosphor_sim::{simulate_chart_png, SimulateChart};
use crate::preset::phosphor::{
    decay_fit_preset, decay_flags_text, provenance_of_files, resolve_material,
};
use crate::preset::to_json_string;

/// Pretty JSON; a serialisation failure is [`Error::Numerical`] ([`crate::io::pretty_json`]).
fn pretty<T: serde::Serialize + ?Sized>(v: &T) -> Result<String> {
    crate::io::pretty_json(v, "JSON serialisation")
}

/// Declares `--plot` when given.
fn declare_plot(out: &mut Outputs, plot: &Option<PathBuf>) -> Result<()> {
    if let Some(p) = plot {
        out.declare("--plot", p)?;
    }
    Ok(())
}

/// `phos simulate`: Eq. 1 under a piecewise-constant irradiance history.
#[derive(Debug, Clone)]
pub struct SimulateJob {
    /// A Table 1 name or a material preset JSON.
    pub material: String,
    /// Irradiance history CSV.
    pub history: PathBuf,
    /// Largest time step, s (also the output sampling).
    pub dt: f64,
    /// Integrator.
    pub integrator: Integrator,
    /// Camera CSV (adds r,g,b columns).
    pub camera: Option<PathBuf>,
    /// Output CSV.
    pub out: PathBuf,
    /// Chart PNG.
    pub plot: Option<PathBuf>,
}

/// Registers the inputs, declares the CSV (and chart), simulates, stages them and returns the
/// line to print.
pub fn run_simulate(
    job: &SimulateJob,
    out: &mut Outputs,
    warn: &mut dyn FnMut(String),
) -> Result<String> {
    let resolved = resolve_material(&job.material)?;
    out.inputs(resolved.path())
        .input(&job.history)
        .inputs(&job.camera);
    out.declare("--out", &job.out)?;
    declare_plot(out, &job.plot)?;
    let material = resolved.material;
    let (hist_csv, hist_source) = HistoryCsv::read(&job.history, material.bands.len())?;
    if let Some(w) = hist_csv.deprecation(&hist_source) {
        warn(format!("warning: {w}"));
    }
    let history = hist_csv.to_segments(&hist_source)?;
    let camera = match &job.camera {
        Some(p) => Some(read_band_camera(p, &material.bands)?),
        None => None,
    };
    let input = format!(
        "{} (--integrator {:?}, --dt {} s)",
        job.history.display(),
        job.integrator,
        job.dt
    );
    let (sim, rgb) = pipe::simulate_checked(
        &material,
        &history,
        job.dt,
        job.integrator,
        camera.as_ref(),
        &input,
    )?;
    if let Some(p) = &job.plot {
        let chart = SimulateChart {
            material: &material,
            integrator: job.integrator,
            dt_s: job.dt,
            history: &history,
            sim: &sim,
            camera_rgb: rgb.as_deref(),
        };
        let png =
            simulate_chart_png(&chart).map_err(|e| e.context(format!("--plot {}", p.display())))?;
        out.stage(p, &png)?;
    }
    let table = SimulationCsv::new(&material.bands, &sim, rgb.as_deref());
    out.stage_text(&job.out, &table.to_csv())?;
    Ok(format!(
        "wrote {} samples of {} ({} states, {} bands) to {}{}",
        sim.t_s.len(),
        material.name,
        material.states.len(),
        material.bands.len(),
        job.out.display(),
        job.plot
            .as_ref()
            .map(|p| format!(" and the plot to {}", p.display()))
            .unwrap_or_default()
    ))
}

/// `--states`: `auto` (BIC over 1–3) or 1, 2, 3.
pub fn parse_states(s: &str) -> Result<StatesChoice> {
    match s.trim() {
        "auto" => Ok(StatesChoice::Auto {
            max: phosphor::decay::MAX_STATES,
        }),
        "1" => Ok(StatesChoice::Fixed(1)),
        "2" => Ok(StatesChoice::Fixed(2)),
        "3" => Ok(StatesChoice::Fixed(3)),
        other => Err(Error::flag(
            "--states",
            format!("'{other}'; expected auto, 1, 2 or 3"),
        )),
    }
}

/// `phos fit-decay`, every flag as typed.
#[derive(Debug, Clone)]
pub struct FitDecayJob {
    /// Curve CSV, or with --roi / --per-pixel a photo series.
    pub curve: Option<PathBuf>,
    /// Photo series (manifest CSV or folder).
    pub series: Option<PathBuf>,
    /// Region `x,y,w,h` of the series.
    pub roi: Option<String>,
    /// Dark frames.
    pub dark: Vec<PathBuf>,
    /// Batch CSV of many curves.
    pub batch: Option<PathBuf>,
    /// Fit every pixel (or block) of a series.
    pub per_pixel: bool,
    /// Block side for --per-pixel.
    pub block: usize,
    /// Peak memory for --per-pixel, GiB.
    pub memory_gb: Option<f64>,
    /// Tile side for --per-pixel.
    pub tile: Option<usize>,
    /// `--shard i/n`.
    pub shard: Option<String>,
    /// `--materials auto|K`.
    pub materials: Option<String>,
    /// Budget of `--materials auto`.
    pub material_budget: f64,
    /// Folder for the tile scratch file.
    pub scratch_dir: Option<PathBuf>,
    /// `--states` as typed.
    pub states: String,
    /// Independent amplitudes per channel.
    pub per_channel: bool,
    /// Fit a constant background.
    pub background: bool,
    /// Emission spectrum CSV.
    pub spectrum: Option<PathBuf>,
    /// Uniform bands over 400–700 nm for --spectrum.
    pub bands: usize,
    /// Camera that recorded the curve.
    pub camera: Option<PathBuf>,
    /// Material name in the preset.
    pub name: Option<String>,
    /// Saturated at switch-off.
    pub saturated: bool,
    /// Charged from dark for this many seconds.
    pub charge_s: Option<f64>,
    /// |E| of the charging light.
    pub charge_irradiance: Option<f64>,
    /// Exposure of every frame, s (0: no correction).
    pub exposure_s: Option<f64>,
    /// `charging.json`.
    pub charging: Option<PathBuf>,
    /// Output: preset, CSV or directory.
    pub out: PathBuf,
    /// Decay chart PNG.
    pub plot: Option<PathBuf>,
}

/// What `phos fit-decay` draws while it runs.
pub struct FitDecayProgress<'a> {
    /// Frames of a series decoded (--roi).
    pub decode: &'a dyn Progress,
    /// Curves of a batch fitted.
    pub curves: &'a dyn Progress,
    /// The per-pixel run.
    pub per_pixel: &'a PerPixelHooks<'a>,
    /// Called when the per-pixel run has returned (its bars can go).
    pub per_pixel_done: &'a dyn Fn(),
}

/// The line `phos fit-decay --per-pixel` prints about its plan.
pub fn plan_line(p: &Plan) -> String {
    format!(
        "per-pixel plan: {}×{} px, {} frames, tiles of {} px ({} tiles, {} here), samples as {:?} in {} ({:.0} MiB), {} frame(s) decoded at once; peak estimate {:.0} MiB of the {} MiB budget",
        p.frame_size[0], p.frame_size[1], p.frames, p.tile_px, p.tiles,
        p.tiles_held[1] - p.tiles_held[0], p.encoding, p.storage, p.store_mib,
        p.frames_in_flight, p.peak_estimate_mib, p.budget_mib
    )
}

/// Picks the mode of `fit-decay` from its flags, fits, stages every output and returns the text
/// to print.
pub fn run_fit_decay(
    job: &FitDecayJob,
    out: &mut Outputs,
    progress: &FitDecayProgress<'_>,
    warn: &mut dyn FnMut(String),
) -> Result<String> {
    let opts = DecayFitOptions {
        states: parse_states(&job.states)?,
        amplitudes: if job.per_channel {
            AmplitudeModel::PerChannel
        } else {
            AmplitudeModel::SharedSpectrum
        },
        background: job.background,
        ..DecayFitOptions::default()
    };
    let charging_given = job.saturated
        || job.charge_s.is_some()
        || job.charge_irradiance.is_some()
        || job.charging.is_some()
        || job.exposure_s.is_some();
    if charging_given && (job.per_pixel || job.batch.is_some()) {
        return Err(Error::message(
            "--saturated/--charge-s/--charge-irradiance/--charging/--exposure-s apply to one curve \
             (a curve CSV or --roi), whose preset records them; not to --batch or --per-pixel",
        ));
    }
    if job.per_pixel || job.roi.is_some() || job.series.is_some() {
        let series = match (&job.series, &job.curve) {
            (Some(_), Some(_)) => {
                return Err(Error::message(
                    "give the series either as the argument or with --series, not both",
                ))
            }
            (Some(s), None) | (None, Some(s)) => s,
            (None, None) => {
                return Err(Error::message(
                    "no series: give a manifest CSV or a folder of frames",
                ))
            }
        };
        if job.batch.is_some() {
            return Err(Error::message(
                "--batch cannot be combined with a photo series",
            ));
        }
        return match (job.per_pixel, &job.roi) {
            (true, Some(_)) => Err(Error::message(
                "give either --roi (one curve) or --per-pixel (maps), not both",
            )),
            (true, None) => per_pixel(series, job, &opts, out, progress, warn),
            (false, Some(r)) => roi_fit(series, r, job, &opts, out, progress.decode, warn),
            (false, None) => Err(Error::message(
                "a photo series needs --roi x,y,w,h or --per-pixel",
            )),
        };
    }
    match (&job.curve, &job.batch) {
        (Some(_), Some(_)) => Err(Error::message(
            "give either a curve CSV or --batch, not both",
        )),
        (None, None) => Err(Error::message(
            "nothing to fit: give a curve CSV or --batch FILE.csv",
        )),
        (None, Some(b)) => batch(b, job, &opts, out, progress.curves),
        (Some(c), None) => {
            fit_outputs(&[c.to_path_buf()], job, out)?;
            let curve = read_curve(c)?;
            fit_and_stage(c, curve, job, &opts, None, None, out, warn)
        }
    }
}

/// Inputs and outputs of a one-curve fit: `inputs` (the curve, or the series and its frames and
/// darks), the spectrum and camera; then `--out` and `--plot`.
fn fit_outputs(inputs: &[PathBuf], job: &FitDecayJob, out: &mut Outputs) -> Result<()> {
    out.inputs(inputs)
        .inputs(&job.spectrum)
        .inputs(&job.camera)
        .inputs(&job.charging);
    out.declare("--out", &job.out)?;
    declare_plot(out, &job.plot)
}

fn roi_fit(
    series_path: &Path,
    roi: &str,
    job: &FitDecayJob,
    opts: &DecayFitOptions,
    out: &mut Outputs,
    progress: &dyn Progress,
    warn: &mut dyn FnMut(String),
) -> Result<String> {
    let mut inputs = series_files(series_path)?;
    inputs.extend(job.dark.iter().cloned());
    fit_outputs(&inputs, job, out)?;
    let roi = Roi::parse_rect(roi)?;
    let options = SeriesOptions {
        t0_s: None,
        darks: job.dark.to_vec(),
    };
    progress.start(inputs.len());
    let loaded = load_series(series_path, &options, &|| progress.inc());
    progress.finish();
    let loaded =
        loaded.map_err(|e| e.context(format!("loading series {}", series_path.display())))?;
    for w in &loaded.warnings {
        warn(format!("warning: {w}"));
    }
    let series = loaded.series;
    let curve = pipe::roi_curve(&series, &roi, &series_path.display().to_string())?;
    let exposure = pipe::series_exposure_s(&series);
    if exposure.is_none() && job.exposure_s.is_none() {
        warn(format!(
            "warning: {}: the frames' exposures differ, so the amplitudes are not corrected for \
             exposure windows; give --exposure-s to correct for one exposure time",
            series_path.display()
        ));
    }
    fit_and_stage(
        series_path,
        curve,
        job,
        opts,
        Some(roi.describe()),
        exposure,
        out,
        warn,
    )
}

#[allow(clippy::too_many_arguments)]
fn fit_and_stage(
    path: &Path,
    curve: DecayCurve,
    job: &FitDecayJob,
    opts: &DecayFitOptions,
    roi: Option<String>,
    series_exposure_s: Option<f64>,
    out: &mut Outputs,
    warn: &mut dyn FnMut(String),
) -> Result<String> {
    let fit =
        fit_decay(&curve, opts).map_err(|e| e.context(format!("{}: decay fit", path.display())))?;
    let source = path.display().to_string();
    let sd = job
        .spectrum
        .as_ref()
        .map(|p| read_spectrum(p))
        .transpose()?;
    let sens = job
        .camera
        .as_ref()
        .map(|p| read_multi_spectrum(p))
        .transpose()?;
    let sp_source = job.spectrum.as_ref().map(|p| p.display().to_string());
    let spectrum = sd.as_ref().map(|sd| pipe::EmissionSpectrum {
        wavelengths_nm: sd.wavelengths(),
        values: sd.values(),
        source: sp_source.as_deref().unwrap_or("--spectrum"),
        n_bands: job.bands,
    });
    let label = job
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
    let flags = pipe::ChargingFlags {
        saturated: job.saturated,
        charge_s: job.charge_s,
        charge_irradiance: job.charge_irradiance,
        file: job.charging.clone(),
    };
    let (charging, origin) = pipe::decay_charging_for(path, &flags)?;
    match &origin {
        pipe::ChargingOrigin::File(f) => warn(format!(
            "note: charging protocol from {}: {}",
            f.display(),
            charging.describe()
        )),
        pipe::ChargingOrigin::Unknown => warn(format!(
            "WARNING: {}: the charging protocol is unknown, so saturation at switch-off (r = 1) \
             is assumed and Λ may be far too low (a sample charged 90 min under |E| = 1 light \
             can sit at r = 0.18); give --saturated, --charge-s S [--charge-irradiance E] or \
             --charging FILE.json. The assumption is recorded in the preset.",
            path.display()
        )),
        pipe::ChargingOrigin::Flags => {}
    }
    dp.record.assumption = pipe::charging_assumption(&charging);
    dp.record.charging = Some(charging);
    match job.exposure_s.or(series_exposure_s) {
        Some(0.0) => {}
        Some(tau) => {
            let f = pipe::correct_for_exposure(&mut dp, tau)?;
            if job.exposure_s.is_none() {
                warn(format!(
                    "note: amplitudes corrected for the series' exposure of {tau} s (×{f:.4?} per state)"
                ));
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
    files.extend(job.spectrum.as_deref());
    if let pipe::ChargingOrigin::File(f) = &origin {
        files.push(f);
    }
    if job.spectrum.is_some() {
        files.extend(job.camera.as_deref());
    }
    let provenance =
        provenance_of_files("lumifit phos fit-decay", &files)?.with_fit_quality(json!({
            "rms": fit.rms, "n_states": fit.states.len(), "flags": decay_flags_text(&fit)
        }));
    let name = job.name.clone().unwrap_or_else(|| {
        path.file_stem()
            .map_or("material".into(), |s| s.to_string_lossy().to_string())
    });
    let preset = decay_fit_preset(&name, provenance, dp.bands, dp.states, &dp.record)?;
    out.stage_text(&job.out, &to_json_string(&preset)?)?;
    if let Some(p) = &job.plot {
        let title = format!("{name}: decay fit, {} state(s)", fit.states.len());
        out.stage(p, &crate::plot::decay_chart_png(&title, &curve, &fit)?)?;
    }
    pretty(&dp.record)
}

fn batch(
    path: &Path,
    job: &FitDecayJob,
    opts: &DecayFitOptions,
    out: &mut Outputs,
    progress: &dyn Progress,
) -> Result<String> {
    out.input(path);
    out.declare("--out", &job.out)?;
    let curves = BatchCsv::read(path)?;
    progress.start(curves.curves.len());
    let start = std::time::Instant::now();
    let rows = pipe::fit_batch(&curves, opts, &path.display().to_string(), &|| {
        progress.inc()
    });
    progress.finish();
    let rows = rows?;
    let secs = start.elapsed().as_secs_f64();
    out.stage_text(&job.out, &BatchResultRow::to_csv(&rows))?;
    Ok(format!(
        "fitted {} curves in {:.3} s ({:.0} curves/s, {} threads) → {}",
        rows.len(),
        secs,
        rows.len() as f64 / secs.max(1e-9),
        rayon::current_num_threads(),
        job.out.display()
    ))
}

/// The per-pixel configuration of the flags.
pub fn per_pixel_config(job: &FitDecayJob) -> Result<pipe_maps::PerPixelConfig> {
    let memory_mib = match job.memory_gb {
        None => crate::limits::memory_budget_mib(),
        Some(g) if g.is_finite() && g > 0.0 => (g * 1024.0) as u64,
        Some(g) => {
            return Err(Error::flag(
                format!("--memory-gb {g}"),
                "expected a positive number of GiB",
            ))
        }
    };
    Ok(pipe_maps::PerPixelConfig {
        block: job.block,
        tile: job.tile,
        memory_mib,
        scratch_dir: job.scratch_dir.clone().unwrap_or_else(std::env::temp_dir),
        shard: job
            .shard
            .as_deref()
            .map(pipe_maps::Shard::parse)
            .transpose()?,
        darks: job.dark.clone(),
        threads: rayon::current_num_threads(),
    })
}

/// `--materials auto|K` with `--material-budget`.
pub fn materials_count(materials: Option<&str>, budget: f64) -> Result<Option<MaterialCount>> {
    let Some(m) = materials else {
        return Ok(None);
    };
    if !(budget.is_finite() && budget > 0.0) {
        return Err(Error::flag(
            format!("--material-budget {budget}"),
            "expected a positive fraction, e.g. 0.02",
        ));
    }
    Ok(Some(match m.trim() {
        "auto" => MaterialCount::Auto {
            max: MAX_MATERIALS,
            budget,
        },
        k => MaterialCount::Fixed(k.parse().ok().filter(|k| *k > 0).ok_or_else(|| {
            Error::flag(
                format!("--materials '{k}'"),
                "expected auto or a number of materials ≥ 1",
            )
        })?),
    }))
}

fn per_pixel(
    series_path: &Path,
    job: &FitDecayJob,
    opts: &DecayFitOptions,
    out: &mut Outputs,
    progress: &FitDecayProgress<'_>,
    warn: &mut dyn FnMut(String),
) -> Result<String> {
    if job.spectrum.is_some() || job.plot.is_some() {
        return Err(Error::message(
            "--spectrum and --plot apply to one curve; with --per-pixel the maps are the output",
        ));
    }
    let cfg = per_pixel_config(job)?;
    let count = materials_count(job.materials.as_deref(), job.material_budget)?;
    if count.is_some() && cfg.shard.is_some() {
        return Err(Error::message(
            "--materials needs the whole map: run it without --shard",
        ));
    }
    out.inputs(series_files(series_path)?).inputs(&job.dark);
    out.declare_dir("--out", &job.out)?;
    let run = pipe_maps::fit_per_pixel(series_path, opts, &cfg, progress.per_pixel);
    (progress.per_pixel_done)();
    let run = run.map_err(|e| e.context(format!("{}: per-pixel fit", series_path.display())))?;
    for w in &run.warnings {
        warn(format!("warning: {w}"));
    }
    if run.reencoded {
        warn("note: a frame is not on the 16-bit grid, so the tiles hold f32 samples and every frame was decoded twice".into());
    }
    let series = series_path.display().to_string();
    let mut names = Vec::new();
    let mut materials = Value::Null;
    if let Some(count) = count {
        let name = job.name.clone().unwrap_or_else(|| "scene".into());
        let (files, report) =
            pipe_maps::material_files(&run.maps, &run.times.t_s, count, series_path, &name)?;
        for (name, bytes) in files {
            out.stage(job.out.join(&name), &bytes)?;
            names.push(name);
        }
        materials = report;
    }
    if cfg.shard.is_some() {
        for (name, bytes) in pipe_maps::shard_files(&run, &series)? {
            out.stage(job.out.join(&name), &bytes)?;
            names.push(name);
        }
    } else {
        pipe::each_pixel_map_file(&run.maps, &mut |name, bytes| {
            out.stage(job.out.join(name), &bytes)?;
            names.push(name.to_string());
            Ok(())
        })?;
        let name = job.name.clone().unwrap_or_else(|| "per-pixel maps".into());
        let (extras, _) = pipe_maps::map_extras(&run.maps, &name, &[series_path.to_path_buf()])?;
        for (name, bytes) in extras {
            out.stage(job.out.join(&name), &bytes)?;
            names.push(name);
        }
    }
    let blocks = run.maps.width * run.maps.height;
    let timing = json!({
        "decode_s": run.decode_s,
        "fit_s": run.fit_s,
        "blocks_per_s": blocks as f64 / run.fit_s.max(1e-9),
        "threads": cfg.threads,
        "peak_rss_mib": pipe_maps::peak_rss_mib(),
    });
    let plan = serde_json::to_value(&run.plan).map_err(|e| Error::Numerical {
        what: "JSON serialisation".into(),
        reason: e.to_string(),
    })?;
    let mut summary = pipe_maps::per_pixel_summary(
        &series,
        &run.maps,
        run.plan.frames,
        run.plan.frame_size,
        &names,
        timing,
        plan,
    );
    if !materials.is_null() {
        summary["materials"] = materials;
    }
    let text = pretty(&summary)?;
    out.stage_text(job.out.join("summary.json"), &text)?;
    Ok(text)
}

/// `phos merge-maps`: registers the shards, declares the folder, merges, stages the full map
/// set and returns the summary text to print.
pub fn run_merge_maps(shards: &[PathBuf], dir: &Path, out: &mut Outputs) -> Result<String> {
    for d in shards {
        out.input(d.join(pipe_maps::SHARD_MANIFEST))
            .input(d.join(pipe_maps::SHARD_DATA));
    }
    out.declare_dir("--out", dir)?;
    let merged = pipe_maps::merge_shards(shards)?;
    let mut names = Vec::new();
    pipe::each_pixel_map_file(&merged.maps, &mut |name, bytes| {
        out.stage(dir.join(name), &bytes)?;
        names.push(name.to_string());
        Ok(())
    })?;
    let manifests: Vec<PathBuf> = shards
        .iter()
        .map(|d| d.join(pipe_maps::SHARD_MANIFEST))
        .collect();
    let (extras, _) = pipe_maps::map_extras(&merged.maps, "per-pixel maps", &manifests)?;
    for (name, bytes) in extras {
        out.stage(dir.join(&name), &bytes)?;
        names.push(name);
    }
    let m0 = &merged.manifests[0];
    let timing = json!({
        "shard_seconds": merged.manifests.iter().map(|m| m.seconds).collect::<Vec<_>>(),
    });
    let summary = pipe_maps::per_pixel_summary(
        &m0.series,
        &merged.maps,
        m0.frames,
        m0.frame_size,
        &names,
        timing,
        json!({
            "shards": merged.manifests.len(),
            "fingerprint": m0.fingerprint,
            "shard_plans": merged.manifests.iter().map(|m| m.plan.clone()).collect::<Vec<_>>(),
        }),
    );
    let text = pretty(&summary)?;
    out.stage_text(dir.join("summary.json"), &text)?;
    Ok(text)
}

/// `phos compare-integrators`: registers the material, declares the table (and chart), runs the
/// comparison, stages them and returns the CSV to print.
pub fn run_compare_integrators(
    material: &str,
    table: &Path,
    plot: &Option<PathBuf>,
    out: &mut Outputs,
) -> Result<String> {
    let resolved = resolve_material(material)?;
    out.inputs(resolved.path());
    out.declare("--out", table)?;
    declare_plot(out, plot)?;
    let material = resolved.material;
    let rows = pipe::compare_integrators(&material)?;
    let csv = pipe::integrators_csv(&rows);
    out.stage_text(table, &csv)?;
    if let Some(p) = plot {
        let title = format!(
            "{}: max relative emission error vs run time (exact = 0)",
            material.name
        );
        let series = pipe::integrator_chart_series(&rows);
        out.stage(p, &crate::plot::integrator_chart_png(&title, &series)?)?;
    }
    Ok(csv)
}
