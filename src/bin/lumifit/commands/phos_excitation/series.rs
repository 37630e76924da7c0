//! Charging samples from photographs and regions of interest (`lumifit phos fit-excitation
//! --series`), and the synthetic photographs of `lumifit synth phos-excitation --images`.
//!
//! Nalbach et al. 2017 §4.6 charge the sample through a linear variable filter, so every band
//! charges its own region of the sample and one photograph taken after switch-off shows all
//! bands at once; one ROI per band picks each band's region.
//!
//! **Manifest** (`image,band,charge_s[,exposure_s,iso,f_number]`, header required, `#`
//! comments): one row per measured (band, charging time); image paths are relative to the
//! manifest's folder and one image may be listed for several bands. Images are anything
//! [`lumifit::io::series::read_frame`] reads (camera RAW, 16-bit linear TIFF/PNG, float
//! TIFF/EXR; 8-bit images are decoded from sRGB with a warning). Exposure settings come from EXIF
//! when present, else from the manifest (as for decay series); a frame with neither is an error
//! naming the image and the field.
//!
//! **ROIs**: `--roi x,y,w,h` (one rectangle for every band) or `--rois FILE.csv` with
//! `band,x,y,w,h` (one rectangle per band, source pixels as [`lumifit::capture::Roi`]).
//!
//! **Per manifest row**: the image minus the mean of the `--dark` frames
//! ([`RgbFrame::mean_of`], [`RgbFrame::subtract`]), then [`roi_stats`] over the band's ROI,
//! divided by the exposure factor *t*·ISO/100/*N*² ([`Exposure::factor`]): the sample's RGB is
//! the ROI mean in relative radiance and its `std` the largest channel's standard error of that
//! mean (pixel std / √n). Any saturated pixel inside an ROI is an error naming the image: the
//! mean of the remaining pixels would be biased low exactly where the signal is strongest.

use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use lumifit::capture::rng::SplitMix64;
use lumifit::capture::{roi_stats, Exposure, FrameInfo, RgbFrame, Roi};
use lumifit::io::series::{exif_or_manifest, read_frame, ManifestTable};
use lumifit::io::{atomic_write, image::encode_tiff16, read_input};
use lumifit::phosphor::excitation::ChargingSample;
use lumifit::table::{as_text, parse_numeric_csv};
use lumifit::Error;
use rayon::prelude::*;

