//! Lines the lamp list does not hold: found in the residual, fitted as free lines, reported.
//!
//! A strong line missing from the lamp list (a contaminant in the lamp, a line the list left
//! out) is a blob the model can only explain by moving the map and the neighbouring lines, so a
//! fit with the list alone is biased by nanometres before anything is reported. When the
//! residual of the fit with the coarsest continuum is well above the noise (RMS over noise >
//! [`SEARCH_OVER_NOISE`]), it is searched with a matched filter — the fitted passband (times the
//! fall-off) slid along the profile, per channel, amplitude a = Σ r·t / Σ t², significance
//! a/(σ_c/√Σ t²) — for blobs at least [`MIN_SIGMA`] standard errors and [`MIN_RELATIVE`] of the
//! profile's peak that are a peak of the significance and lie farther than half a FWHM from
//! every listed line. The best ([`TRIED_PER_ROUND`]) are each tried as an extra line whose
//! wavelength is a free parameter fitted jointly with the map ([`crate::lvf::unlisted`]:
//! multi-start, bounded to ±2 FWHM of the blob); the line is kept when the BIC (its wavelength
//! counted as one more parameter) falls by at least [`MIN_BIC_GAIN`], and the search repeats on
//! the new residual, up to [`MAX_EXTRA`] lines. Kept lines stay in the model for every
//! background candidate, and are reported (`unexplained_lines` with `fitted: true`, a warning
//! naming the fitted wavelength).

/// Residual RMS over the noise above which the residual is searched for unlisted lines (the
/// same level at which [`crate::lvf::fit`] warns of residual structure).
pub const SEARCH_OVER_NOISE: f64 = 3.0;
/// A blob must exceed this many standard errors of its matched-filter amplitude …
pub const MIN_SIGMA: f64 = 8.0;
/// … and this fraction of the profile's peak to be tried.
pub const MIN_RELATIVE: f64 = 0.01;
/// An extra line is kept when it lowers the BIC by at least this much (a "very strong" ΔBIC on
/// Kass & Raftery's scale is 10; the model misfit of a continuum can mimic a weak blob, so the
/// bar is set higher).
pub const MIN_BIC_GAIN: f64 = 25.0;
/// Candidates tried per round.
pub const TRIED_PER_ROUND: usize = 2;
/// Most unlisted lines added.
pub const MAX_EXTRA: usize = 3;

/// A blob in the residual: where, how big, how significant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Blob {
    /// Index of the profile sample at its centre.
    pub index: usize,
    /// Wavelength there (nm, current map).
    pub nm: f64,
    /// Amplitude over the profile's peak (largest channel).
    pub relative: f64,
    /// Amplitude over its standard error (that channel).
    pub significance: f64,
}

/// Matched filter of a channel-major residual (`3·n` values) with the passband `g(Δλ)` at each
/// sample's wavelength `lams[i]`, times `scale[i]` (the fall-off): per sample, the largest
/// channel amplitude over `peak` and its significance against `noise[c]`.
pub(crate) fn matched_filter(
    lams: &[f64],
    scale: &[f64],
    residual: &[f64],
    g: &dyn Fn(f64) -> f64,
    reach_nm: f64,
    noise: [f64; 3],
    peak: f64,
) -> Vec<(f64, f64)> {
    let n = lams.len();
    let mut score = vec![(0.0f64, 0.0f64); n];
    for (i, &li) in lams.iter().enumerate() {
        let (mut stt, mut srt) = (0.0, [0.0; 3]);
        for (j, &lj) in lams.iter().enumerate() {
            let d = lj - li;
            if d.abs() > reach_nm {
                continue;
            }
            let tj = scale.get(j).copied().unwrap_or(1.0) * g(-d);
            stt += tj * tj;
            for (c, s) in srt.iter_mut().enumerate() {
                *s += residual[c * n + j] * tj;
            }
        }
        if stt <= 0.0 {
            continue;
        }
        for (c, s) in srt.iter().enumerate() {
            let a = s / stt;
            let sig = a / (noise[c].max(1e-12 * peak) / stt.sqrt());
            if a / peak > score[i].0 {
                score[i] = (a / peak, sig);
            }
        }
    }
    score
}

