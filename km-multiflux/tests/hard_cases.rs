//! The hard-case grid of the issue: tau from 1e-6 to 1e6 and infinite, albedo
//! up to exactly 1, strongly peaked phase functions, refractive indices up
//! to 2.5 (total internal reflection), incidence up to 89 degrees. Every case
//! must be finite and pass the checks that have an independent answer.

mod common;
use common::scene;
use km_core::fresnel::{reflectance, snell_cos_t};
use km_multiflux::{MultifluxOptions, solve};

const TAUS: [f64; 6] = [1e-6, 1e-3, 1.0, 1e3, 1e6, f64::INFINITY];
const OMEGAS: [f64; 5] = [0.0, 0.5, 0.99, 0.999999, 1.0];
const GS: [f64; 4] = [-0.9, 0.0, 0.9, 0.99];
const NS: [f64; 4] = [1.0, 1.33, 1.5, 2.5];
const THETAS: [f64; 4] = [0.0, 45.0, 75.0, 89.0];

fn text(tau: f64, omega: f64, g: f64, n: f64, theta: f64, dirs: bool) -> String {
    let tau = if tau.is_infinite() { "\"inf\"".to_string() } else { format!("{tau:e}") };
    let mut t = format!(
        "[light]\ntheta_deg = {theta}\n[[layer]]\ntau = {tau}\nalbedo = {omega}\ng = {g}\nn = {n}\n"
    );
    if dirs {
        t += "[output]\ndirections_deg = [[0.0, 0.0], [45.0, 180.0], [89.0, 90.0], [30.0, 0.0]]\n";
    }
    t
}

/// Slab of index n in air, no scattering: the closed form with multiple
/// reflections, R = r + (1-r)^2 r E^2 / (1 - r^2 E^2), T = (1-r)^2 E / (1 - r^2 E^2),
/// E = exp(-tau / mu_t) (Born & Wolf; incoherent sum).
fn clear_slab(tau: f64, n: f64, theta: f64) -> (f64, f64) {
    let mu0 = theta.to_radians().cos();
    let r = reflectance(mu0, 1.0, n);
    let mu_t = snell_cos_t(mu0, 1.0, n).unwrap();
    let e = if tau.is_infinite() { 0.0 } else { (-tau / mu_t).exp() };
    let d = 1.0 - r * r * e * e;
    (r + (1.0 - r) * (1.0 - r) * r * e * e / d, (1.0 - r) * (1.0 - r) * e / d)
}

/// The checks across the sweep of `TAUS` at one (n, g, omega, theta): `r_at`
/// and `t_at` hold R and T at each tau; every failure is pushed to `failures`.
fn check_tau_sweep(
    r_at: &[f64],
    t_at: &[f64],
    n: f64,
    g: f64,
    omega: f64,
    theta: f64,
    failures: &mut Vec<String>,
) {
    // tau = 1e6 and the half-space agree (1e-10) unless scattering
    // is conservative: then T ~ 1/tau_tr leaks through. Diffusion
    // theory: T = (z0 + z_b) / (tau_tr + 2 z_b), z0 = 1,
    // z_b = 2A/3, A = (1 + F_dr)/(1 - F_dr) (internal reflection);
    // bounded here by twice (1 + 2A/3) / tau_tr, and R = 1 - T.
    let fdr = km_core::fresnel::diffuse_reflectance(n, 1.0);
    let a_ref = (1.0 + fdr) / (1.0 - fdr);
    let t_max = 2.0 * (1.0 + 2.0 * a_ref / 3.0) / (1e6 * (1.0 - g));
    let (r6, rinf) = (r_at[4], r_at[5]);
    if omega < 1.0 && (r6 - rinf).abs() > 1e-10 {
        failures.push(format!("tau=1e6 vs inf: {r6} {rinf} (n {n} g {g} w {omega} th {theta})"));
    }
    if omega == 1.0 && !(t_at[4] > 0.0 && t_at[4] < t_max) {
        failures.push(format!("conservative tau=1e6: T = {} (n {n} g {g} th {theta})", t_at[4]));
    }
    // A conservative half-space reflects everything, exactly.
    if omega == 1.0 && rinf != 1.0 {
        failures.push(format!("conservative half-space R = {rinf}"));
    }
    // tau = 1e-6 is the bare interface pair up to O(1e-6 / mu).
    let (rc, _) = clear_slab(0.0, n, theta);
    if (r_at[0] - rc).abs() > 2e-4 {
        failures.push(format!("thin slab {} vs {rc} (n {n} g {g} w {omega} th {theta})", r_at[0]));
    }
}

