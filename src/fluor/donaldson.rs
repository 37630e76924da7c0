//! Donaldson (bispectral) matrices: reading, writing and resampling to a working grid.
//!
//! Orientation: `D[emission, excitation]` — one row per emission wavelength, one column per
//! excitation wavelength, as in the Labsphere BFC-450 file. The entry where excitation equals
//! emission is the ordinary reflectance factor (dimensionless); every other entry is the
//! bispectral luminescent radiance factor *per excitation band* of the file's excitation step
//! (10 nm for BFC-450 files).
//!
//! [`DonaldsonMatrix::to_operator`] turns the measured matrix into an [`OperatorMatrix`] `A` on a
//! uniform square working grid (step `h`), so that the one-bounce output spectrum is `A · e` for
//! an irradiance `e` sampled on the grid:
//!
//! * negatives (measurement noise) are clipped to zero first (option, on by default);
//! * the diagonal is interpolated **as a reflectance**: piecewise linear in wavelength over the
//!   emission wavelengths that have an excitation column, zero outside;
//! * the off-diagonal part (diagonal cells set to zero) is interpolated **as a density**: divided
//!   by the native excitation step, bilinearly interpolated (zero outside the measured grid) and
//!   multiplied by `h` — i.e. rescaled by the ratio of grid steps `h / Δλ_native`;
//! * optionally, anti-Stokes entries (off the diagonal with excitation ≥ emission, physically
//!   impossible for fluorescence and in measured data only noise) are zeroed, both on the native
//!   grid and on the working grid after interpolation.

use nalgebra::DMatrix;

use crate::error::{Error, Result};
use crate::math::interpolation::is_uniform;

/// Tolerance (nm) when matching an excitation wavelength to an emission wavelength.
const WL_MATCH_NM: f64 = 1e-6;

/// A measured Donaldson matrix on its native grids.
#[derive(Debug, Clone, PartialEq)]
pub struct DonaldsonMatrix {
    name: String,
    emission_nm: Vec<f64>,
    excitation_nm: Vec<f64>,
    /// Rows: emission; columns: excitation.
    values: DMatrix<f64>,
}

/// How a measured matrix is turned into an operator on the working grid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ResampleOptions {
    /// Clip negative entries (measurement noise) to zero before interpolating. Default true.
    pub clip_negatives: bool,
    /// Zero off-diagonal entries with excitation ≥ emission (anti-Stokes). Default false.
    pub zero_anti_stokes: bool,
}

impl Default for ResampleOptions {
    fn default() -> Self {
        ResampleOptions {
            clip_negatives: true,
            zero_anti_stokes: false,
        }
    }
}

/// A uniform working grid `start_nm, start_nm + step_nm, …, end_nm`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WorkingGrid {
    /// First wavelength (nm).
    pub start_nm: f64,
    /// Last wavelength (nm).
    pub end_nm: f64,
    /// Step (nm).
    pub step_nm: f64,
}

impl Default for WorkingGrid {
    /// 300–780 nm at 1 nm: the BFC-450 excitation range at the CMFs' sampling.
    fn default() -> Self {
        WorkingGrid {
            start_nm: 300.0,
            end_nm: 780.0,
            step_nm: 1.0,
        }
    }
}

impl WorkingGrid {
    /// A validated grid; `end - start` must be a whole number of steps.
    pub fn new(start_nm: f64, end_nm: f64, step_nm: f64) -> Result<WorkingGrid> {
        let ok = start_nm.is_finite() && end_nm.is_finite() && step_nm.is_finite() && step_nm > 0.0;
        if !ok || end_nm <= start_nm {
            return Err(Error::invalid(
                "working grid",
                format!("{start_nm}–{end_nm} nm every {step_nm} nm; expected finite start < end and step > 0"),
            ));
        }
        let n = (end_nm - start_nm) / step_nm;
        if (n - n.round()).abs() > 1e-9 * n.max(1.0) || n.round() > 100_000.0 {
            return Err(Error::invalid(
                "working grid",
                format!("{start_nm}–{end_nm} nm is not a whole number of {step_nm} nm steps (at most 100000)"),
            ));
        }
        Ok(WorkingGrid {
            start_nm,
            end_nm,
            step_nm,
        })
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        ((self.end_nm - self.start_nm) / self.step_nm).round() as usize + 1
    }

