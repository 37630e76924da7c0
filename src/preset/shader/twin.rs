//! Rust twins of the shader snippets: the same `f32` constants, the same operations in the same
//! order, so a test of the twin against the library's `f64` computation is a test of the shader.

use crate::colorimetry::rgb::RgbSpace;
use crate::error::{Error, Result};

use super::super::afterimage::AfterimageSection;
use super::super::dispersion::DispersionSection;
use super::super::types::{FluorescenceSection, PhosphorescenceSection};
use super::{band_to_rgb, MAX_BANDS, MAX_STATES};
use crate::dispersion::model::Model;

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

/// The fluorescence snippet's constants and its shading, in `f32`.
#[derive(Debug, Clone, PartialEq)]
pub struct FluorTwin {
    /// The RGB space the matrix works in (`fluorescence.rgb.space`).
    pub space: String,
    /// Reduced matrix, row = output channel.
    pub matrix: [[f32; 3]; 3],
}

impl FluorTwin {
    /// The constants of a fluorescence section (`rgb.space`, `rgb.matrix`).
    pub fn from_section(section: &FluorescenceSection) -> Result<Self> {
        let red = &section.rgb;
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
            space: red.space.clone(),
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

/// Refractive index model of a dispersion snippet, λ in µm (the section's `model`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum IorKind {
    /// n = Σ cᵢ λ⁻²ⁱ, evaluated by Horner in λ⁻².
    Cauchy,
    /// n² = 1 + Σ Bᵢ λ²/(λ² − Cᵢ), pairs `[B₁, C₁, …]`, Cᵢ in µm².
    Sellmeier,
}

/// The dispersion snippet's constants and functions, in `f32`.
#[derive(Debug, Clone, PartialEq)]
pub struct DispersionTwin {
    /// The working space of the sample weights (`dispersion.working_space`).
    pub space: String,
    /// The range the model was fitted over, nm.
    pub range_nm: [f32; 2],
    /// The model's family.
    pub kind: IorKind,
    /// The model's coefficients in the section's order.
    pub coefficients: Vec<f32>,
    /// Sample wavelengths, nm.
    pub lambda_nm: Vec<f32>,
    /// Sample weights, linear RGB of `space` (they sum to its white).
    pub rgb: Vec<[f32; 3]>,
}

/// Most wavelength samples a dispersion snippet carries.
pub const MAX_DISPERSION_SAMPLES: usize = 256;

/// Most coefficients of a dispersion model in a snippet.
pub const MAX_DISPERSION_COEFFICIENTS: usize = 16;

impl DispersionTwin {
    /// The constants of a dispersion section.
    pub fn from_section(section: &DispersionSection) -> Result<Self> {
        let model = section.to_model()?;
        let kind = match model {
            Model::Cauchy(_) => IorKind::Cauchy,
            Model::Sellmeier(_) => IorKind::Sellmeier,
        };
        let n = section.samples.len();
        if n == 0 || n > MAX_DISPERSION_SAMPLES {
            return Err(Error::invalid(
                "dispersion.samples",
                format!("{n} samples; a shader snippet carries 1 to {MAX_DISPERSION_SAMPLES}"),
            ));
        }
        let nc = model.coefficients().len();
        if nc > MAX_DISPERSION_COEFFICIENTS {
            return Err(Error::invalid(
                "dispersion.model.coefficients",
                format!("{nc} coefficients; a shader snippet carries at most {MAX_DISPERSION_COEFFICIENTS}"),
            ));
        }
        let coefficients: Vec<f32> = model.coefficients().iter().map(|&c| c as f32).collect();
        let lambda_nm: Vec<f32> = section.samples.iter().map(|s| s.lambda_nm as f32).collect();
        let rgb: Vec<[f32; 3]> = section
            .samples
            .iter()
            .map(|s| s.rgb.map(|v| v as f32))
            .collect();
        let range_nm = section.range_nm.map(|v| v as f32);
        let all: Vec<f64> = coefficients
            .iter()
            .chain(&lambda_nm)
            .chain(rgb.iter().flatten())
            .chain(&range_nm)
            .map(|&v| f64::from(v))
            .collect();
        crate::error::ensure_finite("shader constants (f32)", "the dispersion section", &all)?;
        Ok(DispersionTwin {
            space: section.working_space.clone(),
            range_nm,
            kind,
            coefficients,
            lambda_nm,
            rgb,
        })
    }