/// Where the ROIs come from.
#[derive(Debug, Clone)]
pub(super) enum RoiSource<'a> {
    /// `--roi x,y,w,h` for every band.
    One(&'a str),
    /// `--rois FILE.csv` with `band,x,y,w,h`.
    PerBand(&'a Path),
}

/// One band's ROI with where it was defined (for messages).
#[derive(Debug, Clone)]
struct BandRoi {
    roi: Roi,
    origin: String,
}

/// One row of a charging manifest.
#[derive(Debug, Clone)]
struct ChargingRow {
    image: PathBuf,
    line: usize,
    band: usize,
    charge_s: f64,
    exposure_s: Option<f64>,
    iso: Option<f64>,
    f_number: Option<f64>,
}

/// Charging samples read from a photo series, with what is needed for provenance and report.
#[derive(Debug, Clone)]
pub(super) struct SeriesSamples {
    /// One sample per manifest row, in manifest order.
    pub samples: Vec<ChargingSample>,
    /// Every file read (manifest, ROI file, images, dark frames), for provenance.
    pub inputs: Vec<PathBuf>,
    /// Per-sample details for the report (image, line, ROI, pixels, exposure factor).
    pub report: serde_json::Value,
    /// Non-fatal remarks from the readers (8-bit images, EXIF/manifest disagreements).
    pub warnings: Vec<String>,
}

const MANIFEST_HEADER: &str = "image,band,charge_s[,exposure_s,iso,f_number]";

/// Parses a charging manifest; images are resolved against `base` and must exist.
fn parse_manifest(
    bytes: &[u8],
    source: &str,
    base: &Path,
    n_bands: usize,
) -> lumifit::Result<Vec<ChargingRow>> {
    let text = as_text(bytes, source, &format!("a CSV manifest {MANIFEST_HEADER}"))?;
    let t = ManifestTable::parse(text, source, MANIFEST_HEADER)?;
    let (Some(i_img), Some(i_band), Some(i_t)) =
        (t.column("image"), t.column("band"), t.column("charge_s"))
    else {
        return Err(Error::parse(
            source,
            t.header_line,
            format!(
                "header '{}' lacks 'image', 'band' or 'charge_s'; expected {MANIFEST_HEADER}",
                t.header
            ),
        ));
    };
    let mut rows = Vec::new();
    for r in &t.records {
        let line = r.line;
        let band = t
            .number(r, Some(i_band), "band")?
            .ok_or_else(|| Error::parse(source, line, "band is empty"))?;
        if band.fract() != 0.0 || band < 1.0 || band > n_bands as f64 {
            return Err(Error::parse(
                source,
                line,
                format!(
                    "band {band}; expected an integer from 1 to {n_bands} (the material's bands)"
                ),
            ));
        }
        let charge_s = t
            .number(r, Some(i_t), "charge_s")?
            .ok_or_else(|| Error::parse(source, line, "charge_s is empty"))?;
        if charge_s < 0.0 {
            return Err(Error::parse(
                source,
                line,
                format!("charge_s {charge_s}; expected a charging time ≥ 0 s"),
            ));
        }
        let name = r.fields[i_img];
        if name.is_empty() {
            return Err(Error::parse(source, line, "image name is empty"));
        }
        let image = base.join(name);
        if !image.is_file() {
            return Err(Error::parse(
                source,
                line,
                format!(
                    "image '{}' does not exist (paths are relative to the manifest's folder)",
                    image.display()
                ),
            ));
        }
        let [exposure_s, iso, f_number] = t.exposure(r)?;
        rows.push(ChargingRow {
            image,
            line,
            band: band as usize - 1,
            charge_s,
            exposure_s,
            iso,
            f_number,
        });
    }
    if rows.is_empty() {
        return Err(Error::parse(
            source,
            0,
            format!("the manifest lists no images; expected rows {MANIFEST_HEADER}"),
        ));
    }
    Ok(rows)
}

/// Reads `band,x,y,w,h` (one rectangle per band, bands 1-based and unique).
fn read_rois(path: &Path, n_bands: usize) -> Result<BTreeMap<usize, BandRoi>> {
    let (bytes, source) = read_input(path)?;
    let t = parse_numeric_csv(&bytes, &source)?;
    let mut ci = [0usize; 5];
    for (k, name) in ["band", "x", "y", "w", "h"].iter().enumerate() {
        ci[k] = t.column_index(name).ok_or_else(|| {
            Error::parse(
                &source,
                1,
                format!("no '{name}' column; expected header 'band,x,y,w,h' (source pixels)"),
            )
        })?;
    }
    let mut out = BTreeMap::new();
    for i in 0..t.n_rows() {
        let line = t.lines[i];
        let v = ci.map(|c| t.columns[c][i]);
        if v.iter().any(|x| x.fract() != 0.0 || *x < 0.0) {
            return Err(Error::parse(
                &source,
                line,
                format!(
                    "{},{},{},{},{}: expected non-negative integers band,x,y,w,h",
                    v[0], v[1], v[2], v[3], v[4]
                ),
            )
            .into());
        }
        if v[0] < 1.0 || v[0] > n_bands as f64 {
            return Err(Error::parse(
                &source,
                line,
                format!(
                    "band {}; expected an integer from 1 to {n_bands} (the material's bands)",
                    v[0]
                ),
            )
            .into());
        }
        if v[3] < 1.0 || v[4] < 1.0 {
            return Err(
                Error::parse(&source, line, "width and height must be at least 1 pixel").into(),
            );
        }
        let band = v[0] as usize - 1;
        let roi = Roi::Rect {
            x: v[1] as usize,
            y: v[2] as usize,
            w: v[3] as usize,
            h: v[4] as usize,
        };
        let origin = format!("{source} line {line}");
        if let Some(prev) = out.insert(band, BandRoi { roi, origin }) {
            return Err(Error::parse(
                &source,
                line,
                format!(
                    "band {} already has an ROI ({}); expected one ROI per band",
                    band + 1,
                    prev.origin
                ),
            )
            .into());
        }
    }
    if out.is_empty() {
        return Err(Error::parse(&source, 0, "no ROI rows; expected band,x,y,w,h rows").into());
    }
    Ok(out)
}

/// EXIF first, manifest as fall-back (as [`lumifit::io::series::load_series`] does), with a
/// warning when both are given and differ by more than 1 %.
fn exposure(info: &FrameInfo, row: &ChargingRow, source: &str) -> Result<(Exposure, Vec<String>)> {
    let mut warnings = Vec::new();
    let [t, iso, n] = exif_or_manifest(info, [row.exposure_s, row.iso, row.f_number], &mut warnings)
        .map_err(|name| {
            Error::parse(
                source,
                row.line,
                format!(
                    "{}: {name} is missing (or zero) in EXIF and not given in the manifest; add the column {name}",
                    row.image.display()
                ),
            )
        })?;
    let e = Exposure::new(t, iso, n)
        .with_context(|| format!("{source}: line {}: {}", row.line, row.image.display()))?;
    Ok((e, warnings))
}

/// Loads the charging samples of a manifest with its ROIs (see the module docs). Everything is
/// checked before anything is returned; nothing is written.
pub(super) fn load(
    manifest: &Path,
    rois: RoiSource<'_>,
    darks: &[PathBuf],
    n_bands: usize,
) -> Result<SeriesSamples> {
    let (bytes, source) = read_input(manifest)?;
    let base = manifest.parent().unwrap_or(Path::new("."));
    let rows = parse_manifest(&bytes, &source, base, n_bands)?;
    let mut inputs = vec![manifest.to_path_buf()];
    let per_band: BTreeMap<usize, BandRoi> = match rois {
        RoiSource::One(s) => {
            let roi = Roi::parse_rect(s)?;
            (0..n_bands)
                .map(|b| {
                    (
                        b,
                        BandRoi {
                            roi: roi.clone(),
                            origin: "--roi".into(),
                        },
                    )
                })
                .collect()
        }
        RoiSource::PerBand(p) => {
            inputs.push(p.to_path_buf());
            read_rois(p, n_bands)?
        }
    };
    for r in &rows {
        if !per_band.contains_key(&r.band) {
            let file = match rois {
                RoiSource::PerBand(p) => p.display().to_string(),
                RoiSource::One(_) => "--roi".into(),
            };
            bail!(Error::parse(
                &source,
                r.line,
                format!(
                    "band {} has no ROI in {file}; expected a row '{},x,y,w,h' for it",
                    r.band + 1,
                    r.band + 1
                ),
            ));
        }
    }
    // Decode each image once (an image usually holds every band), in parallel.
    let mut unique: Vec<PathBuf> = Vec::new();
    let mut index: HashMap<PathBuf, usize> = HashMap::new();
    for r in &rows {
        if !index.contains_key(&r.image) {
            index.insert(r.image.clone(), unique.len());
            unique.push(r.image.clone());
        }
    }
    let decoded: Vec<lumifit::Result<(RgbFrame, FrameInfo)>> =
        unique.par_iter().map(|p| read_frame(p)).collect();
    let mut frames = Vec::with_capacity(decoded.len());
    let mut warnings = Vec::new();
    for d in decoded {
        let (f, info) = d?;
        warnings.extend(info.warnings.iter().cloned());
        frames.push((f, info));
    }
    inputs.extend(unique.iter().cloned());
    if !darks.is_empty() {
        let dark_frames = darks
            .iter()
            .map(|p| read_frame(p).map(|(f, _)| f))
            .collect::<lumifit::Result<Vec<_>>>()?;
        let dark = RgbFrame::mean_of(&dark_frames)?;
        for (f, _) in &mut frames {
            f.subtract(&dark)?;
        }
        inputs.extend(darks.iter().cloned());
    }
    let mut samples = Vec::with_capacity(rows.len());
    let mut details = Vec::with_capacity(rows.len());
    for r in &rows {
        let (frame, info) = &frames[index[&r.image]];
        let br = &per_band[&r.band];
        let (exp, w) = exposure(info, r, &source)?;
        warnings.extend(w);
        let st = roi_stats(frame, &br.roi).with_context(|| {
            format!(
                "{source}: line {}: {} (band {}, ROI from {})",
                r.line,
                r.image.display(),
                r.band + 1,
                br.origin
            )
        })?;
        if st.n_saturated > 0 {
            bail!(
                "{source}: line {}: {}: {} of {} pixels in the ROI {} of band {} are saturated; \
                 the mean would be biased low — use a shorter exposure or another region",
                r.line,
                r.image.display(),
                st.n_saturated,
                st.n_pixels,
                br.roi.describe(),
                r.band + 1
            );
        }
        let k = exp.factor();
        let n = st.n_pixels as f64;
        let se = st.std.iter().fold(0.0_f64, |m, s| m.max(*s)) / n.sqrt() / k;
        let rgb = st.mean.map(|m| m / k);
        details.push(serde_json::json!({
            "image": r.image.display().to_string(),
            "manifest_line": r.line,
            "band": r.band + 1,
            "charge_s": r.charge_s,
            "roi": br.roi.describe(),
            "n_pixels": st.n_pixels,
            "exposure_factor": k,
            "rgb": rgb,
            "std": se,
        }));
        samples.push(ChargingSample {
            band: r.band,
            charge_s: r.charge_s,
            rgb,
            sigma: (se > 0.0).then_some(se),
        });
    }
    Ok(SeriesSamples {
        samples,
        inputs,
        report: serde_json::json!({
            "manifest": manifest.display().to_string(),
            "darks": darks.iter().map(|p| p.display().to_string()).collect::<Vec<_>>(),
            "units": "relative radiance: (ROI mean − dark) / (exposure_s * ISO/100 / f_number^2); std = largest channel's standard error of the ROI mean",
            "samples": details,
        }),
        warnings,
    })
}

/// Side of a band's square patch in the synthetic images, in pixels.
pub(super) const PATCH_PX: usize = 16;
/// Gap around and between the patches, in pixels.
const GAP_PX: usize = 8;
/// Dark level (black-level residual) of every synthetic pixel in 16-bit units (2 % of full
/// scale); written as `dark.tif` too. Whole units, so that subtracting `dark.tif` is exact.
pub(super) const PEDESTAL_DN: u16 = 1311;
/// Exposures are chosen in full stops so that an image's brightest band mean lies in
/// (PEAK_TARGET/2, PEAK_TARGET] of full scale.
const PEAK_TARGET: f64 = 0.4;

/// What [`render_images`] wrote.
#[derive(Debug, Clone)]
pub(super) struct RenderedImages {
    /// Number of images written (one per charging time).
    pub images: usize,
    /// Image size in pixels.
    pub size: (usize, usize),
}

/// Renders charging samples as 16-bit linear TIFFs, one per charging time (every band a
/// `PATCH_PX`² patch side by side, as under the LVF), plus `manifest.csv`, `rois.csv` and
/// `dark.tif` into `dir`.
///
/// A patch's pixels are `PEDESTAL_DN/65535 + f·(rgb + s_c·z)` with `f` the image's exposure factor
/// (exposure in full stops, ISO 100, f/1), `rgb` the sample, and `z` a zero-mean,
/// unit-variance pattern (Gaussian, made exact), scaled per channel so that the brightest
/// channel's standard error over the patch equals the sample's σ (`s_c = σ·√n·|rgb_c|/max|rgb|`,
/// at least one 16-bit unit so that rounding dithers).
/// Reading the patch back with the ROI from `rois.csv` and `--dark dark.tif` thus returns the
/// sample and its σ to within 16-bit quantisation.
pub(super) fn render_images(
    dir: &Path,
    samples: &[ChargingSample],
    n_bands: usize,
    times: &[f64],
    seed: u64,
) -> Result<RenderedImages> {
    let w = n_bands * (PATCH_PX + GAP_PX) + GAP_PX;
    let h = PATCH_PX + 2 * GAP_PX;
    let n_px = PATCH_PX * PATCH_PX;
    let pedestal = f64::from(PEDESTAL_DN) / 65535.0;
    let mut rng = SplitMix64::new(seed ^ 0x005E_ED1A_6E5E_71E5_u64);
    // Exposure per image (charging time): full stops with the brightest band at ≤ PEAK_TARGET.
    let peak_of = |t: f64| {
        samples
            .iter()
            .filter(|s| s.charge_s == t)
            .flat_map(|s| s.rgb.iter())
            .fold(0.0_f64, |m, v| m.max(*v))
    };
    let global_peak = times.iter().fold(0.0_f64, |m, t| m.max(peak_of(*t)));
    if global_peak <= 0.0 {
        bail!("--images: every sample is dark (no emission); nothing to render");
    }
    let mut images: Vec<(String, f64, Vec<u16>)> = Vec::with_capacity(times.len());
    for (ti, &t) in times.iter().enumerate() {
        let peak = peak_of(t).max(1e-3 * global_peak);
        let exposure_s = 2f64.powf((PEAK_TARGET / peak).log2().floor());
        let mut px = vec![0.0_f64; 3 * w * h];
        for v in px.iter_mut() {
            *v = pedestal;
        }
        for s in samples.iter().filter(|s| s.charge_s == t) {
            let mx = s.rgb.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
            let sigma = s.sigma.unwrap_or(0.0);
            let (x0, y0) = (GAP_PX + s.band * (PATCH_PX + GAP_PX), GAP_PX);
            for c in 0..3 {
                // At least one 16-bit unit of spread, so that rounding dithers instead of
                // shifting a faint channel's mean by up to half a unit.
                let scale = if mx > 0.0 && sigma > 0.0 {
                    (sigma * (n_px as f64).sqrt() * s.rgb[c].abs() / mx)
                        .max(1.0 / (65535.0 * exposure_s))
                } else {
                    0.0
                };
                let z = exact_pattern(&mut rng, n_px);
                for (k, zk) in z.iter().enumerate() {
                    let (x, y) = (x0 + k % PATCH_PX, y0 + k / PATCH_PX);
                    px[3 * (y * w + x) + c] = pedestal + exposure_s * (s.rgb[c] + scale * zk);
                }
            }
        }
        if let Some(v) = px.iter().find(|v| !(0.0..1.0 - 1.0 / 65535.0).contains(*v)) {
            bail!(
                "--images: charging time {t} s renders a pixel at {v:.3} of full scale, outside \
                 the 16-bit range; lower --noise (the pattern's spread is σ·{PATCH_PX} per pixel)"
            );
        }
        let q = px
            .iter()
            .map(|v| (v * 65535.0).round() as u16)
            .collect::<Vec<_>>();
        images.push((format!("charge_{ti:03}.tif"), exposure_s, q));
    }
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    for (name, _, q) in &images {
        let tiff = encode_tiff16(w as u32, h as u32, q)?;
        atomic_write(&dir.join(name), &tiff)?;
    }
    let dark = vec![PEDESTAL_DN; 3 * w * h];
    atomic_write(
        &dir.join("dark.tif"),
        &encode_tiff16(w as u32, h as u32, &dark)?,
    )?;
    let mut manifest = String::from(
        "# lumifit synth phos-excitation --images: one image per charging time, one patch per band (rois.csv); subtract dark.tif\nimage,band,charge_s,exposure_s,iso,f_number\n",
    );
    for ((name, exposure_s, _), &t) in images.iter().zip(times) {
        for b in 0..n_bands {
            if samples.iter().any(|s| s.band == b && s.charge_s == t) {
                manifest.push_str(&format!("{name},{},{t},{exposure_s},100,1\n", b + 1));
            }
        }
    }
    atomic_write(&dir.join("manifest.csv"), manifest.as_bytes())?;
    let mut rois = String::from("band,x,y,w,h\n");
    for b in 0..n_bands {
        rois.push_str(&format!(
            "{},{},{GAP_PX},{PATCH_PX},{PATCH_PX}\n",
            b + 1,
            GAP_PX + b * (PATCH_PX + GAP_PX)
        ));
    }
    atomic_write(&dir.join("rois.csv"), rois.as_bytes())?;
    Ok(RenderedImages {
        images: images.len(),
        size: (w, h),
    })
}

/// `n` Gaussian draws shifted and scaled to mean exactly 0 and sample standard deviation
/// (n − 1 denominator, as [`roi_stats`]) exactly 1.
fn exact_pattern(rng: &mut SplitMix64, n: usize) -> Vec<f64> {
    let z: Vec<f64> = (0..n).map(|_| rng.normal()).collect();
    let mean = z.iter().sum::<f64>() / n as f64;
    let var = z.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n as f64 - 1.0);
    let sd = var.sqrt();
    z.iter().map(|v| (v - mean) / sd).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_pattern_has_mean_zero_and_unit_sample_deviation_exactly() {
        let mut rng = SplitMix64::new(3);
        let z = exact_pattern(&mut rng, 256);
        let mean = z.iter().sum::<f64>() / 256.0;
        let var = z.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / 255.0;
        assert!(mean.abs() < 1e-14, "{mean}");
        assert!((var - 1.0).abs() < 1e-12, "{var}");
    }

    #[test]
    fn manifest_rows_skip_comments_and_read_optional_exposure_columns() {
        let d = tempfile::tempdir().unwrap();
        std::fs::write(d.path().join("a.tif"), b"x").unwrap();
        let text = "# note\nimage,band,charge_s,exposure_s\na.tif,2,16,\na.tif,1,4,0.5\n";
        let rows = parse_manifest(text.as_bytes(), "m.csv", d.path(), 3).unwrap();
        assert_eq!(rows.len(), 2);
        assert_eq!((rows[0].line, rows[0].band, rows[0].charge_s), (3, 1, 16.0));
        assert_eq!(rows[0].exposure_s, None);
        assert_eq!(rows[1].exposure_s, Some(0.5));
        let err = parse_manifest(b"image,band,charge_s\na.tif,4,1\n", "m.csv", d.path(), 3)
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("m.csv: line 2") && err.contains("band 4"),
            "{err}"
        );
        let err = parse_manifest(b"image,band\na.tif,1\n", "m.csv", d.path(), 3)
            .unwrap_err()
            .to_string();
        assert!(err.contains("charge_s"), "{err}");
    }
}
