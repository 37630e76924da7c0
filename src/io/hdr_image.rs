//! Display images for the afterimage pipeline: HDR and LDR inputs decoded to linear sRGB, and
//! frames written as 16-bit sRGB PNG, linear OpenEXR and an animated PNG preview.
//!
//! Inputs (format guessed from the bytes, not the extension):
//!
//! - **float** pixels — OpenEXR, Radiance HDR (`.hdr`), float TIFF — are linear and kept as
//!   stored (any scale; the afterimage model normalises by the brightest pixel);
//! - **integer** pixels — 8- or 16-bit PNG, JPEG, 8/16-bit TIFF — are display images, sRGB
//!   encoded, and are decoded with the sRGB EOTF. This differs on purpose from
//!   [`crate::io::image::read_image`], which takes 16-bit data as linear camera data: a 16-bit
//!   PNG of a scene to be shown is an sRGB picture.
//!
//! Greyscale is replicated to RGB, alpha is ignored. A non-finite float pixel, an empty image or
//! an unknown format is an error naming the file. The size is checked with
//! [`crate::limits::check_memory`] from the header before the pixels are decoded.
//!
//! Outputs: [`encode_png16_srgb`] clips linear values to 0–1, applies the sRGB inverse EOTF and
//! rounds `⌊65535·V + ½⌋` (the rule the numpy benchmark script repeats); rows use the PNG `Up`
//! filter. [`encode_exr`] writes linear 32-bit float RGB. [`encode_apng`] writes an 8-bit
//! animated PNG (APNG) from frames made with [`preview_rgb8`].

use std::path::Path;

use image::{DynamicImage, ImageEncoder};

use crate::afterimage::LinearImage;
use crate::colorimetry::rgb::{eotf_inverse_srgb, eotf_srgb};
use crate::error::{Error, Result};

fn image_error(path: &Path, reason: impl std::fmt::Display) -> Error {
    Error::io(
        path,
        std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!(
                "not a readable image ({reason}); expected OpenEXR, Radiance HDR, PNG, JPEG or TIFF"
            ),
        ),
    )
}

/// How an input was decoded.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum InputEncoding {
    /// Float pixels taken as linear (EXR, Radiance HDR, float TIFF).
    LinearFloat,
    /// Integer pixels decoded from sRGB (bits per channel).
    Srgb(u8),
}

/// Reads a display image (see the module docs) into linear sRGB.
///
/// # Errors
/// [`Error::Io`] naming the file when it cannot be read or decoded; [`Error::InvalidArgument`]
/// for an empty image or a non-finite pixel; [`Error::TooLarge`] before decoding a huge image.
pub fn read_display_image(
    path: &Path,
    bytes_per_pixel: u128,
) -> Result<(LinearImage, InputEncoding)> {
    let bytes = crate::io::read_input(path)?.0;
    decode_display_image(&bytes, path, bytes_per_pixel)
}

/// As [`read_display_image`], from bytes in memory (`path` names them in messages).
pub fn decode_display_image(
    bytes: &[u8],
    path: &Path,
    bytes_per_pixel: u128,
) -> Result<(LinearImage, InputEncoding)> {
    let name = path.display().to_string();
    let open = || -> Result<image::ImageReader<std::io::Cursor<&[u8]>>> {
        let r = image::ImageReader::new(std::io::Cursor::new(bytes))
            .with_guessed_format()
            .map_err(|e| image_error(path, e))?;
        if r.format().is_none() {
            return Err(image_error(path, "unknown file format"));
        }
        Ok(r)
    };
    let (w, h) = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        open().and_then(|r| r.into_dimensions().map_err(|e| image_error(path, e)))
    }))
    .map_err(|_| image_error(path, "the decoder failed on malformed data"))??;
    if w == 0 || h == 0 {
        return Err(Error::invalid(
            name,
            format!("{w}×{h} px; expected a non-empty image"),
        ));
    }
    crate::limits::check_memory(
        &name,
        &format!("{w}×{h} px"),
        u128::from(w) * u128::from(h),
        bytes_per_pixel,
    )?;
    let mut reader = open()?;
    reader.no_limits();
    let img = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| reader.decode()))
        .map_err(|_| image_error(path, "the decoder failed on malformed data"))?
        .map_err(|e| image_error(path, e))?;
    let (w, h) = (img.width() as usize, img.height() as usize);
    let (data, enc) = match &img {
        DynamicImage::ImageLuma8(_)
        | DynamicImage::ImageLumaA8(_)
        | DynamicImage::ImageRgb8(_)
        | DynamicImage::ImageRgba8(_) => {
            let lut: Vec<f32> = (0..256)
                .map(|v| eotf_srgb(f64::from(v) / 255.0) as f32)
                .collect();
            let data = img
                .to_rgb8()
                .into_raw()
                .into_iter()
                .map(|v| lut[v as usize])
                .collect();
            (data, InputEncoding::Srgb(8))
        }
        DynamicImage::ImageLuma16(_)
        | DynamicImage::ImageLumaA16(_)
        | DynamicImage::ImageRgb16(_)
        | DynamicImage::ImageRgba16(_) => {
            let lut: Vec<f32> = (0..65536)
                .map(|v| eotf_srgb(f64::from(v) / 65535.0) as f32)
                .collect();
            let data = img
                .to_rgb16()
                .into_raw()
                .into_iter()
                .map(|v| lut[v as usize])
                .collect();
            (data, InputEncoding::Srgb(16))
        }
        _ => {
            let data = img.to_rgb32f().into_raw();
            if let Some(i) = data.iter().position(|v| !v.is_finite()) {
                let p = i / 3;
                return Err(Error::invalid(
                    name,
                    format!(
                        "pixel ({}, {}) channel {} is {}; expected finite values",
                        p % w,
                        p / w,
                        i % 3,
                        data[i]
                    ),
                ));
            }
            (data, InputEncoding::LinearFloat)
        }
    };
    Ok((LinearImage::new(&name, w, h, data)?, enc))
}

