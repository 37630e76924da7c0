//! `lumifit spectrum recover`: the spectrum of the light (or a reflectance factor) from one photo
//! through the calibrated LVF.

// `!(a > b)` comparisons deliberately reject NaN along with out-of-range values.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use std::path::{Path, PathBuf};

use anyhow::{anyhow, bail, Context, Result};
use clap::{ArgGroup, Args, Subcommand};
use lumifit::fit::regularized::Weight;
use lumifit::lvf::LvfGeometry;
use lumifit::recovery::{
    exposure_from_white, recover, white_gains, Quantity, Recovered, RecoveryOptions, SensingModel,
};

use super::{emit, resolve_illuminant};

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
    /// Camera sensitivities CSV `wavelength_nm,r,g,b` (default: calib/camera_default.csv, Nikon
    /// 5100 NPL).
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
}

/// Runs a `spectrum` subcommand.
pub fn run(cmd: SpectrumCommand) -> Result<()> {
    match cmd {
        SpectrumCommand::Recover(a) => recover_cmd(&a),
    }
}

/// The bands as read from `--bands`.
pub struct BandSource {
    /// Where the readings come from.
    pub geometry: LvfGeometry,
    /// `calibration` (parametric from lvf.json) or the band file's model.
    pub model: String,
    /// T_j on the recovery grid.
    pub transmission: Vec<Vec<f64>>,
}

/// Parses `LO:HI:STEP`.
pub fn parse_grid(flag: &str, s: &str) -> Result<Vec<f64>> {
    let parts: Vec<f64> = s
        .split(':')
        .map(|p| p.trim().parse::<f64>())
        .collect::<std::result::Result<_, _>>()
        .map_err(|_| anyhow!("{flag}: '{s}' is not LO:HI:STEP in nm, e.g. 400:700:5"))?;
    if parts.len() != 3 || !parts.iter().all(|v| v.is_finite()) {
        bail!("{flag}: '{s}' is not LO:HI:STEP in nm, e.g. 400:700:5");
    }
    let (lo, hi, step) = (parts[0], parts[1], parts[2]);
    if !(step > 0.0) || !(hi > lo) || (hi - lo) / step > 2000.0 {
        bail!("{flag}: '{s}': expected LO < HI and 0 < STEP with at most 2000 steps");
    }
    let n = ((hi - lo) / step + 1e-9).floor() as usize + 1;
    if n < 4 {
        bail!("{flag}: '{s}' gives {n} wavelengths; expected at least 4");
    }
    Ok((0..n).map(|i| lo + step * i as f64).collect())
}

/// Reads the camera CSV and samples it on `grid`; negative values are an error naming the line.
pub fn camera_on_grid(path: Option<&Path>, grid: &[f64]) -> Result<([Vec<f64>; 3], String)> {
    let (bytes, src) = match path {
        Some(p) => lumifit::io::read_input(p)?,
        None => (
            lumifit::lvf::synth::DEFAULT_CAMERA_CSV.as_bytes().to_vec(),
            "calib/camera_default.csv".to_string(),
        ),
    };
    let table = lumifit::table::parse_numeric_csv(&bytes, &src)?;
    if table.columns.len() != 4 {
        bail!(
            "{src}: {} columns; expected wavelength_nm,r,g,b",
            table.columns.len()
        );
    }
    for (c, col) in table.columns.iter().enumerate().skip(1) {
        if let Some(i) = col.iter().position(|v| *v < 0.0) {
            bail!(
                "{src}: line {}: {} sensitivity {} is negative; expected values ≥ 0",
                table.lines[i],
                table.header.get(c).map_or("channel", |s| s.as_str()),
                col[i]
            );
        }
    }
    let cam = lumifit::lvf::synth::camera_from_csv(&bytes, &src)?;
    let wl = cam.wavelengths();
    let (lo, hi) = (wl[0], wl[wl.len() - 1]);
    if grid[0] < lo - 1e-9 || grid[grid.len() - 1] > hi + 1e-9 {
        bail!(
            "{src}: covers {lo}–{hi} nm; the grid needs {}–{} nm (pass --grid inside the camera's range)",
            grid[0],
            grid[grid.len() - 1]
        );
    }
    let interp = |c: usize| -> Result<Vec<f64>> {
        let v = cam.channel(c);
        let sd = lumifit::spectrum::Spectrum::new("camera", wl.to_vec(), v.to_vec())?;
        Ok(sd.values_at(grid, lumifit::math::interpolation::Interpolator::Linear)?)
    };
    Ok(([interp(0)?, interp(1)?, interp(2)?], src))
}

