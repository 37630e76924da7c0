//! Per-pixel decay maps: the decay fit of [`super::decay`] run on every pixel (or every k×k
//! block) of a photo series, in parallel.
//!
//! For each block the curve is the mean linear value of its unsaturated pixels in each frame,
//! divided by the frame's exposure factor *t* · ISO/100 / *N*² (relative radiance, as
//! [`crate::capture::PhotoSeries::extract`] gives for a region). A block with a saturated pixel in
//! a frame uses the remaining pixels; a block saturated entirely in a frame drops that frame.
//!
//! Weights: a single pixel has no spread to measure, so each sample gets the shot + read noise
//! model of the synthesiser ([`crate::capture::synth`]), σ_t² ∝ p·(0.9·max(y_t, 0) + 0.1·p) with
//! y_t = max_c y_c(t) and p the block's peak: variance proportional to the signal (photon noise)
//! plus a constant read-noise part, 10 % of the variance at the peak. Frames that are only read
//! noise, clipped at the black level (a positive bias), then weigh no more than their noise
//! allows. (Proportional errors with a floor at 1 % of the peak, used before, gave those frames
//! 10⁴ times the weight of the first frame: a fast one-state decay lost to a slow fit of the
//! bias, k ≈ 0.004 s⁻¹ instead of 0.227 s⁻¹ in the left half of `synth phos-decay --layout
//! halves`.)
//!
//! Blocks that cannot be fitted (too few frames, no signal, a fit error) get NaN in every map
//! and are counted in [`PixelMaps::n_failed`]. No file system here: the caller writes the maps.

use rayon::prelude::*;

use crate::capture::PhotoSeries;
use crate::error::{Error, Result};

use super::decay::{fit_decay, DecayCurve, DecayFitOptions};

/// Read-noise share of the variance at the block's peak in the weights (see the module docs).
pub const READ_NOISE_FRACTION: f64 = 0.1;

/// Number of states reported per block (k1..k3, a1..a3).
pub const MAP_STATES: usize = 3;

/// Fitted parameter maps, row-major, `width × height` blocks. Missing values are NaN.
#[derive(Debug, Clone)]
pub struct PixelMaps {
    /// Width in blocks.
    pub width: usize,
    /// Height in blocks.
    pub height: usize,
    /// Block side in frame pixels.
    pub block: usize,
    /// Rates k_i in s⁻¹, fastest first (k1 ≥ k2 ≥ k3); NaN where the block has fewer states.
    pub k_per_s: [Vec<f32>; MAP_STATES],
    /// Amplitudes a_i (relative radiance at t = 0 per unit spectrum).
    pub amplitude: [Vec<f32>; MAP_STATES],
    /// Shared spectrum r, g, b (largest channel 1, as [`super::DecayFit::spectrum`]).
    pub spectrum: [Vec<f32>; 3],
    /// Chosen number of states n_c (0 where the fit failed).
    pub n_states: Vec<f32>,
    /// Residual RMS of the fit (unweighted, relative radiance, as [`super::DecayFit::rms`]).
    pub rms: Vec<f32>,
    /// Blocks fitted.
    pub n_fitted: usize,
    /// Blocks that could not be fitted.
    pub n_failed: usize,
}

/// One block's fitted values.
#[derive(Debug, Clone, Copy)]
struct BlockFit {
    k: [f32; MAP_STATES],
    a: [f32; MAP_STATES],
    spectrum: [f32; 3],
    n_states: f32,
    rms: f32,
}

impl BlockFit {
    const FAILED: BlockFit = BlockFit {
        k: [f32::NAN; MAP_STATES],
        a: [f32::NAN; MAP_STATES],
        spectrum: [f32::NAN; 3],
        n_states: 0.0,
        rms: f32::NAN,
    };
}

