//! Excitation and design (`lumifit phos fit-excitation`, `lumifit phos design`, `lumifit synth
//! phos-excitation`; Nalbach et al. 2017 §4.6 and §6): what each command does between its flags
//! and its printed line — resolve the material, read the charging data (a CSV or a photo series),
//! the source spectra and the camera, fit k_e or design from keyframes, assemble the preset and
//! the chart, and stage every output in the caller's [`Outputs`]. The caller commits and prints.
//!
//! Warnings go to the caller's `warn` as whole lines (the binary writes them to standard error),
//! at the moment they arise, so that a later error does not hide them.

use std::path::{Path, PathBuf};

use serde_json::Value;

use crate::error::{Error, Result};
use crate::io::phos_formats::{
    box_camera_csv, parse_band_camera, read_band_camera, ChargingCsv, DesignHistoryCsv,
    KeyframesCsv, SourceSpectraCsv,
};
use crate::io::series::{charging_series_inputs, load_charging_series, RoiSource};
use crate::io::Outputs;
use crate::phosphor::design::{design_from_keyframes, DesignOptions};
use crate::phosphor::excitation::{synth_charging, ExcitationOptions, StateSharing};
use crate::phosphor::{BandSet, DecayCharging, Material};
use crate::pipeline::phos as pipe;
use crate::plot::phosphor_sim::{design_chart_png, DesignChart};
use crate::preset::phosphor::{
    design_preset, excitation_preset, provenance_of_files, resolve_material, DecayFitRecord,
};
use crate::preset::to_json_string;

/// The wavelength bands of `m`; RGB bands are refused with the measurement that is missing.
pub fn wavelength_ranges(m: &Material) -> Result<&[[f64; 2]]> {
    match &m.bands {
        BandSet::RangesNm(r) => Ok(r),
        BandSet::Rgb => Err(Error::message(format!(
            "material '{}' has RGB bands (a `phos fit-decay` preset made without --spectrum); \
             charging experiments need wavelength bands ([[lo_nm, hi_nm], …]) to integrate the \
             source spectra over. The missing measurement is the glow's emission spectrum: \
             photograph the glowing sample through the LVF and recover it (`lumifit spectrum \
             recover GLOW.tiff --bands lvf.json --out emission.csv`), then refit the decay with \
             `lumifit phos fit-decay CURVE --spectrum emission.csv --bands 8 [--camera cam.csv] \
             --out material.json` (docs/phosphorescence.md, \"From RGB bands to wavelength bands\")",
            m.name
        ))),
    }
}

/// The regions of a charging photo series.
#[derive(Debug, Clone)]
pub enum SeriesRois {
    /// `--roi x,y,w,h` for every band.
    One(String),
    /// `--rois FILE.csv` with `band,x,y,w,h`.
    PerBand(PathBuf),
}

impl SeriesRois {
    fn source(&self) -> RoiSource<'_> {
        match self {
            SeriesRois::One(r) => RoiSource::One(r),
            SeriesRois::PerBand(f) => RoiSource::PerBand(f),
        }
    }
}

/// Where the charging samples come from.
#[derive(Debug, Clone)]
pub enum ChargingInput {
    /// `--data FILE.csv` (`band,charge_s,r,g,b[,std]`).
    Csv(PathBuf),
    /// `--series MANIFEST.csv` measured in regions, with dark frames subtracted.
    Series {
        /// The manifest.
        manifest: PathBuf,
        /// The regions.
        rois: SeriesRois,
        /// Dark frames (averaged).
        dark: Vec<PathBuf>,
    },
}

/// `phos fit-excitation`: k_e per band from charging experiments.
#[derive(Debug, Clone)]
pub struct FitExcitationJob {
    /// Material preset JSON with k_r and Λ, or a Table 1 name.
    pub material: String,
    /// The charging data.
    pub data: ChargingInput,
    /// Source spectra CSV (one column per band).
    pub source: PathBuf,
    /// Camera sensitivities CSV.
    pub camera: PathBuf,
    /// Delay between switch-off and measurement, s.
    pub switch_off_delay_s: f64,
    /// k_e shared by the states or per state.
    pub sharing: StateSharing,
    /// Output material preset JSON.
    pub out: PathBuf,
    /// Chart PNG.
    pub plot: Option<PathBuf>,
}

