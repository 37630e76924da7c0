//! glTF 2.0 of a material preset: one material carrying every section glTF can hold, optionally
//! on a lit sphere (`--scene sphere`), as `.gltf` (buffer in a `data:` URI) or `.glb`.
//!
//! | section | glTF |
//! |---|---|
//! | reflectance | `pbrMetallicRoughness.baseColorFactor`: linear sRGB (Rec. 709 primaries, D65 white — glTF's only space) from the spectrum ([`super::base_colour`]); metallic 0, roughness 1 (a diffuse reflectance factor carries no gloss) |
//! | phosphorescence | `emissiveFactor` × `KHR_materials_emissive_strength.emissiveStrength` = the glow at switch-off in cd/m², and its decay as `KHR_animation_pointer` LINEAR keys on both ([`super::glow`]); times in s |
//! | fluorescence | `extras.lumifit_fluorescence` ([`super::fluorescence`]) and its base colour |
//! | dispersion | `KHR_materials_ior` (n_d), `KHR_materials_dispersion` (20/V_d), `KHR_materials_transmission` 1, `KHR_materials_volume` (`thicknessFactor`); roughness 0 |
//!
//! `KHR_materials_dispersion` implies the two-term Cauchy curve n = A + B/λ² through n_d with
//! Abbe number V_d (the preset's `derived.gltf_cauchy` gives A, B and their error against the
//! full model). Afterimage and photometric sections have no glTF material counterpart and are
//! listed in `asset.extras.lumifit.not_exported`.

use serde_json::{json, Map, Value};

use crate::colorimetry::rgb::RgbSpace;
use crate::error::{ensure_finite, Error, Result};
use crate::preset::MaterialPreset;

use super::base_colour::{reflectance_to_base_colour, BaseColour, COLORIMETRY};
use super::buffer::{data_uri, glb, AccessorType, BufferBuilder};
use super::fluorescence::fluorescence_block;
use super::glow::{glow, Glow, GlowOptions};
use super::scene::sphere_scene;

/// What the document holds besides the material.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Scene {
    /// The material alone (no nodes).
    #[default]
    None,
    /// A UV sphere with the material, a camera and a directional light ([`super::scene`]).
    Sphere,
}

/// Options of the glTF export.
#[derive(Debug, Clone, PartialEq)]
pub struct ExportOptions {
    /// `KHR_materials_volume.thicknessFactor` in metres (> 0), dispersion only.
    pub thickness_m: f64,
    /// The scene.
    pub scene: Scene,
    /// Charging, duration, tolerance and scale of the glow (phosphorescence only).
    pub glow: GlowOptions,
}

impl Default for ExportOptions {
    fn default() -> Self {
        ExportOptions {
            thickness_m: 1.0,
            scene: Scene::None,
            glow: GlowOptions::default(),
        }
    }
}

/// A glTF document before serialisation: the JSON (buffer 0 without `uri`) and buffer 0's bytes.
#[derive(Debug, Clone, PartialEq)]
pub struct GltfDocument {
    /// The glTF JSON; `buffers[0]` (when present) has no `uri` yet.
    pub json: Value,
    /// Buffer 0 (empty when the document needs none).
    pub bin: Vec<u8>,
    /// The glow, when the preset has phosphorescence.
    pub glow: Option<Glow>,
    /// Sections written.
    pub sections: Vec<&'static str>,
}

impl GltfDocument {
    /// `.gltf` text: the buffer embedded as a base64 `data:` URI.
    pub fn to_gltf(&self) -> Result<String> {
        let mut doc = self.json.clone();
        if !self.bin.is_empty() {
            doc["buffers"][0]["uri"] = json!(data_uri(&self.bin));
        }
        Ok(
            serde_json::to_string_pretty(&doc).map_err(|e| Error::Numerical {
                what: "glTF JSON".into(),
                reason: e.to_string(),
            })? + "\n",
        )
    }

    /// `.glb` bytes (glTF 2.0 §4.4).
    pub fn to_glb(&self) -> Result<Vec<u8>> {
        let text = serde_json::to_vec(&self.json).map_err(|e| Error::Numerical {
            what: "glTF JSON".into(),
            reason: e.to_string(),
        })?;
        Ok(glb(&text, &self.bin))
    }
}

