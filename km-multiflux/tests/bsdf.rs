//! The BSDF table against `km solve` (the solver's own directions), and its
//! checks: energy, reciprocity (also across an index change), positivity.

use km_core::{Light, MonoScene, Scene};
use km_multiflux::bsdf::{Bsdf, BsdfOptions, Side, check, gauss_angles};
use km_multiflux::{MultifluxOptions, solve};

const TWO_LAYER: &str = "
[[layer]]
sigma_a = [0.002, 0.08, 0.10]
sigma_s = [0.20, 0.15, 0.12]
thickness = 20.0
g = 0.6
n = 1.5
[[layer]]
sigma_a = 0.001
sigma_s = 0.8
thickness = 40.0
g = 0.5
n = 1.5
[substrate]
kind = \"black\"
";

const SLAB_IN_GLASS: &str = "
[[layer]]
tau = 1.5
albedo = 0.95
g = 0.8
n = 1.33
[substrate]
kind = \"transparent\"
n = 1.5
";

const SEED: &str = "
[[layer]]
sigma_a = 0.1
sigma_s = 0.4
thickness = 1.0
n = 1.3
[substrate]
kind = \"lambertian\"
albedo = 0.8
";

const LONE: &str = "
[[layer]]
tau = 2.0
albedo = 0.9
g = 0.7
";

/// Table values against `km solve` at the same directions, same streams.
/// Tolerance 1e-10 (relative to max(1, |value|)): both evaluate the same
/// operators; the only differences are the order of floating-point sums.
/// Both sum every order (`fourier_tol` 0): the two stopping rules (the
/// table's over the whole table, the solver's over its own directions) end
/// the series at different orders, which alone moved the lone layer's
/// values by 2.4e-10 at the default tolerance (within what the rule
/// allows; the rules are tested in tests/fourier_stop.rs).
fn against_solve(text: &str, theta_i: &[f64]) {
    let theta_o = [0.0, 20.0, 45.0, 70.0, 85.0];
    let phis = [0.0, 45.0, 130.0, 180.0, 270.0];
    let every_order = MultifluxOptions { fourier_tol: 0.0, ..Default::default() };
    against_solve_at(text, theta_i, &theta_o, &phis, &every_order);
}

/// [`against_solve`] at given exit polar angles and azimuths, both with the
/// solver options `base` (streams: the table's).
fn against_solve_at(
    text: &str,
    theta_i: &[f64],
    theta_o: &[f64],
    phis: &[f64],
    base: &MultifluxOptions,
) {
    let scene = Scene::from_toml_str(text).unwrap();
    let bopts = BsdfOptions { solver: base.clone(), ..Default::default() };
    let b = Bsdf::new(&scene, theta_i, theta_o, &bopts).unwrap();
    let mut worst = 0.0f64;
    for (i, &ti) in theta_i.iter().enumerate() {
        let s = scene.clone();
        let mut dirs = Vec::new();
        for &to in theta_o {
            for &p in phis {
                dirs.push([to, p]);
            }
        }
        let lit = |ch: &MonoScene| {
            ch.with_light(Light::Collimated { theta_deg: ti })
                .and_then(|c| c.with_directions(dirs.clone()))
                .unwrap()
        };
        let s = s.with_channels(s.channels().iter().map(lit).collect()).unwrap();
        let opts = MultifluxOptions { streams: Some(b.channels[0].streams), ..base.clone() };
        let sol = solve(&s, &opts).unwrap();
        for (c, res) in sol.channels.iter().enumerate() {
            let close = |a: f64, e: f64, what: &str| {
                let d = (a - e).abs() / e.abs().max(1.0);
                assert!(d < 1e-10, "{what}: table {a} vs solve {e} (theta_i {ti}, channel {c})");
                d
            };
            let ch = &b.channels[c];
            worst = worst.max(close(ch.reflectance[i], res.reflectance, "R"));
            worst = worst.max(close(ch.transmittance[i], res.transmittance, "T"));
            worst = worst.max(close(ch.reflectance_specular[i], res.reflectance_specular, "Rs"));
            worst = worst.max(close(ch.transmittance_direct[i], res.transmittance_direct, "Td"));
            let mut k = 0;
            for (o, to) in theta_o.iter().enumerate() {
                for &p in phis {
                    worst = worst.max(close(
                        b.brdf(c, i, o, p),
                        res.brdf[k],
                        &format!("brdf at ({to}, {p})"),
                    ));
                    worst = worst.max(close(
                        b.btdf(c, i, o, p),
                        res.btdf[k],
                        &format!("btdf at ({to}, {p})"),
                    ));
                    k += 1;
                }
            }
        }
    }
    println!("largest relative difference to km solve: {worst:.2e}");
}

const PEAKED: &str = "
[[layer]]
tau = 1.0
albedo = 0.9
g = 0.95
";

const PEAKED_STACK: &str = "
[[layer]]
tau = 0.8
albedo = 0.95
g = 0.95
n = 1.33
[[layer]]
tau = 1.2
albedo = 0.9
g = 0.95
n = 1.6
[substrate]
kind = \"transparent\"
n = 1.5
";

