//! Colour-gel transmission tables (filled next).
