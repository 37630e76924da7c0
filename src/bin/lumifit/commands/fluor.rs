//! `lumifit fluor …` (fluorescence): Donaldson-matrix reduction (Fichet et al. 2024), its
//! evaluation against the spectral reference, basis selection and presets.

use std::path::PathBuf;

use anyhow::Result;
use clap::{Args, Subcommand};
use lumifit::fluor::{DEFAULT_ILLUMINANTS, DEFAULT_METHODS};
use lumifit::io::Outputs;
use lumifit::pipeline::fluor::{self as job, Conditions, EvalJob, ReduceJob, SelectJob, SweepJob};

use super::emit;

/// Subcommands of `lumifit fluor`.
#[derive(Debug, Subcommand)]
pub enum FluorCommand {
    /// Reduce one Donaldson matrix to a K×K matrix in a basis and write a material preset.
    Reduce(ReduceArgs),
    /// ΔE00 of reduced against spectral rendering: materials × illuminants × methods.
    Eval(EvalArgs),
    /// Pick the smallest basis whose worst ΔE00 under the scene's illuminants is below a target.
    Select(SelectArgs),
    /// Monochromatic sweep: one-bounce XYZ per excitation wavelength, reference vs reduced (CSV).
    Sweep(SweepArgs),
}

/// Options shared by every subcommand: observer, grid, matrix conditioning.
#[derive(Debug, Args)]
pub struct CommonArgs {
    /// Observer of the XYZ basis (cie2015-2 = CIE 2006 2°, as the paper; cie1931-2, …).
    #[arg(long, default_value = "cie2015-2")]
    pub observer: String,
    /// Working grid step in nm (grid 300–780 nm).
    #[arg(long, default_value_t = 1.0)]
    pub step_nm: f64,
    /// Zero anti-Stokes entries (excitation ≥ emission off the diagonal).
    #[arg(long)]
    pub zero_anti_stokes: bool,
    /// Keep negative entries (by default measurement-noise negatives are clipped to 0).
    #[arg(long)]
    pub keep_negatives: bool,
}

#[derive(Debug, Args)]
#[command(group(clap::ArgGroup::new("dest").required(true).args(["out", "out_dir"])))]
pub struct ReduceArgs {
    /// Donaldson matrices: BFC-450 files or CSV (header `emission_nm,<excitation nm>…`), or
    /// folders of them (every *.bfc / *.csv inside, sorted). Several need --out-dir.
    #[arg(required = true)]
    pub matrices: Vec<PathBuf>,
    /// Basis: xyz, xyzu, xyz7u or a basis CSV (`wavelength_nm,f1,…,fK`).
    #[arg(long, default_value = "xyz")]
    pub basis: String,
    /// Reduction: dual (Fichet 2024 Eq. 15) or naive (Eq. 7).
    #[arg(long, default_value = "dual")]
    pub method: String,
    /// RGB working space for the 3×3 matrix of Eq. 16: srgb, rec2020, acescg.
    #[arg(long, default_value = "srgb")]
    pub rgb: String,
    /// Illuminants of the ΔE00 table stored with the preset (names or SPD CSV files).
    #[arg(long, value_delimiter = ',', default_values_t = DEFAULT_ILLUMINANTS.map(String::from))]
    pub illuminants: Vec<String>,
    /// Output material preset (JSON), for one matrix.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Output folder: one preset `<file stem>.json` per matrix (any number of matrices).
    #[arg(long)]
    pub out_dir: Option<PathBuf>,
    /// Also write the ΔE00 table of every matrix, CSV `material,file,illuminant,method,delta_e00`
    /// (`-` for standard output; the summary then goes to standard error).
    #[arg(long)]
    pub table: Option<PathBuf>,
    /// Also write a PNG of the Donaldson matrix, the reduced matrix and ΔE00 per illuminant (one
    /// matrix only).
    #[arg(long)]
    pub plot: Option<PathBuf>,
    #[command(flatten)]
    pub common: CommonArgs,
}

#[derive(Debug, Args)]
pub struct EvalArgs {
    /// Donaldson matrices (BFC-450 or CSV), or folders of them (every *.bfc / *.csv inside).
    #[arg(required = true)]
    pub matrices: Vec<PathBuf>,
    /// Illuminants: CIE names or SPD CSV files.
    #[arg(long, value_delimiter = ',', default_values_t = DEFAULT_ILLUMINANTS.map(String::from))]
    pub illuminants: Vec<String>,
    /// Methods `<dual|naive>-<xyz|xyzu|xyz7u>`.
    #[arg(long, value_delimiter = ',', default_values_t = DEFAULT_METHODS.map(String::from))]
    pub methods: Vec<String>,
    /// Print one JSON array of `{material, illuminant, method, delta_e00, xyz_reference, xyz_reduced}`.
    #[arg(long)]
    pub json: bool,
    /// The table (CSV `material,illuminant,method,delta_e00`, or the JSON array with --json):
    /// a file, or `-` for standard output. The summary (mean / max ΔE00 per method and
    /// illuminant) always goes to standard error.
    #[arg(long, default_value = "-")]
    pub out: PathBuf,
    /// Also write one material preset per matrix into this folder (`<file stem>.json`), reduced
    /// with the first of --methods, its ΔE00 table under --illuminants inside.
    #[arg(long)]
    pub out_dir: Option<PathBuf>,
    /// RGB working space of the presets' 3×3 matrix (--out-dir): srgb, rec2020, acescg.
    #[arg(long, default_value = "srgb", requires = "out_dir")]
    pub rgb: String,
    /// Write a PNG: the first matrix, its reduced matrices and mean ΔE00 per illuminant and method.
    #[arg(long)]
    pub plot: Option<PathBuf>,
    #[command(flatten)]
    pub common: CommonArgs,
}

