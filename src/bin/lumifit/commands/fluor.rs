//! `lumifit fluor …` (fluorescence): Donaldson-matrix reduction (Fichet et al. 2024), its
//! evaluation against the spectral reference, basis selection and presets.

use std::path::{Path, PathBuf};

use anyhow::Result;
use clap::{Args, Subcommand};
use lumifit::colorimetry::rgb::RgbSpace;
use lumifit::colorimetry::{Observer, StandardObserver};
use lumifit::fluor::evaluate::{summarise, sweep, SweepRow};
use lumifit::fluor::{
    evaluate, illuminant_on_grid, parse_donaldson, reduce, rgb_matrix, select_basis, xyz_matrix,
    Basis, BasisKind, DonaldsonMatrix, EvalRow, GridIlluminant, Method, OperatorMatrix, Reduction,
    ResampleOptions, WorkingGrid, DEFAULT_ILLUMINANTS, DEFAULT_METHODS,
};
use lumifit::io::sources::file_of;
use lumifit::io::{read_input, spectrum_csv::read_multi_spectrum, Outputs};
use lumifit::plot::{fluor_chart_png, FluorChart};
use lumifit::preset::fluorescence::{fluorescence_section, ReductionRecord};
use lumifit::preset::{to_json_string, MaterialPreset, Provenance};
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
pub struct ReduceArgs {
    /// Donaldson matrix: BFC-450 file or CSV (header `emission_nm,<excitation nm>…`).
    pub matrix: PathBuf,
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
    /// Output material preset (JSON).
    #[arg(long)]
    pub out: PathBuf,
    /// Also write a PNG of the Donaldson matrix, the reduced matrix and ΔE00 per illuminant.
    #[arg(long)]
    pub plot: Option<PathBuf>,
    #[command(flatten)]
    pub common: CommonArgs,
}

