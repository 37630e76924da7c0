//! Synthetic decay curves and frames: charge a material, switch the light off, integrate each
//! frame's exposure window in closed form (exact simulation), map to camera RGB and add noise.
//! [`decay_curve`] gives one curve; [`DecayFrames`] renders whole frames (uniform, or two halves:
//! the material and its [`two_state_variant`]) with per-pixel shot + read noise.
//!
//! Charging follows a [`DecayCharging`] protocol: flat light over the bands (|E| given, the
//! paper's normalisation, §4.6) for a given time from dark, or saturated (r_i = 1 at switch-off,
//! as the paper assumes for its decay measurements, §4.4). [`decay_curve`] and
//! [`DecayFrames::new`] keep the older reading of [`DecaySeriesSpec::charge_s`] (|E| = 1;
//! 0 = saturated); [`decay_curve_charged`] and [`DecayFrames::new_charged`] take the protocol.
//! A flat charge of a material without excitation rates is refused (its state is unknown).
//!
//! Noise, per sample: σ_t = √((ν·max_c Y_c(t))² + (10⁻³ ν·max Y)²) — relative (shot-like) noise
//! ν at the sample's brightest channel plus a read-noise floor — Gaussian, shared by the
//! channels of a sample, from a seeded generator (SplitMix64 + Box–Muller), so a seed gives the
//! same curve on every platform.

use crate::error::{Error, Result};

use super::charging::DecayCharging;
use super::material::Material;
use super::simulate::{window_integrals, BandCamera, Segment};

/// Parameters of a synthetic decay series.
#[derive(Debug, Clone, PartialEq)]
pub struct DecaySeriesSpec {
    /// Charging time in s before switch-off under flat light |E| = 1, read by [`decay_curve`]
    /// and [`DecayFrames::new`] (0 there means saturated; materials without k_e are saturated).
    /// Ignored by [`decay_curve_charged`] and [`DecayFrames::new_charged`].
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
    /// Whether r0 = 1 was set (saturated protocol) rather than simulated.
    pub saturation_assumed: bool,
    /// The charging protocol that produced r0.
    pub charging: DecayCharging,
}

/// Deterministic Gaussian generator: the capture module's SplitMix64 + Box–Muller generator,
/// seeded with `seed ^ 0x9E37_79B9_7F4A_7C15` (so a given seed keeps producing the same data).
#[derive(Debug, Clone)]
pub struct Gaussian(crate::capture::rng::SplitMix64);

impl Gaussian {
    /// A generator from a seed.
    pub fn new(seed: u64) -> Self {
        Gaussian(crate::capture::rng::SplitMix64::new(
            seed ^ 0x9E37_79B9_7F4A_7C15,
        ))
    }

    /// Uniform in (0, 1).
    pub fn uniform(&mut self) -> f64 {
        self.0.uniform()
    }

    /// Standard normal.
    pub fn normal(&mut self) -> f64 {
        self.0.normal()
    }
}

/// The protocol [`decay_curve`] reads from `spec.charge_s`: flat |E| = 1 for that time, or
/// saturated when it is 0 or the material has no excitation rates.
pub fn legacy_charging(material: &Material, spec: &DecaySeriesSpec) -> DecayCharging {
    if !material.has_excitation() || spec.charge_s == 0.0 {
        DecayCharging::Saturated
    } else {
        DecayCharging::Flat {
            duration_s: spec.charge_s,
            irradiance: 1.0,
        }
    }
}

/// Renders a synthetic decay curve of `material` seen by `camera`, charged as
/// [`legacy_charging`] reads `spec.charge_s`.
pub fn decay_curve(
    material: &Material,
    camera: &BandCamera,
    spec: &DecaySeriesSpec,
) -> Result<SyntheticCurve> {
    if !(spec.charge_s.is_finite() && spec.charge_s >= 0.0) {
        return Err(Error::invalid(
            "charge",
            format!("{} s; expected ≥ 0", spec.charge_s),
        ));
    }
    decay_curve_charged(material, camera, spec, &legacy_charging(material, spec))
}

/// Renders a synthetic decay curve of `material` seen by `camera` after `charging`.
///
/// # Errors
/// [`Error::InvalidArgument`] for bad frame settings, a bad protocol, or a flat charge of a
/// material without k_e.
pub fn decay_curve_charged(
    material: &Material,
    camera: &BandCamera,
    spec: &DecaySeriesSpec,
    charging: &DecayCharging,
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
    if *charging == DecayCharging::Unknown {
        return Err(Error::invalid(
            "charging",
            "a synthetic series needs a known protocol (saturated or a flat charge)",
        ));
    }
    let nb = material.bands.len();
    let saturation_assumed = charging.assumes_saturation();
    let r0 = charging.state_at_switch_off(material)?;
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
        charging: charging.clone(),
    })
}

/// Layout of synthetic frames.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FrameLayout {
    /// The material everywhere.
    Uniform,
    /// Left half the material, right half its two-state variant ([`two_state_variant`]).
    Halves,
}

/// The right half of [`FrameLayout::Halves`]: the material's first state plus a second state
/// decaying five times slower with half its re-radiation (and, when it has one, the same
/// excitation). A one-state material thus gains a slow tail; a material with more states keeps
/// only its first, so the two halves always differ.
pub fn two_state_variant(material: &Material) -> Result<Material> {
    let Some(s1) = material.states.first() else {
        return Err(Error::invalid("material", "no states"));
    };
    let mut s2 = s1.clone();
    s2.k_r_per_s = s1.k_r_per_s / 5.0;
    s2.lambda = s1.lambda.iter().map(|l| l / 2.0).collect();
    let m = Material {
        name: format!("{} (two-state variant)", material.name),
        bands: material.bands.clone(),
        states: vec![s1.clone(), s2],
    };
    m.validate()?;
    Ok(m)
}

