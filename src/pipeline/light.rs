//! Photometric lights (`lumifit light …` and `preset export` of a light preset): what each
//! command does between its flags and its printed line — read the IES/EULUMDAT file, shade,
//! assemble the report or preset, render the chart, stage every output in the caller's
//! [`Outputs`]. The caller commits and prints.

use std::path::{Path, PathBuf};

use serde_json::{json, Value};

use crate::error::{ensure_finite, Error, Result};
use crate::io::flags::{parse_pair, parse_triplet};
use crate::io::Outputs;
use crate::photometry::benchmark::{self as bench, BenchmarkSpec};
use crate::photometry::illuminance::{illuminance, Method, RectLight};
use crate::photometry::synthetic::SyntheticProfile;
use crate::photometry::{summary, CandelaGrid, FileFormat, Interp, PhotometricFile, Tilt};

/// Shading method as named on the command line (`--method`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum MethodKind {
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

impl MethodKind {
    /// The method with its parameters: `samples` (default 1024) and `seed` (default 1) only for
    /// Monte Carlo, `tolerance` (default 0.01) only for the adaptive cubature; a parameter given
    /// to another method is refused, naming its flag.
    pub fn method(
        self,
        samples: Option<usize>,
        seed: Option<u64>,
        tolerance: Option<f64>,
    ) -> Result<Method> {
        let only = |flag: &str, given: bool, m: &str| -> Result<()> {
            if given {
                return Err(Error::flag(flag, format!("applies to --method {m} only")));
            }
            Ok(())
        };
        let m = match self {
            MethodKind::Mc => Method::Mc {
                samples: samples.unwrap_or(1024),
                seed: seed.unwrap_or(1),
            },
            MethodKind::CubatureAdaptive => Method::CubatureAdaptive {
                tolerance: tolerance.unwrap_or(0.01),
            },
            MethodKind::Point => Method::Point,
            MethodKind::Structured => Method::Structured,
            MethodKind::Mrp => Method::Mrp,
            MethodKind::Cubature => Method::Cubature,
        };
        if !matches!(m, Method::Mc { .. }) {
            only("--samples", samples.is_some(), "mc")?;
            only("--seed", seed.is_some(), "mc")?;
        }
        if !matches!(m, Method::CubatureAdaptive { .. }) {
            only("--tolerance", tolerance.is_some(), "cubature-adaptive")?;
        }
        if let Method::Mc { samples, .. } = m {
            crate::limits::check_count("--samples", samples, 100_000_000, "samples per point")?;
        }
        Ok(m)
    }
}

/// Reads an IES or EULUMDAT file with its TILT table applied at `lamp_tilt` degrees.
pub fn read_light(path: &Path, lamp_tilt: f64) -> Result<PhotometricFile> {
    if !lamp_tilt.is_finite() {
        return Err(Error::flag(
            "--lamp-tilt",
            "expected a finite angle in degrees",
        ));
    }
    crate::io::read_photometric(path, lamp_tilt)
}

fn file_name(p: &Path) -> String {
    p.file_name()
        .map(|n| n.to_string_lossy().to_string())
        .unwrap_or_default()
}

fn stem_or(p: &Path, default: &str) -> String {
    p.file_stem()
        .map_or_else(|| default.into(), |s| s.to_string_lossy().into_owned())
}

/// `<stem>.ies` beside a glTF file (the IES profile its `EXT_lights_ies` node refers to).
pub fn ies_beside(gltf: &Path) -> PathBuf {
    gltf.with_file_name(format!("{}.ies", stem_or(gltf, "light")))
}

/// What a photometric file says, as JSON and as the text `light inspect` prints.
#[derive(Debug, Clone)]
pub struct Inspection {
    /// The report (`light inspect --json`).
    pub json: Value,
    /// The text report, one quantity per line.
    pub text: String,
}

