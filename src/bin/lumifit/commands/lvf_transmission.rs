//! `lumifit lvf transmission`: solve each band's transmission from gel photos.

use std::path::PathBuf;

use anyhow::{bail, Result};
use clap::Args;

/// `lvf transmission`.
#[derive(Debug, Args)]
pub struct TransmissionArgs {
    /// Output band file JSON.
    #[arg(long)]
    pub out: PathBuf,
}

/// Runs `lvf transmission`.
pub fn run(_a: &TransmissionArgs) -> Result<()> {
    bail!("'lvf transmission' is not implemented yet")
}
