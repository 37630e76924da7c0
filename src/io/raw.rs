//! Camera RAW files through `rawloader`: black level subtracted per CFA colour, scaled by the
//! white level, 2×2 superpixels (R, mean of the two G, B) giving a half-resolution linear
//! camera-RGB [`RgbFrame`] (`pixel_scale = 2`). No demosaicing: region averages do not need it.
//!
//! **Saturation.** The white level in the metadata can be wrong, so it is also measured: when the
//! largest raw value of a colour is shared by many photosites (a clipping plateau: at least 16
//! and at least 1 in 10⁵ of that colour's photosites) that value is the measured white. A photosite
//! at or above `black + 0.98 · (white − black)` (white = the lower of metadata and measured) is
//! saturated; a superpixel with any saturated photosite is flagged in that channel and left out
//! of region averages. Scaling always uses the metadata white (so frames of a series share one
//! scale) unless the data exceed it, in which case the 16-bit full scale is used and a warning
//! is recorded.
//!
//! A file rawloader cannot decode (for example a 14-bit packed DNG such as Magic Lantern writes)
//! is an error naming the file, rawloader's reason, and the workaround.

use std::path::Path;

use rawloader::RawImageData;

use crate::capture::{FrameInfo, RgbFrame};
use crate::error::{Error, Result};

/// File extensions handled as camera RAW (case-insensitive).
pub const RAW_EXTENSIONS: &[&str] = &[
    "dng", "cr2", "cr3", "crw", "nef", "nrw", "arw", "srf", "sr2", "raf", "orf", "rw2", "pef",
    "srw", "3fr", "erf", "mef", "mos", "kdc", "dcr", "rwl", "iiq", "raw",
];

/// Whether `path` has a RAW extension.
pub fn is_raw_path(path: &Path) -> bool {
    path.extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .is_some_and(|e| RAW_EXTENSIONS.contains(&e.as_str()))
}

/// Fraction of the black-to-white range above which a photosite counts as saturated.
pub const SATURATION_FRACTION: f64 = 0.98;

const WORKAROUND: &str = "convert it to an uncompressed 16-bit DNG (Adobe DNG Converter, dnglab convert, or rawler) \
or develop it to a linear 16-bit TIFF without white balance or gamma (dcraw -4 -T -o 0 -r 1 1 1 1, or rawpy with gamma=(1,1), no_auto_bright, output_bps=16) and pass that file instead";

fn decode_error(path: &Path, reason: impl std::fmt::Display) -> Error {
    Error::io(
        path,
        std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!("cannot decode this RAW file ({reason}); workaround: {WORKAROUND}"),
        ),
    )
}

thread_local! {
    /// Set while this thread runs a decoder whose panics are caught and reported as errors.
    static SILENCED: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

/// Runs `f`, turning a panic into `Err(panic message)` without printing the panic.
///
/// A process-wide panic hook is installed once; it stays silent on threads inside this call and
/// hands every other panic to the hook that was there before, so panics elsewhere (other threads,
/// tests) are reported as usual.
pub(crate) fn quiet_catch_unwind<T>(f: impl FnOnce() -> T) -> std::result::Result<T, String> {
    static HOOK: std::sync::Once = std::sync::Once::new();
    HOOK.call_once(|| {
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if !SILENCED.with(|s| s.get()) {
                previous(info);
            }
        }));
    });
    let was = SILENCED.with(|s| s.replace(true));
    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(f));
    SILENCED.with(|s| s.set(was));
    result.map_err(|payload| {
        payload
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| payload.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "panic without a message".to_string())
    })
}

/// Decodes a RAW file into a half-resolution linear frame plus what was learned about it.
///
/// # Errors
/// [`Error::Io`] naming the file when it cannot be read or decoded.
pub fn read_raw(path: &Path) -> Result<(RgbFrame, FrameInfo)> {
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    read_raw_bytes(&bytes, path)
}