#[test]
fn hard_case_grid_totals() {
    let o = MultifluxOptions::default();
    let (mut count, mut finite, mut outside) = (0, 0, 0);
    let mut failures = Vec::new();
    for &n in &NS {
        for &g in &GS {
            for &omega in &OMEGAS {
                for &theta in &THETAS {
                    let mut r_at = Vec::new();
                    let mut t_at = Vec::new();
                    for &tau in &TAUS {
                        count += 1;
                        let t = text(tau, omega, g, n, theta, false);
                        let c = match solve(&scene(&t), &o) {
                            Ok(s) => s.channels[0].clone(),
                            Err(e) => {
                                failures.push(format!("error {e}: {t}"));
                                continue;
                            }
                        };
                        let (r, tr, a) = (c.reflectance, c.transmittance, c.absorptance);
                        if [r, tr, a].iter().all(|x| x.is_finite()) {
                            finite += 1;
                        }
                        let mut bad =
                            |what: &str| failures.push(format!("{what}: R {r} T {tr} A {a}\n{t}"));
                        // Bounds, exactly: no answer outside [0, 1], A >= 0 (eq. 18a
                        // of docs/multiflux.md makes them hold to the last bit).
                        if !(0.0..=1.0).contains(&r)
                            || !(0.0..=1.0).contains(&tr)
                            || !(0.0..=1.0).contains(&a)
                            || !(0.0..=1.0).contains(&c.reflectance_specular)
                            || !(0.0..=1.0).contains(&c.transmittance_direct)
                        {
                            bad("bounds");
                        }
                        // Conservative scattering in a lossless stack (the substrate
                        // is a clear half-space) absorbs nothing: A = 0 exactly.
                        if omega == 1.0 && a != 0.0 {
                            bad("omega = 1 absorbs");
                        }
                        outside += [r, tr, a].iter().filter(|x| !(0.0..=1.0).contains(*x)).count();
                        // No scattering: the closed form (rounding only, 1e-12).
                        if omega == 0.0 {
                            let (rr, tt) = clear_slab(tau, n, theta);
                            if (r - rr).abs() > 1e-12 || (tr - tt).abs() > 1e-12 {
                                bad(&format!("clear slab: expected R {rr} T {tt}"));
                            }
                        }
                        r_at.push(r);
                        t_at.push(tr);
                    }
                    if r_at.len() == TAUS.len() {
                        check_tau_sweep(&r_at, &t_at, n, g, omega, theta, &mut failures);
                    }
                }
            }
        }
    }
    println!(
        "hard-case grid: {count} cases, {finite} finite, {outside} answers outside [0, 1], {} \
         failures",
        failures.len()
    );
    assert!(
        failures.is_empty(),
        "{} failures:\n{}",
        failures.len(),
        failures[..failures.len().min(10)].join("\n")
    );
    assert_eq!(count, 1920);
    assert_eq!(finite, 1920);
    assert_eq!(outside, 0);
}

