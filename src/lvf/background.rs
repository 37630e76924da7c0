//! What lies under and over the lamp lines of an LVF profile: a smooth continuum and a
//! multiplicative fall-off along the axis.
//!
//! The full profile model of channel c at normalised position u ∈ [−1, 1] is
//!
//! ```text
//! y_c(u) = b_c + s_c·u + V(u)·[ Σ_l A_{l,c}·g(λ_l − λ(u)) + Σ_k β_{k,c}·B_k(u) ],
//! V(u)   = 1 + Σ_{j=1..J} v_j·u^j                                (value 1 at the centre)
//! ```
//!
//! - `b + s·u` is the additive offset (black-level residue, stray light that does not pass the
//!   filter), free in sign;
//! - the continuum Σ β_k B_k(u) is a uniform cubic B-spline in u with β ≥ 0, so it is
//!   non-negative everywhere (a B-spline with non-negative coefficients is). A broadband
//!   spectrum S seen through the passband and camera is C_c(u) = ∫ S(λ)·Q_c(λ)·g(λ − λ(u)) dλ,
//!   a bump per channel that follows the camera's sensitivity; the knot spacing is tied to
//!   the passband (at least 1.0 × FWHM in wavelength, [`CONTINUUM_KNOT_FWHM`]) so the continuum
//!   cannot form a blob as narrow as a lamp line; a line missing from the lamp list is searched
//!   for in the residual of the coarsest continuum (2.5 × FWHM), where it stays;
//! - V(u) is lens fall-off / vignetting along the axis (quadratic, cos⁴, tilted or off-centre
//!   fall-off averaged across the ROI are all smooth in u); it multiplies light that passed
//!   the filter (lines and continuum), not the additive offset.
//!
//! Which terms are used is chosen per image by the Bayesian information criterion
//! BIC = N·ln(SSE/N) + k·ln N (k = nonlinear plus active linear parameters), so a clean lamp
//! does not pay for a continuum it does not have.

use nalgebra::{DMatrix, DVector};

/// Knot spacings of the continuum spline tried, in units of the passband FWHM (wavelength).
/// A cubic B-spline element with knot spacing h has a FWHM of about 1.36·h, so at 1.5 × FWHM
/// the narrowest continuum feature is still twice as wide as a line blob; at 2.5 × FWHM 3.4
/// times; at 1.0 × FWHM 1.36 times (and the intervals are capped at
/// [`CONTINUUM_INTERVALS`]`.1`, 31 nm on issue 12's 374 nm profile).
///
/// The 1.0 × FWHM spacing is there for cameras whose sensitivity rises steeply: the Nikon D700's
/// red channel grows fivefold from 570 to 580 nm (the SONY NEX-5N's fourfold), under the
/// 577/579 nm doublet, and its blue 27-fold from 410 to 420 nm. A broadband continuum seen
/// through such a channel and the passband has an edge of width ≈ σ_g (10.6 nm for FWHM 25 nm),
/// which a spline with knots 1.5 FWHM apart cannot follow; the misfit trades with the doublet
/// and biased the map by 0.2–0.4 nm (10 % blackbody 2700 K continuum, 1 % noise). BIC picks the
/// finer spline only when the profile asks for it (a clean lamp keeps the offset alone).
pub const CONTINUUM_KNOT_FWHM: [f64; 3] = [2.5, 1.5, 1.0];

/// Fewest and most intervals of the continuum spline.
pub const CONTINUUM_INTERVALS: (usize, usize) = (3, 12);

/// The terms of the profile model besides the lines and the linear offset.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub struct BackgroundTerms {
    /// Intervals of the cubic B-spline continuum on u ∈ [−1, 1] (0: no continuum).
    pub continuum_intervals: usize,
    /// Degree J of the fall-off polynomial V(u) = 1 + Σ v_j u^j (0: no fall-off).
    pub falloff_degree: usize,
    /// Intervals of the continuum spectrum shared by the three channels through a known camera
    /// (0: none; see [`crate::lvf::shared_continuum`]). Exclusive with `continuum_intervals`.
    pub shared_intervals: usize,
    /// Intervals of a per-channel continuum spectrum (cubic B-spline in wavelength) seen through
    /// the fitted passband (0: none; see [`crate::lvf::passband_continuum`]). Exclusive with
    /// the other continua.
    pub passband_intervals: usize,
    /// Prior roughness of a shared spectrum in thousandths (`SHARED_SMOOTHNESS`: its second
    /// differences ≈ this × its RMS); 0: no roughness penalty.
    pub shared_smoothness_milli: u32,
}

