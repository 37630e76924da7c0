//! Phosphorescence presets: the material a preset describes, and the presets that the decay fit,
//! the excitation fit and the design from keyframes write.
//!
//! The records these commands leave in `phosphorescence.extra` are typed: [`DecayFitRecord`]
//! (`extra.decay_fit`, written by `phos fit-decay`) is read back by `phos fit-excitation`
//! through the same type, so a renamed or missing field is an error naming the file and the
//! field, never a silently empty result. Renaming a field needs a schema version bump.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::phosphor::{
    self, AmplitudeModel, BandSet, Candidate, DecayFit, Material, PhosphorState,
};
use crate::preset::{
    read_material, Bands, InputFile, MaterialPreset, PhosphorescenceSection, PhosphorescentState,
    Provenance,
};

/// Key of the decay-fit record in `phosphorescence.extra`.
pub const DECAY_FIT_KEY: &str = "decay_fit";
/// Key of the excitation-fit record in `phosphorescence.extra`.
pub const EXCITATION_FIT_KEY: &str = "excitation_fit";
/// Key of the design record in `phosphorescence.extra`.
pub const DESIGN_KEY: &str = "design";

/// A material named on the command line: a Table 1 name, or a preset file with a
/// phosphorescence section (then the preset is kept too).
#[derive(Debug, Clone)]
pub struct ResolvedMaterial {
    /// The material.
    pub material: Material,
    /// The preset file and its content, when the material came from one.
    pub preset: Option<(PathBuf, MaterialPreset)>,
}

impl ResolvedMaterial {
    /// The preset file, if any (an input of the command).
    pub fn path(&self) -> Option<&Path> {
        self.preset.as_ref().map(|(p, _)| p.as_path())
    }
}

/// The material of a preset's phosphorescence section, validated; errors name `source`.
pub fn material_from_preset(preset: &MaterialPreset, source: &str) -> Result<Material> {
    let sec = preset.phosphorescence.as_ref().ok_or_else(|| {
        Error::invalid(
            source,
            "the preset has no 'phosphorescence' section; expected one with bands and states",
        )
    })?;
    let m = Material {
        name: preset.name.clone(),
        bands: match &sec.bands {
            Bands::Rgb => BandSet::Rgb,
            Bands::RangesNm(r) => BandSet::RangesNm(r.clone()),
        },
        states: sec
            .states
            .iter()
            .map(|s| PhosphorState {
                k_r_per_s: s.k_r_per_s,
                k_e: s.k_e.clone(),
                lambda: s.lambda.clone(),
            })
            .collect(),
    };
    m.validate()
        .map_err(|e| Error::invalid(format!("{source}: phosphorescence section"), e.to_string()))?;
    Ok(m)
}

/// A Table 1 name (e.g. `blue_paint`) or a material preset JSON file (`*.json` or an existing
/// file) with a phosphorescence section.
pub fn resolve_material(arg: &str) -> Result<ResolvedMaterial> {
    let p = Path::new(arg);
    if arg.ends_with(".json") || p.is_file() {
        let preset = read_material(p)?;
        let material = material_from_preset(&preset, arg)?;
        Ok(ResolvedMaterial {
            material,
            preset: Some((p.to_path_buf(), preset)),
        })
    } else {
        Ok(ResolvedMaterial {
            material: phosphor::table1_material(arg)?.material.clone(),
            preset: None,
        })
    }
}

/// One state of a [`DecayFitRecord`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DecayFitStateRecord {
    /// Amplitude at switch-off per unit spectrum (shared model) or the largest channel's.
    pub amplitude: f64,
    /// Its standard deviation.
    pub amplitude_sigma: Option<f64>,
    /// Amplitude per camera channel at switch-off.
    pub channel_amplitudes: Vec<f64>,
    /// Decay rate, s⁻¹.
    pub k_r_per_s: f64,
    /// Its standard deviation, s⁻¹.
    pub k_r_sigma_per_s: Option<f64>,
}

