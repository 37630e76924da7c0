//! Colour differences in CIE L\*a\*b\*: CIE 1976, CIE 1994, CIEDE2000.
//!
//! - CIE 1976: `ΔE*ab = ‖Lab₁ − Lab₂‖`.
//! - CIE 1994: `ΔE*94 = √((ΔL/(kL·SL))² + (ΔC/(kC·SC))² + (ΔH/(kH·SH))²)` with `SL = 1`,
//!   `SC = 1 + K1·C₁`, `SH = 1 + K2·C₁`, `ΔH² = Δa² + Δb² − ΔC²` (0 when negative); graphic arts
//!   `K1 = 0.045, K2 = 0.015, kL = 1`, textiles `K1 = 0.048, K2 = 0.014, kL = 2`. Not symmetric:
//!   `Lab₁` is the reference.
//! - CIEDE2000: `ΔE00 = √((ΔL'/(kL·SL))² + (ΔC'/(kC·SC))² + (ΔH'/(kH·SH))² +
//!   RT·(ΔC'/(kC·SC))·(ΔH'/(kH·SH)))` with `kC = kH = 1`, `kL = 1` (2 for textiles), following
//!   Sharma, Wu & Dalal (2005) including their hue-difference and mean-hue case analysis.
//!
//! Units: L\*a\*b\* with L\* in 0–100; ΔE in the same units. Hues in degrees.
//!
//! References: CIE 116-1995 (CIE 1994); CIE 142-2001 and Sharma, G., Wu, W., & Dalal, E. N.
//! (2005), *Color Research & Application* 30(1), 21–30 (CIEDE2000).
//!
//! colour-science counterparts: `colour.difference.delta_E_CIE1976`, `delta_E_CIE1994`,
//! `delta_E_CIE2000` (`intermediate_attributes_CIE2000`), `colour.delta_E`.

use crate::error::{Error, Result};

/// A colour-difference formula.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum DeltaEMethod {
    /// Euclidean distance in L\*a\*b\*.
    Cie1976,
    /// CIE 1994, graphic-arts weights.
    Cie1994,
    /// CIEDE2000 with `kL = kC = kH = 1`.
    Ciede2000,
}

impl DeltaEMethod {
    /// All methods.
    pub const ALL: [DeltaEMethod; 3] = [
        DeltaEMethod::Cie1976,
        DeltaEMethod::Cie1994,
        DeltaEMethod::Ciede2000,
    ];

    /// Parses `cie1976`, `cie1994`, `cie2000` / `ciede2000` (case-insensitive; `cie76`, `cie94`,
    /// `de2000` also accepted).
    pub fn from_name(name: &str) -> Result<DeltaEMethod> {
        let key: String = name
            .trim()
            .to_ascii_lowercase()
            .chars()
            .filter(|c| !matches!(c, '-' | '_' | ' '))
            .collect();
        match key.as_str() {
            "cie1976" | "cie76" | "de1976" => Ok(DeltaEMethod::Cie1976),
            "cie1994" | "cie94" | "de1994" => Ok(DeltaEMethod::Cie1994),
            "cie2000" | "ciede2000" | "de2000" | "cie00" => Ok(DeltaEMethod::Ciede2000),
            _ => Err(Error::UnknownName {
                kind: "colour-difference method",
                name: name.to_string(),
                expected: "cie1976, cie1994, cie2000 (ciede2000)".into(),
            }),
        }
    }

    /// lumifit's key.
    pub fn key(self) -> &'static str {
        match self {
            DeltaEMethod::Cie1976 => "cie1976",
            DeltaEMethod::Cie1994 => "cie1994",
            DeltaEMethod::Ciede2000 => "cie2000",
        }
    }
}

impl std::fmt::Display for DeltaEMethod {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.key())
    }
}

/// ΔE between two L\*a\*b\* colours by `method` with colour's defaults (not textiles).
pub fn delta_e(lab1: [f64; 3], lab2: [f64; 3], method: DeltaEMethod) -> f64 {
    match method {
        DeltaEMethod::Cie1976 => delta_e_cie1976(lab1, lab2),
        DeltaEMethod::Cie1994 => delta_e_cie1994(lab1, lab2, false),
        DeltaEMethod::Ciede2000 => delta_e_cie2000(lab1, lab2, false),
    }
}

