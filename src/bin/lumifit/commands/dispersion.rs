//! `lumifit dispersion …`: fit n(λ) into a preset's dispersion section, and check its wavelength
//! samples on the prism reference consumer.

use std::path::PathBuf;

use anyhow::{bail, Result};
use clap::{Args, Subcommand};
use lumifit::dispersion::prism::PrismSetup;
use lumifit::io::Outputs;
use lumifit::pipeline::dispersion::{self as job, FitJob, IndexInput, PrismJob, PrismSamples};

use super::emit;

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
    let mut out = Outputs::new();
    match cmd {
        DispersionCommand::Fit(a) => {
            let command = std::env::args().collect::<Vec<_>>().join(" ");
            let summary = job::run_fit(&a.config(command)?, &mut out)?;
            out.commit()?;
            if a.out.as_os_str() != "-" {
                emit(&serde_json::to_string_pretty(&summary)?)?;
            }
            Ok(())
        }
        DispersionCommand::Prism(a) => {
            let summary = job::run_prism(&a.config(), &mut out)?;
            out.commit()?;
            emit(&serde_json::to_string_pretty(&summary)?)
        }
    }
}

impl FitArgs {
    fn config(&self, command: String) -> Result<FitJob> {
        let input = match (&self.input, &self.glass) {
            (Some(path), _) => IndexInput::File(path.clone()),
            (None, Some(g)) => IndexInput::Glass(g.clone()),
            (None, None) => bail!("give an input file or --glass NAME"),
        };
        Ok(FitJob {
            input,
            model: self.model.clone(),
            range: self.range.clone(),
            tolerance: self.tolerance,
            samples: self.samples,
            working_space: self.working_space.clone(),
            illuminant: self.illuminant.clone(),
            observer: self.observer.clone(),
            convert: self.convert.clone(),
            name: self.name.clone(),
            out: self.out.clone(),
            plot: self.plot.clone(),
            command,
        })
    }
}

impl PrismArgs {
    fn config(&self) -> PrismJob {
        PrismJob {
            preset: self.preset.clone(),
            samples: match (self.target_de00, self.samples) {
                (Some(t), _) => PrismSamples::TargetDe00(t),
                (None, Some(n)) => PrismSamples::Count(n),
                (None, None) => PrismSamples::Preset,
            },
            setup: PrismSetup {
                apex_deg: self.apex_deg,
                incidence_deg: self.incidence_deg,
                screen_distance_m: self.screen_distance_m,
                beam_width_mm: self.beam_width_mm,
                pixel_mm: self.pixel_mm,
            },
            illuminant: self.illuminant.clone(),
            out: self.out.clone(),
            table: self.table.clone(),
        }
    }
}
