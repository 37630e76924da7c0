//! Excitation rates from charging experiments (Nalbach et al. 2017, §4.6).
//!
//! A sample kept dark (r_i = 0) is charged for T seconds by the light of one band j, the light
//! is switched off and, after the switch-off delay δ, the camera reads its emission. With the
//! source spectrum E_j over the material's bands normalised to unit length (the paper's
//! choice) and k_e,i assumed constant over the source's support, the excitation of state i is
//! a_i = k_e,i(j)·s_j with s_j = Σ_b E_j[b] (s_j = 1 for a source inside one band). Eq. 1 under
//! constant light has the exact solution
//!
//! `r_i(T) = a_i/(a_i + k_r,i) · (1 − e^{−(a_i + k_r,i) T})`,
//!
//! and the camera reads `y = Σ_i C (Λ_i k_r,i) r_i(T) e^{−k_r,i δ}` (Eq. 3, C the band camera).
//! The derivative used by the fit is analytic, with λ = a + k_r and E = e^{−λT}:
//!
//! `∂r/∂a = k_r (1 − E)/λ² + (a/λ) T E`,  `∂r/∂k_e = s_j ∂r/∂a`.
//!
//! Bands are fitted independently by the crate's Levenberg–Marquardt ([`fit::lm`](crate::fit::lm))
//! with the bound k_e ≥ 0, started from a log-grid ([`fit::search`](crate::fit::search)). With several states, k_e is either shared by
//! the states or fitted per state; `Auto` takes the per-state model only when BIC prefers it
//! and every per-state rate is determined to better than 50 % (state-specific excitation is
//! only identifiable when the charging curve shows it).
//!
//! When the simulated concentration never exceeds [`SATURATION_MIN`], the signal is linear in
//! a_i, so the data determine only the product k_e·Λ: the fit still reports k_e (given Λ from
//! the decay fit) and flags the band `product_only`.
//!
//! **The decay measurement's charge.** Λ comes from a decay fit, whose amplitudes are
//! Λ_i k_r,i r_i(0): Λ is exact only when the decay sample was saturated at switch-off. When it
//! was charged for T_d under flat light ([`DecayCharging::Flat`],
//! [`ExcitationOptions::decay_charging`]), the decay fit's Λ is the apparent Λ_i·r_i(0) and
//! r_i(0) = a_i/(a_i + k_r,i)(1 − e^{−(a_i + k_r,i)T_d}) with a_i = Σ_b k_e,i[b] E_d[b] depends
//! on the very rates fitted here. The fit then solves both together: a scan over a common
//! r(0) = c ∈ [10⁻⁴, 1] (per-band fits with Λ/c) brackets the self-consistent c where the rates
//! give back r_0(0) = c, bisection finds it (a charge that reaches equilibrium makes this a
//! tangency: then golden section finds the c closest to it), and Levenberg–Marquardt over all bands' rates at
//! once, with Λ_i = Λ_i,apparent / r_i(0; k_e) in the model, gives the final rates and their
//! covariance (the coupling through r(0) included). Bands not measured keep their k_e (or 0).
//!
//! No colour-science counterpart exists.

// Index loops mirror the matrix notation of the maths; `!(a > b)` comparisons deliberately
// reject NaN along with out-of-range values.
#![allow(clippy::needless_range_loop, clippy::neg_cmp_op_on_partial_ord)]

use crate::error::{Error, Result};
use crate::fit::search::log_grid_min;
use crate::fit::stats::{self, bic};
use crate::fit::{levenberg_marquardt, LmOptions, Residuals};

use super::charging::DecayCharging;
use super::material::Material;
use super::simulate::{final_state, BandCamera, Segment};
use super::synth::Gaussian;

/// Largest simulated concentration below which a band's charging is called unsaturated
/// (signal linear in k_e to within 10 %, so k_e and Λ are not separable).
pub const SATURATION_MIN: f64 = 0.1;

/// Relative standard deviation above which a per-state rate counts as undetermined.
const PER_STATE_MAX_REL_SIGMA: f64 = 0.5;

/// One measurement: band j (0-based index into the material's bands) charged for `charge_s`.
#[derive(Debug, Clone, PartialEq)]
pub struct ChargingSample {
    /// Excitation band, 0-based.
    pub band: usize,
    /// Charging time in s (≥ 0).
    pub charge_s: f64,
    /// Camera RGB after the switch-off delay.
    pub rgb: [f64; 3],
    /// Standard deviation of each channel, if known.
    pub sigma: Option<f64>,
}

/// How k_e is shared between states.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StateSharing {
    /// Per-state only when the data identify it (BIC and per-state precision).
    Auto,
    /// One k_e per band for all states.
    Shared,
    /// One k_e per band and state.
    PerState,
}

/// Options of the excitation fit.
#[derive(Debug, Clone, PartialEq)]
pub struct ExcitationOptions {
    /// Delay between switch-off and measurement in s (the paper: about 0.6 s).
    pub switch_off_delay_s: f64,
    /// Sharing of k_e between states.
    pub sharing: StateSharing,
    /// Maximum LM iterations.
    pub max_iterations: usize,
    /// How the decay sample that gave Λ was charged (saturated: Λ as given).
    pub decay_charging: DecayCharging,
}

impl Default for ExcitationOptions {
    fn default() -> Self {
        ExcitationOptions {
            switch_off_delay_s: 0.6,
            sharing: StateSharing::Auto,
            max_iterations: 200,
            decay_charging: DecayCharging::Saturated,
        }
    }
}