    /// Always false (a grid has at least two samples).
    pub fn is_empty(&self) -> bool {
        false
    }

    /// The sample wavelengths.
    pub fn wavelengths(&self) -> Vec<f64> {
        (0..self.len())
            .map(|i| self.start_nm + i as f64 * self.step_nm)
            .collect()
    }
}

/// A Donaldson matrix resampled to a square working grid: output spectrum = `a · e`.
#[derive(Debug, Clone, PartialEq)]
pub struct OperatorMatrix {
    /// Name of the material.
    pub name: String,
    /// The working grid (both axes).
    pub grid: WorkingGrid,
    /// `a[(o, i)]`: emission sample `o`, excitation sample `i`; off-diagonal entries already carry
    /// the band width `h` (they are per sample, not per nm).
    pub a: DMatrix<f64>,
}

impl OperatorMatrix {
    /// The identity operator (a perfect white reflector) on `grid`.
    pub fn identity(name: impl Into<String>, grid: WorkingGrid) -> OperatorMatrix {
        let n = grid.len();
        OperatorMatrix {
            name: name.into(),
            grid,
            a: DMatrix::identity(n, n),
        }
    }

    /// A non-fluorescent material: reflectance `r` (one per grid sample) on the diagonal.
    pub fn diagonal(
        name: impl Into<String>,
        grid: WorkingGrid,
        r: &[f64],
    ) -> Result<OperatorMatrix> {
        let name = name.into();
        if r.len() != grid.len() {
            return Err(Error::ShapeMismatch {
                what: format!("reflectance of '{name}' on the working grid"),
                expected: grid.len(),
                got: r.len(),
            });
        }
        Ok(OperatorMatrix {
            name,
            grid,
            a: DMatrix::from_diagonal(&nalgebra::DVector::from_column_slice(r)),
        })
    }
}

/// Piecewise-linear weights of `v` on the increasing grid `x`: `(index, weight)` pairs, empty
/// outside `[x0, x_last]` (zero extrapolation).
fn linear_weights(x: &[f64], v: f64) -> Vec<(usize, f64)> {
    let n = x.len();
    if n == 0 || v < x[0] - WL_MATCH_NM || v > x[n - 1] + WL_MATCH_NM {
        return Vec::new();
    }
    if n == 1 {
        return vec![(0, 1.0)];
    }
    let v = v.clamp(x[0], x[n - 1]);
    let i = (x.partition_point(|&xi| xi <= v)).clamp(1, n - 1) - 1;
    let t = (v - x[i]) / (x[i + 1] - x[i]);
    if t <= 0.0 {
        vec![(i, 1.0)]
    } else if t >= 1.0 {
        vec![(i + 1, 1.0)]
    } else {
        vec![(i, 1.0 - t), (i + 1, t)]
    }
}

/// Linear interpolation of `y(x)` at `at`, zero outside `[x0, x_last]`.
pub fn interp_zero(x: &[f64], y: &[f64], at: &[f64]) -> Vec<f64> {
    at.iter()
        .map(|&v| linear_weights(x, v).iter().map(|&(i, w)| w * y[i]).sum())
        .collect()
}

fn check_axis(source: &str, what: &str, w: &[f64]) -> Result<f64> {
    if w.len() < 2 {
        return Err(Error::parse(
            source,
            0,
            format!("{what}: expected at least 2 wavelengths, found {}", w.len()),
        ));
    }
    for p in w.windows(2) {
        if p[1].partial_cmp(&p[0]) != Some(std::cmp::Ordering::Greater) {
            return Err(Error::parse(
                source,
                0,
                format!(
                    "{what}: wavelengths must be strictly increasing, but {} nm follows {} nm",
                    p[1], p[0]
                ),
            ));
        }
    }
    if !is_uniform(w) {
        return Err(Error::parse(
            source,
            0,
            format!("{what}: expected a uniform grid (the off-diagonal entries are per band of one step)"),
        ));
    }
    Ok(w[1] - w[0])
}

