//! Evaluation of reduced matrices against the spectral reference (Fichet et al. 2024, §5.2,
//! Table 1), the monochromatic sweep, and basis selection.
//!
//! One bounce under an illuminant `e` (sampled on the working grid, step `h`):
//!
//! * reference: `XYZ_ref = k · h · S_xyzᵀ · A · e`;
//! * reduced: `XYZ_red = k · T · P · (h · Sᵀ e)`, i.e. `T · P · down[e]`;
//! * `k = 100 / (h · Σ ȳ e)`, so the illuminant's white has `Y = 100`;
//! * L\*a\*b\* of both relative to the white `XYZ_w = k · h · S_xyzᵀ e` (its xy, `Y_w = 100`),
//!   and CIEDE2000 (`k_L = k_C = k_H = 1`) between them.
//!
//! The illuminant is resampled with its own interpolator (linear for CIE illuminants) inside its
//! range and is zero outside it. It must cover the range where the observer's CMFs are non-zero
//! on the working grid (390–780 nm for CIE 2006 on the default grid); it may stop short of the
//! UV end of an extended basis (FL1, FL2 and HP5 start at 380 nm): it is then taken as zero there.

use nalgebra::{DMatrix, DVector};

use crate::colorimetry::delta_e::{delta_e, DeltaEMethod};
use crate::colorimetry::lab::xyz_to_lab;
use crate::colorimetry::xyy::xyz_to_xy;
use crate::colorimetry::Illuminant;
use crate::error::{Error, Result};
use crate::fluor::basis::Basis;
use crate::fluor::donaldson::{OperatorMatrix, WorkingGrid};
use crate::fluor::reduce::{reduce, Reduced, Reduction};

/// Built-in basis kinds, by number of functions.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum BasisKind {
    /// XYZ (K = 3).
    Xyz,
    /// XYZ + U (K = 4).
    Xyzu,
    /// Appendix A split with U (K = 7).
    Xyz7u,
}

impl BasisKind {
    /// All, smallest first.
    pub const ALL: [BasisKind; 3] = [BasisKind::Xyz, BasisKind::Xyzu, BasisKind::Xyz7u];

    /// `xyz`, `xyzu`, `xyz7u`.
    pub fn key(self) -> &'static str {
        match self {
            BasisKind::Xyz => "xyz",
            BasisKind::Xyzu => "xyzu",
            BasisKind::Xyz7u => "xyz7u",
        }
    }

    /// Parses a key (case-insensitive; `xyz+u`, `7` accepted).
    pub fn from_name(name: &str) -> Result<BasisKind> {
        match name.trim().to_ascii_lowercase().as_str() {
            "xyz" => Ok(BasisKind::Xyz),
            "xyzu" | "xyz+u" => Ok(BasisKind::Xyzu),
            "xyz7u" | "xyz7" | "7" => Ok(BasisKind::Xyz7u),
            _ => Err(Error::UnknownName {
                kind: "basis",
                name: name.into(),
                expected: "xyz, xyzu, xyz7u, or a basis CSV file".into(),
            }),
        }
    }

    /// Builds the basis from the observer's CMFs on `grid`.
    pub fn build(self, cmfs: &crate::spectrum::MultiSpectrum, grid: &WorkingGrid) -> Result<Basis> {
        match self {
            BasisKind::Xyz => Basis::xyz(cmfs, grid),
            BasisKind::Xyzu => Basis::xyzu(cmfs, grid),
            BasisKind::Xyz7u => Basis::xyz7u(cmfs, grid),
        }
    }
}

/// A method of the evaluation: a reduction in a basis, named `<reduction>-<basis>`.
#[derive(Debug, Clone, PartialEq)]
pub struct Method {
    /// Reduction.
    pub reduction: Reduction,
    /// Basis.
    pub basis: Basis,
}

impl Method {
    /// `dual-xyz`, `naive-xyzu`, …
    pub fn name(&self) -> String {
        format!("{}-{}", self.reduction.key(), self.basis.name())
    }

    /// Parses `<reduction>-<basis kind>` and builds the basis.
    pub fn from_name(
        name: &str,
        cmfs: &crate::spectrum::MultiSpectrum,
        grid: &WorkingGrid,
    ) -> Result<Method> {
        let (r, b) = name
            .trim()
            .split_once('-')
            .ok_or_else(|| Error::UnknownName {
                kind: "evaluation method",
                name: name.into(),
                expected: "<dual|naive>-<xyz|xyzu|xyz7u>, e.g. dual-xyz".into(),
            })?;
        Ok(Method {
            reduction: Reduction::from_name(r)?,
            basis: BasisKind::from_name(b)?.build(cmfs, grid)?,
        })
    }
}