/// Reads `file`, stages the polar chart at `plot` when given, and returns the inspection.
pub fn inspect(
    file: &Path,
    plot: Option<&Path>,
    lamp_tilt: f64,
    out: &mut Outputs,
) -> Result<Inspection> {
    out.input(file);
    if let Some(p) = plot {
        out.declare("--plot", p)?;
    }
    let f = read_light(file, lamp_tilt)?;
    let p = &f.photometry;
    let s = summary(p);
    ensure_finite("flux", &file.display().to_string(), &[s.flux_lm, s.max_cd])?;
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
    let (h, v) = (&p.grid.h_deg, &p.grid.v_deg);
    let report = json!({
        "file": file.display().to_string(),
        "format": f.format, "version": f.version,
        "photometric_type": p.grid.kind, "symmetry": p.symmetry,
        "grid": {"horizontal_angles": h.len(), "vertical_angles": v.len(),
                  "horizontal_deg": [h[0], h[h.len() - 1]],
                  "vertical_deg": [v[0], v[v.len() - 1]]},
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
    if let Some(path) = plot {
        let title = format!(
            "{} — max {:.4} cd, {:.1} lm",
            file_name(file),
            s.max_cd,
            s.flux_lm
        );
        let png = crate::plot::photometry::polar_chart_png(&p.grid, &title)?;
        out.stage(path, &png)?;
    }
    let pct = |x: Option<f64>| {
        x.map(|v| format!("{:.1} %", 100.0 * v))
            .unwrap_or_else(|| "— (absolute photometry)".into())
    };
    let mut t = format!(
        "{}\n  format      {:?} {}, type {:?}, symmetry {:?}\n  grid        {} horizontal × {} vertical angles (after symmetry), γ {}–{}°\n  max         {:.6} cd at h {}°, v {}°\n  flux        {:.2} lm from the grid (down {:.2}, up {:.2}); declared lamp flux {}\n  LOR         {}  DLOR {}  ULOR {}\n",
        file.display(), f.format, f.version, p.grid.kind, p.symmetry, h.len(), v.len(),
        v[0], v[v.len() - 1], s.max_cd, s.max_h_deg, s.max_v_deg,
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
    Ok(Inspection {
        json: report,
        text: t.trim_end().to_string(),
    })
}

/// `light convert`: `file` rewritten as LM-63-2019 or EULUMDAT by the extension of `dest`
/// (staged); returns the one-line JSON summary.
pub fn convert(file: &Path, dest: &Path, lamp_tilt: f64, out: &mut Outputs) -> Result<Value> {
    out.input(file);
    out.declare("--out", dest)?;
    let f = read_light(file, lamp_tilt)?;
    let ext = dest
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    let tool = format!(
        "lumifit {} from {}",
        env!("CARGO_PKG_VERSION"),
        file_name(file)
    );
    let text = match ext.as_str() {
        "ies" => crate::io::ies::write_ies(&f, &tool)?,
        "ldt" => crate::io::eulumdat::write_ldt(&f, &tool)?,
        _ => {
            return Err(Error::flag(
                "--out",
                format!("'{}': expected a .ies or .ldt file name", dest.display()),
            ))
        }
    };
    out.stage(dest, text.as_bytes())?;
    Ok(json!({"in": file.display().to_string(), "out": dest.display().to_string(), "format": ext}))
}

/// `--rect W,H`, or the file's luminous opening (length along C0, width along C90).
pub fn emitter_rect(arg: Option<&str>, f: &PhotometricFile, path: &Path) -> Result<(f64, f64)> {
    match arg {
        Some(r) => parse_pair("--rect", r),
        None => {
            let o = f.photometry.opening;
            if !(o.length_m > 0.0 && o.width_m > 0.0) {
                return Err(Error::flag(
                    "--rect",
                    format!(
                        "{} declares no rectangular luminous opening ({:?} {} × {} m); give --rect W,H",
                        path.display(),
                        o.shape,
                        o.length_m,
                        o.width_m
                    ),
                ));
            }
            Ok((o.length_m, o.width_m))
        }
    }
}

/// The frame of a rectangle light as typed: `--center`, `--normal`, `--up` (comma-separated).
#[derive(Debug, Clone)]
pub struct Frame {
    /// Centre, m.
    pub center: String,
    /// Emitting normal.
    pub normal: String,
    /// Up hint.
    pub up: String,
}

impl Frame {
    fn light(&self, w: f64, h: f64) -> Result<RectLight> {
        RectLight::new(
            parse_triplet("--center", &self.center)?,
            parse_triplet("--normal", &self.normal)?,
            parse_triplet("--up", &self.up)?,
            w,
            h,
        )
    }
}

/// `light illuminance`: a photometric rectangle shading receiving points.
#[derive(Debug, Clone)]
pub struct IlluminanceJob {
    /// IES or EULUMDAT file.
    pub light: PathBuf,
    /// Receiving points CSV (x,y,z,nx,ny,nz).
    pub points: PathBuf,
    /// Output CSV.
    pub out: PathBuf,
    /// `--rect W,H` (default: the file's opening).
    pub rect: Option<String>,
    /// Where the rectangle is.
    pub frame: Frame,
    /// Shading method and its parameters (checked by [`MethodKind::method`]).
    pub method: MethodKind,
    /// Monte Carlo samples per point.
    pub samples: Option<usize>,
    /// Monte Carlo seed.
    pub seed: Option<u64>,
    /// Adaptive cubature tolerance.
    pub tolerance: Option<f64>,
    /// Lamp tilt in degrees.
    pub lamp_tilt: f64,
    /// Interpolation of I(C, γ).
    pub interp: Interp,
}

/// Runs an [`IlluminanceJob`]: stages the E CSV and returns the summary line.
pub fn shade(job: &IlluminanceJob, out: &mut Outputs) -> Result<Value> {
    out.input(&job.light).input(&job.points);
    out.declare("--out", &job.out)?;
    let m = job.method.method(job.samples, job.seed, job.tolerance)?;
    let f = read_light(&job.light, job.lamp_tilt)?;
    let (w, h) = emitter_rect(job.rect.as_deref(), &f, &job.light)?;
    let light = job.frame.light(w, h)?;
    let receivers = crate::io::receivers::read_receivers(&job.points)?;
    let n = receivers.len();
    let started = std::time::Instant::now();
    let grid = f.photometry.grid.clone().with_interp(job.interp);
    let shades = illuminance(&light, &grid, &receivers, m)?;
    let seconds = started.elapsed().as_secs_f64();
    let e: Vec<f64> = shades.iter().map(|s| s.e_lux).collect();
    ensure_finite("E_lux", &job.points.display().to_string(), &e)?;
    let with_std = matches!(m, Method::Mc { .. });
    let with_le = matches!(m, Method::Cubature | Method::CubatureAdaptive { .. });
    let csv = crate::io::receivers::shades_to_csv(&receivers, &shades, with_std, with_le);
    out.stage(&job.out, csv.as_bytes())?;
    let evals: usize = shades.iter().map(|s| s.evaluations).sum();
    Ok(json!({
        "points": n, "method": m.name(), "rect_m": [w, h],
        "compute_seconds": seconds, "points_per_second": n as f64 / seconds.max(1e-12),
        "E_lux_min": e.iter().cloned().fold(f64::INFINITY, f64::min),
        "E_lux_max": e.iter().cloned().fold(f64::NEG_INFINITY, f64::max),
        "mean_evaluations_per_point": evals as f64 / n.max(1) as f64,
        "interp": grid.interp,
        "out": job.out.display().to_string(),
    }))
}

/// `light preset`: a `lumifit.light/1` preset, and optionally the glTF node placing it.
#[derive(Debug, Clone)]
pub struct LightPresetJob {
    /// IES or EULUMDAT file.
    pub file: PathBuf,
    /// `--rect W,H` (default: the file's opening).
    pub rect: Option<String>,
    /// Preset name (default: the file's stem).
    pub name: Option<String>,
    /// Lamp tilt in degrees.
    pub lamp_tilt: f64,
    /// Output preset JSON.
    pub out: PathBuf,
    /// glTF file (the IES is written beside it as `<stem>.ies`).
    pub gltf: Option<PathBuf>,
    /// Where the glTF places the light.
    pub frame: Frame,
}

/// Runs a [`LightPresetJob`]: stages the preset (and glTF + IES) and returns the summary line.
pub fn light_preset(job: &LightPresetJob, out: &mut Outputs) -> Result<Value> {
    out.input(&job.file);
    out.declare("--out", &job.out)?;
    let ies_path = job.gltf.as_deref().map(ies_beside);
    if let (Some(g), Some(i)) = (&job.gltf, &ies_path) {
        out.declare("--gltf", g)?;
        out.declare("--gltf (IES beside it)", i)?;
    }
    let f = read_light(&job.file, job.lamp_tilt)?;
    let (w, h) = emitter_rect(job.rect.as_deref(), &f, &job.file)?;
    let section = crate::preset::photometric::photometric_section(&f, w, h)?;
    let (bytes, _) = crate::io::read_input(&job.file)?;
    let name = job
        .name
        .clone()
        .unwrap_or_else(|| stem_or(&job.file, "light"));
    let provenance =
        crate::preset::Provenance::new("light preset", &[(&job.file, bytes.as_slice())]);
    let p = crate::preset::LightPreset::new(name, provenance, section);
    let text = crate::preset::to_json_string(&p)?;
    out.stage(&job.out, text.as_bytes())?;
    if let (Some(g), Some(i)) = (&job.gltf, &ies_path) {
        let light = job.frame.light(w, h)?;
        stage_gltf(&f, &light, &p.name, g, i, out)?;
    }
    Ok(json!({
        "in": job.file.display().to_string(),
        "out": job.out.display().to_string(),
        "gltf": job.gltf.as_ref().map(|g| g.display().to_string()),
        "ies": ies_path.as_ref().map(|i| i.display().to_string()),
        "rect_m": [w, h],
    }))
}

fn stage_gltf(
    f: &PhotometricFile,
    light: &RectLight,
    name: &str,
    gltf: &Path,
    ies_path: &Path,
    out: &mut Outputs,
) -> Result<()> {
    let uri = ies_path
        .file_name()
        .map_or_else(|| "light.ies".into(), |s| s.to_string_lossy().into_owned());
    let (doc, ies) = crate::preset::export::light::gltf_light(f, light, name, &uri)?;
    out.stage(
        gltf,
        crate::io::pretty_json_line(&doc, "glTF JSON")?.as_bytes(),
    )?;
    out.stage(ies_path, &ies)
}

/// `light synth`: a synthetic profile written as LM-63-2019 at `dest`; returns the summary.
pub fn synth(profile: &str, dest: &Path, out: &mut Outputs) -> Result<Value> {
    out.declare("--out", dest)?;
    let profile: SyntheticProfile = profile.parse()?;
    let f = profile.file()?;
    let tool = format!(
        "lumifit {} light synth --profile {}",
        env!("CARGO_PKG_VERSION"),
        profile.name()
    );
    let text = crate::io::ies::write_ies(&f, &tool)?;
    out.stage(dest, text.as_bytes())?;
    let s = summary(&f.photometry);
    Ok(
        json!({"profile": profile.name(), "out": dest.display().to_string(),
              "max_cd": s.max_cd, "flux_lm": s.flux_lm}),
    )
}

/// `light benchmark`: the paper's benchmark over `lights` into the folder `dir`.
#[derive(Debug, Clone)]
pub struct BenchmarkJob {
    /// IES or EULUMDAT files, one profile each.
    pub lights: Vec<PathBuf>,
    /// Output folder.
    pub dir: PathBuf,
    /// What to compute.
    pub spec: BenchmarkSpec,
    /// Lamp tilt in degrees.
    pub lamp_tilt: f64,
    /// Difference images saturate at ± this fraction of the peak.
    pub diff_range: f64,
}

impl BenchmarkJob {
    /// The number of (profile, height) cases, for a progress bar.
    pub fn cases(&self) -> usize {
        self.lights.len() * self.spec.heights_m.len()
    }
}

/// Runs a [`BenchmarkJob`], calling `progress` after each case: stages the tables, summary
/// and difference images and returns the summary line.
pub fn benchmark(
    job: &BenchmarkJob,
    out: &mut Outputs,
    progress: &(dyn Fn() + Sync),
) -> Result<Value> {
    let spec = &job.spec;
    out.inputs(&job.lights);
    out.declare_dir("--out", &job.dir)?;
    bench::validate(spec, job.lights.len())?;
    let files = job
        .lights
        .iter()
        .map(|l| read_light(l, job.lamp_tilt))
        .collect::<Result<Vec<_>>>()?;
    let names = profile_names(&job.lights);
    let mut pngs = Vec::new();
    for n in &names {
        for h in &spec.heights_m {
            let p = job.dir.join(format!("diff-{n}-h{h}.png"));
            out.declare("--out", &p)?;
            pngs.push(p);
        }
    }
    let tables = ["nrms.csv", "reference.csv", "nrms.md", "summary.json"].map(|f| job.dir.join(f));
    for t in &tables {
        out.declare("--out", t)?;
    }
    let profiles: Vec<(String, &CandelaGrid)> = names
        .iter()
        .cloned()
        .zip(files.iter().map(|f| &f.photometry.grid))
        .collect();
    let started = std::time::Instant::now();
    let cases = bench::run_all(&profiles, spec, &|_| progress())?;
    let seconds = started.elapsed().as_secs_f64();
    for (c, p) in cases.iter().zip(&pngs) {
        let png = crate::plot::photometry::benchmark_difference_png(c, spec, job.diff_range)?;
        out.stage(p, &png)?;
    }
    out.stage(&tables[0], bench::results_csv(&cases).as_bytes())?;
    out.stage(&tables[1], bench::reference_csv(&cases).as_bytes())?;
    out.stage(&tables[2], bench::results_markdown(&cases, spec).as_bytes())?;
    let summary = json!({"spec": spec, "cases": cases, "seconds": seconds,
        "files": job.lights.iter().map(|l| l.display().to_string()).collect::<Vec<_>>()});
    let summary = crate::io::pretty_json_line(&summary, "summary.json")?;
    out.stage(&tables[3], summary.as_bytes())?;
    let worst = cases
        .iter()
        .map(|c| c.reference.noise_ratio)
        .fold(0.0f64, f64::max);
    Ok(
        json!({"out": job.dir.display().to_string(), "profiles": names, "cases": cases.len(),
        "seconds": seconds, "all_references_converged": cases.iter().all(|c| c.reference.converged),
        "worst_reference_noise_ratio": worst}),
    )
}

/// File stems as profile names, made unique with the parent folder's name when two collide
/// (and with `-2`, `-3`, … when they still do).
pub fn profile_names(paths: &[PathBuf]) -> Vec<String> {
    let stems: Vec<String> = paths.iter().map(|p| stem_or(p, "light")).collect();
    let mut names = stems.clone();
    for i in 0..names.len() {
        // Counted on the stems, not on the names being rewritten: every path whose stem is
        // shared gets its folder, not only the ones before the last.
        if stems.iter().filter(|n| **n == stems[i]).count() > 1 {
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
/// --gltf` (default frame: 2.5 m above the origin, facing down, C0 along +Z), the IES staged
/// beside it as `<out stem>.ies`; returns the summary line.
pub fn export_preset_gltf(
    path: &Path,
    preset: &crate::preset::LightPreset,
    gltf: &Path,
    out: &mut Outputs,
) -> Result<Value> {
    out.input(path);
    let ies_path = ies_beside(gltf);
    out.declare("--out", gltf)?;
    out.declare("--out (IES beside it)", &ies_path)?;
    let file = path.display().to_string();
    let section = &preset.photometric;
    let f = crate::preset::photometric::file_from_section(section, &file, &preset.name)?;
    let [w, h] = crate::preset::photometric::read_section(section, &file)?.emitter_rect_m;
    let light = RectLight::new([0.0, 2.5, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, 1.0], w, h)?;
    stage_gltf(&f, &light, &preset.name, gltf, &ies_path, out)?;
    Ok(
        json!({"in": file, "out": gltf.display().to_string(), "ies": ies_path.display().to_string(),
                 "rect_m": [w, h]}),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn profile_names_are_unique_by_parent_then_by_count() {
        let p = |s: &str| PathBuf::from(s);
        let names = profile_names(&[p("a/x.ies"), p("b/x.ies"), p("y.ies"), p("a/x.ldt")]);
        assert_eq!(names, ["a-x", "b-x", "y", "a-x-2"]);
    }

    #[test]
    fn a_method_parameter_given_to_another_method_is_refused() {
        let e = MethodKind::Point.method(Some(10), None, None).unwrap_err();
        assert_eq!(e.to_string(), "--samples: applies to --method mc only");
        let m = MethodKind::Mc.method(None, Some(7), None).unwrap();
        assert!(matches!(
            m,
            Method::Mc {
                samples: 1024,
                seed: 7
            }
        ));
        assert!(MethodKind::Mc.method(None, None, Some(0.1)).is_err());
    }
}
