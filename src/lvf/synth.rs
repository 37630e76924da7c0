//! Synthetic LVF captures: a lamp seen through an LVF by a camera of given spectral
//! sensitivities, with vignetting, shot and read noise. The project's own test data and a
//! planning aid.
//!
//! Along the axis, position p (pixels, centres at integers) passes λ(p) = nm_at_start +
//! nm_per_px·p (+ an optional bow, [`LvfSynthSpec::bow_nm`], a quadratic term) with a passband g
//! of the given FWHM (Gaussian unless [`LvfSynthSpec::passband`] says otherwise); channel c
//! records
//!
//! ```text
//! V(x, y)·[ Σ_l P_l·S_c(λ_l)·⟨g(λ_l − λ(p + t))⟩_t  +  k·Σ_λ C(λ)·S_c(λ)·g(λ − λ(p))·1 nm ]
//! ```
//!
//! scaled so that the brightest pixel is 0.8 of full scale. Lines are exact: each line is a
//! delta at its wavelength (no wavelength grid) and ⟨·⟩_t averages the passband over the pixel's
//! own span t ∈ [−½, ½] (8-point Gauss–Legendre, exact to rounding for a pixel much narrower than
//! the passband), so a line narrower than any grid step does not move. The optional continuum C
//! ([`ContinuumShape`]: flat, blackbody, or the broad bands of a CFL's phosphors) is summed on
//! the 1 nm grid 360–830 nm; k makes its largest value `fraction` of the brightest line blob
//! (both before vignetting). Vignetting V ([`VignettingShape`]): quadratic 1 − v·r² (r the
//! distance from the image centre over the half diagonal), cos⁴ law scaled to 1 − v at the
//! corners, a linear tilt along the axis from 1 to 1 − v, or quadratic about an off-centre point
//! (¾ of the width, ⅓ of the height) reaching 1 − v at the farthest corner. Noise follows
//! [`crate::capture::synth::noisy_value`] with peak 0.8: at the brightest pixel its standard
//! deviation is `noise`·0.8. Deterministic for a seed.

use crate::capture::rng::SplitMix64;
use crate::capture::synth::noisy_value;
use crate::capture::RgbFrame;
use crate::error::{Error, Result};
use crate::lvf::fit::Passband;
use crate::lvf::lamp::Lamp;
use crate::lvf::profile::{Axis, MAX_TILT_DEG};
use crate::spectrum::MultiSpectrum;
use crate::table::parse_numeric_csv;

/// The default camera: Nikon 5100 (NPL) sensitivities from colour-science
/// (`calib/camera_default.csv`, see calib/README.md).
pub const DEFAULT_CAMERA_CSV: &str = include_str!("../../calib/camera_default.csv");

/// Parses a camera table `wavelength_nm,r,g,b`.
///
/// # Errors
/// [`Error::Parse`] / [`Error::InvalidArgument`] when the table is not three channels.
pub fn camera_from_csv(bytes: &[u8], source: &str) -> Result<MultiSpectrum> {
    let t = parse_numeric_csv(bytes, source)?;
    let ms = MultiSpectrum::from_table(&t)?;
    if ms.n_channels() != 3 {
        return Err(Error::parse(
            source,
            0,
            format!(
                "{} value columns; expected wavelength_nm,r,g,b",
                ms.n_channels()
            ),
        ));
    }
    Ok(ms)
}

/// The default camera (see [`DEFAULT_CAMERA_CSV`]).
///
/// # Errors
/// Only if the embedded table were corrupt.
pub fn default_camera() -> Result<MultiSpectrum> {
    camera_from_csv(DEFAULT_CAMERA_CSV.as_bytes(), "calib/camera_default.csv")
}

