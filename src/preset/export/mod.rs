//! Exporters from presets to renderer formats: separate functions here, never methods on domain
//! types (GUIDE §4).
//!
//! | format | function | what |
//! |---|---|---|
//! | glTF 2.0 | [`gltf::material_gltf`] | a material with `KHR_materials_ior`, `KHR_materials_dispersion`, `KHR_materials_volume`, `KHR_materials_transmission` |
//! | glTF 2.0 light | [`light::gltf_light`] | a `lumifit.light/1` preset or photometric file as one node with `KHR_lights_punctual` + `EXT_lights_ies` (IES written by lumifit) |
//! | OpenPBR | [`gltf::openpbr_parameters`] | `specular_ior`, `transmission_dispersion_abbe_number`, `transmission_dispersion_scale` as JSON |

pub mod gltf;
pub mod light;

pub use gltf::{material_gltf, openpbr_parameters, ExportOptions};
