//! `lumifit phos fit-excitation`, `lumifit phos design` and `lumifit synth phos-excitation`:
//! excitation rates from charging experiments (Nalbach et al. 2017 §4.6) and materials designed
//! from keyframes (§6).

use std::path::{Path, PathBuf};

use anyhow::{anyhow, bail, Context, Result};
use clap::{ArgGroup, Args, Subcommand, ValueEnum};
use lumifit::io::{atomic_write, read_input, spectrum_csv::read_multi_spectrum};
use lumifit::phosphor::design::{
    design_from_keyframes, DesignOptions, DesignStage, IrradianceHistory, Keyframe,
};
use lumifit::phosphor::excitation::{
    apply_excitation, band_means_exact, fit_excitation, synth_charging, unit_length,
    ChargingSample, ExcitationFit, ExcitationOptions, StateSharing,
};
use lumifit::phosphor::{BandCamera, BandSet, Material};
use lumifit::preset::{
    read_material, write_preset, Bands, InputFile, MaterialPreset, PhosphorescenceSection,
    PhosphorescentState, Provenance,
};
use lumifit::table::parse_numeric_csv;
use lumifit::Error;

use super::phos::resolve_material;

mod series;

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
    /// Irradiance history CSV `time_s,e_r,e_g,e_b` (constant from each row's time to the next).
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
            "material '{}' has RGB bands; charging experiments need wavelength bands \
             ([[lo_nm, hi_nm], …]) to integrate the source spectra over",
            m.name
        ),
    }
}

/// Reads `band,charge_s,r,g,b[,std]`.
fn read_data(path: &Path, n_bands: usize) -> Result<Vec<ChargingSample>> {
    let (bytes, source) = read_input(path)?;
    let t = parse_numeric_csv(&bytes, &source)?;
    let col = |name: &str| {
        t.column_index(name).ok_or_else(|| {
            Error::parse(
                &source,
                1,
                format!(
                    "no '{name}' column; expected header 'band,charge_s,r,g,b' (optional 'std')"
                ),
            )
        })
    };
    let (cb, ct, cr, cg, cbl) = (
        col("band")?,
        col("charge_s")?,
        col("r")?,
        col("g")?,
        col("b")?,
    );
    let cs = t.column_index("std");
    let mut out = Vec::with_capacity(t.n_rows());
    for i in 0..t.n_rows() {
        let line = t.lines[i];
        let b = t.columns[cb][i];
        if b.fract() != 0.0 || b < 1.0 || b > n_bands as f64 {
            return Err(Error::parse(
                &source,
                line,
                format!("band {b}; expected an integer from 1 to {n_bands} (the material's bands)"),
            )
            .into());
        }
        let ts = t.columns[ct][i];
        if ts < 0.0 {
            return Err(Error::parse(
                &source,
                line,
                format!("charge_s {ts}; expected a charging time ≥ 0 s"),
            )
            .into());
        }
        let sigma = match cs {
            Some(c) => {
                let s = t.columns[c][i];
                if s <= 0.0 {
                    return Err(
                        Error::parse(&source, line, format!("std {s}; expected > 0")).into(),
                    );
                }
                Some(s)
            }
            None => None,
        };
        out.push(ChargingSample {
            band: b as usize - 1,
            charge_s: ts,
            rgb: [t.columns[cr][i], t.columns[cg][i], t.columns[cbl][i]],
            sigma,
        });
    }
    if out.is_empty() {
        return Err(Error::parse(
            &source,
            0,
            "no data rows; expected band,charge_s,r,g,b rows",
        )
        .into());
    }
    Ok(out)
}

