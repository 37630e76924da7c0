//! `lumifit phos …` (phosphorescence): simulate a material under an irradiance history, fit
//! decay curves (one CSV curve or a batch) into the `phosphorescence` section of a preset.

use std::path::{Path, PathBuf};

use anyhow::{anyhow, bail, Context, Result};
use clap::{Args, Subcommand, ValueEnum};
use lumifit::capture::{PhotoSeries, Roi};
use lumifit::io::series::{load_series, SeriesOptions};
use lumifit::io::{atomic_write, read_input, spectrum_csv::read_multi_spectrum};
use lumifit::phosphor::{
    self, band_spectrum, fit_decay, reradiation_functions, reradiation_functions_rgb,
    AmplitudeModel, BandCamera, BandSet, DecayCurve, DecayFit, DecayFitOptions, Integrator,
    Material, PhosphorState, Segment, StatesChoice,
};
use lumifit::preset::{
    write_preset, Bands, MaterialPreset, PhosphorescenceSection, PhosphorescentState, Provenance,
};
use lumifit::table::parse_numeric_csv;
use lumifit::Error;
use rayon::prelude::*;

/// Subcommands of `lumifit phos`.
#[derive(Debug, Subcommand)]
pub enum PhosCommand {
    /// Simulate Eq. 1 under a piecewise-constant irradiance history; write the emission CSV.
    Simulate(SimulateArgs),
    /// Fit a decay curve (or a batch of curves) with a sum of exponentials.
    FitDecay(FitDecayArgs),
    /// Error versus run time of the exact, RK4 and Euler integrators at several step sizes.
    CompareIntegrators(CompareArgs),
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
    /// Irradiance history CSV: `duration_s` then one column per band of the material.
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
    }
}

/// A Table 1 name or a preset file with a phosphorescence section.
pub fn resolve_material(arg: &str) -> Result<Material> {
    let p = Path::new(arg);
    if arg.ends_with(".json") || p.is_file() {
        let preset = lumifit::preset::read_material(p)?;
        let sec = preset.phosphorescence.ok_or_else(|| {
            anyhow!("{arg}: the preset has no 'phosphorescence' section; expected one with bands and states")
        })?;
        let m = Material {
            name: preset.name,
            bands: match sec.bands {
                Bands::Rgb => BandSet::Rgb,
                Bands::RangesNm(r) => BandSet::RangesNm(r),
            },
            states: sec
                .states
                .into_iter()
                .map(|s| PhosphorState {
                    k_r_per_s: s.k_r_per_s,
                    k_e: s.k_e,
                    lambda: s.lambda,
                })
                .collect(),
        };
        m.validate()
            .with_context(|| format!("{arg}: phosphorescence section"))?;
        Ok(m)
    } else {
        Ok(phosphor::table1_material(arg)?.material.clone())
    }
}

fn read_history(path: &Path, n_bands: usize) -> Result<Vec<Segment>> {
    let (bytes, source) = read_input(path)?;
    let t = parse_numeric_csv(&bytes, &source)?;
    if t.column_index("duration_s") != Some(0) {
        return Err(Error::parse(
            &source,
            1,
            "expected the header to start with 'duration_s', then one irradiance column per band",
        )
        .into());
    }
    if t.header.len() != n_bands + 1 {
        return Err(Error::parse(
            &source,
            1,
            format!(
                "{} irradiance columns; the material has {n_bands} bands, expected one column per band",
                t.header.len() - 1
            ),
        )
        .into());
    }
    let mut out = Vec::with_capacity(t.n_rows());
    for r in 0..t.n_rows() {
        let d = t.columns[0][r];
        if d <= 0.0 {
            return Err(Error::parse(
                &source,
                t.lines[r],
                format!("duration {d} s; expected a duration > 0"),
            )
            .into());
        }
        let e: Vec<f64> = (1..=n_bands).map(|c| t.columns[c][r]).collect();
        if let Some(v) = e.iter().find(|v| **v < 0.0) {
            return Err(Error::parse(
                &source,
                t.lines[r],
                format!("irradiance {v}; expected values ≥ 0"),
            )
            .into());
        }
        out.push(Segment {
            duration_s: d,
            irradiance: e,
        });
    }
    if out.is_empty() {
        return Err(Error::parse(&source, 0, "no segments; expected at least one data row").into());
    }
    Ok(out)
}