    /// `disp_sample_count()`.
    pub fn sample_count(&self) -> usize {
        self.lambda_nm.len()
    }

    /// `disp_sample(i)`: (λ in nm, RGB weight); `i` past the end gives the last sample, as the
    /// snippet's `min(i, count − 1)` does.
    pub fn sample(&self, i: usize) -> (f32, [f32; 3]) {
        let i = i.min(self.lambda_nm.len() - 1);
        (self.lambda_nm[i], self.rgb[i])
    }

    /// `disp_ior(λ_nm)`: the model at λ (nm), in the snippet's operation order.
    pub fn ior(&self, lambda_nm: f32) -> f32 {
        let l = lambda_nm * 0.001;
        let l2 = l * l;
        match self.kind {
            IorKind::Cauchy => {
                let inv = 1.0 / l2;
                let c = &self.coefficients;
                let mut acc = c[c.len() - 1];
                for ci in c.iter().rev().skip(1) {
                    acc = acc * inv + ci;
                }
                acc
            }
            IorKind::Sellmeier => {
                let mut sum = 0.0f32;
                for bc in self.coefficients.chunks_exact(2) {
                    sum += bc[0] * l2 / (l2 - bc[1]);
                }
                (1.0 + sum).sqrt()
            }
        }
    }
}

/// The afterimage snippet's constants and functions (Mikamo 2013 Eq. 3–6 and §3.7 per pixel),
/// in `f32`. The image-level steps — the mask, the normalisation by the image's brightest Y,
/// the blur and the dark-adapting background — are the renderer's (see `docs/export.md`).
#[derive(Debug, Clone, PartialEq)]
pub struct AfterimageTwin {
    /// γ of Z.
    pub gamma: f32,
    /// k of Eq. 5–6.
    pub k: f32,
    /// Reference chromaticity (x_R, y_R).
    pub reference_xy: [f32; 2],
    /// XYZ of the Lab white (Yn = 1).
    pub white_xyz: [f32; 3],
    /// Linear sRGB → XYZ (rows).
    pub to_xyz: [[f32; 3]; 3],
    /// XYZ → linear sRGB (rows).
    pub to_rgb: [[f32; 3]; 3],
    /// Eq. 3 breakpoint, s.
    pub breakpoint_s: f32,
    /// Eq. 3 slopes of ln Y per s.
    pub slope_per_s: [f32; 2],
    /// Eq. 3 intercepts of ln Y.
    pub intercept: [f32; 2],
    /// Table 1 step, s (uniform from 0).
    pub step_s: f32,
    /// Table 1 x.
    pub table_x: Vec<f32>,
    /// Table 1 y.
    pub table_y: Vec<f32>,
    /// L_M(0), the lightness of the model at t = 0 (computed in f64).
    pub l_m0: f32,
    /// Whether times past the table's end are allowed (otherwise t is clamped to it).
    pub extrapolate: bool,
    /// Eq. 7 (c, T in s), when the section records a background.
    pub dark: Option<[f32; 2]>,
}

const LAB_EPS: f32 = 216.0 / 24389.0;

/// CIE 1976 f(r) as lumifit's `intermediate_lightness_cie1976` (r = Y/Yn).
fn lab_f(r: f32) -> f32 {
    if r > LAB_EPS {
        r.powf(1.0 / 3.0)
    } else {
        (841.0 / 108.0) * r + 16.0 / 116.0
    }
}

/// Inverse of [`lab_f`] (`intermediate_luminance_cie1976` with Yn = 1).
fn lab_finv(f: f32) -> f32 {
    if f > 24.0 / 116.0 {
        f * f * f
    } else {
        (f - 16.0 / 116.0) * (108.0 / 841.0)
    }
}

fn mul3(m: &[[f32; 3]; 3], v: [f32; 3]) -> [f32; 3] {
    std::array::from_fn(|r| m[r][0] * v[0] + m[r][1] * v[1] + m[r][2] * v[2])
}

impl AfterimageTwin {
    /// The constants of a `mikamo2013` afterimage section.
    pub fn from_section(section: &AfterimageSection) -> Result<Self> {
        let c = &section.colour;
        let n = c.t_s.len();
        if n < 2 || c.interpolation != "catmull-rom" {
            return Err(Error::invalid(
                "afterimage.colour",
                format!(
                    "{n} samples, interpolation '{}'; a shader snippet needs at least 2 samples with catmull-rom",
                    c.interpolation
                ),
            ));
        }
        let step = c.t_s[1] - c.t_s[0];
        let uniform = c.t_s[0] == 0.0
            && step > 0.0
            && c.t_s
                .iter()
                .enumerate()
                .all(|(i, &t)| (t - i as f64 * step).abs() <= 1e-9 * step.max(1.0));
        if !uniform {
            return Err(Error::invalid(
                "afterimage.colour.t_s",
                "expected uniform times from 0 s (the snippet interpolates by index)",
            ));
        }
        let (to_xyz, to_rgb) = crate::afterimage::mikamo2013::display_matrices()?;
        let white = crate::colorimetry::xyy::xy_to_xyz(section.white_xy);
        let y0 = (section.luminance.ln_y_intercept[0]).exp();
        let l_m0 = 116.0 * crate::colorimetry::lab::intermediate_lightness_cie1976(y0, 1.0) - 16.0;
        let f = |v: f64| v as f32;
        let m = |a: [[f64; 3]; 3]| a.map(|r| r.map(f));
        let twin = AfterimageTwin {
            gamma: f(section.gamma),
            k: f(section.k),
            reference_xy: section.reference_xy.map(f),
            white_xyz: white.map(f),
            to_xyz: m(to_xyz),
            to_rgb: m(to_rgb),
            breakpoint_s: f(section.luminance.breakpoint_s),
            slope_per_s: section.luminance.ln_y_slope_per_s.map(f),
            intercept: section.luminance.ln_y_intercept.map(f),
            step_s: f(step),
            table_x: c.x.iter().map(|&v| f(v)).collect(),
            table_y: c.y.iter().map(|&v| f(v)).collect(),
            l_m0: f(l_m0),
            extrapolate: section.extrapolate,
            dark: section
                .dark_adaptation
                .as_ref()
                .map(|d| [f(d.constant), f(d.time_s)]),
        };
        let mut all: Vec<f64> = vec![
            twin.gamma.into(),
            twin.k.into(),
            twin.breakpoint_s.into(),
            twin.step_s.into(),
            twin.l_m0.into(),
        ];
        all.extend(
            twin.table_x
                .iter()
                .chain(&twin.table_y)
                .map(|&v| f64::from(v)),
        );
        all.extend(
            twin.to_xyz
                .iter()
                .chain(&twin.to_rgb)
                .flatten()
                .map(|&v| f64::from(v)),
        );
        all.extend(
            twin.slope_per_s
                .iter()
                .chain(&twin.intercept)
                .map(|&v| f64::from(v)),
        );
        crate::error::ensure_finite("shader constants (f32)", "the afterimage section", &all)?;
        if twin.l_m0 <= 0.0 {
            return Err(Error::invalid(
                "afterimage.luminance.ln_y_intercept",
                "L_M(0) is not > 0; τ_M = L_M/L_M(0) is undefined",
            ));
        }
        Ok(twin)
    }

