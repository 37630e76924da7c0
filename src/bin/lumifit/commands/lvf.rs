//! `lumifit` LVF calibration: being written.

use anyhow::Result;
use clap::Subcommand;

/// Subcommands (LVF calibration).
#[derive(Debug, Subcommand)]
pub enum LvfCommand {}

/// Runs one of these subcommands.
pub fn run(cmd: LvfCommand) -> Result<()> {
    match cmd {}
}
