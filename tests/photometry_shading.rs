//! Shading a photometric rectangle: every method against the closed-form illuminance of a
//! uniform (Lambertian) emitter, the far-field limit, the light's own plane (§5.3) and the frame
//! convention (C = 0° along +u).

use lumifit::photometry::illuminance::{
    illuminance, lambertian_illuminance, Method, Receiver, RectLight,
};
use lumifit::photometry::{CandelaGrid, PhotometricType};
mod common;
use common::tolerances::photometry_shading::*;

/// Intensity of the Lambertian test profile at γ = 0, cd.
const I0: f64 = 1000.0;
/// Grid step of the Lambertian profile. Linear interpolation of cos γ on 0.1° steps is off by
/// at most h²/8 ≈ 4e-7 relative (more only within a degree of 90°, where cos γ → 0).
const STEP_DEG: f64 = 0.1;

fn lambertian() -> CandelaGrid {
    let n = (90.0 / STEP_DEG).round() as usize;
    let v: Vec<f64> = (0..=n).map(|k| k as f64 * STEP_DEG).collect();
    let cd = v
        .iter()
        .map(|g| I0 * g.to_radians().cos().max(0.0))
        .collect();
    CandelaGrid::new(PhotometricType::C, vec![0.0], v, cd).unwrap()
}

fn light_at(h: f64) -> RectLight {
    RectLight::new([0.0, 0.0, h], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0], 1.0, 1.0).unwrap()
}

fn ground(n: usize, half: f64) -> Vec<Receiver> {
    let mut out = Vec::new();
    for i in 0..n {
        for j in 0..n {
            let x = -half + 2.0 * half * i as f64 / (n - 1) as f64;
            let y = -half + 2.0 * half * j as f64 / (n - 1) as f64;
            out.push(Receiver {
                p: [x + 1e-3, y + 2e-3, 0.0],
                n: [0.0, 0.0, 1.0],
            });
        }
    }
    out
}