/// The decay measurement's state at switch-off, solved with k_e (a flat decay charge).
#[derive(Debug, Clone, PartialEq)]
pub struct DecayStateFit {
    /// The protocol of the decay measurement.
    pub charging: DecayCharging,
    /// r_i(0) per state implied by the fitted k_e.
    pub r0: Vec<f64>,
    /// Factor applied to each state's Λ (1/r_i(0)).
    pub lambda_factor: Vec<f64>,
    /// Starts of the joint fit: the self-consistent values of r(0) of the scan (the one with
    /// the least χ² is used), or the value closest to consistency when the scan only touches it.
    pub roots: Vec<f64>,
    /// Levenberg–Marquardt iterations of the joint fit.
    pub iterations: usize,
    /// Whether the joint fit converged.
    pub converged: bool,
}

/// The fit of one band.
#[derive(Debug, Clone, PartialEq)]
pub struct BandFit {
    /// Band, 0-based.
    pub band: usize,
    /// k_e per state (equal when shared).
    pub k_e: Vec<f64>,
    /// Standard deviation of each k_e.
    pub k_e_sigma: Vec<f64>,
    /// Whether one k_e is shared by all states.
    pub shared: bool,
    /// Why the sharing was chosen.
    pub sharing_reason: String,
    /// s_j = Σ_b E_j[b] of the unit-length source.
    pub source_sum: f64,
    /// Largest simulated concentration over the samples.
    pub r_max: f64,
    /// Charging never approached saturation: only k_e·Λ is determined.
    pub product_only: bool,
    /// Charging times of the samples (s).
    pub charge_s: Vec<f64>,
    /// Measured RGB.
    pub data: Vec<[f64; 3]>,
    /// Model RGB at the samples.
    pub model: Vec<[f64; 3]>,
    /// Equilibrium RGB (T → ∞).
    pub equilibrium: [f64; 3],
    /// Root-mean-square weighted residual.
    pub rms: f64,
    /// χ² of the weighted residuals.
    pub chi2: f64,
    /// LM iterations.
    pub iterations: usize,
    /// Whether the relative step fell below 1e-10.
    pub converged: bool,
}

/// All bands.
#[derive(Debug, Clone, PartialEq)]
pub struct ExcitationFit {
    /// Fits, by band.
    pub bands: Vec<BandFit>,
    /// Switch-off delay used.
    pub switch_off_delay_s: f64,
    /// With a flat decay charge: r(0) of the decay measurement and the Λ correction.
    pub decay_state: Option<DecayStateFit>,
}

/// Precomputed per-state camera response and decay.
struct Model {
    /// g_i · e^{−k_r δ}: RGB per unit concentration of state i after the delay.
    g: Vec<[f64; 3]>,
    k_r: Vec<f64>,
    s: f64,
}

impl Model {
    fn new(material: &Material, camera: &BandCamera, s: f64, delay_s: f64) -> Self {
        let mut g = Vec::new();
        let mut k_r = Vec::new();
        for st in &material.states {
            let em: Vec<f64> = st.lambda.iter().map(|l| l * st.k_r_per_s).collect();
            let rgb = camera.rgb(&em);
            let d = (-st.k_r_per_s * delay_s).exp();
            g.push(rgb.map(|v| v * d));
            k_r.push(st.k_r_per_s);
        }
        Model { g, k_r, s }
    }

    /// r and ∂r/∂k_e of state i after charging T with rate k.
    fn r_and_deriv(&self, i: usize, k: f64, t: f64) -> (f64, f64) {
        let a = k * self.s;
        let kr = self.k_r[i];
        let lam = a + kr;
        let e = (-lam * t).exp();
        let r = a / lam * (1.0 - e);
        let dr_da = kr * (1.0 - e) / (lam * lam) + a / lam * t * e;
        (r, dr_da * self.s)
    }

    fn rgb(&self, k: &[f64], t: f64) -> [f64; 3] {
        let mut y = [0.0; 3];
        for i in 0..self.g.len() {
            let (r, _) = self.r_and_deriv(i, k[i], t);
            for c in 0..3 {
                y[c] += self.g[i][c] * r;
            }
        }
        y
    }

    fn equilibrium(&self, k: &[f64]) -> [f64; 3] {
        let mut y = [0.0; 3];
        for i in 0..self.g.len() {
            let a = k[i] * self.s;
            let req = a / (a + self.k_r[i]);
            for c in 0..3 {
                y[c] += self.g[i][c] * req;
            }
        }
        y
    }
}

/// Parameter vector (p entries) to per-state rates.
fn expand(p: &[f64], n_states: usize) -> Vec<f64> {
    if p.len() == 1 {
        vec![p[0]; n_states]
    } else {
        p.to_vec()
    }
}

struct Problem<'a> {
    model: &'a Model,
    t: Vec<f64>,
    y: Vec<[f64; 3]>,
    w: Vec<f64>,
}