impl BackgroundTerms {
    /// Only the linear offset `b + s·u` (the model before continuum and fall-off existed).
    pub const LINEAR: BackgroundTerms = BackgroundTerms {
        continuum_intervals: 0,
        falloff_degree: 0,
        shared_intervals: 0,
        passband_intervals: 0,
        shared_smoothness_milli: 0,
    };

    /// Number of per-channel continuum basis functions (spline in u or spectrum seen through
    /// the passband).
    pub fn n_continuum(&self) -> usize {
        match (self.continuum_intervals, self.passband_intervals) {
            (0, 0) => 0,
            (0, p) => p + 3,
            (c, _) => c + 3,
        }
    }

    /// Whether a continuum of any kind (per channel or shared) is fitted.
    pub fn has_continuum(&self) -> bool {
        self.continuum_intervals > 0 || self.shared_intervals > 0 || self.passband_intervals > 0
    }

    /// Short name for reports: `linear`, `falloff2`, `continuum6`, `continuum6+falloff2`,
    /// `shared-spectrum12`, `shared-spectrum31-s0.03` (penalised), `passband-continuum36`.
    pub fn name(&self) -> String {
        if self.passband_intervals > 0 {
            return match self.falloff_degree {
                0 => format!("passband-continuum{}", self.passband_intervals),
                f => format!("passband-continuum{}+falloff{f}", self.passband_intervals),
            };
        }
        if self.shared_intervals > 0 {
            let smooth = match self.shared_smoothness_milli {
                0 => String::new(),
                m => format!("-s{}", f64::from(m) / 1000.0),
            };
            return match self.falloff_degree {
                0 => format!("shared-spectrum{}{smooth}", self.shared_intervals),
                f => format!(
                    "shared-spectrum{}{smooth}+falloff{f}",
                    self.shared_intervals
                ),
            };
        }
        match (self.continuum_intervals, self.falloff_degree) {
            (0, 0) => "linear".into(),
            (0, f) => format!("falloff{f}"),
            (c, 0) => format!("continuum{c}"),
            (c, f) => format!("continuum{c}+falloff{f}"),
        }
    }
}

/// How the background terms are chosen.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BackgroundChoice {
    /// Smallest BIC among no continuum and continua of the knot spacings
    /// [`CONTINUUM_KNOT_FWHM`] (no fitted fall-off: see [`estimate_radial_falloff`]).
    Auto,
    /// These terms: a continuum (its knots from the passband, see [`continuum_intervals_for`])
    /// or not, and a fall-off polynomial of this degree (0: none).
    Fixed {
        /// Whether to fit a continuum.
        continuum: bool,
        /// Degree of the fall-off polynomial.
        falloff_degree: usize,
    },
}

/// Uniform cubic B-spline basis on [−1, 1] with `intervals` intervals: `intervals + 3`
/// functions, each ≥ 0, summing to 1 on [−1, 1]. Writes the values at `u` into `out`.
pub fn cubic_bspline_row(u: f64, intervals: usize, out: &mut [f64]) {
    out.iter_mut().for_each(|v| *v = 0.0);
    if intervals == 0 {
        return;
    }
    let h = 2.0 / intervals as f64;
    let t = ((u.clamp(-1.0, 1.0) + 1.0) / h).min(intervals as f64 - 1e-12);
    let i = t.floor() as usize;
    let f = t - i as f64;
    let g = 1.0 - f;
    // the four non-zero cubic B-splines on interval i: indices i … i+3
    let w = [
        g * g * g / 6.0,
        (3.0 * f * f * f - 6.0 * f * f + 4.0) / 6.0,
        (-3.0 * f * f * f + 3.0 * f * f + 3.0 * f + 1.0) / 6.0,
        f * f * f / 6.0,
    ];
    for (k, wk) in w.iter().enumerate() {
        if let Some(o) = out.get_mut(i + k) {
            *o = *wk;
        }
    }
}

/// V(u) = 1 + Σ_j v_j·u^j.
pub fn falloff(v: &[f64], u: f64) -> f64 {
    let mut p = u;
    let mut s = 1.0;
    for vj in v {
        s += vj * p;
        p *= u;
    }
    s
}

