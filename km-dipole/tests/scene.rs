//! Scene entry points: what `km solve --method dipole` and `km profile` get.

use km_core::phase::Anisotropy;
use std::f64::consts::PI;

use km_core::Scene;
use km_core::fresnel::{diffuse_reflectance, reflectance};
use km_core::quadrature::gauss_legendre;
use km_dipole::dipole::rd_total;
use km_dipole::{DiffusionParams, DipoleError, DipoleOptions, FdrModel, profile, solve};

fn scene(text: &str) -> Scene {
    Scene::from_toml_str(text).expect("valid scene")
}

const HALF_SPACE_30: &str = r#"
[light]
kind = "collimated"
theta_deg = 30.0
[[layer]]
sigma_a = 0.01
sigma_s = 2.0
g = 0.5
thickness = "inf"
n = 1.3
[output]
directions_deg = [[0.0, 0.0], [45.0, 180.0], [80.0, 90.0]]
"#;

#[test]
fn collimated_totals_are_fresnel_plus_transmitted_dipole() {
    let s = scene(HALF_SPACE_30);
    let sol = solve(&s, &DipoleOptions::default()).unwrap();
    let ch = &sol.channels[0];
    let p = DiffusionParams::new(0.01, 2.0, Anisotropy::new(0.5).unwrap(), 1.3, FdrModel::Exact)
        .unwrap();
    let mu0 = 30f64.to_radians().cos();
    let r_spec = reflectance(mu0, 1.0, 1.3);
    let diffuse = (1.0 - r_spec) * rd_total(&p);
    // Same arithmetic, same order: equal to rounding.
    assert!((ch.reflectance_specular - r_spec).abs() < 1e-15);
    assert!((ch.reflectance - (r_spec + diffuse)).abs() < 1e-15);
    assert_eq!(ch.transmittance, 0.0);
    assert!((ch.absorptance + ch.reflectance - 1.0).abs() < 1e-15);
    assert_eq!(ch.brdf.len(), 3);
    assert_eq!(ch.btdf, vec![0.0; 3]);
    // The BRDF depends on theta_o only and decreases towards grazing.
    assert!(ch.brdf[0] > ch.brdf[1] && ch.brdf[1] > ch.brdf[2]);
    let json = sol.to_json();
    assert_eq!(json["method"], "dipole");
    assert!(
        json["notes"]
            .as_array()
            .unwrap()
            .iter()
            .any(|n| { n.as_str().unwrap().contains("single scattering excluded") })
    );
    assert!((json["fdr"].as_f64().unwrap() - p.fdr).abs() < 1e-15);
    assert!((json["A"].as_f64().unwrap() - p.a).abs() < 1e-15);
}

#[test]
fn brdf_integrates_to_the_diffuse_part() {
    // Sample the BRDF at Gauss–Legendre exit cosines and integrate
    // 2 pi integral f mu dmu: must give the diffuse part (64 nodes, smooth
    // integrand for eta > 1, error < 1e-12).
    let (x, w) = gauss_legendre(64);
    let dirs: Vec<String> =
        x.iter().map(|xi| format!("[{}, 0.0]", (0.5 * (xi + 1.0)).acos().to_degrees())).collect();
    let text = HALF_SPACE_30.replace(
        "directions_deg = [[0.0, 0.0], [45.0, 180.0], [80.0, 90.0]]",
        &format!("directions_deg = [{}]", dirs.join(", ")),
    );
    let sol = solve(&scene(&text), &DipoleOptions::default()).unwrap();
    let ch = &sol.channels[0];
    let integral: f64 = x
        .iter()
        .zip(&w)
        .zip(&ch.brdf)
        .map(|((xi, wi), f)| 0.5 * wi * 2.0 * PI * f * 0.5 * (xi + 1.0))
        .sum();
    let diffuse = ch.reflectance - ch.reflectance_specular;
    assert!((integral - diffuse).abs() < 1e-10 * diffuse, "{integral} vs {diffuse}");
}

