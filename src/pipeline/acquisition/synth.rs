//! `lumifit synth lvf-hg` and `synth lvf-capture`: the synthetic photos through an LVF that the
//! acquisition tests and benchmarks calibrate — a lamp (and optionally a matching flat field) with
//! its true map, or a continuous spectrum through an optional gel — read from their files through
//! `io`, rendered by [`render_lvf`], [`render_lvf_flat`] and [`render_lvf_capture`], and encoded
//! as 16-bit TIFF with the truth as JSON, for the command to stage.

use std::path::PathBuf;

use crate::error::{Error, Result};
use crate::io::camera::{camera_file, read_camera};
use crate::io::filters::{filter_file, read_filter};
use crate::io::image::frame_to_tiff16;
use crate::io::lvf_model::read_lvf_model;
use crate::io::pretty_json;
use crate::io::sources::{file_of, resolve_illuminant, resolve_lamp, resolve_passband};
use crate::io::spectrum_csv::read_spectrum;
use crate::limits::{check_count, check_memory};
use crate::lvf::capture_synth::{render_lvf_capture, CaptureLight, Exposure, LvfCaptureSpec};
use crate::lvf::flat_synth::render_lvf_flat;
use crate::lvf::synth::{Continuum, ContinuumShape, VignettingShape};
use crate::lvf::{render_lvf, Axis, LvfSynthSpec};

/// Most pixels of a synthetic image: 100 megapixels (twice a full-frame camera's sensor; the
/// frames lumifit reads from RAW are half that resolution).
pub const MAX_SYNTH_PIXELS: usize = 100_000_000;
/// Bytes per pixel while rendering and encoding: the f32 RGB frame (12), its saturation mask
/// (1), the 16-bit copy (6) and the encoded TIFF (6).
const BYTES_PER_PIXEL: u128 = 25;

/// Parses `WxH` given to `flag` and bounds it (pixels and memory) before anything is allocated.
///
/// # Errors
/// [`Error::Flag`] for text that is not `WxH`; the limits' errors beyond
/// [`MAX_SYNTH_PIXELS`] or the memory the machine has.
pub fn parse_synth_size(flag: &str, s: &str) -> Result<(usize, usize)> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .and_then(|(w, h)| {
            Some((
                w.trim().parse::<usize>().ok()?,
                h.trim().parse::<usize>().ok()?,
            ))
        })
        .ok_or_else(|| Error::flag(flag, format!("'{s}' is not WxH, e.g. 1200x160")))?;
    let pixels = w.saturating_mul(h);
    check_memory(flag, s, pixels as u128, BYTES_PER_PIXEL)?;
    check_count(
        &format!("{flag} {s}"),
        pixels,
        MAX_SYNTH_PIXELS,
        "pixels of a synthetic image",
    )?;
    Ok((w, h))
}

/// `--exposure`: `auto` or a positive factor.
///
/// # Errors
/// [`Error::Flag`] naming `--exposure`.
pub fn parse_exposure(s: &str) -> Result<Exposure> {
    if s.trim().eq_ignore_ascii_case("auto") {
        return Ok(Exposure::Auto);
    }
    match s.trim().parse::<f64>() {
        Ok(e) if e > 0.0 && e.is_finite() => Ok(Exposure::Fixed(e)),
        _ => Err(Error::flag(
            "--exposure",
            format!("'{s}'; expected 'auto' or a positive number"),
        )),
    }
}

/// A synthetic photo encoded for staging: the 16-bit linear TIFF and the truth as pretty JSON.
#[derive(Debug, Clone)]
pub struct SynthPhoto {
    /// The photo (16-bit linear TIFF).
    pub tiff: Vec<u8>,
    /// Its truth (pretty JSON).
    pub truth_json: String,
}

/// `synth lvf-hg --pedestal` is below this (fraction of full scale): the brightest pixel is 0.8
/// before the pedestal is added.
pub const PEDESTAL_MAX: f64 = 0.2;

