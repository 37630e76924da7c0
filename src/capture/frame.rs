//! A linear RGB frame with per-pixel saturation flags, and the exposure that produced it.

use crate::error::{Error, Result};

/// A linear camera-RGB image in memory.
///
/// Values are linear: 0 = black level, 1 = white level (values may exceed 1 for float inputs and
/// fall below 0 after black/dark subtraction). Pixels are stored row-major, channels interleaved.
#[derive(Debug, Clone, PartialEq)]
pub struct RgbFrame {
    /// Name of the source (file name) used in error messages.
    pub name: String,
    /// Width in frame pixels.
    pub width: usize,
    /// Height in frame pixels.
    pub height: usize,
    /// Source pixels per frame pixel side: 2 for binned Bayer RAWs, 1 otherwise.
    pub pixel_scale: usize,
    data: Vec<f32>,
    saturated: Vec<u8>,
}

impl RgbFrame {
    /// A frame from interleaved RGB values and a per-pixel saturation bit mask (bit *c* set when
    /// channel *c* is saturated).
    ///
    /// # Errors
    /// [`Error::ShapeMismatch`] when the buffers do not hold `width × height` pixels;
    /// [`Error::InvalidArgument`] for an empty frame or a zero `pixel_scale`.
    pub fn new(
        name: impl Into<String>,
        width: usize,
        height: usize,
        pixel_scale: usize,
        data: Vec<f32>,
        saturated: Vec<u8>,
    ) -> Result<Self> {
        let name = name.into();
        if width == 0 || height == 0 {
            return Err(Error::invalid(
                "frame",
                format!("{name}: image is empty ({width}×{height} pixels)"),
            ));
        }
        if pixel_scale == 0 {
            return Err(Error::invalid("pixel_scale", "must be at least 1"));
        }
        let n = width * height;
        if data.len() != 3 * n {
            return Err(Error::ShapeMismatch {
                what: format!("{name}: RGB values of a {width}×{height} frame"),
                expected: 3 * n,
                got: data.len(),
            });
        }
        if saturated.len() != n {
            return Err(Error::ShapeMismatch {
                what: format!("{name}: saturation mask of a {width}×{height} frame"),
                expected: n,
                got: saturated.len(),
            });
        }
        Ok(Self {
            name,
            width,
            height,
            pixel_scale,
            data,
            saturated,
        })
    }

    /// Size of the source image in its own pixels (`width × pixel_scale`, `height × pixel_scale`).
    pub fn source_size(&self) -> (usize, usize) {
        (
            self.width * self.pixel_scale,
            self.height * self.pixel_scale,
        )
    }

    /// RGB of frame pixel (`x`, `y`); callers guarantee `x < width`, `y < height`.
    #[inline]
    pub fn rgb(&self, x: usize, y: usize) -> [f32; 3] {
        let i = 3 * (y * self.width + x);
        [self.data[i], self.data[i + 1], self.data[i + 2]]
    }

    /// Saturation bits of frame pixel (`x`, `y`) (bit *c* for channel *c*).
    #[inline]
    pub fn saturation_bits(&self, x: usize, y: usize) -> u8 {
        self.saturated[y * self.width + x]
    }

    /// Interleaved RGB values.
    pub fn data(&self) -> &[f32] {
        &self.data
    }

    /// Per-pixel saturation bits.
    pub fn saturation_mask(&self) -> &[u8] {
        &self.saturated
    }

    /// Fraction of pixels with at least one saturated channel.
    pub fn saturated_fraction(&self) -> f64 {
        let n = self.saturated.iter().filter(|&&b| b != 0).count();
        n as f64 / self.saturated.len() as f64
    }

    /// Centre of frame pixel `i` along one axis, in source-pixel coordinates (pixel centres of
    /// the source at integers): `i·s + (s − 1)/2`.
    pub fn source_coordinate(&self, i: usize) -> f64 {
        (i * self.pixel_scale) as f64 + (self.pixel_scale as f64 - 1.0) / 2.0
    }

    /// Subtracts a dark frame of the same geometry, pixel by pixel. Saturation flags of both
    /// frames are kept.
    ///
    /// # Errors
    /// [`Error::ShapeMismatch`] when the frames differ in size or binning.
    pub fn subtract(&mut self, dark: &RgbFrame) -> Result<()> {
        if dark.width != self.width
            || dark.height != self.height
            || dark.pixel_scale != self.pixel_scale
        {
            return Err(Error::invalid(
                "dark frame",
                format!(
                    "{} is {}×{} source pixels but {} is {}×{}; a dark frame must be shot with the same camera and size",
                    dark.name,
                    dark.source_size().0,
                    dark.source_size().1,
                    self.name,
                    self.source_size().0,
                    self.source_size().1
                ),
            ));
        }
        for (v, d) in self.data.iter_mut().zip(&dark.data) {
            *v -= *d;
        }
        for (s, d) in self.saturated.iter_mut().zip(&dark.saturated) {
            *s |= *d;
        }
        Ok(())
    }

    /// Pixel-wise mean of frames of equal geometry (e.g. several dark frames).
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] for no frames or frames of different sizes.
    pub fn mean_of(frames: &[RgbFrame]) -> Result<RgbFrame> {
        let Some(first) = frames.first() else {
            return Err(Error::invalid("frames", "no frames to average"));
        };
        let mut out = first.clone();
        for f in &frames[1..] {
            if f.width != first.width
                || f.height != first.height
                || f.pixel_scale != first.pixel_scale
            {
                return Err(Error::invalid(
                    "frames",
                    format!(
                        "{} and {} differ in size; frames to average must match",
                        first.name, f.name
                    ),
                ));
            }
            for (v, d) in out.data.iter_mut().zip(&f.data) {
                *v += *d;
            }
            for (s, d) in out.saturated.iter_mut().zip(&f.saturated) {
                *s |= *d;
            }
        }
        let k = frames.len() as f32;
        for v in &mut out.data {
            *v /= k;
        }
        Ok(out)
    }
}

