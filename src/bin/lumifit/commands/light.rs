//! `lumifit light …`: photometric files (IES LM-63, EULUMDAT) — inspect, convert, and shade a
//! photometric rectangle (Luksch et al. 2020).

use std::path::PathBuf;

use anyhow::Result;
use clap::{Args, Subcommand, ValueEnum};
use lumifit::io::Outputs;
use lumifit::photometry::benchmark::BenchmarkSpec;
use lumifit::pipeline::light::MethodKind;
use lumifit::pipeline::light::{self as job, BenchmarkJob, Frame, IlluminanceJob, LightPresetJob};

use super::emit;

/// Subcommands of `lumifit light`.
#[derive(Debug, Subcommand)]
pub enum LightCommand {
    /// What a photometric file says: format, type, symmetry, grid, max candela, flux from the
    /// grid beside the declared lumens, LOR/DLOR/ULOR, beam and field angles, TILT.
    Inspect(InspectArgs),
    /// Write a photometric file as IES LM-63-2019 (.ies) or EULUMDAT (.ldt), by the output's
    /// extension; the candela grid reads back unchanged.
    Convert(ConvertArgs),
    /// Illuminance on receiving points from a photometric rectangle.
    Illuminance(IlluminanceArgs),
    /// A `lumifit.light/1` preset: the full candela grid, flux, emitter rectangle and frame,
    /// with the source file's SHA-256 in the provenance.
    Preset(PresetArgs),
    /// The paper's benchmark (Luksch et al. 2020 §6): NRMS of every method against a Monte
    /// Carlo reference on ground-plane images, per profile, height and method; false-colour
    /// difference images; time per method; the MC sample count at the cubature's NRMS.
    Benchmark(BenchmarkArgs),
    /// A synthetic profile (lambertian, spot, batwing, asymmetric) written as LM-63-2019 by
    /// lumifit's IES writer.
    Synth(SynthArgs),
}

#[derive(Debug, Args)]
pub struct BenchmarkArgs {
    /// IES or EULUMDAT files (each is one profile, shaded as a 1 × 1 m rectangle).
    #[arg(required = true)]
    pub lights: Vec<PathBuf>,
    /// Output directory: nrms.csv, reference.csv, nrms.md, summary.json, diff-<profile>-h<h>.png.
    #[arg(long, value_name = "DIR/")]
    pub out: PathBuf,
    /// Side of the square ground image in m (centred under the light).
    #[arg(long, default_value_t = 4.0)]
    pub size: f64,
    /// Receivers per image side.
    #[arg(long, default_value_t = 64)]
    pub resolution: usize,
    /// Heights of the light's lowest point above the ground, m.
    #[arg(long, default_value = "0.1,1,2.5", value_delimiter = ',')]
    pub heights: Vec<f64>,
    /// Angles between n_A and n_g in units of π.
    #[arg(long, default_value = "0.5,0.625,0.75,0.875,1", value_delimiter = ',')]
    pub orientations: Vec<f64>,
    /// Tolerance of cubature-adaptive (0.1 keeps the run short: on a striped profile 0.01 costs
    /// 60 000 triangles per receiver; the method is reported, not judged).
    #[arg(long, default_value_t = 0.1)]
    pub tolerance: f64,
    /// The reference's noise must be below this fraction of the smallest judged NRMS.
    #[arg(long, default_value_t = 0.1)]
    pub noise_fraction: f64,
    /// Budget of reference samples per profile and height (all receivers).
    #[arg(long, default_value_t = 4_000_000_000)]
    pub max_reference_samples: u64,
    /// Difference images saturate at ± this fraction of the height's peak illuminance.
    #[arg(long, default_value_t = 0.1)]
    pub diff_range: f64,
    /// Seed of the Monte Carlo reference and ladder.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Lamp tilt in degrees at which an IES TILT table is applied.
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub lamp_tilt: f64,
    /// Interpolation of I(C, γ) between the file's nodes.
    #[arg(long, value_enum, default_value = "bilinear")]
    pub interp: InterpArg,
}