impl Problem<'_> {
    /// Weighted residuals (3 per sample) and Jacobian rows.
    fn eval(&self, p: &[f64]) -> (Vec<f64>, Vec<Vec<f64>>) {
        let ns = self.model.g.len();
        let k = expand(p, ns);
        let mut res = Vec::with_capacity(self.t.len() * 3);
        let mut jac = Vec::with_capacity(self.t.len() * 3);
        for (s, &t) in self.t.iter().enumerate() {
            let mut y = [0.0; 3];
            let mut d = vec![[0.0; 3]; ns];
            for i in 0..ns {
                let (r, dr) = self.model.r_and_deriv(i, k[i], t);
                for c in 0..3 {
                    y[c] += self.model.g[i][c] * r;
                    d[i][c] = self.model.g[i][c] * dr;
                }
            }
            for c in 0..3 {
                res.push((y[c] - self.y[s][c]) * self.w[s]);
                let row: Vec<f64> = if p.len() == 1 {
                    vec![(0..ns).map(|i| d[i][c]).sum::<f64>() * self.w[s]]
                } else {
                    (0..ns).map(|i| d[i][c] * self.w[s]).collect()
                };
                jac.push(row);
            }
        }
        (res, jac)
    }

    fn chi2(&self, p: &[f64]) -> f64 {
        self.eval(p).0.iter().map(|r| r * r).sum()
    }
}

/// The fit of `n_params` rates (1 shared, or one per state) as a least-squares problem for
/// [`fit::lm`](crate::fit::lm), with the analytic Jacobian of [`Problem::eval`].
struct Rates<'a, 'm> {
    prob: &'a Problem<'m>,
    n_params: usize,
}

impl Residuals for Rates<'_, '_> {
    fn n_residuals(&self) -> usize {
        self.prob.t.len() * 3
    }
    fn n_params(&self) -> usize {
        self.n_params
    }
    fn residuals(&self, theta: &[f64], out: &mut [f64]) -> bool {
        out.copy_from_slice(&self.prob.eval(theta).0);
        true
    }
    fn jacobian(&self, theta: &[f64], jac: &mut [f64]) -> bool {
        let (res, rows) = self.prob.eval(theta);
        let m = res.len();
        for (i, row) in rows.iter().enumerate() {
            for (q, v) in row.iter().enumerate() {
                jac[q * m + i] = *v;
            }
        }
        true
    }
}

/// LM on k_e ≥ 0 from `p0`; returns (p, iterations, converged).
fn fit_rates(prob: &Problem, p0: Vec<f64>, max_iter: usize) -> (Vec<f64>, usize, bool) {
    let np = p0.len();
    let opts = LmOptions {
        max_iter,
        lower: Some(vec![0.0; np]),
        ..LmOptions::default()
    };
    let rep = levenberg_marquardt(&Rates { prob, n_params: np }, &p0, &opts);
    (rep.theta, rep.iterations, rep.termination.converged())
}

/// Standard deviations from (JᵀJ)⁻¹ scaled by the reduced χ² when `scale` (σ unknown), else
/// unscaled (residuals already divided by known σ); infinite when J is rank deficient.
fn sigmas(prob: &Problem, p: &[f64], scale: bool) -> Vec<f64> {
    let np = p.len();
    let r = Rates { prob, n_params: np };
    let n = r.n_residuals();
    let mut jac = vec![0.0; n * np];
    r.jacobian(p, &mut jac);
    let chi2 = prob.chi2(p);
    let s2 = if scale && n > np {
        chi2 / (n - np) as f64
    } else {
        1.0
    };
    match stats::covariance_scaled(&jac, n, np, s2) {
        Some(c) => (0..np).map(|i| c[i * np + i].max(0.0).sqrt()).collect(),
        None => vec![f64::INFINITY; np],
    }
}

/// The RGB the camera reads after charging a dark sample for `charge_s` with irradiance
/// `source` (per band of the material) and waiting `delay_s` in darkness (exact simulation).
pub fn charging_rgb(
    material: &Material,
    camera: &BandCamera,
    source: &[f64],
    charge_s: f64,
    delay_s: f64,
) -> Result<[f64; 3]> {
    let ns = material.states.len();
    let nb = material.bands.len();
    let mut hist = Vec::new();
    if charge_s > 0.0 {
        hist.push(Segment {
            duration_s: charge_s,
            irradiance: source.to_vec(),
        });
    }
    if delay_s > 0.0 {
        hist.push(Segment {
            duration_s: delay_s,
            irradiance: vec![0.0; nb],
        });
    }
    let r = if hist.is_empty() {
        vec![0.0; ns]
    } else {
        final_state(material, &hist, &vec![0.0; ns])?
    };
    Ok(camera.rgb(&super::simulate::emission(material, &r)))
}

/// Unit-length irradiance of a source in band `band` only (an ideal narrow-band source).
pub fn box_source(n_bands: usize, band: usize) -> Vec<f64> {
    (0..n_bands)
        .map(|b| f64::from(u8::from(b == band)))
        .collect()
}

/// Normalises a per-band source to unit Euclidean length.
pub fn unit_length(source: &[f64]) -> Result<Vec<f64>> {
    let n = source.iter().map(|v| v * v).sum::<f64>().sqrt();
    if !(n > 0.0 && n.is_finite()) || source.iter().any(|v| *v < 0.0) {
        return Err(Error::invalid(
            "source",
            "the source spectrum is zero (or negative) over the material's bands; expected a \
             non-negative spectrum with light in the bands",
        ));
    }
    Ok(source.iter().map(|v| v / n).collect())
}

