//! A compact material map: the per-pixel decay fits of [`super::maps`] grouped into K materials,
//! so that a scene needs K presets instead of one parameter set per pixel.
//!
//! **Features.** Each fitted block is described by the shape of its fitted decay and its
//! colour: the normalised model curve g(t_m) = Σ_i a_i e^{−k_i t_m} / Σ_i a_i at
//! [`CURVE_SAMPLES`] frame times t_m spread over the series, and the chromaticity
//! (r, g)/(r + g + b) of its shared spectrum. Curve values rather than rates make the features
//! indifferent to an order decision that changes nothing visible (a spurious third state with a
//! tiny amplitude), and they weigh what the reconstructed series shows. Both kinds are fractions
//! and are used as they are: z-scores would inflate a dimension without spread between
//! materials into unit-variance noise, which k-means then splits (seen: green paint and its
//! two-state variant split at random instead of from each other).
//!
//! **Clustering.** k-means with k-means++ seeding (Arthur & Vassilvitskii 2007), seeded
//! ([`crate::capture::rng::SplitMix64`]), [`N_INIT`] restarts, the lowest within-cluster sum of
//! squares kept; on at most [`MAX_SAMPLE`] blocks taken at an even stride, then every block is
//! assigned to the nearest centre.
//!
//! **Material model and its error.** Material k is represented by its medoid block (the sample
//! block nearest the centre): rates K_i, amplitudes A_i and spectrum S. A block's K-material
//! reconstruction is σ_p · S_c · Σ_i A_i e^{−K_i t} with one least-squares scale σ_p per block
//! (its brightness); its error against the block's own fit m_p,c(t) is the RMS over frames and
//! channels of the difference divided by the peak of m_p. [`MaterialCount::Auto`] takes the
//! smallest K whose 95th percentile of that error is within the budget (default
//! [`DEFAULT_BUDGET`]); the BIC of a diagonal Gaussian mixture with hard assignments is reported
//! beside it for every K tried.
//!
//! No colour-science counterpart. Pure: the caller writes presets and the index map.

use crate::capture::rng::SplitMix64;
use crate::error::{Error, Result};

use super::maps::{PixelMaps, MAP_STATES};

/// Curve samples per feature vector.
pub const CURVE_SAMPLES: usize = 6;
/// Feature dimensions: the curve samples and two chromaticities.
pub const DIMS: usize = CURVE_SAMPLES + 2;
/// Blocks clustered at most (an even stride over the fitted blocks); all are then assigned.
pub const MAX_SAMPLE: usize = 200_000;
/// k-means restarts per K.
pub const N_INIT: usize = 3;
/// Default relative-error budget (95th percentile over blocks) of `--materials auto`.
pub const DEFAULT_BUDGET: f64 = 0.02;
/// Largest K tried by `auto`.
pub const MAX_MATERIALS: usize = 12;

/// How many materials.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum MaterialCount {
    /// The smallest K ≤ `max` whose 95th-percentile reconstruction error is ≤ `budget`.
    Auto {
        /// Largest K tried.
        max: usize,
        /// Relative-error budget.
        budget: f64,
    },
    /// Exactly this many.
    Fixed(usize),
}

/// One material: its representative (medoid) fit.
#[derive(Debug, Clone, PartialEq)]
pub struct MaterialFit {
    /// Rates in s⁻¹, fastest first.
    pub k_per_s: Vec<f64>,
    /// Amplitudes per unit spectrum at the material's median brightness.
    pub amplitude: Vec<f64>,
    /// Spectrum r, g, b (largest 1).
    pub spectrum: [f64; 3],
    /// Blocks assigned.
    pub blocks: usize,
}

/// Reconstruction error statistics of one K.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct KError {
    /// Number of materials.
    pub k: usize,
    /// Median relative error over the sampled blocks.
    pub median: f64,
    /// 95th percentile.
    pub p95: f64,
    /// BIC of the diagonal Gaussian mixture (hard assignments) in feature space.
    pub bic: f64,
}

/// The result of [`cluster_materials`].
#[derive(Debug, Clone, PartialEq)]
pub struct Materials {
    /// The materials, largest first.
    pub materials: Vec<MaterialFit>,
    /// Per block (row-major like the maps): 0 where the fit failed, else 1 + material index.
    pub labels: Vec<u16>,
    /// Error statistics of every K tried.
    pub tried: Vec<KError>,
    /// The chosen K's statistics.
    pub chosen: KError,
    /// Blocks in the sample the errors were computed on.
    pub sampled: usize,
}