#[derive(Debug, Args)]
pub struct EvalArgs {
    /// Donaldson matrices (BFC-450 or CSV).
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
    match BasisKind::from_name(arg) {
        Ok(kind) => Ok(kind.build(&s.cmfs, &s.grid)?),
        Err(e) => {
            let p = Path::new(arg);
            if !(p.is_file() || arg.to_ascii_lowercase().ends_with(".csv")) {
                return Err(e.into());
            }
            let table = read_multi_spectrum(p)?;
            let name = p
                .file_stem()
                .map(|x| x.to_string_lossy().into_owned())
                .unwrap_or_else(|| arg.to_string());
            let b = Basis::from_table(name, &table, &s.cmfs, &s.grid)?;
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
    }
}

fn methods_from_names(names: &[String], s: &Setup) -> Result<Vec<Method>> {
    names
        .iter()
        .map(|n| Ok(Method::from_name(n, &s.cmfs, &s.grid)?))
        .collect()
}

fn rows_of(m: &nalgebra::DMatrix<f64>) -> Vec<Vec<f64>> {
    (0..m.nrows())
        .map(|r| (0..m.ncols()).map(|c| m[(r, c)]).collect())
        .collect()
}

fn chart_for(
    d: &DonaldsonMatrix,
    reduced: Vec<(String, Vec<String>, nalgebra::DMatrix<f64>)>,
    rows: &[EvalRow],
) -> FluorChart {
    let summary = summarise(rows);
    FluorChart {
        title: d.name().to_string(),
        emission_nm: d.emission_nm().to_vec(),
        excitation_nm: d.excitation_nm().to_vec(),
        donaldson: rows_of(d.values()),
        reduced: reduced
            .into_iter()
            .map(|(n, l, m)| (n, l, rows_of(&m)))
            .collect(),
        delta_e: summary
            .into_iter()
            .map(|(i, m, mean, _, _)| (i, m, mean))
            .collect(),
    }
}

/// Registers the illuminant files and a basis file as inputs.
fn register_common(out: &mut Outputs, illuminants: &[String], bases: &[&str]) {
    out.inputs(illuminants.iter().filter_map(|n| file_of(n)));
    out.inputs(bases.iter().filter_map(|n| file_of(n)));
}

fn run_reduce(a: &ReduceArgs) -> Result<()> {
    let mut out = Outputs::new();
    out.input(&a.matrix);
    register_common(&mut out, &a.illuminants, &[&a.basis]);
    out.declare("--out", &a.out)?;
    if let Some(p) = &a.plot {
        out.declare("--plot", p)?;
    }
    let s = setup(&a.common)?;
    let (d, bytes) = load_matrix(&a.matrix)?;
    let op = d.to_operator(&s.grid, s.options);
    let basis = basis_from_arg(&a.basis, &s)?;
    let reduction = Reduction::from_name(&a.method)?;
    let space = RgbSpace::from_name(&a.rgb)?;
    let red = reduce(&op, &basis, reduction)?;
    let p3 = xyz_matrix(&red, &basis, &s.xyz)?;
    let p_rgb = rgb_matrix(&p3, &space);
    let ills = load_illuminants(&a.illuminants, &s.xyz)?;
    let method = Method {
        reduction,
        basis: basis.clone(),
    };
    let rows = evaluate(&op, std::slice::from_ref(&method), &ills, &s.xyz)?;
    let section = fluorescence_section(
        &ReductionRecord {
            reduced: &red,
            basis: &basis,
            observer: &s.observer,
            grid: &s.grid,
            xyz_matrix: &p3,
            rgb_matrix: &p_rgb,
            space: &space,
            options: s.options,
            rows: &rows,
        },
        &a.matrix.display().to_string(),
    )?;
    let worst = section.worst_delta_e00;

    let mut inputs: Vec<(PathBuf, Vec<u8>)> = vec![(a.matrix.clone(), bytes)];
    if let Some(bp) = file_of(&a.basis) {
        let (b, _) = read_input(&bp)?;
        inputs.push((bp, b));
    }
    let refs: Vec<(&Path, &[u8])> = inputs
        .iter()
        .map(|(p, b)| (p.as_path(), b.as_slice()))
        .collect();
    let command = std::env::args().collect::<Vec<_>>().join(" ");
    let prov = Provenance::new(&command, &refs)
        .with_fit_quality(json!({"worst_delta_e00": worst, "illuminants": a.illuminants}));
    let mut preset = MaterialPreset::new(d.name(), prov);
    preset.description = Some(format!(
        "Fluorescent material '{}' reduced to the {} basis ({} reduction)",
        d.name(),
        basis.name(),
        reduction.key()
    ));
    preset.fluorescence = Some(section);
    // Validated as a reader would before it is staged.
    out.stage(&a.out, to_json_string(&preset)?.as_bytes())?;
    if let Some(plot) = &a.plot {
        let chart = chart_for(
            &d,
            vec![(method.name(), basis.labels().to_vec(), red.p.clone())],
            &rows,
        );
        out.stage(plot, &fluor_chart_png(&chart)?)?;
    }
    out.commit()?;
    let mut text = format!(
        "{}: {} ({}×{}), worst ΔE00 {:.3}\n",
        d.name(),
        method.name(),
        basis.k(),
        basis.k(),
        worst
    );
    for r in &rows {
        text.push_str(&format!(
            "  {:<8} ΔE00 {:>7.3}\n",
            r.illuminant, r.delta_e00
        ));
    }
    text.push_str(&format!("wrote {}", a.out.display()));
    emit(&text)
}

fn run_eval(a: &EvalArgs) -> Result<()> {
    let mut out = Outputs::new();
    out.inputs(&a.matrices);
    register_common(&mut out, &a.illuminants, &[]);
    if let Some(p) = &a.plot {
        out.declare("--plot", p)?;
    }
    let s = setup(&a.common)?;
    let methods = methods_from_names(&a.methods, &s)?;
    let ills = load_illuminants(&a.illuminants, &s.xyz)?;
    let mut rows = Vec::new();
    let mut first: Option<(DonaldsonMatrix, OperatorMatrix)> = None;
    for p in &a.matrices {
        let (d, _) = load_matrix(p)?;
        let op = d.to_operator(&s.grid, s.options);
        rows.extend(evaluate(&op, &methods, &ills, &s.xyz)?);
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
        let mut chart = chart_for(d, reduced, &rows);
        if a.matrices.len() > 1 {
            chart.title = format!(
                "{} (ΔE00: mean of {} materials)",
                d.name(),
                a.matrices.len()
            );
        }
        out.stage(plot, &fluor_chart_png(&chart)?)?;
    }
    out.commit()?;
    if a.json {
        return emit(&serde_json::to_string(&rows)?);
    }
    let mut t = String::from("material,illuminant,method,delta_e00\n");
    for r in &rows {
        t.push_str(&format!(
            "{},{},{},{:.4}\n",
            r.material, r.illuminant, r.method, r.delta_e00
        ));
    }
    t.push_str("\nsummary over materials: mean / max ΔE00\n");
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
    emit(t.trim_end())
}

fn run_select(a: &SelectArgs) -> Result<()> {
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
    if a.json {
        let mut v = serde_json::to_value(&sel)?;
        if let Value::Object(o) = &mut v {
            o.insert("material".into(), json!(d.name()));
            o.insert(
                "chosen_method".into(),
                json!(sel.chosen.map(|i| sel.candidates[i].method.clone())),
            );
        }
        return emit(&serde_json::to_string_pretty(&v)?);
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
    emit(&t)
}

fn run_sweep(a: &SweepArgs) -> Result<()> {
    let s = setup(&a.common)?;
    let (d, _) = load_matrix(&a.matrix)?;
    let op = d.to_operator(&s.grid, s.options);
    let methods = methods_from_names(&a.methods, &s)?;
    let rows: Vec<SweepRow> = sweep(&op, &methods, &s.xyz, a.every)?;
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
    emit(t.trim_end())
}
