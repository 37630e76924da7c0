//! The colour of a spectrum in the usual representations at once (`lumifit color xyz`), and the
//! XYZ/xy/Lab table of many spectra on one grid (`lumifit color table`).
//!
//! XYZ from spectra is on the 0–100 scale (Y = 100 for the perfect reflector, as
//! `colour.sd_to_XYZ`); xyY, Lab and sRGB are relative to the illuminant's white computed with the
//! same observer, method and grid. sRGB is reached with CAT02 from that white to sRGB's D65 and
//! is gamma-encoded. Every result is checked to be finite ([`crate::error::ensure_finite`]): a
//! spectrum whose values overflow f64 is an error, never a `null` in the output.

use serde::Serialize;

use super::cat::Cat;
use super::lab::xyz_to_lab;
use super::rgb::{xyz_to_rgb, RgbSpace};
use super::tristimulus::D65_XY;
use super::xyy::{xyz_to_xy, xyz_to_xyy};
use super::{illuminant_white, sd_to_xyz, Illuminant, Observer, XyzMethod, XyzOperator};
use crate::error::{ensure_finite, Result};
use crate::spectrum::{MultiSpectrum, Spectrum};

/// The colour of one spectrum.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SdColour {
    /// Tristimulus values (0–100 scale).
    #[serde(rename = "XYZ")]
    pub xyz: [f64; 3],
    /// Chromaticity and luminance.
    #[serde(rename = "xyY")]
    pub xyy: [f64; 3],
    /// CIE L*a*b* relative to the illuminant's white.
    #[serde(rename = "Lab")]
    pub lab: [f64; 3],
    /// Gamma-encoded sRGB (CAT02 from the illuminant's white to D65).
    #[serde(rename = "sRGB")]
    pub srgb: [f64; 3],
    /// The illuminant's white on the same grid.
    #[serde(rename = "white_XYZ")]
    pub white_xyz: [f64; 3],
}

/// XYZ, xyY, Lab and sRGB of `sd` under `illuminant` (see the module docs). `input` names the
/// spectrum in errors.
///
/// # Errors
/// The errors of [`sd_to_xyz`] and the colour-space conversions; [`crate::Error::NonFinite`]
/// naming `input` when a result overflows.
pub fn sd_colour(
    sd: &Spectrum,
    observer: &Observer,
    illuminant: &Illuminant,
    method: XyzMethod,
    k: Option<f64>,
    input: &str,
) -> Result<SdColour> {
    let t = sd_to_xyz(sd, observer, illuminant, method, k)?;
    ensure_finite("XYZ", input, &t.xyz)?;
    let white = illuminant_white(observer, illuminant, method, sd.wavelengths(), k)?;
    let white_xy = xyz_to_xy(white.xyz, D65_XY);
    let xyy = xyz_to_xyy(t.xyz, white_xy);
    let lab = t.lab_relative_to(&white)?;
    let srgb_space = RgbSpace::from_name("srgb")?;
    let xyz01 = t.xyz.map(|v| v / white.xyz[1]);
    let srgb = xyz_to_rgb(xyz01, white_xy, &srgb_space, Some(Cat::Cat02), true)?;
    let c = SdColour {
        xyz: t.xyz,
        xyy,
        lab,
        srgb,
        white_xyz: white.xyz,
    };
    for (what, v) in [("xyY", &c.xyy), ("Lab", &c.lab), ("sRGB", &c.srgb)] {
        ensure_finite(what, input, v)?;
    }
    Ok(c)
}

/// One row of a colour table.
#[derive(Debug, Clone, PartialEq)]
pub struct TableRow {
    /// The spectrum's column label.
    pub name: String,
    /// Tristimulus values (0–100 scale).
    pub xyz: [f64; 3],
    /// Chromaticity.
    pub xy: [f64; 2],
    /// CIE L*a*b* relative to the illuminant's white.
    pub lab: [f64; 3],
}

/// XYZ, xy and Lab of every column of `ms` with one precomputed operator for the shared grid
/// (3·n multiply-adds per spectrum). `input` names the table in errors.
///
/// # Errors
/// The errors of [`XyzOperator::new`]; [`crate::Error::NonFinite`] naming the column when a
/// result overflows.
pub fn xyz_table(
    ms: &MultiSpectrum,
    observer: &Observer,
    illuminant: &Illuminant,
    method: XyzMethod,
    input: &str,
) -> Result<Vec<TableRow>> {
    let white = illuminant_white(observer, illuminant, method, ms.wavelengths(), None)?;
    let white_xy = xyz_to_xy(white.xyz, D65_XY);
    let op = XyzOperator::new(ms.wavelengths(), observer, illuminant, method, None)?;
    let mut rows = Vec::with_capacity(ms.n_channels());
    for (c, name) in ms.labels().iter().enumerate() {
        let xyz = op.apply(ms.channel(c))?;
        let xy = xyz_to_xy(xyz, D65_XY);
        let lab = xyz_to_lab(xyz.map(|v| v / white.xyz[1]), white_xy)?;
        let what = format!("{input}, column '{name}'");
        ensure_finite("XYZ", &what, &xyz)?;
        ensure_finite("Lab", &what, &lab)?;
        rows.push(TableRow {
            name: name.clone(),
            xyz,
            xy,
            lab,
        });
    }
    Ok(rows)
}

/// A colour table as CSV `name,X,Y,Z,x,y,L,a,b` (names with a comma or quote are quoted).
pub fn table_csv(rows: &[TableRow]) -> String {
    let mut out = String::from("name,X,Y,Z,x,y,L,a,b\n");
    for r in rows {
        let name = if r.name.contains(',') || r.name.contains('"') {
            format!("\"{}\"", r.name.replace('"', "\"\""))
        } else {
            r.name.clone()
        };
        out.push_str(&format!(
            "{name},{},{},{},{},{},{},{},{}\n",
            r.xyz[0], r.xyz[1], r.xyz[2], r.xy[0], r.xy[1], r.lab[0], r.lab[1], r.lab[2]
        ));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::colorimetry::StandardObserver;

    #[test]
    fn an_overflowing_spectrum_is_an_error_naming_the_input_not_a_null() {
        let obs = Observer::standard(StandardObserver::Cie1931_2).unwrap();
        let ill = Illuminant::standard("D65").unwrap();
        let wl: Vec<f64> = (0..=80).map(|i| 380.0 + 5.0 * i as f64).collect();
        let huge = Spectrum::new("huge", wl.clone(), vec![1e308; wl.len()]).unwrap();
        let e = sd_colour(&huge, obs, &ill, XyzMethod::Integration, None, "huge.csv")
            .unwrap_err()
            .to_string();
        assert!(e.contains("huge.csv") && e.contains("not finite"), "{e}");
        let grey = Spectrum::new("grey", wl.clone(), vec![0.5; wl.len()]).unwrap();
        let c = sd_colour(&grey, obs, &ill, XyzMethod::Integration, None, "grey.csv").unwrap();
        assert!((c.xyz[1] - 50.0).abs() < 1e-6, "{:?}", c.xyz);
    }
}