/// What to render.
#[derive(Debug, Clone)]
pub struct LvfSynthSpec {
    /// Image width (px).
    pub width: usize,
    /// Image height (px).
    pub height: usize,
    /// Filter axis.
    pub axis: Axis,
    /// λ at position 0 (nm).
    pub nm_at_start: f64,
    /// Dispersion (nm/px), may be negative.
    pub nm_per_px: f64,
    /// Bow of the map (nm): how far λ at the middle of the axis lies from the straight line
    /// through its ends, λ(p) = nm_at_start + nm_per_px·p + 4·bow·p·(L−1−p)/(L−1)² (L positions
    /// along the axis); 0 for the linear map of the paper.
    pub bow_nm: f64,
    /// Slant of the iso-wavelength lines (degrees): the pixel at (along a, across b) sees the
    /// map at a + tan(tilt)·(b − b₀), b₀ the middle across the axis (where the truth's map
    /// holds); 0 for a filter square to the sensor.
    pub tilt_deg: f64,
    /// Passband FWHM (nm).
    pub fwhm_nm: f64,
    /// Passband shape ([`Passband::Gaussian`] unless a generalised normal or a measured shape
    /// is asked for).
    pub passband: Passband,
    /// The lamp.
    pub lamp: Lamp,
    /// Camera sensitivities (3 channels).
    pub camera: MultiSpectrum,
    /// Relative noise at the peak.
    pub noise: f64,
    /// Vignetting strength v.
    pub vignetting: f64,
    /// Shape of the vignetting.
    pub vignetting_shape: VignettingShape,
    /// A broadband continuum under the lines.
    pub continuum: Option<Continuum>,
    /// A level added to every pixel after the fall-off and the noise, before clipping (fraction
    /// of full scale; the brightest pixel is 0.8 before it): a black-level residue, or flare
    /// and stray light that the lens does not vignette. 0 for none.
    pub pedestal: f64,
    /// Random seed.
    pub seed: u64,
}

/// Shape of the vignetting of a synthetic capture (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum VignettingShape {
    /// 1 − v·r² about the image centre.
    Quadratic,
    /// cos⁴ law, 1 − v at the corners.
    Cos4,
    /// Linear tilt along the filter axis, 1 at the start to 1 − v at the end.
    Linear,
    /// 1 − v·r'²/r'²_max about (¾ width, ⅓ height).
    Offcentre,
}

impl VignettingShape {
    /// Parses `AMOUNT` (quadratic) or `SHAPE:AMOUNT`, SHAPE one of quadratic, cos4, linear,
    /// offcentre; AMOUNT in [0, 1).
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] naming `--vignetting`.
    pub fn parse(s: &str) -> Result<(Self, f64)> {
        let (shape, amount) = match s.split_once(':') {
            Some((a, b)) => (a.trim().to_ascii_lowercase(), b.trim()),
            None => ("quadratic".to_string(), s.trim()),
        };
        let shape = match shape.as_str() {
            "quadratic" => VignettingShape::Quadratic,
            "cos4" => VignettingShape::Cos4,
            "linear" => VignettingShape::Linear,
            "offcentre" | "offcenter" => VignettingShape::Offcentre,
            _ => {
                return Err(Error::invalid(
                    "--vignetting",
                    format!("'{s}': expected AMOUNT or SHAPE:AMOUNT with SHAPE quadratic, cos4, linear or offcentre"),
                ))
            }
        };
        match amount.parse::<f64>() {
            Ok(v) if (0.0..1.0).contains(&v) => Ok((shape, v)),
            _ => Err(Error::invalid(
                "--vignetting",
                format!("'{s}': the amount must be a number in [0, 1)"),
            )),
        }
    }

    /// V at pixel (x, y) of a `width` × `height` image whose filter axis is `axis`.
    pub fn at(
        self,
        amount: f64,
        axis: Axis,
        x: usize,
        y: usize,
        width: usize,
        height: usize,
    ) -> f64 {
        let (w, h) = (width as f64, height as f64);
        let (cx, cy) = ((w - 1.0) / 2.0, (h - 1.0) / 2.0);
        let (dx, dy) = (x as f64 - cx, y as f64 - cy);
        let r2 = (dx * dx + dy * dy) / (cx * cx + cy * cy).max(1e-12);
        match self {
            VignettingShape::Quadratic => 1.0 - amount * r2,
            VignettingShape::Cos4 => {
                // 1/(1 + r²/f²)² with 1 − amount at r = 1
                let inv_f2 = (1.0 - amount).powf(-0.5) - 1.0;
                1.0 / (1.0 + r2 * inv_f2).powi(2)
            }
            VignettingShape::Linear => {
                let (p, len) = match axis {
                    Axis::X => (x as f64, w),
                    Axis::Y => (y as f64, h),
                };
                1.0 - amount * p / (len - 1.0).max(1.0)
            }
            VignettingShape::Offcentre => {
                let (ox, oy) = (0.75 * (w - 1.0), (h - 1.0) / 3.0);
                let far = [
                    (0.0, 0.0),
                    (w - 1.0, 0.0),
                    (0.0, h - 1.0),
                    (w - 1.0, h - 1.0),
                ]
                .iter()
                .map(|(a, b)| (a - ox) * (a - ox) + (b - oy) * (b - oy))
                .fold(0.0f64, f64::max)
                .max(1e-12);
                let (ex, ey) = (x as f64 - ox, y as f64 - oy);
                1.0 - amount * (ex * ex + ey * ey) / far
            }
        }
    }
}

