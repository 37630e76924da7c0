//! A photo series in memory: frames with their times and exposures, and region extraction in
//! relative radiance.

use crate::capture::frame::{Exposure, FrameInfo, RgbFrame};
use crate::capture::roi::{roi_stats, Roi};
use crate::error::{Error, Result};

/// One frame of a series.
#[derive(Debug, Clone)]
pub struct SeriesFrame {
    /// Time in s relative to the series' time 0.
    pub time_s: f64,
    /// Exposure settings used to normalise the frame.
    pub exposure: Exposure,
    /// Linear pixels (dark already subtracted when a dark frame was given).
    pub frame: RgbFrame,
    /// What the reader found (EXIF, levels, warnings).
    pub info: FrameInfo,
}

/// Frames of equal size at strictly increasing times.
#[derive(Debug, Clone)]
pub struct PhotoSeries {
    frames: Vec<SeriesFrame>,
}

/// One sample of a region's curve, in relative radiance (value / exposure factor).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct CurveSample {
    /// Time in s.
    pub time_s: f64,
    /// Mean relative radiance per channel.
    pub mean: [f64; 3],
    /// Standard deviation of the pixels' relative radiance per channel.
    pub std: [f64; 3],
    /// Pixels in the region.
    pub n_pixels: usize,
    /// Pixels left out because saturated.
    pub n_saturated: usize,
}

impl PhotoSeries {
    /// Checks and wraps frames: at least one, all of one size and binning, times finite and
    /// strictly increasing in the given order.
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] naming the offending frames.
    pub fn new(frames: Vec<SeriesFrame>) -> Result<Self> {
        let Some(first) = frames.first() else {
            return Err(Error::invalid("series", "no frames; expected at least one"));
        };
        let size = (
            first.frame.width,
            first.frame.height,
            first.frame.pixel_scale,
        );
        for f in &frames {
            let s = (f.frame.width, f.frame.height, f.frame.pixel_scale);
            if s != size {
                return Err(Error::invalid(
                    "series",
                    format!(
                        "{} is {}×{} pixels but {} is {}×{}; all frames of a series must have the same size",
                        f.info.file,
                        f.frame.source_size().0,
                        f.frame.source_size().1,
                        first.info.file,
                        first.frame.source_size().0,
                        first.frame.source_size().1
                    ),
                ));
            }
            if !f.time_s.is_finite() {
                return Err(Error::invalid(
                    "time_s",
                    format!("{}: time {} is not finite", f.info.file, f.time_s),
                ));
            }
        }
        for w in frames.windows(2) {
            if w[1].time_s <= w[0].time_s {
                let what = if w[1].time_s == w[0].time_s {
                    "duplicated"
                } else {
                    "decreasing"
                };
                return Err(Error::invalid(
                    "time_s",
                    format!(
                        "{what} times: {} at {} s follows {} at {} s; times must strictly increase",
                        w[1].info.file, w[1].time_s, w[0].info.file, w[0].time_s
                    ),
                ));
            }
        }
        Ok(Self { frames })
    }

    /// The frames in time order.
    pub fn frames(&self) -> &[SeriesFrame] {
        &self.frames
    }

    /// Number of frames.
    pub fn len(&self) -> usize {
        self.frames.len()
    }

    /// Whether the series is empty (never, once constructed).
    pub fn is_empty(&self) -> bool {
        self.frames.is_empty()
    }

    /// Subtracts a dark frame from every frame.
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] when the dark frame's size differs.
    pub fn subtract_dark(&mut self, dark: &RgbFrame) -> Result<()> {
        for f in &mut self.frames {
            f.frame.subtract(dark)?;
        }
        Ok(())
    }

    /// The region's curve in relative radiance: per frame, ROI statistics divided by the
    /// exposure factor *t* · ISO/100 / *N*².
    ///
    /// # Errors
    /// From [`roi_stats`] (ROI outside the frame, all saturated), and
    /// [`Error::InvalidArgument`] when the region is dark in every frame (no channel's mean is
    /// distinguishable from zero at 3 standard errors), which almost always means a wrong ROI.
    pub fn extract(&self, roi: &Roi) -> Result<Vec<CurveSample>> {
        let mut out = Vec::with_capacity(self.frames.len());
        let mut any_signal = false;
        for f in &self.frames {
            let st = roi_stats(&f.frame, roi).map_err(|e| match e {
                Error::InvalidArgument { field, message } => Error::InvalidArgument {
                    field: format!("{field} in {}", f.info.file),
                    message,
                },
                other => other,
            })?;
            let n_used = (st.n_pixels - st.n_saturated).max(1) as f64;
            for c in 0..3 {
                let se = st.std[c] / n_used.sqrt();
                if st.mean[c] > 3.0 * se && st.mean[c] > 1e-6 {
                    any_signal = true;
                }
            }
            let k = f.exposure.factor();
            out.push(CurveSample {
                time_s: f.time_s,
                mean: st.mean.map(|m| m / k),
                std: st.std.map(|s| s / k),
                n_pixels: st.n_pixels,
                n_saturated: st.n_saturated,
            });
        }
        if !any_signal {
            return Err(Error::invalid(
                "ROI",
                format!(
                    "{} is dark in every frame of the series (first frame {}): no channel is above zero by 3 standard errors; check the ROI coordinates",
                    roi.describe(),
                    self.frames.first().map(|f| f.info.file.as_str()).unwrap_or("?")
                ),
            ));
        }
        Ok(out)
    }
}