fn simulate(a: &SimulateArgs) -> Result<()> {
    let material = resolve_material(&a.material)?;
    let history = read_history(&a.history, material.bands.len())?;
    let integrator = match a.integrator {
        IntegratorArg::Exact => Integrator::Exact,
        IntegratorArg::Rk4 => Integrator::Rk4,
        IntegratorArg::Euler => Integrator::Euler,
    };
    let camera = match &a.camera {
        Some(p) => Some(BandCamera::for_bands(
            &material.bands,
            Some(&read_multi_spectrum(p)?),
        )?),
        None => None,
    };
    let r0 = vec![0.0; material.states.len()];
    let sim = phosphor::simulate(&material, &history, &r0, a.dt, integrator)?;
    let rgb: Option<Vec<[f64; 3]>> = camera
        .as_ref()
        .map(|cam| sim.emission.iter().map(|e| cam.rgb(e)).collect());
    // The plot first: a bad --plot path fails before the CSV is written.
    if let Some(p) = &a.plot {
        lumifit::plot::phosphor_sim::simulate_chart(
            p,
            &lumifit::plot::phosphor_sim::SimulateChart {
                material: &material,
                integrator,
                dt_s: a.dt,
                history: &history,
                sim: &sim,
                camera_rgb: rgb.as_deref(),
            },
        )
        .with_context(|| format!("--plot {}", p.display()))?;
    }
    let mut csv = String::from("time_s");
    let nb = material.bands.len();
    match &material.bands {
        BandSet::Rgb => csv.push_str(",L_r,L_g,L_b"),
        BandSet::RangesNm(r) => {
            for [lo, hi] in r {
                csv.push_str(&format!(",L_{lo}_{hi}nm"));
            }
        }
    }
    for i in 0..material.states.len() {
        csv.push_str(&format!(",r_{}", i + 1));
    }
    if rgb.is_some() {
        csv.push_str(",r,g,b");
    }
    csv.push('\n');
    for k in 0..sim.t_s.len() {
        csv.push_str(&format!("{}", sim.t_s[k]));
        for b in 0..nb {
            csv.push_str(&format!(",{}", sim.emission[k][b]));
        }
        for v in &sim.r[k] {
            csv.push_str(&format!(",{v}"));
        }
        if let Some(rgb) = &rgb {
            for v in rgb[k] {
                csv.push_str(&format!(",{v}"));
            }
        }
        csv.push('\n');
    }
    atomic_write(&a.out, csv.as_bytes())?;
    super::emit(&format!(
        "wrote {} samples of {} ({} states, {} bands) to {}{}",
        sim.t_s.len(),
        material.name,
        material.states.len(),
        nb,
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

/// Reads a curve CSV `time_s,<channels>[,std|weight]`, with errors naming file and line.
pub fn read_curve(path: &Path) -> Result<DecayCurve> {
    let (bytes, source) = read_input(path)?;
    let t = parse_numeric_csv(&bytes, &source)?;
    let Some(ti) = t.column_index("time_s") else {
        return Err(Error::parse(
            &source,
            1,
            "no 'time_s' column; expected 'time_s,r,g,b' (optional 'std' or 'weight')",
        )
        .into());
    };
    let si = t.column_index("std");
    let wi = t.column_index("weight");
    if si.is_some() && wi.is_some() {
        return Err(Error::parse(&source, 1, "both 'std' and 'weight' columns; give one").into());
    }
    let chans: Vec<usize> = (0..t.header.len())
        .filter(|&c| c != ti && Some(c) != si && Some(c) != wi)
        .collect();
    if chans.len() != 1 && chans.len() != 3 {
        return Err(Error::parse(
            &source,
            1,
            format!(
                "{} value columns; expected 1 or 3 (r,g,b) besides time_s and std/weight",
                chans.len()
            ),
        )
        .into());
    }
    check_rows(
        &source,
        &t.lines,
        &t.columns[ti],
        si.map(|i| &t.columns[i][..]),
        wi.map(|i| &t.columns[i][..]),
    )?;
    let sigma = match (si, wi) {
        (Some(i), _) => Some(t.columns[i].clone()),
        (_, Some(i)) => Some(t.columns[i].iter().map(|w| 1.0 / w.sqrt()).collect()),
        _ => None,
    };
    let channels: Vec<Vec<f64>> = chans.iter().map(|&c| t.columns[c].clone()).collect();
    let sigma = sigma.map(|s| floor_sigma(s, &channels));
    DecayCurve::new(t.columns[ti].clone(), channels, sigma).map_err(|e| anyhow!("{source}: {e}"))
}

/// Floors per-sample σ at 1e-9 of the largest |value| (the digits a double-precision curve
/// carries): a noise-free synthetic curve's σ ≈ 1e-154 would otherwise overflow the weights 1/σ².
fn floor_sigma(sigma: Vec<f64>, channels: &[Vec<f64>]) -> Vec<f64> {
    let ymax = channels
        .iter()
        .flatten()
        .fold(0.0f64, |m, v| m.max(v.abs()));
    let floor = 1e-9 * ymax;
    sigma.into_iter().map(|v| v.max(floor)).collect()
}

fn check_rows(
    source: &str,
    lines: &[usize],
    time: &[f64],
    std: Option<&[f64]>,
    weight: Option<&[f64]>,
) -> Result<()> {
    for r in 1..time.len() {
        if time[r] <= time[r - 1] {
            let what = if time[r] == time[r - 1] {
                "duplicated"
            } else {
                "decreasing"
            };
            return Err(Error::parse(
                source,
                lines[r],
                format!(
                    "time {} s after {} s ({what}); times must be strictly increasing",
                    time[r],
                    time[r - 1]
                ),
            )
            .into());
        }
    }
    for (name, col) in [("std", std), ("weight", weight)] {
        if let Some(c) = col {
            if let Some(r) = c.iter().position(|v| *v <= 0.0) {
                return Err(Error::parse(
                    source,
                    lines[r],
                    format!("{name} {}; expected > 0", c[r]),
                )
                .into());
            }
        }
    }
    Ok(())
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
        (None, Some(b)) => batch(b, &opts, &a.out),
        (Some(c), None) => single(c, a, &opts),
    }
}

fn flags_text(fit: &DecayFit) -> String {
    fit.flags
        .iter()
        .map(|f| f.name())
        .collect::<Vec<_>>()
        .join(";")
}

fn single(path: &Path, a: &FitDecayArgs, opts: &DecayFitOptions) -> Result<()> {
    let curve = read_curve(path)?;
    fit_and_write(path, curve, a, opts, None)
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
    let roi = Roi::parse_rect(roi)?;
    let series = load_series_with_bar(series_path, &a.dark)?;
    let samples = series
        .extract(&roi)
        .with_context(|| format!("{}: ROI {}", series_path.display(), roi.describe()))?;
    // σ of each sample: the largest channel's standard error of the ROI mean
    let sigma: Vec<f64> = samples
        .iter()
        .map(|s| {
            let n = (s.n_pixels - s.n_saturated).max(1) as f64;
            s.std.iter().cloned().fold(0.0f64, f64::max) / n.sqrt()
        })
        .collect();
    let sigma = sigma
        .iter()
        .all(|v| v.is_finite() && *v > 0.0)
        .then_some(sigma);
    let t: Vec<f64> = samples.iter().map(|s| s.time_s).collect();
    let channels = (0..3)
        .map(|c| samples.iter().map(|s| s.mean[c]).collect())
        .collect();
    let curve = DecayCurve::new(t, channels, sigma)
        .with_context(|| format!("{}: ROI {}", series_path.display(), roi.describe()))?;
    fit_and_write(series_path, curve, a, opts, Some(roi.describe()))
}

fn fit_and_write(
    path: &Path,
    curve: DecayCurve,
    a: &FitDecayArgs,
    opts: &DecayFitOptions,
    roi: Option<String>,
) -> Result<()> {
    let fit = fit_decay(&curve, opts).with_context(|| format!("{}: decay fit", path.display()))?;
    let mut inputs: Vec<(PathBuf, Vec<u8>)> = if path.is_file() {
        vec![(path.to_path_buf(), read_input(path)?.0)]
    } else {
        vec![]
    };
    let mut lambda_scale = None;
    let (bands, states) = match &a.spectrum {
        Some(sp) => {
            let sd = lumifit::io::spectrum_csv::read_spectrum(sp)?;
            let BandSet::RangesNm(ranges) = BandSet::uniform(400.0, 700.0, a.bands)? else {
                bail!("internal: uniform bands are wavelength bands");
            };
            let spec = band_spectrum(sd.wavelengths(), sd.values(), &ranges)?;
            inputs.push((sp.clone(), read_input(sp)?.0));
            let sens = match &a.camera {
                Some(c) => {
                    inputs.push((c.clone(), read_input(c)?.0));
                    Some(read_multi_spectrum(c)?)
                }
                None => None,
            };
            let camera = BandCamera::for_bands(&BandSet::RangesNm(ranges.clone()), sens.as_ref())?;
            let mut states = reradiation_functions(&fit, &spec);
            // Λ* is normalised to max 1; scale it so that the camera sees the measured RGB
            // amplitudes: camera·(Λ_i k_r,i) ≈ a_i·spectrum_rgb in least squares.
            let (mut num, mut den) = (0.0, 0.0);
            for ((k, l), st) in states.iter().zip(&fit.states) {
                let emission: Vec<f64> = l.iter().map(|v| v * k).collect();
                let model = camera.rgb(&emission);
                for (a, m) in st.channel_amplitudes.iter().zip(model) {
                    num += a * m;
                    den += m * m;
                }
            }
            if curve.channels.len() == 3 {
                if !(den > 0.0 && num > 0.0) {
                    bail!(
                        "{}: the emission spectrum gives no signal in the camera's channels; check --spectrum and --camera",
                        sp.display()
                    );
                }
                let scale = num / den;
                for (_, l) in states.iter_mut() {
                    for v in l.iter_mut() {
                        *v *= scale;
                    }
                }
                lambda_scale = Some(scale);
            }
            (Bands::RangesNm(ranges), states)
        }
        None => {
            if curve.channels.len() != 3 {
                bail!("{}: a single-channel curve needs --spectrum to give the re-radiation functions bands", path.display());
            }
            (Bands::Rgb, reradiation_functions_rgb(&fit))
        }
    };
    let mut report = fit_report(&fit);
    if let (Some(k), Some(obj)) = (lambda_scale, report.as_object_mut()) {
        obj.insert(
            "lambda_camera_scale".into(),
            serde_json::json!({
                "value": k,
                "camera": a.camera.as_ref().map_or("ideal box camera (B 400–500, G 500–600, R 600–700 nm)".to_string(), |p| p.display().to_string()),
                "meaning": "lambda = a_i * spectrum / k_r,i * value, so that the camera sees the measured RGB amplitudes",
            }),
        );
    }
    if let (Some(r), Some(obj)) = (&roi, report.as_object_mut()) {
        obj.insert("roi".into(), serde_json::json!(r));
        obj.insert(
            "series".into(),
            serde_json::json!(path.display().to_string()),
        );
        obj.insert(
            "units".into(),
            serde_json::json!(
                "relative radiance: frame value / (exposure_s * ISO/100 / f_number^2)"
            ),
        );
    }
    let refs: Vec<(&PathBuf, &[u8])> = inputs.iter().map(|(p, b)| (p, &b[..])).collect();
    let provenance =
        Provenance::new("lumifit phos fit-decay", &refs).with_fit_quality(serde_json::json!({
            "rms": fit.rms, "n_states": fit.states.len(), "flags": flags_text(&fit)
        }));
    let name = a.name.clone().unwrap_or_else(|| {
        path.file_stem()
            .map_or("material".into(), |s| s.to_string_lossy().to_string())
    });
    let mut preset = MaterialPreset::new(name.clone(), provenance);
    let mut extra = serde_json::Map::new();
    extra.insert("decay_fit".into(), report.clone());
    preset.phosphorescence = Some(PhosphorescenceSection {
        bands,
        states: states
            .into_iter()
            .map(|(k, l)| PhosphorescentState::new(k, None, l))
            .collect(),
        extra,
    });
    write_preset(&a.out, &preset)?;
    if let Some(p) = &a.plot {
        lumifit::plot::decay_chart(
            p,
            &format!("{name}: decay fit, {} state(s)", fit.states.len()),
            &curve,
            &fit,
        )?;
    }
    super::emit(&serde_json::to_string_pretty(&report)?)
}

fn fit_report(fit: &DecayFit) -> serde_json::Value {
    serde_json::json!({
        "model": match fit.amplitudes {
            AmplitudeModel::SharedSpectrum => "sum of exponentials, spectrum shared by all states",
            AmplitudeModel::PerChannel => "sum of exponentials, amplitudes per channel",
        },
        "assumption": "saturation at switch-off (r_i(0) = 1, Nalbach et al. 2017 §4.4): lambda_i = a_i * spectrum / k_r,i",
        "n_states": fit.states.len(),
        "states": fit.states.iter().map(|s| serde_json::json!({
            "k_r_per_s": s.k_per_s,
            "k_r_sigma_per_s": s.k_sigma_per_s,
            "amplitude": s.amplitude,
            "amplitude_sigma": s.amplitude_sigma,
            "channel_amplitudes": s.channel_amplitudes,
        })).collect::<Vec<_>>(),
        "spectrum": fit.spectrum,
        "background": fit.background,
        "rms": fit.rms,
        "rss": fit.rss,
        "n_obs": fit.n_obs,
        "n_params": fit.n_params,
        "candidates": fit.candidates,
        "flags": fit.flags,
        "termination": fit.termination,
    })
}

/// One curve of a batch.
struct BatchCurve {
    id: String,
    line: usize,
    t: Vec<f64>,
    ch: [Vec<f64>; 3],
    std: Vec<f64>,
    lines: Vec<usize>,
}

fn read_batch(path: &Path) -> Result<Vec<BatchCurve>> {
    let (bytes, source) = read_input(path)?;
    let text = std::str::from_utf8(&bytes)
        .map_err(|_| Error::parse(&source, 0, "not UTF-8 text; expected CSV 'id,time_s,r,g,b'"))?;
    let mut header: Option<Vec<String>> = None;
    let mut curves: Vec<BatchCurve> = Vec::new();
    let mut index = std::collections::HashMap::new();
    let mut has_std = false;
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let l = raw.trim();
        if l.is_empty() || l.starts_with('#') {
            continue;
        }
        let f: Vec<&str> = l.split(',').map(|s| s.trim().trim_matches('"')).collect();
        let Some(h) = &header else {
            let h: Vec<String> = f.iter().map(|s| s.to_ascii_lowercase()).collect();
            let base = ["id", "time_s", "r", "g", "b"];
            if h.len() < 5 || h[..5] != base || (h.len() == 6 && h[5] != "std") || h.len() > 6 {
                return Err(Error::parse(
                    &source,
                    line,
                    format!("header '{l}'; expected 'id,time_s,r,g,b' with an optional ',std'"),
                )
                .into());
            }
            has_std = h.len() == 6;
            header = Some(h);
            continue;
        };
        if f.len() != h.len() {
            return Err(Error::parse(
                &source,
                line,
                format!("{} fields; expected {}", f.len(), h.len()),
            )
            .into());
        }
        let mut v = [0.0; 5];
        for k in 1..h.len() {
            v[k - 1] = f[k]
                .parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| {
                    Error::parse(
                        &source,
                        line,
                        format!("'{}' in column '{}' is not a finite number", f[k], h[k]),
                    )
                })?;
        }
        let idx = *index.entry(f[0].to_string()).or_insert_with(|| {
            curves.push(BatchCurve {
                id: f[0].to_string(),
                line,
                t: vec![],
                ch: [vec![], vec![], vec![]],
                std: vec![],
                lines: vec![],
            });
            curves.len() - 1
        });
        let c = &mut curves[idx];
        c.t.push(v[0]);
        for k in 0..3 {
            c.ch[k].push(v[k + 1]);
        }
        if has_std {
            c.std.push(v[4]);
        }
        c.lines.push(line);
    }
    if header.is_none() {
        return Err(Error::parse(
            &source,
            0,
            "file is empty; expected header 'id,time_s,r,g,b' and data rows",
        )
        .into());
    }
    for c in &curves {
        check_rows(&source, &c.lines, &c.t, has_std.then_some(&c.std[..]), None)
            .with_context(|| format!("curve '{}' (first row at line {})", c.id, c.line))?;
    }
    Ok(curves)
}

