//! The evaluation protocol of Luksch, Prost & Wimmer 2020 §6 (Fig. 9 and 10), reproduced: every
//! shading method against a Monte Carlo reference on ground-plane images.
//!
//! # Scene
//!
//! The ground is the plane z = 0 with normal n_g = +z. The light is a W × H rectangle (1 × 1 in
//! the paper) whose **lowest point** is at height h above the ground (h ∈ {0.1, 1.0, 2.5}), turned
//! about the y axis so that the angle between its emitting normal and the ground's normal is
//! θ = acos(n_A · n_g) ∈ {π/2, 5π/8, 3π/4, 7π/8, π}:
//!
//! n_A = (sin θ, 0, cos θ), up = +y (so C = 0° lies along +y, horizontal),
//! centre = (0, 0, h + ½·H·|sin θ|).
//!
//! θ = π is a downlight facing the ground, θ = π/2 a vertical light shining along +x, its lower
//! edge h above the ground. Each image is N × N receivers at the pixel centres of an S × S m
//! square of the ground centred under the light (x right, y up; row 0 of an image is +y).
//!
//! # Error
//!
//! The paper's NRMS over the images of all orientations stitched together:
//!
//! NRMS = √(Σ (E − E_ref)² / P) / √(Σ E_ref² / P)
//!
//! over the P = N²·(number of orientations) receivers of one profile and height.
//!
//! # The reference
//!
//! Stratified Monte Carlo over the rectangle (unbiased): a *replicate* is the mean of the
//! integrand I(ω)(ω_i·n_x)⁺/r² at one uniformly jittered point in each of 8 × 8 equal cells of
//! the rectangle ([`STRATA_PER_SIDE`]); replicates are independent, so the reference at a
//! receiver is the mean of its replicates and its standard error σᵢ is their standard deviation
//! over √(replicates) — measured, not assumed. (Plain uniform sampling gives the same
//! expectation at 3–30× the variance per sample on these scenes.) The reference is refined
//! until its own noise is below `noise_fraction` (default 1/10) of the smallest NRMS it
//! judges. Its noise is NRMS_ref = √(Σ σᵢ² / P) / √(Σ E_ref² / P). It starts with
//! `pilot_replicates` per receiver; each further round measures the per-replicate standard
//! deviation sᵢ and gives receiver i a total of nᵢ ∝ sᵢ replicates (the allocation that
//! minimises Σ σᵢ² for a given total), scaled so that the predicted noise is 1/1.2 of the
//! target, until the target is met, `max_rounds` rounds have run or the `max_samples` budget
//! (in integrand evaluations) is spent (then `converged` is false and the report says so). The judged methods are `point`,
//! `structured`, `mrp`, `cubature` and every rung of the MC ladder; `cubature-adaptive` is
//! reported but not judged (its error is far below what a feasible MC reference resolves; a
//! value within 10× the reference noise says only "within the reference's resolution").
//!
//! # Monte Carlo at equal NRMS
//!
//! The ladder runs uniform MC with N = 1, 2, 4, … samples per receiver (its own seed) until its
//! NRMS is at or below the paper's cubature (or `mc_max_samples`). The N that matches the
//! cubature is interpolated in log N – log NRMS between the two rungs around the crossing, and
//! its time is the crossing rung's time scaled by N / N_rung; the report gives that N and the
//! time ratio MC(N)/cubature.
//!
//! Everything here is pure and parallel over receivers (rayon); the timings are wall-clock of
//! the library calls.

use std::time::Instant;

use rayon::prelude::*;
use serde::Serialize;

use super::illuminance::{area_sample, illuminance, Method, Receiver, RectLight};
use super::{CandelaGrid, Interp};
use crate::error::{Error, Result};