#[test]
fn diffuse_light_uses_the_hemispherical_fresnel_reflectance() {
    let s =
        scene("[light]\nkind = \"diffuse\"\n[[layer]]\ntau = \"inf\"\nalbedo = 0.99\nn = 1.5\n");
    let ch = &solve(&s, &DipoleOptions::default()).unwrap().channels[0];
    let f_ext = diffuse_reflectance(1.0, 1.5);
    let p =
        DiffusionParams::from_albedo(0.99, Anisotropy::ISOTROPIC, 1.5, FdrModel::Exact).unwrap();
    assert!((ch.reflectance_specular - f_ext).abs() < 1e-15);
    assert!((ch.reflectance - f_ext - (1.0 - f_ext) * rd_total(&p)).abs() < 1e-15);
}

#[test]
fn presets_give_three_channels_and_the_fdr_model_matters() {
    let s = scene("[[layer]]\npreset = \"skimmilk\"\n");
    let exact = solve(&s, &DipoleOptions::default()).unwrap();
    let eh =
        solve(&s, &DipoleOptions { fdr: FdrModel::EganHilgeman, ..Default::default() }).unwrap();
    assert_eq!(exact.channels.len(), 3);
    let json = exact.to_json();
    assert_eq!(json["fdr"].as_array().unwrap().len(), 3);
    assert_eq!(json["fdr_model"], "exact");
    for c in 0..3 {
        let (a, b) = (exact.channels[c].reflectance, eh.channels[c].reflectance);
        // A larger F_dr (Egan–Hilgeman at 1.3) keeps more light inside: slightly less out.
        assert!(b < a && a - b < 1e-3, "channel {c}: {a} {b}");
    }
}

#[test]
fn profile_per_channel_on_a_grid() {
    let s = scene("[[layer]]\npreset = \"marble\"\n");
    let r = [0.0, 0.5, 1.0, 2.0, 4.0, 8.0];
    let rd = profile(&s, &r, &DipoleOptions::default()).unwrap();
    assert_eq!(rd.len(), 3);
    for ch in &rd {
        assert_eq!(ch.len(), r.len());
        assert!(ch.windows(2).all(|w| w[0] > w[1] && w[1] > 0.0));
    }
    // Red light travels farthest in marble (least sigma_s' and sigma_a).
    assert!(rd[0][5] > rd[2][5]);
    let e = profile(&s, &[0.0, -1.0], &DipoleOptions::default()).unwrap_err();
    assert!(e.to_string().contains("r = -1"), "{e}");
}

#[test]
fn refuses_finite_thickness() {
    let s = scene("[[layer]]\nsigma_a = 0.1\nsigma_s = 1.0\nthickness = 2.0\n");
    let e = solve(&s, &DipoleOptions::default()).unwrap_err();
    assert!(matches!(e, DipoleError::FiniteThickness { .. }), "{e}");
    assert!(e.to_string().contains("finite thickness 2"), "{e}");
    assert!(profile(&s, &[1.0], &DipoleOptions::default()).is_err());
}

#[test]
fn refuses_more_than_one_layer() {
    let s = scene(
        "[[layer]]\nsigma_a = 0.1\nsigma_s = 1.0\nthickness = 2.0\n\
         [[layer]]\nsigma_a = 0.1\nsigma_s = 1.0\nthickness = \"inf\"\n",
    );
    let e = solve(&s, &DipoleOptions::default()).unwrap_err();
    assert!(matches!(e, DipoleError::LayerCount { count: 2 }), "{e}");
    assert!(e.to_string().contains("2 layers"), "{e}");
}

#[test]
fn refuses_zero_scattering() {
    // One channel of two has no scattering: refused, naming the channel.
    let s = scene("[[layer]]\nsigma_a = 0.1\nsigma_s = [1.0, 0.0]\nthickness = \"inf\"\n");
    let e = solve(&s, &DipoleOptions::default()).unwrap_err();
    assert!(matches!(e, DipoleError::NoScattering { channel: 1, .. }), "{e}");
    assert!(e.to_string().contains("sigma_s = 0"), "{e}");
}

#[test]
fn refuses_the_fit_below_index_one() {
    // Layer less dense than the ambient: the Egan–Hilgeman fit is undefined,
    // the exact F_dr works.
    let s = scene("[ambient]\nn = 1.5\n[[layer]]\ntau = \"inf\"\nalbedo = 0.9\nn = 1.0\n");
    let e = solve(&s, &DipoleOptions { fdr: FdrModel::EganHilgeman, ..Default::default() })
        .unwrap_err();
    assert!(matches!(e, DipoleError::FitOutOfRange { .. }), "{e}");
    assert!(solve(&s, &DipoleOptions::default()).is_ok());
}
