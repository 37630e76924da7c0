//! Rust twins of the shader snippets: the same `f32` constants, the same operations in the same
//! order, so a test of the twin against the library's `f64` computation is a test of the shader.

use serde::Deserialize;

use crate::colorimetry::rgb::RgbSpace;
use crate::error::{Error, Result};

use super::super::types::{OpenSection, PhosphorescenceSection};
use super::{band_to_rgb, MAX_BANDS, MAX_STATES};

/// The phosphorescence snippet's constants and its per-frame update, in `f32`.
#[derive(Debug, Clone, PartialEq)]
pub struct PhosphorTwin {
    /// Number of states in the preset (≤ [`MAX_STATES`]); the other lanes are inert.
    pub n_states: usize,
    /// Number of bands of the irradiance array.
    pub n_bands: usize,
    /// Decay rate per lane in s⁻¹ (1 for unused lanes).
    pub k_r_per_s: [f32; MAX_STATES],
    /// Excitation coefficient per lane and band (0 for unused lanes or absent `k_e`).
    pub k_e: [Vec<f32>; MAX_STATES],
    /// Linear RGB emitted per unit concentration of each lane, `C_i = k_r,i Σ_b λ_i[b] M[:, b]`.
    pub rgb_per_state: [[f32; 3]; MAX_STATES],
}

impl PhosphorTwin {
    /// The constants of a phosphorescence section, emission in linear RGB of `space`.
    pub fn from_section(section: &PhosphorescenceSection, space: &RgbSpace) -> Result<Self> {
        let n_states = section.states.len();
        if n_states == 0 || n_states > MAX_STATES {
            return Err(Error::invalid(
                "phosphorescence.states",
                format!(
                    "{n_states} states; a shader snippet packs 1 to {MAX_STATES} states in a vec4"
                ),
            ));
        }
        let n_bands = section.bands.len();
        if n_bands == 0 || n_bands > MAX_BANDS {
            return Err(Error::invalid(
                "phosphorescence.bands",
                format!("{n_bands} bands; a shader snippet takes 1 to {MAX_BANDS}"),
            ));
        }
        let m = band_to_rgb(&section.bands, space)?;
        let mut k_r = [1.0f32; MAX_STATES];
        let mut k_e: [Vec<f32>; MAX_STATES] = std::array::from_fn(|_| vec![0.0; n_bands]);
        let mut c = [[0.0f32; 3]; MAX_STATES];
        for (i, s) in section.states.iter().enumerate() {
            let field = |f: &str| format!("phosphorescence.states[{i}].{f}");
            if !(s.k_r_per_s.is_finite() && s.k_r_per_s > 0.0) {
                return Err(Error::invalid(
                    field("k_r_per_s"),
                    format!("{}; expected a finite rate > 0", s.k_r_per_s),
                ));
            }
            if s.lambda.len() != n_bands {
                return Err(Error::ShapeMismatch {
                    what: field("lambda"),
                    expected: n_bands,
                    got: s.lambda.len(),
                });
            }
            k_r[i] = s.k_r_per_s as f32;
            if let Some(ke) = &s.k_e {
                if ke.len() != n_bands {
                    return Err(Error::ShapeMismatch {
                        what: field("k_e"),
                        expected: n_bands,
                        got: ke.len(),
                    });
                }
                k_e[i] = ke.iter().map(|&v| v as f32).collect();
            }
            for ch in 0..3 {
                let v: f64 = s.k_r_per_s
                    * s.lambda
                        .iter()
                        .zip(&m)
                        .map(|(l, col)| l * col[ch])
                        .sum::<f64>();
                c[i][ch] = v as f32;
            }
        }
        let all: Vec<f64> = k_r
            .iter()
            .chain(k_e.iter().flatten())
            .chain(c.iter().flatten())
            .map(|&v| v as f64)
            .collect();
        crate::error::ensure_finite(
            "shader constants (f32)",
            "the phosphorescence section",
            &all,
        )?;
        Ok(PhosphorTwin {
            n_states,
            n_bands,
            k_r_per_s: k_r,
            k_e,
            rgb_per_state: c,
        })
    }

    /// `a_i = Σ_b k_e,i[b]·E[b]`, summed in band order as the snippet writes it.
    pub fn excitation(&self, irradiance: &[f32]) -> [f32; MAX_STATES] {
        std::array::from_fn(|i| {
            let (k, e) = (&self.k_e[i], &irradiance[..self.n_bands]);
            let mut a = k[0] * e[0];
            for (kb, eb) in k.iter().zip(e).skip(1) {
                a += kb * eb;
            }
            a
        })
    }

    /// One frame of length `dt_s` under constant `irradiance` (one value per band), exact.
    pub fn step(&self, r: [f32; MAX_STATES], irradiance: &[f32], dt_s: f32) -> [f32; MAX_STATES] {
        let a = self.excitation(irradiance);
        std::array::from_fn(|i| {
            let lam = a[i] + self.k_r_per_s[i];
            let r_eq = a[i] / lam;
            r_eq + (r[i] - r_eq) * (-lam * dt_s).exp()
        })
    }

    /// Emitted linear RGB for concentrations `r`, `Σ_i r_i·C_i` in lane order.
    pub fn emission_rgb(&self, r: [f32; MAX_STATES]) -> [f32; 3] {
        std::array::from_fn(|ch| {
            let mut v = self.rgb_per_state[0][ch] * r[0];
            for (c, ri) in self.rgb_per_state.iter().zip(r).skip(1) {
                v += c[ch] * ri;
            }
            v
        })
    }
}

/// The part of a fluorescence section a snippet needs (`rgb.space`, `rgb.matrix`).
#[derive(Debug, Clone, Deserialize)]
struct RgbReduction {
    space: String,
    matrix: [[f64; 3]; 3],
}

/// The fluorescence snippet's constants and its shading, in `f32`.
#[derive(Debug, Clone, PartialEq)]
pub struct FluorTwin {
    /// The RGB space the matrix works in (`fluorescence.rgb.space`).
    pub space: String,
    /// Reduced matrix, row = output channel.
    pub matrix: [[f32; 3]; 3],
}

impl FluorTwin {
    /// The constants of a fluorescence section.
    pub fn from_section(section: &OpenSection) -> Result<Self> {
        let rgb = section.get("rgb").ok_or_else(|| {
            Error::invalid(
                "fluorescence.rgb",
                "missing; expected {space, matrix} as written by `lumifit fluor reduce`",
            )
        })?;
        let red: RgbReduction = serde_json::from_value(rgb.clone()).map_err(|e| {
            Error::invalid(
                "fluorescence.rgb",
                format!("{e}; expected {{\"space\": NAME, \"matrix\": [[3 numbers] × 3]}}"),
            )
        })?;
        let matrix = red.matrix.map(|row| row.map(|v| v as f32));
        crate::error::ensure_finite(
            "fluorescence.rgb.matrix (f32)",
            "the fluorescence section",
            &matrix
                .iter()
                .flatten()
                .map(|&v| v as f64)
                .collect::<Vec<_>>(),
        )?;
        Ok(FluorTwin {
            space: red.space,
            matrix,
        })
    }

    /// `max(M · rgb_in, 0)`, each row summed in column order.
    pub fn shade(&self, rgb_in: [f32; 3]) -> [f32; 3] {
        std::array::from_fn(|r| {
            let m = self.matrix[r];
            (m[0] * rgb_in[0] + m[1] * rgb_in[1] + m[2] * rgb_in[2]).max(0.0)
        })
    }
}
