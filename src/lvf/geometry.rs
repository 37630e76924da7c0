//! What the band-transmission solve, spectral recovery and synthetic captures need from an LVF
//! calibration (`lvf.json`): the axis, ROI, map, passband width and the sample bands, with the
//! pixel window each band averages over.
//!
//! A band *j* averages the profile over the positions p with |p − px_j| ≤ width_px_j / 2 (and
//! inside the ROI), so its parametric transmission is the passband averaged over those
//! positions: T_j(λ) = mean_p g(λ − λ(p); FWHM). With the paper's 31 bands (10 nm apart) and a
//! 25 nm passband this widens the effective band to ≈ 25.9 nm FWHM (variances add: σ² = σ_g² + 10²/12).

use crate::capture::RgbFrame;
use crate::error::{Error, Result};
use crate::lvf::calibration::{Band, LvfCalibration};
use crate::lvf::fit::Passband;
use crate::lvf::profile::{extract_profile, Axis};

/// The part of `lvf.json` the downstream tools read.
#[derive(Debug, Clone, PartialEq)]
pub struct LvfGeometry {
    /// The calibration file (or a description).
    pub source: String,
    /// Filter axis.
    pub axis: Axis,
    /// ROI `[x, y, w, h]` in the calibrated image's pixels.
    pub roi: [usize; 4],
    /// Map coefficients: λ(px) = Σ cᵢ·pxⁱ.
    pub map: Vec<f64>,
    /// Passband FWHM (nm).
    pub fwhm_nm: f64,
    /// Standard uncertainty of the FWHM (nm).
    pub fwhm_sigma_nm: f64,
    /// The sample bands.
    pub bands: Vec<Band>,
}

/// Camera readings averaged over each band's window.
#[derive(Debug, Clone, PartialEq)]
pub struct BandReadings {
    /// Mean per band and channel (linear units of the frame).
    pub rgb: Vec<[f64; 3]>,
    /// Standard error of each mean, from the spread of the per-position means across the window
    /// after removing a linear trend (≥ 0; 0 when the window has fewer than 3 positions).
    pub std: Vec<[f64; 3]>,
    /// Pixels averaged per band.
    pub pixels: Vec<usize>,
}

fn field<'a>(v: &'a serde_json::Value, key: &str, src: &str) -> Result<&'a serde_json::Value> {
    v.get(key).ok_or_else(|| {
        Error::parse(
            src,
            0,
            format!(
                "missing field '{key}'; expected an lvf.json written by 'lumifit lvf calibrate'"
            ),
        )
    })
}

fn number(v: &serde_json::Value, key: &str, src: &str) -> Result<f64> {
    field(v, key, src)?
        .as_f64()
        .filter(|x| x.is_finite())
        .ok_or_else(|| Error::parse(src, 0, format!("field '{key}': expected a finite number")))
}

impl LvfGeometry {
    /// Reads `lvf.json` (schema `lumifit.lvf/1`).
    ///
    /// # Errors
    /// [`Error::Parse`] naming the file and field when the JSON is not an LVF calibration, the
    /// map is not increasing or decreasing over the bands, the FWHM is not positive, or there are
    /// fewer than 2 bands.
    pub fn from_json(bytes: &[u8], source: &str) -> Result<Self> {
        let v: serde_json::Value = serde_json::from_slice(bytes)
            .map_err(|e| Error::parse(source, e.line(), format!("not JSON: {e}")))?;
        let schema = field(&v, "schema", source)?.as_str().unwrap_or("");
        if schema != "lumifit.lvf/1" {
            return Err(Error::parse(
                source,
                0,
                format!("field 'schema' is '{schema}'; expected 'lumifit.lvf/1' (an lvf.json from 'lumifit lvf calibrate')"),
            ));
        }
        let axis = match field(&v, "axis", source)?.as_str() {
            Some("x") => Axis::X,
            Some("y") => Axis::Y,
            _ => {
                return Err(Error::parse(
                    source,
                    0,
                    "field 'axis': expected \"x\" or \"y\"",
                ))
            }
        };
        let roi_v: Vec<usize> = field(&v, "roi", source)?
            .as_array()
            .map(|a| {
                a.iter()
                    .filter_map(|x| x.as_u64().map(|u| u as usize))
                    .collect()
            })
            .unwrap_or_default();
        if roi_v.len() != 4 || roi_v[2] == 0 || roi_v[3] == 0 {
            return Err(Error::parse(
                source,
                0,
                "field 'roi': expected [x, y, w, h] with w, h > 0",
            ));
        }
        let map: Vec<f64> = field(field(&v, "map", source)?, "coefficients", source)?
            .as_array()
            .map(|a| a.iter().filter_map(|x| x.as_f64()).collect())
            .unwrap_or_default();
        if map.len() < 2 || map.iter().any(|c| !c.is_finite()) {
            return Err(Error::parse(
                source,
                0,
                "field 'map.coefficients': expected 2 or 3 finite numbers",
            ));
        }
        let fwhm_nm = number(&v, "fwhm_nm", source)?;
        if fwhm_nm <= 0.0 {
            return Err(Error::parse(
                source,
                0,
                format!("field 'fwhm_nm' = {fwhm_nm}; expected > 0"),
            ));
        }
        let fwhm_sigma_nm = v
            .get("fwhm_sigma_nm")
            .and_then(|x| x.as_f64())
            .unwrap_or(0.0);
        let bands_v = field(&v, "bands", source)?
            .as_array()
            .ok_or_else(|| Error::parse(source, 0, "field 'bands': expected an array"))?;
        let mut bands = Vec::with_capacity(bands_v.len());
        for (i, b) in bands_v.iter().enumerate() {
            let f = |k: &str| number(b, k, &format!("{source}: bands[{i}]"));
            let band = Band {
                nm: f("nm")?,
                px: f("px")?,
                width_px: f("width_px")?,
                in_roi: b.get("in_roi").and_then(|x| x.as_bool()).unwrap_or(true),
            };
            if band.width_px <= 0.0 {
                return Err(Error::parse(
                    source,
                    0,
                    format!("bands[{i}].width_px = {}; expected > 0", band.width_px),
                ));
            }
            bands.push(band);
        }
        if bands.len() < 2 {
            return Err(Error::parse(
                source,
                0,
                format!(
                    "field 'bands' has {} entries; expected at least 2",
                    bands.len()
                ),
            ));
        }
        if let Some(i) = bands.windows(2).position(|w| w[1].nm <= w[0].nm) {
            return Err(Error::parse(
                source,
                0,
                format!("bands[{}].nm = {} does not exceed bands[{i}].nm = {}; expected increasing band wavelengths", i + 1, bands[i + 1].nm, bands[i].nm),
            ));
        }
        Ok(LvfGeometry {
            source: source.to_string(),
            axis,
            roi: [roi_v[0], roi_v[1], roi_v[2], roi_v[3]],
            map,
            fwhm_nm,
            fwhm_sigma_nm,
            bands,
        })
    }

