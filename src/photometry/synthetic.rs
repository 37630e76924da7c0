//! Synthetic photometric profiles for the benchmark (Luksch et al. 2020 §6 used seven measured
//! Zumtobel profiles; these four span the same characters: diffuse, directed, batwing,
//! asymmetric). Each is a Type C [`PhotometricFile`] in absolute candela for a 1 × 1 m
//! rectangular opening, so the IES writer ([`crate::io::ies::write_ies`]) turns it into an
//! LM-63-2019 file that any reader can check.
//!
//! With d(C, γ) = (sin γ cos C, sin γ sin C, −cos γ) the luminaire-frame direction (module docs
//! of [`super`]) and I₀ = 1000 cd:
//!
//! - `lambertian`: I = I₀ cos⁺γ (a uniform diffuse emitter; flux π·I₀), γ 0–90° in 1° steps.
//! - `spot`: I = I₀ cos⁺γ^45 (beam angle 2·acos(0.5^{1/45}) = 20.1°), γ 0–90° in 0.5° steps.
//! - `batwing`: I = I₀ cos⁺γ (1 + 3 sin²γ) (peak 1.78·I₀ at γ = asin √(5/9) = 48.2°, I₀ at
//!   nadir), γ 0–90° in 1° steps.
//! - `asymmetric`: I = I₀ (0.2 cos⁺γ + (d·p₁)⁺⁸ + 0.5 (d·p₂)⁺¹⁶) with lobes p₁ = d(0°, 50°)
//!   and p₂ = d(120°, 30°): a forward-throw lobe plus a second one off the C0–C180 plane, so no
//!   symmetry holds; stored as the full circle C 0–355° in 5° steps, γ 0–90° in 2.5° steps.
//!
//! All four emit nothing upwards (γ > 90°).

use super::{
    CandelaGrid, FileFormat, LampSet, LuminousOpening, OpeningShape, PhotometricFile, Photometry,
    Symmetry, Tilt,
};
use crate::error::Result;

/// Peak scale I₀ of the synthetic profiles, cd.
pub const I0_CD: f64 = 1000.0;

/// The synthetic profiles.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SyntheticProfile {
    /// I₀ cos γ.
    Lambertian,
    /// I₀ cos⁴⁵ γ, 20° beam.
    Spot,
    /// I₀ cos γ (1 + 3 sin² γ).
    Batwing,
    /// Two tilted lobes over a diffuse base, no symmetry.
    Asymmetric,
}

impl SyntheticProfile {
    /// Every profile, in the order of the module docs.
    pub const ALL: [SyntheticProfile; 4] = [
        SyntheticProfile::Lambertian,
        SyntheticProfile::Spot,
        SyntheticProfile::Batwing,
        SyntheticProfile::Asymmetric,
    ];

