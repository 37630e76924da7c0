//! `lumifit demo`: every working pipeline end to end on bundled or synthesised data, in one
//! output folder with an `index.html` that shows every plot and links every preset.
//!
//! Stages (each calls the same library functions as the commands named in its line):
//!
//! 1. **LVF**: a synthetic mercury-lamp photo → `lvf calibrate` (whole-profile fit) → `lvf
//!    transmission --model calibration` → synthetic captures of ColorChecker patches and a white
//!    reference under D65 → `spectrum recover` (reflectance mode) and ΔE00 against the truth.
//! 2. **Phosphorescence**: a synthetic decay series of green paint (two halves: the Table 1
//!    material and a two-state variant) → per-pixel maps (`phos fit-decay --per-pixel`) → a
//!    region fit and its decay preset → charging data → `phos fit-excitation` → preset →
//!    `phos simulate` of a charge-and-glow history with the fitted material.
//! 3. **Fluorescence**: three synthetic Donaldson matrices → `fluor reduce` presets (dual, xyz)
//!    → the ΔE00 table of `fluor eval` (methods × illuminants) and its chart.
//! 4. **Dispersion**: N-BK7 from the bundled catalogue → `dispersion fit` (automatic model) →
//!    wavelength samples → preset and glTF (`preset export --format gltf`).
//! 5. **Afterimage**: a synthetic HDR image of a lamp → `afterimage synth` frames, curves and
//!    preset.
//! 6. **Photometric light**: a synthesised IES LM-63 downlight → `light inspect` (flux, beam)
//!    → `light preset --gltf`.
//! 7. **Colour**: the 24 ColorChecker patches under D65 and A (`color table`), a chart and one
//!    reflectance preset per patch, each read back.
//!
//! Intermediate files that a reader needs on disk (TIFF frames, `lvf.json`, a series manifest)
//! go to a scratch folder that is removed at the end; everything the page shows is staged in the
//! caller's [`Outputs`] and appears only when the caller commits.

use std::path::{Path, PathBuf};
use std::time::Instant;

use serde_json::json;

use crate::afterimage::{
    curves, DarkAdaptation, LinearImage, MaskRule, SynthParams, Synthesizer, TimeRange,
};
use crate::calib;
use crate::capture::Roi;
use crate::colorimetry::summary::{patch_colours, patch_table_csv, PatchColour};
use crate::colorimetry::{Illuminant, Observer, StandardObserver, XyzMethod};
use crate::error::{Error, Result};
use crate::io::Outputs;
use crate::preset::{
    parse_preset, to_json_string, MaterialPreset, Preset, Provenance, ReflectanceSection,
};
use crate::spectrum::Spectrum;

/// What one stage did: its title, one line with its key number, its time and its files
/// (relative to the demo folder).
#[derive(Debug, Clone)]
pub struct StageReport {
    /// Short key (`lvf`, `phos`, …).
    pub key: &'static str,
    /// Title on the page.
    pub title: &'static str,
    /// The commands this stage reproduces.
    pub commands: &'static str,
    /// One line: what it did and its key number.
    pub summary: String,
    /// Wall time of the stage in s.
    pub seconds: f64,
    /// PNG charts.
    pub plots: Vec<Plot>,
    /// Presets (material/light JSON) and other exports (relative paths).
    pub presets: Vec<String>,
    /// Data files (CSV/JSON/TIFF, relative paths).
    pub data: Vec<String>,
}

/// A PNG chart of the page: its path (relative to the demo folder) and size in pixels.
#[derive(Debug, Clone)]
pub struct Plot {
    /// Relative path.
    pub path: String,
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
}

/// The demo's result: one report per stage, in order.
#[derive(Debug, Clone)]
pub struct DemoReport {
    /// The stages.
    pub stages: Vec<StageReport>,
    /// The 24 ColorChecker rows under D65 (for the terminal summary).
    pub colorchecker_d65: Vec<PatchColour>,
}

/// A scratch folder removed on drop.
struct Scratch(PathBuf);

impl Scratch {
    fn new() -> Result<Self> {
        let nanos = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.subsec_nanos());
        let p = std::env::temp_dir().join(format!("lumifit-demo-{}-{nanos}", std::process::id()));
        std::fs::create_dir_all(&p).map_err(|e| Error::io(&p, e))?;
        Ok(Self(p))
    }
    fn write(&self, name: &str, bytes: &[u8]) -> Result<PathBuf> {
        let p = self.0.join(name);
        if let Some(d) = p.parent() {
            std::fs::create_dir_all(d).map_err(|e| Error::io(d, e))?;
        }
        std::fs::write(&p, bytes).map_err(|e| Error::io(&p, e))?;
        Ok(p)
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// Stages every output into `out` (the caller commits) and returns what each stage did;
/// `progress` is called after each stage.
///
/// # Errors
/// The first stage that fails, with the library's error.
pub fn run_demo(
    dir: &Path,
    command: &str,
    out: &mut Outputs,
    progress: &dyn Fn(&StageReport),
) -> Result<DemoReport> {
    let scratch = Scratch::new()?;
    let mut ctx = Ctx {
        dir: dir.to_path_buf(),
        command: command.to_string(),
        out,
        scratch,
    };
    let mut stages = Vec::new();
    type StageFn = fn(&mut Ctx<'_>) -> Result<StageReport>;
    let fns: [StageFn; 6] = [
        lvf_stage,
        phos_stage,
        fluor_stage,
        dispersion_stage,
        afterimage_stage,
        light_stage,
    ];
    for f in fns {
        let t = Instant::now();
        let mut r = f(&mut ctx)?;
        r.seconds = t.elapsed().as_secs_f64();
        progress(&r);
        stages.push(r);
    }
    let t = Instant::now();
    let (mut r, d65) = colour_stage(&mut ctx)?;
    r.seconds = t.elapsed().as_secs_f64();
    progress(&r);
    stages.push(r);
    let html = index_html(&stages);
    ctx.out.stage(dir.join("index.html"), html.as_bytes())?;
    Ok(DemoReport {
        stages,
        colorchecker_d65: d65,
    })
}

struct Ctx<'a> {
    dir: PathBuf,
    command: String,
    out: &'a mut Outputs,
    scratch: Scratch,
}

impl Ctx<'_> {
    /// Stages `bytes` at `rel` inside the demo folder and returns `rel`.
    fn put(&mut self, rel: &str, bytes: &[u8]) -> Result<String> {
        self.out.stage(self.dir.join(rel), bytes)?;
        Ok(rel.to_string())
    }
    /// Stages a PNG chart and returns it with its size (from the PNG header).
    fn plot(&mut self, rel: &str, png: &[u8]) -> Result<Plot> {
        let dim = |i: usize| {
            png.get(i..i + 4)
                .map_or(0, |b| u32::from_be_bytes([b[0], b[1], b[2], b[3]]))
        };
        if png.get(1..4) != Some(b"PNG".as_slice()) {
            return Err(Error::invalid(rel, "the chart is not a PNG"));
        }
        let (width, height) = (dim(16), dim(20));
        let path = self.put(rel, png)?;
        Ok(Plot {
            path,
            width,
            height,
        })
    }
    /// A material preset, read back and compared before it is staged.
    fn put_preset(&mut self, rel: &str, preset: MaterialPreset) -> Result<String> {
        let text = to_json_string(&preset)?;
        let back = parse_preset(text.as_bytes(), rel)?;
        if back != Preset::Material(preset) {
            return Err(Error::invalid(
                rel,
                "the preset read back differs from the one written",
            ));
        }
        self.put(rel, text.as_bytes())
    }
    fn provenance(&self, inputs: &[(&str, &[u8])]) -> Provenance {
        Provenance::new(&self.command, inputs)
    }
}

