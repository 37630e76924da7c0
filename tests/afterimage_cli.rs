//! `lumifit afterimage curves|synth` as a user runs them: the CSV contract, the chart, the frames
//! (16-bit PNG, EXR, APNG), the preset section read back through the schema, and bad input
//! refused with exit 2 and nothing written.

// Channel loops index RGB triplets as the equations do; `!(a > b)` comparisons deliberately
// reject NaN along with out-of-range values.
#![allow(clippy::needless_range_loop, clippy::neg_cmp_op_on_partial_ord)]

mod common;

use common::{assert_rejected, lumifit, p, stderr, write};

use lumifit::afterimage::mikamo2013::{display_matrices, TABLE1_T_S, TABLE1_XY};
use lumifit::afterimage::{luminance_y, LinearImage};
use lumifit::colorimetry::xyy::xyy_to_xyz;
use lumifit::io::afterimage_csv::{parse_curves_csv, CURVES_COLUMNS};
use lumifit::io::hdr_image::{decode_display_image, encode_exr, encode_png16_srgb};
use lumifit::math::linalg::mat3_mul_vec;
use lumifit::preset::afterimage::AfterimageSection;
use lumifit::preset::{read_material, MaterialPreset};

/// A 96×64 linear image: black with a reference-coloured square (Y = 1) and a dim green one.
fn stimulus() -> LinearImage {
    let (_, to_rgb) = display_matrices().unwrap();
    let warm = mat3_mul_vec(&to_rgb, xyy_to_xyz([0.41, 0.42, 1.0]));
    let green = mat3_mul_vec(&to_rgb, xyy_to_xyz([0.30, 0.55, 0.7]));
    let (w, h) = (96, 64);
    let mut rgb = vec![0f32; 3 * w * h];
    for y in 0..h {
        for x in 0..w {
            let c = if (12..44).contains(&x) && (16..48).contains(&y) {
                warm
            } else if (56..84).contains(&x) && (18..46).contains(&y) {
                green
            } else {
                [0.0; 3]
            };
            for k in 0..3 {
                rgb[3 * (y * w + x) + k] = c[k] as f32;
            }
        }
    }
    LinearImage::new("stimulus", w, h, rgb).unwrap()
}

