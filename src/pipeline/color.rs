//! Colour (`lumifit color xyz|table|delta-e|convert`): what each command does between its flags
//! and its printed line — read the spectra and the illuminant, compute tristimulus values, colour
//! differences or conversions, check the results are finite, and return what to print (the
//! table is staged in the caller's [`Outputs`]; the caller commits).

use std::path::{Path, PathBuf};

use serde::Serialize;
use serde_json::{json, Value};

use crate::calib;
use crate::colorimetry::cat::Cat;
use crate::colorimetry::delta_e::{delta_e, DeltaEMethod};
use crate::colorimetry::lab::{lab_to_lch, lab_to_xyz, lch_to_lab, xyz_to_lab};
use crate::colorimetry::rgb::{rgb_to_xyz, xyz_to_rgb, RgbSpace};
use crate::colorimetry::summary::{sd_colour, table_csv, xyz_table, SdColour};
use crate::colorimetry::xyy::{xyy_to_xyz, xyz_to_xyy};
use crate::colorimetry::{Observer, StandardObserver, XyzMethod};
use crate::error::{ensure_finite, Error, Result};
use crate::io::flags::parse_triplet;
use crate::io::sources::{file_of, resolve_illuminant};
use crate::io::{spectrum_csv, Outputs};

/// How tristimulus values are computed: illuminant, observer and method as named on the
/// command line.
#[derive(Debug, Clone)]
pub struct XyzSettings {
    /// CIE name, `daylight:<K>`, `blackbody:<K>` or a CSV.
    pub illuminant: String,
    /// Observer name.
    pub observer: String,
    /// `astm-e308` or `integration`.
    pub method: String,
}

/// The summary of `color xyz`.
#[derive(Debug, Serialize)]
pub struct XyzReport {
    /// XYZ, xy, Lab … of the spectrum.
    #[serde(flatten)]
    pub colour: SdColour,
    /// Observer.
    pub observer: String,
    /// Illuminant.
    pub illuminant: String,
    /// Method.
    pub method: String,
    /// Normalisation constant, if given.
    pub k: Option<f64>,
}

/// `color xyz`: the colour of one spectrum (`k`: the normalisation constant, default Y = 100
/// for the perfect reflector).
pub fn xyz(spectrum: &Path, s: &XyzSettings, k: Option<f64>) -> Result<XyzReport> {
    let sd = spectrum_csv::read_spectrum(spectrum)?;
    let illuminant = resolve_illuminant("--illuminant", &s.illuminant)?;
    let observer = Observer::standard(StandardObserver::from_name(&s.observer)?)?;
    let method = XyzMethod::from_name(&s.method)?;
    if let Some(k) = k {
        ensure_finite("--k", &k.to_string(), &[k])?;
    }
    let colour = sd_colour(
        &sd,
        observer,
        &illuminant,
        method,
        k,
        &spectrum.display().to_string(),
    )
    .map_err(|e| e.context(format!("computing XYZ of {}", spectrum.display())))?;
    Ok(XyzReport {
        colour,
        observer: observer.name().to_string(),
        illuminant: illuminant.name().to_string(),
        method: method.cli_name().to_string(),
        k,
    })
}

/// `color table`: XYZ, xy and Lab of every column of a spectral table.
#[derive(Debug, Clone)]
pub struct TableJob {
    /// The spectral table CSV.
    pub spectra: PathBuf,
    /// Illuminant, observer, method.
    pub settings: XyzSettings,
    /// Output CSV.
    pub out: PathBuf,
}

/// Registers the table (and an illuminant file), declares the CSV, computes, stages it and
/// returns the summary to print.
pub fn run_table(job: &TableJob, out: &mut Outputs) -> Result<Value> {
    let s = &job.settings;
    out.input(&job.spectra).inputs(file_of(&s.illuminant));
    out.declare("--out", &job.out)?;
    let ms = spectrum_csv::read_multi_spectrum(&job.spectra)?;
    let illuminant = resolve_illuminant("--illuminant", &s.illuminant)?;
    let observer = Observer::standard(StandardObserver::from_name(&s.observer)?)?;
    let method = XyzMethod::from_name(&s.method)?;
    let started = std::time::Instant::now();
    let rows = xyz_table(
        &ms,
        observer,
        &illuminant,
        method,
        &job.spectra.display().to_string(),
    )
    .map_err(|e| {
        e.context(format!(
            "computing the colour table of {}",
            job.spectra.display()
        ))
    })?;
    let seconds = started.elapsed().as_secs_f64();
    out.stage(&job.out, table_csv(&rows).as_bytes())?;
    Ok(json!({
        "spectra": ms.n_channels(),
        "samples_per_spectrum": ms.len(),
        "observer": observer.name(),
        "illuminant": illuminant.name(),
        "method": method.cli_name(),
        "compute_seconds": seconds,
        "spectra_per_second": ms.n_channels() as f64 / seconds.max(1e-12),
        "out": job.out.display().to_string(),
    }))
}