/// The 16-bit sRGB code of a linear value: `⌊65535·V(clip(v, 0, 1)) + ½⌋`.
pub fn linear_to_srgb16(v: f32) -> u16 {
    let e = eotf_inverse_srgb(f64::from(v).clamp(0.0, 1.0)).clamp(0.0, 1.0);
    (e * 65535.0 + 0.5).floor() as u16
}

/// Encodes a linear frame as a 16-bit sRGB PNG (sRGB chunk, `Up` row filter).
///
/// # Errors
/// [`Error::InvalidArgument`] when encoding fails.
pub fn encode_png16_srgb(img: &LinearImage) -> Result<Vec<u8>> {
    use rayon::prelude::*;
    let mut bytes = vec![0u8; img.rgb.len() * 2];
    bytes
        .par_chunks_mut(2)
        .zip(img.rgb.par_iter())
        .for_each(|(b, v)| b.copy_from_slice(&linear_to_srgb16(*v).to_be_bytes()));
    let mut out = Vec::new();
    {
        let mut enc = png::Encoder::new(&mut out, img.width as u32, img.height as u32);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Sixteen);
        enc.set_compression(png::Compression::Fast);
        enc.set_filter(png::Filter::Up);
        enc.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
        let mut w = enc.write_header().map_err(png_err)?;
        w.write_image_data(&bytes).map_err(png_err)?;
        w.finish().map_err(png_err)?;
    }
    Ok(out)
}

fn png_err(e: impl std::fmt::Display) -> Error {
    Error::invalid("PNG", format!("encoding failed: {e}"))
}

/// Encodes a linear frame as a 32-bit float RGB OpenEXR.
///
/// # Errors
/// [`Error::InvalidArgument`] when encoding fails.
pub fn encode_exr(img: &LinearImage) -> Result<Vec<u8>> {
    let mut out = std::io::Cursor::new(Vec::new());
    let bytes: Vec<u8> = img.rgb.iter().flat_map(|v| v.to_ne_bytes()).collect();
    image::codecs::openexr::OpenExrEncoder::new(&mut out)
        .write_image(
            &bytes,
            img.width as u32,
            img.height as u32,
            image::ExtendedColorType::Rgb32F,
        )
        .map_err(|e| Error::invalid("EXR", format!("encoding failed: {e}")))?;
    Ok(out.into_inner())
}

/// A box-filtered copy whose larger side is at most `max_side_px` (an integer factor; the image
/// itself when it is already small enough).
pub fn downscale(img: &LinearImage, max_side_px: usize) -> LinearImage {
    let side = img.width.max(img.height);
    let f = side.div_ceil(max_side_px.max(1)).max(1);
    if f == 1 {
        return img.clone();
    }
    let (w, h) = (img.width.div_ceil(f), img.height.div_ceil(f));
    let mut out = vec![0f32; 3 * w * h];
    for y in 0..h {
        for x in 0..w {
            let mut acc = [0f64; 3];
            let mut n = 0.0;
            for yy in y * f..((y + 1) * f).min(img.height) {
                for xx in x * f..((x + 1) * f).min(img.width) {
                    let i = 3 * (yy * img.width + xx);
                    for c in 0..3 {
                        acc[c] += f64::from(img.rgb[i + c]);
                    }
                    n += 1.0;
                }
            }
            for c in 0..3 {
                out[3 * (y * w + x) + c] = (acc[c] / n) as f32;
            }
        }
    }
    LinearImage {
        width: w,
        height: h,
        rgb: out,
    }
}

