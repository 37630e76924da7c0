//! Flat-field photo through the LVF: the fall-off divided out with the flat's own smooth model.
//!
//! A flat field is a photo of a broadband source (a white target under a halogen lamp, or the
//! white reference of the transmission calibration) through the same filter, lens and framing as
//! the lamp photo. Averaged across the axis like the lamp profile, channel c reads
//!
//! ```text
//! F_c(a) = V̄(a) · S_c(a),     S_c(a) = k_c · ∫ S(λ)·Q_c(λ)·g(λ − λ(a)) dλ
//! ```
//!
//! with V̄(a) the fall-off averaged across the ROI at position a along the axis (the same V̄
//! that multiplies the lamp profile, since both are averaged over the same pixels), S(λ) the
//! flat's source spectrum, Q_c the camera's sensitivity, g the passband and k_c an unknown
//! per-channel scale. What can and cannot be separated:
//!
//! - **Source spectrum and camera known** (`--flat-spectrum` with `--camera`): S_c(a) is
//!   predicted from the lamp fit's map λ(a) and passband, and V̄(a) = F_c(a)/S_c(a) up to k_c,
//!   common to the three channels ([`FlatFalloff`], solved jointly in ln with one constant per
//!   channel and a degree-[`FLAT_POLY_DEGREE`] polynomial in u, weighted by signal). Every smooth
//!   shape is recovered — tilt, off-centre, cos⁴ — because nothing is assumed about V. The map
//!   and V̄ depend on each other weakly (an error δλ in the map changes ln S_c by
//!   δλ·d ln S_c/dλ), so the lamp fit and V̄ are alternated until the map at 400/700 nm moves
//!   by < [`FLAT_ITER_TOL_NM`].
//! - **Spectrum unknown**: the along-axis part of V̄ cannot be told from the flat's own
//!   spectrum S_c(a) — any smooth factor along the axis can be moved from one to the other —
//!   so only the variation *across* the axis is used: the flat's strips go through the same
//!   radial estimate as the lamp's ([`crate::lvf::background::estimate_radial_falloff`]), with
//!   far more signal (every position is bright, not only the line blobs). A fall-off radial
//!   about the image centre is recovered; a linear tilt along the axis or the along-axis part
//!   of an off-centre fall-off is not, and the report says so.
//!
//! Dividing the lamp photo by the flat pixel by pixel would be wrong: it replaces V̄ by
//! 1/S_c(a), a camera-shaped bump per channel that biases the line blobs just like vignetting.

use crate::capture::RgbFrame;
use crate::error::{Error, Result};
use crate::lvf::background::{estimate_radial_falloff, RadialFalloff};
use crate::lvf::calibration::LvfCalibration;
use crate::lvf::fit::{calibrate_whole_profile, FitOptions, Passband};
use crate::lvf::lamp::Lamp;
use crate::lvf::profile::{extract_profile_tilted, Axis, Profile, Tilt};
use crate::lvf::synth::{sensitivity, ContinuumShape};
use crate::spectrum::MultiSpectrum;

/// Most saturated pixels a flat may have inside the ROI (fraction): a clipped flat has a
/// flattened top, i.e. a wrong fall-off.
pub const FLAT_SATURATED_MAX: f64 = 0.001;
/// Least brightness of a flat: its brightest channel's profile must reach this fraction of full
/// scale (below, quantisation and read noise dominate the fall-off).
pub const FLAT_DARK_MIN: f64 = 0.02;
/// Degree of the polynomial in u = (px − mid)/half for ln V̄ (smooth shapes: cos⁴, quadratic,
/// tilt and off-centre are all represented to < 10⁻⁴ at degree 6 over a 0.3 fall-off).
pub const FLAT_POLY_DEGREE: usize = 6;
/// A channel's predicted flat signal is used where it exceeds this fraction of its maximum.
pub const FLAT_MIN_SIGNAL: f64 = 0.05;
/// The lamp fit and the flat's fall-off are alternated until λ at 400/700 nm moves by less.
pub const FLAT_ITER_TOL_NM: f64 = 1e-3;
/// Most alternations.
pub const FLAT_MAX_ITER: usize = 6;

