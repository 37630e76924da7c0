//! `lumifit light …`: photometric files (IES LM-63, EULUMDAT) — inspect, convert, and shade a
//! photometric rectangle (Luksch et al. 2020).

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::{Args, Subcommand, ValueEnum};
use lumifit::io::Outputs;
use lumifit::photometry::illuminance::{illuminance, Method, RectLight};
use lumifit::photometry::{summary, FileFormat, PhotometricFile, Tilt};
use serde_json::json;

use super::{emit, parse_triplet};

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

#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum MethodArg {
    /// Point light at the centre.
    Point,
    /// Uniform Monte Carlo over the rectangle (unbiased, with its standard error).
    Mc,
    /// Structured sampling: corners + barycentre (Eq. 4).
    Structured,
    /// Most representative point (Drobot 2014).
    Mrp,
    /// The paper's cubature (Eq. 6–11, §5.3).
    Cubature,
    /// The cubature refined adaptively to --tolerance.
    CubatureAdaptive,
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
    pub method: MethodArg,
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

/// Dispatches `lumifit light …`.
pub fn run(c: LightCommand) -> Result<()> {
    match c {
        LightCommand::Inspect(a) => inspect(&a),
        LightCommand::Convert(a) => convert(&a),
        LightCommand::Illuminance(a) => shade(&a),
        LightCommand::Preset(a) => preset(&a),
        LightCommand::Benchmark(a) => benchmark(&a),
        LightCommand::Synth(a) => synth(&a),
    }
}

fn read(path: &std::path::Path, lamp_tilt: f64) -> Result<PhotometricFile> {
    if !lamp_tilt.is_finite() {
        anyhow::bail!("--lamp-tilt: expected a finite angle in degrees");
    }
    Ok(lumifit::io::read_photometric(path, lamp_tilt)?)
}

fn inspect(a: &InspectArgs) -> Result<()> {
    let mut out = Outputs::new();
    out.input(&a.file);
    if let Some(p) = &a.plot {
        out.declare("--plot", p)?;
    }
    let f = read(&a.file, a.lamp_tilt)?;
    let p = &f.photometry;
    let s = summary(p);
    lumifit::error::ensure_finite(
        "flux",
        &a.file.display().to_string(),
        &[s.flux_lm, s.max_cd],
    )?;
    let tilt = match &p.tilt {
        Tilt::None => json!({"kind": "none"}),
        Tilt::Table {
            source,
            geometry,
            angles_deg,
            ..
        } => json!({
            "kind": source, "lamp_to_luminaire_geometry": geometry, "pairs": angles_deg.len(),
            "applied_at_lamp_tilt_deg": p.tilt_applied.0, "factor_applied": p.tilt_applied.1,
        }),
    };
    let report = json!({
        "file": a.file.display().to_string(),
        "format": f.format, "version": f.version,
        "photometric_type": p.grid.kind, "symmetry": p.symmetry,
        "grid": {"horizontal_angles": p.grid.h_deg.len(), "vertical_angles": p.grid.v_deg.len(),
                  "horizontal_deg": [p.grid.h_deg[0], p.grid.h_deg[p.grid.h_deg.len() - 1]],
                  "vertical_deg": [p.grid.v_deg[0], p.grid.v_deg[p.grid.v_deg.len() - 1]]},
        "max_cd": s.max_cd, "max_direction_deg": {"h": s.max_h_deg, "v": s.max_v_deg},
        "flux_from_grid_lm": s.flux_lm, "flux_down_lm": s.flux_down_lm, "flux_up_lm": s.flux_up_lm,
        "declared_lamp_flux_lm": p.lamp_flux_lm, "declared_luminaire_flux_lm": p.declared_luminaire_flux_lm,
        "lor": s.lor, "dlor": s.dlor, "ulor": s.ulor,
        "declared_lorl_percent": p.declared_lor_percent, "declared_dff_percent": p.declared_dff_percent,
        "beam_field": s.planes,
        "luminous_opening_m": p.opening,
        "tilt": tilt,
        "lamp_sets": f.lamps.len(),
        "notes": f.notes,
    });
    if let Some(path) = &a.plot {
        let title = format!(
            "{} — max {:.4} cd, {:.1} lm",
            a.file
                .file_name()
                .map(|n| n.to_string_lossy().to_string())
                .unwrap_or_default(),
            s.max_cd,
            s.flux_lm
        );
        let png = lumifit::plot::photometry::polar_chart_png(&p.grid, &title)?;
        out.stage(path, &png)?;
    }
    out.commit()?;
    if a.json {
        return emit(&serde_json::to_string_pretty(&report)?);
    }
    let pct = |x: Option<f64>| {
        x.map(|v| format!("{:.1} %", 100.0 * v))
            .unwrap_or_else(|| "— (absolute photometry)".into())
    };
    let mut t = format!(
        "{}\n  format      {:?} {}, type {:?}, symmetry {:?}\n  grid        {} horizontal × {} vertical angles (after symmetry), γ {}–{}°\n  max         {:.6} cd at h {}°, v {}°\n  flux        {:.2} lm from the grid (down {:.2}, up {:.2}); declared lamp flux {}\n  LOR         {}  DLOR {}  ULOR {}\n",
        a.file.display(), f.format, f.version, p.grid.kind, p.symmetry, p.grid.h_deg.len(), p.grid.v_deg.len(),
        p.grid.v_deg[0], p.grid.v_deg[p.grid.v_deg.len() - 1], s.max_cd, s.max_h_deg, s.max_v_deg,
        s.flux_lm, s.flux_down_lm, s.flux_up_lm,
        p.lamp_flux_lm.map(|l| format!("{l} lm")).unwrap_or_else(|| "none (absolute photometry)".into()),
        pct(s.lor), pct(s.dlor), pct(s.ulor),
    );
    if f.format == FileFormat::Eulumdat {
        t.push_str(&format!(
            "  declared    LORL {:?} %, DFF {:?} %\n",
            p.declared_lor_percent, p.declared_dff_percent
        ));
    }
    for b in &s.planes {
        t.push_str(&format!(
            "  C{}–C{}   beam {:.1}°, field {:.1}° (max {:.4} cd)\n",
            b.plane_c_deg,
            b.plane_c_deg + 180.0,
            b.beam_deg,
            b.field_deg,
            b.max_cd
        ));
    }
    t.push_str(&format!(
        "  opening     {:?} {:.4} × {:.4} × {:.4} m (length C0 × width C90 × height)\n",
        p.opening.shape, p.opening.length_m, p.opening.width_m, p.opening.height_m
    ));
    t.push_str(&format!("  TILT        {}\n", tilt));
    for n in &f.notes {
        t.push_str(&format!("  note        {n}\n"));
    }
    emit(t.trim_end())
}