fn report(key: &'static str, title: &'static str, commands: &'static str) -> StageReport {
    StageReport {
        key,
        title,
        commands,
        summary: String::new(),
        seconds: 0.0,
        plots: Vec::new(),
        presets: Vec::new(),
        data: Vec::new(),
    }
}

// ---------------------------------------------------------------------------------------------
// 1. LVF: calibration → bands → recovery of ColorChecker patches.

/// Patches recovered through the LVF (1-based ColorChecker indices): blue, green, red, yellow.
const LVF_PATCHES: [usize; 4] = [13, 14, 15, 16];

fn lvf_stage(ctx: &mut Ctx<'_>) -> Result<StageReport> {
    use crate::io::sources::{resolve_lamp, resolve_passband};
    use crate::lvf::capture_synth::{render_lvf_capture, CaptureLight, Exposure, LvfCaptureSpec};
    use crate::lvf::fit::Direction;
    use crate::lvf::transmission::{BandModel, DEFAULT_SUPPORT_FWHM};
    use crate::lvf::{
        calibrate_whole_profile, extract_profile_straightened, render_lvf, Axis, FitOptions,
        LvfSynthSpec, MapChoice,
    };
    use crate::pipeline::acquisition::{
        band_transmissions, recover_spectrum, recovery_csv, recovery_plot_png, RecoverInputs,
        TransmissionConfig, TransmissionInputs,
    };

    let mut r = report(
        "lvf",
        "LVF: wavelength calibration → bands → spectral recovery",
        "synth lvf-hg (4 % flat continuum, quadratic vignetting 0.2, 1 % noise) → lvf calibrate → lvf transmission --model calibration → synth lvf-capture → spectrum recover",
    );
    let (w, h) = (1200, 160);
    let camera = crate::io::camera::read_camera(None)?.curves;
    let spec = LvfSynthSpec {
        width: w,
        height: h,
        axis: Axis::X,
        nm_at_start: 380.0,
        nm_per_px: 0.3,
        bow_nm: 0.0,
        tilt_deg: 0.0,
        passband: crate::lvf::Passband::Gaussian,
        fwhm_nm: 25.0,
        lamp: resolve_lamp("hg")?,
        camera: camera.clone(),
        noise: 0.01,
        vignetting: 0.2,
        vignetting_shape: crate::lvf::synth::VignettingShape::Quadratic,
        // a lamp photo has a continuum under its lines (stray light, black-level residue)
        continuum: Some(crate::lvf::synth::Continuum {
            shape: crate::lvf::synth::ContinuumShape::Flat,
            fraction: 0.04,
        }),
        pedestal: 0.0,
        seed: 1,
    };
    let (frame, _truth) = render_lvf(&spec)?;
    let lamp_tiff = ctx
        .scratch
        .write("lamp.tiff", &crate::io::image::frame_to_tiff16(&frame)?)?;
    let (frame, _) = crate::io::series::read_frame(&lamp_tiff)?;
    // as `lvf calibrate` reads it: along the filter's iso-wavelength lines if they slant, dust
    // shadows replaced
    let (mut profile, _) = extract_profile_straightened(&frame, [0, 0, w, h], Axis::X)?;
    crate::lvf::repair_occlusions(&mut profile);
    let opts = FitOptions {
        map: MapChoice::Linear,
        passband: resolve_passband("gaussian")?,
        fwhm_guess_nm: 25.0,
        direction: Direction::Auto,
        n_bands: 31,
        ..FitOptions::default()
    };
    let cal = calibrate_whole_profile(&profile, &resolve_lamp("hg")?, &opts)?;
    let lvf_json = serde_json::to_string_pretty(&cal)
        .map_err(|e| Error::invalid("lvf.json", e.to_string()))?;
    let lvf_path = ctx.scratch.write("lvf.json", lvf_json.as_bytes())?;
    r.data.push(ctx.put("lvf/lvf.json", lvf_json.as_bytes())?);
    r.plots
        .push(ctx.plot("lvf/calibration.png", &crate::plot::lvf_chart_png(&cal)?)?);

    // Bands from the calibration alone.
    let tin = TransmissionInputs {
        lvf: lvf_path.clone(),
        captures: None,
        filters: None,
        source: None,
        target: None,
        camera: None,
    };
    let tcfg = TransmissionConfig {
        model: BandModel::Calibration,
        grid: None,
        support_fwhm: DEFAULT_SUPPORT_FWHM,
        extend_filters_nm: 0.0,
        weight: crate::fit::regularized::Weight::Gcv,
        nonnegative: true,
        use_std: true,
    };
    let mut warnings = Vec::new();
    let set = band_transmissions(&tin.open()?, &tcfg, &|| {}, &mut warnings)?;
    let bands_json = set.to_json()?;
    let bands_path = ctx.scratch.write("lvf_bands.json", bands_json.as_bytes())?;
    r.data
        .push(ctx.put("lvf/lvf_bands.json", bands_json.as_bytes())?);
    r.plots.push(ctx.plot(
        "lvf/bands.png",
        &crate::plot::lvf_bands::lvf_bands_chart_png(&set)?,
    )?);

    // Captures of a white reference and of four patches under D65, same exposure.
    let model = crate::io::lvf_model::read_lvf_model(&lvf_path)?;
    let d65 = Illuminant::standard("D65")?;
    let d65_sd = d65.spectrum().clone().with_name(d65.name());
    let table = calib::colorchecker_n_ohta();
    let white = Spectrum::new("white reference", vec![380.0, 780.0], vec![1.0, 1.0])?;
    let capture = |refl: Spectrum, exposure: Exposure, seed: u64| {
        render_lvf_capture(&LvfCaptureSpec {
            width: w,
            height: h,
            axis: model.axis,
            map: model.map.clone(),
            fwhm_nm: model.fwhm_nm,
            light: CaptureLight::Reflectance {
                reflectance: refl,
                illuminant: d65_sd.clone(),
            },
            filter: None,
            filter_name: None,
            camera: camera.clone(),
            noise: 0.002,
            vignetting: 0.0,
            vignetting_shape: crate::lvf::synth::VignettingShape::Quadratic,
            seed,
            exposure,
        })
    };
    let (wf, wt) = capture(white, Exposure::Auto, 10)?;
    let white_path = ctx
        .scratch
        .write("white.tiff", &crate::io::image::frame_to_tiff16(&wf)?)?;
    let observer = Observer::standard(StandardObserver::Cie1931_2)?;
    let mut de = Vec::new();
    for (k, &idx) in LVF_PATCHES.iter().enumerate() {
        let truth = Spectrum::from_table(table, idx)?.with_name(table.header[idx].clone());
        let (pf, _) = capture(truth.clone(), Exposure::Fixed(wt.exposure), 20 + k as u64)?;
        let img = ctx.scratch.write(
            &format!("patch{idx}.tiff"),
            &crate::io::image::frame_to_tiff16(&pf)?,
        )?;
        let truth_csv = spectrum_csv(&truth);
        let truth_path = ctx
            .scratch
            .write(&format!("patch{idx}.csv"), truth_csv.as_bytes())?;
        let inputs = RecoverInputs {
            image: Some(img),
            readings: None,
            bands: bands_path.clone(),
            camera: None,
            roi: None,
            grid: None,
            illuminant: Some("D65".into()),
            white: Some(white_path.clone()),
            white_reflectance: "1.0".into(),
            exposure: 1.0,
            compare: Some(truth_path),
        };
        let mut outcome = recover_spectrum(&inputs, &Default::default(), false)?;
        if let Some(c) = outcome.compare.as_mut() {
            c.reference = format!("{} (bundled reflectance)", truth.name());
        }
        let slug = slug(truth.name());
        r.data.push(ctx.put(
            &format!("lvf/recovered_{idx:02}_{slug}.csv"),
            recovery_csv(&outcome.rec).as_bytes(),
        )?);
        r.plots.push(ctx.plot(
            &format!("lvf/recovered_{idx:02}_{slug}.png"),
            &recovery_plot_png(&outcome)?,
        )?);
        let rec = Spectrum::new(
            format!("recovered {}", truth.name()),
            outcome.rec.wavelength_nm.clone(),
            outcome
                .rec
                .value
                .iter()
                .map(|v| v.clamp(0.0, 1.5))
                .collect(),
        )?;
        let rows = patch_colours(
            &[truth.clone(), rec.clone()],
            observer,
            std::slice::from_ref(&d65),
            XyzMethod::Integration,
        )?;
        let e = crate::colorimetry::delta_e::delta_e_cie2000(rows[0].lab, rows[1].lab, false);
        de.push((truth.name().to_string(), e));
        let preset = MaterialPreset {
            reflectance: Some(ReflectanceSection::new(
                rec.wavelengths().to_vec(),
                rec.values().to_vec(),
            )),
            ..MaterialPreset::new(
                format!("{} recovered through the LVF", truth.name()),
                ctx.provenance(&[
                    ("lvf_bands.json (demo)", bands_json.as_bytes()),
                    ("capture (synthetic)", truth_csv.as_bytes()),
                ]),
            )
        };
        r.presets.push(ctx.put_preset(
            &format!("lvf/recovered_{idx:02}_{slug}.preset.json"),
            preset,
        )?);
    }
    let worst = de.iter().map(|d| d.1).fold(0.0f64, f64::max);
    r.summary = format!(
        "Hg lamp fit: λ = {:.2} nm + {:.4} nm/px × px (truth 380 + 0.3), FWHM {:.1} nm (truth 25), {} lines; \
         recovered {} ColorChecker patches under D65 with ΔE00 {} (worst {:.2}; synthetic captures through the same band model, so this checks the chain, not a camera)",
        cal.map.coefficients.first().copied().unwrap_or(f64::NAN),
        cal.map.coefficients.get(1).copied().unwrap_or(f64::NAN),
        cal.fwhm_nm,
        cal.lines.len(),
        de.len(),
        de.iter()
            .map(|(n, e)| format!("{n} {e:.2}"))
            .collect::<Vec<_>>()
            .join(", "),
        worst
    );
    Ok(r)
}

