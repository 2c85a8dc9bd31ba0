//! `km reproduce` never leaves a half-written or mixed output directory:
//! a whole run is staged beside the target and renamed into place when
//! complete (`docs/limits.md` §7), and a directory that is not an earlier
//! run's is never replaced.

use std::path::PathBuf;

use km_bench::{ReproduceOptions, reproduce};

fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("km-bench-out-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Entries of `dir` whose name marks a staging directory.
fn staging_left(dir: &std::path::Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.contains(".partial-"))
        .collect()
}

#[test]
fn a_second_run_replaces_the_first_whole_and_leaves_no_staging() {
    let root = temp_dir("replace");
    let out = root.join("out");
    reproduce(&ReproduceOptions::tiny(&out)).unwrap();
    assert!(out.join("report.md").is_file());
    assert!(out.join(km_bench::reproduce::MANIFEST).is_file());
    // A file of the first run only: gone after the second (no mixing of runs).
    std::fs::write(out.join("stray.csv"), "from an earlier run").unwrap();
    let opts = ReproduceOptions { seed: 2, ..ReproduceOptions::tiny(&out) };
    reproduce(&opts).unwrap();
    assert!(out.join("report.md").is_file());
    assert!(!out.join("stray.csv").exists(), "files of the earlier run were mixed in");
    let manifest = std::fs::read_to_string(out.join(km_bench::reproduce::MANIFEST)).unwrap();
    assert!(manifest.contains("seed 2"), "{manifest}");
    assert!(staging_left(&root).is_empty(), "{:?}", staging_left(&root));
    let _ = std::fs::remove_dir_all(&root);
}

#[test]
fn a_directory_that_is_not_a_run_is_refused_before_any_work_and_left_alone() {
    let root = temp_dir("foreign");
    let out = root.join("thesis");
    std::fs::create_dir_all(&out).unwrap();
    std::fs::write(out.join("chapter1.tex"), "precious").unwrap();
    let err = reproduce(&ReproduceOptions::tiny(&out)).unwrap_err().to_string();
    assert!(err.contains("not the output of an earlier"), "{err}");
    assert_eq!(std::fs::read_to_string(out.join("chapter1.tex")).unwrap(), "precious");
    assert!(staging_left(&root).is_empty());
    // A regular file at the target is refused too.
    let file = root.join("notes.txt");
    std::fs::write(&file, "mine").unwrap();
    assert!(reproduce(&ReproduceOptions::tiny(&file)).is_err());
    assert_eq!(std::fs::read_to_string(&file).unwrap(), "mine");
    let _ = std::fs::remove_dir_all(&root);
}
