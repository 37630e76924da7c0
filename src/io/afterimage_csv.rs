//! The `afterimage curves` CSV (a contract): header `t_s,Y,x,y,L,a,b,tau`, one row per time,
//! numbers in Rust's shortest round-trip form (so Table 1's values read back exactly).

use crate::afterimage::CurvePoint;
use crate::error::{Error, Result};

/// The contract's columns, in order.
pub const CURVES_COLUMNS: [&str; 8] = ["t_s", "Y", "x", "y", "L", "a", "b", "tau"];

/// The CSV text of the curves.
pub fn curves_to_csv(points: &[CurvePoint]) -> String {
    let mut s = CURVES_COLUMNS.join(",");
    s.push('\n');
    for p in points {
        s.push_str(&format!(
            "{},{},{},{},{},{},{},{}\n",
            p.t_s, p.big_y, p.x, p.y, p.lab[0], p.lab[1], p.lab[2], p.tau
        ));
    }
    s
}

/// Reads a curves CSV back (through [`crate::table::parse_numeric_csv`]); every contract column
/// must be present.
pub fn parse_curves_csv(bytes: &[u8], source: &str) -> Result<Vec<CurvePoint>> {
    let table = crate::table::parse_numeric_csv(bytes, source)?;
    let mut idx = [0usize; 8];
    for (k, name) in CURVES_COLUMNS.iter().enumerate() {
        idx[k] = table.column_index(name).ok_or_else(|| {
            Error::parse(
                source,
                1,
                format!(
                    "no column '{name}'; expected the header {}",
                    CURVES_COLUMNS.join(",")
                ),
            )
        })?;
    }
    Ok((0..table.n_rows())
        .map(|r| {
            let v = |k: usize| table.columns[idx[k]][r];
            CurvePoint {
                t_s: v(0),
                big_y: v(1),
                x: v(2),
                y: v(3),
                lab: [v(4), v(5), v(6)],
                tau: v(7),
            }
        })
        .collect())
}
