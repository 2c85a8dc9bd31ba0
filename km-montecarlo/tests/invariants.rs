//! Invariants: exact energy balance, determinism across thread counts,
//! shard + merge == single run (bit for bit), refusals of bad input.

mod common;

use km_core::Scene;
use km_montecarlo::{
    Estimator, McError, McOptions, Partial, merge, run_shard, solve, write_atomic,
};
use serde_json::Value;

/// A scene with every feature: Fresnel interfaces, three layers of different
/// phase functions, a Lambertian substrate, output directions.
const STACK: &str = r#"
[light]
theta_deg = 30.0
[ambient]
n = 1.0
[[layer]]
sigma_a = 0.0
sigma_s = 0.0
thickness = 0.1
n = 1.5
[[layer]]
tau = 1.0
albedo = 0.9
g = 0.9
n = 1.4
[[layer]]
tau = 0.5
albedo = 0.5
g = -0.3
n = 1.3
[substrate]
kind = "lambertian"
albedo = 0.6
[output]
directions_deg = [[0.0, 0.0], [45.0, 180.0], [70.0, 0.0]]
"#;

fn mc(sol: &km_core::Solution, key: &str) -> f64 {
    sol.to_json()["mc"][key].as_f64().unwrap()
}

/// The JSON of a solution without its timing (the only field allowed to differ).
fn json_without_seconds(sol: &km_core::Solution) -> String {
    let mut v = sol.to_json();
    v.as_object_mut().unwrap().remove("seconds");
    serde_json::to_string(&v).unwrap()
}

#[test]
fn energy_balance_is_exact_per_photon() {
    let scenes = [
        STACK.to_string(),
        STACK.replace("kind = \"lambertian\"\nalbedo = 0.6", "kind = \"black\""),
        STACK.replace("kind = \"lambertian\"\nalbedo = 0.6", "kind = \"transparent\"\nn = 1.2"),
        STACK.replace("theta_deg = 30.0", "").replace("[light]", "[light]\nkind = \"diffuse\""),
    ];
    for text in &scenes {
        let s = Scene::from_toml_str(text).unwrap();
        for est in [Estimator::SurvivalBiasing, Estimator::Analog] {
            let sol =
                solve(&s, &McOptions { samples: 50_000, estimator: est, ..Default::default() })
                    .unwrap();
            let c = &sol.channels[0];
            // R + T + A + lost = 1 photon by photon (roulette outcomes are booked
            // in A); summed over 5e4 photons the rounding error stays below 1e-11.
            let total = c.reflectance + c.transmittance + c.absorptance + mc(&sol, "lost_weight");
            assert!((total - 1.0).abs() < 1e-11, "{est:?}: {total}");
            let layers: f64 = c.absorptance_layers.as_ref().unwrap().iter().sum();
            let sub = mc(&sol, "absorptance_substrate");
            assert!((layers + sub - c.absorptance).abs() < 1e-11);
            assert!(c.reflectance_specular <= c.reflectance);
            assert!(c.transmittance_direct <= c.transmittance);
        }
    }
}

#[test]
fn one_and_two_threads_give_identical_json() {
    let s = Scene::from_toml_str(STACK).unwrap();
    let run = |threads| {
        let o =
            McOptions { samples: 30_000, seed: 11, threads: Some(threads), ..Default::default() };
        json_without_seconds(&solve(&s, &o).unwrap())
    };
    assert_eq!(run(1), run(2));
}

#[test]
fn shards_merge_to_the_single_run_bit_for_bit() {
    // Two channels, a sample count that does not divide into batches evenly.
    let text = STACK.replace("albedo = 0.9\n", "albedo = [0.9, 0.7]\n");
    let s = Scene::from_toml_str(&text).unwrap();
    let o = McOptions { samples: 20_011, seed: 5, batch_size: Some(1_000), ..Default::default() };
    let single = solve(&s, &o).unwrap();
    for count in [1u64, 3, 7] {
        let mut parts: Vec<Partial> =
            (0..count).map(|i| run_shard(&s, &o, i, count).unwrap()).collect();
        // Through their files: JSON text, and in another order.
        parts.reverse();
        let parts: Vec<Partial> = parts
            .iter()
            .map(|p| serde_json::from_str(&serde_json::to_string(p).unwrap()).unwrap())
            .collect();
        let merged = merge(&parts).unwrap();
        assert_eq!(json_without_seconds(&merged), json_without_seconds(&single), "{count} shards");
        assert_eq!(merged.channels, single.channels);
    }
}