/// The factor applied to Λ so that the camera sees the measured RGB amplitudes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LambdaCameraScale {
    /// The camera file, or a description of the ideal box camera.
    pub camera: String,
    /// What the factor means.
    pub meaning: String,
    /// The factor.
    pub value: f64,
}

/// `phosphorescence.extra.decay_fit`: what `phos fit-decay` fitted (fields in alphabetical
/// order, as the JSON has always been written).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DecayFitRecord {
    /// The assumption that turns amplitudes into Λ.
    pub assumption: String,
    /// Background per channel, when fitted.
    pub background: Option<Vec<f64>>,
    /// The candidate models (BIC over the number of states).
    pub candidates: serde_json::Value,
    /// How the sample was charged before switch-off (`phos fit-decay --saturated`,
    /// `--charge-s`/`--charge-irradiance` or `charging.json`); absent in older presets, which
    /// assumed saturation. `phos fit-excitation` turns a flat charge into r(0) once k_e is known.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub charging: Option<crate::phosphor::DecayCharging>,
    /// What the report must say about the fit.
    pub flags: serde_json::Value,
    /// The Λ camera scale (with `--spectrum` and an RGB curve).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lambda_camera_scale: Option<LambdaCameraScale>,
    /// The model.
    pub model: String,
    /// Number of observations.
    pub n_obs: usize,
    /// Number of parameters.
    pub n_params: usize,
    /// Number of states.
    pub n_states: usize,
    /// Root-mean-square residual.
    pub rms: f64,
    /// ROI of a photo series (with `--roi`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub roi: Option<String>,
    /// Residual sum of squares.
    pub rss: f64,
    /// The photo series (with `--roi`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub series: Option<String>,
    /// Shared spectrum per channel.
    pub spectrum: Vec<f64>,
    /// The fitted states, fastest first.
    pub states: Vec<DecayFitStateRecord>,
    /// Solver termination.
    pub termination: serde_json::Value,
    /// Units of a photo-series curve (with `--roi`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub units: Option<String>,
}

/// A value as JSON (`null` if it cannot be represented, which the preset validation refuses).
fn json<T: Serialize>(v: &T) -> serde_json::Value {
    serde_json::to_value(v).unwrap_or(serde_json::Value::Null)
}

/// One fitted candidate. A candidate whose solver ran away (a rate that overflowed to ∞, or a
/// BIC/RSS that is not finite) was still fitted, and the record says so:
/// JSON has no ∞, and writing `null` made the whole preset fail its own schema, so the
/// non-finite rates are left out of `k_per_s` and counted in `diverged_states`, and a
/// non-finite `bic`/`rss` is omitted, with a `note`. A finite candidate is written as it always was.
fn candidate_json(c: &Candidate) -> serde_json::Value {
    let finite_k = c.k_per_s.iter().all(|k| k.is_finite());
    if finite_k && c.bic.is_finite() && c.rss.is_finite() {
        return json(c);
    }
    let mut m = serde_json::Map::new();
    m.insert("n_states".into(), serde_json::json!(c.n_states));
    if c.bic.is_finite() {
        m.insert("bic".into(), serde_json::json!(c.bic));
    }
    if c.rss.is_finite() {
        m.insert("rss".into(), serde_json::json!(c.rss));
    }
    let k: Vec<f64> = c
        .k_per_s
        .iter()
        .copied()
        .filter(|k| k.is_finite())
        .collect();
    m.insert("k_per_s".into(), serde_json::json!(k));
    m.insert(
        "diverged_states".into(),
        serde_json::json!(c.k_per_s.len() - k.len()),
    );
    m.insert("termination".into(), json(&c.termination));
    m.insert(
        "note".into(),
        serde_json::json!(
            "the solver diverged on this candidate (a rate or the BIC/RSS is not finite); \
             the non-finite values are left out"
        ),
    );
    serde_json::Value::Object(m)
}

