//! `lumifit lvf transmission`: solve each band's transmission from photos of a grey target
//! through the LVF and colour gels (Nalbach et al. 2017 §4.2), or write the parametric bands of
//! the wavelength calibration alone (`--model calibration`).

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use clap::{Args, ValueEnum};
use lumifit::fit::regularized::Weight;
use lumifit::io::filters::{read_gel_table, Gel};
use lumifit::io::series::read_frame;
use lumifit::lvf::synth::{camera_from_csv, default_camera};
use lumifit::lvf::transmission::{
    calibration_bands, default_grid, solve_transmissions, uniform_grid, BandModel, BandSet,
    GelCapture, TransmissionOptions, TransmissionProblem, DEFAULT_SUPPORT_FWHM,
};
use lumifit::lvf::LvfGeometry;
use lumifit::math::interpolation::Interpolator;
use lumifit::spectrum::{MultiSpectrum, Spectrum};

use super::emit;

/// Band model.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum ModelArg {
    /// Free shape on the grid: non-negative, smoothness-regularised (GCV), support window.
    Nnls,
    /// Free shape by plain least squares (the baseline; no penalty, no sign constraint).
    Lstsq,
    /// Window-averaged Gaussian passband: centre, FWHM, peak.
    Gaussian,
    /// Window-averaged super-Gaussian passband: centre, FWHM, exponent, peak.
    SuperGaussian,
    /// From lvf.json alone: centre from the map, FWHM from the lamp fit, peak 1.
    Calibration,
}

/// `lvf transmission`.
#[derive(Debug, Args)]
pub struct TransmissionArgs {
    /// The wavelength calibration (lvf.json from `lvf calibrate`).
    #[arg(long)]
    pub lvf: PathBuf,
    /// CSV `image,filter`: one photo per line (paths relative to the CSV); filter = a code of the
    /// --filters table, or `none`/empty for the open LVF.
    #[arg(long)]
    pub captures: Option<PathBuf>,
    /// Gel table (Lee layout `code,name,<nm>…` or `wavelength_nm,<code>…`).
    #[arg(long)]
    pub filters: Option<PathBuf>,
    /// Light source: a CIE name (LED-B3, D65 …), daylight:<K>, blackbody:<K> or a CSV.
    #[arg(long)]
    pub source: Option<String>,
    /// Target reflectance CSV wavelength_nm,value.
    #[arg(long)]
    pub target: Option<PathBuf>,
    /// Camera sensitivities CSV wavelength_nm,r,g,b (default: calib/camera_default.csv).
    #[arg(long)]
    pub camera: Option<PathBuf>,
    /// Band model.
    #[arg(long, value_enum, default_value = "nnls")]
    pub model: ModelArg,
    /// Smoothness weight of nnls: gcv or a relative value λ ≥ 0.
    #[arg(long, default_value = "gcv")]
    pub reg: String,
    /// Drop the non-negativity constraint of nnls.
    #[arg(long)]
    pub no_nonneg: bool,
    /// Solve grid LO:HI:STEP (nm). Default: 5 nm over the bands' support, clipped to where
    /// source × target × camera is above 1e-3 of its peak.
    #[arg(long)]
    pub grid: Option<String>,
    /// Support half-width of nnls/lstsq bands in effective calibration FWHMs (T = 0 outside).
    #[arg(long, default_value_t = DEFAULT_SUPPORT_FWHM)]
    pub support: f64,
    /// Allow gels measured over a narrower range than the grid, holding each gel's edge values
    /// constant up to NM beyond its range.
    #[arg(long, default_value_t = 0.0)]
    pub extend_filters: f64,
    /// Do not weight equations by the readings' standard errors.
    #[arg(long)]
    pub unweighted: bool,
    /// Output band file JSON (lvf_bands.json).
    #[arg(long)]
    pub out: PathBuf,
    /// PNG plot of the band transmissions and the fitted centres and widths.
    #[arg(long)]
    pub plot: Option<PathBuf>,
}

/// Level below which source × target × camera counts as not covered (relative to its peak).
const COVERAGE_LEVEL: f64 = 1e-3;

