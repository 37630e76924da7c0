//! Spectral recovery from camera readings through the LVF (filled next).
