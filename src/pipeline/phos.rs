//! Phosphorescence glue between domains and files: what the `phos` and `synth` commands do
//! between reading their inputs and staging their outputs.
//!
//! - [`lambda_camera_scale`]: the one least-squares factor that puts Λ into a camera's units
//!   (used by `phos fit-decay --spectrum` and `phos fit-excitation`);
//! - [`decay_preset`]: a decay fit turned into the bands, states and record of a preset;
//! - [`roi_curve`]: the mean curve of an ROI of a photo series, with σ;
//! - [`fit_batch`]: a batch of curves fitted in parallel into result rows;
//! - [`pixel_map_files`]: the per-pixel maps as TIFF files and their summary;
//! - [`compare_integrators`]: error against run time of the integrators of Eq. 1;
//! - [`excitation`]: the excitation fit with Λ checked against the preset's own decay fit;
//! - [`design_report`]: the report of a design from keyframes;
//! - [`render_charging_images`]: charging samples as 16-bit photographs under an LVF.

use serde::Serialize;

use crate::capture::rng::SplitMix64;
use crate::capture::{PhotoSeries, Roi};
use crate::error::{ensure_finite, Error, Result};
use crate::io::image::encode_tiff16;
use crate::io::maps::{rgb_map_tiff, scalar_map_tiff};
use crate::io::phos_formats::{BatchCsv, BatchResultRow, CurveCsv, SigmaColumn};
use crate::io::series::{charging_manifest_csv, BandRoi, BandRois};
use crate::phosphor::design::{Design, DesignStage, Keyframe};
use crate::phosphor::excitation::{
    apply_excitation, fit_excitation, ChargingSample, ExcitationFit, ExcitationOptions,
    SATURATION_MIN,
};
use crate::phosphor::maps::{PixelMaps, MAP_STATES};
use crate::phosphor::synth::{
    two_state_variant, DecayFrames, DecaySeriesSpec, FrameLayout, SyntheticCurve,
};
use crate::phosphor::{
    band_spectrum, reradiation_functions, reradiation_functions_rgb, simulate, BandCamera, BandSet,
    DecayCurve, DecayFit, Integrator, Material, Segment, Simulation,
};
use crate::phosphor::{fit_decay, DecayFitOptions};
use crate::preset::phosphor::{decay_flags_text, DecayFitRecord, LambdaCameraScale};
use crate::preset::Bands;
use crate::spectrum::MultiSpectrum;
use rayon::prelude::*;

/// The least-squares factor s minimising Σ_i Σ_c (s·(C Λ_i k_r,i)_c − a_i,c)² over states
/// `(k_r,i, Λ_i, a_i)` with `a_i` the RGB amplitudes at switch-off that a decay fit measured:
/// Λ·s then reproduces those amplitudes through `camera`. `None` when the camera sees no signal
/// of the model or of the data (or the factor is not finite).
pub fn lambda_camera_scale<'a>(
    camera: &BandCamera,
    states: impl IntoIterator<Item = (f64, &'a [f64], &'a [f64])>,
) -> Option<f64> {
    let (mut num, mut den) = (0.0, 0.0);
    for (k_r, lambda, amplitudes) in states {
        let emission: Vec<f64> = lambda.iter().map(|l| l * k_r).collect();
        let model = camera.rgb(&emission);
        for (a, m) in amplitudes.iter().zip(model) {
            num += a * m;
            den += m * m;
        }
    }
    let s = num / den;
    (den > 0.0 && num > 0.0 && s.is_finite()).then_some(s)
}

/// The emission spectrum for `phos fit-decay --spectrum`.
#[derive(Debug, Clone, Copy)]
pub struct EmissionSpectrum<'a> {
    /// Wavelengths in nm.
    pub wavelengths_nm: &'a [f64],
    /// Relative emission.
    pub values: &'a [f64],
    /// The file, for messages.
    pub source: &'a str,
    /// Number of uniform bands over 400–700 nm.
    pub n_bands: usize,
}

/// The camera that recorded a decay curve (for Λ in its units).
#[derive(Debug, Clone, Copy)]
pub struct RecordingCamera<'a> {
    /// Sensitivities `r,g,b`; `None` for the ideal box camera.
    pub sensitivities: Option<&'a MultiSpectrum>,
    /// How the camera is named in the record.
    pub label: &'a str,
}

/// Bands, states (k_r, Λ) and record of a decay-fit preset.
#[derive(Debug, Clone)]
pub struct DecayPreset {
    /// The bands Λ refers to.
    pub bands: Bands,
    /// (k_r in s⁻¹, Λ per band) per state.
    pub states: Vec<(f64, Vec<f64>)>,
    /// The record for `extra.decay_fit`.
    pub record: DecayFitRecord,
}

/// Description of the ideal box camera in records.
pub const BOX_CAMERA_LABEL: &str = "ideal box camera (B 400–500, G 500–600, R 600–700 nm)";