/// 8-bit sRGB bytes of a (small) linear image, clipped to 0–1.
pub fn preview_rgb8(img: &LinearImage) -> Vec<u8> {
    img.rgb
        .iter()
        .map(|&v| {
            (eotf_inverse_srgb(f64::from(v).clamp(0.0, 1.0)) * 255.0 + 0.5).floor() as u8
        })
        .collect()
}

/// Encodes 8-bit RGB frames of one size as an endlessly looping APNG; `delays_s[i]` is how long
/// frame i is shown (rounded to 1/1000 s, at least 1/1000 s).
///
/// # Errors
/// [`Error::InvalidArgument`] for no frame, frames of the wrong size or a failed encoding.
pub fn encode_apng(
    width: usize,
    height: usize,
    frames: &[Vec<u8>],
    delays_s: &[f64],
) -> Result<Vec<u8>> {
    if frames.is_empty() || frames.len() != delays_s.len() {
        return Err(Error::invalid(
            "preview",
            format!(
                "{} frames and {} delays; expected at least one frame and one delay each",
                frames.len(),
                delays_s.len()
            ),
        ));
    }
    if let Some(f) = frames.iter().find(|f| f.len() != 3 * width * height) {
        return Err(Error::ShapeMismatch {
            what: "preview frame".into(),
            expected: 3 * width * height,
            got: f.len(),
        });
    }
    let mut out = Vec::new();
    {
        let mut enc = png::Encoder::new(&mut out, width as u32, height as u32);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        enc.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
        enc.set_animated(frames.len() as u32, 0).map_err(png_err)?;
        let mut w = enc.write_header().map_err(png_err)?;
        for (f, d) in frames.iter().zip(delays_s) {
            let ms = (d * 1000.0).round().clamp(1.0, 65535.0) as u16;
            w.set_frame_delay(ms, 1000).map_err(png_err)?;
            w.write_image_data(f).map_err(png_err)?;
        }
        w.finish().map_err(png_err)?;
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sixteen_bit_png_round_trips_through_the_decoder() {
        let rgb: Vec<f32> = (0..3 * 6 * 4).map(|i| i as f32 / 72.0).collect();
        let img = LinearImage::new("t", 6, 4, rgb).unwrap();
        let png = encode_png16_srgb(&img).unwrap();
        let (back, enc) = decode_display_image(&png, Path::new("t.png"), 64).unwrap();
        assert_eq!(enc, InputEncoding::Srgb(16));
        for (a, b) in img.rgb.iter().zip(&back.rgb) {
            // One 16-bit step of the sRGB code is at most 1/65535·12.92⁻¹… in linear near 0 and
            // ≈ 3.5e-5 near 1.
            assert!((a - b).abs() < 4e-5, "{a} vs {b}");
        }
    }

    #[test]
    fn exr_round_trips_exactly() {
        let rgb: Vec<f32> = (0..3 * 5 * 3).map(|i| i as f32 * 7.25).collect();
        let img = LinearImage::new("t", 5, 3, rgb).unwrap();
        let exr = encode_exr(&img).unwrap();
        let (back, enc) = decode_display_image(&exr, Path::new("t.exr"), 64).unwrap();
        assert_eq!(enc, InputEncoding::LinearFloat);
        assert_eq!(back.rgb, img.rgb);
    }

    #[test]
    fn an_animated_png_has_its_frames() {
        let frames = vec![vec![0u8; 3 * 4 * 2], vec![255u8; 3 * 4 * 2]];
        let apng = encode_apng(4, 2, &frames, &[0.4, 0.4]).unwrap();
        let dec = png::Decoder::new(std::io::Cursor::new(apng));
        let reader = dec.read_info().unwrap();
        assert_eq!(reader.info().animation_control().unwrap().num_frames, 2);
    }

    #[test]
    fn garbage_is_refused_with_the_file_name() {
        let e = decode_display_image(b"not an image", Path::new("x.png"), 64).unwrap_err();
        assert!(e.to_string().contains("x.png"), "{e}");
    }
}