fn spectrum_csv(sd: &Spectrum) -> String {
    let mut s = String::from("wavelength_nm,value\n");
    for (l, v) in sd.wavelengths().iter().zip(sd.values()) {
        s.push_str(&format!("{l},{v}\n"));
    }
    s
}

// ---------------------------------------------------------------------------------------------
// 2. Phosphorescence.

fn phos_stage(ctx: &mut Ctx<'_>) -> Result<StageReport> {
    use crate::io::phos_formats::{box_camera_csv, parse_band_camera, SourceSpectraCsv};
    use crate::io::series::{load_series, manifest_csv, SeriesOptions};
    use crate::phosphor::excitation::{synth_charging, ExcitationOptions};
    use crate::phosphor::synth::{DecayFrames, DecaySeriesSpec, FrameLayout};
    use crate::phosphor::{
        fit_decay, maps::fit_pixel_maps, BandCamera, BandSet, DecayFitOptions, Integrator, Segment,
    };
    use crate::pipeline::phos as pipe;
    use crate::preset::phosphor::{decay_fit_preset, excitation_preset, resolve_material};

    let mut r = report(
        "phos",
        "Phosphorescence: decay series → per-pixel maps → excitation → preset → simulation",
        "synth phos-decay → phos fit-decay --per-pixel / --roi → synth phos-excitation → phos fit-excitation → phos simulate",
    );
    let material = resolve_material("green_paint")?.material;
    let camera = BandCamera::for_bands(&material.bands, None)?;
    let spec = DecaySeriesSpec {
        charge_s: 5400.0,
        frames: 37,
        interval_s: 5.0,
        exposure_s: 1.0,
        noise: 0.01,
        seed: 7,
    };
    let (w, h) = (48, 32);
    let fr = DecayFrames::new(&material, FrameLayout::Halves, &camera, &spec, w, h)?;
    let mut rows = Vec::new();
    for j in 0..fr.len() {
        let name = format!("frame_{j:04}.tif");
        ctx.scratch
            .write(&format!("series/{name}"), &pipe::decay_frame_tiff(&fr, j)?)?;
        rows.push((name, fr.t_s[j], fr.exposure_s, 100.0, 1.0));
    }
    let manifest = ctx
        .scratch
        .write("series/manifest.csv", manifest_csv(&rows).as_bytes())?;
    let series = load_series(
        &manifest,
        &SeriesOptions {
            t0_s: None,
            darks: Vec::new(),
        },
        &|| {},
    )?
    .series;
    let opts = DecayFitOptions::default();
    let maps = fit_pixel_maps(&series, 4, &opts, &|| {})?;
    for (name, bytes) in pipe::pixel_map_files(&maps)? {
        r.data.push(ctx.put(&format!("phos/maps/{name}"), &bytes)?);
    }
    r.plots.push(ctx.plot(
        "phos/maps_n_states.png",
        &map_png(&maps.n_states, maps.width, maps.height, 32, (1.0, 2.0))?,
    )?);
    r.plots.push(ctx.plot(
        "phos/maps_k2.png",
        &map_png(&maps.k_per_s[1], maps.width, maps.height, 32, (0.0, 0.1))?,
    )?);
    let half = |right: bool, v: &[f32]| -> Vec<f32> {
        (0..maps.height)
            .flat_map(|y| (0..maps.width).map(move |x| (x, y)))
            .filter(|(x, _)| (*x >= maps.width / 2) == right)
            .map(|(x, y)| v[y * maps.width + x])
            .filter(|v| v.is_finite())
            .collect()
    };
    let k_left = median(&half(false, &maps.k_per_s[0]));
    let k2_right = median(&half(true, &maps.k_per_s[1]));
    let n_left = half(false, &maps.n_states);
    let n_right = half(true, &maps.n_states);
    let share =
        |v: &[f32], n: f32| v.iter().filter(|x| **x == n).count() as f64 / v.len().max(1) as f64;
    let (one_left, two_right) = (share(&n_left, 1.0), share(&n_right, 2.0));

    // One region (the left half: Table 1 green paint) → decay preset.
    let roi = Roi::parse_rect(&format!("0,0,{},{h}", w / 2))?;
    let curve = pipe::roi_curve(&series, &roi, "demo series")?;
    let fit = fit_decay(&curve, &opts)?;
    r.plots.push(ctx.plot(
        "phos/decay_fit.png",
        &crate::plot::decay_chart_png("green paint (left half): decay fit", &curve, &fit)?,
    )?);
    let dp = pipe::decay_preset(
        &fit,
        &curve,
        "demo series",
        None,
        pipe::RecordingCamera {
            sensitivities: None,
            label: pipe::BOX_CAMERA_LABEL,
        },
    )?;
    let decay = decay_fit_preset(
        "green paint (decay fit)",
        ctx.provenance(&[(
            "series/manifest.csv (synthetic)",
            manifest_csv(&rows).as_bytes(),
        )]),
        dp.bands,
        dp.states,
        &dp.record,
    )?;
    r.presets
        .push(ctx.put_preset("phos/green_decay.preset.json", decay)?);

    // Charging experiment → excitation rates (Table 1 bands).
    let BandSet::RangesNm(ranges) = &material.bands else {
        return Err(Error::invalid("green_paint", "expected wavelength bands"));
    };
    let ranges = ranges.clone();
    let n_bands = 3;
    let src_csv = SourceSpectraCsv::boxes(&ranges, n_bands).to_csv();
    let band_idx: Vec<usize> = (0..n_bands).collect();
    let sources = SourceSpectraCsv::parse(src_csv.as_bytes(), "sources (demo)")?
        .unit_irradiance(&ranges, &band_idx)?;
    let cam_csv = box_camera_csv();
    let bcam = parse_band_camera(cam_csv.as_bytes(), "camera (demo)", &material.bands)?;
    let times = [1.0, 2.0, 4.0, 8.0, 16.0, 32.0, 64.0, 128.0, 256.0, 512.0];
    let samples = synth_charging(&material, &bcam, &sources, &times, 0.6, 0.01, 7)?;
    let ex = pipe::excitation(
        &material,
        None,
        &bcam,
        &sources,
        &samples,
        &ExcitationOptions {
            switch_off_delay_s: 0.6,
            ..ExcitationOptions::default()
        },
    )?;
    let rep = pipe::excitation_report(&ex, None);
    r.plots.push(ctx.plot(
        "phos/excitation_fit.png",
        &crate::plot::excitation_chart_png(
            "green paint: excitation fit",
            &ex.material,
            &bcam,
            &ex.fit,
        )?,
    )?);
    let preset = excitation_preset(
        None,
        &ex.updated,
        &ranges,
        ex.rescaled.is_some(),
        ctx.provenance(&[
            ("charging data (synthetic)", src_csv.as_bytes()),
            ("camera (box)", cam_csv.as_bytes()),
        ])
        .with_fit_quality(pipe::excitation_quality(&ex.fit)),
        rep,
    );
    r.presets
        .push(ctx.put_preset("phos/green_paint.preset.json", preset)?);
    let k_e: Vec<f64> = ex
        .updated
        .states
        .first()
        .and_then(|s| s.k_e.as_ref())
        .map(|k| k.iter().take(3).copied().collect())
        .unwrap_or_default();

    // Simulation of a charge-and-glow history with the fitted material.
    let mut on = vec![0.0; ranges.len()];
    for v in on.iter_mut().take(3) {
        *v = 1.0;
    }
    let history = vec![
        Segment {
            duration_s: 60.0,
            irradiance: on,
        },
        Segment {
            duration_s: 120.0,
            irradiance: vec![0.0; ranges.len()],
        },
    ];
    let (sim, rgb) = pipe::simulate_checked(
        &ex.updated,
        &history,
        0.5,
        Integrator::Exact,
        None,
        "demo history",
    )?;
    let chart = crate::plot::phosphor_sim::SimulateChart {
        material: &ex.updated,
        integrator: Integrator::Exact,
        dt_s: 0.5,
        history: &history,
        sim: &sim,
        camera_rgb: rgb.as_deref(),
    };
    r.plots.push(ctx.plot(
        "phos/simulation.png",
        &crate::plot::phosphor_sim::simulate_chart_png(&chart)?,
    )?);
    let table =
        crate::io::phos_formats::SimulationCsv::new(&ex.updated.bands, &sim, rgb.as_deref());
    r.data
        .push(ctx.put("phos/simulation.csv", table.to_csv().as_bytes())?);
    r.summary = format!(
        "per-pixel maps of a {w}×{h} series in blocks of 4: left half (green paint) one state in {:.0} % of blocks, median k₁ {k_left:.3} s⁻¹ \
         (Table 1: 0.227); right half (two-state variant) two states in {:.0} %, median k₂ {k2_right:.4} s⁻¹ (truth 0.0454); \
         region fit k_r {:.4} s⁻¹; excitation k_e = {} (Table 1: 0.1, 0.035, 0.006)",
        100.0 * one_left,
        100.0 * two_right,
        fit.states.first().map_or(f64::NAN, |s| s.k_per_s),
        k_e.iter()
            .map(|k| format!("{k:.4}"))
            .collect::<Vec<_>>()
            .join(", ")
    );
    Ok(r)
}