/// The default methods of `fluor eval`.
pub const DEFAULT_METHODS: [&str; 5] = [
    "dual-xyz",
    "dual-xyzu",
    "naive-xyz",
    "naive-xyzu",
    "dual-xyz7u",
];

/// The default illuminants (Fichet 2024, Table 1).
pub const DEFAULT_ILLUMINANTS: [&str; 7] = ["A", "E", "D60", "D65", "FL1", "FL2", "HP5"];

/// An illuminant sampled on the working grid.
#[derive(Debug, Clone, PartialEq)]
pub struct GridIlluminant {
    /// Name.
    pub name: String,
    /// Relative spectral power on the grid (zero outside the illuminant's own range).
    pub values: Vec<f64>,
}

/// First and last grid wavelength where any function of `xyz` is non-zero.
pub fn cmf_support_nm(xyz: &Basis) -> (f64, f64) {
    let wl = xyz.grid().wavelengths();
    let s = xyz.functions();
    let nz: Vec<usize> = (0..wl.len())
        .filter(|&i| (0..s.ncols()).any(|k| s[(i, k)] != 0.0))
        .collect();
    match (nz.first(), nz.last()) {
        (Some(&a), Some(&b)) => (wl[a], wl[b]),
        _ => (wl[0], wl[wl.len() - 1]),
    }
}

/// Samples `illuminant` on the grid of `xyz`, checking that it covers the CMFs' support.
pub fn illuminant_on_grid(illuminant: &Illuminant, xyz: &Basis) -> Result<GridIlluminant> {
    let sd = illuminant.spectrum();
    let w = sd.wavelengths();
    let (lo, hi) = (w[0], w[w.len() - 1]);
    let (need_lo, need_hi) = cmf_support_nm(xyz);
    if lo > need_lo + 1e-9 || hi < need_hi - 1e-9 {
        return Err(Error::WavelengthOutOfRange {
            lambda_nm: if lo > need_lo + 1e-9 { need_lo } else { need_hi },
            start_nm: lo,
            end_nm: hi,
            what: format!(
                "illuminant '{}' (the evaluation needs {need_lo}–{need_hi} nm, where the CMFs are non-zero on the working grid)",
                illuminant.name()
            ),
        });
    }
    let wl = xyz.grid().wavelengths();
    let inside: Vec<f64> = wl
        .iter()
        .copied()
        .filter(|&l| l >= lo - 1e-9 && l <= hi + 1e-9)
        .collect();
    let vals = sd.values_at(&inside, illuminant.interpolator())?;
    let mut it = vals.into_iter();
    let values = wl
        .iter()
        .map(|&l| {
            if l >= lo - 1e-9 && l <= hi + 1e-9 {
                it.next().unwrap_or(0.0)
            } else {
                0.0
            }
        })
        .collect();
    Ok(GridIlluminant {
        name: illuminant.name().to_string(),
        values,
    })
}

/// One row of the evaluation table.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct EvalRow {
    /// Material name.
    pub material: String,
    /// Illuminant name.
    pub illuminant: String,
    /// Method name (`dual-xyz` …).
    pub method: String,
    /// CIEDE2000 between reference and reduced.
    pub delta_e00: f64,
    /// Spectral reference XYZ (white Y = 100).
    pub xyz_reference: [f64; 3],
    /// Reduced XYZ (white Y = 100).
    pub xyz_reduced: [f64; 3],
}

/// The precomputed spectral side of one (material, illuminant) pair.
#[derive(Debug, Clone)]
pub struct Reference {
    /// XYZ of the white (Y = 100).
    pub white_xyz: [f64; 3],
    /// xy of the white.
    pub white_xy: [f64; 2],
    /// Scale `k · h = 100 / Σ ȳ e` applied to the unweighted sums.
    pub scale: f64,
    /// Reference XYZ (white Y = 100).
    pub xyz: [f64; 3],
}

fn v3(v: &DVector<f64>) -> [f64; 3] {
    [v[0], v[1], v[2]]
}

