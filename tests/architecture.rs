//! The layering of docs/architecture.md, checked by scanning `src/`: a module may refer only to
//! modules of lower layers (`crate::<module>`), never to its own layer's siblings or above.

use std::path::{Path, PathBuf};

/// Layer of each top-level module. Fractions order the documented exceptions within a layer
/// (within L0: error, then math and table, then calib; colorimetry above spectrum; preset and
/// plot above io).
fn layer(module: &str) -> Option<f64> {
    Some(match module {
        "error" => 0.0,
        "math" | "table" | "limits" => 0.1,
        "calib" => 0.2,
        "spectrum" | "fit" | "capture" => 1.0,
        "colorimetry" => 1.1,
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
        for (n, line) in text.lines().enumerate() {
            let mut rest = line;
            while let Some(pos) = rest.find("crate::") {
                rest = &rest[pos + 7..];
                let target: String = rest
                    .chars()
                    .take_while(|c| c.is_alphanumeric() || *c == '_')
                    .collect();
                if target.is_empty() || target == module {
                    continue;
                }
                checked += 1;
                match layer(&target) {
                    Some(l) if l < own => {}
                    Some(_) => violations.push(format!(
                        "{}:{}: '{module}' (layer {own}) uses 'crate::{target}' of the same or a higher layer",
                        rel.display(),
                        n + 1
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
