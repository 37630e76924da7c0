//! `lumifit color …`: spectra to tristimulus values, colour differences, conversions.

use anyhow::{Context, Result};
use lumifit::calib;
use lumifit::colorimetry::cat::Cat;
use lumifit::colorimetry::delta_e::{delta_e as delta_e_fn, DeltaEMethod};
use lumifit::colorimetry::lab::{lab_to_lch, lab_to_xyz, lch_to_lab, xyz_to_lab};
use lumifit::colorimetry::rgb::{rgb_to_xyz, xyz_to_rgb, RgbSpace};
use lumifit::colorimetry::summary::{sd_colour, table_csv, xyz_table, SdColour};
use lumifit::colorimetry::xyy::{xyy_to_xyz, xyz_to_xyy};
use lumifit::colorimetry::{Observer, StandardObserver, XyzMethod};
use lumifit::error::ensure_finite;
use lumifit::io::sources::file_of;
use lumifit::io::{spectrum_csv, Outputs};
use serde::Serialize;

use super::{emit, parse_triplet, resolve_illuminant};
use crate::args::{ConvertArgs, DeltaEArgs, TableArgs, XyzArgs};

#[derive(Serialize)]
struct XyzReport {
    #[serde(flatten)]
    colour: SdColour,
    observer: String,
    illuminant: String,
    method: String,
    k: Option<f64>,
}

/// `lumifit color xyz`.
pub fn xyz(a: &XyzArgs) -> Result<()> {
    let sd = spectrum_csv::read_spectrum(&a.sd)?;
    let illuminant = resolve_illuminant(&a.illuminant)?;
    let observer = Observer::standard(StandardObserver::from_name(&a.observer)?)?;
    let method = XyzMethod::from_name(&a.method)?;
    if let Some(k) = a.k {
        ensure_finite("--k", &k.to_string(), &[k])?;
    }
    let colour = sd_colour(
        &sd,
        observer,
        &illuminant,
        method,
        a.k,
        &a.sd.display().to_string(),
    )
    .with_context(|| format!("computing XYZ of {}", a.sd.display()))?;
    let report = XyzReport {
        colour,
        observer: observer.name().to_string(),
        illuminant: illuminant.name().to_string(),
        method: method.cli_name().to_string(),
        k: a.k,
    };
    emit(&serde_json::to_string_pretty(&report)?)
}

/// `lumifit color table`: XYZ, xy and Lab of every column of a spectral table.
pub fn table(a: &TableArgs) -> Result<()> {
    let mut out = Outputs::new();
    out.input(&a.sds).inputs(file_of(&a.illuminant));
    out.declare("--out", &a.out)?;
    let ms = spectrum_csv::read_multi_spectrum(&a.sds)?;
    let illuminant = resolve_illuminant(&a.illuminant)?;
    let observer = Observer::standard(StandardObserver::from_name(&a.observer)?)?;
    let method = XyzMethod::from_name(&a.method)?;
    let started = std::time::Instant::now();
    let rows = xyz_table(
        &ms,
        observer,
        &illuminant,
        method,
        &a.sds.display().to_string(),
    )
    .with_context(|| format!("computing the colour table of {}", a.sds.display()))?;
    let seconds = started.elapsed().as_secs_f64();
    out.stage(&a.out, table_csv(&rows).as_bytes())?;
    out.commit()?;
    emit(
        &serde_json::json!({
            "spectra": ms.n_channels(),
            "samples_per_spectrum": ms.len(),
            "observer": observer.name(),
            "illuminant": illuminant.name(),
            "method": method.cli_name(),
            "compute_seconds": seconds,
            "spectra_per_second": ms.n_channels() as f64 / seconds.max(1e-12),
            "out": a.out.display().to_string(),
        })
        .to_string(),
    )
}

/// `lumifit color delta-e`.
pub fn delta_e(a: &DeltaEArgs) -> Result<()> {
    let l1 = parse_triplet("--lab1", &a.lab1)?;
    let l2 = parse_triplet("--lab2", &a.lab2)?;
    let method = DeltaEMethod::from_name(&a.method)?;
    let d = delta_e_fn(l1, l2, method);
    ensure_finite(
        "delta_e",
        &format!("--lab1 {} --lab2 {}", a.lab1, a.lab2),
        &[d],
    )?;
    emit(&serde_json::json!({ "delta_e": d, "method": a.method }).to_string())
}

/// White chromaticity (CIE 1931 2°, colour's `CCS_ILLUMINANTS`) of a named illuminant.
fn white_xy(name: &str) -> Result<[f64; 2]> {
    let table = calib::colourspaces()
        .white_chromaticities_xy
        .get("cie1931_2")
        .context("calib/colourspaces.json lacks the CIE 1931 white points")?;
    table
        .iter()
        .find(|(k, _)| k.eq_ignore_ascii_case(name))
        .map(|(_, v)| *v)
        .ok_or_else(|| {
            anyhow::anyhow!(
                "--white: unknown illuminant '{name}'; expected one of: {}",
                table.keys().cloned().collect::<Vec<_>>().join(", ")
            )
        })
}

/// `lumifit color convert`.
pub fn convert(a: &ConvertArgs) -> Result<()> {
    let v = parse_triplet("--value", &a.value)?;
    let w = white_xy(&a.white)?;
    let srgb = RgbSpace::from_name("srgb")?;
    let scale: f64 = if a.scale == "1" { 1.0 } else { 100.0 };
    if matches!(a.from.as_str(), "xyz" | "xyy") {
        let y = if a.from == "xyz" { v[1] } else { v[2] };
        for w in lumifit::colorimetry::xyz_scale_warnings(&a.from, y, scale)? {
            eprintln!("warning: --value {}: {w}", a.value);
        }
    }
    let xyz = match a.from.as_str() {
        "xyz" => v.map(|c| c / scale),
        "xyy" => xyy_to_xyz([v[0], v[1], v[2] / scale]),
        "lab" => lab_to_xyz(v, w)?,
        "lch" => lab_to_xyz(lch_to_lab(v), w)?,
        "srgb" => rgb_to_xyz(v, w, &srgb, Some(Cat::Cat02), true)?,
        "linear-srgb" => rgb_to_xyz(v, w, &srgb, Some(Cat::Cat02), false)?,
        other => anyhow::bail!("--from: unknown representation '{other}'"),
    };
    let out = match a.to.as_str() {
        "xyz" => xyz.map(|c| c * scale),
        "xyy" => {
            let [x, y, big_y] = xyz_to_xyy(xyz, w);
            [x, y, big_y * scale]
        }
        "lab" => xyz_to_lab(xyz, w)?,
        "lch" => lab_to_lch(xyz_to_lab(xyz, w)?),
        "srgb" => xyz_to_rgb(xyz, w, &srgb, Some(Cat::Cat02), true)?,
        "linear-srgb" => xyz_to_rgb(xyz, w, &srgb, Some(Cat::Cat02), false)?,
        other => anyhow::bail!("--to: unknown representation '{other}'"),
    };
    ensure_finite(
        &format!("--to {}", a.to),
        &format!("--value {}", a.value),
        &out,
    )?;
    emit(
        &serde_json::json!({ "from": a.from, "to": a.to, "input": v, "value": out, "xyz_scale": scale, "white": a.white, "white_xy": w })
            .to_string(),
    )
}
