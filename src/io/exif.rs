//! EXIF exposure time, ISO, f-number and capture time (kamadak-exif).
//!
//! Missing or zero fields are `None` (Magic Lantern DNGs, for example, write zeros); callers fall
//! back to a manifest. The capture time is `DateTimeOriginal` (else `DateTime`) with
//! `SubSecTimeOriginal` added, in the camera's local time.

use exif::{In, Reader, Tag, Value};

use crate::capture::civil_to_seconds;

/// EXIF fields lumifit uses.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ExifInfo {
    /// Exposure time in s.
    pub exposure_s: Option<f64>,
    /// ISO (PhotographicSensitivity).
    pub iso: Option<f64>,
    /// f-number.
    pub f_number: Option<f64>,
    /// Capture time as seconds since 1970-01-01 (local camera time), sub-seconds included.
    pub capture_time_s: Option<f64>,
    /// Capture time as text `YYYY:MM:DD HH:MM:SS[.sss]`.
    pub capture_time: Option<String>,
}

fn positive(v: f64) -> Option<f64> {
    (v.is_finite() && v > 0.0).then_some(v)
}

fn number(value: &Value) -> Option<f64> {
    match value {
        Value::Rational(v) => v.first().filter(|r| r.denom != 0).map(|r| r.to_f64()),
        Value::SRational(v) => v.first().filter(|r| r.denom != 0).map(|r| r.to_f64()),
        Value::Short(v) => v.first().map(|&x| f64::from(x)),
        Value::Long(v) => v.first().map(|&x| f64::from(x)),
        Value::Float(v) => v.first().map(|&x| f64::from(x)),
        Value::Double(v) => v.first().copied(),
        _ => None,
    }
}

fn ascii(value: &Value) -> Option<String> {
    match value {
        Value::Ascii(v) => v
            .first()
            .map(|s| String::from_utf8_lossy(s).trim().to_string()),
        _ => None,
    }
}

/// Reads EXIF from the bytes of a TIFF/DNG/JPEG/PNG/… container; `None` when there is none.
pub fn read_exif_bytes(bytes: &[u8]) -> Option<ExifInfo> {
    let exif = Reader::new()
        .read_from_container(&mut std::io::Cursor::new(bytes))
        .ok()?;
    let get = |tag: Tag| exif.get_field(tag, In::PRIMARY).map(|f| &f.value);
    let mut info = ExifInfo {
        exposure_s: get(Tag::ExposureTime).and_then(number).and_then(positive),
        iso: get(Tag::PhotographicSensitivity)
            .and_then(number)
            .and_then(positive),
        f_number: get(Tag::FNumber).and_then(number).and_then(positive),
        ..Default::default()
    };
    let (dt, sub) = match get(Tag::DateTimeOriginal).and_then(ascii) {
        Some(dt) => (Some(dt), get(Tag::SubSecTimeOriginal).and_then(ascii)),
        None => (
            get(Tag::DateTime).and_then(ascii),
            get(Tag::SubSecTime).and_then(ascii),
        ),
    };
    if let Some(dt) = dt {
        if let Ok(p) = exif::DateTime::from_ascii(dt.as_bytes()) {
            let mut seconds = f64::from(p.second);
            let mut text = dt.clone();
            if let Some(sub) =
                sub.filter(|s| !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit()))
            {
                if let Ok(frac) = format!("0.{sub}").parse::<f64>() {
                    seconds += frac;
                    text = format!("{dt}.{sub}");
                }
            }
            if p.year > 0 && p.month > 0 && p.day > 0 {
                info.capture_time_s = Some(civil_to_seconds(
                    i64::from(p.year),
                    i64::from(p.month),
                    i64::from(p.day),
                    i64::from(p.hour),
                    i64::from(p.minute),
                    seconds,
                ));
                info.capture_time = Some(text);
            }
        }
    }
    Some(info)
}
