//! `lumifit phos …` (phosphorescence): being written.

use anyhow::Result;
use clap::Subcommand;

/// Subcommands of `lumifit phos`.
#[derive(Debug, Subcommand)]
pub enum PhosCommand {}

/// Runs a `lumifit phos` subcommand.
pub fn run(cmd: PhosCommand) -> Result<()> {
    match cmd {}
}
