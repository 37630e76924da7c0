//! `lumifit dispersion …`: fit n(λ) into a preset's dispersion section, and check its wavelength
//! samples on the prism reference consumer.

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::{Args, Subcommand};
use lumifit::colorimetry::rgb::RgbSpace;
use lumifit::colorimetry::{Observer, StandardObserver};
use lumifit::dispersion::blanchette2012::{slices_for, table2_samples, wavelength_samples};
use lumifit::dispersion::catalogue::glass;
use lumifit::dispersion::prism::{evaluate, smallest_n_for, CaseInput, PrismSetup};
use lumifit::dispersion::{source, AirVacuum, ModelKind, Source};
use lumifit::io::refractive_index::{parse_n_csv, parse_rii_yaml};
use lumifit::io::{read_input, Outputs};
use lumifit::preset::dispersion::{fit_section, FitConfig};
use lumifit::preset::{read_material, to_json_string, MaterialPreset, Provenance};
use serde_json::json;

use super::{emit, resolve_illuminant};

/// Subcommands of `lumifit dispersion`.
#[derive(Debug, Subcommand)]
pub enum DispersionCommand {
    /// Fit n(λ) from a refractiveindex.info YAML, a CSV `wavelength_nm,n[,std]` or a bundled
    /// glass; write a material preset with the dispersion section (model, n_d, V_d, samples).
    Fit(FitArgs),
    /// Render a white beam through a prism of the preset's material, spectrally and with
    /// wavelength samples; ΔE00 along the strip.
    Prism(PrismArgs),
}

#[derive(Debug, Args)]
pub struct FitArgs {
    /// refractiveindex.info YAML entry (`.yml`/`.yaml`) or CSV `wavelength_nm,n[,std]`.
    #[arg(required_unless_present = "glass", conflicts_with = "glass")]
    pub input: Option<PathBuf>,
    /// A glass of the bundled catalogue (N-BK7, N-SF11, F2, N-K5, N-BAK4, N-BAF10, fused-silica,
    /// water, diamond) instead of a file.
    #[arg(long)]
    pub glass: Option<String>,
    /// Model: auto picks the smallest meeting --tolerance.
    #[arg(long, default_value = "auto", value_parser = ["auto", "cauchy2", "cauchy3", "sellmeier1", "sellmeier2", "sellmeier3"])]
    pub model: String,
    /// Fitted range LO:HI in nm (clipped to the data's validity range).
    #[arg(long, default_value = "380:780")]
    pub range: String,
    /// Tolerance on max |Δn| over the range for the automatic choice.
    #[arg(long, default_value_t = 1e-4)]
    pub tolerance: f64,
    /// Number of wavelength samples.
    #[arg(long, default_value_t = 7)]
    pub samples: usize,
    /// Working space of the sample weights.
    #[arg(long, default_value = "srgb", value_parser = ["srgb", "acescg"])]
    pub working_space: String,
    /// Illuminant whose white the weights sum to (CIE name, daylight:<K>, blackbody:<K>, CSV).
    #[arg(long, default_value = "E")]
    pub illuminant: String,
    /// Observer of the sample colours.
    #[arg(long, default_value = "cie1931-2", value_parser = ["cie1931-2", "cie1964-10", "cie2015-2", "cie2015-10"])]
    pub observer: String,
    /// Convert the source between wavelengths in standard air (n relative to air) and in vacuum
    /// (absolute n), by Ciddor (1996).
    #[arg(long, default_value = "none", value_parser = ["none", "air-to-vacuum", "vacuum-to-air"])]
    pub convert: String,
    /// Material name in the preset (default: the glass or the file name).
    #[arg(long)]
    pub name: Option<String>,
    /// Output material preset (JSON); `-` for standard output.
    #[arg(long, value_name = "material.json")]
    pub out: PathBuf,
    /// Also draw the residuals of every candidate (PNG).
    #[arg(long, value_name = "fit.png")]
    pub plot: Option<PathBuf>,
}

