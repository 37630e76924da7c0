//! Fluorescence (`lumifit fluor …`): what each command does between its flags and its printed
//! lines — expand the matrix folders, set up the working grid and observer, reduce (Fichet et
//! al. 2024), evaluate, select a basis or sweep, build the presets and the tables, render the
//! chart, and stage every output in the caller's [`Outputs`]. The caller commits and prints.

use std::path::{Path, PathBuf};

use serde_json::{json, Value};

use crate::colorimetry::rgb::RgbSpace;
use crate::colorimetry::{Observer, StandardObserver};
use crate::error::{ensure_finite, Error, Result};
use crate::fluor::evaluate::{summarise, sweep, SweepRow};
use crate::fluor::{
    evaluate, illuminant_on_grid, parse_donaldson, reduce, rgb_matrix, select_basis, xyz_matrix,
    Basis, BasisKind, DonaldsonMatrix, GridIlluminant, Method, OperatorMatrix, Reduction,
    ResampleOptions, WorkingGrid,
};
use crate::io::sources::{expand_folders, file_of, resolve_basis, resolve_illuminant};
use crate::io::{read_input, Outputs};
use crate::plot::{fluor_chart_png, FluorChart};
use crate::preset::fluorescence::{fluorescence_preset, fluorescence_section, ReductionRecord};
use crate::preset::to_json_string;
use crate::spectrum::MultiSpectrum;

/// Options shared by every `fluor` command: observer, grid step, matrix conditioning.
#[derive(Debug, Clone)]
pub struct Conditions {
    /// Observer name of the XYZ basis (`cie2015-2`, …).
    pub observer: String,
    /// Working grid step in nm (grid 300–780 nm).
    pub step_nm: f64,
    /// Zero anti-Stokes entries.
    pub zero_anti_stokes: bool,
    /// Keep negative entries (else clipped to 0).
    pub keep_negatives: bool,
}

/// Where notes (not errors) go, e.g. a basis that does not span the CMFs exactly.
pub type Notes<'a> = &'a dyn Fn(&str);

struct Setup {
    grid: WorkingGrid,
    observer: String,
    cmfs: MultiSpectrum,
    xyz: Basis,
    options: ResampleOptions,
    /// The command line, for the presets' provenance (reduce and eval only).
    command: String,
}

fn setup(c: &Conditions) -> Result<Setup> {
    let grid = WorkingGrid::new(300.0, 780.0, c.step_nm)?;
    let obs = StandardObserver::from_name(&c.observer)?;
    let cmfs = Observer::standard(obs)?.cmfs().clone();
    let xyz = Basis::xyz(&cmfs, &grid)?;
    let options = ResampleOptions {
        clip_negatives: !c.keep_negatives,
        zero_anti_stokes: c.zero_anti_stokes,
    };
    Ok(Setup {
        command: String::new(),
        grid,
        observer: obs.cli_name().to_string(),
        cmfs,
        xyz,
        options,
    })
}

fn load_matrix(path: &Path) -> Result<(DonaldsonMatrix, Vec<u8>)> {
    let (bytes, source) = read_input(path)?;
    let d = parse_donaldson(&bytes, &source)?;
    Ok((d, bytes))
}

fn load_illuminants(names: &[String], xyz: &Basis) -> Result<Vec<GridIlluminant>> {
    names
        .iter()
        .map(|n| {
            let ill = resolve_illuminant("--illuminant", n)?;
            illuminant_on_grid(&ill, xyz)
        })
        .collect()
}

fn basis_from_arg(arg: &str, s: &Setup, note: Notes) -> Result<Basis> {
    let b = resolve_basis(arg, &s.cmfs, &s.grid)?;
    if b.transfer_residual() > 1e-3 {
        note(&format!(
            "note: basis '{}' does not span the {} CMFs exactly (relative residual {:.3e}); T is the least-squares fit",
            b.name(),
            s.observer,
            b.transfer_residual()
        ));
    }
    Ok(b)
}

fn methods_from_names(names: &[String], s: &Setup) -> Result<Vec<Method>> {
    names
        .iter()
        .map(|n| Method::from_name(n, &s.cmfs, &s.grid))
        .collect()
}