/// CIE 1976 ΔE\*ab (`colour.difference.delta_E_CIE1976`).
pub fn delta_e_cie1976(lab1: [f64; 3], lab2: [f64; 3]) -> f64 {
    let d0 = lab1[0] - lab2[0];
    let d1 = lab1[1] - lab2[1];
    let d2 = lab1[2] - lab2[2];
    (d0 * d0 + d1 * d1 + d2 * d2).sqrt()
}

/// CIE 1994 ΔE\*94 with `lab1` as reference (`colour.difference.delta_E_CIE1994`); `textiles`
/// selects the textile weights.
pub fn delta_e_cie1994(lab1: [f64; 3], lab2: [f64; 3], textiles: bool) -> f64 {
    let [l1, a1, b1] = lab1;
    let [l2, a2, b2] = lab2;
    let k1 = if textiles { 0.048 } else { 0.045 };
    let k2 = if textiles { 0.014 } else { 0.015 };
    let k_l = if textiles { 2.0 } else { 1.0 };
    let (k_c, k_h) = (1.0, 1.0);

    let c1 = a1.hypot(b1);
    let c2 = a2.hypot(b2);
    let s_l = 1.0;
    let s_c = 1.0 + k1 * c1;
    let s_h = 1.0 + k2 * c1;

    let delta_l = l1 - l2;
    let delta_c = c1 - c2;
    let delta_a = a1 - a2;
    let delta_b = b1 - b2;
    let radical = delta_a * delta_a + delta_b * delta_b - delta_c * delta_c;
    let delta_h = if radical > 0.0 { radical.sqrt() } else { 0.0 };

    let l = sq(delta_l / (k_l * s_l));
    let c = sq(delta_c / (k_c * s_c));
    let h = sq(delta_h / (k_h * s_h));
    (l + c + h).sqrt()
}

fn sq(x: f64) -> f64 {
    x * x
}

/// Python's `x % 360` for floats (result in [0, 360)).
fn mod360(x: f64) -> f64 {
    x.rem_euclid(360.0)
}

/// The intermediate quantities of CIEDE2000 (`colour.difference.intermediate_attributes_CIE2000`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cie2000Attributes {
    /// Lightness weighting `SL`.
    pub s_l: f64,
    /// Chroma weighting `SC`.
    pub s_c: f64,
    /// Hue weighting `SH`.
    pub s_h: f64,
    /// `ΔL' = L₂ − L₁`.
    pub delta_l_p: f64,
    /// `ΔC' = C'₂ − C'₁`.
    pub delta_c_p: f64,
    /// `ΔH' = 2·√(C'₁C'₂)·sin(Δh'/2)`.
    pub delta_h_p: f64,
    /// Rotation term `RT`.
    pub r_t: f64,
}

