//! `lumifit afterimage curves|synth`: the afterimage model of Mikamo et al. 2013 — its curves,
//! and frames of an image's afterimage (docs/afterimage.md).

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{bail, Result};
use clap::{Args, Subcommand};
use lumifit::afterimage::mikamo2013::{BYTES_PER_PIXEL, REFERENCE_XY_TABLE1};
use lumifit::afterimage::{
    curves, time_grid, DarkAdaptation, LinearImage, MaskRule, SynthParams, Synthesizer, TimeRange,
};
use lumifit::io::afterimage_csv::curves_to_csv;
use lumifit::io::hdr_image::{
    decode_display_image, downscale, encode_apng, encode_exr, encode_png16_srgb, preview_rgb8,
};
use lumifit::io::Outputs;
use lumifit::plot::afterimage::{curves_chart, side_by_side_figure, FigureTile};
use lumifit::preset::afterimage::AfterimageSection;
use lumifit::preset::{to_json_string, MaterialPreset, Provenance};

use super::emit;

/// Subcommands (afterimages).
#[derive(Debug, Subcommand)]
pub enum AfterimageCommand {
    /// The model's transitions on a time grid: CSV `t_s,Y,x,y,L,a,b,tau` (Eq. 3, Table 1 with
    /// Catmull-Rom, Lab with white D65, τ = L/L(0)) and optionally the chart.
    Curves(CurvesArgs),
    /// Afterimage frames of an image: 16-bit sRGB PNGs (and linear EXRs), an animated preview,
    /// the curves, a preset `afterimage` section and a side-by-side figure, in one directory.
    Synth(SynthArgs),
}

/// `afterimage curves`.
#[derive(Debug, Args)]
pub struct CurvesArgs {
    /// Grid step, s.
    #[arg(long, default_value_t = 0.1)]
    pub step_s: f64,
    /// Last time, s (over 80 s needs --extrapolate).
    #[arg(long, default_value_t = 80.0)]
    pub end_s: f64,
    /// Allow times after 80 s: Eq. 3 continues, the colour stays at Table 1's 80 s value.
    #[arg(long)]
    pub extrapolate: bool,
    /// Output CSV (`-`: standard output).
    #[arg(long, default_value = "-")]
    pub out: PathBuf,
    /// Chart PNG: Y(t) and the xy track on the CIE 1931 diagram.
    #[arg(long)]
    pub plot: Option<PathBuf>,
}

/// `afterimage synth`.
#[derive(Debug, Args)]
pub struct SynthArgs {
    /// The stimulus image I_on: OpenEXR or Radiance HDR (linear), PNG/JPEG/TIFF (sRGB, decoded).
    pub image: PathBuf,
    /// Background I_off the afterimage is added to, dark-adapting by Eq. 7 (same size; display
    /// linear). Without it the afterimage is shown on black.
    #[arg(long)]
    pub background: Option<PathBuf>,
    /// Frame times: `START:STOP:STEP` (s) or a comma list `0,4,8`.
    #[arg(long, conflicts_with_all = ["fps", "duration"], required_unless_present = "fps")]
    pub times: Option<String>,
    /// Frames per second (with --duration): frames at i/F s.
    #[arg(long, requires = "duration")]
    pub fps: Option<f64>,
    /// Duration, s (with --fps).
    #[arg(long, requires = "fps")]
    pub duration: Option<f64>,
    /// γ of Z = (L_on/L_on^max)^γ.
    #[arg(long, default_value_t = 0.7, allow_hyphen_values = true)]
    pub gamma: f64,
    /// k of Eq. 5–6: how strongly the stimulus colour shows early.
    #[arg(long, default_value_t = 0.05, allow_hyphen_values = true)]
    pub k: f64,
    /// Reference light chromaticity x,y (Table 1's start; §3.2 prints 0.43,0.40).
    #[arg(long, value_name = "X,Y")]
    pub reference_xy: Option<String>,
    /// Mask rule: pixels with Y ≥ this × the image's largest Y make an afterimage (0–1).
    #[arg(long, default_value_t = 0.5, allow_hyphen_values = true)]
    pub mask_threshold: f64,
    /// Gaussian blur σ in px (default: 0.4 % of the image diagonal; 0 turns it off).
    #[arg(long, allow_hyphen_values = true)]
    pub blur_sigma_px: Option<f64>,
    /// Eq. 7: the background at t = 0 is this fraction of I_off (needs --background).
    #[arg(long, requires = "background", allow_hyphen_values = true)]
    pub dark_constant: Option<f64>,
    /// Eq. 7: time constant T, s (needs --background).
    #[arg(long, requires = "background", allow_hyphen_values = true)]
    pub dark_time_s: Option<f64>,
    /// Allow times after 80 s (colour held at 80 s, Eq. 3 continued).
    #[arg(long)]
    pub extrapolate: bool,
    /// Also write each frame as linear 32-bit float OpenEXR (`frame_t….exr`).
    #[arg(long)]
    pub exr: bool,
    /// Output directory (created at the end; nothing is written on failure).
    #[arg(long)]
    pub out: PathBuf,
}