fn rel_errors(light: &RectLight, pts: &[Receiver], m: Method) -> Vec<f64> {
    let g = lambertian();
    let l = I0 / light.area();
    let e = illuminance(light, &g, pts, m).unwrap();
    pts.iter()
        .zip(&e)
        .filter_map(|(r, s)| {
            let exact = lambertian_illuminance(light, l, r);
            // points that see almost nothing of the light are judged relative to the maximum
            (exact > 1e-3 * l).then(|| (s.e_lux - exact).abs() / exact)
        })
        .collect()
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

#[test]
fn monte_carlo_agrees_with_lamberts_formula_within_its_standard_error() {
    let g = lambertian();
    let light = light_at(0.5);
    let pts = ground(6, 2.0);
    let e = illuminance(
        &light,
        &g,
        &pts,
        Method::Mc {
            samples: 100_000,
            seed: 7,
        },
    )
    .unwrap();
    let l = I0 / light.area();
    let mut within3 = 0;
    for (r, s) in pts.iter().zip(&e) {
        let exact = lambertian_illuminance(&light, l, r);
        let sd = s.e_std.unwrap();
        let z = (s.e_lux - exact).abs() / sd.max(1e-300);
        assert!(
            z < 5.0,
            "{:?}: mc {} ± {sd} vs exact {exact} (z = {z})",
            r.p,
            s.e_lux
        );
        within3 += usize::from(z <= 3.0);
    }
    // 99.7 % of normal deviates are within 3σ; of 36 points at most 2 may fall outside.
    assert!(
        within3 >= pts.len() - 2,
        "{within3} of {} within 3σ",
        pts.len()
    );
}

#[test]
fn the_papers_cubature_is_within_its_documented_bound_and_adaptive_within_three_percent() {
    let pts = ground(33, 2.0);
    for h in [0.1, 1.0, 2.5] {
        let light = light_at(h);
        let cub = rel_errors(&light, &pts, Method::Cubature);
        let ada = rel_errors(&light, &pts, Method::CubatureAdaptive { tolerance: 0.01 });
        let (cmax, cmed) = (cub.iter().cloned().fold(0.0, f64::max), median(cub.clone()));
        let amax = ada.iter().cloned().fold(0.0, f64::max);
        eprintln!("h = {h}: cubature max {cmax:.4} median {cmed:.4}; adaptive max {amax:.4}");
        if h == 0.1 {
            assert!(
                cmax < CUBATURE_MAX_REL_H01 && cmed < CUBATURE_MEDIAN_REL_H01,
                "h {h}: {cmax} {cmed}"
            );
        } else {
            assert!(cmax < CUBATURE_MAX_REL_H01, "h {h}: {cmax}");
        }
        assert!(amax <= ADAPTIVE_REL, "h {h}: adaptive max error {amax}");
    }
}

#[test]
fn directly_under_a_close_light_eq10_is_low_and_the_refinement_fixes_it() {
    let g = lambertian();
    let light = light_at(0.1);
    let r = [Receiver {
        p: [0.0, 0.0, 0.0],
        n: [0.0, 0.0, 1.0],
    }];
    let exact = lambertian_illuminance(&light, I0, &r[0]);
    let c = illuminance(&light, &g, &r, Method::Cubature).unwrap()[0];
    let a = illuminance(&light, &g, &r, Method::CubatureAdaptive { tolerance: 0.01 }).unwrap()[0];
    let c_err = c.e_lux / exact - 1.0;
    eprintln!(
        "under the light: exact {exact}, cubature {} ({c_err:+.4}), adaptive {} with {} triangles",
        c.e_lux, a.e_lux, a.evaluations
    );
    assert!(
        c_err < -0.2 && c_err > -0.35,
        "the issue's ≈ −28 %: {c_err}"
    );
    assert!((a.e_lux / exact - 1.0).abs() < ADAPTIVE_REL);
    // Eq. 16 for a uniform emitter returns its radiance
    assert!(
        (a.le_bar.unwrap() / I0 - 1.0).abs() < ADAPTIVE_REL,
        "{:?}",
        a.le_bar
    );
}

#[test]
fn far_away_every_method_tends_to_the_point_light() {
    let g = lambertian();
    let light = light_at(100.0);
    let pts = [
        Receiver {
            p: [10.0, -5.0, 0.0],
            n: [0.0, 0.0, 1.0],
        },
        Receiver {
            p: [0.0, 0.0, 0.0],
            n: [0.0, 0.6, 0.8],
        },
    ];
    let point = illuminance(&light, &g, &pts, Method::Point).unwrap();
    for m in [
        Method::Mc {
            samples: 4096,
            seed: 3,
        },
        Method::Structured,
        Method::Mrp,
        Method::Cubature,
        Method::CubatureAdaptive { tolerance: 0.01 },
    ] {
        let e = illuminance(&light, &g, &pts, m).unwrap();
        for (a, b) in e.iter().zip(&point) {
            // integrating methods differ from the point by O((W/d)²) ≈ 1e-4 at 100 m; mrp and
            // structured evaluate single points up to W/2 off centre, O(W/d) ≈ 1e-2 · ½
            assert!(
                (a.e_lux / b.e_lux - 1.0).abs() < 5e-3,
                "{}: {} vs point {}",
                m.name(),
                a.e_lux,
                b.e_lux
            );
        }
    }
}

#[test]
fn receivers_in_the_lights_own_plane_get_a_finite_continuous_cubature() {
    // isotropic profile: I = I0 in every direction; the exact E is (I0/A) ∫ cos/r² dA, here by
    // a 400 × 400 midpoint rule (smooth integrand, error ≪ 1e-4 at 2 m).
    let v: Vec<f64> = (0..=180).map(|k| k as f64).collect();
    let g = CandelaGrid::new(PhotometricType::C, vec![0.0], v.clone(), vec![I0; v.len()]).unwrap();
    let light = light_at(0.0);
    let exact_at = |p: [f64; 3], n: [f64; 3]| {
        let k = 400;
        let mut s = 0.0;
        for i in 0..k {
            for j in 0..k {
                let q = [
                    -0.5 + (i as f64 + 0.5) / k as f64,
                    -0.5 + (j as f64 + 0.5) / k as f64,
                    0.0,
                ];
                let d = [q[0] - p[0], q[1] - p[1], q[2] - p[2]];
                let r2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
                let c = (d[0] * n[0] + d[1] * n[1] + d[2] * n[2]) / r2.sqrt();
                s += I0 * c.max(0.0) / r2;
            }
        }
        s / (k * k) as f64
    };
    let n = [-1.0, 0.0, 0.0];
    let exact = exact_at([2.0, 0.0, 0.0], n);
    for dz in [0.0, 1e-12, 1e-7, -1e-7] {
        let r = [Receiver {
            p: [2.0, 0.0, dz],
            n,
        }];
        let c = illuminance(&light, &g, &r, Method::Cubature).unwrap()[0].e_lux;
        let a = illuminance(&light, &g, &r, Method::CubatureAdaptive { tolerance: 0.01 }).unwrap()
            [0]
        .e_lux;
        assert!(c.is_finite() && a.is_finite());
        assert!(
            (a / exact - 1.0).abs() < ADAPTIVE_REL,
            "dz {dz}: adaptive {a} vs {exact}"
        );
        assert!(
            (c / exact - 1.0).abs() < 0.05,
            "dz {dz}: cubature {c} vs {exact}"
        );
    }
}

#[test]
fn c_zero_points_along_u_and_c_ninety_along_v() {
    // light only in the C = 0° half-plane (I = 100 cd at C 0, 0 at C 90/180/270)
    let v: Vec<f64> = vec![0.0, 90.0];
    let mut cd = vec![0.0; 8];
    cd[0] = 100.0;
    cd[1] = 100.0;
    let g = CandelaGrid::new(PhotometricType::C, vec![0.0, 90.0, 180.0, 270.0], v, cd).unwrap();
    // light facing down, up = +y so u = +y and v = n × u = (0,0,−1) × (0,1,0) = (1,0,0)
    let light =
        RectLight::new([0.0, 0.0, 1.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0], 0.2, 0.2).unwrap();
    assert_eq!(light.v, [1.0, 0.0, 0.0]);
    let on_u = Receiver {
        p: [0.0, 1.0, 0.0],
        n: [0.0, 0.0, 1.0],
    };
    let on_minus_u = Receiver {
        p: [0.0, -1.0, 0.0],
        n: [0.0, 0.0, 1.0],
    };
    let on_v = Receiver {
        p: [1.0, 0.0, 0.0],
        n: [0.0, 0.0, 1.0],
    };
    for m in [Method::Point, Method::Cubature] {
        let e = illuminance(&light, &g, &[on_u, on_minus_u, on_v], m).unwrap();
        assert!(
            e[0].e_lux > 10.0 * e[1].e_lux.max(1e-9),
            "{}: {:?}",
            m.name(),
            e
        );
        assert!(e[0].e_lux > 1.5 * e[2].e_lux, "{}: {:?}", m.name(), e);
    }
}

#[test]
fn on_a_real_profile_the_adaptive_cubature_agrees_with_monte_carlo() {
    // Prolicht E30 (lidrs example.ldt, real measurement with up-light) as a 1 × 1 m emitter 0.25 m
    // above the ground and beside a wall; MC at 2·10⁵ samples is the unbiased reference.
    let d = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/data/photometric/lidrs_MIT/example.ldt");
    if !d.is_file() {
        assert!(
            std::env::var("LUMIFIT_REQUIRE_DATA").as_deref() != Ok("1"),
            "LUMIFIT_REQUIRE_DATA=1 but {} is absent",
            d.display()
        );
        eprintln!("skipping: {} is absent", d.display());
        return;
    }
    let f = lumifit::io::read_photometric(&d, 0.0).unwrap();
    let g = &f.photometry.grid;
    let light = light_at(0.25);
    let pts = [
        Receiver {
            p: [0.0, 0.0, 0.0],
            n: [0.0, 0.0, 1.0],
        },
        Receiver {
            p: [0.4, -0.3, 0.0],
            n: [0.0, 0.0, 1.0],
        },
        Receiver {
            p: [1.5, 0.5, 0.0],
            n: [0.0, 0.0, 1.0],
        },
        // a wall at x = 0.8 facing the light, at the light's height and above it (up-light)
        Receiver {
            p: [0.8, 0.0, 0.25],
            n: [-1.0, 0.0, 0.0],
        },
        Receiver {
            p: [0.8, 0.1, 0.6],
            n: [-1.0, 0.0, 0.0],
        },
    ];
    let mc = illuminance(
        &light,
        g,
        &pts,
        Method::Mc {
            samples: 200_000,
            seed: 11,
        },
    )
    .unwrap();
    let ad = illuminance(
        &light,
        g,
        &pts,
        Method::CubatureAdaptive { tolerance: 0.01 },
    )
    .unwrap();
    let cu = illuminance(&light, g, &pts, Method::Cubature).unwrap();
    for ((m, a), c) in mc.iter().zip(&ad).zip(&cu) {
        let sd = m.e_std.unwrap();
        eprintln!(
            "mc {:.4} ± {sd:.4}, adaptive {:.4} ({:+.4}), cubature {:.4} ({:+.4})",
            m.e_lux,
            a.e_lux,
            a.e_lux / m.e_lux - 1.0,
            c.e_lux,
            c.e_lux / m.e_lux - 1.0
        );
        // 3 % (the bound) plus the reference's own 3σ
        assert!(
            (a.e_lux - m.e_lux).abs() <= ADAPTIVE_REL * m.e_lux + 3.0 * sd,
            "adaptive {} vs mc {} ± {sd}",
            a.e_lux,
            m.e_lux
        );
    }
}