    /// The geometry of a calibration just computed.
    pub fn from_calibration(cal: &LvfCalibration, source: &str) -> Self {
        LvfGeometry {
            source: source.to_string(),
            axis: cal.axis,
            roi: cal.roi,
            map: cal.map.coefficients.clone(),
            fwhm_nm: cal.fwhm_nm,
            fwhm_sigma_nm: cal.fwhm_sigma_nm,
            bands: cal.bands.clone(),
        }
    }

    /// λ at position `px` (nm).
    pub fn wavelength_at(&self, px: f64) -> f64 {
        self.map.iter().rev().fold(0.0, |acc, c| acc * px + c)
    }

    /// The ROI's extent along the axis as (first, last) pixel centres.
    fn axis_extent(&self) -> (f64, f64) {
        let (lo, len) = match self.axis {
            Axis::X => (self.roi[0], self.roi[2]),
            Axis::Y => (self.roi[1], self.roi[3]),
        };
        (lo as f64, (lo + len) as f64 - 1.0)
    }

    /// Pixel-centre positions (integers) band `j` averages over: |p − px_j| ≤ width_px/2 and
    /// inside the ROI; at least the nearest pixel.
    pub fn window(&self, j: usize) -> Vec<f64> {
        let (first, last) = self.window_bounds(j);
        let mut out = Vec::new();
        let mut p = first;
        while p <= last {
            out.push(p);
            p += 1.0;
        }
        out
    }

    /// First and last pixel centre of band `j`'s window (see [`LvfGeometry::window`]); the one
    /// rule shared by the parametric bands and [`LvfGeometry::band_readings`].
    fn window_bounds(&self, j: usize) -> (f64, f64) {
        let b = &self.bands[j];
        let (lo, hi) = self.axis_extent();
        let half = b.width_px / 2.0;
        let first = (b.px - half).ceil().max(lo);
        let last = (b.px + half).floor().min(hi);
        if first <= last {
            (first, last)
        } else {
            let p = b.px.round().clamp(lo, hi);
            (p, p)
        }
    }

    /// Parametric transmission of band `j` on `grid` (nm): the passband of width `fwhm_nm`
    /// averaged over the band's window, peak transmission `peak`.
    pub fn parametric_band(&self, j: usize, grid: &[f64], fwhm_nm: f64, peak: f64) -> Vec<f64> {
        let win = self.window(j);
        let centres: Vec<f64> = win.iter().map(|&p| self.wavelength_at(p)).collect();
        let g = Passband::Gaussian;
        grid.iter()
            .map(|&l| {
                peak * centres.iter().map(|&c| g.eval(l - c, fwhm_nm)).sum::<f64>()
                    / centres.len() as f64
            })
            .collect()
    }

