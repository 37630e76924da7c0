//! Acquisition glue: the LVF domain (`lvf`: geometry, band files, band-transmission solve) joined
//! with the spectral-recovery domain (`recovery`, which knows no LVF) and the readers of `io`.
//!
//! - [`band_transmissions`] (`lumifit lvf transmission`): `lvf.json`, `captures.csv`, the gel
//!   table, the light source, the target and the camera become one
//!   [`TransmissionProblem`] on a 1 nm quadrature grid, solved by
//!   [`crate::lvf::transmission::solve_transmissions`] (Nalbach et al. 2017 §4.2).
//! - [`recover_spectrum`] (`lumifit spectrum recover`): a band file (`lvf_bands.json`, or the
//!   `lvf.json` alone with parametric Gaussian bands) and the camera become a
//!   [`SensingModel`]; a photo or a readings CSV gives the band readings; the light or a
//!   reflectance factor is recovered by [`crate::recovery::recover`].
//!
//! Every file is read here (through `io`), never by the binary, and every input file a run will
//! read is listed beforehand ([`TransmissionInputs::files`], [`RecoverInputs::files`]) so the
//! command can refuse an output that would replace one of them.

use std::path::{Path, PathBuf};

use crate::error::{Error, Result};
use crate::fit::regularized::Weight;
use crate::io::camera::{read_camera, Camera};
use crate::io::captures::{read_captures, CaptureLine};
use crate::io::filters::{read_gel_table, Gel};
use crate::io::series::read_frame;
use crate::io::sources::{file_of, resolve_illuminant, white_reflectance};
use crate::limits::check_count;
use crate::lvf::transmission::{
    calibration_bands, default_grid, solve_transmissions, uniform_grid, BandModel, BandSet,
    GelCapture, TransmissionOptions, TransmissionProblem,
};
use crate::lvf::LvfGeometry;
use crate::math::interpolation::Interpolator;
use crate::recovery::dump::{system_dump, SystemDump};
use crate::recovery::{
    exposure_from_white, recover, white_gains, Quantity, Recovered, RecoveryOptions, SensingModel,
};
use crate::spectrum::{MultiSpectrum, Spectrum};

/// Level below which source × target × camera counts as not covered (relative to its peak).
pub const COVERAGE_LEVEL: f64 = 1e-3;

/// Most wavelengths of a recovery grid (`spectrum recover --grid`).
pub const MAX_RECOVERY_GRID_STEPS: usize = 2000;

/// Per band r, g, b.
pub type Rgb = Vec<[f64; 3]>;

fn range(w: &[f64]) -> (f64, f64) {
    (w[0], w[w.len() - 1])
}

/// Reads a JSON file as text (BOM removed) and its source name.
fn read_json_text(path: &Path, expected: &str) -> Result<(String, String)> {
    let (bytes, src) = crate::io::read_input(path)?;
    let text = crate::table::as_text(&bytes, &src, expected)?.to_string();
    Ok((text, src))
}

fn json_value(text: &str, src: &str) -> Result<serde_json::Value> {
    serde_json::from_str(text).map_err(|e| {
        Error::parse(
            src,
            e.line(),
            format!("column {}: not JSON: {e}", e.column()),
        )
    })
}

// ---------------------------------------------------------------------------------------------
// lvf transmission
// ---------------------------------------------------------------------------------------------

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
    /// Every file the run reads: the named files, the source when it is a file, and each photo
    /// listed in the captures CSV.
    ///
    /// # Errors
    /// The errors of [`read_captures`] (a missing photo or a folder named as one).
    pub fn files(&self) -> Result<Vec<PathBuf>> {
        let mut out = vec![self.lvf.clone()];
        out.extend(
            self.filters
                .iter()
                .chain(&self.target)
                .chain(&self.camera)
                .cloned(),
        );
        out.extend(self.source.as_deref().and_then(file_of));
        if let Some(c) = &self.captures {
            out.push(c.clone());
            out.extend(read_captures(c)?.into_iter().map(|l| l.image));
        }
        Ok(out)
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
    inputs: &TransmissionInputs,
    cfg: &TransmissionConfig,
    progress: &dyn Fn(),
    warnings: &mut Vec<String>,
) -> Result<BandSet> {
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
        solve_from_captures(inputs, cfg, &geometry, lvf_value, progress, warnings)?
    };
    if let Some(obj) = set.diagnostics.as_object_mut() {
        obj.insert("lvf".into(), serde_json::json!(lvf_src));
    }
    Ok(set)
}