/// The relative-radiance curve of block (`bx`, `by`), `None` when fewer than 3 frames have
/// unsaturated pixels in it.
fn block_curve(series: &PhotoSeries, block: usize, bx: usize, by: usize) -> Option<DecayCurve> {
    let frames = series.frames();
    let mut t = Vec::with_capacity(frames.len());
    let mut ch: [Vec<f64>; 3] = [vec![], vec![], vec![]];
    for f in frames {
        let fr = &f.frame;
        let mut sum = [0.0f64; 3];
        let mut n = 0usize;
        for y in by * block..((by + 1) * block).min(fr.height) {
            for x in bx * block..((bx + 1) * block).min(fr.width) {
                if fr.saturation_bits(x, y) != 0 {
                    continue;
                }
                let v = fr.rgb(x, y);
                for c in 0..3 {
                    sum[c] += f64::from(v[c]);
                }
                n += 1;
            }
        }
        if n == 0 {
            continue;
        }
        let k = f.exposure.factor();
        t.push(f.time_s);
        for c in 0..3 {
            ch[c].push(sum[c] / n as f64 / k);
        }
    }
    if t.len() < 3 {
        return None;
    }
    let peak = ch
        .iter()
        .flat_map(|c| c.iter())
        .cloned()
        .fold(0.0f64, f64::max);
    if !(peak > 0.0 && peak.is_finite()) {
        return None;
    }
    let sigma: Vec<f64> = (0..t.len())
        .map(|j| {
            let m = ch.iter().map(|c| c[j]).fold(0.0f64, f64::max).max(0.0);
            (peak * ((1.0 - READ_NOISE_FRACTION) * m + READ_NOISE_FRACTION * peak)).sqrt()
        })
        .collect();
    DecayCurve::new(t, ch.to_vec(), Some(sigma)).ok()
}

fn fit_block(
    series: &PhotoSeries,
    block: usize,
    bx: usize,
    by: usize,
    opts: &DecayFitOptions,
) -> BlockFit {
    let Some(curve) = block_curve(series, block, bx, by) else {
        return BlockFit::FAILED;
    };
    let Ok(fit) = fit_decay(&curve, opts) else {
        return BlockFit::FAILED;
    };
    if !fit.rms.is_finite() {
        return BlockFit::FAILED;
    }
    let mut out = BlockFit::FAILED;
    // the fit sorts states by decreasing rate: k1 is the fastest
    for (i, s) in fit.states.iter().take(MAP_STATES).enumerate() {
        out.k[i] = s.k_per_s as f32;
        out.a[i] = s.amplitude as f32;
    }
    for (c, v) in fit.spectrum.iter().take(3).enumerate() {
        out.spectrum[c] = *v as f32;
    }
    out.n_states = fit.states.len() as f32;
    out.rms = fit.rms as f32;
    out
}

/// Fits every `block × block` block of `series` (block 1 = every pixel) in parallel with
/// `opts`; `progress` is called once per finished row of blocks, from worker threads.
///
/// # Errors
/// [`Error::InvalidArgument`] when `block` is 0 or larger than the frame, or the series has fewer
/// than 3 frames.
pub fn fit_pixel_maps(
    series: &PhotoSeries,
    block: usize,
    opts: &DecayFitOptions,
    progress: &(dyn Fn() + Sync),
) -> Result<PixelMaps> {
    let Some(first) = series.frames().first() else {
        return Err(Error::invalid("series", "no frames; expected at least 3"));
    };
    if series.len() < 3 {
        return Err(Error::invalid(
            "series",
            format!("{} frames; a decay fit needs at least 3", series.len()),
        ));
    }
    let (w, h) = (first.frame.width, first.frame.height);
    if block == 0 || block > w.min(h) {
        return Err(Error::invalid(
            "--block",
            format!(
                "{block}; expected 1 to {} (the frame's smaller side)",
                w.min(h)
            ),
        ));
    }
    let (bw, bh) = (w.div_ceil(block), h.div_ceil(block));
    let rows: Vec<Vec<BlockFit>> = (0..bh)
        .into_par_iter()
        .map(|by| {
            let row = (0..bw)
                .map(|bx| fit_block(series, block, bx, by, opts))
                .collect();
            progress();
            row
        })
        .collect();
    let n = bw * bh;
    let mut maps = PixelMaps {
        width: bw,
        height: bh,
        block,
        k_per_s: std::array::from_fn(|_| Vec::with_capacity(n)),
        amplitude: std::array::from_fn(|_| Vec::with_capacity(n)),
        spectrum: std::array::from_fn(|_| Vec::with_capacity(n)),
        n_states: Vec::with_capacity(n),
        rms: Vec::with_capacity(n),
        n_fitted: 0,
        n_failed: 0,
    };
    for b in rows.iter().flatten() {
        for i in 0..MAP_STATES {
            maps.k_per_s[i].push(b.k[i]);
            maps.amplitude[i].push(b.a[i]);
        }
        for c in 0..3 {
            maps.spectrum[c].push(b.spectrum[c]);
        }
        maps.n_states.push(b.n_states);
        maps.rms.push(b.rms);
        if b.n_states > 0.0 {
            maps.n_fitted += 1;
        } else {
            maps.n_failed += 1;
        }
    }
    Ok(maps)
}
