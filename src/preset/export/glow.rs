//! The glow of a phosphorescence section after switch-off, as glTF emission keyframes.
//!
//! **Charging** (Nalbach 2017 Eq. 1, exact for constant irradiance E over the charge):
//! `a_i = Σ_b k_e,i[b] E[b]`, `r_i(T) = r_eq (1 − e^{−(a_i + k_r,i) T})` from empty, with
//! `r_eq = a_i/(a_i + k_r,i)`; [`Charge::Saturated`] is T → ∞ (`r_i = r_eq`), [`Charge::Full`]
//! sets every state to 1 (the preset's own reference state: `phos fit-decay` scales Λ so that
//! r = 1 reproduces the measured amplitudes at switch-off, and a decay-only preset has no k_e to
//! charge with). `--charge-s T` uses [`crate::phosphor::simulate::final_state`].
//!
//! **Glow** (Eq. 3) after switch-off: `rgb(t) = s · Σ_i r_i(0) e^{−k_r,i t} C_i` in linear RGB of
//! the working space, `C_i = k_r,i Σ_b Λ_i[b] M[:, b]` with M of
//! [`crate::preset::shader::band_to_rgb`] (identity for `"rgb"` bands; CIE 1931 2° through the
//! space's XYZ → RGB matrix for wavelength bands). A state colour with a negative channel (a band
//! outside the space's gamut) is clipped to 0 per state, which keeps the glow a sum of decaying
//! exponentials; the clipped states are reported.
//!
//! **Units.** glTF emission is luminance: the emitted linear RGB is `emissiveFactor ×
//! emissiveStrength` in cd/m² (nits), and its luminance is `Y = row₂(RGB → XYZ) · rgb`
//! (0.2126, 0.7152, 0.0722 for sRGB). The preset's Λ has no absolute unit (a camera's or a
//! simulation's scale), so the scale s is stated: [`EmissionScale::NitsPerUnit`] (default 1: one
//! unit of the preset's emission is 1 cd/m²) or [`EmissionScale::PeakLuminance`] (s chosen so
//! that Y(0) is the given luminance).
//!
//! **Keys.** [`crate::preset::shader::keyframes::glow_keyframes`] places keys so the chord of
//! every channel stays within `rel·|rgb(t)| + abs·peak` (peak: the brightest channel at t = 0).
//! A glTF engine interpolates `emissiveFactor` (the colour with its largest channel 1) and
//! `emissiveStrength` (that largest channel, nits) separately and multiplies them, which adds
//! `(s² − s)·Δf·Δg` to the chord error, and the keys are stored as `f32`. So the keys are rounded
//! to `f32` first, the exact glow is evaluated at the rounded times, and any segment whose
//! product of interpolations exceeds the tolerance on 1000 points is split at its midpoint until
//! none does; [`GlowKeys::max_error`] is that measured worst ratio (≤ 1).

use crate::colorimetry::rgb::RgbSpace;
use crate::error::{ensure_finite, Error, Result};
use crate::phosphor::simulate::{final_state, Segment};
use crate::preset::phosphor::material_from_preset;
use crate::preset::shader::band_to_rgb;
use crate::preset::shader::keyframes::{error_ratio, glow_keyframes, glow_rgb, KeyframeTolerance};
use crate::preset::MaterialPreset;

/// The charging history before switch-off.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Charge {
    /// Charged to equilibrium under the irradiance (T → ∞).
    Saturated,
    /// Every state at concentration 1 (the preset's reference state).
    Full,
    /// Charged from empty for this many seconds.
    Seconds(f64),
}

/// How the preset's emission scale becomes cd/m².
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum EmissionScale {
    /// cd/m² per unit of the preset's emission (linear RGB channel value).
    NitsPerUnit(f64),
    /// The luminance at switch-off, cd/m².
    PeakLuminance(f64),
}

