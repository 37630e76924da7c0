//! The afterimage model of Mikamo et al. 2013: curves against Table 1 and Eq. 3, and the
//! measured properties of the frames (patch centre on the Table 1 track, luminance following
//! Y_M(t)/Y_M(0), Weve's convergence, Reidenbach's early colour, scale invariance, mask, dark
//! adaptation, bad input).

// Channel loops index RGB triplets as the equations do; `!(a > b)` comparisons deliberately
// reject NaN along with out-of-range values.
#![allow(clippy::needless_range_loop, clippy::neg_cmp_op_on_partial_ord)]

use lumifit::afterimage::mikamo2013::{
    display_matrices, gamut_correct, lab_to_display_rgb, rgb_to_xyy, REFERENCE_XY_TABLE1,
    TABLE1_T_S, TABLE1_XY,
};
use lumifit::afterimage::{
    curve_point, curves, luminance_y, time_grid, DarkAdaptation, LinearImage, MaskRule,
    SynthParams, Synthesizer, TimeRange,
};
use lumifit::colorimetry::lab::xyz_to_lab;
use lumifit::colorimetry::rgb::D65_XY;
use lumifit::colorimetry::xyy::{xy_to_xyz, xyy_to_xyz};
use lumifit::io::hdr_image::linear_to_srgb16;
use lumifit::math::linalg::mat3_mul_vec;
mod common;
use common::tolerances::afterimage::*;

/// The model's display matrices (rgb_to_xyz, xyz_to_rgb).
struct Space {
    matrix_rgb_to_xyz: lumifit::math::linalg::Mat3,
    matrix_xyz_to_rgb: lumifit::math::linalg::Mat3,
}

fn srgb() -> Space {
    let (a, b) = display_matrices().unwrap();
    Space {
        matrix_rgb_to_xyz: a,
        matrix_xyz_to_rgb: b,
    }
}

/// Linear sRGB of chromaticity `xy` at luminance `y`.
fn rgb_of(xy: [f64; 2], y: f64) -> [f64; 3] {
    mat3_mul_vec(&srgb().matrix_xyz_to_rgb, xyy_to_xyz([xy[0], xy[1], y]))
}

/// A `w × h` black image with square patches `(cx, cy, half side, linear rgb)`.
fn patches(w: usize, h: usize, list: &[(usize, usize, usize, [f64; 3])]) -> LinearImage {
    let mut rgb = vec![0f32; 3 * w * h];
    for &(cx, cy, r, c) in list {
        for y in cy - r..cy + r {
            for x in cx - r..cx + r {
                for k in 0..3 {
                    rgb[3 * (y * w + x) + k] = c[k] as f32;
                }
            }
        }
    }
    LinearImage::new("patches", w, h, rgb).unwrap()
}

fn pixel(img: &LinearImage, x: usize, y: usize) -> [f64; 3] {
    let i = 3 * (y * img.width + x);
    [0, 1, 2].map(|c| f64::from(img.rgb[i + c]))
}

fn xy_dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    (a[0] - b[0]).hypot(a[1] - b[1])
}

#[test]
fn curves_reproduce_table_1_exactly_and_eq_3_to_1e_12() {
    let pts = curves(&TABLE1_T_S, TimeRange::Measured).unwrap();
    for (p, xy) in pts.iter().zip(TABLE1_XY) {
        assert_eq!([p.x, p.y], xy, "t = {}", p.t_s);
        let eq3 = if p.t_s <= 22.0 {
            (-0.083 * p.t_s - 0.978).exp()
        } else {
            (-0.055 * p.t_s - 1.584).exp()
        };
        assert!((p.big_y - eq3).abs() <= EQ3_TOL * eq3, "t = {}", p.t_s);
        let lab = xyz_to_lab(xyy_to_xyz([xy[0], xy[1], eq3]), D65_XY).unwrap();
        for c in 0..3 {
            assert!((p.lab[c] - lab[c]).abs() < 1e-9, "t = {} Lab {c}", p.t_s);
        }
    }
    // Printed values: Y_M(0) = e^−0.978, Y_M(80) = e^−5.984.
    assert!((luminance_y(0.0) - 0.376_062_472).abs() < 1e-9);
    assert!((luminance_y(80.0) - 0.002_518_731).abs() < 1e-9);
    // τ = L_M / L_M(0): 1 at 0, and at 80 s the ratio of the lightnesses.
    assert_eq!(pts[0].tau, 1.0);
    assert!((pts[20].tau - pts[20].lab[0] / pts[0].lab[0]).abs() < 1e-15);
}

