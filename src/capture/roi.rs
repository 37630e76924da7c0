//! Regions of interest and their statistics.
//!
//! Coordinates are in the **source image's pixels** (0 = first column/row, pixel centres at
//! integers), whatever the frame's binning: a frame pixel belongs to a rectangle when its centre
//! (in source coordinates) lies inside it, and to a mask when at least half of the source pixels
//! it covers are set in the mask.

use crate::capture::frame::RgbFrame;
use crate::error::{Error, Result};

/// A region of interest.
#[derive(Debug, Clone, PartialEq)]
pub enum Roi {
    /// Rectangle `x, y, w, h` in source pixels.
    Rect {
        /// First column.
        x: usize,
        /// First row.
        y: usize,
        /// Width.
        w: usize,
        /// Height.
        h: usize,
    },
    /// A mask of the source image's size; `true` marks pixels inside.
    Mask {
        /// Mask width (source pixels).
        width: usize,
        /// Mask height (source pixels).
        height: usize,
        /// Row-major inside flags.
        inside: Vec<bool>,
        /// Where the mask came from (for messages).
        name: String,
    },
}

impl Roi {
    /// Parses `x,y,w,h` (non-negative integers, `w`, `h` ≥ 1).
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] naming `--roi` and what was expected.
    pub fn parse_rect(s: &str) -> Result<Roi> {
        let parts: Vec<&str> = s.split(',').map(str::trim).collect();
        let bad = || {
            Error::invalid(
                "--roi",
                format!("'{s}': expected x,y,w,h as four non-negative integers (pixels), e.g. 100,200,50,40"),
            )
        };
        if parts.len() != 4 {
            return Err(bad());
        }
        let mut v = [0usize; 4];
        for (i, p) in parts.iter().enumerate() {
            v[i] = p.parse().map_err(|_| bad())?;
        }
        if v[2] == 0 || v[3] == 0 {
            return Err(Error::invalid(
                "--roi",
                format!("'{s}': width and height must be at least 1 pixel"),
            ));
        }
        Ok(Roi::Rect {
            x: v[0],
            y: v[1],
            w: v[2],
            h: v[3],
        })
    }

    /// Short description for messages and outputs.
    pub fn describe(&self) -> String {
        match self {
            Roi::Rect { x, y, w, h } => format!("{x},{y},{w},{h}"),
            Roi::Mask { name, .. } => format!("mask {name}"),
        }
    }

    /// Frame pixels inside the region, as `(x, y)` frame coordinates.
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] when the region extends outside the frame, a mask has another
    /// size, or no frame pixel falls inside.
    pub fn frame_pixels(&self, frame: &RgbFrame) -> Result<Vec<(usize, usize)>> {
        let (sw, sh) = frame.source_size();
        let s = frame.pixel_scale;
        let mut out = Vec::new();
        match self {
            Roi::Rect { x, y, w, h } => {
                if x + w > sw || y + h > sh {
                    return Err(Error::invalid(
                        "ROI",
                        format!(
                            "{x},{y},{w},{h} extends outside {} ({sw}×{sh} pixels); expected x+w ≤ {sw} and y+h ≤ {sh}",
                            frame.name
                        ),
                    ));
                }
                let inside = |c: f64, lo: usize, len: usize| {
                    c >= lo as f64 - 0.5 && c < (lo + len) as f64 - 0.5
                };
                for fy in 0..frame.height {
                    if !inside(frame.source_coordinate(fy), *y, *h) {
                        continue;
                    }
                    for fx in 0..frame.width {
                        if inside(frame.source_coordinate(fx), *x, *w) {
                            out.push((fx, fy));
                        }
                    }
                }
            }
            Roi::Mask {
                width,
                height,
                inside,
                name,
            } => {
                if (*width, *height) != (sw, sh) {
                    return Err(Error::invalid(
                        "ROI mask",
                        format!(
                            "{name} is {width}×{height} pixels but {} is {sw}×{sh}; the mask must match the image",
                            frame.name
                        ),
                    ));
                }
                for fy in 0..frame.height {
                    for fx in 0..frame.width {
                        let mut n_in = 0;
                        for dy in 0..s {
                            for dx in 0..s {
                                if inside[(fy * s + dy) * width + fx * s + dx] {
                                    n_in += 1;
                                }
                            }
                        }
                        if 2 * n_in >= s * s && n_in > 0 {
                            out.push((fx, fy));
                        }
                    }
                }
            }
        }
        if out.is_empty() {
            return Err(Error::invalid(
                "ROI",
                format!(
                    "{} contains no pixel of {} (binned {}×); make it larger",
                    self.describe(),
                    frame.name,
                    s
                ),
            ));
        }
        Ok(out)
    }
}

