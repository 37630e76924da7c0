//! Helpers shared by the tests that run the `lumifit` binary as a user would.
//!
//! Each test crate uses only some of these, hence the `dead_code` allowance.
#![allow(dead_code)]

pub mod jiang;
pub mod lvf_geometry;
pub mod tolerances;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Runs the binary with `args` and collects its output.
pub fn lumifit(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_lumifit"))
        .args(args)
        .output()
        .expect("the lumifit binary runs")
}

/// Standard error as text.
pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).to_string()
}

/// Exit code 2 and every fragment in standard error.
pub fn assert_exit2_mentions(o: &Output, fragments: &[&str]) {
    let e = stderr(o);
    assert_eq!(
        o.status.code(),
        Some(2),
        "expected exit code 2, stderr: {e}"
    );
    for f in fragments {
        assert!(e.contains(f), "stderr lacks '{f}': {e}");
    }
}

/// [`assert_exit2_mentions`], and no panic message anywhere in standard error.
pub fn assert_rejected(o: &Output, fragments: &[&str]) {
    assert_exit2_mentions(o, fragments);
    let e = stderr(o);
    assert!(!e.contains("panicked"), "panic: {e}");
}

/// Writes `bytes` to `dir/name` and returns the path.
pub fn write(dir: &Path, name: &str, bytes: impl AsRef<[u8]>) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, bytes).expect("write test input");
    p
}

/// `dir/name` as a string argument.
pub fn p(dir: &Path, name: &str) -> String {
    dir.join(name).to_string_lossy().to_string()
}

/// `synth lvf-hg` with its defaults and `seed` into `dir`: `hg.tiff` and its `truth.json`.
pub fn synth_default_lamp(dir: &Path, seed: &str) {
    let o = lumifit(&[
        "synth",
        "lvf-hg",
        "--out",
        &p(dir, "hg.tiff"),
        "--truth",
        &p(dir, "truth.json"),
        "--seed",
        seed,
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
}

/// A JSON file read and parsed (the test fails naming it when it cannot be).
pub fn read_json(path: impl AsRef<Path>) -> serde_json::Value {
    let p = path.as_ref();
    let bytes = std::fs::read(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
    serde_json::from_slice(&bytes).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

/// The signed error of an lvf.json's map at the true 400 and 700 nm positions of a `synth
/// lvf-hg --truth` file: λ(px_at_400) − 400 and λ(px_at_700) − 700 (λ(px) = Σ cᵢ·pxⁱ).
pub fn lvf_map_errors(lvf: &serde_json::Value, truth: &serde_json::Value) -> [f64; 2] {
    let c: Vec<f64> = lvf["map"]["coefficients"]
        .as_array()
        .expect("lvf.json map.coefficients")
        .iter()
        .map(|v| v.as_f64().expect("a number"))
        .collect();
    let lam = |px: f64| c.iter().rev().fold(0.0, |acc, ci| acc * px + ci);
    [("px_at_400", 400.0), ("px_at_700", 700.0)]
        .map(|(key, nm)| lam(truth[key].as_f64().expect("truth px_at_400/700")) - nm)
}

/// Serialises the runs of `scripts/validate_gltf.sh` within a test binary: its first run installs
/// the validator with `npm ci`, which must not race.
static GLTF_VALIDATOR: std::sync::Mutex<()> = std::sync::Mutex::new(());

/// Runs the Khronos glTF validator (`scripts/validate_gltf.sh`) on `files` and returns its report;
/// `None`, with a SKIPPED message, when node is not installed. Fails when the script fails (any
/// file with an error).
pub fn khronos_validator<P: AsRef<std::ffi::OsStr>>(files: &[P]) -> Option<String> {
    if Command::new("node").arg("--version").output().is_err() {
        eprintln!("SKIPPED: node is not installed; the Khronos glTF validator did not run");
        return None;
    }
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("scripts/validate_gltf.sh");
    let _one = GLTF_VALIDATOR.lock().unwrap_or_else(|e| e.into_inner());
    let o = Command::new("bash")
        .arg(script)
        .args(files)
        .output()
        .expect("bash runs");
    let report = String::from_utf8_lossy(&o.stdout).to_string();
    assert!(o.status.success(), "validator: {report}{}", stderr(&o));
    Some(report)
}

/// `lumifit synth lvf-hg EXTRA… --out DIR/hg.tiff --truth DIR/truth.json --seed SEED`, which must
/// succeed; returns the image and truth paths.
pub fn synth_hg(dir: &Path, extra: &[&str], seed: u64) -> (String, String) {
    let (img, truth) = (p(dir, "hg.tiff"), p(dir, "truth.json"));
    let seed = seed.to_string();
    let mut args = vec!["synth", "lvf-hg"];
    args.extend_from_slice(extra);
    args.extend_from_slice(&["--out", &img, "--truth", &truth, "--seed", &seed]);
    let o = lumifit(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    (img, truth)
}
