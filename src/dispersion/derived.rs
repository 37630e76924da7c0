//! The numbers glass catalogues and renderers use, from any n(λ):
//!
//! - n_d, n_F, n_C, n_e, n_F′, n_C′ at the lines of [`super::lines`];
//! - Abbe numbers V_d = (n_d − 1)/(n_F − n_C) and V_e = (n_e − 1)/(n_F′ − n_C′);
//! - the six-digit glass code ⌊1000 (n_d − 1)⌉ ⌊10 V_d⌉ (Schott appends the density, which
//!   n(λ) does not give);
//! - the two-term Cauchy curve n = A + B/λ² (λ in µm) that glTF `KHR_materials_dispersion`
//!   implies: it passes through n_d and has the Abbe number V_d, so
//!   B = (n_d − 1) / (V_d (λ_F⁻² − λ_C⁻²)), A = n_d − B/λ_d²; with its RMS and max |Δn| against
//!   the full model over the range, so a user sees what the export loses.

use super::lines::{C_NM, C_PRIME_NM, D_NM, E_NM, F_NM, F_PRIME_NM};
use super::model::Model;
use super::RefractiveIndex;
use crate::error::{ensure_finite, Result};

/// The derived numbers of one n(λ).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct DerivedNumbers {
    /// n at the helium d line, 587.5618 nm.
    pub n_d: f64,
    /// n at the hydrogen F line, 486.1327 nm.
    pub n_f: f64,
    /// n at the hydrogen C line, 656.2725 nm.
    pub n_c: f64,
    /// n at the mercury e line, 546.0740 nm.
    pub n_e: f64,
    /// Abbe number V_d.
    pub abbe_number_d: f64,
    /// Abbe number V_e (F′, C′ lines).
    pub abbe_number_e: f64,
    /// Six-digit glass code, e.g. `517642` for N-BK7.
    pub glass_code: String,
    /// The two-term Cauchy curve glTF and OpenPBR imply.
    pub gltf_cauchy: GltfCauchy,
}

/// The two-term Cauchy curve through n_d with Abbe number V_d, and what it loses.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct GltfCauchy {
    /// A (dimensionless).
    pub a: f64,
    /// B in µm².
    pub b_um2: f64,
    /// glTF's `dispersion` = 20 / V_d.
    pub gltf_dispersion: f64,
    /// RMS of n_cauchy − n over the range at 1 nm.
    pub rms_error: f64,
    /// max |n_cauchy − n| over the range at 1 nm.
    pub max_abs_error: f64,
}

/// Derived numbers of `n` with the glTF Cauchy error over `range_nm` (1 nm grid).
pub fn derived_numbers(n: &dyn RefractiveIndex, range_nm: [f64; 2]) -> Result<DerivedNumbers> {
    let n_d = n.n_at(D_NM);
    let n_f = n.n_at(F_NM);
    let n_c = n.n_at(C_NM);
    let n_e = n.n_at(E_NM);
    let v_d = (n_d - 1.0) / (n_f - n_c);
    let v_e = (n_e - 1.0) / (n.n_at(F_PRIME_NM) - n.n_at(C_PRIME_NM));
    ensure_finite(
        "Abbe number",
        "the dispersion model",
        &[n_d, n_f, n_c, n_e, v_d, v_e],
    )?;
    let code = format!(
        "{:03}{:03}",
        ((n_d - 1.0) * 1000.0).round().clamp(0.0, 999.0) as u32,
        (v_d * 10.0).round().clamp(0.0, 999.0) as u32
    );
    let inv2 = |l_nm: f64| 1.0 / (l_nm * 1e-3).powi(2);
    let b = (n_d - 1.0) / (v_d * (inv2(F_NM) - inv2(C_NM)));
    let a = n_d - b * inv2(D_NM);
    let cauchy = Model::Cauchy(vec![a, b]);
    let (rms, max) = model_difference(&cauchy, n, range_nm);
    Ok(DerivedNumbers {
        n_d,
        n_f,
        n_c,
        n_e,
        abbe_number_d: v_d,
        abbe_number_e: v_e,
        glass_code: code,
        gltf_cauchy: GltfCauchy {
            a,
            b_um2: b,
            gltf_dispersion: 20.0 / v_d,
            rms_error: rms,
            max_abs_error: max,
        },
    })
}

/// RMS and max |a − b| over `range_nm` on a 1 nm grid (both ends included).
pub fn model_difference(
    a: &dyn RefractiveIndex,
    b: &dyn RefractiveIndex,
    range_nm: [f64; 2],
) -> (f64, f64) {
    let steps = ((range_nm[1] - range_nm[0]).round() as usize).max(1);
    let mut ss = 0.0;
    let mut max: f64 = 0.0;
    for i in 0..=steps {
        let l = range_nm[0] + (range_nm[1] - range_nm[0]) * i as f64 / steps as f64;
        let d = a.n_at(l) - b.n_at(l);
        ss += d * d;
        max = max.max(d.abs());
    }
    ((ss / (steps + 1) as f64).sqrt(), max)
}

/// Standard deviation of V_d from the coefficient covariance of `model` (p × p, column-major),
/// by first-order propagation with central-difference gradients.
pub fn abbe_number_std(model: &Model, covariance: &[f64]) -> Option<f64> {
    let theta = model.coefficients().to_vec();
    let p = theta.len();
    if covariance.len() != p * p {
        return None;
    }
    let vd = |m: &Model| (m.n_at(D_NM) - 1.0) / (m.n_at(F_NM) - m.n_at(C_NM));
    let mut g = vec![0.0; p];
    for j in 0..p {
        let h = 1e-6 * theta[j].abs().max(1e-8);
        let mut up = theta.clone();
        let mut dn = theta.clone();
        up[j] += h;
        dn[j] -= h;
        g[j] =
            (vd(&super::fit::rebuild(model, up)) - vd(&super::fit::rebuild(model, dn))) / (2.0 * h);
    }
    let mut var = 0.0;
    for i in 0..p {
        for j in 0..p {
            var += g[i] * covariance[j * p + i] * g[j];
        }
    }
    (var.is_finite() && var >= 0.0).then(|| var.sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_two_term_cauchy_is_its_own_gltf_curve() {
        let m = Model::Cauchy(vec![1.5046, 0.0042]);
        let d = derived_numbers(&m, [380.0, 780.0]).unwrap();
        assert!((d.gltf_cauchy.a - 1.5046).abs() < 1e-12);
        assert!((d.gltf_cauchy.b_um2 - 0.0042).abs() < 1e-12);
        assert!(d.gltf_cauchy.max_abs_error < 1e-12);
    }

    #[test]
    fn glass_code_rounds_n_d_and_v_d() {
        // n_d 1.5168, V_d 64.17 → 517642
        let b = (0.5168) / (64.17 * (1.0 / 0.4861327f64.powi(2) - 1.0 / 0.6562725f64.powi(2)));
        let a = 1.5168 - b / 0.5875618f64.powi(2);
        let d = derived_numbers(&Model::Cauchy(vec![a, b]), [380.0, 780.0]).unwrap();
        assert_eq!(d.glass_code, "517642");
    }
}
