//! Every output of `km::solve` (the `km solve --json` object) validates
//! against docs/solve.schema.json: every method on every examples/ scene it
//! accepts, a multi-channel Monte Carlo run, and runs with accuracy targets.
//!
//! The checker covers the subset of JSON Schema the file uses (type,
//! properties, required, items, anyOf, const, enum, minimum,
//! additionalProperties = false, local $ref); it refuses any other keyword,
//! so the schema cannot silently grow beyond what is checked.

use std::path::PathBuf;

use km::{Method, Options, Scene};
use serde_json::{Value, json};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn schema() -> Value {
    serde_json::from_str(&std::fs::read_to_string(root().join("docs/solve.schema.json")).unwrap())
        .unwrap()
}

const KNOWN: &[&str] = &[
    "$schema",
    "$id",
    "title",
    "description",
    "$defs",
    "type",
    "properties",
    "required",
    "items",
    "anyOf",
    "const",
    "enum",
    "minimum",
    "additionalProperties",
    "$ref",
];

fn type_ok(t: &str, v: &Value) -> bool {
    match t {
        "object" => v.is_object(),
        "array" => v.is_array(),
        "string" => v.is_string(),
        "number" => v.is_number(),
        "integer" => v.is_u64() || v.is_i64(),
        "boolean" => v.is_boolean(),
        "null" => v.is_null(),
        other => panic!("schema type {other} not supported by the checker"),
    }
}

/// Errors of `v` against `s`, as paths.
fn check(root: &Value, s: &Value, v: &Value, path: &str, out: &mut Vec<String>) {
    let s = s.as_object().expect("a schema is an object");
    for k in s.keys() {
        assert!(KNOWN.contains(&k.as_str()), "schema keyword {k} not supported by the checker");
    }
    if let Some(r) = s.get("$ref").and_then(Value::as_str) {
        let name = r.strip_prefix("#/$defs/").expect("local $ref");
        check(root, &root["$defs"][name], v, path, out);
    }
    if let Some(t) = s.get("type") {
        let ok = match t {
            Value::String(t) => type_ok(t, v),
            Value::Array(ts) => ts.iter().any(|t| type_ok(t.as_str().unwrap(), v)),
            _ => panic!("bad type"),
        };
        if !ok {
            out.push(format!("{path}: {v} is not of type {t}"));
            return;
        }
    }
    if let Some(c) = s.get("const")
        && c != v
    {
        out.push(format!("{path}: {v} != {c}"));
    }
    if let Some(e) = s.get("enum").and_then(Value::as_array)
        && !e.contains(v)
    {
        out.push(format!("{path}: {v} not in {e:?}"));
    }
    if let (Some(m), Some(x)) = (s.get("minimum").and_then(Value::as_f64), v.as_f64())
        && x < m
    {
        out.push(format!("{path}: {x} < {m}"));
    }
    let matches = |a: &Value| {
        let mut e = Vec::new();
        check(root, a, v, path, &mut e);
        e.is_empty()
    };
    if let Some(any) = s.get("anyOf").and_then(Value::as_array)
        && !any.iter().any(matches)
    {
        out.push(format!("{path}: {v} matches none of anyOf"));
    }
    if let (Some(items), Some(a)) = (s.get("items"), v.as_array()) {
        for (i, x) in a.iter().enumerate() {
            check(root, items, x, &format!("{path}[{i}]"), out);
        }
    }
    if let Some(o) = v.as_object() {
        for r in s.get("required").and_then(Value::as_array).into_iter().flatten() {
            if !o.contains_key(r.as_str().unwrap()) {
                out.push(format!("{path}: missing {r}"));
            }
        }
        let props = s.get("properties").and_then(Value::as_object);
        for (k, x) in o {
            match props.and_then(|p| p.get(k)) {
                Some(ps) => check(root, ps, x, &format!("{path}.{k}"), out),
                None if s.get("additionalProperties") == Some(&json!(false)) => {
                    out.push(format!("{path}: unexpected key {k}"))
                }
                None => {}
            }
        }
    }
}

