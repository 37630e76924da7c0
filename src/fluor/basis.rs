//! Transport bases for reduced fluorescence (Fichet et al. 2024, §4 and Appendix A).
//!
//! A basis is the `N × K` matrix `S` of sensitivity functions sampled on the working grid, plus
//! the `3 × K` transfer matrix `T` that maps a colour in the basis to CIE XYZ. Built-in bases:
//!
//! * **XYZ**: the observer's CMFs (`T = I₃`).
//! * **XYZ+U**: XYZ plus `U`, the first element of a clamped degree-2 B-spline partition of unity
//!   of 5 elements over 300–800 nm (knots `300,300,300,550,675,800,800,800`), i.e.
//!   `U(λ) = ((550 − λ)/250)²` below 550 nm and 0 above; scaled so that `Σ U = Σ ȳ` on the grid,
//!   the normalisation of the authors' `xyzu.csv` (`T = [I₃ 0]`). The authors' table puts the
//!   knot at 550.5 nm (√U is linear with its root there); load it as a basis CSV to use it as is.
//! * **7 bases** (Appendix A): `x̄₁ = x̄(1−𝒮(500,2))`, `x̄₂ = x̄𝒮(500,2)𝒮(590,60)`,
//!   `x̄₃ = x̄𝒮(500,2)(1−𝒮(590,60))`, `ȳ₁ = ȳ𝒮(570,60)`, `ȳ₂ = ȳ(1−𝒮(570,60))`, `z̄`, `U`, with
//!   the smoothstep `𝒮(λ; μ, σ) = 3t² − 2t³`, `t = clip(½((λ−μ)/σ + 1), 0, 1)`; `T` is Eq. 22
//!   without its U row (3 × 7).
//! * **from a table** (any basis CSV `wavelength_nm,f1,…,fK`): `T = S_xyzᵀ S̃`, the least-squares
//!   map (exact when the CMFs lie in the span of the basis; [`Basis::transfer_residual`] says how
//!   far they are).
//!
//! Sampling: CMFs and tabulated bases are interpolated linearly onto the grid and are **zero
//! outside their tabulated range** (constant extrapolation would invent sensitivity in the UV).

use nalgebra::DMatrix;

use crate::error::{Error, Result};
use crate::fluor::donaldson::{interp_zero, WorkingGrid};
use crate::spectrum::MultiSpectrum;

/// A transport basis on a working grid.
#[derive(Debug, Clone, PartialEq)]
pub struct Basis {
    name: String,
    labels: Vec<String>,
    grid: WorkingGrid,
    s: DMatrix<f64>,
    t: DMatrix<f64>,
    transfer_residual: f64,
}

/// The smoothstep 𝒮(λ; μ, σ) of Appendix A.
pub fn smoothstep(lambda_nm: f64, mu_nm: f64, sigma_nm: f64) -> f64 {
    let t = (0.5 * ((lambda_nm - mu_nm) / sigma_nm + 1.0)).clamp(0.0, 1.0);
    3.0 * t * t - 2.0 * t * t * t
}

/// Knots of the clamped degree-2 B-spline partition of unity of 5 elements over 300–800 nm.
pub const U_KNOTS_NM: [f64; 8] = [300.0, 300.0, 300.0, 550.0, 675.0, 800.0, 800.0, 800.0];

/// Cox–de Boor: B-spline basis function `i` of degree `p` on `knots` at `x` (right-closed at the
/// last knot so the partition of unity holds on the whole closed interval).
pub fn bspline_basis(knots: &[f64], i: usize, p: usize, x: f64) -> f64 {
    let last = knots[knots.len() - 1];
    if p == 0 {
        let (a, b) = (knots[i], knots[i + 1]);
        let inside = (a <= x && x < b) || (x == last && b == last && a < b);
        return if inside { 1.0 } else { 0.0 };
    }
    let mut v = 0.0;
    let d1 = knots[i + p] - knots[i];
    if d1 > 0.0 {
        v += (x - knots[i]) / d1 * bspline_basis(knots, i, p - 1, x);
    }
    let d2 = knots[i + p + 1] - knots[i + 1];
    if d2 > 0.0 {
        v += (knots[i + p + 1] - x) / d2 * bspline_basis(knots, i + 1, p - 1, x);
    }
    v
}