/// The blobs of a matched-filter `score` worth trying as unlisted lines, best (most
/// significant) first: above [`MIN_SIGMA`] and [`MIN_RELATIVE`], the most significant within
/// ±FWHM/2 (a peak, not the flank of a listed line's residual), inside the profile by half a
/// FWHM, farther than half a FWHM from every `listed` wavelength and a FWHM from each other.
pub(crate) fn blobs(score: &[(f64, f64)], lams: &[f64], fwhm: f64, listed: &[f64]) -> Vec<Blob> {
    let lo = lams.iter().cloned().fold(f64::INFINITY, f64::min);
    let hi = lams.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    let mut order: Vec<usize> = (0..score.len()).collect();
    order.sort_by(|&a, &b| score[b].1.total_cmp(&score[a].1));
    let mut out: Vec<Blob> = Vec::new();
    for i in order {
        let (rel, sig) = score[i];
        if sig < MIN_SIGMA {
            break;
        }
        let nm = lams[i];
        // a blob's centre is a peak of the significance within ±FWHM/2, not the flank of a
        // listed line's residual
        let is_peak = lams
            .iter()
            .zip(score)
            .all(|(l, sc)| (l - nm).abs() > 0.5 * fwhm || sc.1 <= sig);
        if !is_peak
            || rel < MIN_RELATIVE
            || nm < lo + 0.5 * fwhm
            || nm > hi - 0.5 * fwhm
            || listed.iter().any(|l| (l - nm).abs() < 0.5 * fwhm)
            || out.iter().any(|b| (b.nm - nm).abs() < fwhm)
        {
            continue;
        }
        out.push(Blob {
            index: i,
            nm,
            relative: rel,
            significance: sig,
        });
        if out.len() >= TRIED_PER_ROUND {
            break;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn gauss(d: f64) -> f64 {
        let s = 25.0 / (8.0 * std::f64::consts::LN_2).sqrt();
        (-0.5 * (d / s).powi(2)).exp()
    }

    #[test]
    fn a_blob_in_the_residual_is_found_at_its_wavelength_and_listed_ones_are_skipped() {
        let lams: Vec<f64> = (0..1200).map(|i| 372.3 + 0.3117 * i as f64).collect();
        let n = lams.len();
        let mut r = vec![0.0; 3 * n];
        for (i, l) in lams.iter().enumerate() {
            r[n + i] = 0.1 * gauss(l - 490.0) + 0.05 * gauss(l - 546.1);
            // a deterministic ±0.001 ripple as "noise"
            r[i] = if i % 2 == 0 { 1e-3 } else { -1e-3 };
        }
        let score = matched_filter(&lams, &[], &r, &gauss, 50.0, [1e-3; 3], 1.0);
        let b = blobs(&score, &lams, 25.0, &[546.074]);
        assert_eq!(b.len(), 1, "{b:?}");
        assert!((b[0].nm - 490.0).abs() < 0.5, "{b:?}");
        assert!((b[0].relative - 0.1).abs() < 0.01, "{b:?}");
    }

    #[test]
    fn noise_alone_gives_no_blob() {
        let lams: Vec<f64> = (0..600).map(|i| 400.0 + 0.5 * i as f64).collect();
        let n = lams.len();
        let r: Vec<f64> = (0..3 * n)
            .map(|i| if i % 3 == 0 { 1e-3 } else { -5e-4 })
            .collect();
        let score = matched_filter(&lams, &[], &r, &gauss, 50.0, [1e-3; 3], 1.0);
        assert!(blobs(&score, &lams, 25.0, &[]).is_empty());
    }
}
