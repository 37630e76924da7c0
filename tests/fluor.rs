//! Fluorescence (Fichet et al. 2024): algebraic properties of the reductions, the BFC-450 reader,
//! and agreement with the independent numpy implementation
//! (`scripts/reference/fluor_numpy_reference.py` → `fixtures/fluor/reference.json`).
//!
//! Tests that need the measured data read `../shared/data/fluorescence` in place and print a
//! skip message (and pass) when it is absent.

use std::path::{Path, PathBuf};

use lumifit::colorimetry::{Illuminant, Observer, StandardObserver};
use lumifit::fluor::basis::{bspline_basis, U_KNOTS_NM};
use lumifit::fluor::evaluate::{dual_check, spectral_reference};
use lumifit::fluor::{
    evaluate, illuminant_on_grid, parse_bfc, parse_donaldson, parse_donaldson_csv, reduce,
    reduce_fichet2024, reduce_naive_hullin2010, select_basis, Basis, BasisKind, GridIlluminant,
    Method, OperatorMatrix, Reduction, ResampleOptions, WorkingGrid, DEFAULT_ILLUMINANTS,
    DEFAULT_METHODS,
};
use lumifit::spectrum::MultiSpectrum;
use lumifit::table::parse_numeric_csv;
use nalgebra::{DMatrix, DVector};
mod common;
use common::tolerances::fluor::*;

fn data_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data/fluorescence")
}

fn fixture_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/fluor")
}

fn shared_or_skip(test: &str) -> Option<PathBuf> {
    let d = data_dir();
    if d.is_dir() {
        Some(d)
    } else {
        eprintln!(
            "SKIP {test}: {} is absent (measured fluorescence data not available)",
            d.display()
        );
        None
    }
}

fn cmfs() -> MultiSpectrum {
    Observer::standard(StandardObserver::Cie2015_2)
        .unwrap()
        .cmfs()
        .clone()
}

fn measured_files(dir: &Path) -> Vec<PathBuf> {
    let mut v = Vec::new();
    for sub in ["rit_gonzalez_bfc", "labsphere_3m_postit"] {
        for e in std::fs::read_dir(dir.join(sub)).unwrap() {
            let p = e.unwrap().path();
            if p.extension().is_some_and(|x| x.eq_ignore_ascii_case("bfc")) {
                v.push(p);
            }
        }
    }
    v.sort();
    v
}

fn load(path: &Path) -> lumifit::fluor::DonaldsonMatrix {
    let bytes = std::fs::read(path).unwrap();
    parse_donaldson(&bytes, &path.display().to_string()).unwrap()
}

fn max_abs_diff(a: &DMatrix<f64>, b: &DMatrix<f64>) -> f64 {
    (a - b).abs().max()
}

fn all_bases(grid: &WorkingGrid) -> Vec<Basis> {
    BasisKind::ALL
        .iter()
        .map(|k| k.build(&cmfs(), grid).unwrap())
        .collect()
}

#[test]
fn the_dual_basis_satisfies_st_times_dual_equals_identity_for_every_built_in_basis() {
    let grid = WorkingGrid::default();
    for b in all_bases(&grid) {
        let k = b.k();
        let err = max_abs_diff(&dual_check(&b).unwrap(), &DMatrix::identity(k, k));
        assert!(err < ALGEBRA_TOL, "{}: |SᵀS̃ − I| = {err:e}", b.name());
    }
}

#[test]
fn an_identity_donaldson_matrix_reduces_to_the_identity_in_every_basis() {
    let grid = WorkingGrid::default();
    let id = OperatorMatrix::identity("identity", grid);
    for b in all_bases(&grid) {
        let p = reduce_fichet2024(&id, &b).unwrap().p;
        let err = max_abs_diff(&p, &DMatrix::identity(b.k(), b.k()));
        assert!(err < ALGEBRA_TOL, "{}: |P − I| = {err:e}", b.name());
    }
}

