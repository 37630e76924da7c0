//! Dispersion: refractive index n(λ) of transparent materials, fitted models, the numbers glass
//! catalogues and renderers use, and wavelength samples for RGB renderers.
//!
//! Pure maths (layer L2): no file system, no printing. Readers of refractiveindex.info YAML and of
//! measured CSV live in `io::refractive_index`; the preset section and the glTF/OpenPBR
//! exporters in `preset::dispersion` and `preset::export`; charts in `plot::dispersion`.
//!
//! | module | what |
//! |---|---|
//! | [`formula`] | the nine refractiveindex.info dispersion formulas (λ in µm) |
//! | [`model`] | the fitted models: Cauchy n = Σ cᵢ λ⁻²ⁱ and Sellmeier n² = 1 + Σ Bᵢ λ²/(λ² − Cᵢ) |
//! | [`fit`] | (weighted) least-squares fits over a range and the smallest model meeting a tolerance |
//! | [`derived`] | n_d, n_F, n_C, n_e, V_d, V_e, glass code, and the two-term Cauchy glTF implies |
//! | [`air`] | standard-air refractive index (Ciddor 1996) and air ↔ vacuum conversion |
//! | [`source`] | formula or table → observations over a range; air ↔ vacuum |
//! | [`catalogue`] | the bundled glass catalogue (`calib/glasses.csv`) |
//! | [`blanchette2012`] | wavelength samples with RGB weights that sum to white (Blanchette 2012 §4, Table 2) |
//! | [`prism`] | the reference consumer: a white beam through a prism onto a screen, ΔE00 of the samples |
//!
//! Wavelengths are in nm at the interfaces (`lambda_nm`); the formulas work in µm as the
//! refractiveindex.info database does, and every coefficient list says so (`wavelength_unit`).

pub mod air;
pub mod blanchette2012;
pub mod catalogue;
pub mod derived;
pub mod fit;
pub mod formula;
pub mod model;
pub mod prism;
pub mod source;

pub use derived::{derived_numbers, DerivedNumbers, GltfCauchy};
pub use fit::{fit_auto, fit_model, Candidate, FitReport, Observations};
pub use formula::{Formula, FormulaKind};
pub use model::{Model, ModelKind};
pub use source::{AirVacuum, Source};

/// Fraunhofer and mercury reference lines in nm (in air, as glass catalogues use them).
pub mod lines {
    /// Hydrogen F line, 486.1327 nm.
    pub const F_NM: f64 = 486.1327;
    /// Helium d line, 587.5618 nm.
    pub const D_NM: f64 = 587.5618;
    /// Hydrogen C line, 656.2725 nm.
    pub const C_NM: f64 = 656.2725;
    /// Mercury e line, 546.0740 nm.
    pub const E_NM: f64 = 546.0740;
    /// Cadmium F′ line, 479.9914 nm.
    pub const F_PRIME_NM: f64 = 479.9914;
    /// Cadmium C′ line, 643.8469 nm.
    pub const C_PRIME_NM: f64 = 643.8469;
}

/// Anything that gives n(λ) for λ in nm: a database formula, a fitted model, a tabulated entry
/// fitted first.
pub trait RefractiveIndex {
    /// n at `lambda_nm`.
    fn n_at(&self, lambda_nm: f64) -> f64;
}