/// Spectral reference of `a` under `e` with the CMFs of `xyz`.
pub fn spectral_reference(
    a: &OperatorMatrix,
    e: &GridIlluminant,
    xyz: &Basis,
) -> Result<Reference> {
    let ev = DVector::from_column_slice(&e.values);
    let w = xyz.functions().transpose() * &ev;
    if w[1].partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
        return Err(Error::invalid(
            "illuminant",
            format!(
                "'{}' has no power where ȳ is non-zero (Σ ȳ e = {})",
                e.name, w[1]
            ),
        ));
    }
    let scale = 100.0 / w[1];
    let out = &a.a * &ev;
    let xyz_ref = xyz.functions().transpose() * out * scale;
    let white = v3(&(w * scale));
    Ok(Reference {
        white_xyz: white,
        white_xy: xyz_to_xy(white, [0.3127, 0.3290]),
        scale,
        xyz: v3(&xyz_ref),
    })
}

/// Reduced XYZ of `reduced` (in `basis`) under `e`, on the scale of `reference`.
pub fn reduced_xyz(
    reduced: &Reduced,
    basis: &Basis,
    e: &GridIlluminant,
    reference: &Reference,
) -> [f64; 3] {
    let ev = DVector::from_column_slice(&e.values);
    let down = basis.functions().transpose() * ev;
    v3(&(&reduced.t * (&reduced.p * down) * reference.scale))
}

/// CIEDE2000 between two XYZ (white Y = 100) relative to the white `white_xy`.
pub fn delta_e00(xyz_a: [f64; 3], xyz_b: [f64; 3], white_xy: [f64; 2]) -> Result<f64> {
    let la = xyz_to_lab(xyz_a.map(|v| v / 100.0), white_xy)?;
    let lb = xyz_to_lab(xyz_b.map(|v| v / 100.0), white_xy)?;
    Ok(delta_e(la, lb, DeltaEMethod::Ciede2000))
}

/// Evaluates every method on `material` under every illuminant (rows: illuminant-major).
pub fn evaluate(
    material: &OperatorMatrix,
    methods: &[Method],
    illuminants: &[GridIlluminant],
    xyz: &Basis,
) -> Result<Vec<EvalRow>> {
    let reduced: Vec<Reduced> = methods
        .iter()
        .map(|m| reduce(material, &m.basis, m.reduction))
        .collect::<Result<_>>()?;
    let mut rows = Vec::with_capacity(methods.len() * illuminants.len());
    for e in illuminants {
        let r = spectral_reference(material, e, xyz)?;
        for (m, red) in methods.iter().zip(&reduced) {
            let xr = reduced_xyz(red, &m.basis, e, &r);
            rows.push(EvalRow {
                material: material.name.clone(),
                illuminant: e.name.clone(),
                method: m.name(),
                delta_e00: delta_e00(r.xyz, xr, r.white_xy)?,
                xyz_reference: r.xyz,
                xyz_reduced: xr,
            });
        }
    }
    Ok(rows)
}

/// One sample of the monochromatic sweep.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct SweepRow {
    /// Excitation wavelength (nm).
    pub excitation_nm: f64,
    /// Method name.
    pub method: String,
    /// Reference XYZ for unit spectral irradiance at the excitation sample.
    pub xyz_reference: [f64; 3],
    /// Reduced XYZ for the same.
    pub xyz_reduced: [f64; 3],
    /// The re-radiated (off-diagonal) part of the reference Y.
    pub y_reradiated_reference: f64,
}

/// Monochromatic sweep: for each grid sample `j` (every `every` samples), the one-bounce XYZ of a
/// unit impulse of excitation there, reference against reduced. Shows where a basis loses the
/// re-radiation (e.g. UV excitation outside the span of XYZ).
pub fn sweep(
    material: &OperatorMatrix,
    methods: &[Method],
    xyz: &Basis,
    every: usize,
) -> Result<Vec<SweepRow>> {
    let reduced: Vec<Reduced> = methods
        .iter()
        .map(|m| reduce(material, &m.basis, m.reduction))
        .collect::<Result<_>>()?;
    let h = xyz.grid().step_nm;
    let wl = xyz.grid().wavelengths();
    let sx = xyz.functions();
    let mut off = material.a.clone();
    off.fill_diagonal(0.0);
    let ref_all = sx.transpose() * &material.a * h; // 3 × N
    let ref_off = sx.transpose() * &off * h;
    let mut rows = Vec::new();
    for j in (0..wl.len()).step_by(every.max(1)) {
        for (m, red) in methods.iter().zip(&reduced) {
            let down: DVector<f64> = m.basis.functions().row(j).transpose() * h;
            let xr = &red.t * (&red.p * down);
            rows.push(SweepRow {
                excitation_nm: wl[j],
                method: m.name(),
                xyz_reference: [ref_all[(0, j)], ref_all[(1, j)], ref_all[(2, j)]],
                xyz_reduced: v3(&xr),
                y_reradiated_reference: ref_off[(1, j)],
            });
        }
    }
    Ok(rows)
}