fn convert(a: &ConvertArgs) -> Result<()> {
    let mut out = Outputs::new();
    out.input(&a.file);
    out.declare("--out", &a.out)?;
    let f = read(&a.file, a.lamp_tilt)?;
    let ext = a
        .out
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    let tool = format!(
        "lumifit {} from {}",
        env!("CARGO_PKG_VERSION"),
        a.file
            .file_name()
            .map(|n| n.to_string_lossy().to_string())
            .unwrap_or_default()
    );
    let text = match ext.as_str() {
        "ies" => lumifit::io::ies::write_ies(&f, &tool)?,
        "ldt" => lumifit::io::eulumdat::write_ldt(&f, &tool)?,
        _ => anyhow::bail!(
            "--out: '{}': expected a .ies or .ldt file name",
            a.out.display()
        ),
    };
    out.stage(&a.out, text.as_bytes())?;
    out.commit()?;
    emit(&json!({"in": a.file.display().to_string(), "out": a.out.display().to_string(), "format": ext}).to_string())
}

fn parse_pair(flag: &str, s: &str) -> Result<(f64, f64)> {
    let v: Vec<&str> = s.split(',').map(str::trim).collect();
    let (Some(a), Some(b), 2) = (v.first(), v.get(1), v.len()) else {
        anyhow::bail!("{flag}: expected two comma-separated numbers like 1,0.5, got '{s}'");
    };
    let a: f64 = a
        .parse()
        .with_context(|| format!("{flag}: '{a}' is not a number"))?;
    let b: f64 = b
        .parse()
        .with_context(|| format!("{flag}: '{b}' is not a number"))?;
    Ok((a, b))
}