#[derive(Debug, Args)]
pub struct SynthArgs {
    /// lambertian (I₀ cos γ), spot (cos⁴⁵ γ, 20° beam), batwing (cos γ (1 + 3 sin² γ)) or
    /// asymmetric (two tilted lobes, no symmetry); I₀ = 1000 cd, 1 × 1 m opening.
    #[arg(long)]
    pub profile: String,
    /// Output IES file.
    #[arg(long, value_name = "FILE.ies")]
    pub out: PathBuf,
}

#[derive(Debug, Args)]
pub struct PresetArgs {
    /// IES or EULUMDAT file.
    pub file: PathBuf,
    /// Emitter size W,H in m (default: the file's luminous opening).
    #[arg(long, value_name = "W,H", allow_hyphen_values = true)]
    pub rect: Option<String>,
    /// Preset name (default: the file's stem).
    #[arg(long)]
    pub name: Option<String>,
    /// Lamp tilt in degrees at which an IES TILT table is applied.
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub lamp_tilt: f64,
    /// Output preset JSON.
    #[arg(long, value_name = "light.json")]
    pub out: PathBuf,
    /// Also write a glTF 2.0 file placing the light (`KHR_lights_punctual` point light of the
    /// equivalent isotropic intensity, plus `EXT_lights_ies` with the profile as an LM-63-2019
    /// file written beside it as `<FILE stem>.ies`), in the frame of --center/--normal/--up.
    #[arg(long, value_name = "light.gltf")]
    pub gltf: Option<PathBuf>,
    /// glTF: centre of the emitter in m (glTF is Y-up; default 2.5 m above the origin).
    #[arg(long, default_value = "0,2.5,0", allow_hyphen_values = true)]
    pub center: String,
    /// glTF: emitting normal (γ = 0; default straight down).
    #[arg(long, default_value = "0,-1,0", allow_hyphen_values = true)]
    pub normal: String,
    /// glTF: up hint; C = 0° points along its part perpendicular to the normal.
    #[arg(long, default_value = "0,0,1", allow_hyphen_values = true)]
    pub up: String,
}

#[derive(Debug, Args)]
pub struct InspectArgs {
    /// IES or EULUMDAT file.
    pub file: PathBuf,
    /// Print JSON instead of text.
    #[arg(long)]
    pub json: bool,
    /// Datasheet polar plot (PNG) of the C0–C180 and C90–C270 curves.
    #[arg(long, value_name = "FILE.png")]
    pub plot: Option<PathBuf>,
    /// Lamp tilt in degrees at which an IES TILT table is applied (0 = as photometered).
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub lamp_tilt: f64,
}

#[derive(Debug, Args)]
pub struct ConvertArgs {
    /// IES or EULUMDAT file.
    pub file: PathBuf,
    /// Output: `.ies` (LM-63-2019) or `.ldt` (EULUMDAT).
    #[arg(long, value_name = "FILE.ies|FILE.ldt")]
    pub out: PathBuf,
    /// Lamp tilt in degrees at which an IES TILT table is applied before writing.
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub lamp_tilt: f64,
}

#[derive(Debug, Args)]
pub struct IlluminanceArgs {
    /// IES or EULUMDAT file.
    pub light: PathBuf,
    /// Emitter size W,H in m (W along u = C0, H along v = C90); default: the file's luminous
    /// opening (length, width).
    #[arg(long, value_name = "W,H", allow_hyphen_values = true)]
    pub rect: Option<String>,
    /// Centre of the rectangle, m.
    #[arg(long, value_name = "x,y,z", allow_hyphen_values = true)]
    pub center: String,
    /// Emitting normal (γ = 0).
    #[arg(long, value_name = "nx,ny,nz", allow_hyphen_values = true)]
    pub normal: String,
    /// Up vector: its part perpendicular to --normal is u (C = 0°); v = n × u is C = 90°.
    #[arg(long, value_name = "ux,uy,uz", allow_hyphen_values = true)]
    pub up: String,
    /// Receiving points: CSV with columns x,y,z,nx,ny,nz (m; unit normals).
    #[arg(long, value_name = "points.csv")]
    pub points: PathBuf,
    /// Shading method.
    #[arg(long, value_enum, default_value = "cubature")]
    pub method: MethodKind,
    /// Monte Carlo samples per point (mc only).
    #[arg(long)]
    pub samples: Option<usize>,
    /// Monte Carlo seed (mc only).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Relative tolerance (cubature-adaptive only).
    #[arg(long)]
    pub tolerance: Option<f64>,
    /// Lamp tilt in degrees at which an IES TILT table is applied.
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub lamp_tilt: f64,
    /// Output CSV: the points, E_lux, and E_std (mc) or Le_bar (cubature methods).
    #[arg(long, value_name = "E.csv")]
    pub out: PathBuf,
    /// Interpolation of I(C, γ) between the file's nodes.
    #[arg(long, value_enum, default_value = "bilinear")]
    pub interp: InterpArg,
}