/// Synthetic charging data: for each band (with its unit-length source) and charge time, the
/// exact camera RGB after the delay plus Gaussian noise σ = √((ν·max_c y)² + (10⁻³ν·peak)²)
/// (the noise model of [`super::synth`]). Returns the samples with σ filled in.
pub fn synth_charging(
    material: &Material,
    camera: &BandCamera,
    sources: &[(usize, Vec<f64>)],
    charge_s: &[f64],
    delay_s: f64,
    noise: f64,
    seed: u64,
) -> Result<Vec<ChargingSample>> {
    material.validate()?;
    if !material.has_excitation() {
        return Err(Error::invalid(
            "material",
            format!(
                "'{}' has no excitation rates k_e (decay only); charging data need k_e",
                material.name
            ),
        ));
    }
    if !(noise.is_finite() && noise >= 0.0) {
        return Err(Error::invalid("noise", format!("{noise}; expected ≥ 0")));
    }
    check_delay(delay_s)?;
    if let Some(t) = charge_s.iter().find(|t| !(t.is_finite() && **t >= 0.0)) {
        return Err(Error::invalid(
            "charge times",
            format!("{t} s; expected finite times ≥ 0"),
        ));
    }
    let mut clean = Vec::new();
    for (band, src) in sources {
        for &t in charge_s {
            clean.push((*band, t, charging_rgb(material, camera, src, t, delay_s)?));
        }
    }
    let peak = clean
        .iter()
        .flat_map(|(_, _, y)| y.iter())
        .fold(0.0_f64, |m, v| m.max(*v));
    let mut g = Gaussian::new(seed);
    Ok(clean
        .into_iter()
        .map(|(band, t, y)| {
            let mx = y.iter().fold(0.0_f64, |m, v| m.max(*v));
            let s = ((noise * mx).powi(2) + (1e-3 * noise * peak).powi(2)).sqrt();
            let rgb = if noise > 0.0 {
                y.map(|v| v + s * g.normal())
            } else {
                y
            };
            ChargingSample {
                band,
                charge_s: t,
                rgb,
                sigma: (s > 0.0).then_some(s),
            }
        })
        .collect())
}

fn check_delay(delay_s: f64) -> Result<()> {
    if !(delay_s.is_finite() && delay_s >= 0.0) {
        return Err(Error::invalid(
            "switch-off delay",
            format!("{delay_s} s; expected a finite delay ≥ 0"),
        ));
    }
    Ok(())
}

/// Fits k_e per band. `sources` gives, per measured band, the unit-length source irradiance
/// over the material's bands. Every band present in `data` needs a source. With a flat
/// [`ExcitationOptions::decay_charging`], Λ of `material` is read as the apparent Λ·r(0) of that
/// decay measurement and solved together with k_e (module docs); [`apply_excitation`] and
/// [`corrected_material`] then carry the corrected Λ.
pub fn fit_excitation(
    material: &Material,
    camera: &BandCamera,
    sources: &[(usize, Vec<f64>)],
    data: &[ChargingSample],
    opts: &ExcitationOptions,
) -> Result<ExcitationFit> {
    material.validate()?;
    check_delay(opts.switch_off_delay_s)?;
    opts.decay_charging.validate()?;
    let inputs = band_inputs(material, sources, data)?;
    if opts.decay_charging.assumes_saturation() {
        return Ok(ExcitationFit {
            bands: fit_bands(material, camera, &inputs, opts)?,
            switch_off_delay_s: opts.switch_off_delay_s,
            decay_state: None,
        });
    }
    fit_with_decay_charging(material, camera, &inputs, opts)
}

/// The samples of one measured band.
struct BandInput<'a> {
    band: usize,
    s_j: f64,
    samples: Vec<&'a ChargingSample>,
}

fn band_inputs<'a>(
    material: &Material,
    sources: &[(usize, Vec<f64>)],
    data: &'a [ChargingSample],
) -> Result<Vec<BandInput<'a>>> {
    let nb = material.bands.len();
    let mut bands: Vec<usize> = data.iter().map(|s| s.band).collect();
    bands.sort_unstable();
    bands.dedup();
    if bands.is_empty() {
        return Err(Error::invalid(
            "data",
            "no charging samples; expected rows band,charge_s,r,g,b",
        ));
    }
    let mut out = Vec::new();
    for &j in &bands {
        if j >= nb {
            return Err(Error::invalid(
                "data",
                format!(
                    "band {} but the material has {nb} bands; expected 1 to {nb}",
                    j + 1
                ),
            ));
        }
        let src = sources.iter().find(|(b, _)| *b == j).ok_or_else(|| {
            Error::invalid(
                "source",
                format!(
                    "no source spectrum for band {}; expected one per band in the data",
                    j + 1
                ),
            )
        })?;
        let samples: Vec<&ChargingSample> = data.iter().filter(|s| s.band == j).collect();
        for s in &samples {
            if !(s.charge_s.is_finite() && s.charge_s >= 0.0) {
                return Err(Error::invalid(
                    "charge_s",
                    format!("{} s in band {}; expected times ≥ 0", s.charge_s, j + 1),
                ));
            }
        }
        if samples.len() < 2 {
            return Err(Error::invalid(
                "data",
                format!(
                    "band {} has {} sample(s); expected at least 2",
                    j + 1,
                    samples.len()
                ),
            ));
        }
        let s_j: f64 = src.1.iter().sum();
        if !(s_j > 0.0) {
            return Err(Error::invalid(
                "source",
                format!(
                    "the source of band {} has no light in the material's bands",
                    j + 1
                ),
            ));
        }
        out.push(BandInput {
            band: j,
            s_j,
            samples,
        });
    }
    Ok(out)
}

fn fit_bands(
    material: &Material,
    camera: &BandCamera,
    inputs: &[BandInput],
    opts: &ExcitationOptions,
) -> Result<Vec<BandFit>> {
    let ns = material.states.len();
    inputs
        .iter()
        .map(|b| fit_band(material, camera, b.band, b.s_j, &b.samples, opts, ns))
        .collect()
}

