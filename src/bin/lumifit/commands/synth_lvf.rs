//! `lumifit` synthetic LVF captures; flattened into `lumifit synth`: being written.

use anyhow::Result;
use clap::Subcommand;

/// Subcommands (synthetic LVF captures; flattened into `lumifit synth`).
#[derive(Debug, Subcommand)]
pub enum LvfSynthCommand {}

/// Runs one of these subcommands.
pub fn run(cmd: LvfSynthCommand) -> Result<()> {
    match cmd {}
}