/// Number of continuum intervals for a profile spanning `span_nm` with passband `fwhm_nm`:
/// knots at least `knot_fwhm` FWHM apart, within [`CONTINUUM_INTERVALS`].
pub fn continuum_intervals_for(span_nm: f64, fwhm_nm: f64, knot_fwhm: f64) -> usize {
    let n = (span_nm.abs() / (knot_fwhm * fwhm_nm.max(1e-6))).floor();
    (n.max(0.0) as usize).clamp(CONTINUUM_INTERVALS.0, CONTINUUM_INTERVALS.1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cubic_bspline_is_a_non_negative_partition_of_unity() {
        for n in [3, 6, 11] {
            let mut row = vec![0.0; n + 3];
            for i in 0..=200 {
                let u = -1.0 + 2.0 * i as f64 / 200.0;
                cubic_bspline_row(u, n, &mut row);
                assert!(row.iter().all(|v| *v >= 0.0));
                assert!((row.iter().sum::<f64>() - 1.0).abs() < 1e-12, "u {u}");
            }
        }
    }

    #[test]
    fn falloff_is_one_at_the_centre() {
        assert_eq!(falloff(&[0.3, -0.2], 0.0), 1.0);
        assert!((falloff(&[0.0, -0.2], 1.0) - 0.8).abs() < 1e-15);
    }
}

/// Radial fall-off estimated from the image itself: how each strip across the axis differs
/// from the ROI's mean (see [`estimate_radial_falloff`]).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct RadialFalloff {
    /// κ₀, κ₁ in d ln V / d(r²) = κ₀ + κ₁·r² (r = distance from the image centre over the half
    /// diagonal).
    pub kappa: [f64; 2],
    /// Their standard errors (cluster-robust; κ₁'s is 0 when it was left out: under
    /// [`KAPPA1_KEEP_SIGMA`] of its σ, or not determined by the strips).
    pub kappa_sigma: [f64; 2],
    /// κ₀, κ₁ fitted together (equal to `kappa` when κ₁ was kept).
    pub kappa_two_term: [f64; 2],
    /// The covariance (cluster-robust) of `kappa_two_term`: the uncertainty of the fall-off's
    /// shape whether or not κ₁ was used, propagated into the map's statistical σ.
    pub kappa_covariance: [[f64; 2]; 2],
    /// κ₀ and its σ when fitted alone (κ₁ = 0): the sharper test of whether there is a fall-off
    /// at all ([`RadialFalloff::significant`]).
    pub kappa0_alone: [f64; 2],
    /// The centre assumed (source px): the image centre.
    pub centre_px: [f64; 2],
    /// Half diagonal (px).
    pub half_diagonal_px: f64,
    /// V at the first and last profile position over its largest value.
    pub at_ends: [f64; 2],
    /// Strip × position × channel samples used.
    pub samples: usize,
    /// A level per channel (r, g, b) under the fall-off, not subject to it (a black-level
    /// residue, flare or stray light over the sensor), with its σ: y = V·S + p. `None` when
    /// the strips do not show one ([`PEDESTAL_APPLY_CHI2`]); then the fall-off is estimated as
    /// if p = 0.
    pub pedestal: Option<[[f64; 2]; 3]>,
    /// V at each profile position, peak 1.
    #[serde(skip)]
    pub along: Vec<f64>,
    /// r² at each profile position (on the profile's centre line, strips averaged):
    /// ∂ ln V/∂κ = (Q, Q²/2).
    #[serde(skip)]
    pub q_along: Vec<f64>,
}

/// The radial fall-off is divided out only when it differs from none by more than noise: κ₀
/// fitted alone beyond 3 of its (cluster-robust) σ, or κ = (κ₀, κ₁) jointly beyond the χ²₂
/// quantile of the same p = 0.0027 — a spurious fall-off biases the map more than none. Against
/// the formal σ of κ₀ this was 6σ (images without vignetting scattered by up to ~4 formal σ);
/// the robust σ is 3–4× the formal one and follows the scatter of κ₀ over seeds (≈ 0.015 at 1 %
/// noise). With κ₁ free, κ₀ alone can be 0 under a strong fall-off (a 5 % noise image:
/// κ = (+0.01 ± 0.08, −0.67 ± 0.30) for a 1 − 0.3·r² vignetting), hence the one-term test.
pub const RADIAL_APPLY: (f64, f64) = (3.0, 11.83);