    /// The end of the colour table, s.
    pub fn end_s(&self) -> f32 {
        self.step_s * (self.table_x.len() - 1) as f32
    }

    /// Model time as the snippet takes it: ≥ 0, and ≤ the table's end unless extrapolating.
    pub fn model_time(&self, t_s: f32) -> f32 {
        let t = t_s.max(0.0);
        if self.extrapolate {
            t
        } else {
            t.min(self.end_s())
        }
    }

    /// `afterimage_luminance(t)`: Eq. 3.
    pub fn luminance(&self, t_s: f32) -> f32 {
        let t = self.model_time(t_s);
        let b = usize::from(t > self.breakpoint_s);
        (self.slope_per_s[b] * t + self.intercept[b]).exp()
    }

    /// `afterimage_xy(t)`: Table 1, uniform Catmull-Rom with phantom end points.
    pub fn chromaticity(&self, t_s: f32) -> [f32; 2] {
        let t = self.model_time(t_s);
        let n = self.table_x.len();
        let s = t / self.step_s;
        let i = (s.floor() as usize).min(n - 2);
        let u = s - i as f32;
        let tab = [&self.table_x, &self.table_y];
        std::array::from_fn(|c| {
            let p = tab[c];
            let p1 = p[i];
            let p2 = p[i + 1];
            let p0 = if i == 0 { 2.0 * p[0] - p[1] } else { p[i - 1] };
            let p3 = if i + 2 >= n {
                2.0 * p[n - 1] - p[n - 2]
            } else {
                p[i + 2]
            };
            0.5 * (2.0 * p1
                + (-p0 + p2) * u
                + (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3) * u * u
                + (-p0 + 3.0 * p1 - 3.0 * p2 + p3) * u * u * u)
        })
    }