fn method(a: &IlluminanceArgs) -> Result<Method> {
    let only = |flag: &str, given: bool, m: &str| -> Result<()> {
        if given {
            anyhow::bail!("{flag} applies to --method {m} only");
        }
        Ok(())
    };
    let m = match a.method {
        MethodArg::Mc => Method::Mc {
            samples: a.samples.unwrap_or(1024),
            seed: a.seed.unwrap_or(1),
        },
        MethodArg::CubatureAdaptive => Method::CubatureAdaptive {
            tolerance: a.tolerance.unwrap_or(0.01),
        },
        MethodArg::Point => Method::Point,
        MethodArg::Structured => Method::Structured,
        MethodArg::Mrp => Method::Mrp,
        MethodArg::Cubature => Method::Cubature,
    };
    if !matches!(m, Method::Mc { .. }) {
        only("--samples", a.samples.is_some(), "mc")?;
        only("--seed", a.seed.is_some(), "mc")?;
    }
    if !matches!(m, Method::CubatureAdaptive { .. }) {
        only("--tolerance", a.tolerance.is_some(), "cubature-adaptive")?;
    }
    if let Method::Mc { samples, .. } = m {
        lumifit::limits::check_count("--samples", samples, 100_000_000, "samples per point")?;
    }
    Ok(m)
}

fn shade(a: &IlluminanceArgs) -> Result<()> {
    let mut out = Outputs::new();
    out.input(&a.light).input(&a.points);
    out.declare("--out", &a.out)?;
    let m = method(a)?;
    let f = read(&a.light, a.lamp_tilt)?;
    let (w, h) = rect(a.rect.as_deref(), &f, &a.light)?;
    let light = RectLight::new(
        parse_triplet("--center", &a.center)?,
        parse_triplet("--normal", &a.normal)?,
        parse_triplet("--up", &a.up)?,
        w,
        h,
    )?;
    let receivers = lumifit::io::receivers::read_receivers(&a.points)?;
    let n = receivers.len();
    let started = std::time::Instant::now();
    let grid = f.photometry.grid.clone().with_interp(a.interp.into());
    let shades = illuminance(&light, &grid, &receivers, m)?;
    let seconds = started.elapsed().as_secs_f64();
    let e: Vec<f64> = shades.iter().map(|s| s.e_lux).collect();
    lumifit::error::ensure_finite("E_lux", &a.points.display().to_string(), &e)?;
    let with_std = matches!(m, Method::Mc { .. });
    let with_le = matches!(m, Method::Cubature | Method::CubatureAdaptive { .. });
    let csv = lumifit::io::receivers::shades_to_csv(&receivers, &shades, with_std, with_le);
    out.stage(&a.out, csv.as_bytes())?;
    out.commit()?;
    let evals: usize = shades.iter().map(|s| s.evaluations).sum();
    emit(
        &json!({
            "points": n, "method": m.name(), "rect_m": [w, h],
            "compute_seconds": seconds, "points_per_second": n as f64 / seconds.max(1e-12),
            "E_lux_min": e.iter().cloned().fold(f64::INFINITY, f64::min),
            "E_lux_max": e.iter().cloned().fold(f64::NEG_INFINITY, f64::max),
            "mean_evaluations_per_point": evals as f64 / n.max(1) as f64,
            "interp": grid.interp,
            "out": a.out.display().to_string(),
        })
        .to_string(),
    )
}

/// `--rect W,H`, or the file's luminous opening (length along C0, width along C90).
fn rect(arg: Option<&str>, f: &PhotometricFile, path: &std::path::Path) -> Result<(f64, f64)> {
    match arg {
        Some(r) => parse_pair("--rect", r),
        None => {
            let o = f.photometry.opening;
            if !(o.length_m > 0.0 && o.width_m > 0.0) {
                anyhow::bail!(
                    "--rect: {} declares no rectangular luminous opening ({:?} {} × {} m); give --rect W,H",
                    path.display(),
                    o.shape,
                    o.length_m,
                    o.width_m
                );
            }
            Ok((o.length_m, o.width_m))
        }
    }
}

