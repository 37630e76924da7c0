//! Illuminants as run-time values: a name and a relative spectral power distribution.
//!
//! The CIE illuminants A, C, D50–D75, E, FL1–FL12, HP1–HP5 and LED-B1–B5 are embedded from
//! colour-science (`calib/illuminants/`); any spectrum can serve as an illuminant.
//!
//! An illuminant remembers how it is to be interpolated when aligned to an observer's grid: the
//! embedded CIE illuminants linearly (as colour's `SDS_ILLUMINANTS` and CIE 015 recommend), user
//! spectra with colour's default (Sprague on uniform grids, cubic spline otherwise).

use crate::calib;
use crate::error::Result;
use crate::math::interpolation::Interpolator;
use crate::spectrum::Spectrum;

/// A named illuminant.
#[derive(Debug, Clone, PartialEq)]
pub struct Illuminant {
    name: String,
    sd: Spectrum,
    interpolator: Interpolator,
}

impl Illuminant {
    /// An embedded CIE illuminant by colour's name (case-insensitive): `D65`, `A`, `FL2`, `LED-B3` …
    pub fn standard(name: &str) -> Result<Illuminant> {
        let table = calib::illuminant_table(name)?;
        let canonical = calib::illuminant_names()
            .into_iter()
            .find(|n| n.eq_ignore_ascii_case(name))
            .unwrap_or(name);
        let sd = Spectrum::from_table(table, 1)?.with_name(canonical);
        Ok(Illuminant {
            name: canonical.to_string(),
            sd,
            interpolator: Interpolator::Linear,
        })
    }

    /// Any spectrum used as an illuminant.
    pub fn from_spectrum(name: impl Into<String>, sd: Spectrum) -> Illuminant {
        Illuminant {
            name: name.into(),
            sd,
            interpolator: Interpolator::Default,
        }
    }

    /// The same illuminant, interpolated with `interpolator` when aligned.
    pub fn with_interpolator(mut self, interpolator: Interpolator) -> Illuminant {
        self.interpolator = interpolator;
        self
    }

    /// How the illuminant is interpolated onto other grids.
    pub fn interpolator(&self) -> Interpolator {
        self.interpolator
    }

    /// The illuminant's name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Its relative spectral power distribution.
    pub fn spectrum(&self) -> &Spectrum {
        &self.sd
    }

    /// Names of the embedded illuminants.
    pub fn standard_names() -> Vec<&'static str> {
        calib::illuminant_names()
    }
}
