//! `lumifit demo`: every working pipeline end to end on synthesised or bundled data (see
//! [`lumifit::pipeline::demo`]); all outputs are staged and committed together, with an
//! `index.html` that shows every plot and links every preset.

use anyhow::Result;
use lumifit::colorimetry::summary::srgb_hex;
use lumifit::io::Outputs;
use lumifit::pipeline::demo::{run_demo, StageReport};

use super::emit;
use crate::args::DemoArgs;

/// Runs the demo, writing into `args.out` (created at the end, with everything else, only when
/// every stage succeeded). One progress line per stage goes to standard error.
pub fn run(args: &DemoArgs) -> Result<()> {
    let started = std::time::Instant::now();
    let mut outputs = Outputs::new();
    outputs.declare_dir("--out", &args.out)?;
    let command = format!("lumifit demo --out {}", args.out.display());
    // A closed standard error (`lumifit demo 2>&1 | head`) must not stop the run.
    let progress = |s: &StageReport| {
        use std::io::Write;
        let _ = writeln!(
            std::io::stderr(),
            "[{:>6.2} s] {:<10} {}",
            s.seconds,
            s.key,
            s.summary
        );
    };
    let report = run_demo(&args.out, &command, &mut outputs, &progress)?;
    let written = outputs.commit()?;
    let mut text =
        String::from("lumifit demo — ColorChecker N Ohta under D65 (CIE 1931 2°, ASTM E308)\n");
    text.push_str(&format!(
        "{:>3}  {:<21} {:>7} {:>7} {:>7}   {:>7}\n",
        "#", "patch", "L*", "a*", "b*", "sRGB"
    ));
    for r in &report.colorchecker_d65 {
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
    text.push('\n');
    for s in &report.stages {
        text.push_str(&format!(
            "{:<10} {:>6.2} s  {}\n",
            s.key, s.seconds, s.summary
        ));
    }
    text.push_str(&format!(
        "\nwrote {} files in {:.1} s; open {}",
        written.len(),
        started.elapsed().as_secs_f64(),
        args.out.join("index.html").display()
    ));
    emit(&text)
}
