//! Exporters from presets to renderer formats: separate functions here, never methods on domain
//! types (GUIDE §4). One module per concern:
//!
//! | module | what |
//! |---|---|
//! | [`base_colour`] | reflectance → linear RGB base colour (CIE 1931 2°, D65) |
//! | [`glow`] | phosphorescence → emission in cd/m² after a stated charge, and its keyframes |
//! | [`fluorescence`] | the `lumifit_fluorescence` extras block (no standard exists) |
//! | [`scene`] | the `--scene sphere` mesh, camera and light |
//! | [`buffer`] | glTF buffers, accessors, data URIs and the GLB container |
//! | [`gltf`] | [`gltf::material_gltf`]: the glTF 2.0 document of every material section |
//! | [`openpbr`] | [`openpbr::openpbr_parameters`] (JSON) and [`openpbr::materialx_document`] (MaterialX 1.39 `open_pbr_surface`) |
//! | [`light`] | [`light::gltf_light`]: a `lumifit.light/1` preset or photometric file as one node with `KHR_lights_punctual` + `EXT_lights_ies` (IES written by lumifit) |

pub mod base_colour;
pub mod buffer;
pub mod fluorescence;
pub mod glow;
pub mod gltf;
pub mod light;
pub mod openpbr;
pub mod scene;

pub use glow::{Charge, EmissionScale, GlowOptions};
pub use gltf::{material_gltf, ExportOptions, GltfDocument, Scene};
pub use openpbr::{materialx_document, openpbr_parameters, OpenPbrOptions};
