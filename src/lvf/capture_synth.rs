//! Synthetic captures of a continuous spectrum through the LVF (filled next).