/// The sections glTF carries, or an error naming what the preset has instead.
fn exported_sections(preset: &MaterialPreset, file: &str) -> Result<Vec<&'static str>> {
    let s: Vec<&'static str> = preset
        .sections()
        .into_iter()
        .filter(|s| {
            [
                "reflectance",
                "phosphorescence",
                "fluorescence",
                "dispersion",
            ]
            .contains(s)
        })
        .collect();
    if s.is_empty() {
        let has = preset.sections();
        return Err(Error::invalid(
            format!("{file}: sections"),
            format!(
                "no section a material export carries (reflectance, phosphorescence, fluorescence, dispersion); the preset has: {}",
                if has.is_empty() { "none".to_string() } else { has.join(", ") }
            ),
        ));
    }
    Ok(s)
}

/// The glTF 2.0 document of `preset` (see the module docs); `file` names the preset in errors.
pub fn material_gltf(
    preset: &MaterialPreset,
    file: &str,
    opts: &ExportOptions,
) -> Result<GltfDocument> {
    let sections = exported_sections(preset, file)?;
    let srgb = RgbSpace::srgb()?;
    let mut used: Vec<&str> = Vec::new();
    let mut buf = BufferBuilder::new();
    let mut extras = Map::new();
    let mut report = Map::new();

    let reflectance: Option<BaseColour> = preset
        .reflectance
        .as_ref()
        .map(|r| reflectance_to_base_colour(r, &srgb, file))
        .transpose()?;
    let mut base = reflectance.as_ref().map(|b| b.factor).unwrap_or([1.0; 3]);
    if let Some(b) = &reflectance {
        report.insert(
            "reflectance".into(),
            json!({"linear_srgb_unclipped": b.linear_rgb, "clipped": b.clipped, "xyz_d65": b.xyz}),
        );
    }
    if let Some(f) = &preset.fluorescence {
        let (block, b) = fluorescence_block(f, reflectance.as_ref(), &srgb, file)?;
        base = b;
        extras.insert("lumifit_fluorescence".into(), block);
    }
    let mut material = json!({
        "name": preset.name,
        "pbrMetallicRoughness": {
            "baseColorFactor": [base[0], base[1], base[2], 1.0],
            "metallicFactor": 0.0,
            "roughnessFactor": 1.0
        }
    });
    let mut ext = Map::new();

    if let Some(d) = &preset.dispersion {
        if !(opts.thickness_m.is_finite() && opts.thickness_m > 0.0) {
            return Err(Error::invalid(
                "--thickness-m",
                format!("{}; expected a positive thickness in m", opts.thickness_m),
            ));
        }
        let dispersion = 20.0 / d.abbe_number;
        ensure_finite("glTF dispersion (20 / V_d)", file, &[d.n_d, dispersion])?;
        material["pbrMetallicRoughness"]["roughnessFactor"] = json!(0.0);
        ext.insert("KHR_materials_ior".into(), json!({"ior": d.n_d}));
        ext.insert(
            "KHR_materials_dispersion".into(),
            json!({"dispersion": dispersion}),
        );
        ext.insert(
            "KHR_materials_transmission".into(),
            json!({"transmissionFactor": 1.0}),
        );
        ext.insert(
            "KHR_materials_volume".into(),
            json!({"thicknessFactor": opts.thickness_m}),
        );
        used.extend([
            "KHR_materials_dispersion",
            "KHR_materials_ior",
            "KHR_materials_transmission",
            "KHR_materials_volume",
        ]);
        report.insert(
            "dispersion".into(),
            json!({"abbe_number": d.abbe_number, "dispersion_model": d.model.kind, "range_nm": d.range_nm}),
        );
    }

    let (mut channels, mut samplers, mut glow_input) = (Vec::new(), Vec::new(), None);
    let glow = match &preset.phosphorescence {
        Some(_) => Some(glow(preset, file, &srgb, &opts.glow)?),
        None => None,
    };
    if let Some(g) = &glow {
        let (factor0, strength0) = g.at_switch_off();
        material["emissiveFactor"] = json!(factor0.map(f64::from));
        ext.insert(
            "KHR_materials_emissive_strength".into(),
            json!({"emissiveStrength": f64::from(strength0)}),
        );
        used.extend(["KHR_animation_pointer", "KHR_materials_emissive_strength"]);
        let k = &g.keys;
        let input = buf.push_f32(&k.t_s, AccessorType::Scalar, None, true);
        let factors: Vec<f32> = k.factor.iter().flatten().copied().collect();
        let out_f = buf.push_f32(&factors, AccessorType::Vec3, None, false);
        let out_s = buf.push_f32(&k.strength, AccessorType::Scalar, None, false);
        channels.push(pointer_channel(0, "/materials/0/emissiveFactor"));
        channels.push(pointer_channel(
            1,
            "/materials/0/extensions/KHR_materials_emissive_strength/emissiveStrength",
        ));
        samplers.push(json!({"input": input, "output": out_f, "interpolation": "LINEAR"}));
        samplers.push(json!({"input": input, "output": out_s, "interpolation": "LINEAR"}));
        glow_input = Some(input);
        report.insert("emission".into(), emission_report(g));
    }
    if !ext.is_empty() {
        material["extensions"] = Value::Object(ext);
    }
    if !extras.is_empty() {
        material["extras"] = Value::Object(extras);
    }

    let not_exported: Vec<&str> = preset
        .sections()
        .into_iter()
        .filter(|s| !sections.contains(s))
        .collect();
    let mut doc = json!({
        "asset": {
            "version": "2.0",
            "generator": format!("lumifit {} preset export", env!("CARGO_PKG_VERSION")),
            "extras": {"lumifit": {
                "preset": preset.name,
                "sections": sections,
                "not_exported": not_exported,
                "working_space": "linear sRGB (Rec. 709 primaries, D65 white), glTF 2.0 §3.9.2",
                "colorimetry": COLORIMETRY,
                "sections_detail": report,
            }}
        },
        "materials": [material],
    });
    if opts.scene == Scene::Sphere {
        let (nodes, meshes, cameras, lights) = sphere_scene(&mut buf, &preset.name, 0);
        doc["scene"] = json!(0);
        doc["scenes"] =
            json!([{"name": preset.name, "nodes": (0..nodes.len()).collect::<Vec<_>>()}]);
        doc["nodes"] = json!(nodes);
        doc["meshes"] = meshes;
        doc["cameras"] = cameras;
        doc["extensions"] = json!({"KHR_lights_punctual": lights});
        used.push("KHR_lights_punctual");
        // The glow is what is seen after switch-off: the animation turns the light off at t = 0
        // (a STEP channel holding 0 on the glow's times); without animation support the light
        // stays on and the material shows its switch-off values.
        if let (Some(g), Some(input)) = (&glow, glow_input) {
            let off = buf.push_f32(
                &vec![0.0; g.keys.t_s.len()],
                AccessorType::Scalar,
                None,
                false,
            );
            channels.push(pointer_channel(
                samplers.len(),
                "/extensions/KHR_lights_punctual/lights/0/intensity",
            ));
            samplers.push(json!({"input": input, "output": off, "interpolation": "STEP"}));
        }
    }
    if let Some(g) = &glow {
        doc["animations"] = json!([{
            "name": format!("glow after switch-off ({} charge)", g.charge.describe()),
            "channels": channels,
            "samplers": samplers,
        }]);
    }
    if !buf.is_empty() {
        doc["buffers"] = json!([{"byteLength": buf.bytes.len()}]);
        doc["bufferViews"] = json!(buf.views);
        doc["accessors"] = json!(buf.accessors);
    }
    used.sort_unstable();
    used.dedup();
    if !used.is_empty() {
        doc["extensionsUsed"] = json!(used);
    }
    Ok(GltfDocument {
        json: doc,
        bin: buf.bytes,
        glow,
        sections,
    })
}

