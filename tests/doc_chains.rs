//! The workflows of `docs/cli.md`, run verbatim: every fenced block whose info string is
//! `sh chain=NAME` is extracted from the doc and run by `sh -e` in an empty folder, with
//! `lumifit` a shell function calling the binary under test. Any command that exits non-zero
//! fails the test and prints the command trace, so a doc edit that breaks a chain fails CI.

use std::path::Path;
use std::process::Command;

/// The pipelines that must each have a documented chain.
const PIPELINES: [&str; 8] = [
    "lvf",
    "phos",
    "fluor",
    "dispersion",
    "afterimage",
    "light",
    "colour",
    "demo",
];

/// (name, script) of every `sh chain=NAME` block of `docs/cli.md`, in order.
fn chains() -> Vec<(String, String)> {
    let doc = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/cli.md"))
        .expect("docs/cli.md is readable");
    let mut out = Vec::new();
    let mut current: Option<(String, String)> = None;
    for line in doc.lines() {
        match &mut current {
            None => {
                let info = line.trim_start();
                if let Some(rest) = info.strip_prefix("```") {
                    let mut words = rest.split_whitespace();
                    if words.next() == Some("sh") {
                        if let Some(name) = words.find_map(|w| w.strip_prefix("chain=")) {
                            current = Some((name.to_string(), String::new()));
                        }
                    }
                }
            }
            Some((name, body)) => {
                if line.trim_start().starts_with("```") {
                    out.push((name.clone(), std::mem::take(body)));
                    current = None;
                } else {
                    body.push_str(line);
                    body.push('\n');
                }
            }
        }
    }
    assert!(current.is_none(), "docs/cli.md: an unclosed chain block");
    out
}

fn run_chain(name: &str) {
    let all = chains();
    let found: Vec<&(String, String)> = all.iter().filter(|(n, _)| n == name).collect();
    assert_eq!(
        found.len(),
        1,
        "docs/cli.md must hold exactly one `sh chain={name}` block"
    );
    let script = &found[0].1;
    let dir = tempfile::tempdir().unwrap();
    let started = std::time::Instant::now();
    let o = Command::new("sh")
        .arg("-e")
        .arg("-x")
        .arg("-c")
        .arg(format!(
            "lumifit() {{ \"$LUMIFIT_BIN\" \"$@\"; }}\n{script}"
        ))
        .env("LUMIFIT_BIN", env!("CARGO_BIN_EXE_lumifit"))
        .current_dir(dir.path())
        .output()
        .expect("sh runs");
    let trace = String::from_utf8_lossy(&o.stderr);
    assert!(
        o.status.success(),
        "chain '{name}' of docs/cli.md failed ({}):\n{script}\n--- trace and stderr ---\n{trace}",
        o.status
    );
    eprintln!(
        "chain {name}: {} commands in {:.1} s",
        script
            .lines()
            .filter(|l| l.trim_start().starts_with("lumifit "))
            .count(),
        started.elapsed().as_secs_f64()
    );
}

#[test]
fn every_pipeline_has_one_documented_chain_and_nothing_else_is_marked() {
    let names: Vec<String> = chains().into_iter().map(|(n, _)| n).collect();
    for p in PIPELINES {
        assert_eq!(
            names.iter().filter(|n| *n == p).count(),
            1,
            "chain '{p}' in docs/cli.md: {names:?}"
        );
    }
    for n in &names {
        assert!(
            PIPELINES.contains(&n.as_str()),
            "chain '{n}' is not run by a test"
        );
    }
}

#[test]
fn a_failing_command_in_a_chain_fails_the_run() {
    // The harness itself: a chain whose command exits 2 must not pass.
    let dir = tempfile::tempdir().unwrap();
    let o = Command::new("sh")
        .arg("-e")
        .arg("-c")
        .arg("lumifit() { \"$LUMIFIT_BIN\" \"$@\"; }\nlumifit color xyz --spectrum missing.csv\necho reached")
        .env("LUMIFIT_BIN", env!("CARGO_BIN_EXE_lumifit"))
        .current_dir(dir.path())
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(!String::from_utf8_lossy(&o.stdout).contains("reached"));
}

#[test]
fn chain_lvf_runs_as_documented() {
    run_chain("lvf");
}

#[test]
fn chain_phos_runs_as_documented() {
    run_chain("phos");
}

#[test]
fn chain_fluor_runs_as_documented() {
    run_chain("fluor");
}

#[test]
fn chain_dispersion_runs_as_documented() {
    run_chain("dispersion");
}

#[test]
fn chain_afterimage_runs_as_documented() {
    run_chain("afterimage");
}

#[test]
fn chain_light_runs_as_documented() {
    run_chain("light");
}

#[test]
fn chain_colour_runs_as_documented() {
    run_chain("colour");
}

#[test]
fn chain_demo_runs_as_documented() {
    run_chain("demo");
}
