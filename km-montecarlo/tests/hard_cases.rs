//! Hard cases: grazing light, total internal reflection, optically tiny
//! layers, conservative half-spaces and the work budget. None may hang.

mod common;

use common::{check, se};
use km_core::Scene;
use km_core::fresnel::{reflectance, snell_cos_t};
use km_montecarlo::{Estimator, McError, McOptions, RadialBins, radial_profile, solve};

/// A clear absorbing slab (no scattering) of index n in air at 89 degrees:
/// everything is delta, and the exact answer is the geometric series of
/// internal reflections (Stokes: the same R_F inside and outside),
/// with `t = exp(-sigma_a d / cos_t)`:
/// `R = R_F + (1 - R_F)^2 R_F t^2 / (1 - R_F^2 t^2)`,
/// `T = (1 - R_F)^2 t / (1 - R_F^2 t^2)`.
#[test]
fn grazing_89_degrees_on_an_absorbing_clear_slab() {
    let (n, sa, d, theta) = (1.5f64, 0.3f64, 1.0f64, 89.0f64);
    let s = Scene::from_toml_str(&format!(
        "[light]\ntheta_deg = {theta}\n[[layer]]\nsigma_a = {sa}\nsigma_s = 0.0\nthickness = {d}\nn = {n}\n"
    ))
    .unwrap();
    let mu0 = theta.to_radians().cos();
    let rf = reflectance(mu0, 1.0, n);
    let t = (-sa * d / snell_cos_t(mu0, 1.0, n).unwrap()).exp();
    let r_exact = rf + (1.0 - rf).powi(2) * rf * t * t / (1.0 - rf * rf * t * t);
    let t_exact = (1.0 - rf).powi(2) * t / (1.0 - rf * rf * t * t);
    for est in [Estimator::SurvivalBiasing, Estimator::Analog] {
        let sol = solve(&s, &McOptions { samples: 200_000, estimator: est, ..Default::default() })
            .unwrap();
        let c = &sol.channels[0];
        // Closed forms exact to rounding.
        check("grazing", "R", c.reflectance, se(&sol, "reflectance"), r_exact, 1e-12);
        check("grazing", "T", c.transmittance, se(&sol, "transmittance"), t_exact, 1e-12);
        assert_eq!(c.reflectance, c.reflectance_specular, "all reflection is specular");
        assert_eq!(c.transmittance, c.transmittance_direct, "all transmission is direct");
    }
}

/// Grazing light on a scattering Fresnel slab: finishes, balances, and the
/// specular part is at least the first-surface Fresnel reflection.
#[test]
fn grazing_89_degrees_on_a_scattering_fresnel_slab() {
    let s = Scene::from_toml_str(
        "[light]\ntheta_deg = 89.0\n[[layer]]\ntau = 1.0\nalbedo = 0.9\ng = 0.8\nn = 1.3\n\
         [output]\ndirections_deg = [[89.0, 180.0], [60.0, 180.0]]\n",
    )
    .unwrap();
    let rf = reflectance(89f64.to_radians().cos(), 1.0, 1.3);
    for est in [Estimator::SurvivalBiasing, Estimator::Analog] {
        let sol = solve(&s, &McOptions { samples: 100_000, estimator: est, ..Default::default() })
            .unwrap();
        let c = &sol.channels[0];
        assert!((c.reflectance + c.transmittance + c.absorptance - 1.0).abs() < 1e-11);
        check(
            "grazing-scat",
            "R_spec >= R_F",
            c.reflectance_specular.max(rf),
            se(&sol, "reflectance_specular"),
            c.reflectance_specular,
            0.0,
        );
        assert!(c.brdf.iter().all(|f| f.is_finite() && *f >= 0.0));
    }
}

/// tau = 1e-6: the direct beam is exp(-tau) to rounding, scattering is a
/// ~1e-6 effect, and nothing breaks.
#[test]
fn optically_tiny_layer() {
    let s = Scene::from_toml_str("[[layer]]\ntau = 1e-6\nalbedo = 0.9\ng = 0.5\n").unwrap();
    let sol = solve(&s, &McOptions { samples: 200_000, ..Default::default() }).unwrap();
    let c = &sol.channels[0];
    check(
        "tiny",
        "T_direct",
        c.transmittance_direct,
        se(&sol, "transmittance_direct"),
        (-1e-6f64).exp(),
        1.0 / 2e5,
    );
    assert!(c.reflectance < 1e-5 && c.absorptance < 1e-5);
    assert!((c.reflectance + c.transmittance + c.absorptance - 1.0).abs() < 1e-11);
}