/// A decay fit of `curve` as a preset: without a spectrum, Λ over RGB bands (needs three
/// channels); with one, Λ over `n_bands` uniform bands of 400–700 nm, scaled (for an RGB curve)
/// so that `camera` sees the measured amplitudes ([`lambda_camera_scale`]).
pub fn decay_preset(
    fit: &DecayFit,
    curve: &DecayCurve,
    curve_source: &str,
    spectrum: Option<EmissionSpectrum<'_>>,
    camera: RecordingCamera<'_>,
) -> Result<DecayPreset> {
    let fitted: Vec<f64> = fit
        .states
        .iter()
        .flat_map(|s| {
            [s.k_per_s, s.amplitude]
                .into_iter()
                .chain(s.channel_amplitudes.iter().copied())
        })
        .chain(fit.spectrum.iter().copied())
        .chain([fit.rms])
        .collect();
    ensure_finite("the decay fit", curve_source, &fitted)?;
    let mut record = DecayFitRecord::new(fit);
    let Some(sp) = spectrum else {
        if curve.channels.len() != 3 {
            return Err(Error::invalid(
                curve_source,
                "a single-channel curve needs --spectrum to give the re-radiation functions bands",
            ));
        }
        return Ok(DecayPreset {
            bands: Bands::Rgb,
            states: reradiation_functions_rgb(fit),
            record,
        });
    };
    let BandSet::RangesNm(ranges) = BandSet::uniform(400.0, 700.0, sp.n_bands)? else {
        return Err(Error::invalid(
            "--bands",
            "uniform bands are wavelength bands",
        ));
    };
    let spec = band_spectrum(sp.wavelengths_nm, sp.values, &ranges)?;
    let cam = BandCamera::for_bands(&BandSet::RangesNm(ranges.clone()), camera.sensitivities)?;
    let mut states = reradiation_functions(fit, &spec);
    if curve.channels.len() == 3 {
        // Λ* is normalised to max 1; scale it so that the camera sees the measured RGB
        // amplitudes: camera·(Λ_i k_r,i) ≈ a_i·spectrum_rgb in least squares.
        let scale = lambda_camera_scale(
            &cam,
            states
                .iter()
                .zip(&fit.states)
                .map(|((k, l), st)| (*k, &l[..], &st.channel_amplitudes[..])),
        )
        .ok_or_else(|| {
            Error::invalid(
                sp.source,
                "the emission spectrum gives no signal in the camera's channels; check --spectrum and --camera",
            )
        })?;
        for (_, l) in states.iter_mut() {
            for v in l.iter_mut() {
                *v *= scale;
            }
        }
        record.lambda_camera_scale = Some(LambdaCameraScale {
            camera: camera.label.to_string(),
            meaning: "lambda = a_i * spectrum / k_r,i * value, so that the camera sees the measured RGB amplitudes".into(),
            value: scale,
        });
    }
    let lambda: Vec<f64> = states.iter().flat_map(|(_, l)| l.iter().copied()).collect();
    ensure_finite("the re-radiation functions Λ", sp.source, &lambda)?;
    Ok(DecayPreset {
        bands: Bands::RangesNm(ranges),
        states,
        record,
    })
}

/// The mean curve of `roi` over a photo series (relative radiance), σ of each sample the
/// largest channel's standard error of the ROI mean (equal weights when any σ is not > 0).
pub fn roi_curve(series: &PhotoSeries, roi: &Roi, source: &str) -> Result<DecayCurve> {
    let ctx = |e: Error| Error::invalid(format!("{source}: ROI {}", roi.describe()), e.to_string());
    let samples = series.extract(roi).map_err(ctx)?;
    let sigma: Vec<f64> = samples
        .iter()
        .map(|s| {
            let n = (s.n_pixels - s.n_saturated).max(1) as f64;
            s.std.iter().cloned().fold(0.0f64, f64::max) / n.sqrt()
        })
        .collect();
    let sigma = sigma
        .iter()
        .all(|v| v.is_finite() && *v > 0.0)
        .then_some(sigma);
    let t: Vec<f64> = samples.iter().map(|s| s.time_s).collect();
    let channels = (0..3)
        .map(|c| samples.iter().map(|s| s.mean[c]).collect())
        .collect();
    DecayCurve::new(t, channels, sigma).map_err(ctx)
}

/// The files of a per-pixel fit: `k<i>_per_s.tif`, `a<i>.tif`, `n_states.tif`, `rms.tif`,
/// `spectrum_<c>.tif`, `spectrum_rgb.tif` (name, TIFF bytes), in that order.
pub fn pixel_map_files(maps: &PixelMaps) -> Result<Vec<(String, Vec<u8>)>> {
    let (w, h) = (maps.width, maps.height);
    let mut files = Vec::new();
    for i in 0..MAP_STATES {
        files.push((
            format!("k{}_per_s.tif", i + 1),
            scalar_map_tiff(w, h, &maps.k_per_s[i])?,
        ));
        files.push((
            format!("a{}.tif", i + 1),
            scalar_map_tiff(w, h, &maps.amplitude[i])?,
        ));
    }
    files.push((
        "n_states.tif".into(),
        scalar_map_tiff(w, h, &maps.n_states)?,
    ));
    files.push(("rms.tif".into(), scalar_map_tiff(w, h, &maps.rms)?));
    for (c, name) in ["r", "g", "b"].iter().enumerate() {
        files.push((
            format!("spectrum_{name}.tif"),
            scalar_map_tiff(w, h, &maps.spectrum[c])?,
        ));
    }
    files.push((
        "spectrum_rgb.tif".into(),
        rgb_map_tiff(
            w,
            h,
            [&maps.spectrum[0], &maps.spectrum[1], &maps.spectrum[2]],
        )?,
    ));
    Ok(files)
}

