//! Afterimages (`lumifit afterimage …`, Mikamo et al. 2013): what each command does between its
//! flags and its printed line — build the time grid, synthesize the frames, encode them, assemble
//! the curves, the preset section and the figure, and stage every output in the caller's
//! [`Outputs`]. The caller commits and prints.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

use serde_json::{json, Value};

use crate::afterimage::mikamo2013::{BYTES_PER_PIXEL, REFERENCE_XY_TABLE1};
use crate::afterimage::{
    check_times, curves, time_grid, DarkAdaptation, LinearImage, MaskRule, SynthParams,
    Synthesizer, TimeRange,
};
use crate::error::{ensure_finite, Error, Result};
use crate::io::afterimage_csv::curves_to_csv;
use crate::io::hdr_image::{
    decode_display_image, downscale, encode_apng, encode_exr, encode_png16_srgb, preview_rgb8,
};
use crate::io::Outputs;
use crate::plot::afterimage::{curves_chart, side_by_side_figure, FigureTile};
use crate::preset::afterimage::AfterimageSection;
use crate::preset::{to_json_string, MaterialPreset, Provenance};

/// The time range of `--extrapolate`: measured (≤ 80 s) or continued past it.
pub fn range(extrapolate: bool) -> TimeRange {
    if extrapolate {
        TimeRange::Extrapolate
    } else {
        TimeRange::Measured
    }
}

/// `afterimage curves`: the model's transitions on a time grid.
#[derive(Debug, Clone)]
pub struct CurvesJob {
    /// Grid step, s.
    pub step_s: f64,
    /// Last time, s.
    pub end_s: f64,
    /// Allow times after 80 s.
    pub extrapolate: bool,
    /// Output CSV (`-`: standard output).
    pub out: PathBuf,
    /// Chart PNG.
    pub plot: Option<PathBuf>,
}

/// Declares the CSV (and chart) and stages them; the caller commits.
pub fn run_curves(job: &CurvesJob, out: &mut Outputs) -> Result<()> {
    out.declare("--out", &job.out)?;
    if let Some(p) = &job.plot {
        out.declare("--plot", p)?;
    }
    let grid = time_grid(job.step_s, job.end_s)
        .map_err(|e| Error::flag("--step-s/--end-s", e.to_string()))?;
    let points =
        curves(&grid, range(job.extrapolate)).map_err(|e| Error::flag("--end-s", e.to_string()))?;
    out.stage_text(&job.out, &curves_to_csv(&points))?;
    if let Some(p) = &job.plot {
        out.stage(p, &curves_chart(&points)?)?;
    }
    Ok(())
}

/// Frame times of `--times`: `START:STOP:STEP` or a comma list `a,b,c`.
pub fn parse_times(spec: &str) -> Result<Vec<f64>> {
    let num = |s: &str| -> Result<f64> {
        s.trim()
            .parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| {
                Error::flag(
                    "--times",
                    format!(
                        "'{s}' is not a number; expected START:STOP:STEP or a comma list like 0,4,8"
                    ),
                )
            })
    };
    if spec.contains(':') {
        let parts: Vec<&str> = spec.split(':').collect();
        if parts.len() != 3 {
            return Err(Error::flag(
                "--times",
                format!("'{spec}'; expected START:STOP:STEP such as 0:80:4"),
            ));
        }
        let (start, stop, step) = (num(parts[0])?, num(parts[1])?, num(parts[2])?);
        if step.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) || stop < start {
            return Err(Error::flag(
                "--times",
                format!("'{spec}'; expected STEP > 0 and STOP ≥ START"),
            ));
        }
        let n = ((stop - start) / step + 1e-9).floor() as usize;
        crate::limits::check_count("--times", n + 1, 100_000, "frames of one run")?;
        Ok((0..=n).map(|i| start + i as f64 * step).collect())
    } else {
        spec.split(',').map(num).collect()
    }
}

