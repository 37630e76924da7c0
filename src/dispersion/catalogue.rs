//! The bundled glass catalogue (`calib/glasses.csv`): a refractiveindex.info formula per material
//! with its source, so `lumifit dispersion fit --glass N-BK7` needs no file. See
//! `calib/README.md` for where the coefficients come from.

use super::formula::{Formula, FormulaKind};
use crate::error::{Error, Result};

const GLASSES_CSV: &str = include_str!("../../calib/glasses.csv");

/// One catalogue entry.
#[derive(Debug, Clone, PartialEq)]
pub struct Glass {
    /// Name as typed after `--glass` (case-insensitive).
    pub name: String,
    /// The dispersion formula.
    pub formula: Formula,
    /// Catalogue n_d, when the source prints it.
    pub catalogue_n_d: Option<f64>,
    /// Catalogue V_d, when the source prints it.
    pub catalogue_v_d: Option<f64>,
    /// Where the coefficients come from.
    pub source: String,
}

/// Every entry of the bundled catalogue.
pub fn glasses() -> Result<Vec<Glass>> {
    let mut reader = csv::ReaderBuilder::new()
        .has_headers(true)
        .from_reader(GLASSES_CSV.as_bytes());
    let mut out = Vec::new();
    for (i, rec) in reader.records().enumerate() {
        let line = i + 2;
        let bad = |msg: String| Error::parse("calib/glasses.csv", line, msg);
        let rec = rec.map_err(|e| bad(e.to_string()))?;
        let field = |j: usize| rec.get(j).unwrap_or("").trim();
        let num = |j: usize| -> Result<Option<f64>> {
            let s = field(j);
            if s.is_empty() {
                return Ok(None);
            }
            s.parse::<f64>()
                .map(Some)
                .map_err(|_| bad(format!("column {}: '{s}' is not a number", j + 1)))
        };
        let kind = FormulaKind::from_number(
            field(1)
                .parse()
                .map_err(|_| bad(format!("formula '{}' is not a number", field(1))))?,
        )?;
        let coefficients = field(2)
            .split_whitespace()
            .map(|s| {
                s.parse::<f64>()
                    .map_err(|_| bad(format!("coefficient '{s}' is not a number")))
            })
            .collect::<Result<Vec<f64>>>()?;
        let lo = num(3)?.ok_or_else(|| bad("range_lo_um missing".into()))?;
        let hi = num(4)?.ok_or_else(|| bad("range_hi_um missing".into()))?;
        out.push(Glass {
            name: field(0).to_string(),
            formula: Formula::new(kind, coefficients, [lo, hi])?,
            catalogue_n_d: num(5)?,
            catalogue_v_d: num(6)?,
            source: field(7).to_string(),
        });
    }
    Ok(out)
}

/// The entry named `name` (case-insensitive).
pub fn glass(name: &str) -> Result<Glass> {
    let all = glasses()?;
    let names: Vec<String> = all.iter().map(|g| g.name.clone()).collect();
    all.into_iter()
        .find(|g| g.name.eq_ignore_ascii_case(name.trim()))
        .ok_or_else(|| Error::UnknownName {
            kind: "glass (--glass)",
            name: name.to_string(),
            expected: names.join(", "),
        })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dispersion::derived::derived_numbers;

    #[test]
    fn catalogue_n_d_and_v_d_agree_with_the_formulas_to_the_printed_digits() {
        let mut checked = 0;
        for g in glasses().unwrap() {
            let d = derived_numbers(&g.formula, [380.0, 780.0]).unwrap();
            if let (Some(nd), Some(vd)) = (g.catalogue_n_d, g.catalogue_v_d) {
                // printed to 5 decimals (4 for N-BK7) and 2 decimals: half the last digit
                assert!(
                    (d.n_d - nd).abs() <= 0.5e-4 + 1e-12,
                    "{}: {}",
                    g.name,
                    d.n_d
                );
                assert!(
                    (d.abbe_number_d - vd).abs() <= 0.005 + 1e-9,
                    "{}: {}",
                    g.name,
                    d.abbe_number_d
                );
                checked += 1;
            }
        }
        assert_eq!(checked, 6);
        assert!(glass("n-bk7").is_ok());
        assert!(glass("unobtainium").is_err());
    }
}
