//! `lumifit color …`: spectra to tristimulus values, colour differences, conversions.

use anyhow::{Context, Result};
use lumifit::calib;
use lumifit::colorimetry::cat::Cat;
use lumifit::colorimetry::delta_e::{delta_e as delta_e_fn, DeltaEMethod};
use lumifit::colorimetry::lab::{lab_to_lch, lab_to_xyz, lch_to_lab, xyz_to_lab};
use lumifit::colorimetry::rgb::{rgb_to_xyz, xyz_to_rgb, RgbSpace};
use lumifit::colorimetry::tristimulus::D65_XY;
use lumifit::colorimetry::xyy::{xyy_to_xyz, xyz_to_xy, xyz_to_xyy};
use lumifit::colorimetry::{
    illuminant_white, sd_to_xyz, Observer, StandardObserver, XyzMethod, XyzOperator,
};
use lumifit::io::spectrum_csv;
use serde::Serialize;

use super::{emit, parse_triplet, resolve_illuminant};
use crate::args::{ConvertArgs, DeltaEArgs, TableArgs, XyzArgs};

#[derive(Serialize)]
struct XyzReport {
    #[serde(rename = "XYZ")]
    xyz: [f64; 3],
    #[serde(rename = "xyY")]
    xyy: [f64; 3],
    #[serde(rename = "Lab")]
    lab: [f64; 3],
    #[serde(rename = "sRGB")]
    srgb: [f64; 3],
    observer: String,
    illuminant: String,
    method: String,
    #[serde(rename = "white_XYZ")]
    white_xyz: [f64; 3],
    k: Option<f64>,
}

/// `lumifit color xyz`.
pub fn xyz(a: &XyzArgs) -> Result<()> {
    let sd = spectrum_csv::read_spectrum(&a.sd)?;
    let illuminant = resolve_illuminant(&a.illuminant)?;
    let observer = Observer::standard(StandardObserver::from_name(&a.observer)?)?;
    let method = XyzMethod::from_name(&a.method)?;
    let t = sd_to_xyz(&sd, observer, &illuminant, method, a.k)
        .with_context(|| format!("computing XYZ of {}", a.sd.display()))?;
    let white = illuminant_white(observer, &illuminant, method, sd.wavelengths(), a.k)?;
    let white_xy = xyz_to_xy(white.xyz, D65_XY);
    let xyy = xyz_to_xyy(t.xyz, white_xy);
    // Lab and sRGB of the colour relative to the illuminant's white on the same grid.
    let lab = t.lab_relative_to(&white)?;
    let srgb_space = RgbSpace::from_name("srgb")?;
    let xyz01 = t.xyz.map(|v| v / white.xyz[1]);
    let srgb = xyz_to_rgb(xyz01, white_xy, &srgb_space, Some(Cat::Cat02), true)?;
    let report = XyzReport {
        xyz: t.xyz,
        xyy,
        lab,
        srgb,
        observer: observer.name().to_string(),
        illuminant: illuminant.name().to_string(),
        method: method.cli_name().to_string(),
        white_xyz: white.xyz,
        k: a.k,
    };
    emit(&serde_json::to_string_pretty(&report)?)
}

/// `lumifit color table`: XYZ, xy and Lab of every column of a spectral table.
pub fn table(a: &TableArgs) -> Result<()> {
    let ms = spectrum_csv::read_multi_spectrum(&a.sds)?;
    let illuminant = resolve_illuminant(&a.illuminant)?;
    let observer = Observer::standard(StandardObserver::from_name(&a.observer)?)?;
    let method = XyzMethod::from_name(&a.method)?;
    let white = illuminant_white(observer, &illuminant, method, ms.wavelengths(), None)?;
    let white_xy = xyz_to_xy(white.xyz, D65_XY);
    let started = std::time::Instant::now();
    // One linear operator for the shared grid, then 3·n multiply-adds per spectrum.
    let op = XyzOperator::new(ms.wavelengths(), observer, &illuminant, method, None)
        .with_context(|| format!("preparing XYZ weights for {}", a.sds.display()))?;
    let mut rows = Vec::with_capacity(ms.n_channels());
    for c in 0..ms.n_channels() {
        let xyz = op.apply(ms.channel(c))?;
        let xy = xyz_to_xy(xyz, D65_XY);
        let lab = xyz_to_lab(xyz.map(|v| v / white.xyz[1]), white_xy)?;
        rows.push((xyz, xy, lab));
    }
    let seconds = started.elapsed().as_secs_f64();
    let mut out = String::from("name,X,Y,Z,x,y,L,a,b\n");
    for (label, (xyz, xy, lab)) in ms.labels().iter().zip(&rows) {
        let name = if label.contains(',') || label.contains('"') {
            format!("\"{}\"", label.replace('"', "\"\""))
        } else {
            label.clone()
        };
        out.push_str(&format!(
            "{name},{},{},{},{},{},{},{},{}\n",
            xyz[0], xyz[1], xyz[2], xy[0], xy[1], lab[0], lab[1], lab[2]
        ));
    }
    lumifit::io::atomic_write(&a.out, out.as_bytes())?;
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
    let xyz = match a.from.as_str() {
        "xyz" => v,
        "xyy" => xyy_to_xyz(v),
        "lab" => lab_to_xyz(v, w)?,
        "lch" => lab_to_xyz(lch_to_lab(v), w)?,
        "srgb" => rgb_to_xyz(v, w, &srgb, Some(Cat::Cat02), true)?,
        "linear-srgb" => rgb_to_xyz(v, w, &srgb, Some(Cat::Cat02), false)?,
        other => anyhow::bail!("--from: unknown representation '{other}'"),
    };
    let out = match a.to.as_str() {
        "xyz" => xyz,
        "xyy" => xyz_to_xyy(xyz, w),
        "lab" => xyz_to_lab(xyz, w)?,
        "lch" => lab_to_lch(xyz_to_lab(xyz, w)?),
        "srgb" => xyz_to_rgb(xyz, w, &srgb, Some(Cat::Cat02), true)?,
        "linear-srgb" => xyz_to_rgb(xyz, w, &srgb, Some(Cat::Cat02), false)?,
        other => anyhow::bail!("--to: unknown representation '{other}'"),
    };
    emit(
        &serde_json::json!({ "from": a.from, "to": a.to, "input": v, "value": out, "white": a.white, "white_xy": w })
            .to_string(),
    )
}