/// What the benchmark runs.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BenchmarkSpec {
    /// Heights of the light's lowest point above the ground, m.
    pub heights_m: Vec<f64>,
    /// Angles θ = acos(n_A·n_g), radians.
    pub orientations_rad: Vec<f64>,
    /// Side of the square ground image, m.
    pub image_size_m: f64,
    /// Receivers per image side.
    pub resolution_px: usize,
    /// Emitter size (W, H), m.
    pub rect_m: (f64, f64),
    /// Tolerance of `cubature-adaptive`.
    pub adaptive_tolerance: f64,
    /// Reference noise must be below this fraction of the smallest judged NRMS (0.1).
    pub noise_fraction: f64,
    /// Stratified replicates (of m × m samples each) per receiver in the reference's first round.
    pub pilot_replicates: usize,
    /// Refinement rounds of the reference at most.
    pub max_rounds: usize,
    /// Budget of reference samples per profile and height (all receivers together).
    pub max_samples: u64,
    /// Largest rung of the MC ladder (samples per receiver).
    pub mc_max_samples: usize,
    /// Seed of every random number.
    pub seed: u64,
    /// Interpolation of the profiles' I(C, γ) for every method and the reference.
    pub interp: Interp,
}

impl Default for BenchmarkSpec {
    fn default() -> Self {
        use std::f64::consts::PI;
        Self {
            heights_m: vec![0.1, 1.0, 2.5],
            orientations_rad: vec![PI / 2.0, 5.0 * PI / 8.0, 3.0 * PI / 4.0, 7.0 * PI / 8.0, PI],
            image_size_m: 4.0,
            resolution_px: 64,
            rect_m: (1.0, 1.0),
            adaptive_tolerance: 0.1,
            noise_fraction: 0.1,
            pilot_replicates: 4,
            max_rounds: 8,
            max_samples: 4_000_000_000,
            mc_max_samples: 1 << 16,
            seed: 1,
            interp: Interp::Bilinear,
        }
    }
}

/// One method's result on one profile and height.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MethodResult {
    /// CLI name of the method (`mc` for ladder rungs).
    pub method: String,
    /// Samples per receiver (MC rungs).
    pub samples: Option<usize>,
    /// NRMS against the reference (a fraction, not %).
    pub nrms: f64,
    /// Wall-clock seconds for all images of this height.
    pub seconds: f64,
    /// Mean evaluations per receiver (triangles or samples).
    pub evaluations_per_point: f64,
    /// Whether the reference's noise target covers this method.
    pub judged: bool,
}

/// The Monte Carlo reference of one profile and height.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ReferenceResult {
    /// Samples drawn over all receivers.
    pub samples_total: u64,
    /// Mean samples per receiver.
    pub samples_per_point_mean: f64,
    /// Most samples at one receiver.
    pub samples_per_point_max: u64,
    /// Rounds run (pilot included).
    pub rounds: usize,
    /// NRMS_ref (module docs).
    pub noise_nrms: f64,
    /// Smallest NRMS among the judged methods.
    pub smallest_judged_nrms: f64,
    /// noise_nrms / smallest_judged_nrms.
    pub noise_ratio: f64,
    /// Whether noise_ratio < noise_fraction.
    pub converged: bool,
    /// Wall-clock seconds.
    pub seconds: f64,
}

/// MC against the paper's cubature at equal NRMS.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct McEqual {
    /// NRMS of `cubature`.
    pub cubature_nrms: f64,
    /// Seconds of `cubature` (all images of the height).
    pub cubature_seconds: f64,
    /// Interpolated samples per receiver at which MC's NRMS equals the cubature's (`None`: the
    /// ladder never got there).
    pub samples_equal: Option<f64>,
    /// The first rung at or below the cubature's NRMS.
    pub rung_samples: Option<usize>,
    /// Seconds of MC at `samples_equal`.
    pub mc_seconds_equal: Option<f64>,
    /// mc_seconds_equal / cubature_seconds.
    pub time_ratio: Option<f64>,
}

/// Illuminance images of one method: `[orientation][row·N + col]`, lux.
#[derive(Debug, Clone, PartialEq)]
pub struct MethodImages {
    /// Method label (`cubature`, `mc 64`, …).
    pub label: String,
    /// One image per orientation.
    pub images: Vec<Vec<f64>>,
}

