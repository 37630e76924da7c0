//! `lumifit fluor …` (fluorescence): Donaldson-matrix reduction (Fichet et al. 2024), its
//! evaluation against the spectral reference, basis selection and presets.

use std::path::{Path, PathBuf};

use anyhow::Result;
use clap::{Args, Subcommand};
use lumifit::colorimetry::rgb::RgbSpace;
use lumifit::colorimetry::{Observer, StandardObserver};
use lumifit::error::ensure_finite;
use lumifit::fluor::evaluate::{summarise, sweep, SweepRow};
use lumifit::fluor::{
    evaluate, illuminant_on_grid, parse_donaldson, reduce, rgb_matrix, select_basis, xyz_matrix,
    Basis, BasisKind, DonaldsonMatrix, GridIlluminant, Method, OperatorMatrix, Reduction,
    ResampleOptions, WorkingGrid, DEFAULT_ILLUMINANTS, DEFAULT_METHODS,
};
use lumifit::io::sources::{expand_folders, file_of, resolve_basis};
use lumifit::io::{read_input, Outputs};
use lumifit::plot::{fluor_chart_png, FluorChart};
use lumifit::preset::fluorescence::{fluorescence_preset, fluorescence_section, ReductionRecord};
use lumifit::preset::to_json_string;
use lumifit::spectrum::MultiSpectrum;
use serde_json::{json, Value};

use super::{emit, resolve_illuminant};

/// Subcommands of `lumifit fluor`.
#[derive(Debug, Subcommand)]
pub enum FluorCommand {
    /// Reduce one Donaldson matrix to a K×K matrix in a basis and write a material preset.
    Reduce(ReduceArgs),
    /// ΔE00 of reduced against spectral rendering: materials × illuminants × methods.
    Eval(EvalArgs),
    /// Pick the smallest basis whose worst ΔE00 under the scene's illuminants is below a target.
    Select(SelectArgs),
    /// Monochromatic sweep: one-bounce XYZ per excitation wavelength, reference vs reduced (CSV).
    Sweep(SweepArgs),
}

/// Options shared by every subcommand: observer, grid, matrix conditioning.
#[derive(Debug, Args)]
pub struct CommonArgs {
    /// Observer of the XYZ basis (cie2015-2 = CIE 2006 2°, as the paper; cie1931-2, …).
    #[arg(long, default_value = "cie2015-2")]
    pub observer: String,
    /// Working grid step in nm (grid 300–780 nm).
    #[arg(long, default_value_t = 1.0)]
    pub step_nm: f64,
    /// Zero anti-Stokes entries (excitation ≥ emission off the diagonal).
    #[arg(long)]
    pub zero_anti_stokes: bool,
    /// Keep negative entries (by default measurement-noise negatives are clipped to 0).
    #[arg(long)]
    pub keep_negatives: bool,
}

#[derive(Debug, Args)]
#[command(group(clap::ArgGroup::new("dest").required(true).args(["out", "out_dir"])))]
pub struct ReduceArgs {
    /// Donaldson matrices: BFC-450 files or CSV (header `emission_nm,<excitation nm>…`), or
    /// folders of them (every *.bfc / *.csv inside, sorted). Several need --out-dir.
    #[arg(required = true)]
    pub matrices: Vec<PathBuf>,
    /// Basis: xyz, xyzu, xyz7u or a basis CSV (`wavelength_nm,f1,…,fK`).
    #[arg(long, default_value = "xyz")]
    pub basis: String,
    /// Reduction: dual (Fichet 2024 Eq. 15) or naive (Eq. 7).
    #[arg(long, default_value = "dual")]
    pub method: String,
    /// RGB working space for the 3×3 matrix of Eq. 16: srgb, rec2020, acescg.
    #[arg(long, default_value = "srgb")]
    pub rgb: String,
    /// Illuminants of the ΔE00 table stored with the preset (names or SPD CSV files).
    #[arg(long, value_delimiter = ',', default_values_t = DEFAULT_ILLUMINANTS.map(String::from))]
    pub illuminants: Vec<String>,
    /// Output material preset (JSON), for one matrix.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Output folder: one preset `<file stem>.json` per matrix (any number of matrices).
    #[arg(long)]
    pub out_dir: Option<PathBuf>,
    /// Also write the ΔE00 table of every matrix, CSV `material,file,illuminant,method,delta_e00`
    /// (`-` for standard output; the summary then goes to standard error).
    #[arg(long)]
    pub table: Option<PathBuf>,
    /// Also write a PNG of the Donaldson matrix, the reduced matrix and ΔE00 per illuminant (one
    /// matrix only).
    #[arg(long)]
    pub plot: Option<PathBuf>,
    #[command(flatten)]
    pub common: CommonArgs,
}

