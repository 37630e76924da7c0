//! Command-line syntax (clap derive). Parsed values are validated into library types in
//! `commands`; the library never sees clap types.

use std::path::PathBuf;

use clap::{Args, Parser, Subcommand};

/// lumifit — turn measurements of unusual appearance into material and light presets.
///
/// The `about` line lists only the pipelines that exist (not the package description, which
/// names the planned ones too).
#[derive(Debug, Parser)]
#[command(
    name = "lumifit",
    version,
    about = "Fit phosphorescence and fluorescence, and recover spectra through a linear variable filter, from measurements into renderer presets",
    long_about = None,
    propagate_version = true
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// Colorimetry: spectra to XYZ/Lab/sRGB, colour differences, conversions.
    #[command(subcommand)]
    Color(ColorCommand),
    /// Fluorescence: reduce Donaldson (bispectral) matrices for RGB/XYZ renderers (Fichet 2024).
    #[command(subcommand)]
    Fluor(crate::commands::fluor::FluorCommand),
    /// Photometric lights: inspect and convert IES/EULUMDAT files, shade photometric rectangles.
    #[command(subcommand)]
    Light(crate::commands::light::LightCommand),
    /// Phosphorescence: simulate the rate equation and fit decays (Nalbach 2017).
    #[command(subcommand)]
    Phos(crate::commands::PhosCommands),
    /// Synthetic test data rendered by lumifit's own models.
    #[command(subcommand)]
    Synth(crate::commands::SynthCommands),
    /// Photo series: inspect frames and extract region curves in relative radiance.
    #[command(subcommand)]
    Series(crate::commands::series::SeriesCommand),
    /// Linear variable bandpass filter: wavelength calibration from lamp photos, band
    /// transmissions from photos through colour gels.
    #[command(subcommand)]
    Lvf(crate::commands::lvf::LvfCommand),
    /// Spectra from captures: recover a light or reflectance spectrum from a photo through the LVF.
    #[command(subcommand)]
    Spectrum(crate::commands::spectrum::SpectrumCommand),
    /// Afterimages: the Mikamo 2013 luminance and colour transitions, and frames of an image's afterimage.
    #[command(subcommand)]
    Afterimage(crate::commands::afterimage::AfterimageCommand),
    /// Dispersion: fit n(λ), wavelength samples for RGB renderers, the prism check.
    #[command(subcommand)]
    Dispersion(crate::commands::dispersion::DispersionCommand),
    /// Material and light presets.
    #[command(subcommand)]
    Preset(PresetCommand),
    /// Run every pipeline end to end on synthesised or bundled data (LVF, phosphorescence,
    /// fluorescence, dispersion, afterimage, photometric light, colour) into one folder with an
    /// index.html showing every plot and linking every preset.
    Demo(DemoArgs),
}

#[derive(Debug, Subcommand)]
pub enum ColorCommand {
    /// Tristimulus values of a spectrum (CSV `wavelength_nm,value`), printed as JSON.
    ///
    /// Reflectance factors (0–1) give XYZ on the 0–100 scale, Y = 100 for the perfect reflector,
    /// as colour.sd_to_XYZ. Lab and sRGB are relative to the illuminant's white computed with
    /// the same observer.
    Xyz(XyzArgs),
    /// Tristimulus values of many spectra at once: a CSV `wavelength_nm,<name>,<name>,…` in, a CSV
    /// `name,X,Y,Z,x,y,L,a,b` out; prints a JSON summary with the compute time.
    Table(TableArgs),
    /// Colour difference of two CIE L*a*b* colours, printed as JSON.
    DeltaE(DeltaEArgs),
    /// Convert one colour between XYZ, xyY, Lab and (linear) sRGB, printed as JSON.
    Convert(ConvertArgs),
}

