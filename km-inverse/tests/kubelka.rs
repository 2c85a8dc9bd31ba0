//! The Kubelka–Munk inverse against the closed forms of Kubelka (1948) and
//! against km-core's forward two-flux model (round trips over grids).

use km_core::Scene;
use km_core::two_flux::{self, KmCoefficients, KmOptions, layer_rt, r_infinity};
use km_inverse::kubelka::{
    KubelkaError, Saunderson, Specular, black_white_uncertainty, from_black_white, from_r_inf_r0,
    k_over_s, masstone_tint, mixture_reflectance, r_inf_from_k_over_s, r_inf_r0_uncertainty,
    reflectance_over_ground,
};
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};

/// Round-trip tolerance where the readings carry the information (b S X <= 4):
/// the inverse is a handful of operations, so its error is a few ulps times
/// the conditioning (~exp(2 b S X) <= 3000). Largest errors measured on these
/// grids: 6.2e-14 (R_inf, R_0) and 2.3e-13 (two grounds); see docs/inverse-km.md.
const ROUND_TRIP: f64 = 1e-12;

/// K/S values of the grids (0: a white film; 100: a very dark one).
const K_OVER_S: [f64; 7] = [0.0, 1e-3, 1e-2, 0.1, 1.0, 10.0, 100.0];
/// Scattering powers S X of the grids.
const SX: [f64; 7] = [0.01, 0.1, 0.5, 1.0, 2.0, 4.0, 8.0];
/// Film thickness (any unit; K, S come out per that unit).
const X: f64 = 0.7;

/// `b S X`: the film's optical depth in the two-flux attenuation; the
/// information about S X in `R_inf - R_0` decays like `exp(-2 b S X)`.
fn bsx(q: f64, sx: f64) -> f64 {
    sx * (q * (q + 2.0)).sqrt()
}

#[test]
fn r_inf_and_k_over_s_match_the_printed_closed_forms() {
    // Reference: Kubelka (1948) eq. 6 as printed, R_inf = 1 + K/S - sqrt((K/S)^2 + 2 K/S),
    // and km-core's r_infinity(K, S). The printed form loses ~ eps (K/S)^2 to
    // cancellation for large K/S (1e-12 at K/S = 100 on values ~5e-3), so the
    // comparison is absolute, 1e-12.
    let mut worst: f64 = 0.0;
    for &q in &[0.0f64, 1e-6, 1e-3, 0.05, 0.3, 1.0, 3.0, 10.0, 30.0] {
        let printed = 1.0 + q - (q * q + 2.0 * q).sqrt();
        let r = r_inf_from_k_over_s(q).unwrap();
        let core = r_infinity(q * 2.5, 2.5).unwrap();
        worst = worst.max((r - printed).abs()).max((r - core).abs());
        // And back: K/S = (1 - R)^2 / (2R), relative.
        if q > 0.0 {
            worst = worst.max((k_over_s(r).unwrap() - q).abs() / q);
        }
    }
    assert!(worst < 1e-12, "worst {worst:e}");
}

#[test]
fn reflectance_over_ground_matches_kubelka_hyperbolic_form() {
    // Reference: Kubelka (1948) eq. 11 typed as printed:
    // R = (1 - R_g (a - b coth(bSX))) / (a - R_g + b coth(bSX)),
    // evaluated where coth is well conditioned (b S X in [0.02, 5]).
    let mut worst: f64 = 0.0;
    for &(k, s) in &[(0.01f64, 1.0f64), (0.3, 2.0), (1.0, 1.0), (5.0, 0.5)] {
        let a = (k + s) / s;
        let b = (a * a - 1.0).sqrt();
        for &x in &[0.1, 0.5, 1.0, 2.0] {
            let coth = 1.0 / (b * s * x).tanh();
            if !(0.02..=5.0).contains(&(b * s * x)) {
                continue;
            }
            for &rg in &[0.0, 0.05, 0.5, 0.9, 1.0] {
                let kubelka = (1.0 - rg * (a - b * coth)) / (a - rg + b * coth);
                let r = reflectance_over_ground(k, s, x, rg).unwrap();
                worst = worst.max((r - kubelka).abs());
            }
        }
    }
    // Rounding of the printed form (coth near 1/(bSX), a few ulps) bounds the
    // agreement; 1e-12 as the brief's closed-form tolerance.
    assert!(worst < 1e-12, "worst {worst:e}");
}

