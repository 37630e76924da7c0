//! The naive baseline: pick the peaks of the profile and fit a straight line through them
//! (Nalbach et al. 2017, §4.2: "localizing the spectral lines of a mercury vapor lamp and
//! extrapolating them linearly").
//!
//! The channel sum is smoothed (moving average over 1 % of the profile), local maxima with a
//! prominence of at least 5 % of the range are located to sub-pixel precision by a parabola, and
//! matched in order to the lamp's line groups (lines closer than the assumed FWHM merge into one
//! group at their mean wavelength). Blended blobs pull the peaks towards each other, which is the
//! bias the whole-profile fit removes.

use crate::error::{Error, Result};
use crate::lvf::calibration::{
    LineReport, LvfCalibration, MapKind, MapModel, MapSelection, ProfileCurves,
};
use crate::lvf::fit::{check_signal, group_lines, FitOptions};
use crate::lvf::lamp::Lamp;
use crate::lvf::profile::Profile;

/// Peak-picking calibration (baseline).
///
/// # Errors
/// [`Error::InvalidArgument`] when the profile shows no lines or fewer than two peaks.
pub fn calibrate_peaks(
    profile: &Profile,
    lamp: &Lamp,
    opts: &FitOptions,
) -> Result<LvfCalibration> {
    check_signal(profile)?;
    let increasing = opts.direction.is_increasing(profile)?;
    let n = profile.px.len();
    let sum: Vec<f64> = (0..n)
        .map(|i| (0..3).map(|c| profile.values[c][i]).sum())
        .collect();
    let r = (n / 200).max(1);
    let smooth: Vec<f64> = (0..n)
        .map(|i| {
            let lo = i.saturating_sub(r);
            let hi = (i + r + 1).min(n);
            sum[lo..hi].iter().sum::<f64>() / (hi - lo) as f64
        })
        .collect();
    let max = smooth.iter().cloned().fold(f64::MIN, f64::max);
    let min = smooth.iter().cloned().fold(f64::MAX, f64::min);
    let mut peaks: Vec<(f64, f64)> = Vec::new(); // (prominence, px)
    for i in 1..n - 1 {
        if !(smooth[i] > smooth[i - 1] && smooth[i] >= smooth[i + 1]) {
            continue;
        }
        let left_base = {
            let mut m = smooth[i];
            let mut j = i;
            while j > 0 && smooth[j - 1] <= smooth[i] {
                j -= 1;
                m = m.min(smooth[j]);
            }
            m
        };
        let right_base = {
            let mut m = smooth[i];
            let mut j = i;
            while j + 1 < n && smooth[j + 1] <= smooth[i] {
                j += 1;
                m = m.min(smooth[j]);
            }
            m
        };
        let prom = smooth[i] - left_base.max(right_base);
        if prom >= 0.05 * (max - min) {
            let (a, b, c) = (smooth[i - 1], smooth[i], smooth[i + 1]);
            let denom = a - 2.0 * b + c;
            let off = if denom != 0.0 {
                0.5 * (a - c) / denom
            } else {
                0.0
            };
            let step = profile.px[i + 1] - profile.px[i];
            peaks.push((prom, profile.px[i] + off.clamp(-1.0, 1.0) * step));
        }
    }
    let lines: Vec<f64> = lamp.lines.iter().map(|l| l.nm).collect();
    let groups = group_lines(&lines, opts.fwhm_guess_nm);
    // Blobs that merged into a shoulder give no peak: match the peaks found to the strongest
    // groups (by the lamp's nominal relative powers), as one would by eye.
    let mut by_power: Vec<(f64, f64)> = groups
        .iter()
        .map(|g| {
            let nm = g.iter().map(|&i| lines[i]).sum::<f64>() / g.len() as f64;
            let power: f64 = g.iter().map(|&i| lamp.lines[i].relative_power).sum();
            (power, nm)
        })
        .collect();
    by_power.sort_by(|a, b| b.0.total_cmp(&a.0));
    let k_used = peaks.len().min(groups.len());
    if k_used < 2 {
        return Err(Error::invalid(
            "--method peaks",
            format!(
                "{}: found {} peak(s); peak picking needs at least two resolved peaks (use the whole-profile method)",
                profile.source,
                peaks.len()
            ),
        ));
    }
    let mut nominal: Vec<f64> = by_power[..k_used].iter().map(|p| p.1).collect();
    nominal.sort_by(f64::total_cmp);
    peaks.sort_by(|a, b| b.0.total_cmp(&a.0));
    peaks.truncate(k_used);
    let mut pos: Vec<f64> = peaks.iter().map(|p| p.1).collect();
    pos.sort_by(f64::total_cmp);
    if !increasing {
        pos.reverse();
    }
    // Least squares λ = c0 + c1·px.
    let k = pos.len() as f64;
    let mx = pos.iter().sum::<f64>() / k;
    let my = nominal.iter().sum::<f64>() / k;
    let sxx: f64 = pos.iter().map(|x| (x - mx).powi(2)).sum();
    let sxy: f64 = pos
        .iter()
        .zip(&nominal)
        .map(|(x, y)| (x - mx) * (y - my))
        .sum();
    if sxx <= 0.0 {
        return Err(Error::invalid(
            "--method peaks",
            "all peaks at one position",
        ));
    }
    let c1 = sxy / sxx;
    let c0 = my - c1 * mx;
    let res: Vec<f64> = pos
        .iter()
        .zip(&nominal)
        .map(|(x, y)| c0 + c1 * x - y)
        .collect();
    let s2 = if pos.len() > 2 {
        res.iter().map(|r| r * r).sum::<f64>() / (k - 2.0)
    } else {
        0.0
    };
    let var_c1 = s2 / sxx;
    let var_c0 = s2 * (1.0 / k + mx * mx / sxx);
    let cov01 = -s2 * mx / sxx;
    let map = MapModel {
        kind: MapKind::Linear,
        coefficients: vec![c0, c1],
        covariance: vec![vec![var_c0, cov01], vec![cov01, var_c1]],
    };
    let rms = (res.iter().map(|r| r * r).sum::<f64>() / k).sqrt();
    let line_reports = nominal
        .iter()
        .zip(&pos)
        .zip(&res)
        .map(|((&nm, &px), &r)| LineReport {
            nm,
            px,
            residual_nm: Some(r),
            residual_sigma_nm: None,
            amplitude: [0.0; 3],
        })
        .collect();
    let mut cal = LvfCalibration {
        schema: crate::lvf::calibration::LVF_SCHEMA,
        method: "peaks".into(),
        source: profile.source.clone(),
        axis: profile.axis,
        roi: profile.roi,
        tilt: profile.tilt,
        lamp: lamp.name.clone(),
        map,
        fwhm_nm: opts.fwhm_guess_nm,
        fwhm_sigma_nm: 0.0,
        // the shape the user gave, for the bands the next commands draw from lvf.json
        passband: opts.passband.report(),
        rms_residual_nm: rms,
        rms_residual_relative: None,
        sigma_nm_at_400: 0.0,
        sigma_nm_at_700: 0.0,
        sigma_statistical_nm_at_400: 0.0,
        sigma_statistical_nm_at_700: 0.0,
        sigma_systematic_nm_at_400: 0.0,
        sigma_systematic_nm_at_700: 0.0,
        lines: line_reports,
        bands: Vec::new(),
        map_selection: MapSelection {
            requested: "linear".into(),
            f_statistic: None,
            quadratic_t: None,
            reason: "peak picking fits a straight line".into(),
        },
        wavelength_increases_with_px: increasing,
        background: None,
        unexplained_lines: Vec::new(),
        warnings: Vec::new(),
        diagnostics: serde_json::json!({ "peaks": pos.len(), "smoothing_radius_px": r }),
        curves: ProfileCurves {
            px: profile.px.clone(),
            data: profile.values.clone(),
            model: Default::default(),
            background: Default::default(),
            falloff: Vec::new(),
            falloff_sigma: Vec::new(),
        },
    };
    cal.set_bands(opts.n_bands)?;
    Ok(cal)
}