/// Runs `lvf transmission`.
pub fn run(a: &TransmissionArgs) -> Result<()> {
    let t0 = std::time::Instant::now();
    let (lvf_bytes, lvf_src) = lumifit::io::read_input(&a.lvf)?;
    let geometry = LvfGeometry::from_json(&lvf_bytes, &lvf_src)?;
    let lvf_value: serde_json::Value =
        serde_json::from_slice(&lvf_bytes).with_context(|| format!("{lvf_src}: not JSON"))?;
    if !(a.support.is_finite() && a.support > 0.5 && a.support <= 10.0) {
        bail!("--support: {}; expected 0.5–10 FWHMs", a.support);
    }
    if !(a.extend_filters.is_finite() && a.extend_filters >= 0.0) {
        bail!("--extend-filters: {}; expected ≥ 0 nm", a.extend_filters);
    }
    let explicit_grid = a.grid.as_deref().map(parse_grid).transpose()?;
    let model = match a.model {
        ModelArg::Nnls => BandModel::Nnls,
        ModelArg::Lstsq => BandModel::Lstsq,
        ModelArg::Gaussian => BandModel::Gaussian,
        ModelArg::SuperGaussian => BandModel::SuperGaussian,
        ModelArg::Calibration => BandModel::Calibration,
    };
    let set = if model == BandModel::Calibration {
        let grid = match explicit_grid {
            Some(g) => g,
            None => default_grid(&geometry, a.support, 5.0, None)?,
        };
        calibration_bands(&geometry, lvf_value, &grid)?
    } else {
        solve(a, &geometry, lvf_value, explicit_grid, model)?
    };
    let mut set = set;
    let seconds = t0.elapsed().as_secs_f64();
    if let Some(obj) = set.diagnostics.as_object_mut() {
        obj.insert("seconds".into(), serde_json::json!(seconds));
        obj.insert("lvf".into(), serde_json::json!(lvf_src));
    }
    lumifit::io::atomic_write(&a.out, set.to_json()?.as_bytes())?;
    if let Some(p) = &a.plot {
        lumifit::plot::lvf_bands::lvf_bands_chart(p, &set)?;
    }
    emit(&serde_json::to_string_pretty(&summary(a, &set, seconds))?)
}

fn summary(a: &TransmissionArgs, set: &BandSet, seconds: f64) -> serde_json::Value {
    let d = &set.diagnostics;
    serde_json::json!({
        "out": a.out.display().to_string(),
        "model": set.model.name(),
        "grid_nm": [set.grid_nm.first(), set.grid_nm.last(), set.grid_nm.get(1).zip(set.grid_nm.first()).map(|(b, a)| b - a)],
        "bands": set.bands.iter().map(|b| serde_json::json!({
            "nm": b.nm,
            "centre_nm": b.centre_nm,
            "centre_sigma_nm": b.centre_sigma_nm,
            "fwhm_nm": b.fwhm_nm,
            "fwhm_sigma_nm": b.fwhm_sigma_nm,
            "effective_fwhm_nm": b.effective_fwhm_nm,
            "peak": b.peak,
            "rms_residual": b.rms_residual,
            "lambda": b.lambda,
        })).collect::<Vec<_>>(),
        "condition_number_full_grid": d.get("condition_number_full_grid"),
        "condition_number_gel_range": d.get("condition_number_gel_range"),
        "condition_number_band_median": d.get("condition_number_band_median"),
        "at_bound": d.get("at_bound"),
        "not_converged": d.get("not_converged"),
        "seconds": seconds,
    })
}

fn parse_grid(s: &str) -> Result<Vec<f64>> {
    let parts: Vec<&str> = s.split(':').map(str::trim).collect();
    let nums: Option<Vec<f64>> = parts.iter().map(|p| p.parse::<f64>().ok()).collect();
    match nums.as_deref() {
        Some(&[lo, hi, step]) if parts.len() == 3 => Ok(uniform_grid(lo, hi, step)?),
        _ => bail!("--grid: '{s}' is not LO:HI:STEP, e.g. 400:700:5"),
    }
}

/// One line of captures.csv.
struct CaptureLine {
    line: usize,
    image: PathBuf,
    filter: Option<String>,
}

