//! The weighted system a recovery solved, for another solver to solve the identical problem
//! (`spectrum recover --dump-system`, compared with `scipy.optimize.nnls` by
//! `scripts/reference/`).
//!
//! ```text
//! min ‖A x − b‖² + μ ‖D x‖²   (x ≥ 0 when non-negative),   μ = λ · tr(AᵀA) / tr(DᵀD)
//! ```
//!
//! A and b come from [`super::weighted_system`] — the one construction [`super::recover`] uses —
//! and are checked against the recovery's residuals, so the dump cannot describe a different
//! problem than the one solved. D is [`crate::fit::regularized::penalty_operator`]. For the
//! non-negative case the stacked problem `[A; √μ D] x ≈ [b; 0]` is also solved alone by
//! Lawson–Hanson NNLS and timed (best of [`NNLS_TIMING_RUNS`]), the step a peer solver repeats.

use serde::{Deserialize, Serialize};

use super::{weighted_system, Quantity, Recovered, RecoveryOptions, SensingModel, WeightedSystem};
use crate::error::{Error, Result};

/// Schema tag of the dump.
pub const SYSTEM_SCHEMA: &str = "lumifit.recovery-system/1";

/// Runs of the stacked NNLS whose best time is reported.
pub const NNLS_TIMING_RUNS: usize = 5;

/// Largest relative difference between the rebuilt system's residuals and the recovery's.
const RESIDUAL_TOLERANCE: f64 = 1e-6;

/// The dump (`lumifit.recovery-system/1`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SystemDump {
    /// [`SYSTEM_SCHEMA`].
    pub schema: String,
    /// The problem in words.
    pub problem: String,
    /// Equations.
    pub m: usize,
    /// Unknowns.
    pub n: usize,
    /// A, column-major m × n.
    pub a_column_major: Vec<f64>,
    /// Weighted readings.
    pub b: Vec<f64>,
    /// Recovery grid (nm).
    pub grid_nm: Vec<f64>,
    /// Relative penalty weight λ.
    pub lambda: f64,
    /// Whether λ came from GCV.
    pub lambda_from_gcv: bool,
    /// Absolute penalty weight μ.
    pub mu: f64,
    /// How μ follows from λ.
    pub mu_rule: String,
    /// Order of the difference operator D.
    pub difference_order: usize,
    /// Whether x ≥ 0 was imposed.
    pub nonnegative: bool,
    /// The recovery's solution.
    pub x: Vec<f64>,
    /// Time of the whole recovery solve (s).
    pub solve_seconds: f64,
    /// What `solve_seconds` includes.
    pub solve_includes: String,
    /// Best time of the stacked NNLS alone (s); `None` without non-negativity.
    pub nnls_stacked_seconds: Option<f64>,
    /// Solution of the stacked NNLS.
    pub nnls_stacked_x: Option<Vec<f64>>,
}

/// Builds the dump of the recovery `rec` (solved in `solve_seconds`) of `rgb` through `model`.
///
/// # Errors
/// As [`weighted_system`]; [`Error::Numerical`] when the rebuilt system does not reproduce the
/// recovery's residuals (a bug, reported instead of writing a wrong dump).
pub fn system_dump(
    model: &SensingModel,
    rgb: &[[f64; 3]],
    std: Option<&[[f64; 3]]>,
    quantity: &Quantity,
    opts: &RecoveryOptions,
    rec: &Recovered,
    solve_seconds: f64,
) -> Result<SystemDump> {
    let nb = model.transmission.len();
    let WeightedSystem {
        a,
        b,
        sigma: sig,
        m,
        n,
    } = weighted_system(model, rgb, std, quantity)?;
    let mut worst = 0.0f64;
    for j in 0..nb {
        for c in 0..3 {
            let r = 3 * j + c;
            let ax: f64 = (0..n).map(|i| a[i * m + r] * rec.value[i]).sum();
            let d = ((b[r] - ax) - rec.residuals[j][c] / sig[r]).abs();
            worst = worst.max(d / b[r].abs().max(1.0));
        }
    }
    if worst > RESIDUAL_TOLERANCE {
        return Err(Error::Numerical {
            what: "--dump-system".to_string(),
            reason: format!("the rebuilt system does not reproduce the recovery's residuals (relative difference {worst:.2e}); this is a bug"),
        });
    }
    let d = crate::fit::regularized::penalty_operator(n, opts.smoothness);
    let order = n - d.nrows();
    let gram_trace: f64 = a.iter().map(|v| v * v).sum();
    let dtd_trace: f64 = d.iter().map(|v| v * v).sum();
    let mu = rec.lambda * gram_trace / dtd_trace;
    let stacked = if opts.nonnegative {
        let rows = m + d.nrows();
        let sq = mu.sqrt();
        let mut st = Vec::with_capacity(rows * n);
        for col in 0..n {
            st.extend_from_slice(&a[col * m..(col + 1) * m]);
            st.extend(d.column(col).iter().map(|v| sq * v));
        }
        let mut rhs = b.clone();
        rhs.resize(rows, 0.0);
        let mut best = f64::INFINITY;
        let mut x = Vec::new();
        for _ in 0..NNLS_TIMING_RUNS {
            let t = std::time::Instant::now();
            let sol = crate::fit::nnls::nnls(&st, rows, n, &rhs, &vec![false; n]);
            best = best.min(t.elapsed().as_secs_f64());
            x = sol.x;
        }
        Some((best, x))
    } else {
        None
    };
    Ok(SystemDump {
        schema: SYSTEM_SCHEMA.to_string(),
        problem: "min ‖A x − b‖² + μ ‖D x‖² (x ≥ 0 when nonnegative); D the difference operator of the given order on the grid".to_string(),
        m,
        n,
        a_column_major: a,
        b,
        grid_nm: model.grid_nm.clone(),
        lambda: rec.lambda,
        lambda_from_gcv: rec.lambda_from_gcv,
        mu,
        mu_rule: "μ = λ · tr(AᵀA) / tr(DᵀD)".to_string(),
        difference_order: order,
        nonnegative: opts.nonnegative,
        x: rec.value.clone(),
        solve_seconds,
        solve_includes:
            "GCV search (when chosen), the solve, the uncertainty and the resolution matrix"
                .to_string(),
        nnls_stacked_seconds: stacked.as_ref().map(|s| s.0),
        nnls_stacked_x: stacked.map(|s| s.1),
    })
}
