//! Lamp line lists.
//!
//! Mercury: NIST Atomic Spectra Database, Hg I persistent lines in air (nm): 404.656, 407.783,
//! 435.833, 546.074, 576.960, 579.066. Compact fluorescent lamps add the emission lines of their
//! rare-earth phosphors (Tb³⁺ 487.7, 542.4, 625.7 nm; Eu³⁺ in Y₂O₃ 587.6, 593.4, 599.7, 611.6,
//! 631.1, 650.8, 707.0, 709.0, 712.3 nm), as commonly identified in CFL spectra. The relative
//! powers are only used to render synthetic captures (the calibration fits one amplitude per
//! line and channel); they are rough typical values, not measurements.

use crate::error::{Error, Result};
use crate::table::NumericTable;

/// One emission line.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct LampLine {
    /// Wavelength in air, nm.
    pub nm: f64,
    /// Relative power (synthetic rendering only).
    pub relative_power: f64,
}

/// A lamp: a name and its lines, sorted by wavelength.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Lamp {
    /// Name (`hg`, `cfl`, or the file it came from).
    pub name: String,
    /// Lines by increasing wavelength.
    pub lines: Vec<LampLine>,
}

const HG: &[(f64, f64)] = &[
    (404.656, 0.40),
    (407.783, 0.04),
    (435.833, 1.00),
    (546.074, 0.90),
    (576.960, 0.20),
    (579.066, 0.22),
];

const CFL_PHOSPHOR: &[(f64, f64)] = &[
    (487.7, 0.30),
    (542.4, 1.00),
    (587.6, 0.10),
    (593.4, 0.07),
    (599.7, 0.05),
    (611.6, 0.90),
    (625.7, 0.06),
    (631.1, 0.14),
    (650.8, 0.05),
    (707.0, 0.04),
    (709.0, 0.02),
    (712.3, 0.03),
];

impl Lamp {
    fn from_pairs(name: &str, pairs: impl Iterator<Item = (f64, f64)>) -> Self {
        let mut lines: Vec<LampLine> = pairs
            .map(|(nm, p)| LampLine {
                nm,
                relative_power: p,
            })
            .collect();
        lines.sort_by(|a, b| a.nm.total_cmp(&b.nm));
        Self {
            name: name.into(),
            lines,
        }
    }

    /// Low-pressure mercury lamp (NIST Hg I lines).
    pub fn mercury() -> Self {
        Self::from_pairs("hg", HG.iter().copied())
    }

    /// Mercury with weak violet lines (404.7 and 407.8 nm at 1/20 of their usual power, as
    /// behind a UV-blocking envelope or at low camera sensitivity): the calibration must not
    /// lean on them.
    pub fn mercury_weak_violet() -> Self {
        Self::from_pairs(
            "hg-weak",
            HG.iter()
                .map(|&(nm, p)| (nm, if nm < 420.0 { p / 20.0 } else { p })),
        )
    }

    /// Compact fluorescent lamp: mercury plus Tb³⁺/Eu³⁺ phosphor lines. Mercury lines are weaker
    /// relative to the phosphors than in a bare mercury lamp.
    pub fn cfl() -> Self {
        Self::from_pairs(
            "cfl",
            HG.iter()
                .map(|&(nm, p)| (nm, 0.5 * p))
                .chain(CFL_PHOSPHOR.iter().copied()),
        )
    }

    /// A lamp from a table whose first column is the wavelength in nm and whose optional second
    /// column is the relative power (default 1).
    ///
    /// # Errors
    /// [`Error::Parse`] for wavelengths outside 200–1100 nm or negative powers.
    pub fn from_table(table: &NumericTable) -> Result<Self> {
        let Some(wl) = table.columns.first() else {
            return Err(Error::parse(
                &table.source,
                0,
                "no columns; expected wavelength_nm[,relative_power]",
            ));
        };
        let mut pairs = Vec::new();
        for (i, &nm) in wl.iter().enumerate() {
            let p = table.columns.get(1).map_or(1.0, |c| c[i]);
            if !(200.0..=1100.0).contains(&nm) || p < 0.0 {
                return Err(Error::parse(
                    &table.source,
                    table.lines[i],
                    format!("line {nm} nm with power {p}: expected 200–1100 nm and a non-negative power"),
                ));
            }
            pairs.push((nm, p));
        }
        if pairs.is_empty() {
            return Err(Error::parse(&table.source, 0, "no lines listed"));
        }
        Ok(Self::from_pairs(&table.source, pairs.into_iter()))
    }
}
