//! Shader snippets of presets (issue 17): parsed and validated by naga in both languages, and
//! their Rust twins checked against the library's own f64 simulation and reduction.

use lumifit::afterimage::mikamo2013::{
    self as mikamo, DarkAdaptation, LinearImage, MaskRule, SynthParams, Synthesizer, TimeRange,
};
use lumifit::colorimetry::rgb::RgbSpace;
use lumifit::dispersion::RefractiveIndex;
use lumifit::phosphor::simulate::{emission, final_state, Segment};
use lumifit::phosphor::{table1_materials, BandSet, Material, PhosphorState};
use lumifit::preset::afterimage::AfterimageSection;
use lumifit::preset::dispersion::{DispersionModel, DispersionSection};
use lumifit::preset::shader::{
    afterimage_snippet, band_to_rgb, dispersion_snippet, fluorescence_snippet,
    phosphorescence_snippet, AfterimageTwin, DispersionTwin, FluorTwin, PhosphorTwin,
    ShaderLanguage,
};
use lumifit::preset::{Bands, FluorescenceSection, PhosphorescenceSection, PhosphorescentState};
mod common;
use common::tolerances::shader_export::*;

fn section_of(m: &Material) -> PhosphorescenceSection {
    PhosphorescenceSection {
        bands: match &m.bands {
            BandSet::Rgb => Bands::Rgb,
            BandSet::RangesNm(r) => Bands::RangesNm(r.clone()),
        },
        states: m
            .states
            .iter()
            .map(|s| PhosphorescentState {
                k_r_per_s: s.k_r_per_s,
                k_e: s.k_e.clone(),
                lambda: s.lambda.clone(),
                extra: Default::default(),
            })
            .collect(),
        extra: Default::default(),
    }
}

fn rgb_material() -> Material {
    Material {
        name: "two_state_rgb".into(),
        bands: BandSet::Rgb,
        states: vec![
            PhosphorState {
                k_r_per_s: 0.227,
                k_e: Some(vec![0.0, 0.02, 0.1]),
                lambda: vec![0.2, 1.0, 0.3],
            },
            PhosphorState {
                k_r_per_s: 0.0454,
                k_e: Some(vec![0.001, 0.01, 0.05]),
                lambda: vec![0.1, 0.8, 0.2],
            },
        ],
    }
}

/// A SplitMix64 stream mapped to [0, 1): deterministic random inputs without a dependency.
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
}

fn validate_wgsl(src: &str) {
    let module = naga::front::wgsl::parse_str(src)
        .unwrap_or_else(|e| panic!("WGSL parse error: {}\n{src}", e.emit_to_string(src)));
    naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::all(),
    )
    .validate(&module)
    .unwrap_or_else(|e| panic!("WGSL validation error: {e:?}\n{src}"));
}

fn validate_glsl(src: &str) {
    let mut frontend = naga::front::glsl::Frontend::default();
    let options = naga::front::glsl::Options::from(naga::ShaderStage::Fragment);
    let module = frontend
        .parse(&options, src)
        .unwrap_or_else(|e| panic!("GLSL parse error: {e:?}\n{src}"));
    naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::all(),
    )
    .validate(&module)
    .unwrap_or_else(|e| panic!("GLSL validation error: {e:?}\n{src}"));
}

/// The snippet plus an entry point that calls every function, as a renderer would.
fn phos_wgsl_program(snippet: &str, n_bands: usize) -> String {
    format!(
        "{snippet}\n@group(0) @binding(0) var<storage, read_write> state: array<vec4<f32>>;\n\
         @group(0) @binding(1) var<storage, read_write> glow: array<vec4<f32>>;\n\
         @compute @workgroup_size(64)\n\
         fn main(@builtin(global_invocation_id) id: vec3<u32>) {{\n\
         \x20   var e: array<f32, {n_bands}>;\n\
         \x20   for (var b = 0u; b < PHOS_N_BANDS; b++) {{ e[b] = 1.0; }}\n\
         \x20   let r = phos_step(state[id.x], e, 1.0 / 60.0);\n\
         \x20   state[id.x] = r;\n\
         \x20   glow[id.x] = vec4<f32>(phos_emission_rgb(r), 1.0);\n}}\n"
    )
}

