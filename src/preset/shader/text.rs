//! The text of the snippets in both languages, from one generator: the two languages differ only
//! in how types, constants, parameters, function heads and local bindings are spelled
//! ([`ShaderLanguage`]'s methods below), so the numbers and the operation order cannot drift apart.

use super::twin::{AfterimageTwin, DispersionTwin, FluorTwin, IorKind, PhosphorTwin};
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

    fn scalar(self) -> &'static str {
        match self {
            ShaderLanguage::Wgsl => "f32",
            ShaderLanguage::Glsl => "float",
        }
    }

    /// The index type (`u32` / `int`).
    fn index(self) -> &'static str {
        match self {
            ShaderLanguage::Wgsl => "u32",
            ShaderLanguage::Glsl => "int",
        }
    }

    /// An index literal.
    fn idx(self, n: usize) -> String {
        match self {
            ShaderLanguage::Wgsl => format!("{n}u"),
            ShaderLanguage::Glsl => n.to_string(),
        }
    }

    /// A constant array of `ty` elements (already spelled literals).
    fn const_array(self, name: &str, ty: &str, items: &[String]) -> String {
        let n = items.len();
        let body = items.join(", ");
        match self {
            ShaderLanguage::Wgsl => {
                format!("const {name}: array<{ty}, {n}> = array<{ty}, {n}>({body});\n")
            }
            ShaderLanguage::Glsl => format!("const {ty} {name}[{n}] = {ty}[{n}]({body});\n"),
        }
    }

    /// A local copy of a constant array (so that it can be indexed by a runtime value).
    fn local_array(self, name: &str, ty: &str, n: usize, value: &str) -> String {
        match self {
            ShaderLanguage::Wgsl => format!("    var {name} = {value};\n"),
            ShaderLanguage::Glsl => format!("    {ty} {name}[{n}] = {value};\n"),
        }
    }

    /// A mutable local.
    fn var(self, name: &str, ty: &str, expr: &str) -> String {
        match self {
            ShaderLanguage::Wgsl => format!("    var {name} = {expr};\n"),
            ShaderLanguage::Glsl => format!("    {ty} {name} = {expr};\n"),
        }
    }

    fn cast_float(self, e: &str) -> String {
        format!("{}({e})", self.scalar())
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

/// A literal, parenthesised when negative (safe after any operator).
fn plit(v: f32) -> String {
    let s = lit(v);
    if s.starts_with('-') {
        format!("({s})")
    } else {
        s
    }
}

/// Dispersion: `disp_sample_count`, `disp_sample`, `disp_ior`.
pub(super) fn dispersion(lang: ShaderLanguage, name: &str, t: &DispersionTwin) -> String {
    let n = t.sample_count();
    let (f, ix, v4) = (lang.scalar(), lang.index(), lang.vec(4));
    let model = match t.kind {
        IorKind::Cauchy => "Cauchy n = sum_i c_i * lambda^(-2i)",
        IorKind::Sellmeier => "Sellmeier n^2 = 1 + sum_i B_i * lambda^2 / (lambda^2 - C_i)",
    };
    let mut s = format!(
        "// lumifit dispersion snippet for preset '{}' (lumifit.material/1), {}.\n\
         // {n} wavelength sample(s) (Blanchette 2012): trace one ray per sample with index\n\
         // disp_ior(lambda_nm) and weight its radiance by the sample's linear {} weight; the\n\
         // weights sum to the space's white (1, 1, 1). Model: {model}, lambda in um,\n\
         // fitted over {}-{} nm (outside that range it is an extrapolation).\n",
        comment_name(name),
        lang.tag(),
        t.space,
        t.range_nm[0],
        t.range_nm[1],
    );
    s.push_str(&lang.constant("DISP_N_SAMPLES", ix, &lang.idx(n)));
    s.push_str(&lang.constant(
        "DISP_RANGE_NM",
        &lang.vec(2),
        &format!(
            "{}({}, {})",
            lang.vec(2),
            lit(t.range_nm[0]),
            lit(t.range_nm[1])
        ),
    ));
    let arr = |v: Vec<f32>| v.into_iter().map(lit).collect::<Vec<_>>();
    s.push_str(&lang.const_array("DISP_LAMBDA_NM", f, &arr(t.lambda_nm.clone())));
    for (c, ch) in ["R", "G", "B"].iter().enumerate() {
        s.push_str(&lang.const_array(
            &format!("DISP_WEIGHT_{ch}"),
            f,
            &arr(t.rgb.iter().map(|w| w[c]).collect()),
        ));
    }
    s.push_str("\n// Number of wavelength samples.\n");
    s.push_str(&lang.fn_head("disp_sample_count", &[], ix));
    s.push_str("    return DISP_N_SAMPLES;\n}\n\n");
    s.push_str(
        "// Sample i (past the end: the last one): xyz = linear RGB weight, w = lambda in nm.\n",
    );
    s.push_str(&lang.fn_head("disp_sample", &[lang.param("i", ix)], &v4));
    let j = match lang {
        ShaderLanguage::Wgsl => "min(i, DISP_N_SAMPLES - 1u)".to_string(),
        ShaderLanguage::Glsl => "clamp(i, 0, DISP_N_SAMPLES - 1)".to_string(),
    };
    s.push_str(&lang.binding("j", ix, &j));
    for (local, c) in [
        ("lam", "DISP_LAMBDA_NM"),
        ("wr", "DISP_WEIGHT_R"),
        ("wg", "DISP_WEIGHT_G"),
        ("wb", "DISP_WEIGHT_B"),
    ] {
        s.push_str(&lang.local_array(local, f, n, c));
    }
    s.push_str(&format!(
        "    return {v4}(wr[j], wg[j], wb[j], lam[j]);\n}}\n\n"
    ));
    s.push_str("// Refractive index at lambda_nm (nm), the preset's fitted model as lumifit evaluates it.\n");
    s.push_str(&lang.fn_head("disp_ior", &[lang.param("lambda_nm", f)], f));
    s.push_str(&lang.binding("l", f, "lambda_nm * 0.001"));
    s.push_str(&lang.binding("l2", f, "l * l"));
    let c = &t.coefficients;
    match t.kind {
        IorKind::Cauchy => {
            s.push_str(&lang.binding("inv", f, "1.0 / l2"));
            let mut e = plit(c[c.len() - 1]);
            for ci in c.iter().rev().skip(1) {
                e = format!("({e}) * inv + {}", plit(*ci));
            }
            s.push_str(&format!("    return {e};\n}}\n"));
        }
        IorKind::Sellmeier => {
            let terms: Vec<String> = c
                .chunks_exact(2)
                .map(|bc| format!("{} * l2 / (l2 - {})", plit(bc[0]), plit(bc[1])))
                .collect();
            s.push_str(&lang.binding("sum", f, &terms.join(" + ")));
            s.push_str("    return sqrt(1.0 + sum);\n}\n");
        }
    }
    s
}

/// Afterimage: `afterimage_luminance`, `afterimage_xy`, `afterimage_curve_lab`, `afterimage_at`
/// (and `afterimage_dark_weight` when the section records Eq. 7).
pub(super) fn afterimage(lang: ShaderLanguage, name: &str, t: &AfterimageTwin) -> String {
    let (f, ix) = (lang.scalar(), lang.index());
    let (v2, v3) = (lang.vec(2), lang.vec(3));
    let n = t.table_x.len();
    let vec2l = |a: f32, b: f32| format!("{v2}({}, {})", lit(a), lit(b));
    let vec3l = |v: [f32; 3]| format!("{v3}({}, {}, {})", lit(v[0]), lit(v[1]), lit(v[2]));
    let mut s = format!(
        "// lumifit afterimage snippet for preset '{}' (lumifit.material/1), {}.\n\
         // Mikamo 2013 per pixel: Eq. 3 luminance, Table 1 chromaticity (uniform Catmull-Rom),\n\
         // Eq. 4-6 (L_A = L_M Z, a_A = a_M Z + tau k da, b_A = b_M Z + tau k db) and the gamut\n\
         // correction of 3.7, in linear sRGB with display white Y = 1 (Lab white D65, Yn = 1).\n\
         // The stimulus must already be divided by the image's brightest luminance Y and lie in\n\
         // the mask; the mask, the blur and the background (Eq. 7) are the renderer's.\n\
         // Model time t_s in s; {}.\n",
        comment_name(name),
        lang.tag(),
        if t.extrapolate {
            "after the table's end the colour is held and Eq. 3 continues"
        } else {
            "times are clamped to the table's 0-end range (the preset was made without --extrapolate)"
        }
    );
    s.push_str(&lang.constant("AI_GAMMA", f, &lit(t.gamma)));
    s.push_str(&lang.constant("AI_K", f, &lit(t.k)));
    s.push_str(&lang.constant(
        "AI_REF_XY",
        &v2,
        &vec2l(t.reference_xy[0], t.reference_xy[1]),
    ));
    s.push_str(&lang.constant("AI_WHITE", &v3, &vec3l(t.white_xyz)));
    s.push_str(&lang.constant("AI_BREAK_S", f, &lit(t.breakpoint_s)));
    s.push_str(&lang.constant("AI_SLOPE", &v2, &vec2l(t.slope_per_s[0], t.slope_per_s[1])));
    s.push_str(&lang.constant("AI_INTERCEPT", &v2, &vec2l(t.intercept[0], t.intercept[1])));
    s.push_str(&lang.constant("AI_STEP_S", f, &lit(t.step_s)));
    s.push_str(&lang.constant("AI_END_S", f, &lit(t.end_s())));
    s.push_str(&lang.constant("AI_L_M0", f, &lit(t.l_m0)));
    s.push_str(&lang.constant("AI_N_TABLE", ix, &lang.idx(n)));
    let items: Vec<String> = t
        .table_x
        .iter()
        .zip(&t.table_y)
        .map(|(&x, &y)| vec2l(x, y))
        .collect();
    s.push_str(&lang.const_array("AI_TABLE_XY", &v2, &items));
    // Model time.
    s.push_str("\n// Model time: >= 0");
    s.push_str(if t.extrapolate {
        ".\n"
    } else {
        ", <= AI_END_S.\n"
    });
    s.push_str(&lang.fn_head("ai_time", &[lang.param("t_s", f)], f));
    if t.extrapolate {
        s.push_str("    return max(t_s, 0.0);\n}\n\n");
    } else {
        s.push_str("    return min(max(t_s, 0.0), AI_END_S);\n}\n\n");
    }
    s.push_str("// Eq. 3: Y_M(t) (display white = 1).\n");
    s.push_str(&lang.fn_head("afterimage_luminance", &[lang.param("t_s", f)], f));
    s.push_str(&lang.binding("t", f, "ai_time(t_s)"));
    s.push_str(
        "    if (t > AI_BREAK_S) {\n        return exp(AI_SLOPE.y * t + AI_INTERCEPT.y);\n    }\n",
    );
    s.push_str("    return exp(AI_SLOPE.x * t + AI_INTERCEPT.x);\n}\n\n");
    s.push_str("// Table 1: (x_M, y_M)(t), uniform Catmull-Rom, phantom ends 2 P0 - P1.\n");
    s.push_str(&lang.fn_head("afterimage_xy", &[lang.param("t_s", f)], &v2));
    s.push_str(&lang.binding("sc", f, "ai_time(t_s) / AI_STEP_S"));
    let i_expr = match lang {
        ShaderLanguage::Wgsl => format!("min(u32(floor(sc)), {})", "AI_N_TABLE - 2u"),
        ShaderLanguage::Glsl => "min(int(floor(sc)), AI_N_TABLE - 2)".to_string(),
    };
    s.push_str(&lang.binding("i", ix, &i_expr));
    s.push_str(&lang.binding("u", f, &format!("sc - {}", lang.cast_float("i"))));
    s.push_str(&lang.local_array("tab", &v2, n, "AI_TABLE_XY"));
    let one = lang.idx(1);
    let two = lang.idx(2);
    s.push_str(&lang.binding("p1", &v2, "tab[i]"));
    s.push_str(&lang.binding("p2", &v2, &format!("tab[i + {one}]")));
    s.push_str(&lang.var(
        "p0",
        &v2,
        &format!("2.0 * tab[{}] - tab[{}]", lang.idx(0), one),
    ));
    s.push_str(&format!(
        "    if (i > {}) {{\n        p0 = tab[i - {one}];\n    }}\n",
        lang.idx(0)
    ));
    s.push_str(&lang.var(
        "p3",
        &v2,
        &format!("2.0 * tab[{}] - tab[{}]", lang.idx(n - 1), lang.idx(n - 2)),
    ));
    s.push_str(&format!(
        "    if (i + {two} < AI_N_TABLE) {{\n        p3 = tab[i + {two}];\n    }}\n"
    ));
    s.push_str(
        "    return 0.5 * (2.0 * p1\n        + (-p0 + p2) * u\n        + (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3) * u * u\n        + (-p0 + 3.0 * p1 - 3.0 * p2 + p3) * u * u * u);\n}\n\n",
    );
    // Lab helpers.
    s.push_str("// CIE 1976 f and its inverse (Yn = 1).\n");
    s.push_str(&lang.fn_head("ai_lab_f", &[lang.param("r", f)], f));
    s.push_str(&format!(
        "    if (r > {}) {{\n        return pow(r, {});\n    }}\n    return {} * r + {};\n}}\n\n",
        lit(216.0f32 / 24389.0),
        lit(1.0f32 / 3.0),
        lit(841.0f32 / 108.0),
        lit(16.0f32 / 116.0)
    ));
    s.push_str(&lang.fn_head("ai_lab_finv", &[lang.param("fv", f)], f));
    s.push_str(&format!(
        "    if (fv > {}) {{\n        return fv * fv * fv;\n    }}\n    return (fv - {}) * {};\n}}\n\n",
        lit(24.0f32 / 116.0),
        lit(16.0f32 / 116.0),
        lit(108.0f32 / 841.0)
    ));
    s.push_str(&lang.fn_head("ai_lab", &[lang.param("c", &v3)], &v3));
    for (v, ch) in [("fx", "x"), ("fy", "y"), ("fz", "z")] {
        s.push_str(&lang.binding(v, f, &format!("ai_lab_f(c.{ch} / AI_WHITE.{ch})")));
    }
    s.push_str(&format!(
        "    return {v3}(116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz));\n}}\n\n"
    ));
    s.push_str(&lang.fn_head("ai_xyz", &[lang.param("c", &v3)], &v3));
    s.push_str(&lang.binding("fy", f, "(c.x + 16.0) / 116.0"));
    s.push_str(&lang.binding("fx", f, "c.y / 500.0 + fy"));
    s.push_str(&lang.binding("fz", f, "fy - c.z / 200.0"));
    s.push_str(&format!(
        "    return {v3}(AI_WHITE.x * ai_lab_finv(fx), AI_WHITE.y * ai_lab_finv(fy), AI_WHITE.z * ai_lab_finv(fz));\n}}\n\n"
    ));
    let mat = |m: &[[f32; 3]; 3]| {
        let row = |r: usize| {
            format!(
                "{} * c.x + {} * c.y + {} * c.z",
                plit(m[r][0]),
                plit(m[r][1]),
                plit(m[r][2])
            )
        };
        format!(
            "    return {v3}(\n        {},\n        {},\n        {}\n    );\n}}\n\n",
            row(0),
            row(1),
            row(2)
        )
    };
    s.push_str(
        "// The display's sRGB <-> XYZ matrices (sRGB primaries' NPM, D65, and its inverse).\n",
    );
    s.push_str(&lang.fn_head("ai_to_xyz", &[lang.param("c", &v3)], &v3));
    s.push_str(&mat(&t.to_xyz));
    s.push_str(&lang.fn_head("ai_to_rgb", &[lang.param("c", &v3)], &v3));
    s.push_str(&mat(&t.to_rgb));
    s.push_str("// (L_M, a_M, b_M)(t): Lab of (x_M, y_M, Y_M).\n");
    s.push_str(&lang.fn_head("afterimage_curve_lab", &[lang.param("t_s", f)], &v3));
    s.push_str(&lang.binding("yy", f, "afterimage_luminance(t_s)"));
    s.push_str(&lang.binding("xy", &v2, "afterimage_xy(t_s)"));
    s.push_str(&format!(
        "    return ai_lab({v3}(xy.x * yy / xy.y, yy, (1.0 - xy.x - xy.y) * yy / xy.y));\n}}\n\n"
    ));
    s.push_str("// The afterimage (linear sRGB) a normalised stimulus leaves at model time t_s.\n");
    s.push_str(&lang.fn_head(
        "afterimage_at",
        &[lang.param("t_s", f), lang.param("rgb_stimulus", &v3)],
        &v3,
    ));
    s.push_str(&lang.binding(
        "c_on",
        &v3,
        &format!("ai_to_xyz(max(rgb_stimulus, {v3}(0.0)))"),
    ));
    s.push_str(&lang.binding("y", f, "c_on.y"));
    s.push_str(&format!(
        "    if (!(y > 0.0)) {{\n        return {v3}(0.0);\n    }}\n"
    ));
    s.push_str(&lang.binding("lab_on", &v3, "ai_lab(c_on)"));
    s.push_str(&lang.binding(
        "lab_ref",
        &v3,
        &format!("ai_lab({v3}(AI_REF_XY.x * y / AI_REF_XY.y, y, (1.0 - AI_REF_XY.x - AI_REF_XY.y) * y / AI_REF_XY.y))"),
    ));
    s.push_str(&lang.binding("zz", f, "pow(max(lab_on.x / 100.0, 0.0), AI_GAMMA)"));
    s.push_str(&lang.binding("da", f, "lab_on.y - lab_ref.y"));
    s.push_str(&lang.binding("db", f, "lab_on.z - lab_ref.z"));
    s.push_str(&lang.binding("m", &v3, "afterimage_curve_lab(t_s)"));
    s.push_str(&lang.binding("tk", f, "m.x / AI_L_M0 * AI_K"));
    s.push_str(&lang.binding(
        "lab_a",
        &v3,
        &format!("{v3}(m.x * zz, m.y * zz + tk * da, m.z * zz + tk * db)"),
    ));
    s.push_str(&lang.binding("c_a", &v3, "ai_xyz(lab_a)"));
    s.push_str(&lang.binding("y_goal", f, "max(c_a.y, 0.0)"));
    s.push_str(&lang.binding("rgb_a", &v3, "ai_to_rgb(c_a)"));
    let all_pos = match lang {
        ShaderLanguage::Wgsl => format!("all(rgb_a >= {v3}(0.0))"),
        ShaderLanguage::Glsl => format!("all(greaterThanEqual(rgb_a, {v3}(0.0)))"),
    };
    s.push_str(&format!(
        "    if ({all_pos}) {{\n        return rgb_a;\n    }}\n"
    ));
    s.push_str(&lang.binding("cl", &v3, &format!("max(rgb_a, {v3}(0.0))")));
    let m = &t.to_xyz;
    s.push_str(&lang.binding(
        "cy",
        f,
        &format!(
            "{} * cl.x + {} * cl.y + {} * cl.z",
            plit(m[1][0]),
            plit(m[1][1]),
            plit(m[1][2])
        ),
    ));
    s.push_str(&format!(
        "    if (cy > 0.0) {{\n        return cl * (y_goal / cy);\n    }}\n    return {v3}(0.0);\n}}\n"
    ));
    if let Some([c, tt]) = t.dark {
        s.push_str("\n// Eq. 7: weight of the background's linear RGB at model time t_s.\n");
        s.push_str(&lang.fn_head("afterimage_dark_weight", &[lang.param("t_s", f)], f));
        s.push_str(&format!(
            "    return 1.0 - (1.0 - {}) * exp(-ai_time(t_s) / {});\n}}\n",
            plit(c),
            plit(tt)
        ));
    }
    s
}