fn read_captures_csv(path: &Path) -> Result<Vec<CaptureLine>> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("cannot read --captures {}", path.display()))?;
    let base = path.parent().unwrap_or(Path::new("."));
    let mut out = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let line = raw.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let mut cells = line.split(',').map(|c| c.trim().trim_matches('"'));
        let image = cells.next().unwrap_or("");
        let filter = cells.next().unwrap_or("");
        if out.is_empty() && image.eq_ignore_ascii_case("image") {
            continue;
        }
        if image.is_empty() {
            bail!(
                "{}:{}: empty image path; expected 'image,filter'",
                path.display(),
                i + 1
            );
        }
        let filter = if filter.is_empty() || filter.eq_ignore_ascii_case("none") {
            None
        } else {
            Some(filter.to_string())
        };
        out.push(CaptureLine {
            line: i + 1,
            image: base.join(image),
            filter,
        });
    }
    if out.is_empty() {
        bail!(
            "{}: no captures; expected lines 'image,filter'",
            path.display()
        );
    }
    Ok(out)
}

/// Reads the camera table, rejecting negative sensitivities with their line number.
fn read_camera(path: Option<&Path>) -> Result<MultiSpectrum> {
    let Some(p) = path else {
        return Ok(default_camera()?);
    };
    let (bytes, src) = lumifit::io::read_input(p)?;
    let text = String::from_utf8_lossy(&bytes);
    for (i, line) in text.lines().enumerate() {
        let t = line.trim();
        if t.is_empty() || t.starts_with('#') {
            continue;
        }
        let cells: Vec<&str> = t.split(',').map(str::trim).collect();
        for (k, c) in cells.iter().enumerate().skip(1) {
            if let Ok(v) = c.parse::<f64>() {
                if v < 0.0 {
                    bail!(
                        "{src}:{}: column {} is {v}; camera sensitivities must be ≥ 0",
                        i + 1,
                        k + 1
                    );
                }
            }
        }
    }
    Ok(camera_from_csv(&bytes, &src)?)
}

fn range(w: &[f64]) -> (f64, f64) {
    (w[0], w[w.len() - 1])
}