fn solve_from_captures(
    inputs: &TransmissionInputs,
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
    need(inputs.captures.is_some(), "--captures")?;
    need(inputs.source.is_some(), "--source")?;
    need(inputs.target.is_some(), "--target")?;
    let captures_path = inputs.captures.as_deref().unwrap_or(Path::new(""));
    let csv = captures_path.display().to_string();
    let lines = read_captures(captures_path)?;
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
    for l in &lines {
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

// ---------------------------------------------------------------------------------------------
// spectrum recover
// ---------------------------------------------------------------------------------------------

/// Parses a recovery grid `LO:HI:STEP` (nm): at least 4 and at most
/// [`MAX_RECOVERY_GRID_STEPS`] steps.
///
/// # Errors
/// [`Error::InvalidArgument`] naming `flag`.
pub fn parse_recovery_grid(flag: &str, s: &str) -> Result<Vec<f64>> {
    let bad = || {
        Error::invalid(
            flag,
            format!("'{s}' is not LO:HI:STEP in nm, e.g. 400:700:5"),
        )
    };
    let parts: Vec<f64> = s
        .split(':')
        .map(|p| p.trim().parse::<f64>())
        .collect::<std::result::Result<_, _>>()
        .map_err(|_| bad())?;
    if parts.len() != 3 || !parts.iter().all(|v| v.is_finite()) {
        return Err(bad());
    }
    let (lo, hi, step) = (parts[0], parts[1], parts[2]);
    if !(step > 0.0 && hi > lo) {
        return Err(Error::invalid(
            flag,
            format!("'{s}': expected LO < HI and 0 < STEP"),
        ));
    }
    let steps = (hi - lo) / step;
    if steps > MAX_RECOVERY_GRID_STEPS as f64 {
        return Err(Error::invalid(
            flag,
            format!(
                "'{s}' gives {} steps, over the limit of {MAX_RECOVERY_GRID_STEPS} (the recovery solves a dense system of that many unknowns)",
                steps.floor()
            ),
        ));
    }
    let n = (steps + 1e-9).floor() as usize + 1;
    if n < 4 {
        return Err(Error::invalid(
            flag,
            format!("'{s}' gives {n} wavelengths; expected at least 4"),
        ));
    }
    Ok((0..n).map(|i| lo + step * i as f64).collect())
}

/// The bands as read from `--bands`, sampled on the recovery grid.
#[derive(Debug, Clone)]
pub struct BandSource {
    /// Where the readings come from.
    pub geometry: LvfGeometry,
    /// `calibration` (parametric from lvf.json) or the band file's model.
    pub model: String,
    /// T_j on the recovery grid.
    pub transmission: Vec<Vec<f64>>,
}

/// The default recovery grid.
const DEFAULT_RECOVERY_GRID: &str = "400:700:5";

/// Reads `--bands`: an `lvf_bands.json` (`lumifit.lvf-bands/1`) or an `lvf.json`
/// (`lumifit.lvf/1`, parametric Gaussian bands of peak 1), and samples the bands on `grid`
/// (default 400:700:5, clipped to a band file's grid). Returns the bands and the grid.
///
/// # Errors
/// [`Error::Parse`] naming the file for malformed JSON or another schema; the band file's errors.
pub fn read_band_source(path: &Path, grid: Option<&[f64]>) -> Result<(BandSource, Vec<f64>)> {
    let (text, src) = read_json_text(path, "lvf_bands.json or lvf.json")?;
    let v = json_value(&text, &src)?;
    match v.get("schema").and_then(|s| s.as_str()) {
        Some("lumifit.lvf/1") => {
            let geometry = LvfGeometry::from_json(text.as_bytes(), &src)?;
            let grid = match grid {
                Some(g) => g.to_vec(),
                None => parse_recovery_grid("--grid", DEFAULT_RECOVERY_GRID)?,
            };
            let transmission = (0..geometry.bands.len())
                .map(|j| geometry.parametric_band(j, &grid, geometry.fwhm_nm, 1.0))
                .collect();
            Ok((
                BandSource {
                    geometry,
                    model: "calibration".into(),
                    transmission,
                },
                grid,
            ))
        }
        Some("lumifit.lvf-bands/1") => {
            let set = BandSet::from_json(text.as_bytes(), &src)?;
            let geometry = set.geometry(&src)?;
            let (lo, hi) = range(&set.grid_nm);
            let grid = match grid {
                Some(g) => g.to_vec(),
                None => {
                    let g: Vec<f64> = parse_recovery_grid("--grid", DEFAULT_RECOVERY_GRID)?
                        .into_iter()
                        .filter(|l| *l >= lo - 1e-9 && *l <= hi + 1e-9)
                        .collect();
                    if g.len() < 4 {
                        return Err(Error::invalid(
                            "--grid",
                            format!("{src}: the band grid {lo}–{hi} nm hardly overlaps 400–700 nm; pass --grid"),
                        ));
                    }
                    g
                }
            };
            let transmission = (0..set.bands.len())
                .map(|j| set.transmission_on(j, &grid))
                .collect::<Result<Vec<_>>>()?;
            Ok((
                BandSource {
                    geometry,
                    model: set.model.name().to_string(),
                    transmission,
                },
                grid,
            ))
        }
        other => Err(Error::parse(
            &src,
            0,
            format!(
                "field 'schema' is {}; expected 'lumifit.lvf-bands/1' (from 'lvf transmission') or 'lumifit.lvf/1' (from 'lvf calibrate')",
                other.map_or("missing".to_string(), |s| format!("'{s}'"))
            ),
        )),
    }
}

/// Reads a readings CSV `band,r,g,b[,std_r,std_g,std_b]` (band 1-based, one row per band).
///
/// # Errors
/// [`Error::Parse`] naming the file and line: wrong column count, a band out of range or given
/// twice, a band count other than `n_bands`.
pub fn read_band_readings(path: &Path, n_bands: usize) -> Result<(Rgb, Option<Rgb>)> {
    let (bytes, src) = crate::io::read_input(path)?;
    let t = crate::table::parse_numeric_csv(&bytes, &src)?;
    let ncol = t.columns.len();
    if ncol != 4 && ncol != 7 {
        return Err(Error::parse(
            &src,
            0,
            format!("{ncol} columns; expected band,r,g,b or band,r,g,b,std_r,std_g,std_b"),
        ));
    }
    let mut rgb = vec![[f64::NAN; 3]; n_bands];
    let mut std = vec![[0.0; 3]; n_bands];
    for i in 0..t.n_rows() {
        let b = t.columns[0][i];
        if b.fract() != 0.0 || b < 1.0 || b > n_bands as f64 {
            return Err(Error::parse(
                &src,
                t.lines[i],
                format!(
                    "band {b}; expected an integer 1–{n_bands} (the band file has {n_bands} bands)"
                ),
            ));
        }
        let j = b as usize - 1;
        if !rgb[j][0].is_nan() {
            return Err(Error::parse(
                &src,
                t.lines[i],
                format!("band {b} given twice"),
            ));
        }
        for c in 0..3 {
            rgb[j][c] = t.columns[1 + c][i];
            if ncol == 7 {
                std[j][c] = t.columns[4 + c][i];
            }
        }
    }
    if t.n_rows() != n_bands {
        return Err(Error::parse(
            &src,
            0,
            format!(
                "{} bands read; the band file has {n_bands} — expected one row per band",
                t.n_rows()
            ),
        ));
    }
    Ok((rgb, (ncol == 7).then_some(std)))
}

fn capture_readings(path: &Path, geometry: &LvfGeometry) -> Result<(Rgb, Rgb)> {
    let (frame, _) = read_frame(path)?;
    let r = geometry.band_readings(&frame).map_err(|e| {
        Error::invalid(
            "capture",
            format!("{}: reading the LVF bands: {e}", path.display()),
        )
    })?;
    Ok((r.rgb, r.std))
}

/// The files and values of `spectrum recover`.
#[derive(Debug, Clone)]
pub struct RecoverInputs {
    /// The photo through the LVF (or `readings`).
    pub image: Option<PathBuf>,
    /// Readings per band CSV (instead of a photo).
    pub readings: Option<PathBuf>,
    /// `lvf_bands.json` or `lvf.json`.
    pub bands: PathBuf,
    /// Camera sensitivities CSV (default: the embedded camera).
    pub camera: Option<PathBuf>,
    /// Region `[x, y, w, h]` replacing the calibration's ROI.
    pub roi: Option<[usize; 4]>,
    /// Recovery grid (default 400:700:5 clipped to the band file).
    pub grid: Option<Vec<f64>>,
    /// Reflectance mode: the illuminant (name or CSV).
    pub illuminant: Option<String>,
    /// Reflectance mode: a capture of a white reference.
    pub white: Option<PathBuf>,
    /// Reflectance of the white reference: a number or a CSV.
    pub white_reflectance: String,
    /// With an illuminant and no white: the exposure factor.
    pub exposure: f64,
    /// Reference spectrum CSV to compare with.
    pub compare: Option<PathBuf>,
}

impl RecoverInputs {
    /// Every file the run reads.
    pub fn files(&self) -> Vec<PathBuf> {
        let mut out = vec![self.bands.clone()];
        out.extend(
            self.image
                .iter()
                .chain(&self.readings)
                .chain(&self.camera)
                .chain(&self.white)
                .chain(&self.compare)
                .cloned(),
        );
        out.extend(self.illuminant.as_deref().and_then(file_of));
        out.extend(file_of(&self.white_reflectance));
        out
    }
}

/// A reference compared with the recovery.
#[derive(Debug, Clone)]
pub struct Comparison {
    /// The reference file.
    pub reference: String,
    /// The reference scaled to the recovery.
    pub scaled: Spectrum,
    /// RMS difference on the grid.
    pub rms: f64,
    /// Peak of the scaled reference on the grid.
    pub peak: f64,
    /// Least-squares scale applied (light mode; 1 for reflectance).
    pub scale: f64,
}

/// What `spectrum recover` produced.
#[derive(Debug, Clone)]
pub struct RecoverOutcome {
    /// The recovery.
    pub rec: Recovered,
    /// Band model of the band file (`calibration`, `nnls`, …).
    pub band_model: String,
    /// Where the camera curves came from.
    pub camera: String,
    /// `light`, or which reflectance.
    pub mode: String,
    /// Whether the light itself was recovered (not a reflectance factor).
    pub is_light: bool,
    /// Exposure used or found from the white reference.
    pub exposure: Option<f64>,
    /// Number of bands.
    pub n_bands: usize,
    /// The reference comparison, when asked.
    pub compare: Option<Comparison>,
    /// The solved system, when asked.
    pub dump: Option<SystemDump>,
    /// Time of the whole recovery (s).
    pub seconds: f64,
}

/// Recovers the light, or a reflectance factor, from one capture (or readings) through the
/// bands (see the module docs).
///
/// # Errors
/// Every reader's error naming its file; a band count that differs between capture and band
/// file; the recovery's errors.
pub fn recover_spectrum(
    inputs: &RecoverInputs,
    opts: &RecoveryOptions,
    dump_system: bool,
) -> Result<RecoverOutcome> {
    let (mut bands, grid) = read_band_source(&inputs.bands, inputs.grid.as_deref())?;
    if let Some(roi) = inputs.roi {
        bands.geometry.roi = roi;
    }
    let cam = read_camera(inputs.camera.as_deref())?;
    let model = SensingModel {
        grid_nm: grid.clone(),
        transmission: bands.transmission.clone(),
        camera: cam.on_grid(&grid)?,
    };
    let nb = model.transmission.len();
    let (rgb, std) = match (&inputs.image, &inputs.readings) {
        (Some(img), _) => {
            let (rgb, std) = capture_readings(img, &bands.geometry)?;
            (rgb, Some(std))
        }
        (None, Some(csv)) => read_band_readings(csv, nb)?,
        (None, None) => return Err(Error::invalid("input", "give a photo or --readings")),
    };
    if rgb.len() != nb {
        return Err(Error::invalid(
            "--bands",
            format!(
                "the capture gives {} bands but {} holds {nb} band transmissions",
                rgb.len(),
                inputs.bands.display()
            ),
        ));
    }
    let started = std::time::Instant::now();
    let mut mode = "light".to_string();
    let mut exposure = None;
    let quantity = match (&inputs.illuminant, &inputs.white) {
        (None, None) => Quantity::Light,
        (ill, white) => {
            let rho = white_reflectance(&inputs.white_reflectance, &grid)?;
            let white_rgb = match white {
                Some(w) => Some(capture_readings(w, &bands.geometry)?),
                None => None,
            };
            let mut gains = None;
            let weight = match (ill, white_rgb) {
                (Some(name), w) => {
                    let ill = resolve_illuminant("--illuminant", name)?;
                    let s = ill.spectrum().values_at(&grid, ill.interpolator())?;
                    mode = format!("reflectance under {}", ill.name());
                    match w {
                        Some((wr, _)) => {
                            exposure = Some(exposure_from_white(&model, &wr, &s, &rho)?);
                            gains = Some(white_gains(&model, &wr, &s, &rho)?);
                            s
                        }
                        None => {
                            exposure = Some(inputs.exposure);
                            s.iter().map(|v| v * inputs.exposure).collect()
                        }
                    }
                }
                (None, Some((wr, ws))) => {
                    let lw =
                        recover(&model, &wr, Some(&ws), &Quantity::Light, opts).map_err(|e| {
                            Error::invalid(
                                "--white",
                                format!("recovering the white reference: {e}"),
                            )
                        })?;
                    mode = "reflectance relative to the recovered white reference".into();
                    lw.value
                        .iter()
                        .zip(&rho)
                        .map(|(l, r)| (l / r).max(0.0))
                        .collect()
                }
                (None, None) => Vec::new(),
            };
            Quantity::Reflectance { weight, gains }
        }
    };
    let solve_started = std::time::Instant::now();
    let rec = recover(&model, &rgb, std.as_deref(), &quantity, opts)?;
    let solve_s = solve_started.elapsed().as_secs_f64();
    let seconds = started.elapsed().as_secs_f64();
    crate::error::ensure_finite(
        "the recovered spectrum",
        &inputs.bands.display().to_string(),
        &rec.value,
    )?;
    let dump = if dump_system {
        Some(system_dump(
            &model,
            &rgb,
            std.as_deref(),
            &quantity,
            opts,
            &rec,
            solve_s,
        )?)
    } else {
        None
    };
    let is_light = matches!(quantity, Quantity::Light);
    let compare = match &inputs.compare {
        Some(p) => Some(compare_with(p, &grid, &rec, is_light)?),
        None => None,
    };
    Ok(RecoverOutcome {
        rec,
        band_model: bands.model,
        camera: cam.source,
        mode,
        is_light,
        exposure,
        n_bands: nb,
        compare,
        dump,
        seconds,
    })
}

/// A reference to compare with; a light's absolute level is the capture's (exposure), so in
/// light mode the reference is scaled to the recovery by least squares first.
fn compare_with(path: &Path, grid: &[f64], rec: &Recovered, is_light: bool) -> Result<Comparison> {
    let sd = crate::io::spectrum_csv::read_spectrum(path)?;
    let v = sd.values_at(grid, Interpolator::Linear)?;
    let scale = if is_light {
        let num: f64 = rec.value.iter().zip(&v).map(|(x, y)| x * y).sum();
        let den: f64 = v.iter().map(|y| y * y).sum();
        if den > 0.0 {
            num / den
        } else {
            1.0
        }
    } else {
        1.0
    };
    let rms = (rec
        .value
        .iter()
        .zip(&v)
        .map(|(x, y)| (x - scale * y).powi(2))
        .sum::<f64>()
        / v.len() as f64)
        .sqrt();
    let peak = v.iter().fold(0.0f64, |m, y| m.max(scale * y.abs()));
    Ok(Comparison {
        reference: path.display().to_string(),
        scaled: sd.scaled(scale),
        rms,
        peak,
        scale,
    })
}

/// The recovery as CSV `wavelength_nm,value,std`.
pub fn recovery_csv(rec: &Recovered) -> String {
    let mut csv = String::from("wavelength_nm,value,std\n");
    for ((l, v), sd) in rec.wavelength_nm.iter().zip(&rec.value).zip(&rec.std) {
        csv.push_str(&format!("{l},{v},{sd}\n"));
    }
    csv
}

/// The JSON summary of `spectrum recover` (`lumifit.spectrum-recovery/1`).
pub fn recovery_summary(
    o: &RecoverOutcome,
    inputs: &RecoverInputs,
    out: &Path,
) -> serde_json::Value {
    let rec = &o.rec;
    let res: Vec<f64> = rec
        .resolution_nm
        .iter()
        .copied()
        .filter(|v| v.is_finite())
        .collect();
    let (rmin, rmax) = res.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), v| {
        (lo.min(*v), hi.max(*v))
    });
    let at = |nm: f64| {
        rec.wavelength_nm
            .iter()
            .position(|l| (l - nm).abs() < 1e-9)
            .map(|i| rec.resolution_nm[i])
    };
    serde_json::json!({
        "schema": "lumifit.spectrum-recovery/1",
        "input": inputs.image.as_ref().or(inputs.readings.as_ref()).map(|p| p.display().to_string()),
        "bands": inputs.bands.display().to_string(),
        "band_model": o.band_model,
        "camera": o.camera,
        "mode": o.mode,
        "exposure": o.exposure,
        "out": out.display().to_string(),
        "grid_nm": [rec.wavelength_nm.first(), rec.wavelength_nm.last(), rec.wavelength_nm.len()],
        "lambda": rec.lambda,
        "lambda_from_gcv": rec.lambda_from_gcv,
        "effective_parameters": rec.effective_parameters,
        "equations": rec.equations,
        "unknowns": rec.unknowns,
        "condition_number": rec.condition_number,
        "relative_residual": rec.relative_residual,
        "clamped_to_zero": rec.clamped,
        "resolution_nm": {
            "min": rmin, "max": rmax,
            "at_450": at(450.0), "at_550": at(550.0), "at_650": at(650.0),
            "meaning": "FWHM of the resolution matrix row: features narrower than this are blurred to about this width",
        },
        "compare": o.compare.as_ref().map(|c| serde_json::json!({
            "reference": c.reference, "scale": c.scale, "rms": c.rms, "rms_relative_to_peak": c.rms / c.peak,
        })),
        "seconds": o.seconds,
    })
}

/// The recovery chart (recovered ± 2σ, the reference when compared, resolution per wavelength)
/// as PNG bytes.
///
/// # Errors
/// The chart's errors.
pub fn recovery_plot_png(o: &RecoverOutcome) -> Result<Vec<u8>> {
    let title = format!(
        "Recovered {} ({} bands, {})",
        o.mode, o.n_bands, o.band_model
    );
    let y_label = if o.is_light {
        "relative spectral radiance"
    } else {
        "reflectance factor"
    };
    let refs: Vec<(String, Vec<f64>, Vec<f64>)> = o
        .compare
        .iter()
        .map(|c| {
            let label = if (c.scale - 1.0).abs() > 1e-12 {
                format!("{} (× {:.4e}, least-squares scale)", c.reference, c.scale)
            } else {
                c.reference.clone()
            };
            (
                label,
                c.scaled.wavelengths().to_vec(),
                c.scaled.values().to_vec(),
            )
        })
        .collect();
    let r: Vec<crate::plot::recovery::Reference<'_>> = refs
        .iter()
        .map(|(n, x, y)| (n.as_str(), x.as_slice(), y.as_slice()))
        .collect();
    crate::plot::recovery::recovery_chart_png(&title, y_label, &o.rec, &r)
}