/// The summary of a per-pixel fit (`summary.json`).
pub fn pixel_map_summary(
    series_source: &str,
    series: &PhotoSeries,
    maps: &PixelMaps,
    files: &[String],
    seconds: f64,
    threads: usize,
) -> serde_json::Value {
    let (w, h) = series
        .frames()
        .first()
        .map_or((0, 0), |f| (f.frame.width, f.frame.height));
    let (mw, mh) = (maps.width, maps.height);
    let median = |v: &[f32]| -> Option<f64> {
        let mut x: Vec<f32> = v.iter().cloned().filter(|x| x.is_finite()).collect();
        if x.is_empty() {
            return None;
        }
        x.sort_by(f32::total_cmp);
        Some(f64::from(x[x.len() / 2]))
    };
    let mut hist = [0usize; 4];
    for n in &maps.n_states {
        hist[(*n as usize).min(3)] += 1;
    }
    let n_blocks = mw * mh;
    serde_json::json!({
        "series": series_source,
        "frames": series.len(),
        "frame_size": [w, h],
        "block": maps.block,
        "map_size": [mw, mh],
        "blocks": n_blocks,
        "fitted": maps.n_fitted,
        "failed": maps.n_failed,
        "n_states_histogram": {"failed": hist[0], "1": hist[1], "2": hist[2], "3": hist[3]},
        "median": {
            "k1_per_s": median(&maps.k_per_s[0]), "k2_per_s": median(&maps.k_per_s[1]),
            "k3_per_s": median(&maps.k_per_s[2]), "rms": median(&maps.rms),
        },
        "seconds": seconds,
        "blocks_per_s": n_blocks as f64 / seconds.max(1e-9),
        "threads": threads,
        "maps": files,
        "format": "32-bit float TIFF, value repeated in R=G=B (spectrum_rgb.tif: r,g,b); NaN where a block could not be fitted; k1 is the fastest rate",
        "weights": "shot + read noise: sigma_t^2 = peak * (0.9 * max(max_c y_c(t), 0) + 0.1 * peak) per block",
    })
}

/// One row of the batch output for a fitted curve.
pub fn batch_row(id: &str, fit: &DecayFit) -> BatchResultRow {
    let k = |j: usize| fit.states.get(j).map(|s| s.k_per_s);
    let a = |j: usize| fit.states.get(j).map(|s| s.amplitude);
    let sp = |c: usize| fit.spectrum.get(c).copied();
    BatchResultRow {
        id: id.to_string(),
        n_states: Some(fit.states.len()),
        k1_per_s: k(0),
        k2_per_s: k(1),
        k3_per_s: k(2),
        a1: a(0),
        a2: a(1),
        a3: a(2),
        spectrum_r: sp(0),
        spectrum_g: sp(1),
        spectrum_b: sp(2),
        rms: Some(fit.rms),
        flags: decay_flags_text(fit),
    }
}

fn fit_is_finite(fit: &DecayFit) -> bool {
    fit.states
        .iter()
        .all(|s| s.k_per_s.is_finite() && s.amplitude.is_finite())
        && fit.spectrum.iter().all(|v| v.is_finite())
        && fit.rms.is_finite()
}

/// Fits every curve of a batch in parallel (`progress` is called once per curve). A curve that
/// cannot be fitted gives an error row; when every curve fails, the error names `source` and
/// the first failure (a batch that fits nothing is not a success).
pub fn fit_batch(
    batch: &BatchCsv,
    opts: &DecayFitOptions,
    source: &str,
    progress: &(dyn Fn() + Sync),
) -> Result<Vec<BatchResultRow>> {
    let rows: Vec<BatchResultRow> = batch
        .curves
        .par_iter()
        .map(|c| {
            let row = match c.to_curve().and_then(|curve| fit_decay(&curve, opts)) {
                Ok(fit) if fit_is_finite(&fit) => batch_row(&c.id, &fit),
                Ok(_) => BatchResultRow::failed(
                    &c.id,
                    "the fit is not finite (overflow or 0/0); expected values whose result fits in f64",
                ),
                Err(e) => BatchResultRow::failed(&c.id, &e.to_string()),
            };
            progress();
            row
        })
        .collect();
    if !rows.is_empty() && rows.iter().all(BatchResultRow::is_error) {
        return Err(Error::invalid(
            source,
            format!(
                "none of the {} curves could be fitted; the first, '{}': {}",
                rows.len(),
                rows[0].id,
                rows[0].flags.trim_start_matches("error: ")
            ),
        ));
    }
    Ok(rows)
}

