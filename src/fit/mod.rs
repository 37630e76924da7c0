//! Solvers, options and reports shared by the fitting domains (no physics).