/// Exit directions in and around the 10-degree cone of the transmitted beam
/// (30 deg in air; 19.5 deg in the substrate of index 1.5), where the solver
/// adds the second-order peak correction (IMS) for `|g| > 0.9`.
const CONE_THETA_O: [f64; 8] = [12.0, 16.0, 19.5, 22.0, 26.0, 30.0, 34.0, 39.0];
const CONE_PHI: [f64; 7] = [0.0, 90.0, 150.0, 170.0, 180.0, 190.0, 240.0];

/// With g = 0.95 the azimuthal series decays slowly (`chi_m = 0.95^m`), and
/// the two stopping rules (the table's: orders below 1e-9 of the largest
/// order-0 coefficient of the whole table; the solver's: below 1e-9 of its
/// largest value so far at its own directions) stop at different orders,
/// which alone moves values by up to ~1.5e-9 (measured with the IMS term
/// off on both sides). Both therefore sum the same fixed orders 0..=40
/// (none of them below the stopping threshold), so that the comparison
/// tests the operators, the single-scattering and the IMS correction.
fn peaked_opts() -> MultifluxOptions {
    MultifluxOptions { max_fourier_order: Some(40), ..Default::default() }
}

#[test]
fn equals_solve_peaked_slab_near_the_beam() {
    against_solve_at(PEAKED, &[0.0, 30.0, 60.0], &CONE_THETA_O, &CONE_PHI, &peaked_opts());
}

#[test]
fn equals_solve_peaked_stack_near_the_beam() {
    against_solve_at(PEAKED_STACK, &[30.0, 50.0], &CONE_THETA_O, &CONE_PHI, &peaked_opts());
}

#[test]
fn equals_solve_two_layer_coating() {
    against_solve(TWO_LAYER, &[0.0, 30.0, 60.0]);
}

#[test]
fn equals_solve_slab_between_media() {
    against_solve(SLAB_IN_GLASS, &[10.0, 50.0]);
}

#[test]
fn equals_solve_seed_lambertian() {
    against_solve(SEED, &[45.0, 75.0]);
}

#[test]
fn equals_solve_lone_layer() {
    against_solve(LONE, &[0.0, 40.0, 80.0]);
}

#[test]
fn incidence_from_below_equals_the_flipped_stack() {
    // From below = the stack turned over and lit from above (an independent
    // scene written by hand).
    let scene = Scene::from_toml_str(SLAB_IN_GLASS).unwrap();
    let flipped = Scene::from_toml_str(
        "[ambient]\nn = 1.5\n[[layer]]\ntau = 1.5\nalbedo = 0.95\ng = 0.8\nn = 1.33\n\
         [substrate]\nkind = \"transparent\"\nn = 1.0\n",
    )
    .unwrap();
    let opts = BsdfOptions { side: Side::Below, ..Default::default() };
    let a = Bsdf::new(&scene, &[20.0], &[10.0, 50.0], &opts).unwrap();
    let b = Bsdf::new(&flipped, &[20.0], &[10.0, 50.0], &BsdfOptions::default()).unwrap();
    for o in 0..2 {
        for p in [0.0, 90.0, 180.0] {
            assert_eq!(a.brdf(0, 0, o, p), b.brdf(0, 0, o, p));
            assert_eq!(a.btdf(0, 0, o, p), b.btdf(0, 0, o, p));
        }
    }
    // An opaque stack has no "below".
    let seed = Scene::from_toml_str(SEED).unwrap();
    assert!(Bsdf::new(&seed, &[20.0], &[10.0], &opts).is_err());
}

