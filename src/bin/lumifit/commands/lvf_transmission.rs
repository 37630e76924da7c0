//! `lumifit lvf transmission`: solve each band's transmission from photos of a grey target
//! through the LVF and colour gels (Nalbach et al. 2017 §4.2), or write the parametric bands of
//! the wavelength calibration alone (`--model calibration`).

use std::path::PathBuf;

use anyhow::{bail, Result};
use clap::{Args, ValueEnum};
use lumifit::fit::regularized::Weight;
use lumifit::io::Outputs;
use lumifit::lvf::transmission::{BandModel, DEFAULT_SUPPORT_FWHM};
use lumifit::pipeline::acquisition::{
    band_transmissions, parse_transmission_grid, transmission_summary, TransmissionConfig,
    TransmissionInputs,
};
use lumifit::plot::lvf_bands::lvf_bands_chart_png;

use super::emit;

/// Band model.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum ModelArg {
    /// Free shape on the grid: non-negative, smoothness-regularised (GCV), support window.
    Nnls,
    /// Free shape by plain least squares (the baseline; no penalty, no sign constraint).
    Lstsq,
    /// Window-averaged Gaussian passband: centre, FWHM, peak.
    Gaussian,
    /// Window-averaged super-Gaussian passband: centre, FWHM, exponent, peak.
    SuperGaussian,
    /// From lvf.json alone: centre from the map, FWHM from the lamp fit, peak 1.
    Calibration,
}

/// `lvf transmission`.
#[derive(Debug, Args)]
pub struct TransmissionArgs {
    /// The wavelength calibration (lvf.json from `lvf calibrate`).
    #[arg(long)]
    pub lvf: PathBuf,
    /// CSV `image,filter`: one photo per line (paths relative to the CSV); filter = a code of the
    /// --filters table, or `none`/empty for the open LVF.
    #[arg(long)]
    pub captures: Option<PathBuf>,
    /// Gel table (Lee layout `code,name,<nm>…` or `wavelength_nm,<code>…`).
    #[arg(long)]
    pub filters: Option<PathBuf>,
    /// Light source: a CIE name (LED-B3, D65 …), daylight:<K>, blackbody:<K> or a CSV
    /// (`--source` is the deprecated spelling).
    #[arg(long = "illuminant", alias = "source")]
    pub source: Option<String>,
    /// Target reflectance CSV wavelength_nm,value.
    #[arg(long)]
    pub target: Option<PathBuf>,
    /// Camera sensitivities: CSV wavelength_nm,r,g,b, DATABASE:NAME (a long CSV
    /// camera,wavelength_nm,r,g,b or Jiang's camspec_database.txt), or Academy spectral-data
    /// JSON as in rawtoaces-data (default: calib/camera_default.csv).
    #[arg(long)]
    pub camera: Option<PathBuf>,
    /// Band model.
    #[arg(long, value_enum, default_value = "nnls")]
    pub model: ModelArg,
    /// Smoothness weight of nnls: gcv or a relative value λ ≥ 0.
    #[arg(long, default_value = "gcv")]
    pub reg: String,
    /// Drop the non-negativity constraint of nnls.
    #[arg(long)]
    pub no_nonneg: bool,
    /// Solve grid LO:HI:STEP (nm). Default: 5 nm over the bands' support, clipped to where
    /// source × target × camera is above 1e-3 of its peak.
    #[arg(long)]
    pub grid: Option<String>,
    /// Support half-width of nnls/lstsq bands in effective calibration FWHMs (T = 0 outside).
    #[arg(long, default_value_t = DEFAULT_SUPPORT_FWHM)]
    pub support: f64,
    /// Allow gels measured over a narrower range than the grid, holding each gel's edge values
    /// constant up to NM beyond its range.
    #[arg(long, default_value_t = 0.0)]
    pub extend_filters: f64,
    /// Do not weight equations by the readings' standard errors.
    #[arg(long)]
    pub unweighted: bool,
    /// Output band file JSON (lvf_bands.json).
    #[arg(long)]
    pub out: PathBuf,
    /// PNG plot of the band transmissions and the fitted centres and widths.
    #[arg(long)]
    pub plot: Option<PathBuf>,
}

/// Runs `lvf transmission`.
pub fn run(a: &TransmissionArgs) -> Result<()> {
    let t0 = std::time::Instant::now();
    if !(a.support.is_finite() && a.support > 0.5 && a.support <= 10.0) {
        bail!("--support: {}; expected 0.5–10 FWHMs", a.support);
    }
    if !(a.extend_filters.is_finite() && a.extend_filters >= 0.0) {
        bail!("--extend-filters: {}; expected ≥ 0 nm", a.extend_filters);
    }
    let inputs = TransmissionInputs {
        lvf: a.lvf.clone(),
        captures: a.captures.clone(),
        filters: a.filters.clone(),
        source: a.source.clone(),
        target: a.target.clone(),
        camera: a.camera.clone(),
    };
    let job = inputs.open()?;
    let mut out = Outputs::new();
    out.inputs(job.files());
    out.declare("--out", &a.out)?;
    if let Some(p) = &a.plot {
        out.declare("--plot", p)?;
    }
    let config = TransmissionConfig {
        model: match a.model {
            ModelArg::Nnls => BandModel::Nnls,
            ModelArg::Lstsq => BandModel::Lstsq,
            ModelArg::Gaussian => BandModel::Gaussian,
            ModelArg::SuperGaussian => BandModel::SuperGaussian,
            ModelArg::Calibration => BandModel::Calibration,
        },
        grid: a.grid.as_deref().map(parse_transmission_grid).transpose()?,
        support_fwhm: a.support,
        extend_filters_nm: a.extend_filters,
        weight: parse_weight(&a.reg)?,
        nonnegative: !a.no_nonneg,
        use_std: !a.unweighted,
    };
    let bar = super::progress_bar(job.photo_count(), "reading", "captures");
    let mut warnings = Vec::new();
    let set = band_transmissions(&job, &config, &|| bar.inc(1), &mut warnings);
    bar.finish_and_clear();
    for w in &warnings {
        eprintln!("warning: {w}");
    }
    let mut set = set?;
    let seconds = t0.elapsed().as_secs_f64();
    if let Some(obj) = set.diagnostics.as_object_mut() {
        obj.insert("seconds".into(), serde_json::json!(seconds));
    }
    out.stage(&a.out, set.to_json()?.as_bytes())?;
    if let Some(p) = &a.plot {
        out.stage(p, &lvf_bands_chart_png(&set)?)?;
    }
    out.commit()?;
    emit(&serde_json::to_string_pretty(&transmission_summary(
        &set, &a.out, seconds,
    ))?)
}

/// `--reg`: `gcv` or a relative weight λ ≥ 0.
fn parse_weight(reg: &str) -> Result<Weight> {
    if reg.eq_ignore_ascii_case("gcv") {
        return Ok(Weight::Gcv);
    }
    let v: f64 = reg
        .parse()
        .map_err(|_| anyhow::anyhow!("--reg: '{reg}'; expected gcv or a number ≥ 0"))?;
    if !(v.is_finite() && v >= 0.0) {
        bail!("--reg: {v}; expected gcv or a number ≥ 0");
    }
    Ok(Weight::Fixed(v))
}
