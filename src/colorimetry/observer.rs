//! Standard observers (colour-matching functions) as run-time values.
//!
//! An [`Observer`] is a name plus three colour-matching functions x̄, ȳ, z̄ on one wavelength grid.
//! The four CIE observers are embedded (`calib/cmfs/`, exported from colour-science); any other
//! set of CMFs can be loaded from CSV. Quantities computed with different observers must not be
//! mixed: [`super::Tristimulus`] carries the observer's name and refuses to combine with another.

use std::sync::OnceLock;

use crate::calib::CmfTable;
use crate::error::{Error, Result};
use crate::spectrum::MultiSpectrum;

/// The embedded CIE standard observers, named as on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum StandardObserver {
    /// CIE 1931 2° (`cie1931-2`), colour's default.
    Cie1931_2,
    /// CIE 1964 10° (`cie1964-10`).
    Cie1964_10,
    /// CIE 2006 2° XYZ, called "CIE 2015 2 Degree Standard Observer" by colour (`cie2015-2`).
    Cie2015_2,
    /// CIE 2006 10° XYZ, called "CIE 2015 10 Degree Standard Observer" by colour (`cie2015-10`).
    Cie2015_10,
}

impl StandardObserver {
    /// All standard observers.
    pub const ALL: [StandardObserver; 4] = [
        StandardObserver::Cie1931_2,
        StandardObserver::Cie1964_10,
        StandardObserver::Cie2015_2,
        StandardObserver::Cie2015_10,
    ];

    /// The command-line name (`cie1931-2`, …).
    pub fn cli_name(self) -> &'static str {
        match self {
            StandardObserver::Cie1931_2 => "cie1931-2",
            StandardObserver::Cie1964_10 => "cie1964-10",
            StandardObserver::Cie2015_2 => "cie2015-2",
            StandardObserver::Cie2015_10 => "cie2015-10",
        }
    }

    /// colour-science's name for the observer.
    pub fn colour_name(self) -> &'static str {
        match self {
            StandardObserver::Cie1931_2 => "CIE 1931 2 Degree Standard Observer",
            StandardObserver::Cie1964_10 => "CIE 1964 10 Degree Standard Observer",
            StandardObserver::Cie2015_2 => "CIE 2015 2 Degree Standard Observer",
            StandardObserver::Cie2015_10 => "CIE 2015 10 Degree Standard Observer",
        }
    }

    /// Parses a command-line or colour name (case-insensitive; `cie2006-2` is accepted for
    /// `cie2015-2`).
    pub fn from_name(name: &str) -> Result<Self> {
        let n = name.trim().to_ascii_lowercase();
        for o in Self::ALL {
            if n == o.cli_name() || n == o.colour_name().to_ascii_lowercase() {
                return Ok(o);
            }
        }
        match n.as_str() {
            "cie2006-2" => Ok(StandardObserver::Cie2015_2),
            "cie2006-10" => Ok(StandardObserver::Cie2015_10),
            _ => Err(Error::UnknownName {
                kind: "observer",
                name: name.to_string(),
                expected: Self::ALL.map(|o| o.cli_name()).join(", "),
            }),
        }
    }

    fn table(self) -> CmfTable {
        match self {
            StandardObserver::Cie1931_2 => CmfTable::Cie1931_2,
            StandardObserver::Cie1964_10 => CmfTable::Cie1964_10,
            StandardObserver::Cie2015_2 => CmfTable::Cie2015_2,
            StandardObserver::Cie2015_10 => CmfTable::Cie2015_10,
        }
    }
}

/// A standard observer: a name and its colour-matching functions.
#[derive(Debug, Clone, PartialEq)]
pub struct Observer {
    name: String,
    cmfs: MultiSpectrum,
}

impl Observer {
    /// One of the embedded CIE observers (parsed once, then shared).
    pub fn standard(which: StandardObserver) -> Result<&'static Observer> {
        static CELLS: [OnceLock<Option<Observer>>; 4] = [
            OnceLock::new(),
            OnceLock::new(),
            OnceLock::new(),
            OnceLock::new(),
        ];
        let idx = StandardObserver::ALL
            .iter()
            .position(|&o| o == which)
            .unwrap_or(0);
        let cell = CELLS[idx].get_or_init(|| {
            let t = which.table().table();
            MultiSpectrum::new(
                which.colour_name(),
                t.columns[0].clone(),
                vec!["x_bar".into(), "y_bar".into(), "z_bar".into()],
                t.columns[1..4].to_vec(),
            )
            .ok()
            .map(|cmfs| Observer {
                name: which.cli_name().to_string(),
                cmfs,
            })
        });
        cell.as_ref().ok_or_else(|| Error::InvalidSpectrum {
            name: format!("calib/cmfs/{}.csv", which.table().key()),
            reason: "embedded table is invalid (build defect)".into(),
        })
    }

    /// An observer from user CMFs: exactly three channels (x̄, ȳ, z̄), uniform 1 nm or coarser grid.
    pub fn from_cmfs(name: impl Into<String>, cmfs: MultiSpectrum) -> Result<Observer> {
        if cmfs.n_channels() != 3 {
            return Err(Error::ShapeMismatch {
                what: format!(
                    "colour-matching functions '{}' (x_bar,y_bar,z_bar)",
                    cmfs.name()
                ),
                expected: 3,
                got: cmfs.n_channels(),
            });
        }
        Ok(Observer {
            name: name.into(),
            cmfs,
        })
    }

    /// The observer's name (`cie1931-2` for the standard ones); used to detect mixing.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The colour-matching functions.
    pub fn cmfs(&self) -> &MultiSpectrum {
        &self.cmfs
    }
}