/// Options of the glow export.
#[derive(Debug, Clone, PartialEq)]
pub struct GlowOptions {
    /// Charging history; `None` picks [`Charge::Saturated`] when every state has k_e, else
    /// [`Charge::Full`].
    pub charge: Option<Charge>,
    /// Irradiance during the charge, one value per band or one for all (the units k_e was
    /// fitted against).
    pub irradiance: Vec<f64>,
    /// Length of the glow animation in s; `None`: until the slowest state has decayed to
    /// 1/1000 (ln 1000 / k_min).
    pub duration_s: Option<f64>,
    /// Tolerance of linear interpolation.
    pub tolerance: KeyframeTolerance,
    /// Emission scale.
    pub scale: EmissionScale,
}

impl Default for GlowOptions {
    fn default() -> Self {
        GlowOptions {
            charge: None,
            irradiance: vec![1.0],
            duration_s: None,
            tolerance: KeyframeTolerance::default(),
            scale: EmissionScale::NitsPerUnit(1.0),
        }
    }
}

/// The keys as written: `f32` times, colours and strengths.
#[derive(Debug, Clone, PartialEq)]
pub struct GlowKeys {
    /// Key times in s, from 0, strictly increasing.
    pub t_s: Vec<f32>,
    /// `emissiveFactor` per key (largest channel 1).
    pub factor: Vec<[f32; 3]>,
    /// `emissiveStrength` per key, cd/m².
    pub strength: Vec<f32>,
    /// Worst interpolation error over 1000 points per segment, as a fraction of the allowed error.
    pub max_error: f64,
    /// Keys placed by the chord criterion before the product/f32 refinement.
    pub chord_keys: usize,
}

/// The glow after switch-off and its keys.
#[derive(Debug, Clone, PartialEq)]
pub struct Glow {
    /// The charge used.
    pub charge: Charge,
    /// Irradiance per band during the charge.
    pub irradiance: Vec<f64>,
    /// Concentrations at switch-off.
    pub r0: Vec<f64>,
    /// Decay rates, s⁻¹.
    pub k_r_per_s: Vec<f64>,
    /// Linear RGB (cd/m²) per unit concentration of each state, clipped to ≥ 0.
    pub rgb_per_state: Vec<[f64; 3]>,
    /// States whose colour had a negative channel in the space (clipped to 0).
    pub clipped_states: Vec<usize>,
    /// The scale s (cd/m² per unit of the preset's emission).
    pub nits_per_unit: f64,
    /// Luminance weights of the space (row Y of RGB → XYZ).
    pub luminance_weights: [f64; 3],
    /// Working space key.
    pub space: String,
    /// Length of the animation, s.
    pub duration_s: f64,
    /// The tolerance the keys meet.
    pub tolerance: KeyframeTolerance,
    /// The keys.
    pub keys: GlowKeys,
}

impl Glow {
    /// Exact emitted linear RGB (cd/m²) at `t_s` after switch-off.
    pub fn rgb_at(&self, t_s: f64) -> [f64; 3] {
        glow_rgb(&self.r0, &self.k_r_per_s, &self.rgb_per_state, t_s)
    }

    /// Luminance (cd/m²) of `rgb`.
    pub fn luminance(&self, rgb: [f64; 3]) -> f64 {
        (0..3).map(|c| self.luminance_weights[c] * rgb[c]).sum()
    }

    /// The colour and strength at switch-off (what a viewer without animation shows).
    pub fn at_switch_off(&self) -> ([f32; 3], f32) {
        (self.keys.factor[0], self.keys.strength[0])
    }
}

fn charge_name(c: Charge) -> String {
    match c {
        Charge::Saturated => "saturated".into(),
        Charge::Full => "full".into(),
        Charge::Seconds(t) => format!("{t} s"),
    }
}

impl Charge {
    /// How the charge is written in reports: `saturated`, `full` or `T s`.
    pub fn describe(self) -> String {
        charge_name(self)
    }
}

/// Splits a linear RGB value into glTF's colour (largest channel 1) and strength.
fn split(rgb: [f64; 3]) -> ([f32; 3], f32) {
    let m = rgb.iter().fold(0.0f64, |a, &v| a.max(v));
    if m <= 0.0 {
        return ([0.0; 3], 0.0);
    }
    (rgb.map(|v| ((v / m) as f32).clamp(0.0, 1.0)), m as f32)
}