/// Header of the batch output (a contract).
pub const BATCH_HEADER: &str =
    "id,n_states,k1_per_s,k2_per_s,k3_per_s,a1,a2,a3,spectrum_r,spectrum_g,spectrum_b,rms,flags";

fn batch(path: &Path, opts: &DecayFitOptions, out: &Path) -> Result<()> {
    let curves = read_batch(path)?;
    let bar = indicatif::ProgressBar::new(curves.len() as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "{bar:40} {pos}/{len} curves ({per_sec}, eta {eta})",
        )
        .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    let start = std::time::Instant::now();
    let rows: Vec<String> = curves
        .par_iter()
        .map(|c| {
            let sigma = (!c.std.is_empty()).then(|| c.std.clone());
            let row = DecayCurve::new(c.t.clone(), c.ch.to_vec(), sigma)
                .and_then(|curve| fit_decay(&curve, opts));
            bar.inc(1);
            let id = if c.id.contains([',', '"']) {
                format!("\"{}\"", c.id.replace('"', "\"\""))
            } else {
                c.id.clone()
            };
            match row {
                Ok(fit) => {
                    let mut f = vec![id, fit.states.len().to_string()];
                    for j in 0..3 {
                        f.push(
                            fit.states
                                .get(j)
                                .map_or(String::new(), |s| format!("{}", s.k_per_s)),
                        );
                    }
                    for j in 0..3 {
                        f.push(
                            fit.states
                                .get(j)
                                .map_or(String::new(), |s| format!("{}", s.amplitude)),
                        );
                    }
                    for v in &fit.spectrum {
                        f.push(format!("{v}"));
                    }
                    f.push(format!("{}", fit.rms));
                    f.push(flags_text(&fit));
                    f.join(",")
                }
                Err(e) => format!(
                    "{id},,,,,,,,,,,,\"error: {}\"",
                    e.to_string().replace('"', "'")
                ),
            }
        })
        .collect();
    bar.finish_and_clear();
    let secs = start.elapsed().as_secs_f64();
    let mut text = String::from(BATCH_HEADER);
    text.push('\n');
    for r in &rows {
        text.push_str(r);
        text.push('\n');
    }
    atomic_write(out, text.as_bytes())?;
    super::emit(&format!(
        "fitted {} curves in {:.3} s ({:.0} curves/s, {} threads) → {}",
        rows.len(),
        secs,
        rows.len() as f64 / secs.max(1e-9),
        rayon::current_num_threads(),
        out.display()
    ))
}