fn solve(
    a: &TransmissionArgs,
    geometry: &LvfGeometry,
    lvf_value: serde_json::Value,
    explicit_grid: Option<Vec<f64>>,
    model: BandModel,
) -> Result<BandSet> {
    let need = |o: bool, flag: &str| -> Result<()> {
        if o {
            Ok(())
        } else {
            bail!("{flag} is required with --model {}", model.name())
        }
    };
    need(a.captures.is_some(), "--captures")?;
    need(a.source.is_some(), "--source")?;
    need(a.target.is_some(), "--target")?;
    let captures_path = a.captures.as_deref().unwrap_or(Path::new(""));
    let lines = read_captures_csv(captures_path)?;
    let gels: Vec<Gel> = if lines.iter().any(|l| l.filter.is_some()) {
        let Some(f) = &a.filters else {
            bail!(
                "{}: captures name gels but no --filters table was given",
                captures_path.display()
            );
        };
        read_gel_table(f)?
    } else {
        Vec::new()
    };
    let mut capture_gels: Vec<Option<&Gel>> = Vec::with_capacity(lines.len());
    for l in &lines {
        match &l.filter {
            None => capture_gels.push(None),
            Some(code) => {
                let g =
                    gels.iter()
                        .find(|g| g.code.eq_ignore_ascii_case(code))
                        .ok_or_else(|| {
                            let sample: Vec<&str> =
                                gels.iter().take(6).map(|g| g.code.as_str()).collect();
                            anyhow::anyhow!(
                        "{}:{}: unknown gel code '{code}'; the table {} has {} gels, e.g. {}",
                        captures_path.display(),
                        l.line,
                        a.filters.as_deref().map(|p| p.display().to_string()).unwrap_or_default(),
                        gels.len(),
                        sample.join(", ")
                    )
                        })?;
                capture_gels.push(Some(g));
            }
        }
    }
    let source_arg = a.source.as_deref().unwrap_or("");
    let source =
        super::resolve_illuminant(source_arg).with_context(|| format!("--source {source_arg}"))?;
    let source = source.spectrum().clone();
    let target_path = a.target.as_deref().unwrap_or(Path::new(""));
    let target = lumifit::io::spectrum_csv::read_spectrum(target_path)
        .with_context(|| format!("--target {}", target_path.display()))?;
    if let Some(i) = target.values().iter().position(|v| *v < 0.0) {
        bail!(
            "--target {}: reflectance {} at {} nm; expected ≥ 0",
            target_path.display(),
            target.values()[i],
            target.wavelengths()[i]
        );
    }
    let camera = read_camera(a.camera.as_deref())?;

    // Grid: explicit, or the bands' support clipped to where S·R·Q is seen.
    let grid = match explicit_grid {
        Some(g) => {
            for (what, w) in [
                ("--source", source.wavelengths()),
                ("--target", target.wavelengths()),
                ("--camera", camera.wavelengths()),
            ] {
                let (lo, hi) = range(w);
                if g[0] < lo - 1e-9 || g[g.len() - 1] > hi + 1e-9 {
                    bail!(
                        "--grid {}–{} nm reaches beyond {what}, which covers {lo}–{hi} nm",
                        g[0],
                        g[g.len() - 1]
                    );
                }
            }
            g
        }
        None => default_grid(
            geometry,
            a.support,
            5.0,
            Some(coverage(&source, &target, &camera)?),
        )?,
    };
    let (glo, ghi) = (grid[0], grid[grid.len() - 1]);
    // Gels must cover the grid (or be extended explicitly).
    for g in capture_gels.iter().flatten() {
        let (lo, hi) = range(g.transmission.wavelengths());
        if !(lo - a.extend_filters <= glo + 1e-9 && hi + a.extend_filters >= ghi - 1e-9) {
            let need = ((lo - glo).max(ghi - hi)).max(0.0);
            bail!(
                "gel {} covers {lo}–{hi} nm; the grid needs {glo}–{ghi} nm: pass --grid {}:{}:{} or --extend-filters {} (holds each gel's edge value constant)",
                g.code,
                lo.max(glo),
                hi.min(ghi),
                grid[1] - grid[0],
                need.ceil()
            );
        }
    }
    // Quadrature: 1 nm over the grid.
    let nq = ((ghi - glo).round() as usize).max(1) + 1;
    let quad: Vec<f64> = (0..nq)
        .map(|i| glo + (ghi - glo) * i as f64 / (nq - 1) as f64)
        .collect();
    let s_q = source.values_at(&quad, Interpolator::Linear)?;
    let r_q = target.values_at(&quad, Interpolator::Linear)?;
    let cam_q = camera.resample(&quad, Interpolator::Linear)?;
    let camera_q = [
        cam_q.channel(0).to_vec(),
        cam_q.channel(1).to_vec(),
        cam_q.channel(2).to_vec(),
    ];

    // Photos.
    let bar = indicatif::ProgressBar::new(lines.len() as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "{prefix} [{bar:30}] {pos}/{len} captures {elapsed}",
        )
        .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
        .progress_chars("=> "),
    );
    bar.set_prefix("reading");
    let [rx, ry, rw, rh] = geometry.roi;
    let mut size: Option<(usize, usize, PathBuf)> = None;
    let mut captures = Vec::with_capacity(lines.len());
    for (l, gel) in lines.iter().zip(&capture_gels) {
        let loaded = load_capture(l, captures_path, rx + rw, ry + rh, &mut size);
        let frame = match loaded {
            Ok(f) => f,
            Err(e) => {
                bar.finish_and_clear();
                return Err(e);
            }
        };
        let readings = match geometry.band_readings(&frame) {
            Ok(r) => r,
            Err(e) => {
                bar.finish_and_clear();
                return Err(anyhow::Error::new(e).context(format!(
                    "{}:{}: {}",
                    captures_path.display(),
                    l.line,
                    l.image.display()
                )));
            }
        };
        captures.push(GelCapture {
            label: format!(
                "{} ({})",
                l.image.display(),
                gel.map_or("open LVF".to_string(), |g| g.label())
            ),
            filter: gel.map(|g| quad.iter().map(|&x| g.at(x)).collect()),
            readings,
        });
        bar.inc(1);
    }
    bar.finish_and_clear();
    let problem = TransmissionProblem {
        quad_nm: quad,
        source: s_q,
        target: r_q,
        camera: camera_q,
        captures,
    };
    let mut opts = TransmissionOptions::new(model, grid);
    opts.support_fwhm = a.support;
    opts.nonnegative = !a.no_nonneg;
    opts.use_std = !a.unweighted;
    opts.weight = if a.reg.eq_ignore_ascii_case("gcv") {
        Weight::Gcv
    } else {
        let v: f64 = a
            .reg
            .parse()
            .map_err(|_| anyhow::anyhow!("--reg: '{}'; expected gcv or a number ≥ 0", a.reg))?;
        if !(v.is_finite() && v >= 0.0) {
            bail!("--reg: {v}; expected gcv or a number ≥ 0");
        }
        Weight::Fixed(v)
    };
    let mut set = solve_transmissions(geometry, lvf_value, &problem, &opts)?;
    if let Some(obj) = set.diagnostics.as_object_mut() {
        obj.insert(
            "inputs".into(),
            serde_json::json!({
                "captures": captures_path.display().to_string(),
                "filters": a.filters.as_ref().map(|p| p.display().to_string()),
                "source": source_arg,
                "target": target_path.display().to_string(),
                "camera": a.camera.as_ref().map_or("calib/camera_default.csv".to_string(), |p| p.display().to_string()),
                "extend_filters_nm": a.extend_filters,
            }),
        );
    }
    Ok(set)
}