fn preset(a: &PresetArgs) -> Result<()> {
    let mut out = Outputs::new();
    out.input(&a.file);
    out.declare("--out", &a.out)?;
    let ies_path = a.gltf.as_ref().map(|g| {
        let stem = g
            .file_stem()
            .map_or_else(|| "light".into(), |s| s.to_string_lossy().into_owned());
        g.with_file_name(format!("{stem}.ies"))
    });
    if let (Some(g), Some(i)) = (&a.gltf, &ies_path) {
        out.declare("--gltf", g)?;
        out.declare("--gltf (IES beside it)", i)?;
    }
    let f = read(&a.file, a.lamp_tilt)?;
    let (w, h) = rect(a.rect.as_deref(), &f, &a.file)?;
    let section = lumifit::preset::photometric::photometric_section(&f, w, h)?;
    let (bytes, _) = lumifit::io::read_input(&a.file)?;
    let name = a.name.clone().unwrap_or_else(|| {
        a.file
            .file_stem()
            .map(|s| s.to_string_lossy().to_string())
            .unwrap_or_else(|| "light".into())
    });
    let provenance =
        lumifit::preset::Provenance::new("light preset", &[(&a.file, bytes.as_slice())]);
    let p = lumifit::preset::LightPreset::new(name, provenance, section);
    let text = lumifit::preset::to_json_string(&p)?;
    out.stage(&a.out, text.as_bytes())?;
    if let (Some(g), Some(i)) = (&a.gltf, &ies_path) {
        let light = RectLight::new(
            parse_triplet("--center", &a.center)?,
            parse_triplet("--normal", &a.normal)?,
            parse_triplet("--up", &a.up)?,
            w,
            h,
        )?;
        let uri = i
            .file_name()
            .map_or_else(|| "light.ies".into(), |s| s.to_string_lossy().into_owned());
        let (doc, ies) = lumifit::preset::export::light::gltf_light(&f, &light, &p.name, &uri)?;
        out.stage(g, (serde_json::to_string_pretty(&doc)? + "\n").as_bytes())?;
        out.stage(i, &ies)?;
    }
    out.commit()?;
    emit(
        &json!({
            "in": a.file.display().to_string(),
            "out": a.out.display().to_string(),
            "gltf": a.gltf.as_ref().map(|g| g.display().to_string()),
            "ies": ies_path.as_ref().map(|i| i.display().to_string()),
            "rect_m": [w, h],
        })
        .to_string(),
    )
}

fn synth(a: &SynthArgs) -> Result<()> {
    let mut out = Outputs::new();
    out.declare("--out", &a.out)?;
    let profile: lumifit::photometry::synthetic::SyntheticProfile = a.profile.parse()?;
    let f = profile.file()?;
    let tool = format!(
        "lumifit {} light synth --profile {}",
        env!("CARGO_PKG_VERSION"),
        profile.name()
    );
    let text = lumifit::io::ies::write_ies(&f, &tool)?;
    out.stage(&a.out, text.as_bytes())?;
    out.commit()?;
    let s = summary(&f.photometry);
    emit(
        &json!({"profile": profile.name(), "out": a.out.display().to_string(),
                 "max_cd": s.max_cd, "flux_lm": s.flux_lm})
        .to_string(),
    )
}

fn benchmark(a: &BenchmarkArgs) -> Result<()> {
    use lumifit::photometry::benchmark::{self as bench, BenchmarkSpec};
    let mut out = Outputs::new();
    for l in &a.lights {
        out.input(l);
    }
    out.declare_dir("--out", &a.out)?;
    let spec = BenchmarkSpec {
        heights_m: a.heights.clone(),
        orientations_rad: a
            .orientations
            .iter()
            .map(|f| f * std::f64::consts::PI)
            .collect(),
        image_size_m: a.size,
        resolution_px: a.resolution,
        adaptive_tolerance: a.tolerance,
        noise_fraction: a.noise_fraction,
        max_samples: a.max_reference_samples,
        seed: a.seed,
        interp: a.interp.into(),
        ..BenchmarkSpec::default()
    };
    bench::validate(&spec, a.lights.len())?;
    let files = a
        .lights
        .iter()
        .map(|l| read(l, a.lamp_tilt))
        .collect::<Result<Vec<_>>>()?;
    let names = profile_names(&a.lights);
    let mut pngs = Vec::new();
    for n in &names {
        for h in &spec.heights_m {
            let p = a.out.join(format!("diff-{n}-h{h}.png"));
            out.declare("--out", &p)?;
            pngs.push(p);
        }
    }
    let tables = ["nrms.csv", "reference.csv", "nrms.md", "summary.json"].map(|f| a.out.join(f));
    for t in &tables {
        out.declare("--out", t)?;
    }
    let profiles: Vec<(String, &lumifit::photometry::CandelaGrid)> = names
        .iter()
        .cloned()
        .zip(files.iter().map(|f| &f.photometry.grid))
        .collect();
    let bar = super::progress_bar(
        profiles.len() * spec.heights_m.len(),
        "benchmark",
        "profile × height",
    );
    let started = std::time::Instant::now();
    let cases = bench::run_all(&profiles, &spec, &|_| bar.inc(1))?;
    bar.finish_and_clear();
    let seconds = started.elapsed().as_secs_f64();
    for (c, p) in cases.iter().zip(&pngs) {
        out.stage(
            p,
            &lumifit::plot::photometry::benchmark_difference_png(c, &spec, a.diff_range)?,
        )?;
    }
    out.stage(&tables[0], bench::results_csv(&cases).as_bytes())?;
    out.stage(&tables[1], bench::reference_csv(&cases).as_bytes())?;
    out.stage(
        &tables[2],
        bench::results_markdown(&cases, &spec).as_bytes(),
    )?;
    let summary = json!({"spec": spec, "cases": cases, "seconds": seconds,
        "files": a.lights.iter().map(|l| l.display().to_string()).collect::<Vec<_>>()});
    out.stage(
        &tables[3],
        (serde_json::to_string_pretty(&summary)? + "\n").as_bytes(),
    )?;
    out.commit()?;
    let worst = cases
        .iter()
        .map(|c| c.reference.noise_ratio)
        .fold(0.0f64, f64::max);
    emit(
        &json!({"out": a.out.display().to_string(), "profiles": names, "cases": cases.len(),
        "seconds": seconds, "all_references_converged": cases.iter().all(|c| c.reference.converged),
        "worst_reference_noise_ratio": worst})
        .to_string(),
    )
}

