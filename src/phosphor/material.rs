//! A phosphorescent material (Nalbach et al. 2017, Eq. 1 and 3) and the 11 materials of the
//! paper's Table 1, embedded from `calib/phosphor_materials.json`.
//!
//! Model, per state i over n_λ bands b:
//!
//! `dr_i/dt = (1 − r_i) Σ_b k_e,i[b] E[b] − k_r,i r_i`,  `L_p[b] = Σ_i Λ_i[b] k_r,i r_i`,
//!
//! with concentrations r_i ∈ [0, 1], k_r in s⁻¹, E per band in the units the k_e were fitted for
//! (the paper normalises the light source's |E| to 1).

// Index loops mirror the matrix notation of the maths; `!(a > b)` comparisons deliberately
// reject NaN along with out-of-range values.
#![allow(clippy::needless_range_loop, clippy::neg_cmp_op_on_partial_ord)]

use std::sync::OnceLock;

use serde::Deserialize;

use crate::error::{Error, Result};

/// The spectral bands the per-band arrays refer to.
#[derive(Debug, Clone, PartialEq)]
pub enum BandSet {
    /// The camera's linear R, G, B channels.
    Rgb,
    /// Wavelength bands `[lo_nm, hi_nm]`.
    RangesNm(Vec<[f64; 2]>),
}

impl BandSet {
    /// Number of bands.
    pub fn len(&self) -> usize {
        match self {
            BandSet::Rgb => 3,
            BandSet::RangesNm(r) => r.len(),
        }
    }

    /// True when there are no bands.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// `n` uniform bands from `lo_nm` to `hi_nm`.
    pub fn uniform(lo_nm: f64, hi_nm: f64, n: usize) -> Result<Self> {
        if n == 0 || !(hi_nm > lo_nm) || !lo_nm.is_finite() || !hi_nm.is_finite() {
            return Err(Error::invalid(
                "bands",
                format!("{n} bands over {lo_nm}–{hi_nm} nm; expected n ≥ 1 and lo < hi"),
            ));
        }
        let w = (hi_nm - lo_nm) / n as f64;
        Ok(BandSet::RangesNm(
            (0..n)
                .map(|i| [lo_nm + w * i as f64, lo_nm + w * (i + 1) as f64])
                .collect(),
        ))
    }
}

/// One state of Eq. 1.
#[derive(Debug, Clone, PartialEq)]
pub struct PhosphorState {
    /// Re-radiation (decay) rate k_r in s⁻¹ (> 0).
    pub k_r_per_s: f64,
    /// Excitation rate per band (≥ 0); `None` when only the decay was measured.
    pub k_e: Option<Vec<f64>>,
    /// Re-radiation function Λ per band (≥ 0).
    pub lambda: Vec<f64>,
}

/// A material: bands and states.
#[derive(Debug, Clone, PartialEq)]
pub struct Material {
    /// Short name (`blue_paint`).
    pub name: String,
    /// The bands of every per-band array.
    pub bands: BandSet,
    /// The states, at least one.
    pub states: Vec<PhosphorState>,
}

impl Material {
    /// Checks the invariants: at least one state, k_r > 0 and finite, per-band arrays of the
    /// band count with finite non-negative values.
    pub fn validate(&self) -> Result<()> {
        let nb = self.bands.len();
        if nb == 0 {
            return Err(Error::invalid("bands", "no bands; expected at least one"));
        }
        if let BandSet::RangesNm(r) = &self.bands {
            for (b, [lo, hi]) in r.iter().enumerate() {
                if !(lo.is_finite() && hi.is_finite() && hi > lo) {
                    return Err(Error::invalid(
                        format!("bands[{b}]"),
                        format!("[{lo}, {hi}] nm; expected lo < hi, finite"),
                    ));
                }
            }
        }
        if self.states.is_empty() {
            return Err(Error::invalid("states", "no states; expected at least one"));
        }
        for (i, s) in self.states.iter().enumerate() {
            if !(s.k_r_per_s.is_finite() && s.k_r_per_s > 0.0) {
                return Err(Error::invalid(
                    format!("states[{i}].k_r_per_s"),
                    format!("{}; expected a finite rate > 0 s⁻¹", s.k_r_per_s),
                ));
            }
            let mut arrays = vec![("lambda", &s.lambda)];
            if let Some(k) = &s.k_e {
                arrays.push(("k_e", k));
            }
            for (what, a) in arrays {
                if a.len() != nb {
                    return Err(Error::ShapeMismatch {
                        what: format!("states[{i}].{what} against the bands"),
                        expected: nb,
                        got: a.len(),
                    });
                }
                if let Some(v) = a.iter().find(|v| !(v.is_finite() && **v >= 0.0)) {
                    return Err(Error::invalid(
                        format!("states[{i}].{what}"),
                        format!("value {v}; expected finite values ≥ 0"),
                    ));
                }
            }
        }
        Ok(())
    }