/// Registers every file read, declares the preset (and chart), fits, stages them and returns
/// the report to print.
pub fn run_fit_excitation(
    job: &FitExcitationJob,
    out: &mut Outputs,
    warn: &mut dyn FnMut(String),
) -> Result<Value> {
    let resolved = resolve_material(&job.material)?;
    let ranges = wavelength_ranges(&resolved.material)?.to_vec();
    let n_bands = ranges.len();
    // Every file read is registered before any output is declared.
    let data_files = match &job.data {
        ChargingInput::Csv(d) => vec![d.clone()],
        ChargingInput::Series {
            manifest,
            rois,
            dark,
        } => charging_series_inputs(manifest, &rois.source(), dark, n_bands)?,
    };
    out.inputs(resolved.path())
        .inputs(&data_files)
        .input(&job.source)
        .input(&job.camera);
    out.declare("--out", &job.out)?;
    if let Some(p) = &job.plot {
        out.declare("--plot", p)?;
    }
    let decay = match &resolved.preset {
        Some((p, preset)) => DecayFitRecord::from_preset(preset, &p.display().to_string())?,
        None => None,
    };
    let (data, data_path, series_report) = match &job.data {
        ChargingInput::Csv(d) => (ChargingCsv::read(d, n_bands)?, d.clone(), None),
        ChargingInput::Series {
            manifest,
            rois,
            dark,
        } => {
            let s = load_charging_series(manifest, rois.source(), dark, n_bands)?;
            for w in &s.warnings {
                warn(format!("warning: {w}"));
            }
            (s.samples, manifest.clone(), Some(s.report))
        }
    };
    let mut bands: Vec<usize> = data.iter().map(|s| s.band).collect();
    bands.sort_unstable();
    bands.dedup();
    let sources = SourceSpectraCsv::read(&job.source)?.unit_irradiance(&ranges, &bands)?;
    let camera = read_band_camera(&job.camera, &resolved.material.bands)?;
    let decay_charging = decay_charging_of(decay.as_ref(), &job.material, warn);
    let opts = ExcitationOptions {
        decay_charging,
        switch_off_delay_s: job.switch_off_delay_s,
        sharing: job.sharing,
        ..ExcitationOptions::default()
    };
    let r = pipe::excitation(
        &resolved.material,
        decay.as_ref(),
        &camera,
        &sources,
        &data,
        &opts,
    )
    .map_err(|e| e.context(format!("{}: excitation fit", data_path.display())))?;
    if let Some(s) = r.rescaled {
        warn(format!(
            "warning: {}: camera·Λ·k_r does not reproduce the preset's own decay fit through {} \
             (Λ off by a factor {:.4}); Λ rescaled by {s:.6} before fitting k_e",
            job.material,
            job.camera.display(),
            1.0 / s
        ));
    }
    let report = pipe::excitation_report(&r, series_report);
    // Provenance: the material, the data files (with --series every image), source, camera.
    let mut files: Vec<PathBuf> = resolved.path().map(Path::to_path_buf).into_iter().collect();
    files.extend(data_files);
    files.extend([job.source.clone(), job.camera.clone()]);
    let provenance = provenance_of_files("lumifit phos fit-excitation", &files)?
        .with_fit_quality(pipe::excitation_quality(&r.fit));
    let base = resolved.preset.map(|(_, p)| p);
    let preset = excitation_preset(
        base,
        &r.updated,
        &ranges,
        // Λ changed: rescaled to the camera, or divided by the decay measurement's r(0).
        r.rescaled.is_some() || r.fit.decay_state.is_some(),
        provenance,
        report.clone(),
    );
    out.stage_text(&job.out, &to_json_string(&preset)?)?;
    if let Some(p) = &job.plot {
        let title = format!("{}: excitation fit", r.material.name);
        let png = crate::plot::excitation_chart_png(&title, &r.material, &camera, &r.fit)?;
        out.stage(p, &png)?;
    }
    Ok(report)
}

/// The charging protocol of the decay measurement behind the preset's Λ: a material without a
/// decay-fit record (Table 1, designed) has exact Λ; a record without a protocol (older
/// presets) or with an unknown one is read as saturated, with a warning.
pub fn decay_charging_of(
    decay: Option<&DecayFitRecord>,
    material: &str,
    warn: &mut dyn FnMut(String),
) -> DecayCharging {
    let Some(d) = decay else {
        return DecayCharging::Saturated;
    };
    match &d.charging {
        Some(DecayCharging::Unknown) | None => {
            warn(format!(
                "WARNING: {material}: the decay fit does not know how the sample was charged, so its \
                 Λ assumes saturation (r = 1) at switch-off; if the sample was not saturated, Λ is \
                 too low and k_e comes out too high. Refit the decay with phos fit-decay \
                 --saturated or --charge-s S [--charge-irradiance E]."
            ));
            DecayCharging::Saturated
        }
        Some(c) => c.clone(),
    }
}

