//! `lumifit phos fit-excitation`, `lumifit phos design` and `lumifit synth phos-excitation`: being
//! written.

use anyhow::Result;
use clap::Subcommand;

/// Excitation-rate fitting and design from keyframes (flattened into `lumifit phos`).
#[derive(Debug, Subcommand)]
pub enum PhosExcitationCommand {}

/// Charging-experiment generators (flattened into `lumifit synth`).
#[derive(Debug, Subcommand)]
pub enum SynthExcitationCommand {}

/// Runs a `lumifit phos` excitation/design subcommand.
pub fn run(cmd: PhosExcitationCommand) -> Result<()> {
    match cmd {}
}

/// Runs a `lumifit synth` charging-experiment generator.
pub fn run_synth(cmd: SynthExcitationCommand) -> Result<()> {
    match cmd {}
}
