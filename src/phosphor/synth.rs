//! Synthetic decay curves: charge a material, switch the light off, integrate each frame's
//! exposure window in closed form (exact simulation), map to camera RGB and add noise.
//!
//! Charging uses a flat irradiance with |E| = 1 over the bands (the paper's normalisation,
//! §4.6). Materials without excitation rates (Table 1's decay-only rows) are assumed saturated
//! at switch-off, r_i = 1, as the paper assumes for its decay measurements (§4.4).
//!
//! Noise, per sample: σ_t = √((ν·max_c Y_c(t))² + (10⁻³ ν·max Y)²) — relative (shot-like) noise
//! ν at the sample's brightest channel plus a read-noise floor — Gaussian, shared by the
//! channels of a sample, from a seeded generator (SplitMix64 + Box–Muller), so a seed gives the
//! same curve on every platform.

use crate::error::{Error, Result};

use super::material::Material;
use super::simulate::{final_state, window_integrals, BandCamera, Segment};

/// Parameters of a synthetic decay series.
#[derive(Debug, Clone, PartialEq)]
pub struct DecaySeriesSpec {
    /// Charging time in s before switch-off.
    pub charge_s: f64,
    /// Number of frames.
    pub frames: usize,
    /// Time between frame starts in s.
    pub interval_s: f64,
    /// Exposure of each frame in s (≤ interval).
    pub exposure_s: f64,
    /// Relative noise ν (0 for none).
    pub noise: f64,
    /// Seed of the noise generator.
    pub seed: u64,
}

/// A synthetic curve: frame start times after switch-off, noisy and clean RGB, σ per sample.
#[derive(Debug, Clone, PartialEq)]
pub struct SyntheticCurve {
    /// Frame start times in s after switch-off.
    pub t_s: Vec<f64>,
    /// Noisy mean RGB over each exposure, per sample.
    pub rgb: Vec<[f64; 3]>,
    /// Noise-free values.
    pub clean: Vec<[f64; 3]>,
    /// Standard deviation used per sample.
    pub sigma: Vec<f64>,
    /// Concentrations at switch-off.
    pub r0: Vec<f64>,
    /// Whether r0 was assumed (material without k_e) rather than simulated.
    pub saturation_assumed: bool,
}

/// Deterministic Gaussian generator (SplitMix64 + Box–Muller).
#[derive(Debug, Clone)]
pub struct Gaussian {
    state: u64,
    spare: Option<f64>,
}

impl Gaussian {
    /// A generator from a seed.
    pub fn new(seed: u64) -> Self {
        Gaussian {
            state: seed ^ 0x9E37_79B9_7F4A_7C15,
            spare: None,
        }
    }

    fn next_u64(&mut self) -> u64 {
        self.state = self.state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in (0, 1).
    pub fn uniform(&mut self) -> f64 {
        ((self.next_u64() >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }

    /// Standard normal.
    pub fn normal(&mut self) -> f64 {
        if let Some(s) = self.spare.take() {
            return s;
        }
        let (u1, u2) = (self.uniform(), self.uniform());
        let r = (-2.0 * u1.ln()).sqrt();
        let th = std::f64::consts::TAU * u2;
        self.spare = Some(r * th.sin());
        r * th.cos()
    }
}

/// Renders a synthetic decay curve of `material` seen by `camera`.
pub fn decay_curve(
    material: &Material,
    camera: &BandCamera,
    spec: &DecaySeriesSpec,
) -> Result<SyntheticCurve> {
    material.validate()?;
    if spec.frames < 3 || spec.frames > 1_000_000 {
        return Err(Error::invalid(
            "frames",
            format!("{}; expected 3 to 1000000", spec.frames),
        ));
    }
    for (field, v) in [("interval", spec.interval_s), ("exposure", spec.exposure_s)] {
        if !(v.is_finite() && v > 0.0) {
            return Err(Error::invalid(field, format!("{v} s; expected > 0")));
        }
    }
    if spec.exposure_s > spec.interval_s {
        return Err(Error::invalid(
            "exposure",
            format!(
                "{} s is longer than the interval {} s; frames would overlap",
                spec.exposure_s, spec.interval_s
            ),
        ));
    }
    if !(spec.noise.is_finite() && spec.noise >= 0.0) {
        return Err(Error::invalid(
            "noise",
            format!("{}; expected ≥ 0", spec.noise),
        ));
    }
    if !(spec.charge_s.is_finite() && spec.charge_s >= 0.0) {
        return Err(Error::invalid(
            "charge",
            format!("{} s; expected ≥ 0", spec.charge_s),
        ));
    }
    let nb = material.bands.len();
    let ns = material.states.len();
    let saturation_assumed = !material.has_excitation() || spec.charge_s == 0.0;
    let r0 = if saturation_assumed {
        vec![1.0; ns]
    } else {
        let e = 1.0 / (nb as f64).sqrt();
        final_state(
            material,
            &[Segment {
                duration_s: spec.charge_s,
                irradiance: vec![e; nb],
            }],
            &vec![0.0; ns],
        )?
    };
    // after switch-off: a dark history starting from r0
    let dark = [Segment {
        duration_s: f64::MAX / 4.0,
        irradiance: vec![0.0; nb],
    }];
    let t_s: Vec<f64> = (0..spec.frames)
        .map(|j| j as f64 * spec.interval_s)
        .collect();
    let windows: Vec<(f64, f64)> = t_s.iter().map(|t| (*t, t + spec.exposure_s)).collect();
    let ints = window_integrals(material, &dark, &r0, &windows)?;
    let clean: Vec<[f64; 3]> = ints
        .iter()
        .map(|b| {
            let rgb = camera.rgb(b);
            rgb.map(|v| v / spec.exposure_s)
        })
        .collect();
    let peak = clean
        .iter()
        .flat_map(|v| v.iter())
        .cloned()
        .fold(0.0_f64, f64::max);
    let mut g = Gaussian::new(spec.seed);
    let mut rgb = Vec::with_capacity(clean.len());
    let mut sigma = Vec::with_capacity(clean.len());
    for v in &clean {
        let mx = v.iter().cloned().fold(0.0_f64, f64::max);
        let s = ((spec.noise * mx).powi(2) + (1e-3 * spec.noise * peak).powi(2)).sqrt();
        let s = if s > 0.0 { s } else { f64::MIN_POSITIVE.sqrt() };
        sigma.push(s);
        rgb.push(if spec.noise > 0.0 {
            v.map(|x| x + s * g.normal())
        } else {
            *v
        });
    }
    Ok(SyntheticCurve {
        t_s,
        rgb,
        clean,
        sigma,
        r0,
        saturation_assumed,
    })
}