#[derive(Debug, Args)]
pub struct EvalArgs {
    /// Donaldson matrices (BFC-450 or CSV), or folders of them (every *.bfc / *.csv inside).
    #[arg(required = true)]
    pub matrices: Vec<PathBuf>,
    /// Illuminants: CIE names or SPD CSV files.
    #[arg(long, value_delimiter = ',', default_values_t = DEFAULT_ILLUMINANTS.map(String::from))]
    pub illuminants: Vec<String>,
    /// Methods `<dual|naive>-<xyz|xyzu|xyz7u>`.
    #[arg(long, value_delimiter = ',', default_values_t = DEFAULT_METHODS.map(String::from))]
    pub methods: Vec<String>,
    /// Print one JSON array of `{material, illuminant, method, delta_e00, xyz_reference, xyz_reduced}`.
    #[arg(long)]
    pub json: bool,
    /// The table (CSV `material,illuminant,method,delta_e00`, or the JSON array with --json):
    /// a file, or `-` for standard output. The summary (mean / max ΔE00 per method and
    /// illuminant) always goes to standard error.
    #[arg(long, default_value = "-")]
    pub out: PathBuf,
    /// Also write one material preset per matrix into this folder (`<file stem>.json`), reduced
    /// with the first of --methods, its ΔE00 table under --illuminants inside.
    #[arg(long)]
    pub out_dir: Option<PathBuf>,
    /// RGB working space of the presets' 3×3 matrix (--out-dir): srgb, rec2020, acescg.
    #[arg(long, default_value = "srgb", requires = "out_dir")]
    pub rgb: String,
    /// Write a PNG: the first matrix, its reduced matrices and mean ΔE00 per illuminant and method.
    #[arg(long)]
    pub plot: Option<PathBuf>,
    #[command(flatten)]
    pub common: CommonArgs,
}

#[derive(Debug, Args)]
pub struct SelectArgs {
    /// Donaldson matrix (BFC-450 or CSV).
    pub matrix: PathBuf,
    /// The illuminants the scene uses (names or SPD CSV files).
    #[arg(long, value_delimiter = ',', default_values_t = DEFAULT_ILLUMINANTS.map(String::from))]
    pub illuminants: Vec<String>,
    /// Target: worst ΔE00 over the illuminants must be below this.
    #[arg(long, default_value_t = 1.0)]
    pub target_de: f64,
    /// Extra candidate bases (CSV files), tried with the built-ins in order of size.
    #[arg(long, value_delimiter = ',')]
    pub extra_basis: Vec<PathBuf>,
    /// Print JSON instead of a table.
    #[arg(long)]
    pub json: bool,
    /// Output file for the table (or JSON); `-` is standard output.
    #[arg(long, default_value = "-")]
    pub out: PathBuf,
    #[command(flatten)]
    pub common: CommonArgs,
}

#[derive(Debug, Args)]
pub struct SweepArgs {
    /// Donaldson matrix (BFC-450 or CSV).
    pub matrix: PathBuf,
    /// Methods `<dual|naive>-<xyz|xyzu|xyz7u>`.
    #[arg(long, value_delimiter = ',', default_values_t = ["dual-xyz", "dual-xyzu", "dual-xyz7u"].map(String::from))]
    pub methods: Vec<String>,
    /// Report every n-th grid sample.
    #[arg(long, default_value_t = 5)]
    pub every: usize,
    /// Output CSV; `-` is standard output.
    #[arg(long, default_value = "-")]
    pub out: PathBuf,
    #[command(flatten)]
    pub common: CommonArgs,
}

/// Runs a `lumifit fluor` subcommand.
pub fn run(cmd: FluorCommand) -> Result<()> {
    match cmd {
        FluorCommand::Reduce(a) => run_reduce(&a),
        FluorCommand::Eval(a) => run_eval(&a),
        FluorCommand::Select(a) => run_select(&a),
        FluorCommand::Sweep(a) => run_sweep(&a),
    }
}

struct Setup {
    grid: WorkingGrid,
    observer: String,
    cmfs: MultiSpectrum,
    xyz: Basis,
    options: ResampleOptions,
}

fn setup(c: &CommonArgs) -> Result<Setup> {
    let grid = WorkingGrid::new(300.0, 780.0, c.step_nm)?;
    let obs = StandardObserver::from_name(&c.observer)?;
    let cmfs = Observer::standard(obs)?.cmfs().clone();
    let xyz = Basis::xyz(&cmfs, &grid)?;
    let options = ResampleOptions {
        clip_negatives: !c.keep_negatives,
        zero_anti_stokes: c.zero_anti_stokes,
    };
    Ok(Setup {
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
            let ill = resolve_illuminant(n)?;
            Ok(illuminant_on_grid(&ill, xyz)?)
        })
        .collect()
}

