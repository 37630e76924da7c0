//! WGSL text of the snippets (see the module docs of [`super`] for the equations).

use super::twin::{FluorTwin, PhosphorTwin};
use super::{comment_name, lit, MAX_STATES};

const LANES: [&str; MAX_STATES] = ["x", "y", "z", "w"];

fn vec4(v: &[f32; MAX_STATES]) -> String {
    format!(
        "vec4<f32>({}, {}, {}, {})",
        lit(v[0]),
        lit(v[1]),
        lit(v[2]),
        lit(v[3])
    )
}

/// Phosphorescence: `phos_excitation`, `phos_step`, `phos_emission_rgb`.
pub(super) fn phosphorescence(name: &str, space: &str, t: &PhosphorTwin) -> String {
    let nb = t.n_bands;
    let mut s = String::new();
    s.push_str(&format!(
        "// lumifit phosphorescence snippet for preset '{}' (lumifit.material/1).\n\
         // {} state(s) over {nb} band(s), packed in a vec4 (unused lanes stay 0).\n\
         // Nalbach 2017 Eq. 1, exact for irradiance constant over the frame:\n\
         //   a = K_E * e; lam = a + K_R; r_eq = a / lam; r' = r_eq + (r - r_eq) * exp(-lam * dt)\n\
         // Emission (Eq. 3) in linear {space} (relative units): rgb = sum_i r_i * C_i.\n\
         // Keep r per surface point (a texture or vertex attribute) and call phos_step once a frame.\n",
        comment_name(name),
        t.n_states
    ));
    s.push_str(&format!("const PHOS_N_BANDS: u32 = {nb}u;\n"));
    s.push_str(&format!(
        "const PHOS_K_R: vec4<f32> = {};\n",
        vec4(&t.k_r_per_s)
    ));
    for (i, c) in t.rgb_per_state.iter().enumerate() {
        s.push_str(&format!(
            "const PHOS_C{i}: vec3<f32> = vec3<f32>({}, {}, {});\n",
            lit(c[0]),
            lit(c[1]),
            lit(c[2])
        ));
    }
    s.push_str(&format!(
        "\n// a_i = sum_b k_e[i][b] * e[b] (per-band irradiance of this frame)\n\
         fn phos_excitation(e: array<f32, {nb}>) -> vec4<f32> {{\n    return vec4<f32>(\n"
    ));
    for i in 0..MAX_STATES {
        let terms: Vec<String> = (0..nb)
            .map(|b| format!("{} * e[{b}]", lit(t.k_e[i][b])))
            .collect();
        let sep = if i + 1 < MAX_STATES { "," } else { "" };
        s.push_str(&format!("        {}{sep}\n", terms.join(" + ")));
    }
    s.push_str("    );\n}\n\n");
    s.push_str(&format!(
        "// One frame of length dt_s (s) under constant irradiance e: exact update of r.\n\
         fn phos_step(r: vec4<f32>, e: array<f32, {nb}>, dt_s: f32) -> vec4<f32> {{\n\
         \x20   let a = phos_excitation(e);\n\
         \x20   let lam = a + PHOS_K_R;\n\
         \x20   let r_eq = a / lam;\n\
         \x20   return r_eq + (r - r_eq) * exp(-lam * dt_s);\n}}\n\n"
    ));
    s.push_str("// Emitted linear RGB for concentrations r.\nfn phos_emission_rgb(r: vec4<f32>) -> vec3<f32> {\n    return PHOS_C0 * r.x");
    for (i, lane) in LANES.iter().enumerate().skip(1) {
        s.push_str(&format!(" + PHOS_C{i} * r.{lane}"));
    }
    s.push_str(";\n}\n");
    s
}

/// Fluorescence: `fluor_shade`.
pub(super) fn fluorescence(name: &str, t: &FluorTwin) -> String {
    let m = t.matrix;
    let row = |r: usize| {
        format!(
            "{} * rgb_in.x + {} * rgb_in.y + {} * rgb_in.z",
            lit(m[r][0]),
            lit(m[r][1]),
            lit(m[r][2])
        )
    };
    format!(
        "// lumifit fluorescence snippet for preset '{}' (lumifit.material/1).\n\
         // Fichet 2024 Eq. 16: the reduced matrix in linear {space}; rgb_in is the light arriving\n\
         // (in that space), the result what the material returns (reflection + fluorescence).\n\
         // Off-diagonal entries may be negative; the result is clamped at 0.\n\
         fn fluor_shade(rgb_in: vec3<f32>) -> vec3<f32> {{\n\
         \x20   return max(vec3<f32>(\n        {},\n        {},\n        {}\n    ), vec3<f32>(0.0));\n}}\n",
        comment_name(name),
        row(0),
        row(1),
        row(2),
        space = t.space
    )
}
