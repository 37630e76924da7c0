//! `lumifit phos …` (phosphorescence): simulate a material under an irradiance history, fit
//! decay curves (one CSV curve or a batch) into the `phosphorescence` section of a preset.

use std::path::{Path, PathBuf};

use anyhow::{anyhow, bail, Context, Result};
use clap::{Args, Subcommand, ValueEnum};
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
    /// Plot (not implemented yet for simulate).
    #[arg(long)]
    pub plot: Option<PathBuf>,
}

/// `lumifit phos fit-decay`.
#[derive(Debug, Args)]
pub struct FitDecayArgs {
    /// Curve CSV: `time_s` and channels (`r,g,b` or one column), optional `std` or `weight`.
    pub curve: Option<PathBuf>,
    /// Photo series directory (needs the capture I/O of issue 3; not implemented yet).
    #[arg(long)]
    pub series: Option<PathBuf>,
    /// Region of interest in the series (with --series).
    #[arg(long)]
    pub roi: Option<String>,
    /// Batch CSV `id,time_s,r,g,b[,std]` with many curves; writes one CSV row per curve.
    #[arg(long)]
    pub batch: Option<PathBuf>,
    /// Fit every pixel of a series (not implemented yet).
    #[arg(long)]
    pub per_pixel: bool,
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
    /// Material name written into the preset.
    #[arg(long)]
    pub name: Option<String>,
    /// Output: material preset JSON (curve) or CSV (--batch).
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
    if a.plot.is_some() {
        bail!("--plot for 'phos simulate' is not implemented yet; write the CSV and plot it elsewhere");
    }
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
    if camera.is_some() {
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
        if let Some(cam) = &camera {
            for v in cam.rgb(&sim.emission[k]) {
                csv.push_str(&format!(",{v}"));
            }
        }
        csv.push('\n');
    }
    atomic_write(&a.out, csv.as_bytes())?;
    super::emit(&format!(
        "wrote {} samples of {} ({} states, {} bands) to {}",
        sim.t_s.len(),
        material.name,
        material.states.len(),
        nb,
        a.out.display()
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
    let channels = chans.iter().map(|&c| t.columns[c].clone()).collect();
    DecayCurve::new(t.columns[ti].clone(), channels, sigma).map_err(|e| anyhow!("{source}: {e}"))
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
    if a.per_pixel {
        bail!("--per-pixel is not implemented yet — needs the capture I/O of issue 3 (photo series in memory)");
    }
    if a.series.is_some() || a.roi.is_some() {
        bail!("fitting a photo series (--series/--roi) is not implemented yet — needs the capture I/O of issue 3");
    }
    let opts = options(a)?;
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
    let fit = fit_decay(&curve, opts).with_context(|| format!("{}: decay fit", path.display()))?;
    let (bytes, _) = read_input(path)?;
    let mut inputs: Vec<(PathBuf, Vec<u8>)> = vec![(path.to_path_buf(), bytes)];
    let (bands, states) = match &a.spectrum {
        Some(sp) => {
            let sd = lumifit::io::spectrum_csv::read_spectrum(sp)?;
            let BandSet::RangesNm(ranges) = BandSet::uniform(400.0, 700.0, a.bands)? else {
                bail!("internal: uniform bands are wavelength bands");
            };
            let spec = band_spectrum(sd.wavelengths(), sd.values(), &ranges)?;
            inputs.push((sp.clone(), read_input(sp)?.0));
            (Bands::RangesNm(ranges), reradiation_functions(&fit, &spec))
        }
        None => {
            if curve.channels.len() != 3 {
                bail!("{}: a single-channel curve needs --spectrum to give the re-radiation functions bands", path.display());
            }
            (Bands::Rgb, reradiation_functions_rgb(&fit))
        }
    };
    let report = fit_report(&fit);
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