impl RadialFalloff {
    /// Whether the fall-off is distinguishable from none ([`RADIAL_APPLY`]).
    pub fn significant(&self) -> bool {
        let [k0, s0] = self.kappa0_alone;
        (s0 > 0.0 && k0.abs() > RADIAL_APPLY.0 * s0) || self.wald_chi2() > RADIAL_APPLY.1
    }

    /// The covariance of κ = (κ₀, κ₁) that stands for the fall-off's uncertainty: the two-term
    /// fit's when the fall-off was divided out (`applied`); when not, κ₀ = 0 ± its σ fitted
    /// alone (the strips only bound it), κ₁ = 0.
    pub fn uncertainty(&self, applied: bool) -> [[f64; 2]; 2] {
        if applied {
            self.kappa_covariance
        } else {
            [[self.kappa0_alone[1].powi(2), 0.0], [0.0, 0.0]]
        }
    }

    /// 1σ of ln V at each profile position from [`RadialFalloff::uncertainty`]
    /// (∂ ln V/∂κ = (Q, Q²/2)).
    pub fn ln_v_sigma(&self, applied: bool) -> Vec<f64> {
        let k = self.uncertainty(applied);
        self.q_along
            .iter()
            .map(|&q| {
                let d = [q, 0.5 * q * q];
                let v = d[0] * (k[0][0] * d[0] + k[0][1] * d[1])
                    + d[1] * (k[1][0] * d[0] + k[1][1] * d[1]);
                v.max(0.0).sqrt()
            })
            .collect()
    }

    /// The Wald statistic κᵀΣ⁻¹κ of the two-term κ against no fall-off (Σ its covariance; over
    /// κ₀ alone when the strips do not determine κ₁). 0 when Σ is singular.
    pub fn wald_chi2(&self) -> f64 {
        let [k0, k1] = self.kappa_two_term;
        let c = self.kappa_covariance;
        if c[1][1] > 0.0 {
            let det = c[0][0] * c[1][1] - c[0][1] * c[1][0];
            if det <= 0.0 {
                return 0.0;
            }
            (k0 * k0 * c[1][1] - 2.0 * k0 * k1 * c[0][1] + k1 * k1 * c[0][0]) / det
        } else if c[0][0] > 0.0 {
            k0 * k0 / c[0][0]
        } else {
            0.0
        }
    }
}

/// κ₁ is used when beyond this many of its (cluster-robust) σ. Kept always, it drew a
/// 1 − 0.3·r² vignetting better (a CFL's map at 700 nm: 0.017–0.075 nm against 0.069–0.106
/// with it dropped under 4 formal σ, ≈ 1 robust σ), but followed the misfit of a fall-off
/// centred elsewhere (an off-centre 0.3 fall-off, Hg, seed 5: 0.176 nm at 700 nm against 0.146);
/// at 2σ the shape is used when the strips show it, and its uncertainty (the two-term
/// covariance) reaches the map's σ either way.
pub const KAPPA1_KEEP_SIGMA: f64 = 2.0;

/// Smallest signal (fraction of the channel's peak) at which a strip ratio is used.
const STRIP_MIN_SIGNAL: f64 = 0.05;

/// A pedestal (a level the fall-off does not scale, [`RadialFalloff::pedestal`]) is estimated
/// with the fall-off when its three levels are jointly beyond this Wald χ²₃ (p = 10⁻⁴). Left
/// out, a pedestal p dilutes each strip's ratio by (ȳ − p)/ȳ, most where the signal is low — at
/// the ends of the axis, where the fall-off is strongest: a 5 % black-level residue under a
/// 1 − 0.3·r² vignetting made the fall-off at the ends 0.88 instead of 0.71 and moved a CFL's
/// map by 0.3–0.4 nm at 700 nm. At p = 0.0027 (χ² 14.16, the 3σ of [`RADIAL_APPLY`]) one of 48
/// images without a pedestal (a CFL at 5 % noise, levels 1–3.6σ) took one and its map moved
/// 0.07 nm further off; the pedestals that matter are far beyond either (χ² in the hundreds at
/// 1 % noise).
pub const PEDESTAL_APPLY_CHI2: f64 = 21.11;

/// A pedestal level above this many times the darkest strip mean it dilutes is refused
/// ([`estimate_radial_falloff`]).
const PEDESTAL_OVER_DARKEST: f64 = 2.0;