/// Checks the memory a simulation of `history` at step `dt_s` would take for a material with
/// `n_bands` bands and `n_states` states (and camera RGB), before simulating.
pub fn check_simulation_size(
    history: &[Segment],
    dt_s: f64,
    n_bands: usize,
    n_states: usize,
) -> Result<()> {
    let total: f64 = history.iter().map(|s| s.duration_s).sum();
    if !(dt_s.is_finite() && dt_s > 0.0) {
        return Err(Error::invalid(
            "--dt",
            format!("{dt_s} s; expected a finite step > 0"),
        ));
    }
    let steps = (total / dt_s).ceil() + history.len() as f64 + 1.0;
    let steps = if steps.is_finite() && steps < 1e30 {
        steps as u128
    } else {
        u128::MAX
    };
    // per sample: time, emission and r vectors (24-byte headers + values), RGB, CSV text ~ 24 B/value
    let per =
        8 + 2 * 24 + 8 * (n_bands + n_states) as u128 + 24 + 24 * (n_bands + n_states + 4) as u128;
    crate::limits::check_memory("--dt", &format!("{dt_s} s over {total} s"), steps, per)
}

/// Checks the sizes a user typed for `synth phos-decay` against the memory they need: `frames`
/// samples per curve, and (`size` = Some((w, h))) one float frame plus its 16-bit TIFF for each
/// of `in_flight` frames rendered at once.
pub fn check_decay_series_size(
    frames: usize,
    size: Option<(usize, usize)>,
    in_flight: usize,
) -> Result<()> {
    // per frame and curve: time, RGB, clean RGB, σ (8 B each) in two curves, plus CSV text
    crate::limits::check_memory(
        "--frames",
        &frames.to_string(),
        frames as u128,
        2 * 8 * 8 + 128,
    )?;
    if let Some((w, h)) = size {
        // 3 channels × (f32 frame + u16 pixels + u16 TIFF bytes)
        crate::limits::check_memory(
            "--size",
            &format!("{w}x{h}"),
            (w as u128) * (h as u128) * 3 * in_flight.max(1) as u128,
            4 + 2 + 2,
        )?;
    }
    Ok(())
}

/// Frame `j` of a synthetic decay series as a 16-bit linear TIFF.
pub fn decay_frame_tiff(fr: &DecayFrames, j: usize) -> Result<Vec<u8>> {
    let px: Vec<u16> = fr
        .frame(j)?
        .iter()
        .map(|v| (f64::from(*v) * 65535.0).round() as u16)
        .collect();
    encode_tiff16(fr.width as u32, fr.height as u32, &px)
}

/// What `synth phos-decay --curve-only` records beside `curve.csv` (`manifest.json`).
pub fn synth_curve_manifest(
    material: &Material,
    c: &SyntheticCurve,
    spec: &DecaySeriesSpec,
) -> serde_json::Value {
    serde_json::json!({
        "generator": "lumifit synth phos-decay",
        "material": material.name,
        "rates_per_s": material.states.iter().map(|s| s.k_r_per_s).collect::<Vec<_>>(),
        "r_at_switch_off": c.r0,
        "saturation_assumed": c.saturation_assumed,
        "charge_s": spec.charge_s, "frames": spec.frames, "interval_s": spec.interval_s,
        "exposure_s": spec.exposure_s, "noise": spec.noise, "seed": spec.seed,
        "time_s": "start of each exposure window after switch-off; values are window means",
        "curve": "curve.csv",
    })
}

/// The curve of `synth phos-decay --curve-only` as its CSV type.
pub fn synth_curve_csv(c: &SyntheticCurve) -> CurveCsv {
    CurveCsv {
        time_s: c.t_s.clone(),
        names: vec!["r".into(), "g".into(), "b".into()],
        channels: (0..3)
            .map(|k| c.rgb.iter().map(|v| v[k]).collect())
            .collect(),
        sigma: Some((SigmaColumn::Std, c.sigma.clone())),
    }
}

/// The ground truth of a synthetic decay series (`truth.json`).
pub fn synth_frames_truth(
    material: &Material,
    layout: FrameLayout,
    fr: &DecayFrames,
    spec: &DecaySeriesSpec,
) -> Result<serde_json::Value> {
    let region = |i: usize, m: &Material| {
        serde_json::json!({
            "material": m.name,
            "rates_per_s": m.states.iter().map(|s| s.k_r_per_s).collect::<Vec<_>>(),
            "r_at_switch_off": fr.curves[i].r0,
            "saturation_assumed": fr.curves[i].saturation_assumed,
            "first_frame_value": fr.clean_value(i, 0),
        })
    };
    let mut regions = vec![region(0, material)];
    if layout == FrameLayout::Halves {
        let v = two_state_variant(material)?;
        regions.push(region(1, &v));
    }
    Ok(serde_json::json!({
        "generator": "lumifit synth phos-decay",
        "layout": match layout { FrameLayout::Uniform => "uniform", FrameLayout::Halves => "halves: x < width/2 is regions[0], the rest regions[1]" },
        "size": [fr.width, fr.height],
        "regions": regions,
        "charge_s": spec.charge_s, "frames": spec.frames, "interval_s": spec.interval_s,
        "exposure_s": spec.exposure_s, "iso": 100, "f_number": 1,
        "noise": spec.noise, "seed": spec.seed,
        "gain": fr.gain,
        "values": "frame value = gain * camera RGB window mean * exposure_s, 16-bit linear (0-65535 = 0-1), shot + read noise (capture::synth::noisy_value, peak 0.8)",
        "manifest": "manifest.csv",
    }))
}