/// Reads `wavelength_nm,band1,…` and returns unit-length per-band irradiance for `bands`.
fn read_sources(
    path: &Path,
    ranges: &[[f64; 2]],
    bands: &[usize],
) -> Result<Vec<(usize, Vec<f64>)>> {
    let (bytes, source) = read_input(path)?;
    let t = parse_numeric_csv(&bytes, &source)?;
    let Some(wi) = t.column_index("wavelength_nm") else {
        return Err(Error::parse(
            &source,
            1,
            "no 'wavelength_nm' column; expected 'wavelength_nm,band1,band2,…'",
        )
        .into());
    };
    let wl = &t.columns[wi];
    for r in 1..wl.len() {
        if wl[r] <= wl[r - 1] {
            return Err(Error::parse(
                &source,
                t.lines[r],
                format!(
                    "wavelength {} nm after {} nm; expected strictly increasing",
                    wl[r],
                    wl[r - 1]
                ),
            )
            .into());
        }
    }
    let mut out = Vec::new();
    for &j in bands {
        let names = [
            format!("band{}", j + 1),
            format!("band_{}", j + 1),
            format!("{}", j + 1),
        ];
        let Some(c) = names.iter().find_map(|n| t.column_index(n)) else {
            return Err(Error::parse(
                &source,
                1,
                format!(
                    "no column for band {} (header: {}); expected a column 'band{}' with the \
                     source spectrum that charged that band",
                    j + 1,
                    t.header.join(","),
                    j + 1
                ),
            )
            .into());
        };
        let means = band_means_exact(wl, &t.columns[c], ranges)
            .map_err(|e| anyhow!("{source}: band{}: {e}", j + 1))?;
        let unit = unit_length(&means).map_err(|e| anyhow!("{source}: band{}: {e}", j + 1))?;
        out.push((j, unit));
    }
    Ok(out)
}

fn read_camera(path: &Path, m: &Material) -> Result<BandCamera> {
    let ms = read_multi_spectrum(path)?;
    BandCamera::for_bands(&m.bands, Some(&ms)).with_context(|| format!("{}", path.display()))
}

