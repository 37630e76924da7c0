//! Smoothness-regularised (non-negative) least squares with GCV (filled next).