/// Simulates `material` under `history` (from dark) and, with a camera, the camera RGB of the
/// emission; a result that is not finite (an explicit integrator leaving its stable region, an
/// overflow) is [`Error::NonFinite`] naming `input`, never a CSV of NaN.
pub fn simulate_checked(
    material: &Material,
    history: &[Segment],
    dt_s: f64,
    integrator: Integrator,
    camera: Option<&BandCamera>,
    input: &str,
) -> Result<(Simulation, Option<Vec<[f64; 3]>>)> {
    check_simulation_size(history, dt_s, material.bands.len(), material.states.len())?;
    let r0 = vec![0.0; material.states.len()];
    let sim = simulate(material, history, &r0, dt_s, integrator)?;
    let rgb: Option<Vec<[f64; 3]>> =
        camera.map(|cam| sim.emission.iter().map(|e| cam.rgb(e)).collect());
    let values: Vec<f64> = sim
        .emission
        .iter()
        .chain(&sim.r)
        .flatten()
        .copied()
        .chain(rgb.iter().flatten().flatten().copied())
        .collect();
    ensure_finite("the simulated emission", input, &values)?;
    Ok((sim, rgb))
}

/// One row of the integrator comparison.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct IntegratorRow {
    /// `normal |E|=1` or `bright |E|=100`.
    pub case: &'static str,
    /// `exact`, `rk4` or `euler`.
    pub integrator: &'static str,
    /// Step in s.
    pub dt_s: f64,
    /// Run time per simulation in s.
    pub seconds: f64,
    /// Largest emission error relative to the peak of the exact run (∞ when diverged).
    pub error: f64,
}

/// The comparison's cases: (name, |E|).
pub const COMPARISON_CASES: [(&str, f64); 2] = [("normal |E|=1", 1.0), ("bright |E|=100", 100.0)];
/// The comparison's steps in s.
pub const COMPARISON_STEPS_S: [f64; 6] = [0.05, 0.1, 0.5, 1.0, 5.0, 10.0];

/// History of the comparison: charge 600 s under flat light of magnitude `scale` (|E| = scale
/// over the bands), then 600 s dark.
pub fn compare_history(material: &Material, scale: f64) -> Vec<Segment> {
    let nb = material.bands.len();
    let e = scale / (nb as f64).sqrt();
    vec![
        Segment {
            duration_s: 600.0,
            irradiance: vec![e; nb],
        },
        Segment {
            duration_s: 600.0,
            irradiance: vec![0.0; nb],
        },
    ]
}

/// Largest |x − y| / peak over two emission records (∞ as soon as one value is not finite).
pub fn max_relative_error(emission: &[Vec<f64>], reference: &[Vec<f64>], peak: f64) -> f64 {
    let mut err = 0.0f64;
    for (l, lr) in emission.iter().zip(reference) {
        for (x, y) in l.iter().zip(lr) {
            let d = (x - y).abs() / peak;
            err = if d.is_finite() {
                err.max(d)
            } else {
                f64::INFINITY
            };
        }
    }
    err
}

/// Error versus run time of the exact, RK4 and Euler integrators at [`COMPARISON_STEPS_S`] for
/// both [`COMPARISON_CASES`] (each run repeated until 20 ms have passed or 1000 runs).
pub fn compare_integrators(material: &Material) -> Result<Vec<IntegratorRow>> {
    if !material.has_excitation() {
        return Err(Error::invalid(
            "--material",
            format!(
                "{}: the material has no excitation rates k_e; pick one that does (e.g. green_paint)",
                material.name
            ),
        ));
    }
    let r0 = vec![0.0; material.states.len()];
    let mut rows = Vec::new();
    for (case, scale) in COMPARISON_CASES {
        let history = compare_history(material, scale);
        for dt in COMPARISON_STEPS_S {
            let reference = simulate(material, &history, &r0, dt, Integrator::Exact)?;
            let peak = reference
                .emission
                .iter()
                .flatten()
                .cloned()
                .fold(0.0f64, f64::max)
                .max(f64::MIN_POSITIVE);
            for (name, integ) in [
                ("exact", Integrator::Exact),
                ("rk4", Integrator::Rk4),
                ("euler", Integrator::Euler),
            ] {
                let start = std::time::Instant::now();
                let mut runs = 0u32;
                let sim = loop {
                    let sim = simulate(material, &history, &r0, dt, integ)?;
                    runs += 1;
                    if start.elapsed().as_secs_f64() > 0.02 || runs >= 1000 {
                        break sim;
                    }
                };
                let seconds = start.elapsed().as_secs_f64() / f64::from(runs);
                rows.push(IntegratorRow {
                    case,
                    integrator: name,
                    dt_s: dt,
                    seconds,
                    error: max_relative_error(&sim.emission, &reference.emission, peak),
                });
            }
        }
    }
    Ok(rows)
}