#[test]
fn the_naive_reduction_of_the_identity_is_the_cosine_matrix_not_the_identity() {
    let grid = WorkingGrid::default();
    let id = OperatorMatrix::identity("identity", grid);
    let b = Basis::xyz(&cmfs(), &grid).unwrap();
    let p = reduce_naive_hullin2010(&id, &b).unwrap().p;
    for k in 0..3 {
        assert!((p[(k, k)] - 1.0).abs() < ALGEBRA_TOL);
    }
    assert!(
        p[(0, 1)] > 0.5,
        "x̄ and ȳ overlap strongly, cos = {}",
        p[(0, 1)]
    );
}

fn smooth_reflectance(grid: &WorkingGrid) -> Vec<f64> {
    grid.wavelengths()
        .iter()
        .map(|&l| 0.2 + 0.6 / (1.0 + (-(l - 560.0) / 25.0).exp()))
        .collect()
}

#[test]
fn a_diagonal_matrix_reduces_to_reflectance_rendering_of_the_upsampled_light() {
    // P c = down[r · up[c]] exactly: the reduced matrix of a non-fluorescent material renders the
    // reflectance under the light reconstructed in the basis.
    let grid = WorkingGrid::default();
    let r = smooth_reflectance(&grid);
    let op = OperatorMatrix::diagonal("diag", grid, &r).unwrap();
    for b in all_bases(&grid) {
        let p = reduce_fichet2024(&op, &b).unwrap().p;
        let c = DVector::from_fn(b.k(), |i, _| 1.0 + 0.3 * i as f64);
        let up = b.dual().unwrap() * &c;
        let reflected = DVector::from_fn(up.len(), |i, _| r[i] * up[i]);
        let expected = b.functions().transpose() * reflected;
        let err = (&p * &c - &expected).abs().max() / expected.abs().max();
        assert!(err < ALGEBRA_TOL, "{}: {err:e}", b.name());
    }
}

#[test]
fn a_grey_diagonal_matrix_reduces_to_the_grey_times_identity() {
    let grid = WorkingGrid::default();
    let op = OperatorMatrix::diagonal("grey", grid, &vec![0.37; grid.len()]).unwrap();
    for b in all_bases(&grid) {
        let p = reduce_fichet2024(&op, &b).unwrap().p;
        let err = max_abs_diff(&p, &(DMatrix::identity(b.k(), b.k()) * 0.37));
        assert!(err < ALGEBRA_TOL, "{}: {err:e}", b.name());
    }
}

#[test]
fn a_diagonal_matrix_under_a_light_in_the_basis_span_matches_ordinary_reflectance_rendering() {
    // Light e = S̃ c lies in the span of the basis: the reduced one-bounce XYZ equals the spectral
    // XYZ of the reflectance, Σ s̄ r e, which is what a reflectance-only renderer would compute.
    let grid = WorkingGrid::default();
    let r = smooth_reflectance(&grid);
    let op = OperatorMatrix::diagonal("diag", grid, &r).unwrap();
    let xyz = Basis::xyz(&cmfs(), &grid).unwrap();
    for b in all_bases(&grid) {
        let c = DVector::from_fn(b.k(), |i, _| 50.0 + 10.0 * i as f64);
        let e = b.dual().unwrap() * c;
        let ill = GridIlluminant {
            name: "in-span".into(),
            values: e.iter().copied().collect(),
        };
        let red = reduce(&op, &b, Reduction::Dual).unwrap();
        let reference = spectral_reference(&op, &ill, &xyz).unwrap();
        let reduced = lumifit::fluor::evaluate::reduced_xyz(&red, &b, &ill, &reference);
        let k = reference.scale;
        let by_hand: Vec<f64> = (0..3)
            .map(|ch| {
                k * (0..grid.len())
                    .map(|i| xyz.functions()[(i, ch)] * r[i] * e[i])
                    .sum::<f64>()
            })
            .collect();
        for ch in 0..3 {
            assert!(
                (reference.xyz[ch] - by_hand[ch]).abs() < ALGEBRA_TOL * 100.0,
                "reference is reflectance rendering"
            );
            assert!(
                (reduced[ch] - by_hand[ch]).abs() < 1e-10 * by_hand[ch].abs().max(1.0),
                "{}: {} vs {}",
                b.name(),
                reduced[ch],
                by_hand[ch]
            );
        }
    }
}

