//! Command implementations: validate arguments into library types, call the library, print or
//! write the results.

pub mod afterimage;
pub mod color;
pub mod demo;
pub mod dispersion;
pub mod fluor;
pub mod light;
pub mod lvf;
pub mod lvf_transmission;
pub mod phos;
pub mod phos_excitation;
pub mod preset;
pub mod preset_export;
pub mod preset_preview;
pub mod series;
pub mod spectrum;
pub mod synth;
pub mod synth_lvf;

use anyhow::Result;
use lumifit::colorimetry::Illuminant;

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

/// Old flag spellings still accepted as clap aliases for one release (docs/conventions.md):
/// (command path, old flag, new flag).
const DEPRECATED_FLAGS: [(&[&str], &str, &str); 3] = [
    (&["color", "xyz"], "--sd", "--spectrum"),
    (&["color", "table"], "--sds", "--spectra"),
    (&["lvf", "transmission"], "--source", "--illuminant"),
];

/// One warning per deprecated flag spelling in `args` (the process arguments, program name
/// first), naming the new spelling.
pub fn deprecated_flag_warnings(args: &[String]) -> Vec<String> {
    let words: Vec<&str> = args.iter().skip(1).map(String::as_str).collect();
    let mut out = Vec::new();
    for (path, old, new) in DEPRECATED_FLAGS {
        let is_command = words.len() >= path.len() && words[..path.len()] == *path;
        if !is_command {
            continue;
        }
        let used = words[path.len()..]
            .iter()
            .take_while(|w| **w != "--")
            .any(|w| *w == old || w.starts_with(&format!("{old}=")));
        if used {
            out.push(format!(
                "{} {old} is deprecated and will be removed in the next release; use {new}",
                path.join(" ")
            ));
        }
    }
    out
}

/// Dispatches a parsed command line.
pub fn run(cli: Cli) -> Result<()> {
    for w in deprecated_flag_warnings(&std::env::args().collect::<Vec<_>>()) {
        eprintln!("warning: {w}");
    }
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
        Command::Preset(PresetCommand::Preview(a)) => preset_preview::run(&a),
        Command::Dispersion(c) => dispersion::run(c),
        Command::Fluor(c) => fluor::run(c),
        Command::Light(c) => light::run(c),
        Command::Phos(PhosCommands::Decay(c)) => phos::run(c),
        Command::Phos(PhosCommands::Excitation(c)) => phos_excitation::run(c),
        Command::Synth(SynthCommands::Phos(c)) => synth::run(c),
        Command::Synth(SynthCommands::Lvf(c)) => synth_lvf::run(c),
        Command::Synth(SynthCommands::Excitation(c)) => phos_excitation::run_synth(c),
        Command::Series(c) => series::run(c),
        Command::Lvf(c) => lvf::run(c),
        Command::Spectrum(c) => spectrum::run(c),
        Command::Afterimage(c) => afterimage::run(c),
        Command::Demo(a) => demo::run(&a),
    }
}

/// A progress bar on standard error for `n` items (`prefix` while running, `items` named).
pub fn progress_bar(n: usize, prefix: &'static str, items: &str) -> indicatif::ProgressBar {
    let bar = indicatif::ProgressBar::new(n as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template(&format!(
            "{{prefix}} [{{bar:30}}] {{pos}}/{{len}} {items} {{elapsed}}"
        ))
        .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
        .progress_chars("=> "),
    );
    bar.set_prefix(prefix);
    bar
}

/// A progress bar made when the step starts (`make(total)`), as [`lumifit::pipeline::Progress`].
pub struct Bar<F> {
    make: F,
    bar: std::sync::OnceLock<indicatif::ProgressBar>,
}

impl<F: Fn(usize) -> indicatif::ProgressBar + Sync> Bar<F> {
    /// A bar that `make` builds once the total is known.
    pub fn new(make: F) -> Self {
        Bar {
            make,
            bar: std::sync::OnceLock::new(),
        }
    }
}

impl<F: Fn(usize) -> indicatif::ProgressBar + Sync> lumifit::pipeline::Progress for Bar<F> {
    fn start(&self, total: usize) {
        self.bar.get_or_init(|| (self.make)(total));
    }
    fn inc(&self) {
        if let Some(b) = self.bar.get() {
            b.inc(1);
        }
    }
    fn finish(&self) {
        if let Some(b) = self.bar.get() {
            b.finish_and_clear();
        }
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

/// `--illuminant`/`--source`: a CIE name, `daylight:<K>`, `blackbody:<K>` or a CSV file (see
/// [`lumifit::io::sources::resolve_illuminant`]).
pub fn resolve_illuminant(arg: &str) -> Result<Illuminant> {
    Ok(lumifit::io::sources::resolve_illuminant(
        "--illuminant",
        arg,
    )?)
}

/// `--roi x,y,w,h` as a rectangle `[x, y, w, h]`.
pub use lumifit::io::flags::parse_rect;