/// All of one profile at one height.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CaseResult {
    /// Profile name.
    pub profile: String,
    /// Height of the light's lowest point, m.
    pub height_m: f64,
    /// Receivers (all orientations).
    pub points: usize,
    /// The deterministic methods and `cubature-adaptive`.
    pub methods: Vec<MethodResult>,
    /// The MC ladder.
    pub mc_ladder: Vec<MethodResult>,
    /// The reference.
    pub reference: ReferenceResult,
    /// MC at equal NRMS.
    pub mc_equal: McEqual,
    /// Images: the reference first, then each method, then the MC rung that matched.
    #[serde(skip)]
    pub images: Vec<MethodImages>,
}

/// The light of orientation θ and height h (module docs).
pub fn scene_light(spec: &BenchmarkSpec, height_m: f64, theta_rad: f64) -> Result<RectLight> {
    let (w, h) = spec.rect_m;
    let n = [theta_rad.sin(), 0.0, theta_rad.cos()];
    let center = [0.0, 0.0, height_m + 0.5 * h * theta_rad.sin().abs()];
    RectLight::new(center, n, [0.0, 1.0, 0.0], w, h)
}

/// The ground receivers of one image (pixel centres, row 0 at +y).
pub fn ground_receivers(spec: &BenchmarkSpec) -> Vec<Receiver> {
    let n = spec.resolution_px;
    let s = spec.image_size_m;
    let step = s / n as f64;
    let mut out = Vec::with_capacity(n * n);
    for row in 0..n {
        let y = 0.5 * s - (row as f64 + 0.5) * step;
        for col in 0..n {
            let x = -0.5 * s + (col as f64 + 0.5) * step;
            out.push(Receiver {
                p: [x, y, 0.0],
                n: [0.0, 0.0, 1.0],
            });
        }
    }
    out
}

/// Checks the spec (sizes, counts and memory) before any work.
pub fn validate(spec: &BenchmarkSpec, profiles: usize) -> Result<()> {
    let pos = |what: &str, x: f64| -> Result<()> {
        if x > 0.0 && x.is_finite() {
            Ok(())
        } else {
            Err(Error::invalid(
                what,
                format!("{x}: expected a positive number"),
            ))
        }
    };
    pos("--size", spec.image_size_m)?;
    pos("--rect", spec.rect_m.0)?;
    pos("--rect", spec.rect_m.1)?;
    for &h in &spec.heights_m {
        pos("--heights", h)?;
    }
    if spec.heights_m.is_empty() || spec.orientations_rad.is_empty() {
        return Err(Error::invalid(
            "--heights/--orientations",
            "expected at least one height and one orientation",
        ));
    }
    for &t in &spec.orientations_rad {
        if !(t.is_finite() && t > 0.0 && t <= std::f64::consts::PI + 1e-12) {
            return Err(Error::invalid(
                "--orientations",
                format!(
                    "{} π: expected an angle in (0, 1] π between n_A and n_g",
                    t / std::f64::consts::PI
                ),
            ));
        }
    }
    if !(spec.adaptive_tolerance > 0.0 && spec.adaptive_tolerance < 1.0) {
        return Err(Error::invalid(
            "--tolerance",
            "expected a relative tolerance in (0, 1)",
        ));
    }
    if !(spec.noise_fraction > 0.0 && spec.noise_fraction < 1.0) {
        return Err(Error::invalid(
            "--noise-fraction",
            "expected a fraction in (0, 1)",
        ));
    }
    if spec.resolution_px < 2 {
        return Err(Error::invalid("--resolution", "expected at least 2 px"));
    }
    if spec.pilot_replicates < 2 {
        return Err(Error::invalid("pilot replicates", "expected at least 2"));
    }
    crate::limits::check_count(
        "--resolution",
        spec.resolution_px,
        4096,
        "receivers per image side",
    )?;
    crate::limits::check_count(
        "--orientations",
        spec.orientations_rad.len(),
        64,
        "orientations",
    )?;
    crate::limits::check_count("profiles", profiles, 10_000, "profiles per run")?;
    let points = (spec.resolution_px * spec.resolution_px * spec.orientations_rad.len()) as u128;
    // images of ~ (reference + 5 methods + 1 rung + the ladder's working copy) and the
    // reference's three accumulators, 8 bytes each
    crate::limits::check_memory(
        "--resolution",
        &format!(
            "{} px × {} orientations",
            spec.resolution_px,
            spec.orientations_rad.len()
        ),
        points,
        8 * 12,
    )
}

