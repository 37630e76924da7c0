//! §4.5: re-radiation functions and band spectra from a decay fit.

#![allow(clippy::needless_range_loop, clippy::neg_cmp_op_on_partial_ord)]

use super::*;

/// Re-radiation functions of §4.5: Λ_i = a_i Λ* / k_r,i for every state, with `spectrum` the
/// emission spectrum Λ* on the target bands (max 1), assuming saturation (r_i(0) = 1) at
/// switch-off. Returns (k_r, Λ_i) per state.
pub fn reradiation_functions(fit: &DecayFit, spectrum: &[f64]) -> Vec<(f64, Vec<f64>)> {
    fit.states
        .iter()
        .map(|s| {
            (
                s.k_per_s,
                spectrum
                    .iter()
                    .map(|l| s.amplitude * l / s.k_per_s)
                    .collect(),
            )
        })
        .collect()
}

/// Per-channel re-radiation functions on the data's own channels (bands "rgb"):
/// Λ_i[c] = a_ic / k_r,i.
pub fn reradiation_functions_rgb(fit: &DecayFit) -> Vec<(f64, Vec<f64>)> {
    fit.states
        .iter()
        .map(|s| {
            (
                s.k_per_s,
                s.channel_amplitudes.iter().map(|a| a / s.k_per_s).collect(),
            )
        })
        .collect()
}

/// Band averages of a sampled spectrum over `bands_nm`, normalised to a maximum of 1
/// (trapezoidal, linear interpolation; zero outside the sampled range).
pub fn band_spectrum(
    wavelengths_nm: &[f64],
    values: &[f64],
    bands_nm: &[[f64; 2]],
) -> Result<Vec<f64>> {
    if wavelengths_nm.len() < 2 || wavelengths_nm.len() != values.len() {
        return Err(Error::invalid(
            "spectrum",
            "expected at least two samples with one value each",
        ));
    }
    let n0 = wavelengths_nm.len();
    let mut out = Vec::with_capacity(bands_nm.len());
    for [lo, hi] in bands_nm {
        let n = ((hi - lo).ceil() as usize).clamp(8, 4096);
        let mut s = 0.0;
        for k in 0..=n {
            let x = lo + (hi - lo) * k as f64 / n as f64;
            let v = if x < wavelengths_nm[0] || x > wavelengths_nm[n0 - 1] {
                0.0
            } else {
                crate::math::interpolation::linear_at(wavelengths_nm, values, x)
            };
            s += if k == 0 || k == n { 0.5 * v } else { v };
        }
        out.push(s / n as f64);
    }
    let mx = out.iter().cloned().fold(0.0_f64, f64::max);
    if !(mx > 0.0) {
        return Err(Error::invalid(
            "spectrum",
            "the emission spectrum is zero over every band; expected a positive emission",
        ));
    }
    Ok(out.into_iter().map(|v| (v / mx).max(0.0)).collect())
}
