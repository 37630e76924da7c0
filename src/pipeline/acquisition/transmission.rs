//! `lumifit lvf transmission`: `lvf.json`, `captures.csv`, the gel table, the light source, the
//! target and the camera become one [`TransmissionProblem`] on a 1 nm quadrature grid, solved by
//! [`solve_transmissions`] (Nalbach et al. 2017 §4.2).

use std::path::{Path, PathBuf};

use super::{json_value, range, read_json_text};
use crate::error::{Error, Result};
use crate::fit::regularized::Weight;
use crate::io::camera::{read_camera, Camera};
use crate::io::captures::{read_captures, CaptureLine};
use crate::io::filters::{read_gel_table, Gel};
use crate::io::series::read_frame;
use crate::io::sources::{file_of, resolve_illuminant};
use crate::limits::check_count;
use crate::lvf::transmission::{
    calibration_bands, default_grid, solve_transmissions, uniform_grid, BandModel, BandSet,
    GelCapture, TransmissionOptions, TransmissionProblem,
};
use crate::lvf::LvfGeometry;
use crate::math::interpolation::Interpolator;
use crate::spectrum::{MultiSpectrum, Spectrum};

/// Level below which source × target × camera counts as not covered (relative to its peak).
pub const COVERAGE_LEVEL: f64 = 1e-3;

/// The files of `lvf transmission`.
#[derive(Debug, Clone, Default)]
pub struct TransmissionInputs {
    /// The wavelength calibration (`lvf.json`).
    pub lvf: PathBuf,
    /// `captures.csv` (`image,filter`).
    pub captures: Option<PathBuf>,
    /// Gel table.
    pub filters: Option<PathBuf>,
    /// Light source: a CIE name, `daylight:<K>`, `blackbody:<K>` or a CSV.
    pub source: Option<String>,
    /// Target reflectance CSV.
    pub target: Option<PathBuf>,
    /// Camera sensitivities CSV (default: the embedded camera).
    pub camera: Option<PathBuf>,
}

impl TransmissionInputs {
    /// Reads the captures CSV (when given) once and returns the job [`band_transmissions`]
    /// runs: its photo list and every file it reads, for the output-path check and a progress
    /// bar, without a second parse.
    ///
    /// # Errors
    /// The errors of [`read_captures`] (a missing photo or a folder named as one).
    pub fn open(self) -> Result<TransmissionJob> {
        let captures = self.captures.as_deref().map(read_captures).transpose()?;
        Ok(TransmissionJob {
            inputs: self,
            captures,
        })
    }
}

/// [`TransmissionInputs`] with the captures CSV read: what [`band_transmissions`] solves.
#[derive(Debug, Clone)]
pub struct TransmissionJob {
    inputs: TransmissionInputs,
    captures: Option<Vec<CaptureLine>>,
}

impl TransmissionJob {
    /// The photos the captures CSV lists (0 without `--captures`).
    pub fn photo_count(&self) -> usize {
        self.captures.as_ref().map_or(0, Vec::len)
    }

    /// Every file the run reads: the named files, the source when it is a file, the captures
    /// CSV and each photo it lists.
    pub fn files(&self) -> Vec<PathBuf> {
        let i = &self.inputs;
        let mut out = vec![i.lvf.clone()];
        out.extend(i.filters.iter().chain(&i.target).chain(&i.camera).cloned());
        out.extend(i.source.as_deref().and_then(file_of));
        if let Some(c) = &i.captures {
            out.push(c.clone());
        }
        if let Some(lines) = &self.captures {
            out.extend(lines.iter().map(|l| l.image.clone()));
        }
        out
    }
}

/// Options of `lvf transmission`.
#[derive(Debug, Clone)]
pub struct TransmissionConfig {
    /// Band model.
    pub model: BandModel,
    /// Solve grid; `None`: 5 nm over the bands' support, clipped to the covered range.
    pub grid: Option<Vec<f64>>,
    /// Support half-width of nnls/lstsq bands in effective calibration FWHMs.
    pub support_fwhm: f64,
    /// How far (nm) gels may be held constant beyond their measured range.
    pub extend_filters_nm: f64,
    /// Smoothness weight of nnls.
    pub weight: Weight,
    /// Non-negativity of nnls.
    pub nonnegative: bool,
    /// Weight equations by the readings' standard errors.
    pub use_std: bool,
}

