//! Dispersion (`lumifit dispersion fit|prism`, Blanchette 2012 sampling): what each command does
//! between its flags and its printed line — read the index data (refractiveindex.info YAML, CSV
//! or a bundled glass), fit n(λ) into a preset's dispersion section, render the prism reference
//! and its ΔE00 table, and stage every output in the caller's [`Outputs`]. The caller commits
//! and prints.

use std::path::PathBuf;

use serde_json::{json, Value};

use crate::colorimetry::rgb::RgbSpace;
use crate::colorimetry::{Observer, StandardObserver};
use crate::dispersion::blanchette2012::{slices_for, table2_samples, wavelength_samples};
use crate::dispersion::catalogue::glass;
use crate::dispersion::prism::{evaluate, smallest_n_for, CaseInput, PrismEvaluation, PrismSetup};
use crate::dispersion::{source, AirVacuum, ModelKind, Source};
use crate::error::{Error, Result};
use crate::io::refractive_index::{parse_n_csv, parse_rii_yaml};
use crate::io::sources::resolve_illuminant;
use crate::io::{read_input, Outputs};
use crate::preset::dispersion::{fit_section, FitConfig};
use crate::preset::{read_material, to_json_string, MaterialPreset, Provenance};

/// `--range LO:HI` in nm, with 0 < LO < HI.
pub fn parse_range(s: &str) -> Result<[f64; 2]> {
    let flag = "--range";
    let (a, b) = s
        .split_once(':')
        .ok_or_else(|| Error::flag(flag, format!("'{s}'; expected LO:HI in nm, e.g. 380:780")))?;
    let number = |t: &str| -> Result<f64> {
        t.trim()
            .parse()
            .map_err(|e: std::num::ParseFloatError| Error::Flag {
                flag: flag.to_string(),
                message: format!("'{t}' is not a number"),
                source: Some(Box::new(e)),
            })
    };
    let (lo, hi) = (number(a)?, number(b)?);
    if !(lo.is_finite() && hi.is_finite() && 0.0 < lo && lo < hi) {
        return Err(Error::flag(
            flag,
            format!("{s}; expected 0 < LO < HI in nm"),
        ));
    }
    Ok([lo, hi])
}

/// Where the refractive index comes from.
#[derive(Debug, Clone)]
pub enum IndexInput {
    /// A refractiveindex.info YAML entry or a CSV `wavelength_nm,n[,std]`.
    File(PathBuf),
    /// A glass of the bundled catalogue.
    Glass(String),
}

/// `dispersion fit`: n(λ) into a preset's dispersion section.
#[derive(Debug, Clone)]
pub struct FitJob {
    /// The data.
    pub input: IndexInput,
    /// Model name, or `auto` (the smallest meeting the tolerance).
    pub model: String,
    /// `--range LO:HI` as typed.
    pub range: String,
    /// Tolerance on max |Δn| for the automatic choice.
    pub tolerance: f64,
    /// Number of wavelength samples.
    pub samples: usize,
    /// Working space of the sample weights.
    pub working_space: String,
    /// Illuminant (CIE name, daylight:<K>, blackbody:<K>, CSV).
    pub illuminant: String,
    /// Observer name.
    pub observer: String,
    /// Air/vacuum conversion name.
    pub convert: String,
    /// Material name (default: the glass or the file stem).
    pub name: Option<String>,
    /// Output preset (`-`: standard output).
    pub out: PathBuf,
    /// Residual chart PNG.
    pub plot: Option<PathBuf>,
    /// The command line, for the preset's provenance.
    pub command: String,
}