/// The glow of `preset`'s phosphorescence section in linear `space` (see the module docs);
/// `file` names the preset in errors.
pub fn glow(
    preset: &MaterialPreset,
    file: &str,
    space: &RgbSpace,
    opts: &GlowOptions,
) -> Result<Glow> {
    let section = preset.phosphorescence.as_ref().ok_or_else(|| {
        Error::invalid(
            format!("{file}: phosphorescence"),
            "the preset has no phosphorescence section",
        )
    })?;
    let material = material_from_preset(preset, file)?;
    let nb = material.bands.len();
    let irradiance = match opts.irradiance.len() {
        1 => vec![opts.irradiance[0]; nb],
        n if n == nb => opts.irradiance.clone(),
        n => {
            return Err(Error::invalid(
                "--charge-irradiance",
                format!("{n} values; expected 1 or one per band of the preset ({nb})"),
            ))
        }
    };
    if let Some(v) = irradiance.iter().find(|v| !(v.is_finite() && **v >= 0.0)) {
        return Err(Error::invalid(
            "--charge-irradiance",
            format!("{v}; expected finite values ≥ 0"),
        ));
    }
    let charge = opts.charge.unwrap_or(if material.has_excitation() {
        Charge::Saturated
    } else {
        Charge::Full
    });
    if charge != Charge::Full && !material.has_excitation() {
        return Err(Error::invalid(
            "--charge-s",
            format!(
                "{}: not every phosphorescent state of {file} has excitation rates k_e, so it cannot be charged; use --charge-s full (every state at 1, the preset's reference state)",
                charge_name(charge)
            ),
        ));
    }
    let r0: Vec<f64> = match charge {
        Charge::Full => vec![1.0; material.states.len()],
        Charge::Saturated => material
            .states
            .iter()
            .map(|s| {
                let a: f64 = s
                    .k_e
                    .as_deref()
                    .unwrap_or(&[])
                    .iter()
                    .zip(&irradiance)
                    .map(|(k, e)| k * e)
                    .sum();
                a / (a + s.k_r_per_s)
            })
            .collect(),
        Charge::Seconds(t) => {
            if !(t.is_finite() && t > 0.0) {
                return Err(Error::invalid(
                    "--charge-s",
                    format!("{t}; expected a charging time > 0 s, 'saturated' or 'full'"),
                ));
            }
            let seg = Segment {
                duration_s: t,
                irradiance: irradiance.clone(),
            };
            final_state(&material, &[seg], &vec![0.0; material.states.len()])?
        }
    };
    ensure_finite("concentrations at switch-off", file, &r0)?;
    let m = band_to_rgb(&section.bands, space)?;
    let mut clipped_states = Vec::new();
    let mut unscaled: Vec<[f64; 3]> = Vec::new();
    for (i, s) in material.states.iter().enumerate() {
        let c: [f64; 3] = std::array::from_fn(|ch| {
            s.k_r_per_s
                * s.lambda
                    .iter()
                    .zip(&m)
                    .map(|(l, col)| l * col[ch])
                    .sum::<f64>()
        });
        if c.iter().any(|v| *v < 0.0) {
            clipped_states.push(i);
        }
        unscaled.push(c.map(|v| v.max(0.0)));
    }
    let k_r: Vec<f64> = material.states.iter().map(|s| s.k_r_per_s).collect();
    let weights = space.matrix_rgb_to_xyz[1];
    let lum = |rgb: [f64; 3]| -> f64 { (0..3).map(|c| weights[c] * rgb[c]).sum() };
    let y0 = lum(glow_rgb(&r0, &k_r, &unscaled, 0.0));
    if y0.is_nan() || y0 <= 0.0 {
        return Err(Error::invalid(
            format!("{file}: phosphorescence"),
            format!(
                "the glow at switch-off is dark (luminance {y0}) after the charge '{}' under irradiance {irradiance:?}; expected a charge that fills a state that emits",
                charge_name(charge)
            ),
        ));
    }
    let nits_per_unit = match opts.scale {
        EmissionScale::NitsPerUnit(s) => {
            if !(s.is_finite() && s > 0.0) {
                return Err(Error::invalid(
                    "--nits-per-unit",
                    format!("{s}; expected a scale > 0 (cd/m² per unit of the preset's emission)"),
                ));
            }
            s
        }
        EmissionScale::PeakLuminance(l) => {
            if !(l.is_finite() && l > 0.0) {
                return Err(Error::invalid(
                    "--peak-luminance",
                    format!("{l}; expected a luminance > 0 cd/m²"),
                ));
            }
            l / y0
        }
    };
    let rgb_per_state: Vec<[f64; 3]> = unscaled
        .iter()
        .map(|c| c.map(|v| v * nits_per_unit))
        .collect();
    ensure_finite("glow colours (cd/m²)", file, &rgb_per_state.concat())?;
    let k_min = k_r.iter().copied().fold(f64::INFINITY, f64::min);
    let duration_s = opts.duration_s.unwrap_or(1000f64.ln() / k_min);
    if !(duration_s.is_finite() && duration_s > 0.0 && duration_s <= f64::from(f32::MAX)) {
        return Err(Error::invalid(
            "--glow-s",
            format!("{duration_s}; expected a finite duration > 0 s"),
        ));
    }
    let tol = opts.tolerance;
    let chord = glow_keyframes(&r0, &k_r, &rgb_per_state, duration_s, tol)?;
    let f = |t: f64| glow_rgb(&r0, &k_r, &rgb_per_state, t);
    let keys = refine(&chord.t_s, &f, tol, file)?;
    Ok(Glow {
        charge,
        irradiance,
        r0,
        k_r_per_s: k_r,
        rgb_per_state,
        clipped_states,
        nits_per_unit,
        luminance_weights: weights,
        space: space.key.clone(),
        duration_s,
        tolerance: tol,
        keys: GlowKeys {
            chord_keys: chord.t_s.len(),
            ..keys
        },
    })
}

