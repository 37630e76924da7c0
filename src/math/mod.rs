//! Layer 0 numerical helpers shared by every domain: interpolation, linear algebra on tiny
//! fixed-size matrices, and quadrature. Nothing here knows about colour or physics.

pub mod interpolation;
pub mod linalg;
pub mod minimize;