impl DonaldsonMatrix {
    /// Builds a validated matrix: `values` has one row per emission and one column per
    /// excitation wavelength; both axes uniform and increasing; every emission wavelength must
    /// have an excitation column (that cell is the reflectance factor).
    pub fn new(
        name: impl Into<String>,
        emission_nm: Vec<f64>,
        excitation_nm: Vec<f64>,
        values: DMatrix<f64>,
    ) -> Result<DonaldsonMatrix> {
        let name = name.into();
        check_axis(&name, "emission axis", &emission_nm)?;
        check_axis(&name, "excitation axis", &excitation_nm)?;
        if values.nrows() != emission_nm.len() {
            return Err(Error::ShapeMismatch {
                what: format!("rows (emission wavelengths) of Donaldson matrix '{name}'"),
                expected: emission_nm.len(),
                got: values.nrows(),
            });
        }
        if values.ncols() != excitation_nm.len() {
            return Err(Error::ShapeMismatch {
                what: format!("columns (excitation wavelengths) of Donaldson matrix '{name}'"),
                expected: excitation_nm.len(),
                got: values.ncols(),
            });
        }
        if let Some(((r, c), v)) = values
            .iter()
            .enumerate()
            .map(|(k, v)| ((k % values.nrows(), k / values.nrows()), v))
            .find(|(_, v)| !v.is_finite())
        {
            return Err(Error::invalid(
                "Donaldson matrix",
                format!("'{name}': entry at emission {} nm, excitation {} nm is {v}; expected a finite number", emission_nm[r], excitation_nm[c]),
            ));
        }
        for &e in &emission_nm {
            if !excitation_nm.iter().any(|&x| (x - e).abs() <= WL_MATCH_NM) {
                return Err(Error::invalid(
                    "Donaldson matrix",
                    format!("'{name}': emission {e} nm has no excitation column; the diagonal (reflectance factor) needs excitation = emission"),
                ));
            }
        }
        Ok(DonaldsonMatrix {
            name,
            emission_nm,
            excitation_nm,
            values,
        })
    }

    /// Name (usually the file it came from).
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Renamed copy.
    pub fn with_name(mut self, name: impl Into<String>) -> Self {
        self.name = name.into();
        self
    }

    /// Emission wavelengths (rows).
    pub fn emission_nm(&self) -> &[f64] {
        &self.emission_nm
    }

    /// Excitation wavelengths (columns).
    pub fn excitation_nm(&self) -> &[f64] {
        &self.excitation_nm
    }

    /// The values, rows = emission, columns = excitation.
    pub fn values(&self) -> &DMatrix<f64> {
        &self.values
    }

    /// Excitation step (nm): the band width of the off-diagonal entries.
    pub fn excitation_step_nm(&self) -> f64 {
        self.excitation_nm[1] - self.excitation_nm[0]
    }

    /// Column index of the excitation equal to emission row `r`.
    fn diagonal_column(&self, r: usize) -> Option<usize> {
        let e = self.emission_nm[r];
        self.excitation_nm
            .iter()
            .position(|&x| (x - e).abs() <= WL_MATCH_NM)
    }

    /// The reflectance factor (diagonal), one value per emission wavelength.
    pub fn diagonal(&self) -> Vec<f64> {
        (0..self.emission_nm.len())
            .map(|r| self.diagonal_column(r).map_or(0.0, |c| self.values[(r, c)]))
            .collect()
    }

