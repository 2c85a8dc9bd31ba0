//! Every recipe runs at the tiny size and writes non-empty, well-formed SVG
//! and PNG files, CSV files with a header, and a report that links them.

use std::path::{Path, PathBuf};

use km_bench::{ReproduceOptions, reproduce};

/// A fresh directory under the system temporary directory.
fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("km-bench-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A small well-formedness check of XML: the document is an `<svg` root,
/// and start and end tags balance with matching names (comments,
/// declarations and self-closing tags skipped).
fn check_svg(path: &Path) {
    let text = std::fs::read_to_string(path).unwrap();
    let body = text.trim_start();
    let body = if body.starts_with("<?xml") { &body[body.find("?>").unwrap() + 2..] } else { body };
    assert!(body.trim_start().starts_with("<svg"), "{} does not start with <svg", path.display());
    let mut stack: Vec<String> = Vec::new();
    let mut rest = body;
    while let Some(i) = rest.find('<') {
        rest = &rest[i + 1..];
        let end = rest.find('>').unwrap_or_else(|| panic!("unclosed tag in {}", path.display()));
        let tag = &rest[..end];
        rest = &rest[end + 1..];
        if tag.starts_with('!') || tag.starts_with('?') || tag.ends_with('/') {
            continue;
        }
        if let Some(name) = tag.strip_prefix('/') {
            let open =
                stack.pop().unwrap_or_else(|| panic!("stray </{name}> in {}", path.display()));
            assert_eq!(open, name.trim(), "mismatched tags in {}", path.display());
        } else {
            let name = tag.split(|c: char| c.is_whitespace()).next().unwrap();
            stack.push(name.to_string());
        }
    }
    assert!(stack.is_empty(), "unclosed <{:?}> in {}", stack, path.display());
}

#[test]
fn every_recipe_writes_its_charts_at_tiny_size() {
    let dir = temp_dir("tiny");
    let summary = reproduce(&ReproduceOptions::tiny(&dir)).unwrap();
    println!("{summary}");
    assert_eq!(summary.failures(), 0, "failed recipes:\n{summary}");
    let report = std::fs::read_to_string(dir.join("report.md")).unwrap();
    let mut svgs = 0;
    for entry in std::fs::read_dir(&dir).unwrap() {
        let p = entry.unwrap().path();
        match p.extension().and_then(|e| e.to_str()) {
            Some("svg") => {
                check_svg(&p);
                svgs += 1;
                // Each SVG has its PNG twin, non-empty and with the PNG signature.
                let png = std::fs::read(p.with_extension("png")).unwrap();
                assert!(png.starts_with(b"\x89PNG\r\n\x1a\n"), "{} is not a PNG", p.display());
                // And the report links it.
                let name = p.file_name().unwrap().to_str().unwrap();
                assert!(report.contains(name), "report does not link {name}");
            }
            Some("csv") => {
                let text = std::fs::read_to_string(&p).unwrap();
                assert!(text.starts_with('#'), "{} has no header comment", p.display());
                assert!(
                    text.lines().filter(|l| !l.starts_with('#')).count() >= 2,
                    "{} has no rows",
                    p.display()
                );
            }
            _ => {}
        }
    }
    assert!(svgs > 0);
    // Every data link of the report names a CSV that exists.
    for part in report.split("[data](").skip(1) {
        let name = &part[..part.find(')').unwrap()];
        assert!(dir.join(name).is_file(), "report links missing data {name}");
    }
    // KM_BENCH_KEEP=1 keeps the output for inspection.
    if std::env::var_os("KM_BENCH_KEEP").is_none() {
        let _ = std::fs::remove_dir_all(&dir);
    } else {
        println!("output kept in {}", dir.display());
    }
}
