//! Validation of a parsed preset: schema version, JSON Schema, then the checks JSON Schema cannot
//! express.

use std::sync::OnceLock;

use serde_json::Value;

use super::types::{Bands, LightPreset, MaterialPreset, PhosphorescenceSection, Preset};
use super::{MATERIAL_SCHEMA, SCHEMA_JSON, SUPPORTED_SCHEMAS};
use crate::error::{Error, Result};

/// Longest message kept from the JSON Schema validator (it quotes the offending instance, which
/// can be a whole section).
const MAX_MESSAGE_CHARS: usize = 300;

/// The embedded JSON Schema, parsed.
pub fn schema_value() -> Result<Value> {
    serde_json::from_str(SCHEMA_JSON).map_err(|e| {
        Error::parse(
            "docs/preset-schema.json (embedded)",
            e.line(),
            e.to_string(),
        )
    })
}

fn validator() -> Result<&'static jsonschema::Validator> {
    static VALIDATOR: OnceLock<std::result::Result<jsonschema::Validator, String>> =
        OnceLock::new();
    let built = VALIDATOR.get_or_init(|| {
        let schema = schema_value().map_err(|e| e.to_string())?;
        jsonschema::draft202012::options()
            .should_validate_formats(true)
            .build(&schema)
            .map_err(|e| e.to_string())
    });
    built.as_ref().map_err(|message| Error::SchemaViolation {
        file: "docs/preset-schema.json (embedded)".to_string(),
        details: format!("  the schema itself does not compile: {message}"),
    })
}

/// One violation line: JSON pointer (or `(root)`) and message.
fn violation(pointer: &str, message: &str) -> String {
    let pointer = if pointer.is_empty() {
        "(root)"
    } else {
        pointer
    };
    let mut message = message.to_string();
    if message.chars().count() > MAX_MESSAGE_CHARS {
        message = message.chars().take(MAX_MESSAGE_CHARS).collect::<String>() + " …";
    }
    format!("  {pointer}: {message}")
}

fn violations(file: &str, lines: Vec<String>) -> Result<()> {
    if lines.is_empty() {
        Ok(())
    } else {
        Err(Error::SchemaViolation {
            file: file.to_string(),
            details: lines.join("\n"),
        })
    }
}

/// Validates a parsed preset and returns it typed. `file` names the source in errors.
///
/// Order: the `schema` field (unknown versions give [`Error::UnsupportedSchema`]), the JSON
/// Schema (every violation, as JSON pointer and message, in one [`Error::SchemaViolation`]), then
/// typed deserialisation and semantic checks (equal lengths, strictly increasing wavelengths,
/// band ranges with `lo_nm < hi_nm`, one `k_e` and `lambda` value per band).
pub fn validate_value(value: &Value, file: &str) -> Result<Preset> {
    let schema = schema_id(value, file)?;

    let errors: Vec<String> = validator()?
        .iter_errors(value)
        .map(|e| violation(e.instance_path().as_str(), &e.to_string()))
        .collect();
    let mut unique = Vec::with_capacity(errors.len());
    for e in errors {
        if !unique.contains(&e) {
            unique.push(e);
        }
    }
    violations(file, unique)?;
    violations(file, null_numbers(value))?;

    let typed_error = |e: serde_json::Error| Error::SchemaViolation {
        file: file.to_string(),
        details: violation("", &e.to_string()),
    };
    let preset = if schema == MATERIAL_SCHEMA {
        let m: MaterialPreset = serde_json::from_value(value.clone()).map_err(typed_error)?;
        violations(file, check_material(&m))?;
        Preset::Material(m)
    } else {
        let l: LightPreset = serde_json::from_value(value.clone()).map_err(typed_error)?;
        Preset::Light(l)
    };
    Ok(preset)
}

/// Most `null` entries listed in one error.
const MAX_NULLS_LISTED: usize = 8;

/// `null` inside an array of a section: what serde writes for a non-finite number (overflow,
/// 0/0). A preset's arrays hold numbers (or strings), never nulls, so each is a violation naming
/// its JSON pointer. The provenance (free-form fit quality) is not checked.
fn null_numbers(value: &Value) -> Vec<String> {
    // `strict`: a typed section without optional fields, where any null is a lost number.
    fn walk(
        v: &Value,
        pointer: &mut String,
        in_array: bool,
        strict: bool,
        found: &mut Vec<String>,
    ) {
        match v {
            Value::Null if in_array || strict => found.push(pointer.clone()),
            Value::Array(items) => {
                for (i, item) in items.iter().enumerate() {
                    let len = pointer.len();
                    pointer.push_str(&format!("/{i}"));
                    walk(item, pointer, true, strict, found);
                    pointer.truncate(len);
                }
            }
            Value::Object(map) => {
                for (k, item) in map {
                    let len = pointer.len();
                    pointer.push('/');
                    pointer.push_str(&k.replace('~', "~0").replace('/', "~1"));
                    walk(item, pointer, false, strict, found);
                    pointer.truncate(len);
                }
            }
            _ => {}
        }
    }
    let mut found = Vec::new();
    if let Some(map) = value.as_object() {
        for (k, v) in map {
            if k != "provenance" {
                let strict = k == "fluorescence";
                walk(v, &mut format!("/{k}"), false, strict, &mut found);
            }
        }
    }
    let n = found.len();
    let mut lines: Vec<String> = found
        .iter()
        .take(MAX_NULLS_LISTED)
        .map(|p| {
            violation(
                p,
                "null where a number was expected (a non-finite value — overflow or 0/0 — written as null)",
            )
        })
        .collect();
    if n > MAX_NULLS_LISTED {
        lines.push(format!(
            "  … and {} more null entries",
            n - MAX_NULLS_LISTED
        ));
    }
    lines
}