fn cmfs_on_grid(cmfs: &MultiSpectrum, grid: &WorkingGrid) -> Result<[Vec<f64>; 3]> {
    if cmfs.n_channels() != 3 {
        return Err(Error::ShapeMismatch {
            what: format!("colour-matching functions '{}'", cmfs.name()),
            expected: 3,
            got: cmfs.n_channels(),
        });
    }
    let wl = grid.wavelengths();
    let w = cmfs.wavelengths();
    Ok([
        interp_zero(w, cmfs.channel(0), &wl),
        interp_zero(w, cmfs.channel(1), &wl),
        interp_zero(w, cmfs.channel(2), &wl),
    ])
}

impl Basis {
    /// A basis from its functions (`functions[k]` sampled on `grid`) and transfer matrix.
    pub fn new(
        name: impl Into<String>,
        labels: Vec<String>,
        grid: WorkingGrid,
        functions: Vec<Vec<f64>>,
        t: DMatrix<f64>,
    ) -> Result<Basis> {
        let name = name.into();
        let k = functions.len();
        if k == 0 || labels.len() != k {
            return Err(Error::ShapeMismatch {
                what: format!("labels of basis '{name}'"),
                expected: k,
                got: labels.len(),
            });
        }
        let n = grid.len();
        for (j, f) in functions.iter().enumerate() {
            if f.len() != n {
                return Err(Error::ShapeMismatch {
                    what: format!("basis function '{}' of '{name}'", labels[j]),
                    expected: n,
                    got: f.len(),
                });
            }
            if f.iter().any(|v| !v.is_finite()) {
                return Err(Error::invalid(
                    "basis",
                    format!("'{name}': function '{}' has a non-finite value", labels[j]),
                ));
            }
        }
        if t.nrows() != 3 || t.ncols() != k {
            return Err(Error::ShapeMismatch {
                what: format!("columns of the transfer matrix T of basis '{name}'"),
                expected: k,
                got: t.ncols(),
            });
        }
        let s = DMatrix::from_fn(n, k, |i, j| functions[j][i]);
        Ok(Basis {
            name,
            labels,
            grid,
            s,
            t,
            transfer_residual: 0.0,
        })
    }

    /// The observer's XYZ CMFs (`cmfs`: x̄, ȳ, z̄).
    pub fn xyz(cmfs: &MultiSpectrum, grid: &WorkingGrid) -> Result<Basis> {
        let [x, y, z] = cmfs_on_grid(cmfs, grid)?;
        Basis::new(
            "xyz",
            vec!["X".into(), "Y".into(), "Z".into()],
            *grid,
            vec![x, y, z],
            DMatrix::identity(3, 3),
        )
    }

    /// The UV function U on `grid`, normalised to `Σ U = Σ ȳ` (see the module docs).
    pub fn u_function(y_bar: &[f64], grid: &WorkingGrid) -> Vec<f64> {
        let raw: Vec<f64> = grid
            .wavelengths()
            .iter()
            .map(|&l| {
                if (U_KNOTS_NM[0]..=U_KNOTS_NM[7]).contains(&l) {
                    bspline_basis(&U_KNOTS_NM, 0, 2, l)
                } else {
                    0.0
                }
            })
            .collect();
        let (su, sy): (f64, f64) = (raw.iter().sum(), y_bar.iter().sum());
        let c = if su > 0.0 { sy / su } else { 1.0 };
        raw.iter().map(|v| v * c).collect()
    }

    /// XYZ + U (Fichet 2024 §4.2).
    pub fn xyzu(cmfs: &MultiSpectrum, grid: &WorkingGrid) -> Result<Basis> {
        let [x, y, z] = cmfs_on_grid(cmfs, grid)?;
        let u = Basis::u_function(&y, grid);
        let t = DMatrix::from_row_slice(3, 4, &[1., 0., 0., 0., 0., 1., 0., 0., 0., 0., 1., 0.]);
        Basis::new(
            "xyzu",
            vec!["X".into(), "Y".into(), "Z".into(), "U".into()],
            *grid,
            vec![x, y, z, u],
            t,
        )
    }

