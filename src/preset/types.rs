//! Serde types of `lumifit.material/1` and `lumifit.light/1`.

use serde::{Deserialize, Serialize};

use super::provenance::Provenance;
use super::{LIGHT_SCHEMA, MATERIAL_SCHEMA};

/// A section whose fields a later pipeline defines: any JSON object.
pub type OpenSection = serde_json::Map<String, serde_json::Value>;

/// A `lumifit.material/1` preset: name, provenance and independent optional sections.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MaterialPreset {
    /// Always [`MATERIAL_SCHEMA`].
    pub schema: String,
    /// Human-readable name.
    pub name: String,
    /// Free text: what was measured, under which conditions.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub description: Option<String>,
    /// How the preset was produced.
    pub provenance: Provenance,
    /// Spectral reflectance factor.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reflectance: Option<ReflectanceSection>,
    /// Phosphorescent states over spectral bands.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub phosphorescence: Option<PhosphorescenceSection>,
    /// Fluorescence: a Donaldson matrix reduced to a basis (Fichet et al. 2024).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fluorescence: Option<FluorescenceSection>,
    /// Dispersion: fitted n(λ), derived numbers and wavelength samples for RGB renderers.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dispersion: Option<super::dispersion::DispersionSection>,
    /// Afterimage; fields defined by the afterimage pipeline.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub afterimage: Option<OpenSection>,
    /// Photometric emission; fields defined by the photometry pipeline.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub photometric: Option<OpenSection>,
}

/// A `lumifit.light/1` preset: name, provenance and a photometric section.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LightPreset {
    /// Always [`LIGHT_SCHEMA`].
    pub schema: String,
    /// Human-readable name.
    pub name: String,
    /// Free text: what was measured, under which conditions.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub description: Option<String>,
    /// How the preset was produced.
    pub provenance: Provenance,
    /// Photometric description; fields defined by the photometry pipeline.
    pub photometric: OpenSection,
}

/// Spectral reflectance factor sampled at strictly increasing wavelengths.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ReflectanceSection {
    /// Sample wavelengths in nm, strictly increasing, at least two.
    pub wavelength_nm: Vec<f64>,
    /// Reflectance factor (dimensionless, typically 0–1), one per wavelength.
    pub value: Vec<f64>,
    /// Further fields, kept as read.
    #[serde(flatten)]
    pub extra: OpenSection,
}

/// Phosphorescence: a set of spectral bands and the states that store and re-emit light in them.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PhosphorescenceSection {
    /// The bands every per-band array refers to.
    pub bands: Bands,
    /// The phosphorescent states, at least one.
    pub states: Vec<PhosphorescentState>,
    /// Further fields, kept as read.
    #[serde(flatten)]
    pub extra: OpenSection,
}

/// One phosphorescent state.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PhosphorescentState {
    /// Decay rate in s⁻¹ (> 0).
    pub k_r_per_s: f64,
    /// Excitation coefficient, one per band (≥ 0); may be absent.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub k_e: Option<Vec<f64>>,
    /// Emission weight, one per band (≥ 0).
    pub lambda: Vec<f64>,
    /// Further fields, kept as read.
    #[serde(flatten)]
    pub extra: OpenSection,
}

/// Fluorescence: the material's Donaldson matrix reduced to a K-function basis (Fichet, Belcour
/// & Barla 2024, CGF 43(4)), with the 3×3 matrices for XYZ and RGB renderers and the colour
/// error of the reduction under the illuminants it was checked with.
///
/// A renderer multiplies the reflected light's basis coordinates by `matrix` (K×K), or XYZ by
/// `xyz_matrix`, or linear RGB of `rgb.space` by `rgb.matrix`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FluorescenceSection {
    /// Reduction: `dual` (Eq. 15) or `naive` (Eq. 7).
    pub method: String,
    /// The paper the reduction follows.
    pub paper: String,
    /// The basis the matrix is expressed in.
    pub basis: FluorescenceBasis,
    /// Reduced matrix P (K×K, row-major).
    pub matrix: Vec<Vec<f64>>,
    /// Transfer T from basis coordinates to XYZ (3×K, row-major).
    pub transfer_xyz: Vec<Vec<f64>>,
    /// P projected to XYZ (3×3, row-major).
    pub xyz_matrix: [[f64; 3]; 3],
    /// P projected to an RGB working space (Eq. 16).
    pub rgb: FluorescenceRgb,
    /// How the measured matrix was resampled onto the working grid.
    pub resampling: FluorescenceResampling,
    /// ΔE00 of reduced against spectral rendering, one entry per illuminant.
    pub delta_e00: Vec<FluorescenceDeltaE>,
    /// Largest ΔE00 of `delta_e00`.
    pub worst_delta_e00: f64,
    /// Further fields, kept as read.
    #[serde(flatten)]
    pub extra: OpenSection,
}

