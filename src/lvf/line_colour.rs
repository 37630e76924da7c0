//! Are the camera curves given with `--camera` those of the image's channels? The lamp lines
//! answer it: a line at λ_l records A_{l,c} = p_l·Q_c(λ_l) in channel c (its power times the
//! channel's sensitivity, whatever the fall-off, the passband or the continuum), so its colour
//! A_{l,r} : A_{l,g} : A_{l,b} is the camera's colour at λ_l. Curves of another camera, a
//! white-balanced or otherwise processed image put the observed colours off the predicted ones,
//! and a continuum shared through those curves ([`crate::lvf::shared_continuum`]) is then drawn in
//! the wrong colour: on a CFL at 5 % noise another camera of the Jiang database moved 700 nm by
//! up to 1.35 nm with σ 0.3, BIC unable to tell (`scripts/bench/lvf_camera_choice.py`).
//!
//! The check takes the per-channel amplitudes of a fit whose continuum is shared through the
//! curves (lines trade least with the continuum there). Unresolved lines can trade amplitude
//! among themselves, so each line that carries at least [`DOMINANT_SHARE`] of the amplitude
//! within ±[`NEIGHBOURHOOD_FWHM`] × FWHM is judged with its neighbourhood: observed the summed
//! amplitudes, predicted Σ_m w_m·Q(λ_m) with w_m the line's amplitude summed over the channels
//! over Q's sum at λ_m. Neighbourhoods whose brightest channel is under [`MIN_RELATIVE`] of the
//! brightest are left out (their colour is noise). With one free scale s_l per neighbourhood,
//! the misfit is √(Σ‖A_l − s_l·P_l‖² / Σ‖A_l‖²).

use crate::lvf::shared_continuum::CameraResponse;

/// Half-width of a line's neighbourhood, in passband FWHMs.
pub const NEIGHBOURHOOD_FWHM: f64 = 0.5;

/// Share of its neighbourhood's amplitude (summed over the channels) a line must carry to be
/// judged.
pub const DOMINANT_SHARE: f64 = 0.5;

/// A neighbourhood is judged when its brightest channel is at least this fraction of the
/// brightest neighbourhood's.
pub const MIN_RELATIVE: f64 = 0.05;

/// Above this misfit the curves are judged not to be the image's.
pub const MISFIT_MAX: f64 = 0.03;

/// Above this misfit (and up to [`MISFIT_MAX`]) the curves are only nearly the image's: the
/// image's own curves on lumifit's renders stay ≤ 0.010, while two measurements of one camera
/// model differ by 0.011–0.027 and a close other camera (the Nikon D80 on a D700 image, 0.028)
/// still moved 700 nm by 0.5–0.6 nm through the shared spectrum; there the best fit without the
/// shared spectrum counts in the model-choice σ.
pub const MISFIT_NEAR: f64 = 0.015;

/// One judged line: its neighbourhood's observed and predicted amplitudes per channel
/// (predicted scaled to the observed).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct JudgedLine {
    /// The line (nm).
    pub nm: f64,
    /// Lines summed with it (nm), itself included.
    pub with_nm: Vec<f64>,
    /// Observed amplitudes r, g, b.
    pub observed: [f64; 3],
    /// The camera's colour at those lines, scaled to the observed.
    pub predicted: [f64; 3],
}

/// The check's result.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct LineColourCheck {
    /// √(Σ‖A − s·P‖² / Σ‖A‖²) over the judged lines.
    pub misfit: f64,
    /// The judged lines.
    pub lines: Vec<JudgedLine>,
}

impl JudgedLine {
    /// ‖observed − predicted‖² / ‖observed‖²: how far the line's colour is off the curves'.
    pub fn relative_misfit_squared(&self) -> f64 {
        let d: f64 = (0..3)
            .map(|c| (self.observed[c] - self.predicted[c]).powi(2))
            .sum();
        let o: f64 = self.observed.iter().map(|v| v * v).sum();
        d / o.max(1e-300)
    }
}

