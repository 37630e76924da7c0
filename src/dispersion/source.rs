//! Where n(λ) comes from — a database formula or a table of measurements — and how it becomes
//! the observations a fit sees over a range.
//!
//! A formula is sampled at 1 nm over the requested range intersected with its validity range
//! (never extrapolated); a table is restricted to the range and **fitted, never interpolated**
//! (interpolating the coarse, rounded Hale & Querry water table linearly gives V_d ≈ 73; see
//! `docs/dispersion.md`). The intersection must contain the F to C lines (486.13–656.27 nm),
//! otherwise V_d is undefined and the range is refused naming `wavelength_range`.

use super::air::{air_to_vacuum_nm, n_air_ciddor1996, vacuum_to_air_nm};
use super::fit::Observations;
use super::formula::Formula;
use super::lines::{C_NM, F_NM};
use super::RefractiveIndex;
use crate::error::{Error, Result};

/// An optional conversion between wavelengths in standard air (index relative to air) and in
/// vacuum (absolute index), by Ciddor (1996) standard air ([`super::air`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum AirVacuum {
    /// Keep the source's convention.
    #[default]
    AsGiven,
    /// The source is in air (relative n); produce vacuum wavelengths and absolute n.
    AirToVacuum,
    /// The source is in vacuum (absolute n); produce air wavelengths and n relative to air.
    VacuumToAir,
}

impl AirVacuum {
    /// CLI names `none`, `air-to-vacuum`, `vacuum-to-air`.
    pub fn from_name(name: &str) -> Result<AirVacuum> {
        match name {
            "none" => Ok(AirVacuum::AsGiven),
            "air-to-vacuum" => Ok(AirVacuum::AirToVacuum),
            "vacuum-to-air" => Ok(AirVacuum::VacuumToAir),
            other => Err(Error::UnknownName {
                kind: "--convert",
                name: other.into(),
                expected: "none, air-to-vacuum, vacuum-to-air".into(),
            }),
        }
    }

    /// The name written into reports.
    pub fn key(self) -> &'static str {
        match self {
            AirVacuum::AsGiven => "none",
            AirVacuum::AirToVacuum => "air-to-vacuum (Ciddor 1996 standard air)",
            AirVacuum::VacuumToAir => "vacuum-to-air (Ciddor 1996 standard air)",
        }
    }

    /// (source wavelength, factor on n) for a target wavelength `lambda_nm`.
    fn map(self, lambda_nm: f64) -> (f64, f64) {
        match self {
            AirVacuum::AsGiven => (lambda_nm, 1.0),
            // target is vacuum: the source (air) sees λ_air; n_abs = n_rel · n_air
            AirVacuum::AirToVacuum => (vacuum_to_air_nm(lambda_nm), n_air_ciddor1996(lambda_nm)),
            // target is air: the source (vacuum) sees λ_vac; n_rel = n_abs / n_air
            AirVacuum::VacuumToAir => {
                let vac = air_to_vacuum_nm(lambda_nm);
                (vac, 1.0 / n_air_ciddor1996(vac))
            }
        }
    }

    /// A source observation (λ, n) in the target convention.
    fn map_observation(self, lambda_nm: f64, n: f64) -> (f64, f64) {
        match self {
            AirVacuum::AsGiven => (lambda_nm, n),
            AirVacuum::AirToVacuum => {
                let vac = air_to_vacuum_nm(lambda_nm);
                (vac, n * n_air_ciddor1996(vac))
            }
            AirVacuum::VacuumToAir => {
                (vacuum_to_air_nm(lambda_nm), n / n_air_ciddor1996(lambda_nm))
            }
        }
    }
}

/// n(λ) as the source gives it.
#[derive(Debug, Clone, PartialEq)]
pub enum Source {
    /// A dispersion formula with its validity range.
    Formula(Formula),
    /// Measured or tabulated values (wavelengths in nm).
    Table(Observations),
}