#[derive(Debug, Args)]
pub struct PrismArgs {
    /// Material preset with a dispersion section.
    pub preset: PathBuf,
    /// Compute N samples (default: the preset's own samples).
    #[arg(long, conflicts_with = "target_de00")]
    pub samples: Option<usize>,
    /// Pick the smallest N whose maximum ΔE00 along the strip is at most this.
    #[arg(long)]
    pub target_de00: Option<f64>,
    /// Prism apex angle in degrees.
    #[arg(long, default_value_t = 60.0)]
    pub apex_deg: f64,
    /// Angle of incidence in degrees (default: minimum deviation at the d line).
    #[arg(long, allow_hyphen_values = true)]
    pub incidence_deg: Option<f64>,
    /// Screen distance in m.
    #[arg(long, default_value_t = 1.0)]
    pub screen_distance_m: f64,
    /// Beam width on the screen in mm.
    #[arg(long, default_value_t = 2.0)]
    pub beam_width_mm: f64,
    /// Pixel width on the screen in mm.
    #[arg(long, default_value_t = 0.05)]
    pub pixel_mm: f64,
    /// Illuminant of the white beam (default: the preset's).
    #[arg(long)]
    pub illuminant: Option<String>,
    /// Output PNG: both strips and the ΔE00 curve.
    #[arg(long, value_name = "strip.png")]
    pub out: PathBuf,
    /// ΔE00 table (CSV) for N = 3, 5, 7, 11, 21, the preset's samples and Blanchette's Table 2.
    #[arg(long, value_name = "de.csv")]
    pub table: Option<PathBuf>,
}

/// Runs a `dispersion` subcommand.
pub fn run(cmd: DispersionCommand) -> Result<()> {
    match cmd {
        DispersionCommand::Fit(a) => fit(&a),
        DispersionCommand::Prism(a) => prism(&a),
    }
}

fn parse_range(s: &str) -> Result<[f64; 2]> {
    let (a, b) = s
        .split_once(':')
        .with_context(|| format!("--range: '{s}'; expected LO:HI in nm, e.g. 380:780"))?;
    let lo: f64 = a
        .trim()
        .parse()
        .with_context(|| format!("--range: '{a}' is not a number"))?;
    let hi: f64 = b
        .trim()
        .parse()
        .with_context(|| format!("--range: '{b}' is not a number"))?;
    anyhow::ensure!(
        lo.is_finite() && hi.is_finite() && 0.0 < lo && lo < hi,
        "--range: {s}; expected 0 < LO < HI in nm"
    );
    Ok([lo, hi])
}

