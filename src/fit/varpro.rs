//! Variable projection (Golub & Pereyra 1973) with non-negative linear coefficients, solved by
//! Levenberg–Marquardt on the projected residual with Kaufman's (1975) Jacobian.
//!
//! The model is `Y ≈ Φ(θ) C`: Y holds `n_rhs` right-hand sides of m rows each (for example the
//! R, G, B channels of one curve), Φ(θ) is an m × n basis depending on the nonlinear parameters
//! θ, and C (n × n_rhs) holds linear coefficients. For each θ the coefficients are solved exactly
//! by [`nnls`](super::nnls::nnls) (columns may be marked free), so the outer solver sees only
//!
//! `f(θ) = ½ Σ_rhs ‖W^{1/2} (y_rhs − Φ(θ) c*_rhs(θ))‖²`.
//!
//! Structure assumed (it keeps the Jacobian cheap): every basis column depends on at most one
//! nonlinear parameter, given by [`SeparableModel::column_param`], with the derivative supplied by
//! the model. With the passive set P of the NNLS solution held fixed, Kaufman's Jacobian column
//! for θ_p is `−P⊥_{Φ_P} Σ_{j: param(j)=p} ∂φ_j/∂θ_p · c_j`.
//!
//! The iteration stops with a [`Termination`] reason recorded as data; a fit that runs out of
//! iterations is still a report.

// Index loops mirror the matrix notation of the maths; `!(a > b)` comparisons deliberately
// reject NaN along with out-of-range values.
#![allow(clippy::needless_range_loop, clippy::neg_cmp_op_on_partial_ord)]

use super::nnls::{nnls_in, NnlsWorkspace};
use super::qr::Qr;
pub use super::termination::Termination;
use super::termination::{cost_converged, cost_stalled, norm, step_converged};

/// A separable model: the basis Φ(θ) and its column derivatives. Knows nothing about the data.
pub trait SeparableModel {
    /// Number of rows m of the basis (samples per right-hand side).
    fn n_rows(&self) -> usize;
    /// Number of nonlinear parameters.
    fn n_params(&self) -> usize;
    /// Number of basis columns n.
    fn n_cols(&self) -> usize;
    /// The nonlinear parameter column `col` depends on, if any.
    fn column_param(&self, col: usize) -> Option<usize>;
    /// Whether column `col`'s coefficients are unconstrained (otherwise ≥ 0).
    fn column_free(&self, col: usize) -> bool;
    /// Fills `basis` and `dbasis` (both m × n column-major): `dbasis[:, j] = ∂φ_j/∂θ_{param(j)}`
    /// (zero for columns without a parameter).
    fn eval(&self, theta: &[f64], basis: &mut [f64], dbasis: &mut [f64]);
}

/// Stopping rules and limits.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SolverOptions {
    /// Maximum number of accepted-or-rejected iterations.
    pub max_iter: usize,
    /// Relative cost reduction below which the fit is converged.
    pub ftol: f64,
    /// Relative step size below which the fit is converged.
    pub xtol: f64,
    /// Gradient size (cosine between residual and Jacobian columns) below which it is converged.
    pub gtol: f64,
}

impl Default for SolverOptions {
    fn default() -> Self {
        SolverOptions {
            max_iter: 200,
            ftol: 1e-12,
            xtol: 1e-10,
            gtol: 1e-10,
        }
    }
}

impl From<&super::lm::LmOptions> for SolverOptions {
    /// The stopping rules of [`LmOptions`](super::lm::LmOptions) (varpro has no bounds).
    fn from(o: &super::lm::LmOptions) -> Self {
        SolverOptions {
            max_iter: o.max_iter,
            ftol: o.ftol,
            xtol: o.xtol,
            gtol: o.gtol,
        }
    }
}

