//! Criterion benchmarks of the dispersion domain: n(λ) of the N-BK7 formula (refractiveindex.info
//! formula 2, three Sellmeier terms) at 10⁶ wavelengths, and the prism reference render (the
//! 1 nm spectral strip plus the 7-sample strip and their ΔE00) with the defaults of
//! `lumifit dispersion prism`. The numpy side is `scripts/bench/dispersion_speed.py`, which runs
//! this bench and prints both in one table for docs/performance.md.

use criterion::{black_box, criterion_group, criterion_main, Criterion};
use lumifit::colorimetry::rgb::RgbSpace;
use lumifit::colorimetry::{Illuminant, Observer, StandardObserver};
use lumifit::dispersion::blanchette2012::{slices_for, wavelength_samples};
use lumifit::dispersion::catalogue::glass;
use lumifit::dispersion::prism::{evaluate, PrismSetup};
use lumifit::dispersion::RefractiveIndex;

fn bench(c: &mut Criterion) {
    let bk7 = glass("N-BK7").expect("bundled glass").formula;
    let lambda: Vec<f64> = (0..1_000_000)
        .map(|i| 380.0 + 400.0 * i as f64 / 999_999.0)
        .collect();
    c.bench_function("n(λ) N-BK7 formula 2, 1e6 wavelengths", |b| {
        b.iter(|| {
            let mut s = 0.0;
            for &l in &lambda {
                s += bk7.n_at(black_box(l));
            }
            s
        })
    });
    let observer = Observer::standard(StandardObserver::Cie1931_2).expect("observer");
    let e = Illuminant::standard("E").expect("illuminant");
    let space = RgbSpace::srgb().expect("srgb");
    let slices = slices_for(observer, &e, &space, [380.0, 780.0]).expect("slices");
    let set = wavelength_samples(&slices, 7).expect("samples");
    let samples: Vec<(f64, [f64; 3])> = set.samples.iter().map(|s| (s.lambda_nm, s.rgb)).collect();
    c.bench_function(
        "prism render N-BK7: spectral 1 nm + 7 samples + ΔE00",
        |b| {
            b.iter(|| {
                evaluate(
                    &bk7,
                    &slices,
                    &PrismSetup::default(),
                    vec![("N = 7".into(), samples.clone(), None)],
                )
                .expect("render")
            })
        },
    );
}

criterion_group!(benches, bench);
criterion_main!(benches);