fn basis_from_arg(arg: &str, s: &Setup) -> Result<Basis> {
    let b = resolve_basis(arg, &s.cmfs, &s.grid)?;
    if b.transfer_residual() > 1e-3 {
        eprintln!(
            "note: basis '{}' does not span the {} CMFs exactly (relative residual {:.3e}); T is the least-squares fit",
            b.name(),
            s.observer,
            b.transfer_residual()
        );
    }
    Ok(b)
}

fn methods_from_names(names: &[String], s: &Setup) -> Result<Vec<Method>> {
    names
        .iter()
        .map(|n| Ok(Method::from_name(n, &s.cmfs, &s.grid)?))
        .collect()
}

/// Registers the illuminant files and a basis file as inputs.
fn register_common(out: &mut Outputs, illuminants: &[String], bases: &[&str]) {
    out.inputs(illuminants.iter().filter_map(|n| file_of(n)));
    out.inputs(bases.iter().filter_map(|n| file_of(n)));
}

/// The matrices named on the command line: files as given, folders expanded to their
/// `*.bfc` / `*.csv` files (sorted by name).
fn expand_matrices(paths: &[PathBuf]) -> Result<Vec<PathBuf>> {
    Ok(expand_folders(paths, &["bfc", "csv"])?)
}

/// `DIR/<stem>.json` for every matrix; two matrices with the same stem are refused.
fn preset_paths(dir: &Path, matrices: &[PathBuf]) -> Result<Vec<PathBuf>> {
    let mut seen = std::collections::HashMap::new();
    let mut out = Vec::new();
    for m in matrices {
        let stem = m
            .file_stem()
            .map_or("matrix".into(), |s| s.to_string_lossy().to_string());
        if let Some(prev) = seen.insert(stem.clone(), m.clone()) {
            anyhow::bail!(
                "--out-dir: {} and {} would both be written as {stem}.json; rename one",
                prev.display(),
                m.display()
            );
        }
        out.push(dir.join(format!("{stem}.json")));
    }
    Ok(out)
}

/// One matrix reduced into a preset.
struct ReducedPreset {
    matrix: DonaldsonMatrix,
    red: lumifit::fluor::reduce::Reduced,
    rows: Vec<lumifit::fluor::evaluate::EvalRow>,
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
    let command = std::env::args().collect::<Vec<_>>().join(" ");
    let preset = fluorescence_preset(d.name(), section, &command, &refs, illuminant_names);
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

fn run_reduce(a: &ReduceArgs) -> Result<()> {
    let matrices = expand_matrices(&a.matrices)?;
    if matrices.len() > 1 && a.out.is_some() {
        anyhow::bail!(
            "--out names one preset but {} matrices were given; use --out-dir DIR for one preset each",
            matrices.len()
        );
    }
    if matrices.len() > 1 && a.plot.is_some() {
        anyhow::bail!("--plot draws one matrix; {} were given", matrices.len());
    }
    let mut out = Outputs::new();
    out.inputs(&matrices);
    register_common(&mut out, &a.illuminants, &[&a.basis]);
    let targets = match (&a.out, &a.out_dir) {
        (Some(p), None) => vec![p.clone()],
        (None, Some(dir)) => {
            out.declare_dir("--out-dir", dir)?;
            preset_paths(dir, &matrices)?
        }
        _ => anyhow::bail!("give either --out FILE.json (one matrix) or --out-dir DIR"),
    };
    for t in &targets {
        out.declare("--out", t)?;
    }
    if let Some(p) = &a.table {
        out.declare("--table", p)?;
    }
    if let Some(p) = &a.plot {
        out.declare("--plot", p)?;
    }
    let s = setup(&a.common)?;
    let basis = basis_from_arg(&a.basis, &s)?;
    let reduction = Reduction::from_name(&a.method)?;
    let space = RgbSpace::from_name(&a.rgb)?;
    let ills = load_illuminants(&a.illuminants, &s.xyz)?;
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
            &a.illuminants,
            file_of(&a.basis),
        )?;
        out.stage(target, r.json.as_bytes())?;
        done.push((m.clone(), r));
    }
    if let (Some(plot), Some((_, r))) = (&a.plot, done.first()) {
        let chart = FluorChart::from_evaluation(
            &r.matrix,
            vec![(method.name(), basis.labels().to_vec(), r.red.p.clone())],
            &r.rows,
        );
        out.stage(plot, &fluor_chart_png(&chart)?)?;
    }
    if let Some(p) = &a.table {
        out.stage_text(p, &reduce_table(&done))?;
    }
    out.commit()?;
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
    let text = text.trim_end();
    // The summary never shares standard output with a table written there.
    if a.table.as_ref().is_some_and(|p| p.as_os_str() == "-") || done.len() > 1 {
        eprintln!("{text}");
        Ok(())
    } else {
        emit(text)
    }
}