/// The data: `n_rhs` right-hand sides of m rows, stored rhs after rhs, and optional per-row
/// square-root weights (1/σ).
#[derive(Debug, Clone, Copy)]
pub struct SeparableData<'a> {
    /// m × n_rhs values, right-hand side after right-hand side.
    pub y: &'a [f64],
    /// Number of right-hand sides.
    pub n_rhs: usize,
    /// Per-row √weight (1/σ), shared by all right-hand sides; `None` for unit weights.
    pub sqrt_w: Option<&'a [f64]>,
}

/// Result of [`solve_separable`].
#[derive(Debug, Clone, PartialEq)]
pub struct SeparableFit {
    /// Nonlinear parameters at the end.
    pub theta: Vec<f64>,
    /// Linear coefficients, n × n_rhs (column after column per right-hand side).
    pub coeffs: Vec<f64>,
    /// Weighted residual sum of squares (2 × cost).
    pub rss: f64,
    /// Iterations used.
    pub iterations: usize,
    /// Why it stopped.
    pub termination: Termination,
}

/// Reusable buffers of one evaluation point.
#[derive(Debug, Clone, Default)]
struct Point {
    basis: Vec<f64>,
    dbasis: Vec<f64>,
    coeffs: Vec<f64>,
    passive: Vec<bool>,
    /// Per right-hand side (m each): Qᵀy, the data in the coordinates of `qr`, when every
    /// column is passive (`all_passive`); otherwise the residual y − Φc.
    resid: Vec<f64>,
    rss: f64,
    /// QR of the whole (weighted) basis, shared by every right-hand side.
    qr: Qr,
    /// Per right-hand side: the unconstrained solution was feasible, so every column is
    /// passive and `qr` is the factorisation of the passive columns.
    all_passive: Vec<bool>,
}

/// Scratch buffers of the solver, allocated once per solve.
#[derive(Debug, Clone, Default)]
struct Scratch {
    qtb: Vec<f64>,
    x: Vec<f64>,
    v: Vec<f64>,
    sub: Vec<f64>,
    sub_qr: Qr,
    /// Qᵀ ∂φ_j for every column j with a parameter (m each), shared by the right-hand sides
    /// whose passive set is every column.
    qtd: Vec<f64>,
    nnls: NnlsWorkspace,
    /// Passive columns per right-hand side (rows of the compact Jacobian: m − k).
    ks: Vec<usize>,
}

struct Evaluator<'m, 'd, 'w, M: SeparableModel> {
    model: &'m M,
    data: SeparableData<'d>,
    m: usize,
    n: usize,
    free: &'w [bool],
    params: &'w [Option<usize>],
    wy: &'w [f64],
}

/// Every buffer of one solve, kept per thread and reused by the next solve (a decay fit runs
/// thousands of small solves; allocating these each time cost about a tenth of the time).
#[derive(Debug, Default)]
struct Workspace {
    free: Vec<bool>,
    params: Vec<Option<usize>>,
    wy: Vec<f64>,
    cur: Point,
    trial: Point,
    sc: Scratch,
    jac: Vec<f64>,
    rc: Vec<f64>,
    qr: Qr,
    qtr: Vec<f64>,
    g: Vec<f64>,
    diag: Vec<f64>,
    step: Vec<f64>,
    trial_theta: Vec<f64>,
    aug: Vec<f64>,
    rhs: Vec<f64>,
    small: Qr,
    lin: Vec<f64>,
}

thread_local! {
    static WORKSPACE: std::cell::RefCell<Workspace> = std::cell::RefCell::new(Workspace::default());
}

/// `v` cleared and filled with `len` copies of `x`.
fn reset<T: Clone>(v: &mut Vec<T>, len: usize, x: T) {
    v.clear();
    v.resize(len, x);
}