/// `--charge-times a,b,c`: at least two charging times ≥ 0 s.
pub fn parse_charge_times(s: &str) -> Result<Vec<f64>> {
    let flag = "--charge-times";
    let mut out = Vec::new();
    for (i, p) in s.split(',').map(str::trim).enumerate() {
        let v: f64 = p
            .parse()
            .map_err(|_| Error::flag(flag, format!("entry {} '{p}' is not a number", i + 1)))?;
        if !(v.is_finite() && v >= 0.0) {
            return Err(Error::flag(
                flag,
                format!("entry {} is {v}; expected charging times ≥ 0 s", i + 1),
            ));
        }
        out.push(v);
    }
    if out.len() < 2 {
        return Err(Error::flag(
            flag,
            format!("expected at least two times, got '{s}'"),
        ));
    }
    Ok(out)
}

/// `<stem>.<suffix>` beside `out`.
fn sibling(out: &Path, suffix: &str) -> PathBuf {
    let stem = out
        .file_stem()
        .map_or("charging".into(), |s| s.to_string_lossy().to_string());
    out.with_file_name(format!("{stem}.{suffix}"))
}

/// `synth phos-excitation`: charging data from the exact simulation.
#[derive(Debug, Clone)]
pub struct SynthExcitationJob {
    /// A Table 1 name or a material preset JSON (with k_e).
    pub material: String,
    /// Number of excitation bands (the first N of the material).
    pub bands: usize,
    /// `--charge-times` as typed.
    pub charge_times: String,
    /// Delay between switch-off and measurement, s.
    pub switch_off_delay_s: f64,
    /// Relative noise.
    pub noise: f64,
    /// Camera CSV (default: the ideal box camera, written beside the output).
    pub camera: Option<PathBuf>,
    /// Noise seed.
    pub seed: u64,
    /// Output CSV.
    pub out: PathBuf,
    /// Folder for the same samples rendered as photographs.
    pub images: Option<PathBuf>,
}

/// Registers the inputs, declares the CSV, its source and camera CSVs (and the image folder),
/// simulates, stages them and returns the line to print.
pub fn run_synth_excitation(job: &SynthExcitationJob, out: &mut Outputs) -> Result<String> {
    let resolved = resolve_material(&job.material)?;
    let ranges = wavelength_ranges(&resolved.material)?.to_vec();
    if job.bands == 0 || job.bands > ranges.len() {
        return Err(Error::flag(
            format!("--bands {}", job.bands),
            format!("expected 1 to {} (the material's bands)", ranges.len()),
        ));
    }
    let times = parse_charge_times(&job.charge_times)?;
    if job.images.is_some() {
        let mut sorted = times.clone();
        sorted.sort_by(f64::total_cmp);
        if let Some(w) = sorted.windows(2).find(|w| w[0] == w[1]) {
            return Err(Error::flag(
                "--charge-times",
                format!(
                    "{} s is listed twice; with --images every charging time is one \
                     image, so the times must differ",
                    w[0]
                ),
            ));
        }
    }
    let src_path = sibling(&job.out, "source.csv");
    let cam_path = job
        .camera
        .clone()
        .unwrap_or_else(|| sibling(&job.out, "camera.csv"));
    out.inputs(resolved.path()).inputs(&job.camera);
    out.declare("--out", &job.out)?;
    out.declare("--out (source spectra beside it)", &src_path)?;
    if job.camera.is_none() {
        out.declare("--out (camera beside it)", &cam_path)?;
    }
    if let Some(dir) = &job.images {
        out.declare_dir("--images", dir)?;
    }
    // Box sources, one per band, with sharp edges; the camera as written. Both are read back
    // from the bytes that are written, so the data are those of the files beside the output.
    let src_csv = SourceSpectraCsv::boxes(&ranges, job.bands).to_csv();
    let src_name = src_path.display().to_string();
    let bands: Vec<usize> = (0..job.bands).collect();
    let sources =
        SourceSpectraCsv::parse(src_csv.as_bytes(), &src_name)?.unit_irradiance(&ranges, &bands)?;
    let camera = match &job.camera {
        Some(p) => read_band_camera(p, &resolved.material.bands)?,
        None => parse_band_camera(
            box_camera_csv().as_bytes(),
            &cam_path.display().to_string(),
            &resolved.material.bands,
        )?,
    };
    let samples = synth_charging(
        &resolved.material,
        &camera,
        &sources,
        &times,
        job.switch_off_delay_s,
        job.noise,
        job.seed,
    )?;
    let rendered = match &job.images {
        Some(dir) => {
            let r = pipe::render_charging_images(&samples, job.bands, &times, job.seed)
                .map_err(|e| e.context(format!("rendering images into {}", dir.display())))?;
            for (name, bytes) in &r.files {
                out.stage(dir.join(name), bytes)?;
            }
            Some((dir, r))
        }
        None => None,
    };
    out.stage_text(&src_path, &src_csv)?;
    if job.camera.is_none() {
        out.stage_text(&cam_path, &box_camera_csv())?;
    }
    let data = ChargingCsv { samples };
    out.stage_text(&job.out, &data.to_csv())?;
    let images = match &rendered {
        Some((dir, r)) => format!(
            "; {} images of {}×{} pixels (patches of {} px, dark level {} of 65535) with \
             manifest.csv, rois.csv and dark.tif in {}",
            r.images,
            r.size.0,
            r.size.1,
            pipe::PATCH_PX,
            pipe::PEDESTAL_DN,
            dir.display()
        ),
        None => String::new(),
    };
    Ok(format!(
        "wrote {} samples ({} bands × {} charge times) of {} to {}, sources to {}, camera {}{images}",
        data.samples.len(),
        job.bands,
        times.len(),
        resolved.material.name,
        job.out.display(),
        src_path.display(),
        cam_path.display()
    ))
}