/// Error of a fitted (K, S) on the scale of S: `K/S = a - 1` is found from
/// `a ~ 1` for weak absorbers, so its absolute (not relative) error is what
/// the data bound; for K/S >= 0.1 this is also K's relative error within 10x.
fn err(k: f64, s: f64, fk: f64, fs: f64) -> (f64, f64) {
    ((fk - k).abs() / s, (fs - s).abs() / s)
}

#[test]
fn r_inf_r0_round_trip_over_a_grid() {
    let (mut worst, mut count) = (0.0f64, 0);
    for &q in &K_OVER_S {
        for &sx in &SX {
            let (s, k) = (sx / X, q * sx / X);
            // Forward with km-core: the opaque film and the film over black.
            let r_inf = r_infinity(k, s).unwrap();
            let r0 = layer_rt(k, s, X).unwrap().r;
            let depth = bsx(q, sx);
            match from_r_inf_r0(r_inf, r0, X) {
                Ok(f) => {
                    let (ek, es) = err(k, s, f.k, f.s);
                    if depth <= 4.0 {
                        worst = worst.max(ek).max(es);
                        count += 1;
                    } else {
                        // Beyond b S X = 4 the readings hold S X only to
                        // ~ eps exp(2 b S X) (R_inf - R_0 ~ exp(-2bSX)); 8 eps of slack.
                        let bound = 8.0 * f64::EPSILON * (2.0 * depth).exp();
                        assert!(ek.max(es) < bound, "q {q} sx {sx}: {ek:e} {es:e} > {bound:e}");
                    }
                    // Whatever the conditioning, the fitted film reproduces the readings.
                    assert!((layer_rt(f.k, f.s, X).unwrap().r - r0).abs() < 1e-15);
                    assert!((f.r_inf - r_inf).abs() < 1e-15 && (f.r0 - r0).abs() < 1e-15);
                }
                Err(e) => {
                    // Only films opaque to double precision may be refused.
                    assert!(r0 == r_inf && depth > 18.0, "q {q} sx {sx}: {e}");
                    assert!(matches!(e, KubelkaError::Infeasible { .. }));
                }
            }
        }
    }
    assert!(count >= 35, "{count} well-conditioned points");
    println!("worst {worst:e} over {count} points");
    assert!(worst < ROUND_TRIP, "worst {worst:e}");
}

#[test]
fn black_white_round_trip_over_a_grid_of_films_and_grounds() {
    let grounds = [(0.0, 0.8), (0.02, 0.85), (0.05, 1.0), (0.3, 0.6)];
    let (mut worst, mut count) = (0.0f64, 0);
    for &(gb, gw) in &grounds {
        for &q in &K_OVER_S {
            for &sx in &SX {
                let (s, k) = (sx / X, q * sx / X);
                // Forward with km-core's adding of layer and ground.
                let rb = reflectance_over_ground(k, s, X, gb).unwrap();
                let rw = reflectance_over_ground(k, s, X, gw).unwrap();
                let depth = bsx(q, sx);
                match from_black_white(rb, gb, rw, gw, X) {
                    Ok(f) => {
                        let (ek, es) = err(k, s, f.k, f.s);
                        if depth <= 4.0 {
                            worst = worst.max(ek).max(es);
                            count += 1;
                        } else {
                            let bound = 8.0 * f64::EPSILON * (2.0 * depth).exp();
                            assert!(ek.max(es) < bound, "{gb} {gw} q {q} sx {sx}: {ek:e} {es:e}");
                        }
                        // The fitted film reproduces both readings.
                        let back_b = reflectance_over_ground(f.k, f.s, X, gb).unwrap();
                        let back_w = reflectance_over_ground(f.k, f.s, X, gw).unwrap();
                        assert!((back_b - rb).abs() < 1e-14 && (back_w - rw).abs() < 1e-14);
                    }
                    Err(e) => assert!(rb == rw && depth > 18.0, "{gb} {gw} q {q} sx {sx}: {e}"),
                }
            }
        }
    }
    assert!(count >= 140, "{count} well-conditioned points");
    println!("worst {worst:e} over {count} points");
    assert!(worst < ROUND_TRIP, "worst {worst:e}");
}

