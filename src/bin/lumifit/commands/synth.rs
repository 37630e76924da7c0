//! `lumifit synth …` (synthetic data): phosphorescent decay series from the exact simulation —
//! 16-bit TIFF frames with a manifest the series loader reads, or (`--curve-only`) one curve CSV.

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::{Args, Subcommand, ValueEnum};
use lumifit::io::{atomic_write, spectrum_csv::read_multi_spectrum};
use lumifit::phosphor::synth::{decay_curve, DecayFrames, DecaySeriesSpec, FrameLayout};
use lumifit::phosphor::BandCamera;
use rayon::prelude::*;

use super::phos::resolve_material;

/// Subcommands of `lumifit synth`.
#[derive(Debug, Subcommand)]
pub enum SynthCommand {
    /// A phosphorescent decay series: 16-bit TIFF frames + manifest.csv (or a curve CSV with --curve-only).
    PhosDecay(PhosDecayArgs),
}

/// `lumifit synth phos-decay`.
#[derive(Debug, Args)]
pub struct PhosDecayArgs {
    /// A Table 1 material name or a material preset JSON file.
    #[arg(long)]
    pub material: String,
    /// Charging time in s under flat light (|E| = 1) before switch-off.
    #[arg(long, default_value_t = 5400.0)]
    pub charge_s: f64,
    /// Number of frames.
    #[arg(long, default_value_t = 37)]
    pub frames: usize,
    /// Time between frames in s.
    #[arg(long, default_value_t = 5.0)]
    pub interval_s: f64,
    /// Exposure per frame in s (default: a fifth of the interval).
    #[arg(long)]
    pub exposure_s: Option<f64>,
    /// Camera sensitivities CSV `wavelength_nm,r,g,b` (default: ideal box camera).
    #[arg(long)]
    pub camera: Option<PathBuf>,
    /// Relative noise per sample (0.01 = 1 %).
    #[arg(long, default_value_t = 0.01)]
    pub noise: f64,
    /// Frame size WxH in pixels.
    #[arg(long, default_value = "64x48")]
    pub size: String,
    /// Layout: the material everywhere, or left half the material and right half a two-state
    /// variant (its first state plus one 5× slower with half the re-radiation).
    #[arg(long, value_enum, default_value_t = LayoutArg::Uniform)]
    pub layout: LayoutArg,
    /// Seed of the noise generator.
    #[arg(long)]
    pub seed: u64,
    /// Write only the curve CSV (`time_s,r,g,b,std`) into the output directory.
    #[arg(long)]
    pub curve_only: bool,
    /// Output directory.
    #[arg(long)]
    pub out: PathBuf,
}

/// Frame layout.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum LayoutArg {
    /// The material everywhere.
    Uniform,
    /// Left half the material, right half its two-state variant.
    Halves,
}

fn parse_size(s: &str) -> Result<(usize, usize)> {
    let bad = || anyhow::anyhow!("--size '{s}': expected WxH in pixels, e.g. 1000x1000");
    let (w, h) = s.trim().split_once(['x', 'X']).ok_or_else(bad)?;
    let w: usize = w.trim().parse().map_err(|_| bad())?;
    let h: usize = h.trim().parse().map_err(|_| bad())?;
    Ok((w, h))
}

/// Runs a `lumifit synth` subcommand.
pub fn run(cmd: SynthCommand) -> Result<()> {
    match cmd {
        SynthCommand::PhosDecay(a) => phos_decay(&a),
    }
}

fn phos_decay(a: &PhosDecayArgs) -> Result<()> {
    let material = resolve_material(&a.material)?;
    let camera = match &a.camera {
        Some(p) => BandCamera::for_bands(&material.bands, Some(&read_multi_spectrum(p)?))?,
        None => BandCamera::for_bands(&material.bands, None)?,
    };
    let spec = DecaySeriesSpec {
        charge_s: a.charge_s,
        frames: a.frames,
        interval_s: a.interval_s,
        exposure_s: a.exposure_s.unwrap_or(a.interval_s / 5.0),
        noise: a.noise,
        seed: a.seed,
    };
    if !a.curve_only {
        return frames(a, &material, &camera, &spec);
    }
    let c = decay_curve(&material, &camera, &spec)?;
    std::fs::create_dir_all(&a.out).map_err(|e| lumifit::Error::io(&a.out, e))?;
    let mut csv = String::from("time_s,r,g,b,std\n");
    for i in 0..c.t_s.len() {
        let [r, g, b] = c.rgb[i];
        csv.push_str(&format!("{},{r},{g},{b},{}\n", c.t_s[i], c.sigma[i]));
    }
    let path = a.out.join("curve.csv");
    atomic_write(&path, csv.as_bytes())?;
    let manifest = serde_json::json!({
        "generator": "lumifit synth phos-decay",
        "material": material.name,
        "rates_per_s": material.states.iter().map(|s| s.k_r_per_s).collect::<Vec<_>>(),
        "r_at_switch_off": c.r0,
        "saturation_assumed": c.saturation_assumed,
        "charge_s": spec.charge_s, "frames": spec.frames, "interval_s": spec.interval_s,
        "exposure_s": spec.exposure_s, "noise": spec.noise, "seed": spec.seed,
        "time_s": "start of each exposure window after switch-off; values are window means",
        "curve": "curve.csv",
    });
    atomic_write(
        &a.out.join("manifest.json"),
        serde_json::to_string_pretty(&manifest)?.as_bytes(),
    )?;
    super::emit(&format!("wrote {} and manifest.json", path.display()))
}