fn median(v: &[f32]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    let mut s = v.to_vec();
    s.sort_by(f32::total_cmp);
    f64::from(s[s.len() / 2])
}

/// A false-colour PNG of a scalar map: blue at `range.0` → red at `range.1` (clamped), black
/// where NaN; each value a `scale`×`scale` square.
fn map_png(
    values: &[f32],
    width: usize,
    height: usize,
    scale: usize,
    range: (f32, f32),
) -> Result<Vec<u8>> {
    let (lo, hi) = range;
    let span = if hi > lo { hi - lo } else { 1.0 };
    let (wp, hp) = (width * scale, height * scale);
    let mut rgb = Vec::with_capacity(3 * wp * hp);
    for y in 0..hp {
        for x in 0..wp {
            let v = values[(y / scale) * width + x / scale];
            if v.is_finite() {
                let t = ((v - lo) / span).clamp(0.0, 1.0);
                rgb.extend_from_slice(&[t, 0.2 * (1.0 - (2.0 * t - 1.0).abs()), 1.0 - t]);
            } else {
                rgb.extend_from_slice(&[0.0, 0.0, 0.0]);
            }
        }
    }
    let img = LinearImage::new("map", wp, hp, rgb)?;
    crate::io::hdr_image::encode_png16_srgb(&img)
}

