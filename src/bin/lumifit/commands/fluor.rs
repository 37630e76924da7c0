//! `lumifit fluor …` (fluorescence): being written.

use anyhow::Result;
use clap::Subcommand;

/// Subcommands of `lumifit fluor`.
#[derive(Debug, Subcommand)]
pub enum FluorCommand {}

/// Runs a `lumifit fluor` subcommand.
pub fn run(cmd: FluorCommand) -> Result<()> {
    match cmd {}
}
