//! Criterion benchmarks of spectral → XYZ: one spectrum through the full colour-compatible
//! pipeline, and 10,000 spectra on one grid through the precomputed linear operator (the path
//! `lumifit color table` uses). The side-by-side comparison with colour-science is
//! `scripts/bench/xyz_throughput.py`; numbers are reported in docs/performance.md.

use criterion::{black_box, criterion_group, criterion_main, Criterion, Throughput};
use lumifit::colorimetry::{
    sd_to_xyz, Illuminant, Observer, StandardObserver, XyzMethod, XyzOperator,
};
use lumifit::spectrum::Spectrum;

fn smooth(n_spectra: usize, w: &[f64]) -> Vec<Vec<f64>> {
    // Deterministic smooth spectra (no RNG dependency): shifted Gaussians on a sloped base.
    (0..n_spectra)
        .map(|i| {
            let c = 400.0 + (i * 37 % 360) as f64;
            let s = 30.0 + (i * 13 % 80) as f64;
            w.iter()
                .map(|&x| {
                    0.1 + 0.0005 * (x - 380.0) * ((i % 3) as f64) / 3.0
                        + 0.7 * (-0.5 * ((x - c) / s).powi(2)).exp()
                })
                .collect()
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let observer = Observer::standard(StandardObserver::Cie1931_2).expect("embedded observer");
    let d65 = Illuminant::standard("D65").expect("embedded illuminant");
    for interval in [5.0, 10.0] {
        let w: Vec<f64> = (0..)
            .map(|i| 380.0 + interval * i as f64)
            .take_while(|&x| x <= 780.0)
            .collect();
        let spectra = smooth(10_000, &w);
        for method in [XyzMethod::AstmE308, XyzMethod::Integration] {
            let sd = Spectrum::new("s", w.clone(), spectra[0].clone()).expect("valid spectrum");
            c.bench_function(
                &format!("sd_to_xyz one spectrum {interval} nm {}", method.cli_name()),
                |b| {
                    b.iter(|| sd_to_xyz(black_box(&sd), observer, &d65, method, None).expect("xyz"))
                },
            );
            let op = XyzOperator::new(&w, observer, &d65, method, None).expect("operator");
            let mut g = c.benchmark_group(format!(
                "operator 10k spectra {interval} nm {}",
                method.cli_name()
            ));
            g.throughput(Throughput::Elements(spectra.len() as u64));
            g.bench_function("apply", |b| {
                b.iter(|| {
                    let mut acc = 0.0;
                    for s in &spectra {
                        acc += op.apply(black_box(s)).expect("xyz")[1];
                    }
                    acc
                })
            });
            g.finish();
        }
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