#[test]
fn the_fine_grid_passes_through_every_table_time_and_interpolates_smoothly() {
    let grid = time_grid(0.1, 80.0).unwrap();
    assert_eq!(grid.len(), 801);
    for t in TABLE1_T_S {
        assert!(grid.contains(&t), "{t} s not on the grid");
    }
    let pts = curves(&grid, TimeRange::Measured).unwrap();
    // Catmull-Rom is C¹: no jump between neighbours larger than the table's steepest segment
    // allows (max |Δx| over 4 s is 0.09 → ≤ 0.0045 per 0.1 s with overshoot margin ×2).
    for w in pts.windows(2) {
        assert!((w[1].x - w[0].x).abs() < 0.009 && (w[1].y - w[0].y).abs() < 0.009);
    }
    // Between samples the curve leaves the chords (it is not linear interpolation).
    let mid = curve_point(6.0).unwrap();
    assert!(((mid.x - 0.345).abs() + (mid.y - 0.51).abs()) > 1e-4);
}

#[test]
fn times_outside_0_80_s_are_refused_unless_extrapolating() {
    let e = curves(&[81.0], TimeRange::Measured).unwrap_err();
    assert!(e.to_string().contains("--extrapolate"), "{e}");
    assert!(curves(&[-1.0], TimeRange::Extrapolate).is_err());
    let p = curves(&[120.0], TimeRange::Extrapolate).unwrap();
    assert_eq!([p[0].x, p[0].y], TABLE1_XY[20]);
    assert!((p[0].big_y - (-0.055f64 * 120.0 - 1.584).exp()).abs() < 1e-15);
}

/// Reference-chromaticity patch at the image's maximum luminance: at its centre the frame's
/// chromaticity is the Table 1 track where that is inside the sRGB gamut, and gamut-corrected
/// (a channel at 0, luminance kept) where it is not; its luminance follows Y_M(t)/Y_M(0).
#[test]
fn a_reference_patch_follows_the_table_1_track_and_y_m_at_its_centre() {
    let img = patches(160, 120, &[(80, 60, 40, rgb_of(REFERENCE_XY_TABLE1, 1.0))]);
    let params = SynthParams {
        blur_sigma_px: 4.0,
        ..SynthParams::default()
    };
    let syn = Synthesizer::new(&img, "patches", None, params).unwrap();
    let y0 = rgb_to_xyy(pixel(&syn.frame(0.0).unwrap(), 80, 60)).unwrap()[2];
    assert!(
        (y0 - luminance_y(0.0)).abs() < F32_TOL,
        "Y(0) = {y0} vs {}",
        luminance_y(0.0)
    );
    let (mut inside, mut outside) = (0, 0);
    for (t, xy) in TABLE1_T_S.iter().zip(TABLE1_XY) {
        let c = pixel(&syn.frame(*t).unwrap(), 80, 60);
        let xyy = rgb_to_xyy(c).unwrap();
        let ratio = xyy[2] / y0;
        let want = luminance_y(*t) / luminance_y(0.0);
        assert!(
            (ratio - want).abs() < F32_TOL * want.max(1e-2) * 10.0,
            "t = {t}: Y ratio {ratio} vs {want}"
        );
        let track = rgb_of(xy, luminance_y(*t));
        if track.iter().all(|&v| v >= 0.0) {
            inside += 1;
            assert!(
                (xyy[0] - xy[0]).abs() < F32_TOL * 10.0 && (xyy[1] - xy[1]).abs() < F32_TOL * 10.0,
                "t = {t}: xy ({}, {}) vs Table 1 {xy:?}",
                xyy[0],
                xyy[1]
            );
        } else {
            outside += 1;
            let min = c.iter().cloned().fold(f64::INFINITY, f64::min);
            assert!(
                min.abs() < 1e-7,
                "t = {t}: corrected colour {c:?} keeps no channel at 0"
            );
            assert!(
                c.iter().all(|&v| v >= 0.0),
                "t = {t}: negative channel {c:?}"
            );
        }
    }
    println!(
        "Table 1 points inside the sRGB gamut: {inside}, outside (gamut-corrected): {outside}"
    );
    assert!(
        inside >= 5 && outside >= 5,
        "{inside} inside, {outside} outside"
    );
}