/// `color delta-e`: ΔE between `--lab1` and `--lab2` (as typed) by `method`.
pub fn delta_e_of(lab1: &str, lab2: &str, method: &str) -> Result<Value> {
    let l1 = parse_triplet("--lab1", lab1)?;
    let l2 = parse_triplet("--lab2", lab2)?;
    let d = delta_e(l1, l2, DeltaEMethod::from_name(method)?);
    ensure_finite("delta_e", &format!("--lab1 {lab1} --lab2 {lab2}"), &[d])?;
    Ok(json!({ "delta_e": d, "method": method }))
}

/// White chromaticity (CIE 1931 2°, colour's `CCS_ILLUMINANTS`) of a named illuminant.
pub fn white_xy(name: &str) -> Result<[f64; 2]> {
    let table = calib::colourspaces()
        .white_chromaticities_xy
        .get("cie1931_2")
        .ok_or_else(|| Error::message("calib/colourspaces.json lacks the CIE 1931 white points"))?;
    table
        .iter()
        .find(|(k, _)| k.eq_ignore_ascii_case(name))
        .map(|(_, v)| *v)
        .ok_or_else(|| {
            Error::flag(
                "--white",
                format!(
                    "unknown illuminant '{name}'; expected one of: {}",
                    table.keys().cloned().collect::<Vec<_>>().join(", ")
                ),
            )
        })
}

/// `color convert`: one colour from one representation to another, as typed.
#[derive(Debug, Clone)]
pub struct ConvertJob {
    /// `xyz`, `xyy`, `lab`, `lch`, `srgb` or `linear-srgb`.
    pub from: String,
    /// The same names.
    pub to: String,
    /// `--value a,b,c`.
    pub value: String,
    /// `100` (Y of white 100) or `1`.
    pub scale: String,
    /// White illuminant name.
    pub white: String,
}

/// Converts and returns the summary to print; warnings about the XYZ scale go to `warn`.
pub fn convert(job: &ConvertJob, warn: &mut dyn FnMut(String)) -> Result<Value> {
    let v = parse_triplet("--value", &job.value)?;
    let w = white_xy(&job.white)?;
    let srgb = RgbSpace::from_name("srgb")?;
    let scale: f64 = if job.scale == "1" { 1.0 } else { 100.0 };
    if matches!(job.from.as_str(), "xyz" | "xyy") {
        let y = if job.from == "xyz" { v[1] } else { v[2] };
        for m in crate::colorimetry::xyz_scale_warnings(&job.from, y, scale)? {
            warn(format!("warning: --value {}: {m}", job.value));
        }
    }
    let unknown =
        |flag: &str, other: &str| Error::flag(flag, format!("unknown representation '{other}'"));
    let xyz = match job.from.as_str() {
        "xyz" => v.map(|c| c / scale),
        "xyy" => xyy_to_xyz([v[0], v[1], v[2] / scale]),
        "lab" => lab_to_xyz(v, w)?,
        "lch" => lab_to_xyz(lch_to_lab(v), w)?,
        "srgb" => rgb_to_xyz(v, w, &srgb, Some(Cat::Cat02), true)?,
        "linear-srgb" => rgb_to_xyz(v, w, &srgb, Some(Cat::Cat02), false)?,
        other => return Err(unknown("--from", other)),
    };
    let out = match job.to.as_str() {
        "xyz" => xyz.map(|c| c * scale),
        "xyy" => {
            let [x, y, big_y] = xyz_to_xyy(xyz, w);
            [x, y, big_y * scale]
        }
        "lab" => xyz_to_lab(xyz, w)?,
        "lch" => lab_to_lch(xyz_to_lab(xyz, w)?),
        "srgb" => xyz_to_rgb(xyz, w, &srgb, Some(Cat::Cat02), true)?,
        "linear-srgb" => xyz_to_rgb(xyz, w, &srgb, Some(Cat::Cat02), false)?,
        other => return Err(unknown("--to", other)),
    };
    ensure_finite(
        &format!("--to {}", job.to),
        &format!("--value {}", job.value),
        &out,
    )?;
    Ok(
        json!({ "from": job.from, "to": job.to, "input": v, "value": out, "xyz_scale": scale, "white": job.white, "white_xy": w }),
    )
}