/// Registers the illuminant files and a basis file as inputs.
fn register_common(out: &mut Outputs, illuminants: &[String], bases: &[&str]) {
    out.inputs(illuminants.iter().filter_map(|n| file_of(n)));
    out.inputs(bases.iter().filter_map(|n| file_of(n)));
}

/// The matrices named on the command line: files as given, folders expanded to their
/// `*.bfc` / `*.csv` files (sorted by name).
pub fn expand_matrices(paths: &[PathBuf]) -> Result<Vec<PathBuf>> {
    expand_folders(paths, &["bfc", "csv"])
}

/// `DIR/<stem>.json` for every matrix; two matrices with the same stem are refused.
pub fn preset_paths(dir: &Path, matrices: &[PathBuf]) -> Result<Vec<PathBuf>> {
    let mut seen = std::collections::HashMap::new();
    let mut out = Vec::new();
    for m in matrices {
        let stem = m
            .file_stem()
            .map_or("matrix".into(), |s| s.to_string_lossy().to_string());
        if let Some(prev) = seen.insert(stem.clone(), m.clone()) {
            return Err(Error::flag(
                "--out-dir",
                format!(
                    "{} and {} would both be written as {stem}.json; rename one",
                    prev.display(),
                    m.display()
                ),
            ));
        }
        out.push(dir.join(format!("{stem}.json")));
    }
    Ok(out)
}

/// One matrix reduced into a preset.
struct ReducedPreset {
    matrix: DonaldsonMatrix,
    red: crate::fluor::reduce::Reduced,
    rows: Vec<crate::fluor::evaluate::EvalRow>,
    worst: f64,
    json: String,
}

/// Reduces `path` with `method` and builds its preset (validated) with the ΔE00 table under
/// `ills`.
fn reduce_one(
    path: &Path,
    s: &Setup,
    method: &Method,
    space: &RgbSpace,
    ills: &[GridIlluminant],
    illuminant_names: &[String],
    basis_file: Option<PathBuf>,
) -> Result<ReducedPreset> {
    let (d, bytes) = load_matrix(path)?;
    let op = d.to_operator(&s.grid, s.options);
    let basis = &method.basis;
    let red = reduce(&op, basis, method.reduction)?;
    let p3 = xyz_matrix(&red, basis, &s.xyz)?;
    let p_rgb = rgb_matrix(&p3, space);
    let rows = evaluate(&op, std::slice::from_ref(method), ills, &s.xyz)?;
    let section = fluorescence_section(
        &ReductionRecord {
            reduced: &red,
            basis,
            observer: &s.observer,
            grid: &s.grid,
            xyz_matrix: &p3,
            rgb_matrix: &p_rgb,
            space,
            options: s.options,
            rows: &rows,
        },
        &path.display().to_string(),
    )?;
    let worst = section.worst_delta_e00;
    let mut inputs: Vec<(PathBuf, Vec<u8>)> = vec![(path.to_path_buf(), bytes)];
    if let Some(bp) = basis_file {
        let (b, _) = read_input(&bp)?;
        inputs.push((bp, b));
    }
    let refs: Vec<(&Path, &[u8])> = inputs
        .iter()
        .map(|(p, b)| (p.as_path(), b.as_slice()))
        .collect();
    let preset = fluorescence_preset(d.name(), section, &s.command, &refs, illuminant_names);
    // Validated as a reader would before it is staged.
    let json = to_json_string(&preset)?;
    Ok(ReducedPreset {
        matrix: d,
        red,
        rows,
        worst,
        json,
    })
}

/// The ΔE00 table of reduced presets: `material,file,illuminant,method,delta_e00`.
fn reduce_table(done: &[(PathBuf, ReducedPreset)]) -> String {
    let mut t = String::from("material,file,illuminant,method,delta_e00\n");
    for (p, r) in done {
        for row in &r.rows {
            t.push_str(&format!(
                "{},{},{},{},{:.4}\n",
                csv_field(&row.material),
                csv_field(&p.display().to_string()),
                csv_field(&row.illuminant),
                row.method,
                row.delta_e00
            ));
        }
    }
    t
}