/// The fitted candidates, then the screened-out one (not fitted), if any.
fn candidates_json(fit: &DecayFit) -> serde_json::Value {
    let mut v = serde_json::Value::Array(fit.candidates.iter().map(candidate_json).collect());
    if let (Some(sc), serde_json::Value::Array(list)) = (&fit.screened, &mut v) {
        list.push(serde_json::json!({
            "n_states": sc.n_states,
            "screened": true,
            "gain_ratio": sc.gain_ratio,
            "note": "not fitted: one more state could gain only gain_ratio of the RSS reduction BIC requires",
        }));
    }
    v
}

impl DecayFitRecord {
    /// The record of a decay fit.
    pub fn new(fit: &DecayFit) -> Self {
        Self {
            assumption: "saturation at switch-off (r_i(0) = 1, Nalbach et al. 2017 §4.4): lambda_i = a_i * spectrum / k_r,i".into(),
            background: fit.background.clone(),
            candidates: candidates_json(fit),
            charging: None,
            flags: json(&fit.flags),
            lambda_camera_scale: None,
            model: match fit.amplitudes {
                AmplitudeModel::SharedSpectrum => {
                    "sum of exponentials, spectrum shared by all states".into()
                }
                AmplitudeModel::PerChannel => "sum of exponentials, amplitudes per channel".into(),
            },
            n_obs: fit.n_obs,
            n_params: fit.n_params,
            n_states: fit.states.len(),
            rms: fit.rms,
            roi: None,
            rss: fit.rss,
            series: None,
            spectrum: fit.spectrum.clone(),
            states: fit
                .states
                .iter()
                .map(|s| DecayFitStateRecord {
                    amplitude: s.amplitude,
                    amplitude_sigma: s.amplitude_sigma,
                    channel_amplitudes: s.channel_amplitudes.clone(),
                    k_r_per_s: s.k_per_s,
                    k_r_sigma_per_s: s.k_sigma_per_s,
                })
                .collect(),
            termination: json(&fit.termination),
            units: None,
        }
    }

    /// The record in a preset's phosphorescence section: `Ok(None)` when there is none (a
    /// Table 1 material or a designed one), an error naming `source` and the field when it is
    /// there but does not read as a decay-fit record.
    pub fn from_preset(preset: &MaterialPreset, source: &str) -> Result<Option<Self>> {
        let Some(v) = preset
            .phosphorescence
            .as_ref()
            .and_then(|s| s.extra.get(DECAY_FIT_KEY))
        else {
            return Ok(None);
        };
        serde_json::from_value(v.clone()).map(Some).map_err(|e| {
            Error::invalid(
                format!("{source}: phosphorescence.{DECAY_FIT_KEY}"),
                format!("{e}; expected the record written by `lumifit phos fit-decay`"),
            )
        })
    }
}

/// Provenance of `command` listing `files` with the SHA-256 of each (read now).
pub fn provenance_of_files<P: AsRef<Path>>(command: &str, files: &[P]) -> Result<Provenance> {
    let mut p = Provenance::new::<&Path>(command, &[]);
    p.inputs = files
        .iter()
        .map(InputFile::from_file)
        .collect::<Result<Vec<_>>>()?;
    Ok(p)
}

/// The fit-quality summary of a decay fit (flags joined by `;`).
pub fn decay_flags_text(fit: &DecayFit) -> String {
    fit.flags
        .iter()
        .map(|f| f.name())
        .collect::<Vec<_>>()
        .join(";")
}

/// The preset of `phos fit-decay`: bands, states (k_r, Λ) and the decay-fit record.
pub fn decay_fit_preset(
    name: &str,
    provenance: Provenance,
    bands: Bands,
    states: Vec<(f64, Vec<f64>)>,
    record: &DecayFitRecord,
) -> Result<MaterialPreset> {
    let mut preset = MaterialPreset::new(name.to_string(), provenance);
    let mut extra = serde_json::Map::new();
    extra.insert(
        DECAY_FIT_KEY.into(),
        serde_json::to_value(record).map_err(|e| Error::invalid(DECAY_FIT_KEY, e.to_string()))?,
    );
    preset.phosphorescence = Some(PhosphorescenceSection {
        bands,
        states: states
            .into_iter()
            .map(|(k, l)| PhosphorescentState::new(k, None, l))
            .collect(),
        extra,
    });
    Ok(preset)
}

