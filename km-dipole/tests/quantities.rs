//! The quantities of seed 003 and Jensen et al. 2001 against hand-computed
//! and published values.

use km_core::phase::Anisotropy;
use km_dipole::params::a_from_fdr;
use km_dipole::{DiffusionParams, DipoleError, FdrModel};

/// d'Eon & Irving (2011) fit of the *external* hemispherical Fresnel
/// reflectance `F_ext(eta)` (light from the low-index side), as printed in
/// layerlab (github.com/wjakob/layerlab, src/fresnel.cpp,
/// `fresnelDielectricIntegral`, commit 1306d9bc), with its stated maximum
/// relative error of 0.1 % for 1 <= eta <= 2. An independent published
/// reference for the exact integral.
fn deon_irving_external(eta: f64) -> f64 {
    let i = 1.0 / eta;
    0.919317 - 3.4793 * i + 6.75335 * i.powi(2) - 7.80989 * i.powi(3) + 4.98554 * i.powi(4)
        - 1.36881 * i.powi(5)
}

#[test]
fn fdr_of_matched_index_is_zero() {
    // No interface, no reflection: exactly 0 for the exact integral.
    assert_eq!(FdrModel::Exact.fdr(1.0).unwrap(), 0.0);
    assert_eq!(a_from_fdr(0.0), 1.0);
    // The Egan–Hilgeman fit is a fit: -1.440 + 0.710 + 0.668 + 0.0636 = 0.0016 at eta = 1.
    let eh = FdrModel::EganHilgeman.fdr(1.0).unwrap();
    assert!((eh - 0.0016).abs() < 1e-12, "{eh}");
}

#[test]
fn exact_fdr_matches_published_fits_at_1_3_and_1_5() {
    for eta in [1.3, 1.5] {
        let exact = FdrModel::Exact.fdr(eta).unwrap();
        // 1. d'Eon–Irving: F_dr = 1 - (1 - F_ext) / eta^2 (flux balance across the
        //    interface, n^2 law). Tolerance: the fit's 0.1 % of F_ext, carried through.
        let f_ext = deon_irving_external(eta);
        let from_fit = 1.0 - (1.0 - f_ext) / (eta * eta);
        let tol = 1e-3 * f_ext / (eta * eta);
        assert!(
            (exact - from_fit).abs() < tol,
            "eta {eta}: exact {exact} vs d'Eon-Irving {from_fit}"
        );
        // 2. Egan–Hilgeman (as quoted by Jensen et al. 2001): stated within 0.1 %
        //    for 1 <= eta <= 1.5 (layerlab / Mitsuba comment on the same fit).
        let eh = FdrModel::EganHilgeman.fdr(eta).unwrap();
        assert!((exact - eh).abs() < 1e-3 * eh, "eta {eta}: exact {exact} vs EH {eh}");
        println!(
            "eta {eta}: F_dr exact {exact:.6}, d'Eon-Irving {from_fit:.6}, Egan-Hilgeman {eh:.6}"
        );
    }
}

#[test]
fn egan_hilgeman_by_hand_at_1_3() {
    // F_dr = -1.440 / 1.69 + 0.710 / 1.3 + 0.668 + 0.0636 * 1.3
    //      = -0.852071006 + 0.546153846 + 0.668 + 0.08268 = 0.444762840
    // A    = 1.444762840 / 0.555237160 = 2.602064388
    let f = FdrModel::EganHilgeman.fdr(1.3).unwrap();
    assert!((f - 0.444762840).abs() < 1e-9, "{f}");
    assert!((a_from_fdr(f) - 2.602064388).abs() < 1e-8);
}

