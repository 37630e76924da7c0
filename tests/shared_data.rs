//! The tests that read real measured data from `../shared/data/` skip with a message when that
//! folder is absent (a fresh clone without the shared material). In CI the folder is always
//! there, so a skip would hide a broken path: with `LUMIFIT_REQUIRE_DATA=1` (set by `.ci/run`)
//! every `../shared/data/…` path named in a test must exist, and this test fails loudly
//! naming the ones that do not.

use std::path::{Path, PathBuf};

/// Every `../shared/data/…` string literal in `tests/*.rs`, with the file that names it.
fn data_paths_named_in_tests() -> Vec<(String, String)> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests");
    let mut out = Vec::new();
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .expect("tests/ is readable")
        .map(|e| e.expect("directory entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "rs"))
        .collect();
    files.sort();
    for f in files {
        let text = std::fs::read_to_string(&f).expect("test source is text");
        let name = f.file_name().unwrap().to_string_lossy().to_string();
        let mut rest = text.as_str();
        while let Some(pos) = rest.find("\"../shared/data") {
            let lit = &rest[pos + 1..];
            let end = lit.find('"').unwrap_or(lit.len());
            let path = &lit[..end];
            // `{}` placeholders of format strings name a family of files: check the folder.
            let path = path.split('{').next().unwrap_or(path).trim_end_matches('/');
            out.push((name.clone(), path.to_string()));
            rest = &lit[end..];
        }
    }
    out
}

#[test]
fn every_shared_data_path_a_test_names_exists_when_data_is_required() {
    let named = data_paths_named_in_tests();
    assert!(
        named.len() >= 8,
        "only {} ../shared/data paths found in tests/: is the scan reading the test sources?",
        named.len()
    );
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let missing: Vec<String> = named
        .iter()
        .filter(|(_, p)| !root.join(p).exists())
        .map(|(f, p)| format!("{f}: {p}"))
        .collect();
    let required = std::env::var("LUMIFIT_REQUIRE_DATA").is_ok_and(|v| v == "1");
    if required {
        assert!(
            missing.is_empty(),
            "LUMIFIT_REQUIRE_DATA=1 but these shared data paths are absent, so the tests that read them would skip:\n{}",
            missing.join("\n")
        );
    } else if !missing.is_empty() {
        eprintln!(
            "note: {} shared data paths are absent; the tests that read them skip (set LUMIFIT_REQUIRE_DATA=1 to make this an error):\n{}",
            missing.len(),
            missing.join("\n")
        );
    }
}