    /// The 7-basis split of Appendix A (X in three, Y in two, Z, U).
    pub fn xyz7u(cmfs: &MultiSpectrum, grid: &WorkingGrid) -> Result<Basis> {
        let [x, y, z] = cmfs_on_grid(cmfs, grid)?;
        let u = Basis::u_function(&y, grid);
        let wl = grid.wavelengths();
        let s500: Vec<f64> = wl.iter().map(|&l| smoothstep(l, 500.0, 2.0)).collect();
        let s590: Vec<f64> = wl.iter().map(|&l| smoothstep(l, 590.0, 60.0)).collect();
        let s570: Vec<f64> = wl.iter().map(|&l| smoothstep(l, 570.0, 60.0)).collect();
        let n = wl.len();
        let x1: Vec<f64> = (0..n).map(|i| x[i] * (1.0 - s500[i])).collect();
        let x2: Vec<f64> = (0..n).map(|i| x[i] * s500[i] * s590[i]).collect();
        let x3: Vec<f64> = (0..n).map(|i| x[i] * s500[i] * (1.0 - s590[i])).collect();
        let y1: Vec<f64> = (0..n).map(|i| y[i] * s570[i]).collect();
        let y2: Vec<f64> = (0..n).map(|i| y[i] * (1.0 - s570[i])).collect();
        #[rustfmt::skip]
        let t = DMatrix::from_row_slice(3, 7, &[
            1., 1., 1., 0., 0., 0., 0.,
            0., 0., 0., 1., 1., 0., 0.,
            0., 0., 0., 0., 0., 1., 0.,
        ]);
        let labels = ["X1", "X2", "X3", "Y1", "Y2", "Z", "U"]
            .map(String::from)
            .to_vec();
        Basis::new("xyz7u", labels, *grid, vec![x1, x2, x3, y1, y2, z, u], t)
    }

    /// Any basis from a table (`table`: wavelength, then one column per function), with
    /// `T = S_xyzᵀ S̃` computed from the observer's CMFs.
    pub fn from_table(
        name: impl Into<String>,
        table: &MultiSpectrum,
        cmfs: &MultiSpectrum,
        grid: &WorkingGrid,
    ) -> Result<Basis> {
        let name = name.into();
        let wl = grid.wavelengths();
        let functions: Vec<Vec<f64>> = (0..table.n_channels())
            .map(|c| interp_zero(table.wavelengths(), table.channel(c), &wl))
            .collect();
        for (c, f) in functions.iter().enumerate() {
            if f.iter().all(|v| *v == 0.0) {
                return Err(Error::invalid(
                    "basis",
                    format!(
                        "'{name}': function '{}' is zero on the working grid {}–{} nm",
                        table.labels()[c],
                        grid.start_nm,
                        grid.end_nm
                    ),
                ));
            }
        }
        let k = functions.len();
        let mut b = Basis::new(
            name,
            table.labels().to_vec(),
            *grid,
            functions,
            DMatrix::zeros(3, k),
        )?;
        let xyz = Basis::xyz(cmfs, grid)?;
        let dual = b.dual()?;
        let t = xyz.s.transpose() * &dual;
        let fit = &b.s * t.transpose();
        let norm = xyz.s.norm();
        b.transfer_residual = if norm > 0.0 {
            (&xyz.s - fit).norm() / norm
        } else {
            0.0
        };
        b.t = t;
        Ok(b)
    }

    /// Name (`xyz`, `xyzu`, `xyz7u`, or the file's).
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Renamed copy.
    pub fn with_name(mut self, name: impl Into<String>) -> Self {
        self.name = name.into();
        self
    }

    /// Labels of the K functions.
    pub fn labels(&self) -> &[String] {
        &self.labels
    }

    /// K, the number of functions.
    pub fn k(&self) -> usize {
        self.s.ncols()
    }

    /// The working grid.
    pub fn grid(&self) -> &WorkingGrid {
        &self.grid
    }

    /// `S`, `N × K`.
    pub fn functions(&self) -> &DMatrix<f64> {
        &self.s
    }

    /// `T`, `3 × K`: basis colour → XYZ.
    pub fn transfer(&self) -> &DMatrix<f64> {
        &self.t
    }

    /// ‖S_xyz − S Tᵀ‖_F / ‖S_xyz‖_F: 0 when XYZ is exactly a combination of the basis.
    pub fn transfer_residual(&self) -> f64 {
        self.transfer_residual
    }

    /// The dual basis `S̃ = S (SᵀS)⁻¹` (`N × K`), so that `Sᵀ S̃ = I_K`.
    ///
    /// (The paper's footnote to Eq. 11 writes `(SSᵀ)⁻¹S`; with `S` of shape `N × K` the product
    /// that gives `SᵀS̃ = I` is this one.)
    pub fn dual(&self) -> Result<DMatrix<f64>> {
        let gram = self.s.transpose() * &self.s;
        let chol = nalgebra::linalg::Cholesky::new(gram.clone()).ok_or_else(|| Error::Numerical {
            what: format!("dual of basis '{}'", self.name),
            reason: "SᵀS is singular: the basis functions are linearly dependent (or one is zero) on the working grid".into(),
        })?;
        let inv = chol.inverse();
        Ok(&self.s * inv)
    }

    /// Whether `other` is sampled on the same grid.
    pub fn same_grid(&self, grid: &WorkingGrid) -> bool {
        self.grid == *grid
    }
}