#[test]
fn the_u_function_is_the_first_element_of_a_quadratic_b_spline_partition_of_unity() {
    for i in 0..=500 {
        let x = 300.0 + i as f64;
        let sum: f64 = (0..5).map(|k| bspline_basis(&U_KNOTS_NM, k, 2, x)).sum();
        assert!((sum - 1.0).abs() < ALGEBRA_TOL, "Σ B = {sum} at {x} nm");
    }
    assert_eq!(bspline_basis(&U_KNOTS_NM, 0, 2, 300.0), 1.0);
    assert_eq!(bspline_basis(&U_KNOTS_NM, 0, 2, 550.0), 0.0);
    assert!((bspline_basis(&U_KNOTS_NM, 0, 2, 400.0) - 0.36).abs() < ALGEBRA_TOL);
}

#[test]
fn the_built_in_xyzu_basis_matches_the_authors_table_and_a_table_basis_gets_t_equal_to_identity_and_zero(
) {
    let Some(d) = shared_or_skip("xyzu table") else {
        return;
    };
    let bytes = std::fs::read(d.join("cmf_basis/xyzu.csv")).unwrap();
    let mut text = String::from("wavelength_nm,X,Y,Z,U\n");
    text.push_str(std::str::from_utf8(&bytes).unwrap());
    let table = MultiSpectrum::from_table(&parse_numeric_csv(text.as_bytes(), "xyzu.csv").unwrap())
        .unwrap();
    let grid = WorkingGrid::default();
    let built = Basis::xyzu(&cmfs(), &grid).unwrap();
    let tab = Basis::from_table("xyzu.csv", &table, &cmfs(), &grid).unwrap();
    // U: the authors put the knot at 550.5 nm, ours at 550 nm: differences stay below 0.5 % of U(300).
    let u_max = built.functions().column(3).max();
    let du = (built.functions().column(3) - tab.functions().column(3))
        .abs()
        .max();
    assert!(du < 0.005 * u_max, "U differs by {du}");
    // XYZ columns identical (same CIE 2006 table at 1 nm), so T = [I 0] to rounding.
    let expected = DMatrix::from_row_slice(3, 4, &[1., 0., 0., 0., 0., 1., 0., 0., 0., 0., 1., 0.]);
    assert!(
        max_abs_diff(tab.transfer(), &expected) < 1e-9,
        "{}",
        tab.transfer()
    );
    assert!(tab.transfer_residual() < 1e-9);
    let k = tab.k();
    assert!(max_abs_diff(&dual_check(&tab).unwrap(), &DMatrix::identity(k, k)) < ALGEBRA_TOL);
}

#[test]
fn the_bfc_reader_reads_all_ten_measured_matrices() {
    let Some(d) = shared_or_skip("BFC reader on measured data") else {
        return;
    };
    let files = measured_files(&d);
    assert_eq!(files.len(), 10);
    for f in &files {
        let m = load(f);
        assert_eq!(m.values().shape(), (41, 49), "{}", f.display());
        assert_eq!(m.emission_nm()[0], 380.0);
        assert_eq!(m.excitation_nm()[0], 300.0);
        let diag = m.diagonal();
        assert!(
            diag.iter().all(|v| *v > -0.05 && *v < 2.0),
            "{}: diagonal is a reflectance factor",
            f.display()
        );
    }
    let ciba = load(&d.join("rit_gonzalez_bfc/CIBA12.BFC"));
    assert_eq!(
        ciba.values()[(0, 8)],
        0.0764103,
        "CIBA12 reflectance at 380 nm"
    );
    assert_eq!(ciba.values()[(0, 0)], 0.000401615);
}