    /// Resamples to an operator on `grid` (see the module docs for the conventions).
    pub fn to_operator(&self, grid: &WorkingGrid, options: ResampleOptions) -> OperatorMatrix {
        let (n_em, n_ex) = (self.emission_nm.len(), self.excitation_nm.len());
        let mut v = self.values.clone();
        if options.clip_negatives {
            v.iter_mut().for_each(|x| *x = x.max(0.0));
        }
        if options.zero_anti_stokes {
            for r in 0..n_em {
                for c in 0..n_ex {
                    if self.excitation_nm[c] >= self.emission_nm[r] - WL_MATCH_NM
                        && self.diagonal_column(r) != Some(c)
                    {
                        v[(r, c)] = 0.0;
                    }
                }
            }
        }
        let mut diag = vec![0.0; n_em];
        for (r, d) in diag.iter_mut().enumerate() {
            if let Some(c) = self.diagonal_column(r) {
                *d = v[(r, c)];
                v[(r, c)] = 0.0;
            }
        }
        let wl = grid.wavelengths();
        let n = wl.len();
        let scale = grid.step_nm / self.excitation_step_nm();
        // Along excitation first: tmp[r][j] = off-diagonal row r at working excitation j.
        let ex_w: Vec<Vec<(usize, f64)>> = wl
            .iter()
            .map(|&x| linear_weights(&self.excitation_nm, x))
            .collect();
        let em_w: Vec<Vec<(usize, f64)>> = wl
            .iter()
            .map(|&x| linear_weights(&self.emission_nm, x))
            .collect();
        let mut tmp = DMatrix::<f64>::zeros(n_em, n);
        for r in 0..n_em {
            for (j, ws) in ex_w.iter().enumerate() {
                tmp[(r, j)] = ws.iter().map(|&(c, w)| w * v[(r, c)]).sum::<f64>() * scale;
            }
        }
        let mut a = DMatrix::<f64>::zeros(n, n);
        for (o, ws) in em_w.iter().enumerate() {
            if ws.is_empty() {
                continue;
            }
            for j in 0..n {
                a[(o, j)] = ws.iter().map(|&(r, w)| w * tmp[(r, j)]).sum();
            }
        }
        if options.zero_anti_stokes {
            for o in 0..n {
                for j in o..n {
                    a[(o, j)] = 0.0;
                }
            }
        }
        let diag_w = interp_zero(&self.emission_nm, &diag, &wl);
        for (k, d) in diag_w.iter().enumerate() {
            a[(k, k)] += d;
        }
        OperatorMatrix {
            name: self.name.clone(),
            grid: *grid,
            a,
        }
    }

    /// The matrix as a Labsphere BFC-450 "Matrix File" (tab-separated, CRLF-free).
    ///
    /// Needs uniform axes with the same step (as the format's header line describes them).
    pub fn to_bfc(&self) -> Result<String> {
        let step_em = self.emission_nm[1] - self.emission_nm[0];
        let step_ex = self.excitation_step_nm();
        let (e0, e1) = (
            self.emission_nm[0],
            self.emission_nm[self.emission_nm.len() - 1],
        );
        let mut s = String::from("VEC_01\t5167\nBFC-450 Matrix File\n");
        s.push_str(&format!(
            ";{}\n;written by lumifit {}\n;<none>\n;<none>\n;<none>\n;<none>\n;<none>\n;<none>\n",
            self.name,
            env!("CARGO_PKG_VERSION")
        ));
        s.push_str(&format!(
            "{e0}\t{e1}\t{step_em}\t{}\t{}\t{step_ex}\n",
            self.excitation_nm.len(),
            self.excitation_nm[0]
        ));
        s.push_str("r:c:");
        for x in &self.excitation_nm {
            s.push_str(&format!("\t{x}"));
        }
        s.push('\n');
        for (r, e) in self.emission_nm.iter().enumerate() {
            s.push_str(&format!("{e}"));
            for c in 0..self.excitation_nm.len() {
                s.push_str(&format!("\t{:e}", self.values[(r, c)]));
            }
            s.push('\n');
        }
        s.push_str("EOD\n");
        Ok(s)
    }

    /// The matrix as lumifit's CSV layout (see [`parse_donaldson_csv`]).
    pub fn to_csv(&self) -> String {
        let mut s = String::from("emission_nm");
        for x in &self.excitation_nm {
            s.push_str(&format!(",{x}"));
        }
        s.push('\n');
        for (r, e) in self.emission_nm.iter().enumerate() {
            s.push_str(&format!("{e}"));
            for c in 0..self.excitation_nm.len() {
                s.push_str(&format!(",{:e}", self.values[(r, c)]));
            }
            s.push('\n');
        }
        s
    }
}

fn parse_f64(source: &str, line: usize, what: &str, field: &str) -> Result<f64> {
    let v: f64 = field.trim().parse().map_err(|_| {
        Error::parse(
            source,
            line,
            format!("{what}: expected a number, found '{field}'"),
        )
    })?;
    if !v.is_finite() {
        return Err(Error::parse(
            source,
            line,
            format!("{what}: expected a finite number, found '{field}'"),
        ));
    }
    Ok(v)
}