#[test]
fn marble_red_channel_by_hand() {
    // Marble, R channel (Jensen et al. 2001): sigma_s' = 2.19, sigma_a = 0.0021 /mm, eta = 1.5.
    //   sigma_t' = 2.19 + 0.0021                     = 2.1921 /mm
    //   alpha'   = 2.19 / 2.1921                     = 0.999042015
    //   D        = 1 / (3 * 2.1921) = 1 / 6.5763     = 0.152061189 mm
    //   sigma_tr = sqrt(3 * 0.0021 * 2.1921)
    //            = sqrt(0.01381023)                  = 0.117516935 /mm
    //            = sqrt(sigma_a / D) = sqrt(0.0021 * 6.5763), the same number
    //   F_dr(EH) = -1.44 / 2.25 + 0.71 / 1.5 + 0.668 + 0.0636 * 1.5
    //            = -0.64 + 0.473333333 + 0.668 + 0.0954 = 0.596733333
    //   A        = 1.596733333 / 0.403266667         = 3.959497438
    //   z_b      = 2 A D = 2 * 3.959497438 * 0.152061189 = 1.204171780 mm
    //   z_r      = 1 / 2.1921                        = 0.456183568 mm
    //   z_v      = z_r + 4 A D = 0.456183568 + 2.408343560 = 2.864527128 mm
    // Tolerance: the hand values are rounded at the 9th decimal.
    let p = DiffusionParams::from_reduced(0.0021, 2.19, 1.5, FdrModel::EganHilgeman).unwrap();
    let close = |x: f64, y: f64| (x - y).abs() < 1e-9;
    assert!(close(p.sigma_t_prime, 2.1921));
    assert!(close(p.alpha_prime, 0.999042015));
    assert!(close(p.d, 0.152061189), "{}", p.d);
    assert!(close(p.sigma_tr, 0.117516935), "{}", p.sigma_tr);
    assert!(close(p.sigma_tr, (p.sigma_a / p.d).sqrt()));
    assert!(close(p.fdr, 0.596733333));
    assert!(close(p.a, 3.959497438), "{}", p.a);
    assert!(close(p.z_b, 1.204171780), "{}", p.z_b);
    assert!(close(p.z_r, 0.456183568));
    assert!(close(p.z_v, 2.864527128), "{}", p.z_v);
}

#[test]
fn reduced_scattering_from_g() {
    // sigma_s' = (1 - g) sigma_s: g = 0.5, sigma_s = 2 gives sigma_s' = 1, sigma_t' = 1.1,
    // D = 1 / 3.3, sigma_tr = sqrt(3 * 0.1 * 1.1) = sqrt(0.33).
    let p = DiffusionParams::new(0.1, 2.0, Anisotropy::new(0.5).unwrap(), 1.3, FdrModel::Exact)
        .unwrap();
    assert!((p.sigma_s_prime - 1.0).abs() < 1e-15);
    assert!((p.d - 1.0 / 3.3).abs() < 1e-15);
    assert!((p.sigma_tr - 0.33f64.sqrt()).abs() < 1e-15);
    // Similarity: (g = 0.9, sigma_s = 10) and (g = 0, sigma_s = 1) are the same medium.
    let a = DiffusionParams::new(0.05, 10.0, Anisotropy::new(0.9).unwrap(), 1.4, FdrModel::Exact)
        .unwrap();
    let b = DiffusionParams::new(0.05, 1.0, Anisotropy::ISOTROPIC, 1.4, FdrModel::Exact).unwrap();
    assert!((a.alpha_prime - b.alpha_prime).abs() < 1e-14);
    assert!((a.z_v - b.z_v).abs() < 1e-13);
}

#[test]
fn bad_parameters_are_refused_with_their_name() {
    let e =
        DiffusionParams::new(0.1, 0.0, Anisotropy::ISOTROPIC, 1.3, FdrModel::Exact).unwrap_err();
    assert!(e.to_string().contains("sigma_s = 0"), "{e}");
    assert!(e.to_string().contains("needs scattering"), "{e}");
    let e =
        DiffusionParams::new(-0.1, 1.0, Anisotropy::ISOTROPIC, 1.3, FdrModel::Exact).unwrap_err();
    assert!(e.to_string().contains("sigma_a"), "{e}");
    // |g| < 1 is the type's check (km_core::phase::Anisotropy), not repeated here.
    let e = Anisotropy::new(1.0).unwrap_err();
    assert!(e.to_string().contains("g = 1"), "{e}");
    let e = DiffusionParams::new(0.1, 1.0, Anisotropy::ISOTROPIC, 0.8, FdrModel::EganHilgeman)
        .unwrap_err();
    assert!(matches!(e, DipoleError::FitOutOfRange { .. }), "{e}");
    assert!(e.to_string().contains("eta = 0.8"), "{e}");
    // The exact F_dr is fine below 1 (no total internal reflection inside).
    assert!(DiffusionParams::new(0.1, 1.0, Anisotropy::ISOTROPIC, 0.8, FdrModel::Exact).is_ok());
    let e = FdrModel::Exact.fdr(f64::NAN).unwrap_err();
    assert!(e.to_string().contains("eta"), "{e}");
}

#[test]
fn exact_fdr_is_the_core_integral() {
    // FdrModel::Exact runs the quadrature of km_core::fresnel::diffuse_reflectance
    // (same panels and rule, nodes cached): equal to rounding, both sides of eta = 1.
    for eta in [0.5, 0.8, 1.0, 1.1, 1.3, 1.33, 1.5, 2.5] {
        let a = FdrModel::Exact.fdr(eta).unwrap();
        let b = km_core::fresnel::diffuse_reflectance(eta, 1.0);
        assert!((a - b).abs() < 1e-14, "eta {eta}: {a} vs {b}");
    }
}