fn phos_glsl_program(snippet: &str, n_bands: usize) -> String {
    format!(
        "#version 450\n{snippet}\nlayout(location = 0) in vec4 r_in;\n\
         layout(location = 0) out vec4 colour;\n\
         void main() {{\n\
         \x20   float e[{n_bands}];\n\
         \x20   for (int b = 0; b < {n_bands}; b++) {{ e[b] = 1.0; }}\n\
         \x20   vec4 r = phos_step(r_in, e, 1.0 / 60.0);\n\
         \x20   colour = vec4(phos_emission_rgb(r), 1.0);\n}}\n"
    )
}

#[test]
fn phosphorescence_snippets_validate_in_naga_for_rgb_and_wavelength_bands() {
    let srgb = RgbSpace::srgb().unwrap();
    let mut materials = vec![rgb_material()];
    materials.extend(
        table1_materials()
            .unwrap()
            .iter()
            .map(|t| t.material.clone()),
    );
    let mut checked = 0;
    for m in &materials {
        let sec = section_of(m);
        if sec.states.len() > 4 {
            continue;
        }
        let nb = m.bands.len();
        let w = phosphorescence_snippet(&m.name, &sec, &srgb, ShaderLanguage::Wgsl).unwrap();
        validate_wgsl(&phos_wgsl_program(&w, nb));
        let g = phosphorescence_snippet(&m.name, &sec, &srgb, ShaderLanguage::Glsl).unwrap();
        validate_glsl(&phos_glsl_program(&g, nb));
        checked += 1;
    }
    assert!(checked >= 2, "only {checked} materials checked");
}

#[test]
fn the_phosphorescence_twin_steps_like_the_exact_library_simulation() {
    let srgb = RgbSpace::srgb().unwrap();
    let mut materials = vec![rgb_material()];
    materials.extend(
        table1_materials()
            .unwrap()
            .iter()
            .map(|t| t.material.clone()),
    );
    let mut rng = Rng(17);
    let mut worst: f64 = 0.0;
    let mut n = 0;
    for m in materials.iter().filter(|m| m.states.len() <= 4) {
        let twin = PhosphorTwin::from_section(&section_of(m), &srgb).unwrap();
        let m_rgb = band_to_rgb(&section_of(m).bands, &srgb).unwrap();
        for _ in 0..200 {
            let r0: Vec<f64> = (0..m.states.len())
                .map(|_| (rng.next() as f32) as f64)
                .collect();
            // Decay-only materials (no k_e) cannot be charged: they are stepped in the dark.
            let chargeable = m.states.iter().all(|s| s.k_e.is_some());
            let e: Vec<f64> = (0..m.bands.len())
                .map(|_| ((10.0 * rng.next()) as f32) as f64 * f64::from(u8::from(chargeable)))
                .collect();
            let dt = ((1e-3 + 10.0 * rng.next()) as f32) as f64;
            let lib = final_state(
                m,
                &[Segment {
                    duration_s: dt,
                    irradiance: e.clone(),
                }],
                &r0,
            )
            .unwrap();
            let mut r4 = [0.0f32; 4];
            for (d, s) in r4.iter_mut().zip(&r0) {
                *d = *s as f32;
            }
            let e32: Vec<f32> = e.iter().map(|&v| v as f32).collect();
            let tw = twin.step(r4, &e32, dt as f32);
            for (i, l) in lib.iter().enumerate() {
                let rel = (tw[i] as f64 - l).abs() / l.abs().max(1e-3);
                worst = worst.max(rel);
            }
            for unused in &tw[m.states.len()..] {
                assert_eq!(*unused, 0.0, "an unused lane moved");
            }
            // Emission: the library's per-band L through the same band → RGB matrix, in f64.
            let l_band = emission(m, &lib);
            let tw_rgb = twin.emission_rgb(tw);
            for ch in 0..3 {
                let want: f64 = l_band.iter().zip(&m_rgb).map(|(l, c)| l * c[ch]).sum();
                let scale: f64 = l_band
                    .iter()
                    .zip(&m_rgb)
                    .map(|(l, c)| (l * c[ch]).abs())
                    .sum::<f64>()
                    .max(1e-9);
                worst = worst.max((tw_rgb[ch] as f64 - want).abs() / scale);
            }
            n += 1;
        }
    }
    eprintln!(
        "phosphorescence twin vs library: {n} random frames, worst relative difference {worst:.2e}"
    );
    assert!(n >= 400);
    assert!(worst < TWIN_REL_TOL, "worst relative difference {worst:e}");
}