fn fit_cmd(a: &FitExcitationArgs) -> Result<()> {
    let material = resolve_material(&a.material)?;
    let ranges = wavelength_ranges(&material)?.to_vec();
    // The charging data: a CSV, or photographs + ROIs (clap makes them exclusive).
    let (data, data_path, data_files, series_report) = match (&a.data, &a.series) {
        (Some(d), None) => (
            read_data(d, ranges.len())?,
            d.clone(),
            vec![d.clone()],
            None,
        ),
        (None, Some(m)) => {
            let rois = match (&a.roi, &a.rois) {
                (Some(r), None) => series::RoiSource::One(r),
                (None, Some(f)) => series::RoiSource::PerBand(f),
                _ => bail!("--series needs either --roi x,y,w,h or --rois FILE.csv"),
            };
            let s = series::load(m, rois, &a.dark, ranges.len())?;
            for w in &s.warnings {
                eprintln!("warning: {w}");
            }
            (s.samples, m.clone(), s.inputs, Some(s.report))
        }
        _ => bail!("give the charging data either as --data FILE.csv or as --series MANIFEST.csv"),
    };
    let mut bands: Vec<usize> = data.iter().map(|s| s.band).collect();
    bands.sort_unstable();
    bands.dedup();
    let sources = read_sources(&a.source, &ranges, &bands)?;
    let camera = read_camera(&a.camera, &material)?;
    // Λ must be in the camera's units for y = C Λ k_r r to compare with the data; a
    // `phos fit-decay --spectrum` preset records its RGB fit, which fixes that scale.
    let mut material = material;
    let lambda_scale = decay_fit_lambda_scale(&a.material, &material, &camera)?;
    let rescaled = lambda_scale.filter(|s| (s - 1.0).abs() > LAMBDA_SCALE_TOLERANCE);
    if let Some(s) = rescaled {
        eprintln!(
            "warning: {}: camera·Λ·k_r does not reproduce the preset's own decay fit through {} \
             (Λ off by a factor {:.4}); Λ rescaled by {s:.6} before fitting k_e",
            a.material,
            a.camera.display(),
            1.0 / s
        );
        for st in &mut material.states {
            for l in &mut st.lambda {
                *l *= s;
            }
        }
    }
    let opts = ExcitationOptions {
        switch_off_delay_s: a.switch_off_delay_s,
        sharing: match a.states {
            SharingArg::Auto => StateSharing::Auto,
            SharingArg::Shared => StateSharing::Shared,
            SharingArg::PerState => StateSharing::PerState,
        },
        ..ExcitationOptions::default()
    };
    let fit = fit_excitation(&material, &camera, &sources, &data, &opts)
        .with_context(|| format!("{}: excitation fit", data_path.display()))?;
    let updated = apply_excitation(&material, &fit);
    let mut report = fit_report(&fit);
    if let Some(obj) = report.as_object_mut() {
        if let Some(sr) = series_report {
            obj.insert("series".into(), sr);
        }
        if let Some(s) = lambda_scale {
            obj.insert(
                "lambda_camera_scale".into(),
                serde_json::json!({
                    "factor": s,
                    "applied": rescaled.is_some(),
                    "note": "least-squares factor making camera·Λ_i·k_r,i equal the RGB amplitudes of the preset's decay fit (extra.decay_fit); applied to Λ when it differs from 1 by more than 1 %",
                }),
            );
        }
    }
    // Provenance: every input with its hash.
    let mut inputs: Vec<(PathBuf, Vec<u8>)> = Vec::new();
    let mat_path = Path::new(&a.material);
    let base = if mat_path.is_file() {
        inputs.push((mat_path.to_path_buf(), read_input(mat_path)?.0));
        Some(read_material(mat_path)?)
    } else {
        None
    };
    for p in [&a.source, &a.camera] {
        inputs.push((p.clone(), read_input(p)?.0));
    }
    let refs: Vec<(&PathBuf, &[u8])> = inputs.iter().map(|(p, b)| (p, &b[..])).collect();
    let worst_rms = fit.bands.iter().fold(0.0_f64, |m, b| m.max(b.rms));
    let mut provenance = Provenance::new("lumifit phos fit-excitation", &refs).with_fit_quality(
        serde_json::json!({
            "excitation_rms_max": worst_rms,
            "product_only_bands": fit.bands.iter().filter(|b| b.product_only).map(|b| b.band + 1).collect::<Vec<_>>(),
        }),
    );
    // The data files (with --series possibly many large images) are hashed one at a time and
    // listed after the material.
    let data_inputs = data_files
        .iter()
        .map(InputFile::from_file)
        .collect::<lumifit::Result<Vec<_>>>()?;
    let at = usize::from(base.is_some());
    provenance.inputs.splice(at..at, data_inputs);
    let mut preset = match base {
        Some(mut p) => {
            if let Some(old) = p.provenance.fit_quality.take() {
                let mut q = provenance.fit_quality.clone().unwrap_or_default();
                if let Some(obj) = q.as_object_mut() {
                    obj.insert("earlier".into(), old);
                }
                p.provenance = Provenance {
                    fit_quality: Some(q),
                    ..provenance
                };
            } else {
                p.provenance = provenance;
            }
            p
        }
        None => MaterialPreset::new(material.name.clone(), provenance),
    };
    let mut section = preset
        .phosphorescence
        .take()
        .unwrap_or_else(|| PhosphorescenceSection {
            bands: Bands::RangesNm(ranges.clone()),
            states: vec![],
            extra: serde_json::Map::new(),
        });
    let old_states = std::mem::take(&mut section.states);
    section.states = updated
        .states
        .iter()
        .enumerate()
        .map(|(i, s)| {
            let mut st = old_states
                .get(i)
                .cloned()
                .unwrap_or_else(|| PhosphorescentState::new(s.k_r_per_s, None, s.lambda.clone()));
            st.k_e = s.k_e.clone();
            if rescaled.is_some() {
                st.lambda = s.lambda.clone();
            }
            st
        })
        .collect();
    section
        .extra
        .insert("excitation_fit".into(), report.clone());
    preset.phosphorescence = Some(section);
    write_preset(&a.out, &preset)?;
    if let Some(p) = &a.plot {
        lumifit::plot::excitation_chart(
            p,
            &format!("{}: excitation fit", material.name),
            &material,
            &camera,
            &fit,
        )?;
    }
    super::emit(&serde_json::to_string_pretty(&report)?)
}

