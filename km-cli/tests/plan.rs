//! The plan through the command: `km plan` names the simplifications, and
//! `km solve` with the plan agrees with `--all-effects`.

use std::process::Command;

use serde_json::Value;

fn km_json(args: &[&str]) -> Value {
    let out = Command::new(env!("CARGO_BIN_EXE_km")).args(args).output().expect("run km");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_slice(&out.stdout).expect("JSON on stdout")
}

fn scene_file(tag: &str, text: &str) -> String {
    let dir = std::env::temp_dir().join(format!("km-plan-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(format!("{tag}.toml"));
    std::fs::write(&p, text).unwrap();
    p.to_string_lossy().into_owned()
}

/// Every number of a JSON value (nested arrays flattened).
fn flat(v: &Value) -> Vec<f64> {
    match v {
        Value::Array(a) => a.iter().flat_map(flat).collect(),
        x => x.as_f64().into_iter().collect(),
    }
}

fn skipped(v: &Value) -> Vec<String> {
    v["plan"]["skipped"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s.as_str().unwrap().to_string())
        .collect()
}

#[test]
fn duplicate_channels_are_solved_once_with_the_same_answer() {
    let p = scene_file(
        "dup",
        "[light]\ntheta_deg = 30\n[[layer]]\ntau = [1, 2, 1, 1]\nalbedo = 0.9\ng = 0.5\n\
         [output]\ndirections_deg = [[10.0, 0.0], [40.0, 180.0]]\n",
    );
    for method in ["km", "multiflux"] {
        let planned = km_json(&["solve", &p, "--method", method, "--json"]);
        let full = km_json(&["solve", &p, "--method", method, "--json", "--all-effects"]);
        assert!(skipped(&planned).contains(&"duplicate-channels".to_string()));
        assert!(!skipped(&full).contains(&"duplicate-channels".to_string()));
        // With all effects the multi-flux solver sums every Fourier order the
        // streams resolve instead of stopping at its azimuthal convergence
        // test (relative 1e-9): the answers then agree to rounding, 1e-10.
        for key in ["reflectance", "transmittance", "absorptance", "brdf", "btdf"] {
            let (a, b) = (flat(&planned[key]), flat(&full[key]));
            assert_eq!(a.len(), b.len(), "{method} {key}");
            for (x, y) in a.iter().zip(&b) {
                assert!((x - y).abs() <= 1e-10, "{method} {key}: {x} vs {y}");
            }
        }
        assert_eq!(planned["reflectance"].as_array().unwrap().len(), 4);
    }
}

#[test]
fn km_plan_names_each_simplification() {
    let cases = [
        ("interface", "[[layer]]\ntau = 1\nalbedo = 0.5\n", "multiflux"),
        (
            "scattering",
            "[[layer]]\nsigma_a = 1\nsigma_s = 0\nthickness = 1\nn = 1.5\n",
            "multiflux",
        ),
        ("azimuth", "[[layer]]\ntau = 1\nalbedo = 0.5\ng = 0.7\n", "multiflux"),
        (
            "transmission",
            "[[layer]]\ntau = 1e5\nalbedo = 0.9\n[substrate]\nkind = \"lambertian\"\nalbedo = 0.5\n",
            "multiflux",
        ),
        ("angular-tallies", "[[layer]]\ntau = 1\nalbedo = 0.5\n", "mc"),
    ];
    for (name, text, method) in cases {
        let p = scene_file(name, text);
        let v = km_json(&["plan", &p, "--method", method, "--json"]);
        let s: Vec<&str> =
            v["skipped"].as_array().unwrap().iter().map(|x| x.as_str().unwrap()).collect();
        assert!(s.contains(&name), "{name}: {v}");
        assert!(v["reasons"][name].as_str().is_some_and(|r| !r.is_empty()), "{name}: {v}");
        let off = km_json(&["plan", &p, "--method", method, "--json", "--all-effects"]);
        assert!(off["skipped"].as_array().unwrap().is_empty(), "{name}: {off}");
    }
}

#[test]
fn dipole_takes_a_layer_the_transmission_rule_makes_a_half_space() {
    let stack = scene_file(
        "dipole-stack",
        "[[layer]]\nsigma_a = 0.01\nsigma_s = 1\nthickness = 5000\nn = 1.3\n[[layer]]\ntau = 1\nalbedo = 0.5\n",
    );
    let half = scene_file(
        "dipole-half",
        "[[layer]]\nsigma_a = 0.01\nsigma_s = 1\nthickness = \"inf\"\nn = 1.3\n",
    );
    let a = km_json(&["solve", &stack, "--method", "dipole", "--json"]);
    let b = km_json(&["solve", &half, "--method", "dipole", "--json"]);
    assert_eq!(a["reflectance"], b["reflectance"]);
    let notes = a["notes"].as_array().unwrap();
    assert!(notes.iter().any(|n| n.as_str().unwrap().contains("transmission")), "{notes:?}");
    // With the planner off the stack is no half-space: a clear refusal.
    let out = Command::new(env!("CARGO_BIN_EXE_km"))
        .args(["solve", &stack, "--method", "dipole", "--all-effects"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("half-space"));
}