/// Header of the comparison table.
pub const INTEGRATORS_HEADER: &str = "case,integrator,dt_s,seconds_per_run,max_rel_error";

/// The comparison table as CSV.
pub fn integrators_csv(rows: &[IntegratorRow]) -> String {
    let mut csv = format!("{INTEGRATORS_HEADER}\n");
    for r in rows {
        csv.push_str(&format!(
            "{},{},{},{:.3e},{:.3e}\n",
            r.case, r.integrator, r.dt_s, r.seconds, r.error
        ));
    }
    csv
}

/// The chart series of the comparison: (run time, error) of RK4 and Euler per case.
pub fn integrator_chart_series(rows: &[IntegratorRow]) -> Vec<(String, Vec<(f64, f64)>)> {
    rows.chunk_by(|x, y| x.case == y.case)
        .flat_map(|case_rows| {
            ["rk4", "euler"].map(|name| {
                (
                    format!("{} {}", name, case_rows[0].case),
                    case_rows
                        .iter()
                        .filter(|r| r.integrator == name)
                        .map(|r| (r.seconds, r.error))
                        .collect::<Vec<_>>(),
                )
            })
        })
        .collect()
}

/// Relative deviation from 1 above which the Λ camera scale is applied before fitting k_e: the
/// decay fit determines its amplitudes to a fraction of a percent at 1 % noise, so a larger
/// factor is a units mismatch, not noise.
pub const LAMBDA_SCALE_TOLERANCE: f64 = 0.01;

/// An excitation fit with the material it produced.
#[derive(Debug, Clone)]
pub struct ExcitationResult {
    /// The fit.
    pub fit: ExcitationFit,
    /// The material with k_e (and Λ rescaled, when it was).
    pub updated: Material,
    /// The material fitted (Λ rescaled, when it was).
    pub material: Material,
    /// The Λ camera scale of the preset's decay fit, if the preset has one.
    pub lambda_scale: Option<f64>,
    /// The factor applied to Λ (when it differed from 1 by more than [`LAMBDA_SCALE_TOLERANCE`]).
    pub rescaled: Option<f64>,
}

/// Fits k_e. When the material comes from a `phos fit-decay` preset (`decay`), Λ is first
/// checked against that fit through `camera` ([`lambda_camera_scale`]: a `fit-decay --spectrum`
/// preset has Λ in units of the RGB fit's brightest channel, not the camera's) and rescaled
/// when it is off by more than [`LAMBDA_SCALE_TOLERANCE`].
pub fn excitation(
    material: &Material,
    decay: Option<&DecayFitRecord>,
    camera: &BandCamera,
    sources: &[(usize, Vec<f64>)],
    data: &[ChargingSample],
    opts: &ExcitationOptions,
) -> Result<ExcitationResult> {
    let lambda_scale = decay.and_then(|d| {
        if d.states.len() != material.states.len()
            || d.states.iter().any(|s| s.channel_amplitudes.len() != 3)
        {
            return None;
        }
        lambda_camera_scale(
            camera,
            material
                .states
                .iter()
                .zip(&d.states)
                .map(|(m, s)| (m.k_r_per_s, &m.lambda[..], &s.channel_amplitudes[..])),
        )
    });
    let rescaled = lambda_scale.filter(|s| (s - 1.0).abs() > LAMBDA_SCALE_TOLERANCE);
    let mut material = material.clone();
    if let Some(s) = rescaled {
        for st in &mut material.states {
            for l in &mut st.lambda {
                *l *= s;
            }
        }
    }
    let fit = fit_excitation(&material, camera, sources, data, opts)?;
    let updated = apply_excitation(&material, &fit);
    let k_e: Vec<f64> = updated
        .states
        .iter()
        .flat_map(|s| s.k_e.iter().flatten().chain(&s.lambda).copied())
        .collect();
    ensure_finite("the excitation fit (k_e, Λ)", "the charging data", &k_e)?;
    Ok(ExcitationResult {
        fit,
        updated,
        material,
        lambda_scale,
        rescaled,
    })
}

