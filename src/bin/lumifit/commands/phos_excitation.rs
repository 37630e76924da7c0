//! `lumifit phos fit-excitation`, `lumifit phos design` and `lumifit synth phos-excitation`:
//! excitation rates from charging experiments (Nalbach et al. 2017 §4.6) and materials designed
//! from keyframes (§6).

use std::path::{Path, PathBuf};

use anyhow::{anyhow, bail, Context, Result};
use clap::{ArgGroup, Args, Subcommand, ValueEnum};
use lumifit::io::phos_formats::{
    box_camera_csv, parse_band_camera, read_band_camera, ChargingCsv, DesignHistoryCsv,
    KeyframesCsv, SourceSpectraCsv,
};
use lumifit::io::series::{charging_series_inputs, load_charging_series, RoiSource};
use lumifit::io::Outputs;
use lumifit::phosphor::design::{design_from_keyframes, DesignOptions};
use lumifit::phosphor::excitation::{synth_charging, ExcitationOptions, StateSharing};
use lumifit::phosphor::{BandSet, DecayCharging, Material};
use lumifit::pipeline::phos as pipe;
use lumifit::plot::phosphor_sim::{design_chart_png, DesignChart};
use lumifit::preset::phosphor::{
    design_preset, excitation_preset, provenance_of_files, DecayFitRecord,
};
use lumifit::preset::to_json_string;

use super::phos::resolve_material;

/// Excitation-rate fitting and design from keyframes (flattened into `lumifit phos`).
#[derive(Debug, Subcommand)]
pub enum PhosExcitationCommand {
    /// Fit excitation rates k_e per band from charging experiments; adds k_e to the preset.
    FitExcitation(FitExcitationArgs),
    /// Design a one-state RGB material from keyframes of outgoing radiance (§6, Eq. 7).
    Design(DesignArgs),
}

/// Charging-experiment generators (flattened into `lumifit synth`).
#[derive(Debug, Subcommand)]
pub enum SynthExcitationCommand {
    /// Charging data `band,charge_s,r,g,b,std` from the exact simulation (plus the source and
    /// camera CSVs it used, beside the output).
    PhosExcitation(SynthExcitationArgs),
}

/// Sharing of k_e between states.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum SharingArg {
    /// Per state only when the charging curves identify it.
    Auto,
    /// One k_e per band for all states.
    Shared,
    /// One k_e per band and state.
    PerState,
}

/// `lumifit phos fit-excitation`.
#[derive(Debug, Args)]
#[command(group(ArgGroup::new("charging").required(true).args(["data", "series"])))]
#[command(group(ArgGroup::new("series_rois").args(["roi", "rois"])))]
pub struct FitExcitationArgs {
    /// Material preset JSON with k_r and Λ from the decay fit (or a Table 1 name).
    #[arg(long)]
    pub material: String,
    /// Charging data CSV `band,charge_s,r,g,b[,std]` (band 1-based).
    #[arg(long)]
    pub data: Option<PathBuf>,
    /// Instead of --data: photographs listed in a manifest CSV
    /// `image,band,charge_s[,exposure_s,iso,f_number]` (paths relative to the manifest; RAW,
    /// 16-bit TIFF/PNG, float TIFF/EXR), measured in --roi or --rois.
    #[arg(long, requires = "series_rois")]
    pub series: Option<PathBuf>,
    /// With --series: one region `x,y,w,h` (source pixels) for every band.
    #[arg(long, requires = "series")]
    pub roi: Option<String>,
    /// With --series: regions per band, CSV `band,x,y,w,h` (one ROI per band under the LVF).
    #[arg(long, requires = "series")]
    pub rois: Option<PathBuf>,
    /// With --series: dark frame(s), averaged and subtracted from every image.
    #[arg(long, requires = "series")]
    pub dark: Vec<PathBuf>,
    /// Source spectra CSV `wavelength_nm,band1,band2,…` (one column per excitation band).
    #[arg(long)]
    pub source: PathBuf,
    /// Camera sensitivities CSV `wavelength_nm,r,g,b`.
    #[arg(long)]
    pub camera: PathBuf,
    /// Delay between switch-off and measurement in s.
    #[arg(long, default_value_t = 0.6)]
    pub switch_off_delay_s: f64,
    /// k_e shared by the states or per state.
    #[arg(long, value_enum, default_value_t = SharingArg::Auto)]
    pub states: SharingArg,
    /// Output material preset JSON.
    #[arg(long)]
    pub out: PathBuf,
    /// Plot PNG: per band, data, simulated charging curve and equilibrium level.
    #[arg(long)]
    pub plot: Option<PathBuf>,
}