/// A formula seen through an air ↔ vacuum conversion.
#[derive(Debug, Clone, PartialEq)]
pub struct Converted<'a> {
    /// The formula.
    pub formula: &'a Formula,
    /// The conversion.
    pub conversion: AirVacuum,
}

impl RefractiveIndex for Converted<'_> {
    fn n_at(&self, lambda_nm: f64) -> f64 {
        let (src, factor) = self.conversion.map(lambda_nm);
        self.formula.n_at(src) * factor
    }
}

/// The observations of `source` over `range_nm` (converted as asked) and the range actually
/// covered. `name` names the source in errors.
pub fn observations(
    source: &Source,
    range_nm: [f64; 2],
    conversion: AirVacuum,
    name: &str,
) -> Result<(Observations, [f64; 2])> {
    if !(range_nm[0].is_finite() && range_nm[1].is_finite() && range_nm[0] < range_nm[1]) {
        return Err(Error::invalid(
            "--range",
            format!(
                "{}:{}; expected LO:HI in nm with LO < HI",
                range_nm[0], range_nm[1]
            ),
        ));
    }
    let (obs, covered) = match source {
        Source::Formula(f) => {
            let conv = Converted {
                formula: f,
                conversion,
            };
            // validity range in the target convention
            let valid = [
                target_wavelength(conversion, f.range_um[0] * 1e3),
                target_wavelength(conversion, f.range_um[1] * 1e3),
            ];
            let lo = range_nm[0].max(valid[0]);
            let hi = range_nm[1].min(valid[1]);
            check_covers(name, [lo, hi], valid, "wavelength_range")?;
            let mut l = Vec::new();
            let mut x = lo.ceil();
            if x > lo {
                l.push(lo);
            }
            while x <= hi {
                l.push(x);
                x += 1.0;
            }
            if *l.last().unwrap_or(&lo) < hi {
                l.push(hi);
            }
            let n = l.iter().map(|&x| conv.n_at(x)).collect();
            (Observations::new(l, n, None, false, name)?, [lo, hi])
        }
        Source::Table(t) => {
            let mut l = Vec::with_capacity(t.len());
            let mut n = Vec::with_capacity(t.len());
            for i in 0..t.len() {
                let (a, b) = conversion.map_observation(t.lambda_nm[i], t.n[i]);
                l.push(a);
                n.push(b);
            }
            let conv = Observations::new(l, n, t.std.clone(), t.measured, name)?;
            let inside = conv.within(range_nm);
            let covered = match (inside.lambda_nm.first(), inside.lambda_nm.last()) {
                (Some(&a), Some(&b)) => [a, b],
                _ => [f64::NAN, f64::NAN],
            };
            let table_range = [
                *conv.lambda_nm.first().unwrap_or(&f64::NAN),
                *conv.lambda_nm.last().unwrap_or(&f64::NAN),
            ];
            check_covers(name, covered, table_range, "wavelength")?;
            (inside, covered)
        }
    };
    Ok((obs, covered))
}

fn target_wavelength(conversion: AirVacuum, source_nm: f64) -> f64 {
    match conversion {
        AirVacuum::AsGiven => source_nm,
        AirVacuum::AirToVacuum => air_to_vacuum_nm(source_nm),
        AirVacuum::VacuumToAir => vacuum_to_air_nm(source_nm),
    }
}

fn check_covers(name: &str, covered: [f64; 2], valid: [f64; 2], field: &str) -> Result<()> {
    if !(covered[0] <= F_NM - 1.0 && covered[1] >= C_NM + 1.0) {
        return Err(Error::invalid(
            format!("{name}: {field}"),
            format!(
                "the data cover {:.1}–{:.1} nm, so the fitted range would be {:.1}–{:.1} nm; expected a range with data spanning at least the F to C lines (485–657 nm) so that n_d and V_d are defined (no extrapolation)",
                valid[0], valid[1], covered[0], covered[1]
            ),
        ));
    }
    Ok(())
}