/// Parses a Labsphere BFC-450 "Matrix File" (`text`, named `source` in errors).
///
/// Layout: line 1 `VEC_01 …`, line 2 `BFC-450 Matrix File`, `;` comment lines, then the header
/// `emit_start emit_end emit_step n_excit excit_start excit_step`, the `r:c:` line listing the
/// excitation wavelengths, one row per emission wavelength (emission nm, then one value per
/// excitation), and `EOD`. Blank lines inside the data block are skipped (a quirk of some files).
pub fn parse_bfc(text: &str, source: &str) -> Result<DonaldsonMatrix> {
    let mut lines = text.lines().enumerate().map(|(i, l)| (i + 1, l.trim()));
    let mut header: Option<(usize, [f64; 6])> = None;
    let mut seen_magic = false;
    for (no, line) in lines.by_ref() {
        if line.is_empty() || line.starts_with(';') {
            continue;
        }
        if line.starts_with("VEC_") || line.eq_ignore_ascii_case("BFC-450 Matrix File") {
            seen_magic = true;
            continue;
        }
        let fields: Vec<&str> = line.split_whitespace().collect();
        if fields.len() != 6 {
            return Err(Error::parse(
                source,
                no,
                format!(
                    "expected the BFC-450 grid line 'emit_start emit_end emit_step n_excit excit_start excit_step' (6 numbers), found '{line}'{}",
                    if seen_magic { "" } else { " (is this a BFC-450 matrix file?)" }
                ),
            ));
        }
        let mut h = [0.0; 6];
        for (k, f) in fields.iter().enumerate() {
            h[k] = parse_f64(source, no, "grid line", f)?;
        }
        header = Some((no, h));
        break;
    }
    let (hline, [e0, e1, es, nx, x0, xs]) = header.ok_or_else(|| {
        Error::parse(
            source,
            0,
            "no BFC-450 grid line found; expected a Labsphere BFC-450 matrix file",
        )
    })?;
    if !(es > 0.0 && xs > 0.0 && e1 >= e0 && nx >= 1.0 && nx.fract() == 0.0) {
        return Err(Error::parse(source, hline, "grid line: expected positive steps, end ≥ start and a whole number of excitation samples"));
    }
    let n_em = ((e1 - e0) / es).round() as usize + 1;
    let n_ex = nx as usize;
    if n_em > 10_000 || n_ex > 10_000 {
        return Err(Error::parse(
            source,
            hline,
            "grid line: more than 10000 samples on an axis",
        ));
    }
    let emission_nm: Vec<f64> = (0..n_em).map(|i| e0 + i as f64 * es).collect();
    let excitation_nm: Vec<f64> = (0..n_ex).map(|i| x0 + i as f64 * xs).collect();
    // The r:c: line.
    let (rc_no, rc) = lines.by_ref().find(|(_, l)| !l.is_empty()).ok_or_else(|| {
        Error::parse(
            source,
            hline,
            "file ends after the grid line; expected the 'r:c:' excitation line",
        )
    })?;
    let rc_fields: Vec<&str> = rc.split_whitespace().collect();
    if rc_fields
        .first()
        .is_none_or(|f| !f.eq_ignore_ascii_case("r:c:"))
    {
        return Err(Error::parse(
            source,
            rc_no,
            format!("expected the 'r:c:' line listing the excitation wavelengths, found '{rc}'"),
        ));
    }
    if rc_fields.len() - 1 != n_ex {
        return Err(Error::parse(
            source,
            rc_no,
            format!(
                "the 'r:c:' line lists {} excitation wavelengths; the grid line declares {n_ex}",
                rc_fields.len() - 1
            ),
        ));
    }
    for (k, f) in rc_fields[1..].iter().enumerate() {
        let v = parse_f64(source, rc_no, "excitation wavelength", f)?;
        if (v - excitation_nm[k]).abs() > 1e-6 {
            return Err(Error::parse(
                source,
                rc_no,
                format!(
                    "excitation wavelength #{} is {v} nm; the grid line implies {} nm",
                    k + 1,
                    excitation_nm[k]
                ),
            ));
        }
    }
    let mut values = DMatrix::<f64>::zeros(n_em, n_ex);
    let mut row = 0;
    let mut last_line = rc_no;
    let mut saw_eod = false;
    for (no, line) in lines {
        last_line = no;
        if line.is_empty() {
            continue;
        }
        if line.starts_with("EOD") {
            saw_eod = true;
            break;
        }
        if row >= n_em {
            return Err(Error::parse(
                source,
                no,
                format!("more than the {n_em} emission rows the grid line declares ({e0}–{e1} nm every {es} nm); expected 'EOD'"),
            ));
        }
        let fields: Vec<&str> = line.split_whitespace().collect();
        let wl = parse_f64(source, no, "emission wavelength (first field)", fields[0])?;
        if (wl - emission_nm[row]).abs() > 1e-6 {
            return Err(Error::parse(
                source,
                no,
                format!(
                    "row starts with emission {wl} nm; expected {} nm (row {} of {n_em})",
                    emission_nm[row],
                    row + 1
                ),
            ));
        }
        if fields.len() - 1 != n_ex {
            return Err(Error::parse(
                source,
                no,
                format!("emission {wl} nm: expected {n_ex} values (one per excitation wavelength), found {}", fields.len() - 1),
            ));
        }
        for (c, f) in fields[1..].iter().enumerate() {
            values[(row, c)] = parse_f64(
                source,
                no,
                &format!("emission {wl} nm, excitation {} nm", excitation_nm[c]),
                f,
            )?;
        }
        row += 1;
    }
    if row != n_em {
        return Err(Error::parse(
            source,
            last_line,
            format!("found {row} emission rows; the grid line declares {n_em} ({e0}–{e1} nm every {es} nm)"),
        ));
    }
    if !saw_eod {
        return Err(Error::parse(
            source,
            last_line,
            "missing the closing 'EOD' line (truncated file?)",
        ));
    }
    let name = std::path::Path::new(source)
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| source.to_string());
    DonaldsonMatrix::new(name, emission_nm, excitation_nm, values)
}

