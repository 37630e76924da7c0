//! Float parameter maps as 32-bit float TIFF files.
//!
//! The `image` crate's TIFF encoder writes float data only as RGB or RGBA, so a scalar map is
//! stored as a 32-bit float RGB TIFF with the value repeated in R, G and B (readable by any TIFF
//! reader and by [`crate::io::image::read_image`], which gives back the value in every channel);
//! a three-channel map (the spectrum) uses the channels as they are. Missing values are NaN.
//! Files are written atomically.

use std::path::Path;

use image::ImageEncoder;

use crate::error::{Error, Result};
use crate::io::atomic_write;

/// Encodes interleaved RGB floats as an uncompressed 32-bit float TIFF.
///
/// # Errors
/// [`Error::ShapeMismatch`] when the buffer does not hold `width × height` RGB pixels;
/// [`Error::InvalidArgument`] when encoding fails.
pub fn encode_tiff_rgb32f(width: usize, height: usize, rgb: &[f32]) -> Result<Vec<u8>> {
    if rgb.len() != 3 * width * height {
        return Err(Error::ShapeMismatch {
            what: "float TIFF pixels".into(),
            expected: 3 * width * height,
            got: rgb.len(),
        });
    }
    let (Ok(w), Ok(h)) = (u32::try_from(width), u32::try_from(height)) else {
        return Err(Error::invalid("TIFF", "image too large"));
    };
    let bytes: Vec<u8> = rgb.iter().flat_map(|v| v.to_ne_bytes()).collect();
    let mut out = std::io::Cursor::new(Vec::new());
    image::codecs::tiff::TiffEncoder::new(&mut out)
        .write_image(&bytes, w, h, image::ExtendedColorType::Rgb32F)
        .map_err(|e| Error::invalid("TIFF", format!("encoding failed: {e}")))?;
    Ok(out.into_inner())
}

/// Writes a scalar map (row-major, `width × height`) as a float TIFF, value in R = G = B.
///
/// # Errors
/// As [`encode_tiff_rgb32f`], and [`Error::Io`] naming the path.
pub fn write_scalar_map(path: &Path, width: usize, height: usize, values: &[f32]) -> Result<()> {
    if values.len() != width * height {
        return Err(Error::ShapeMismatch {
            what: format!("map {}", path.display()),
            expected: width * height,
            got: values.len(),
        });
    }
    atomic_write(path, &scalar_map_tiff(width, height, values)?)
}

/// A scalar map (row-major, `width × height`) as float TIFF bytes, value in R = G = B.
///
/// # Errors
/// As [`encode_tiff_rgb32f`].
pub fn scalar_map_tiff(width: usize, height: usize, values: &[f32]) -> Result<Vec<u8>> {
    if values.len() != width * height {
        return Err(Error::ShapeMismatch {
            what: "scalar map".into(),
            expected: width * height,
            got: values.len(),
        });
    }
    let rgb: Vec<f32> = values.iter().flat_map(|v| [*v, *v, *v]).collect();
    encode_tiff_rgb32f(width, height, &rgb)
}

/// Writes three planar maps (row-major) as the R, G, B channels of one float TIFF.
///
/// # Errors
/// As [`write_scalar_map`].
pub fn write_rgb_map(path: &Path, width: usize, height: usize, planes: [&[f32]; 3]) -> Result<()> {
    let n = width * height;
    if let Some(p) = planes.iter().find(|p| p.len() != n) {
        return Err(Error::ShapeMismatch {
            what: format!("map {}", path.display()),
            expected: n,
            got: p.len(),
        });
    }
    atomic_write(path, &rgb_map_tiff(width, height, planes)?)
}

/// Three planar maps (row-major) as the R, G, B channels of float TIFF bytes.
///
/// # Errors
/// As [`encode_tiff_rgb32f`].
pub fn rgb_map_tiff(width: usize, height: usize, planes: [&[f32]; 3]) -> Result<Vec<u8>> {
    let n = width * height;
    if let Some(p) = planes.iter().find(|p| p.len() != n) {
        return Err(Error::ShapeMismatch {
            what: "RGB map".into(),
            expected: n,
            got: p.len(),
        });
    }
    let rgb: Vec<f32> = (0..n).flat_map(|i| planes.map(|p| p[i])).collect();
    encode_tiff_rgb32f(width, height, &rgb)
}