/// `material` with each state's Λ multiplied by `factor[i]`.
fn scale_lambda(material: &Material, factor: &[f64]) -> Material {
    let mut m = material.clone();
    for (st, f) in m.states.iter_mut().zip(factor) {
        for l in &mut st.lambda {
            *l *= f;
        }
    }
    m
}

/// Per-band rates of `fits` written into `material` (as [`apply_excitation`], without the Λ
/// correction).
fn with_rates(material: &Material, bands: &[(usize, Vec<f64>)]) -> Material {
    let nb = material.bands.len();
    let mut m = material.clone();
    for (i, st) in m.states.iter_mut().enumerate() {
        let mut k = st.k_e.clone().unwrap_or_else(|| vec![0.0; nb]);
        for (b, ke) in bands {
            if *b < nb {
                k[*b] = ke[i];
            }
        }
        st.k_e = Some(k);
    }
    m
}

/// Number of points of the r(0) scan over [`R0_SCAN_MIN`, 1] (log-spaced).
const R0_SCAN_POINTS: usize = 41;
/// Smallest r(0) of the scan.
const R0_SCAN_MIN: f64 = 1e-4;
/// Largest |ln r(0)_implied − ln r(0)| accepted at the start of the joint fit (10 %): beyond it
/// the decay's Λ and the charging curves are not of one material in one camera's units.
const MAX_START_MISMATCH: f64 = 0.0953;

/// Per-band fits with Λ/c, the r(0) those rates imply, and the total χ².
fn scan_point(
    material: &Material,
    camera: &BandCamera,
    inputs: &[BandInput],
    opts: &ExcitationOptions,
    c: f64,
) -> Result<(Vec<BandFit>, Vec<f64>, f64)> {
    let ns = material.states.len();
    let m = scale_lambda(material, &vec![1.0 / c; ns]);
    let fits = fit_bands(&m, camera, inputs, opts)?;
    let rates: Vec<(usize, Vec<f64>)> = fits.iter().map(|f| (f.band, f.k_e.clone())).collect();
    let r0 = opts
        .decay_charging
        .state_at_switch_off(&with_rates(material, &rates))?;
    let chi2 = fits.iter().map(|f| f.chi2).sum();
    Ok((fits, r0, chi2))
}

/// ln r_0(0; k_e(c)) − ln c: zero where the rates fitted with Λ/c give back r(0) = c.
fn mismatch(r0: &[f64], c: f64) -> f64 {
    r0[0].max(1e-300).ln() - c.ln()
}

/// All bands' rates at once with Λ_i / r_i(0; k_e) (finite-difference Jacobian).
struct Joint<'a> {
    material: &'a Material,
    camera: &'a BandCamera,
    inputs: &'a [BandInput<'a>],
    /// Parameters per band (1 shared, or one per state).
    n_per_band: Vec<usize>,
    weights: Vec<Vec<f64>>,
    charging: &'a DecayCharging,
    delay_s: f64,
}

impl Joint<'_> {
    fn rates(&self, p: &[f64]) -> Vec<(usize, Vec<f64>)> {
        let ns = self.material.states.len();
        let mut at = 0;
        self.inputs
            .iter()
            .zip(&self.n_per_band)
            .map(|(b, &n)| {
                let k = expand(&p[at..at + n], ns);
                at += n;
                (b.band, k)
            })
            .collect()
    }

    /// r(0) and the material with Λ corrected, for parameters `p`.
    fn corrected(&self, p: &[f64]) -> Option<(Vec<f64>, Material)> {
        let rates = self.rates(p);
        let r0 = self
            .charging
            .state_at_switch_off(&with_rates(self.material, &rates))
            .ok()?;
        if r0.iter().any(|r| !(*r > 0.0 && r.is_finite())) {
            return None;
        }
        let f: Vec<f64> = r0.iter().map(|r| 1.0 / r).collect();
        Some((r0, scale_lambda(self.material, &f)))
    }
}

impl Residuals for Joint<'_> {
    fn n_residuals(&self) -> usize {
        self.inputs.iter().map(|b| 3 * b.samples.len()).sum()
    }
    fn n_params(&self) -> usize {
        self.n_per_band.iter().sum()
    }
    fn residuals(&self, theta: &[f64], out: &mut [f64]) -> bool {
        let Some((_, m)) = self.corrected(theta) else {
            return false;
        };
        let rates = self.rates(theta);
        let mut at = 0;
        for ((b, w), (_, k)) in self.inputs.iter().zip(&self.weights).zip(&rates) {
            let model = Model::new(&m, self.camera, b.s_j, self.delay_s);
            for (s, wt) in b.samples.iter().zip(w) {
                let y = model.rgb(k, s.charge_s);
                for c in 0..3 {
                    out[at] = (y[c] - s.rgb[c]) * wt;
                    at += 1;
                }
            }
        }
        true
    }
}