/// A `KHR_animation_pointer` channel of `sampler` targeting the JSON pointer `pointer`.
fn pointer_channel(sampler: usize, pointer: &str) -> Value {
    json!({"sampler": sampler, "target": {"path": "pointer", "extensions": {"KHR_animation_pointer": {"pointer": pointer}}}})
}

/// What the glow export states: charge, scale, tolerance, keys and the luminance at switch-off.
pub fn emission_report(g: &Glow) -> Value {
    json!({
        "charge": g.charge.describe(),
        "charge_irradiance": g.irradiance,
        "concentrations_at_switch_off": g.r0,
        "nits_per_unit": g.nits_per_unit,
        "unit": "emissiveFactor × emissiveStrength = linear RGB in cd/m²",
        "luminance_at_switch_off_cd_m2": g.luminance(g.rgb_at(0.0)),
        "luminance_at_end_cd_m2": g.luminance(g.rgb_at(g.duration_s)),
        "duration_s": g.duration_s,
        "keys": g.keys.t_s.len(),
        "chord_keys": g.keys.chord_keys,
        "interpolation": "LINEAR on emissiveFactor and emissiveStrength, times in s",
        "key_tolerance": {"rel": g.tolerance.rel_tol, "abs_of_peak": g.tolerance.abs_tol},
        "max_error_of_tolerance": g.keys.max_error,
        "gamut_clipped_states": g.clipped_states,
    })
}
