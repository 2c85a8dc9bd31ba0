//! Monte Carlo against the project's multi-flux solver (an independent
//! method: discrete ordinates, eigen-decomposition in depth), on 12 scenes
//! with Fresnel interfaces, g = 0.9, Lambertian and black substrates, a
//! 3-layer stack, diffuse light and a half-space. Reference values in
//! tests/data/multiflux_peer.json (64 streams per hemisphere, with the
//! solver's commit). Every total, delta part and BRDF/BTDF bin within
//! K = 4 standard errors, plus: 1e-9 for the delta parts (deterministic in
//! the survival estimator, se ~ 0; both methods evaluate the same Fresnel
//! formula) and the 1.2 % bin-bias allowance of tests/bins.rs for the bins.

mod common;

use common::{check, data};
use km_core::Scene;
use km_montecarlo::{McOptions, solve};

/// Bins excluded, with the reason: the BTDF of the g = 0.9 slab in the
/// direction of its transmitted beam sits on the single-scattering forward
/// peak, where a 5-degree bin reads 26 % low (docs/montecarlo.md §6).
const EXCLUDED: &[(&str, &str, usize)] = &[("g09_slab", "btdf", 1)];

#[test]
fn agrees_with_the_multiflux_solver() {
    let peer = data("multiflux_peer.json");
    let mut n = 0;
    let mut zmax: f64 = 0.0;
    for case in peer["cases"].as_array().unwrap() {
        let id = case["id"].as_str().unwrap();
        let scene = Scene::from_toml_str(case["scene_toml"].as_str().unwrap()).unwrap();
        let sol =
            solve(&scene, &McOptions { samples: 200_000, seed: 17, ..Default::default() }).unwrap();
        let mc = sol.to_json();
        let mf = &case["multiflux"];
        for key in ["reflectance", "transmittance", "reflectance_specular", "transmittance_direct"]
        {
            let se = mc["stderr"][key].as_f64().unwrap();
            let z = check(id, key, mc[key].as_f64().unwrap(), se, mf[key].as_f64().unwrap(), 1e-9);
            if se > 1e-6 {
                zmax = zmax.max(z.abs());
            }
            n += 1;
        }
        for arr in ["brdf", "btdf"] {
            let reference = mf[arr].as_array().unwrap();
            for (k, r) in reference.iter().enumerate() {
                if EXCLUDED.contains(&(id, arr, k)) {
                    continue;
                }
                let r = r.as_f64().unwrap();
                let se = mc["stderr"][arr][k].as_f64().unwrap();
                let v = mc[arr][k].as_f64().unwrap();
                let z = check(id, &format!("{arr}[{k}]"), v, se, r, 1.2e-2 * r.abs() + 1e-12);
                if se > 0.0 {
                    zmax = zmax.max(z.abs());
                }
                n += 1;
            }
        }
    }
    eprintln!("multiflux peer: {n} comparisons, max |z| = {zmax:.2}");
    assert!(n >= 100);
}