/// Relative deviation from 1 above which [`decay_fit_lambda_scale`] is applied to Λ: the decay
/// fit determines its amplitudes to a fraction of a percent at 1 % noise, so a larger factor
/// is a units mismatch, not noise.
const LAMBDA_SCALE_TOLERANCE: f64 = 0.01;

/// For a preset written by `phos fit-decay` (it records `extra.decay_fit` with the RGB
/// amplitudes of every state at switch-off), the factor s minimising
/// Σ_i Σ_c (s·(C Λ_i k_r,i)_c − a_i,c)²: Λ·s then reproduces the decay fit through this
/// camera. `fit-decay --spectrum` scales the band spectrum to a maximum of 1 without a camera,
/// so its Λ is in units of the RGB fit's brightest channel, not the camera's. `None` when the
/// material is not such a preset (a Table 1 name, or no decay-fit record matching the states).
fn decay_fit_lambda_scale(
    material_arg: &str,
    material: &Material,
    camera: &BandCamera,
) -> Result<Option<f64>> {
    let path = Path::new(material_arg);
    if !path.is_file() {
        return Ok(None);
    }
    let preset = read_material(path)?;
    let Some(states) = preset
        .phosphorescence
        .as_ref()
        .and_then(|s| s.extra.get("decay_fit"))
        .and_then(|f| f.get("states"))
        .and_then(|v| v.as_array())
    else {
        return Ok(None);
    };
    if states.len() != material.states.len() {
        return Ok(None);
    }
    let (mut num, mut den) = (0.0, 0.0);
    for (st, m) in states.iter().zip(&material.states) {
        let amps: Option<Vec<f64>> = st
            .get("channel_amplitudes")
            .and_then(|v| v.as_array())
            .and_then(|a| a.iter().map(|x| x.as_f64()).collect());
        let Some(amps) = amps.filter(|a| a.len() == 3) else {
            return Ok(None);
        };
        let emission: Vec<f64> = m.lambda.iter().map(|l| l * m.k_r_per_s).collect();
        let model = camera.rgb(&emission);
        for c in 0..3 {
            num += amps[c] * model[c];
            den += model[c] * model[c];
        }
    }
    Ok((den > 0.0 && num > 0.0 && (num / den).is_finite()).then_some(num / den))
}