    /// Band readings of a capture through the LVF: the profile across the ROI averaged over
    /// each band's window.
    ///
    /// # Errors
    /// The ROI errors of [`extract_profile`]; [`Error::InvalidArgument`] when a band's window
    /// holds no unsaturated position, or the capture is all zero.
    pub fn band_readings(&self, frame: &RgbFrame) -> Result<BandReadings> {
        let profile = extract_profile(frame, self.roi, self.axis)?;
        let mut rgb = Vec::with_capacity(self.bands.len());
        let mut std = Vec::with_capacity(self.bands.len());
        let mut pixels = Vec::with_capacity(self.bands.len());
        for (j, b) in self.bands.iter().enumerate() {
            // Downsampled frames (RAW half size) have fractional source coordinates: widen by
            // half a pixel so each source pixel of the window is represented.
            let (first, last) = self.window_bounds(j);
            let idx: Vec<usize> = (0..profile.px.len())
                .filter(|&i| profile.px[i] >= first - 0.5 && profile.px[i] < last + 0.5)
                .collect();
            if idx.is_empty() {
                return Err(Error::invalid(
                    "capture",
                    format!(
                        "{}: band {} ({} nm at px {:.1}) has no unsaturated pixels inside the ROI",
                        frame.name,
                        j + 1,
                        b.nm,
                        b.px
                    ),
                ));
            }
            let n = idx.len() as f64;
            let mut mean = [0.0; 3];
            let mut se = [0.0; 3];
            let count: usize = idx.iter().map(|&i| profile.counts[i]).sum();
            for c in 0..3 {
                let v = &profile.values[c];
                mean[c] = idx.iter().map(|&i| v[i]).sum::<f64>() / n;
                if idx.len() >= 3 {
                    // Residual spread about a straight line across the window.
                    let xm = idx.iter().map(|&i| profile.px[i]).sum::<f64>() / n;
                    let sxx: f64 = idx.iter().map(|&i| (profile.px[i] - xm).powi(2)).sum();
                    let sxy: f64 = idx
                        .iter()
                        .map(|&i| (profile.px[i] - xm) * (v[i] - mean[c]))
                        .sum();
                    let slope = if sxx > 0.0 { sxy / sxx } else { 0.0 };
                    let ss: f64 = idx
                        .iter()
                        .map(|&i| (v[i] - mean[c] - slope * (profile.px[i] - xm)).powi(2))
                        .sum();
                    se[c] = (ss / (n - 2.0) / n).sqrt();
                }
            }
            rgb.push(mean);
            std.push(se);
            pixels.push(count);
        }
        if rgb.iter().all(|v| v.iter().all(|&x| x <= 0.0)) {
            return Err(Error::invalid(
                "capture",
                format!("{}: every band reads zero inside the ROI; nothing to recover (lens cap on, wrong ROI or a dark frame?)", frame.name),
            ));
        }
        Ok(BandReadings { rgb, std, pixels })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn geometry() -> LvfGeometry {
        let json = serde_json::json!({
            "schema": "lumifit.lvf/1", "axis": "x", "roi": [0, 0, 1200, 100],
            "map": {"kind": "linear", "coefficients": [380.0, 0.3]},
            "fwhm_nm": 25.0,
            "bands": (0..31).map(|k| {
                let nm = 400.0 + 10.0 * k as f64;
                serde_json::json!({"nm": nm, "px": (nm - 380.0) / 0.3, "width_px": 10.0 / 0.3, "in_roi": true})
            }).collect::<Vec<_>>()
        });
        LvfGeometry::from_json(json.to_string().as_bytes(), "lvf.json").unwrap()
    }

    #[test]
    fn window_and_parametric_band_are_consistent() {
        let g = geometry();
        let w = g.window(10);
        // 500 nm at px 400, ±16.7 px.
        assert_eq!(w.first().copied(), Some(384.0));
        assert_eq!(w.last().copied(), Some(416.0));
        let grid: Vec<f64> = (0..=400).map(|i| 400.0 + 0.5 * i as f64).collect();
        let t = g.parametric_band(10, &grid, 25.0, 1.0);
        let (imax, max) = t
            .iter()
            .enumerate()
            .fold((0, 0.0), |a, (i, &v)| if v > a.1 { (i, v) } else { a });
        assert!((grid[imax] - 500.0).abs() < 0.6, "peak at {}", grid[imax]);
        // The window (10 nm box) widens the 25 nm Gaussian: FWHM ≈ 25.9 nm.
        let above: Vec<f64> = grid
            .iter()
            .zip(&t)
            .filter(|(_, &v)| v >= max / 2.0)
            .map(|(l, _)| *l)
            .collect();
        let fwhm = above.last().unwrap() - above.first().unwrap();
        assert!(
            (fwhm - 25.9).abs() < 1.0 && fwhm > 25.0 - 1e-9,
            "fwhm {fwhm}"
        );
    }

    #[test]
    fn rejects_other_json() {
        let e =
            LvfGeometry::from_json(br#"{"schema":"lumifit.material/1"}"#, "x.json").unwrap_err();
        assert!(e.to_string().contains("lumifit.lvf/1"), "{e}");
        let e = LvfGeometry::from_json(b"[1,", "y.json").unwrap_err();
        assert!(e.to_string().contains("y.json"), "{e}");
    }
}
