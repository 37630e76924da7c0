//! The real DNGs in `../shared/data/raw/` handled as a user expects: all three (the 14-bit
//! Magic Lantern original and its uncompressed and LJPEG-compressed 16-bit rewrites) decode with
//! the right black and white levels and identical linear values. Each test reports and passes
//! when the folder is absent (and `tests/shared_data.rs` fails under LUMIFIT_REQUIRE_DATA=1).

use std::path::{Path, PathBuf};

use lumifit::capture::{roi_stats, Roi};
use lumifit::io::series::read_frame;

fn raw_dir() -> Option<PathBuf> {
    let d = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data/raw");
    if d.is_dir() {
        Some(d)
    } else {
        eprintln!("skipped: {} is absent", d.display());
        None
    }
}

/// Black and white levels written by Magic Lantern for this 550D file (PROVENANCE.md).
const BLACK: f64 = 2056.0;
const WHITE: f64 = 15000.0;

#[test]
fn sixteen_bit_rewrites_decode_with_the_documented_black_and_white_levels() {
    let Some(dir) = raw_dir() else { return };
    for name in [
        "tinydng_colorchart_rawler_uncompressed16.dng",
        "tinydng_colorchart_rawler_ljpeg.dng",
    ] {
        let (frame, info) = read_frame(&dir.join(name)).expect("16-bit DNG decodes");
        eprintln!(
            "{name}: {}x{} binned, black {:?}, white {:?}, measured white {:?}, saturated {:.4}",
            frame.width,
            frame.height,
            info.black_level,
            info.white_level,
            info.white_level_measured,
            frame.saturated_fraction()
        );
        assert_eq!(frame.pixel_scale, 2);
        // The active area trims the 1888×1182 sensor to the image area.
        let (sw, sh) = frame.source_size();
        assert!(
            sw <= 1888 && sh <= 1182 && sw > 1600 && sh > 1000,
            "{sw}×{sh}"
        );
        let black = info.black_level.expect("RAW reports black levels");
        for (c, b) in black.iter().enumerate().take(3) {
            assert_eq!(*b, BLACK, "black level of colour {c}");
        }
        assert_eq!(info.white_level, Some(WHITE));
        // Linear values live in [−black/range, 1]: the chart is neither clipped nor negative on average.
        let st = roi_stats(&frame, &Roi::parse_rect(&format!("0,0,{sw},{sh}")).unwrap()).unwrap();
        for c in 0..3 {
            assert!(
                st.mean[c] > 0.0 && st.mean[c] < 1.0,
                "mean {c} = {}",
                st.mean[c]
            );
        }
    }
}

#[test]
fn both_sixteen_bit_rewrites_give_identical_linear_values() {
    let Some(dir) = raw_dir() else { return };
    let (a, _) = read_frame(&dir.join("tinydng_colorchart_rawler_uncompressed16.dng")).unwrap();
    let (b, _) = read_frame(&dir.join("tinydng_colorchart_rawler_ljpeg.dng")).unwrap();
    // LJPEG-92 is lossless: the decoded photosites, hence the binned values, are bit-identical.
    assert_eq!(a.data(), b.data());
}

#[test]
fn the_fourteen_bit_magic_lantern_original_decodes_to_the_same_values_as_its_rewrites() {
    // rawloader refused this file ("Don't know about 14 bps"); rawler reads it. The 16-bit
    // rewrites hold the same photosites, so the linear superpixels must be identical.
    let Some(dir) = raw_dir() else { return };
    let (orig, info) = read_frame(&dir.join("tinydng_colorchart.dng")).expect("14-bit DNG decodes");
    let (rewrite, _) =
        read_frame(&dir.join("tinydng_colorchart_rawler_uncompressed16.dng")).unwrap();
    assert_eq!(info.black_level.map(|b| b[0]), Some(BLACK));
    assert_eq!(info.white_level, Some(WHITE));
    assert_eq!((orig.width, orig.height), (rewrite.width, rewrite.height));
    assert_eq!(orig.data(), rewrite.data());
}