    fn lab(&self, xyz: [f32; 3]) -> [f32; 3] {
        let w = self.white_xyz;
        let fx = lab_f(xyz[0] / w[0]);
        let fy = lab_f(xyz[1] / w[1]);
        let fz = lab_f(xyz[2] / w[2]);
        [116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz)]
    }

    fn xyz(&self, lab: [f32; 3]) -> [f32; 3] {
        let w = self.white_xyz;
        let fy = (lab[0] + 16.0) / 116.0;
        let fx = lab[1] / 500.0 + fy;
        let fz = fy - lab[2] / 200.0;
        [
            w[0] * lab_finv(fx),
            w[1] * lab_finv(fy),
            w[2] * lab_finv(fz),
        ]
    }

    /// `afterimage_curve_lab(t)`: (L_M, a_M, b_M) of (x_M, y_M, Y_M).
    pub fn curve_lab(&self, t_s: f32) -> [f32; 3] {
        let big_y = self.luminance(t_s);
        let [x, y] = self.chromaticity(t_s);
        self.lab([x * big_y / y, big_y, (1.0 - x - y) * big_y / y])
    }

    /// `afterimage_at(t, rgb)`: the afterimage (linear sRGB, display white = 1) that a stimulus
    /// of linear sRGB `rgb` — already divided by the image's brightest luminance Y, inside the
    /// mask — leaves at model time t: Eq. 4–6, then §3.7's gamut correction.
    pub fn afterimage_at(&self, t_s: f32, rgb: [f32; 3]) -> [f32; 3] {
        let xyz = mul3(&self.to_xyz, rgb.map(|v| v.max(0.0)));
        let y = xyz[1];
        if y.is_nan() || y <= 0.0 {
            return [0.0; 3];
        }
        let [xr, yr] = self.reference_xy;
        let lab_on = self.lab(xyz);
        let lab_r = self.lab([xr * y / yr, y, (1.0 - xr - yr) * y / yr]);
        let z = (lab_on[0] / 100.0).max(0.0).powf(self.gamma);
        let da = lab_on[1] - lab_r[1];
        let db = lab_on[2] - lab_r[2];
        let m = self.curve_lab(t_s);
        let tk = m[0] / self.l_m0 * self.k;
        let lab = [m[0] * z, m[1] * z + tk * da, m[2] * z + tk * db];
        let xyz = self.xyz(lab);
        let target_y = xyz[1].max(0.0);
        let out = mul3(&self.to_rgb, xyz);
        if out.iter().all(|&c| c >= 0.0) {
            return out;
        }
        let clamped = out.map(|c| c.max(0.0));
        let cy = self.to_xyz[1][0] * clamped[0]
            + self.to_xyz[1][1] * clamped[1]
            + self.to_xyz[1][2] * clamped[2];
        if cy > 0.0 {
            let s = target_y / cy;
            clamped.map(|c| c * s)
        } else {
            [0.0; 3]
        }
    }

    /// `afterimage_dark_weight(t)`: Eq. 7's w(t) = 1 − (1 − c)·e^(−t/T), when recorded.
    pub fn dark_weight(&self, t_s: f32) -> Option<f32> {
        self.dark
            .map(|[c, tt]| 1.0 - (1.0 - c) * (-self.model_time(t_s) / tt).exp())
    }
}
