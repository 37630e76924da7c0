//! OpenPBR Surface parameters of a material preset, as JSON and as a MaterialX 1.39 document
//! (`<open_pbr_surface>` node with a `<surfacematerial>`).
//!
//! | section | OpenPBR |
//! |---|---|
//! | reflectance | `base_color` (linear, in the chosen space; MaterialX `colorspace` names it), `base_weight` 1, `base_metalness` 0 |
//! | phosphorescence | `emission_luminance` (cd/m², the glow at switch-off after the stated charge) and `emission_color` (that glow's linear RGB divided by its luminance, so the colour has luminance 1 and `emission_luminance` is the luminance; a saturated colour can exceed 1 in a channel). The decay is lost: OpenPBR has no animation; the JSON carries the keys (`lumifit_glow`) |
//! | fluorescence | JSON only: `lumifit_fluorescence` (as in glTF) and its base colour; MaterialX gets the base colour |
//! | dispersion | `specular_ior` = n_d, `specular_roughness` 0, `transmission_weight` 1, `transmission_dispersion_abbe_number` = V_d, `transmission_dispersion_scale` 1 |

use serde_json::{json, Map, Value};

use crate::colorimetry::rgb::RgbSpace;
use crate::error::{ensure_finite, Error, Result};
use crate::math::linalg::mat3_mul_vec;
use crate::preset::MaterialPreset;

use super::base_colour::{clip_unit, reflectance_to_base_colour, COLORIMETRY};
use super::fluorescence::{fluorescence_block, rgb_matrix};
use super::glow::{glow, GlowOptions};
use super::gltf::emission_report;

/// Options of the OpenPBR export.
#[derive(Debug, Clone, PartialEq)]
pub struct OpenPbrOptions {
    /// Linear working space of the colours (`srgb`, `acescg`, `display-p3`).
    pub space: RgbSpace,
    /// Charge, scale and keys of the glow.
    pub glow: GlowOptions,
}

/// MaterialX 1.39 colour-space name of a lumifit working space.
pub fn materialx_colorspace(space: &RgbSpace) -> Result<&'static str> {
    match space.key.as_str() {
        "srgb" => Ok("lin_rec709"),
        "acescg" => Ok("acescg"),
        "display-p3" => Ok("lin_displayp3"),
        other => Err(Error::invalid(
            "--space",
            format!(
                "'{other}' has no MaterialX 1.39 colour-space name; expected srgb (lin_rec709), acescg or display-p3 (lin_displayp3)"
            ),
        )),
    }
}