/// `synth lvf-hg`: a lamp seen through an LVF by a camera.
#[derive(Debug, Clone)]
pub struct LampPhotoJob {
    /// Image size `WxH`.
    pub size: String,
    /// Filter axis.
    pub axis: Axis,
    /// λ at pixel 0 (nm).
    pub nm_at_start: f64,
    /// Dispersion (nm per pixel).
    pub nm_per_px: f64,
    /// Bow of the map (nm).
    pub bow_nm: f64,
    /// Slant of the iso-wavelength lines (degrees).
    pub tilt_deg: f64,
    /// Passband FWHM (nm).
    pub fwhm_nm: f64,
    /// Passband shape: `gaussian`, `gennorm:BETA` or a CSV.
    pub passband: String,
    /// Lamp: `hg`, `hg-weak`, `cfl` or a CSV.
    pub lamp: String,
    /// Camera sensitivities (`None`: the embedded default camera).
    pub camera: Option<PathBuf>,
    /// Relative noise at the brightest pixel.
    pub noise: f64,
    /// Vignetting: `AMOUNT` or `SHAPE:AMOUNT`.
    pub vignetting: String,
    /// Continuum under the lines as a fraction of the brightest blob (0: none).
    pub continuum: f64,
    /// Spectrum of the continuum: `flat`, `cfl` or `blackbody:K`.
    pub continuum_spectrum: String,
    /// A level under everything, not vignetted (fraction of full scale; 0: none).
    pub pedestal: f64,
    /// Also render a matching flat field.
    pub flat: bool,
    /// Spectrum of the flat's source: `flat`, `cfl` or `blackbody:K` (checked even without
    /// `flat`).
    pub flat_spectrum: String,
    /// Random seed.
    pub seed: u64,
}

impl LampPhotoJob {
    /// Every file the job reads: the camera's (or its database's), the passband and lamp CSVs.
    pub fn files(&self) -> Vec<PathBuf> {
        let mut out: Vec<PathBuf> = self.camera.iter().map(|c| camera_file(c)).collect();
        out.extend(file_of(&self.passband));
        out.extend(file_of(&self.lamp));
        out
    }
}

/// The lamp photo, its truth, and the flat field when asked for.
#[derive(Debug, Clone)]
pub struct LampPhotos {
    /// The lamp photo and its truth (the true map).
    pub lamp: SynthPhoto,
    /// The flat field (16-bit linear TIFF): same geometry, camera, vignetting and noise, the
    /// flat's source instead of the lamp.
    pub flat_tiff: Option<Vec<u8>>,
}

/// Renders `synth lvf-hg`. Every flag is checked before anything is rendered.
///
/// # Errors
/// [`Error::Flag`] naming the flag for a malformed size, vignetting, continuum or spectrum; the
/// readers' errors naming the file; the renderer's.
pub fn synth_lamp_photo(job: &LampPhotoJob) -> Result<LampPhotos> {
    let (width, height) = parse_synth_size("--size", &job.size)?;
    let (vignetting_shape, vignetting) = VignettingShape::parse(&job.vignetting)?;
    let flat_shape = ContinuumShape::parse("--flat-spectrum", &job.flat_spectrum)?;
    let continuum = if job.continuum > 0.0 {
        Some(Continuum {
            shape: ContinuumShape::parse("--continuum-spectrum", &job.continuum_spectrum)?,
            fraction: job.continuum,
        })
    } else if job.continuum == 0.0 {
        None
    } else {
        return Err(Error::flag(
            "--continuum",
            format!("{}; expected a fraction ≥ 0", job.continuum),
        ));
    };
    if !(job.pedestal.is_finite() && (0.0..PEDESTAL_MAX).contains(&job.pedestal)) {
        return Err(Error::flag(
            "--pedestal",
            format!(
                "{}; expected a fraction of full scale in [0, {PEDESTAL_MAX}) (the brightest pixel is 0.8 before it, so more would saturate it)",
                job.pedestal
            ),
        ));
    }
    let spec = LvfSynthSpec {
        width,
        height,
        axis: job.axis,
        nm_at_start: job.nm_at_start,
        nm_per_px: job.nm_per_px,
        bow_nm: job.bow_nm,
        tilt_deg: job.tilt_deg,
        fwhm_nm: job.fwhm_nm,
        passband: resolve_passband(&job.passband)?,
        lamp: resolve_lamp(&job.lamp)?,
        camera: read_camera(job.camera.as_deref())?.curves,
        noise: job.noise,
        vignetting,
        vignetting_shape,
        continuum,
        pedestal: job.pedestal,
        seed: job.seed,
    };
    let (frame, truth) = render_lvf(&spec)?;
    let lamp = SynthPhoto {
        tiff: frame_to_tiff16(&frame)?,
        truth_json: pretty_json(&truth, "truth JSON")?,
    };
    let flat_tiff = match job.flat {
        true => Some(frame_to_tiff16(&render_lvf_flat(&spec, flat_shape)?)?),
        false => None,
    };
    Ok(LampPhotos { lamp, flat_tiff })
}

