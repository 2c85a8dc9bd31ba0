//! Each simplification of the planner (`docs/planner.md`) against the solve
//! with every effect on (`--all-effects`): the plan names it, and the two
//! answers agree.
//!
//! Tolerances: multi-flux 1e-10 absolute (the skipped work is exactly the
//! identity, a zero or a non-excited order, so only rounding differs), or the
//! plan's stated cut-off bound for `transmission`; Monte Carlo within 4
//! combined standard errors when the random streams differ (a 4-sigma event
//! has probability 6e-5 per comparison), bit-identical totals when they do
//! not.

use std::process::Command;

use km_core::Scene;
use km_core::plan::{Request, plan_scene};
use km_montecarlo::McOptions;
use km_multiflux::MultifluxOptions;
use serde_json::Value;

/// Multi-flux agreement where the skipped work is exact (see the module note).
const MF_TOL: f64 = 1e-10;

fn scene(text: &str) -> Scene {
    Scene::from_toml_str(text).expect("scene")
}

fn km_json(args: &[&str]) -> Value {
    let out = Command::new(env!("CARGO_BIN_EXE_km")).args(args).output().expect("run km");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_slice(&out.stdout).expect("JSON on stdout")
}

fn scene_file(tag: &str, text: &str) -> String {
    let dir = std::env::temp_dir().join(format!("km-planned-vs-full-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(format!("{tag}.toml"));
    std::fs::write(&p, text).unwrap();
    p.to_string_lossy().into_owned()
}

/// The plan names `name` for `method`, both in the library and in the JSON
/// of `km solve --json` ("plan.skipped"), and `--all-effects` names nothing.
fn assert_named(tag: &str, text: &str, method: &str, name: &str) {
    let s = scene(text);
    let req = Request::from_scene(&s.channels()[0]);
    assert!(plan_scene(&s, req, false).for_method(method).skips(name), "{tag}: library plan");
    assert!(plan_scene(&s, req, true).skipped.is_empty(), "{tag}: all effects");
    let p = scene_file(tag, text);
    let mut args = vec!["solve", &p, "--method", method, "--json"];
    if method == "mc" {
        args.extend(["--samples", "2000"]);
    }
    let v = km_json(&args);
    let skipped: Vec<&str> =
        v["plan"]["skipped"].as_array().unwrap().iter().map(|x| x.as_str().unwrap()).collect();
    assert!(skipped.contains(&name), "{tag}: {}", v["plan"]);
    args.push("--all-effects");
    let off = km_json(&args);
    assert!(off["plan"]["skipped"].as_array().unwrap().is_empty(), "{tag}: {}", off["plan"]);
}

/// Planned and full multi-flux answers; returns the largest difference over
/// R, T, specular, direct, BRDF and BTDF, and both solutions.
fn mf_pair(text: &str) -> (f64, km_core::Solution, km_core::Solution) {
    let s = scene(text);
    let planned = km_multiflux::solve(&s, &MultifluxOptions::default()).unwrap();
    let full =
        km_multiflux::solve(&s, &MultifluxOptions { all_effects: true, ..Default::default() })
            .unwrap();
    let mut worst = 0.0f64;
    for (a, b) in planned.channels.iter().zip(&full.channels) {
        for (x, y) in [
            (a.reflectance, b.reflectance),
            (a.transmittance, b.transmittance),
            (a.reflectance_specular, b.reflectance_specular),
            (a.transmittance_direct, b.transmittance_direct),
        ] {
            worst = worst.max((x - y).abs());
        }
        for (x, y) in a.brdf.iter().zip(&b.brdf).chain(a.btdf.iter().zip(&b.btdf)) {
            worst = worst.max((x - y).abs());
        }
    }
    (worst, planned, full)
}

fn se(c: &km_core::ChannelResult, key: &str) -> f64 {
    c.stderr.as_ref().and_then(|m| m.get(key)).expect("stderr")
}

/// Planned and full Monte Carlo totals agree within 4 combined standard errors.
fn mc_agree(tag: &str, text: &str) -> (km_core::Solution, km_core::Solution) {
    let s = scene(text);
    let o = McOptions { samples: 40_000, seed: 7, ..Default::default() };
    let planned = km_montecarlo::solve(&s, &o).unwrap();
    let full = km_montecarlo::solve(&s, &McOptions { all_effects: true, ..o }).unwrap();
    for (a, b) in planned.channels.iter().zip(&full.channels) {
        for (key, x, y) in [
            ("reflectance", a.reflectance, b.reflectance),
            ("transmittance", a.transmittance, b.transmittance),
        ] {
            let bound = 4.0 * se(a, key).hypot(se(b, key));
            assert!((x - y).abs() <= bound, "{tag} {key}: {x} vs {y}, 4 se = {bound}");
        }
    }
    (planned, full)
}

#[test]
fn interface_matched_indices() {
    // Every boundary is matched (ambient 1, layers 1, clear substrate 1).
    let text = "[light]\ntheta_deg = 30\n[[layer]]\ntau = 1\nalbedo = 0.9\ng = 0.5\n\
                [[layer]]\ntau = 0.5\nalbedo = 0.6\n[substrate]\nkind = \"transparent\"\nn = 1\n";
    assert_named("interface", text, "multiflux", "interface");
    assert_named("interface-mc", text, "mc", "interface");
    let (d, _, _) = mf_pair(text);
    assert!(d <= MF_TOL, "interface: {d:e}");
    mc_agree("interface", text);
}

#[test]
fn scattering_absorbing_layer_over_a_scattering_one() {
    let text = "[light]\ntheta_deg = 30\n[[layer]]\nsigma_a = 1\nsigma_s = 0\nthickness = 0.5\n\
                n = 1.5\n[[layer]]\ntau = 1\nalbedo = 0.9\ng = 0.5\nn = 1.5\n\
                [substrate]\nkind = \"lambertian\"\nalbedo = 0.5\n\
                [output]\ndirections_deg = [[10.0, 0.0], [40.0, 180.0]]\n";
    assert_named("scattering", text, "multiflux", "scattering");
    let (d, _, _) = mf_pair(text);
    assert!(d <= MF_TOL, "scattering: {d:e}");
}

#[test]
fn azimuth_isotropic_with_directions_and_anisotropic_totals() {
    let iso = "[light]\ntheta_deg = 40\n[[layer]]\ntau = 1\nalbedo = 0.9\nn = 1.3\n\
               [output]\ndirections_deg = [[10.0, 0.0], [40.0, 180.0], [60.0, 90.0]]\n";
    let totals = "[light]\ntheta_deg = 40\n[[layer]]\ntau = 1\nalbedo = 0.9\ng = 0.7\nn = 1.3\n";
    for (tag, text) in [("azimuth-iso", iso), ("azimuth-totals", totals)] {
        assert_named(tag, text, "multiflux", "azimuth");
        let (d, planned, full) = mf_pair(text);
        assert!(d <= MF_TOL, "{tag}: {d:e}");
        // Planned: the one order m = 0; full: every order the streams resolve.
        assert_eq!(planned.to_json()["fourier_orders"], 1, "{tag}");
        let streams = full.to_json()["streams"].as_u64().unwrap();
        assert_eq!(full.to_json()["fourier_orders"].as_u64().unwrap(), 2 * streams, "{tag}");
    }
}

#[test]
fn transmission_thick_absorbing_layer_over_a_substrate() {
    let text = "[[layer]]\ntau = 40\nalbedo = 0.2\nn = 1.4\n[[layer]]\ntau = 2\nalbedo = 0.9\n\
                n = 1.4\n[substrate]\nkind = \"lambertian\"\nalbedo = 0.5\n";
    assert_named("transmission", text, "multiflux", "transmission");
    let (d, planned, full) = mf_pair(text);
    let bound = planned.to_json()["cutoff_bound"].as_f64().expect("cutoff_bound in extra");
    assert!(bound < 1e-14, "bound {bound:e}");
    assert!(full.to_json().get("cutoff_bound").is_none());
    // The neglected light is at most the stated bound (plus rounding).
    assert!(d <= bound + MF_TOL, "transmission: {d:e} > {bound:e}");
}

#[test]
fn angular_tallies_monte_carlo_totals_only() {
    // One mismatched top boundary over a black substrate: the Fresnel tests
    // are the same with and without the plan, so the random streams are the
    // same and the totals bit-identical; only the rings are extra.
    let text = "[light]\ntheta_deg = 20\n[[layer]]\ntau = 2\nalbedo = 0.9\ng = 0.7\nn = 1.4\n";
    assert_named("angular-tallies", text, "mc", "angular-tallies");
    let (planned, full) = mc_agree("angular-tallies", text);
    let (a, b) = (&planned.channels[0], &full.channels[0]);
    assert_eq!(a.reflectance.to_bits(), b.reflectance.to_bits());
    assert_eq!(a.transmittance.to_bits(), b.transmittance.to_bits());
    assert_eq!(a.absorptance.to_bits(), b.absorptance.to_bits());
    assert!(planned.to_json()["mc"].get("rings").is_none());
    let json = full.to_json();
    let rings = &json["mc"]["rings"]["brdf"];
    assert_eq!(rings.as_array().map(Vec::len), Some(8), "{rings}");
}

#[test]
fn duplicate_channels_rgb_scene() {
    let text = "[light]\ntheta_deg = 30\n[[layer]]\ntau = [1, 2, 1]\nalbedo = [0.9, 0.5, 0.9]\n\
                g = 0.3\nn = 1.2\n";
    let p = scene_file("rgb", text);
    for method in ["multiflux", "mc"] {
        assert_named(&format!("rgb-{method}"), text, method, "duplicate-channels");
        let mut args = vec!["solve", &p, "--method", method, "--json"];
        if method == "mc" {
            args.extend(["--samples", "40000"]);
        }
        let planned = km_json(&args);
        args.push("--all-effects");
        let full = km_json(&args);
        for key in ["reflectance", "transmittance"] {
            let a = planned[key].as_array().unwrap();
            let b = full[key].as_array().unwrap();
            assert_eq!(a.len(), 3);
            for c in 0..3 {
                let (x, y) = (a[c].as_f64().unwrap(), b[c].as_f64().unwrap());
                let tol = if method == "mc" {
                    // stderr: an object of lists over channels (format 2, docs/cli.md).
                    let s = |v: &Value| v["stderr"][key][c].as_f64().unwrap();
                    4.0 * s(&planned).hypot(s(&full))
                } else {
                    MF_TOL
                };
                assert!((x - y).abs() <= tol, "{method} {key}[{c}]: {x} vs {y} ({tol:e})");
            }
        }
        // The duplicated channel (3) is the planned solve of channel 1.
        if method == "mc" {
            assert_eq!(planned["reflectance"][0], planned["reflectance"][2]);
        }
    }
}

#[test]
fn all_effects_runs_stay_deterministic_and_shard_exactly() {
    // The extra Fresnel draws and rings keep the run a pure function of the
    // seed: two shards merged give the single run's numbers bit for bit.
    let text = "[light]\ntheta_deg = 30\n[[layer]]\ntau = 1\nalbedo = 0.9\ng = 0.5\n\
                [[layer]]\ntau = 0.5\nalbedo = 0.6\nn = 1.3\n[substrate]\nkind = \"transparent\"\nn = 1.3\n";
    let s = scene(text);
    let o = McOptions { samples: 20_000, seed: 3, all_effects: true, ..Default::default() };
    let one = km_montecarlo::solve(&s, &o).unwrap();
    let again = km_montecarlo::solve(&s, &McOptions { threads: Some(1), ..o.clone() }).unwrap();
    let parts: Vec<_> = (0..2).map(|i| km_montecarlo::run_shard(&s, &o, i, 2).unwrap()).collect();
    let merged = km_montecarlo::merge(&parts).unwrap();
    for other in [&again, &merged] {
        let (a, b) = (&one.channels[0], &other.channels[0]);
        assert_eq!(a.reflectance.to_bits(), b.reflectance.to_bits());
        assert_eq!(a.transmittance.to_bits(), b.transmittance.to_bits());
        assert_eq!(one.to_json()["mc"]["rings"], other.to_json()["mc"]["rings"]);
    }
}
