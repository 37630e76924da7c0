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