/// The parameters as an ordered list of `(name, value)`, plus the JSON-only blocks.
struct Parameters {
    params: Vec<(&'static str, Value)>,
    extras: Map<String, Value>,
    lost: Vec<String>,
}

fn parameters(preset: &MaterialPreset, file: &str, opts: &OpenPbrOptions) -> Result<Parameters> {
    let space = &opts.space;
    let mut params: Vec<(&'static str, Value)> = Vec::new();
    let mut extras = Map::new();
    let mut lost = Vec::new();
    let reflectance = preset
        .reflectance
        .as_ref()
        .map(|r| reflectance_to_base_colour(r, space, file))
        .transpose()?;
    let mut base = reflectance.as_ref().map(|b| b.factor);
    if let Some(f) = &preset.fluorescence {
        let srgb = RgbSpace::srgb()?;
        let refl_srgb = preset
            .reflectance
            .as_ref()
            .map(|r| reflectance_to_base_colour(r, &srgb, file))
            .transpose()?;
        let (block, _) = fluorescence_block(f, refl_srgb.as_ref(), &srgb, file)?;
        extras.insert("lumifit_fluorescence".into(), block);
        if base.is_none() {
            let m = rgb_matrix(f, space);
            base = Some(clip_unit(mat3_mul_vec(&m, [1.0; 3])).0);
        }
        lost.push("fluorescence: no OpenPBR parameter; the JSON keeps the reduced matrix (lumifit_fluorescence), MaterialX only its base colour".into());
    }
    if let Some(b) = base {
        params.push(("base_weight", json!(1.0)));
        params.push(("base_color", json!(b)));
        params.push(("base_metalness", json!(0.0)));
    }
    if preset.phosphorescence.is_some() {
        let g = glow(preset, file, space, &opts.glow)?;
        let rgb0 = g.rgb_at(0.0);
        let y0 = g.luminance(rgb0);
        let colour = rgb0.map(|v| v / y0);
        ensure_finite("OpenPBR emission", file, &[&[y0][..], &colour[..]].concat())?;
        params.push(("emission_luminance", json!(y0)));
        params.push(("emission_color", json!(colour)));
        let lum: Vec<f64> = g
            .keys
            .t_s
            .iter()
            .map(|&t| g.luminance(g.rgb_at(f64::from(t))))
            .collect();
        extras.insert(
            "lumifit_glow".into(),
            json!({
                "summary": emission_report(&g),
                "t_s": g.keys.t_s,
                "emission_luminance_cd_m2": lum,
                "note": "linear interpolation of emission_luminance between these keys stays within the key tolerance of the exact luminance (the luminance is a positive combination of the channels the keys were placed for)",
            }),
        );
        lost.push("phosphorescence: only the glow at switch-off (OpenPBR has no animation); lumifit_glow holds the keys".into());
    }
    if let Some(d) = &preset.dispersion {
        ensure_finite("OpenPBR dispersion", file, &[d.n_d, d.abbe_number])?;
        params.push(("specular_ior", json!(d.n_d)));
        params.push(("specular_roughness", json!(0.0)));
        params.push(("transmission_weight", json!(1.0)));
        params.push(("transmission_dispersion_abbe_number", json!(d.abbe_number)));
        params.push(("transmission_dispersion_scale", json!(1.0)));
        lost.push("dispersion: only n_d and V_d (the two-term Cauchy curve through n_d; see the preset's dispersion.derived.gltf_cauchy for its error)".into());
    }
    if params.is_empty() {
        let has = preset.sections();
        return Err(Error::invalid(
            format!("{file}: sections"),
            format!(
                "no section an OpenPBR export carries (reflectance, phosphorescence, fluorescence, dispersion); the preset has: {}",
                if has.is_empty() { "none".to_string() } else { has.join(", ") }
            ),
        ));
    }
    for s in preset.sections() {
        if s == "afterimage" || s == "photometric" {
            lost.push(format!("{s}: not exported (no OpenPBR counterpart)"));
        }
    }
    Ok(Parameters {
        params,
        extras,
        lost,
    })
}

/// OpenPBR parameters of `preset` as JSON (see the module docs). The parameters are top-level
/// fields named as in the OpenPBR specification.
pub fn openpbr_parameters(
    preset: &MaterialPreset,
    file: &str,
    opts: &OpenPbrOptions,
) -> Result<Value> {
    let p = parameters(preset, file, opts)?;
    let mut doc = Map::new();
    doc.insert("format".into(), json!("OpenPBR Surface 1.1 parameters"));
    doc.insert("material".into(), json!(preset.name));
    doc.insert(
        "color_space".into(),
        json!(materialx_colorspace(&opts.space)?),
    );
    doc.insert("colorimetry".into(), json!(COLORIMETRY));
    for (k, v) in p.params {
        doc.insert(k.into(), v);
    }
    for (k, v) in p.extras {
        doc.insert(k, v);
    }
    doc.insert("lost".into(), json!(p.lost));
    Ok(Value::Object(doc))
}

/// A MaterialX identifier: letters, digits and `_`, not starting with a digit.
fn identifier(name: &str) -> String {
    let mut s: String = name
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect();
    if s.is_empty() || s.starts_with(|c: char| c.is_ascii_digit()) {
        s.insert(0, '_');
    }
    s
}

/// Text that may stand inside an XML comment (no `--`, no control characters).
fn comment_text(s: &str) -> String {
    let mut t: String = s
        .chars()
        .map(|c| if c.is_control() { ' ' } else { c })
        .collect();
    while t.contains("--") {
        t = t.replace("--", "- -");
    }
    if t.ends_with('-') {
        t.push(' ');
    }
    t
}

fn xml_attr(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// A MaterialX 1.39 document: one `open_pbr_surface` (the standard library's OpenPBR node) with
/// the parameters of [`openpbr_parameters`] and a `surfacematerial` using it.
pub fn materialx_document(
    preset: &MaterialPreset,
    file: &str,
    opts: &OpenPbrOptions,
) -> Result<String> {
    let colorspace = materialx_colorspace(&opts.space)?;
    let p = parameters(preset, file, opts)?;
    let id = identifier(&preset.name);
    let mut x = String::new();
    x.push_str("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n");
    x.push_str(&format!(
        "<materialx version=\"1.39\" colorspace=\"{colorspace}\">\n"
    ));
    x.push_str(&format!(
        "  <!-- lumifit {} preset export of '{}'. Colours linear in {colorspace} ({}). Not carried: {} -->\n",
        env!("CARGO_PKG_VERSION"),
        comment_text(&preset.name),
        comment_text(COLORIMETRY),
        comment_text(&if p.lost.is_empty() { "nothing".to_string() } else { p.lost.join("; ") }),
    ));
    x.push_str(&format!(
        "  <open_pbr_surface name=\"SR_{id}\" type=\"surfaceshader\">\n"
    ));
    for (name, v) in &p.params {
        let (ty, value) = match v {
            Value::Array(a) => (
                "color3",
                a.iter()
                    .map(|c| c.as_f64().unwrap_or(0.0).to_string())
                    .collect::<Vec<_>>()
                    .join(", "),
            ),
            other => ("float", other.as_f64().unwrap_or(0.0).to_string()),
        };
        x.push_str(&format!(
            "    <input name=\"{name}\" type=\"{ty}\" value=\"{}\" />\n",
            xml_attr(&value)
        ));
    }
    x.push_str("  </open_pbr_surface>\n");
    x.push_str(&format!(
        "  <surfacematerial name=\"M_{id}\" type=\"material\">\n    <input name=\"surfaceshader\" type=\"surfaceshader\" nodename=\"SR_{id}\" />\n  </surfacematerial>\n"
    ));
    x.push_str("</materialx>\n");
    Ok(x)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn identifiers_and_comments_are_safe_for_materialx() {
        assert_eq!(identifier("glow tape, green"), "glow_tape__green");
        assert_eq!(identifier("3M"), "_3M");
        assert!(!comment_text("a -- b ---").contains("--"));
        assert!(!comment_text("a-").ends_with('-'));
    }
}
