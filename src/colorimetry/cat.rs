//! Von Kries-type chromatic adaptation transforms: Bradford, CAT02, von Kries.
//!
//! With the transform's cone-response matrix `M`, source white `XYZw` and destination white
//! `XYZwr` (both on the same scale, usually Y = 1):
//!
//! ```text
//! ρβγ_w = M·XYZw,   ρβγ_wr = M·XYZwr,   D = diag(ρβγ_wr / ρβγ_w)
//! M_CAT = M⁻¹ · D · M,                  XYZ_adapted = M_CAT · XYZ
//! ```
//!
//! Units: XYZ dimensionless (any common scale). References: Lam (1985) and Lindbloom for
//! Bradford; Moroney et al. (2002) / CIE 159:2004 for CAT02; von Kries (1902) with the
//! Hunt-Pointer-Estévez matrix as tabulated by Fairchild (2013).
//!
//! colour-science counterparts: `colour.adaptation.CAT_BRADFORD`, `CAT_CAT02`, `CAT_VON_KRIES`,
//! `colour.adaptation.matrix_chromatic_adaptation_VonKries`,
//! `colour.adaptation.chromatic_adaptation_VonKries`.

use crate::error::{Error, Result};
use crate::math::linalg::{mat3_inv, mat3_mul, mat3_mul_vec, Mat3};

/// colour's `CAT_BRADFORD`.
pub const CAT_BRADFORD: Mat3 = [
    [0.8951000, 0.2664000, -0.1614000],
    [-0.7502000, 1.7135000, 0.0367000],
    [0.0389000, -0.0685000, 1.0296000],
];

/// colour's `CAT_CAT02`.
pub const CAT_CAT02: Mat3 = [
    [0.7328, 0.4296, -0.1624],
    [-0.7036, 1.6975, 0.0061],
    [0.0030, 0.0136, 0.9834],
];

/// colour's `CAT_VON_KRIES` (Hunt-Pointer-Estévez, normalised to D65).
pub const CAT_VON_KRIES: Mat3 = [
    [0.40024, 0.7076, -0.08081],
    [-0.2263, 1.16532, 0.0457],
    [0.0, 0.0, 0.91822],
];

/// A chromatic adaptation transform.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Cat {
    /// Bradford (Lam 1985).
    Bradford,
    /// CAT02 (CIECAM02); colour's default.
    Cat02,
    /// von Kries with the Hunt-Pointer-Estévez cone fundamentals.
    VonKries,
}

impl Cat {
    /// All transforms.
    pub const ALL: [Cat; 3] = [Cat::Bradford, Cat::Cat02, Cat::VonKries];

    /// Parses `bradford`, `cat02`, `von-kries` / `vonkries` / `von kries` (case-insensitive).
    pub fn from_name(name: &str) -> Result<Cat> {
        let key: String = name
            .trim()
            .to_ascii_lowercase()
            .chars()
            .filter(|c| !matches!(c, '-' | '_' | ' '))
            .collect();
        match key.as_str() {
            "bradford" => Ok(Cat::Bradford),
            "cat02" => Ok(Cat::Cat02),
            "vonkries" => Ok(Cat::VonKries),
            _ => Err(Error::UnknownName {
                kind: "chromatic adaptation transform",
                name: name.to_string(),
                expected: "bradford, cat02, von-kries".into(),
            }),
        }
    }

    /// lumifit's key (`bradford`, `cat02`, `von-kries`).
    pub fn key(self) -> &'static str {
        match self {
            Cat::Bradford => "bradford",
            Cat::Cat02 => "cat02",
            Cat::VonKries => "von-kries",
        }
    }

    /// colour's name (`Bradford`, `CAT02`, `Von Kries`).
    pub fn colour_name(self) -> &'static str {
        match self {
            Cat::Bradford => "Bradford",
            Cat::Cat02 => "CAT02",
            Cat::VonKries => "Von Kries",
        }
    }

    /// The cone-response matrix `M`.
    pub fn matrix(self) -> &'static Mat3 {
        match self {
            Cat::Bradford => &CAT_BRADFORD,
            Cat::Cat02 => &CAT_CAT02,
            Cat::VonKries => &CAT_VON_KRIES,
        }
    }
}

impl std::fmt::Display for Cat {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.key())
    }
}

fn check_white(what: &str, w: [f64; 3]) -> Result<()> {
    if w.iter().all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err(Error::invalid(
            what,
            format!("{w:?}; expected finite tristimulus values"),
        ))
    }
}

/// The 3×3 matrix adapting XYZ seen under the white `xyz_w_src` to the white `xyz_w_dst`
/// (`colour.adaptation.matrix_chromatic_adaptation_VonKries(XYZ_w, XYZ_wr, transform)`).
///
/// Errors when a white is not finite or the source white has a zero cone response (colour would
/// silently produce a zero gain there).
pub fn chromatic_adaptation_matrix(
    xyz_w_src: [f64; 3],
    xyz_w_dst: [f64; 3],
    cat: Cat,
) -> Result<Mat3> {
    check_white("source white", xyz_w_src)?;
    check_white("destination white", xyz_w_dst)?;
    let m = cat.matrix();
    let rgb_w = mat3_mul_vec(m, xyz_w_src);
    let rgb_wr = mat3_mul_vec(m, xyz_w_dst);
    if rgb_w.contains(&0.0) {
        return Err(Error::invalid(
            "source white",
            format!("{xyz_w_src:?} has a zero {cat} cone response; expected a real white"),
        ));
    }
    let d = [
        rgb_wr[0] / rgb_w[0],
        rgb_wr[1] / rgb_w[1],
        rgb_wr[2] / rgb_w[2],
    ];
    let m_inv = mat3_inv(m)?;
    // M⁻¹ · diag(D): scale the columns.
    let mut m_cat = m_inv;
    for row in m_cat.iter_mut() {
        for (j, cell) in row.iter_mut().enumerate() {
            *cell *= d[j];
        }
    }
    Ok(mat3_mul(&m_cat, m))
}

/// Adapts `xyz` from the white `xyz_w_src` to `xyz_w_dst`
/// (`colour.adaptation.chromatic_adaptation_VonKries`).
pub fn adapt(
    xyz: [f64; 3],
    xyz_w_src: [f64; 3],
    xyz_w_dst: [f64; 3],
    cat: Cat,
) -> Result<[f64; 3]> {
    let m = chromatic_adaptation_matrix(xyz_w_src, xyz_w_dst, cat)?;
    Ok(mat3_mul_vec(&m, xyz))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::colorimetry::xyy::xy_to_xyz;

    #[test]
    fn adaptation_maps_the_source_white_to_the_destination_white() {
        let a = xy_to_xyz([0.44758, 0.40745]);
        let d65 = xy_to_xyz([0.3127, 0.329]);
        for cat in Cat::ALL {
            let w = adapt(a, a, d65, cat).unwrap();
            for i in 0..3 {
                assert!((w[i] - d65[i]).abs() < 1e-13, "{cat}");
            }
        }
    }

    #[test]
    fn names_parse_with_and_without_hyphen() {
        assert_eq!(Cat::from_name("von-kries").unwrap(), Cat::VonKries);
        assert_eq!(Cat::from_name("VonKries").unwrap(), Cat::VonKries);
        assert_eq!(Cat::from_name("CAT02").unwrap(), Cat::Cat02);
        assert!(matches!(
            Cat::from_name("cat16"),
            Err(Error::UnknownName { .. })
        ));
    }
}