/// The preset of `phos fit-excitation`: the base preset (when the material came from one)
/// with k_e per state, Λ replaced when it was rescaled, the excitation record, and provenance
/// whose fit quality keeps the earlier one under `earlier`. Without a base, a new preset with
/// wavelength bands `ranges`.
pub fn excitation_preset(
    base: Option<MaterialPreset>,
    updated: &Material,
    ranges: &[[f64; 2]],
    lambda_rescaled: bool,
    provenance: Provenance,
    report: serde_json::Value,
) -> MaterialPreset {
    let mut preset = match base {
        Some(mut p) => {
            if let Some(old) = p.provenance.fit_quality.take() {
                let mut q = provenance.fit_quality.clone().unwrap_or_default();
                if let Some(obj) = q.as_object_mut() {
                    obj.insert("earlier".into(), old);
                }
                p.provenance = Provenance {
                    fit_quality: Some(q),
                    ..provenance
                };
            } else {
                p.provenance = provenance;
            }
            p
        }
        None => MaterialPreset::new(updated.name.clone(), provenance),
    };
    let mut section = preset
        .phosphorescence
        .take()
        .unwrap_or_else(|| PhosphorescenceSection {
            bands: Bands::RangesNm(ranges.to_vec()),
            states: vec![],
            extra: serde_json::Map::new(),
        });
    let old_states = std::mem::take(&mut section.states);
    section.states = updated
        .states
        .iter()
        .enumerate()
        .map(|(i, s)| {
            let mut st = old_states
                .get(i)
                .cloned()
                .unwrap_or_else(|| PhosphorescentState::new(s.k_r_per_s, None, s.lambda.clone()));
            st.k_e = s.k_e.clone();
            if lambda_rescaled {
                st.lambda = s.lambda.clone();
            }
            st
        })
        .collect();
    section.extra.insert(EXCITATION_FIT_KEY.into(), report);
    preset.phosphorescence = Some(section);
    preset
}