// ---------------------------------------------------------------------------------------------
// 3. Fluorescence.

/// Synthetic fluorescent materials: (name, absorption centre, absorption width, emission
/// centre, emission width, quantum-yield-like strength, diagonal reflectance level).
const FLUORS: [(&str, f64, f64, f64, f64, f64, f64); 3] = [
    (
        "demo yellow highlighter",
        430.0,
        35.0,
        540.0,
        25.0,
        0.35,
        0.85,
    ),
    ("demo orange paint", 470.0, 40.0, 600.0, 30.0, 0.30, 0.6),
    ("demo pink paper", 520.0, 35.0, 620.0, 25.0, 0.25, 0.7),
];

/// A Donaldson matrix as CSV (`emission_nm,<excitation nm>…`, 10 nm from 300 to 780 nm):
/// a reflectance diagonal that dips where the material absorbs, and a Stokes-shifted emission
/// block below the diagonal.
fn donaldson_csv(f: &(&str, f64, f64, f64, f64, f64, f64)) -> String {
    let (_, ac, aw, ec, ew, q, base) = *f;
    let grid: Vec<f64> = (0..=48).map(|i| 300.0 + 10.0 * i as f64).collect();
    let g = |x: f64, c: f64, w: f64| (-0.5 * ((x - c) / w).powi(2)).exp();
    let mut s = String::from("emission_nm");
    for x in &grid {
        s.push_str(&format!(",{x}"));
    }
    s.push('\n');
    for &em in &grid {
        s.push_str(&format!("{em}"));
        for &ex in &grid {
            let v = if (em - ex).abs() < 1e-9 {
                base * (1.0 - 0.8 * g(ex, ac, aw))
            } else if em > ex {
                q * g(ex, ac, aw) * g(em, ec, ew) * 0.1
            } else {
                0.0
            };
            s.push_str(&format!(",{v:.6}"));
        }
        s.push('\n');
    }
    s
}

fn fluor_stage(ctx: &mut Ctx<'_>) -> Result<StageReport> {
    use crate::colorimetry::rgb::RgbSpace;
    use crate::fluor::{
        evaluate, illuminant_on_grid, parse_donaldson, reduce, rgb_matrix, xyz_matrix, Basis,
        Method, Reduction, ResampleOptions, WorkingGrid, DEFAULT_ILLUMINANTS, DEFAULT_METHODS,
    };
    use crate::preset::fluorescence::{fluorescence_preset, fluorescence_section, ReductionRecord};

    let mut r = report(
        "fluor",
        "Fluorescence: Donaldson matrices → reduced presets → ΔE00 table",
        "fluor reduce --basis xyz --method dual → fluor eval",
    );
    let grid = WorkingGrid::new(300.0, 780.0, 1.0)?;
    let obs = StandardObserver::from_name("cie2015-2")?;
    let cmfs = Observer::standard(obs)?.cmfs().clone();
    let xyz = Basis::xyz(&cmfs, &grid)?;
    let options = ResampleOptions {
        clip_negatives: true,
        zero_anti_stokes: false,
    };
    let ills = DEFAULT_ILLUMINANTS
        .iter()
        .map(|n| illuminant_on_grid(&Illuminant::standard(n)?, &xyz))
        .collect::<Result<Vec<_>>>()?;
    let methods = DEFAULT_METHODS
        .iter()
        .map(|n| Method::from_name(n, &cmfs, &grid))
        .collect::<Result<Vec<_>>>()?;
    let space = RgbSpace::from_name("srgb")?;
    let mut all_rows = Vec::new();
    let mut first = None;
    let ill_names: Vec<String> = DEFAULT_ILLUMINANTS.iter().map(|s| s.to_string()).collect();
    for f in &FLUORS {
        let csv = donaldson_csv(f);
        let rel = format!("fluor/{}.donaldson.csv", slug(f.0));
        r.data.push(ctx.put(&rel, csv.as_bytes())?);
        let d = parse_donaldson(csv.as_bytes(), f.0)?;
        let op = d.to_operator(&grid, options);
        let red = reduce(&op, &xyz, Reduction::Dual)?;
        let p3 = xyz_matrix(&red, &xyz, &xyz)?;
        let p_rgb = rgb_matrix(&p3, &space);
        let method = Method {
            reduction: Reduction::Dual,
            basis: xyz.clone(),
        };
        let rows = evaluate(&op, std::slice::from_ref(&method), &ills, &xyz)?;
        let section = fluorescence_section(
            &ReductionRecord {
                reduced: &red,
                basis: &xyz,
                observer: obs.cli_name(),
                grid: &grid,
                xyz_matrix: &p3,
                rgb_matrix: &p_rgb,
                space: &space,
                options,
                rows: &rows,
            },
            &rel,
        )?;
        let preset = fluorescence_preset(
            f.0,
            section,
            &ctx.command,
            &[(Path::new(&rel), csv.as_bytes())],
            &ill_names,
        );
        r.presets
            .push(ctx.put_preset(&format!("fluor/{}.preset.json", slug(f.0)), preset)?);
        all_rows.extend(evaluate(&op, &methods, &ills, &xyz)?);
        if first.is_none() {
            first = Some((d, op));
        }
    }
    let mut t = String::from("material,illuminant,method,delta_e00\n");
    for row in &all_rows {
        t.push_str(&format!(
            "{},{},{},{:.4}\n",
            row.material, row.illuminant, row.method, row.delta_e00
        ));
    }
    r.data.push(ctx.put("fluor/delta_e.csv", t.as_bytes())?);
    if let Some((d, op)) = &first {
        let reduced = methods
            .iter()
            .map(|m| {
                Ok((
                    m.name(),
                    m.basis.labels().to_vec(),
                    reduce(op, &m.basis, m.reduction)?.p,
                ))
            })
            .collect::<Result<Vec<_>>>()?;
        let mut chart = crate::plot::FluorChart::from_evaluation(d, reduced, &all_rows);
        chart.title = format!("{} (ΔE00: mean of {} materials)", d.name(), FLUORS.len());
        r.plots.push(ctx.plot(
            "fluor/reduction.png",
            &crate::plot::fluor_chart_png(&chart)?,
        )?);
    }
    let worst = |m: &str| {
        all_rows
            .iter()
            .filter(|x| x.method == m)
            .map(|x| x.delta_e00)
            .fold(0.0f64, f64::max)
    };
    r.summary = format!(
        "{} materials × {} illuminants × {} methods: worst ΔE00 {}",
        FLUORS.len(),
        ills.len(),
        methods.len(),
        methods
            .iter()
            .map(|m| format!("{} {:.2}", m.name(), worst(&m.name())))
            .collect::<Vec<_>>()
            .join(", ")
    );
    Ok(r)
}

