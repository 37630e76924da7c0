//! Material and light presets: the toolkit's product (GUIDE §4).
//!
//! A preset is a versioned JSON document that holds only what a scene needs, with units in field
//! names (`wavelength_nm`, `k_r_per_s`), plus the provenance needed to reproduce it (tool version,
//! command, every input with its SHA-256, creation time, fit quality).
//!
//! | schema | Rust type | sections |
//! |---|---|---|
//! | `lumifit.material/1` | [`MaterialPreset`] | optional, independent: `reflectance`, `phosphorescence`, `fluorescence`, `dispersion`, `afterimage`, `photometric` |
//! | `lumifit.light/1` | [`LightPreset`] | `photometric` (required) |
//!
//! The format is documented field by field in `docs/preset-schema.md`; the JSON Schema
//! (draft 2020-12) beside it, `docs/preset-schema.json`, is embedded here as [`SCHEMA_JSON`] so
//! validation works from any directory.
//!
//! Reading ([`read_preset`], [`read_material`], [`read_light`], [`parse_preset`]) goes through
//! [`validate_value`], in this order:
//!
//! 1. JSON syntax (errors carry file, line and column);
//! 2. the `schema` field: an unknown or future version (`lumifit.material/2`) is rejected with
//!    [`Error::UnsupportedSchema`](crate::Error::UnsupportedSchema) before anything else is read;
//! 3. the JSON Schema: every violation is reported as a JSON pointer and a message;
//! 4. typed deserialisation and the checks JSON Schema cannot express (equal lengths, strictly
//!    increasing wavelengths, one `k_e`/`lambda` value per band).
//!
//! Writing ([`write_preset`]) validates the document the same way, then writes pretty JSON
//! atomically ([`crate::io::atomic_write`]); an invalid preset is never written and an existing
//! file is left untouched.

pub mod afterimage;
pub mod dispersion;
pub mod export;
mod file;
pub mod fluorescence;
pub mod phosphor;
pub mod photometric;
pub mod preview;
mod provenance;
pub mod shader;
mod types;
mod validate;

pub use file::{
    parse_preset, read_light, read_material, read_preset, to_json_string, write_preset,
};
pub use provenance::{sha256_hex, InputFile, Provenance};
pub use types::{
    Bands, FluorescenceBasis, FluorescenceDeltaE, FluorescenceResampling, FluorescenceRgb,
    FluorescenceSection, GridNm, LightPreset, MaterialPreset, OpenSection, PhosphorescenceSection,
    PhosphorescentState, Preset, PresetDocument, ReflectanceSection,
};
pub use validate::{schema_value, validate_value};

/// Schema identifier of material presets.
pub const MATERIAL_SCHEMA: &str = "lumifit.material/1";

/// Schema identifier of light presets.
pub const LIGHT_SCHEMA: &str = "lumifit.light/1";

/// Every schema identifier this version of lumifit reads and writes.
pub const SUPPORTED_SCHEMAS: [&str; 2] = [MATERIAL_SCHEMA, LIGHT_SCHEMA];

/// The JSON Schema (draft 2020-12) of both preset kinds, `docs/preset-schema.json`.
pub const SCHEMA_JSON: &str = include_str!("../../docs/preset-schema.json");

/// Names of the optional sections of a material preset, in document order.
pub const MATERIAL_SECTIONS: [&str; 6] = [
    "reflectance",
    "phosphorescence",
    "fluorescence",
    "dispersion",
    "afterimage",
    "photometric",
];