fn fit(a: &FitArgs) -> Result<()> {
    let range = parse_range(&a.range)?;
    let kinds = match a.model.as_str() {
        "auto" => ModelKind::ALL.to_vec(),
        m => vec![ModelKind::from_name(m)?],
    };
    let mut out = Outputs::new();
    let mut inputs: Vec<(PathBuf, Vec<u8>)> = Vec::new();
    let (src, source_name, default_name) = match (&a.input, &a.glass) {
        (Some(path), _) => {
            out.input(path);
            let (bytes, file) = read_input(path)?;
            let lower = file.to_ascii_lowercase();
            let src = if lower.ends_with(".csv") {
                Source::Table(parse_n_csv(&bytes, &file)?)
            } else {
                parse_rii_yaml(&bytes, &file)?.source
            };
            inputs.push((path.clone(), bytes));
            let stem = path
                .file_stem()
                .map_or_else(|| "material".into(), |s| s.to_string_lossy().into_owned());
            (src, file, stem)
        }
        (None, Some(g)) => {
            let g = glass(g)?;
            let name = format!("calib/glasses.csv:{}", g.name);
            (Source::Formula(g.formula), name, g.name)
        }
        (None, None) => anyhow::bail!("give an input file or --glass NAME"),
    };
    out.declare("--out", &a.out)?;
    if let Some(p) = &a.plot {
        out.declare("--plot", p)?;
    }
    let observer = Observer::standard(StandardObserver::from_name(&a.observer)?)?;
    let illuminant = resolve_illuminant(&a.illuminant)?;
    let space = RgbSpace::from_name(&a.working_space)?;
    let conversion = AirVacuum::from_name(&a.convert)?;
    let cfg = FitConfig {
        kinds,
        range_nm: range,
        tolerance: a.tolerance,
        n_samples: a.samples,
        conversion,
        observer,
        illuminant: &illuminant,
        space: &space,
        source_name: &source_name,
    };
    let fitted = fit_section(&src, &cfg)?;
    let command = std::env::args().collect::<Vec<_>>().join(" ");
    let refs: Vec<(&PathBuf, &[u8])> = inputs.iter().map(|(p, b)| (p, b.as_slice())).collect();
    let best = fitted.report.best();
    let provenance = Provenance::new(&command, &refs).with_fit_quality(json!({
        "chosen_model": best.kind.key(),
        "rms_residual": best.rms_residual,
        "max_abs_residual": best.max_abs_residual,
        "tolerance_met": fitted.report.tolerance_met,
        "termination": best.termination,
    }));
    let mut preset = MaterialPreset::new(a.name.clone().unwrap_or(default_name), provenance);
    preset.dispersion = Some(fitted.section.clone());
    out.stage_text(&a.out, &to_json_string(&preset)?)?;
    if let Some(p) = &a.plot {
        let (obs, _) = source::observations(&src, range, conversion, &source_name)?;
        let title = format!(
            "{}: n(model) − n(data), {} observations",
            preset.name,
            obs.len()
        );
        let png =
            lumifit::plot::dispersion::fit_residuals_png(&title, &obs, &fitted.report.candidates)?;
        out.stage(p, &png)?;
    }
    let candidates: Vec<_> = fitted
        .report
        .candidates
        .iter()
        .map(|c| {
            json!({"model": c.kind.key(), "valid": c.valid, "rms_residual": c.rms_residual,
                   "max_abs_residual": c.max_abs_residual, "termination": c.termination, "note": c.note})
        })
        .collect();
    let summary = json!({
        "source": source_name,
        "range_nm": fitted.section.range_nm,
        "chosen_model": best.kind.key(),
        "tolerance": a.tolerance,
        "tolerance_met": fitted.report.tolerance_met,
        "candidates": candidates,
        "derived": fitted.derived,
        "abbe_number_std": fitted.abbe_number_std,
        "samples": fitted.section.samples,
        "written": out.staged_paths().iter().map(|p| p.display().to_string()).collect::<Vec<_>>(),
    });
    out.commit()?;
    if a.out.as_os_str() != "-" {
        emit(&serde_json::to_string_pretty(&summary)?)?;
    }
    Ok(())
}

