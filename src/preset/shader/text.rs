//! The text of the snippets in both languages, from one generator: the two languages differ only
//! in how types, constants, parameters, function heads and local bindings are spelled
//! ([`ShaderLanguage`]'s methods below), so the numbers and the operation order cannot drift apart.

use super::twin::{FluorTwin, PhosphorTwin};
use super::{comment_name, lit, ShaderLanguage, MAX_STATES};

const LANES: [&str; MAX_STATES] = ["x", "y", "z", "w"];

impl ShaderLanguage {
    fn vec(self, n: usize) -> String {
        match self {
            ShaderLanguage::Wgsl => format!("vec{n}<f32>"),
            ShaderLanguage::Glsl => format!("vec{n}"),
        }
    }

    fn constant(self, name: &str, ty: &str, value: &str) -> String {
        match self {
            ShaderLanguage::Wgsl => format!("const {name}: {ty} = {value};\n"),
            ShaderLanguage::Glsl => format!("const {ty} {name} = {value};\n"),
        }
    }

    fn param(self, name: &str, ty: &str) -> String {
        match self {
            ShaderLanguage::Wgsl => format!("{name}: {ty}"),
            ShaderLanguage::Glsl => format!("{ty} {name}"),
        }
    }

    fn array_param(self, name: &str, n: usize) -> String {
        match self {
            ShaderLanguage::Wgsl => format!("{name}: array<f32, {n}>"),
            ShaderLanguage::Glsl => format!("float {name}[{n}]"),
        }
    }

    fn fn_head(self, name: &str, params: &[String], ret: &str) -> String {
        let params = params.join(", ");
        match self {
            ShaderLanguage::Wgsl => format!("fn {name}({params}) -> {ret} {{\n"),
            ShaderLanguage::Glsl => format!("{ret} {name}({params}) {{\n"),
        }
    }

    fn binding(self, name: &str, ty: &str, expr: &str) -> String {
        match self {
            ShaderLanguage::Wgsl => format!("    let {name} = {expr};\n"),
            ShaderLanguage::Glsl => format!("    {ty} {name} = {expr};\n"),
        }
    }

    fn tag(self) -> &'static str {
        match self {
            ShaderLanguage::Wgsl => "WGSL",
            ShaderLanguage::Glsl => "GLSL 4.50",
        }
    }
}

/// Phosphorescence: `phos_excitation`, `phos_step`, `phos_emission_rgb`.
pub(super) fn phosphorescence(
    lang: ShaderLanguage,
    name: &str,
    space: &str,
    t: &PhosphorTwin,
) -> String {
    let nb = t.n_bands;
    let (v3, v4) = (lang.vec(3), lang.vec(4));
    let mut s = format!(
        "// lumifit phosphorescence snippet for preset '{}' (lumifit.material/1), {}.\n\
         // {} state(s) over {nb} band(s), packed in a vec4 (unused lanes stay 0).\n\
         // Nalbach 2017 Eq. 1, exact for irradiance constant over the frame:\n\
         //   a = K_E * e; lam = a + K_R; r_eq = a / lam; r' = r_eq + (r - r_eq) * exp(-lam * dt)\n\
         // Emission (Eq. 3) in linear {space} (relative units): rgb = sum_i r_i * C_i.\n\
         // Keep r per surface point (a texture or vertex attribute) and call phos_step once a frame.\n",
        comment_name(name),
        lang.tag(),
        t.n_states
    );
    s.push_str(&match lang {
        ShaderLanguage::Wgsl => lang.constant("PHOS_N_BANDS", "u32", &format!("{nb}u")),
        ShaderLanguage::Glsl => lang.constant("PHOS_N_BANDS", "int", &nb.to_string()),
    });
    let k = t.k_r_per_s.map(lit).join(", ");
    s.push_str(&lang.constant("PHOS_K_R", &v4, &format!("{v4}({k})")));
    for (i, c) in t.rgb_per_state.iter().enumerate() {
        let c = c.map(lit).join(", ");
        s.push_str(&lang.constant(&format!("PHOS_C{i}"), &v3, &format!("{v3}({c})")));
    }
    s.push_str("\n// a_i = sum_b k_e[i][b] * e[b] (per-band irradiance of this frame)\n");
    s.push_str(&lang.fn_head("phos_excitation", &[lang.array_param("e", nb)], &v4));
    s.push_str(&format!("    return {v4}(\n"));
    for i in 0..MAX_STATES {
        let terms: Vec<String> = (0..nb)
            .map(|b| format!("{} * e[{b}]", lit(t.k_e[i][b])))
            .collect();
        let sep = if i + 1 < MAX_STATES { "," } else { "" };
        s.push_str(&format!("        {}{sep}\n", terms.join(" + ")));
    }
    s.push_str("    );\n}\n\n");
    s.push_str("// One frame of length dt_s (s) under constant irradiance e: exact update of r.\n");
    s.push_str(&lang.fn_head(
        "phos_step",
        &[
            lang.param("r", &v4),
            lang.array_param("e", nb),
            lang.param(
                "dt_s",
                if lang == ShaderLanguage::Wgsl {
                    "f32"
                } else {
                    "float"
                },
            ),
        ],
        &v4,
    ));
    s.push_str(&lang.binding("a", &v4, "phos_excitation(e)"));
    s.push_str(&lang.binding("lam", &v4, "a + PHOS_K_R"));
    s.push_str(&lang.binding("r_eq", &v4, "a / lam"));
    s.push_str("    return r_eq + (r - r_eq) * exp(-lam * dt_s);\n}\n\n");
    s.push_str("// Emitted linear RGB for concentrations r.\n");
    s.push_str(&lang.fn_head("phos_emission_rgb", &[lang.param("r", &v4)], &v3));
    s.push_str("    return PHOS_C0 * r.x");
    for (i, lane) in LANES.iter().enumerate().skip(1) {
        s.push_str(&format!(" + PHOS_C{i} * r.{lane}"));
    }
    s.push_str(";\n}\n");
    s
}

/// Fluorescence: `fluor_shade`.
pub(super) fn fluorescence(lang: ShaderLanguage, name: &str, t: &FluorTwin) -> String {
    let m = t.matrix;
    let v3 = lang.vec(3);
    let row = |r: usize| {
        format!(
            "{} * rgb_in.x + {} * rgb_in.y + {} * rgb_in.z",
            lit(m[r][0]),
            lit(m[r][1]),
            lit(m[r][2])
        )
    };
    let mut s = format!(
        "// lumifit fluorescence snippet for preset '{}' (lumifit.material/1), {}.\n\
         // Fichet 2024 Eq. 16: the reduced matrix in linear {}; rgb_in is the light arriving\n\
         // (in that space), the result what the material returns (reflection + fluorescence).\n\
         // Off-diagonal entries may be negative; the result is clamped at 0.\n",
        comment_name(name),
        lang.tag(),
        t.space
    );
    s.push_str(&lang.fn_head("fluor_shade", &[lang.param("rgb_in", &v3)], &v3));
    s.push_str(&format!(
        "    return max({v3}(\n        {},\n        {},\n        {}\n    ), {v3}(0.0));\n}}\n",
        row(0),
        row(1),
        row(2)
    ));
    s
}
