//! Shader snippets of presets (issue 17): parsed and validated by naga in both languages, and
//! their Rust twins checked against the library's own f64 simulation and reduction.

use lumifit::colorimetry::rgb::RgbSpace;
use lumifit::phosphor::simulate::{emission, final_state, Segment};
use lumifit::phosphor::{table1_materials, BandSet, Material, PhosphorState};
use lumifit::preset::shader::{
    band_to_rgb, fluorescence_snippet, phosphorescence_snippet, FluorTwin, PhosphorTwin,
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
