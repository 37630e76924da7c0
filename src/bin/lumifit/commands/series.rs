//! `lumifit` photo series: being written.

use anyhow::Result;
use clap::Subcommand;

/// Subcommands (photo series).
#[derive(Debug, Subcommand)]
pub enum SeriesCommand {}

/// Runs one of these subcommands.
pub fn run(cmd: SeriesCommand) -> Result<()> {
    match cmd {}
}
