//! Sampled spectral distributions.
//!
//! A [`Spectrum`] is one quantity sampled at strictly increasing wavelengths (nm), uniform or not;
//! a [`MultiSpectrum`] is several quantities on one grid (colour-matching functions, camera
//! sensitivities, filter banks). Both are validated on construction: at least one sample, equal
//! lengths, strictly increasing finite wavelengths, finite values.
//!
//! Reshaping follows colour-science (`colour.SpectralDistribution.align/interpolate/trim`):
//! Sprague interpolation on uniform grids, a not-a-knot cubic spline otherwise, and constant
//! extrapolation. The one deliberate difference: [`Spectrum::align`] always returns exactly the
//! requested grid, where colour keeps the source's off-grid samples when the two grids are offset
//! (a case in which colour's own integration then fails).

use crate::error::{Error, Result};
use crate::math::interpolation::{self, Interpolator};
use crate::table::NumericTable;

/// A regular wavelength grid `start_nm, start_nm + interval_nm, …, end_nm`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpectralShape {
    /// First wavelength (nm).
    pub start_nm: f64,
    /// Last wavelength (nm).
    pub end_nm: f64,
    /// Step (nm).
    pub interval_nm: f64,
}

impl SpectralShape {
    /// A validated shape: finite, `start < end`, positive interval.
    pub fn new(start_nm: f64, end_nm: f64, interval_nm: f64) -> Result<Self> {
        if !(start_nm.is_finite() && end_nm.is_finite() && interval_nm.is_finite()) {
            return Err(Error::invalid("spectral shape", "values must be finite"));
        }
        if start_nm >= end_nm || interval_nm <= 0.0 {
            return Err(Error::invalid(
                "spectral shape",
                format!(
                    "expected start < end and interval > 0, got {start_nm}:{end_nm}:{interval_nm}"
                ),
            ));
        }
        Ok(SpectralShape {
            start_nm,
            end_nm,
            interval_nm,
        })
    }

    /// The wavelengths of the grid, computed as colour's `SpectralShape.range()`:
    /// `linspace(start, end, round((interval + end - start) / interval))`.
    pub fn wavelengths(&self) -> Vec<f64> {
        let n =
            ((self.interval_nm + self.end_nm - self.start_nm) / self.interval_nm).round() as usize;
        linspace(self.start_nm, self.end_nm, n.max(1))
    }
}

impl std::fmt::Display for SpectralShape {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{}–{} nm every {} nm",
            self.start_nm, self.end_nm, self.interval_nm
        )
    }
}

/// numpy.linspace: `start + i·step` with the last value forced to `end`.
pub fn linspace(start: f64, end: f64, n: usize) -> Vec<f64> {
    if n == 1 {
        return vec![start];
    }
    let step = (end - start) / (n - 1) as f64;
    let mut v: Vec<f64> = (0..n).map(|i| start + i as f64 * step).collect();
    v[n - 1] = end;
    v
}

fn validate_wavelengths(name: &str, wavelengths_nm: &[f64]) -> Result<()> {
    if wavelengths_nm.is_empty() {
        return Err(Error::InvalidSpectrum {
            name: name.into(),
            reason: "no samples; expected at least one wavelength".into(),
        });
    }
    for (i, w) in wavelengths_nm.iter().enumerate() {
        if !w.is_finite() {
            return Err(Error::InvalidSpectrum {
                name: name.into(),
                reason: format!(
                    "wavelength #{} is {w}; expected a finite number of nm",
                    i + 1
                ),
            });
        }
    }
    for (i, p) in wavelengths_nm.windows(2).enumerate() {
        if p[1] <= p[0] {
            return Err(Error::InvalidSpectrum {
                name: name.into(),
                reason: format!(
                    "wavelengths must be strictly increasing, but sample #{} ({} nm) follows {} nm",
                    i + 2,
                    p[1],
                    p[0]
                ),
            });
        }
    }
    Ok(())
}

/// Shape of a sampled grid as colour reports it: first, last and the *smallest* interval.
fn grid_shape(w: &[f64]) -> SpectralShape {
    let n = w.len();
    let interval = w
        .windows(2)
        .map(|p| p[1] - p[0])
        .fold(f64::INFINITY, f64::min);
    SpectralShape {
        start_nm: w[0],
        end_nm: w[n - 1],
        interval_nm: if interval.is_finite() { interval } else { 1.0 },
    }
}