#[test]
fn gamut_correction_clamps_negatives_and_restores_the_luminance() {
    let space = srgb();
    let white = xy_to_xyz(D65_XY);
    // A saturated blue-violet beyond the sRGB triangle at L* = 40.
    let lab = [40.0, 60.0, -110.0];
    let raw = mat3_mul_vec(
        &space.matrix_xyz_to_rgb,
        lumifit::colorimetry::lab::lab_to_xyz(lab, D65_XY).unwrap(),
    );
    assert!(
        raw.iter().any(|&v| v < 0.0),
        "test colour must be out of gamut"
    );
    let c = gamut_correct(
        lab,
        white,
        &space.matrix_xyz_to_rgb,
        &space.matrix_rgb_to_xyz,
    );
    assert!(c.iter().all(|&v| v >= 0.0));
    let l = xyz_to_lab(mat3_mul_vec(&space.matrix_rgb_to_xyz, c), D65_XY).unwrap()[0];
    assert!((l - 40.0).abs() < 1e-9, "L* {l}");
    // In-gamut colours pass unchanged.
    let inside = [50.0, 5.0, 5.0];
    let a = lab_to_display_rgb(inside).unwrap();
    let b = mat3_mul_vec(
        &space.matrix_xyz_to_rgb,
        lumifit::colorimetry::lab::lab_to_xyz(inside, D65_XY).unwrap(),
    );
    for k in 0..3 {
        assert!((a[k] - b[k]).abs() < 1e-12);
    }
}

/// Weve (1925): afterimages of different stimulus colours converge to one sequence. Two patches
/// of very different colour at the same (maximum) luminance: the xy distance between their
/// frames falls as τ falls.
#[test]
fn trajectories_from_different_colours_converge_as_tau_falls() {
    let red = rgb_of([0.55, 0.33], 1.0);
    let blue = rgb_of([0.20, 0.20], 1.0);
    let img = patches(200, 100, &[(50, 50, 30, red), (150, 50, 30, blue)]);
    let syn = Synthesizer::new(&img, "patches", None, SynthParams::default()).unwrap();
    let d = |t: f64| {
        let f = syn.frame(t).unwrap();
        xy_dist(
            rgb_to_xyy(pixel(&f, 50, 50)).unwrap(),
            rgb_to_xyy(pixel(&f, 150, 50)).unwrap(),
        )
    };
    let ds: Vec<(f64, f64)> = [0.0, 8.0, 16.0, 24.0, 32.0, 40.0, 60.0, 80.0]
        .iter()
        .map(|&t| (t, d(t)))
        .collect();
    println!("xy distance between the red and blue afterimages: {ds:?}");
    let d0 = ds[0].1;
    assert!(d0 > 0.02, "the stimuli must start apart: {d0}");
    for &(t, dt) in &ds[1..] {
        assert!(
            dt < d0,
            "t = {t}: distance {dt} not below the t = 0 distance {d0}"
        );
    }
    assert!(ds[7].1 < 0.5 * d0, "no convergence by 80 s: {ds:?}");
}

/// Reidenbach (2008): the first colours resemble the stimulus; a larger k makes the t = 0 frame
/// closer to the stimulus colour.
#[test]
fn larger_k_starts_closer_to_the_stimulus_colour() {
    let green_xy = [0.30, 0.55];
    let img = patches(100, 100, &[(50, 50, 30, rgb_of(green_xy, 1.0))]);
    let stim = [green_xy[0], green_xy[1], 0.0];
    let mut last = f64::INFINITY;
    let mut seen = Vec::new();
    for k in [0.0, 0.05, 0.2, 0.5, 1.0] {
        let params = SynthParams {
            k,
            ..SynthParams::default()
        };
        let syn = Synthesizer::new(&img, "patches", None, params).unwrap();
        let xyy = rgb_to_xyy(pixel(&syn.frame(0.0).unwrap(), 50, 50)).unwrap();
        let d = xy_dist(xyy, stim);
        seen.push((k, d));
        assert!(
            d < last,
            "k = {k}: distance {d} not below {last} ({seen:?})"
        );
        last = d;
    }
    println!("xy distance to the stimulus at t = 0 by k: {seen:?}");
    // k = 0 starts on Table 1's first point whatever the stimulus.
    let xyy0 = seen[0].1;
    assert!((xyy0 - xy_dist([0.41, 0.42, 0.0], stim)).abs() < 1e-5);
}

