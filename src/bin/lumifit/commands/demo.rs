//! `lumifit demo`: the main job on the bundled defaults.
//!
//! Stage 1 (foundation): colorimetry of the 24 ColorChecker patches (colour's N Ohta reflectances,
//! embedded from `calib/`) under D65 and A — a CSV table, a PNG chart of the spectra and rendered
//! swatches, and one material preset per patch, each read back to prove the round trip. All
//! outputs are staged and committed together.

use std::path::Path;

use anyhow::Result;
use lumifit::calib;
use lumifit::colorimetry::summary::{patch_colours, patch_table_csv, srgb_hex, PatchColour};
use lumifit::colorimetry::{Illuminant, Observer, StandardObserver, XyzMethod};
use lumifit::io::Outputs;
use lumifit::plot::{colorchecker_chart_png, SwatchPatch};
use lumifit::preset::{
    parse_preset, to_json_string, MaterialPreset, Preset, Provenance, ReflectanceSection,
};
use lumifit::spectrum::Spectrum;

use super::emit;
use crate::args::DemoArgs;

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

/// Runs the demo, writing into `args.out` (created at the end, with everything else, only when
/// every output was produced).
pub fn run(args: &DemoArgs) -> Result<()> {
    let out = &args.out;
    let mut outputs = Outputs::new();
    outputs.declare_dir("--out", out)?;
    let presets_dir = out.join("presets");

    let table = calib::colorchecker_n_ohta();
    let observer = Observer::standard(StandardObserver::Cie1931_2)?;
    let method = XyzMethod::AstmE308;
    let patches: Vec<Spectrum> = (1..table.header.len())
        .map(|c| Spectrum::from_table(table, c).map(|s| s.with_name(table.header[c].clone())))
        .collect::<lumifit::Result<_>>()?;
    let illuminants = ILLUMINANTS
        .iter()
        .map(|n| Illuminant::standard(n))
        .collect::<lumifit::Result<Vec<_>>>()?;
    let rows = patch_colours(&patches, observer, &illuminants, method)?;
    let csv = patch_table_csv(&rows, observer.name(), method.cli_name());
    let table_path = out.join("colorchecker_colorimetry.csv");
    outputs.stage(&table_path, csv.as_bytes())?;

    // Chart.
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
    let chart_path = out.join("colorchecker.png");
    let chart = colorchecker_chart_png(
        "ColorChecker (N Ohta) — CIE 1931 2°, ASTM E308, sRGB (CAT02 to D65)",
        &ILLUMINANTS.map(String::from),
        &swatches,
    )?;
    outputs.stage(&chart_path, &chart)?;

    // One reflectance preset per patch, each read back.
    let command = format!("lumifit demo --out {}", out.display());
    for (i, sd) in patches.iter().enumerate() {
        let preset = MaterialPreset {
            reflectance: Some(ReflectanceSection::new(
                sd.wavelengths().to_vec(),
                sd.values().to_vec(),
            )),
            ..MaterialPreset::new(
                format!("ColorChecker N Ohta {:02} {}", i + 1, sd.name()),
                Provenance::new(
                    &command,
                    &[(
                        "calib/colorchecker_n_ohta.csv (embedded)",
                        calib::COLORCHECKER_N_OHTA_CSV.as_bytes(),
                    )],
                ),
            )
        };
        let path = presets_dir.join(format!("{:02}_{}.json", i + 1, slug(sd.name())));
        let text = to_json_string(&preset)?;
        let back = parse_preset(text.as_bytes(), &path.display().to_string())?;
        if back != Preset::Material(preset) {
            anyhow::bail!(
                "{}: the preset read back differs from the one written",
                path.display()
            );
        }
        outputs.stage(&path, text.as_bytes())?;
    }
    outputs.commit()?;

    print_summary(&rows[..n], out, &table_path, &chart_path, &presets_dir)
}

fn print_summary(
    d65: &[PatchColour],
    out: &Path,
    table: &Path,
    chart: &Path,
    presets: &Path,
) -> Result<()> {
    let mut text =
        String::from("lumifit demo — ColorChecker N Ohta under D65 (CIE 1931 2°, ASTM E308)\n");
    text.push_str(&format!(
        "{:>3}  {:<21} {:>7} {:>7} {:>7}   {:>7}\n",
        "#", "patch", "L*", "a*", "b*", "sRGB"
    ));
    for r in d65 {
        text.push_str(&format!(
            "{:>3}  {:<21} {:>7.2} {:>7.2} {:>7.2}   {}\n",
            r.index,
            r.name,
            r.lab[0],
            r.lab[1],
            r.lab[2],
            srgb_hex(r.srgb)
        ));
    }
    text.push_str(&format!("\nwrote {}\n", table.display()));
    text.push_str(&format!("wrote {}\n", chart.display()));
    text.push_str(&format!(
        "wrote {} (24 material presets, each read back)\n",
        presets.display()
    ));
    text.push_str(&format!("all outputs in {}", out.display()));
    emit(&text)
}
