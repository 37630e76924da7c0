//! The `afterimage` section of a material preset, as written by `lumifit afterimage synth`
//! (method `mikamo2013`): the parameters, the mask rule and the curves, enough for a renderer to
//! replay the model (Eq. 3 coefficients, Table 1 with its interpolation, Eq. 4–7 parameters).
//!
//! The section is stored in [`MaterialPreset::afterimage`](super::MaterialPreset) as a JSON
//! object; [`AfterimageSection::to_section`] and [`AfterimageSection::from_section`] convert both
//! ways, and the JSON Schema (`docs/preset-schema.json`, `$defs/afterimage_mikamo2013`) checks
//! every section whose `method` is `mikamo2013`.

use serde::{Deserialize, Serialize};

use super::types::OpenSection;
use crate::afterimage::mikamo2013::{
    CurvePoint, SynthParams, TimeRange, EQ3_BREAK_S, EQ3_COEFFICIENTS, TABLE1_T_S, TABLE1_XY,
};
use crate::colorimetry::rgb::D65_XY;
use crate::error::{Error, Result};

/// Method name written in the section.
pub const METHOD: &str = "mikamo2013";

/// The afterimage section (all fields are a contract of `lumifit.material/1`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AfterimageSection {
    /// Always [`METHOD`].
    pub method: String,
    /// γ of Z = (L_on / L_on^max)^γ.
    pub gamma: f64,
    /// k of Eq. 5–6.
    pub k: f64,
    /// Reference light chromaticity (x, y) of §3.2.
    pub reference_xy: [f64; 2],
    /// White of every Yxy → Lab conversion (D65, Yn = 1 = display white).
    pub white_xy: [f64; 2],
    /// How the input is normalised before the Lab conversions.
    pub normalisation: String,
    /// Which pixels make an afterimage.
    pub mask: MaskSection,
    /// Standard deviation of the Gaussian blur in pixels of the input (0: none).
    pub blur_sigma_px: f64,
    /// Eq. 7 parameters, present when a background was given.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dark_adaptation: Option<DarkSection>,
    /// Eq. 3.
    pub luminance: LuminanceSection,
    /// Table 1 and its interpolation.
    pub colour: ColourSection,
    /// Whether times after 80 s were allowed (colour held at 80 s, Eq. 3 continued).
    pub extrapolate: bool,
    /// The curves at the frame times.
    pub curves: CurvesSection,
}

/// The mask rule.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MaskSection {
    /// `relative_luminance_at_least`: Y / Y_max ≥ threshold (and Y > 0).
    pub rule: String,
    /// The threshold (0–1).
    pub threshold: f64,
}

/// Eq. 7.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DarkSection {
    /// c: the background at t = 0 is c·I_off.
    pub constant: f64,
    /// T, s.
    pub time_s: f64,
}

/// Eq. 3: `ln Y = slope·t + intercept`, first pair for t ≤ breakpoint.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LuminanceSection {
    /// Breakpoint, s.
    pub breakpoint_s: f64,
    /// Slopes of ln Y, per s.
    pub ln_y_slope_per_s: [f64; 2],
    /// Intercepts of ln Y.
    pub ln_y_intercept: [f64; 2],
}

/// Table 1.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ColourSection {
    /// `catmull-rom` (uniform, phantom end points 2P₀ − P₁).
    pub interpolation: String,
    /// Sample times, s.
    pub t_s: Vec<f64>,
    /// x per sample.
    pub x: Vec<f64>,
    /// y per sample.
    pub y: Vec<f64>,
}

/// The curves at the frame times (the `afterimage curves` CSV columns).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[allow(non_snake_case)]
pub struct CurvesSection {
    /// Times, s.
    pub t_s: Vec<f64>,
    /// Y_M.
    pub Y: Vec<f64>,
    /// x_M.
    pub x: Vec<f64>,
    /// y_M.
    pub y: Vec<f64>,
    /// L_M.
    pub L: Vec<f64>,
    /// a_M.
    pub a: Vec<f64>,
    /// b_M.
    pub b: Vec<f64>,
    /// τ_M.
    pub tau: Vec<f64>,
}