/// As [`read_raw`], from bytes already in memory (`path` names them in messages).
pub fn read_raw_bytes(bytes: &[u8], path: &Path) -> Result<(RgbFrame, FrameInfo)> {
    // rawloader panics on some malformed inputs (e.g. truncated data); a panic is a decode error,
    // and its text is not printed (the hook is silenced for this thread while decoding).
    let decoded = quiet_catch_unwind(|| rawloader::decode(&mut std::io::Cursor::new(bytes)));
    let raw = match decoded {
        Ok(Ok(r)) => r,
        // rawloader catches some of its own panics and says so with a plea to file a bug; for a
        // user that is the same malformed or truncated file as a panic caught here.
        Ok(Err(e)) if format!("{e:?}").contains("Caught a panic") => {
            return Err(decode_error(
                path,
                "rawloader failed on malformed or truncated data",
            ))
        }
        Ok(Err(e)) => return Err(decode_error(path, format!("rawloader: {e:?}"))),
        Err(cause) => {
            return Err(decode_error(
                path,
                format!("rawloader failed on malformed or truncated data: {cause}"),
            ))
        }
    };
    let name = path.display().to_string();
    let (w, h, cpp) = (raw.width, raw.height, raw.cpp);
    let values: Vec<f32> = match &raw.data {
        RawImageData::Integer(v) => v.iter().map(|&x| f32::from(x)).collect(),
        RawImageData::Float(v) => v.clone(),
    };
    if w == 0 || h == 0 || values.len() < w * h * cpp {
        return Err(decode_error(
            path,
            format!(
                "image data holds {} values for {w}×{h}×{cpp}; the file is truncated",
                values.len()
            ),
        ));
    }
    let is_float = matches!(raw.data, RawImageData::Float(_));
    let black: [f64; 4] = raw.blacklevels.map(f64::from);
    let white_meta: [f64; 4] = raw.whitelevels.map(f64::from);
    let mut info = FrameInfo {
        file: name.clone(),
        black_level: Some(black),
        white_level: Some(white_meta.iter().cloned().fold(0.0, f64::max)),
        ..Default::default()
    };
    // Active area from the crops (top, right, bottom, left).
    let [top, right, bottom, left] = raw.crops;
    let (x0, y0) = (left.min(w), top.min(h));
    let (x1, y1) = (
        w.saturating_sub(right).max(x0),
        h.saturating_sub(bottom).max(y0),
    );

    if cpp == 3 {
        return linear_raw(
            &values,
            w,
            (x0, y0, x1, y1),
            &black,
            &white_meta,
            is_float,
            info,
            &name,
        );
    }
    if cpp != 1 {
        return Err(decode_error(
            path,
            format!("{cpp} components per pixel are not supported"),
        ));
    }
    // The CFA must be a 2×2 Bayer pattern with one R, two G, one B.
    let colour = |r: usize, c: usize| raw.cfa.color_at(r, c);
    let mut counts = [0usize; 4];
    for dy in 0..2 {
        for dx in 0..2 {
            let k = colour(y0 + dy, x0 + dx).min(3);
            counts[k] += 1;
            if colour(y0 + dy + 2, x0 + dx) != colour(y0 + dy, x0 + dx)
                || colour(y0 + dy, x0 + dx + 2) != colour(y0 + dy, x0 + dx)
            {
                counts = [9; 4];
            }
        }
    }
    if counts != [1, 2, 1, 0] {
        return Err(decode_error(
            path,
            format!(
                "CFA pattern '{}' is not a 2×2 Bayer pattern (R, G, G, B)",
                raw.cfa.to_string()
            ),
        ));
    }
    // Measure the clipping plateau per colour.
    let mut max_v = [f32::MIN; 3];
    let mut at_max = [0usize; 3];
    let mut n_col = [0usize; 3];
    for y in y0..y1 {
        for x in x0..x1 {
            let c = colour(y, x).min(2);
            let v = values[y * w + x];
            n_col[c] += 1;
            if v > max_v[c] {
                max_v[c] = v;
                at_max[c] = 1;
            } else if v == max_v[c] {
                at_max[c] += 1;
            }
        }
    }
    let mut white = [0.0f64; 3];
    let mut scale_white = [0.0f64; 3];
    let mut threshold = [0.0f64; 3];
    let mut measured: Option<f64> = None;
    let mut meta_wrong = false;
    for c in 0..3 {
        let wm = white_meta[c];
        let mx = f64::from(max_v[c]);
        let plateau = at_max[c] >= 16 && (at_max[c] as f64) >= 1e-5 * n_col[c] as f64;
        if plateau {
            measured = Some(measured.map_or(mx, |m: f64| m.max(mx)));
        }
        let meta_ok = wm > black[c] && mx <= wm * 1.001;
        if !meta_ok {
            meta_wrong = true;
        }
        scale_white[c] = if meta_ok {
            wm
        } else if is_float {
            1.0_f64.max(mx)
        } else {
            65535.0
        };
        white[c] = if plateau && mx < scale_white[c] {
            mx
        } else {
            scale_white[c]
        };
        threshold[c] = black[c] + SATURATION_FRACTION * (white[c] - black[c]);
    }
    info.white_level_measured = measured;
    info.saturation_threshold = Some(threshold.iter().cloned().fold(f64::INFINITY, f64::min));
    if meta_wrong {
        info.warnings.push(format!(
            "{name}: raw values exceed the metadata white level {:?}; scaled by the 16-bit full scale instead",
            white_meta
        ));
    }
    let fw = (x1 - x0) / 2;
    let fh = (y1 - y0) / 2;
    if fw == 0 || fh == 0 {
        return Err(decode_error(
            path,
            "the active sensor area is smaller than 2×2 pixels",
        ));
    }
    let mut data = Vec::with_capacity(3 * fw * fh);
    let mut sat = vec![0u8; fw * fh];
    for fy in 0..fh {
        for fx in 0..fw {
            let mut acc = [0.0f64; 3];
            let mut n = [0u8; 3];
            let mut bits = 0u8;
            for dy in 0..2 {
                for dx in 0..2 {
                    let (y, x) = (y0 + 2 * fy + dy, x0 + 2 * fx + dx);
                    let c = colour(y, x).min(2);
                    let v = f64::from(values[y * w + x]);
                    if v >= threshold[c] {
                        bits |= 1 << c;
                    }
                    acc[c] += (v - black[c]) / (scale_white[c] - black[c]);
                    n[c] += 1;
                }
            }
            for c in 0..3 {
                data.push((acc[c] / f64::from(n[c].max(1))) as f32);
            }
            sat[fy * fw + fx] = bits;
        }
    }
    info.encoding = "raw-bayer".into();
    let frame = RgbFrame::new(name, fw, fh, 2, data, sat)?;
    Ok((frame, info))
}

