//! Inputs named on the command line that are either a built-in name or a file: illuminants,
//! lamps, measured passbands, white-reference reflectances.
//!
//! Each resolver reads the file through the house readers (BOM, comments, NaN refused with file
//! and line) and [`file_of`] tells which argument is a file, so a command can register it as an
//! input before declaring its outputs.

use std::path::{Path, PathBuf};

use crate::colorimetry::Illuminant;
use crate::error::{Error, Result};
use crate::lvf::{Lamp, Passband};
use crate::math::interpolation::Interpolator;

/// The file an argument names, when it is one (`-`, standard input, is not a file to protect).
pub fn file_of(arg: &str) -> Option<PathBuf> {
    let p = Path::new(arg);
    p.is_file().then(|| p.to_path_buf())
}

/// An illuminant given as a CIE name, `daylight:<CCT K>` (CIE D-series of that correlated colour
/// temperature), `blackbody:<T K>` (Planck, 360–830 nm at 1 nm) or a CSV file
/// `wavelength_nm,value`.
///
/// # Errors
/// [`Error::InvalidArgument`] naming `flag` for a malformed temperature; the reader's errors for a
/// file; [`Error::UnknownName`] for an unknown CIE name.
pub fn resolve_illuminant(flag: &str, arg: &str) -> Result<Illuminant> {
    let lower = arg.to_ascii_lowercase();
    for (prefix, daylight) in [("daylight:", true), ("blackbody:", false)] {
        if let Some(rest) = lower.strip_prefix(prefix) {
            let t: f64 = rest.trim().trim_end_matches('k').parse().map_err(|_| {
                Error::invalid(
                    flag,
                    format!(
                        "'{arg}': expected a temperature in K after '{prefix}', e.g. {prefix}5000"
                    ),
                )
            })?;
            let sd = if daylight {
                crate::colorimetry::daylight::sd_d_series_from_cct(t)?
            } else {
                let shape = crate::spectrum::SpectralShape::new(360.0, 830.0, 1.0)?;
                crate::colorimetry::blackbody::sd_blackbody(t, &shape)?
            };
            let ill = Illuminant::from_spectrum(arg, sd);
            // colour builds D-series spectra with linear interpolation, like the CIE tables.
            return Ok(if daylight {
                ill.with_interpolator(Interpolator::Linear)
            } else {
                ill
            });
        }
    }
    let path = Path::new(arg);
    let looks_like_file = path.is_file()
        || arg == "-"
        || lower.ends_with(".csv")
        || arg.contains(std::path::MAIN_SEPARATOR);
    if looks_like_file {
        let sd = super::spectrum_csv::read_spectrum(path)?;
        Ok(Illuminant::from_spectrum(arg, sd))
    } else {
        Illuminant::standard(arg)
    }
}

/// `--lamp`: `hg` (mercury), `hg-weak` (weak 405/408 nm), `cfl`, or a CSV `wavelength_nm[,relative_power]`.
///
/// # Errors
/// [`Error::InvalidArgument`] when the argument is neither a lamp name nor an existing file; the
/// table and lamp errors of the file.
pub fn resolve_lamp(arg: &str) -> Result<Lamp> {
    match arg.to_ascii_lowercase().as_str() {
        "hg" | "mercury" => Ok(Lamp::mercury()),
        "cfl" => Ok(Lamp::cfl()),
        "hg-weak" => Ok(Lamp::mercury_weak_violet()),
        _ => {
            let path = Path::new(arg);
            if !path.is_file() {
                return Err(Error::invalid(
                    "--lamp",
                    format!("'{arg}' is neither hg, hg-weak, cfl nor an existing CSV file wavelength_nm[,relative_power]"),
                ));
            }
            let (bytes, src) = super::read_input(path)?;
            let t = crate::table::parse_numeric_csv(&bytes, &src)?;
            Lamp::from_table(&t)
        }
    }
}

/// `--passband`: `gaussian`, `gennorm:BETA` (a generalised normal of exponent BETA), or a CSV
/// `offset_nm,transmission` (a measured shape). (`gennorm` alone, the exponent fitted, is the
/// caller's: [`crate::lvf::FitOptions::passband_exponent_search`].)
///
/// # Errors
/// The table errors of the file; [`Error::Parse`] when it has fewer than two columns.
pub fn resolve_passband(arg: &str) -> Result<Passband> {
    if arg.eq_ignore_ascii_case("gaussian") {
        return Ok(Passband::Gaussian);
    }
    if let Some(b) = arg
        .strip_prefix("gennorm:")
        .or_else(|| arg.strip_prefix("GENNORM:"))
    {
        return match b.trim().parse::<f64>() {
            Ok(beta) if (0.5..=20.0).contains(&beta) => Ok(Passband::GenNormal { beta }),
            _ => Err(Error::invalid(
                "--passband",
                format!("'{arg}': expected gennorm:BETA with the exponent BETA in [0.5, 20] (2: Gaussian), or gennorm to fit it"),
            )),
        };
    }
    let (bytes, src) = super::read_input(Path::new(arg))?;
    let t = crate::table::parse_numeric_csv(&bytes, &src)?;
    if t.columns.len() < 2 {
        return Err(Error::parse(
            &src,
            0,
            "expected columns offset_nm,transmission (a measured passband)",
        ));
    }
    Passband::measured(t.columns[0].clone(), t.columns[1].clone())
        .map_err(|e| Error::invalid("--passband", format!("{src}: {e}")))
}