impl LineColourCheck {
    /// The `n` judged lines furthest off the curves' colours, as "λ nm r:g:b R : 1 : B where the
    /// curves give R' : 1 : B'" joined by commas (for a warning).
    pub fn furthest_off(&self, n: usize) -> String {
        let mut far: Vec<&JudgedLine> = self.lines.iter().collect();
        far.sort_by(|a, b| {
            b.relative_misfit_squared()
                .total_cmp(&a.relative_misfit_squared())
        });
        let ratio = |a: [f64; 3]| {
            if a[1] > 0.0 {
                format!("{:.2} : 1 : {:.2}", a[0] / a[1], a[2] / a[1])
            } else {
                "-".into()
            }
        };
        far.iter()
            .take(n)
            .map(|j| {
                format!(
                    "{} nm r:g:b {} where the curves give {}",
                    j.nm,
                    ratio(j.observed),
                    ratio(j.predicted)
                )
            })
            .collect::<Vec<_>>()
            .join(", ")
    }

    /// The median over the judged lines of each line's own misfit √(‖A − s·P‖² / ‖A‖²): robust to
    /// a few lines whose amplitudes went wrong (in a fit without the curves a channel's continuum
    /// can take part of a line's light), so it ranks cameras where `misfit`, weighted by the
    /// brightest lines, is led by them. 0 without judged lines.
    pub fn median_line_misfit(&self) -> f64 {
        let mut m: Vec<f64> = self
            .lines
            .iter()
            .map(|j| j.relative_misfit_squared().sqrt())
            .collect();
        if m.is_empty() {
            return 0.0;
        }
        m.sort_by(f64::total_cmp);
        let k = m.len() / 2;
        if m.len() % 2 == 1 {
            m[k]
        } else {
            0.5 * (m[k - 1] + m[k])
        }
    }

    /// True when the curves are judged not to be the image's ([`MISFIT_MAX`]).
    pub fn inconsistent(&self) -> bool {
        self.misfit > MISFIT_MAX
    }

    /// True when the curves pass but only nearly ([`MISFIT_NEAR`] < misfit ≤ [`MISFIT_MAX`]).
    pub fn near(&self) -> bool {
        self.misfit > MISFIT_NEAR && !self.inconsistent()
    }
}

impl CameraResponse {
    /// Q_r, Q_g, Q_b at `nm` (linear interpolation on the 1 nm grid, 0 outside).
    pub fn at(&self, nm: f64) -> [f64; 3] {
        let x = nm - self.first_nm;
        if self.q.is_empty() || !x.is_finite() || x < 0.0 || x > (self.q.len() - 1) as f64 {
            return [0.0; 3];
        }
        let i = (x.floor() as usize).min(self.q.len().saturating_sub(2));
        let t = x - i as f64;
        let (a, b) = (self.q[i], self.q.get(i + 1).copied().unwrap_or(self.q[i]));
        std::array::from_fn(|c| a[c] + t * (b[c] - a[c]))
    }
}