/// Alternations of the pedestal and the fall-off ([`estimate_radial_falloff`]) at most.
const PEDESTAL_ITERATIONS: usize = 50;

/// Estimates a radial fall-off V(r) about the image centre from the strips of the ROI across
/// the filter axis.
///
/// Along the axis the fall-off is, to first order, indistinguishable from a shift of the map
/// (g(λ−λ₀)·(1 + ε(λ−λ₀)) ≈ g(λ−λ₀−εσ²) for a Gaussian passband of width σ), so a lamp profile
/// alone cannot determine it. Across the axis the wavelength is constant and only V changes:
/// at position a along the axis, strip j at distance b_j across has
/// ln(y_j/ȳ) ≈ κ(r²)·(q_j − q̄), q = (b − b_c)²/R², κ = d ln V/d(r²) — the same for every line,
/// continuum and channel. κ(r²) = κ₀ + κ₁·r² is solved by weighted least squares (weights
/// value²·pixels, positions where the channel is above 5 % of its peak; covariance clustered by
/// position, [`solve_strip_rows`]), κ₁ kept when beyond [`KAPPA1_KEEP_SIGMA`] of its σ, and V
/// along the profile is
/// exp(κ₀·Q + κ₁·Q²/2), Q = r² on the profile's centre
/// line. This assumes the fall-off is radial about the image centre (lens vignetting,
/// cos⁴ law); a tilt or an off-centre fall-off is not seen this way (a flat-field photo would
/// be needed). A level p per channel that the fall-off does not scale (y = V·S + p: a
/// black-level residue, flare) dilutes every ratio by (ȳ − p)/ȳ; it is estimated with κ and
/// used when significant ([`PEDESTAL_APPLY_CHI2`], [`RadialFalloff::pedestal`]).
///
/// Returns `None` when the ROI has fewer than 2 strips or the strips do not span different
/// radii.
pub fn estimate_radial_falloff(profile: &crate::lvf::Profile) -> Option<RadialFalloff> {
    if profile.strips.len() < 2 {
        return None;
    }
    let [w, h] = profile.frame_size;
    let (cx, cy) = ((w as f64 - 1.0) / 2.0, (h as f64 - 1.0) / 2.0);
    let r2 = (cx * cx + cy * cy).max(1e-12);
    let (ca, cb) = match profile.axis {
        crate::lvf::Axis::X => (cx, cy),
        crate::lvf::Axis::Y => (cy, cx),
    };
    let qb: Vec<f64> = profile
        .strips
        .iter()
        .map(|s| (s.across_px - cb).powi(2) / r2)
        .collect();
    let n = profile.px.len();
    let qbar: Vec<f64> = (0..n)
        .map(|i| {
            let (mut sq, mut sn) = (0.0, 0.0);
            for (s, q) in profile.strips.iter().zip(&qb) {
                sq += s.counts[i] as f64 * q;
                sn += s.counts[i] as f64;
            }
            if sn > 0.0 {
                sq / sn
            } else {
                0.0
            }
        })
        .collect();
    let big_q: Vec<f64> = (0..n)
        .map(|i| (profile.px[i] - ca).powi(2) / r2 + qbar[i])
        .collect();
    // rows (d, d·Q) → ln ratio, weight, position (the cluster of the robust covariance); each
    // row's channel and the position's mean ȳ beside them (for the pedestal)
    let mut rows: Vec<(f64, f64, f64, f64, usize)> = Vec::new();
    let mut row_cy: Vec<(usize, f64)> = Vec::new();
    for c in 0..3 {
        let v = &profile.values[c];
        let peak = v.iter().cloned().fold(0.0, f64::max);
        if peak <= 0.0 {
            continue;
        }
        for i in 0..n {
            if v[i] < STRIP_MIN_SIGNAL * peak {
                continue;
            }
            for (s, q) in profile.strips.iter().zip(&qb) {
                let sv = s.values[c][i];
                if !(sv.is_finite() && sv > 0.0) || s.counts[i] == 0 {
                    continue;
                }
                let d = q - qbar[i];
                rows.push((
                    d,
                    d * big_q[i],
                    (sv / v[i]).ln(),
                    v[i] * v[i] * s.counts[i] as f64,
                    i,
                ));
                row_cy.push((c, v[i]));
            }
        }
    }
    let mut one = solve_strip_rows(&rows, n, false)?;
    let mut two = solve_strip_rows(&rows, n, true);
    // a pedestal only matters (and is only determined) under a fall-off the strips see
    let seen = one.1[0] > 0.0 && one.0[0].abs() > RADIAL_APPLY.0 * one.1[0];
    let pedestal = seen
        .then(|| estimate_pedestal(&rows, &row_cy, n, two.map_or(one.0, |t| t.0)))
        .flatten();
    if let Some(ped) = &pedestal {
        // the fall-off again with each ratio's dilution (ȳ − p)/ȳ in its regressors, and the
        // covariance of κ from the joint fit with the pedestal (its uncertainty included)
        let scaled = scaled_rows(&rows, &row_cy, &ped.level);
        one = solve_strip_rows(&scaled, n, false)?;
        two = solve_strip_rows(&scaled, n, true);
        if let Some(c) = joint_covariance(&rows, &row_cy, n, one.0, &ped.level, false) {
            one.1[0] = c[(0, 0)].max(0.0).sqrt();
            one.2[0][0] = c[(0, 0)];
        }
        if let Some((k, s, cv)) = two.as_mut() {
            if let Some(c) = joint_covariance(&rows, &row_cy, n, *k, &ped.level, true) {
                *cv = [[c[(0, 0)], c[(0, 1)]], [c[(1, 0)], c[(1, 1)]]];
                *s = [c[(0, 0)].max(0.0).sqrt(), c[(1, 1)].max(0.0).sqrt()];
            }
        }
    }
    // κ₁ is used when the strips determine it (beyond KAPPA1_KEEP_SIGMA of its robust σ); the
    // two-term covariance is the fall-off's uncertainty either way.
    let (kappa, sigma) = match two {
        Some((k, s, _)) if k[1].abs() > KAPPA1_KEEP_SIGMA * s[1] => (k, s),
        _ => (one.0, one.1),
    };
    let (kappa_two_term, covariance) = match two {
        Some((k, _, c)) => (k, c),
        None => (one.0, one.2),
    };
    let ln_v: Vec<f64> = big_q
        .iter()
        .map(|&q| kappa[0] * q + 0.5 * kappa[1] * q * q)
        .collect();
    let top = ln_v.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    let along: Vec<f64> = ln_v.iter().map(|l| (l - top).exp()).collect();
    Some(RadialFalloff {
        kappa,
        kappa_sigma: sigma,
        kappa_covariance: covariance,
        kappa0_alone: [one.0[0], one.1[0]],
        kappa_two_term,
        centre_px: [cx, cy],
        half_diagonal_px: r2.sqrt(),
        at_ends: [along[0], along[n - 1]],
        samples: rows.len(),
        pedestal: pedestal.map(|p| std::array::from_fn(|c| [p.level[c], p.sigma[c]])),
        along,
        q_along: big_q,
    })
}