impl<M: SeparableModel> Evaluator<'_, '_, '_, M> {
    /// Evaluates the basis and the projected residual at θ. The basis is factorised once and
    /// the factorisation is shared by all right-hand sides: when the unconstrained solution is
    /// feasible (the common case) it is the NNLS solution (same arithmetic as the fast path of
    /// [`nnls`]); otherwise that right-hand side goes through Lawson–Hanson.
    fn eval(&self, theta: &[f64], pt: &mut Point, sc: &mut Scratch) -> bool {
        let (m, n) = (self.m, self.n);
        pt.basis.resize(m * n, 0.0);
        pt.dbasis.resize(m * n, 0.0);
        self.model.eval(theta, &mut pt.basis, &mut pt.dbasis);
        if let Some(w) = self.data.sqrt_w {
            // column by column without index checks (the loop vectorises)
            let w = &w[..m];
            for (b, d) in pt
                .basis
                .chunks_exact_mut(m)
                .zip(pt.dbasis.chunks_exact_mut(m))
            {
                for ((bi, di), wi) in b.iter_mut().zip(d.iter_mut()).zip(w) {
                    *bi *= wi;
                    *di *= wi;
                }
            }
        }
        if pt.basis.iter().any(|v| !v.is_finite()) {
            return false;
        }
        pt.coeffs.clear();
        pt.passive.clear();
        pt.all_passive.clear();
        pt.resid.clear();
        pt.rss = 0.0;
        let fast = m >= n;
        if fast {
            pt.qr.factor(&pt.basis, m, n);
        }
        sc.x.resize(n, 0.0);
        for r in 0..self.data.n_rhs {
            let y = &self.wy[r * m..(r + 1) * m];
            let mut feasible = false;
            if fast {
                sc.qtb.clear();
                sc.qtb.extend_from_slice(y);
                pt.qr.qt_mul(&mut sc.qtb);
                pt.qr.solve_r(&sc.qtb, &mut sc.x);
                feasible = sc.x.iter().zip(self.free).all(|(v, f)| *f || *v >= 0.0);
            }
            if feasible {
                // the residual in the coordinates of Q: Qᵀr = Qᵀy − R c, whose rows below n are
                // those of Qᵀy (kept for the Jacobian); the rows above are rounding unless a
                // column was dependent (its coefficient set to 0)
                let qr = &pt.qr;
                let mut rss = 0.0;
                for i in 0..n {
                    let mut v = sc.qtb[i];
                    for l in i..n {
                        v -= qr.r(i, l) * sc.x[l];
                    }
                    rss += v * v;
                }
                pt.rss += rss + sc.qtb[n..].iter().map(|v| v * v).sum::<f64>();
                pt.coeffs.extend_from_slice(&sc.x);
                pt.passive.extend(std::iter::repeat_n(true, n));
                pt.all_passive.push(true);
                pt.resid.extend_from_slice(&sc.qtb);
                continue;
            }
            // the unconstrained solution was just found infeasible (or m < n): straight to
            // Lawson–Hanson, in reused buffers (the same arithmetic as `nnls`)
            nnls_in(&pt.basis, m, n, y, self.free, false, &mut sc.nnls);
            pt.coeffs.extend_from_slice(&sc.nnls.x);
            pt.passive.extend_from_slice(&sc.nnls.passive);
            pt.all_passive.push(false);
            let c = &pt.coeffs[r * n..(r + 1) * n];
            let start = pt.resid.len();
            pt.resid.extend_from_slice(y);
            let res = &mut pt.resid[start..];
            for j in 0..n {
                if c[j] != 0.0 {
                    let col = &pt.basis[j * m..(j + 1) * m];
                    for i in 0..m {
                        res[i] -= col[i] * c[j];
                    }
                }
            }
            pt.rss += res.iter().map(|v| v * v).sum::<f64>();
        }
        pt.rss.is_finite()
    }

    /// Kaufman's Jacobian in the coordinates of the residual's own space, column-major, and the
    /// residual in the same coordinates; returns their number of rows.
    ///
    /// For each right-hand side the residual lies in the orthogonal complement of the passive
    /// columns, r = Q₂Q₂ᵀr, and so does every Kaufman column −P⊥Σ ∂φ_j c_j = −Q₂Q₂ᵀ(…). Q₂ has
    /// orthonormal columns, so J = Q₂J₂ and r = Q₂r₂ with J₂ = −Q₂ᵀ(…) and r₂ = Q₂ᵀr: the
    /// Gram matrix, the gradient, the column norms and every Levenberg–Marquardt step are the
    /// same from (J₂, r₂) as from (J, r), at half the cost of the projection (one pass of the
    /// reflectors, not two) and with k fewer rows per right-hand side (k passive columns).
    fn jacobian(
        &self,
        pt: &Point,
        p: usize,
        jac: &mut Vec<f64>,
        rc: &mut Vec<f64>,
        sc: &mut Scratch,
    ) -> usize {
        let (m, n) = (self.m, self.n);
        // rows of each right-hand side: m − k_r
        sc.ks.clear();
        for r in 0..self.data.n_rhs {
            let k = if pt.all_passive[r] {
                n
            } else {
                pt.passive[r * n..(r + 1) * n]
                    .iter()
                    .filter(|v| **v)
                    .count()
            };
            sc.ks.push(k.min(m));
        }
        let rows_c: usize = sc.ks.iter().map(|k| m - k).sum();
        // at least p rows (zero rows change neither the Gram matrix nor the gradient)
        let rows = rows_c.max(p);
        jac.clear();
        jac.resize(rows * p, 0.0);
        rc.clear();
        rc.resize(rows, 0.0);
        sc.v.resize(m, 0.0);
        let mut off = 0;
        let mut qtd_done = false;
        for r in 0..self.data.n_rhs {
            let c = &pt.coeffs[r * n..(r + 1) * n];
            let pas = &pt.passive[r * n..(r + 1) * n];
            let k = sc.ks[r];
            let qr = if pt.all_passive[r] {
                &pt.qr
            } else {
                sc.sub.clear();
                for j in 0..n {
                    if pas[j] {
                        sc.sub.extend_from_slice(&pt.basis[j * m..(j + 1) * m]);
                    }
                }
                if k > 0 {
                    sc.sub_qr.factor(&sc.sub, m, k);
                }
                &sc.sub_qr
            };
            let len = m - k;
            if pt.all_passive[r] {
                // Qᵀy is stored: the compact residual is its rows k.., and every Jacobian
                // column is −Σ c_j (Qᵀ∂φ_j)[k..] with Qᵀ∂φ_j found once for all such
                // right-hand sides
                if !qtd_done {
                    sc.qtd.clear();
                    sc.qtd.resize(m * n, 0.0);
                    for j in 0..n {
                        if self.params[j].is_some() {
                            let d = &mut sc.qtd[j * m..(j + 1) * m];
                            d.copy_from_slice(&pt.dbasis[j * m..(j + 1) * m]);
                            if k > 0 {
                                qr.qt_mul(d);
                            }
                        }
                    }
                    qtd_done = true;
                }
                rc[off..off + len].copy_from_slice(&pt.resid[r * m + k..(r + 1) * m]);
                for j in 0..n {
                    if let Some(q) = self.params[j] {
                        if c[j] != 0.0 {
                            let d = &sc.qtd[j * m + k..(j + 1) * m];
                            let col = &mut jac[q * rows + off..q * rows + off + len];
                            for (x, dv) in col.iter_mut().zip(d) {
                                *x -= dv * c[j];
                            }
                        }
                    }
                }
                off += len;
                continue;
            }
            sc.v.copy_from_slice(&pt.resid[r * m..(r + 1) * m]);
            if k > 0 {
                qr.qt_mul(&mut sc.v);
            }
            rc[off..off + len].copy_from_slice(&sc.v[k..]);
            for q in 0..p {
                sc.v.iter_mut().for_each(|x| *x = 0.0);
                let mut any = false;
                for j in 0..n {
                    if self.params[j] == Some(q) && c[j] != 0.0 {
                        any = true;
                        let d = &pt.dbasis[j * m..(j + 1) * m];
                        for i in 0..m {
                            sc.v[i] -= d[i] * c[j];
                        }
                    }
                }
                if any {
                    if k > 0 {
                        qr.qt_mul(&mut sc.v);
                    }
                    jac[q * rows + off..q * rows + off + len].copy_from_slice(&sc.v[k..]);
                }
            }
            off += len;
        }
        rows
    }
}