#[test]
fn ideal_black_two_ground_form_equals_kubelka_a_formula() {
    // Kubelka (1948): a = (R_w + (R_0 - R_w + R_g) / (R_0 R_g)) / 2 for an ideal black,
    // and R_inf = a - b; from_black_white uses the general Cramer form (I6).
    let (k, s, x, g) = (0.4, 3.0, 0.3, 0.8);
    let r0 = layer_rt(k, s, x).unwrap().r;
    let rw = reflectance_over_ground(k, s, x, g).unwrap();
    let a = 0.5 * (rw + (r0 - rw + g) / (r0 * g));
    let r_inf = a - (a * a - 1.0).sqrt();
    let f = from_black_white(r0, 0.0, rw, g, x).unwrap();
    assert!((f.r_inf - r_inf).abs() < 1e-14, "{} {}", f.r_inf, r_inf);
    assert!((f.k_over_s - (a - 1.0)).abs() < 1e-14);
}

#[test]
fn saunderson_round_trip_and_the_scene_solver() {
    // 1. Both directions are inverses, for both geometries.
    for sp in [Specular::Included, Specular::Excluded] {
        let c = Saunderson::new(0.04, 0.6, sp).unwrap();
        for i in 0..=100 {
            let r = i as f64 / 100.0;
            let m = c.measured_from_internal(r).unwrap();
            assert!((c.internal_from_measured(m).unwrap() - r).abs() < 1e-14, "{r}");
        }
    }
    // 2. km-core's scene solver with a binder of index n over a Lambertian
    // ground, lit at normal incidence, adds exactly Saunderson's interface
    // (docs/two-flux.md eq. K11-K12); Saunderson::fresnel(n) must undo it, and
    // the two-ground inverse must then recover the scene's K = sigma_a, S = sigma_s.
    let (k, s, x, n) = (0.35, 4.0, 0.2, 1.5);
    let measure = |ground: f64| {
        let toml = format!(
            "[light]\nkind = \"collimated\"\ntheta_deg = 0.0\n[[layer]]\nsigma_a = {k}\n\
             sigma_s = {s}\nthickness = {x}\nn = {n}\n[substrate]\nkind = \"lambertian\"\n\
             albedo = {ground}\n"
        );
        let scene = Scene::from_toml_str(&toml).unwrap();
        two_flux::solve(&scene, &KmOptions::SEED).unwrap().channels[0].reflectance
    };
    let (gb, gw) = (0.03, 0.82);
    let c = Saunderson::fresnel(n, Specular::Included).unwrap();
    let rb = c.internal_from_measured(measure(gb)).unwrap();
    let rw = c.internal_from_measured(measure(gw)).unwrap();
    let f = from_black_white(rb, gb, rw, gw, x).unwrap();
    let (ek, es) = err(k, s, f.k, f.s);
    // The scene solver's r_e is the same Fresnel value and its r_i the same
    // integral: agreement to rounding, 1e-12 as above.
    assert!(ek < ROUND_TRIP && es < ROUND_TRIP, "{ek:e} {es:e}");
}

#[test]
fn masstone_and_tint_recover_the_pigment_and_predict_mixtures() {
    let white = KmCoefficients { k: 0.004, s: 1.0 };
    let mut worst: f64 = 0.0;
    for &(kp, sp) in &[(2.0, 0.1), (0.5, 0.02), (8.0, 1.5), (0.05, 0.3)] {
        let pigment = KmCoefficients { k: kp, s: sp };
        for &cp in &[0.01, 0.1, 0.5] {
            let cw = 1.0 - cp;
            // Forward (Duncan, km-core's mix_pigments): masstone and tint, opaque.
            let r_m = mixture_reflectance(&[1.0], &[pigment], f64::INFINITY, 0.0).unwrap();
            let r_t =
                mixture_reflectance(&[cp, cw], &[pigment, white], f64::INFINITY, 0.0).unwrap();
            let p = masstone_tint(r_m, r_t, cp, cw, white).unwrap();
            worst = worst.max((p.k - kp).abs() / kp).max((p.s - sp).abs() / sp);
            // Predict another tint with the fitted constants.
            let pred = mixture_reflectance(&[0.3, 0.7], &[p, white], f64::INFINITY, 0.0).unwrap();
            let truth =
                mixture_reflectance(&[0.3, 0.7], &[pigment, white], f64::INFINITY, 0.0).unwrap();
            assert!((pred - truth).abs() < 1e-13);
        }
    }
    // Three divisions after eq. I1 on each reading; 1e-12 as the round trips.
    assert!(worst < ROUND_TRIP, "worst {worst:e}");
}