/// The flat's source spectrum seen by a known camera.
#[derive(Debug, Clone)]
pub struct FlatSpectrum {
    /// The source's spectrum (flat, blackbody:K, …).
    pub shape: ContinuumShape,
    /// Camera sensitivities (3 channels).
    pub camera: MultiSpectrum,
    /// Name of the camera for the report.
    pub camera_name: String,
}

impl FlatSpectrum {
    /// The source spectrum `shape` (flat, blackbody:K, cfl; [`ContinuumShape::parse`]) seen
    /// through the sensitivities `camera` (named `camera_name` in the report).
    ///
    /// # Errors
    /// Those of [`ContinuumShape::parse`], naming `--flat-spectrum`.
    pub fn parse(shape: &str, camera: &MultiSpectrum, camera_name: &str) -> Result<Self> {
        Ok(FlatSpectrum {
            shape: ContinuumShape::parse("--flat-spectrum", shape)?,
            camera: camera.clone(),
            camera_name: camera_name.to_string(),
        })
    }
}

/// A flat-field photo reduced to its profile over the lamp's ROI.
#[derive(Debug, Clone)]
pub struct FlatField {
    /// Name of the file.
    pub source: String,
    /// Its profile (same ROI and axis as the lamp's), with strips.
    pub profile: Profile,
    /// Its spectrum and camera, when known.
    pub spectrum: Option<FlatSpectrum>,
}

impl FlatField {
    /// Reduces `flat` over `roi` (along the lamp photo's slanted iso-wavelength lines when
    /// `tilt` is given, so that both profiles average the same pixels), checking that it fits the lamp photo of size `lamp_size`
    /// (source px).
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] naming `--flat` and the file when the flat's size differs from
    /// the lamp photo's, more than [`FLAT_SATURATED_MAX`] of its ROI pixels are saturated, or it
    /// is darker than [`FLAT_DARK_MIN`] of full scale.
    pub fn new(
        flat: &RgbFrame,
        lamp_size: (usize, usize),
        roi: [usize; 4],
        axis: Axis,
        tilt: Option<&Tilt>,
        spectrum: Option<FlatSpectrum>,
    ) -> Result<Self> {
        let name = &flat.name;
        let size = flat.source_size();
        if size != lamp_size {
            return Err(Error::invalid(
                "--flat",
                format!(
                    "{name}: {}×{} px, but the lamp photo is {}×{} px; expected a flat field of the same size (same camera, lens and framing)",
                    size.0, size.1, lamp_size.0, lamp_size.1
                ),
            ));
        }
        let [x, y, w, h] = roi;
        let inside =
            |c: f64, lo: usize, len: usize| c >= lo as f64 - 0.5 && c < (lo + len) as f64 - 0.5;
        let (mut n, mut sat) = (0usize, 0usize);
        for fy in 0..flat.height {
            if !inside(flat.source_coordinate(fy), y, h) {
                continue;
            }
            for fx in 0..flat.width {
                if inside(flat.source_coordinate(fx), x, w) {
                    n += 1;
                    sat += usize::from(flat.saturation_bits(fx, fy) != 0);
                }
            }
        }
        if n > 0 && sat as f64 > FLAT_SATURATED_MAX * n as f64 {
            return Err(Error::invalid(
                "--flat",
                format!(
                    "{name}: {sat} of {n} pixels in ROI {x},{y},{w},{h} are saturated ({:.2} %, at most {:.1} % allowed); a clipped flat flattens the fall-off — use a shorter exposure",
                    100.0 * sat as f64 / n as f64,
                    100.0 * FLAT_SATURATED_MAX
                ),
            ));
        }
        let profile = extract_profile_tilted(flat, roi, axis, tilt)?;
        let peak = profile
            .values
            .iter()
            .flatten()
            .cloned()
            .fold(f64::MIN, f64::max);
        if peak.is_nan() || peak < FLAT_DARK_MIN {
            return Err(Error::invalid(
                "--flat",
                format!(
                    "{name}: too dark: its brightest channel peaks at {:.4} of full scale in ROI {x},{y},{w},{h}; expected ≥ {FLAT_DARK_MIN} (a broadband source through the LVF: longer exposure or brighter light)",
                    peak.max(0.0)
                ),
            ));
        }
        Ok(Self {
            source: name.clone(),
            profile,
            spectrum,
        })
    }
}