/// A CSV field, quoted when it holds a comma or a quote.
fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

/// `fluor reduce`: one preset per matrix, optionally a ΔE00 table and a chart.
#[derive(Debug, Clone)]
pub struct ReduceJob {
    /// Matrix files or folders of them.
    pub matrices: Vec<PathBuf>,
    /// Basis name or CSV.
    pub basis: String,
    /// Reduction name (`dual`, `naive`).
    pub method: String,
    /// RGB working space name.
    pub rgb: String,
    /// Illuminants of the ΔE00 table (names or SPD files).
    pub illuminants: Vec<String>,
    /// One preset file (one matrix).
    pub out: Option<PathBuf>,
    /// A folder of presets (any number of matrices).
    pub out_dir: Option<PathBuf>,
    /// The ΔE00 table (`-` for standard output).
    pub table: Option<PathBuf>,
    /// The chart (one matrix).
    pub plot: Option<PathBuf>,
    /// Observer, grid, conditioning.
    pub conditions: Conditions,
    /// The command line, for the presets' provenance.
    pub command: String,
}

/// What a command prints when it is done, and where.
#[derive(Debug, Clone)]
pub struct Summary {
    /// The text.
    pub text: String,
    /// Standard error (standard output carries a table, or there are many lines).
    pub to_stderr: bool,
}

/// Runs a [`ReduceJob`].
pub fn run_reduce(job: &ReduceJob, out: &mut Outputs, note: Notes) -> Result<Summary> {
    let matrices = expand_matrices(&job.matrices)?;
    if matrices.len() > 1 && job.out.is_some() {
        return Err(Error::flag(
            "--out",
            format!(
                "names one preset but {} matrices were given; use --out-dir DIR for one preset each",
                matrices.len()
            ),
        ));
    }
    if matrices.len() > 1 && job.plot.is_some() {
        return Err(Error::flag(
            "--plot",
            format!("draws one matrix; {} were given", matrices.len()),
        ));
    }
    out.inputs(&matrices);
    register_common(out, &job.illuminants, &[&job.basis]);
    let targets = match (&job.out, &job.out_dir) {
        (Some(p), None) => vec![p.clone()],
        (None, Some(dir)) => {
            out.declare_dir("--out-dir", dir)?;
            preset_paths(dir, &matrices)?
        }
        _ => {
            return Err(Error::invalid(
                "--out/--out-dir",
                "give either --out FILE.json (one matrix) or --out-dir DIR",
            ))
        }
    };
    for t in &targets {
        out.declare("--out", t)?;
    }
    if let Some(p) = &job.table {
        out.declare("--table", p)?;
    }
    if let Some(p) = &job.plot {
        out.declare("--plot", p)?;
    }
    let s = Setup {
        command: job.command.clone(),
        ..setup(&job.conditions)?
    };
    let basis = basis_from_arg(&job.basis, &s, note)?;
    let reduction = Reduction::from_name(&job.method)?;
    let space = RgbSpace::from_name(&job.rgb)?;
    let ills = load_illuminants(&job.illuminants, &s.xyz)?;
    let method = Method {
        reduction,
        basis: basis.clone(),
    };
    let mut done = Vec::with_capacity(matrices.len());
    for (m, target) in matrices.iter().zip(&targets) {
        let r = reduce_one(
            m,
            &s,
            &method,
            &space,
            &ills,
            &job.illuminants,
            file_of(&job.basis),
        )?;
        out.stage(target, r.json.as_bytes())?;
        done.push((m.clone(), r));
    }
    if let (Some(plot), Some((_, r))) = (&job.plot, done.first()) {
        let chart = FluorChart::from_evaluation(
            &r.matrix,
            vec![(method.name(), basis.labels().to_vec(), r.red.p.clone())],
            &r.rows,
        );
        out.stage(plot, &fluor_chart_png(&chart)?)?;
    }
    if let Some(p) = &job.table {
        out.stage_text(p, &reduce_table(&done))?;
    }
    let mut text = String::new();
    for (target, (_, r)) in targets.iter().zip(&done) {
        text.push_str(&format!(
            "{}: {} ({}×{}), worst ΔE00 {:.3} → {}\n",
            r.matrix.name(),
            method.name(),
            basis.k(),
            basis.k(),
            r.worst,
            target.display()
        ));
        if done.len() == 1 {
            for row in &r.rows {
                text.push_str(&format!(
                    "  {:<8} ΔE00 {:>7.3}\n",
                    row.illuminant, row.delta_e00
                ));
            }
        }
    }
    // The summary never shares standard output with a table written there.
    let to_stderr = job.table.as_ref().is_some_and(|p| p.as_os_str() == "-") || done.len() > 1;
    Ok(Summary {
        text: text.trim_end().to_string(),
        to_stderr,
    })
}