/// Per-channel statistics of a region (saturated pixels excluded).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct RoiStats {
    /// Mean per channel over unsaturated pixels.
    pub mean: [f64; 3],
    /// Sample standard deviation per channel over unsaturated pixels.
    pub std: [f64; 3],
    /// Number of frame pixels in the region.
    pub n_pixels: usize,
    /// Number of them with at least one saturated channel (left out of mean and std).
    pub n_saturated: usize,
}

/// Mean, standard deviation and counts of `frame` over `roi`; a pixel with any saturated channel
/// is left out of all channels.
///
/// # Errors
/// From [`Roi::frame_pixels`], and [`Error::InvalidArgument`] when every pixel is saturated.
pub fn roi_stats(frame: &RgbFrame, roi: &Roi) -> Result<RoiStats> {
    let pixels = roi.frame_pixels(frame)?;
    let mut sum = [0.0f64; 3];
    let mut n = 0usize;
    let mut n_sat = 0usize;
    for &(x, y) in &pixels {
        if frame.saturation_bits(x, y) != 0 {
            n_sat += 1;
            continue;
        }
        let v = frame.rgb(x, y);
        for c in 0..3 {
            sum[c] += f64::from(v[c]);
        }
        n += 1;
    }
    if n == 0 {
        return Err(Error::invalid(
            "ROI",
            format!(
                "{} of {} is entirely saturated ({} pixels at the white level); use a shorter exposure or another region",
                roi.describe(),
                frame.name,
                n_sat
            ),
        ));
    }
    let mean = sum.map(|s| s / n as f64);
    let mut ss = [0.0f64; 3];
    for &(x, y) in &pixels {
        if frame.saturation_bits(x, y) != 0 {
            continue;
        }
        let v = frame.rgb(x, y);
        for c in 0..3 {
            ss[c] += (f64::from(v[c]) - mean[c]).powi(2);
        }
    }
    let std = if n > 1 {
        ss.map(|s| (s / (n - 1) as f64).sqrt())
    } else {
        [0.0; 3]
    };
    Ok(RoiStats {
        mean,
        std,
        n_pixels: pixels.len(),
        n_saturated: n_sat,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(w: usize, h: usize, s: usize) -> RgbFrame {
        let data: Vec<f32> = (0..w * h)
            .flat_map(|i| [i as f32, 2.0 * i as f32, 1.0])
            .collect();
        RgbFrame::new("t", w, h, s, data, vec![0; w * h]).unwrap()
    }

    #[test]
    fn rectangle_in_source_pixels_selects_superpixels_by_their_centres() {
        let f = frame(4, 3, 2); // source 8×6
        let roi = Roi::parse_rect("2,0,4,2").unwrap();
        let px = roi.frame_pixels(&f).unwrap();
        assert_eq!(px, vec![(1, 0), (2, 0)]);
        let st = roi_stats(&f, &roi).unwrap();
        assert_eq!(st.mean, [1.5, 3.0, 1.0]);
        assert_eq!(st.n_pixels, 2);
    }

    #[test]
    fn rectangle_outside_the_frame_is_an_error_naming_the_size() {
        let f = frame(4, 3, 1);
        let err = roi_stats(&f, &Roi::parse_rect("3,0,2,1").unwrap()).unwrap_err();
        assert!(err.to_string().contains("4×3"), "{err}");
        assert!(Roi::parse_rect("1,2,3").is_err());
        assert!(Roi::parse_rect("1,2,0,3").is_err());
    }

    #[test]
    fn saturated_pixels_are_counted_but_never_averaged() {
        let mut sat = vec![0u8; 4];
        sat[1] = 0b001;
        let data = vec![1.0, 1.0, 1.0, 9.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0];
        let f = RgbFrame::new("t", 2, 2, 1, data, sat).unwrap();
        let st = roi_stats(&f, &Roi::parse_rect("0,0,2,2").unwrap()).unwrap();
        assert_eq!(st.mean, [1.0; 3]);
        assert_eq!(st.n_saturated, 1);
        let all = RgbFrame::new("t", 1, 1, 1, vec![1.0; 3], vec![7]).unwrap();
        assert!(roi_stats(&all, &Roi::parse_rect("0,0,1,1").unwrap())
            .unwrap_err()
            .to_string()
            .contains("saturated"));
    }
}