/// Wavelengths of `target` that lie within `[lo, hi]` (colour's interpolate range clipping).
fn trim_indices(w: &[f64], lo: f64, hi: f64) -> (usize, usize) {
    let a = w.partition_point(|&x| x < lo);
    let b = w.partition_point(|&x| x <= hi);
    (a, b.max(a))
}

/// One quantity sampled over wavelength.
#[derive(Debug, Clone, PartialEq)]
pub struct Spectrum {
    name: String,
    wavelengths_nm: Vec<f64>,
    values: Vec<f64>,
}

impl Spectrum {
    /// Builds a validated spectrum. `name` appears in every error about it.
    pub fn new(
        name: impl Into<String>,
        wavelengths_nm: Vec<f64>,
        values: Vec<f64>,
    ) -> Result<Self> {
        let name = name.into();
        validate_wavelengths(&name, &wavelengths_nm)?;
        if values.len() != wavelengths_nm.len() {
            return Err(Error::ShapeMismatch {
                what: format!("values of '{name}'"),
                expected: wavelengths_nm.len(),
                got: values.len(),
            });
        }
        if let Some((i, v)) = values.iter().enumerate().find(|(_, v)| !v.is_finite()) {
            return Err(Error::InvalidSpectrum {
                name,
                reason: format!(
                    "value at {} nm is {v}; expected a finite number",
                    wavelengths_nm[i]
                ),
            });
        }
        Ok(Spectrum {
            name,
            wavelengths_nm,
            values,
        })
    }

    /// A spectrum on a regular grid.
    pub fn from_shape(
        name: impl Into<String>,
        shape: &SpectralShape,
        values: Vec<f64>,
    ) -> Result<Self> {
        Spectrum::new(name, shape.wavelengths(), values)
    }

    /// Builds from a table: wavelengths from the first column, values from column `column`.
    pub fn from_table(table: &NumericTable, column: usize) -> Result<Self> {
        let name = format!(
            "{} ({})",
            table.source,
            table.header.get(column).map_or("?", |s| s)
        );
        check_table_wavelengths(table)?;
        Spectrum::new(
            name,
            table.columns[0].clone(),
            table.columns[column].clone(),
        )
    }

    /// Name given at construction.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// A copy with another name.
    pub fn with_name(mut self, name: impl Into<String>) -> Self {
        self.name = name.into();
        self
    }

    /// Sample wavelengths (nm).
    pub fn wavelengths(&self) -> &[f64] {
        &self.wavelengths_nm
    }

    /// Sample values.
    pub fn values(&self) -> &[f64] {
        &self.values
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.values.len()
    }

    /// Always false: a spectrum has at least one sample.
    pub fn is_empty(&self) -> bool {
        self.values.is_empty()
    }

    /// First, last and smallest interval (colour's `SpectralDistribution.shape`).
    pub fn shape(&self) -> SpectralShape {
        grid_shape(&self.wavelengths_nm)
    }

    /// True when the samples are equally spaced.
    pub fn is_uniform(&self) -> bool {
        interpolation::is_uniform(&self.wavelengths_nm)
    }

    /// Values at arbitrary wavelengths, interpolated inside the range and held constant outside.
    pub fn values_at(&self, wavelengths_nm: &[f64], method: Interpolator) -> Result<Vec<f64>> {
        interpolation::resample(&self.wavelengths_nm, &self.values, wavelengths_nm, method)
    }

    /// colour's `interpolate`: the samples of `shape` that lie within this spectrum's range.
    pub fn interpolate(&self, shape: &SpectralShape, method: Interpolator) -> Result<Spectrum> {
        let s = self.shape();
        let lo = shape.start_nm.max(s.start_nm);
        let hi = shape.end_nm.min(s.end_nm);
        let target = SpectralShape::new(lo, hi, shape.interval_nm)
            .map(|t| t.wavelengths())
            .unwrap_or_else(|_| vec![lo]);
        let values = self.values_at(&target, method)?;
        self.derived_finite(&values)?;
        Spectrum::new(self.name.clone(), target, values)
    }

    /// A spectrum derived from finite values (interpolated, resampled) that is no longer finite
    /// overflowed: say so, naming this spectrum, instead of blaming a NaN the input never had.
    fn derived_finite(&self, values: &[f64]) -> Result<()> {
        crate::error::ensure_finite(
            "the spectrum interpolated to the working grid",
            &format!("'{}' (values near ±1.8e308 overflow)", self.name),
            values,
        )
    }