/// Runs one of these subcommands.
pub fn run(cmd: AfterimageCommand) -> Result<()> {
    match cmd {
        AfterimageCommand::Curves(a) => run_curves(&a),
        AfterimageCommand::Synth(a) => run_synth(&a),
    }
}

fn range(extrapolate: bool) -> TimeRange {
    if extrapolate {
        TimeRange::Extrapolate
    } else {
        TimeRange::Measured
    }
}

fn run_curves(a: &CurvesArgs) -> Result<()> {
    let mut out = Outputs::new();
    out.declare("--out", &a.out)?;
    if let Some(p) = &a.plot {
        out.declare("--plot", p)?;
    }
    let grid = time_grid(a.step_s, a.end_s).map_err(|e| anyhow::anyhow!("--step-s/--end-s: {e}"))?;
    let points = curves(&grid, range(a.extrapolate)).map_err(|e| anyhow::anyhow!("--end-s: {e}"))?;
    out.stage_text(&a.out, &curves_to_csv(&points))?;
    if let Some(p) = &a.plot {
        out.stage(p, &curves_chart(&points)?)?;
    }
    out.commit()?;
    Ok(())
}

/// `START:STOP:STEP` or `a,b,c`.
fn parse_times(spec: &str) -> Result<Vec<f64>> {
    let num = |s: &str| -> Result<f64> {
        s.trim()
            .parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| anyhow::anyhow!("--times: '{s}' is not a number; expected START:STOP:STEP or a comma list like 0,4,8"))
    };
    if spec.contains(':') {
        let parts: Vec<&str> = spec.split(':').collect();
        if parts.len() != 3 {
            bail!("--times: '{spec}'; expected START:STOP:STEP such as 0:80:4");
        }
        let (start, stop, step) = (num(parts[0])?, num(parts[1])?, num(parts[2])?);
        if !(step > 0.0) || stop < start {
            bail!("--times: '{spec}'; expected STEP > 0 and STOP ≥ START");
        }
        let n = ((stop - start) / step + 1e-9).floor() as usize;
        lumifit::limits::check_count("--times", n + 1, 100_000, "frames of one run")?;
        Ok((0..=n).map(|i| start + i as f64 * step).collect())
    } else {
        spec.split(',').map(num).collect()
    }
}

fn parse_xy(s: &str) -> Result<[f64; 2]> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    let v: Vec<f64> = parts.iter().filter_map(|p| p.parse().ok()).collect();
    if parts.len() != 2 || v.len() != 2 {
        bail!("--reference-xy: '{s}'; expected two numbers x,y such as 0.43,0.40");
    }
    Ok([v[0], v[1]])
}

fn frame_name(t_s: f64, ext: &str) -> String {
    format!("frame_t{t_s:07.3}.{ext}")
}