/// A pedestal under the fall-off: its level per channel and σ.
struct Pedestal {
    level: [f64; 3],
    sigma: [f64; 3],
}

/// The strip rows with each regressor times its ratio's dilution (ȳ − p_c)/ȳ: ln(y_j/ȳ) ≈
/// (ln V_j − ln V̄)·(ȳ − p)/ȳ when y = V·S + p.
fn scaled_rows(
    rows: &[(f64, f64, f64, f64, usize)],
    row_cy: &[(usize, f64)],
    p: &[f64; 3],
) -> Vec<(f64, f64, f64, f64, usize)> {
    rows.iter()
        .zip(row_cy)
        .map(|(&(x0, x1, y, w, i), &(c, ybar))| {
            let f = 1.0 - p[c] / ybar;
            (x0 * f, x1 * f, y, w, i)
        })
        .collect()
}

/// The pedestal p (per channel) and the fall-off κ fitted together by alternation — κ from the
/// scaled rows ([`scaled_rows`]), then each p_c by least squares of the rows' residual on
/// −(κ₀·d + κ₁·d·Q)/ȳ — returned when its three levels are jointly beyond
/// [`PEDESTAL_APPLY_CHI2`] (the joint fit's cluster-robust covariance).
fn estimate_pedestal(
    rows: &[(f64, f64, f64, f64, usize)],
    row_cy: &[(usize, f64)],
    n_positions: usize,
    kappa_start: [f64; 2],
) -> Option<Pedestal> {
    let mut p = [0.0f64; 3];
    let mut kappa = kappa_start;
    let scale = row_cy
        .iter()
        .map(|r| r.1.abs())
        .fold(0.0, f64::max)
        .max(1e-300);
    for _ in 0..PEDESTAL_ITERATIONS {
        let mut num = [0.0f64; 3];
        let mut den = [0.0f64; 3];
        for (&(x0, x1, y, w, _), &(c, ybar)) in rows.iter().zip(row_cy) {
            let z = -(kappa[0] * x0 + kappa[1] * x1) / ybar;
            num[c] += w * z * (y - kappa[0] * x0 - kappa[1] * x1);
            den[c] += w * z * z;
        }
        let next: [f64; 3] =
            std::array::from_fn(|c| if den[c] > 0.0 { num[c] / den[c] } else { 0.0 });
        let moved = (0..3).map(|c| (next[c] - p[c]).abs()).fold(0.0, f64::max);
        p = next;
        let scaled = scaled_rows(rows, row_cy, &p);
        kappa = solve_strip_rows(&scaled, n_positions, true)
            .or_else(|| solve_strip_rows(&scaled, n_positions, false))?
            .0;
        if moved <= 1e-9 * scale {
            break;
        }
    }
    let cov = joint_covariance(rows, row_cy, n_positions, kappa, &p, true)
        .or_else(|| joint_covariance(rows, row_cy, n_positions, kappa, &p, false))?;
    let m = cov.nrows();
    // the pedestal block: the last three parameters (channels without rows have 0 there)
    let idx: Vec<usize> = (m - 3..m).filter(|&j| cov[(j, j)] > 0.0).collect();
    if idx.is_empty() {
        return None;
    }
    let block = DMatrix::from_fn(idx.len(), idx.len(), |a, b| cov[(idx[a], idx[b])]);
    let pv = DVector::from_fn(idx.len(), |a, _| p[idx[a] + 3 - m]);
    let chi2 = block
        .clone()
        .try_inverse()
        .map(|inv| (pv.transpose() * inv * &pv)[(0, 0)])?;
    if chi2.is_nan() || chi2 <= PEDESTAL_APPLY_CHI2 {
        return None;
    }
    let sigma: [f64; 3] = std::array::from_fn(|c| cov[(m - 3 + c, m - 3 + c)].max(0.0).sqrt());
    // y = V·S + p with S ≥ 0: no channel's level lies far above its darkest used mean (else
    // the alternation has run off along κ·(1 − p/ȳ) ≈ const: a 40-row ROI whose strips barely
    // saw the fall-off gave a blue "pedestal" of 0.29 ± 0.05 over means from 0.04, and V 0.04
    // at the ends). Twice that mean, not the mean itself: the two-term ln V leaves the levels
    // biased by up to ≈ 25 % (a 0.04 pedestal under rows from 0.042 came out 0.050 in green,
    // with σ near 0 on a noise-free image).
    for (c, level) in p.iter().enumerate() {
        let darkest = row_cy
            .iter()
            .filter(|r| r.0 == c)
            .map(|r| r.1)
            .fold(f64::INFINITY, f64::min);
        if darkest.is_finite() && *level > PEDESTAL_OVER_DARKEST * darkest {
            return None;
        }
    }
    Some(Pedestal { level: p, sigma })
}