/// `lumifit phos design`.
#[derive(Debug, Args)]
pub struct DesignArgs {
    /// Irradiance history CSV `time_s,e_r,e_g,e_b` (constant from each row's time to the next,
    /// the last row holds on); the same file feeds `phos simulate`, which ends at the last row.
    #[arg(long)]
    pub history: PathBuf,
    /// Keyframe targets CSV `time_s,l_r,l_g,l_b` (outgoing radiance = albedo·E/π + L_p).
    #[arg(long)]
    pub targets: PathBuf,
    /// Albedo per channel `r,g,b`.
    #[arg(long, default_value = "0,0,0")]
    pub albedo: String,
    /// Grid points per rate dimension.
    #[arg(long, default_value_t = 6)]
    pub grid_points: usize,
    /// Report the grid optimum only (no least-squares refinement).
    #[arg(long)]
    pub grid_only: bool,
    /// Material name written into the preset.
    #[arg(long, default_value = "designed")]
    pub name: String,
    /// Output material preset JSON.
    #[arg(long)]
    pub out: PathBuf,
    /// Plot PNG: irradiance history, designed outgoing radiance per channel (grid optimum
    /// dashed), targets at the keyframes and every keyframe's residual.
    #[arg(long)]
    pub plot: Option<PathBuf>,
}

/// `lumifit synth phos-excitation`.
#[derive(Debug, Args)]
pub struct SynthExcitationArgs {
    /// A Table 1 material name or a material preset JSON file (with k_e).
    #[arg(long)]
    pub material: String,
    /// Number of excitation bands (the first N bands of the material).
    #[arg(long, default_value_t = 3)]
    pub bands: usize,
    /// Charging times in s, comma-separated.
    #[arg(long, default_value = "1,2,4,8,16,32,64,128,256,512")]
    pub charge_times: String,
    /// Delay between switch-off and measurement in s.
    #[arg(long, default_value_t = 0.6)]
    pub switch_off_delay_s: f64,
    /// Relative noise (0.01 = 1 %).
    #[arg(long, default_value_t = 0.01)]
    pub noise: f64,
    /// Camera sensitivities CSV `wavelength_nm,r,g,b` (default: an ideal box camera, written
    /// beside the output as `<out>.camera.csv`).
    #[arg(long)]
    pub camera: Option<PathBuf>,
    /// Seed of the noise generator.
    #[arg(long)]
    pub seed: u64,
    /// Output CSV; `<stem>.source.csv` (and `<stem>.camera.csv`) are written beside it.
    #[arg(long)]
    pub out: PathBuf,
    /// Also render the same samples as photographs into this folder: one 16-bit TIFF per
    /// charging time with one patch per band (as under the LVF), `manifest.csv`, `rois.csv` and
    /// `dark.tif` — the input of `phos fit-excitation --series DIR/manifest.csv --rois
    /// DIR/rois.csv --dark DIR/dark.tif`.
    #[arg(long)]
    pub images: Option<PathBuf>,
}

/// Runs a `lumifit phos` excitation/design subcommand.
pub fn run(cmd: PhosExcitationCommand) -> Result<()> {
    match cmd {
        PhosExcitationCommand::FitExcitation(a) => fit_cmd(&a),
        PhosExcitationCommand::Design(a) => design_cmd(&a),
    }
}

