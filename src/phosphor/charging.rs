//! The charging protocol of a decay measurement: what the sample went through before the light
//! was switched off, and the state it leaves (Nalbach et al. 2017, Eq. 1).
//!
//! A decay fit measures amplitudes a_i = Λ_i k_r,i r_i(0) (Eq. 3 at switch-off), so Λ follows
//! from the amplitudes only when r_i(0) is known. The paper charges for 90 minutes under a strong
//! lamp and assumes saturation, r_i(0) = 1 (§4.4). Under flat light with |E| = e over the
//! material's n bands (E[b] = e/√n, the paper's normalisation, §4.6) for T seconds from dark,
//! Eq. 1 has the closed form
//!
//! `r_i(0) = a_i/(a_i + k_r,i) · (1 − e^{−(a_i + k_r,i) T})`,  `a_i = Σ_b k_e,i[b] E[b]`,
//!
//! which needs k_e: a decay fit alone cannot know it, so `phos fit-decay` records the protocol
//! and `phos fit-excitation` solves for k_e and r_i(0) together
//! ([`super::excitation::ExcitationOptions::decay_charging`]).
//!
//! Units: s, and irradiance in the units k_e refers to (Table 1: |E| = 1).

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};

use super::material::Material;
use super::simulate::{final_state, Segment};

/// How a sample was charged before its decay was measured.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "protocol", rename_all = "snake_case")]
pub enum DecayCharging {
    /// Saturated at switch-off: r_i(0) = 1 (a long charge under a strong lamp, §4.4).
    Saturated,
    /// Charged from dark for `duration_s` under flat light of norm `irradiance` over the
    /// material's bands (E[b] = irradiance/√n).
    Flat {
        /// Charging time in s (> 0).
        duration_s: f64,
        /// |E| of the flat light, in the units of k_e (Table 1: 1).
        irradiance: f64,
    },
    /// Not recorded: saturation is assumed (Λ is then Λ·r(0), a lower bound).
    Unknown,
}

impl DecayCharging {
    /// Checks the numbers of a [`DecayCharging::Flat`] protocol.
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] naming the field when the duration or irradiance is not a
    /// finite number > 0 (a sample that was not charged does not glow).
    pub fn validate(&self) -> Result<()> {
        if let DecayCharging::Flat {
            duration_s,
            irradiance,
        } = self
        {
            if !(duration_s.is_finite() && *duration_s > 0.0) {
                return Err(Error::invalid(
                    "charging duration_s",
                    format!(
                        "{duration_s} s; expected a charging time > 0 (a sample that was not \
                         charged does not glow; for r = 1 at switch-off say 'saturated')"
                    ),
                ));
            }
            if !(irradiance.is_finite() && *irradiance > 0.0) {
                return Err(Error::invalid(
                    "charging irradiance",
                    format!("{irradiance}; expected |E| > 0 in the units of k_e (Table 1: 1)"),
                ));
            }
        }
        Ok(())
    }

    /// Whether r_i(0) = 1 is assumed (saturated or unknown).
    pub fn assumes_saturation(&self) -> bool {
        !matches!(self, DecayCharging::Flat { .. })
    }

    /// One line for reports and warnings.
    pub fn describe(&self) -> String {
        match self {
            DecayCharging::Saturated => "saturated at switch-off (r = 1)".into(),
            DecayCharging::Flat {
                duration_s,
                irradiance,
            } => {
                format!("charged from dark for {duration_s} s under flat light |E| = {irradiance}")
            }
            DecayCharging::Unknown => {
                "unknown charging protocol: saturation at switch-off (r = 1) assumed".into()
            }
        }
    }

    /// The concentrations r_i at switch-off of `material` (which needs k_e for a
    /// [`DecayCharging::Flat`] protocol; 1 for saturated or unknown).
    ///
    /// # Errors
    /// As [`DecayCharging::validate`]; [`Error::InvalidArgument`] when a flat charge is applied
    /// to a material without excitation rates.
    pub fn state_at_switch_off(&self, material: &Material) -> Result<Vec<f64>> {
        self.validate()?;
        let ns = material.states.len();
        let DecayCharging::Flat {
            duration_s,
            irradiance,
        } = self
        else {
            return Ok(vec![1.0; ns]);
        };
        if !material.has_excitation() {
            return Err(Error::invalid(
                "material",
                format!(
                    "'{}' has no excitation rates k_e, so the state after charging {duration_s} s \
                     is unknown; expected a material with k_e (or a saturated protocol)",
                    material.name
                ),
            ));
        }
        let nb = material.bands.len();
        let e = irradiance / (nb as f64).sqrt();
        final_state(
            material,
            &[Segment {
                duration_s: *duration_s,
                irradiance: vec![e; nb],
            }],
            &vec![0.0; ns],
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::phosphor::table1_material;

    #[test]
    fn green_paint_after_ninety_minutes_of_unit_light_is_far_from_saturated() {
        let m = &table1_material("green_paint").unwrap().material;
        let r = DecayCharging::Flat {
            duration_s: 5400.0,
            irradiance: 1.0,
        }
        .state_at_switch_off(m)
        .unwrap();
        // a = (0.1 + 0.035 + 0.006)/√8 = 0.04985 s⁻¹; equilibrium a/(a + 0.227) = 0.1801.
        let a = 0.141 / 8f64.sqrt();
        assert!((r[0] - a / (a + 0.227)).abs() < 1e-9, "{r:?}");
        assert_eq!(
            DecayCharging::Saturated.state_at_switch_off(m).unwrap(),
            vec![1.0]
        );
    }

    #[test]
    fn a_zero_charge_is_refused_naming_the_field() {
        let e = DecayCharging::Flat {
            duration_s: 0.0,
            irradiance: 1.0,
        }
        .validate()
        .unwrap_err()
        .to_string();
        assert!(e.contains("duration_s") && e.contains("saturated"), "{e}");
    }

    #[test]
    fn the_protocol_reads_back_from_its_json() {
        for c in [
            DecayCharging::Saturated,
            DecayCharging::Unknown,
            DecayCharging::Flat {
                duration_s: 5400.0,
                irradiance: 2.5,
            },
        ] {
            let s = serde_json::to_string(&c).unwrap();
            assert_eq!(serde_json::from_str::<DecayCharging>(&s).unwrap(), c, "{s}");
        }
    }
}