/// Running sums of the reference at one receiver, over independent stratified replicates.
#[derive(Clone, Copy, Default)]
struct Acc {
    /// Replicates drawn.
    n: u64,
    sum: f64,
    sum2: f64,
}

impl Acc {
    fn add(&mut self, x: f64) {
        self.n += 1;
        self.sum += x;
        self.sum2 += x * x;
    }
    fn mean(&self) -> f64 {
        if self.n == 0 {
            0.0
        } else {
            self.sum / self.n as f64
        }
    }
    /// Standard deviation of one replicate.
    fn s(&self) -> f64 {
        if self.n < 2 {
            return 0.0;
        }
        let n = self.n as f64;
        let m = self.mean();
        ((self.sum2 - n * m * m) / (n - 1.0)).max(0.0).sqrt()
    }
    fn var_of_mean(&self) -> f64 {
        if self.n == 0 {
            0.0
        } else {
            self.s().powi(2) / self.n as f64
        }
    }
}

/// Strata per side of one reference replicate (m × m jittered samples).
pub const STRATA_PER_SIDE: usize = 8;

/// One stratified replicate of E at `r`: the mean of the integrand over one jittered sample in
/// each of m × m equal cells of the rectangle (unbiased; replicates are independent).
fn stratified_replicate(
    light: &RectLight,
    grid: &CandelaGrid,
    r: &Receiver,
    rng: &mut crate::capture::rng::SplitMix64,
) -> f64 {
    let m = STRATA_PER_SIDE;
    let mut s = 0.0;
    for i in 0..m {
        for j in 0..m {
            let a = ((i as f64 + rng.uniform()) / m as f64 - 0.5) * light.width_m;
            let b = ((j as f64 + rng.uniform()) / m as f64 - 0.5) * light.height_m;
            s += area_sample(light, grid, r, a, b);
        }
    }
    s / (m * m) as f64
}

fn rms(v: impl Iterator<Item = f64>) -> f64 {
    let (mut s, mut k) = (0.0, 0usize);
    for x in v {
        s += x * x;
        k += 1;
    }
    if k == 0 {
        0.0
    } else {
        (s / k as f64).sqrt()
    }
}

/// NRMS of stitched images `e` against `reference`.
pub fn nrms(e: &[Vec<f64>], reference: &[Vec<f64>]) -> f64 {
    let den = rms(reference.iter().flatten().copied());
    let num = rms(e
        .iter()
        .flatten()
        .zip(reference.iter().flatten())
        .map(|(a, b)| a - b));
    if den > 0.0 {
        num / den
    } else if num == 0.0 {
        0.0
    } else {
        f64::INFINITY
    }
}

struct Scene<'a> {
    lights: Vec<RectLight>,
    receivers: Vec<Receiver>,
    grid: &'a CandelaGrid,
}

impl Scene<'_> {
    /// Runs `method` on every orientation: images, seconds, mean evaluations.
    fn run(&self, method: impl Fn(usize) -> Method) -> Result<(Vec<Vec<f64>>, f64, f64)> {
        let t = Instant::now();
        let mut images = Vec::with_capacity(self.lights.len());
        let mut evals = 0usize;
        for (o, light) in self.lights.iter().enumerate() {
            let s = illuminance(light, self.grid, &self.receivers, method(o))?;
            evals += s.iter().map(|x| x.evaluations).sum::<usize>();
            images.push(s.into_iter().map(|x| x.e_lux).collect());
        }
        let points = (self.lights.len() * self.receivers.len()).max(1);
        Ok((
            images,
            t.elapsed().as_secs_f64(),
            evals as f64 / points as f64,
        ))
    }
}