/// One candidate's result in [`select_basis`].
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Candidate {
    /// Method name.
    pub method: String,
    /// Number of basis functions.
    pub k: usize,
    /// Worst ΔE00 over the scene's illuminants.
    pub worst_delta_e00: f64,
    /// Mean ΔE00 over the scene's illuminants.
    pub mean_delta_e00: f64,
    /// The illuminant that gave the worst ΔE00.
    pub worst_illuminant: String,
}

/// The outcome of [`select_basis`].
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Selection {
    /// Target worst ΔE00.
    pub target_delta_e00: f64,
    /// Index into `candidates` of the smallest basis meeting the target, if any.
    pub chosen: Option<usize>,
    /// Index of the candidate with the lowest worst ΔE00 (the best reachable).
    pub best: usize,
    /// Every candidate, in the order tried (smallest K first).
    pub candidates: Vec<Candidate>,
}

/// "Model only what a scene needs": the smallest-K method (dual reduction) whose worst ΔE00 over
/// the scene's illuminants is below `target`; otherwise the best reachable.
pub fn select_basis(
    material: &OperatorMatrix,
    methods: &[Method],
    illuminants: &[GridIlluminant],
    xyz: &Basis,
    target: f64,
) -> Result<Selection> {
    if methods.is_empty() || illuminants.is_empty() {
        return Err(Error::invalid(
            "basis selection",
            "needs at least one candidate basis and one illuminant",
        ));
    }
    if !(target.is_finite() && target > 0.0) {
        return Err(Error::invalid(
            "target ΔE00",
            format!("{target}; expected a positive number"),
        ));
    }
    let mut order: Vec<usize> = (0..methods.len()).collect();
    order.sort_by_key(|&i| methods[i].basis.k());
    let mut candidates = Vec::new();
    for &i in &order {
        let rows = evaluate(
            material,
            std::slice::from_ref(&methods[i]),
            illuminants,
            xyz,
        )?;
        let (mut worst, mut worst_ill, mut sum) = (f64::NEG_INFINITY, String::new(), 0.0);
        for r in &rows {
            sum += r.delta_e00;
            if r.delta_e00 > worst {
                worst = r.delta_e00;
                worst_ill = r.illuminant.clone();
            }
        }
        candidates.push(Candidate {
            method: methods[i].name(),
            k: methods[i].basis.k(),
            worst_delta_e00: worst,
            mean_delta_e00: sum / rows.len() as f64,
            worst_illuminant: worst_ill,
        });
    }
    let chosen = candidates.iter().position(|c| c.worst_delta_e00 < target);
    let best = (0..candidates.len())
        .min_by(|&a, &b| {
            candidates[a]
                .worst_delta_e00
                .total_cmp(&candidates[b].worst_delta_e00)
        })
        .unwrap_or(0);
    Ok(Selection {
        target_delta_e00: target,
        chosen,
        best,
        candidates,
    })
}

/// Mean and max ΔE00 per (illuminant, method) over materials: `(illuminant, method, mean, max, n)`.
pub fn summarise(rows: &[EvalRow]) -> Vec<(String, String, f64, f64, usize)> {
    let mut keys: Vec<(String, String)> = Vec::new();
    for r in rows {
        let k = (r.illuminant.clone(), r.method.clone());
        if !keys.contains(&k) {
            keys.push(k);
        }
    }
    keys.into_iter()
        .map(|(ill, m)| {
            let v: Vec<f64> = rows
                .iter()
                .filter(|r| r.illuminant == ill && r.method == m)
                .map(|r| r.delta_e00)
                .collect();
            let mean = v.iter().sum::<f64>() / v.len() as f64;
            let max = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            (ill, m, mean, max, v.len())
        })
        .collect()
}

/// `Sᵀ S̃` for a basis (should be `I_K`); exposed for tests and diagnostics.
pub fn dual_check(basis: &Basis) -> Result<DMatrix<f64>> {
    Ok(basis.functions().transpose() * basis.dual()?)
}