#[test]
fn mixture_of_a_film_over_a_ground_is_the_forward_model() {
    let a = KmCoefficients { k: 0.2, s: 3.0 };
    let b = KmCoefficients { k: 4.0, s: 0.5 };
    let r = mixture_reflectance(&[1.0, 3.0], &[a, b], 0.4, 0.7).unwrap();
    let (k, s) = ((0.2 + 12.0) / 4.0, (3.0 + 1.5) / 4.0);
    let slab = two_flux::add(
        &two_flux::Slab::layer(k, s, 0.4).unwrap(),
        &two_flux::Slab::ground(0.7).unwrap(),
    );
    assert!((r - slab.r_top).abs() < 1e-15);
}

fn names(e: KubelkaError) -> (String, f64) {
    match e {
        KubelkaError::Invalid { name, value, .. }
        | KubelkaError::Infeasible { name, value, .. } => (name, value),
        KubelkaError::Core(c) => panic!("core error {c}"),
    }
}

#[test]
fn infeasible_and_invalid_inputs_are_refused_by_name() {
    // Readings swapped: more over black than over white.
    let e = from_black_white(0.6, 0.0, 0.4, 0.8, 1.0).unwrap_err();
    assert_eq!(names(e.clone()), ("r_black".into(), 0.6));
    assert!(e.to_string().contains("r_white = 0.4"), "{e}");
    // Out of [0, 1].
    assert_eq!(names(from_black_white(1.2, 0.0, 0.4, 0.8, 1.0).unwrap_err()).0, "r_black");
    assert_eq!(names(from_black_white(0.2, 0.0, 0.4, -0.1, 1.0).unwrap_err()).0, "r_white_ground");
    assert_eq!(names(from_black_white(0.2, 0.9, 0.4, 0.8, 1.0).unwrap_err()).0, "r_black_ground");
    assert_eq!(names(from_black_white(0.2, 0.0, 0.4, 0.8, 0.0).unwrap_err()).0, "thickness");
    assert_eq!(names(from_black_white(0.2, 0.0, 0.4, 0.8, f64::NAN).unwrap_err()).0, "thickness");
    // A pair that needs K < 0: over white the film shows more than the white
    // ground and a lossless layer could give (R_w = 0.99 with R_0 = 0.1, g = 0.5).
    let e = from_black_white(0.1, 0.0, 0.99, 0.5, 1.0).unwrap_err();
    assert!(matches!(e, KubelkaError::Infeasible { .. }), "{e}");
    // R_0 at or above R_inf.
    assert_eq!(names(from_r_inf_r0(0.5, 0.5, 1.0).unwrap_err()), ("r_zero".into(), 0.5));
    assert_eq!(names(from_r_inf_r0(0.5, 0.6, 1.0).unwrap_err()).0, "r_zero");
    assert_eq!(names(from_r_inf_r0(0.0, 0.0, 1.0).unwrap_err()).0, "r_inf");
    assert_eq!(names(from_r_inf_r0(0.5, 0.0, 1.0).unwrap_err()).0, "r_zero");
    // Saunderson: measured below the surface reflection.
    let c = Saunderson::from_index(1.5, 0.6, Specular::Included).unwrap();
    assert_eq!(names(c.internal_from_measured(0.01).unwrap_err()).0, "measured reflectance");
    assert_eq!(names(Saunderson::from_index(0.5, 0.6, Specular::Included).unwrap_err()).0, "n");
    // Masstone and tint: a tint darker than the masstone.
    let white = KmCoefficients { k: 0.004, s: 1.0 };
    let e = masstone_tint(0.3, 0.2, 0.1, 0.9, white).unwrap_err();
    assert_eq!(names(e).0, "r_inf_tint");
    assert_eq!(names(k_over_s(f64::INFINITY).unwrap_err()).0, "r_inf");
    assert_eq!(names(r_inf_from_k_over_s(-1.0).unwrap_err()).0, "K/S");
}

