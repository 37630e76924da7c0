//! Command implementations: validate arguments into library types, call the library, print or
//! write the results.

pub mod color;
pub mod demo;
pub mod fluor;
pub mod phos;
pub mod preset;
pub mod synth;

use std::path::Path;

use anyhow::Result;
use lumifit::colorimetry::Illuminant;
use lumifit::io::spectrum_csv;

use crate::args::{Cli, ColorCommand, Command, PresetCommand};

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
        Command::Fluor(c) => fluor::run(c),
        Command::Phos(c) => phos::run(c),
        Command::Synth(c) => synth::run(c),
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

/// An illuminant given as a CIE name or as a CSV file.
pub fn resolve_illuminant(arg: &str) -> Result<Illuminant> {
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
