//! The band file `lvf_bands.json`: the [`BandSet`] type, written and read through serde.

#![allow(clippy::needless_range_loop)]

use super::*;

/// How each band's transmission is modelled.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum BandModel {
    /// Free shape on the grid: non-negative, smoothness-regularised, support window.
    Nnls,
    /// Free shape on the grid by plain least squares (support window only; the baseline).
    Lstsq,
    /// Window-averaged Gaussian passband: centre shift, FWHM, peak.
    Gaussian,
    /// Window-averaged super-Gaussian passband: centre shift, FWHM, exponent, peak.
    SuperGaussian,
    /// From the wavelength calibration alone: centre from the map, FWHM from the lamp fit, peak 1.
    Calibration,
}

impl BandModel {
    /// The name used in files and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            BandModel::Nnls => "nnls",
            BandModel::Lstsq => "lstsq",
            BandModel::Gaussian => "gaussian",
            BandModel::SuperGaussian => "super-gaussian",
            BandModel::Calibration => "calibration",
        }
    }
}

/// One band's solved transmission and its summary (written and read by serde: optional fields
/// may be `null` or absent, `std` absent or `null` reads as zeros).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BandTransmission {
    /// Nominal wavelength of the band (nm, from the calibration).
    pub nm: f64,
    /// Band centre position (px).
    pub px: f64,
    /// Window width (px).
    pub width_px: f64,
    /// Fitted centre (nm): window-mean λ + δ for parametric models, centroid of T for `nnls`/`lstsq`.
    pub centre_nm: f64,
    /// Standard uncertainty of the centre (nm), when known.
    #[serde(default)]
    pub centre_sigma_nm: Option<f64>,
    /// Passband FWHM (nm): the fitted passband's own width for parametric models, the effective
    /// width of T for `nnls`/`lstsq`.
    pub fwhm_nm: f64,
    /// Standard uncertainty of `fwhm_nm` (nm), when known.
    #[serde(default)]
    pub fwhm_sigma_nm: Option<f64>,
    /// Half-maximum width of T_j itself (window-widened; nm).
    pub effective_fwhm_nm: f64,
    /// Standard uncertainty of the effective FWHM (nm), when known.
    #[serde(default)]
    pub effective_fwhm_sigma_nm: Option<f64>,
    /// Peak of T_j (relative units; includes the exposure).
    pub peak: f64,
    /// Standard uncertainty of the peak, when known.
    #[serde(default)]
    pub peak_sigma: Option<f64>,
    /// Super-Gaussian exponent e (1 for a Gaussian), for parametric models.
    #[serde(default)]
    pub exponent: Option<f64>,
    /// Standard uncertainty of the exponent, when fitted.
    #[serde(default)]
    pub exponent_sigma: Option<f64>,
    /// T_j on the set's `grid_nm`.
    pub transmission: Vec<f64>,
    /// Standard uncertainty of T_j on `grid_nm` (noise part).
    #[serde(default, deserialize_with = "null_as_empty")]
    pub std: Vec<f64>,
    /// RMS of the residuals y − ŷ of this band's equations (reading units).
    #[serde(default)]
    pub rms_residual: Option<f64>,
    /// Regularisation weight λ (relative, see [`crate::fit::regularized`]) for `nnls`.
    #[serde(default)]
    pub lambda: Option<f64>,
    /// Condition number of this band's weighted design restricted to its support.
    #[serde(default)]
    pub condition_number: Option<f64>,
    /// Support window [lo, hi] (nm) outside which T_j = 0 was assumed (`nnls`/`lstsq`).
    #[serde(default)]
    pub support_nm: Option<[f64; 2]>,
    /// Unknowns held at zero by the non-negativity constraint.
    #[serde(default)]
    pub n_clamped: Option<usize>,
}

/// All bands of an LVF: the content of `lvf_bands.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BandSet {
    /// [`BANDS_SCHEMA`].
    pub schema: String,
    /// The model the bands were solved with.
    pub model: BandModel,
    /// The `lvf.json` object the bands belong to, verbatim.
    pub lvf: serde_json::Value,
    /// Wavelength grid of the transmissions (nm, increasing).
    pub grid_nm: Vec<f64>,
    /// One entry per band of the calibration, in its order.
    pub bands: Vec<BandTransmission>,
    /// Solver diagnostics (free-form object).
    #[serde(default)]
    pub diagnostics: serde_json::Value,
}

/// `null` or a missing array reads as empty (filled with zeros by [`BandSet::from_json`]).
fn null_as_empty<'de, D: serde::Deserializer<'de>>(
    d: D,
) -> std::result::Result<Vec<f64>, D::Error> {
    Ok(Option::<Vec<f64>>::deserialize(d)?.unwrap_or_default())
}

impl BandSet {
    /// Serialises to pretty JSON.
    ///
    /// # Errors
    /// Only if serialisation failed (it cannot for finite values).
    pub fn to_json(&self) -> Result<String> {
        serde_json::to_string_pretty(self)
            .map_err(|e| Error::invalid("lvf_bands.json", format!("cannot serialise: {e}")))
    }