/// A linear (demosaiced, 3 values per pixel) DNG.
#[allow(clippy::too_many_arguments)]
fn linear_raw(
    values: &[f32],
    w: usize,
    (x0, y0, x1, y1): (usize, usize, usize, usize),
    black: &[f64; 4],
    white_meta: &[f64; 4],
    is_float: bool,
    mut info: FrameInfo,
    name: &str,
) -> Result<(RgbFrame, FrameInfo)> {
    let (fw, fh) = (x1 - x0, y1 - y0);
    let mut data = Vec::with_capacity(3 * fw * fh);
    let mut sat = vec![0u8; fw * fh];
    let white: [f64; 3] = std::array::from_fn(|c| {
        if white_meta[c] > black[c] {
            white_meta[c]
        } else if is_float {
            1.0
        } else {
            65535.0
        }
    });
    for y in y0..y1 {
        for x in x0..x1 {
            for c in 0..3 {
                let v = f64::from(values[3 * (y * w + x) + c]);
                if v >= black[c] + SATURATION_FRACTION * (white[c] - black[c]) {
                    sat[(y - y0) * fw + (x - x0)] |= 1 << c;
                }
                data.push(((v - black[c]) / (white[c] - black[c])) as f32);
            }
        }
    }
    info.encoding = "raw-linear".into();
    let frame = RgbFrame::new(name, fw, fh, 1, data, sat)?;
    Ok((frame, info))
}