    /// colour's `align`: exactly the grid of `shape`, interpolated inside this spectrum's range and
    /// extrapolated with the end values outside.
    pub fn align(&self, shape: &SpectralShape, method: Interpolator) -> Result<Spectrum> {
        self.resample(&shape.wavelengths(), method)
    }

    /// Resamples onto arbitrary strictly increasing wavelengths (constant extrapolation).
    pub fn resample(&self, wavelengths_nm: &[f64], method: Interpolator) -> Result<Spectrum> {
        if wavelengths_nm == self.wavelengths_nm.as_slice() {
            return Ok(self.clone());
        }
        let values = self.values_at(wavelengths_nm, method)?;
        self.derived_finite(&values)?;
        Spectrum::new(self.name.clone(), wavelengths_nm.to_vec(), values)
    }

    /// colour's `trim`: keeps the samples within `[shape.start_nm, shape.end_nm]`.
    pub fn trim(&self, shape: &SpectralShape) -> Result<Spectrum> {
        let (a, b) = trim_indices(&self.wavelengths_nm, shape.start_nm, shape.end_nm);
        Spectrum::new(
            self.name.clone(),
            self.wavelengths_nm[a..b].to_vec(),
            self.values[a..b].to_vec(),
        )
    }

    /// Multiplies every value by `factor`.
    pub fn scaled(&self, factor: f64) -> Spectrum {
        Spectrum {
            name: self.name.clone(),
            wavelengths_nm: self.wavelengths_nm.clone(),
            values: self.values.iter().map(|v| v * factor).collect(),
        }
    }

    /// Trapezoidal integral over the sampled range (value·nm).
    pub fn integrate(&self) -> f64 {
        trapezoid(&self.wavelengths_nm, &self.values)
    }
}

/// Trapezoidal rule over a possibly non-uniform grid.
pub fn trapezoid(x: &[f64], y: &[f64]) -> f64 {
    x.windows(2)
        .zip(y.windows(2))
        .map(|(xw, yw)| 0.5 * (xw[1] - xw[0]) * (yw[0] + yw[1]))
        .sum()
}

fn check_table_wavelengths(table: &NumericTable) -> Result<()> {
    for (i, w) in table.columns[0].windows(2).enumerate() {
        if w[1] <= w[0] {
            return Err(Error::parse(
                table.source.clone(),
                table.lines[i + 1],
                format!(
                    "wavelengths must be strictly increasing: {} nm follows {} nm",
                    w[1], w[0]
                ),
            ));
        }
    }
    Ok(())
}

/// Several quantities sampled on one wavelength grid (CMFs, camera sensitivities, filter banks).
#[derive(Debug, Clone, PartialEq)]
pub struct MultiSpectrum {
    name: String,
    wavelengths_nm: Vec<f64>,
    labels: Vec<String>,
    channels: Vec<Vec<f64>>,
}

impl MultiSpectrum {
    /// Builds a validated multi-spectral distribution; `channels[c][i]` is channel `c` at
    /// wavelength `i`.
    pub fn new(
        name: impl Into<String>,
        wavelengths_nm: Vec<f64>,
        labels: Vec<String>,
        channels: Vec<Vec<f64>>,
    ) -> Result<Self> {
        let name = name.into();
        validate_wavelengths(&name, &wavelengths_nm)?;
        if labels.len() != channels.len() || channels.is_empty() {
            return Err(Error::ShapeMismatch {
                what: format!("channel labels of '{name}'"),
                expected: channels.len(),
                got: labels.len(),
            });
        }
        for (c, ch) in channels.iter().enumerate() {
            if ch.len() != wavelengths_nm.len() {
                return Err(Error::ShapeMismatch {
                    what: format!("channel '{}' of '{name}'", labels[c]),
                    expected: wavelengths_nm.len(),
                    got: ch.len(),
                });
            }
            if let Some((i, v)) = ch.iter().enumerate().find(|(_, v)| !v.is_finite()) {
                return Err(Error::InvalidSpectrum {
                    name,
                    reason: format!(
                        "channel '{}' at {} nm is {v}; expected a finite number",
                        labels[c], wavelengths_nm[i]
                    ),
                });
            }
        }
        Ok(MultiSpectrum {
            name,
            wavelengths_nm,
            labels,
            channels,
        })
    }

