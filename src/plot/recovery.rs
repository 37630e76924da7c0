//! Charts of recovered spectra (filled next).