    /// Its name (`lambertian`, `spot`, `batwing`, `asymmetric`).
    pub fn name(self) -> &'static str {
        match self {
            SyntheticProfile::Lambertian => "lambertian",
            SyntheticProfile::Spot => "spot",
            SyntheticProfile::Batwing => "batwing",
            SyntheticProfile::Asymmetric => "asymmetric",
        }
    }

    /// Intensity in cd in the direction (C, γ) in degrees.
    pub fn intensity_cd(self, c_deg: f64, gamma_deg: f64) -> f64 {
        let (c, g) = (c_deg.to_radians(), gamma_deg.to_radians());
        let cos_g = g.cos().max(0.0);
        match self {
            SyntheticProfile::Lambertian => I0_CD * cos_g,
            SyntheticProfile::Spot => I0_CD * cos_g.powi(45),
            SyntheticProfile::Batwing => I0_CD * cos_g * (1.0 + 3.0 * g.sin().powi(2)),
            SyntheticProfile::Asymmetric => {
                let d = [g.sin() * c.cos(), g.sin() * c.sin(), -g.cos()];
                let lobe = |cp: f64, gp: f64, m: i32| {
                    let (cp, gp) = (cp.to_radians(), gp.to_radians());
                    let p = [gp.sin() * cp.cos(), gp.sin() * cp.sin(), -gp.cos()];
                    (d[0] * p[0] + d[1] * p[1] + d[2] * p[2]).max(0.0).powi(m)
                };
                I0_CD * (0.2 * cos_g + lobe(0.0, 50.0, 8) + 0.5 * lobe(120.0, 30.0, 16))
            }
        }
    }

    /// The profile as a photometric file (absolute photometry, 1 × 1 m rectangular opening).
    pub fn file(self) -> Result<PhotometricFile> {
        let (v_step, h_deg, symmetry): (f64, Vec<f64>, Symmetry) = match self {
            SyntheticProfile::Asymmetric => (
                2.5,
                (0..72).map(|k| 5.0 * k as f64).collect(),
                Symmetry::None,
            ),
            SyntheticProfile::Spot => (0.5, vec![0.0], Symmetry::Rotational),
            _ => (1.0, vec![0.0], Symmetry::Rotational),
        };
        let nv = (90.0 / v_step).round() as usize + 1;
        let v_deg: Vec<f64> = (0..nv).map(|k| k as f64 * v_step).collect();
        let mut cd = Vec::with_capacity(h_deg.len() * nv);
        for &c in &h_deg {
            for &g in &v_deg {
                // exact zero at the horizon (cos 90° is 6e-17 in floating point)
                cd.push(if g >= 90.0 {
                    0.0
                } else {
                    self.intensity_cd(c, g)
                });
            }
        }
        let grid = CandelaGrid::new(super::PhotometricType::C, h_deg, v_deg, cd)?;
        Ok(PhotometricFile {
            format: FileFormat::Ies,
            version: "LM-63-2019".into(),
            keywords: vec![
                (
                    "TEST".into(),
                    format!("lumifit synthetic profile '{}'", self.name()),
                ),
                ("TESTLAB".into(), "none (analytic)".into()),
                ("MANUFAC".into(), "lumifit".into()),
                (
                    "LUMINAIRE".into(),
                    format!("synthetic {} 1 x 1 m", self.name()),
                ),
            ],
            lamps: vec![LampSet {
                count: 1,
                kind: "synthetic".into(),
                flux_lm: -1.0,
                colour_temperature: String::new(),
                colour_rendering: String::new(),
                watts: 0.0,
            }],
            direct_ratios: Vec::new(),
            ldt_type_indicator: 0,
            input_watts: 0.0,
            notes: Vec::new(),
            photometry: Photometry {
                grid,
                symmetry,
                lamp_flux_lm: None,
                declared_luminaire_flux_lm: None,
                declared_lor_percent: None,
                declared_dff_percent: None,
                opening: LuminousOpening {
                    length_m: 1.0,
                    width_m: 1.0,
                    height_m: 0.0,
                    shape: OpeningShape::Rectangular,
                },
                tilt: Tilt::None,
                tilt_applied: (0.0, 1.0),
            },
        })
    }
}

impl std::str::FromStr for SyntheticProfile {
    type Err = crate::error::Error;
    fn from_str(s: &str) -> Result<Self> {
        SyntheticProfile::ALL
            .into_iter()
            .find(|p| p.name() == s)
            .ok_or_else(|| {
                crate::error::Error::invalid(
                    "--profile",
                    format!("'{s}': expected lambertian, spot, batwing or asymmetric"),
                )
            })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lambertian_profile_has_flux_pi_i0_and_the_spot_its_twenty_degree_beam() {
        let f = SyntheticProfile::Lambertian.file().unwrap();
        let flux = f.photometry.grid.flux_lm();
        assert!(
            (flux / (std::f64::consts::PI * I0_CD) - 1.0).abs() < 1e-4,
            "{flux}"
        );
        let s = SyntheticProfile::Spot.file().unwrap();
        let b = super::super::beam_angles(&s.photometry.grid, 0.0);
        let want = 2.0 * 0.5f64.powf(1.0 / 45.0).acos().to_degrees();
        assert!((b.beam_deg - want).abs() < 0.05, "{} vs {want}", b.beam_deg);
    }

    #[test]
    fn asymmetric_profile_differs_between_mirror_planes() {
        let p = SyntheticProfile::Asymmetric;
        let a = p.intensity_cd(120.0, 30.0);
        let b = p.intensity_cd(240.0, 30.0);
        let c = p.intensity_cd(60.0, 30.0);
        assert!(a > 1.5 * b && a > 1.5 * c, "{a} {b} {c}");
        let g = p.file().unwrap().photometry.grid;
        assert_eq!(g.h_deg.len(), 72);
        assert_eq!(g.intensity(120.0, 30.0), a);
    }
}
