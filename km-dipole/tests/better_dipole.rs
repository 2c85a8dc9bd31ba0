//! The better dipole (d'Eon 2012): moments, energy, closed form.

use km_core::phase::Anisotropy;
use std::f64::consts::PI;

use km_core::fresnel::diffuse_reflectance;
use km_core::quadrature::gauss_legendre;
use km_dipole::better_dipole::{BetterDipole, fresnel_moment};

/// pbrt-v3's polynomial fits of the Fresnel moments for `eta > 1`
/// (github.com/mmp/pbrt-v3, src/core/bssrdf.cpp, `FresnelMoment1`,
/// `FresnelMoment2`): an independent published reference for the moments.
fn pbrt_moment1(eta: f64) -> f64 {
    -4.61686 + 11.1136 * eta - 10.4646 * eta.powi(2) + 5.11455 * eta.powi(3) - 1.27198 * eta.powi(4)
        + 0.12746 * eta.powi(5)
}

fn pbrt_moment2(eta: f64) -> f64 {
    let r = 1.0 / eta;
    -547.033 + 45.3087 * r.powi(3) - 218.725 * r.powi(2) + 458.843 * r + 404.557 * eta
        - 189.519 * eta.powi(2)
        + 54.9327 * eta.powi(3)
        - 9.00603 * eta.powi(4)
        + 0.63942 * eta.powi(5)
}

#[test]
fn fresnel_moments_against_pbrt_fits() {
    for eta in [1.3, 1.4, 1.5] {
        let (c1, c2) = (fresnel_moment(eta, 1), fresnel_moment(eta, 2));
        // 2 C_1 is F_dr (same integral, eq. D9).
        assert!((2.0 * c1 - diffuse_reflectance(eta, 1.0)).abs() < 1e-13);
        // The fits are single-precision polynomials of unstated accuracy; the
        // differences measured here are below 2e-3 (tolerance set at that bound).
        let (f1, f2) = (pbrt_moment1(eta), pbrt_moment2(eta));
        println!("eta {eta}: C1 {c1:.6} (pbrt fit {f1:.6}), C2 {c2:.6} (pbrt fit {f2:.6})");
        assert!((c1 - f1).abs() < 2e-3, "eta {eta}: C1 {c1} vs {f1}");
        assert!((c2 - f2).abs() < 2e-3, "eta {eta}: C2 {c2} vs {f2}");
    }
    // Matched index: no reflection.
    assert_eq!(fresnel_moment(1.0, 1), 0.0);
    let b = BetterDipole::new(0.1, 1.0, Anisotropy::ISOTROPIC, 1.0).unwrap();
    assert_eq!((b.a, b.c_phi, b.c_e), (1.0, 0.25, 0.5));
}

#[test]
fn conservative_medium_returns_everything() {
    // 2 A C_phi + C_E = (1 + 3 C_2)/2 + (1 - 3 C_2)/2 = 1 for alpha' = 1.
    for eta in [1.0, 1.3, 1.5, 0.8] {
        let b = BetterDipole::new(0.0, 1.0, Anisotropy::ISOTROPIC, eta).unwrap();
        assert!((b.rd_total() - 1.0).abs() < 1e-14, "eta {eta}: {}", b.rd_total());
    }
}

#[test]
fn closed_form_total_equals_integral_of_the_profile() {
    // Same quadrature as tests/dipole.rs (map r = L t / (1 - t), composite
    // 20-point Gauss–Legendre; 200 vs 400 panels bound the error).
    let quad = |b: &BetterDipole, panels: usize| -> f64 {
        let l = if b.sigma_tr > 0.0 { (b.z_v / b.sigma_tr).sqrt() } else { b.z_v };
        let (x, w) = gauss_legendre(20);
        let h = 1.0 / panels as f64;
        let mut sum = 0.0;
        for k in 0..panels {
            for (xi, wi) in x.iter().zip(&w) {
                let t = (k as f64 + 0.5) * h + 0.5 * h * xi;
                let r = l * t / (1.0 - t);
                sum += 0.5 * h * wi * 2.0 * PI * r * b.rd_radial(r) * l / ((1.0 - t) * (1.0 - t));
            }
        }
        sum
    };
    for (sa, ss, g, eta) in [
        (0.0021, 2.19, 0.0, 1.5),
        (0.48, 1.01, 0.0, 1.3),
        (0.1, 0.9, 0.0, 1.0),
        (0.01, 10.0, 0.9, 1.4),
        (0.0, 1.0, 0.0, 1.3),
    ] {
        let b = BetterDipole::new(sa, ss, Anisotropy::new(g).unwrap(), eta).unwrap();
        let (q1, q2) = (quad(&b, 200), quad(&b, 400));
        assert!((q1 - q2).abs() < 1e-13, "{sa} {ss} {g} {eta}: {q1} {q2} closed {}", b.rd_total());
        assert!((b.rd_total() - q2).abs() < 1e-12, "{} vs {q2}", b.rd_total());
    }
}

#[test]
fn grosjean_diffusion_coefficient_by_hand() {
    // sigma_a = 0.5, sigma_s' = 1: sigma_t' = 1.5, D_G = (1 + 1) / (3 * 2.25) = 2 / 6.75
    // = 0.296296..., sigma_tr = sqrt(0.5 / 0.296296) = sqrt(1.6875) = 1.299038...
    // (classical D = 1/4.5 = 0.2222, sigma_tr = sqrt(2.25) = 1.5).
    let b = BetterDipole::new(0.5, 1.0, Anisotropy::ISOTROPIC, 1.3).unwrap();
    assert!((b.d_g - 2.0 / 6.75).abs() < 1e-15);
    assert!((b.sigma_tr - 1.6875f64.sqrt()).abs() < 1e-15);
}

#[test]
fn better_and_classical_dipoles_agree_at_high_albedo_and_part_at_low() {
    use km_dipole::{DiffusionParams, FdrModel, dipole::rd_total};
    // Both are diffusion theory: for alpha' -> 1 they meet (both give 1 at
    // alpha' = 1); the difference grows as absorption grows.
    for albedo in [0.999, 0.99, 0.9, 0.5, 0.1] {
        let c = rd_total(
            &DiffusionParams::from_albedo(albedo, Anisotropy::ISOTROPIC, 1.3, FdrModel::Exact)
                .unwrap(),
        );
        let b =
            BetterDipole::new(1.0 - albedo, albedo, Anisotropy::ISOTROPIC, 1.3).unwrap().rd_total();
        let rel = (b - c).abs() / c;
        println!("albedo {albedo}: classical {c:.5}, better {b:.5}, relative difference {rel:.4}");
    }
}

#[test]
fn scene_solve_with_the_better_dipole() {
    use km_dipole::{DipoleModel, DipoleOptions, solve};
    let s = km_core::Scene::from_toml_str("[[layer]]\npreset = \"marble\"\n").unwrap();
    let opts = DipoleOptions { model: DipoleModel::Better, ..Default::default() };
    let sol = solve(&s, &opts).unwrap();
    let json = sol.to_json();
    assert_eq!(json["dipole_model"], "better");
    let b = BetterDipole::from_reduced(0.0021, 2.19, 1.5).unwrap();
    let r_spec = km_core::fresnel::reflectance(1.0, 1.0, 1.5);
    assert!((sol.channels[0].reflectance - (r_spec + (1.0 - r_spec) * b.rd_total())).abs() < 1e-15);
    let rd = km_dipole::profile(&s, &[0.5], &opts).unwrap();
    assert!((rd[0][0] - b.rd_radial(0.5)).abs() < 1e-15 * rd[0][0]);
}
