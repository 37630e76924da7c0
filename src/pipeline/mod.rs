//! Glue that joins two domains, or a domain and its files (layer 3, above `io`, `preset` and
//! `plot`): what a command does between reading its inputs and staging its outputs, so that the
//! binary only declares flags, calls one function here and prints.
//!
//! - [`phos`]: phosphorescence (Λ camera scaling, decay presets, integrator comparison,
//!   excitation, design reports, synthetic charging images).

pub mod phos;