/// Total internal reflection traps light in a high-index scattering layer
/// over a white (albedo 1) Lambertian substrate: only absorption in the
/// layer ends the walks, the run finishes and balances.
#[test]
fn total_internal_reflection_trapping() {
    let s = Scene::from_toml_str(
        "[light]\ntheta_deg = 60.0\n[[layer]]\ntau = 0.2\nalbedo = 0.999\nn = 2.4\n\
         [substrate]\nkind = \"lambertian\"\nalbedo = 1.0\n",
    )
    .unwrap();
    let sol = solve(&s, &McOptions { samples: 50_000, ..Default::default() }).unwrap();
    let c = &sol.channels[0];
    assert_eq!(sol.to_json()["mc"]["capped_photons"], 0);
    assert!((c.reflectance + c.absorptance - 1.0).abs() < 1e-11);
    assert!(sol.to_json()["mc"]["interactions_per_photon"].as_f64().unwrap() > 1.0);
}

/// A conservative half-space reflects everything (R = 1), but its walks have
/// a heavy tail (infinite mean length). The step cap stops the longest; their
/// weight is reported as `lost_weight`, the bound of the bias, and
/// R + lost = 1 exactly.
#[test]
fn conservative_half_space_reports_its_bias_bound() {
    let s = Scene::from_toml_str("[[layer]]\ntau = \"inf\"\nalbedo = 1.0\n").unwrap();
    let o = McOptions { samples: 20_000, max_steps_per_photon: 10_000, ..Default::default() };
    let sol = solve(&s, &o).unwrap();
    let c = &sol.channels[0];
    let lost = sol.to_json()["mc"]["lost_weight"].as_f64().unwrap();
    let capped = sol.to_json()["mc"]["capped_photons"].as_u64().unwrap();
    assert!(capped > 0 && lost > 0.0 && lost < 0.05, "capped {capped} lost {lost}");
    assert!((c.reflectance + lost - 1.0).abs() < 1e-12);
    assert_eq!(c.absorptance, 0.0);
}

/// A thick conservative slab (tau = 1e4: ~tau^2 = 1e8 steps to cross) is
/// refused early with the projected cost when it exceeds the budget.
#[test]
fn thick_conservative_slab_is_refused_with_its_cost() {
    let s = Scene::from_toml_str("[[layer]]\ntau = 1e4\nalbedo = 1.0\n").unwrap();
    let o = McOptions { samples: 100_000, max_events: Some(2_000_000), ..Default::default() };
    let t0 = std::time::Instant::now();
    let e = solve(&s, &o).unwrap_err();
    assert!(matches!(e, McError::TooExpensive { .. }), "{e}");
    let msg = e.to_string();
    assert!(msg.contains("photon steps") && msg.contains("budget"), "{msg}");
    eprintln!("{msg}");
    assert!(t0.elapsed().as_secs_f64() < 20.0);
}

/// Rd(r): the annuli plus the overflow hold exactly the diffuse reflectance.
#[test]
fn radial_profile_adds_up_to_the_diffuse_reflectance() {
    let s = Scene::from_toml_str(
        "[[layer]]\nsigma_a = 0.5\nsigma_s = 10.0\nthickness = \"inf\"\ng = 0.9\nn = 1.4\n",
    )
    .unwrap();
    let bins = RadialBins { dr: 0.05, count: 100 };
    let p =
        radial_profile(&s, &McOptions { samples: 100_000, ..Default::default() }, bins).unwrap();
    let c = &p.solution.channels[0];
    let total: f64 = p.rd[0]
        .iter()
        .enumerate()
        .map(|(i, rd)| rd * std::f64::consts::PI * (2.0 * i as f64 + 1.0) * bins.dr * bins.dr)
        .sum::<f64>()
        + p.overflow[0];
    let diffuse = c.reflectance - c.reflectance_specular;
    assert!((total - diffuse).abs() < 1e-12 * diffuse.max(1.0), "{total} vs {diffuse}");
    assert!(p.rd[0][0] > p.rd[0][20] && p.rd[0][20] > p.rd[0][80]);
    assert!(p.stderr[0].iter().all(|s| s.is_finite() && *s >= 0.0));
}