#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum InterpArg {
    /// Bilinear in C and γ.
    Bilinear,
    /// Cubic Hermite in C and γ (C¹, exact on cubics, wraps at 360°, never below 0).
    Bicubic,
}

impl From<InterpArg> for lumifit::photometry::Interp {
    fn from(a: InterpArg) -> Self {
        match a {
            InterpArg::Bilinear => lumifit::photometry::Interp::Bilinear,
            InterpArg::Bicubic => lumifit::photometry::Interp::Bicubic,
        }
    }
}

/// Dispatches `lumifit light …`: each subcommand is one call of [`lumifit::pipeline::light`].
pub fn run(c: LightCommand) -> Result<()> {
    let mut out = Outputs::new();
    let line = match c {
        LightCommand::Inspect(a) => {
            let r = job::inspect(&a.file, a.plot.as_deref(), a.lamp_tilt, &mut out)?;
            out.commit()?;
            return match a.json {
                true => emit(&serde_json::to_string_pretty(&r.json)?),
                false => emit(&r.text),
            };
        }
        LightCommand::Convert(a) => job::convert(&a.file, &a.out, a.lamp_tilt, &mut out)?,
        LightCommand::Illuminance(a) => job::shade(&a.config(), &mut out)?,
        LightCommand::Preset(a) => job::light_preset(&a.config(), &mut out)?,
        LightCommand::Benchmark(a) => {
            let config = a.config();
            let bar = super::progress_bar(config.cases(), "benchmark", "profile × height");
            let line = job::benchmark(&config, &mut out, &|| bar.inc(1))?;
            bar.finish_and_clear();
            line
        }
        LightCommand::Synth(a) => job::synth(&a.profile, &a.out, &mut out)?,
    };
    out.commit()?;
    emit(&line.to_string())
}

impl IlluminanceArgs {
    fn config(&self) -> IlluminanceJob {
        let frame = Frame {
            center: self.center.clone(),
            normal: self.normal.clone(),
            up: self.up.clone(),
        };
        IlluminanceJob {
            light: self.light.clone(),
            points: self.points.clone(),
            out: self.out.clone(),
            rect: self.rect.clone(),
            frame,
            method: self.method,
            samples: self.samples,
            seed: self.seed,
            tolerance: self.tolerance,
            lamp_tilt: self.lamp_tilt,
            interp: self.interp.into(),
        }
    }
}

impl PresetArgs {
    fn config(&self) -> LightPresetJob {
        let frame = Frame {
            center: self.center.clone(),
            normal: self.normal.clone(),
            up: self.up.clone(),
        };
        LightPresetJob {
            file: self.file.clone(),
            rect: self.rect.clone(),
            name: self.name.clone(),
            lamp_tilt: self.lamp_tilt,
            out: self.out.clone(),
            gltf: self.gltf.clone(),
            frame,
        }
    }
}

impl BenchmarkArgs {
    fn config(&self) -> BenchmarkJob {
        let spec = BenchmarkSpec {
            heights_m: self.heights.clone(),
            orientations_rad: self
                .orientations
                .iter()
                .map(|f| f * std::f64::consts::PI)
                .collect(),
            image_size_m: self.size,
            resolution_px: self.resolution,
            adaptive_tolerance: self.tolerance,
            noise_fraction: self.noise_fraction,
            max_samples: self.max_reference_samples,
            seed: self.seed,
            interp: self.interp.into(),
            ..BenchmarkSpec::default()
        };
        BenchmarkJob {
            lights: self.lights.clone(),
            dir: self.out.clone(),
            spec,
            lamp_tilt: self.lamp_tilt,
            diff_range: self.diff_range,
        }
    }
}