fn per_pixel(series_path: &Path, a: &FitDecayArgs, opts: &DecayFitOptions) -> Result<()> {
    if a.spectrum.is_some() || a.plot.is_some() {
        bail!("--spectrum and --plot apply to one curve; with --per-pixel the maps are the output");
    }
    let series = load_series_with_bar(series_path, &a.dark)?;
    let first = series
        .frames()
        .first()
        .ok_or_else(|| anyhow!("{}: no frames", series_path.display()))?;
    let (w, h) = (first.frame.width, first.frame.height);
    let rows = h.div_ceil(a.block.max(1));
    let bar = indicatif::ProgressBar::new(rows as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "fitting [{bar:30}] {pos}/{len} rows of blocks ({per_sec}, eta {eta})",
        )
        .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    let start = std::time::Instant::now();
    let maps = phosphor::maps::fit_pixel_maps(&series, a.block, opts, &|| bar.inc(1));
    bar.finish_and_clear();
    let maps = maps.with_context(|| format!("{}: per-pixel fit", series_path.display()))?;
    let secs = start.elapsed().as_secs_f64();
    let out = &a.out;
    std::fs::create_dir_all(out).map_err(|e| Error::io(out, e))?;
    let (mw, mh) = (maps.width, maps.height);
    let mut files = Vec::new();
    let mut scalar = |name: &str, v: &[f32]| -> Result<()> {
        lumifit::io::maps::write_scalar_map(&out.join(name), mw, mh, v)?;
        files.push(name.to_string());
        Ok(())
    };
    for i in 0..phosphor::maps::MAP_STATES {
        scalar(&format!("k{}_per_s.tif", i + 1), &maps.k_per_s[i])?;
        scalar(&format!("a{}.tif", i + 1), &maps.amplitude[i])?;
    }
    scalar("n_states.tif", &maps.n_states)?;
    scalar("rms.tif", &maps.rms)?;
    for (c, name) in ["r", "g", "b"].iter().enumerate() {
        scalar(&format!("spectrum_{name}.tif"), &maps.spectrum[c])?;
    }
    lumifit::io::maps::write_rgb_map(
        &out.join("spectrum_rgb.tif"),
        mw,
        mh,
        [&maps.spectrum[0], &maps.spectrum[1], &maps.spectrum[2]],
    )?;
    files.push("spectrum_rgb.tif".into());
    let median = |v: &[f32]| -> Option<f64> {
        let mut x: Vec<f32> = v.iter().cloned().filter(|x| x.is_finite()).collect();
        if x.is_empty() {
            return None;
        }
        x.sort_by(f32::total_cmp);
        Some(f64::from(x[x.len() / 2]))
    };
    let mut hist = [0usize; 4];
    for n in &maps.n_states {
        hist[(*n as usize).min(3)] += 1;
    }
    let n_blocks = mw * mh;
    let summary = serde_json::json!({
        "series": series_path.display().to_string(),
        "frames": series.len(),
        "frame_size": [w, h],
        "block": maps.block,
        "map_size": [mw, mh],
        "blocks": n_blocks,
        "fitted": maps.n_fitted,
        "failed": maps.n_failed,
        "n_states_histogram": {"failed": hist[0], "1": hist[1], "2": hist[2], "3": hist[3]},
        "median": {
            "k1_per_s": median(&maps.k_per_s[0]), "k2_per_s": median(&maps.k_per_s[1]),
            "k3_per_s": median(&maps.k_per_s[2]), "rms": median(&maps.rms),
        },
        "seconds": secs,
        "blocks_per_s": n_blocks as f64 / secs.max(1e-9),
        "threads": rayon::current_num_threads(),
        "maps": files,
        "format": "32-bit float TIFF, value repeated in R=G=B (spectrum_rgb.tif: r,g,b); NaN where a block could not be fitted; k1 is the fastest rate",
        "weights": "relative: sigma_t = max(max_c y_c(t), 1e-2 * peak) per block",
    });
    atomic_write(
        &out.join("summary.json"),
        serde_json::to_string_pretty(&summary)?.as_bytes(),
    )?;
    super::emit(&serde_json::to_string_pretty(&summary)?)
}