/// The preset of `phos design`: one RGB state with k_r, k_e and Λ, and the design record.
pub fn design_preset(
    name: &str,
    provenance: Provenance,
    k_r_per_s: f64,
    k_e: [f64; 3],
    lambda: [f64; 3],
    report: serde_json::Value,
) -> MaterialPreset {
    let mut preset = MaterialPreset::new(name.to_string(), provenance);
    let mut extra = serde_json::Map::new();
    extra.insert(DESIGN_KEY.into(), report);
    preset.phosphorescence = Some(PhosphorescenceSection {
        bands: Bands::Rgb,
        states: vec![PhosphorescentState::new(
            k_r_per_s,
            Some(k_e.to_vec()),
            lambda.to_vec(),
        )],
        extra,
    });
    preset
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::preset::{parse_preset, to_json_string, Preset};

    fn record() -> DecayFitRecord {
        DecayFitRecord {
            assumption: "a".into(),
            background: None,
            candidates: serde_json::json!([{"n_states": 1, "bic": -3.5}]),
            charging: None,
            flags: serde_json::json!([]),
            lambda_camera_scale: Some(LambdaCameraScale {
                camera: "cam.csv".into(),
                meaning: "m".into(),
                value: 0.75,
            }),
            model: "sum".into(),
            n_obs: 30,
            n_params: 5,
            n_states: 1,
            rms: 1e-3,
            roi: None,
            rss: 3e-5,
            series: None,
            spectrum: vec![1.0, 0.5, 0.25],
            states: vec![DecayFitStateRecord {
                amplitude: 2.0,
                amplitude_sigma: Some(0.01),
                channel_amplitudes: vec![2.0, 1.0, 0.5],
                k_r_per_s: 0.1,
                k_r_sigma_per_s: None,
            }],
            termination: serde_json::json!("converged"),
            units: None,
        }
    }

    #[test]
    fn a_decay_fit_preset_round_trips_its_record_through_the_preset_json() {
        let prov = Provenance::new::<&str>("test", &[]);
        let r = record();
        let p = decay_fit_preset(
            "m",
            prov,
            Bands::Rgb,
            vec![(0.1, vec![0.5, 0.25, 0.125])],
            &r,
        )
        .unwrap();
        let text = to_json_string(&p).unwrap();
        let Preset::Material(back) = parse_preset(text.as_bytes(), "m.json").unwrap() else {
            panic!("not a material preset");
        };
        assert_eq!(
            DecayFitRecord::from_preset(&back, "m.json").unwrap(),
            Some(r)
        );
        let m = material_from_preset(&back, "m.json").unwrap();
        assert_eq!(m.states.len(), 1);
        assert_eq!(m.states[0].lambda, vec![0.5, 0.25, 0.125]);
    }

    #[test]
    fn a_candidate_whose_rate_overflowed_is_recorded_without_null_and_says_so() {
        use crate::fit::Termination;
        let finite = Candidate {
            n_states: 2,
            bic: -120.5,
            rss: 0.25,
            k_per_s: vec![0.5, 0.01],
            termination: Termination::CostConverged,
        };
        assert_eq!(candidate_json(&finite), json(&finite));
        let runaway = Candidate {
            n_states: 3,
            bic: f64::NAN,
            rss: 0.24,
            k_per_s: vec![f64::INFINITY, 0.5, 0.01],
            termination: Termination::NonFinite,
        };
        let v = candidate_json(&runaway);
        assert!(!v.to_string().contains("null"), "{v}");
        assert_eq!(v["k_per_s"], serde_json::json!([0.5, 0.01]));
        assert_eq!(v["diverged_states"], serde_json::json!(1));
        assert_eq!(v["rss"], serde_json::json!(0.24));
        assert!(v.get("bic").is_none());
        assert!(v["note"].as_str().unwrap().contains("diverged"));
        // and the preset that holds it passes its own schema
        let prov = Provenance::new::<&str>("test", &[]);
        let mut r = record();
        r.candidates = serde_json::Value::Array(vec![json(&finite), v]);
        let p = decay_fit_preset(
            "m",
            prov,
            Bands::Rgb,
            vec![(0.1, vec![0.5, 0.25, 0.125])],
            &r,
        )
        .unwrap();
        let text = to_json_string(&p).unwrap();
        assert!(parse_preset(text.as_bytes(), "m.json").is_ok());
    }

    #[test]
    fn a_renamed_field_of_the_decay_record_is_an_error_naming_the_field() {
        let prov = Provenance::new::<&str>("test", &[]);
        let mut p = decay_fit_preset(
            "m",
            prov,
            Bands::Rgb,
            vec![(0.1, vec![0.5, 0.25, 0.125])],
            &record(),
        )
        .unwrap();
        let sec = p.phosphorescence.as_mut().unwrap();
        let rec = sec.extra.get_mut(DECAY_FIT_KEY).unwrap();
        let st = rec["states"][0].as_object_mut().unwrap();
        let v = st.remove("channel_amplitudes").unwrap();
        st.insert("rgb_amplitudes".into(), v);
        let e = DecayFitRecord::from_preset(&p, "m.json")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("m.json: phosphorescence.decay_fit") && e.contains("channel_amplitudes"),
            "{e}"
        );
    }

    #[test]
    fn a_preset_without_a_decay_record_has_none() {
        let prov = Provenance::new::<&str>("test", &[]);
        let p = design_preset(
            "d",
            prov,
            0.1,
            [1.0, 1.0, 1.0],
            [0.1, 0.2, 0.3],
            serde_json::json!({}),
        );
        assert_eq!(DecayFitRecord::from_preset(&p, "d.json").unwrap(), None);
    }
}