/// CIEDE2000 intermediate attributes, ported line by line from colour 0.4.7.
pub fn cie2000_attributes(lab1: [f64; 3], lab2: [f64; 3]) -> Cie2000Attributes {
    let [l1, a1, b1] = lab1;
    let [l2, a2, b2] = lab2;
    let p25_7 = 6_103_515_625.0; // 25**7, exact

    let c1_ab = a1.hypot(b1);
    let c2_ab = a2.hypot(b2);
    let c_bar_ab = (c1_ab + c2_ab) / 2.0;
    let c_bar_ab_7 = c_bar_ab.powf(7.0);
    let g = 0.5 * (1.0 - (c_bar_ab_7 / (c_bar_ab_7 + p25_7)).sqrt());

    let a_p_1 = (1.0 + g) * a1;
    let a_p_2 = (1.0 + g) * a2;
    let c_p_1 = a_p_1.hypot(b1);
    let c_p_2 = a_p_2.hypot(b2);

    let h_p_1 = if b1 == 0.0 && a_p_1 == 0.0 {
        0.0
    } else {
        mod360(b1.atan2(a_p_1).to_degrees())
    };
    let h_p_2 = if b2 == 0.0 && a_p_2 == 0.0 {
        0.0
    } else {
        mod360(b2.atan2(a_p_2).to_degrees())
    };

    let delta_l_p = l2 - l1;
    let delta_c_p = c_p_2 - c_p_1;

    let h_p_2_s_1 = h_p_2 - h_p_1;
    let c_p_1_m_2 = c_p_1 * c_p_2;
    // np.select: first matching condition wins; no match gives 0.
    let delta_h_p = if c_p_1_m_2 == 0.0 {
        0.0
    } else if h_p_2_s_1.abs() <= 180.0 {
        h_p_2_s_1
    } else if h_p_2_s_1 > 180.0 {
        h_p_2_s_1 - 360.0
    } else if h_p_2_s_1 < -180.0 {
        h_p_2_s_1 + 360.0
    } else {
        0.0
    };
    let delta_h_p_big = 2.0 * c_p_1_m_2.sqrt() * (delta_h_p / 2.0).to_radians().sin();

    let l_bar_p = (l1 + l2) / 2.0;
    let c_bar_p = (c_p_1 + c_p_2) / 2.0;

    let a_h_p_1_s_2 = (h_p_1 - h_p_2).abs();
    let h_p_1_a_2 = h_p_1 + h_p_2;
    let h_bar_p = if c_p_1_m_2 == 0.0 {
        h_p_1_a_2
    } else if a_h_p_1_s_2 <= 180.0 {
        h_p_1_a_2 / 2.0
    } else if a_h_p_1_s_2 > 180.0 && h_p_1_a_2 < 360.0 {
        (h_p_1_a_2 + 360.0) / 2.0
    } else if a_h_p_1_s_2 > 180.0 && h_p_1_a_2 >= 360.0 {
        (h_p_1_a_2 - 360.0) / 2.0
    } else {
        0.0
    };

    let t = 1.0 - 0.17 * (h_bar_p - 30.0).to_radians().cos()
        + 0.24 * (2.0 * h_bar_p).to_radians().cos()
        + 0.32 * (3.0 * h_bar_p + 6.0).to_radians().cos()
        - 0.20 * (4.0 * h_bar_p - 63.0).to_radians().cos();

    let delta_theta = 30.0 * (-sq((h_bar_p - 275.0) / 25.0)).exp();

    let c_bar_p_7 = c_bar_p.powf(7.0);
    let r_c = 2.0 * (c_bar_p_7 / (c_bar_p_7 + p25_7)).sqrt();

    let l_bar_p_2 = sq(l_bar_p - 50.0);
    let s_l = 1.0 + (0.015 * l_bar_p_2) / (20.0 + l_bar_p_2).sqrt();
    let s_c = 1.0 + 0.045 * c_bar_p;
    let s_h = 1.0 + 0.015 * c_bar_p * t;
    let r_t = -(2.0 * delta_theta).to_radians().sin() * r_c;

    Cie2000Attributes {
        s_l,
        s_c,
        s_h,
        delta_l_p,
        delta_c_p,
        delta_h_p: delta_h_p_big,
        r_t,
    }
}

/// CIEDE2000 ΔE00 (`colour.difference.delta_E_CIE2000`); `textiles` sets `kL = 2`.
pub fn delta_e_cie2000(lab1: [f64; 3], lab2: [f64; 3], textiles: bool) -> f64 {
    let at = cie2000_attributes(lab1, lab2);
    let k_l = if textiles { 2.0 } else { 1.0 };
    let (k_c, k_h) = (1.0, 1.0);
    let l = at.delta_l_p / (k_l * at.s_l);
    let c = at.delta_c_p / (k_c * at.s_c);
    let h = at.delta_h_p / (k_h * at.s_h);
    (l * l + c * c + h * h + at.r_t * c * h).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn identical_colours_have_zero_difference_by_every_method() {
        let lab = [50.0, 20.0, -30.0];
        for m in DeltaEMethod::ALL {
            assert_eq!(delta_e(lab, lab, m), 0.0, "{m}");
        }
    }

    #[test]
    fn ciede2000_reproduces_sharma_pair_17() {
        let d = delta_e_cie2000([50.0, 2.5, 0.0], [73.0, 25.0, -18.0], false);
        assert!((d - 27.1492).abs() < 5e-5, "{d}");
    }

    #[test]
    fn method_names_parse() {
        assert_eq!(
            DeltaEMethod::from_name("CIEDE2000").unwrap(),
            DeltaEMethod::Ciede2000
        );
        assert_eq!(
            DeltaEMethod::from_name("cie2000").unwrap(),
            DeltaEMethod::Ciede2000
        );
        assert_eq!(
            DeltaEMethod::from_name("cie1994").unwrap(),
            DeltaEMethod::Cie1994
        );
        assert!(DeltaEMethod::from_name("cmc").is_err());
    }
}