fn frames(
    a: &PhosDecayArgs,
    material: &lumifit::phosphor::Material,
    camera: &BandCamera,
    spec: &DecaySeriesSpec,
) -> Result<()> {
    let (w, h) = parse_size(&a.size)?;
    let layout = match a.layout {
        LayoutArg::Uniform => FrameLayout::Uniform,
        LayoutArg::Halves => FrameLayout::Halves,
    };
    let fr = DecayFrames::new(material, layout, camera, spec, w, h)?;
    std::fs::create_dir_all(&a.out).map_err(|e| lumifit::Error::io(&a.out, e))?;
    let bar = indicatif::ProgressBar::new(fr.len() as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "rendering [{bar:30}] {pos}/{len} frames {elapsed}",
        )
        .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    let names: Vec<String> = (0..fr.len()).map(|j| format!("frame_{j:04}.tif")).collect();
    let written: Result<Vec<()>> = (0..fr.len())
        .into_par_iter()
        .map(|j| {
            let px: Vec<u16> = fr
                .frame(j)?
                .iter()
                .map(|v| (f64::from(*v) * 65535.0).round() as u16)
                .collect();
            let tiff = lumifit::io::image::encode_tiff16(w as u32, h as u32, &px)?;
            atomic_write(&a.out.join(&names[j]), &tiff)?;
            bar.inc(1);
            Ok(())
        })
        .collect();
    bar.finish_and_clear();
    written.with_context(|| format!("writing frames to {}", a.out.display()))?;
    let mut csv = String::from("file,time_s,exposure_s,iso,f_number\n");
    for (j, n) in names.iter().enumerate() {
        csv.push_str(&format!("{n},{},{},100,1\n", fr.t_s[j], fr.exposure_s));
    }
    atomic_write(&a.out.join("manifest.csv"), csv.as_bytes())?;
    let region = |i: usize, m: &lumifit::phosphor::Material| {
        serde_json::json!({
            "material": m.name,
            "rates_per_s": m.states.iter().map(|s| s.k_r_per_s).collect::<Vec<_>>(),
            "r_at_switch_off": fr.curves[i].r0,
            "saturation_assumed": fr.curves[i].saturation_assumed,
            "first_frame_value": fr.clean_value(i, 0),
        })
    };
    let mut regions = vec![region(0, material)];
    if layout == FrameLayout::Halves {
        let v = lumifit::phosphor::synth::two_state_variant(material)?;
        regions.push(region(1, &v));
    }
    let truth = serde_json::json!({
        "generator": "lumifit synth phos-decay",
        "layout": match layout { FrameLayout::Uniform => "uniform", FrameLayout::Halves => "halves: x < width/2 is regions[0], the rest regions[1]" },
        "size": [w, h],
        "regions": regions,
        "charge_s": spec.charge_s, "frames": spec.frames, "interval_s": spec.interval_s,
        "exposure_s": spec.exposure_s, "iso": 100, "f_number": 1,
        "noise": spec.noise, "seed": spec.seed,
        "gain": fr.gain,
        "values": "frame value = gain * camera RGB window mean * exposure_s, 16-bit linear (0-65535 = 0-1), shot + read noise (capture::synth::noisy_value, peak 0.8)",
        "manifest": "manifest.csv",
    });
    atomic_write(
        &a.out.join("truth.json"),
        serde_json::to_string_pretty(&truth)?.as_bytes(),
    )?;
    super::emit(&format!(
        "wrote {} frames {w}x{h} ({}), manifest.csv and truth.json to {}",
        fr.len(),
        a.size,
        a.out.display()
    ))
}
