//! Fluorescence: Donaldson-matrix reduction (Fichet et al. 2024).