#[test]
fn bad_input_is_refused_with_clear_errors() {
    let s = Scene::from_toml_str(STACK).unwrap();
    let o = McOptions { samples: 4_000, ..Default::default() };
    let zero = McOptions { samples: 0, ..o.clone() };
    assert!(matches!(solve(&s, &zero), Err(McError::Option { name: "samples", .. })));
    assert!(matches!(run_shard(&s, &o, 3, 3), Err(McError::Shard { index: 3, count: 3 })));
    assert!(matches!(run_shard(&s, &o, 0, 0), Err(McError::Shard { .. })));
    let bad = McOptions { bin_half_angle_deg: 0.0, ..o.clone() };
    assert!(matches!(solve(&s, &bad), Err(McError::Option { .. })));
    let bad = McOptions { ring_mu_edges: Some(vec![0.5, 0.2]), ..o.clone() };
    assert!(matches!(solve(&s, &bad), Err(McError::Option { .. })));

    let p0 = run_shard(&s, &o, 0, 2).unwrap();
    let p1 = run_shard(&s, &o, 1, 2).unwrap();
    let msg = |r: Result<km_core::Solution, McError>| r.unwrap_err().to_string();
    assert!(msg(merge(&[])).contains("no parts"));
    assert!(msg(merge(std::slice::from_ref(&p0))).contains("missing shard(s) 1 of 2"));
    assert!(msg(merge(&[p0.clone(), p0.clone()])).contains("given twice"));
    let other_seed = run_shard(&s, &McOptions { seed: 2, ..o.clone() }, 1, 2).unwrap();
    assert!(msg(merge(&[p0.clone(), other_seed])).contains("seed"));
    let other_n = run_shard(&s, &McOptions { samples: 5_000, ..o.clone() }, 1, 2).unwrap();
    assert!(msg(merge(&[p0.clone(), other_n])).contains("samples"));
    let s2 = Scene::from_toml_str(&STACK.replace("albedo = 0.6", "albedo = 0.5")).unwrap();
    let other_scene = run_shard(&s2, &o, 1, 2).unwrap();
    assert!(msg(merge(&[p0.clone(), other_scene])).contains("scene"));
    let mut cut = p1.clone();
    cut.batches.pop();
    // The checksum catches the edit; resealed, the batch count does.
    assert!(msg(merge(&[p0.clone(), cut.clone()])).contains("checksum"));
    assert!(msg(merge(&[p0.clone(), cut.seal()])).contains("batch(es) stored"));
    assert!(merge(&[p1, p0]).is_ok());
}

