//! Command implementations: validate arguments into library types, call the library, print or
//! write the results.

pub mod color;
pub mod demo;
pub mod dispersion;
pub mod fluor;
pub mod lvf;
pub mod lvf_transmission;
pub mod phos;
pub mod phos_excitation;
pub mod preset;
pub mod preset_export;
pub mod series;
pub mod spectrum;
pub mod synth;
pub mod synth_lvf;

use std::path::Path;

use anyhow::Result;
use lumifit::colorimetry::Illuminant;
use lumifit::io::spectrum_csv;

use crate::args::{Cli, ColorCommand, Command, PresetCommand};

/// `lumifit synth …`: each domain contributes its own generators.
// Parsed once per process; the size of the variants is irrelevant.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, clap::Subcommand)]
pub enum SynthCommands {
    /// Phosphorescence generators.
    #[command(flatten)]
    Phos(synth::SynthCommand),
    /// LVF capture generators.
    #[command(flatten)]
    Lvf(synth_lvf::LvfSynthCommand),
    /// Phosphor charging-experiment generators.
    #[command(flatten)]
    Excitation(phos_excitation::SynthExcitationCommand),
}

/// `lumifit phos …`: simulation and decay fitting, then excitation and design.
// Parsed once per process; the size of the variants is irrelevant.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, clap::Subcommand)]
pub enum PhosCommands {
    /// Simulation and decay fitting.
    #[command(flatten)]
    Decay(phos::PhosCommand),
    /// Excitation-rate fitting and design from keyframes.
    #[command(flatten)]
    Excitation(phos_excitation::PhosExcitationCommand),
}

/// Dispatches a parsed command line.
pub fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Color(ColorCommand::Xyz(a)) => color::xyz(&a),
        Command::Color(ColorCommand::Table(a)) => color::table(&a),
        Command::Color(ColorCommand::DeltaE(a)) => color::delta_e(&a),
        Command::Color(ColorCommand::Convert(a)) => color::convert(&a),
        Command::Preset(PresetCommand::Validate { file }) => {
            let report = preset::validate(&file)?;
            emit(&serde_json::to_string_pretty(&report)?)
        }
        Command::Preset(PresetCommand::Export(a)) => preset_export::run(&a),
        Command::Dispersion(c) => dispersion::run(c),
        Command::Fluor(c) => fluor::run(c),
        Command::Phos(PhosCommands::Decay(c)) => phos::run(c),
        Command::Phos(PhosCommands::Excitation(c)) => phos_excitation::run(c),
        Command::Synth(SynthCommands::Phos(c)) => synth::run(c),
        Command::Synth(SynthCommands::Lvf(c)) => synth_lvf::run(c),
        Command::Synth(SynthCommands::Excitation(c)) => phos_excitation::run_synth(c),
        Command::Series(c) => series::run(c),
        Command::Lvf(c) => lvf::run(c),
        Command::Spectrum(c) => spectrum::run(c),
        Command::Demo(a) => demo::run(&a),
    }
}

/// Writes a line to standard output; a closed pipe (`lumifit … | head`) is not an error.
pub fn emit(text: &str) -> Result<()> {
    use std::io::Write;
    let mut out = std::io::stdout().lock();
    match writeln!(out, "{text}").and_then(|_| out.flush()) {
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Ok(()),
        other => Ok(other?),
    }
}

/// An illuminant given as a CIE name, `daylight:<CCT K>` (CIE D-series of that correlated colour
/// temperature), `blackbody:<T K>` (Planck, 360–830 nm at 1 nm) or a CSV file.
pub fn resolve_illuminant(arg: &str) -> Result<Illuminant> {
    let lower = arg.to_ascii_lowercase();
    for (prefix, daylight) in [("daylight:", true), ("blackbody:", false)] {
        if let Some(rest) = lower.strip_prefix(prefix) {
            let t: f64 = rest.trim().trim_end_matches('k').parse().map_err(|_| {
                anyhow::anyhow!("--illuminant: '{arg}': expected a temperature in K after '{prefix}', e.g. {prefix}5000")
            })?;
            let sd = if daylight {
                lumifit::colorimetry::daylight::sd_d_series_from_cct(t)?
            } else {
                let shape = lumifit::spectrum::SpectralShape::new(360.0, 830.0, 1.0)?;
                lumifit::colorimetry::blackbody::sd_blackbody(t, &shape)?
            };
            let ill = Illuminant::from_spectrum(arg, sd);
            // colour builds D-series spectra with linear interpolation, like the CIE tables.
            return Ok(if daylight {
                ill.with_interpolator(lumifit::math::interpolation::Interpolator::Linear)
            } else {
                ill
            });
        }
    }
    let path = Path::new(arg);
    let looks_like_file = path.is_file()
        || arg == "-"
        || arg.to_ascii_lowercase().ends_with(".csv")
        || arg.contains(std::path::MAIN_SEPARATOR);
    if looks_like_file {
        let sd = spectrum_csv::read_spectrum(path)?;
        Ok(Illuminant::from_spectrum(arg, sd))
    } else {
        Ok(Illuminant::standard(arg)?)
    }
}

/// Parses `a,b,c` into three finite numbers, naming the flag on error.
pub fn parse_triplet(flag: &str, s: &str) -> Result<[f64; 3]> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    if parts.len() != 3 {
        anyhow::bail!("{flag}: expected three comma-separated numbers like 50,10,-20, got '{s}'");
    }
    let mut out = [0.0; 3];
    for (i, p) in parts.iter().enumerate() {
        let v: f64 = p
            .parse()
            .map_err(|_| anyhow::anyhow!("{flag}: component {} '{p}' is not a number", i + 1))?;
        if !v.is_finite() {
            anyhow::bail!("{flag}: component {} must be finite, got '{p}'", i + 1);
        }
        out[i] = v;
    }
    Ok(out)
}