/// The spectrum of a continuum under the lamp lines.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum ContinuumShape {
    /// Equal power at every wavelength.
    Flat,
    /// Planck's law at this temperature (K).
    Blackbody(f64),
    /// The broad emission bands under a CFL's lines: a blue band (BaMgAl₁₀O₁₇:Eu²⁺, peak
    /// 450 nm, FWHM 50 nm) and weak broad green and red wings (520 nm / 80 nm at 0.3,
    /// 620 nm / 120 nm at 0.2) — a typical shape, not a measurement.
    Cfl,
}

impl ContinuumShape {
    /// Parses `flat`, `cfl` or `blackbody:K`, the value of the flag `flag`.
    ///
    /// # Errors
    /// [`Error::Flag`] naming `flag`, what was given and what is expected.
    pub fn parse(flag: &str, s: &str) -> Result<Self> {
        let t = s.trim().to_ascii_lowercase();
        if t == "flat" {
            return Ok(ContinuumShape::Flat);
        }
        if t == "cfl" {
            return Ok(ContinuumShape::Cfl);
        }
        if let Some(k) = t.strip_prefix("blackbody:") {
            if let Ok(k) = k.parse::<f64>() {
                if (500.0..=50_000.0).contains(&k) {
                    return Ok(ContinuumShape::Blackbody(k));
                }
            }
        }
        Err(Error::flag(
            flag,
            format!("'{s}': expected flat, cfl or blackbody:K with 500 ≤ K ≤ 50000"),
        ))
    }

    /// Relative spectral power at `nm` (any scale; the renderer normalises).
    pub fn value(self, nm: f64) -> f64 {
        let band = |c: f64, fwhm: f64| {
            let s = fwhm / (8.0 * std::f64::consts::LN_2).sqrt();
            (-0.5 * ((nm - c) / s).powi(2)).exp()
        };
        match self {
            ContinuumShape::Flat => 1.0,
            ContinuumShape::Blackbody(t) => {
                crate::colorimetry::blackbody::planck_law(nm * 1e-9, t).unwrap_or(0.0)
            }
            ContinuumShape::Cfl => {
                band(450.0, 50.0) + 0.3 * band(520.0, 80.0) + 0.2 * band(620.0, 120.0)
            }
        }
    }
}

/// A continuum under the lines and its size.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Continuum {
    /// Its spectrum.
    pub shape: ContinuumShape,
    /// Its largest value through passband and camera over the brightest line blob's.
    pub fraction: f64,
}