/// Judges `cam` against the lines `nm` with fitted per-channel amplitudes `amp` (a passband of
/// `fwhm_nm`). None when no line can be judged or `amp` does not give one entry per line.
pub fn check(
    cam: &CameraResponse,
    nm: &[f64],
    amp: &[[f64; 3]],
    fwhm_nm: f64,
) -> Option<LineColourCheck> {
    if amp.len() != nm.len() {
        return None;
    }
    let half = NEIGHBOURHOOD_FWHM * fwhm_nm;
    let total = |a: &[f64; 3]| a.iter().map(|v| v.max(0.0)).sum::<f64>();
    let mut judged: Vec<JudgedLine> = Vec::new();
    for (i, &li) in nm.iter().enumerate() {
        let nb: Vec<usize> = (0..nm.len())
            .filter(|&m| (nm[m] - li).abs() <= half)
            .collect();
        let sum: f64 = nb.iter().map(|&m| total(&amp[m])).sum();
        if sum.is_nan() || sum <= 0.0 || total(&amp[i]) < DOMINANT_SHARE * sum {
            continue;
        }
        let mut observed = [0.0; 3];
        let mut predicted = [0.0; 3];
        for &m in &nb {
            let q = cam.at(nm[m]);
            let qs: f64 = q.iter().sum();
            if qs <= 0.0 {
                continue;
            }
            let w = total(&amp[m]) / qs;
            for c in 0..3 {
                observed[c] += amp[m][c].max(0.0);
                predicted[c] += w * q[c];
            }
        }
        let pp: f64 = predicted.iter().map(|p| p * p).sum();
        if pp <= 0.0 {
            continue;
        }
        let s = (0..3).map(|c| observed[c] * predicted[c]).sum::<f64>() / pp;
        let mut with_nm: Vec<f64> = nb.iter().map(|&m| nm[m]).collect();
        with_nm.sort_by(f64::total_cmp);
        judged.push(JudgedLine {
            nm: li,
            with_nm,
            observed,
            predicted: predicted.map(|p| s * p),
        });
    }
    let peak = judged.iter().flat_map(|j| j.observed).fold(0.0, f64::max);
    judged.retain(|j| j.observed.iter().fold(0.0, |m: f64, v| m.max(*v)) >= MIN_RELATIVE * peak);
    if judged.is_empty() || peak <= 0.0 {
        return None;
    }
    let (mut num, mut den) = (0.0, 0.0);
    for j in &judged {
        for c in 0..3 {
            num += (j.observed[c] - j.predicted[c]).powi(2);
            den += j.observed[c].powi(2);
        }
    }
    Some(LineColourCheck {
        misfit: (num / den).sqrt(),
        lines: judged,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Curves with a colour that changes along λ: r rises, b falls.
    fn camera(tilt: f64) -> CameraResponse {
        CameraResponse {
            source: "test".into(),
            first_nm: 380.0,
            q: (0..=400)
                .map(|i| {
                    let x = i as f64 / 400.0;
                    [0.2 + x * (1.0 + tilt), 0.8, 1.0 - 0.8 * x]
                })
                .collect(),
        }
    }

    fn lines_through(cam: &CameraResponse, nm: &[f64], power: &[f64]) -> Vec<[f64; 3]> {
        nm.iter()
            .zip(power)
            .map(|(&l, &p)| cam.at(l).map(|q| p * q))
            .collect()
    }

    #[test]
    fn the_image_s_own_curves_fit_its_line_colours_and_other_curves_do_not() {
        let cam = camera(0.0);
        let nm = [404.656, 407.783, 435.833, 546.074, 576.96, 579.066];
        let power = [0.4, 0.04, 1.0, 0.9, 0.2, 0.22];
        let amp = lines_through(&cam, &nm, &power);
        let own = check(&cam, &nm, &amp, 25.0).unwrap();
        assert!(own.misfit < 1e-9, "{own:?}");
        assert!(!own.inconsistent());
        // 404.7 (with 407.8), 435.8, 546.1 and 579.1 (with 577.0) are judged; 407.8 and 577.0
        // carry too little of their neighbourhood
        let judged: Vec<f64> = own.lines.iter().map(|j| j.nm).collect();
        assert_eq!(judged, vec![404.656, 435.833, 546.074, 579.066]);
        // another camera: r rising twice as fast
        let other = check(&camera(1.0), &nm, &amp, 25.0).unwrap();
        assert!(other.inconsistent(), "{other:?}");
        // the warning names the lines furthest off first: red rises with λ in the other curves
        let far = other.furthest_off(2);
        assert_eq!(far.matches(" nm r:g:b ").count(), 2, "{far}");
        assert!(
            far.starts_with("404.656 nm") || far.starts_with("579.066 nm"),
            "{far}"
        );
        // a split traded inside an unresolved pair leaves the check unmoved
        let mut traded = amp.clone();
        let moved = traded[4].map(|a| 0.5 * a);
        for (c, m) in moved.iter().enumerate() {
            traded[4][c] -= m;
            traded[5][c] += m;
        }
        let t = check(&cam, &nm, &traded, 25.0).unwrap();
        assert!(t.misfit < 0.002, "{t:?}");
    }

    #[test]
    fn a_channel_gain_is_inconsistent_and_nothing_to_judge_gives_none() {
        let cam = camera(0.0);
        let nm = [435.833, 546.074];
        let mut amp = lines_through(&cam, &nm, &[1.0, 0.9]);
        for a in &mut amp {
            a[0] *= 1.5; // a white-balance gain on red
        }
        assert!(check(&cam, &nm, &amp, 25.0).unwrap().inconsistent());
        assert!(check(&cam, &nm, &[[0.0; 3]; 2], 25.0).is_none());
        assert!(check(&cam, &[900.0], &[[1.0, 1.0, 1.0]], 25.0).is_none());
        assert!(check(&cam, &nm, &amp[..1], 25.0).is_none());
    }

    #[test]
    fn a_misfit_between_near_and_max_is_near_and_above_max_inconsistent() {
        let at = |misfit| LineColourCheck {
            misfit,
            lines: Vec::new(),
        };
        assert!(!at(0.5 * MISFIT_NEAR).near() && !at(0.5 * MISFIT_NEAR).inconsistent());
        assert!(at(0.5 * (MISFIT_NEAR + MISFIT_MAX)).near());
        assert!(at(1.01 * MISFIT_MAX).inconsistent() && !at(1.01 * MISFIT_MAX).near());
    }

    /// The median of the lines' own misfits ignores a minority of lines gone wrong, where the
    /// amplitude-weighted misfit is led by them when they are bright.
    #[test]
    fn the_median_line_misfit_ignores_a_few_bright_lines_gone_wrong() {
        let line = |nm: f64, observed: [f64; 3], predicted: [f64; 3]| JudgedLine {
            nm,
            with_nm: vec![nm],
            observed,
            predicted,
        };
        let good = [1.0, 2.0, 0.5];
        let c = LineColourCheck {
            misfit: 0.0,
            lines: vec![
                line(436.0, good, good),
                line(487.7, good, [1.0, 2.0, 0.55]),
                line(546.1, good, good),
                line(611.6, [10.0, 1.0, 5.0], [10.0, 1.0, 0.0]),
            ],
        };
        // per line: 0, 0.05/‖good‖ = 0.0218, 0, 5/√126 = 0.445; median of four
        let m = c.median_line_misfit();
        assert!((m - 0.5 * 0.05 / 5.25f64.sqrt()).abs() < 1e-12, "{m}");
        let empty = LineColourCheck {
            misfit: 0.0,
            lines: vec![],
        };
        assert_eq!(empty.median_line_misfit(), 0.0);
    }

    #[test]
    fn the_camera_is_read_between_its_grid_points_and_is_zero_outside() {
        let cam = camera(0.0);
        let a = cam.at(380.0);
        let b = cam.at(381.0);
        let m = cam.at(380.5);
        for c in 0..3 {
            assert!((m[c] - 0.5 * (a[c] + b[c])).abs() < 1e-12);
        }
        assert_eq!(cam.at(379.0), [0.0; 3]);
        assert_eq!(cam.at(781.0), [0.0; 3]);
        assert_eq!(cam.at(f64::NAN), [0.0; 3]);
        let empty = CameraResponse {
            q: Vec::new(),
            ..cam.clone()
        };
        assert_eq!(empty.at(380.0), [0.0; 3]);
        let one = CameraResponse {
            q: vec![[1.0, 2.0, 3.0]],
            ..cam
        };
        assert_eq!(one.at(380.0), [1.0, 2.0, 3.0]);
    }
}