/// A fluorescence section as `fluor reduce` writes it, with the given RGB matrix.
fn fluor_section(matrix: [[f64; 3]; 3]) -> FluorescenceSection {
    let xyz = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let v = serde_json::json!({
        "method": "dual", "paper": "Fichet, Belcour & Barla 2024",
        "basis": {"name": "xyz", "k": 3, "labels": ["X", "Y", "Z"], "observer": "cie2015-2",
                  "grid_nm": {"start_nm": 380.0, "end_nm": 382.0, "step_nm": 1.0},
                  "functions": [[0.1, 0.2, 0.1], [0.0, 0.1, 0.0], [0.5, 0.4, 0.3]]},
        "matrix": xyz, "transfer_xyz": xyz, "xyz_matrix": xyz,
        "rgb": {"space": "srgb", "matrix": matrix, "projected_from_k": 3, "equation": "Eq. 16"},
        "resampling": {"clip_negatives": true, "zero_anti_stokes": true,
                       "diagonal": "linear", "off_diagonal": "bilinear"},
        "delta_e00": [], "worst_delta_e00": 0.0
    });
    serde_json::from_value(v).expect("a fluorescence section")
}

#[test]
fn fluorescence_snippets_validate_and_the_twin_is_the_matrix_product_clamped_at_zero() {
    // A matrix with the shape `fluor reduce` writes: diagonal reflectance, negative and positive
    // off-diagonal terms (energy moved from blue to green).
    let m = [[0.80, -0.02, 0.01], [0.05, 0.70, 0.35], [-0.01, 0.00, 0.30]];
    let sec = fluor_section(m);
    let w = fluorescence_snippet("pink", &sec, ShaderLanguage::Wgsl).unwrap();
    validate_wgsl(&format!(
        "{w}\n@fragment fn main(@location(0) c: vec3<f32>) -> @location(0) vec4<f32> {{ return vec4<f32>(fluor_shade(c), 1.0); }}\n"
    ));
    let g = fluorescence_snippet("pink", &sec, ShaderLanguage::Glsl).unwrap();
    validate_glsl(&format!(
        "#version 450\n{g}\nlayout(location = 0) in vec3 c;\nlayout(location = 0) out vec4 o;\nvoid main() {{ o = vec4(fluor_shade(c), 1.0); }}\n"
    ));
    let twin = FluorTwin::from_section(&sec).unwrap();
    let mut rng = Rng(5);
    let mut worst: f64 = 0.0;
    for _ in 0..1000 {
        let c = [rng.next(), rng.next(), rng.next()].map(|v| (v as f32) as f64);
        let out = twin.shade(c.map(|v| v as f32));
        for r in 0..3 {
            let want = (m[r][0] * c[0] + m[r][1] * c[1] + m[r][2] * c[2]).max(0.0);
            let scale = m[r].iter().zip(&c).map(|(a, b)| (a * b).abs()).sum::<f64>();
            worst = worst.max((out[r] as f64 - want).abs() / scale.max(1e-9));
        }
    }
    assert!(worst < TWIN_REL_TOL, "worst {worst:e}");
    // A pure blue light makes the negative red term win: clamped to zero, not negative.
    assert_eq!(twin.shade([0.0, 1.0, 0.0])[0], 0.0);
}

#[test]
fn snippets_refuse_presets_they_cannot_carry() {
    let srgb = RgbSpace::srgb().unwrap();
    let mut m = rgb_material();
    let s = m.states[0].clone();
    m.states = vec![s; 5];
    let e =
        phosphorescence_snippet("five", &section_of(&m), &srgb, ShaderLanguage::Wgsl).unwrap_err();
    assert!(e.to_string().contains("1 to 4 states"), "{e}");
    // A matrix entry beyond f32 cannot become a shader constant.
    let e = fluorescence_snippet(
        "big",
        &fluor_section([[1e39, 0.0, 0.0]; 3]),
        ShaderLanguage::Glsl,
    )
    .unwrap_err();
    assert!(e.to_string().contains("fluorescence.rgb.matrix"), "{e}");
}