/// The fall-off recovered from a flat with a known spectrum.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct FlatFalloff {
    /// V̄ at each lamp profile position, largest 1.
    #[serde(skip)]
    pub along: Vec<f64>,
    /// V̄ at the first and last position.
    pub at_ends: [f64; 2],
    /// RMS of the channels' ln(F_c/S_c) about the common fit (how well one V̄ explains all
    /// three channels; noise plus any error of the assumed spectrum or camera).
    pub rms_ln_residual: f64,
    /// Samples (position × channel) used.
    pub samples: usize,
}

/// Linear interpolation of `ys` (at increasing `xs`) at `x`, clamped at the ends.
fn interp(xs: &[f64], ys: &[f64], x: f64) -> f64 {
    let n = xs.len();
    if n == 0 {
        return f64::NAN;
    }
    if x <= xs[0] {
        return ys[0];
    }
    if x >= xs[n - 1] {
        return ys[n - 1];
    }
    let i = xs.partition_point(|&v| v <= x).clamp(1, n - 1);
    let f = (x - xs[i - 1]) / (xs[i] - xs[i - 1]);
    ys[i - 1] + f * (ys[i] - ys[i - 1])
}

/// V̄ at the lamp's positions `px` from a flat of known spectrum, given the map λ(px) and the
/// passband (see the module docs).
///
/// # Errors
/// [`Error::Numerical`] when fewer than 2·([`FLAT_POLY_DEGREE`] + 4) samples have signal.
pub fn flat_falloff_known(
    flat: &Profile,
    spectrum: &FlatSpectrum,
    px: &[f64],
    lambda_at: impl Fn(f64) -> f64,
    passband: &Passband,
    fwhm_nm: f64,
) -> Result<FlatFalloff> {
    let grid: Vec<f64> = (360..=830).map(f64::from).collect();
    let w: Vec<[f64; 3]> = grid
        .iter()
        .map(|&l| {
            std::array::from_fn(|c| spectrum.shape.value(l) * sensitivity(&spectrum.camera, c, l))
        })
        .collect();
    let n = px.len();
    let predicted: Vec<[f64; 3]> = px
        .iter()
        .map(|&p| {
            let lc = lambda_at(p);
            let mut s = [0.0; 3];
            for (l, wl) in grid.iter().zip(&w) {
                let g = passband.eval(l - lc, fwhm_nm);
                if g > 0.0 {
                    for c in 0..3 {
                        s[c] += wl[c] * g;
                    }
                }
            }
            s
        })
        .collect();
    let lo = px.iter().cloned().fold(f64::INFINITY, f64::min);
    let hi = px.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    let (mid, half) = (0.5 * (lo + hi), (0.5 * (hi - lo)).max(0.5));
    // rows: (position i, channel c, ln ratio, weight)
    let mut rows: Vec<(usize, usize, f64, f64)> = Vec::new();
    for c in 0..3 {
        let smax = predicted.iter().map(|s| s[c]).fold(0.0, f64::max);
        if smax <= 0.0 {
            continue;
        }
        for (i, &p) in px.iter().enumerate() {
            let f = interp(&flat.px, &flat.values[c], p);
            let s = predicted[i][c];
            if s > FLAT_MIN_SIGNAL * smax && f > 0.0 && f.is_finite() {
                // shot-noise-like weight: the relative error of F_c falls as its signal grows
                rows.push((i, c, (f / s).ln(), f));
            }
        }
    }
    let d = FLAT_POLY_DEGREE;
    let n_par = d + 1 + 3; // polynomial (constant included) + 3 channel constants, one pinned
    if rows.len() < 2 * n_par {
        return Err(Error::Numerical {
            what: "flat-field fall-off".into(),
            reason: format!(
                "only {} position × channel samples of the flat have signal; the flat and its spectrum do not overlap the camera's channels in this ROI",
                rows.len()
            ),
        });
    }
    // ln ratio = Σ_j p_j u^j + k_c (k_0 = 0): weighted linear least squares.
    let cols = d + 1 + 2;
    let mut a = nalgebra::DMatrix::<f64>::zeros(cols, cols);
    let mut b = nalgebra::DVector::<f64>::zeros(cols);
    let row_of = |i: usize, c: usize| -> Vec<f64> {
        let u = (px[i] - mid) / half;
        let mut r = vec![0.0; cols];
        let mut p = 1.0;
        for v in r.iter_mut().take(d + 1) {
            *v = p;
            p *= u;
        }
        if c > 0 {
            r[d + c] = 1.0;
        }
        r
    };
    for &(i, c, y, wt) in &rows {
        let r = row_of(i, c);
        for j in 0..cols {
            b[j] += wt * r[j] * y;
            for k in 0..cols {
                a[(j, k)] += wt * r[j] * r[k];
            }
        }
    }
    for j in 0..cols {
        a[(j, j)] += 1e-12 * a[(j, j)].max(1e-300);
    }
    let coef = a
        .cholesky()
        .map(|ch| ch.solve(&b))
        .ok_or_else(|| Error::Numerical {
            what: "flat-field fall-off".into(),
            reason: "the flat's channels do not determine a common fall-off (singular system)"
                .into(),
        })?;
    let ln_v: Vec<f64> = (0..n)
        .map(|i| {
            let r = row_of(i, 0);
            (0..=d).map(|j| r[j] * coef[j]).sum()
        })
        .collect();
    let (mut sr, mut sw) = (0.0, 0.0);
    for &(i, c, y, wt) in &rows {
        let r = row_of(i, c);
        let m: f64 = r.iter().zip(coef.iter()).map(|(x, k)| x * k).sum();
        sr += wt * (y - m) * (y - m);
        sw += wt;
    }
    let top = ln_v.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    let along: Vec<f64> = ln_v.iter().map(|l| (l - top).exp()).collect();
    Ok(FlatFalloff {
        at_ends: [along[0], along[n - 1]],
        rms_ln_residual: (sr / sw.max(1e-300)).sqrt(),
        samples: rows.len(),
        along,
    })
}