// ---------------------------------------------------------------------------------------------
// 4. Dispersion.

fn dispersion_stage(ctx: &mut Ctx<'_>) -> Result<StageReport> {
    use crate::colorimetry::rgb::RgbSpace;
    use crate::dispersion::catalogue::glass;
    use crate::dispersion::{source, AirVacuum, ModelKind, Source};
    use crate::preset::dispersion::{fit_section, FitConfig};
    use crate::preset::export::{material_gltf, ExportOptions};

    let mut r = report(
        "dispersion",
        "Dispersion: glass → n(λ) fit → wavelength samples → preset + glTF",
        "dispersion fit --glass N-BK7 → preset export --format gltf",
    );
    let g = glass("N-BK7")?;
    let src = Source::Formula(g.formula);
    let source_name = format!("calib/glasses.csv:{}", g.name);
    let observer = Observer::standard(StandardObserver::Cie1931_2)?;
    let illuminant = Illuminant::standard("E")?;
    let space = RgbSpace::from_name("srgb")?;
    let range = [380.0, 780.0];
    let cfg = FitConfig {
        kinds: ModelKind::ALL.to_vec(),
        range_nm: range,
        tolerance: 1e-4,
        n_samples: 7,
        conversion: AirVacuum::AsGiven,
        observer,
        illuminant: &illuminant,
        space: &space,
        source_name: &source_name,
    };
    let fitted = fit_section(&src, &cfg)?;
    let best = fitted.report.best();
    let mut preset = MaterialPreset::new(
        g.name.clone(),
        ctx.provenance(&[]).with_fit_quality(json!({
            "chosen_model": best.kind.key(),
            "rms_residual": best.rms_residual,
            "tolerance_met": fitted.report.tolerance_met,
        })),
    );
    preset.dispersion = Some(fitted.section.clone());
    let (obs, _) = source::observations(&src, range, AirVacuum::AsGiven, &source_name)?;
    r.plots.push(ctx.plot(
        "dispersion/fit_residuals.png",
        &crate::plot::dispersion::fit_residuals_png(
            &format!("{}: n(model) − n(data), {} observations", g.name, obs.len()),
            &obs,
            &fitted.report.candidates,
        )?,
    )?);
    let rel = "dispersion/n-bk7.preset.json";
    let opts = ExportOptions {
        scene: crate::preset::export::Scene::Sphere,
        ..ExportOptions::default()
    };
    let doc = material_gltf(&preset, rel, &opts)?;
    r.presets.push(ctx.put_preset(rel, preset)?);
    let gltf = doc.to_gltf()?;
    r.presets
        .push(ctx.put("dispersion/n-bk7.gltf", gltf.as_bytes())?);
    let derived = serde_json::to_value(&fitted.derived).unwrap_or_default();
    let num = |k: &str| derived[k].as_f64().unwrap_or(f64::NAN);
    r.summary = format!(
        "{}: chose {} (RMS |Δn| {:.1e}); n_d {:.5}, V_d {:.2} (catalogue 1.51680, 64.17), glass code {}; {} RGB wavelength samples",
        g.name,
        best.kind.key(),
        best.rms_residual,
        num("n_d"),
        num("abbe_number_d"),
        derived["glass_code"].as_str().unwrap_or("?"),
        fitted.section.samples.len(),
    );
    Ok(r)
}

// ---------------------------------------------------------------------------------------------
// 5. Afterimage.

fn afterimage_stage(ctx: &mut Ctx<'_>) -> Result<StageReport> {
    use crate::afterimage::mikamo2013::REFERENCE_XY_TABLE1;
    use crate::io::afterimage_csv::curves_to_csv;
    use crate::io::hdr_image::encode_png16_srgb;
    use crate::plot::afterimage::{curves_chart, side_by_side_figure, FigureTile};
    use crate::preset::afterimage::AfterimageSection;

    let mut r = report(
        "afterimage",
        "Afterimage: synthetic HDR stimulus → afterimage frames and curves",
        "afterimage synth IMAGE.exr --times 0,2,5,10,20 → afterimage curves",
    );
    // A warm lamp (a bright disk, 50× the background) on a dim blue-grey wall, 160×120.
    let (w, h) = (160usize, 120usize);
    let mut rgb = Vec::with_capacity(3 * w * h);
    for y in 0..h {
        for x in 0..w {
            let d = ((x as f64 - 80.0).powi(2) + (y as f64 - 60.0).powi(2)).sqrt();
            if d < 22.0 {
                rgb.extend_from_slice(&[50.0f32, 40.0, 20.0]);
            } else {
                rgb.extend_from_slice(&[0.20f32, 0.22, 0.28]);
            }
        }
    }
    let input = LinearImage::new("demo stimulus", w, h, rgb)?;
    let params = SynthParams {
        gamma: 0.7,
        k: 0.05,
        reference_xy: REFERENCE_XY_TABLE1,
        mask: MaskRule { threshold: 0.5 },
        blur_sigma_px: 0.004 * (w as f64).hypot(h as f64),
        dark: DarkAdaptation {
            constant: 0.05,
            time_s: 20.0,
        },
        range: TimeRange::Measured,
    };
    let syn = Synthesizer::new(&input, "demo stimulus", None, params)?;
    let times = [0.0, 2.0, 5.0, 10.0, 20.0];
    let mut frames = Vec::new();
    for &t in &times {
        let f = syn.frame(t)?;
        r.data.push(ctx.put(
            &format!("afterimage/frame_t{t:06.2}s.png"),
            &encode_png16_srgb(&f)?,
        )?);
        frames.push((t, f));
    }
    let norm = LinearImage {
        rgb: input
            .rgb
            .iter()
            .map(|v| (f64::from(*v) / syn.input_y_max()) as f32)
            .collect(),
        ..input.clone()
    };
    let mut tiles = vec![FigureTile {
        title: "input I_on (normalised)".into(),
        image: &norm,
    }];
    for (t, f) in &frames {
        tiles.push(FigureTile {
            title: format!("t = {t} s"),
            image: f,
        });
    }
    r.plots
        .push(ctx.plot("afterimage/figure.png", &side_by_side_figure(&tiles, 300)?)?);
    let grid: Vec<f64> = (0..=800).map(|i| 0.1 * i as f64).collect();
    let points = curves(&grid, TimeRange::Measured)?;
    r.plots
        .push(ctx.plot("afterimage/curves.png", &curves_chart(&points)?)?);
    r.data
        .push(ctx.put("afterimage/curves.csv", curves_to_csv(&points).as_bytes())?);
    let at = curves(&times, TimeRange::Measured)?;
    let section = AfterimageSection::new(syn.params(), false, &at);
    let mut preset =
        MaterialPreset::new("afterimage of a warm lamp".to_string(), ctx.provenance(&[]));
    preset.afterimage = Some(section.to_section()?);
    r.presets
        .push(ctx.put_preset("afterimage/afterimage.preset.json", preset)?);
    let mask = syn.mask().iter().filter(|m| **m).count();
    r.summary = format!(
        "{w}×{h} HDR stimulus, {mask} pixels in the mask; {} frames at {:?} s; Mikamo 2013 curves 0–80 s ({} points)",
        times.len(),
        times,
        points.len()
    );
    Ok(r)
}