#[test]
fn curves_csv_keeps_the_contract_and_the_table_values() {
    let dir = tempfile::tempdir().unwrap();
    let csv = p(dir.path(), "curves.csv");
    let png = p(dir.path(), "curves.png");
    let o = lumifit(&["afterimage", "curves", "--out", &csv, "--plot", &png]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(&csv).unwrap();
    assert_eq!(text.lines().next().unwrap(), CURVES_COLUMNS.join(","));
    let pts = parse_curves_csv(text.as_bytes(), &csv).unwrap();
    assert_eq!(pts.len(), 801);
    for (t, xy) in TABLE1_T_S.iter().zip(TABLE1_XY) {
        let q = pts
            .iter()
            .find(|q| q.t_s == *t)
            .expect("Table 1 time on the grid");
        assert_eq!([q.x, q.y], xy);
        assert!((q.big_y - luminance_y(*t)).abs() <= 1e-12 * luminance_y(*t));
    }
    let img = image::open(&png).unwrap().to_rgb8();
    assert_eq!((img.width(), img.height()), (1700, 760));
    // The chart is drawn: many distinct colours (locus, track swatches), not a blank canvas.
    let distinct: std::collections::HashSet<[u8; 3]> = img.pixels().map(|p| p.0).collect();
    assert!(distinct.len() > 50, "{} colours", distinct.len());
    // Over 80 s needs --extrapolate.
    let o = lumifit(&[
        "afterimage",
        "curves",
        "--end-s",
        "90",
        "--out",
        &p(dir.path(), "x.csv"),
    ]);
    assert_rejected(&o, &["--extrapolate"]);
    assert!(!dir.path().join("x.csv").exists());
}

#[test]
fn synth_writes_frames_preview_curves_preset_and_figure() {
    let dir = tempfile::tempdir().unwrap();
    let input = write(dir.path(), "stimulus.exr", encode_exr(&stimulus()).unwrap());
    let out = dir.path().join("out");
    let o = lumifit(&[
        "afterimage",
        "synth",
        input.to_str().unwrap(),
        "--times",
        "0:80:20",
        "--blur-sigma-px",
        "1.5",
        "--exr",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let summary: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(summary["frames"], 5);
    assert_eq!(summary["input_encoding"], "LinearFloat");
    for t in [0.0, 20.0, 40.0, 60.0, 80.0] {
        let name = format!("frame_t{t:07.3}");
        let bytes = std::fs::read(out.join(format!("{name}.png"))).unwrap();
        let img = image::load_from_memory(&bytes).unwrap();
        assert!(
            matches!(img, image::DynamicImage::ImageRgb16(_)),
            "{name} is not 16-bit RGB"
        );
        assert_eq!((img.width(), img.height()), (96, 64));
        // The EXR holds the linear frame; its sRGB encoding is the PNG, code for code.
        let exr = std::fs::read(out.join(format!("{name}.exr"))).unwrap();
        let (lin, _) = decode_display_image(&exr, std::path::Path::new("f.exr"), 64).unwrap();
        let png_again = encode_png16_srgb(&lin).unwrap();
        let a = image::load_from_memory(&png_again).unwrap().to_rgb16();
        assert_eq!(a.as_raw(), img.to_rgb16().as_raw(), "{name}");
        // Outside the mask (a corner far from both squares) the afterimage is black.
        assert_eq!(img.to_rgb16().get_pixel(2, 2).0, [0, 0, 0]);
    }
    // At t = 0 the reference square's centre is lit, by 80 s it has faded.
    let f0 = image::open(out.join("frame_t000.000.png"))
        .unwrap()
        .to_rgb16();
    let f80 = image::open(out.join("frame_t080.000.png"))
        .unwrap()
        .to_rgb16();
    assert!(f0.get_pixel(28, 32).0[1] > 20_000);
    assert!(f80.get_pixel(28, 32).0[1] < f0.get_pixel(28, 32).0[1] / 4);
    // The green square is below the default mask threshold relative to Y_max? Its Y is 0.7 ≥ 0.5:
    // it is in the mask and lit.
    assert!(f0.get_pixel(70, 32).0[1] > 10_000);

    let apng = std::fs::read(out.join("preview.apng")).unwrap();
    let reader = png::Decoder::new(std::io::Cursor::new(apng))
        .read_info()
        .unwrap();
    assert_eq!(reader.info().animation_control().unwrap().num_frames, 5);

    let curves = std::fs::read(out.join("curves.csv")).unwrap();
    let pts = parse_curves_csv(&curves, "curves.csv").unwrap();
    assert_eq!(
        pts.iter().map(|q| q.t_s).collect::<Vec<_>>(),
        vec![0.0, 20.0, 40.0, 60.0, 80.0]
    );

    let preset: MaterialPreset = read_material(&out.join("afterimage.preset.json")).unwrap();
    let section =
        AfterimageSection::from_section(preset.afterimage.as_ref().unwrap(), "preset").unwrap();
    assert_eq!(section.gamma, 0.7);
    assert_eq!(section.k, 0.05);
    assert_eq!(section.blur_sigma_px, 1.5);
    assert_eq!(section.curves.t_s.len(), 5);
    assert!(section.dark_adaptation.is_none());
    assert_eq!(preset.provenance.inputs.len(), 1);

    let fig = image::open(out.join("figure.png")).unwrap();
    assert!(fig.width() > 4 * 300, "input, mask and frames side by side");
}

#[test]
fn an_ldr_png_and_a_background_dark_adapt() {
    let dir = tempfile::tempdir().unwrap();
    let input = write(
        dir.path(),
        "on.png",
        encode_png16_srgb(&stimulus()).unwrap(),
    );
    let bg = LinearImage::new("bg", 96, 64, vec![0.4f32; 3 * 96 * 64]).unwrap();
    let bg_path = write(dir.path(), "off.png", encode_png16_srgb(&bg).unwrap());
    let out = dir.path().join("o");
    let o = lumifit(&[
        "afterimage",
        "synth",
        input.to_str().unwrap(),
        "--background",
        bg_path.to_str().unwrap(),
        "--times",
        "0,40",
        "--dark-constant",
        "0.1",
        "--dark-time-s",
        "10",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let summary: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(summary["input_encoding"], "Srgb(16)");
    let corner = |t: &str| {
        let img = image::open(out.join(format!("frame_t{t}.png")))
            .unwrap()
            .to_rgb16();
        let code = img.get_pixel(1, 1).0[0];
        lumifit::colorimetry::rgb::eotf_srgb(f64::from(code) / 65535.0)
    };
    // Background only: 0.4·w(t), w(0) = 0.1, w(40) = 1 − 0.9 e^−4.
    assert!(
        (corner("000.000") - 0.04).abs() < 2e-4,
        "{}",
        corner("000.000")
    );
    let w40 = 1.0 - 0.9 * (-4.0f64).exp();
    assert!((corner("040.000") - 0.4 * w40).abs() < 2e-4);
    let preset = read_material(&out.join("afterimage.preset.json")).unwrap();
    let s = AfterimageSection::from_section(preset.afterimage.as_ref().unwrap(), "p").unwrap();
    assert_eq!(s.dark_adaptation.unwrap().time_s, 10.0);
    assert_eq!(preset.provenance.inputs.len(), 2);
}

#[test]
fn bad_input_is_exit_2_with_the_file_or_flag_and_nothing_written() {
    let dir = tempfile::tempdir().unwrap();
    let good = write(dir.path(), "on.exr", encode_exr(&stimulus()).unwrap());
    let black = write(
        dir.path(),
        "black.exr",
        encode_exr(&LinearImage::new("b", 8, 8, vec![0.0; 192]).unwrap()).unwrap(),
    );
    let junk = write(dir.path(), "junk.png", b"this is not an image");
    let out = dir.path().join("out");
    let o_s = out.to_str().unwrap();
    let g = good.to_str().unwrap();
    let cases: Vec<(Vec<&str>, Vec<&str>)> = vec![
        (
            vec![black.to_str().unwrap(), "--times", "0"],
            vec!["black.exr", "L_on^max"],
        ),
        (
            vec![junk.to_str().unwrap(), "--times", "0"],
            vec!["junk.png", "not a readable image"],
        ),
        (
            vec![g, "--times", "0:90:10"],
            vec!["--times", "--extrapolate"],
        ),
        (vec![g, "--times", "0", "--gamma", "-1"], vec!["--gamma"]),
        (vec![g, "--times", "0", "--k", "-0.5"], vec!["--k"]),
        (
            vec![g, "--times", "0", "--mask-threshold", "2"],
            vec!["--mask-threshold"],
        ),
        (
            vec![g, "--times", "0", "--dark-constant", "0.1"],
            vec!["--background"],
        ),
        (vec![g, "--times", "a,b"], vec!["--times"]),
        (
            vec![g, "--times", "4,8,4"],
            vec!["--times", "frame_t004.000.png"],
        ),
        (
            vec![g, "--times", "0", "--background", black.to_str().unwrap()],
            vec!["--background"],
        ),
    ];
    for (args, fragments) in cases {
        let mut full = vec!["afterimage", "synth"];
        full.extend(args.iter());
        full.extend(["--out", o_s]);
        let o = lumifit(&full);
        assert_rejected(&o, &fragments);
        assert!(!out.exists(), "{args:?} wrote {}", out.display());
    }
    // Extrapolation is allowed when asked for.
    let o = lumifit(&[
        "afterimage",
        "synth",
        g,
        "--times",
        "0,100",
        "--extrapolate",
        "--out",
        o_s,
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(out.join("frame_t100.000.png").exists());
}

/// CRC-32 (IEEE) for hand-made PNG chunks.
fn crc32(bytes: &[u8]) -> u32 {
    let mut c = 0xFFFF_FFFFu32;
    for &b in bytes {
        c ^= u32::from(b);
        for _ in 0..8 {
            c = if c & 1 != 0 {
                0xEDB8_8320 ^ (c >> 1)
            } else {
                c >> 1
            };
        }
    }
    !c
}

#[test]
fn an_absurd_image_size_is_refused_from_the_header_and_an_input_is_never_overwritten() {
    let dir = tempfile::tempdir().unwrap();
    // A PNG whose header claims 100000 × 100000 px (≈ 900 GiB of planes): refused before decoding.
    let mut ihdr = b"IHDR".to_vec();
    ihdr.extend(100_000u32.to_be_bytes());
    ihdr.extend(100_000u32.to_be_bytes());
    ihdr.extend([16, 2, 0, 0, 0]);
    let mut png = b"\x89PNG\r\n\x1a\n".to_vec();
    png.extend(13u32.to_be_bytes());
    png.extend(&ihdr);
    png.extend(crc32(&ihdr).to_be_bytes());
    // A short IDAT (the header reader stops at the first image data) and IEND.
    for (tag, body) in [
        (&b"IDAT"[..], &[0x78u8, 0x9c, 0x03, 0x00][..]),
        (&b"IEND"[..], &[][..]),
    ] {
        let mut chunk = tag.to_vec();
        chunk.extend(body);
        png.extend((body.len() as u32).to_be_bytes());
        png.extend(&chunk);
        png.extend(crc32(&chunk).to_be_bytes());
    }
    let huge = write(dir.path(), "huge.png", png);
    let out = dir.path().join("o");
    let o = lumifit(&[
        "afterimage",
        "synth",
        huge.to_str().unwrap(),
        "--times",
        "0",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_rejected(&o, &["huge.png", "100000×100000", "MiB"]);
    assert!(!out.exists());

    // The input sits in the output directory under a frame's name: refused, left byte-identical.
    let out = dir.path().join("frames");
    std::fs::create_dir(&out).unwrap();
    let bytes = encode_png16_srgb(&stimulus()).unwrap();
    let input = write(&out, "frame_t000.000.png", &bytes);
    let o = lumifit(&[
        "afterimage",
        "synth",
        input.to_str().unwrap(),
        "--times",
        "0,4",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_rejected(&o, &["is the input"]);
    assert_eq!(std::fs::read(&input).unwrap(), bytes);
    assert_eq!(
        std::fs::read_dir(&out).unwrap().count(),
        1,
        "nothing else written"
    );
}

#[test]
fn fps_and_duration_give_frames_at_i_over_f() {
    let dir = tempfile::tempdir().unwrap();
    let input = write(dir.path(), "on.exr", encode_exr(&stimulus()).unwrap());
    let out = dir.path().join("o");
    let o = lumifit(&[
        "afterimage",
        "synth",
        input.to_str().unwrap(),
        "--fps",
        "2",
        "--duration",
        "2",
        "--blur-sigma-px",
        "0",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    for t in ["000.000", "000.500", "001.000", "001.500", "002.000"] {
        assert!(out.join(format!("frame_t{t}.png")).exists(), "{t}");
    }
    let pts = parse_curves_csv(&std::fs::read(out.join("curves.csv")).unwrap(), "c").unwrap();
    assert_eq!(pts.len(), 5);
    let o = lumifit(&[
        "afterimage",
        "synth",
        input.to_str().unwrap(),
        "--fps",
        "0",
        "--duration",
        "2",
        "--out",
        p(dir.path(), "o2").as_str(),
    ]);
    assert_rejected(&o, &["--fps"]);
}