fn errors(v: &Value) -> Vec<String> {
    let s = schema();
    let mut out = Vec::new();
    check(&s, &s, v, "", &mut out);
    out
}

fn example(name: &str) -> Scene {
    Scene::from_path(&root().join("examples").join(name)).unwrap()
}

fn mc(samples: u64) -> Options {
    Options::from(km::McOptions { samples, seed: 5, ..Default::default() })
}

#[test]
fn every_method_on_every_example_validates() {
    let mut checked = 0;
    for entry in std::fs::read_dir(root().join("examples")).unwrap() {
        let path = entry.unwrap().path();
        // Scene files only (examples/ also holds the Python examples' directory).
        if path.extension().is_none_or(|e| e != "toml") {
            continue;
        }
        let scene = Scene::from_path(&path).unwrap();
        for method in Method::ALL {
            let opts = if method == Method::Mc { mc(5_000) } else { Options::new(method) };
            let sol = match km::solve(&scene, &opts) {
                Ok(sol) => sol,
                Err(km::KmError::Unsupported(u)) => {
                    // The dipole: one half-space; the direction set: no output directions.
                    assert!(
                        matches!(
                            (u.method, &u.reason),
                            (Method::Dipole, _)
                                | (Method::DirectionSet, km::Reason::OutputDirections { .. })
                        ),
                        "{}: {u}",
                        path.display()
                    );
                    continue;
                }
                Err(e) => panic!("{} {method}: {e}", path.display()),
            };
            let e = errors(&sol.to_json());
            assert!(e.is_empty(), "{} {method}: {}", path.display(), e.join("\n"));
            checked += 1;
        }
    }
    assert_eq!(
        checked, 18,
        "5 scenes x 3 methods + the dipole on the marble half-space + the direction set on the \
         two scenes without output directions"
    );
}

#[test]
fn multi_channel_monte_carlo_and_accuracy_targets_validate() {
    // Three channels with directions: stderr becomes an object of lists.
    let paint = example("paint-over-primer.toml");
    let v = km::solve(&paint, &mc(5_000)).unwrap().to_json();
    assert!(v["stderr"]["reflectance"].as_array().unwrap().len() == 3);
    assert!(v["stderr"]["brdf"][2].as_array().unwrap().len() == 3);
    assert!(errors(&v).is_empty(), "{:?}", errors(&v));
    let v =
        km::solve(&paint, &Options::new(Method::Multiflux).with_tolerance(1e-3)).unwrap().to_json();
    assert!(v["error_estimate"]["brdf"][0].is_array());
    assert!(errors(&v).is_empty(), "{:?}", errors(&v));
    let slab = example("fresnel-slab.toml");
    let v = km::solve(&slab, &mc(1).with_tolerance(2e-2)).unwrap().to_json();
    assert!(v["tolerance"]["samples"].as_u64().unwrap() >= 10_000);
    assert!(errors(&v).is_empty(), "{:?}", errors(&v));
}