// ---------------------------------------------------------------------------------------------
// 6. Photometric light.

/// An IES LM-63-2002 downlight: 0.6 × 0.6 m opening, I(γ) = 1000 cd · cos^1.5 γ below the
/// horizon, rotationally symmetric.
fn downlight_ies() -> String {
    let v: Vec<f64> = (0..=18).map(|i| 5.0 * i as f64).collect();
    let cd: Vec<String> = v
        .iter()
        .map(|g: &f64| format!("{:.3}", 1000.0 * g.to_radians().cos().max(0.0).powf(1.5)))
        .collect();
    let angles: Vec<String> = v.iter().map(|g| format!("{g}")).collect();
    format!(
        "IESNA:LM-63-2002\n[TEST] lumifit demo\n[MANUFAC] lumifit (synthesised)\n[LUMINAIRE] demo downlight, cos^1.5\nTILT=NONE\n\
         1 -1 1 {} 1 1 2 0.6 0.6 0.0\n1.0 1.0 30\n{}\n0\n{}\n",
        v.len(),
        angles.join(" "),
        cd.join(" ")
    )
}

fn light_stage(ctx: &mut Ctx<'_>) -> Result<StageReport> {
    use crate::io::ies::parse_ies;
    use crate::photometry::illuminance::RectLight;
    use crate::photometry::summary;
    use crate::preset::export::light::gltf_light;
    use crate::preset::photometric::photometric_section;

    let mut r = report(
        "light",
        "Photometric light: IES → inspect → light preset + glTF",
        "light inspect downlight.ies --plot → light preset downlight.ies --gltf",
    );
    let ies = downlight_ies();
    r.data.push(ctx.put("light/downlight.ies", ies.as_bytes())?);
    let no_tilt = |name: &str| -> Result<(Vec<u8>, String)> {
        Err(Error::invalid(
            "TILT",
            format!("no TILT file '{name}' in the demo"),
        ))
    };
    let f = parse_ies(ies.as_bytes(), "light/downlight.ies", &no_tilt, 0.0)?;
    let s = summary(&f.photometry);
    crate::error::ensure_finite("flux", "light/downlight.ies", &[s.flux_lm, s.max_cd])?;
    r.plots.push(ctx.plot(
        "light/polar.png",
        &crate::plot::photometry::polar_chart_png(
            &f.photometry.grid,
            &format!(
                "demo downlight — max {:.1} cd, {:.1} lm",
                s.max_cd, s.flux_lm
            ),
        )?,
    )?);
    let section = photometric_section(&f, 0.6, 0.6)?;
    let p = crate::preset::LightPreset::new(
        "demo downlight",
        ctx.provenance(&[("light/downlight.ies", ies.as_bytes())]),
        section,
    );
    let text = to_json_string(&p)?;
    parse_preset(text.as_bytes(), "light/downlight.preset.json")?;
    r.presets
        .push(ctx.put("light/downlight.preset.json", text.as_bytes())?);
    let light = RectLight::new([0.0, 2.5, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, 1.0], 0.6, 0.6)?;
    let (doc, ies_bytes) = gltf_light(&f, &light, &p.name, "downlight_gltf.ies")?;
    let gltf = serde_json::to_string_pretty(&doc)
        .map_err(|e| Error::invalid("glTF", e.to_string()))?
        + "\n";
    r.presets
        .push(ctx.put("light/downlight.gltf", gltf.as_bytes())?);
    r.data
        .push(ctx.put("light/downlight_gltf.ies", &ies_bytes)?);
    let beam = s.planes.first().map_or(f64::NAN, |b| b.beam_deg);
    r.summary = format!(
        "flux {:.1} lm from the grid (analytic 2π·1000/2.5 = {:.1} lm), max {:.0} cd, beam angle {beam:.1}°",
        s.flux_lm,
        2.0 * std::f64::consts::PI * 1000.0 / 2.5,
        s.max_cd
    );
    Ok(r)
}

// ---------------------------------------------------------------------------------------------
// 7. Colour.

const ILLUMINANTS: [&str; 2] = ["D65", "A"];

fn slug(name: &str) -> String {
    let s: String = name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() {
                c.to_ascii_lowercase()
            } else {
                '_'
            }
        })
        .collect();
    s.split('_')
        .filter(|p| !p.is_empty())
        .collect::<Vec<_>>()
        .join("_")
}

fn colour_stage(ctx: &mut Ctx<'_>) -> Result<(StageReport, Vec<PatchColour>)> {
    use crate::plot::{colorchecker_chart_png, SwatchPatch};

    let mut r = report(
        "colour",
        "Colour: ColorChecker colorimetry under D65 and A",
        "color table --spectra colorchecker.csv --illuminant D65 (and A)",
    );
    let table = calib::colorchecker_n_ohta();
    let observer = Observer::standard(StandardObserver::Cie1931_2)?;
    let method = XyzMethod::AstmE308;
    let patches: Vec<Spectrum> = (1..table.header.len())
        .map(|c| Spectrum::from_table(table, c).map(|s| s.with_name(table.header[c].clone())))
        .collect::<Result<_>>()?;
    let illuminants = ILLUMINANTS
        .iter()
        .map(|n| Illuminant::standard(n))
        .collect::<Result<Vec<_>>>()?;
    let rows = patch_colours(&patches, observer, &illuminants, method)?;
    let csv = patch_table_csv(&rows, observer.name(), method.cli_name());
    r.data
        .push(ctx.put("colorchecker_colorimetry.csv", csv.as_bytes())?);
    let n = patches.len();
    let swatches: Vec<SwatchPatch> = patches
        .iter()
        .enumerate()
        .map(|(i, sd)| SwatchPatch {
            name: sd.name().to_string(),
            reflectance: sd.clone(),
            srgb_by_illuminant: vec![rows[i].srgb, rows[n + i].srgb],
        })
        .collect();
    r.plots.push(ctx.plot(
        "colorchecker.png",
        &colorchecker_chart_png(
            "ColorChecker (N Ohta) — CIE 1931 2°, ASTM E308, sRGB (CAT02 to D65)",
            &ILLUMINANTS.map(String::from),
            &swatches,
        )?,
    )?);
    for (i, sd) in patches.iter().enumerate() {
        let preset = MaterialPreset {
            reflectance: Some(ReflectanceSection::new(
                sd.wavelengths().to_vec(),
                sd.values().to_vec(),
            )),
            ..MaterialPreset::new(
                format!("ColorChecker N Ohta {:02} {}", i + 1, sd.name()),
                ctx.provenance(&[(
                    "calib/colorchecker_n_ohta.csv (embedded)",
                    calib::COLORCHECKER_N_OHTA_CSV.as_bytes(),
                )]),
            )
        };
        r.presets.push(ctx.put_preset(
            &format!("presets/{:02}_{}.json", i + 1, slug(sd.name())),
            preset,
        )?);
    }
    let white = &rows[18];
    let worst = (0..n)
        .map(|i| crate::colorimetry::delta_e::delta_e_cie2000(rows[i].lab, rows[n + i].lab, false))
        .fold(0.0f64, f64::max);
    r.summary = format!(
        "24 patches under D65 and A (CIE 1931 2°, ASTM E308): patch 19 '{}' L* = {:.2}; largest ΔE00 between a patch's Lab under D65 and under A (each relative to its own white) {worst:.2}; 24 reflectance presets, each read back",
        white.name, white.lab[0]
    );
    Ok((r, rows[..n].to_vec()))
}