fn run_synth(a: &SynthArgs) -> Result<()> {
    let mut out = Outputs::new();
    out.input(&a.image);
    if let Some(b) = &a.background {
        out.input(b);
    }
    out.declare_dir("--out", &a.out)?;
    let times = match (&a.times, a.fps, a.duration) {
        (Some(spec), _, _) => parse_times(spec)?,
        (None, Some(fps), Some(d)) => {
            if !(fps.is_finite() && fps > 0.0) || !(d.is_finite() && d >= 0.0) {
                bail!("--fps/--duration: {fps}, {d}; expected fps > 0 and a duration ≥ 0 s");
            }
            let n = (d * fps + 1e-9).floor() as usize;
            lumifit::limits::check_count("--fps × --duration", n + 1, 100_000, "frames of one run")?;
            (0..=n).map(|i| i as f64 / fps).collect()
        }
        _ => bail!("give --times or --fps with --duration"),
    };
    let mut params = SynthParams {
        gamma: a.gamma,
        k: a.k,
        reference_xy: match &a.reference_xy {
            Some(s) => parse_xy(s)?,
            None => REFERENCE_XY_TABLE1,
        },
        mask: MaskRule {
            threshold: a.mask_threshold,
        },
        blur_sigma_px: a.blur_sigma_px.unwrap_or(0.0),
        dark: DarkAdaptation {
            constant: a.dark_constant.unwrap_or(0.05),
            time_s: a.dark_time_s.unwrap_or(20.0),
        },
        range: range(a.extrapolate),
    };
    params.validate()?;
    lumifit::afterimage::check_times("--times", &times, params.range)?;

    let t_read = Instant::now();
    let image_bytes = lumifit::io::read_input(&a.image)?.0;
    let (input, enc) = decode_display_image(&image_bytes, &a.image, BYTES_PER_PIXEL)?;
    let mut inputs: Vec<(PathBuf, Vec<u8>)> = Vec::new();
    let background = match &a.background {
        Some(p) => {
            let bytes = lumifit::io::read_input(p)?.0;
            let bg = decode_display_image(&bytes, p, 12)?.0;
            inputs.push((p.clone(), bytes));
            Some(bg)
        }
        None => None,
    };
    inputs.insert(0, (a.image.clone(), image_bytes));
    if a.blur_sigma_px.is_none() {
        params.blur_sigma_px = 0.004 * (input.width as f64).hypot(input.height as f64);
    }
    let name = a.image.display().to_string();
    let has_bg = background.is_some();
    let syn = Synthesizer::new(&input, &name, background, params)?;
    let read_s = t_read.elapsed().as_secs_f64();

    // Preview: ≤ 480 px, at most 240 frames, played at 10× real time.
    let every = times.len().div_ceil(240).max(1);
    let mut preview_frames = Vec::new();
    let mut preview_times = Vec::new();
    let mut figure_frames: Vec<(f64, LinearImage)> = Vec::new();
    let figure_idx: Vec<usize> = {
        let n = times.len();
        let mut v: Vec<usize> = (0..4.min(n)).map(|k| if n > 1 { k * (n - 1) / 3.min(n - 1).max(1) } else { 0 }).collect();
        v.dedup();
        v
    };
    let (mut compute_s, mut encode_s) = (0.0, 0.0);
    let (mut pw, mut ph) = (0, 0);
    for (i, &t) in times.iter().enumerate() {
        let t0 = Instant::now();
        let frame = syn.frame(t)?;
        lumifit::error::ensure_finite(
            "afterimage frame",
            &format!("{name} at t = {t} s"),
            &frame.rgb.iter().map(|v| f64::from(*v)).collect::<Vec<_>>(),
        )?;
        compute_s += t0.elapsed().as_secs_f64();
        let t1 = Instant::now();
        out.stage(a.out.join(frame_name(t, "png")), &encode_png16_srgb(&frame)?)?;
        if a.exr {
            out.stage(a.out.join(frame_name(t, "exr")), &encode_exr(&frame)?)?;
        }
        if i % every == 0 {
            let small = downscale(&frame, 480);
            (pw, ph) = (small.width, small.height);
            preview_frames.push(preview_rgb8(&small));
            preview_times.push(t);
        }
        if figure_idx.contains(&i) {
            figure_frames.push((t, downscale(&frame, 480)));
        }
        encode_s += t1.elapsed().as_secs_f64();
    }
    let delays: Vec<f64> = (0..preview_times.len())
        .map(|i| match preview_times.get(i + 1) {
            Some(next) => (next - preview_times[i]) / 10.0,
            None => 1.0,
        })
        .collect();
    out.stage(a.out.join("preview.apng"), &encode_apng(pw, ph, &preview_frames, &delays)?)?;

    let points = curves(&times, params.range)?;
    out.stage_text(a.out.join("curves.csv"), &curves_to_csv(&points))?;
    let section = AfterimageSection::new(syn.params(), has_bg, &points);
    let refs: Vec<(&Path, &[u8])> = inputs.iter().map(|(p, b)| (p.as_path(), b.as_slice())).collect();
    let command = std::env::args().collect::<Vec<_>>().join(" ");
    let mut preset = MaterialPreset::new(
        &format!("afterimage of {}", a.image.file_name().map(|f| f.to_string_lossy().into_owned()).unwrap_or_default()),
        Provenance::new(&command, &refs),
    );
    preset.afterimage = Some(section.to_section()?);
    out.stage_text(a.out.join("afterimage.preset.json"), &to_json_string(&preset)?)?;

    // Figure: input (normalised to its brightest pixel), mask, frames at up to four times.
    let norm = LinearImage {
        rgb: input.rgb.iter().map(|v| (f64::from(*v) / syn.input_y_max()) as f32).collect(),
        ..input.clone()
    };
    let mask_img = LinearImage {
        rgb: syn.mask().iter().flat_map(|&m| [if m { 1.0f32 } else { 0.0 }; 3]).collect(),
        ..input.clone()
    };
    let (norm_s, mask_s) = (downscale(&norm, 480), downscale(&mask_img, 480));
    let mut tiles = vec![
        FigureTile { title: "input I_on (normalised)".into(), image: &norm_s },
        FigureTile { title: format!("mask (Y ≥ {} Y_max)", params.mask.threshold), image: &mask_s },
    ];
    for (t, f) in &figure_frames {
        tiles.push(FigureTile { title: format!("t = {t} s"), image: f });
    }
    out.stage(a.out.join("figure.png"), &side_by_side_figure(&tiles, 300)?)?;
    let written = out.commit()?;

    let n = times.len() as f64;
    emit(&serde_json::to_string_pretty(&serde_json::json!({
        "image": name,
        "input_encoding": format!("{enc:?}"),
        "size_px": [syn.width(), syn.height()],
        "input_y_max": syn.input_y_max(),
        "mask_pixels": syn.mask().iter().filter(|m| **m).count(),
        "blur_sigma_px": syn.params().blur_sigma_px,
        "frames": times.len(),
        "read_and_prepare_s": read_s,
        "compute_s": compute_s,
        "encode_s": encode_s,
        "compute_frames_per_s": n / compute_s.max(1e-12),
        "files": written.len(),
        "out": a.out.display().to_string(),
    }))?)
}
