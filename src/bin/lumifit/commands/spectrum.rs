//! `lumifit spectrum recover`: the spectrum of the light (or a reflectance) from one photo
//! through the calibrated LVF.

use std::path::PathBuf;

use anyhow::{bail, Result};
use clap::{Args, Subcommand};

/// `lumifit spectrum …`.
#[derive(Debug, Subcommand)]
pub enum SpectrumCommand {
    /// Recover a spectrum from one photo through the LVF.
    Recover(RecoverArgs),
}

/// `spectrum recover`.
#[derive(Debug, Args)]
pub struct RecoverArgs {
    /// The photo.
    pub image: PathBuf,
    /// Output CSV.
    #[arg(long)]
    pub out: PathBuf,
}

/// Runs a `spectrum` subcommand.
pub fn run(cmd: SpectrumCommand) -> Result<()> {
    match cmd {
        SpectrumCommand::Recover(_a) => bail!("'spectrum recover' is not implemented yet"),
    }
}