// ---------------------------------------------------------------------------------------------
// The page.

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// One line under each plot of the page: (path prefix, caption).
const CAPTIONS: [(&str, &str); 15] = [
    ("lvf/calibration.png", "the lamp profile along the filter, the fitted model and the mercury lines; residuals below"),
    ("lvf/bands.png", "the 31 band transmissions from the calibration alone (Gaussian passbands averaged over each pixel window)"),
    ("lvf/recovered_", "recovered reflectance ± 2σ against the patch's bundled reflectance; effective resolution below"),
    ("phos/maps_n_states.png", "states chosen per 4×4 block (blue 1, red 2): left half Table 1 green paint, right half its two-state variant"),
    ("phos/maps_k2.png", "k₂ per block, blue 0 … red 0.1 s⁻¹, black where the block has one state (truth 0.0454 s⁻¹ on the right)"),
    ("phos/decay_fit.png", "the left half's mean curve and its decay fit"),
    ("phos/excitation_fit.png", "charging curves per band (box sources, 1–512 s) and the fitted model"),
    ("phos/simulation.png", "60 s of charging in the three blue bands, then 120 s of glow, with the fitted material"),
    ("fluor/reduction.png", "the first Donaldson matrix, its reduced matrices, and the mean ΔE00 of the three materials per illuminant and method"),
    ("dispersion/fit_residuals.png", "n(model) − n(data) of every candidate model over 380–780 nm"),
    ("afterimage/figure.png", "the stimulus (normalised), then its afterimage on black at 0, 2, 5, 10 and 20 s"),
    ("afterimage/curves.png", "Mikamo 2013: afterimage luminance Y(t) and its chromaticity track"),
    ("light/polar.png", "candela distribution in the C0–C180 and C90–C270 planes"),
    ("colorchecker.png", "rendered swatches under D65 and A beside the reflectance spectra"),
    ("", ""),
];

fn caption(path: &str) -> &'static str {
    CAPTIONS
        .iter()
        .find(|(p, _)| !p.is_empty() && path.starts_with(p))
        .map_or("", |(_, c)| c)
}

/// `index.html`: one section per stage with its line, its plots (relative `<img>`) and links to
/// its presets and data.
pub fn index_html(stages: &[StageReport]) -> String {
    let total: f64 = stages.iter().map(|s| s.seconds).sum();
    let mut h = String::from(
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\n<title>lumifit demo</title>\n<style>\n\
         body{font-family:system-ui,sans-serif;max-width:1200px;margin:2em auto;padding:0 1em;color:#222}\n\
         h1{margin-bottom:0.2em} section{border-top:1px solid #ccc;padding:0.5em 0 1em}\n\
         .sum{background:#f4f4f4;padding:0.4em 0.6em;border-radius:4px}\n\
         code{font-size:0.9em;color:#555} img{max-width:100%;border:1px solid #ddd;margin:0.3em 0}\n\
         .plots{display:flex;flex-wrap:wrap;gap:8px} .plots figure{margin:0;flex:1 1 520px} .plots figure.wide{flex-basis:100%}\n\
         img{height:auto}\n\
         ul.files{columns:2;font-size:0.9em} table{border-collapse:collapse;width:100%}\n\
         td,th{padding:3px 8px;text-align:left;vertical-align:top;border-bottom:1px solid #eee}\n\
         td.t{white-space:nowrap;text-align:right} figcaption{font-size:0.85em;color:#444}\n\
         </style></head><body>\n<h1>lumifit demo</h1>\n",
    );
    h.push_str(&format!(
        "<p>Every pipeline of lumifit, end to end on synthesised or bundled data, in {total:.1} s. \
         Each section names the commands it reproduces; every plot and preset below was written by this run.</p>\n<table>\n<tr><th>stage</th><th>time</th><th>what it did, and its key number</th></tr>\n"
    ));
    for s in stages {
        h.push_str(&format!(
            "<tr><td><a href=\"#{}\">{}</a></td><td class=\"t\">{:.2} s</td><td>{}</td></tr>\n",
            s.key,
            esc(s.title.split(':').next().unwrap_or(s.title)),
            s.seconds,
            esc(&s.summary)
        ));
    }
    h.push_str("</table>\n");
    for s in stages {
        h.push_str(&format!(
            "<section id=\"{}\">\n<h2>{}</h2>\n<p class=\"sum\">{} <em>({:.2} s)</em></p>\n<p><code>lumifit {}</code></p>\n<div class=\"plots\">\n",
            s.key,
            esc(s.title),
            esc(&s.summary),
            s.seconds,
            esc(s.commands)
        ));
        for p in &s.plots {
            let wide = p.width > 2 * p.height;
            h.push_str(&format!(
                "<figure{}><img src=\"{}\" alt=\"{}\" width=\"{}\" height=\"{}\"><figcaption>{} <code>{}</code></figcaption></figure>\n",
                if wide { " class=\"wide\"" } else { "" },
                esc(&p.path),
                esc(&p.path),
                p.width,
                p.height,
                esc(caption(&p.path)),
                esc(&p.path)
            ));
        }
        h.push_str("</div>\n");
        if !s.presets.is_empty() {
            h.push_str("<p>Presets and exports:</p>\n<ul class=\"files\">\n");
            for p in &s.presets {
                h.push_str(&format!("<li><a href=\"{0}\">{0}</a></li>\n", esc(p)));
            }
            h.push_str("</ul>\n");
        }
        if !s.data.is_empty() {
            h.push_str("<p>Data:</p>\n<ul class=\"files\">\n");
            for p in &s.data {
                h.push_str(&format!("<li><a href=\"{0}\">{0}</a></li>\n", esc(p)));
            }
            h.push_str("</ul>\n");
        }
        h.push_str("</section>\n");
    }
    h.push_str("</body></html>\n");
    h
}