/// `synth lvf-capture`: a continuous spectrum through an optional gel and the LVF.
#[derive(Debug, Clone)]
pub struct CapturePhotoJob {
    /// Emission spectrum CSV.
    pub spectrum: Option<PathBuf>,
    /// Reflectance CSV (with `illuminant`).
    pub reflectance: Option<PathBuf>,
    /// Illuminant of the reflectance: a CIE name, `daylight:K`, `blackbody:K` or a CSV.
    pub illuminant: Option<String>,
    /// Gel: `FILE.csv` or `FILE.csv:CODE`.
    pub filter: Option<String>,
    /// The LVF: a truth JSON of `synth lvf-hg` or an `lvf.json`.
    pub lvf: PathBuf,
    /// Camera sensitivities (`None`: the embedded default camera).
    pub camera: Option<PathBuf>,
    /// Relative noise at 0.8 of full scale.
    pub noise: f64,
    /// Vignetting: `AMOUNT` or `SHAPE:AMOUNT`.
    pub vignetting: String,
    /// Exposure: `auto` or a factor.
    pub exposure: String,
    /// Image size `WxH` (default: the size the LVF file records).
    pub size: Option<String>,
    /// Random seed.
    pub seed: u64,
}

impl CapturePhotoJob {
    /// Every file the job reads: the light's spectra, the camera's, the LVF file, the
    /// illuminant's and the gel table.
    pub fn files(&self) -> Vec<PathBuf> {
        let mut out: Vec<PathBuf> = self
            .spectrum
            .iter()
            .chain(&self.reflectance)
            .cloned()
            .collect();
        out.extend(self.camera.iter().map(|c| camera_file(c)));
        out.push(self.lvf.clone());
        out.extend(self.illuminant.as_deref().and_then(file_of));
        out.extend(self.filter.as_deref().and_then(filter_file));
        out
    }
}

/// Renders `synth lvf-capture`.
///
/// # Errors
/// [`Error::Flag`] naming the flag for a malformed exposure, vignetting or size, a missing
/// `--size` with an `lvf.json` that records none, or a light given twice or not at all; the
/// readers' errors naming the file (the LVF file's in the context `--lvf FILE`); the renderer's.
pub fn synth_capture_photo(job: &CapturePhotoJob) -> Result<SynthPhoto> {
    let exposure = parse_exposure(&job.exposure)?;
    let (vignetting_shape, vignetting) = VignettingShape::parse(&job.vignetting)?;
    let model =
        read_lvf_model(&job.lvf).map_err(|e| e.context(format!("--lvf {}", job.lvf.display())))?;
    let (width, height) = match (&job.size, model.size) {
        (Some(s), _) => parse_synth_size("--size", s)?,
        (None, Some((w, h))) => parse_synth_size("--size", &format!("{w}x{h}"))?,
        (None, None) => {
            return Err(Error::flag(
                "--size",
                format!(
                    "required with an lvf.json from 'lvf calibrate' ({} holds no image size); give the size of the calibrated image, e.g. --size 1200x160",
                    job.lvf.display()
                ),
            ))
        }
    };
    let light = match (&job.spectrum, &job.reflectance, &job.illuminant) {
        (Some(s), None, _) => CaptureLight::Emission(read_spectrum(s)?),
        (None, Some(r), Some(i)) => CaptureLight::Reflectance {
            reflectance: read_spectrum(r)?,
            illuminant: {
                let ill = resolve_illuminant("--illuminant", i)?;
                ill.spectrum().clone().with_name(ill.name())
            },
        },
        (None, Some(_), None) => {
            return Err(Error::flag(
                "--reflectance",
                "needs --illuminant NAME|FILE.csv",
            ))
        }
        _ => {
            return Err(Error::message(
                "give exactly one of --spectrum FILE.csv or --reflectance FILE.csv",
            ))
        }
    };
    let (filter, filter_name) = match &job.filter {
        None => (None, None),
        Some(f) => {
            let gel = read_filter(f)?;
            let label = gel.label();
            (Some(gel.transmission), Some(label))
        }
    };
    let spec = LvfCaptureSpec {
        width,
        height,
        axis: model.axis,
        map: model.map,
        fwhm_nm: model.fwhm_nm,
        light,
        filter,
        filter_name,
        camera: read_camera(job.camera.as_deref())?.curves,
        noise: job.noise,
        vignetting,
        vignetting_shape,
        seed: job.seed,
        exposure,
    };
    let (frame, truth) = render_lvf_capture(&spec)?;
    Ok(SynthPhoto {
        tiff: frame_to_tiff16(&frame)?,
        truth_json: pretty_json(&truth, "truth JSON")?,
    })
}