/// The report of an excitation fit (`extra.excitation_fit`).
pub fn excitation_report(
    r: &ExcitationResult,
    series: Option<serde_json::Value>,
) -> serde_json::Value {
    let fit = &r.fit;
    let mut report = serde_json::json!({
        "model": "Eq. 1 charged from dark under the unit-length source of each band, exact closed form; measured after the switch-off delay; k_e assumed constant over the source's support",
        "switch_off_delay_s": fit.switch_off_delay_s,
        "bands": fit.bands.iter().map(|b| serde_json::json!({
            "band": b.band + 1,
            "k_e": b.k_e,
            "k_e_sigma": b.k_e_sigma,
            "shared_by_states": b.shared,
            "sharing_reason": b.sharing_reason,
            "r_max": b.r_max,
            "product_only": b.product_only,
            "note": if b.product_only {
                format!("charging never approaches saturation (largest r = {:.3} < {}): only the product k_e·Λ is determined; k_e relies on the scale of Λ from the decay fit", b.r_max, SATURATION_MIN)
            } else {
                format!("charging reaches r = {:.3}: k_e and Λ are separable", b.r_max)
            },
            "equilibrium_rgb": b.equilibrium,
            "rms_weighted": b.rms,
            "iterations": b.iterations,
            "converged": b.converged,
            "residuals": b.data.iter().zip(&b.model).zip(&b.charge_s).map(|((d, m), t)| serde_json::json!({
                "charge_s": t, "rgb": d, "model": m,
            })).collect::<Vec<_>>(),
        })).collect::<Vec<_>>(),
    });
    if let Some(obj) = report.as_object_mut() {
        if let Some(sr) = series {
            obj.insert("series".into(), sr);
        }
        if let Some(s) = r.lambda_scale {
            obj.insert(
                "lambda_camera_scale".into(),
                serde_json::json!({
                    "factor": s,
                    "applied": r.rescaled.is_some(),
                    "note": "least-squares factor making camera·Λ_i·k_r,i equal the RGB amplitudes of the preset's decay fit (extra.decay_fit); applied to Λ when it differs from 1 by more than 1 %",
                }),
            );
        }
    }
    report
}

/// The fit quality of an excitation fit (provenance).
pub fn excitation_quality(fit: &ExcitationFit) -> serde_json::Value {
    let worst_rms = fit.bands.iter().fold(0.0_f64, |m, b| m.max(b.rms));
    serde_json::json!({
        "excitation_rms_max": worst_rms,
        "product_only_bands": fit.bands.iter().filter(|b| b.product_only).map(|b| b.band + 1).collect::<Vec<_>>(),
    })
}

/// The report of a design from keyframes (`extra.design`).
pub fn design_report(
    d: &Design,
    keys: &[Keyframe],
    albedo: [f64; 3],
    history_rows: usize,
    refined: bool,
) -> serde_json::Value {
    let mut sorted = keys.to_vec();
    sorted.sort_by(|x, y| x.t_s.total_cmp(&y.t_s));
    let stage = |s: &DesignStage| {
        serde_json::json!({
            "k_e": s.k_e, "k_r_per_s": s.k_r_per_s, "lambda": s.lambda, "cost_eq7": s.cost,
            "time_ms": s.time_s * 1e3,
            "keyframes": sorted.iter().zip(&s.predicted).zip(&s.relative_residual).map(|((k, p), r)| serde_json::json!({
                "time_s": k.t_s, "target": k.radiance, "designed": p, "relative_residual": r,
            })).collect::<Vec<_>>(),
        })
    };
    serde_json::json!({
        "method": "Eq. 7 with Λ projected out (closed-form non-negative least squares per channel); log-grid over k_e (3, plus 0) and k_r, then Levenberg–Marquardt on log-rates",
        "albedo": albedo,
        "history_rows": history_rows,
        "keyframes": keys.len(),
        "grid_candidates": d.grid_candidates,
        "grid": stage(&d.grid),
        "refined": if refined { stage(&d.refined) } else { serde_json::Value::Null },
        "reachable": d.reachable,
        "note": d.note,
    })
}

/// Side of a band's square patch in the synthetic charging images, in pixels.
pub const PATCH_PX: usize = 16;
/// Gap around and between the patches, in pixels.
const GAP_PX: usize = 8;
/// Dark level (black-level residual) of every synthetic pixel in 16-bit units (2 % of full
/// scale); written as `dark.tif` too. Whole units, so that subtracting `dark.tif` is exact.
pub const PEDESTAL_DN: u16 = 1311;
/// Exposures are chosen in full stops so that an image's brightest band mean lies in
/// (PEAK_TARGET/2, PEAK_TARGET] of full scale.
const PEAK_TARGET: f64 = 0.4;

/// The files of [`render_charging_images`].
#[derive(Debug, Clone)]
pub struct ChargingImages {
    /// (file name, bytes): the images, `dark.tif`, `manifest.csv`, `rois.csv`.
    pub files: Vec<(String, Vec<u8>)>,
    /// Number of images (one per charging time).
    pub images: usize,
    /// Image size in pixels.
    pub size: (usize, usize),
}