/// Parses `--grid LO:HI:STEP` of `lvf transmission`. The grid may be no finer than the 1 nm
/// quadrature the problem is integrated on (more points resolve nothing and the solve grows with
/// the cube of their number).
///
/// # Errors
/// [`Error::InvalidArgument`] naming `--grid` for malformed text or a grid over the limit.
pub fn parse_transmission_grid(s: &str) -> Result<Vec<f64>> {
    let parts: Vec<&str> = s.split(':').map(str::trim).collect();
    let nums: Option<Vec<f64>> = parts.iter().map(|p| p.parse::<f64>().ok()).collect();
    let (lo, hi, step) = match nums.as_deref() {
        Some(&[lo, hi, step]) => (lo, hi, step),
        _ => {
            return Err(Error::invalid(
                "--grid",
                format!("'{s}' is not LO:HI:STEP, e.g. 400:700:5"),
            ))
        }
    };
    if step.is_finite() && step > 0.0 && hi.is_finite() && lo.is_finite() && hi > lo {
        let points = ((hi - lo) / step + 1e-9).floor() + 1.0;
        let quadrature = (hi - lo).round().max(1.0) + 1.0;
        check_count(
            "--grid",
            points.min(usize::MAX as f64) as usize,
            quadrature as usize,
            &format!(
                "grid points of {s}: the transmissions are integrated on a 1 nm grid over {lo}–{hi} nm, so STEP must be ≥ 1 nm"
            ),
        )?;
    }
    uniform_grid(lo, hi, step)
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
        return Err(Error::invalid(
            "--source/--target/--camera",
            format!("source ({s0}–{s1} nm), target ({t0}–{t1} nm) and camera ({c0}–{c1} nm) share less than 10 nm"),
        ));
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
        return Err(Error::invalid(
            "--source/--target/--camera",
            "source × target × camera is zero everywhere: nothing reaches the camera",
        ));
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

/// Solves the band transmissions of `lvf transmission` (or, for [`BandModel::Calibration`],
/// builds them from `lvf.json` alone). `progress` is called once per photo read; the photos'
/// non-fatal remarks (8-bit input, …) are appended to `warnings`.
///
/// # Errors
/// Every reader's error naming its file (and line), missing inputs for the model, grids that
/// reach beyond the source, target, camera or gels, photos of another size than the
/// calibration's, and the solver's errors.
pub fn band_transmissions(
    job: &TransmissionJob,
    cfg: &TransmissionConfig,
    progress: &dyn Fn(),
    warnings: &mut Vec<String>,
) -> Result<BandSet> {
    let inputs = &job.inputs;
    let (lvf_text, lvf_src) = read_json_text(&inputs.lvf, "an lvf.json from 'lvf calibrate'")?;
    let geometry = LvfGeometry::from_json(lvf_text.as_bytes(), &lvf_src)?;
    let lvf_value = json_value(&lvf_text, &lvf_src)?;
    let mut set = if cfg.model == BandModel::Calibration {
        let grid = match &cfg.grid {
            Some(g) => g.clone(),
            None => default_grid(&geometry, cfg.support_fwhm, 5.0, None)?,
        };
        calibration_bands(&geometry, lvf_value, &grid)?
    } else {
        solve_from_captures(job, cfg, &geometry, lvf_value, progress, warnings)?
    };
    if let Some(obj) = set.diagnostics.as_object_mut() {
        obj.insert("lvf".into(), serde_json::json!(lvf_src));
    }
    Ok(set)
}

fn solve_from_captures(
    job: &TransmissionJob,
    cfg: &TransmissionConfig,
    geometry: &LvfGeometry,
    lvf_value: serde_json::Value,
    progress: &dyn Fn(),
    warnings: &mut Vec<String>,
) -> Result<BandSet> {
    let need = |present: bool, flag: &str| -> Result<()> {
        if present {
            Ok(())
        } else {
            Err(Error::invalid(
                flag,
                format!("required with --model {}", cfg.model.name()),
            ))
        }
    };
    let inputs = &job.inputs;
    need(inputs.captures.is_some(), "--captures")?;
    need(inputs.source.is_some(), "--source")?;
    need(inputs.target.is_some(), "--target")?;
    let captures_path = inputs.captures.as_deref().unwrap_or(Path::new(""));
    let csv = captures_path.display().to_string();
    let lines: &[CaptureLine] = job.captures.as_deref().unwrap_or(&[]);
    let gels: Vec<Gel> = if lines.iter().any(|l| l.filter.is_some()) {
        let Some(f) = &inputs.filters else {
            return Err(Error::invalid(
                "--filters",
                format!("{csv}: captures name gels but no --filters table was given"),
            ));
        };
        read_gel_table(f)?
    } else {
        Vec::new()
    };
    let mut capture_gels: Vec<Option<&Gel>> = Vec::with_capacity(lines.len());
    for l in lines {
        match &l.filter {
            None => capture_gels.push(None),
            Some(code) => {
                let g = gels
                    .iter()
                    .find(|g| g.code.eq_ignore_ascii_case(code))
                    .ok_or_else(|| {
                        let sample: Vec<&str> =
                            gels.iter().take(6).map(|g| g.code.as_str()).collect();
                        Error::parse(
                            &csv,
                            l.line,
                            format!(
                                "unknown gel code '{code}'; the table {} has {} gels, e.g. {}",
                                inputs
                                    .filters
                                    .as_deref()
                                    .map(|p| p.display().to_string())
                                    .unwrap_or_default(),
                                gels.len(),
                                sample.join(", ")
                            ),
                        )
                    })?;
                capture_gels.push(Some(g));
            }
        }
    }
    let source_arg = inputs.source.as_deref().unwrap_or("");
    let source = resolve_illuminant("--source", source_arg)?
        .spectrum()
        .clone();
    let target_path = inputs.target.as_deref().unwrap_or(Path::new(""));
    let target = crate::io::spectrum_csv::read_spectrum(target_path)?;
    if let Some(i) = target.values().iter().position(|v| *v < 0.0) {
        return Err(Error::invalid(
            "--target",
            format!(
                "{}: reflectance {} at {} nm; expected ≥ 0",
                target_path.display(),
                target.values()[i],
                target.wavelengths()[i]
            ),
        ));
    }
    let Camera {
        curves: camera,
        source: camera_src,
    } = read_camera(inputs.camera.as_deref())?;

    // Grid: explicit, or the bands' support clipped to where S·R·Q is seen.
    let grid = match &cfg.grid {
        Some(g) => {
            for (what, w) in [
                ("--source", source.wavelengths()),
                ("--target", target.wavelengths()),
                ("--camera", camera.wavelengths()),
            ] {
                let (lo, hi) = range(w);
                if g[0] < lo - 1e-9 || g[g.len() - 1] > hi + 1e-9 {
                    return Err(Error::invalid(
                        "--grid",
                        format!(
                            "{}–{} nm reaches beyond {what}, which covers {lo}–{hi} nm",
                            g[0],
                            g[g.len() - 1]
                        ),
                    ));
                }
            }
            g.clone()
        }
        None => default_grid(
            geometry,
            cfg.support_fwhm,
            5.0,
            Some(coverage(&source, &target, &camera)?),
        )?,
    };
    let (glo, ghi) = (grid[0], grid[grid.len() - 1]);
    // Gels must cover the grid (or be extended explicitly).
    for g in capture_gels.iter().flatten() {
        let (lo, hi) = range(g.transmission.wavelengths());
        let ext = cfg.extend_filters_nm;
        if !(lo - ext <= glo + 1e-9 && hi + ext >= ghi - 1e-9) {
            let need = ((lo - glo).max(ghi - hi)).max(0.0);
            return Err(Error::invalid(
                "--filters",
                format!(
                    "gel {} covers {lo}–{hi} nm; the grid needs {glo}–{ghi} nm: pass --grid {}:{}:{} or --extend-filters {} (holds each gel's edge value constant)",
                    g.code,
                    lo.max(glo),
                    hi.min(ghi),
                    grid[1] - grid[0],
                    need.ceil()
                ),
            ));
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
    let [rx, ry, rw, rh] = geometry.roi;
    let mut size: Option<(usize, usize, PathBuf)> = None;
    let mut captures = Vec::with_capacity(lines.len());
    for (l, gel) in lines.iter().zip(&capture_gels) {
        let frame = load_capture(l, &csv, rx + rw, ry + rh, &mut size, warnings)?;
        let readings = geometry
            .band_readings(&frame)
            .map_err(|e| Error::parse(&csv, l.line, format!("{}: {e}", l.image.display())))?;
        captures.push(GelCapture {
            label: format!(
                "{} ({})",
                l.image.display(),
                gel.map_or("open LVF".to_string(), |g| g.label())
            ),
            filter: gel.map(|g| quad.iter().map(|&x| g.at(x)).collect()),
            readings,
        });
        progress();
    }
    let problem = TransmissionProblem {
        quad_nm: quad,
        source: s_q,
        target: r_q,
        camera: camera_q,
        captures,
    };
    let mut opts = TransmissionOptions::new(cfg.model, grid);
    opts.support_fwhm = cfg.support_fwhm;
    opts.nonnegative = cfg.nonnegative;
    opts.use_std = cfg.use_std;
    opts.weight = cfg.weight;
    let mut set = solve_transmissions(geometry, lvf_value, &problem, &opts)?;
    if let Some(obj) = set.diagnostics.as_object_mut() {
        obj.insert(
            "inputs".into(),
            serde_json::json!({
                "captures": csv,
                "filters": inputs.filters.as_ref().map(|p| p.display().to_string()),
                "source": source_arg,
                "target": target_path.display().to_string(),
                "camera": camera_src,
                "extend_filters_nm": cfg.extend_filters_nm,
            }),
        );
    }
    Ok(set)
}

fn load_capture(
    l: &CaptureLine,
    csv: &str,
    need_w: usize,
    need_h: usize,
    size: &mut Option<(usize, usize, PathBuf)>,
    warnings: &mut Vec<String>,
) -> Result<crate::capture::RgbFrame> {
    let (frame, info) = read_frame(&l.image)
        .map_err(|e| Error::parse(csv, l.line, format!("reading {}: {e}", l.image.display())))?;
    warnings.extend(
        info.warnings
            .iter()
            .map(|w| format!("{}: {w}", l.image.display())),
    );
    if frame.width < need_w || frame.height < need_h {
        return Err(Error::parse(
            csv,
            l.line,
            format!(
                "image {} is {}×{} px but the lvf ROI needs at least {need_w}×{need_h} px (a photo from another camera setup?)",
                l.image.display(),
                frame.width,
                frame.height
            ),
        ));
    }
    match size {
        None => *size = Some((frame.width, frame.height, l.image.clone())),
        Some((w, h, first)) if (*w, *h) != (frame.width, frame.height) => {
            return Err(Error::parse(
                csv,
                l.line,
                format!(
                    "image {} is {}×{} px but {} is {w}×{h} px; all captures must share the calibration's image size",
                    l.image.display(),
                    frame.width,
                    frame.height,
                    first.display()
                ),
            ))
        }
        _ => {}
    }
    Ok(frame)
}

/// The JSON summary `lvf transmission` prints.
pub fn transmission_summary(set: &BandSet, out: &Path, seconds: f64) -> serde_json::Value {
    let d = &set.diagnostics;
    serde_json::json!({
        "out": out.display().to_string(),
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