/// V̄ at the lamp's positions from the flat's variation across the axis only (spectrum
/// unknown): the radial estimate on the flat's strips.
///
/// # Errors
/// [`Error::InvalidArgument`] when the flat's ROI has fewer than two strips across the axis.
pub fn flat_falloff_radial(flat: &FlatField, px: &[f64]) -> Result<(RadialFalloff, Vec<f64>)> {
    let r = estimate_radial_falloff(&flat.profile).ok_or_else(|| {
        Error::invalid(
            "--flat",
            format!(
                "{}: the ROI is too narrow across the axis to see the fall-off (needs ≥ 4 px, 2 strips); give --flat-spectrum and --camera so the along-axis fall-off can be solved",
                flat.source
            ),
        )
    })?;
    let along: Vec<f64> = px
        .iter()
        .map(|&p| interp(&flat.profile.px, &r.along, p))
        .collect();
    let top = along.iter().cloned().fold(0.0, f64::max).max(1e-300);
    Ok((r, along.iter().map(|v| v / top).collect()))
}

/// Whole-profile calibration with the fall-off taken from a flat-field photo (see the module
/// docs): with a known flat spectrum the lamp fit and the flat's V̄ alternate until the map is
/// stable; without one the flat's across-axis (radial) estimate is used. lvf.json's
/// `background.flat_field` names the file and `background.falloff_source` says which part of
/// the fall-off the flat determined. The change of λ at 400/700 nm over the last alternation is
/// added (in quadrature) to the systematic σ.
///
/// # Errors
/// Those of [`calibrate_whole_profile`], [`flat_falloff_known`] and [`flat_falloff_radial`].
pub fn calibrate_with_flat(
    profile: &Profile,
    lamp: &Lamp,
    opts: &FitOptions,
    flat: &FlatField,
) -> Result<LvfCalibration> {
    let px = &profile.px;
    let (mut cal, source, iterations, last_change, detail) = match &flat.spectrum {
        None => {
            let (r, along) = flat_falloff_radial(flat, px)?;
            let o = FitOptions {
                fixed_falloff: Some(along),
                ..opts.clone()
            };
            let cal = calibrate_whole_profile(profile, lamp, &o)?;
            let source = format!(
                "flat-field {} (across-axis only, radial about the image centre: the flat's spectrum is unknown, so a fall-off along the axis — tilt, off-centre — cannot be separated from it; give --flat-spectrum and --camera)",
                flat.source
            );
            (
                cal,
                source,
                1,
                [0.0; 2],
                serde_json::json!({"kind": "radial", "radial": r}),
            )
        }
        Some(spec) => {
            let mut cal = calibrate_whole_profile(profile, lamp, opts)?;
            let mut change = [f64::INFINITY; 2];
            let mut it = 0;
            let mut ff = None;
            while it < FLAT_MAX_ITER && change.iter().any(|c| *c > FLAT_ITER_TOL_NM) {
                let f = flat_falloff_known(
                    &flat.profile,
                    spec,
                    px,
                    |p| cal.map.eval(p),
                    &opts.passband,
                    cal.fwhm_nm,
                )?;
                let o = FitOptions {
                    fixed_falloff: Some(f.along.clone()),
                    ..opts.clone()
                };
                let next = calibrate_whole_profile(profile, lamp, &o)?;
                // change of λ at the previous map's 400/700 nm positions
                change = [400.0, 700.0].map(|nm| {
                    cal.map
                        .inverse(nm)
                        .map(|p| (next.map.eval(p) - nm).abs())
                        .unwrap_or(0.0)
                });
                cal = next;
                ff = Some(f);
                it += 1;
            }
            let source = format!(
                "flat-field {} (spectrum {:?} through camera {}: the fall-off along and across the axis)",
                flat.source, spec.shape, spec.camera_name
            );
            (
                cal,
                source,
                it,
                change,
                serde_json::json!({"kind": "known-spectrum", "fit": ff}),
            )
        }
    };
    if let Some(b) = cal.background.as_mut() {
        b.flat_field = Some(flat.source.clone());
        b.falloff_source = source;
        b.systematic_note.push_str(&format!(
            "; with the flat field, the change of λ over the last lamp-fit/flat alternation ({:.4} / {:.4} nm) is added in quadrature",
            last_change[0], last_change[1]
        ));
    }
    let add = |s: f64, d: f64| (s * s + d * d).sqrt();
    cal.sigma_systematic_nm_at_400 = add(cal.sigma_systematic_nm_at_400, last_change[0]);
    cal.sigma_systematic_nm_at_700 = add(cal.sigma_systematic_nm_at_700, last_change[1]);
    cal.combine_sigma();
    cal.diagnostics["flat_field"] = serde_json::json!({
        "file": flat.source,
        "alternations": iterations,
        "last_change_nm_at_400_700": last_change,
        "detail": detail,
    });
    Ok(cal)
}