/// `fluor eval`: the ΔE00 table of matrices × illuminants × methods, optionally presets and a
/// chart.
#[derive(Debug, Clone)]
pub struct EvalJob {
    /// Matrix files or folders of them.
    pub matrices: Vec<PathBuf>,
    /// Illuminants (names or SPD files).
    pub illuminants: Vec<String>,
    /// Methods `<dual|naive>-<xyz|xyzu|xyz7u>`.
    pub methods: Vec<String>,
    /// The table as a JSON array instead of CSV.
    pub json: bool,
    /// The table (`-` for standard output).
    pub out: PathBuf,
    /// Also one preset per matrix into this folder.
    pub out_dir: Option<PathBuf>,
    /// RGB working space of the presets.
    pub rgb: String,
    /// The chart.
    pub plot: Option<PathBuf>,
    /// Observer, grid, conditioning.
    pub conditions: Conditions,
    /// The command line, for the presets' provenance.
    pub command: String,
}

/// Runs an [`EvalJob`]; the summary goes to standard error (standard output may carry the
/// table).
pub fn run_eval(job: &EvalJob, out: &mut Outputs) -> Result<Summary> {
    let matrices = expand_matrices(&job.matrices)?;
    out.inputs(&matrices);
    register_common(out, &job.illuminants, &[]);
    out.declare("--out", &job.out)?;
    if let Some(p) = &job.plot {
        out.declare("--plot", p)?;
    }
    let presets = match &job.out_dir {
        Some(dir) => {
            out.declare_dir("--out-dir", dir)?;
            let paths = preset_paths(dir, &matrices)?;
            for p in &paths {
                out.declare("--out-dir", p)?;
            }
            paths
        }
        None => Vec::new(),
    };
    let s = Setup {
        command: job.command.clone(),
        ..setup(&job.conditions)?
    };
    let methods = methods_from_names(&job.methods, &s)?;
    let ills = load_illuminants(&job.illuminants, &s.xyz)?;
    if let (Some(_), Some(first_method)) = (&job.out_dir, methods.first()) {
        let space = RgbSpace::from_name(&job.rgb)?;
        for (m, target) in matrices.iter().zip(&presets) {
            let r = reduce_one(m, &s, first_method, &space, &ills, &job.illuminants, None)?;
            out.stage(target, r.json.as_bytes())?;
        }
    }
    let mut rows = Vec::new();
    let mut first: Option<(DonaldsonMatrix, OperatorMatrix)> = None;
    for p in &matrices {
        let (d, _) = load_matrix(p)?;
        let op = d.to_operator(&s.grid, s.options);
        let evaluated = evaluate(&op, &methods, &ills, &s.xyz)?;
        for r in &evaluated {
            let values = [&[r.delta_e00][..], &r.xyz_reference, &r.xyz_reduced].concat();
            ensure_finite(
                &format!("ΔE00 ({}, {})", r.illuminant, r.method),
                &p.display().to_string(),
                &values,
            )?;
        }
        rows.extend(evaluated);
        if first.is_none() {
            first = Some((d, op));
        }
    }
    if let (Some(plot), Some((d, op))) = (&job.plot, &first) {
        let reduced = methods
            .iter()
            .map(|m| {
                Ok((
                    m.name(),
                    m.basis.labels().to_vec(),
                    reduce(op, &m.basis, m.reduction)?.p,
                ))
            })
            .collect::<Result<Vec<_>>>()?;
        let mut chart = FluorChart::from_evaluation(d, reduced, &rows);
        if matrices.len() > 1 {
            chart.title = format!("{} (ΔE00: mean of {} materials)", d.name(), matrices.len());
        }
        out.stage(plot, &fluor_chart_png(&chart)?)?;
    }
    let table = if job.json {
        serde_json::to_string(&rows).map_err(|e| Error::Numerical {
            what: "the ΔE00 table".into(),
            reason: e.to_string(),
        })? + "\n"
    } else {
        let mut t = String::from("material,illuminant,method,delta_e00\n");
        for r in &rows {
            t.push_str(&format!(
                "{},{},{},{:.4}\n",
                csv_field(&r.material),
                csv_field(&r.illuminant),
                r.method,
                r.delta_e00
            ));
        }
        t
    };
    out.stage_text(&job.out, &table)?;
    let mut t = format!(
        "{} materials × {} illuminants × {} methods{}{}\nsummary over materials: mean / max ΔE00\n",
        matrices.len(),
        ills.len(),
        methods.len(),
        if job.out.as_os_str() == "-" {
            String::new()
        } else {
            format!("; table → {}", job.out.display())
        },
        job.out_dir
            .as_ref()
            .map(|d| format!("; {} presets → {}", presets.len(), d.display()))
            .unwrap_or_default()
    );
    let summary = summarise(&rows);
    t.push_str(&format!("{:<12}", "method"));
    for i in &ills {
        let short = Path::new(&i.name)
            .file_stem()
            .map_or(i.name.clone(), |s| s.to_string_lossy().into_owned());
        t.push_str(&format!("{short:>15}"));
    }
    t.push('\n');
    for m in &methods {
        t.push_str(&format!("{:<12}", m.name()));
        for i in &ills {
            if let Some((_, _, mean, max, _)) =
                summary.iter().find(|x| x.0 == i.name && x.1 == m.name())
            {
                t.push_str(&format!("{:>15}", format!("{mean:.2} / {max:.2}")));
            }
        }
        t.push('\n');
    }
    Ok(Summary {
        text: t.trim_end().to_string(),
        to_stderr: true,
    })
}

