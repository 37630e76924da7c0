//! Reference tables shipped with lumifit, embedded in the binary and parsed once.
//!
//! Everything here is exported from colour-science by `scripts/reference/export_calib.py`
//! (versions pinned in `scripts/reference/requirements.txt`); `calib/README.md` gives sources and
//! licences. Values are written in shortest round-trip form, so the parsed doubles equal colour's
//! bit for bit (`tests/calib_tables.rs`).

use std::collections::BTreeMap;
use std::sync::OnceLock;

use serde::Deserialize;

use crate::error::{Error, Result};
use crate::table::{parse_numeric_csv, NumericTable};

/// The standard observers whose colour-matching functions are embedded.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum CmfTable {
    /// CIE 1931 2° standard observer (360–830 nm, 1 nm).
    Cie1931_2,
    /// CIE 1964 10° standard observer (360–830 nm, 1 nm).
    Cie1964_10,
    /// CIE 2006 2° XYZ CMFs, colour's "CIE 2015 2 Degree Standard Observer" (390–830 nm, 1 nm).
    Cie2015_2,
    /// CIE 2006 10° XYZ CMFs, colour's "CIE 2015 10 Degree Standard Observer" (390–830 nm, 1 nm).
    Cie2015_10,
}

impl CmfTable {
    /// All embedded observers.
    pub const ALL: [CmfTable; 4] = [
        CmfTable::Cie1931_2,
        CmfTable::Cie1964_10,
        CmfTable::Cie2015_2,
        CmfTable::Cie2015_10,
    ];

    /// The CSV text as shipped in `calib/cmfs/`.
    pub fn csv(self) -> &'static str {
        match self {
            CmfTable::Cie1931_2 => include_str!("../calib/cmfs/cie1931_2.csv"),
            CmfTable::Cie1964_10 => include_str!("../calib/cmfs/cie1964_10.csv"),
            CmfTable::Cie2015_2 => include_str!("../calib/cmfs/cie2015_2.csv"),
            CmfTable::Cie2015_10 => include_str!("../calib/cmfs/cie2015_10.csv"),
        }
    }

    /// File name within `calib/cmfs/`, without extension (also the key in `colourspaces.json`).
    pub fn key(self) -> &'static str {
        match self {
            CmfTable::Cie1931_2 => "cie1931_2",
            CmfTable::Cie1964_10 => "cie1964_10",
            CmfTable::Cie2015_2 => "cie2015_2",
            CmfTable::Cie2015_10 => "cie2015_10",
        }
    }

    /// The parsed table `wavelength_nm,x_bar,y_bar,z_bar`.
    pub fn table(self) -> &'static NumericTable {
        static CELLS: [OnceLock<NumericTable>; 4] = [
            OnceLock::new(),
            OnceLock::new(),
            OnceLock::new(),
            OnceLock::new(),
        ];
        let idx = CmfTable::ALL.iter().position(|&c| c == self).unwrap_or(0);
        CELLS[idx]
            .get_or_init(|| parse_embedded(self.csv(), &format!("calib/cmfs/{}.csv", self.key())))
    }
}

/// Parses an embedded table; the tables are checked by tests, so a failure is a build defect.
fn parse_embedded(text: &str, source: &str) -> NumericTable {
    match parse_numeric_csv(text.as_bytes(), source) {
        Ok(t) => t,
        // Unreachable for shipped data (tests parse every embedded table); keep the binary
        // usable by returning an empty table that downstream validation rejects with the name.
        Err(_) => NumericTable {
            source: source.to_string(),
            header: vec!["wavelength_nm".into(), "value".into()],
            columns: vec![Vec::new(), Vec::new()],
            lines: Vec::new(),
        },
    }
}

/// Embedded illuminant spectra: (colour's name, CSV text).
pub const ILLUMINANTS: &[(&str, &str)] = &[
    ("A", include_str!("../calib/illuminants/A.csv")),
    ("C", include_str!("../calib/illuminants/C.csv")),
    ("D50", include_str!("../calib/illuminants/D50.csv")),
    ("D55", include_str!("../calib/illuminants/D55.csv")),
    ("D60", include_str!("../calib/illuminants/D60.csv")),
    ("D65", include_str!("../calib/illuminants/D65.csv")),
    ("D75", include_str!("../calib/illuminants/D75.csv")),
    ("E", include_str!("../calib/illuminants/E.csv")),
    ("FL1", include_str!("../calib/illuminants/FL1.csv")),
    ("FL2", include_str!("../calib/illuminants/FL2.csv")),
    ("FL3", include_str!("../calib/illuminants/FL3.csv")),
    ("FL4", include_str!("../calib/illuminants/FL4.csv")),
    ("FL5", include_str!("../calib/illuminants/FL5.csv")),
    ("FL6", include_str!("../calib/illuminants/FL6.csv")),
    ("FL7", include_str!("../calib/illuminants/FL7.csv")),
    ("FL8", include_str!("../calib/illuminants/FL8.csv")),
    ("FL9", include_str!("../calib/illuminants/FL9.csv")),
    ("FL10", include_str!("../calib/illuminants/FL10.csv")),
    ("FL11", include_str!("../calib/illuminants/FL11.csv")),
    ("FL12", include_str!("../calib/illuminants/FL12.csv")),
    ("HP1", include_str!("../calib/illuminants/HP1.csv")),
    ("HP2", include_str!("../calib/illuminants/HP2.csv")),
    ("HP3", include_str!("../calib/illuminants/HP3.csv")),
    ("HP4", include_str!("../calib/illuminants/HP4.csv")),
    ("HP5", include_str!("../calib/illuminants/HP5.csv")),
    ("LED-B1", include_str!("../calib/illuminants/LED-B1.csv")),
    ("LED-B2", include_str!("../calib/illuminants/LED-B2.csv")),
    ("LED-B3", include_str!("../calib/illuminants/LED-B3.csv")),
    ("LED-B4", include_str!("../calib/illuminants/LED-B4.csv")),
    ("LED-B5", include_str!("../calib/illuminants/LED-B5.csv")),
];