#[derive(Debug, Args)]
pub struct SelectArgs {
    /// Donaldson matrix (BFC-450 or CSV).
    pub matrix: PathBuf,
    /// The illuminants the scene uses (names or SPD CSV files).
    #[arg(long, value_delimiter = ',', default_values_t = DEFAULT_ILLUMINANTS.map(String::from))]
    pub illuminants: Vec<String>,
    /// Target: worst ΔE00 over the illuminants must be below this.
    #[arg(long, default_value_t = 1.0)]
    pub target_de: f64,
    /// Extra candidate bases (CSV files), tried with the built-ins in order of size.
    #[arg(long, value_delimiter = ',')]
    pub extra_basis: Vec<PathBuf>,
    /// Print JSON instead of a table.
    #[arg(long)]
    pub json: bool,
    /// Output file for the table (or JSON); `-` is standard output.
    #[arg(long, default_value = "-")]
    pub out: PathBuf,
    #[command(flatten)]
    pub common: CommonArgs,
}

#[derive(Debug, Args)]
pub struct SweepArgs {
    /// Donaldson matrix (BFC-450 or CSV).
    pub matrix: PathBuf,
    /// Methods `<dual|naive>-<xyz|xyzu|xyz7u>`.
    #[arg(long, value_delimiter = ',', default_values_t = ["dual-xyz", "dual-xyzu", "dual-xyz7u"].map(String::from))]
    pub methods: Vec<String>,
    /// Report every n-th grid sample.
    #[arg(long, default_value_t = 5)]
    pub every: usize,
    /// Output CSV; `-` is standard output.
    #[arg(long, default_value = "-")]
    pub out: PathBuf,
    #[command(flatten)]
    pub common: CommonArgs,
}

/// Runs a `lumifit fluor` subcommand: one call of [`lumifit::pipeline::fluor`].
pub fn run(cmd: FluorCommand) -> Result<()> {
    let mut out = Outputs::new();
    let note = |n: &str| eprintln!("{n}");
    let command = std::env::args().collect::<Vec<_>>().join(" ");
    let summary = match cmd {
        FluorCommand::Reduce(a) => Some(job::run_reduce(&a.config(command), &mut out, &note)?),
        FluorCommand::Eval(a) => Some(job::run_eval(&a.config(command), &mut out)?),
        FluorCommand::Select(a) => {
            let config = SelectJob {
                matrix: a.matrix,
                illuminants: a.illuminants,
                target_de: a.target_de,
                extra_basis: a.extra_basis,
                json: a.json,
                out: a.out,
                conditions: a.common.config(),
            };
            job::run_select(&config, &mut out, &note)?;
            None
        }
        FluorCommand::Sweep(a) => {
            let config = SweepJob {
                matrix: a.matrix,
                methods: a.methods,
                every: a.every,
                out: a.out,
                conditions: a.common.config(),
            };
            job::run_sweep(&config, &mut out)?;
            None
        }
    };
    out.commit()?;
    match summary {
        Some(s) if s.to_stderr => eprintln!("{}", s.text),
        Some(s) => emit(&s.text)?,
        None => {}
    }
    Ok(())
}

impl CommonArgs {
    fn config(&self) -> Conditions {
        Conditions {
            observer: self.observer.clone(),
            step_nm: self.step_nm,
            zero_anti_stokes: self.zero_anti_stokes,
            keep_negatives: self.keep_negatives,
        }
    }
}

impl ReduceArgs {
    fn config(self, command: String) -> ReduceJob {
        ReduceJob {
            conditions: self.common.config(),
            matrices: self.matrices,
            basis: self.basis,
            method: self.method,
            rgb: self.rgb,
            illuminants: self.illuminants,
            out: self.out,
            out_dir: self.out_dir,
            table: self.table,
            plot: self.plot,
            command,
        }
    }
}

impl EvalArgs {
    fn config(self, command: String) -> EvalJob {
        EvalJob {
            conditions: self.common.config(),
            matrices: self.matrices,
            illuminants: self.illuminants,
            methods: self.methods,
            json: self.json,
            out: self.out,
            out_dir: self.out_dir,
            rgb: self.rgb,
            plot: self.plot,
            command,
        }
    }
}