/// Parses lumifit's Donaldson CSV layout (`bytes`, named `source` in errors):
///
/// ```text
/// emission_nm,300,310,…,780        ← header: 'emission_nm', then the excitation wavelengths
/// 380,0.0004,0.0004,…,-0.0003      ← one row per emission wavelength
/// ```
///
/// Rows = emission, columns = excitation; units as in BFC-450 files. `#` lines are comments.
pub fn parse_donaldson_csv(bytes: &[u8], source: &str) -> Result<DonaldsonMatrix> {
    let table = crate::table::parse_numeric_csv(bytes, source)?;
    if !table.header[0].eq_ignore_ascii_case("emission_nm") {
        return Err(Error::parse(
            source,
            1,
            format!("first header field is '{}'; expected 'emission_nm' followed by the excitation wavelengths", table.header[0]),
        ));
    }
    let header_line = table
        .lines
        .first()
        .map_or(1, |l| l.saturating_sub(1))
        .max(1);
    let mut excitation_nm = Vec::with_capacity(table.header.len() - 1);
    for h in &table.header[1..] {
        excitation_nm.push(parse_f64(
            source,
            header_line,
            "header (excitation wavelength in nm)",
            h,
        )?);
    }
    let emission_nm = table.columns[0].clone();
    let n_em = emission_nm.len();
    let values = DMatrix::from_fn(n_em, excitation_nm.len(), |r, c| table.columns[c + 1][r]);
    let name = std::path::Path::new(source)
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| source.to_string());
    DonaldsonMatrix::new(name, emission_nm, excitation_nm, values)
}

/// Parses BFC-450 or CSV by content: a BFC file's first non-blank line starts with `VEC_` or
/// the file names `BFC-450`; anything else is read as CSV.
pub fn parse_donaldson(bytes: &[u8], source: &str) -> Result<DonaldsonMatrix> {
    let text = crate::table::as_text(bytes, source, "a BFC-450 matrix file or a Donaldson CSV")?;
    let first = text
        .lines()
        .map(str::trim)
        .find(|l| !l.is_empty())
        .unwrap_or("");
    if first.starts_with("VEC_")
        || text.contains("BFC-450")
        || source.to_ascii_lowercase().ends_with(".bfc")
    {
        parse_bfc(text, source)
    } else {
        parse_donaldson_csv(bytes, source)
    }
}