impl AfterimageSection {
    /// The section of a synthesis with `params` (dark adaptation recorded only when a background
    /// was used) and the curves at its frame times.
    pub fn new(params: &SynthParams, with_background: bool, curves: &[CurvePoint]) -> Self {
        AfterimageSection {
            method: METHOD.to_string(),
            gamma: params.gamma,
            k: params.k,
            reference_xy: params.reference_xy,
            white_xy: D65_XY,
            normalisation: "input divided by its largest luminance Y (brightest pixel Y = 1 = display white) before the Lab conversions".to_string(),
            mask: MaskSection {
                rule: "relative_luminance_at_least".to_string(),
                threshold: params.mask.threshold,
            },
            blur_sigma_px: params.blur_sigma_px,
            dark_adaptation: with_background.then_some(DarkSection {
                constant: params.dark.constant,
                time_s: params.dark.time_s,
            }),
            luminance: LuminanceSection {
                breakpoint_s: EQ3_BREAK_S,
                ln_y_slope_per_s: [EQ3_COEFFICIENTS[0][0], EQ3_COEFFICIENTS[1][0]],
                ln_y_intercept: [EQ3_COEFFICIENTS[0][1], EQ3_COEFFICIENTS[1][1]],
            },
            colour: ColourSection {
                interpolation: "catmull-rom".to_string(),
                t_s: TABLE1_T_S.to_vec(),
                x: TABLE1_XY.iter().map(|p| p[0]).collect(),
                y: TABLE1_XY.iter().map(|p| p[1]).collect(),
            },
            extrapolate: params.range == TimeRange::Extrapolate,
            curves: CurvesSection {
                t_s: curves.iter().map(|c| c.t_s).collect(),
                Y: curves.iter().map(|c| c.big_y).collect(),
                x: curves.iter().map(|c| c.x).collect(),
                y: curves.iter().map(|c| c.y).collect(),
                L: curves.iter().map(|c| c.lab[0]).collect(),
                a: curves.iter().map(|c| c.lab[1]).collect(),
                b: curves.iter().map(|c| c.lab[2]).collect(),
                tau: curves.iter().map(|c| c.tau).collect(),
            },
        }
    }

    /// As the JSON object stored in the preset.
    pub fn to_section(&self) -> Result<OpenSection> {
        match serde_json::to_value(self) {
            Ok(serde_json::Value::Object(m)) => Ok(m),
            Ok(_) => Err(Error::invalid("afterimage", "section is not a JSON object")),
            Err(e) => Err(Error::invalid(
                "afterimage",
                format!("cannot be represented as JSON: {e}"),
            )),
        }
    }

    /// Reads the section back (`file` names the preset in errors), checking what the schema
    /// cannot: the method, equal curve lengths.
    pub fn from_section(section: &OpenSection, file: &str) -> Result<Self> {
        let s: AfterimageSection =
            serde_json::from_value(serde_json::Value::Object(section.clone())).map_err(|e| {
                Error::SchemaViolation {
                    file: file.to_string(),
                    details: format!("  /afterimage: {e}"),
                }
            })?;
        if s.method != METHOD {
            return Err(Error::SchemaViolation {
                file: file.to_string(),
                details: format!(
                    "  /afterimage/method: '{}'; this lumifit reads '{METHOD}'",
                    s.method
                ),
            });
        }
        let c = &s.curves;
        let n = c.t_s.len();
        for (name, len) in [
            ("Y", c.Y.len()),
            ("x", c.x.len()),
            ("y", c.y.len()),
            ("L", c.L.len()),
            ("a", c.a.len()),
            ("b", c.b.len()),
            ("tau", c.tau.len()),
        ] {
            if len != n {
                return Err(Error::SchemaViolation {
                    file: file.to_string(),
                    details: format!(
                        "  /afterimage/curves/{name}: {len} values; expected one per time ({n})"
                    ),
                });
            }
        }
        let t = &s.colour;
        if t.x.len() != t.t_s.len() || t.y.len() != t.t_s.len() {
            return Err(Error::SchemaViolation {
                file: file.to_string(),
                details: "  /afterimage/colour: x and y need one value per t_s".to_string(),
            });
        }
        Ok(s)
    }
}