#[derive(Debug, Clone, Copy)]
struct Params {
    k: [f64; MAP_STATES],
    a: [f64; MAP_STATES],
    n: usize,
    s: [f64; 3],
}

fn params(maps: &PixelMaps, i: usize) -> Option<Params> {
    let n = maps.n_states[i] as usize;
    if n == 0 || n > MAP_STATES {
        return None;
    }
    let mut p = Params {
        k: [0.0; MAP_STATES],
        a: [0.0; MAP_STATES],
        n,
        s: [0.0; 3],
    };
    for j in 0..n {
        p.k[j] = f64::from(maps.k_per_s[j][i]);
        p.a[j] = f64::from(maps.amplitude[j][i]);
    }
    for c in 0..3 {
        p.s[c] = f64::from(maps.spectrum[c][i]);
    }
    let ok = p.k[..n]
        .iter()
        .chain(&p.a[..n])
        .chain(&p.s)
        .all(|v| v.is_finite())
        && p.a[..n].iter().sum::<f64>() > 0.0
        && p.s.iter().sum::<f64>() > 0.0;
    ok.then_some(p)
}

fn curve(p: &Params, t: f64) -> f64 {
    (0..p.n).map(|j| p.a[j] * (-p.k[j] * t).exp()).sum()
}

fn features(p: &Params, t_m: &[f64; CURVE_SAMPLES]) -> [f64; DIMS] {
    let a0: f64 = p.a[..p.n].iter().sum();
    let mut x = [0.0; DIMS];
    for (m, t) in t_m.iter().enumerate() {
        x[m] = curve(p, *t) / a0;
    }
    let s: f64 = p.s.iter().sum();
    x[CURVE_SAMPLES] = p.s[0] / s;
    x[CURVE_SAMPLES + 1] = p.s[1] / s;
    x
}

fn dist2(a: &[f64; DIMS], b: &[f64; DIMS]) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum()
}

fn nearest(x: &[f64; DIMS], centres: &[[f64; DIMS]]) -> (usize, f64) {
    let mut best = (0, f64::INFINITY);
    for (k, c) in centres.iter().enumerate() {
        let d = dist2(x, c);
        if d < best.1 {
            best = (k, d);
        }
    }
    best
}

/// k-means++ then Lloyd iterations; (centres, labels, within-cluster sum of squares).
fn kmeans(
    z: &[[f64; DIMS]],
    k: usize,
    rng: &mut SplitMix64,
) -> (Vec<[f64; DIMS]>, Vec<usize>, f64) {
    let n = z.len();
    let mut centres = vec![z[(rng.uniform() * n as f64) as usize % n]];
    let mut d2: Vec<f64> = z.iter().map(|x| dist2(x, &centres[0])).collect();
    while centres.len() < k {
        let total: f64 = d2.iter().sum();
        let pick = if total > 0.0 {
            let mut r = rng.uniform() * total;
            let mut idx = n - 1;
            for (i, d) in d2.iter().enumerate() {
                r -= d;
                if r <= 0.0 {
                    idx = i;
                    break;
                }
            }
            idx
        } else {
            (rng.uniform() * n as f64) as usize % n
        };
        centres.push(z[pick]);
        for (i, x) in z.iter().enumerate() {
            d2[i] = d2[i].min(dist2(x, &centres[centres.len() - 1]));
        }
    }
    let mut labels = vec![usize::MAX; n];
    let mut wss = 0.0;
    for _ in 0..100 {
        let mut changed = false;
        wss = 0.0;
        for (i, x) in z.iter().enumerate() {
            let (l, d) = nearest(x, &centres);
            wss += d;
            if labels[i] != l {
                labels[i] = l;
                changed = true;
            }
        }
        if !changed {
            break;
        }
        let mut sum = vec![[0.0; DIMS]; k];
        let mut cnt = vec![0usize; k];
        for (x, l) in z.iter().zip(&labels) {
            cnt[*l] += 1;
            for d in 0..DIMS {
                sum[*l][d] += x[d];
            }
        }
        for j in 0..k {
            if cnt[j] > 0 {
                for d in 0..DIMS {
                    centres[j][d] = sum[j][d] / cnt[j] as f64;
                }
            }
        }
    }
    (centres, labels, wss)
}

