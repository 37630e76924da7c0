//! `lumifit spectrum recover`: the spectrum of the light (or a reflectance factor) from one photo
//! through the calibrated LVF.

// `!(a > b)` comparisons deliberately reject NaN along with out-of-range values.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use std::path::PathBuf;

use anyhow::{anyhow, bail, Result};
use clap::{ArgGroup, Args, Subcommand};
use lumifit::fit::regularized::Weight;
use lumifit::io::Outputs;
use lumifit::pipeline::acquisition::{
    parse_recovery_grid, recover_spectrum, recovery_csv, recovery_plot_png, recovery_summary,
    RecoverInputs,
};
use lumifit::preset::phosphor::provenance_of_files;
use lumifit::preset::{to_json_string, MaterialPreset, Provenance, ReflectanceSection};
use lumifit::recovery::{Recovered, RecoveryOptions};

use super::emit;

/// `lumifit spectrum …`.
#[derive(Debug, Subcommand)]
pub enum SpectrumCommand {
    /// Recover a spectrum (or a reflectance factor) from one photo through the calibrated LVF.
    ///
    /// Each band of the LVF gives three camera readings; the spectrum on the grid is the
    /// non-negative, smoothness-regularised least-squares solution (weight by generalised
    /// cross-validation unless --reg gives it). Writes `wavelength_nm,value,std` and prints a
    /// JSON summary with the effective resolution per wavelength.
    Recover(RecoverArgs),
}

/// `spectrum recover`.
#[derive(Debug, Args)]
#[command(group(ArgGroup::new("input").required(true).args(["image", "readings"])))]
pub struct RecoverArgs {
    /// The photo through the LVF (TIFF, PNG or camera RAW; linear).
    pub image: Option<PathBuf>,
    /// Instead of a photo: readings per band, CSV `band,r,g,b[,std_r,std_g,std_b]` (band 1-based).
    #[arg(long)]
    pub readings: Option<PathBuf>,
    /// Band transmissions: `lvf_bands.json` from `lvf transmission`, or the `lvf.json` of the
    /// wavelength calibration alone (then each band is the calibrated Gaussian passband averaged
    /// over its pixel window, peak 1).
    #[arg(long)]
    pub bands: PathBuf,
    /// Camera sensitivities CSV `wavelength_nm,r,g,b` (default: calib/camera_default.csv, Nikon
    /// 5100 NPL).
    #[arg(long)]
    pub camera: Option<PathBuf>,
    /// Region `x,y,w,h` (source pixels) to average across the filter; default: the calibration's
    /// ROI.
    #[arg(long)]
    pub roi: Option<String>,
    /// Recovery grid `LO:HI:STEP` in nm (default 400:700:5, clipped to the band file's grid).
    #[arg(long)]
    pub grid: Option<String>,
    /// Penalty weight: `gcv` or a relative value λ ≥ 0 (0 = plain non-negative least squares).
    #[arg(long, default_value = "gcv")]
    pub reg: String,
    /// Drop the non-negativity constraint (`--reg 0 --no-nonneg` is plain least squares; for
    /// comparisons — the system is badly conditioned and the result oscillates).
    #[arg(long)]
    pub no_nonneg: bool,
    /// Write the weighted system actually solved to this JSON (A column-major, b, λ, μ, the
    /// difference order, the solution x and the solve time), so another solver can solve the
    /// identical problem.
    #[arg(long)]
    pub dump_system: Option<PathBuf>,
    /// Reflectance mode: the illuminant (CIE name, daylight:<K>, blackbody:<K> or CSV); the
    /// output is a reflectance factor.
    #[arg(long)]
    pub illuminant: Option<String>,
    /// Reflectance mode: a capture of a white reference under the same light and exposure. With
    /// --illuminant it fixes the exposure; alone, its recovered spectrum is the illuminant.
    #[arg(long)]
    pub white: Option<PathBuf>,
    /// Reflectance of the white reference: a number or CSV `wavelength_nm,value`.
    #[arg(long, default_value = "1.0")]
    pub white_reflectance: String,
    /// With --illuminant and no --white: readings = exposure · Σ R·S·T·Q·Δλ.
    #[arg(long, default_value_t = 1.0)]
    pub exposure: f64,
    /// Reference spectrum CSV drawn on the plot and compared in the summary (RMS).
    #[arg(long)]
    pub compare: Option<PathBuf>,
    /// Output CSV `wavelength_nm,value,std`.
    #[arg(long)]
    pub out: PathBuf,
    /// Also write the JSON summary to this file.
    #[arg(long)]
    pub summary: Option<PathBuf>,
    /// Plot PNG: recovered spectrum ± 2σ (with --compare) and the resolution per wavelength.
    #[arg(long)]
    pub plot: Option<PathBuf>,
    /// Reflectance mode (--illuminant or --white): also write a material preset
    /// (`lumifit.material/1`) with the recovered reflectance as its `reflectance` section (the
    /// per-wavelength σ beside it as `std`), validated before it is written.
    #[arg(long)]
    pub preset: Option<PathBuf>,
    /// Material name in the --preset (default: the photo's file stem).
    #[arg(long, requires = "preset")]
    pub name: Option<String>,
}