/// Reads the data, declares the preset (and chart), fits, stages them and returns the summary
/// to print (the caller prints it only when the preset is not on standard output).
pub fn run_fit(job: &FitJob, out: &mut Outputs) -> Result<Value> {
    let range = parse_range(&job.range)?;
    let kinds = match job.model.as_str() {
        "auto" => ModelKind::ALL.to_vec(),
        m => vec![ModelKind::from_name(m)?],
    };
    let mut inputs: Vec<(PathBuf, Vec<u8>)> = Vec::new();
    let (src, source_name, default_name) = match &job.input {
        IndexInput::File(path) => {
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
        IndexInput::Glass(g) => {
            let g = glass(g)?;
            let name = format!("calib/glasses.csv:{}", g.name);
            (Source::Formula(g.formula), name, g.name)
        }
    };
    out.declare("--out", &job.out)?;
    if let Some(p) = &job.plot {
        out.declare("--plot", p)?;
    }
    let observer = Observer::standard(StandardObserver::from_name(&job.observer)?)?;
    let illuminant = resolve_illuminant("--illuminant", &job.illuminant)?;
    let space = RgbSpace::from_name(&job.working_space)?;
    let conversion = AirVacuum::from_name(&job.convert)?;
    let cfg = FitConfig {
        kinds,
        range_nm: range,
        tolerance: job.tolerance,
        n_samples: job.samples,
        conversion,
        observer,
        illuminant: &illuminant,
        space: &space,
        source_name: &source_name,
    };
    let fitted = fit_section(&src, &cfg)?;
    let refs: Vec<(&PathBuf, &[u8])> = inputs.iter().map(|(p, b)| (p, b.as_slice())).collect();
    let best = fitted.report.best();
    let provenance = Provenance::new(&job.command, &refs).with_fit_quality(json!({
        "chosen_model": best.kind.key(),
        "rms_residual": best.rms_residual,
        "max_abs_residual": best.max_abs_residual,
        "tolerance_met": fitted.report.tolerance_met,
        "termination": best.termination,
    }));
    let mut preset = MaterialPreset::new(job.name.clone().unwrap_or(default_name), provenance);
    preset.dispersion = Some(fitted.section.clone());
    out.stage_text(&job.out, &to_json_string(&preset)?)?;
    if let Some(p) = &job.plot {
        let (obs, _) = source::observations(&src, range, conversion, &source_name)?;
        let title = format!(
            "{}: n(model) − n(data), {} observations",
            preset.name,
            obs.len()
        );
        let png =
            crate::plot::dispersion::fit_residuals_png(&title, &obs, &fitted.report.candidates)?;
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
    Ok(json!({
        "source": source_name,
        "range_nm": fitted.section.range_nm,
        "chosen_model": best.kind.key(),
        "tolerance": job.tolerance,
        "tolerance_met": fitted.report.tolerance_met,
        "candidates": candidates,
        "derived": fitted.derived,
        "abbe_number_std": fitted.abbe_number_std,
        "samples": fitted.section.samples,
        "written": out.staged_paths().iter().map(|p| p.display().to_string()).collect::<Vec<_>>(),
    }))
}

/// How many wavelength samples `dispersion prism` renders.
#[derive(Debug, Clone, Copy)]
pub enum PrismSamples {
    /// The preset's own samples.
    Preset,
    /// N computed samples.
    Count(usize),
    /// The smallest N whose maximum ΔE00 along the strip is at most this.
    TargetDe00(f64),
}

/// `dispersion prism`: a white beam through a prism of the preset's material.
#[derive(Debug, Clone)]
pub struct PrismJob {
    /// Material preset with a dispersion section.
    pub preset: PathBuf,
    /// The samples to render.
    pub samples: PrismSamples,
    /// The prism, screen and beam.
    pub setup: PrismSetup,
    /// Illuminant of the beam (default: the preset's, else E).
    pub illuminant: Option<String>,
    /// Output PNG.
    pub out: PathBuf,
    /// ΔE00 table CSV.
    pub table: Option<PathBuf>,
}

/// The ΔE00 table of a prism evaluation (CSV).
pub fn prism_table_csv(eval: &PrismEvaluation) -> String {
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
    csv
}

/// Reads the preset, declares the chart (and table), renders, stages them and returns the
/// summary to print.
pub fn run_prism(job: &PrismJob, out: &mut Outputs) -> Result<Value> {
    out.input(&job.preset);
    let preset = read_material(&job.preset)?;
    let file = job.preset.display().to_string();
    let d = preset.dispersion.as_ref().ok_or_else(|| {
        Error::message(format!(
            "{file}: dispersion: missing; write one with `lumifit dispersion fit`"
        ))
    })?;
    out.declare("--out", &job.out)?;
    if let Some(t) = &job.table {
        out.declare("--table", t)?;
    }
    let model = d
        .to_model()
        .map_err(|e| e.context(format!("{file}: dispersion.model")))?;
    let space = RgbSpace::from_name(&d.working_space)?;
    let ill_name = job
        .illuminant
        .clone()
        .or_else(|| {
            d.extra
                .get("illuminant")
                .and_then(|v| v.as_str())
                .map(String::from)
        })
        .unwrap_or_else(|| "E".into());
    let illuminant = resolve_illuminant("--illuminant", &ill_name)?;
    let obs_name = d
        .extra
        .get("observer")
        .and_then(|v| v.as_str())
        .unwrap_or("cie1931-2");
    let observer = Observer::standard(StandardObserver::from_name(obs_name)?)?;
    let range = [d.range_nm[0].ceil(), d.range_nm[1].floor()];
    let slices = slices_for(observer, &illuminant, &space, range)?;
    let setup = &job.setup;
    let computed = |label: String, n: usize| -> Result<CaseInput> {
        let set = wavelength_samples(&slices, n)?;
        Ok((
            label,
            set.samples.iter().map(|s| (s.lambda_nm, s.rgb)).collect(),
            Some(set.samples.iter().map(|s| s.target_rgb).collect()),
        ))
    };
    let mut target = None;
    let main: CaseInput = match job.samples {
        PrismSamples::TargetDe00(t) => {
            let found = smallest_n_for(&model, &slices, setup, t, 401)?;
            let (n, _) = found.ok_or_else(|| {
                Error::flag(
                    format!("--target-de00 {t}"),
                    format!("no N up to 401 samples reaches a maximum sampling ΔE00 of {t}"),
                )
            })?;
            target = Some(n);
            computed(format!("N = {n} (smallest for sampling ΔE00 ≤ {t})"), n)?
        }
        PrismSamples::Count(n) => computed(format!("N = {n}"), n)?,
        PrismSamples::Preset => (
            format!("preset samples (N = {})", d.samples.len()),
            d.samples.iter().map(|s| (s.lambda_nm, s.rgb)).collect(),
            None,
        ),
    };
    let mut cases = vec![main];
    if job.table.is_some() {
        for n in [3, 5, 7, 11, 21] {
            cases.push(computed(format!("N = {n}"), n)?);
        }
        cases.push(("Blanchette 2012 Table 2".into(), table2_samples(), None));
    }
    let eval = evaluate(&model, &slices, setup, cases)?;
    let title = format!(
        "{}: prism {}°, incidence {:.2}°, beam {} mm at {} m — {}",
        preset.name,
        setup.apex_deg,
        eval.layout.incidence_deg,
        setup.beam_width_mm,
        setup.screen_distance_m,
        eval.cases[0].label
    );
    out.stage(
        &job.out,
        &crate::plot::dispersion::prism_chart_png(&title, &eval, 0)?,
    )?;
    if let Some(t) = &job.table {
        out.stage_text(t, &prism_table_csv(&eval))?;
    }
    let rows: Vec<_> = eval
        .cases
        .iter()
        .map(|c| json!({"case": c.label, "n_samples": c.samples.len(), "mean_de00": c.difference.mean, "max_de00": c.difference.max,
                        "mean_de00_sampling_only": c.sampling_only.as_ref().map(|s| s.mean),
                        "max_de00_sampling_only": c.sampling_only.as_ref().map(|s| s.max)}))
        .collect();
    Ok(json!({
        "preset": file,
        "incidence_deg": eval.layout.incidence_deg,
        "deviation_d_deg": eval.layout.deviation_d_deg,
        "pixels": eval.layout.n_pixels,
        "smallest_n_for_target": target,
        "cases": rows,
    }))
}