fn bic(z: &[[f64; DIMS]], labels: &[usize], k: usize) -> f64 {
    let n = z.len() as f64;
    let mut ll = 0.0;
    for j in 0..k {
        let members: Vec<&[f64; DIMS]> = z
            .iter()
            .zip(labels)
            .filter(|(_, l)| **l == j)
            .map(|(x, _)| x)
            .collect();
        let nk = members.len() as f64;
        if nk < 1.0 {
            continue;
        }
        ll += nk * (nk / n).ln();
        for d in 0..DIMS {
            let m = members.iter().map(|x| x[d]).sum::<f64>() / nk;
            let v = (members.iter().map(|x| (x[d] - m).powi(2)).sum::<f64>() / nk).max(1e-6);
            ll -= nk / 2.0 * ((2.0 * std::f64::consts::PI * v).ln() + 1.0);
        }
    }
    let p = (k * 2 * DIMS + k - 1) as f64;
    -2.0 * ll + p * n.ln()
}

/// Relative error of reconstructing `p` by material `m` with the best scale (module docs).
fn recon_error(p: &Params, m: &Params, t_s: &[f64]) -> f64 {
    let (mut num, mut den, mut peak) = (0.0, 0.0, 0.0f64);
    let mut pairs = Vec::with_capacity(3 * t_s.len());
    for t in t_s {
        let (cp, cm) = (curve(p, *t), curve(m, *t));
        for c in 0..3 {
            let (y, x) = (p.s[c] * cp, m.s[c] * cm);
            num += x * y;
            den += x * x;
            peak = peak.max(y.abs());
            pairs.push((y, x));
        }
    }
    let scale = if den > 0.0 { num / den } else { 0.0 };
    let ss: f64 = pairs.iter().map(|(y, x)| (y - scale * x).powi(2)).sum();
    (ss / pairs.len() as f64).sqrt() / peak.max(f64::MIN_POSITIVE)
}

fn quantile(v: &mut [f64], q: f64) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    v[((v.len() - 1) as f64 * q).round() as usize]
}