    /// Builds from a table: wavelengths from the first column, one channel per other column.
    pub fn from_table(table: &NumericTable) -> Result<Self> {
        check_table_wavelengths(table)?;
        MultiSpectrum::new(
            table.source.clone(),
            table.columns[0].clone(),
            table.header[1..].to_vec(),
            table.columns[1..].to_vec(),
        )
    }

    /// Name given at construction.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Sample wavelengths (nm).
    pub fn wavelengths(&self) -> &[f64] {
        &self.wavelengths_nm
    }

    /// Channel labels.
    pub fn labels(&self) -> &[String] {
        &self.labels
    }

    /// Channel `c`'s values.
    pub fn channel(&self, c: usize) -> &[f64] {
        &self.channels[c]
    }

    /// All channels.
    pub fn channels(&self) -> &[Vec<f64>] {
        &self.channels
    }

    /// Number of channels.
    pub fn n_channels(&self) -> usize {
        self.channels.len()
    }

    /// Number of wavelengths.
    pub fn len(&self) -> usize {
        self.wavelengths_nm.len()
    }

    /// Always false: validated distributions have samples.
    pub fn is_empty(&self) -> bool {
        self.wavelengths_nm.is_empty()
    }

    /// First, last and smallest interval.
    pub fn shape(&self) -> SpectralShape {
        grid_shape(&self.wavelengths_nm)
    }

    /// True when the samples are equally spaced.
    pub fn is_uniform(&self) -> bool {
        interpolation::is_uniform(&self.wavelengths_nm)
    }

    /// Channel `c` as a [`Spectrum`].
    pub fn to_spectrum(&self, c: usize) -> Spectrum {
        Spectrum {
            name: format!("{} ({})", self.name, self.labels[c]),
            wavelengths_nm: self.wavelengths_nm.clone(),
            values: self.channels[c].clone(),
        }
    }

    /// Resamples every channel onto `wavelengths_nm` (constant extrapolation).
    pub fn resample(&self, wavelengths_nm: &[f64], method: Interpolator) -> Result<MultiSpectrum> {
        if wavelengths_nm == self.wavelengths_nm.as_slice() {
            return Ok(self.clone());
        }
        let channels = self
            .channels
            .iter()
            .map(|ch| interpolation::resample(&self.wavelengths_nm, ch, wavelengths_nm, method))
            .collect::<Result<Vec<_>>>()?;
        MultiSpectrum::new(
            self.name.clone(),
            wavelengths_nm.to_vec(),
            self.labels.clone(),
            channels,
        )
    }

    /// colour's `align` onto `shape`.
    pub fn align(&self, shape: &SpectralShape, method: Interpolator) -> Result<MultiSpectrum> {
        self.resample(&shape.wavelengths(), method)
    }

    /// colour's `trim`.
    pub fn trim(&self, shape: &SpectralShape) -> Result<MultiSpectrum> {
        let (a, b) = trim_indices(&self.wavelengths_nm, shape.start_nm, shape.end_nm);
        MultiSpectrum::new(
            self.name.clone(),
            self.wavelengths_nm[a..b].to_vec(),
            self.labels.clone(),
            self.channels.iter().map(|c| c[a..b].to_vec()).collect(),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decreasing_wavelengths_are_rejected_with_the_sample_named() {
        let e = Spectrum::new("s", vec![400.0, 410.0, 405.0], vec![1.0; 3]).unwrap_err();
        assert!(e.to_string().contains("sample #3"), "{e}");
    }

    #[test]
    fn colour_shape_range_matches_linspace() {
        let s = SpectralShape::new(360.0, 830.0, 1.0).unwrap();
        let w = s.wavelengths();
        assert_eq!(w.len(), 471);
        assert_eq!(w[470], 830.0);
    }

    #[test]
    fn align_extends_with_end_values_and_keeps_nodes() {
        let w: Vec<f64> = (0..10).map(|i| 400.0 + 10.0 * i as f64).collect();
        let v: Vec<f64> = (0..10).map(|i| i as f64).collect();
        let s = Spectrum::new("s", w, v).unwrap();
        let a = s
            .align(
                &SpectralShape::new(380.0, 500.0, 5.0).unwrap(),
                Interpolator::Default,
            )
            .unwrap();
        assert_eq!(a.values()[0], 0.0);
        assert_eq!(*a.values().last().unwrap(), 9.0);
        assert!((a.values()[4] - 0.0).abs() < 1e-12); // 400 nm
        assert!((a.values()[6] - 1.0).abs() < 1e-12); // 410 nm
    }
}