/// `fluor select`: the smallest basis whose worst ΔE00 is below a target.
#[derive(Debug, Clone)]
pub struct SelectJob {
    /// Matrix file.
    pub matrix: PathBuf,
    /// The scene's illuminants (names or SPD files).
    pub illuminants: Vec<String>,
    /// Target worst ΔE00.
    pub target_de: f64,
    /// Extra candidate bases (CSV files).
    pub extra_basis: Vec<PathBuf>,
    /// JSON instead of a table.
    pub json: bool,
    /// Output (`-` for standard output).
    pub out: PathBuf,
    /// Observer, grid, conditioning.
    pub conditions: Conditions,
}

/// Runs a [`SelectJob`], staging its table or JSON.
pub fn run_select(job: &SelectJob, out: &mut Outputs, note: Notes) -> Result<()> {
    out.input(&job.matrix);
    register_common(out, &job.illuminants, &[]);
    out.inputs(&job.extra_basis);
    out.declare("--out", &job.out)?;
    let s = setup(&job.conditions)?;
    let (d, _) = load_matrix(&job.matrix)?;
    let op = d.to_operator(&s.grid, s.options);
    let ills = load_illuminants(&job.illuminants, &s.xyz)?;
    let mut methods: Vec<Method> = BasisKind::ALL
        .iter()
        .map(|k| {
            Ok(Method {
                reduction: Reduction::Dual,
                basis: k.build(&s.cmfs, &s.grid)?,
            })
        })
        .collect::<Result<_>>()?;
    for p in &job.extra_basis {
        methods.push(Method {
            reduction: Reduction::Dual,
            basis: basis_from_arg(&p.to_string_lossy(), &s, note)?,
        });
    }
    let sel = select_basis(&op, &methods, &ills, &s.xyz, job.target_de)?;
    for c in &sel.candidates {
        ensure_finite(
            &format!("ΔE00 of {}", c.method),
            &job.matrix.display().to_string(),
            &[c.worst_delta_e00, c.mean_delta_e00],
        )?;
    }
    if job.json {
        let mut v = serde_json::to_value(&sel).map_err(|e| Error::Numerical {
            what: "the selection".into(),
            reason: e.to_string(),
        })?;
        if let Value::Object(o) = &mut v {
            o.insert("material".into(), json!(d.name()));
            o.insert(
                "chosen_method".into(),
                json!(sel.chosen.map(|i| sel.candidates[i].method.clone())),
            );
        }
        return out.stage_text(&job.out, &crate::io::pretty_json_line(&v, "the selection")?);
    }
    let mut t = format!(
        "{}: illuminants {}; target worst ΔE00 < {}\n",
        d.name(),
        job.illuminants.join(","),
        job.target_de
    );
    t.push_str(&format!(
        "{:<14}{:>4}{:>12}{:>12}  worst under\n",
        "method", "K", "worst", "mean"
    ));
    for c in &sel.candidates {
        t.push_str(&format!(
            "{:<14}{:>4}{:>12.3}{:>12.3}  {}\n",
            c.method, c.k, c.worst_delta_e00, c.mean_delta_e00, c.worst_illuminant
        ));
    }
    match sel.chosen {
        Some(i) => t.push_str(&format!(
            "chosen: {} (K = {})",
            sel.candidates[i].method, sel.candidates[i].k
        )),
        None => {
            let b = &sel.candidates[sel.best];
            t.push_str(&format!(
                "no candidate reaches ΔE00 < {}; best reachable: {} (K = {}, worst ΔE00 {:.3} under {})",
                job.target_de, b.method, b.k, b.worst_delta_e00, b.worst_illuminant
            ))
        }
    }
    t.push('\n');
    out.stage_text(&job.out, &t)
}