fn prism(a: &PrismArgs) -> Result<()> {
    let mut out = Outputs::new();
    out.input(&a.preset);
    let preset = read_material(&a.preset)?;
    let file = a.preset.display().to_string();
    let d = preset.dispersion.as_ref().with_context(|| {
        format!("{file}: dispersion: missing; write one with `lumifit dispersion fit`")
    })?;
    out.declare("--out", &a.out)?;
    if let Some(t) = &a.table {
        out.declare("--table", t)?;
    }
    let model = d
        .to_model()
        .with_context(|| format!("{file}: dispersion.model"))?;
    let space = RgbSpace::from_name(&d.working_space)?;
    let ill_name = a
        .illuminant
        .clone()
        .or_else(|| {
            d.extra
                .get("illuminant")
                .and_then(|v| v.as_str())
                .map(String::from)
        })
        .unwrap_or_else(|| "E".into());
    let illuminant = resolve_illuminant(&ill_name)?;
    let obs_name = d
        .extra
        .get("observer")
        .and_then(|v| v.as_str())
        .unwrap_or("cie1931-2");
    let observer = Observer::standard(StandardObserver::from_name(obs_name)?)?;
    let range = [d.range_nm[0].ceil(), d.range_nm[1].floor()];
    let slices = slices_for(observer, &illuminant, &space, range)?;
    let setup = PrismSetup {
        apex_deg: a.apex_deg,
        incidence_deg: a.incidence_deg,
        screen_distance_m: a.screen_distance_m,
        beam_width_mm: a.beam_width_mm,
        pixel_mm: a.pixel_mm,
    };
    let computed = |label: String, n: usize| -> Result<CaseInput> {
        let set = wavelength_samples(&slices, n)?;
        Ok((
            label,
            set.samples.iter().map(|s| (s.lambda_nm, s.rgb)).collect(),
            Some(set.samples.iter().map(|s| s.target_rgb).collect()),
        ))
    };
    let mut target = None;
    let main: CaseInput = if let Some(t) = a.target_de00 {
        let found = smallest_n_for(&model, &slices, &setup, t, 401)?;
        let (n, _) = found.with_context(|| {
            format!(
                "--target-de00 {t}: no N up to 401 samples reaches a maximum sampling ΔE00 of {t}"
            )
        })?;
        target = Some(n);
        computed(format!("N = {n} (smallest for sampling ΔE00 ≤ {t})"), n)?
    } else if let Some(n) = a.samples {
        computed(format!("N = {n}"), n)?
    } else {
        (
            format!("preset samples (N = {})", d.samples.len()),
            d.samples.iter().map(|s| (s.lambda_nm, s.rgb)).collect(),
            None,
        )
    };
    let mut cases = vec![main];
    if a.table.is_some() {
        for n in [3, 5, 7, 11, 21] {
            cases.push(computed(format!("N = {n}"), n)?);
        }
        cases.push(("Blanchette 2012 Table 2".into(), table2_samples(), None));
    }
    let eval = evaluate(&model, &slices, &setup, cases)?;
    let title = format!(
        "{}: prism {}°, incidence {:.2}°, beam {} mm at {} m — {}",
        preset.name,
        a.apex_deg,
        eval.layout.incidence_deg,
        a.beam_width_mm,
        a.screen_distance_m,
        eval.cases[0].label
    );
    out.stage(
        &a.out,
        &lumifit::plot::dispersion::prism_chart_png(&title, &eval, 0)?,
    )?;
    if let Some(t) = &a.table {
        let mut csv = String::from(
            "case,n_samples,mean_de00,max_de00,mean_de00_sampling_only,max_de00_sampling_only,lit_pixels\n",
        );
        for c in &eval.cases {
            let (m, x) = c
                .sampling_only
                .as_ref()
                .map_or((String::new(), String::new()), |s| {
                    (format!("{:.4}", s.mean), format!("{:.4}", s.max))
                });
            csv.push_str(&format!(
                "\"{}\",{},{:.4},{:.4},{m},{x},{}\n",
                c.label,
                c.samples.len(),
                c.difference.mean,
                c.difference.max,
                c.difference.lit_pixels
            ));
        }
        out.stage_text(t, &csv)?;
    }
    let rows: Vec<_> = eval
        .cases
        .iter()
        .map(|c| json!({"case": c.label, "n_samples": c.samples.len(), "mean_de00": c.difference.mean, "max_de00": c.difference.max,
                        "mean_de00_sampling_only": c.sampling_only.as_ref().map(|s| s.mean),
                        "max_de00_sampling_only": c.sampling_only.as_ref().map(|s| s.max)}))
        .collect();
    let summary = json!({
        "preset": file,
        "incidence_deg": eval.layout.incidence_deg,
        "deviation_d_deg": eval.layout.deviation_d_deg,
        "pixels": eval.layout.n_pixels,
        "smallest_n_for_target": target,
        "cases": rows,
    });
    out.commit()?;
    emit(&serde_json::to_string_pretty(&summary)?)
}