/// The cluster-robust covariance (one cluster per profile position, as [`solve_strip_rows`]) of
/// (κ₀[, κ₁], p_r, p_g, p_b) in the model ln(y_j/ȳ) = (κ₀·d + κ₁·d·Q)·(1 − p_c/ȳ) at the given
/// values. Channels without rows keep zero rows and columns. None when singular.
fn joint_covariance(
    rows: &[(f64, f64, f64, f64, usize)],
    row_cy: &[(usize, f64)],
    n_positions: usize,
    kappa: [f64; 2],
    p: &[f64; 3],
    two: bool,
) -> Option<DMatrix<f64>> {
    let nk = if two { 2 } else { 1 };
    let m = nk + 3;
    let mut a = DMatrix::<f64>::zeros(m, m);
    let mut score = vec![DVector::<f64>::zeros(m); n_positions];
    let mut used = vec![false; n_positions];
    for (&(x0, x1, y, w, i), &(c, ybar)) in rows.iter().zip(row_cy) {
        let f = 1.0 - p[c] / ybar;
        let k1 = if two { kappa[1] } else { 0.0 };
        let mut j = DVector::<f64>::zeros(m);
        j[0] = x0 * f;
        if two {
            j[1] = x1 * f;
        }
        j[nk + c] = -(kappa[0] * x0 + k1 * x1) / ybar;
        let r = y - (kappa[0] * x0 + k1 * x1) * f;
        a += &j * j.transpose() * w;
        score[i] += &j * (w * r);
        used[i] = true;
    }
    let g = used.iter().filter(|u| **u).count() as f64;
    if g <= m as f64 + 1.0 {
        return None;
    }
    // channels without rows: keep their diagonal invertible, their covariance 0 below
    let empty: Vec<usize> = (nk..m).filter(|&j| a[(j, j)] <= 0.0).collect();
    for &j in &empty {
        a[(j, j)] = 1.0;
    }
    let inv = a.try_inverse()?;
    let mut meat = DMatrix::<f64>::zeros(m, m);
    for s in &score {
        meat += s * s.transpose();
    }
    let mut cov = &inv * meat * &inv * (g / (g - 1.0));
    for &j in &empty {
        for k in 0..m {
            cov[(j, k)] = 0.0;
            cov[(k, j)] = 0.0;
        }
    }
    Some(cov)
}