/// Renders charging samples as 16-bit linear TIFFs, one per charging time (every band a
/// `PATCH_PX`² patch side by side, as under the LVF), plus `manifest.csv`, `rois.csv` and
/// `dark.tif` — the input of `phos fit-excitation --series DIR/manifest.csv --rois DIR/rois.csv
/// --dark DIR/dark.tif`. Nothing is written; the caller stages the files.
///
/// A patch's pixels are `PEDESTAL_DN/65535 + f·(rgb + s_c·z)` with `f` the image's exposure factor
/// (exposure in full stops, ISO 100, f/1), `rgb` the sample, and `z` a zero-mean,
/// unit-variance pattern (Gaussian, made exact), scaled per channel so that the brightest
/// channel's standard error over the patch equals the sample's σ (`s_c = σ·√n·|rgb_c|/max|rgb|`,
/// at least one 16-bit unit so that rounding dithers).
/// Reading the patch back with the ROI from `rois.csv` and `--dark dark.tif` thus returns the
/// sample and its σ to within 16-bit quantisation.
pub fn render_charging_images(
    samples: &[ChargingSample],
    n_bands: usize,
    times: &[f64],
    seed: u64,
) -> Result<ChargingImages> {
    let w = n_bands * (PATCH_PX + GAP_PX) + GAP_PX;
    let h = PATCH_PX + 2 * GAP_PX;
    crate::limits::check_memory(
        "--charge-times",
        &format!("{} images of {w}×{h}", times.len()),
        (times.len() as u128 + 1) * (w * h * 3) as u128,
        8 + 2 + 2,
    )?;
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
        return Err(Error::invalid(
            "--images",
            "every sample is dark (no emission); nothing to render",
        ));
    }
    let mut files = Vec::with_capacity(times.len() + 3);
    let mut exposures = Vec::with_capacity(times.len());
    for (ti, &t) in times.iter().enumerate() {
        let peak = peak_of(t).max(1e-3 * global_peak);
        let exposure_s = 2f64.powf((PEAK_TARGET / peak).log2().floor());
        let mut px = vec![pedestal; 3 * w * h];
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
            return Err(Error::invalid(
                "--images",
                format!(
                    "charging time {t} s renders a pixel at {v:.3} of full scale, outside the \
                     16-bit range; lower --noise (the pattern's spread is σ·{PATCH_PX} per pixel)"
                ),
            ));
        }
        let q = px
            .iter()
            .map(|v| (v * 65535.0).round() as u16)
            .collect::<Vec<_>>();
        let name = format!("charge_{ti:03}.tif");
        files.push((name.clone(), encode_tiff16(w as u32, h as u32, &q)?));
        exposures.push((name, exposure_s));
    }
    let dark = vec![PEDESTAL_DN; 3 * w * h];
    files.push(("dark.tif".into(), encode_tiff16(w as u32, h as u32, &dark)?));
    let mut rows = Vec::new();
    for ((name, exposure_s), &t) in exposures.iter().zip(times) {
        for b in 0..n_bands {
            if samples.iter().any(|s| s.band == b && s.charge_s == t) {
                rows.push((name.clone(), b, t, *exposure_s));
            }
        }
    }
    let manifest = charging_manifest_csv(
        "lumifit synth phos-excitation --images: one image per charging time, one patch per band (rois.csv); subtract dark.tif",
        &rows,
    );
    files.push(("manifest.csv".into(), manifest.into_bytes()));
    let rois = BandRois(
        (0..n_bands)
            .map(|b| {
                (
                    b,
                    BandRoi {
                        roi: Roi::Rect {
                            x: GAP_PX + b * (PATCH_PX + GAP_PX),
                            y: GAP_PX,
                            w: PATCH_PX,
                            h: PATCH_PX,
                        },
                        origin: "synthetic".into(),
                    },
                )
            })
            .collect(),
    );
    files.push(("rois.csv".into(), rois.to_csv().into_bytes()));
    Ok(ChargingImages {
        files,
        images: times.len(),
        size: (w, h),
    })
}

/// `n` Gaussian draws shifted and scaled to mean exactly 0 and sample standard deviation
/// (n − 1 denominator, as [`crate::capture::roi_stats`]) exactly 1.
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
    use crate::phosphor::table1_material;

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
    fn the_lambda_scale_recovers_a_known_factor_and_refuses_a_blind_camera() {
        let cam = BandCamera::for_bands(&BandSet::Rgb, None).unwrap();
        let lambda = [0.5, 0.25, 0.125];
        let k = 0.2;
        let model = cam.rgb(&lambda.map(|l| l * k));
        let amps: Vec<f64> = model.iter().map(|m| 3.5 * m).collect();
        let s = lambda_camera_scale(&cam, [(k, &lambda[..], &amps[..])]).unwrap();
        // one least-squares ratio of sums: rounding only
        assert!((s - 3.5).abs() < 1e-12, "{s}");
        let zero = [0.0; 3];
        assert_eq!(lambda_camera_scale(&cam, [(k, &zero[..], &amps[..])]), None);
    }

    #[test]
    fn the_integrator_comparison_has_every_case_step_and_integrator() {
        let m = &table1_material("green_paint").unwrap().material;
        let rows = compare_integrators(m).unwrap();
        assert_eq!(rows.len(), 2 * 6 * 3);
        assert!(rows
            .iter()
            .filter(|r| r.integrator == "exact")
            .all(|r| r.error == 0.0));
        let csv = integrators_csv(&rows);
        assert_eq!(csv.lines().count(), 1 + rows.len());
        assert_eq!(integrator_chart_series(&rows).len(), 4);
    }
}
