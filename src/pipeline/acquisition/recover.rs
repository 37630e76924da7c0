//! `lumifit spectrum recover`: a band file (`lvf_bands.json`, or the `lvf.json` alone with
//! parametric Gaussian bands) and the camera become a [`SensingModel`]; a photo or a readings
//! CSV gives the band readings; the light or a reflectance factor is recovered by [`recover`].

use std::path::{Path, PathBuf};

use super::{json_value, range, read_json_text};
use crate::error::{Error, Result};
use crate::io::camera::read_camera;
use crate::io::series::read_frame;
use crate::io::sources::{file_of, resolve_illuminant, white_reflectance};
use crate::lvf::transmission::BandSet;
use crate::lvf::LvfGeometry;
use crate::math::interpolation::Interpolator;
use crate::recovery::dump::{system_dump, SystemDump};
use crate::recovery::{
    exposure_from_white, recover, white_gains, Quantity, Recovered, RecoveryOptions, SensingModel,
};
use crate::spectrum::Spectrum;

/// Most wavelengths of a recovery grid (`spectrum recover --grid`).
pub const MAX_RECOVERY_GRID_STEPS: usize = 2000;

/// Per band r, g, b.
pub type Rgb = Vec<[f64; 3]>;

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
