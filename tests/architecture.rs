//! The house rules of docs/architecture.md, checked by scanning `src/`:
//!
//! - a module may refer only to modules of lower layers (`crate::<module>`, also inside grouped
//!   imports `use crate::{a::X, b}`), never to its own layer's siblings or above;
//! - domains (L2) do no file I/O and no printing (outside their `#[cfg(test)]` modules);
//! - the binary parses no CSV, JSON or YAML itself and opens no file (readers live in
//!   `io`/`preset`; it may hand bytes from `io::read_input` to them, e.g. for provenance).

use std::path::{Path, PathBuf};

/// Layer of each top-level module. Fractions order the documented exceptions within a layer
/// (within L0: error, then math and table, then calib; colorimetry above spectrum; preset and
/// plot above io).
fn layer(module: &str) -> Option<f64> {
    Some(match module {
        "error" => 0.0,
        "limits" => 0.05,
        "math" | "table" => 0.1,
        "calib" => 0.2,
        "spectrum" | "fit" | "capture" => 1.0,
        "colorimetry" => 1.1,
        "render" => 1.2,
        "lvf" | "recovery" | "phosphor" | "fluor" | "dispersion" | "photometry" | "afterimage" => {
            2.0
        }
        "io" => 3.0,
        "preset" | "plot" => 3.1,
        "pipeline" => 3.2,
        _ => return None,
    })
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let p = entry.unwrap().path();
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|e| e == "rs") {
            out.push(p);
        }
    }
}

/// Every `crate::<module>` reference with its 1-based line, including the top-level names of
/// grouped imports (`use crate::{error::Error, math::{a, b}};` yields `error` and `math`).
fn crate_references(text: &str) -> Vec<(usize, String)> {
    let ident = |s: &str| -> String {
        s.chars()
            .take_while(|c| c.is_alphanumeric() || *c == '_')
            .collect()
    };
    // Comments (doc links such as [`crate::io`]) are not dependencies: drop them, keeping
    // the line structure so line numbers stay right.
    let code: String = text
        .lines()
        .map(|l| l.split("//").next().unwrap_or(""))
        .collect::<Vec<_>>()
        .join("\n");
    let text = code.as_str();
    let line_of = |pos: usize| 1 + text[..pos].matches('\n').count();
    let mut out = Vec::new();
    let mut from = 0;
    while let Some(rel) = text[from..].find("crate::") {
        let at = from + rel;
        let rest = &text[at + 7..];
        from = at + 7;
        if let Some(group) = rest.strip_prefix('{') {
            // Top-level items of the group: split at depth-0 commas.
            let mut depth = 0usize;
            let mut item_start = 0usize;
            let mut items = Vec::new();
            for (i, c) in group.char_indices() {
                match c {
                    '{' => depth += 1,
                    '}' if depth == 0 => {
                        items.push(&group[item_start..i]);
                        break;
                    }
                    '}' => depth -= 1,
                    ',' if depth == 0 => {
                        items.push(&group[item_start..i]);
                        item_start = i + 1;
                    }
                    _ => {}
                }
            }
            for item in items {
                let name = ident(item.trim_start());
                if !name.is_empty() && name != "self" {
                    out.push((line_of(at), name));
                }
            }
        } else {
            let name = ident(rest);
            if !name.is_empty() {
                out.push((line_of(at), name));
            }
        }
    }
    out
}

/// The text of a source file without its `#[cfg(test)]` modules (from the attribute to the end
/// of the file, which is where this crate keeps them).
fn without_tests(text: &str) -> &str {
    match text.find("#[cfg(test)]") {
        Some(pos) => &text[..pos],
        None => text,
    }
}

fn src_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("src")
}

#[test]
fn grouped_imports_are_read_by_the_layering_scan() {
    let refs = crate_references(
        "use crate::{error::{Error, Result}, math::linalg, self};\nlet x = crate::fit::qr::Qr::new();\n/// see [`crate::io`]\n",
    );
    let names: Vec<_> = refs.iter().map(|(l, n)| (*l, n.as_str())).collect();
    assert_eq!(names, vec![(1, "error"), (1, "math"), (2, "fit")]);
}

