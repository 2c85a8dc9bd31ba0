//! The BSDF table against converged DISORT at oblique incidence
//! (`tests/data/bsdf_disort.json`, from `km-bench/scripts/bsdf_disort.py`:
//! cdisort 2.1.3 via nanodisort, NSTR 128, NMOM 1000, Nakajima–Tanaka
//! intensity correction).

use km_core::Scene;
use km_multiflux::bsdf::{Bsdf, BsdfOptions};

/// Largest relative error (or absolute error where the value is below
/// 1e-2: the target is "1 % or 1e-4 absolute") of km against DISORT for the
/// case of asymmetry `g`; also prints every miss.
fn compare(g: f64) -> f64 {
    let text = include_str!("data/bsdf_disort.json");
    let d: serde_json::Value = serde_json::from_str(text).unwrap();
    let case = d["cases"].as_array().unwrap().iter().find(|c| c["g"] == g).unwrap();
    let theta_o: Vec<f64> =
        d["theta_o"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
    let phi: Vec<f64> = d["phi"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
    let theta_i = d["theta_i"].as_f64().unwrap();
    let scene =
        Scene::from_toml_str(&format!("[[layer]]\ntau = 1.0\nalbedo = 0.9\ng = {g}\n")).unwrap();
    let b = Bsdf::new(&scene, &[theta_i], &theta_o, &BsdfOptions::default()).unwrap();
    let (mut worst, mut at) = (0.0f64, String::new());
    for (o, to) in theta_o.iter().enumerate() {
        for (p, ph) in phi.iter().enumerate() {
            for (key, km) in [("brdf", b.brdf(0, 0, o, *ph)), ("btdf", b.btdf(0, 0, o, *ph))] {
                let r = case[key][o][p].as_f64().unwrap();
                // Score 1 at the target: 1 % of the value, or 1e-4 absolute.
                let score = (km - r).abs() / (0.01 * r.abs()).max(1e-4);
                if score > 1.0 {
                    println!("g {g} {key} theta_o {to} phi {ph}: km {km:.6e} DISORT {r:.6e}");
                }
                if score > worst {
                    worst = score;
                    at = format!("{key} theta_o {to} phi {ph}: km {km:.6e} DISORT {r:.6e}");
                }
            }
        }
    }
    let c = &b.channels[0];
    println!(
        "g {g}: worst score {worst:.3} (1 = 1 % or 1e-4) at {at}; R {:.6} vs {:.6}, T {:.6} vs {:.6}",
        c.reflectance[0],
        case["reflectance"].as_f64().unwrap(),
        c.transmittance[0],
        case["transmittance"].as_f64().unwrap()
    );
    worst
}

#[test]
fn within_one_percent_of_disort_g03() {
    assert!(compare(0.3) <= 1.0);
}

#[test]
fn within_one_percent_of_disort_g08() {
    assert!(compare(0.8) <= 1.0);
}

/// g = 0.95 at default accuracy (48 streams beyond |g| = 0.9 when
/// directions are asked for; TMS and, inside the 10-degree cone around the
/// transmitted beam, the IMS term). The reference's exit angles 40 and 60
/// deg lie on the edge of the cone around the 50-degree beam (10 deg away,
/// inside by rounding: the IMS term is applied there, as in DISORT).
#[test]
fn within_one_percent_of_disort_g095() {
    assert!(compare(0.95) <= 1.0);
}