/// The basis of a [`FluorescenceSection`]: K functions sampled on a uniform grid.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FluorescenceBasis {
    /// Basis name (`xyz`, `xyzu`, `xyz7u` or a file stem).
    pub name: String,
    /// Number of functions K.
    pub k: usize,
    /// One label per function.
    pub labels: Vec<String>,
    /// Observer whose colour-matching functions the basis spans.
    pub observer: String,
    /// The sampling grid.
    pub grid_nm: GridNm,
    /// K functions, each sampled on `grid_nm`.
    pub functions: Vec<Vec<f64>>,
}

/// A uniform wavelength grid `start_nm..=end_nm` in steps of `step_nm`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct GridNm {
    /// First wavelength (nm).
    pub start_nm: f64,
    /// Last wavelength (nm).
    pub end_nm: f64,
    /// Step (nm).
    pub step_nm: f64,
}

/// The reduced matrix in an RGB working space.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FluorescenceRgb {
    /// Working space key (`srgb`, `rec2020`, `acescg`).
    pub space: String,
    /// 3×3 matrix on linear RGB (row-major).
    pub matrix: [[f64; 3]; 3],
    /// K of the basis the matrix was projected from.
    pub projected_from_k: usize,
    /// The projection applied.
    pub equation: String,
}

/// Resampling of the measured Donaldson matrix onto the working grid.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FluorescenceResampling {
    /// Negative entries (measurement noise) clipped to 0.
    pub clip_negatives: bool,
    /// Anti-Stokes entries (excitation ≥ emission off the diagonal) zeroed.
    pub zero_anti_stokes: bool,
    /// How the diagonal was resampled.
    pub diagonal: String,
    /// How the off-diagonal part was resampled.
    pub off_diagonal: String,
}

/// ΔE00 of the reduction under one illuminant.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FluorescenceDeltaE {
    /// Illuminant name (or file).
    pub illuminant: String,
    /// CIEDE2000 difference, reduced against spectral.
    pub delta_e00: f64,
    /// XYZ of the spectral (reference) rendering.
    pub xyz_reference: [f64; 3],
    /// XYZ of the reduced rendering.
    pub xyz_reduced: [f64; 3],
}

/// The spectral bands of a phosphorescence section.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "BandsRepr", into = "BandsRepr")]
pub enum Bands {
    /// The three linear RGB channels, written `"rgb"`.
    Rgb,
    /// Wavelength bands `[lo_nm, hi_nm]`, written `[[lo_nm, hi_nm], …]`.
    RangesNm(Vec<[f64; 2]>),
}

impl Bands {
    /// Number of bands (3 for RGB).
    pub fn len(&self) -> usize {
        match self {
            Bands::Rgb => 3,
            Bands::RangesNm(ranges) => ranges.len(),
        }
    }