#[test]
fn a_bfc_and_a_csv_written_by_lumifit_read_back_identically() {
    let syn = fixture_dir().join("synthetic.bfc");
    let m = load(&syn);
    let bfc = m.to_bfc().unwrap();
    let back = parse_bfc(&bfc, "written.bfc").unwrap();
    assert_eq!(back.values(), m.values());
    assert_eq!(back.emission_nm(), m.emission_nm());
    assert_eq!(back.excitation_nm(), m.excitation_nm());
    let csv = m.to_csv();
    let back = parse_donaldson_csv(csv.as_bytes(), "written.csv").unwrap();
    assert_eq!(back.values(), m.values());
    if let Some(d) = shared_or_skip("BFC round trip of measured data") {
        for f in measured_files(&d) {
            let m = load(&f);
            let back = parse_bfc(&m.to_bfc().unwrap(), "rt.bfc").unwrap();
            assert_eq!(back.values(), m.values(), "{}", f.display());
        }
    }
}

#[test]
fn a_bfc_with_a_wrong_row_count_is_rejected_naming_the_file_and_line() {
    let text = std::fs::read_to_string(fixture_dir().join("synthetic.bfc")).unwrap();
    let mut lines: Vec<&str> = text.lines().collect();
    lines.remove(20);
    let e = parse_bfc(&lines.join("\n"), "short.bfc")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("short.bfc: line") && e.contains("emission"),
        "{e}"
    );
}

#[test]
fn a_bfc_with_a_non_numeric_cell_is_rejected_naming_the_line_and_the_cell() {
    let text = std::fs::read_to_string(fixture_dir().join("synthetic.bfc")).unwrap();
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    let mut f: Vec<String> = lines[14].split('\t').map(String::from).collect();
    f[5] = "x.y".into();
    lines[14] = f.join("\t");
    let e = parse_bfc(&lines.join("\n"), "bad.bfc")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("bad.bfc: line 15") && e.contains("x.y") && e.contains("expected a number"),
        "{e}"
    );
}

#[test]
fn a_csv_matrix_whose_size_does_not_match_its_grid_is_rejected() {
    let e = parse_donaldson_csv(b"emission_nm,300,310,320\n300,1,0,0\n310,0,1\n", "m.csv")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("m.csv: line 3") && e.contains("expected 4 columns"),
        "{e}"
    );
    let e = parse_donaldson_csv(b"emission_nm,300,310\n300,1,0\n310,0,1\n320,0,0\n", "m.csv")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("320") && e.contains("no excitation column"),
        "{e}"
    );
}

#[test]
fn an_illuminant_not_covering_the_cmf_range_is_rejected() {
    let xyz = Basis::xyz(&cmfs(), &WorkingGrid::default()).unwrap();
    let sd =
        lumifit::spectrum::Spectrum::new("narrow", vec![400.0, 500.0, 600.0, 700.0], vec![1.0; 4])
            .unwrap();
    let e = illuminant_on_grid(&Illuminant::from_spectrum("narrow.csv", sd), &xyz)
        .unwrap_err()
        .to_string();
    assert!(e.contains("narrow.csv") && e.contains("390"), "{e}");
    // FL1 starts at 380 nm: it covers the CMFs (390–780 nm) and is accepted for every basis.
    assert!(illuminant_on_grid(&Illuminant::standard("FL1").unwrap(), &xyz).is_ok());
}

#[test]
fn anti_stokes_zeroing_leaves_only_the_diagonal_and_longer_emission() {
    let m = load(&fixture_dir().join("synthetic.bfc"));
    let grid = WorkingGrid::default();
    let op = m.to_operator(
        &grid,
        ResampleOptions {
            clip_negatives: true,
            zero_anti_stokes: true,
        },
    );
    for o in 0..grid.len() {
        for i in (o + 1)..grid.len() {
            assert_eq!(op.a[(o, i)], 0.0);
        }
    }
    assert!(op.a.iter().all(|v| *v >= 0.0));
}

fn fixture() -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(fixture_dir().join("reference.json")).unwrap()).unwrap()
}