#[test]
fn depth_fields_validate_for_one_and_several_channels() {
    // The paint example (three channels) and the Fresnel slab (one), with
    // depths added: the field's keys, and for Monte Carlo their standard
    // errors inside `stderr`; with directions inside as well, the radiance
    // (docs/field.md §6).
    const DIRS: &str = "\ninside_directions_deg = [[30.0, 0.0], [150.0, 180.0]]";
    for name in ["paint-over-primer.toml", "fresnel-slab.toml"] {
        for inside in [false, true] {
            let text = std::fs::read_to_string(root().join("examples").join(name)).unwrap();
            let keys = format!("depths = [0.0, 0.001]{}", if inside { DIRS } else { "" });
            let with = if text.contains("[output]") {
                text.replace("[output]", &format!("[output]\n{keys}"))
            } else {
                format!("{text}\n[output]\n{keys}\n")
            };
            let scene = Scene::from_toml_str(&with).unwrap();
            for opts in [Options::new(Method::Multiflux), mc(2_000)] {
                let v = km::solve(&scene, &opts).unwrap().to_json();
                assert!(v["depths"].is_array() && v["fluence"].is_array(), "{name}: {v}");
                if opts.method() == Method::Mc {
                    assert!(v["stderr"]["net_flux"].is_array(), "{name}");
                }
                assert_eq!(v["radiance"]["values"].is_array(), inside, "{name}");
                assert!(errors(&v).is_empty(), "{name}: {:?}", errors(&v));
            }
        }
    }
    // The dipole's field of a half-space (three channels of a preset).
    let scene =
        Scene::from_toml_str("[[layer]]\npreset = \"skin1\"\n[output]\ndepths = [0.0, 0.5]\n")
            .unwrap();
    let v = km::solve(&scene, &Options::new(Method::Dipole)).unwrap().to_json();
    assert!(v["depths"].is_array() && v["fluence"].is_array(), "dipole: {v}");
    assert!(errors(&v).is_empty(), "dipole: {:?}", errors(&v));
}

#[test]
fn spectral_channels_are_numeric_wavelengths_and_validate() {
    let text = "[spectrum]\nwavelengths_nm = [450, 550, 650]\n[[layer]]\nsigma_a = [0.1, 0.2, 0.3]\n\
                sigma_s = 1\nthickness = 2\n";
    let scene = Scene::from_toml_str(text).unwrap();
    let methods = [Method::Km, Method::Multiflux, Method::DirectionSet].map(Options::new);
    for opts in methods.into_iter().chain([mc(2_000)]) {
        let mut v = km::solve(&scene, &opts).unwrap().to_json();
        assert_eq!(v["channels"], json!([450.0, 550.0, 650.0]));
        assert!(errors(&v).is_empty(), "{:?}", errors(&v));
        v["channels"] = json!([true]);
        assert!(!errors(&v).is_empty(), "a boolean channel accepted");
    }
}

#[test]
fn the_checker_rejects_what_the_schema_forbids() {
    let slab = example("fresnel-slab.toml");
    let good = km::solve(&slab, &Options::new(Method::Km)).unwrap().to_json();
    assert!(errors(&good).is_empty());
    let mutations: [(&str, Value); 5] = [
        ("format", json!(1)),
        ("method", json!("magic")),
        ("reflectance", json!("0.1")),
        ("notes", json!("one note")),
        ("stderr", json!({"reflectance": -1.0})),
    ];
    for (k, bad) in mutations {
        let mut v = good.clone();
        v[k] = bad;
        assert!(!errors(&v).is_empty(), "{k} accepted");
    }
    let mut v = good.clone();
    v.as_object_mut().unwrap().remove("notes");
    assert!(!errors(&v).is_empty(), "missing notes accepted");
}

#[test]
fn model_error_estimates_and_cones_validate() {
    // Three channels: model_error_estimate and cone_half_angle_deg become
    // objects of lists over channels.
    let paint = example("paint-over-primer.toml");
    let v = km::solve(&paint, &Options::new(Method::Km)).unwrap().to_json();
    assert_eq!(v["model_error_estimate"]["brdf"].as_array().unwrap().len(), 3);
    assert!(errors(&v).is_empty(), "{:?}", errors(&v));
    let v = km::solve(&paint, &mc(2_000)).unwrap().to_json();
    assert_eq!(v["cone_half_angle_deg"]["brdf"][2].as_array().unwrap().len(), 3);
    assert!(errors(&v).is_empty(), "{:?}", errors(&v));
    let slab = example("fresnel-slab.toml");
    let one = slab.channels()[0].with_directions(vec![[10.0, 180.0]]).unwrap();
    let slab = slab.with_channels(vec![one]).unwrap();
    let v = km::solve(&slab, &Options::new(Method::Multiflux).with_cone(3.0)).unwrap().to_json();
    assert_eq!(v["cone_half_angle_deg"]["btdf"], json!([3.0]));
    assert!(errors(&v).is_empty(), "{:?}", errors(&v));
}