/// `fluor sweep`: one-bounce XYZ per excitation wavelength, reference vs reduced.
#[derive(Debug, Clone)]
pub struct SweepJob {
    /// Matrix file.
    pub matrix: PathBuf,
    /// Methods `<dual|naive>-<xyz|xyzu|xyz7u>`.
    pub methods: Vec<String>,
    /// Every n-th grid sample.
    pub every: usize,
    /// Output CSV (`-` for standard output).
    pub out: PathBuf,
    /// Observer, grid, conditioning.
    pub conditions: Conditions,
}

/// Runs a [`SweepJob`], staging its CSV.
pub fn run_sweep(job: &SweepJob, out: &mut Outputs) -> Result<()> {
    out.input(&job.matrix);
    out.declare("--out", &job.out)?;
    let s = setup(&job.conditions)?;
    let (d, _) = load_matrix(&job.matrix)?;
    let op = d.to_operator(&s.grid, s.options);
    let methods = methods_from_names(&job.methods, &s)?;
    let rows: Vec<SweepRow> = sweep(&op, &methods, &s.xyz, job.every)?;
    for r in &rows {
        let values = [
            &r.xyz_reference[..],
            &r.xyz_reduced,
            &[r.y_reradiated_reference],
        ]
        .concat();
        ensure_finite(
            &format!("the sweep at {} nm ({})", r.excitation_nm, r.method),
            &job.matrix.display().to_string(),
            &values,
        )?;
    }
    let mut t = String::from(
        "excitation_nm,method,X_ref,Y_ref,Z_ref,X_red,Y_red,Z_red,Y_reradiated_ref,Y_lost\n",
    );
    for r in &rows {
        t.push_str(&format!(
            "{},{},{:.6e},{:.6e},{:.6e},{:.6e},{:.6e},{:.6e},{:.6e},{:.6e}\n",
            r.excitation_nm,
            r.method,
            r.xyz_reference[0],
            r.xyz_reference[1],
            r.xyz_reference[2],
            r.xyz_reduced[0],
            r.xyz_reduced[1],
            r.xyz_reduced[2],
            r.y_reradiated_reference,
            r.xyz_reference[1] - r.xyz_reduced[1]
        ));
    }
    out.stage_text(&job.out, &t)
}
