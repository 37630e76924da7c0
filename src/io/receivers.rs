//! Receiving points for `light illuminance`: `points.csv` in (`x,y,z,nx,ny,nz`, metres and the
//! receiving surface's normal) and the shaded table out (`…,E_lux[,E_std][,Le_bar]`).
//!
//! Reading goes through [`crate::table::parse_numeric_csv`] (header, comments, BOM, CRLF,
//! duplicate columns and non-finite values refused with file and line); extra columns are
//! ignored, so the output of one run can be the input of the next.

use std::path::Path;

use crate::error::{Error, Result};
use crate::photometry::illuminance::{Receiver, Shade};

/// The columns a points file must have.
pub const POINT_COLUMNS: [&str; 6] = ["x", "y", "z", "nx", "ny", "nz"];

/// Reads `points.csv` (or `-`): one receiver per row, normals normalised; a zero or non-finite
/// normal is an error naming the line.
pub fn read_receivers(path: &Path) -> Result<Vec<Receiver>> {
    let (bytes, source) = super::read_input(path)?;
    let table = crate::table::parse_numeric_csv(&bytes, &source)?;
    let cols: Vec<usize> = POINT_COLUMNS
        .iter()
        .map(|c| {
            table.column_index(c).ok_or_else(|| {
                Error::parse(
                    &source,
                    1,
                    format!("no column '{c}'; expected columns x,y,z,nx,ny,nz"),
                )
            })
        })
        .collect::<Result<_>>()?;
    let n = table.n_rows();
    crate::limits::check_memory("points", &format!("{n} rows"), n as u128, 160)?;
    let mut receivers = Vec::with_capacity(n);
    for i in 0..n {
        let v: Vec<f64> = cols.iter().map(|&c| table.columns[c][i]).collect();
        let nn = (v[3] * v[3] + v[4] * v[4] + v[5] * v[5]).sqrt();
        if nn <= 0.0 || !nn.is_finite() {
            return Err(Error::parse(
                &source,
                table.lines[i],
                "normal (nx,ny,nz) is zero; expected a direction",
            ));
        }
        receivers.push(Receiver {
            p: [v[0], v[1], v[2]],
            n: [v[3] / nn, v[4] / nn, v[5] / nn],
        });
    }
    Ok(receivers)
}

/// The shaded table: the receivers repeated, `E_lux`, and `E_std` / `Le_bar` when asked for.
pub fn shades_to_csv(
    receivers: &[Receiver],
    shades: &[Shade],
    with_std: bool,
    with_le_bar: bool,
) -> String {
    let mut csv = String::from("x,y,z,nx,ny,nz,E_lux");
    if with_std {
        csv.push_str(",E_std");
    }
    if with_le_bar {
        csv.push_str(",Le_bar");
    }
    csv.push('\n');
    for (r, s) in receivers.iter().zip(shades) {
        csv.push_str(&format!(
            "{},{},{},{},{},{},{}",
            r.p[0], r.p[1], r.p[2], r.n[0], r.n[1], r.n[2], s.e_lux
        ));
        if with_std {
            csv.push_str(&format!(",{}", s.e_std.unwrap_or(0.0)));
        }
        if with_le_bar {
            csv.push_str(&format!(",{}", s.le_bar.unwrap_or(0.0)));
        }
        csv.push('\n');
    }
    csv
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_shaded_table_reads_back_as_points() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("p.csv");
        std::fs::write(&p, "\u{feff}x,y,z,nx,ny,nz\n0,0,0,0,0,2\n1,2,3,1,0,0\n").unwrap();
        let r = read_receivers(&p).unwrap();
        assert_eq!(r[0].n, [0.0, 0.0, 1.0]);
        let shades: Vec<Shade> = r
            .iter()
            .map(|_| Shade {
                e_lux: 5.0,
                e_std: Some(0.1),
                le_bar: None,
                evaluations: 1,
            })
            .collect();
        let out = dir.path().join("e.csv");
        std::fs::write(&out, shades_to_csv(&r, &shades, true, false)).unwrap();
        assert_eq!(read_receivers(&out).unwrap(), r);
    }

    #[test]
    fn a_zero_normal_names_its_line() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("p.csv");
        std::fs::write(&p, "x,y,z,nx,ny,nz\n0,0,0,0,0,1\n0,0,0,0,0,0\n").unwrap();
        let e = read_receivers(&p).unwrap_err().to_string();
        assert!(e.contains("line 3") && e.contains("normal"), "{e}");
    }
}