/// Runs a `spectrum` subcommand.
pub fn run(cmd: SpectrumCommand) -> Result<()> {
    match cmd {
        SpectrumCommand::Recover(a) => recover_cmd(&a),
    }
}

fn recover_cmd(a: &RecoverArgs) -> Result<()> {
    let weight = match a.reg.trim().to_ascii_lowercase().as_str() {
        "gcv" => Weight::Gcv,
        s => {
            let v: f64 = s
                .parse()
                .map_err(|_| anyhow!("--reg: '{}' is neither 'gcv' nor a number", a.reg))?;
            if !(v >= 0.0) || !v.is_finite() {
                bail!("--reg: {v}; expected a finite relative weight ≥ 0");
            }
            Weight::Fixed(v)
        }
    };
    if !(a.exposure > 0.0) || !a.exposure.is_finite() {
        bail!("--exposure: {}; expected a finite value > 0", a.exposure);
    }
    if a.preset.is_some() && a.illuminant.is_none() && a.white.is_none() {
        bail!(
            "--preset writes a reflectance preset, but without --illuminant or --white the \
             recovered spectrum is the light itself; give the illuminant (--illuminant NAME|CSV) \
             or a white reference capture (--white FILE) to recover a reflectance factor"
        );
    }
    let inputs = RecoverInputs {
        image: a.image.clone(),
        readings: a.readings.clone(),
        bands: a.bands.clone(),
        camera: a.camera.clone(),
        roi: a.roi.as_deref().map(super::parse_rect).transpose()?,
        grid: a
            .grid
            .as_deref()
            .map(|g| parse_recovery_grid("--grid", g))
            .transpose()?,
        illuminant: a.illuminant.clone(),
        white: a.white.clone(),
        white_reflectance: a.white_reflectance.clone(),
        exposure: a.exposure,
        compare: a.compare.clone(),
    };
    let mut out = Outputs::new();
    out.inputs(inputs.files());
    out.declare("--out", &a.out)?;
    for (flag, p) in [
        ("--dump-system", &a.dump_system),
        ("--summary", &a.summary),
        ("--plot", &a.plot),
        ("--preset", &a.preset),
    ] {
        if let Some(p) = p {
            out.declare(flag, p)?;
        }
    }
    let opts = RecoveryOptions {
        weight,
        nonnegative: !a.no_nonneg,
        ..Default::default()
    };
    let outcome = recover_spectrum(&inputs, &opts, a.dump_system.is_some())?;
    let text = serde_json::to_string_pretty(&recovery_summary(&outcome, &inputs, &a.out))?;
    out.stage(&a.out, recovery_csv(&outcome.rec).as_bytes())?;
    if let (Some(p), Some(d)) = (&a.dump_system, &outcome.dump) {
        out.stage(p, serde_json::to_string(d)?.as_bytes())?;
    }
    if let Some(p) = &a.summary {
        out.stage(p, text.as_bytes())?;
    }
    if let Some(p) = &a.plot {
        out.stage(p, &recovery_plot_png(&outcome)?)?;
    }
    if let Some(p) = &a.preset {
        let name = a.name.clone().unwrap_or_else(|| {
            a.image
                .as_ref()
                .or(a.readings.as_ref())
                .and_then(|f| f.file_stem())
                .map_or("recovered".into(), |s| s.to_string_lossy().to_string())
        });
        let provenance = provenance_of_files("lumifit spectrum recover", &inputs.files())?
            .with_fit_quality(serde_json::json!({
                "regularisation": outcome.rec.lambda,
                "mode": outcome.mode,
            }));
        let preset = reflectance_preset(&outcome.rec, &name, provenance, &outcome.mode);
        out.stage_text(p, &to_json_string(&preset)?)?;
    }
    out.commit()?;
    emit(&text)
}

/// The reflectance preset of a recovery: the values on the grid, and beside them (open fields)
/// σ per wavelength and what was recovered.
fn reflectance_preset(
    rec: &Recovered,
    name: &str,
    provenance: Provenance,
    mode: &str,
) -> MaterialPreset {
    let mut section = ReflectanceSection::new(rec.wavelength_nm.clone(), rec.value.clone());
    if rec.std.iter().all(|v| v.is_finite()) {
        section
            .extra
            .insert("std".into(), serde_json::json!(rec.std));
    }
    section.extra.insert(
        "source".into(),
        serde_json::json!(format!("lumifit spectrum recover ({mode}) through the LVF")),
    );
    MaterialPreset {
        reflectance: Some(section),
        ..MaterialPreset::new(name, provenance)
    }
}
