//! CIE xyY chromaticity and the CIE 1960 UCS uv chromaticity.
//!
//! Equations (XYZ dimensionless, on colour-science's 0–1 "reference" scale):
//!
//! - xyY: `x = X / (X + Y + Z)`, `y = Y / (X + Y + Z)`, `Y = Y`; back: `X = x·Y/y`,
//!   `Z = (1 − x − y)·Y/y`.
//! - CIE 1960 UCS: `U = 2X/3`, `V = Y`, `W = (−X + 3Y + Z)/2`, `u = U/(U+V+W)`, `v = V/(U+V+W)`;
//!   from xy directly `u = 4x / (−2x + 12y + 3)`, `v = 6y / (−2x + 12y + 3)`, and back
//!   `x = 3u / (2u − 8v + 4)`, `y = 2v / (2u − 8v + 4)`.
//!
//! Reference: CIE 015:2018 *Colorimetry*, §7.3 and §8.1; Wyszecki & Stiles (2000) §3.3.
//!
//! colour-science counterparts: `colour.XYZ_to_xyY`, `xyY_to_XYZ`, `XYZ_to_xy`, `xy_to_XYZ`,
//! `colour.models.xy_to_UCS_uv`, `UCS_uv_to_xy`, `UCS_to_uv(XYZ_to_UCS(XYZ))`. Divisions follow
//! colour's default "Ignore Zero Conversion" mode: a division whose result is not finite
//! (0/0, x/0) yields 0. The one deliberate extension is [`xyz_to_xyy`]'s `black_xy`: colour 0.4.7
//! returns `(0, 0, 0)` for black; pass `[0.0, 0.0]` to reproduce that, or the illuminant's xy
//! (colour ≤ 0.3 behaviour) to keep black on the white point.

/// colour's "Ignore Zero Conversion" division: `a / b`, or 0 when that is not finite.
pub(crate) fn sdiv(a: f64, b: f64) -> f64 {
    let c = a / b;
    if c.is_finite() {
        c
    } else {
        0.0
    }
}

/// XYZ → xyY (`colour.XYZ_to_xyY`). When `X + Y + Z = 0` the chromaticity is undefined and
/// `black_xy` is returned with the given Y (colour 0.4.7 itself returns x = y = 0, i.e.
/// `black_xy = [0.0, 0.0]`).
pub fn xyz_to_xyy(xyz: [f64; 3], black_xy: [f64; 2]) -> [f64; 3] {
    let [x_, y_, z_] = xyz;
    let sum = x_ + y_ + z_;
    if sum == 0.0 {
        return [black_xy[0], black_xy[1], y_];
    }
    [sdiv(x_, sum), sdiv(y_, sum), y_]
}

/// xyY → XYZ (`colour.xyY_to_XYZ`); y = 0 gives X = Z = 0 as in colour.
pub fn xyy_to_xyz(xyy: [f64; 3]) -> [f64; 3] {
    let [x, y, big_y] = xyy;
    let y_y = sdiv(big_y, y);
    [x * y_y, big_y, (1.0 - (x + y)) * y_y]
}

/// XYZ → xy (`colour.XYZ_to_xy`), with `black_xy` as in [`xyz_to_xyy`].
pub fn xyz_to_xy(xyz: [f64; 3], black_xy: [f64; 2]) -> [f64; 2] {
    let xyy = xyz_to_xyy(xyz, black_xy);
    [xyy[0], xyy[1]]
}

/// xy → XYZ with Y = 1 (`colour.xy_to_XYZ`), e.g. a white point's tristimulus values.
pub fn xy_to_xyz(xy: [f64; 2]) -> [f64; 3] {
    xyy_to_xyz([xy[0], xy[1], 1.0])
}

/// xy → CIE 1960 UCS uv (`colour.models.xy_to_UCS_uv`).
pub fn xy_to_uv_1960(xy: [f64; 2]) -> [f64; 2] {
    let [x, y] = xy;
    let d = 12.0 * y - 2.0 * x + 3.0;
    [sdiv(4.0 * x, d), sdiv(6.0 * y, d)]
}

/// CIE 1960 UCS uv → xy (`colour.models.UCS_uv_to_xy`).
pub fn uv_1960_to_xy(uv: [f64; 2]) -> [f64; 2] {
    let [u, v] = uv;
    let d = 2.0 * u - 8.0 * v + 4.0;
    [sdiv(3.0 * u, d), sdiv(2.0 * v, d)]
}

/// XYZ → CIE 1960 UCS uv (`colour.UCS_to_uv(colour.XYZ_to_UCS(XYZ))`).
pub fn xyz_to_uv_1960(xyz: [f64; 3]) -> [f64; 2] {
    let [x_, y_, z_] = xyz;
    let u_ = 2.0 / 3.0 * x_;
    let v_ = y_;
    let w_ = 1.0 / 2.0 * (-x_ + 3.0 * y_ + z_);
    let s = u_ + v_ + w_;
    [sdiv(u_, s), sdiv(v_, s)]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn xyy_round_trips_and_black_keeps_the_given_chromaticity() {
        let xyz = [0.2065, 0.1219, 0.0514];
        let back = xyy_to_xyz(xyz_to_xyy(xyz, [0.0, 0.0]));
        for i in 0..3 {
            assert!((back[i] - xyz[i]).abs() < 1e-15);
        }
        assert_eq!(xyz_to_xyy([0.0; 3], [0.3127, 0.329]), [0.3127, 0.329, 0.0]);
        assert_eq!(xyy_to_xyz([0.3, 0.0, 0.5]), [0.0, 0.5, 0.0]);
    }

    #[test]
    fn uv_1960_inverts_xy_and_agrees_with_the_ucs_route() {
        let xy = [0.3127, 0.329];
        let uv = xy_to_uv_1960(xy);
        let back = uv_1960_to_xy(uv);
        assert!((back[0] - xy[0]).abs() < 1e-15 && (back[1] - xy[1]).abs() < 1e-15);
        let uv2 = xyz_to_uv_1960(xy_to_xyz(xy));
        assert!((uv2[0] - uv[0]).abs() < 1e-15 && (uv2[1] - uv[1]).abs() < 1e-15);
    }
}