/// Reads the `schema` field and checks it is one this lumifit reads.
fn schema_id(value: &Value, file: &str) -> Result<&'static str> {
    let expected = SUPPORTED_SCHEMAS
        .iter()
        .map(|s| format!("'{s}'"))
        .collect::<Vec<_>>()
        .join(" or ");
    let Some(object) = value.as_object() else {
        return violations(
            file,
            vec![violation(
                "",
                "a preset is a JSON object with a \"schema\" field",
            )],
        )
        .map(|_| MATERIAL_SCHEMA);
    };
    let found = match object.get("schema") {
        None => {
            return violations(
                file,
                vec![violation(
                    "/schema",
                    &format!("missing; expected {expected}"),
                )],
            )
            .map(|_| MATERIAL_SCHEMA)
        }
        Some(Value::String(s)) => s,
        Some(other) => {
            return violations(
                file,
                vec![violation(
                    "/schema",
                    &format!("{other} is not a string; expected {expected}"),
                )],
            )
            .map(|_| MATERIAL_SCHEMA)
        }
    };
    SUPPORTED_SCHEMAS
        .iter()
        .find(|s| **s == found.as_str())
        .copied()
        .ok_or_else(|| Error::UnsupportedSchema {
            file: file.to_string(),
            found: found.clone(),
            expected,
        })
}

/// Checks a material preset beyond the JSON Schema; one line per violation.
fn check_material(m: &MaterialPreset) -> Vec<String> {
    let mut out = Vec::new();
    if m.schema != MATERIAL_SCHEMA {
        out.push(violation(
            "/schema",
            &format!("expected '{MATERIAL_SCHEMA}', found '{}'", m.schema),
        ));
    }
    if let Some(r) = &m.reflectance {
        check_samples(
            "/reflectance",
            &r.wavelength_nm,
            &r.value,
            "value",
            &mut out,
        );
    }
    if let Some(p) = &m.phosphorescence {
        check_phosphorescence(p, &mut out);
    }
    if let Some(d) = &m.dispersion {
        for (pointer, message) in super::dispersion::check(d) {
            out.push(violation(&pointer, &message));
        }
    }
    out
}

/// Checks a sampled spectrum: finite, strictly increasing wavelengths and one value per
/// wavelength.
fn check_samples(
    at: &str,
    wavelength_nm: &[f64],
    values: &[f64],
    values_name: &str,
    out: &mut Vec<String>,
) {
    if values.len() != wavelength_nm.len() {
        out.push(violation(
            &format!("{at}/{values_name}"),
            &format!(
                "has {} values but wavelength_nm has {}; expected one value per wavelength",
                values.len(),
                wavelength_nm.len()
            ),
        ));
    }
    for (i, pair) in wavelength_nm.windows(2).enumerate() {
        if pair[1].partial_cmp(&pair[0]) != Some(std::cmp::Ordering::Greater) {
            out.push(violation(
                &format!("{at}/wavelength_nm/{}", i + 1),
                &format!(
                    "{} nm does not follow {} nm; wavelengths must be strictly increasing",
                    pair[1], pair[0]
                ),
            ));
        }
    }
}

fn check_phosphorescence(p: &PhosphorescenceSection, out: &mut Vec<String>) {
    if let Bands::RangesNm(ranges) = &p.bands {
        for (i, [lo_nm, hi_nm]) in ranges.iter().enumerate() {
            if lo_nm.partial_cmp(hi_nm) != Some(std::cmp::Ordering::Less) {
                out.push(violation(
                    &format!("/phosphorescence/bands/{i}"),
                    &format!("[{lo_nm}, {hi_nm}] is not a band; expected [lo_nm, hi_nm] with lo_nm < hi_nm"),
                ));
            }
        }
    }
    let n = p.bands.len();
    let bands = match &p.bands {
        Bands::Rgb => "\"rgb\" has 3 bands".to_string(),
        Bands::RangesNm(_) => format!("bands has {n}"),
    };
    for (i, state) in p.states.iter().enumerate() {
        if !(state.k_r_per_s > 0.0 && state.k_r_per_s.is_finite()) {
            out.push(violation(
                &format!("/phosphorescence/states/{i}/k_r_per_s"),
                &format!(
                    "{} is not a decay rate; expected a finite rate > 0 s⁻¹",
                    state.k_r_per_s
                ),
            ));
        }
        let per_band = std::iter::once(("lambda", Some(&state.lambda)))
            .chain(std::iter::once(("k_e", state.k_e.as_ref())));
        for (field, values) in per_band {
            if let Some(values) = values {
                if values.len() != n {
                    out.push(violation(
                        &format!("/phosphorescence/states/{i}/{field}"),
                        &format!(
                            "has {} values but {bands}; expected one value per band",
                            values.len()
                        ),
                    ));
                }
            }
        }
    }
}
