//! Ordinary images through the `image` crate: 8/16-bit PNG and TIFF, float TIFF, OpenEXR.
//!
//! - 16-bit integer and float data are taken as **linear** (0–65535 → 0–1; floats as stored).
//! - 8-bit data are assumed to be sRGB-encoded and are decoded to linear with the sRGB EOTF; a
//!   warning says so, because 8-bit photos are rarely linear and quantisation limits precision.
//! - Greyscale images are replicated to R = G = B; alpha is ignored.
//! - Integer pixels at full scale (255 or 65535) are flagged saturated; floats never are.
//!
//! [`encode_tiff16`] writes a 16-bit linear RGB TIFF (the synthetic captures' format).

use std::path::Path;

use image::{DynamicImage, ImageEncoder};

use crate::capture::{FrameInfo, RgbFrame};
use crate::colorimetry::rgb::eotf_srgb;
use crate::error::{Error, Result};

fn image_error(path: &Path, reason: impl std::fmt::Display) -> Error {
    Error::io(
        path,
        std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!(
                "not a readable image ({reason}); expected a camera RAW, PNG, TIFF (8/16-bit or float) or OpenEXR file"
            ),
        ),
    )
}

/// Reads an image file into a linear frame (`pixel_scale = 1`).
///
/// # Errors
/// [`Error::Io`] naming the file when it cannot be read or decoded.
pub fn read_image(path: &Path) -> Result<(RgbFrame, FrameInfo)> {
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    read_image_bytes(&bytes, path)
}

/// As [`read_image`], from bytes in memory (`path` names them in messages).
pub fn read_image_bytes(bytes: &[u8], path: &Path) -> Result<(RgbFrame, FrameInfo)> {
    let reader = image::ImageReader::new(std::io::Cursor::new(bytes))
        .with_guessed_format()
        .map_err(|e| image_error(path, e))?;
    if reader.format().is_none() {
        return Err(image_error(path, "unknown file format"));
    }
    let mut reader = reader;
    reader.no_limits();
    let img = super::raw::quiet_catch_unwind(|| reader.decode())
        .map_err(|cause| {
            image_error(
                path,
                format!("the decoder failed on malformed data: {cause}"),
            )
        })?
        .map_err(|e| image_error(path, e))?;
    let name = path.display().to_string();
    let mut info = FrameInfo {
        file: name.clone(),
        ..Default::default()
    };
    let (w, h) = (img.width() as usize, img.height() as usize);
    let mut data = Vec::with_capacity(3 * w * h);
    let mut sat = vec![0u8; w * h];
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    match &img {
        DynamicImage::ImageLuma8(_)
        | DynamicImage::ImageLumaA8(_)
        | DynamicImage::ImageRgb8(_)
        | DynamicImage::ImageRgba8(_) => {
            let lut: Vec<f32> = (0..256)
                .map(|v| eotf_srgb(f64::from(v) / 255.0) as f32)
                .collect();
            let rgb = img.to_rgb8();
            for (i, p) in rgb.pixels().enumerate() {
                for c in 0..3 {
                    data.push(lut[p[c] as usize]);
                    if p[c] == 255 {
                        sat[i] |= 1 << c;
                    }
                }
            }
            info.encoding = format!("{ext}-8bit-srgb");
            info.warnings.push(format!(
                "{name}: 8-bit image decoded from sRGB to linear; 8-bit photos are rarely linear and are quantised — prefer RAW or a 16-bit linear export"
            ));
        }
        DynamicImage::ImageLuma16(_)
        | DynamicImage::ImageLumaA16(_)
        | DynamicImage::ImageRgb16(_)
        | DynamicImage::ImageRgba16(_) => {
            let rgb = img.to_rgb16();
            for (i, p) in rgb.pixels().enumerate() {
                for c in 0..3 {
                    data.push(f32::from(p[c]) / 65535.0);
                    if p[c] == u16::MAX {
                        sat[i] |= 1 << c;
                    }
                }
            }
            info.encoding = format!("{ext}-16bit-linear");
        }
        _ => {
            let rgb = img.to_rgb32f();
            for p in rgb.pixels() {
                for c in 0..3 {
                    let v = p[c];
                    data.push(if v.is_finite() { v } else { 0.0 });
                }
            }
            info.encoding = format!("{ext}-float-linear");
        }
    }
    let frame = RgbFrame::new(name, w, h, 1, data, sat)?;
    Ok((frame, info))
}

/// Encodes 16-bit RGB pixels (row-major, interleaved) as an uncompressed TIFF.
///
/// # Errors
/// [`Error::InvalidArgument`] when the buffer does not match the size or encoding fails.
pub fn encode_tiff16(width: u32, height: u32, rgb: &[u16]) -> Result<Vec<u8>> {
    if rgb.len() != 3 * width as usize * height as usize {
        return Err(Error::ShapeMismatch {
            what: "16-bit TIFF pixels".into(),
            expected: 3 * width as usize * height as usize,
            got: rgb.len(),
        });
    }
    let mut out = std::io::Cursor::new(Vec::new());
    let bytes: Vec<u8> = rgb.iter().flat_map(|v| v.to_ne_bytes()).collect();
    image::codecs::tiff::TiffEncoder::new(&mut out)
        .write_image(&bytes, width, height, image::ExtendedColorType::Rgb16)
        .map_err(|e| Error::invalid("TIFF", format!("encoding failed: {e}")))?;
    Ok(out.into_inner())
}

/// Quantises a frame's linear values (0–1 → 0–65535, clipped) and encodes a 16-bit TIFF.
///
/// # Errors
/// As [`encode_tiff16`].
pub fn frame_to_tiff16(frame: &RgbFrame) -> Result<Vec<u8>> {
    let px: Vec<u16> = frame
        .data()
        .iter()
        .map(|&v| (f64::from(v).clamp(0.0, 1.0) * 65535.0).round() as u16)
        .collect();
    encode_tiff16(frame.width as u32, frame.height as u32, &px)
}
