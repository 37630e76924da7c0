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
use serde::Deserialize;

use crate::lvf::calibration::{Band, LvfCalibration, MapKind, LVF_SCHEMA};
use crate::lvf::fit::Passband;
use crate::lvf::profile::{extract_profile_tilted, repair_known_patches, Axis, Occlusion, Tilt};

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
    /// The passband's shape (lvf.json's `passband`; Gaussian when absent, as lvf.json files
    /// written before it was recorded).
    pub passband: Passband,
    /// The slant of the iso-wavelength lines the calibration's profile was averaged along
    /// (lvf.json's `tilt`; `None`: along the rows); captures are read along the same lines.
    pub tilt: Option<Tilt>,
    /// Dark patches (dust) the calibration found on the lamp photo (lvf.json's
    /// `diagnostics.occlusions.patches`; empty when none or not looked for): captures through
    /// the same filter are shadowed at the same pixels, and [`LvfGeometry::band_readings`]
    /// replaces them there ([`repair_known_patches`]).
    pub occlusions: Vec<Occlusion>,
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

/// `lvf.json` as read: the fields of [`LvfCalibration`] the downstream tools need, with the
/// writer's own types ([`Axis`], [`MapKind`], [`Band`]); the writer's other fields (lines,
/// diagnostics, curves, …) are ignored so the contract may grow.
#[derive(Debug, Deserialize)]
struct LvfFile {
    axis: Axis,
    roi: [usize; 4],
    map: MapFile,
    fwhm_nm: f64,
    #[serde(default)]
    fwhm_sigma_nm: f64,
    #[serde(default)]
    passband: Option<serde_json::Value>,
    #[serde(default)]
    tilt: Option<Tilt>,
    bands: Vec<Band>,
    #[serde(default)]
    diagnostics: Option<DiagnosticsFile>,
}

/// The part of lvf.json's `diagnostics` the readings use.
#[derive(Debug, Deserialize)]
struct DiagnosticsFile {
    #[serde(default)]
    occlusions: Option<OcclusionsFile>,
}

/// `diagnostics.occlusions`.
#[derive(Debug, Deserialize)]
struct OcclusionsFile {
    #[serde(default)]
    patches: Vec<Occlusion>,
}

/// The `map` object of `lvf.json` (its covariance is not needed downstream).
#[derive(Debug, Deserialize)]
struct MapFile {
    #[serde(default)]
    kind: Option<MapKind>,
    coefficients: Vec<f64>,
}

/// Schema tag, read first so another JSON file gets that message, not a missing field.
#[derive(Debug, Deserialize)]
struct SchemaTag {
    schema: Option<String>,
}