/// 8-point Gauss–Legendre nodes and weights on [−½, ½] (weights sum to 1).
const GL8: [(f64, f64); 8] = [
    (-0.480_144_830_023_052_4, 0.050_614_268_145_188_13),
    (-0.398_333_238_706_813_3, 0.111_190_517_226_687_2),
    (-0.262_766_204_958_164_2, 0.156_853_322_938_943_6),
    (-0.091_717_321_247_824_89, 0.181_341_891_689_181_1),
    (0.091_717_321_247_824_89, 0.181_341_891_689_181_1),
    (0.262_766_204_958_164_2, 0.156_853_322_938_943_6),
    (0.398_333_238_706_813_3, 0.111_190_517_226_687_2),
    (0.480_144_830_023_052_4, 0.050_614_268_145_188_13),
];

/// The truth written beside a synthetic capture.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct LvfTruth {
    /// Schema tag.
    pub schema: &'static str,
    /// Axis.
    pub axis: Axis,
    /// Image size `[w, h]`.
    pub size: [usize; 2],
    /// True map (λ = c0 + c1·px, with a bow + c2·px²).
    pub map: serde_json::Value,
    /// True FWHM (nm).
    pub fwhm_nm: f64,
    /// The passband's shape ([`Passband::report`]).
    pub passband: serde_json::Value,
    /// Position of 400 nm (px).
    pub px_at_400: f64,
    /// Position of 700 nm (px).
    pub px_at_700: f64,
    /// Slant of the iso-wavelength lines (degrees; the map and positions hold at the middle
    /// across the axis, `(size − 1)/2`).
    pub tilt_deg: f64,
    /// Lamp name and lines.
    pub lamp: Lamp,
    /// Camera name.
    pub camera: String,
    /// Noise level.
    pub noise: f64,
    /// Vignetting.
    pub vignetting: f64,
    /// Vignetting shape.
    pub vignetting_shape: VignettingShape,
    /// The continuum under the lines, if any.
    pub continuum: Option<Continuum>,
    /// Seed.
    pub seed: u64,
}

pub(crate) fn sensitivity(camera: &MultiSpectrum, c: usize, nm: f64) -> f64 {
    let wl = camera.wavelengths();
    let v = camera.channel(c);
    let n = wl.len();
    if n == 0 || nm < wl[0] || nm > wl[n - 1] {
        return 0.0;
    }
    let i = wl.partition_point(|&w| w <= nm).clamp(1, n - 1);
    let f = (nm - wl[i - 1]) / (wl[i] - wl[i - 1]);
    (v[i - 1] + f * (v[i] - v[i - 1])).max(0.0)
}