fn load_capture(
    l: &CaptureLine,
    csv: &Path,
    need_w: usize,
    need_h: usize,
    size: &mut Option<(usize, usize, PathBuf)>,
) -> Result<lumifit::capture::RgbFrame> {
    if !l.image.is_file() {
        bail!(
            "{}:{}: image {} does not exist",
            csv.display(),
            l.line,
            l.image.display()
        );
    }
    let (frame, info) = read_frame(&l.image).with_context(|| {
        format!(
            "{}:{}: reading {}",
            csv.display(),
            l.line,
            l.image.display()
        )
    })?;
    for w in &info.warnings {
        eprintln!("warning: {}: {w}", l.image.display());
    }
    if frame.width < need_w || frame.height < need_h {
        bail!(
            "{}:{}: image {} is {}×{} px but the lvf ROI needs at least {need_w}×{need_h} px (a photo from another camera setup?)",
            csv.display(),
            l.line,
            l.image.display(),
            frame.width,
            frame.height
        );
    }
    match size {
        None => *size = Some((frame.width, frame.height, l.image.clone())),
        Some((w, h, first)) if (*w, *h) != (frame.width, frame.height) => bail!(
            "{}:{}: image {} is {}×{} px but {} is {w}×{h} px; all captures must share the calibration's image size",
            csv.display(),
            l.line,
            l.image.display(),
            frame.width,
            frame.height,
            first.display()
        ),
        _ => {}
    }
    Ok(frame)
}

/// Where source × target × max camera channel is at least [`COVERAGE_LEVEL`] of its peak,
/// inside the range all three are sampled over (1 nm scan).
fn coverage(source: &Spectrum, target: &Spectrum, camera: &MultiSpectrum) -> Result<(f64, f64)> {
    let (s0, s1) = range(source.wavelengths());
    let (t0, t1) = range(target.wavelengths());
    let (c0, c1) = range(camera.wavelengths());
    let lo = s0.max(t0).max(c0).ceil();
    let hi = s1.min(t1).min(c1).floor();
    if hi - lo < 10.0 {
        bail!("source ({s0}–{s1} nm), target ({t0}–{t1} nm) and camera ({c0}–{c1} nm) share less than 10 nm");
    }
    let n = (hi - lo) as usize + 1;
    let x: Vec<f64> = (0..n).map(|i| lo + i as f64).collect();
    let s = source.values_at(&x, Interpolator::Linear)?;
    let r = target.values_at(&x, Interpolator::Linear)?;
    let q = camera.resample(&x, Interpolator::Linear)?;
    let v: Vec<f64> = (0..n)
        .map(|i| s[i] * r[i] * (0..3).map(|c| q.channel(c)[i]).fold(0.0, f64::max))
        .collect();
    let peak = v.iter().cloned().fold(0.0, f64::max);
    if peak.is_nan() || peak <= 0.0 {
        bail!("source × target × camera is zero everywhere: nothing reaches the camera");
    }
    let first = v
        .iter()
        .position(|&y| y >= COVERAGE_LEVEL * peak)
        .unwrap_or(0);
    let last = v
        .iter()
        .rposition(|&y| y >= COVERAGE_LEVEL * peak)
        .unwrap_or(n - 1);
    Ok((x[first], x[last]))
}