fn fit_report(fit: &ExcitationFit) -> serde_json::Value {
    serde_json::json!({
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
                format!("charging never approaches saturation (largest r = {:.3} < {}): only the product k_e·Λ is determined; k_e relies on the scale of Λ from the decay fit", b.r_max, lumifit::phosphor::excitation::SATURATION_MIN)
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
    })
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
    let material = resolve_material(&a.material)?;
    let ranges = wavelength_ranges(&material)?.to_vec();
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
    // Box sources, one per band, with sharp edges (ramps of 1e-6 nm), written and read back.
    let eps = 1e-6;
    let mut grid: Vec<f64> = Vec::new();
    for [lo, hi] in &ranges {
        grid.extend([lo - eps, *lo, lo + eps, hi - eps, *hi, hi + eps]);
    }
    grid.sort_by(f64::total_cmp);
    grid.dedup_by(|x, y| (*x - *y).abs() < eps * 0.1);
    let mut src = String::from("wavelength_nm");
    for j in 0..a.bands {
        src.push_str(&format!(",band{}", j + 1));
    }
    src.push('\n');
    for w in &grid {
        src.push_str(&format!("{w}"));
        for [lo, hi] in ranges.iter().take(a.bands) {
            let inside = *w >= lo + eps * 0.5 && *w <= hi - eps * 0.5;
            src.push_str(if inside { ",1" } else { ",0" });
        }
        src.push('\n');
    }
    let src_path = sibling(&a.out, "source.csv");
    atomic_write(&src_path, src.as_bytes())?;
    let cam_path = match &a.camera {
        Some(p) => p.clone(),
        None => {
            let p = sibling(&a.out, "camera.csv");
            let mut cam = String::from("wavelength_nm,r,g,b\n");
            for k in 0..=340 {
                let w = 380.0 + k as f64;
                let v = |lo: f64, hi: f64| if w >= lo && w < hi { 1 } else { 0 };
                cam.push_str(&format!(
                    "{w},{},{},{}\n",
                    v(600.0, 700.0),
                    v(500.0, 600.0),
                    v(400.0, 500.0)
                ));
            }
            atomic_write(&p, cam.as_bytes())?;
            p
        }
    };
    let bands: Vec<usize> = (0..a.bands).collect();
    let sources = read_sources(&src_path, &ranges, &bands)?;
    let camera = read_camera(&cam_path, &material)?;
    let samples = synth_charging(
        &material,
        &camera,
        &sources,
        &times,
        a.switch_off_delay_s,
        a.noise,
        a.seed,
    )?;
    let rendered = match &a.images {
        Some(dir) => Some(
            series::render_images(dir, &samples, a.bands, &times, a.seed)
                .with_context(|| format!("rendering images into {}", dir.display()))?,
        ),
        None => None,
    };
    let mut csv = String::from("band,charge_s,r,g,b,std\n");
    for s in &samples {
        let [r, g, b] = s.rgb;
        csv.push_str(&format!(
            "{},{},{r},{g},{b},{}\n",
            s.band + 1,
            s.charge_s,
            s.sigma.unwrap_or(1.0)
        ));
    }
    atomic_write(&a.out, csv.as_bytes())?;
    let images = match (&a.images, &rendered) {
        (Some(dir), Some(r)) => format!(
            "; {} images of {}×{} pixels (patches of {} px, dark level {} of 65535) with \
             manifest.csv, rois.csv and dark.tif in {}",
            r.images,
            r.size.0,
            r.size.1,
            series::PATCH_PX,
            series::PEDESTAL_DN,
            dir.display()
        ),
        _ => String::new(),
    };
    super::emit(&format!(
        "wrote {} samples ({} bands × {} charge times) of {} to {}, sources to {}, camera {}{images}",
        samples.len(),
        a.bands,
        times.len(),
        material.name,
        a.out.display(),
        src_path.display(),
        cam_path.display()
    ))
}

/// Times, RGB rows, line numbers and the source name of a `time_s,a,b,c` CSV.
type RgbRows = (Vec<f64>, Vec<[f64; 3]>, Vec<usize>, String);

/// Reads a CSV `time_s,<a>,<b>,<c>` with the given column names.
fn read_rgb_rows(path: &Path, cols: [&str; 3], what: &str) -> Result<RgbRows> {
    let (bytes, source) = read_input(path)?;
    let t = parse_numeric_csv(&bytes, &source)?;
    let expected = format!("time_s,{},{},{}", cols[0], cols[1], cols[2]);
    let ti = t.column_index("time_s").ok_or_else(|| {
        Error::parse(
            &source,
            1,
            format!("no 'time_s' column; expected {what} '{expected}'"),
        )
    })?;
    let mut ci = [0; 3];
    for (k, c) in cols.iter().enumerate() {
        ci[k] = t.column_index(c).ok_or_else(|| {
            Error::parse(
                &source,
                1,
                format!("no '{c}' column; expected {what} '{expected}'"),
            )
        })?;
    }
    let times = t.columns[ti].clone();
    let rows = (0..t.n_rows())
        .map(|i| ci.map(|c| t.columns[c][i]))
        .collect();
    if times.is_empty() {
        return Err(Error::parse(&source, 0, format!("no data rows; expected {what} rows")).into());
    }
    Ok((times, rows, t.lines.clone(), source))
}