fn fit_with_decay_charging(
    material: &Material,
    camera: &BandCamera,
    inputs: &[BandInput],
    opts: &ExcitationOptions,
) -> Result<ExcitationFit> {
    let ns = material.states.len();
    // 1. Scan a common r(0) = c and bracket the self-consistent values.
    let grid: Vec<f64> = (0..R0_SCAN_POINTS)
        .map(|q| {
            let u = q as f64 / (R0_SCAN_POINTS - 1) as f64;
            (R0_SCAN_MIN.ln() * (1.0 - u)).exp()
        })
        .collect();
    let mut g = Vec::with_capacity(grid.len());
    for &c in &grid {
        let (_, r0, _) = scan_point(material, camera, inputs, opts, c)?;
        g.push(mismatch(&r0, c));
    }
    let mut roots = Vec::new();
    for q in 0..grid.len() - 1 {
        let (mut lo, mut hi) = (grid[q].ln(), grid[q + 1].ln());
        let (mut glo, ghi) = (g[q], g[q + 1]);
        if glo == 0.0 {
            roots.push(grid[q]);
            continue;
        }
        if !(glo.is_finite() && ghi.is_finite()) || glo.signum() == ghi.signum() {
            continue;
        }
        for _ in 0..40 {
            let mid = 0.5 * (lo + hi);
            let (_, r0, _) = scan_point(material, camera, inputs, opts, mid.exp())?;
            let gm = mismatch(&r0, mid.exp());
            if gm.signum() == glo.signum() {
                lo = mid;
                glo = gm;
            } else {
                hi = mid;
            }
        }
        roots.push((0.5 * (lo + hi)).exp());
    }
    if g.last().is_some_and(|v| *v == 0.0) {
        roots.push(1.0);
    }
    if roots.is_empty() {
        // The consistency can be a tangency (a decay charge that reaches equilibrium gives an r(0)
        // of the same rates): start from the c closest to consistency, refined by golden section
        // on |mismatch| around the best grid point; the joint fit below enforces it exactly.
        let q = (0..g.len())
            .filter(|&q| g[q].is_finite())
            .min_by(|&a, &b| g[a].abs().total_cmp(&g[b].abs()))
            .ok_or_else(|| {
                Error::invalid(
                    "charging data",
                    format!(
                        "no excitation rates are consistent with the decay measurement ({})",
                        opts.decay_charging.describe()
                    ),
                )
            })?;
        let (mut lo, mut hi) = (
            grid[q.saturating_sub(1)].ln(),
            grid[(q + 1).min(grid.len() - 1)].ln(),
        );
        let phi = 0.5 * (5f64.sqrt() - 1.0);
        let at = |x: f64| -> Result<f64> {
            let (_, r0, _) = scan_point(material, camera, inputs, opts, x.exp())?;
            Ok(mismatch(&r0, x.exp()).abs())
        };
        let (mut x1, mut x2) = (hi - phi * (hi - lo), lo + phi * (hi - lo));
        let (mut f1, mut f2) = (at(x1)?, at(x2)?);
        for _ in 0..30 {
            if f1 < f2 {
                hi = x2;
                x2 = x1;
                f2 = f1;
                x1 = hi - phi * (hi - lo);
                f1 = at(x1)?;
            } else {
                lo = x1;
                x1 = x2;
                f1 = f2;
                x2 = lo + phi * (hi - lo);
                f2 = at(x2)?;
            }
        }
        roots.push((0.5 * (lo + hi)).exp());
    }
    let mut best: Option<(f64, Vec<BandFit>, f64)> = None;
    for &c in &roots {
        let (fits, _, chi2) = scan_point(material, camera, inputs, opts, c)?;
        if best.as_ref().is_none_or(|b| chi2 < b.2) {
            best = Some((c, fits, chi2));
        }
    }
    let Some((c_best, start, _)) = best else {
        return Err(Error::invalid(
            "charging data",
            "no start for the joint fit of k_e and r(0)",
        ));
    };
    let (_, r0_best, _) = scan_point(material, camera, inputs, opts, c_best)?;
    let miss = mismatch(&r0_best, c_best);
    if !(miss.abs() <= MAX_START_MISMATCH) {
        return Err(Error::invalid(
            "charging data",
            format!(
                "the charging curves and the decay preset's Λ disagree in scale: with the decay \
                 measurement {}, the best r(0) = {c_best:.4} gives rates that imply r(0) = {:.4} \
                 (no r(0) in [{R0_SCAN_MIN}, 1] agrees to {:.0} %); both measurements must be in \
                 the same camera units (relative radiance of one camera), and the protocol must be \
                 the one used",
                opts.decay_charging.describe(),
                r0_best[0],
                (MAX_START_MISMATCH.exp() - 1.0) * 100.0
            ),
        ));
    }
    // 2. All bands at once with the exact coupling through r(0).
    let n_per_band: Vec<usize> = start
        .iter()
        .map(|f| if f.shared { 1 } else { ns })
        .collect();
    let mut p0 = Vec::new();
    for (f, &n) in start.iter().zip(&n_per_band) {
        p0.extend(f.k_e.iter().take(n).copied());
    }
    let weights: Vec<Vec<f64>> = inputs
        .iter()
        .map(|b| sample_weights(&b.samples).0)
        .collect();
    let known_sigma = inputs.iter().all(|b| sample_weights(&b.samples).1);
    let joint = Joint {
        material,
        camera,
        inputs,
        n_per_band: n_per_band.clone(),
        weights,
        charging: &opts.decay_charging,
        delay_s: opts.switch_off_delay_s,
    };
    let lm = LmOptions {
        max_iter: opts.max_iterations,
        lower: Some(vec![0.0; p0.len()]),
        ..LmOptions::default()
    };
    let rep = levenberg_marquardt(&joint, &p0, &lm);
    let p = rep.theta.clone();
    let Some((r0, corrected)) = joint.corrected(&p) else {
        return Err(Error::invalid(
            "charging data",
            "the joint fit of k_e and the decay measurement's r(0) left r(0) = 0",
        ));
    };
    // Covariance of the joint fit (finite-difference Jacobian at the optimum).
    let m = joint.n_residuals();
    let np = p.len();
    let mut r_plus = vec![0.0; m];
    let mut r_minus = vec![0.0; m];
    let mut jac = vec![0.0; m * np];
    let mut jac_ok = true;
    for q in 0..np {
        let h = 1e-6 * p[q].abs().max(1e-6);
        let mut pp = p.clone();
        pp[q] += h;
        let mut pm = p.clone();
        pm[q] = (pm[q] - h).max(0.0);
        let dh = pp[q] - pm[q];
        jac_ok &= joint.residuals(&pp, &mut r_plus) && joint.residuals(&pm, &mut r_minus);
        for i in 0..m {
            jac[q * m + i] = (r_plus[i] - r_minus[i]) / dh;
        }
    }
    let mut res = vec![0.0; m];
    joint.residuals(&p, &mut res);
    let chi2_total: f64 = res.iter().map(|r| r * r).sum();
    let s2 = if !known_sigma && m > np {
        chi2_total / (m - np) as f64
    } else {
        1.0
    };
    let sig: Vec<f64> = match stats::covariance_scaled(&jac, m, np, s2).filter(|_| jac_ok) {
        Some(c) => (0..np).map(|i| c[i * np + i].max(0.0).sqrt()).collect(),
        None => vec![f64::INFINITY; np],
    };
    // 3. The band records at the joint optimum, with Λ corrected.
    let rates = joint.rates(&p);
    let sig_rates = joint.rates(&sig);
    let mut bands = Vec::with_capacity(inputs.len());
    for ((((b, f), (_, k)), (_, ks)), w) in inputs
        .iter()
        .zip(&start)
        .zip(&rates)
        .zip(&sig_rates)
        .zip(&joint.weights)
    {
        let model = Model::new(&corrected, camera, b.s_j, opts.switch_off_delay_s);
        let prob = Problem {
            model: &model,
            t: b.samples.iter().map(|s| s.charge_s).collect(),
            y: b.samples.iter().map(|s| s.rgb).collect(),
            w: w.clone(),
        };
        let chi2 = prob.chi2(&k[..]);
        let r_max = prob
            .t
            .iter()
            .flat_map(|t| {
                (0..ns)
                    .map(|i| model.r_and_deriv(i, k[i], *t).0)
                    .collect::<Vec<_>>()
            })
            .fold(0.0_f64, f64::max);
        bands.push(BandFit {
            band: b.band,
            k_e: k.clone(),
            k_e_sigma: ks.clone(),
            shared: f.shared,
            sharing_reason: f.sharing_reason.clone(),
            source_sum: b.s_j,
            r_max,
            product_only: r_max < SATURATION_MIN,
            charge_s: prob.t.clone(),
            data: prob.y.clone(),
            model: prob.t.iter().map(|t| model.rgb(k, *t)).collect(),
            equilibrium: model.equilibrium(k),
            rms: (chi2 / (3 * b.samples.len()) as f64).sqrt(),
            chi2,
            iterations: rep.iterations,
            converged: rep.termination.converged(),
        });
    }
    Ok(ExcitationFit {
        bands,
        switch_off_delay_s: opts.switch_off_delay_s,
        decay_state: Some(DecayStateFit {
            charging: opts.decay_charging.clone(),
            lambda_factor: r0.iter().map(|r| 1.0 / r).collect(),
            r0,
            roots,
            iterations: rep.iterations,
            converged: rep.termination.converged(),
        }),
    })
}