    /// Reads `lvf_bands.json` (schema [`BANDS_SCHEMA`]).
    ///
    /// # Errors
    /// [`Error::Parse`] naming `source` and the field: not JSON, another schema, an unknown
    /// model, an embedded `lvf` that is not a valid `lvf.json`, a grid that is not strictly
    /// increasing, a band count different from the embedded calibration's, or a transmission /
    /// std whose length differs from the grid's.
    pub fn from_json(bytes: &[u8], source: &str) -> Result<BandSet> {
        // the schema first, so another file type gets that message rather than a missing field
        #[derive(Deserialize)]
        struct Tag {
            schema: Option<String>,
        }
        let tag: Tag = serde_json::from_slice(bytes)
            .map_err(|e| Error::parse(source, e.line(), format!("not JSON: {e}")))?;
        let schema = tag.schema.unwrap_or_default();
        if schema != BANDS_SCHEMA {
            return Err(Error::parse(
                source,
                0,
                format!("field 'schema' is '{schema}'; expected '{BANDS_SCHEMA}' (an lvf_bands.json from 'lumifit lvf transmission')"),
            ));
        }
        let mut set: BandSet = serde_json::from_slice(bytes).map_err(|e| {
            Error::parse(
                source,
                e.line(),
                format!("{e}; expected an lvf_bands.json written by 'lumifit lvf transmission'"),
            )
        })?;
        let geometry = LvfGeometry::from_json(
            set.lvf.to_string().as_bytes(),
            &format!("{source}: field 'lvf'"),
        )?;
        let grid_nm = &set.grid_nm;
        if grid_nm.len() < 2 {
            return Err(Error::parse(
                source,
                0,
                "field 'grid_nm': expected at least 2 wavelengths",
            ));
        }
        if let Some(i) = grid_nm.windows(2).position(|w| w[1] <= w[0]) {
            return Err(Error::parse(
                source,
                0,
                format!("field 'grid_nm': grid_nm[{}] = {} does not exceed grid_nm[{i}] = {}; expected strictly increasing wavelengths", i + 1, grid_nm[i + 1], grid_nm[i]),
            ));
        }
        if set.bands.len() != geometry.bands.len() {
            return Err(Error::parse(
                source,
                0,
                format!("field 'bands' has {} entries but the embedded lvf.json has {} bands; expected one transmission per band", set.bands.len(), geometry.bands.len()),
            ));
        }
        let n = grid_nm.len();
        for (j, b) in set.bands.iter_mut().enumerate() {
            let at = format!("bands[{j}]: ");
            if b.transmission.len() != n {
                return Err(Error::parse(
                    source,
                    0,
                    format!("{at}field 'transmission' has {} values; expected {n}, one per grid_nm entry", b.transmission.len()),
                ));
            }
            if b.std.is_empty() {
                b.std = vec![0.0; n];
            }
            if b.std.len() != n {
                return Err(Error::parse(
                    source,
                    0,
                    format!(
                        "{at}field 'std' has {} values; expected {n}, one per grid_nm entry",
                        b.std.len()
                    ),
                ));
            }
        }
        Ok(set)
    }

    /// The geometry of the embedded `lvf.json`.
    ///
    /// # Errors
    /// The [`LvfGeometry::from_json`] errors.
    pub fn geometry(&self, source: &str) -> Result<LvfGeometry> {
        LvfGeometry::from_json(self.lvf.to_string().as_bytes(), source)
    }

    /// T_j on `grid` (nm) by linear interpolation of the stored transmission.
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] when `j` is not a band, or `grid` reaches beyond `grid_nm` on a
    /// side where band j is not zero (its end value above 1e-6 of its peak).
    pub fn transmission_on(&self, j: usize, grid: &[f64]) -> Result<Vec<f64>> {
        let b = self.bands.get(j).ok_or_else(|| {
            Error::invalid(
                "band",
                format!("band index {j}; the set has {} bands", self.bands.len()),
            )
        })?;
        interp_band(&self.grid_nm, &b.transmission, grid, j, b.nm)
    }

    /// The noise standard deviation of T_j on `grid` (linear interpolation; 0 beyond `grid_nm`).
    ///
    /// # Errors
    /// As [`BandSet::transmission_on`].
    pub fn std_on(&self, j: usize, grid: &[f64]) -> Result<Vec<f64>> {
        let b = self.bands.get(j).ok_or_else(|| {
            Error::invalid(
                "band",
                format!("band index {j}; the set has {} bands", self.bands.len()),
            )
        })?;
        interp_band(&self.grid_nm, &b.transmission, grid, j, b.nm)?;
        Ok(grid
            .iter()
            .map(|&l| lerp(&self.grid_nm, &b.std, l).unwrap_or(0.0))
            .collect())
    }
}
