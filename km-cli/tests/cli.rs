//! The `km` command end to end: bad input is refused with a message naming the
//! key and a non-zero exit, never a panic; good input prints the contract.

use std::path::PathBuf;
use std::process::{Command, Output};

fn km(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_km")).args(args).output().expect("run km")
}

fn examples(name: &str) -> String {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..").join("examples").join(name);
    root.to_string_lossy().into_owned()
}

/// Write a scene into a fresh temporary file and return its path.
fn scene_file(tag: &str, text: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("km-cli-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(format!("{tag}.toml"));
    std::fs::write(&p, text).unwrap();
    p
}

fn assert_refused(out: &Output, names: &str) {
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "exit status success; stderr: {err}");
    assert!(err.contains(names), "stderr does not name `{names}`: {err}");
    assert!(!err.contains("panicked"), "panic text on stderr: {err}");
    assert!(out.stdout.is_empty(), "stdout not empty on error");
}

const LAYER: &str = "[[layer]]\nsigma_a = 0.1\nsigma_s = 0.4\nthickness = 1.0\n";

#[test]
fn every_bad_input_class_is_refused_by_name() {
    let cases: &[(&str, String, &str)] = &[
        (
            "negative",
            "[[layer]]\nsigma_a = -1\nsigma_s = 1\nthickness = 1\n".into(),
            "layer[1].sigma_a",
        ),
        ("g", format!("{LAYER}g = 1.0\n"), "layer[1].g"),
        ("n", format!("{LAYER}n = 0.5\n"), "layer[1].n"),
        (
            "nan",
            "[[layer]]\nsigma_a = nan\nsigma_s = 1\nthickness = 1\n".into(),
            "layer[1].sigma_a",
        ),
        ("empty", "[light]\nkind = \"diffuse\"\n".into(), "layer"),
        (
            "lengths",
            "[[layer]]\nsigma_a = [1, 2]\nsigma_s = [1, 2, 3]\nthickness = 1\n".into(),
            "layer[1].sigma_s",
        ),
        ("unknown", format!("{LAYER}colour = 3\n"), "colour"),
        (
            "both",
            "[[layer]]\nsigma_a = 1\nsigma_s = 1\ntau = 1\nalbedo = 0.5\n".into(),
            "layer[1].tau",
        ),
        ("syntax", "[[layer]\n".into(), "line 1"),
    ];
    for (tag, text, names) in cases {
        let p = scene_file(tag, text);
        for method in ["km", "multiflux", "mc", "dipole"] {
            let out = km(&["solve", p.to_str().unwrap(), "--method", method, "--json"]);
            assert_refused(&out, names);
            // The line is named too (all cases but the empty stack have one).
            if *tag != "empty" {
                assert!(String::from_utf8_lossy(&out.stderr).contains("line "), "{tag}");
            }
        }
    }
}

#[test]
fn missing_file_and_bad_flags() {
    let out = km(&["solve", "no-such-scene.toml", "--method", "km"]);
    assert_refused(&out, "no-such-scene.toml");
    let out = km(&["solve", &examples("fresnel-slab.toml"), "--method", "magic"]);
    assert_refused(&out, "magic");
}

#[test]
fn help_shows_examples() {
    for args in [vec!["--help"], vec!["solve", "--help"], vec!["check", "--help"]] {
        let out = km(&args);
        assert!(out.status.success());
        let text = String::from_utf8_lossy(&out.stdout);
        assert!(text.contains("Example"), "{args:?}: {text}");
        assert!(text.contains("km "), "{args:?}");
    }
}

#[test]
fn check_describes_channels() {
    let out = km(&["check", &examples("paint-over-primer.toml")]);
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("channels: 3 (R, G, B)"), "{text}");
}

/// `km reproduce --help` names every recipe `--only` accepts (the list in
/// the help is written by hand; the recipes are km-bench's).
#[test]
fn reproduce_help_names_every_recipe() {
    let out = km(&["reproduce", "--help"]);
    assert!(out.status.success());
    let help = String::from_utf8_lossy(&out.stdout);
    let words: Vec<&str> =
        help.split(|c: char| c.is_whitespace() || c == ',' || c == '(' || c == ')').collect();
    for (name, _) in km_bench::recipes::all() {
        assert!(words.contains(&name), "`km reproduce --help` does not name the recipe {name}");
    }
}