/// Weights 1/σ of `samples` (σ as given when every sample has one, else relative with a floor
/// of 10⁻³ of the peak) and whether σ was known.
fn sample_weights(samples: &[&ChargingSample]) -> (Vec<f64>, bool) {
    let peak = samples
        .iter()
        .flat_map(|s| s.rgb.iter())
        .fold(0.0_f64, |m, v| m.max(v.abs()));
    let known_sigma = samples.iter().all(|s| s.sigma.is_some_and(|v| v > 0.0));
    let w = samples
        .iter()
        .map(|s| {
            let sd = match s.sigma {
                Some(v) if known_sigma => v,
                _ => {
                    let mx = s.rgb.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
                    (mx * mx + (1e-3 * peak).powi(2)).sqrt()
                }
            };
            if sd > 0.0 {
                1.0 / sd
            } else {
                1.0
            }
        })
        .collect();
    (w, known_sigma)
}

fn fit_band(
    material: &Material,
    camera: &BandCamera,
    j: usize,
    s_j: f64,
    samples: &[&ChargingSample],
    opts: &ExcitationOptions,
    ns: usize,
) -> Result<BandFit> {
    let model = Model::new(material, camera, s_j, opts.switch_off_delay_s);
    let (w, known_sigma) = sample_weights(samples);
    let prob = Problem {
        model: &model,
        t: samples.iter().map(|s| s.charge_s).collect(),
        y: samples.iter().map(|s| s.rgb).collect(),
        w,
    };
    // Log-grid start for the shared rate: a = k s from 1e-6 to 1e3 s⁻¹.
    let grid = log_grid_min(1e-6, 1e3, 91, |a| prob.chi2(&[a / s_j]));
    let mut best = (grid.value(), grid.x() / s_j);
    if prob.chi2(&[0.0]) <= best.0 {
        best = (prob.chi2(&[0.0]), 0.0);
    }
    let (p1, it1, conv1) = fit_rates(&prob, vec![best.1], opts.max_iterations);
    let chi1 = prob.chi2(&p1);
    let sig1 = sigmas(&prob, &p1, !known_sigma);
    let n = (samples.len() * 3) as f64;
    let mut choice = (p1.clone(), sig1.clone(), it1, conv1, true);
    let reason;
    if ns == 1 {
        reason = "one state: k_e is the state's".to_string();
    } else if opts.sharing == StateSharing::Shared {
        reason = "shared by request".to_string();
    } else {
        let (pn, itn, convn) = fit_rates(&prob, vec![p1[0]; ns], opts.max_iterations);
        let chin = prob.chi2(&pn);
        let sign = sigmas(&prob, &pn, !known_sigma);
        let n_obs = samples.len() * 3;
        let (b1, bn) = (bic(chi1, n_obs, 1), bic(chin, n_obs, ns));
        let precise = pn
            .iter()
            .zip(&sign)
            .all(|(k, s)| *k > 0.0 && s / k < PER_STATE_MAX_REL_SIGMA);
        if opts.sharing == StateSharing::PerState {
            reason = "per state by request".to_string();
            choice = (pn, sign, itn, convn, false);
        } else if bn < b1 && precise {
            reason = format!(
                "per state: BIC {bn:.1} < {b1:.1} (shared) and every per-state rate determined \
                 to better than {:.0} %",
                PER_STATE_MAX_REL_SIGMA * 100.0
            );
            choice = (pn, sign, itn, convn, false);
        } else if bn < b1 {
            reason = format!(
                "shared: per-state BIC {bn:.1} < {b1:.1} but some per-state rate is undetermined \
                 (relative σ ≥ {:.0} %)",
                PER_STATE_MAX_REL_SIGMA * 100.0
            );
        } else {
            reason = format!(
                "shared: the charging curve does not show state-specific excitation (BIC \
                 {b1:.1} shared ≤ {bn:.1} per state)"
            );
        }
    }
    let (p, sig, iterations, converged, shared) = choice;
    let k = expand(&p, ns);
    let k_sigma = expand(&sig, ns);
    let chi2 = prob.chi2(&p);
    let mut r_max = 0.0_f64;
    for s in samples {
        for i in 0..ns {
            r_max = r_max.max(model.r_and_deriv(i, k[i], s.charge_s).0);
        }
    }
    Ok(BandFit {
        band: j,
        k_e_sigma: k_sigma,
        shared,
        sharing_reason: reason,
        source_sum: s_j,
        r_max,
        product_only: r_max < SATURATION_MIN,
        charge_s: prob.t.clone(),
        data: prob.y.clone(),
        model: prob.t.iter().map(|t| model.rgb(&k, *t)).collect(),
        equilibrium: model.equilibrium(&k),
        rms: (chi2 / n).sqrt(),
        chi2,
        iterations,
        converged,
        k_e: k,
    })
}