#[test]
fn domains_do_no_file_io_and_no_printing() {
    let domains = [
        "lvf",
        "recovery",
        "phosphor",
        "fluor",
        "dispersion",
        "photometry",
        "afterimage",
    ];
    let forbidden = [
        "std::fs",
        "fs::read",
        "fs::write",
        "File::open",
        "File::create",
        "println!",
        "eprintln!",
        "print!(",
        "eprint!(",
        "dbg!(",
        "std::io::stdout",
        "std::io::stderr",
        "std::io::stdin",
    ];
    let mut violations = Vec::new();
    let mut scanned = 0;
    for d in domains {
        let mut files = Vec::new();
        let dir = src_dir().join(d);
        if dir.is_dir() {
            rust_files(&dir, &mut files);
        }
        let single = src_dir().join(format!("{d}.rs"));
        if single.is_file() {
            files.push(single);
        }
        for f in files {
            scanned += 1;
            let text = std::fs::read_to_string(&f).unwrap();
            for (n, line) in without_tests(&text).lines().enumerate() {
                let code = line.split("//").next().unwrap_or("");
                for pat in forbidden {
                    if code.contains(pat) {
                        violations.push(format!("{}:{}: `{pat}` in a domain", f.display(), n + 1));
                    }
                }
            }
        }
    }
    assert!(scanned >= 4, "only {scanned} domain files scanned");
    assert!(
        violations.is_empty(),
        "domains must be pure (readers in io, printing in the binary):\n{}",
        violations.join("\n")
    );
}

#[test]
fn the_binary_parses_no_csv_or_json_itself() {
    // Readers live in `io`/`preset`; the binary hands paths or bytes to them. Flag values
    // (`--roi 0,0,8,8`) are split in the binary, which is argument parsing, not a file format.
    let forbidden = [
        "serde_json::from_",
        "parse_numeric_csv",
        "as_text(",
        "csv::Reader",
        "csv::ReaderBuilder",
        "std::fs::read",
        "fs::read_to_string",
        "File::open",
        "yaml_rust2",
        "serde_yaml",
    ];
    let mut files = Vec::new();
    rust_files(&src_dir().join("bin"), &mut files);
    assert!(
        files.len() >= 5,
        "only {} binary files scanned",
        files.len()
    );
    let mut violations = Vec::new();
    for f in files {
        let text = std::fs::read_to_string(&f).unwrap();
        for (n, line) in without_tests(&text).lines().enumerate() {
            let code = line.split("//").next().unwrap_or("");
            for pat in forbidden {
                if code.contains(pat) {
                    violations.push(format!("{}:{}: `{pat}`", f.display(), n + 1));
                }
            }
        }
    }
    assert!(
        violations.is_empty(),
        "the binary parses files itself (move the reader to io or preset):\n{}",
        violations.join("\n")
    );
}

#[test]
fn modules_import_only_from_lower_layers() {
    let src = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    let mut violations = Vec::new();
    let mut checked = 0;
    for f in files {
        let rel = f.strip_prefix(&src).unwrap();
        let first = rel
            .components()
            .next()
            .unwrap()
            .as_os_str()
            .to_string_lossy()
            .to_string();
        if first == "bin" || first == "lib.rs" {
            continue;
        }
        let module = first.trim_end_matches(".rs").to_string();
        let Some(own) = layer(&module) else {
            violations.push(format!(
                "{}: module '{module}' has no layer in docs/architecture.md",
                rel.display()
            ));
            continue;
        };
        let text = std::fs::read_to_string(&f).unwrap();
        for (n, target) in crate_references(&text) {
            {
                if target == module {
                    continue;
                }
                checked += 1;
                match layer(&target) {
                    Some(l) if l < own => {}
                    Some(_) => violations.push(format!(
                        "{}:{}: '{module}' (layer {own}) uses 'crate::{target}' of the same or a higher layer",
                        rel.display(),
                        n
                    )),
                    None => {}
                }
            }
        }
    }
    assert!(
        violations.is_empty(),
        "layering violations:\n{}",
        violations.join("\n")
    );
    assert!(
        checked > 10,
        "the scan found only {checked} cross-module references; is it reading src/?"
    );
}