/// One row of the integrator comparison.
struct IntegratorRow {
    case: &'static str,
    integrator: &'static str,
    dt_s: f64,
    seconds: f64,
    error: f64,
}

/// History of the comparison: charge 600 s under flat light of magnitude `scale` (|E| = scale
/// over the bands), then 600 s dark.
fn compare_history(material: &Material, scale: f64) -> Vec<Segment> {
    let nb = material.bands.len();
    let e = scale / (nb as f64).sqrt();
    vec![
        Segment {
            duration_s: 600.0,
            irradiance: vec![e; nb],
        },
        Segment {
            duration_s: 600.0,
            irradiance: vec![0.0; nb],
        },
    ]
}

fn compare_integrators(a: &CompareArgs) -> Result<()> {
    let material = resolve_material(&a.material)?;
    if !material.has_excitation() {
        bail!(
            "{}: the material has no excitation rates k_e; pick one that does (e.g. green_paint)",
            a.material
        );
    }
    let r0 = vec![0.0; material.states.len()];
    let mut rows = Vec::new();
    for (case, scale) in [("normal |E|=1", 1.0), ("bright |E|=100", 100.0)] {
        let history = compare_history(&material, scale);
        for dt in [0.05, 0.1, 0.5, 1.0, 5.0, 10.0] {
            let reference = phosphor::simulate(&material, &history, &r0, dt, Integrator::Exact)?;
            let peak = reference
                .emission
                .iter()
                .flatten()
                .cloned()
                .fold(0.0f64, f64::max)
                .max(f64::MIN_POSITIVE);
            for (name, integ) in [
                ("exact", Integrator::Exact),
                ("rk4", Integrator::Rk4),
                ("euler", Integrator::Euler),
            ] {
                // repeat until 20 ms have passed, report the time per run
                let start = std::time::Instant::now();
                let mut runs = 0u32;
                let sim = loop {
                    let sim = phosphor::simulate(&material, &history, &r0, dt, integ)?;
                    runs += 1;
                    if start.elapsed().as_secs_f64() > 0.02 || runs >= 1000 {
                        break sim;
                    }
                };
                let seconds = start.elapsed().as_secs_f64() / f64::from(runs);
                let mut err = 0.0f64;
                for (l, lr) in sim.emission.iter().zip(&reference.emission) {
                    for (x, y) in l.iter().zip(lr) {
                        let d = (x - y).abs() / peak;
                        err = if d.is_finite() {
                            err.max(d)
                        } else {
                            f64::INFINITY
                        };
                    }
                }
                rows.push(IntegratorRow {
                    case,
                    integrator: name,
                    dt_s: dt,
                    seconds,
                    error: err,
                });
            }
        }
    }
    let mut csv = String::from("case,integrator,dt_s,seconds_per_run,max_rel_error\n");
    for r in &rows {
        csv.push_str(&format!(
            "{},{},{},{:.3e},{:.3e}\n",
            r.case, r.integrator, r.dt_s, r.seconds, r.error
        ));
    }
    atomic_write(&a.out, csv.as_bytes())?;
    if let Some(p) = &a.plot {
        let series: Vec<(String, Vec<(f64, f64)>)> = rows
            .chunk_by(|x, y| x.case == y.case)
            .flat_map(|case_rows| {
                ["rk4", "euler"].map(|name| {
                    (
                        format!("{} {}", name, case_rows[0].case),
                        case_rows
                            .iter()
                            .filter(|r| r.integrator == name)
                            .map(|r| (r.seconds, r.error))
                            .collect::<Vec<_>>(),
                    )
                })
            })
            .collect();
        lumifit::plot::integrator_chart(
            p,
            &format!(
                "{}: max relative emission error vs run time (exact = 0)",
                material.name
            ),
            &series,
        )?;
    }
    super::emit(&csv)
}