/// The conservative half-space under an index change of the issue (omega = 1,
/// g = 0.99, n = 1.5, normal incidence), where the adding's rounding gave
/// R = 1 + 1.5e-12 .. 1 + 2.6e-10: now R = 1 and A = 0 exactly, and the size
/// of the fix-up is reported (`conservation_residual`, below 1e-9: rounding).
/// With omega = 0.999999 (not lossless) nothing is forced: A > 0.
#[test]
fn conservative_half_space_reflects_exactly_one() {
    for &n in &[1.33, 1.5, 2.5] {
        for &g in &[0.9, 0.99] {
            for &theta in &[0.0, 45.0, 89.0] {
                let t = text(f64::INFINITY, 1.0, g, n, theta, false);
                let s = solve(&scene(&t), &MultifluxOptions::default()).unwrap();
                let c = &s.channels[0];
                assert_eq!(c.reflectance, 1.0, "{t}");
                assert_eq!(c.absorptance, 0.0, "{t}");
                assert_eq!(c.transmittance, 0.0, "{t}");
                let res =
                    s.to_json().get("conservation_residual").map_or(0.0, |v| v.as_f64().unwrap());
                assert!(res < 1e-9, "residual {res}\n{t}");
                let t = text(f64::INFINITY, 0.999999, g, n, theta, false);
                let c = solve(&scene(&t), &MultifluxOptions::default()).unwrap().channels.remove(0);
                assert!(c.absorptance > 0.0 && c.reflectance < 1.0, "{t}");
            }
        }
    }
}

/// The same grid at 16 and 32 streams, on its scattering cases: the totals
/// move by less than 1e-4 (the accuracy target: 16 streams are converged)
/// for isotropic scattering or index-matched layers, up to 75 degrees of
/// incidence. Three corners converge more slowly (measured, see
/// docs/multiflux.md), and there the test only bounds the change:
/// |g| = 0.9 inside a mismatched index (the phase function's lobes against
/// the critical cone: ~1e-3 at 16 streams, 3e-5 at 32); g = 0.99, where
/// delta-M still moves g^{2N} = 0.72 of the scattering into the forward peak
/// at N = 16 (~1e-2); and 89 degrees, where the once-scattered light of the
/// grazing beam stays near the horizon, where Gauss nodes are sparse (2e-2).
#[test]
fn hard_case_grid_converges() {
    let (o16, o32) = (
        MultifluxOptions { streams: Some(16), ..Default::default() },
        MultifluxOptions { streams: Some(32), ..Default::default() },
    );
    let mut worst = (0.0f64, String::new());
    let (mut grazing, mut peaked, mut lobes) = (0.0f64, 0.0f64, 0.0f64);
    let mut count = 0;
    for &n in &NS {
        for &g in &GS {
            for &omega in &OMEGAS[1..] {
                for &theta in &[0.0, 75.0, 89.0] {
                    for &tau in &[1e-3, 1.0, 1e3, f64::INFINITY] {
                        let t = text(tau, omega, g, n, theta, false);
                        let a = solve(&scene(&t), &o16).unwrap().channels.remove(0);
                        let b = solve(&scene(&t), &o32).unwrap().channels.remove(0);
                        let d = (a.reflectance - b.reflectance)
                            .abs()
                            .max((a.transmittance - b.transmittance).abs());
                        if theta == 89.0 {
                            grazing = grazing.max(d);
                        } else if g > 0.9 {
                            peaked = peaked.max(d);
                        } else if g != 0.0 && n != 1.0 {
                            lobes = lobes.max(d);
                        } else if d > worst.0 {
                            worst = (d, t);
                        }
                        count += 1;
                    }
                }
            }
        }
    }
    println!(
        "convergence 16 -> 32 streams over {count} cases: worst {:.2e} (theta <= 75, g = 0 or n = 1); \
         |g| = 0.9 with n > 1: {lobes:.2e}; g = 0.99: {peaked:.2e}; theta = 89: {grazing:.2e}",
        worst.0
    );
    assert!(worst.0 < 1e-4, "{:.3e}\n{}", worst.0, worst.1);
    assert!(
        lobes < 3e-3 && peaked < 1e-2 && grazing < 3e-2,
        "{lobes:.3e} {peaked:.3e} {grazing:.3e}"
    );
}