#[derive(Debug, Args)]
pub struct XyzArgs {
    /// Spectrum CSV with a header row `wavelength_nm,value`; `-` reads standard input
    /// (`--sd` is the deprecated spelling).
    #[arg(long = "spectrum", alias = "sd", value_name = "FILE.csv")]
    pub sd: PathBuf,
    /// Illuminant: a CIE name (A, C, D50, D55, D60, D65, D75, E, FL1–FL12, HP1–HP5, LED-B1–LED-B5),
    /// `daylight:<CCT>` (CIE D-series, 4000–25000 K), `blackbody:<T>` (Planck), or a CSV file
    /// `wavelength_nm,value`.
    #[arg(long, default_value = "D65", value_name = "NAME|FILE.csv")]
    pub illuminant: String,
    /// Standard observer.
    #[arg(long, default_value = "cie1931-2", value_parser = ["cie1931-2", "cie1964-10", "cie2015-2", "cie2015-10"])]
    pub observer: String,
    /// Computation method (ASTM E308 needs data at 1, 5, 10 or 20 nm).
    #[arg(long, default_value = "astm-e308", value_parser = ["astm-e308", "integration"])]
    pub method: String,
    /// Normalisation constant k (e.g. 683 for absolute photometric values of an emission
    /// spectrum with illuminant E); default: Y = 100 for the perfect reflector.
    #[arg(long)]
    pub k: Option<f64>,
}

#[derive(Debug, Args)]
pub struct TableArgs {
    /// Spectra CSV: `wavelength_nm` then one column per spectrum; `-` reads standard input
    /// (`--sds` is the deprecated spelling).
    #[arg(long = "spectra", alias = "sds", value_name = "FILE.csv")]
    pub sds: PathBuf,
    /// Illuminant: a CIE name, `daylight:<CCT>`, `blackbody:<T>` or a CSV file `wavelength_nm,value`.
    #[arg(long, default_value = "D65", value_name = "NAME|FILE.csv")]
    pub illuminant: String,
    /// Standard observer.
    #[arg(long, default_value = "cie1931-2", value_parser = ["cie1931-2", "cie1964-10", "cie2015-2", "cie2015-10"])]
    pub observer: String,
    /// Computation method.
    #[arg(long, default_value = "astm-e308", value_parser = ["astm-e308", "integration"])]
    pub method: String,
    /// Output CSV (written atomically).
    #[arg(long, value_name = "FILE.csv")]
    pub out: PathBuf,
}

#[derive(Debug, Args)]
pub struct DeltaEArgs {
    /// First colour as `L,a,b`.
    #[arg(long, value_name = "L,a,b", allow_hyphen_values = true)]
    pub lab1: String,
    /// Second colour as `L,a,b`.
    #[arg(long, value_name = "L,a,b", allow_hyphen_values = true)]
    pub lab2: String,
    /// Colour-difference formula.
    #[arg(long, default_value = "cie2000", value_parser = ["cie2000", "cie1994", "cie1976"])]
    pub method: String,
}

#[derive(Debug, Args)]
pub struct ConvertArgs {
    /// Input representation.
    #[arg(long, value_parser = ["xyz", "xyy", "lab", "lch", "srgb", "linear-srgb"])]
    pub from: String,
    /// Output representation.
    #[arg(long, value_parser = ["xyz", "xyy", "lab", "lch", "srgb", "linear-srgb"])]
    pub to: String,
    /// The colour as three comma-separated numbers (XYZ and xyY's Y on the scale of --scale).
    #[arg(long, value_name = "a,b,c", allow_hyphen_values = true)]
    pub value: String,
    /// Scale of XYZ and of xyY's Y, in and out: 100 (Y = 100 for the reference white, as
    /// `color xyz` and `color table` print and colour.sd_to_XYZ returns) or 1 (colour's
    /// "reference" scale of its conversion functions).
    #[arg(long, default_value = "100", value_parser = ["100", "1"])]
    pub scale: String,
    /// Reference white for Lab/LCh and for adapting to sRGB's D65 (CAT02): a CIE illuminant name.
    #[arg(long, default_value = "D65")]
    pub white: String,
}

#[derive(Debug, Subcommand)]
pub enum PresetCommand {
    /// Check a preset JSON file against the lumifit preset schema.
    Validate {
        /// The preset file.
        file: PathBuf,
    },
    /// Export a preset to a renderer format (glTF 2.0 material, OpenPBR parameters).
    Export(Box<crate::commands::preset_export::ExportArgs>),
    /// Render a reference preview PNG of a preset through the shader twins (sphere on a floor).
    Preview(crate::commands::preset_preview::PreviewArgs),
}

#[derive(Debug, Args)]
pub struct DemoArgs {
    /// Output directory (created with everything at the end, only if every stage succeeded).
    #[arg(long, default_value = "lumifit-demo")]
    pub out: PathBuf,
}