fn read_bands(path: &Path, grid: Option<&[f64]>) -> Result<(BandSource, Vec<f64>)> {
    let (bytes, src) = lumifit::io::read_input(path)?;
    let v: serde_json::Value = serde_json::from_slice(&bytes)
        .map_err(|e| anyhow!("{src}: line {}: not JSON: {e}", e.line()))?;
    match v.get("schema").and_then(|s| s.as_str()) {
        Some("lumifit.lvf/1") => {
            let geometry = LvfGeometry::from_json(&bytes, &src)?;
            let grid = match grid {
                Some(g) => g.to_vec(),
                None => parse_grid("--grid", "400:700:5")?,
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
        Some("lumifit.lvf-bands/1") => band_file(&bytes, &src, grid),
        other => bail!(
            "{src}: field 'schema' is {}; expected 'lumifit.lvf-bands/1' (from 'lvf transmission') or 'lumifit.lvf/1' (from 'lvf calibrate')",
            other.map_or("missing".to_string(), |s| format!("'{s}'"))
        ),
    }
}

fn band_file(bytes: &[u8], src: &str, grid: Option<&[f64]>) -> Result<(BandSource, Vec<f64>)> {
    let set = lumifit::lvf::transmission::BandSet::from_json(bytes, src)?;
    let geometry = set.geometry(src)?;
    let (lo, hi) = (set.grid_nm[0], set.grid_nm[set.grid_nm.len() - 1]);
    let grid = match grid {
        Some(g) => g.to_vec(),
        None => {
            let all = parse_grid("--grid", "400:700:5")?;
            let g: Vec<f64> = all
                .into_iter()
                .filter(|l| *l >= lo - 1e-9 && *l <= hi + 1e-9)
                .collect();
            if g.len() < 4 {
                bail!("{src}: the band grid {lo}–{hi} nm hardly overlaps 400–700 nm; pass --grid");
            }
            g
        }
    };
    let transmission = (0..set.bands.len())
        .map(|j| set.transmission_on(j, &grid))
        .collect::<lumifit::Result<Vec<_>>>()?;
    Ok((
        BandSource {
            geometry,
            model: set.model.name().to_string(),
            transmission,
        },
        grid,
    ))
}

/// Per band r, g, b readings.
type Rgb = Vec<[f64; 3]>;

fn readings_csv(path: &Path, n_bands: usize) -> Result<(Rgb, Option<Rgb>)> {
    let (bytes, src) = lumifit::io::read_input(path)?;
    let t = lumifit::table::parse_numeric_csv(&bytes, &src)?;
    let ncol = t.columns.len();
    if ncol != 4 && ncol != 7 {
        bail!("{src}: {ncol} columns; expected band,r,g,b or band,r,g,b,std_r,std_g,std_b");
    }
    let mut rgb = vec![[f64::NAN; 3]; n_bands];
    let mut std = vec![[0.0; 3]; n_bands];
    for i in 0..t.n_rows() {
        let b = t.columns[0][i];
        if b.fract() != 0.0 || b < 1.0 || b > n_bands as f64 {
            bail!(
                "{src}: line {}: band {b}; expected an integer 1–{n_bands} (the band file has {n_bands} bands)",
                t.lines[i]
            );
        }
        let j = b as usize - 1;
        if !rgb[j][0].is_nan() {
            bail!("{src}: line {}: band {b} given twice", t.lines[i]);
        }
        for c in 0..3 {
            rgb[j][c] = t.columns[1 + c][i];
            if ncol == 7 {
                std[j][c] = t.columns[4 + c][i];
            }
        }
    }
    if t.n_rows() != n_bands {
        bail!(
            "{src}: {} bands read; the band file has {n_bands} — expected one row per band",
            t.n_rows()
        );
    }
    Ok((rgb, (ncol == 7).then_some(std)))
}

fn capture_readings(path: &Path, geometry: &LvfGeometry) -> Result<(Rgb, Rgb)> {
    let (frame, _) = lumifit::io::series::read_frame(path)?;
    let r = geometry
        .band_readings(&frame)
        .with_context(|| format!("{}: reading the LVF bands", path.display()))?;
    Ok((r.rgb, r.std))
}

fn white_reflectance(arg: &str, grid: &[f64]) -> Result<Vec<f64>> {
    if let Ok(v) = arg.trim().parse::<f64>() {
        if !(v > 0.0 && v <= 1.5) {
            bail!("--white-reflectance: {v}; expected a reflectance in (0, 1.5]");
        }
        return Ok(vec![v; grid.len()]);
    }
    let sd = lumifit::io::spectrum_csv::read_spectrum(Path::new(arg))?;
    let v = sd.values_at(grid, lumifit::math::interpolation::Interpolator::Linear)?;
    if v.iter().any(|x| !(*x > 0.0)) {
        bail!("--white-reflectance {arg}: values must be > 0 over the grid");
    }
    Ok(v)
}

fn recover_cmd(a: &RecoverArgs) -> Result<()> {
    let weight = match a.reg.trim().to_ascii_lowercase().as_str() {
        "gcv" => Weight::Gcv,
        s => {
            let v: f64 = s
                .parse()
                .map_err(|_| anyhow!("--reg: '{}' is neither 'gcv' nor a number", a.reg))?;
            if !(v >= 0.0) || !v.is_finite() {
                bail!("--reg: {v}; expected a finite relative weight ≥ 0");
            }
            Weight::Fixed(v)
        }
    };
    if !(a.exposure > 0.0) || !a.exposure.is_finite() {
        bail!("--exposure: {}; expected a finite value > 0", a.exposure);
    }
    let grid_arg = a
        .grid
        .as_deref()
        .map(|g| parse_grid("--grid", g))
        .transpose()?;
    let (mut bands, grid) = read_bands(&a.bands, grid_arg.as_deref())?;
    if let Some(r) = &a.roi {
        match lumifit::capture::Roi::parse_rect(r)? {
            lumifit::capture::Roi::Rect { x, y, w, h } => bands.geometry.roi = [x, y, w, h],
            _ => bail!("--roi: expected a rectangle x,y,w,h"),
        }
    }
    let (camera, camera_src) = camera_on_grid(a.camera.as_deref(), &grid)?;
    let model = SensingModel {
        grid_nm: grid.clone(),
        transmission: bands.transmission.clone(),
        camera,
    };
    let nb = model.transmission.len();
    let (rgb, std) = match (&a.image, &a.readings) {
        (Some(img), _) => {
            let (rgb, std) = capture_readings(img, &bands.geometry)?;
            (rgb, Some(std))
        }
        (None, Some(csv)) => readings_csv(csv, nb)?,
        (None, None) => bail!("give a photo or --readings"),
    };
    if rgb.len() != nb {
        bail!(
            "the capture gives {} bands but {} holds {nb} band transmissions",
            rgb.len(),
            a.bands.display()
        );
    }
    let opts = RecoveryOptions {
        weight,
        nonnegative: !a.no_nonneg,
        ..Default::default()
    };
    let started = std::time::Instant::now();
    let mut mode = "light".to_string();
    let mut exposure = None;
    let mut gains: Option<Vec<[f64; 3]>> = None;
    let quantity = match (&a.illuminant, &a.white) {
        (None, None) => Quantity::Light,
        (ill, white) => {
            let rho = white_reflectance(&a.white_reflectance, &grid)?;
            let white_rgb = match white {
                Some(w) => Some(capture_readings(w, &bands.geometry)?),
                None => None,
            };
            let weight = match (ill, white_rgb) {
                (Some(name), w) => {
                    let ill = resolve_illuminant(name)?;
                    let s = ill.spectrum().values_at(&grid, ill.interpolator())?;
                    mode = format!("reflectance under {}", ill.name());
                    match w {
                        Some((wr, _)) => {
                            exposure = Some(exposure_from_white(&model, &wr, &s, &rho)?);
                            gains = Some(white_gains(&model, &wr, &s, &rho)?);
                            s
                        }
                        None => {
                            exposure = Some(a.exposure);
                            s.iter().map(|v| v * a.exposure).collect()
                        }
                    }
                }
                (None, Some((wr, ws))) => {
                    let lw = recover(&model, &wr, Some(&ws), &Quantity::Light, &opts)
                        .context("recovering the white reference")?;
                    mode = "reflectance relative to the recovered white reference".into();
                    lw.value
                        .iter()
                        .zip(&rho)
                        .map(|(l, r)| (l / r).max(0.0))
                        .collect()
                }
                (None, None) => unreachable!("matched above"),
            };
            Quantity::Reflectance {
                weight,
                gains: gains.clone(),
            }
        }
    };
    let solve_started = std::time::Instant::now();
    let rec = recover(&model, &rgb, std.as_deref(), &quantity, &opts)?;
    let solve_s = solve_started.elapsed().as_secs_f64();
    let elapsed = started.elapsed().as_secs_f64();
    let dump = match &a.dump_system {
        Some(_) => Some(system_json(
            &model,
            &rgb,
            std.as_deref(),
            &quantity,
            &opts,
            &rec,
            solve_s,
        )?),
        None => None,
    };

    // A reference to compare with; a light's absolute level is the capture's (exposure), so in
    // light mode the reference is scaled to the recovery by least squares first.
    let mut compare = None;
    if let Some(p) = &a.compare {
        let sd = lumifit::io::spectrum_csv::read_spectrum(p)?;
        let v = sd.values_at(&grid, lumifit::math::interpolation::Interpolator::Linear)?;
        let scale = if matches!(quantity, Quantity::Light) {
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
        compare = Some((p.display().to_string(), sd.scaled(scale), rms, peak, scale));
    }

    let mut csv = String::from("wavelength_nm,value,std\n");
    for ((l, v), sd) in grid.iter().zip(&rec.value).zip(&rec.std) {
        csv.push_str(&format!("{l},{v},{sd}\n"));
    }
    let summary = summary_json(
        a,
        &bands,
        &camera_src,
        &mode,
        exposure,
        &rec,
        elapsed,
        &compare,
    );
    let text = serde_json::to_string_pretty(&summary)?;
    // Render everything before writing anything, so a failure leaves no partial output.
    let plot_png = match &a.plot {
        Some(_) => {
            let title = format!("Recovered {} ({} bands, {})", mode, nb, bands.model);
            let y_label = if matches!(quantity, Quantity::Light) {
                "relative spectral radiance"
            } else {
                "reflectance factor"
            };
            let refs: Vec<(String, Vec<f64>, Vec<f64>)> = compare
                .iter()
                .map(|(n, sd, _, _, k)| {
                    let label = if (*k - 1.0).abs() > 1e-12 {
                        format!("{n} (× {k:.4e}, least-squares scale)")
                    } else {
                        n.clone()
                    };
                    (label, sd.wavelengths().to_vec(), sd.values().to_vec())
                })
                .collect();
            let r: Vec<lumifit::plot::recovery::Reference<'_>> = refs
                .iter()
                .map(|(n, x, y)| (n.as_str(), x.as_slice(), y.as_slice()))
                .collect();
            let tmp = tempfile_path(a.plot.as_deref().unwrap_or(Path::new("plot.png")));
            lumifit::plot::recovery::recovery_chart(&tmp, &title, y_label, &rec, &r)?;
            let bytes = std::fs::read(&tmp).with_context(|| tmp.display().to_string())?;
            let _ = std::fs::remove_file(&tmp);
            Some(bytes)
        }
        None => None,
    };
    lumifit::io::atomic_write(&a.out, csv.as_bytes())?;
    if let (Some(p), Some(d)) = (&a.dump_system, &dump) {
        lumifit::io::atomic_write(p, d.as_bytes())?;
    }
    if let Some(p) = &a.summary {
        lumifit::io::atomic_write(p, text.as_bytes())?;
    }
    if let (Some(p), Some(png)) = (&a.plot, plot_png) {
        lumifit::io::atomic_write(p, &png)?;
    }
    emit(&text)
}

/// The weighted system that [`recover`] solves ([`lumifit::recovery::weighted_system`]; μ =
/// λ·tr(AᵀA)/tr(DᵀD)), checked against the recovery's residuals, as JSON for `--dump-system`.
fn system_json(
    model: &SensingModel,
    rgb: &[[f64; 3]],
    std: Option<&[[f64; 3]]>,
    quantity: &Quantity,
    opts: &RecoveryOptions,
    rec: &Recovered,
    solve_s: f64,
) -> Result<String> {
    let nb = model.transmission.len();
    let lumifit::recovery::WeightedSystem {
        a,
        b,
        sigma: sig,
        m,
        n,
    } = lumifit::recovery::weighted_system(model, rgb, std, quantity)?;
    // The rebuilt system must be the one solved: its residuals at x are the recovery's.
    let mut worst = 0.0f64;
    for j in 0..nb {
        for c in 0..3 {
            let r = 3 * j + c;
            let ax: f64 = (0..n).map(|i| a[i * m + r] * rec.value[i]).sum();
            let d = ((b[r] - ax) - rec.residuals[j][c] / sig[r]).abs();
            worst = worst.max(d / b[r].abs().max(1.0));
        }
    }
    if worst > 1e-6 {
        bail!("--dump-system: the rebuilt system does not reproduce the recovery's residuals (relative difference {worst:.2e}); this is a bug");
    }
    let d = lumifit::fit::regularized::penalty_operator(n, opts.smoothness);
    let order = n - d.nrows();
    let gram_trace: f64 = a.iter().map(|v| v * v).sum();
    let dtd_trace: f64 = d.iter().map(|v| v * v).sum();
    let mu = rec.lambda * gram_trace / dtd_trace;
    // The constrained step alone, timed: Lawson–Hanson NNLS on [A; √μ D] x ≈ [b; 0] — the
    // problem scipy.optimize.nnls solves from the dump (best of 5 runs).
    let stacked = if opts.nonnegative {
        let rows = m + d.nrows();
        let sq = mu.sqrt();
        let mut st = Vec::with_capacity(rows * n);
        for col in 0..n {
            st.extend_from_slice(&a[col * m..(col + 1) * m]);
            st.extend(d.column(col).iter().map(|v| sq * v));
        }
        let mut rhs = b.clone();
        rhs.resize(rows, 0.0);
        let mut best = f64::INFINITY;
        let mut x = Vec::new();
        for _ in 0..5 {
            let t = std::time::Instant::now();
            let sol = lumifit::fit::nnls::nnls(&st, rows, n, &rhs, &vec![false; n]);
            best = best.min(t.elapsed().as_secs_f64());
            x = sol.x;
        }
        Some((best, x))
    } else {
        None
    };
    let v = serde_json::json!({
        "schema": "lumifit.recovery-system/1",
        "problem": "min ‖A x − b‖² + μ ‖D x‖² (x ≥ 0 when nonnegative); D the difference operator of the given order on the grid",
        "m": m,
        "n": n,
        "a_column_major": a,
        "b": b,
        "grid_nm": model.grid_nm,
        "lambda": rec.lambda,
        "lambda_from_gcv": rec.lambda_from_gcv,
        "mu": mu,
        "mu_rule": "μ = λ · tr(AᵀA) / tr(DᵀD)",
        "difference_order": order,
        "nonnegative": opts.nonnegative,
        "x": rec.value,
        "solve_seconds": solve_s,
        "solve_includes": "GCV search (when chosen), the solve, the uncertainty and the resolution matrix",
        "nnls_stacked_seconds": stacked.as_ref().map(|s| s.0),
        "nnls_stacked_x": stacked.as_ref().map(|s| s.1.clone()),
    });
    Ok(serde_json::to_string(&v)?)
}

/// A scratch path next to `target` for rendering before the real write.
fn tempfile_path(target: &Path) -> PathBuf {
    let name = target
        .file_name()
        .map(|n| n.to_string_lossy().to_string())
        .unwrap_or_else(|| "plot.png".into());
    target.with_file_name(format!(".{name}.{}.tmp.png", std::process::id()))
}

#[allow(clippy::too_many_arguments)]
fn summary_json(
    a: &RecoverArgs,
    bands: &BandSource,
    camera_src: &str,
    mode: &str,
    exposure: Option<f64>,
    rec: &Recovered,
    elapsed: f64,
    compare: &Option<(String, lumifit::spectrum::Spectrum, f64, f64, f64)>,
) -> serde_json::Value {
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
        "input": a.image.as_ref().or(a.readings.as_ref()).map(|p| p.display().to_string()),
        "bands": a.bands.display().to_string(),
        "band_model": bands.model,
        "camera": camera_src,
        "mode": mode,
        "exposure": exposure,
        "out": a.out.display().to_string(),
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
        "compare": compare.as_ref().map(|(n, _, r, peak, k)| serde_json::json!({
            "reference": n, "scale": k, "rms": r, "rms_relative_to_peak": r / peak,
        })),
        "seconds": elapsed,
    })
}