/// Synthetic 16-bit-ready frames of a decay: noiseless curves per region, scaled so the brightest
/// value of the series is `peak_level` of full scale, rendered frame by frame with the shot +
/// read noise of [`crate::capture::synth::noisy_value`].
///
/// A frame value is *v* = gain · Y(t) · exposure_s (ISO 100, f/1: the exposure factor is
/// `exposure_s`), so the series loader's relative radiance *v* / exposure_s is gain · Y(t).
#[derive(Debug, Clone)]
pub struct DecayFrames {
    /// Frame width in pixels.
    pub width: usize,
    /// Frame height in pixels.
    pub height: usize,
    /// Frame start times in s after switch-off.
    pub t_s: Vec<f64>,
    /// Exposure of every frame in s.
    pub exposure_s: f64,
    /// Scale from the simulation's camera RGB to relative radiance in the frames.
    pub gain: f64,
    /// Relative noise level.
    pub noise: f64,
    /// Noiseless curves: one for the uniform layout, left then right for halves.
    pub curves: Vec<SyntheticCurve>,
    seed: u64,
    peak: f64,
}

/// Brightest frame value, as a fraction of full scale.
pub const PEAK_LEVEL: f64 = 0.8;

impl DecayFrames {
    /// Prepares frames of `material` in `layout` seen by `camera` (the noise in `spec` is
    /// applied per pixel by [`DecayFrames::frame`]).
    ///
    /// # Errors
    /// As [`decay_curve`]; [`Error::InvalidArgument`] for an empty or huge size, or a material
    /// that never glows (no signal).
    pub fn new(
        material: &Material,
        layout: FrameLayout,
        camera: &BandCamera,
        spec: &DecaySeriesSpec,
        width: usize,
        height: usize,
    ) -> Result<Self> {
        if !(spec.charge_s.is_finite() && spec.charge_s >= 0.0) {
            return Err(Error::invalid(
                "charge",
                format!("{} s; expected ≥ 0", spec.charge_s),
            ));
        }
        let charging = legacy_charging(material, spec);
        Self::new_charged(material, layout, camera, spec, &charging, (width, height))
    }

    /// As [`DecayFrames::new`], charged by `charging` (both halves alike).
    ///
    /// # Errors
    /// As [`DecayFrames::new`] and [`decay_curve_charged`].
    pub fn new_charged(
        material: &Material,
        layout: FrameLayout,
        camera: &BandCamera,
        spec: &DecaySeriesSpec,
        charging: &DecayCharging,
        (width, height): (usize, usize),
    ) -> Result<Self> {
        if width < 2 || height < 1 || width.saturating_mul(height) > 64_000_000 {
            return Err(Error::invalid(
                "--size",
                format!("{width}x{height}; expected 2x1 up to 64 megapixels"),
            ));
        }
        let clean_spec = DecaySeriesSpec {
            noise: 0.0,
            ..spec.clone()
        };
        let mut curves = vec![decay_curve_charged(
            material,
            camera,
            &clean_spec,
            charging,
        )?];
        if layout == FrameLayout::Halves {
            let v = two_state_variant(material)?;
            curves.push(decay_curve_charged(&v, camera, &clean_spec, charging)?);
        }
        let max_y = curves
            .iter()
            .flat_map(|c| c.clean.iter().flatten())
            .cloned()
            .fold(0.0f64, f64::max);
        if !(max_y.is_finite() && max_y > 0.0) {
            return Err(Error::invalid(
                "material",
                format!("{} emits nothing after charging", material.name),
            ));
        }
        let gain = PEAK_LEVEL / (max_y * spec.exposure_s);
        Ok(Self {
            width,
            height,
            t_s: curves[0].t_s.clone(),
            exposure_s: spec.exposure_s,
            gain,
            noise: spec.noise,
            curves,
            seed: spec.seed,
            peak: PEAK_LEVEL,
        })
    }

    /// Number of frames.
    pub fn len(&self) -> usize {
        self.t_s.len()
    }

    /// Whether there are no frames (never, once constructed).
    pub fn is_empty(&self) -> bool {
        self.t_s.is_empty()
    }

    /// Noiseless frame value of region `region` (0 = left/uniform, 1 = right) in frame `j`.
    pub fn clean_value(&self, region: usize, j: usize) -> [f64; 3] {
        let c = &self.curves[region.min(self.curves.len() - 1)];
        c.clean[j].map(|y| y * self.gain * self.exposure_s)
    }

    /// Frame `j` as interleaved linear RGB in [0, 1] (values at 1 saturate), with a seed derived
    /// from the series seed and `j`, so frames can be rendered in any order or in parallel.
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] when `j` is out of range.
    pub fn frame(&self, j: usize) -> Result<Vec<f32>> {
        if j >= self.len() {
            return Err(Error::invalid(
                "frame",
                format!("{j}; the series has {} frames", self.len()),
            ));
        }
        let mut rng = crate::capture::rng::SplitMix64::new(
            self.seed ^ (j as u64 + 1).wrapping_mul(0xD1B5_4A32_D192_ED03),
        );
        let vals: Vec<[f64; 3]> = (0..self.curves.len())
            .map(|r| self.clean_value(r, j))
            .collect();
        let half = self.width / 2;
        let mut out = Vec::with_capacity(3 * self.width * self.height);
        for _y in 0..self.height {
            for x in 0..self.width {
                let v = if vals.len() > 1 && x >= half {
                    vals[1]
                } else {
                    vals[0]
                };
                for c in v {
                    let n = crate::capture::synth::noisy_value(c, self.noise, self.peak, &mut rng);
                    out.push(n.clamp(0.0, 1.0) as f32);
                }
            }
        }
        Ok(out)
    }
}
