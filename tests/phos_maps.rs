//! Per-pixel decay maps (`phosphor::maps`) and their float TIFF files (`io::maps`), on synthetic
//! series rendered by `phosphor::synth::DecayFrames`.

use lumifit::capture::{Exposure, FrameInfo, PhotoSeries, RgbFrame, SeriesFrame};
use lumifit::phosphor::maps::fit_pixel_maps;
use lumifit::phosphor::synth::{DecayFrames, DecaySeriesSpec, FrameLayout};
use lumifit::phosphor::{table1_material, BandCamera, DecayFitOptions};
mod common;
use common::tolerances::phos_maps::*;

fn series(layout: FrameLayout, w: usize, h: usize, noise: f64) -> (PhotoSeries, DecayFrames) {
    let m = &table1_material("green_paint").unwrap().material;
    let cam = BandCamera::for_bands(&m.bands, None).unwrap();
    let spec = DecaySeriesSpec {
        charge_s: 5400.0,
        frames: 37,
        interval_s: 5.0,
        exposure_s: 1.0,
        noise,
        seed: 11,
    };
    let fr = DecayFrames::new(m, layout, &cam, &spec, w, h).unwrap();
    let frames = (0..fr.len())
        .map(|j| {
            let data = fr.frame(j).unwrap();
            let sat = vec![0u8; w * h];
            SeriesFrame {
                time_s: fr.t_s[j],
                exposure: Exposure::new(fr.exposure_s, 100.0, 1.0).unwrap(),
                frame: RgbFrame::new(format!("f{j}"), w, h, 1, data, sat).unwrap(),
                info: FrameInfo::default(),
            }
        })
        .collect();
    (PhotoSeries::new(frames).unwrap(), fr)
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

#[test]
fn per_pixel_maps_recover_the_rate_of_each_half_of_a_halves_series() {
    let (w, h) = (12, 6);
    let (s, _) = series(FrameLayout::Halves, w, h, 0.002);
    let maps = fit_pixel_maps(&s, 1, &DecayFitOptions::default(), &|| {}).unwrap();
    assert_eq!((maps.width, maps.height), (w, h));
    assert_eq!(maps.n_failed, 0);
    let left: Vec<usize> = (0..w * h).filter(|i| i % w < w / 2).collect();
    let right: Vec<usize> = (0..w * h).filter(|i| i % w >= w / 2).collect();
    // left: green paint, one state at 0.227 /s
    let k_left = median(
        left.iter()
            .map(|&i| f64::from(maps.k_per_s[0][i]))
            .collect(),
    );
    assert!(
        (k_left / 0.227 - 1.0).abs() < MEDIAN_RATE_TOL,
        "left k1 = {k_left}"
    );
    // right: the two-state variant, 0.227 and 0.0454 /s
    let n2 = right.iter().filter(|&&i| maps.n_states[i] == 2.0).count();
    assert!(
        n2 * 10 >= right.len() * 9,
        "{n2} of {} two-state",
        right.len()
    );
    let k2_right = median(
        right
            .iter()
            .map(|&i| f64::from(maps.k_per_s[1][i]))
            .collect(),
    );
    assert!(
        (k2_right / 0.0454 - 1.0).abs() < MEDIAN_RATE_TOL,
        "right k2 = {k2_right}"
    );
}

#[test]
fn blocks_average_pixels_and_shrink_the_maps() {
    let (s, _) = series(FrameLayout::Uniform, 10, 7, 0.01);
    let maps = fit_pixel_maps(&s, 3, &DecayFitOptions::default(), &|| {}).unwrap();
    assert_eq!((maps.width, maps.height, maps.block), (4, 3, 3));
    assert_eq!(maps.n_states.len(), 12);
    assert_eq!(maps.rms.len(), 12);
}

#[test]
fn a_block_larger_than_the_frame_is_rejected() {
    let (s, _) = series(FrameLayout::Uniform, 4, 4, 0.01);
    let e = fit_pixel_maps(&s, 5, &DecayFitOptions::default(), &|| {}).unwrap_err();
    assert!(e.to_string().contains("--block"), "{e}");
}

#[test]
fn float_maps_read_back_with_the_value_in_every_channel() {
    let d = tempfile::tempdir().unwrap();
    let p = d.path().join("k.tif");
    let v = vec![0.25f32, f32::NAN, 3.5, -1.0, 1e-6, 7.0];
    lumifit::io::maps::write_scalar_map(&p, 3, 2, &v).unwrap();
    let (f, _) = lumifit::io::image::read_image(&p).unwrap();
    assert_eq!((f.width, f.height), (3, 2));
    for (i, want) in v.iter().enumerate() {
        let got = f.rgb(i % 3, i / 3);
        for g in got {
            // the reader maps NaN to 0; everything else is stored bit for bit
            let w = if want.is_nan() { 0.0 } else { *want };
            assert_eq!(g, w, "pixel {i}");
        }
    }
}

#[test]
fn per_pixel_maps_hold_at_the_default_one_percent_noise() {
    // At 1 % noise the one-state half decays into clipped read noise after a few frames; the
    // weights must not let those frames (a small positive bias) pull the rate towards 0.
    let (w, h) = (16, 8);
    let (s, _) = series(FrameLayout::Halves, w, h, 0.01);
    let maps = fit_pixel_maps(&s, 1, &DecayFitOptions::default(), &|| {}).unwrap();
    assert_eq!(maps.n_failed, 0);
    let left: Vec<f64> = (0..w * h)
        .filter(|i| i % w < w / 2)
        .map(|i| f64::from(maps.k_per_s[0][i]))
        .collect();
    let k_left = median(left);
    assert!((k_left / 0.227 - 1.0).abs() < 0.05, "left k1 = {k_left}");
    let right: Vec<usize> = (0..w * h).filter(|i| i % w >= w / 2).collect();
    let n2 = right.iter().filter(|&&i| maps.n_states[i] == 2.0).count();
    assert!(
        n2 * 10 >= right.len() * 8,
        "{n2} of {} two-state",
        right.len()
    );
    let k2 = median(
        right
            .iter()
            .map(|&i| f64::from(maps.k_per_s[1][i]))
            .collect(),
    );
    assert!((k2 / 0.0454 - 1.0).abs() < 0.1, "right k2 = {k2}");
}

/// Bit patterns of every plane (NaN compares equal to itself).
fn bits(m: &lumifit::phosphor::maps::PixelMaps) -> Vec<Vec<u32>> {
    m.planes()
        .iter()
        .map(|p| p.iter().map(|v| v.to_bits()).collect())
        .collect()
}

#[test]
fn the_streamed_tile_run_equals_the_in_memory_fit_in_memory_and_through_a_scratch_file() {
    use lumifit::io::series::{load_series, manifest_csv, SeriesOptions};
    use lumifit::pipeline::phos::decay_frame_tiff;
    use lumifit::pipeline::phos_maps::{fit_per_pixel, PerPixelConfig, PerPixelHooks};
    let d = tempfile::tempdir().unwrap();
    let (w, h) = (96, 64);
    let (_, fr) = series(FrameLayout::Halves, w, h, 0.01);
    let mut rows = Vec::new();
    for j in 0..fr.len() {
        let name = format!("f{j:02}.tif");
        std::fs::write(d.path().join(&name), decay_frame_tiff(&fr, j).unwrap()).unwrap();
        rows.push((name, fr.t_s[j], fr.exposure_s, 100.0, 1.0));
    }
    // a dark frame of 16-bit values, subtracted by both paths
    let dark: Vec<u16> = (0..3 * w * h).map(|i| (i % 97) as u16).collect();
    let dark_path = d.path().join("dark.tif");
    std::fs::write(
        &dark_path,
        lumifit::io::image::encode_tiff16(w as u32, h as u32, &dark).unwrap(),
    )
    .unwrap();
    let manifest = d.path().join("manifest.csv");
    std::fs::write(&manifest, manifest_csv(&rows)).unwrap();
    let opts = DecayFitOptions::default();
    for darks in [vec![], vec![dark_path.clone()]] {
        let loaded = load_series(
            &manifest,
            &SeriesOptions {
                t0_s: None,
                darks: darks.clone(),
            },
            &|| {},
        )
        .unwrap();
        let want = fit_pixel_maps(&loaded.series, 1, &opts, &|| {}).unwrap();
        // 65 MiB: the 1.4 MB store does not fit beside the 64 MiB base, 32 px tiles do
        for (memory_mib, storage) in [(4096, "memory"), (65, "scratch file")] {
            let cfg = PerPixelConfig {
                block: 1,
                tile: Some(32),
                memory_mib,
                scratch_dir: d.path().join("scratch"),
                shard: None,
                darks: darks.clone(),
                threads: 2,
            };
            let hooks = PerPixelHooks {
                planned: &|_| {},
                decoded: &|| {},
                fitted: &|| {},
            };
            let run = fit_per_pixel(&manifest, &opts, &cfg, &hooks).unwrap();
            assert!(run.plan.storage.starts_with(storage), "{:?}", run.plan);
            assert_eq!(
                run.plan.encoding,
                lumifit::phosphor::maps::SampleEncoding::U16
            );
            assert!(run.plan.peak_estimate_mib <= memory_mib as f64);
            assert_eq!((run.maps.width, run.maps.height), (w, h));
            assert_eq!(run.maps.n_failed, want.n_failed);
            assert!(
                bits(&run.maps) == bits(&want),
                "{storage}, {} darks: the maps differ",
                darks.len()
            );
        }
    }
}

#[test]
fn materials_auto_finds_the_three_materials_of_a_noisy_scene_and_assigns_99_percent_of_pixels() {
    use lumifit::phosphor::cluster::{cluster_materials, MaterialCount, DEFAULT_BUDGET};
    // three stripes of 16 px: green paint (one state), its two-state variant (the synthesiser's
    // halves layout), blue paint; the synthesiser's shot + read noise at 1 %
    let spec = DecaySeriesSpec {
        charge_s: 5400.0,
        frames: 37,
        interval_s: 5.0,
        exposure_s: 1.0,
        noise: 0.01,
        seed: 3,
    };
    let (w, h) = (48, 24);
    let frames_of = |name: &str, layout, w| {
        let m = &table1_material(name).unwrap().material;
        let cam = BandCamera::for_bands(&m.bands, None).unwrap();
        DecayFrames::new(m, layout, &cam, &spec, w, h).unwrap()
    };
    let gv = frames_of("green_paint", FrameLayout::Halves, 32);
    let bl = frames_of("blue_paint", FrameLayout::Uniform, 16);
    assert_eq!(gv.t_s, bl.t_s);
    let t_s = gv.t_s.clone();
    let truth = |x: usize| x / 16;
    let frames = (0..t_s.len())
        .map(|j| {
            let (a, b) = (gv.frame(j).unwrap(), bl.frame(j).unwrap());
            let mut data = Vec::with_capacity(3 * w * h);
            for y in 0..h {
                data.extend_from_slice(&a[3 * 32 * y..3 * 32 * (y + 1)]);
                data.extend_from_slice(&b[3 * 16 * y..3 * 16 * (y + 1)]);
            }
            SeriesFrame {
                time_s: t_s[j],
                exposure: Exposure::new(gv.exposure_s, 100.0, 1.0).unwrap(),
                frame: RgbFrame::new(format!("f{j}"), w, h, 1, data, vec![0; w * h]).unwrap(),
                info: FrameInfo::default(),
            }
        })
        .collect();
    let s = PhotoSeries::new(frames).unwrap();
    let maps = fit_pixel_maps(&s, 1, &DecayFitOptions::default(), &|| {}).unwrap();
    let m = cluster_materials(
        &maps,
        &t_s,
        MaterialCount::Auto {
            max: 12,
            budget: DEFAULT_BUDGET,
        },
        7,
    )
    .unwrap();
    assert_eq!(m.materials.len(), 3, "tried {:?}", m.tried);
    // each true material's majority label, then the share of pixels carrying it
    let mut correct = 0;
    let mut seen = Vec::new();
    for mat in 0..3 {
        let mut count = [0usize; 4];
        for i in (0..w * h).filter(|i| truth(i % w) == mat) {
            count[usize::from(m.labels[i]).min(3)] += 1;
        }
        let (best, n) = count
            .iter()
            .enumerate()
            .skip(1)
            .max_by_key(|(_, n)| **n)
            .unwrap();
        eprintln!(
            "material {mat}: label {best} for {n} of {} pixels",
            w * h / 3
        );
        assert!(!seen.contains(&best), "two materials share label {best}");
        seen.push(best);
        correct += n;
    }
    let share = correct as f64 / (w * h) as f64;
    assert!(share >= 0.99, "{share}: {:?}", m.tried);
    // the K-material model reconstructs the per-pixel fits to well within the budget
    assert!(m.chosen.p95 <= DEFAULT_BUDGET, "{:?}", m.chosen);
    eprintln!("chosen {:?}; tried {:?}", m.chosen, m.tried);
}