/// κ, their standard errors and covariance, of one strip fit.
type StripFit = ([f64; 2], [f64; 2], [[f64; 2]; 2]);

/// Weighted least squares of the strip rows (d, d·Q, ln ratio, weight, position) for κ₀ (and
/// κ₁ when `two`): κ, their standard errors and covariance. The covariance is the
/// cluster-robust sandwich A⁻¹(Σ_i g_i g_iᵀ)A⁻¹·G/(G − 1) with one cluster per profile position
/// i (all strips and channels there share the position's mean in their ratios, and the noise
/// grows with the signal, so the rows are neither independent nor of the weights' variance; the
/// formal s²A⁻¹ understated the scatter of κ₀ by up to ~4× on images without vignetting).
/// None when A is singular or there are too few rows or positions.
fn solve_strip_rows(
    rows: &[(f64, f64, f64, f64, usize)],
    n_positions: usize,
    two: bool,
) -> Option<StripFit> {
    let (mut a00, mut a01, mut a11, mut b0, mut b1) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for &(x0, x1, y, wt, _) in rows {
        a00 += wt * x0 * x0;
        a01 += wt * x0 * x1;
        a11 += wt * x1 * x1;
        b0 += wt * x0 * y;
        b1 += wt * x1 * y;
    }
    let p = if two { 2 } else { 1 };
    if a00 <= 0.0 || rows.len() <= p + 1 {
        return None;
    }
    // A⁻¹ (2 × 2, or 1 × 1 in the corner)
    let inv = if two {
        let det = a00 * a11 - a01 * a01;
        if det <= 1e-12 * a00 * a11 {
            return None;
        }
        [[a11 / det, -a01 / det], [-a01 / det, a00 / det]]
    } else {
        [[1.0 / a00, 0.0], [0.0, 0.0]]
    };
    let k = [
        inv[0][0] * b0 + inv[0][1] * b1,
        inv[1][0] * b0 + inv[1][1] * b1,
    ];
    // per-position score sums Σ w·x·r
    let mut score = vec![[0.0f64; 2]; n_positions];
    let mut used = vec![false; n_positions];
    for &(x0, x1, y, wt, i) in rows {
        let r = y - k[0] * x0 - k[1] * x1;
        score[i][0] += wt * x0 * r;
        score[i][1] += wt * x1 * r;
        used[i] = true;
    }
    let g = used.iter().filter(|u| **u).count() as f64;
    if g <= p as f64 + 1.0 {
        return None;
    }
    let mut meat = [[0.0f64; 2]; 2];
    for s in &score {
        for a in 0..2 {
            for b in 0..2 {
                meat[a][b] += s[a] * s[b];
            }
        }
    }
    let f = g / (g - 1.0);
    let mut cov = [[0.0f64; 2]; 2];
    for a in 0..p {
        for b in 0..p {
            cov[a][b] = f
                * (0..p)
                    .flat_map(|i| (0..p).map(move |j| (i, j)))
                    .map(|(i, j)| inv[a][i] * meat[i][j] * inv[j][b])
                    .sum::<f64>();
        }
    }
    Some((
        k,
        [cov[0][0].max(0.0).sqrt(), cov[1][1].max(0.0).sqrt()],
        cov,
    ))
}