fn mix(seed: u64, k: u64) -> u64 {
    let mut z = seed ^ k.wrapping_mul(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Runs the benchmark for one profile at one height (module docs).
pub fn run_case(
    profile: &str,
    grid: &CandelaGrid,
    spec: &BenchmarkSpec,
    height_m: f64,
) -> Result<CaseResult> {
    let lights = spec
        .orientations_rad
        .iter()
        .map(|&t| scene_light(spec, height_m, t))
        .collect::<Result<Vec<_>>>()?;
    let grid = &grid.clone().with_interp(spec.interp);
    let scene = Scene {
        lights,
        receivers: ground_receivers(spec),
        grid,
    };
    let per_image = scene.receivers.len();
    let points = per_image * scene.lights.len();

    // deterministic methods (judged) and the adaptive cubature (reported)
    let det = [
        (Method::Point, true),
        (Method::Structured, true),
        (Method::Mrp, true),
        (Method::Cubature, true),
        (
            Method::CubatureAdaptive {
                tolerance: spec.adaptive_tolerance,
            },
            false,
        ),
    ];
    let mut det_runs = Vec::new();
    for (m, judged) in det {
        let (img, secs, evals) = scene.run(|_| m)?;
        det_runs.push((m.name().to_string(), judged, img, secs, evals));
    }

    // reference: pilot round
    let t_ref = Instant::now();
    let mut acc = vec![Acc::default(); points];
    let mut used: u64 = 0;
    let mut rounds = 0usize;
    let add_round = |acc: &mut Vec<Acc>, want: &[u64], round: u64| -> u64 {
        let scene = &scene;
        let drawn: Vec<Acc> = (0..points)
            .into_par_iter()
            .map(|g| {
                let mut a = acc[g];
                if want[g] <= a.n {
                    return a;
                }
                let (o, i) = (g / per_image, g % per_image);
                let mut rng = crate::capture::rng::SplitMix64::new(mix(
                    mix(spec.seed, 0x5EED_0000 + round),
                    g as u64,
                ));
                while a.n < want[g] {
                    a.add(stratified_replicate(
                        &scene.lights[o],
                        scene.grid,
                        &scene.receivers[i],
                        &mut rng,
                    ));
                }
                a
            })
            .collect();
        let before: u64 = acc.iter().map(|a| a.n).sum();
        *acc = drawn;
        let after: u64 = acc.iter().map(|a| a.n).sum();
        (after - before) * (STRATA_PER_SIDE * STRATA_PER_SIDE) as u64
    };
    let pilot = vec![spec.pilot_replicates as u64; points];
    used += add_round(&mut acc, &pilot, 0);
    rounds += 1;

    let mut ladder: Vec<(usize, Vec<Vec<f64>>, f64, f64)> = Vec::new();
    let split = |acc: &[Acc]| -> Vec<Vec<f64>> {
        acc.chunks(per_image)
            .map(|c| c.iter().map(Acc::mean).collect())
            .collect()
    };
    let mut ref_seconds_ladder = 0.0;
    let (reference, noise, smallest, converged) = loop {
        let reference = split(&acc);
        let den = rms(reference.iter().flatten().copied());
        let noise = if den > 0.0 {
            (acc.iter().map(Acc::var_of_mean).sum::<f64>() / points as f64).sqrt() / den
        } else {
            0.0
        };
        // judged NRMS against the current reference; extend the ladder past the cubature
        let cub = det_runs
            .iter()
            .find(|d| d.0 == "cubature")
            .map(|d| nrms(&d.2, &reference))
            .unwrap_or(f64::INFINITY);
        loop {
            let last = ladder.last().map(|l| nrms(&l.1, &reference));
            let n_next = ladder.last().map_or(1, |l| l.0 * 2);
            if last.is_some_and(|x| x <= cub) || n_next > spec.mc_max_samples {
                break;
            }
            let t = Instant::now();
            let (img, secs, evals) = scene.run(|o| Method::Mc {
                samples: n_next,
                seed: mix(spec.seed, 0x1ADD_E800 + ((n_next as u64) << 8) + o as u64),
            })?;
            ref_seconds_ladder += t.elapsed().as_secs_f64();
            ladder.push((n_next, img, secs, evals));
        }
        let smallest = det_runs
            .iter()
            .filter(|d| d.1)
            .map(|d| nrms(&d.2, &reference))
            .chain(ladder.iter().map(|l| nrms(&l.1, &reference)))
            .fold(f64::INFINITY, f64::min);
        let target = spec.noise_fraction * smallest;
        if noise < target || smallest == 0.0 && noise == 0.0 {
            break (reference, noise, smallest, true);
        }
        if rounds >= spec.max_rounds || used >= spec.max_samples {
            break (reference, noise, smallest, false);
        }
        // n_i ∝ s_i for a predicted noise of target / 1.2
        let aim = target / 1.2;
        let sum_s: f64 = acc.iter().map(Acc::s).sum();
        let k = sum_s / (points as f64 * (aim * den).powi(2));
        let mut want: Vec<u64> = acc
            .iter()
            .map(|a| a.n.max((k * a.s()).ceil().min(1e15) as u64))
            .collect();
        let extra: u64 = want.iter().zip(&acc).map(|(w, a)| w - a.n).sum();
        let budget = (spec.max_samples - used) / (STRATA_PER_SIDE * STRATA_PER_SIDE) as u64;
        if extra > budget {
            let f = budget as f64 / extra as f64;
            for (w, a) in want.iter_mut().zip(&acc) {
                *w = a.n + ((*w - a.n) as f64 * f).floor() as u64;
            }
        }
        used += add_round(&mut acc, &want, rounds as u64);
        rounds += 1;
    };
    let ref_seconds = t_ref.elapsed().as_secs_f64() - ref_seconds_ladder;
    let reference_result = ReferenceResult {
        samples_total: used,
        samples_per_point_mean: used as f64 / points as f64,
        samples_per_point_max: acc.iter().map(|a| a.n).max().unwrap_or(0)
            * (STRATA_PER_SIDE * STRATA_PER_SIDE) as u64,
        rounds,
        noise_nrms: noise,
        smallest_judged_nrms: smallest,
        noise_ratio: if smallest > 0.0 {
            noise / smallest
        } else {
            0.0
        },
        converged,
        seconds: ref_seconds,
    };

    let methods: Vec<MethodResult> = det_runs
        .iter()
        .map(|d| MethodResult {
            method: d.0.clone(),
            samples: None,
            nrms: nrms(&d.2, &reference),
            seconds: d.3,
            evaluations_per_point: d.4,
            judged: d.1,
        })
        .collect();
    let mc_ladder: Vec<MethodResult> = ladder
        .iter()
        .map(|l| MethodResult {
            method: "mc".into(),
            samples: Some(l.0),
            nrms: nrms(&l.1, &reference),
            seconds: l.2,
            evaluations_per_point: l.3,
            judged: true,
        })
        .collect();
    let cub = methods
        .iter()
        .find(|m| m.method == "cubature")
        .cloned()
        .ok_or_else(|| Error::invalid("benchmark", "cubature missing"))?;
    let mc_equal = equal_nrms(&cub, &mc_ladder);

    let mut images = vec![MethodImages {
        label: "reference".into(),
        images: reference,
    }];
    for d in det_runs {
        images.push(MethodImages {
            label: d.0,
            images: d.2,
        });
    }
    if let Some(n) = mc_equal.rung_samples {
        if let Some(l) = ladder.into_iter().find(|l| l.0 == n) {
            images.push(MethodImages {
                label: format!("mc {n}"),
                images: l.1,
            });
        }
    }
    Ok(CaseResult {
        profile: profile.to_string(),
        height_m,
        points,
        methods,
        mc_ladder,
        reference: reference_result,
        mc_equal,
        images,
    })
}

/// Runs every profile at every height, calling `on_case` after each (for a progress bar).
pub fn run_all(
    profiles: &[(String, &CandelaGrid)],
    spec: &BenchmarkSpec,
    on_case: &(dyn Fn(&CaseResult) + Sync),
) -> Result<Vec<CaseResult>> {
    validate(spec, profiles.len())?;
    let mut out = Vec::with_capacity(profiles.len() * spec.heights_m.len());
    for (name, grid) in profiles {
        for &h in &spec.heights_m {
            let c = run_case(name, grid, spec, h)?;
            let mut values: Vec<f64> = c.methods.iter().map(|m| m.nrms).collect();
            values.extend(c.mc_ladder.iter().map(|m| m.nrms));
            values.push(c.reference.noise_nrms);
            crate::error::ensure_finite("NRMS", name, &values)?;
            on_case(&c);
            out.push(c);
        }
    }
    Ok(out)
}

/// CSV of every result: one row per profile, height and method (ladder rungs as `mc` with
/// their samples), NRMS as a fraction.
pub fn results_csv(cases: &[CaseResult]) -> String {
    let mut s = String::from(
        "profile,height_m,method,samples_per_point,nrms,seconds,points,points_per_second,evaluations_per_point,judged\n",
    );
    for c in cases {
        for m in c.methods.iter().chain(&c.mc_ladder) {
            s.push_str(&format!(
                "{},{},{},{},{},{},{},{},{},{}\n",
                csv_field(&c.profile),
                c.height_m,
                m.method,
                m.samples.map(|n| n.to_string()).unwrap_or_default(),
                m.nrms,
                m.seconds,
                c.points,
                c.points as f64 / m.seconds.max(1e-12),
                m.evaluations_per_point,
                m.judged
            ));
        }
    }
    s
}

/// CSV of the references and the MC-at-equal-NRMS analysis, one row per profile and height.
pub fn reference_csv(cases: &[CaseResult]) -> String {
    let mut s = String::from(
        "profile,height_m,reference_samples_total,reference_samples_per_point_mean,reference_samples_per_point_max,reference_rounds,reference_noise_nrms,smallest_judged_nrms,noise_ratio,converged,reference_seconds,cubature_nrms,cubature_seconds,mc_samples_equal,mc_rung_samples,mc_seconds_equal,time_ratio_mc_over_cubature\n",
    );
    let opt = |x: Option<f64>| x.map(|v| v.to_string()).unwrap_or_default();
    for c in cases {
        let (r, e) = (&c.reference, &c.mc_equal);
        s.push_str(&format!(
            "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}\n",
            csv_field(&c.profile),
            c.height_m,
            r.samples_total,
            r.samples_per_point_mean,
            r.samples_per_point_max,
            r.rounds,
            r.noise_nrms,
            r.smallest_judged_nrms,
            r.noise_ratio,
            r.converged,
            r.seconds,
            e.cubature_nrms,
            e.cubature_seconds,
            opt(e.samples_equal),
            e.rung_samples.map(|n| n.to_string()).unwrap_or_default(),
            opt(e.mc_seconds_equal),
            opt(e.time_ratio)
        ));
    }
    s
}

fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

/// The Fig. 10-shaped Markdown table: NRMS (%) per profile and height for each method, the
/// reference's noise and samples, and MC at the cubature's NRMS.
pub fn results_markdown(cases: &[CaseResult], spec: &BenchmarkSpec) -> String {
    let mut s = format!(
        "NRMS against a Monte Carlo reference, {n}×{n} ground receivers over {size} × {size} m per \
         orientation, orientations θ = acos(n_A·n_g) = {o} π, images of all orientations stitched; \
         light {w} × {h}, its lowest point at the height above the ground. † = within 10× the \
         reference's noise (not resolved); cubature-adaptive (tolerance {tol}) is not judged; \
         I(C, γ) interpolated {interp:?}.\n\n",
        n = spec.resolution_px,
        size = spec.image_size_m,
        o = spec
            .orientations_rad
            .iter()
            .map(|t| format!("{}", (t / std::f64::consts::PI * 1e6).round() / 1e6))
            .collect::<Vec<_>>()
            .join(", "),
        w = spec.rect_m.0,
        h = spec.rect_m.1,
        tol = spec.adaptive_tolerance,
        interp = spec.interp,
    );
    let names: Vec<String> = cases
        .first()
        .map(|c| c.methods.iter().map(|m| m.method.clone()).collect())
        .unwrap_or_default();
    s.push_str("| profile | h | ");
    for n in &names {
        s.push_str(&format!("{n} | "));
    }
    s.push_str("MC ref noise | MC ref samples/point | MC N at cubature's NRMS | time MC(N)/cubature |\n|---|---|");
    for _ in 0..names.len() + 4 {
        s.push_str("---|");
    }
    s.push('\n');
    for c in cases {
        let noise = c.reference.noise_nrms;
        s.push_str(&format!("| {} | {} | ", c.profile, c.height_m));
        for m in &c.methods {
            let mark = if m.nrms < 10.0 * noise { " †" } else { "" };
            s.push_str(&format!("{:.2} %{mark} | ", 100.0 * m.nrms));
        }
        let e = &c.mc_equal;
        s.push_str(&format!(
            "{:.3} % ({:.2}× smallest){} | {:.0} | {} | {} |\n",
            100.0 * noise,
            c.reference.noise_ratio,
            if c.reference.converged {
                ""
            } else {
                " NOT CONVERGED"
            },
            c.reference.samples_per_point_mean,
            e.samples_equal
                .map(|n| format!("{n:.0}"))
                .unwrap_or_else(|| format!("> {}", spec.mc_max_samples)),
            e.time_ratio
                .map(|r| format!("{r:.1}"))
                .unwrap_or_else(|| "—".into()),
        ));
    }
    s
}

/// The MC sample count and time at the cubature's NRMS (module docs).
pub fn equal_nrms(cub: &MethodResult, ladder: &[MethodResult]) -> McEqual {
    let mut out = McEqual {
        cubature_nrms: cub.nrms,
        cubature_seconds: cub.seconds,
        samples_equal: None,
        rung_samples: None,
        mc_seconds_equal: None,
        time_ratio: None,
    };
    let Some(k) = ladder.iter().position(|r| r.nrms <= cub.nrms) else {
        return out;
    };
    let b = &ladder[k];
    let nb = b.samples.unwrap_or(1) as f64;
    let n_eq = if k == 0 {
        // NRMS ∝ N^(−1/2) below the first rung
        nb * (b.nrms / cub.nrms).powi(2)
    } else {
        let a = &ladder[k - 1];
        let na = a.samples.unwrap_or(1) as f64;
        if a.nrms > b.nrms && b.nrms > 0.0 && cub.nrms > 0.0 {
            let t = (a.nrms.ln() - cub.nrms.ln()) / (a.nrms.ln() - b.nrms.ln());
            (na.ln() + t * (nb.ln() - na.ln())).exp()
        } else {
            nb
        }
    };
    let secs = b.seconds * n_eq / nb;
    out.samples_equal = Some(n_eq);
    out.rung_samples = b.samples;
    out.mc_seconds_equal = Some(secs);
    out.time_ratio = (cub.seconds > 0.0).then(|| secs / cub.seconds);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_light_at_each_orientation_has_its_lowest_point_at_the_height() {
        let spec = BenchmarkSpec::default();
        for &t in &spec.orientations_rad {
            let l = scene_light(&spec, 0.1, t).unwrap();
            let low = l
                .corners()
                .iter()
                .map(|c| c[2])
                .fold(f64::INFINITY, f64::min);
            assert!((low - 0.1).abs() < 1e-12, "θ = {t}: lowest {low}");
            let cos = l.n[2];
            assert!((cos.acos() - t).abs() < 1e-12);
        }
    }

    #[test]
    fn equal_nrms_interpolates_between_the_rungs_around_the_crossing() {
        let r = |n: usize, e: f64, s: f64| MethodResult {
            method: "mc".into(),
            samples: Some(n),
            nrms: e,
            seconds: s,
            evaluations_per_point: n as f64,
            judged: true,
        };
        // NRMS = 0.8/√N: the cubature's 0.1 is matched at N = 64
        let ladder: Vec<_> = (0..8)
            .map(|k| 1usize << k)
            .map(|n| r(n, 0.8 / (n as f64).sqrt(), 0.01 * n as f64))
            .collect();
        let mut cub = r(0, 0.1, 0.02);
        cub.method = "cubature".into();
        let e = equal_nrms(&cub, &ladder);
        assert!((e.samples_equal.unwrap() - 64.0).abs() < 1e-9);
        assert!((e.time_ratio.unwrap() - 32.0).abs() < 1e-9);
    }
}