/// Exposure settings of a frame.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Exposure {
    /// Exposure time in s.
    pub exposure_s: f64,
    /// ISO sensitivity.
    pub iso: f64,
    /// f-number *N*.
    pub f_number: f64,
}

impl Exposure {
    /// Validated exposure settings (all finite and positive).
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] naming the field.
    pub fn new(exposure_s: f64, iso: f64, f_number: f64) -> Result<Self> {
        for (field, v) in [
            ("exposure_s", exposure_s),
            ("iso", iso),
            ("f_number", f_number),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(Error::invalid(
                    field,
                    format!("{v} is not a positive finite number"),
                ));
            }
        }
        Ok(Self {
            exposure_s,
            iso,
            f_number,
        })
    }

    /// Exposure factor *t* · ISO/100 / *N*²; relative radiance = value / factor.
    pub fn factor(&self) -> f64 {
        self.exposure_s * self.iso / 100.0 / (self.f_number * self.f_number)
    }
}

/// What a reader learned about a frame besides its pixels.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct FrameInfo {
    /// Source file.
    pub file: String,
    /// Encoding read: `raw-bayer`, `raw-linear`, `png-8bit-srgb`, `tiff-16bit`, `exr-float`, …
    pub encoding: String,
    /// Exposure time in s from EXIF (None when missing or zero).
    pub exposure_s: Option<f64>,
    /// ISO from EXIF.
    pub iso: Option<f64>,
    /// f-number from EXIF.
    pub f_number: Option<f64>,
    /// EXIF capture time (camera local time) as seconds since 1970-01-01, sub-seconds included.
    pub capture_time_s: Option<f64>,
    /// EXIF capture time as written (`YYYY:MM:DD HH:MM:SS[.sss]`).
    pub capture_time: Option<String>,
    /// Black level per CFA colour (R, G, B, E) in raw units (RAW only).
    pub black_level: Option<[f64; 4]>,
    /// White level from the metadata in raw units (RAW only; largest over colours).
    pub white_level: Option<f64>,
    /// White level measured from the clipping plateau of the data, when one was found.
    pub white_level_measured: Option<f64>,
    /// Raw value at and above which a photosite is treated as saturated.
    pub saturation_threshold: Option<f64>,
    /// Non-fatal remarks (8-bit sRGB decoded, metadata disagreeing with data, …).
    pub warnings: Vec<String>,
}

/// Days since 1970-01-01 of a proleptic Gregorian date (H. Hinnant's algorithm).
fn days_from_civil(y: i64, m: i64, d: i64) -> i64 {
    let y = if m <= 2 { y - 1 } else { y };
    let era = if y >= 0 { y } else { y - 399 } / 400;
    let yoe = y - era * 400;
    let mp = (m + 9) % 12;
    let doy = (153 * mp + 2) / 5 + d - 1;
    let doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    era * 146_097 + doe - 719_468
}

/// Seconds since 1970-01-01 00:00 of a civil date and time (no time zone applied).
pub fn civil_to_seconds(
    year: i64,
    month: i64,
    day: i64,
    hour: i64,
    minute: i64,
    second: f64,
) -> f64 {
    (days_from_civil(year, month, day) * 86_400 + hour * 3600 + minute * 60) as f64 + second
}

/// Parses `YYYY:MM:DD HH:MM:SS[.fff]` (EXIF) or `YYYY-MM-DD[T ]HH:MM:SS[.fff]` into seconds
/// since 1970-01-01 (no time zone). Returns `None` for anything else.
pub fn parse_datetime(s: &str) -> Option<f64> {
    let s = s.trim();
    let (date, time) = s.split_once(['T', ' '])?;
    let d: Vec<&str> = date.split([':', '-']).collect();
    let t: Vec<&str> = time.trim().split(':').collect();
    if d.len() != 3 || t.len() != 3 {
        return None;
    }
    let year: i64 = d[0].parse().ok()?;
    let month: i64 = d[1].parse().ok()?;
    let day: i64 = d[2].parse().ok()?;
    let hour: i64 = t[0].parse().ok()?;
    let minute: i64 = t[1].parse().ok()?;
    let second: f64 = t[2].parse().ok()?;
    let valid = (1..=12).contains(&month)
        && (1..=31).contains(&day)
        && (0..24).contains(&hour)
        && (0..60).contains(&minute)
        && (0.0..61.0).contains(&second);
    valid.then(|| civil_to_seconds(year, month, day, hour, minute, second))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn civil_dates_count_days_from_the_unix_epoch() {
        assert_eq!(civil_to_seconds(1970, 1, 1, 0, 0, 0.0), 0.0);
        assert_eq!(civil_to_seconds(2000, 3, 1, 0, 0, 0.0), 951_868_800.0);
        let a = parse_datetime("2024:02:28 23:59:59.5").unwrap();
        let b = parse_datetime("2024-02-29T00:00:04.5").unwrap();
        assert!((b - a - 5.0).abs() < 1e-9);
        assert!(parse_datetime("yesterday").is_none());
    }

    #[test]
    fn exposure_factor_follows_time_iso_and_aperture() {
        let e = Exposure::new(2.0, 200.0, 4.0).unwrap();
        assert!((e.factor() - 2.0 * 2.0 / 16.0).abs() < 1e-15);
        assert!(Exposure::new(0.0, 100.0, 2.8).is_err());
    }
}