/// HDR inputs of any scale give the same frames: the input is normalised to its brightest
/// pixel before the Lab conversions.
#[test]
fn scaling_an_hdr_input_does_not_change_the_frames() {
    let base = patches(
        120,
        80,
        &[
            (30, 40, 20, rgb_of([0.45, 0.41], 1.0)),
            (90, 40, 15, rgb_of([0.25, 0.30], 0.3)),
        ],
    );
    let scaled = |s: f32| LinearImage {
        rgb: base.rgb.iter().map(|v| v * s).collect(),
        ..base.clone()
    };
    let params = SynthParams {
        blur_sigma_px: 2.0,
        mask: MaskRule { threshold: 0.1 },
        ..SynthParams::default()
    };
    let reference = Synthesizer::new(&base, "x1", None, params).unwrap();
    for s in [1e-3f32, 4.0, 1e4] {
        let other = Synthesizer::new(&scaled(s), "xs", None, params).unwrap();
        for t in [0.0, 20.0, 56.0] {
            let a = reference.frame(t).unwrap();
            let b = other.frame(t).unwrap();
            let max_code = a
                .rgb
                .iter()
                .zip(&b.rgb)
                .map(|(p, q)| {
                    (i32::from(linear_to_srgb16(*p)) - i32::from(linear_to_srgb16(*q))).abs()
                })
                .max()
                .unwrap();
            assert!(
                max_code <= 1,
                "scale {s}, t = {t}: 16-bit codes differ by {max_code}"
            );
        }
    }
}

#[test]
fn pixels_below_the_mask_threshold_make_no_afterimage() {
    let img = patches(
        80,
        40,
        &[(20, 20, 10, [1.0, 1.0, 1.0]), (60, 20, 10, [0.3, 0.3, 0.3])],
    );
    let params = SynthParams {
        mask: MaskRule { threshold: 0.5 },
        ..SynthParams::default()
    };
    let syn = Synthesizer::new(&img, "patches", None, params).unwrap();
    assert!(syn.mask()[20 * 80 + 20] && !syn.mask()[20 * 80 + 60]);
    let f = syn.frame(0.0).unwrap();
    assert_eq!(pixel(&f, 60, 20), [0.0; 3]);
    assert!(pixel(&f, 20, 20)[1] > 0.05);
    // Threshold 0.2 takes the grey patch in, with a weaker afterimage (Z < 1).
    let params = SynthParams {
        mask: MaskRule { threshold: 0.2 },
        ..SynthParams::default()
    };
    let f = Synthesizer::new(&img, "patches", None, params)
        .unwrap()
        .frame(0.0)
        .unwrap();
    let (dim, bright) = (pixel(&f, 60, 20), pixel(&f, 20, 20));
    assert!(dim[1] > 0.0 && dim[1] < bright[1]);
}

#[test]
fn the_background_dark_adapts_by_eq_7() {
    let img = patches(40, 40, &[(20, 20, 5, [1.0, 1.0, 1.0])]);
    let bg = LinearImage::new("bg", 40, 40, vec![0.5f32; 3 * 40 * 40]).unwrap();
    let dark = DarkAdaptation {
        constant: 0.1,
        time_s: 10.0,
    };
    let params = SynthParams {
        dark,
        ..SynthParams::default()
    };
    let syn = Synthesizer::new(&img, "patches", Some(bg), params).unwrap();
    for t in [0.0, 10.0, 80.0] {
        let v = pixel(&syn.frame(t).unwrap(), 2, 2)[0];
        let want = 0.5 * (1.0 - 0.9 * (-t / 10.0f64).exp());
        assert!((v - want).abs() < 1e-6, "t = {t}: {v} vs {want}");
    }
    let wrong = LinearImage::new("bg", 20, 40, vec![0.5f32; 3 * 20 * 40]).unwrap();
    let e = Synthesizer::new(&img, "patches", Some(wrong), params).unwrap_err();
    assert!(e.to_string().contains("--background"), "{e}");
}

#[test]
fn bad_parameters_and_black_images_are_refused_by_name() {
    let black = LinearImage::new("black.png", 10, 10, vec![0.0; 300]).unwrap();
    let e = Synthesizer::new(&black, "black.png", None, SynthParams::default()).unwrap_err();
    assert!(
        e.to_string().contains("black.png") && e.to_string().contains("L_on^max"),
        "{e}"
    );
    let img = patches(10, 10, &[(5, 5, 2, [1.0, 1.0, 1.0])]);
    for (flag, p) in [
        (
            "--gamma",
            SynthParams {
                gamma: -0.1,
                ..SynthParams::default()
            },
        ),
        (
            "--k",
            SynthParams {
                k: -1.0,
                ..SynthParams::default()
            },
        ),
        (
            "--mask-threshold",
            SynthParams {
                mask: MaskRule { threshold: 1.5 },
                ..SynthParams::default()
            },
        ),
    ] {
        let e = Synthesizer::new(&img, "img", None, p).unwrap_err();
        assert!(e.to_string().contains(flag), "{flag}: {e}");
    }
    let syn = Synthesizer::new(&img, "img", None, SynthParams::default()).unwrap();
    assert!(syn.frame(80.5).is_err());
    assert!(LinearImage::new("empty", 0, 0, vec![]).is_err());
}