/// Frame times at i/F s for `--fps F --duration D`.
pub fn fps_times(fps: f64, duration: f64) -> Result<Vec<f64>> {
    if !(fps.is_finite() && fps > 0.0 && duration.is_finite() && duration >= 0.0) {
        return Err(Error::flag(
            "--fps/--duration",
            format!("{fps}, {duration}; expected fps > 0 and a duration ≥ 0 s"),
        ));
    }
    let n = (duration * fps + 1e-9).floor() as usize;
    crate::limits::check_count("--fps × --duration", n + 1, 100_000, "frames of one run")?;
    Ok((0..=n).map(|i| i as f64 / fps).collect())
}

/// `--reference-xy x,y`.
pub fn parse_xy(s: &str) -> Result<[f64; 2]> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    let v: Vec<f64> = parts.iter().filter_map(|p| p.parse().ok()).collect();
    if parts.len() != 2 || v.len() != 2 {
        return Err(Error::flag(
            "--reference-xy",
            format!("'{s}'; expected two numbers x,y such as 0.43,0.40"),
        ));
    }
    Ok([v[0], v[1]])
}

/// The file name of the frame at `t_s` seconds.
pub fn frame_name(t_s: f64, ext: &str) -> String {
    format!("frame_t{t_s:07.3}.{ext}")
}

/// The frame times of `afterimage synth`, as given on the command line.
#[derive(Debug, Clone)]
pub enum FrameTimes {
    /// `--times START:STOP:STEP` or `a,b,c` (parsed by [`parse_times`]).
    Spec(String),
    /// `--fps F --duration D`.
    Fps {
        /// Frames per second.
        fps: f64,
        /// Duration, s.
        duration: f64,
    },
}

/// `afterimage synth`: frames of an image's afterimage and everything beside them.
#[derive(Debug, Clone)]
pub struct SynthJob {
    /// The stimulus image I_on.
    pub image: PathBuf,
    /// Background I_off (display linear, same size).
    pub background: Option<PathBuf>,
    /// Frame times.
    pub times: FrameTimes,
    /// γ of Z.
    pub gamma: f64,
    /// k of Eq. 5–6.
    pub k: f64,
    /// `--reference-xy` as typed (default: Table 1's start).
    pub reference_xy: Option<String>,
    /// Mask threshold (0–1).
    pub mask_threshold: f64,
    /// Blur σ in px (default: 0.4 % of the image diagonal).
    pub blur_sigma_px: Option<f64>,
    /// Eq. 7 constant (default 0.05).
    pub dark_constant: Option<f64>,
    /// Eq. 7 time constant T, s (default 20).
    pub dark_time_s: Option<f64>,
    /// Allow times after 80 s.
    pub extrapolate: bool,
    /// Also write linear EXR frames.
    pub exr: bool,
    /// Output directory.
    pub out: PathBuf,
    /// The command line, for the preset's provenance.
    pub command: String,
}