fn check_against_fixture(names: &[(String, PathBuf)]) -> usize {
    let fx = fixture();
    let grid = WorkingGrid::default();
    let cm = cmfs();
    let xyz = Basis::xyz(&cm, &grid).unwrap();
    let methods: Vec<Method> = DEFAULT_METHODS
        .iter()
        .map(|m| Method::from_name(m, &cm, &grid).unwrap())
        .collect();
    let ills: Vec<GridIlluminant> = DEFAULT_ILLUMINANTS
        .iter()
        .map(|n| illuminant_on_grid(&Illuminant::standard(n).unwrap(), &xyz).unwrap())
        .collect();
    let rows = fx["rows"].as_array().unwrap();
    let mut checked = 0;
    for (name, path) in names {
        let op = load(path)
            .with_name(name.clone())
            .to_operator(&grid, ResampleOptions::default());
        for m in &methods {
            let p = reduce(&op, &m.basis, m.reduction).unwrap().p;
            let want = &fx["reduced"][format!("{name}|{}", m.name())];
            for r in 0..p.nrows() {
                for c in 0..p.ncols() {
                    let w = want[r][c].as_f64().unwrap();
                    assert!(
                        (p[(r, c)] - w).abs() <= FIXTURE_TOL * w.abs().max(1.0),
                        "{name} {} P[{r},{c}] {} vs {w}",
                        m.name(),
                        p[(r, c)]
                    );
                }
            }
        }
        for got in evaluate(&op, &methods, &ills, &xyz).unwrap() {
            let want = rows
                .iter()
                .find(|r| {
                    r["material"] == got.material.as_str()
                        && r["illuminant"] == got.illuminant.as_str()
                        && r["method"] == got.method.as_str()
                })
                .unwrap_or_else(|| {
                    panic!(
                        "fixture lacks {} {} {}",
                        got.material, got.illuminant, got.method
                    )
                });
            let de = want["delta_e00"].as_f64().unwrap();
            assert!(
                (got.delta_e00 - de).abs() <= FIXTURE_TOL,
                "{} {} {}: ΔE00 {} vs {de}",
                got.material,
                got.illuminant,
                got.method,
                got.delta_e00
            );
            for (key, vals) in [
                ("xyz_reference", got.xyz_reference),
                ("xyz_reduced", got.xyz_reduced),
            ] {
                for k in 0..3 {
                    let w = want[key][k].as_f64().unwrap();
                    assert!(
                        (vals[k] - w).abs() <= FIXTURE_TOL * w.abs().max(1.0),
                        "{} {key}[{k}] {} vs {w}",
                        got.material,
                        vals[k]
                    );
                }
            }
            checked += 1;
        }
    }
    checked
}

#[test]
fn reductions_and_evaluation_of_the_synthetic_matrix_agree_with_numpy() {
    let n = check_against_fixture(&[("synthetic".into(), fixture_dir().join("synthetic.bfc"))]);
    assert_eq!(n, 35);
}

#[test]
fn reductions_and_evaluation_of_the_measured_matrices_agree_with_numpy() {
    let Some(d) = shared_or_skip("numpy agreement on measured data") else {
        return;
    };
    let names: Vec<(String, PathBuf)> = measured_files(&d)
        .into_iter()
        .map(|p| (p.file_stem().unwrap().to_string_lossy().into_owned(), p))
        .collect();
    assert_eq!(check_against_fixture(&names), 350);
}

#[test]
fn basis_selection_picks_the_smallest_basis_under_the_target_or_reports_the_best_reachable() {
    let grid = WorkingGrid::default();
    let cm = cmfs();
    let xyz = Basis::xyz(&cm, &grid).unwrap();
    let op =
        load(&fixture_dir().join("synthetic.bfc")).to_operator(&grid, ResampleOptions::default());
    let methods: Vec<Method> = BasisKind::ALL
        .iter()
        .map(|k| Method {
            reduction: Reduction::Dual,
            basis: k.build(&cm, &grid).unwrap(),
        })
        .collect();
    let ills = vec![illuminant_on_grid(&Illuminant::standard("D65").unwrap(), &xyz).unwrap()];
    let lenient = select_basis(&op, &methods, &ills, &xyz, 1e6).unwrap();
    assert_eq!(lenient.chosen, Some(0));
    let strict = select_basis(&op, &methods, &ills, &xyz, 1e-9).unwrap();
    assert_eq!(strict.chosen, None);
    let best = &strict.candidates[strict.best];
    assert!(strict
        .candidates
        .iter()
        .all(|c| c.worst_delta_e00 >= best.worst_delta_e00));
}