fn design_cmd(a: &DesignArgs) -> Result<()> {
    let albedo = super::parse_triplet("--albedo", &a.albedo)?;
    if albedo.iter().any(|v| *v < 0.0) {
        bail!("--albedo: {:?}; expected values ≥ 0", albedo);
    }
    let (ht, he, hl, hs) = read_rgb_rows(&a.history, ["e_r", "e_g", "e_b"], "irradiance history")?;
    for i in 0..ht.len() {
        if i > 0 && ht[i] <= ht[i - 1] {
            return Err(Error::parse(
                &hs,
                hl[i],
                format!(
                    "time {} s after {} s; times must be strictly increasing",
                    ht[i],
                    ht[i - 1]
                ),
            )
            .into());
        }
        if let Some(v) = he[i].iter().find(|v| **v < 0.0) {
            return Err(
                Error::parse(&hs, hl[i], format!("irradiance {v}; expected values ≥ 0")).into(),
            );
        }
    }
    let (tt, tl, tlines, ts) =
        read_rgb_rows(&a.targets, ["l_r", "l_g", "l_b"], "keyframe targets")?;
    for i in 0..tt.len() {
        if tt[i] < ht[0] {
            return Err(Error::parse(
                &ts,
                tlines[i],
                format!(
                    "keyframe at {} s is before the history starts ({} s in {}); expected \
                     keyframes within the history",
                    tt[i], ht[0], hs
                ),
            )
            .into());
        }
    }
    let hist = IrradianceHistory { t_s: ht, e: he };
    let keys: Vec<Keyframe> = tt
        .iter()
        .zip(&tl)
        .map(|(t, l)| Keyframe {
            t_s: *t,
            radiance: *l,
        })
        .collect();
    let opts = DesignOptions {
        albedo,
        grid_points: a.grid_points,
        refine: !a.grid_only,
    };
    let d = design_from_keyframes(&hist, &keys, &opts)?;
    // The plot before the preset: a bad --plot path fails before anything is written.
    if let Some(p) = &a.plot {
        lumifit::plot::phosphor_sim::design_chart(
            p,
            &lumifit::plot::phosphor_sim::DesignChart {
                name: &a.name,
                history: &hist,
                keyframes: &keys,
                albedo,
                design: &d,
                refined: !a.grid_only,
            },
        )
        .with_context(|| format!("--plot {}", p.display()))?;
    }
    let mut sorted = keys.clone();
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
    let report = serde_json::json!({
        "method": "Eq. 7 with Λ projected out (closed-form non-negative least squares per channel); log-grid over k_e (3, plus 0) and k_r, then Levenberg–Marquardt on log-rates",
        "albedo": albedo,
        "history_rows": hist.t_s.len(),
        "keyframes": keys.len(),
        "grid_candidates": d.grid_candidates,
        "grid": stage(&d.grid),
        "refined": if a.grid_only { serde_json::Value::Null } else { stage(&d.refined) },
        "reachable": d.reachable,
        "note": d.note,
    });
    let fin = &d.refined;
    let mut inputs: Vec<(PathBuf, Vec<u8>)> = Vec::new();
    for p in [&a.history, &a.targets] {
        inputs.push((p.clone(), read_input(p)?.0));
    }
    let refs: Vec<(&PathBuf, &[u8])> = inputs.iter().map(|(p, b)| (p, &b[..])).collect();
    let worst = fin.relative_residual.iter().fold(0.0_f64, |m, v| m.max(*v));
    let provenance = Provenance::new("lumifit phos design", &refs).with_fit_quality(
        serde_json::json!({"worst_keyframe_relative_residual": worst, "reachable": d.reachable}),
    );
    let mut preset = MaterialPreset::new(a.name.clone(), provenance);
    let mut extra = serde_json::Map::new();
    extra.insert("design".into(), report.clone());
    preset.phosphorescence = Some(PhosphorescenceSection {
        bands: Bands::Rgb,
        states: vec![PhosphorescentState::new(
            fin.k_r_per_s,
            Some(fin.k_e.to_vec()),
            fin.lambda.to_vec(),
        )],
        extra,
    });
    write_preset(&a.out, &preset)?;
    super::emit(&serde_json::to_string_pretty(&report)?)
}