/// Renders the capture (linear, 0–1, `pixel_scale` 1) and its truth.
///
/// # Errors
/// [`Error::InvalidArgument`] for sizes outside 16–20000 px, non-positive FWHM, negative noise or
/// vignetting outside [0, 1), or a lamp none of whose lines the camera sees in the range.
pub fn render_lvf(spec: &LvfSynthSpec) -> Result<(RgbFrame, LvfTruth)> {
    let ok_size = |v: usize| (16..=20_000).contains(&v);
    if !ok_size(spec.width) || !ok_size(spec.height) {
        return Err(Error::invalid(
            "--size",
            format!(
                "{}x{}: each side must be 16–20000 px",
                spec.width, spec.height
            ),
        ));
    }
    if !(spec.fwhm_nm > 0.0 && spec.fwhm_nm.is_finite()) {
        return Err(Error::invalid("--fwhm", "must be a positive number of nm"));
    }
    if !(spec.noise >= 0.0 && spec.noise.is_finite()) {
        return Err(Error::invalid("--noise", "must be ≥ 0"));
    }
    if !(0.0..1.0).contains(&spec.vignetting) {
        return Err(Error::invalid("--vignetting", "must be in [0, 1)"));
    }
    if !(spec.nm_per_px.is_finite() && spec.nm_per_px != 0.0 && spec.nm_at_start.is_finite()) {
        return Err(Error::invalid("--nm-per-px", "must be finite and non-zero"));
    }
    let along = match spec.axis {
        Axis::X => spec.width,
        Axis::Y => spec.height,
    };
    if let Some(c) = &spec.continuum {
        if !(c.fraction >= 0.0 && c.fraction <= 100.0) {
            return Err(Error::invalid(
                "--continuum",
                format!(
                    "{}: expected a fraction of the brightest blob in [0, 100]",
                    c.fraction
                ),
            ));
        }
    }
    // λ = c0 + c1·p + c2·p² with the bow's quadratic term
    let span = (along.max(2) - 1) as f64;
    let coeffs = [
        spec.nm_at_start,
        spec.nm_per_px + 4.0 * spec.bow_nm / span,
        -4.0 * spec.bow_nm / (span * span),
    ];
    if !spec.bow_nm.is_finite() || 4.0 * spec.bow_nm.abs() / span >= spec.nm_per_px.abs() {
        return Err(Error::invalid(
            "--bow",
            format!(
                "{} nm: the map must stay monotonic along the axis, |bow| < |nm-per-px|·(L − 1)/4 = {:.1} nm",
                spec.bow_nm,
                spec.nm_per_px.abs() * span / 4.0
            ),
        ));
    }
    let g = &spec.passband;
    let lam_at = |p: f64| coeffs[0] + coeffs[1] * p + coeffs[2] * p * p;
    // the position of a wavelength: the root of the quadratic in [0, L − 1] (or the linear map's)
    let px_at = |nm: f64| {
        if coeffs[2] == 0.0 {
            return (nm - coeffs[0]) / coeffs[1];
        }
        let (a, b, c) = (coeffs[2], coeffs[1], coeffs[0] - nm);
        let d = (b * b - 4.0 * a * c).max(0.0).sqrt();
        // the root continuous with the linear map's (−c/b) as a → 0
        2.0 * -c / (b + b.signum() * d)
    };
    if !(spec.tilt_deg.is_finite() && spec.tilt_deg.abs() < MAX_TILT_DEG) {
        return Err(Error::invalid(
            "--tilt",
            format!(
                "{} degrees: expected an angle between -{MAX_TILT_DEG} and {MAX_TILT_DEG}",
                spec.tilt_deg
            ),
        ));
    }
    // the lines at (fractional) position p, each averaged exactly over the pixel's span
    let lines_at = |p: f64| -> [f64; 3] {
        std::array::from_fn(|c| {
            spec.lamp
                .lines
                .iter()
                .map(|l| {
                    let mean_g: f64 = GL8
                        .iter()
                        .map(|(t, w)| w * g.eval(l.nm - lam_at(p + t), spec.fwhm_nm))
                        .sum();
                    l.relative_power * sensitivity(&spec.camera, c, l.nm) * mean_g
                })
                .sum()
        })
    };
    let continuum = spec.continuum.filter(|c| c.fraction > 0.0).map(|cont| {
        let grid: Vec<f64> = (360..=830).map(f64::from).collect();
        let w: Vec<[f64; 3]> = grid
            .iter()
            .map(|&l| {
                std::array::from_fn(|c| cont.shape.value(l) * sensitivity(&spec.camera, c, l))
            })
            .collect();
        (cont, grid, w)
    });
    // the continuum through the passband at (fractional) position p
    let continuum_at = |p: f64| -> [f64; 3] {
        let mut s = [0.0; 3];
        if let Some((_, grid, w)) = &continuum {
            let lc = lam_at(p);
            for (l, wl) in grid.iter().zip(w) {
                let gi = g.eval(l - lc, spec.fwhm_nm);
                if gi > 0.0 {
                    for c in 0..3 {
                        s[c] += wl[c] * gi;
                    }
                }
            }
        }
        s
    };
    let mut profile: Vec<[f64; 3]> = (0..along).map(|p| lines_at(p as f64)).collect();
    // the continuum's scale: a fraction of the brightest line blob of the square (middle) row
    let mut k_cont = 0.0;
    if let Some((cont, _, _)) = &continuum {
        let cp: Vec<[f64; 3]> = (0..along).map(|p| continuum_at(p as f64)).collect();
        let lmax = profile.iter().flatten().cloned().fold(0.0, f64::max);
        let cmax = cp.iter().flatten().cloned().fold(0.0, f64::max);
        if cmax > 0.0 && lmax > 0.0 {
            k_cont = cont.fraction * lmax / cmax;
            for (pp, cc) in profile.iter_mut().zip(&cp) {
                for c in 0..3 {
                    pp[c] += k_cont * cc[c];
                }
            }
        }
    }
    // a slanted filter: each position across the axis sees the profile shifted along it
    let across_len = match spec.axis {
        Axis::X => spec.height,
        Axis::Y => spec.width,
    };
    let slope = spec.tilt_deg.to_radians().tan();
    let slanted: Option<Vec<Vec<[f64; 3]>>> = (slope != 0.0).then(|| {
        let b0 = (across_len as f64 - 1.0) / 2.0;
        (0..across_len)
            .map(|b| {
                let shift = slope * (b as f64 - b0);
                (0..along)
                    .map(|p| {
                        let q = p as f64 + shift;
                        let (l, c) = (lines_at(q), continuum_at(q));
                        std::array::from_fn(|ch| l[ch] + k_cont * c[ch])
                    })
                    .collect()
            })
            .collect()
    });
    let value_at = |x: usize, y: usize| -> [f64; 3] {
        let (p, b) = match spec.axis {
            Axis::X => (x, y),
            Axis::Y => (y, x),
        };
        match &slanted {
            Some(rows) => rows[b][p],
            None => profile[p],
        }
    };
    let vig = |x: usize, y: usize| {
        spec.vignetting_shape
            .at(spec.vignetting, spec.axis, x, y, spec.width, spec.height)
    };
    let mut max = 0.0f64;
    for y in 0..spec.height {
        for x in 0..spec.width {
            for v in value_at(x, y) {
                max = max.max(v * vig(x, y));
            }
        }
    }
    if max <= 0.0 {
        return Err(Error::invalid(
            "synthetic LVF",
            "no lamp line falls inside the rendered wavelength range and the camera's sensitivity",
        ));
    }
    const PEAK: f64 = 0.8;
    let scale = PEAK / max;
    let mut rng = SplitMix64::new(spec.seed);
    let n = spec.width * spec.height;
    let mut data = Vec::with_capacity(3 * n);
    let mut sat = vec![0u8; n];
    for y in 0..spec.height {
        for x in 0..spec.width {
            let v = vig(x, y);
            for (c, pc) in value_at(x, y).iter().enumerate() {
                let s = (noisy_value(pc * v * scale, spec.noise, PEAK, &mut rng) + spec.pedestal)
                    .clamp(0.0, 1.0);
                if s >= 1.0 {
                    sat[y * spec.width + x] |= 1 << c;
                }
                data.push(s as f32);
            }
        }
    }
    let frame = RgbFrame::new("synthetic LVF", spec.width, spec.height, 1, data, sat)?;
    let truth = LvfTruth {
        schema: "lumifit.lvf-truth/1",
        axis: spec.axis,
        size: [spec.width, spec.height],
        map: if spec.bow_nm == 0.0 {
            serde_json::json!({"kind": "linear", "coefficients": [spec.nm_at_start, spec.nm_per_px]})
        } else {
            serde_json::json!({"kind": "quadratic", "coefficients": coeffs, "bow_nm": spec.bow_nm})
        },
        fwhm_nm: spec.fwhm_nm,
        passband: spec.passband.report(),
        px_at_400: px_at(400.0),
        px_at_700: px_at(700.0),
        tilt_deg: spec.tilt_deg,
        lamp: spec.lamp.clone(),
        camera: spec.camera.name().to_string(),
        noise: spec.noise,
        vignetting: spec.vignetting,
        vignetting_shape: spec.vignetting_shape,
        continuum: spec.continuum,
        seed: spec.seed,
    };
    Ok((frame, truth))
}