/// BRDF/BTDF on a sub-grid (all Fourier orders, any exit direction): finite,
/// and non-negative except for the small ringing of the truncated phase series
/// (bounded by 1e-3 of the largest value).
#[test]
fn hard_case_grid_brdf() {
    let o = MultifluxOptions::default();
    let mut count = 0;
    for &n in &[1.0, 2.5] {
        for &g in &[-0.9, 0.99] {
            for &omega in &[0.5, 0.999999, 1.0] {
                for &theta in &[0.0, 89.0] {
                    for &tau in &[1e-6, 1.0, 1e6, f64::INFINITY] {
                        let t = text(tau, omega, g, n, theta, true);
                        let c = solve(&scene(&t), &o).unwrap().channels.remove(0);
                        let all: Vec<f64> = c.brdf.iter().chain(&c.btdf).copied().collect();
                        let top = all.iter().fold(0.0f64, |a, &b| a.max(b.abs()));
                        for &x in &all {
                            assert!(
                                x.is_finite() && x >= -1e-3 * top - 1e-12,
                                "{x} (max {top})\n{t}"
                            );
                        }
                        count += 1;
                    }
                }
            }
        }
    }
    assert_eq!(count, 96);
}

/// The default stream count meets 1e-4 in the |g| = 0.9 corners that 16
/// streams miss (it switches to 32 there): compared with 64 streams.
#[test]
fn default_streams_meet_the_target_in_the_peaked_corner() {
    let o64 = MultifluxOptions { streams: Some(64), ..Default::default() };
    let mut worst = 0.0f64;
    for &n in &[1.5, 2.5] {
        for &g in &[-0.9, 0.9] {
            for &theta in &[0.0, 75.0] {
                let t = text(1.0, 0.99, g, n, theta, false);
                let a = solve(&scene(&t), &MultifluxOptions::default()).unwrap().channels.remove(0);
                let b = solve(&scene(&t), &o64).unwrap().channels.remove(0);
                worst = worst
                    .max((a.reflectance - b.reflectance).abs())
                    .max((a.transmittance - b.transmittance).abs());
            }
        }
    }
    println!("default streams, |g| = 0.9 in n = 1.5, 2.5: worst {worst:.2e} vs 64 streams");
    assert!(worst < 1e-4, "{worst:.3e}");
}

/// g = 0.99 (|g| > 0.95) in an index-matched layer: the default stream
/// count meets 1e-4 on the totals against a converged reference, 256 streams
/// of the same solver (whose own distance to 128 streams is <= 6e-8 up to
/// 75 degrees). Defaults: 32 streams up to 75 degrees, 128 at 89 degrees.
/// At 89 degrees the convergence in N is not monotone (w = 0.5: 3.6e-5 at
/// N = 96, 1.5e-4 at N = 128 from 256), so the reference is itself uncertain
/// at ~1e-4 there: measured 9.0e-5 at w = 0.99, bounded here by 2e-4.
#[test]
fn default_streams_meet_the_target_at_g_099() {
    let o256 = MultifluxOptions { streams: Some(256), ..Default::default() };
    let (mut worst, mut worst_grazing) = (0.0f64, 0.0f64);
    for &theta in &[0.0, 75.0, 89.0] {
        let t = text(1.0, 0.99, 0.99, 1.0, theta, false);
        let a = solve(&scene(&t), &MultifluxOptions::default()).unwrap();
        let b = solve(&scene(&t), &o256).unwrap().channels.remove(0);
        let c = &a.channels[0];
        let e =
            (c.reflectance - b.reflectance).abs().max((c.transmittance - b.transmittance).abs());
        let expect = if theta > 80.0 { 128 } else { 32 };
        assert_eq!(a.to_json()["streams"], expect, "{t}");
        if theta > 80.0 {
            worst_grazing = worst_grazing.max(e);
        } else {
            worst = worst.max(e);
        }
    }
    println!(
        "g = 0.99, default streams vs 256: {worst:.2e} (<= 75 deg), {worst_grazing:.2e} (89 deg)"
    );
    assert!(worst < 1e-4, "{worst:.3e}");
    assert!(worst_grazing < 2e-4, "{worst_grazing:.3e}");
}