/// Sample standard deviations of two series and their correlation.
fn sample_stats(a: &[f64], b: &[f64]) -> (f64, f64, f64) {
    let n = a.len() as f64;
    let (ma, mb) = (a.iter().sum::<f64>() / n, b.iter().sum::<f64>() / n);
    let (mut va, mut vb, mut cab) = (0.0, 0.0, 0.0);
    for (x, y) in a.iter().zip(b) {
        va += (x - ma) * (x - ma);
        vb += (y - mb) * (y - mb);
        cab += (x - ma) * (y - mb);
    }
    ((va / (n - 1.0)).sqrt(), (vb / (n - 1.0)).sqrt(), cab / (va * vb).sqrt())
}

#[test]
fn propagated_uncertainty_matches_monte_carlo_perturbation() {
    // Perturb the readings with Gaussian noise of the stated standard
    // uncertainty, fit each draw, and compare the scatter of K and S with the
    // first-order propagation. N = 20000 draws: the relative standard error
    // of a sample standard deviation is 1/sqrt(2N) = 0.5 %, of a correlation
    // (1 - rho^2)/sqrt(N) <= 0.7 %; tolerances are 5 of those (2.5 %, and
    // 0.035 for the correlation), the noise being small enough (2e-4) that
    // the second-order terms are below 0.1 %.
    const N: usize = 20_000;
    let mut rng = rand_pcg::Pcg64::seed_from_u64(20261129);
    let (k, s, x) = (0.3, 2.0, 0.5);
    let cases: [(&str, [f64; 2], [f64; 2]); 2] =
        [("black_white", [0.02, 0.85], [2e-4, 2e-4]), ("r_inf_r0", [0.0, 0.0], [1e-4, 3e-4])];
    for (name, grounds, u) in cases {
        let (r1, r2) = if name == "black_white" {
            (
                reflectance_over_ground(k, s, x, grounds[0]).unwrap(),
                reflectance_over_ground(k, s, x, grounds[1]).unwrap(),
            )
        } else {
            (r_infinity(k, s).unwrap(), layer_rt(k, s, x).unwrap().r)
        };
        let fit = |a: f64, b: f64| {
            if name == "black_white" {
                from_black_white(a, grounds[0], b, grounds[1], x)
            } else {
                from_r_inf_r0(a, b, x)
            }
        };
        let predicted = if name == "black_white" {
            black_white_uncertainty(r1, grounds[0], r2, grounds[1], x, u[0], u[1]).unwrap()
        } else {
            r_inf_r0_uncertainty(r1, r2, x, u[0], u[1]).unwrap()
        };
        let (n1, n2) = (Normal::new(0.0, u[0]).unwrap(), Normal::new(0.0, u[1]).unwrap());
        let (mut ks, mut ss) = (Vec::with_capacity(N), Vec::with_capacity(N));
        for _ in 0..N {
            let f = fit(r1 + n1.sample(&mut rng), r2 + n2.sample(&mut rng)).unwrap();
            ks.push(f.k);
            ss.push(f.s);
        }
        let (sk, s_s, rho) = sample_stats(&ks, &ss);
        println!(
            "{name}: u(K) {:.4e} vs MC {sk:.4e}, u(S) {:.4e} vs MC {s_s:.4e}, rho {:.4} vs {rho:.4}",
            predicted.k, predicted.s, predicted.correlation
        );
        assert!((predicted.k / sk - 1.0).abs() < 0.025, "{name}: K {} vs {sk}", predicted.k);
        assert!((predicted.s / s_s - 1.0).abs() < 0.025, "{name}: S {} vs {s_s}", predicted.s);
        assert!((predicted.correlation - rho).abs() < 0.035, "{name}: rho");
    }
    // Uncertainties must be finite and >= 0.
    let e = r_inf_r0_uncertainty(0.6, 0.4, 1.0, -1e-3, 1e-3).unwrap_err();
    assert!(matches!(e, KubelkaError::Invalid { .. }), "{e}");
}