/// Names of the embedded illuminants, in colour's spelling.
pub fn illuminant_names() -> Vec<&'static str> {
    ILLUMINANTS.iter().map(|(n, _)| *n).collect()
}

/// The parsed table `wavelength_nm,relative_power` of a named illuminant (case-insensitive).
pub fn illuminant_table(name: &str) -> Result<&'static NumericTable> {
    static CELLS: OnceLock<Vec<NumericTable>> = OnceLock::new();
    let tables = CELLS.get_or_init(|| {
        ILLUMINANTS
            .iter()
            .map(|(n, text)| parse_embedded(text, &format!("calib/illuminants/{n}.csv")))
            .collect()
    });
    let idx = ILLUMINANTS
        .iter()
        .position(|(n, _)| n.eq_ignore_ascii_case(name))
        .ok_or_else(|| Error::UnknownName {
            kind: "illuminant",
            name: name.to_string(),
            expected: illuminant_names().join(", "),
        })?;
    Ok(&tables[idx])
}

/// The CIE D-series basis `wavelength_nm,S0,S1,S2` (300–830 nm, 5 nm).
pub fn d_series_basis() -> &'static NumericTable {
    static CELL: OnceLock<NumericTable> = OnceLock::new();
    CELL.get_or_init(|| {
        parse_embedded(
            include_str!("../calib/d_series_basis.csv"),
            "calib/d_series_basis.csv",
        )
    })
}

/// The CSV text of `calib/colorchecker_n_ohta.csv` (for provenance hashes).
pub const COLORCHECKER_N_OHTA_CSV: &str = include_str!("../calib/colorchecker_n_ohta.csv");

/// The 24 ColorChecker reflectances of colour's "ColorChecker N Ohta" (380–780 nm, 5 nm).
pub fn colorchecker_n_ohta() -> &'static NumericTable {
    static CELL: OnceLock<NumericTable> = OnceLock::new();
    CELL.get_or_init(|| parse_embedded(COLORCHECKER_N_OHTA_CSV, "calib/colorchecker_n_ohta.csv"))
}

/// One RGB colour space as exported from colour.
#[derive(Debug, Clone, Deserialize)]
pub struct RgbSpaceData {
    /// colour's name for the space.
    pub colour_name: String,
    /// Chromaticities of the R, G, B primaries.
    pub primaries_xy: [[f64; 2]; 3],
    /// Chromaticity of the white point.
    pub whitepoint_xy: [f64; 2],
    /// Name of the white point (`D65`, `ACES`).
    pub whitepoint_name: String,
    /// Transfer function key: `srgb`, `rec2020` or `linear`.
    pub transfer: String,
    /// colour's normalised primary matrix (RGB → XYZ), for cross-checking.
    pub matrix_rgb_to_xyz: [[f64; 3]; 3],
}

/// The content of `calib/colourspaces.json`.
#[derive(Debug, Clone, Deserialize)]
pub struct ColourspaceData {
    /// Versions of colour and numpy used to export.
    pub source: String,
    /// colour's `CCS_ILLUMINANTS`: observer key → illuminant name → xy.
    pub white_chromaticities_xy: BTreeMap<String, BTreeMap<String, [f64; 2]>>,
    /// RGB spaces by lumifit key (`srgb`, `display-p3`, `rec2020`, `acescg`).
    pub rgb_colourspaces: BTreeMap<String, RgbSpaceData>,
}

/// Parsed `calib/colourspaces.json`.
pub fn colourspaces() -> &'static ColourspaceData {
    static CELL: OnceLock<ColourspaceData> = OnceLock::new();
    CELL.get_or_init(|| {
        serde_json::from_str(include_str!("../calib/colourspaces.json")).unwrap_or_else(|_| {
            ColourspaceData {
                source: "invalid calib/colourspaces.json".into(),
                white_chromaticities_xy: BTreeMap::new(),
                rgb_colourspaces: BTreeMap::new(),
            }
        })
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_embedded_table_parses() {
        for c in CmfTable::ALL {
            assert!(c.table().n_rows() > 400, "{:?}", c);
        }
        for n in illuminant_names() {
            assert!(illuminant_table(n).unwrap().n_rows() > 50, "{n}");
        }
        assert_eq!(d_series_basis().header.len(), 4);
        assert_eq!(colorchecker_n_ohta().header.len(), 25);
        assert_eq!(colourspaces().rgb_colourspaces.len(), 4);
    }
}