/// File stems as profile names, made unique with the parent folder's name when two collide.
fn profile_names(paths: &[PathBuf]) -> Vec<String> {
    let stem = |p: &PathBuf| {
        p.file_stem()
            .map_or_else(|| "light".into(), |s| s.to_string_lossy().into_owned())
    };
    let mut names: Vec<String> = paths.iter().map(stem).collect();
    for i in 0..names.len() {
        if names.iter().filter(|n| **n == names[i]).count() > 1 {
            let parent = paths[i]
                .parent()
                .and_then(|d| d.file_name())
                .map_or_else(String::new, |s| s.to_string_lossy().into_owned());
            names[i] = format!("{parent}-{}", names[i]);
        }
    }
    let mut seen = std::collections::HashMap::new();
    for n in names.iter_mut() {
        let k = seen.entry(n.clone()).or_insert(0usize);
        *k += 1;
        if *k > 1 {
            *n = format!("{n}-{k}");
        }
    }
    names
}

/// `preset export LIGHT.json --format gltf --out light.gltf`: the same node as `light preset
/// --gltf` (default frame: 2.5 m above the origin, facing down, C0 along +Z), the IES written
/// beside it as `<out stem>.ies`.
pub fn export_preset_gltf(
    path: &std::path::Path,
    preset: &lumifit::preset::LightPreset,
    gltf: &std::path::Path,
) -> Result<()> {
    let mut out = Outputs::new();
    out.input(path);
    let stem = gltf
        .file_stem()
        .map_or_else(|| "light".into(), |s| s.to_string_lossy().into_owned());
    let ies_path = gltf.with_file_name(format!("{stem}.ies"));
    out.declare("--out", gltf)?;
    out.declare("--out (IES beside it)", &ies_path)?;
    let file = path.display().to_string();
    let section = &preset.photometric;
    let f = lumifit::preset::photometric::file_from_section(section, &file, &preset.name)?;
    let [w, h] = lumifit::preset::photometric::read_section(section, &file)?.emitter_rect_m;
    let light = RectLight::new([0.0, 2.5, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, 1.0], w, h)?;
    let uri = ies_path
        .file_name()
        .map_or_else(|| "light.ies".into(), |s| s.to_string_lossy().into_owned());
    let (doc, ies) = lumifit::preset::export::light::gltf_light(&f, &light, &preset.name, &uri)?;
    out.stage(
        gltf,
        (serde_json::to_string_pretty(&doc)? + "\n").as_bytes(),
    )?;
    out.stage(&ies_path, &ies)?;
    out.commit()?;
    emit(&json!({"in": file, "out": gltf.display().to_string(), "ies": ies_path.display().to_string(),
                 "rect_m": [w, h]}).to_string())
}