impl LvfGeometry {
    /// Reads `lvf.json` (schema `lumifit.lvf/1`).
    ///
    /// # Errors
    /// [`Error::Parse`] naming the file and field when the JSON is not an LVF calibration, the
    /// map is not increasing or decreasing over the bands, the FWHM is not positive, or there are
    /// fewer than 2 bands.
    pub fn from_json(bytes: &[u8], source: &str) -> Result<Self> {
        let tag: SchemaTag = serde_json::from_slice(bytes)
            .map_err(|e| Error::parse(source, e.line(), format!("not JSON: {e}")))?;
        let schema = tag.schema.unwrap_or_default();
        if schema != LVF_SCHEMA {
            return Err(Error::parse(
                source,
                0,
                format!("field 'schema' is '{schema}'; expected '{LVF_SCHEMA}' (an lvf.json from 'lumifit lvf calibrate')"),
            ));
        }
        let f: LvfFile = serde_json::from_slice(bytes).map_err(|e| {
            Error::parse(
                source,
                e.line(),
                format!("{e}; expected an lvf.json written by 'lumifit lvf calibrate'"),
            )
        })?;
        let roi_v = f.roi;
        if roi_v[2] == 0 || roi_v[3] == 0 {
            return Err(Error::parse(
                source,
                0,
                "field 'roi': expected [x, y, w, h] with w, h > 0",
            ));
        }
        let map = f.map.coefficients;
        let degree_ok = match f.map.kind {
            Some(MapKind::Linear) => map.len() == 2,
            Some(MapKind::Quadratic) => map.len() == 3,
            None => map.len() == 2 || map.len() == 3,
        };
        if !degree_ok {
            return Err(Error::parse(
                source,
                0,
                format!(
                    "field 'map.coefficients' has {} values; expected 2 (linear) or 3 (quadratic) matching 'map.kind'",
                    map.len()
                ),
            ));
        }
        let fwhm_nm = f.fwhm_nm;
        if fwhm_nm <= 0.0 {
            return Err(Error::parse(
                source,
                0,
                format!("field 'fwhm_nm' = {fwhm_nm}; expected > 0"),
            ));
        }
        let fwhm_sigma_nm = f.fwhm_sigma_nm;
        let bands = f.bands;
        if let Some((i, b)) = bands.iter().enumerate().find(|(_, b)| b.width_px <= 0.0) {
            return Err(Error::parse(
                source,
                0,
                format!("bands[{i}].width_px = {}; expected > 0", b.width_px),
            ));
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
        let passband = match &f.passband {
            Some(v) => Passband::from_report(v, source)?,
            None => Passband::Gaussian,
        };
        Ok(LvfGeometry {
            source: source.to_string(),
            axis: f.axis,
            roi: [roi_v[0], roi_v[1], roi_v[2], roi_v[3]],
            map,
            fwhm_nm,
            fwhm_sigma_nm,
            passband,
            tilt: f.tilt,
            occlusions: f
                .diagnostics
                .and_then(|d| d.occlusions)
                .map(|o| o.patches)
                .unwrap_or_default(),
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
            // written by Passband::report, so it reads back; Gaussian only for a hand-made value
            passband: Passband::from_report(&cal.passband, source).unwrap_or(Passband::Gaussian),
            tilt: cal.tilt,
            occlusions: Vec::new(),
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

    /// Parametric transmission of band `j` on `grid` (nm): the passband (the calibration's
    /// shape) of width `fwhm_nm` averaged over the band's window, peak transmission `peak`.
    pub fn parametric_band(&self, j: usize, grid: &[f64], fwhm_nm: f64, peak: f64) -> Vec<f64> {
        let win = self.window(j);
        let centres: Vec<f64> = win.iter().map(|&p| self.wavelength_at(p)).collect();
        let g = &self.passband;
        grid.iter()
            .map(|&l| {
                peak * centres.iter().map(|&c| g.eval(l - c, fwhm_nm)).sum::<f64>()
                    / centres.len() as f64
            })
            .collect()
    }

    /// Band readings of a capture through the LVF: the profile across the ROI (read along the
    /// calibration's slanted iso-wavelength lines when it has a `tilt`, with the lamp photo's dust
    /// patches replaced from the other strips, [`LvfGeometry::occlusions`]) averaged over each
    /// band's window.
    ///
    /// # Errors
    /// The ROI errors of [`crate::lvf::extract_profile`]; [`Error::InvalidArgument`] when a band's window
    /// holds no unsaturated position, or the capture is all zero.
    pub fn band_readings(&self, frame: &RgbFrame) -> Result<BandReadings> {
        let mut profile = extract_profile_tilted(frame, self.roi, self.axis, self.tilt.as_ref())?;
        repair_known_patches(&mut profile, &self.occlusions);
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

    fn lvf_text() -> String {
        let json = serde_json::json!({
            "schema": "lumifit.lvf/1", "axis": "x", "roi": [0, 0, 1200, 100],
            "map": {"kind": "linear", "coefficients": [380.0, 0.3]},
            "fwhm_nm": 25.0,
            "bands": (0..31).map(|k| {
                let nm = 400.0 + 10.0 * k as f64;
                serde_json::json!({"nm": nm, "px": (nm - 380.0) / 0.3, "width_px": 10.0 / 0.3, "in_roi": true})
            }).collect::<Vec<_>>()
        });
        json.to_string()
    }

    fn geometry() -> LvfGeometry {
        LvfGeometry::from_json(lvf_text().as_bytes(), "lvf.json").unwrap()
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
        // typed fields: a wrong type or a missing field is named with its line
        let mut v: serde_json::Value = serde_json::from_str(&lvf_text()).unwrap();
        v["axis"] = serde_json::json!("z");
        let e = LvfGeometry::from_json(
            serde_json::to_string_pretty(&v).unwrap().as_bytes(),
            "z.json",
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("z.json") && e.contains("line"), "{e}");
        let mut v: serde_json::Value = serde_json::from_str(&lvf_text()).unwrap();
        v["bands"][4].as_object_mut().unwrap().remove("width_px");
        let e = LvfGeometry::from_json(v.to_string().as_bytes(), "w.json")
            .unwrap_err()
            .to_string();
        assert!(e.contains("w.json") && e.contains("width_px"), "{e}");
        let mut v: serde_json::Value = serde_json::from_str(&lvf_text()).unwrap();
        v["map"]["coefficients"] = serde_json::json!([380.0, 0.3, 1e-6]);
        let e = LvfGeometry::from_json(v.to_string().as_bytes(), "m.json")
            .unwrap_err()
            .to_string();
        assert!(e.contains("map.coefficients"), "{e}");
        // absent in_roi and fwhm_sigma_nm take their defaults
        let g = geometry();
        assert!(g.bands.iter().all(|b| b.in_roi));
        let mut v: serde_json::Value = serde_json::from_str(&lvf_text()).unwrap();
        v["bands"][0].as_object_mut().unwrap().remove("in_roi");
        let g2 = LvfGeometry::from_json(v.to_string().as_bytes(), "lvf.json").unwrap();
        assert_eq!(g2, g);
        assert_eq!(g2.fwhm_sigma_nm, 0.0);
        assert_eq!(g2.passband, Passband::Gaussian);
        // an unknown passband shape or exponent is named
        for (pb, field) in [
            (serde_json::json!({"shape": "lorentz"}), "passband.shape"),
            (
                serde_json::json!({"shape": "gennorm", "beta": 0.1}),
                "passband.beta",
            ),
        ] {
            let mut v: serde_json::Value = serde_json::from_str(&lvf_text()).unwrap();
            v["passband"] = pb;
            let e = LvfGeometry::from_json(v.to_string().as_bytes(), "p.json")
                .unwrap_err()
                .to_string();
            assert!(e.contains("p.json") && e.contains(field), "{e}");
        }
    }

    #[test]
    fn the_parametric_bands_take_the_calibrations_passband_shape() {
        // a flat-topped passband (β = 4) read from lvf.json: the band is flatter at its centre
        // than the Gaussian of the same FWHM and falls faster beyond it
        let mut v: serde_json::Value = serde_json::from_str(&lvf_text()).unwrap();
        v["passband"] = Passband::GenNormal { beta: 4.0 }.report();
        let g4 = LvfGeometry::from_json(v.to_string().as_bytes(), "lvf.json").unwrap();
        assert_eq!(g4.passband, Passband::GenNormal { beta: 4.0 });
        let g2 = geometry();
        let grid = [500.0, 510.0, 530.0];
        let (t4, t2) = (
            g4.parametric_band(10, &grid, 25.0, 1.0),
            g2.parametric_band(10, &grid, 25.0, 1.0),
        );
        assert!(t4[1] > t2[1] && t4[2] < t2[2], "{t4:?} {t2:?}");
        // and a measured shape round-trips through its report
        let m = Passband::measured(vec![-30.0, 0.0, 30.0], vec![0.0, 1.0, 0.0]).unwrap();
        assert_eq!(Passband::from_report(&m.report(), "x").unwrap(), m);
    }
}