#[test]
fn energy_of_the_table_matches_the_totals() {
    // Gauss grid of 32 exit cosines: the hemispherical integral is a Gauss
    // quadrature of a function smooth in mu (these exits see no critical
    // angle); measured 5e-14 .. 5e-11; 1e-8 bounds the quadrature error of
    // a 32-node rule on such polynomials-like functions with margin.
    let (theta, _) = gauss_angles(32);
    for text in [TWO_LAYER, SEED, LONE] {
        let scene = Scene::from_toml_str(text).unwrap();
        let b = Bsdf::new(&scene, &theta[..], &theta, &BsdfOptions::default()).unwrap();
        let e = check::energy(&b, 72);
        println!("energy: largest |table - solver| = {:.2e}", e.max_error);
        assert!(e.max_error < 1e-8, "energy off by {}", e.max_error);
    }
    // The slab in glass: its BTDF has kinks where the Snell invariant
    // n sin(theta) of the glass direction crosses the ambient's 1.0 (41.8 deg)
    // and the layer's 1.33 (62.5 deg; beyond, nothing arrives): the plain
    // Gauss rule integrates it to 2.5e-3 only; a composite Gauss rule split
    // at both.
    let scene = Scene::from_toml_str(SLAB_IN_GLASS).unwrap();
    let mu_at = |s: f64| (1.0 - (s / 1.5f64).powi(2)).sqrt();
    let cuts = [0.0, mu_at(1.33), mu_at(1.0), 1.0];
    let (t16, w16) = gauss_angles(16);
    let (mut theta_s, mut w_s) = (Vec::new(), Vec::new());
    for seg in cuts.windows(2) {
        for (t, w) in t16.iter().zip(&w16) {
            let mu = seg[0] + t.to_radians().cos() * (seg[1] - seg[0]);
            theta_s.push(mu.acos().to_degrees());
            w_s.push(w * (seg[1] - seg[0]));
        }
    }
    let b = Bsdf::new(&scene, &theta[..8], &theta_s, &BsdfOptions::default()).unwrap();
    let e = check::energy_weighted(&b, &w_s, 72);
    println!("energy (slab in glass, split rule): {:.2e}", e.max_error);
    // Measured 7e-6 with 16 nodes per segment (1.6e-4 with one split, 2.5e-3
    // with none): the rule's error near the kinks; 5e-5 is 7x that.
    assert!(e.max_error < 5e-5, "energy off by {}", e.max_error);
    // A table that lost its BTDF would fail: the check sees the difference.
    let scene = Scene::from_toml_str(SLAB_IN_GLASS).unwrap();
    let mut b = Bsdf::new(&scene, &[30.0], &theta, &BsdfOptions::default()).unwrap();
    b.transmits = false;
    assert!(check::energy(&b, 72).max_error > 1e-2);
}

#[test]
fn reciprocity_of_reflection_and_the_n2_law() {
    let (theta, _) = gauss_angles(8);
    let phis = [0.0, 60.0, 150.0, 180.0];
    for text in [TWO_LAYER, SLAB_IN_GLASS, SEED, LONE] {
        let scene = Scene::from_toml_str(text).unwrap();
        let b = Bsdf::new(&scene, &theta, &theta, &BsdfOptions::default()).unwrap();
        let r = check::reciprocity(&b, &phis, 1e-3).unwrap();
        println!("reflection reciprocity: {r:.2e}");
        // Beams and probes meet in the same discrete operators, which are
        // reciprocal: measured 2e-14 .. 1.4e-11; 1e-9 leaves room for rounding
        // in the adding of larger stacks.
        assert!(r < 1e-9, "reciprocity {r}");
    }
    let scene = Scene::from_toml_str(SLAB_IN_GLASS).unwrap();
    let above = Bsdf::new(&scene, &theta, &theta, &BsdfOptions::default()).unwrap();
    let opts = BsdfOptions { side: Side::Below, ..Default::default() };
    let below = Bsdf::new(&scene, &theta, &theta, &opts).unwrap();
    let t = check::transmission_reciprocity(&above, &below, &phis, 1e-3).unwrap();
    println!("transmission reciprocity (n^2 law): {t:.2e}");
    // Measured 1.5e-9 (rounding through two Fresnel interfaces and the
    // flipped stack's own operators); 1e-7 is still far below the 0.1 that a
    // missing n^2 factor makes (checked next).
    assert!(t < 1e-7, "n^2 law {t}");
    // Without the n^2 factors the law fails: the check can tell.
    let mut wrong = above.clone();
    wrong.n_out = Some(1.0);
    wrong.n_in = 1.0;
    let w = check::transmission_reciprocity(&wrong, &below, &phis, 1e-3).unwrap();
    assert!(w > 0.1, "{w}");
}

#[test]
fn negatives_are_reported_where_they_are() {
    let scene = Scene::from_toml_str(SLAB_IN_GLASS).unwrap();
    let theta = [0.0, 30.0, 60.0, 80.0];
    let b = Bsdf::new(&scene, &theta, &theta, &BsdfOptions::default()).unwrap();
    let phis: Vec<f64> = (0..36).map(|k| 10.0 * k as f64).collect();
    let n = check::negatives(&b, &phis);
    // Independent scan by single evaluations.
    let mut count = 0;
    let mut worst = 0.0f64;
    for i in 0..4 {
        for o in 0..4 {
            for &p in &phis {
                for v in [b.brdf(0, i, o, p), b.btdf(0, i, o, p)] {
                    if v < 0.0 {
                        count += 1;
                        worst = worst.min(v);
                    }
                }
            }
        }
    }
    assert_eq!(n.count, count);
    assert_eq!(n.total, 2 * 16 * 36);
    assert_eq!(n.worst.map_or(0.0, |w| w.0), worst);
    println!("negatives: {} of {}, worst {:?}", n.count, n.total, n.worst);
}

#[test]
fn bad_grids_are_refused() {
    let scene = Scene::from_toml_str(LONE).unwrap();
    let o = BsdfOptions::default();
    assert!(Bsdf::new(&scene, &[], &[10.0], &o).is_err());
    assert!(Bsdf::new(&scene, &[90.0], &[10.0], &o).is_err());
    assert!(Bsdf::new(&scene, &[10.0], &[f64::NAN], &o).is_err());
    assert!(Bsdf::new(&scene, &[10.0], &[-1.0], &o).is_err());
}
