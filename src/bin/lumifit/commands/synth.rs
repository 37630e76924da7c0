//! `lumifit synth …` (synthetic data): being written.

use anyhow::Result;
use clap::Subcommand;

/// Subcommands of `lumifit synth`.
#[derive(Debug, Subcommand)]
pub enum SynthCommand {}

/// Runs a `lumifit synth` subcommand.
pub fn run(cmd: SynthCommand) -> Result<()> {
    match cmd {}
}
