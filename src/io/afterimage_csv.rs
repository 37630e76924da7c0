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

/// Reads a curves CSV back. The header must be the contract exactly (`Y` and `y` differ only in
/// case, which [`crate::table::parse_numeric_csv`] refuses as a duplicate column, so this fixed
/// format has its own reader); the text goes through [`crate::table::as_text`] (BOM, binary
/// refused), `#` comment and blank lines are skipped, CRLF is accepted, and every row needs eight
/// finite numbers. Errors name the source and the line.
pub fn parse_curves_csv(bytes: &[u8], source: &str) -> Result<Vec<CurvePoint>> {
    let text = crate::table::as_text(bytes, source, "an afterimage curves CSV")?;
    let mut rows = text
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim_end_matches('\r').trim()))
        .filter(|(_, l)| !l.is_empty() && !l.starts_with('#'));
    let header = CURVES_COLUMNS.join(",");
    match rows.next() {
        Some((_, h))
            if h.split(',')
                .map(str::trim)
                .eq(CURVES_COLUMNS.iter().copied()) => {}
        Some((n, h)) => {
            return Err(Error::parse(
                source,
                n,
                format!("header '{h}'; expected '{header}'"),
            ))
        }
        None => {
            return Err(Error::parse(
                source,
                0,
                format!("empty; expected the header '{header}' and rows"),
            ))
        }
    }
    let mut out = Vec::new();
    for (n, line) in rows {
        let v: Vec<&str> = line.split(',').map(str::trim).collect();
        if v.len() != 8 {
            return Err(Error::parse(
                source,
                n,
                format!("{} fields; expected 8 ({header})", v.len()),
            ));
        }
        let mut x = [0.0; 8];
        for (k, f) in v.iter().enumerate() {
            x[k] = f
                .parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| {
                    Error::parse(
                        source,
                        n,
                        format!(
                            "column '{}': '{f}' is not a finite number",
                            CURVES_COLUMNS[k]
                        ),
                    )
                })?;
        }
        out.push(CurvePoint {
            t_s: x[0],
            big_y: x[1],
            x: x[2],
            y: x[3],
            lab: [x[4], x[5], x[6]],
            tau: x[7],
        });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn curves_round_trip_and_a_bad_row_names_its_line() {
        let pts =
            crate::afterimage::curves(&[0.0, 6.0, 80.0], crate::afterimage::TimeRange::Measured)
                .unwrap();
        let back = parse_curves_csv(curves_to_csv(&pts).as_bytes(), "c.csv").unwrap();
        assert_eq!(back, pts);
        let e = parse_curves_csv(b"t_s,Y,x,y,L,a,b,tau\n0,1,2,3,4,5,6,x\n", "c.csv").unwrap_err();
        assert!(
            e.to_string().contains("c.csv: line 2") && e.to_string().contains("tau"),
            "{e}"
        );
        assert!(parse_curves_csv(b"t_s,y,x,Y,L,a,b,tau\n", "c.csv").is_err());
    }
}
