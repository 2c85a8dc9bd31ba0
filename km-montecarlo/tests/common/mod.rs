//! Shared helpers of the integration tests: reference files and scenes.
#![allow(dead_code)]

use km_core::Scene;
use serde_json::Value;

/// Number of standard errors a Monte Carlo estimate may lie from an exact
/// reference: |z| > 4 has probability 6e-5 for a normal estimate, so the
/// whole suite (a few hundred comparisons) fails by chance with p < 2 %.
pub const K: f64 = 4.0;

/// Load a reference file of `tests/data`.
pub fn data(name: &str) -> Value {
    let path = format!("{}/tests/data/{name}", env!("CARGO_MANIFEST_DIR"));
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

fn toml_num(v: &Value) -> String {
    let x = v.as_f64().unwrap();
    if x.is_infinite() { "\"inf\"".into() } else { format!("{x:?}") }
}

/// A scene from the JSON form of the reference files (same keys as the scene file).
pub fn scene_from_json(s: &Value, directions: Option<&Value>) -> Scene {
    let mut t = String::new();
    let light = &s["light"];
    t += &format!("[light]\nkind = \"{}\"\n", light["kind"].as_str().unwrap());
    if let Some(th) = light.get("theta_deg") {
        t += &format!("theta_deg = {}\n", toml_num(th));
    }
    if let Some(a) = s.get("ambient") {
        t += &format!("[ambient]\nn = {}\n", toml_num(&a["n"]));
    }
    for l in s["layers"].as_array().unwrap() {
        t += "[[layer]]\n";
        for (k, v) in l.as_object().unwrap() {
            t += &format!("{k} = {}\n", toml_num(v));
        }
    }
    if let Some(sub) = s.get("substrate") {
        t += &format!("[substrate]\nkind = \"{}\"\n", sub["kind"].as_str().unwrap());
        if let Some(n) = sub.get("n") {
            t += &format!("n = {}\n", toml_num(n));
        }
    }
    if let Some(d) = directions {
        let pairs: Vec<String> = d
            .as_array()
            .unwrap()
            .iter()
            .map(|p| format!("[{}, {}]", toml_num(&p[0]), toml_num(&p[1])))
            .collect();
        t += &format!("[output]\ndirections_deg = [{}]\n", pairs.join(", "));
    }
    Scene::from_toml_str(&t).unwrap_or_else(|e| panic!("{e}\n{t}"))
}

/// Standard error of a key of a one-channel solution.
pub fn se(sol: &km_core::Solution, key: &str) -> f64 {
    sol.channels[0].stderr.as_ref().unwrap().get(key).unwrap()
}

/// `|mc - reference| <= K se + floor`, with a message naming the case.
/// `floor` is the resolution of a tally (1/N: a tally with no photon cannot
/// tell a value below it from 0) plus the stated uncertainty of the reference.
pub fn check(case: &str, what: &str, mc: f64, se: f64, reference: f64, floor: f64) -> f64 {
    let d = mc - reference;
    let z = d / se;
    assert!(
        d.abs() <= K * se + floor,
        "{case} {what}: mc = {mc} +- {se}, reference = {reference}, z = {z:.2}"
    );
    z
}
