//! Shared helpers of the integration tests: scenes from the reference files.
#![allow(dead_code)]

use km_core::Scene;
use km_multiflux::{MultifluxOptions, solve};
use serde_json::Value;

/// A scene-file (TOML) text from the JSON scene form of `slabs.json` / `classic.json`.
pub fn toml_of(s: &Value, dirs: Option<&Value>) -> String {
    let mut t = String::new();
    let l = &s["light"];
    t += &format!("[light]\nkind = \"{}\"\n", l["kind"].as_str().unwrap());
    if let Some(th) = l.get("theta_deg") {
        t += &format!("theta_deg = {th}\n");
    }
    t += &format!("[ambient]\nn = {}\n", s["ambient"]["n"]);
    for la in s["layers"].as_array().unwrap() {
        t += &format!(
            "[[layer]]\ntau = {}\nalbedo = {}\ng = {}\nn = {}\n",
            la["tau"], la["albedo"], la["g"], la["n"]
        );
    }
    let sub = &s["substrate"];
    t += &format!("[substrate]\nkind = \"{}\"\n", sub["kind"].as_str().unwrap());
    if let Some(n) = sub.get("n") {
        t += &format!("n = {n}\n");
    }
    if let Some(d) = dirs {
        t += &format!("[output]\ndirections_deg = {d}\n");
    }
    t
}

/// Parse a scene text (test input, so unwrap).
pub fn scene(t: &str) -> Scene {
    Scene::from_toml_str(t).unwrap_or_else(|e| panic!("{e}\n{t}"))
}

/// Solve with `n` streams and return the one channel.
pub fn run(t: &str, n: usize) -> km_core::ChannelResult {
    let o = MultifluxOptions { streams: Some(n), ..Default::default() };
    solve(&scene(t), &o).unwrap().channels.remove(0)
}

/// Load a JSON data file of `tests/data`.
pub fn data(name: &str) -> Value {
    let p = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data").join(name);
    serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap()
}