/// Points per segment at which the written keys are checked.
const CHECK_POINTS: usize = 1000;
/// Most keys an export may hold.
const MAX_KEYS: usize = 100_000;

/// Rounds the chord keys to `f32`, evaluates the exact glow there and splits every segment whose
/// interpolated product exceeds the tolerance (module docs).
fn refine(
    t_chord: &[f64],
    f: &dyn Fn(f64) -> [f64; 3],
    tol: KeyframeTolerance,
    file: &str,
) -> Result<GlowKeys> {
    let peak = f(0.0).iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let mut t: Vec<f32> = Vec::with_capacity(t_chord.len());
    for &x in t_chord {
        let x = x as f32;
        if t.last().is_none_or(|&l| x > l) {
            t.push(x);
        }
    }
    let key = |x: f32| split(f(f64::from(x)));
    let ratio = |a: f32, b: f32| -> f64 {
        let ((fa, ga), (fb, gb)) = (key(a), key(b));
        let (a, b) = (f64::from(a), f64::from(b));
        let mut worst = 0.0f64;
        for j in 1..CHECK_POINTS {
            let s = j as f64 / CHECK_POINTS as f64;
            let x = a + s * (b - a);
            let exact = f(x);
            let g = f64::from(ga) + s * (f64::from(gb) - f64::from(ga));
            for ch in 0..3 {
                let fc = f64::from(fa[ch]) + s * (f64::from(fb[ch]) - f64::from(fa[ch]));
                let err = (fc * g - exact[ch]).abs();
                let allowed = tol.rel_tol * exact[ch].abs() + tol.abs_tol * peak;
                worst = worst.max(error_ratio(err, allowed));
            }
        }
        worst
    };
    let mut out = vec![t[0]];
    let mut max_error = 0.0f64;
    // Segments still to check, as a stack of (start, end); the output grows in time order.
    let mut pending: Vec<(f32, f32)> = t.windows(2).rev().map(|w| (w[0], w[1])).collect();
    while let Some((a, b)) = pending.pop() {
        let r = ratio(a, b);
        if r <= 1.0 {
            out.push(b);
            max_error = max_error.max(r);
            continue;
        }
        let mid = ((f64::from(a) + f64::from(b)) / 2.0) as f32;
        if !(mid > a && mid < b) {
            return Err(Error::Numerical {
                what: format!("glow keys of {file}"),
                reason: format!(
                    "the segment [{a}, {b}] s cannot be split in f32 and misses the tolerance by ×{r:.3}; loosen --key-tolerance"
                ),
            });
        }
        pending.push((mid, b));
        pending.push((a, mid));
        if out.len() + pending.len() > MAX_KEYS {
            return Err(Error::invalid(
                "--key-tolerance",
                format!("more than {MAX_KEYS} keys would be needed; loosen it or shorten --glow-s"),
            ));
        }
    }
    let (factor, strength): (Vec<[f32; 3]>, Vec<f32>) = out.iter().map(|&x| key(x)).unzip();
    let flat: Vec<f64> = strength
        .iter()
        .map(|&v| f64::from(v))
        .chain(factor.iter().flatten().map(|&v| f64::from(v)))
        .collect();
    ensure_finite("glow keys (f32)", file, &flat)?;
    Ok(GlowKeys {
        t_s: out,
        factor,
        strength,
        max_error,
        chord_keys: t_chord.len(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::preset::{Bands, PhosphorescenceSection, PhosphorescentState, Provenance};

    fn preset(states: Vec<PhosphorescentState>) -> MaterialPreset {
        let mut p = MaterialPreset::new("t", Provenance::new("test", &[] as &[(&str, &[u8])]));
        p.phosphorescence = Some(PhosphorescenceSection {
            bands: Bands::Rgb,
            states,
            extra: Default::default(),
        });
        p
    }

    #[test]
    fn saturated_charge_is_the_equilibrium_and_a_long_charge_reaches_it() {
        let p = preset(vec![PhosphorescentState::new(
            0.2,
            Some(vec![0.1, 0.3, 0.0]),
            vec![0.1, 1.0, 0.2],
        )]);
        let srgb = RgbSpace::srgb().unwrap();
        let sat = glow(&p, "t", &srgb, &GlowOptions::default()).unwrap();
        assert!((sat.r0[0] - 0.4 / 0.6).abs() < 1e-15);
        let long = glow(
            &p,
            "t",
            &srgb,
            &GlowOptions {
                charge: Some(Charge::Seconds(200.0)),
                ..GlowOptions::default()
            },
        )
        .unwrap();
        assert!((long.r0[0] - sat.r0[0]).abs() < 1e-12);
        assert!(sat.keys.max_error <= 1.0);
        assert_eq!(sat.keys.t_s[0], 0.0);
        assert_eq!(
            f64::from(*sat.keys.t_s.last().unwrap()),
            (sat.duration_s as f32) as f64
        );
    }

    #[test]
    fn peak_luminance_sets_the_luminance_at_switch_off() {
        let p = preset(vec![PhosphorescentState::new(
            0.05,
            None,
            vec![0.2, 1.0, 0.3],
        )]);
        let srgb = RgbSpace::srgb().unwrap();
        let g = glow(
            &p,
            "t",
            &srgb,
            &GlowOptions {
                scale: EmissionScale::PeakLuminance(2.5),
                ..GlowOptions::default()
            },
        )
        .unwrap();
        assert_eq!(g.charge, Charge::Full);
        assert!((g.luminance(g.rgb_at(0.0)) - 2.5).abs() < 1e-12);
        let (f, s) = g.at_switch_off();
        assert_eq!(f[1], 1.0);
        assert!((f64::from(s) - g.rgb_at(0.0)[1]).abs() < 1e-6 * f64::from(s));
    }

    #[test]
    fn a_decay_only_preset_cannot_be_charged_for_a_time() {
        let p = preset(vec![PhosphorescentState::new(
            0.05,
            None,
            vec![0.2, 1.0, 0.3],
        )]);
        let e = glow(
            &p,
            "x.json",
            &RgbSpace::srgb().unwrap(),
            &GlowOptions {
                charge: Some(Charge::Seconds(10.0)),
                ..GlowOptions::default()
            },
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("--charge-s") && e.contains("k_e"), "{e}");
    }
}
