//! Strict flags: every method-specific flag of `km solve` and `km profile`
//! with every method, refused (exit 2, naming the flag, the method and why)
//! or honoured (accepted, and it changes the answer as it should).

use std::path::PathBuf;
use std::process::{Command, Output};

fn km(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_km")).args(args).output().expect("run km")
}

fn examples(name: &str) -> String {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..").join("examples").join(name);
    root.to_string_lossy().into_owned()
}

const METHODS: [&str; 5] = ["km", "multiflux", "direction-set", "mc", "dipole"];

/// A scene every method treats for `method` (the dipole needs a half-space).
fn scene_for(method: &str) -> String {
    examples(if method == "dipole" { "marble-half-space.toml" } else { "fresnel-slab.toml" })
}

/// Flag, two values that must give different answers where honoured
/// (`None`: the same answer, e.g. thread count), and the methods it applies to.
const FLAGS: &[(&str, &str, &str, bool, &[&str])] = &[
    ("--samples", "2000", "3000", true, &["mc"]),
    ("--seed", "1", "2", true, &["mc"]),
    ("--threads", "1", "2", false, &["mc"]),
    ("--estimator", "survival", "analog", true, &["mc"]),
    ("--streams", "4", "8", true, &["multiflux"]),
    ("--order", "1", "2", true, &["multiflux"]),
    ("--directions", "50", "100", true, &["direction-set"]),
    ("--km-mapping", "seed", "star1988", true, &["km"]),
    ("--km-model", "four-flux", "two-flux", true, &["km"]),
    // The cones change BRDF/BTDF values only (none in this scene), not R.
    ("--cone", "3", "10", false, &["mc", "multiflux"]),
    ("--fdr", "exact", "egan-hilgeman", true, &["dipole"]),
    ("--dipole", "jensen2001", "better", true, &["dipole"]),
    ("--tolerance", "1e-2", "1e-3", false, &["multiflux", "mc"]),
];

fn reflectance(out: &Output) -> f64 {
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON on stdout");
    // One channel: top-level keys; several: per channel.
    let r = &v["reflectance"];
    r.as_f64().or_else(|| r[0].as_f64()).expect("reflectance")
}

#[test]
fn every_flag_with_every_method_is_refused_or_honoured() {
    for (flag, a, b, differs, applies) in FLAGS {
        for method in METHODS {
            let scene = scene_for(method);
            let mut base = vec!["solve", scene.as_str(), "--method", method, "--json"];
            // Keep Monte Carlo runs short (except where the flag itself sets the count).
            if method == "mc" && *flag != "--samples" && *flag != "--tolerance" {
                base.extend(["--samples", "2000"]);
            }
            let run = |v: &str| {
                let mut args = base.clone();
                args.extend([*flag, v]);
                km(&args)
            };
            let out = run(a);
            let err = String::from_utf8_lossy(&out.stderr).into_owned();
            if applies.contains(&method) {
                assert!(out.status.success(), "{flag} with {method} refused: {err}");
                let (ra, rb) = (reflectance(&out), reflectance(&run(b)));
                if *differs {
                    assert!(ra != rb, "{flag} {a} and {b} give the same R = {ra} with {method}");
                } else if *flag == "--threads" {
                    // The same seed gives bit-identical results for any thread count.
                    assert_eq!(ra, rb, "{flag} changed the answer with {method}");
                }
            } else {
                assert_eq!(out.status.code(), Some(2), "{flag} with {method} accepted: {err}");
                assert!(out.stdout.is_empty());
                assert!(
                    err.contains(&format!("{flag} does not apply to --method {method}")),
                    "{flag} with {method}: {err}"
                );
                for m in *applies {
                    assert!(err.contains(m), "{flag} with {method} does not name {m}: {err}");
                }
            }
        }
    }
}

#[test]
fn tolerance_with_shard_or_samples_is_refused_with_the_recipe() {
    let scene = examples("fresnel-slab.toml");
    let out = km(&[
        "solve",
        &scene,
        "--method",
        "mc",
        "--tolerance",
        "1e-3",
        "--shard",
        "0/2",
        "--out",
        "/nonexistent/part.json",
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("--samples N --shard") && err.contains("km merge"), "{err}");
    let out = km(&["solve", &scene, "--method", "mc", "--tolerance", "1e-3", "--samples", "10"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("either --samples or --tolerance"), "{err}");
}

#[test]
fn profile_lists_and_accepts_only_its_methods() {
    let help = String::from_utf8_lossy(&km(&["profile", "--help"]).stdout).into_owned();
    assert!(help.contains("[possible values: dipole, mc]"), "{help}");
    let scene = examples("marble-half-space.toml");
    for method in ["km", "multiflux"] {
        let out = km(&["profile", &scene, "--method", method]);
        assert_eq!(out.status.code(), Some(2));
    }
    for flag in ["--samples", "--seed"] {
        let out = km(&["profile", &scene, flag, "5"]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{err}");
        assert!(err.contains(&format!("{flag} does not apply to --method dipole")), "{err}");
        let small = ["--points", "5", "--samples", "2000"];
        let mut args = vec!["profile", scene.as_str(), "--method", "mc", "--seed", "5"];
        args.extend(small);
        let out = km(&args);
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    }
}

#[test]
fn dipole_refusal_speaks_of_the_tau_the_user_wrote() {
    let dir = std::env::temp_dir().join(format!("km-flags-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join("tau64.toml");
    // tau = 64 of a strong absorber: not cut to a half-space by the planner
    // only if light still crosses it, so use albedo 0.999 and all effects on.
    std::fs::write(&p, "[[layer]]\ntau = 64\nalbedo = 0.999\n").unwrap();
    let out = km(&["solve", p.to_str().unwrap(), "--method", "dipole", "--all-effects"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("optical thickness tau = sigma_t * thickness = 64 "), "{err}");
    assert!(!err.contains("thickness 1"), "{err}");
}

#[test]
fn demo_says_it_skips_the_dipole_and_why() {
    let out = km(&["demo"]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success());
    assert!(text.contains("dipole: skipped: method dipole cannot treat this scene"), "{text}");
}

#[test]
fn direction_set_refuses_output_directions_and_bad_sizes_naming_the_flag() {
    let seed = examples("seed-three-layers.toml");
    let out = km(&["solve", &seed, "--method", "direction-set", "--json"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(out.stdout.is_empty());
    assert!(err.contains("--method direction-set") && err.contains("6 output directions"), "{err}");
    let slab = examples("fresnel-slab.toml");
    for n in ["3", "2001"] {
        let out = km(&["solve", &slab, "--method", "direction-set", "--directions", n]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{err}");
        assert!(err.contains(&format!("--directions {n}: must lie in [4, 2000]")), "{err}");
    }
    // `km sweep` reaches it too (at its default settings).
    let out = km(&["sweep", &slab, "--set", "layer[1].g=0:0.5:2", "--method", "direction-set"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert_eq!(String::from_utf8_lossy(&out.stdout).lines().count(), 3, "a header and 2 rows");
}