#[test]
fn preset_export_writes_snippets_that_naga_validates_and_refuses_presets_without_them() {
    let dir = tempfile::tempdir().unwrap();
    let preset = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("fixtures/presets/valid_material.json");
    let run = |args: &[&str]| {
        std::process::Command::new(env!("CARGO_BIN_EXE_lumifit"))
            .args(args)
            .output()
            .expect("lumifit runs")
    };
    let wgsl = dir.path().join("glow.wgsl");
    let o = run(&[
        "preset",
        "export",
        preset.to_str().unwrap(),
        "--format",
        "wgsl",
        "--out",
        wgsl.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = std::fs::read_to_string(&wgsl).unwrap();
    validate_wgsl(&phos_wgsl_program(&text, 3));
    let o = run(&[
        "preset",
        "export",
        preset.to_str().unwrap(),
        "--format",
        "glsl",
        "--out",
        "-",
    ]);
    assert!(o.status.success());
    validate_glsl(&phos_glsl_program(&String::from_utf8(o.stdout).unwrap(), 3));
    // A preset with no phosphorescence or fluorescence: exit 2, the file named, nothing written.
    let minimal = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("fixtures/presets/valid_minimal_material.json");
    let none = dir.path().join("none.wgsl");
    let o = run(&[
        "preset",
        "export",
        minimal.to_str().unwrap(),
        "--format",
        "wgsl",
        "--out",
        none.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("valid_minimal_material.json"));
    assert!(!none.exists());
}

fn lumifit(args: &[&str]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_lumifit"))
        .args(args)
        .output()
        .expect("lumifit runs")
}

/// `lumifit dispersion fit --glass N-BK7` into `dir`: the preset's path.
fn nbk7_preset(dir: &std::path::Path) -> std::path::PathBuf {
    let out = dir.join("nbk7.json");
    let o = lumifit(&[
        "dispersion",
        "fit",
        "--glass",
        "N-BK7",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    out
}

fn nbk7_section(dir: &std::path::Path) -> DispersionSection {
    lumifit::preset::read_material(&nbk7_preset(dir))
        .unwrap()
        .dispersion
        .expect("a dispersion section")
}

/// A renderer's use of every function of the dispersion and afterimage snippets.
fn wgsl_program(snippet: &str, disp: bool, after: bool, dark: bool) -> String {
    let mut body = String::from("    var acc = vec4<f32>(0.0);\n");
    if disp {
        body.push_str(
            "    for (var i = 0u; i < disp_sample_count(); i++) {\n\
             \x20       let s = disp_sample(i);\n\
             \x20       acc += vec4<f32>(s.xyz * disp_ior(s.w), s.w);\n    }\n",
        );
    }
    if after {
        body.push_str(
            "    acc += vec4<f32>(afterimage_at(f32(id.x) * 0.1, vec3<f32>(0.9, 0.5, 0.1)),\n\
             \x20       afterimage_luminance(1.0) + afterimage_xy(2.0).x + afterimage_curve_lab(3.0).z);\n",
        );
    }
    if dark {
        body.push_str("    acc.w += afterimage_dark_weight(5.0);\n");
    }
    format!(
        "{snippet}\n@group(0) @binding(0) var<storage, read_write> out_buf: array<vec4<f32>>;\n\
         @compute @workgroup_size(64)\n\
         fn main(@builtin(global_invocation_id) id: vec3<u32>) {{\n{body}    out_buf[id.x] = acc;\n}}\n"
    )
}

fn glsl_program(snippet: &str, disp: bool, after: bool, dark: bool) -> String {
    let mut body = String::from("    vec4 acc = vec4(0.0);\n");
    if disp {
        body.push_str(
            "    for (int i = 0; i < disp_sample_count(); i++) {\n\
             \x20       vec4 s = disp_sample(i);\n\
             \x20       acc += vec4(s.xyz * disp_ior(s.w), s.w);\n    }\n",
        );
    }
    if after {
        body.push_str(
            "    acc += vec4(afterimage_at(v_in.x, v_in.yzw),\n\
             \x20       afterimage_luminance(1.0) + afterimage_xy(2.0).x + afterimage_curve_lab(3.0).z);\n",
        );
    }
    if dark {
        body.push_str("    acc.w += afterimage_dark_weight(5.0);\n");
    }
    format!(
        "#version 450\n{snippet}\nlayout(location = 0) in vec4 v_in;\n\
         layout(location = 0) out vec4 colour;\n\
         void main() {{\n{body}    colour = acc;\n}}\n"
    )
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs().max(f64::MIN_POSITIVE)
}

fn check_dispersion_twin(section: &DispersionSection, label: &str) {
    let twin = DispersionTwin::from_section(section).unwrap();
    let model = section.to_model().unwrap();
    let [lo, hi] = section.range_nm;
    let mut rng = Rng(17);
    let mut worst = 0.0f64;
    for _ in 0..1000 {
        // λ exactly representable in f32, so the twin and the library see the same wavelength.
        let l = (lo + (hi - lo) * rng.next()) as f32;
        let got = f64::from(twin.ior(l));
        let want = model.n_at(f64::from(l));
        worst = worst.max(rel(got, want));
    }
    println!(
        "{label}: disp_ior twin vs library n(λ), 1000 λ in [{lo}, {hi}] nm: max rel {worst:.2e}"
    );
    assert!(worst <= TWIN_REL_TOL, "{label}: {worst:e}");
    // The weights sum to the library's white (1, 1, 1) of the working space.
    assert_eq!(twin.sample_count(), section.samples.len());
    let mut sum = [0.0f64; 3];
    for i in 0..twin.sample_count() {
        let (l, w) = twin.sample(i);
        assert_eq!(l, section.samples[i].lambda_nm as f32);
        for c in 0..3 {
            sum[c] += f64::from(w[c]);
        }
    }
    let lib: Vec<f64> = (0..3)
        .map(|c| section.samples.iter().map(|s| s.rgb[c]).sum())
        .collect();
    for c in 0..3 {
        assert!(
            (lib[c] - 1.0).abs() < 1e-9,
            "{label}: library white {lib:?}"
        );
        assert!(
            (sum[c] - lib[c]).abs() <= TWIN_REL_TOL,
            "{label}: twin weights sum to {sum:?}, the library to {lib:?}"
        );
    }
    let last = twin.sample(twin.sample_count() - 1);
    assert_eq!(twin.sample(twin.sample_count() + 5), last);
    for lang in [ShaderLanguage::Wgsl, ShaderLanguage::Glsl] {
        let text = dispersion_snippet(label, section, lang).unwrap();
        match lang {
            ShaderLanguage::Wgsl => validate_wgsl(&wgsl_program(&text, true, false, false)),
            ShaderLanguage::Glsl => validate_glsl(&glsl_program(&text, true, false, false)),
        }
    }
}

#[test]
fn dispersion_twin_is_the_library_model_and_its_weights_sum_to_white() {
    let dir = tempfile::tempdir().unwrap();
    let section = nbk7_section(dir.path());
    assert_eq!(section.model.kind, "sellmeier");
    check_dispersion_twin(&section, "N-BK7 sellmeier");
    // A Cauchy section (the other model family), same samples.
    let mut cauchy = section.clone();
    cauchy.model = DispersionModel {
        kind: "cauchy".into(),
        coefficients: vec![1.5046, 0.00420, -1.2e-5, 2.0e-6],
        wavelength_unit: "um".into(),
    };
    check_dispersion_twin(&cauchy, "cauchy 4-term");
    let text = dispersion_snippet("x", &cauchy, ShaderLanguage::Wgsl).unwrap();
    assert!(text.contains("* inv +"), "Horner in 1/λ²:\n{text}");
}

fn afterimage_section(params: &SynthParams, with_background: bool) -> AfterimageSection {
    let times = mikamo::time_grid(4.0, 80.0).unwrap();
    let curves = mikamo::curves(&times, TimeRange::Measured).unwrap();
    AfterimageSection::new(params, with_background, &curves)
}

#[test]
fn afterimage_twin_curves_follow_the_library() {
    let params = SynthParams::default();
    let twin = AfterimageTwin::from_section(&afterimage_section(&params, false)).unwrap();
    let mut rng = Rng(3);
    let mut worst = [0.0f64; 3];
    for k in 0..1000 {
        // Include every Table 1 time and the Eq. 3 breakpoint's neighbourhood.
        let t = if k < 21 {
            4.0 * k as f32
        } else {
            (80.0 * rng.next()) as f32
        };
        let t64 = f64::from(t);
        worst[0] = worst[0].max(rel(f64::from(twin.luminance(t)), mikamo::luminance_y(t64)));
        let xy = twin.chromaticity(t);
        let want = mikamo::chromaticity_xy(t64);
        for c in 0..2 {
            worst[1] = worst[1].max(rel(f64::from(xy[c]), want[c]));
        }
        let lab = twin.curve_lab(t);
        let want = mikamo::curve_point(t64).unwrap().lab;
        // a and b cross zero: relative to the size of the colour (|Lab|∞).
        let scale = want.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        for c in 0..3 {
            worst[2] = worst[2].max((f64::from(lab[c]) - want[c]).abs() / scale);
        }
    }
    println!(
        "afterimage curves twin vs library, 1000 t in [0, 80] s: Y_M rel {:.2e}, (x, y) rel {:.2e}, Lab rel to |Lab|∞ {:.2e}",
        worst[0], worst[1], worst[2]
    );
    for w in worst {
        assert!(w <= TWIN_REL_TOL, "{worst:?}");
    }
    // Without --extrapolate the snippet holds t at the table's end; with it Eq. 3 continues.
    assert_eq!(twin.luminance(200.0), twin.luminance(80.0));
    let ext = AfterimageTwin::from_section(&afterimage_section(
        &SynthParams {
            range: TimeRange::Extrapolate,
            ..params
        },
        false,
    ))
    .unwrap();
    assert!(rel(f64::from(ext.luminance(200.0)), mikamo::luminance_y(200.0)) <= TWIN_REL_TOL);
}

#[test]
fn afterimage_at_follows_the_library_synthesis_at_random_stimuli() {
    let params = SynthParams {
        mask: MaskRule { threshold: 0.0 },
        dark: DarkAdaptation {
            constant: 0.1,
            time_s: 15.0,
        },
        ..SynthParams::default()
    };
    let section = afterimage_section(&params, true);
    let twin = AfterimageTwin::from_section(&section).unwrap();
    let mut rng = Rng(42);
    let (mut worst, mut clamped) = (0.0f64, 0);
    let mut worst_case = String::new();
    for k in 0..1000 {
        let t = (80.0 * rng.next()) as f32;
        // Channels in [0, 1): luminance below the white pixel's 1, so the image's brightest Y
        // is the white and the stimulus reaches the model unscaled. Every fourth stimulus has a
        // channel near 0 (saturated colours whose afterimage leaves the gamut).
        let mut rgb = [0.0f32; 3];
        for v in rgb.iter_mut() {
            *v = rng.next() as f32;
        }
        if k % 4 == 0 {
            rgb[k / 4 % 3] *= 1e-3;
        }
        let image = LinearImage::new(
            "stimulus",
            2,
            1,
            vec![rgb[0], rgb[1], rgb[2], 1.0, 1.0, 1.0],
        )
        .unwrap();
        let synth = Synthesizer::new(&image, "stimulus", None, params).unwrap();
        let y_max = synth.input_y_max();
        assert!((y_max - 1.0).abs() < 1e-12, "{y_max}");
        let want = synth.afterimage_unblurred(f64::from(t)).unwrap();
        let got = twin.afterimage_at(t, rgb);
        let scale = want[..3].iter().fold(0.0f32, |m, v| m.max(v.abs()));
        assert!(scale > 0.0);
        for c in 0..3 {
            let e = f64::from((got[c] - want[c]).abs() / scale);
            if e > worst {
                worst = e;
                worst_case = format!(
                    "t {t} s, rgb {rgb:?}: twin {got:?}, library {:?}",
                    &want[..3]
                );
            }
        }
        if want[..3].contains(&0.0) {
            clamped += 1;
        }
        let w = twin.dark_weight(t).unwrap();
        let wl = params.dark.weight(f64::from(t));
        assert!(rel(f64::from(w), wl) <= TWIN_REL_TOL, "{w} vs {wl}");
    }
    println!(
        "afterimage_at twin vs Synthesizer::afterimage_unblurred, 1000 (t, rgb): max |Δ|/|rgb|∞ {worst:.2e}; {clamped} went through the gamut correction; worst at {worst_case}"
    );
    assert!(clamped > 0, "no stimulus exercised the gamut correction");
    assert!(worst <= AFTERIMAGE_REL_TOL, "{worst:e}");
    // A black stimulus leaves none.
    assert_eq!(twin.afterimage_at(10.0, [0.0, -1.0, 0.0]), [0.0; 3]);
}

#[test]
fn afterimage_snippets_validate_in_naga_with_and_without_dark_adaptation() {
    for (bg, range) in [(false, TimeRange::Measured), (true, TimeRange::Extrapolate)] {
        let params = SynthParams {
            range,
            ..SynthParams::default()
        };
        let section = afterimage_section(&params, bg);
        let w = afterimage_snippet("after", &section, ShaderLanguage::Wgsl).unwrap();
        validate_wgsl(&wgsl_program(&w, false, true, bg));
        let g = afterimage_snippet("after", &section, ShaderLanguage::Glsl).unwrap();
        validate_glsl(&glsl_program(&g, false, true, bg));
        assert_eq!(w.contains("afterimage_dark_weight"), bg);
    }
    // A colour table the snippet cannot index is refused with the field named.
    let mut section = afterimage_section(&SynthParams::default(), false);
    section.colour.t_s[3] += 0.5;
    let e = afterimage_snippet("x", &section, ShaderLanguage::Wgsl).unwrap_err();
    assert!(e.to_string().contains("afterimage.colour.t_s"), "{e}");
}

#[test]
fn preset_export_carries_dispersion_and_afterimage_snippets() {
    let dir = tempfile::tempdir().unwrap();
    let disp = nbk7_preset(dir.path());
    let mut doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&disp).unwrap()).unwrap();
    let after = serde_json::Value::Object(
        afterimage_section(&SynthParams::default(), true)
            .to_section()
            .unwrap(),
    );
    doc["afterimage"] = after;
    let both = dir.path().join("both.json");
    std::fs::write(&both, serde_json::to_string_pretty(&doc).unwrap()).unwrap();
    doc.as_object_mut().unwrap().remove("dispersion");
    let only_after = dir.path().join("after.json");
    std::fs::write(&only_after, serde_json::to_string_pretty(&doc).unwrap()).unwrap();
    for (preset, d, a) in [
        (&disp, true, false),
        (&only_after, false, true),
        (&both, true, true),
    ] {
        for fmt in ["wgsl", "glsl"] {
            let out = dir.path().join(format!("snippet.{fmt}"));
            let o = lumifit(&[
                "preset",
                "export",
                preset.to_str().unwrap(),
                "--format",
                fmt,
                "--out",
                out.to_str().unwrap(),
            ]);
            assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
            let report: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
            let sections = report["sections"].to_string();
            assert_eq!(sections.contains("dispersion"), d, "{sections}");
            assert_eq!(sections.contains("afterimage"), a, "{sections}");
            let text = std::fs::read_to_string(&out).unwrap();
            if fmt == "wgsl" {
                validate_wgsl(&wgsl_program(&text, d, a, a));
            } else {
                validate_glsl(&glsl_program(&text, d, a, a));
            }
            std::fs::remove_file(&out).unwrap();
        }
    }
    // A preset whose only section no snippet carries: exit 2 naming the file and its sections.
    let refl = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("fixtures/presets/valid_minimal_material.json");
    let out = dir.path().join("none.glsl");
    let o = lumifit(&[
        "preset",
        "export",
        refl.to_str().unwrap(),
        "--format",
        "glsl",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("valid_minimal_material.json") && err.contains("the preset has: none"),
        "{err}"
    );
    assert!(err.contains("dispersion, afterimage"), "{err}");
    assert!(!out.exists());
}