/// Solves `min_θ f(θ)` from `theta0` (see the module docs).
///
/// Never fails: non-finite starts or models end with [`Termination::NonFinite`] and the start
/// returned as is (with infinite RSS when it could not be evaluated).
pub fn solve_separable<M: SeparableModel>(
    model: &M,
    data: SeparableData<'_>,
    theta0: &[f64],
    opts: &SolverOptions,
) -> SeparableFit {
    WORKSPACE.with(|ws| match ws.try_borrow_mut() {
        Ok(mut ws) => solve_in(model, data, theta0, opts, &mut ws),
        // re-entered from inside a model (not done by the crate's models): fresh buffers
        Err(_) => solve_in(model, data, theta0, opts, &mut Workspace::default()),
    })
}

fn solve_in<M: SeparableModel>(
    model: &M,
    data: SeparableData<'_>,
    theta0: &[f64],
    opts: &SolverOptions,
    ws: &mut Workspace,
) -> SeparableFit {
    let m = model.n_rows();
    let n = model.n_cols();
    let p = model.n_params();
    let Workspace {
        free,
        params,
        wy,
        cur,
        trial,
        sc,
        jac,
        rc,
        qr,
        qtr,
        g,
        diag,
        step,
        trial_theta,
        aug,
        rhs,
        small,
        lin,
    } = ws;
    wy.clear();
    wy.extend_from_slice(&data.y[..m * data.n_rhs]);
    if let Some(w) = data.sqrt_w {
        for r in 0..data.n_rhs {
            for i in 0..m {
                wy[r * m + i] *= w[i];
            }
        }
    }
    free.clear();
    free.extend((0..n).map(|j| model.column_free(j)));
    params.clear();
    params.extend((0..n).map(|j| model.column_param(j)));
    let ev = Evaluator {
        model,
        data,
        m,
        n,
        free,
        params,
        wy,
    };
    let mut theta = theta0.to_vec();
    if !ev.eval(&theta, cur, sc) {
        return SeparableFit {
            theta,
            coeffs: vec![0.0; n * data.n_rhs],
            rss: f64::INFINITY,
            iterations: 0,
            termination: Termination::NonFinite,
        };
    }
    let mut mu = 0.0_f64;
    let mut nu = 2.0;
    let mut iterations = 0;
    let mut termination = Termination::MaxIterations;
    let mut need_jac = true;
    reset(g, p, 0.0);
    reset(diag, p, 0.0);
    reset(step, p, 0.0);
    reset(trial_theta, p, 0.0);
    reset(rhs, 2 * p, 0.0);
    lin.clear();
    while iterations < opts.max_iter {
        iterations += 1;
        if need_jac {
            let rows = ev.jacobian(cur, p, jac, rc, sc);
            qr.factor(jac, rows, p);
            qtr.clear();
            qtr.extend_from_slice(rc);
            qr.qt_mul(qtr);
            // gradient g = Jᵀ r and column norms
            let rnorm = cur.rss.sqrt();
            let mut gmax = 0.0_f64;
            for q in 0..p {
                let col = &jac[q * rows..(q + 1) * rows];
                g[q] = col.iter().zip(rc.iter()).map(|(a, b)| a * b).sum();
                let cn = col.iter().map(|v| v * v).sum::<f64>().sqrt();
                diag[q] = diag[q].max(cn);
                if cn > 0.0 && rnorm > 0.0 {
                    gmax = gmax.max(g[q].abs() / (cn * rnorm));
                }
            }
            if gmax <= opts.gtol || cur.rss == 0.0 {
                termination = Termination::GradientConverged;
                break;
            }
            // The full Gauss–Newton step from here would lower the RSS by ‖Q₁ᵀr‖² (Q₁ the
            // range of J): when even that is at most ftol relative to the cost, no step can
            // pass MINPACK's cost test by more, so the fit is converged without trying one.
            if qtr[..p].iter().map(|v| v * v).sum::<f64>() <= opts.ftol * cur.rss {
                termination = Termination::CostConverged;
                break;
            }
            // A Jacobian whose factorisation overflowed (a column ~1e-35 against one of order 1:
            // a rate gone to the edge of the range) gives a non-finite step for every damping,
            // so raising μ until it overflows changes nothing: stop here with the same result.
            if qtr[..p].iter().any(|v| !v.is_finite()) {
                termination = Termination::NoProgress;
                break;
            }
            if mu == 0.0 {
                let dmax = diag.iter().fold(0.0_f64, |a, b| a.max(*b));
                mu = 1e-3 * dmax * dmax;
            }
            need_jac = false;
        }
        // LM step: min ‖[R; √μ D] δ + [Qᵀr; 0]‖ (R from the QR of J). The residual is y − f and
        // J = ∂r/∂θ, so the Gauss–Newton step solves J δ ≈ −r.
        aug.clear();
        aug.resize(2 * p * p, 0.0);
        rhs.iter_mut().for_each(|v| *v = 0.0);
        for j in 0..p {
            for i in 0..=j {
                aug[j * 2 * p + i] = qr.r(i, j);
            }
            let d = if diag[j] > 0.0 { diag[j] } else { 1.0 };
            aug[j * 2 * p + p + j] = mu.sqrt() * d;
            rhs[j] = -qtr[j];
        }
        small.factor(aug, 2 * p, p);
        small.qt_mul(rhs);
        small.solve_r(rhs, step);
        for q in 0..p {
            trial_theta[q] = theta[q] + step[q];
        }
        let ok = ev.eval(trial_theta, trial, sc);
        // predicted reduction of ½‖r‖²: −gᵀδ·... computed from the linear model.
        lin.clear();
        lin.extend_from_slice(&qtr[..p]);
        for i in 0..p {
            for j in i..p {
                lin[i] += qr.r(i, j) * step[j];
            }
        }
        let pred = 0.5
            * (qtr[..p].iter().map(|v| v * v).sum::<f64>()
                - lin.iter().map(|v| v * v).sum::<f64>());
        let actual = 0.5 * (cur.rss - trial.rss);
        if ok && trial.rss.is_finite() && actual > 0.0 {
            let rho = if pred > 0.0 { actual / pred } else { 1.0 };
            let old_rss = cur.rss;
            let step_norm = norm(step);
            let theta_norm = norm(&theta);
            theta.copy_from_slice(trial_theta);
            std::mem::swap(cur, trial);
            need_jac = true;
            mu *= (1.0_f64 / 3.0).max(1.0 - (2.0 * rho - 1.0).powi(3));
            nu = 2.0;
            // MINPACK's rule: actual and predicted relative reductions both tiny
            if cost_converged(old_rss, cur.rss, pred, opts.ftol) {
                termination = Termination::CostConverged;
                break;
            }
            if step_converged(step_norm, theta_norm, opts.xtol) {
                termination = Termination::StepConverged;
                break;
            }
        } else {
            if !ok && !trial.rss.is_finite() && mu > 1e300 {
                termination = Termination::NonFinite;
                break;
            }
            if ok && step_converged(norm(step), norm(&theta), opts.xtol) {
                termination = Termination::StepConverged;
                break;
            }
            // MINPACK's rule also applies to a rejected step: when the predicted reduction and
            // the actual change are both below ftol relative to the cost, the cost is at its
            // minimum to the requested precision (the "increase" is rounding).
            if ok && cost_stalled(cur.rss, trial.rss, pred, opts.ftol) {
                termination = Termination::CostConverged;
                break;
            }
            mu *= nu;
            nu *= 2.0;
            if !mu.is_finite() || mu > 1e300 {
                termination = Termination::NoProgress;
                break;
            }
        }
    }
    SeparableFit {
        theta,
        coeffs: cur.coeffs.clone(),
        rss: cur.rss,
        iterations,
        termination,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// e^{−e^{θ_j} t} columns and a free constant.
    struct Exp2 {
        t: Vec<f64>,
    }

    impl SeparableModel for Exp2 {
        fn n_rows(&self) -> usize {
            self.t.len()
        }
        fn n_params(&self) -> usize {
            2
        }
        fn n_cols(&self) -> usize {
            3
        }
        fn column_param(&self, col: usize) -> Option<usize> {
            (col < 2).then_some(col)
        }
        fn column_free(&self, col: usize) -> bool {
            col == 2
        }
        fn eval(&self, theta: &[f64], basis: &mut [f64], dbasis: &mut [f64]) {
            let m = self.t.len();
            for j in 0..2 {
                let k = theta[j].exp();
                for (i, t) in self.t.iter().enumerate() {
                    let e = (-k * t).exp();
                    basis[j * m + i] = e;
                    dbasis[j * m + i] = -k * t * e;
                }
            }
            basis[2 * m..].iter_mut().for_each(|v| *v = 1.0);
            dbasis[2 * m..].iter_mut().for_each(|v| *v = 0.0);
        }
    }

    /// RSS recomputed from the returned θ and coefficients, y − Φc explicitly.
    fn explicit_rss(model: &Exp2, y: &[f64], n_rhs: usize, w: &[f64], fit: &SeparableFit) -> f64 {
        let m = model.t.len();
        let mut b = vec![0.0; 3 * m];
        let mut d = vec![0.0; 3 * m];
        model.eval(&fit.theta, &mut b, &mut d);
        let mut rss = 0.0;
        for r in 0..n_rhs {
            for i in 0..m {
                let f: f64 = (0..3).map(|j| b[j * m + i] * fit.coeffs[r * 3 + j]).sum();
                rss += (w[i] * (y[r * m + i] - f)).powi(2);
            }
        }
        rss
    }

    #[test]
    fn rss_and_steps_from_the_stored_projection_match_the_explicit_residual() {
        // two rates 2 and 0.3 s⁻¹ on 37 samples, three right-hand sides with a background and
        // a small deterministic wiggle (so the RSS is not zero), weighted rows
        let m = 37;
        let model = Exp2 {
            t: (0..m).map(|i| i as f64 * 0.25).collect(),
        };
        let w: Vec<f64> = (0..m).map(|i| 1.0 / (1.0 + 0.02 * i as f64)).collect();
        let mut y = Vec::new();
        for r in 0..3 {
            let (a1, a2, bg) = (1.0 + r as f64, 0.5 + 0.2 * r as f64, 0.05 * r as f64);
            y.extend(model.t.iter().enumerate().map(|(i, t)| {
                a1 * (-2.0 * t).exp() + a2 * (-0.3 * t).exp() + bg + 1e-3 * (i as f64 * 1.7).sin()
            }));
        }
        let data = SeparableData {
            y: &y,
            n_rhs: 3,
            sqrt_w: Some(&w),
        };
        // the reported RSS is the explicit one, to rounding
        let fit_matching_explicit_rss = |theta0: &[f64]| {
            let fit = solve_separable(&model, data, theta0, &SolverOptions::default());
            let rss = explicit_rss(&model, &y, 3, &w, &fit);
            assert!(
                (fit.rss - rss).abs() <= 1e-10 * rss,
                "start {theta0:?}: {} vs {}",
                fit.rss,
                rss
            );
            fit
        };
        let fit = fit_matching_explicit_rss(&[0.0, -2.0]);
        let mut k: Vec<f64> = fit.theta.iter().map(|v| v.exp()).collect();
        k.sort_by(f64::total_cmp);
        assert!(
            (k[0] / 0.3 - 1.0).abs() < 1e-2 && (k[1] / 2.0 - 1.0).abs() < 1e-2,
            "{k:?}"
        );
        assert_ne!(fit.termination, Termination::MaxIterations);
        // equal start rates: the basis starts rank deficient (a coefficient set to 0), where
        // the RSS needs the rows of Qᵀy − Rc above n as well
        fit_matching_explicit_rss(&[-1.0, -1.0]);
    }
}