fn run_eval(a: &EvalArgs) -> Result<()> {
    let matrices = expand_matrices(&a.matrices)?;
    let mut out = Outputs::new();
    out.inputs(&matrices);
    register_common(&mut out, &a.illuminants, &[]);
    out.declare("--out", &a.out)?;
    if let Some(p) = &a.plot {
        out.declare("--plot", p)?;
    }
    let presets = match &a.out_dir {
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
    let s = setup(&a.common)?;
    let methods = methods_from_names(&a.methods, &s)?;
    let ills = load_illuminants(&a.illuminants, &s.xyz)?;
    if let (Some(_), Some(first_method)) = (&a.out_dir, methods.first()) {
        let space = RgbSpace::from_name(&a.rgb)?;
        for (m, target) in matrices.iter().zip(&presets) {
            let r = reduce_one(m, &s, first_method, &space, &ills, &a.illuminants, None)?;
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
    if let (Some(plot), Some((d, op))) = (&a.plot, &first) {
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
    let table = if a.json {
        serde_json::to_string(&rows)? + "\n"
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
    out.stage_text(&a.out, &table)?;
    out.commit()?;
    let mut t = format!(
        "{} materials × {} illuminants × {} methods{}{}\nsummary over materials: mean / max ΔE00\n",
        matrices.len(),
        ills.len(),
        methods.len(),
        if a.out.as_os_str() == "-" {
            String::new()
        } else {
            format!("; table → {}", a.out.display())
        },
        a.out_dir
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
    // The summary goes to standard error: standard output may carry the table.
    eprintln!("{}", t.trim_end());
    Ok(())
}

fn run_select(a: &SelectArgs) -> Result<()> {
    let mut out = Outputs::new();
    out.input(&a.matrix);
    register_common(&mut out, &a.illuminants, &[]);
    out.inputs(&a.extra_basis);
    out.declare("--out", &a.out)?;
    let s = setup(&a.common)?;
    let (d, _) = load_matrix(&a.matrix)?;
    let op = d.to_operator(&s.grid, s.options);
    let ills = load_illuminants(&a.illuminants, &s.xyz)?;
    let mut methods: Vec<Method> = BasisKind::ALL
        .iter()
        .map(|k| {
            Ok(Method {
                reduction: Reduction::Dual,
                basis: k.build(&s.cmfs, &s.grid)?,
            })
        })
        .collect::<Result<_>>()?;
    for p in &a.extra_basis {
        methods.push(Method {
            reduction: Reduction::Dual,
            basis: basis_from_arg(&p.to_string_lossy(), &s)?,
        });
    }
    let sel = select_basis(&op, &methods, &ills, &s.xyz, a.target_de)?;
    for c in &sel.candidates {
        ensure_finite(
            &format!("ΔE00 of {}", c.method),
            &a.matrix.display().to_string(),
            &[c.worst_delta_e00, c.mean_delta_e00],
        )?;
    }
    if a.json {
        let mut v = serde_json::to_value(&sel)?;
        if let Value::Object(o) = &mut v {
            o.insert("material".into(), json!(d.name()));
            o.insert(
                "chosen_method".into(),
                json!(sel.chosen.map(|i| sel.candidates[i].method.clone())),
            );
        }
        out.stage_text(&a.out, &(serde_json::to_string_pretty(&v)? + "\n"))?;
        out.commit()?;
        return Ok(());
    }
    let mut t = format!(
        "{}: illuminants {}; target worst ΔE00 < {}\n",
        d.name(),
        a.illuminants.join(","),
        a.target_de
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
                a.target_de, b.method, b.k, b.worst_delta_e00, b.worst_illuminant
            ))
        }
    }
    t.push('\n');
    out.stage_text(&a.out, &t)?;
    out.commit()?;
    Ok(())
}

fn run_sweep(a: &SweepArgs) -> Result<()> {
    let mut out = Outputs::new();
    out.input(&a.matrix);
    out.declare("--out", &a.out)?;
    let s = setup(&a.common)?;
    let (d, _) = load_matrix(&a.matrix)?;
    let op = d.to_operator(&s.grid, s.options);
    let methods = methods_from_names(&a.methods, &s)?;
    let rows: Vec<SweepRow> = sweep(&op, &methods, &s.xyz, a.every)?;
    for r in &rows {
        let values = [
            &r.xyz_reference[..],
            &r.xyz_reduced,
            &[r.y_reradiated_reference],
        ]
        .concat();
        ensure_finite(
            &format!("the sweep at {} nm ({})", r.excitation_nm, r.method),
            &a.matrix.display().to_string(),
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
    out.stage_text(&a.out, &t)?;
    out.commit()?;
    Ok(())
}