    /// True when there is no band (never true for a valid preset).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

#[derive(Serialize, Deserialize)]
#[serde(untagged)]
enum BandsRepr {
    Name(String),
    Ranges(Vec<[f64; 2]>),
}

impl TryFrom<BandsRepr> for Bands {
    type Error = String;
    fn try_from(repr: BandsRepr) -> Result<Self, String> {
        match repr {
            BandsRepr::Name(name) if name == "rgb" => Ok(Bands::Rgb),
            BandsRepr::Name(name) => Err(format!(
                "bands '{name}' unknown; expected \"rgb\" or [[lo_nm, hi_nm], …]"
            )),
            BandsRepr::Ranges(ranges) => Ok(Bands::RangesNm(ranges)),
        }
    }
}

impl From<Bands> for BandsRepr {
    fn from(bands: Bands) -> Self {
        match bands {
            Bands::Rgb => BandsRepr::Name("rgb".to_string()),
            Bands::RangesNm(ranges) => BandsRepr::Ranges(ranges),
        }
    }
}

/// A preset of either kind, as read from a file.
// One value per file read: boxing the material variant would cost ergonomics for nothing.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(untagged)]
pub enum Preset {
    /// `lumifit.material/1`.
    Material(MaterialPreset),
    /// `lumifit.light/1`.
    Light(LightPreset),
}

/// A document [`write_preset`](super::write_preset) can write: [`MaterialPreset`],
/// [`LightPreset`] or [`Preset`]. Sealed.
pub trait PresetDocument: Serialize + sealed::Sealed {}

mod sealed {
    pub trait Sealed {}
    impl Sealed for super::MaterialPreset {}
    impl Sealed for super::LightPreset {}
    impl Sealed for super::Preset {}
}

impl PresetDocument for MaterialPreset {}
impl PresetDocument for LightPreset {}
impl PresetDocument for Preset {}

impl MaterialPreset {
    /// A material preset with no sections yet.
    pub fn new(name: impl Into<String>, provenance: Provenance) -> Self {
        MaterialPreset {
            schema: MATERIAL_SCHEMA.to_string(),
            name: name.into(),
            description: None,
            provenance,
            reflectance: None,
            phosphorescence: None,
            fluorescence: None,
            dispersion: None,
            afterimage: None,
            photometric: None,
        }
    }

    /// Names of the sections present, in document order.
    pub fn sections(&self) -> Vec<&'static str> {
        let present = [
            self.reflectance.is_some(),
            self.phosphorescence.is_some(),
            self.fluorescence.is_some(),
            self.dispersion.is_some(),
            self.afterimage.is_some(),
            self.photometric.is_some(),
        ];
        super::MATERIAL_SECTIONS
            .iter()
            .zip(present)
            .filter(|(_, p)| *p)
            .map(|(name, _)| *name)
            .collect()
    }
}

impl LightPreset {
    /// A light preset with the given photometric section.
    pub fn new(name: impl Into<String>, provenance: Provenance, photometric: OpenSection) -> Self {
        LightPreset {
            schema: LIGHT_SCHEMA.to_string(),
            name: name.into(),
            description: None,
            provenance,
            photometric,
        }
    }
}

impl ReflectanceSection {
    /// A reflectance section with no further fields (checked when the preset is validated).
    pub fn new(wavelength_nm: Vec<f64>, value: Vec<f64>) -> Self {
        ReflectanceSection {
            wavelength_nm,
            value,
            extra: OpenSection::new(),
        }
    }
}

impl PhosphorescentState {
    /// A state with no further fields (checked when the preset is validated).
    pub fn new(k_r_per_s: f64, k_e: Option<Vec<f64>>, lambda: Vec<f64>) -> Self {
        PhosphorescentState {
            k_r_per_s,
            k_e,
            lambda,
            extra: OpenSection::new(),
        }
    }
}

impl Preset {
    /// The schema identifier.
    pub fn schema(&self) -> &str {
        match self {
            Preset::Material(m) => &m.schema,
            Preset::Light(l) => &l.schema,
        }
    }

    /// The preset's name.
    pub fn name(&self) -> &str {
        match self {
            Preset::Material(m) => &m.name,
            Preset::Light(l) => &l.name,
        }
    }

    /// The preset's provenance.
    pub fn provenance(&self) -> &Provenance {
        match self {
            Preset::Material(m) => &m.provenance,
            Preset::Light(l) => &l.provenance,
        }
    }

    /// Names of the sections present, in document order.
    pub fn sections(&self) -> Vec<&'static str> {
        match self {
            Preset::Material(m) => m.sections(),
            Preset::Light(_) => vec!["photometric"],
        }
    }
}

impl From<MaterialPreset> for Preset {
    fn from(m: MaterialPreset) -> Self {
        Preset::Material(m)
    }
}

impl From<LightPreset> for Preset {
    fn from(l: LightPreset) -> Self {
        Preset::Light(l)
    }
}