/// Registers the images, declares the directory, stages every frame, the preview, the curves,
/// the preset and the figure, and returns the summary to print (without `files`, which the
/// caller adds after its commit).
pub fn run_synth(job: &SynthJob, out: &mut Outputs) -> Result<Value> {
    out.input(&job.image);
    if let Some(b) = &job.background {
        out.input(b);
    }
    out.declare_dir("--out", &job.out)?;
    let times = match &job.times {
        FrameTimes::Spec(spec) => parse_times(spec)?,
        FrameTimes::Fps { fps, duration } => fps_times(*fps, *duration)?,
    };
    let mut params = SynthParams {
        gamma: job.gamma,
        k: job.k,
        reference_xy: match &job.reference_xy {
            Some(s) => parse_xy(s)?,
            None => REFERENCE_XY_TABLE1,
        },
        mask: MaskRule {
            threshold: job.mask_threshold,
        },
        blur_sigma_px: job.blur_sigma_px.unwrap_or(0.0),
        dark: DarkAdaptation {
            constant: job.dark_constant.unwrap_or(0.05),
            time_s: job.dark_time_s.unwrap_or(20.0),
        },
        range: range(job.extrapolate),
    };
    params.validate()?;
    check_times("--times", &times, params.range)?;
    let mut names = HashMap::new();
    for &t in &times {
        if let Some(prev) = names.insert(frame_name(t, "png"), t) {
            return Err(Error::flag(
                "--times",
                format!(
                    "{prev} s and {t} s would both be written as {}; expected distinct times at least 1 ms apart",
                    frame_name(t, "png")
                ),
            ));
        }
    }

    let t_read = Instant::now();
    let image_bytes = crate::io::read_input(&job.image)?.0;
    let (input, enc) = decode_display_image(&image_bytes, &job.image, BYTES_PER_PIXEL)?;
    let mut inputs: Vec<(PathBuf, Vec<u8>)> = Vec::new();
    let background = match &job.background {
        Some(p) => {
            let bytes = crate::io::read_input(p)?.0;
            let bg = decode_display_image(&bytes, p, 12)?.0;
            inputs.push((p.clone(), bytes));
            Some(bg)
        }
        None => None,
    };
    inputs.insert(0, (job.image.clone(), image_bytes));
    if job.blur_sigma_px.is_none() {
        params.blur_sigma_px = 0.004 * (input.width as f64).hypot(input.height as f64);
    }
    let name = job.image.display().to_string();
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
        let mut v: Vec<usize> = (0..4.min(n))
            .map(|k| {
                if n > 1 {
                    k * (n - 1) / 3.min(n - 1).max(1)
                } else {
                    0
                }
            })
            .collect();
        v.dedup();
        v
    };
    let (mut compute_s, mut encode_s) = (0.0, 0.0);
    let (mut pw, mut ph) = (0, 0);
    for (i, &t) in times.iter().enumerate() {
        let t0 = Instant::now();
        let frame = syn.frame(t)?;
        if let Some(v) = frame.rgb.iter().find(|v| !v.is_finite()) {
            ensure_finite(
                "afterimage frame",
                &format!("{name} at t = {t} s"),
                &[f64::from(*v)],
            )?;
        }
        compute_s += t0.elapsed().as_secs_f64();
        let t1 = Instant::now();
        out.stage(
            job.out.join(frame_name(t, "png")),
            &encode_png16_srgb(&frame)?,
        )?;
        if job.exr {
            out.stage(job.out.join(frame_name(t, "exr")), &encode_exr(&frame)?)?;
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
    out.stage(
        job.out.join("preview.apng"),
        &encode_apng(pw, ph, &preview_frames, &delays)?,
    )?;

    let points = curves(&times, params.range)?;
    out.stage_text(job.out.join("curves.csv"), &curves_to_csv(&points))?;
    let section = AfterimageSection::new(syn.params(), has_bg, &points);
    let refs: Vec<(&Path, &[u8])> = inputs
        .iter()
        .map(|(p, b)| (p.as_path(), b.as_slice()))
        .collect();
    let mut preset = MaterialPreset::new(
        format!(
            "afterimage of {}",
            job.image
                .file_name()
                .map(|f| f.to_string_lossy().into_owned())
                .unwrap_or_default()
        ),
        Provenance::new(&job.command, &refs),
    );
    preset.afterimage = Some(section.to_section()?);
    out.stage_text(
        job.out.join("afterimage.preset.json"),
        &to_json_string(&preset)?,
    )?;

    // Figure: input (normalised to its brightest pixel), mask, frames at up to four times.
    let norm = LinearImage {
        rgb: input
            .rgb
            .iter()
            .map(|v| (f64::from(*v) / syn.input_y_max()) as f32)
            .collect(),
        ..input.clone()
    };
    let mask_img = LinearImage {
        rgb: syn
            .mask()
            .iter()
            .flat_map(|&m| [if m { 1.0f32 } else { 0.0 }; 3])
            .collect(),
        ..input.clone()
    };
    let (norm_s, mask_s) = (downscale(&norm, 480), downscale(&mask_img, 480));
    let mut tiles = vec![
        FigureTile {
            title: "input I_on (normalised)".into(),
            image: &norm_s,
        },
        FigureTile {
            title: format!("mask (max RGB ≥ {} of the peak)", params.mask.threshold),
            image: &mask_s,
        },
    ];
    for (t, f) in &figure_frames {
        tiles.push(FigureTile {
            title: format!("t = {t} s"),
            image: f,
        });
    }
    out.stage(
        job.out.join("figure.png"),
        &side_by_side_figure(&tiles, 300)?,
    )?;

    let n = times.len() as f64;
    Ok(json!({
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
        "out": job.out.display().to_string(),
    }))
}