    /// Whether every state has excitation rates (needed to simulate charging).
    pub fn has_excitation(&self) -> bool {
        self.states.iter().all(|s| s.k_e.is_some())
    }
}

#[derive(Deserialize)]
struct CalibFile {
    bands_nm: Vec<[f64; 2]>,
    materials: Vec<CalibMaterial>,
}

#[derive(Deserialize)]
struct CalibMaterial {
    name: String,
    label: String,
    k_r_per_s: f64,
    #[serde(default)]
    k_e: Option<Vec<f64>>,
    lambda: Vec<f64>,
}

/// A Table 1 material with the paper's display label.
#[derive(Debug, Clone, PartialEq)]
pub struct TableMaterial {
    /// The paper's label ("Blue paint").
    pub label: String,
    /// The material (one state, 8 bands of 37.5 nm from 400 nm).
    pub material: Material,
}

const CALIB_JSON: &str = include_str!("../../calib/phosphor_materials.json");

fn parse_table() -> Result<Vec<TableMaterial>> {
    let f: CalibFile = serde_json::from_str(CALIB_JSON)
        .map_err(|e| Error::parse("calib/phosphor_materials.json", e.line(), e.to_string()))?;
    let bands = BandSet::RangesNm(f.bands_nm);
    f.materials
        .into_iter()
        .map(|m| {
            let material = Material {
                name: m.name,
                bands: bands.clone(),
                states: vec![PhosphorState {
                    k_r_per_s: m.k_r_per_s,
                    k_e: m.k_e,
                    lambda: m.lambda,
                }],
            };
            material.validate()?;
            Ok(TableMaterial {
                label: m.label,
                material,
            })
        })
        .collect()
}

/// The 11 materials of Table 1 (parsed once).
pub fn table1_materials() -> Result<&'static [TableMaterial]> {
    static CELL: OnceLock<std::result::Result<Vec<TableMaterial>, String>> = OnceLock::new();
    match CELL.get_or_init(|| parse_table().map_err(|e| e.to_string())) {
        Ok(v) => Ok(v),
        Err(e) => Err(Error::invalid("calib/phosphor_materials.json", e.clone())),
    }
}

/// A Table 1 material by name (`blue_paint`) or label (`Blue paint`), case-insensitive.
pub fn table1_material(name: &str) -> Result<&'static TableMaterial> {
    let all = table1_materials()?;
    let key = name.trim().to_ascii_lowercase().replace([' ', '-'], "_");
    all.iter()
        .find(|m| m.material.name == key)
        .ok_or_else(|| Error::UnknownName {
            kind: "phosphorescent material",
            name: name.to_string(),
            expected: all
                .iter()
                .map(|m| m.material.name.as_str())
                .collect::<Vec<_>>()
                .join(", "),
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table1_has_eleven_valid_materials_with_eight_bands() {
        let all = table1_materials().unwrap();
        assert_eq!(all.len(), 11);
        for m in all {
            assert_eq!(m.material.bands.len(), 8);
        }
        assert_eq!(
            table1_material("Blue paint").unwrap().material.states[0].k_r_per_s,
            0.032
        );
        assert!(table1_material("unobtainium").is_err());
    }
}