/// Groups the fitted blocks of `maps` into materials (see the module docs); `t_s` are the
/// series' frame times.
///
/// # Errors
/// [`Error::InvalidArgument`] naming `--materials` when no block was fitted, K is 0 or more
/// than the fitted blocks, or no K ≤ max meets the budget (the message gives the best error).
pub fn cluster_materials(
    maps: &PixelMaps,
    t_s: &[f64],
    count: MaterialCount,
    seed: u64,
) -> Result<Materials> {
    if t_s.len() < 2 {
        return Err(Error::invalid(
            "--materials",
            "needs the series' frame times",
        ));
    }
    let n_all = maps.n_states.len();
    let fitted: Vec<(usize, Params)> = (0..n_all)
        .filter_map(|i| params(maps, i).map(|p| (i, p)))
        .collect();
    if fitted.is_empty() {
        return Err(Error::invalid(
            "--materials",
            "no block was fitted; nothing to group",
        ));
    }
    let t_m: [f64; CURVE_SAMPLES] = std::array::from_fn(|m| {
        let j = (m * (t_s.len() - 1)) as f64 / (CURVE_SAMPLES - 1) as f64;
        t_s[j.round() as usize]
    });
    let x: Vec<[f64; DIMS]> = fitted.iter().map(|(_, p)| features(p, &t_m)).collect();
    // natural units: curve values and chromaticities are both fractions; z-scores would blow up
    // a dimension without between-material spread (e.g. the red chromaticity of green and blue
    // paint) into unit-variance noise that k-means then splits
    let z = x;
    let stride = z.len().div_ceil(MAX_SAMPLE).max(1);
    let sample: Vec<usize> = (0..z.len()).step_by(stride).collect();
    let zs: Vec<[f64; DIMS]> = sample.iter().map(|&i| z[i]).collect();
    let ks: Vec<usize> = match count {
        MaterialCount::Fixed(k) => {
            if k == 0 || k > zs.len() || k > usize::from(u16::MAX) - 1 {
                return Err(Error::invalid(
                    "--materials",
                    format!("{k}; expected auto or 1 to {}", zs.len().min(65534)),
                ));
            }
            vec![k]
        }
        MaterialCount::Auto { max, .. } => (1..=max.min(zs.len()).max(1)).collect(),
    };
    let mut rng = SplitMix64::new(seed ^ 0x6D61_7465_7269_616C);
    let mut tried = Vec::new();
    let mut result = None;
    for &k in &ks {
        let mut best: Option<(Vec<[f64; DIMS]>, Vec<usize>, f64)> = None;
        for _ in 0..N_INIT {
            let r = kmeans(&zs, k, &mut rng);
            if best.as_ref().is_none_or(|b| r.2 < b.2) {
                best = Some(r);
            }
        }
        let Some((centres, labels, _)) = best else {
            continue;
        };
        // medoid of each cluster within the sample
        let medoid: Vec<Option<usize>> = (0..k)
            .map(|j| {
                labels
                    .iter()
                    .enumerate()
                    .filter(|(_, l)| **l == j)
                    .map(|(s, _)| (s, dist2(&zs[s], &centres[j])))
                    .min_by(|a, b| a.1.total_cmp(&b.1))
                    .map(|(s, _)| sample[s])
            })
            .collect();
        let mut errs: Vec<f64> = sample
            .iter()
            .zip(&labels)
            .filter_map(|(&i, l)| medoid[*l].map(|m| recon_error(&fitted[i].1, &fitted[m].1, t_s)))
            .collect();
        let e = KError {
            k,
            median: quantile(&mut errs, 0.5),
            p95: quantile(&mut errs, 0.95),
            bic: bic(&zs, &labels, k),
        };
        tried.push(e);
        let done = match count {
            MaterialCount::Fixed(_) => true,
            MaterialCount::Auto { budget, .. } => e.p95 <= budget,
        };
        if done {
            result = Some((centres, medoid, e));
            break;
        }
    }
    let Some((centres, medoid, chosen)) = result else {
        let best = tried.iter().map(|e| e.p95).fold(f64::INFINITY, f64::min);
        let (max, budget) = match count {
            MaterialCount::Auto { max, budget } => (max, budget),
            MaterialCount::Fixed(k) => (k, f64::NAN),
        };
        return Err(Error::invalid(
            "--materials",
            format!(
                "no K up to {max} reconstructs the per-pixel fits within the budget {budget} (95th percentile); the best was {best:.4} (K: p95 {}); raise --material-budget or give K",
                tried.iter().map(|e| format!("{}: {:.4}, BIC {:.0}", e.k, e.p95, e.bic)).collect::<Vec<_>>().join("; ")
            ),
        ));
    };
    // assign every fitted block; materials sorted by size, largest first
    let k = centres.len();
    let mut lab = vec![0usize; z.len()];
    let mut sizes = vec![0usize; k];
    for (i, v) in z.iter().enumerate() {
        let (l, _) = nearest(v, &centres);
        lab[i] = l;
        sizes[l] += 1;
    }
    let mut order: Vec<usize> = (0..k).collect();
    order.sort_by(|a, b| sizes[*b].cmp(&sizes[*a]).then(a.cmp(b)));
    let mut rank = vec![0usize; k];
    for (r, &j) in order.iter().enumerate() {
        rank[j] = r;
    }
    let mut labels = vec![0u16; n_all];
    let mut scales: Vec<Vec<f64>> = vec![Vec::new(); k];
    for ((i, p), l) in fitted.iter().zip(&lab) {
        labels[*i] = (rank[*l] + 1) as u16;
        if let Some(m) = medoid[*l] {
            let a0: f64 = fitted[m].1.a[..fitted[m].1.n].iter().sum();
            let ap: f64 = p.a[..p.n].iter().sum();
            scales[*l].push(ap / a0);
        }
    }
    let materials = order
        .iter()
        .filter_map(|&j| {
            let m = &fitted[medoid[j]?].1;
            let s = quantile(&mut scales[j], 0.5);
            Some(MaterialFit {
                k_per_s: m.k[..m.n].to_vec(),
                amplitude: m.a[..m.n].iter().map(|a| a * s).collect(),
                spectrum: m.s,
                blocks: sizes[j],
            })
        })
        .collect();
    Ok(Materials {
        materials,
        labels,
        tried,
        chosen,
        sampled: sample.len(),
    })
}
