//! Glue that joins two domains, or a domain and its files (layer L3, above `io`, `preset` and
//! `plot`): each module reads its inputs through `io`, builds the inputs of one domain from the
//! outputs of another, and returns typed results for the binary to print or stage, so that a
//! command declares flags, calls one function here and prints. No domain imports another; they
//! meet here.
//!
//! - [`acquisition`]: acquisition and colour glue.
//! - [`afterimage`]: afterimages (curves; synth: frames, preview, curves, preset, figure).
//! - [`color`]: colour (XYZ of a spectrum or a table, ΔE, conversions).
//! - [`dispersion`]: dispersion (fit n(λ) into a preset; the prism reference and its ΔE00
//!   table).
//! - [`fluor`]: fluorescence (reduce, eval, select, sweep: presets, tables, charts).
//! - [`light`]: photometric lights (inspect, convert, shade, preset, benchmark, glTF export).
//! - [`phos`]: phosphorescence (Λ camera scaling, decay presets, batch fits, integrator
//!   comparison, excitation, design reports, synthetic charging images).
//! - [`phos_excitation`]: excitation rates from charging experiments, design from keyframes,
//!   synthetic charging data (presets, charts, images).
//! - [`phos_fit`]: simulate, fit-decay (curve, ROI, batch, per pixel), merge-maps,
//!   compare-integrators.
//! - [`phos_maps`]: per-pixel decay maps at camera resolution (tile store, memory plan, shards).
//! - [`phos_synth`]: synthetic decay series (frames, manifest, truth, or one curve).
//! - [`preset_export`]: renderer formats of a material preset (glTF, OpenPBR, MaterialX,
//!   WGSL/GLSL).
//! - [`recover`]: spectral recovery from one LVF photo (CSV, summary, chart, reflectance preset).
//! - [`series`]: photo series (per-frame metadata, region curves).

pub mod acquisition;
pub mod afterimage;
pub mod color;
pub mod demo;
pub mod dispersion;
pub mod fluor;
pub mod light;
pub mod phos;
pub mod phos_excitation;
pub mod phos_fit;
pub mod phos_maps;
pub mod phos_synth;
pub mod preset_export;
pub mod recover;
pub mod series;

/// Progress of a long step (decoding frames, rendering frames), for a bar on standard error:
/// `start(total)` once, `inc()` per item (from any thread), `finish()` when the step is done.
pub trait Progress: Sync {
    /// The step starts with `total` items.
    fn start(&self, total: usize);
    /// One more item is done.
    fn inc(&self);
    /// The step is done.
    fn finish(&self);
}

/// No progress display.
#[derive(Debug, Clone, Copy, Default)]
pub struct NoProgress;

impl Progress for NoProgress {
    fn start(&self, _: usize) {}
    fn inc(&self) {}
    fn finish(&self) {}
}