/// `phos design`: a one-state RGB material from keyframes of outgoing radiance.
#[derive(Debug, Clone)]
pub struct DesignJob {
    /// Irradiance history CSV.
    pub history: PathBuf,
    /// Keyframe targets CSV.
    pub targets: PathBuf,
    /// `--albedo r,g,b` as typed.
    pub albedo: String,
    /// Grid points per rate dimension.
    pub grid_points: usize,
    /// Report the grid optimum only.
    pub grid_only: bool,
    /// Material name written into the preset.
    pub name: String,
    /// Output material preset JSON.
    pub out: PathBuf,
    /// Chart PNG.
    pub plot: Option<PathBuf>,
}

/// Registers the history and targets, declares the preset (and chart), designs, stages them
/// and returns the report to print.
pub fn run_design(
    job: &DesignJob,
    out: &mut Outputs,
    warn: &mut dyn FnMut(String),
) -> Result<Value> {
    let albedo = crate::io::flags::parse_triplet("--albedo", &job.albedo)?;
    if albedo.iter().any(|v| *v < 0.0) {
        return Err(Error::flag(
            "--albedo",
            format!("{:?}; expected values ≥ 0", albedo),
        ));
    }
    out.input(&job.history).input(&job.targets);
    out.declare("--out", &job.out)?;
    if let Some(p) = &job.plot {
        out.declare("--plot", p)?;
    }
    let (hist, deprecation) = DesignHistoryCsv::read(&job.history)?;
    if let Some(w) = deprecation {
        warn(format!("warning: {w}"));
    }
    let keys = KeyframesCsv::read(&job.targets, &hist, &job.history.display().to_string())?;
    let opts = DesignOptions {
        albedo,
        grid_points: job.grid_points,
        refine: !job.grid_only,
    };
    let d = design_from_keyframes(&hist, &keys, &opts)?;
    if let Some(p) = &job.plot {
        let chart = DesignChart {
            name: &job.name,
            history: &hist,
            keyframes: &keys,
            albedo,
            design: &d,
            refined: !job.grid_only,
        };
        let png =
            design_chart_png(&chart).map_err(|e| e.context(format!("--plot {}", p.display())))?;
        out.stage(p, &png)?;
    }
    let report = pipe::design_report(&d, &keys, albedo, hist.t_s.len(), !job.grid_only);
    let fin = &d.refined;
    let worst = fin.relative_residual.iter().fold(0.0_f64, |m, v| m.max(*v));
    let provenance = provenance_of_files("lumifit phos design", &[&job.history, &job.targets])?
        .with_fit_quality(
            serde_json::json!({"worst_keyframe_relative_residual": worst, "reachable": d.reachable}),
        );
    let preset = design_preset(
        &job.name,
        provenance,
        fin.k_r_per_s,
        fin.k_e,
        fin.lambda,
        report.clone(),
    );
    out.stage_text(&job.out, &to_json_string(&preset)?)?;
    Ok(report)
}
