//! lumifit: photographs and measurements of unusual appearance turned into compact material and
//! light presets.
//!
//! The crate is layered (see `docs/architecture.md`); a module imports only from layers below it:
//!
//! | layer | modules |
//! |---|---|
//! | L0 | [`error`], [`limits`], [`math`], [`table`], [`calib`] |
//! | L1 | [`spectrum`], [`colorimetry`], [`fit`], [`capture`], [`render`] (a pure ray caster for previews) |
//! | L2 | [`afterimage`], [`dispersion`], [`fluor`], [`phosphor`], [`lvf`], [`recovery`], [`photometry`] |
//! | L3 | [`io`], [`preset`], [`plot`], [`pipeline`] |
//!
//! The binary `lumifit` (L4) is a thin clap front end over these.

pub mod afterimage;
pub mod calib;
pub mod capture;
pub mod colorimetry;
pub mod dispersion;
pub mod error;
pub mod fit;
pub mod fluor;
pub mod io;
pub mod limits;
pub mod lvf;
pub mod math;
pub mod phosphor;
pub mod photometry;
pub mod pipeline;
pub mod plot;
pub mod preset;
pub mod recovery;
pub mod render;
pub mod spectrum;
pub mod table;

pub use error::{Error, Result};
