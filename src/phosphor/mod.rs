//! Phosphorescence: rate-equation model, simulation and decay fitting (Nalbach et al. 2017).