/// Runs a `lumifit synth` charging-experiment generator.
pub fn run_synth(cmd: SynthExcitationCommand) -> Result<()> {
    match cmd {
        SynthExcitationCommand::PhosExcitation(a) => synth_cmd(&a),
    }
}

fn wavelength_ranges(m: &Material) -> Result<&[[f64; 2]]> {
    match &m.bands {
        BandSet::RangesNm(r) => Ok(r),
        BandSet::Rgb => bail!(
            "material '{}' has RGB bands (a `phos fit-decay` preset made without --spectrum); \
             charging experiments need wavelength bands ([[lo_nm, hi_nm], …]) to integrate the \
             source spectra over. The missing measurement is the glow's emission spectrum: \
             photograph the glowing sample through the LVF and recover it (`lumifit spectrum \
             recover GLOW.tiff --bands lvf.json --out emission.csv`), then refit the decay with \
             `lumifit phos fit-decay CURVE --spectrum emission.csv --bands 8 [--camera cam.csv] \
             --out material.json` (docs/phosphorescence.md, \"From RGB bands to wavelength bands\")",
            m.name
        ),
    }
}

fn fit_cmd(a: &FitExcitationArgs) -> Result<()> {
    let resolved = resolve_material(&a.material)?;
    let ranges = wavelength_ranges(&resolved.material)?.to_vec();
    let n_bands = ranges.len();
    let rois = match (&a.roi, &a.rois) {
        (Some(r), None) => Some(RoiSource::One(r)),
        (None, Some(f)) => Some(RoiSource::PerBand(f)),
        _ => None,
    };
    // Every file read is registered before any output is declared.
    let data_files = match (&a.data, &a.series) {
        (Some(d), None) => vec![d.clone()],
        (None, Some(m)) => {
            let Some(r) = &rois else {
                bail!("--series needs either --roi x,y,w,h or --rois FILE.csv");
            };
            charging_series_inputs(m, r, &a.dark, n_bands)?
        }
        _ => bail!("give the charging data either as --data FILE.csv or as --series MANIFEST.csv"),
    };
    let mut out = Outputs::new();
    out.inputs(resolved.path())
        .inputs(&data_files)
        .input(&a.source)
        .input(&a.camera);
    out.declare("--out", &a.out)?;
    if let Some(p) = &a.plot {
        out.declare("--plot", p)?;
    }
    let decay = match &resolved.preset {
        Some((p, preset)) => DecayFitRecord::from_preset(preset, &p.display().to_string())?,
        None => None,
    };
    let (data, data_path, series_report) = match (&a.data, &a.series, rois) {
        (Some(d), None, _) => (ChargingCsv::read(d, n_bands)?, d.clone(), None),
        (None, Some(m), Some(r)) => {
            let s = load_charging_series(m, r, &a.dark, n_bands)?;
            for w in &s.warnings {
                eprintln!("warning: {w}");
            }
            (s.samples, m.clone(), Some(s.report))
        }
        _ => bail!("give the charging data either as --data FILE.csv or as --series MANIFEST.csv"),
    };
    let mut bands: Vec<usize> = data.iter().map(|s| s.band).collect();
    bands.sort_unstable();
    bands.dedup();
    let sources = SourceSpectraCsv::read(&a.source)?.unit_irradiance(&ranges, &bands)?;
    let camera = read_band_camera(&a.camera, &resolved.material.bands)?;
    let decay_charging = decay_charging_of(decay.as_ref(), &a.material);
    let opts = ExcitationOptions {
        decay_charging,
        switch_off_delay_s: a.switch_off_delay_s,
        sharing: match a.states {
            SharingArg::Auto => StateSharing::Auto,
            SharingArg::Shared => StateSharing::Shared,
            SharingArg::PerState => StateSharing::PerState,
        },
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
    .with_context(|| format!("{}: excitation fit", data_path.display()))?;
    if let Some(s) = r.rescaled {
        eprintln!(
            "warning: {}: camera·Λ·k_r does not reproduce the preset's own decay fit through {} \
             (Λ off by a factor {:.4}); Λ rescaled by {s:.6} before fitting k_e",
            a.material,
            a.camera.display(),
            1.0 / s
        );
    }
    let report = pipe::excitation_report(&r, series_report);
    // Provenance: the material, the data files (with --series every image), source, camera.
    let mut files: Vec<PathBuf> = resolved.path().map(Path::to_path_buf).into_iter().collect();
    files.extend(data_files);
    files.extend([a.source.clone(), a.camera.clone()]);
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
    out.stage_text(&a.out, &to_json_string(&preset)?)?;
    if let Some(p) = &a.plot {
        let title = format!("{}: excitation fit", r.material.name);
        let png = lumifit::plot::excitation_chart_png(&title, &r.material, &camera, &r.fit)?;
        out.stage(p, &png)?;
    }
    out.commit()?;
    super::emit(&serde_json::to_string_pretty(&report)?)
}

/// The charging protocol of the decay measurement behind the preset's Λ: a material without a
/// decay-fit record (Table 1, designed) has exact Λ; a record without a protocol (older
/// presets) or with an unknown one is read as saturated, with a warning.
fn decay_charging_of(decay: Option<&DecayFitRecord>, material: &str) -> DecayCharging {
    let Some(d) = decay else {
        return DecayCharging::Saturated;
    };
    match &d.charging {
        Some(DecayCharging::Unknown) | None => {
            eprintln!(
                "WARNING: {material}: the decay fit does not know how the sample was charged, so its \
                 Λ assumes saturation (r = 1) at switch-off; if the sample was not saturated, Λ is \
                 too low and k_e comes out too high. Refit the decay with phos fit-decay \
                 --saturated or --charge-s S [--charge-irradiance E]."
            );
            DecayCharging::Saturated
        }
        Some(c) => c.clone(),
    }
}

fn parse_times(s: &str) -> Result<Vec<f64>> {
    let mut out = Vec::new();
    for (i, p) in s.split(',').map(str::trim).enumerate() {
        let v: f64 = p
            .parse()
            .map_err(|_| anyhow!("--charge-times: entry {} '{p}' is not a number", i + 1))?;
        if !(v.is_finite() && v >= 0.0) {
            bail!(
                "--charge-times: entry {} is {v}; expected charging times ≥ 0 s",
                i + 1
            );
        }
        out.push(v);
    }
    if out.len() < 2 {
        bail!("--charge-times: expected at least two times, got '{s}'");
    }
    Ok(out)
}

fn sibling(out: &Path, suffix: &str) -> PathBuf {
    let stem = out
        .file_stem()
        .map_or("charging".into(), |s| s.to_string_lossy().to_string());
    out.with_file_name(format!("{stem}.{suffix}"))
}

fn synth_cmd(a: &SynthExcitationArgs) -> Result<()> {
    let resolved = resolve_material(&a.material)?;
    let ranges = wavelength_ranges(&resolved.material)?.to_vec();
    if a.bands == 0 || a.bands > ranges.len() {
        bail!(
            "--bands {}: expected 1 to {} (the material's bands)",
            a.bands,
            ranges.len()
        );
    }
    let times = parse_times(&a.charge_times)?;
    if a.images.is_some() {
        let mut sorted = times.clone();
        sorted.sort_by(f64::total_cmp);
        if let Some(w) = sorted.windows(2).find(|w| w[0] == w[1]) {
            bail!(
                "--charge-times: {} s is listed twice; with --images every charging time is one \
                 image, so the times must differ",
                w[0]
            );
        }
    }
    let src_path = sibling(&a.out, "source.csv");
    let cam_path = a
        .camera
        .clone()
        .unwrap_or_else(|| sibling(&a.out, "camera.csv"));
    let mut out = Outputs::new();
    out.inputs(resolved.path()).inputs(&a.camera);
    out.declare("--out", &a.out)?;
    out.declare("--out (source spectra beside it)", &src_path)?;
    if a.camera.is_none() {
        out.declare("--out (camera beside it)", &cam_path)?;
    }
    if let Some(dir) = &a.images {
        out.declare_dir("--images", dir)?;
    }
    // Box sources, one per band, with sharp edges; the camera as written. Both are read back
    // from the bytes that are written, so the data are those of the files beside the output.
    let src_csv = SourceSpectraCsv::boxes(&ranges, a.bands).to_csv();
    let src_name = src_path.display().to_string();
    let bands: Vec<usize> = (0..a.bands).collect();
    let sources =
        SourceSpectraCsv::parse(src_csv.as_bytes(), &src_name)?.unit_irradiance(&ranges, &bands)?;
    let camera = match &a.camera {
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
        a.switch_off_delay_s,
        a.noise,
        a.seed,
    )?;
    let rendered = match &a.images {
        Some(dir) => {
            let r = pipe::render_charging_images(&samples, a.bands, &times, a.seed)
                .with_context(|| format!("rendering images into {}", dir.display()))?;
            for (name, bytes) in &r.files {
                out.stage(dir.join(name), bytes)?;
            }
            Some((dir, r))
        }
        None => None,
    };
    out.stage_text(&src_path, &src_csv)?;
    if a.camera.is_none() {
        out.stage_text(&cam_path, &box_camera_csv())?;
    }
    let data = ChargingCsv { samples };
    out.stage_text(&a.out, &data.to_csv())?;
    out.commit()?;
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
    super::emit(&format!(
        "wrote {} samples ({} bands × {} charge times) of {} to {}, sources to {}, camera {}{images}",
        data.samples.len(),
        a.bands,
        times.len(),
        resolved.material.name,
        a.out.display(),
        src_path.display(),
        cam_path.display()
    ))
}

fn design_cmd(a: &DesignArgs) -> Result<()> {
    let albedo = super::parse_triplet("--albedo", &a.albedo)?;
    if albedo.iter().any(|v| *v < 0.0) {
        bail!("--albedo: {:?}; expected values ≥ 0", albedo);
    }
    let mut out = Outputs::new();
    out.input(&a.history).input(&a.targets);
    out.declare("--out", &a.out)?;
    if let Some(p) = &a.plot {
        out.declare("--plot", p)?;
    }
    let (hist, deprecation) = DesignHistoryCsv::read(&a.history)?;
    if let Some(w) = deprecation {
        eprintln!("warning: {w}");
    }
    let keys = KeyframesCsv::read(&a.targets, &hist, &a.history.display().to_string())?;
    let opts = DesignOptions {
        albedo,
        grid_points: a.grid_points,
        refine: !a.grid_only,
    };
    let d = design_from_keyframes(&hist, &keys, &opts)?;
    if let Some(p) = &a.plot {
        let chart = DesignChart {
            name: &a.name,
            history: &hist,
            keyframes: &keys,
            albedo,
            design: &d,
            refined: !a.grid_only,
        };
        let png = design_chart_png(&chart).with_context(|| format!("--plot {}", p.display()))?;
        out.stage(p, &png)?;
    }
    let report = pipe::design_report(&d, &keys, albedo, hist.t_s.len(), !a.grid_only);
    let fin = &d.refined;
    let worst = fin.relative_residual.iter().fold(0.0_f64, |m, v| m.max(*v));
    let provenance = provenance_of_files("lumifit phos design", &[&a.history, &a.targets])?
        .with_fit_quality(
            serde_json::json!({"worst_keyframe_relative_residual": worst, "reachable": d.reachable}),
        );
    let preset = design_preset(
        &a.name,
        provenance,
        fin.k_r_per_s,
        fin.k_e,
        fin.lambda,
        report.clone(),
    );
    out.stage_text(&a.out, &to_json_string(&preset)?)?;
    out.commit()?;
    super::emit(&serde_json::to_string_pretty(&report)?)
}