#[test]
fn write_atomic_replaces_the_file_and_leaves_no_temporary() {
    let dir = std::env::temp_dir().join(format!("km-mc-atomic-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("part.json");
    write_atomic(&path, b"old").unwrap();
    write_atomic(&path, b"new").unwrap();
    assert_eq!(std::fs::read(&path).unwrap(), b"new");
    let names: Vec<_> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name()).collect();
    assert_eq!(names.len(), 1, "{names:?}");
    assert!(write_atomic(&dir.join("no/such/dir/x"), b"x").is_err());
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn stderr_has_the_contract_keys() {
    let s = Scene::from_toml_str(STACK).unwrap();
    let sol = solve(&s, &McOptions { samples: 10_000, ..Default::default() }).unwrap();
    let v = sol.to_json();
    for k in [
        "reflectance",
        "reflectance_specular",
        "transmittance",
        "transmittance_direct",
        "absorptance",
    ] {
        assert!(v["stderr"][k].as_f64().unwrap() >= 0.0, "{k}");
    }
    assert_eq!(v["stderr"]["brdf"].as_array().unwrap().len(), 3);
    assert_eq!(v["btdf"].as_array().unwrap().len(), 3);
    assert_eq!(v["method"], Value::from("mc"));
}

#[test]
fn rings_covering_the_hemisphere_hold_the_diffuse_totals() {
    // Rings over [0, 1] in mu partition the scattered exit weight: sum of
    // (ring BRDF x projected solid angle) = R - R_specular, likewise for T.
    let s = Scene::from_toml_str(
        &STACK.replace("kind = \"lambertian\"\nalbedo = 0.6", "kind = \"transparent\"\nn = 1.0"),
    )
    .unwrap();
    let edges = vec![0.0, 0.2, 0.45, 0.7, 0.9, 1.0];
    let o = McOptions { samples: 20_000, ring_mu_edges: Some(edges.clone()), ..Default::default() };
    let sol = solve(&s, &o).unwrap();
    let c = &sol.channels[0];
    let json = sol.to_json();
    let rings = &json["mc"]["rings"];
    let sum = |key: &str| -> f64 {
        rings[key]
            .as_array()
            .unwrap()
            .iter()
            .zip(edges.windows(2))
            .map(|(f, e)| f.as_f64().unwrap() * std::f64::consts::PI * (e[1] * e[1] - e[0] * e[0]))
            .sum()
    };
    assert!((sum("brdf") - (c.reflectance - c.reflectance_specular)).abs() < 1e-12);
    assert!((sum("btdf") - (c.transmittance - c.transmittance_direct)).abs() < 1e-12);
}

#[test]
fn shards_partition_the_batches() {
    for batches in [1u64, 5, 999, 1000] {
        for count in [1u64, 2, 3, 7, 1000] {
            let mut next = 0;
            for i in 0..count {
                let r = km_montecarlo::shard_batches(batches, i, count);
                assert_eq!(r.start, next);
                next = r.end;
            }
            assert_eq!(next, batches);
        }
    }
}

#[test]
fn partial_files_keep_awkward_options_exact() {
    // Options with values that have no short decimal form must come back
    // bit for bit, or the merge would refuse the parts.
    let s = Scene::from_toml_str(STACK).unwrap();
    let o = McOptions {
        samples: 3_000,
        bin_half_angle_deg: 10.0 / 3.0,
        roulette_threshold: 0.1 + 0.2,
        radial: Some(km_montecarlo::RadialBins { dr: 1.0 / 7.0, count: 9 }),
        ..Default::default()
    };
    let single = solve(&s, &o).unwrap();
    let parts: Vec<Partial> = (0..2)
        .map(|i| {
            let p = run_shard(&s, &o, i, 2).unwrap();
            serde_json::from_str(&serde_json::to_string(&p).unwrap()).unwrap()
        })
        .collect();
    assert_eq!(json_without_seconds(&merge(&parts).unwrap()), json_without_seconds(&single));
}

#[test]
fn progress_callback_does_not_change_the_result() {
    // The callback sees every batch once and the numbers stay bit-identical.
    let s = Scene::from_toml_str(STACK).unwrap();
    let o = McOptions { samples: 5_000, ..Default::default() };
    let a = solve(&s, &o).unwrap();
    let calls = std::sync::Arc::new(std::sync::atomic::AtomicU64::new(0));
    let c = calls.clone();
    let p = km_montecarlo::Progress::new(move |done, total| {
        assert!(done >= 1 && done <= total);
        c.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    });
    let b = solve(&s, &McOptions { progress: Some(p), ..o }).unwrap();
    assert_eq!(json_without_seconds(&a), json_without_seconds(&b));
    let batches = b.to_json()["mc"]["batches"].as_u64().unwrap();
    assert_eq!(calls.load(std::sync::atomic::Ordering::Relaxed), batches);
}