/// Simulated charging curve of a fitted band at `charge_s` (for plots).
pub fn band_curve(
    material: &Material,
    camera: &BandCamera,
    fit: &BandFit,
    switch_off_delay_s: f64,
    charge_s: &[f64],
) -> Vec<[f64; 3]> {
    let model = Model::new(material, camera, fit.source_sum, switch_off_delay_s);
    charge_s.iter().map(|t| model.rgb(&fit.k_e, *t)).collect()
}

/// `material` with Λ corrected for the decay measurement's r(0) (unchanged when the fit had no
/// flat decay charge): the material the charging curves of `fit` were computed with.
pub fn corrected_material(material: &Material, fit: &ExcitationFit) -> Material {
    match &fit.decay_state {
        Some(d) => scale_lambda(material, &d.lambda_factor),
        None => material.clone(),
    }
}

/// The material with the fitted k_e written in: measured bands get the fit, unmeasured bands
/// keep an existing value or 0; Λ corrected as [`corrected_material`].
pub fn apply_excitation(material: &Material, fit: &ExcitationFit) -> Material {
    let nb = material.bands.len();
    let mut m = corrected_material(material, fit);
    for (i, st) in m.states.iter_mut().enumerate() {
        let mut k = st.k_e.clone().unwrap_or_else(|| vec![0.0; nb]);
        for b in &fit.bands {
            if b.band < nb {
                k[b.band] = b.k_e[i];
            }
        }
        st.k_e = Some(k);
    }
    m
}

/// Mean of a piecewise-linear sampled function over each `[lo, hi]` band, integrated exactly
/// (zero outside the samples). Used to turn source spectra into per-band irradiance without
/// leaking a sharp band edge into the neighbouring band.
pub fn band_means_exact(
    wavelengths_nm: &[f64],
    values: &[f64],
    bands_nm: &[[f64; 2]],
) -> Result<Vec<f64>> {
    if wavelengths_nm.len() < 2
        || wavelengths_nm.len() != values.len()
        || wavelengths_nm.windows(2).any(|w| !(w[1] > w[0]))
    {
        return Err(Error::invalid(
            "spectrum",
            "expected at least two samples at strictly increasing wavelengths, one value each",
        ));
    }
    let mut out = Vec::with_capacity(bands_nm.len());
    for &[lo, hi] in bands_nm {
        let mut s = 0.0;
        for k in 0..wavelengths_nm.len() - 1 {
            let (x0, x1) = (wavelengths_nm[k], wavelengths_nm[k + 1]);
            let (a, b) = (lo.max(x0), hi.min(x1));
            if b <= a {
                continue;
            }
            let f = |x: f64| values[k] + (values[k + 1] - values[k]) * (x - x0) / (x1 - x0);
            s += 0.5 * (f(a) + f(b)) * (b - a);
        }
        out.push(s / (hi - lo));
    }
    Ok(out)
}