/// `--basis` of `fluor`: a built-in basis (`xyz`, `xyzu`, `xyz7u`) or a basis CSV
/// `wavelength_nm,f1,…,fK` (named by its file stem), on `grid` for the observer's `cmfs`.
///
/// # Errors
/// The unknown-name error when the argument is neither a built-in nor a CSV file; the reader's
/// and [`crate::fluor::Basis::from_table`]'s errors for a file.
pub fn resolve_basis(
    arg: &str,
    cmfs: &crate::spectrum::MultiSpectrum,
    grid: &crate::fluor::WorkingGrid,
) -> Result<crate::fluor::Basis> {
    match crate::fluor::BasisKind::from_name(arg) {
        Ok(kind) => kind.build(cmfs, grid),
        Err(e) => {
            let p = Path::new(arg);
            if !(p.is_file() || arg.to_ascii_lowercase().ends_with(".csv")) {
                return Err(e);
            }
            let table = super::spectrum_csv::read_multi_spectrum(p)?;
            let name = p
                .file_stem()
                .map(|x| x.to_string_lossy().into_owned())
                .unwrap_or_else(|| arg.to_string());
            crate::fluor::Basis::from_table(name, &table, cmfs, grid)
        }
    }
}

/// `--white-reflectance`: a number in (0, 1.5] or a CSV `wavelength_nm,value`, sampled on
/// `grid_nm` (values must be > 0 there).
///
/// # Errors
/// [`Error::InvalidArgument`] for a number out of range or a file with values ≤ 0 on the grid.
pub fn white_reflectance(arg: &str, grid_nm: &[f64]) -> Result<Vec<f64>> {
    if let Ok(v) = arg.trim().parse::<f64>() {
        if !(v > 0.0 && v <= 1.5) {
            return Err(Error::invalid(
                "--white-reflectance",
                format!("{v}; expected a reflectance in (0, 1.5]"),
            ));
        }
        return Ok(vec![v; grid_nm.len()]);
    }
    let sd = super::spectrum_csv::read_spectrum(Path::new(arg))?;
    let v = sd.values_at(grid_nm, Interpolator::Linear)?;
    if v.iter().any(|x| x.is_nan() || *x <= 0.0) {
        return Err(Error::invalid(
            "--white-reflectance",
            format!("{arg}: values must be > 0 over the grid"),
        ));
    }
    Ok(v)
}

/// The files named on the command line with folders expanded: a file stays as given, a folder
/// stands for its files whose extension is one of `extensions` (case-insensitive), sorted by
/// name; other files in it are ignored.
///
/// # Errors
/// [`Error::Io`] when a folder cannot be listed; [`Error::InvalidArgument`] naming the folder
/// when it holds no such file.
pub fn expand_folders(paths: &[PathBuf], extensions: &[&str]) -> Result<Vec<PathBuf>> {
    let mut out = Vec::new();
    for p in paths {
        if !p.is_dir() {
            out.push(p.clone());
            continue;
        }
        let entries = std::fs::read_dir(p).map_err(|e| Error::io(p, e))?;
        let mut found: Vec<PathBuf> = entries
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|f| {
                f.is_file()
                    && f.extension()
                        .is_some_and(|x| extensions.iter().any(|want| x.eq_ignore_ascii_case(want)))
            })
            .collect();
        if found.is_empty() {
            return Err(Error::invalid(
                p.display().to_string(),
                format!(
                    "no input files in the folder; expected {}",
                    extensions
                        .iter()
                        .map(|e| format!("*.{e}"))
                        .collect::<Vec<_>>()
                        .join(" or ")
                ),
            ));
        }
        found.sort();
        out.extend(found);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_temperatures_and_files_resolve() {
        assert_eq!(resolve_illuminant("--x", "D65").unwrap().name(), "D65");
        assert!(resolve_illuminant("--x", "daylight:5000").is_ok());
        let e = resolve_illuminant("--source", "blackbody:hot")
            .unwrap_err()
            .to_string();
        assert!(e.contains("--source") && e.contains("temperature"), "{e}");
        assert!(resolve_lamp("hg").is_ok());
        assert!(resolve_lamp("no-such-lamp").is_err());
        assert!(matches!(
            resolve_passband("gaussian").unwrap(),
            Passband::Gaussian
        ));
        assert!(
            matches!(resolve_passband("gennorm:2.5").unwrap(), Passband::GenNormal { beta } if beta == 2.5)
        );
        let e = resolve_passband("gennorm:0").unwrap_err().to_string();
        assert!(e.contains("--passband") && e.contains("[0.5, 20]"), "{e}");
        assert_eq!(
            white_reflectance("0.9", &[400.0, 500.0]).unwrap(),
            [0.9, 0.9]
        );
        assert!(white_reflectance("2", &[400.0]).is_err());
        assert!(file_of("D65").is_none());
    }
}
