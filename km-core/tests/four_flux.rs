//! The four-flux model (docs/two-flux.md §12): the layer's collimated
//! responses against RK4 integration of eq. K16, split layers against the
//! whole, energy balance, and the clear cases against the closed-form
//! Fresnel plate.

use km_core::Scene;
use km_core::fresnel;
use km_core::two_flux::{
    FourSlab, KmModel, KmOptions, Slab, add_four, backscatter_fraction, collimated_layer, layer_rt,
    solve,
};

/// `(R_cd, T_cd)` of a layer by shooting with RK4 on eq. K16: start at
/// `z = 0` with `i+ = 0`, `i- = x`, integrate to `z = d`, and choose `x` so
/// that `i-(d) = 0` (the equations are linear in `x`).
fn rk4_layer(k: f64, s: f64, beta: f64, fwd: f64, bwd: f64, d: f64, steps: usize) -> (f64, f64) {
    let deriv = |y: [f64; 3]| {
        let [c, p, m] = y;
        [-beta * c, -(k + s) * p + s * m + fwd * c, -s * p + (k + s) * m - bwd * c]
    };
    let run = |x: f64| {
        let mut y = [1.0, 0.0, x];
        let h = d / steps as f64;
        for _ in 0..steps {
            let k1 = deriv(y);
            let k2 = deriv(std::array::from_fn(|i| y[i] + 0.5 * h * k1[i]));
            let k3 = deriv(std::array::from_fn(|i| y[i] + 0.5 * h * k2[i]));
            let k4 = deriv(std::array::from_fn(|i| y[i] + h * k3[i]));
            y = std::array::from_fn(|i| {
                y[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
            });
        }
        y
    };
    let (y0, y1) = (run(0.0), run(1.0));
    let x = -y0[2] / (y1[2] - y0[2]);
    (x, y0[1] + x * (y1[1] - y0[1]))
}

/// The closed forms (eq. K21–K22) against RK4, across the resonance
/// `beta = lambda`, at `K = 0`, `S = 0`, thin and thick. Tolerance 1e-11:
/// RK4 with 4000 steps has a truncation error of about `(h L)^4 / 120` per
/// unit length (`L` the largest rate, here <= 12, `h L <= 0.03`), measured
/// below 1e-12 on these cases.
#[test]
fn collimated_layer_matches_rk4_shooting() {
    // (K, S, sigma_a, sigma_s, b, mu, d)
    let cases = [
        (0.1f64, 0.4, 0.05, 0.6, 0.3, 0.8, 1.0),
        (2.0, 0.075, 1.0, 0.1, 0.5, 0.0, 1.0), // mu set below for beta = lambda
        (0.0, 0.5, 0.0, 0.7, 0.2, 0.6, 2.0),   // K = 0
        (0.3, 0.0, 0.3, 0.2, 0.4, 0.9, 1.5),   // S = 0
        (0.2, 0.9, 0.1, 1.2, 0.05, 1.0, 4.0),  // thick: lambda d ~ 2.7, beta d ~ 5
        (1.0, 3.0, 0.5, 3.5, 0.45, 0.35, 0.01), // thin, slanted
    ];
    for (i, &(k, s, sa, ss, b, mu, d)) in cases.iter().enumerate() {
        let lambda = (k * (k + 2.0 * s)).sqrt();
        let mu = if i == 1 { (sa + ss) / lambda } else { mu };
        let beta = (sa + ss) / mu;
        let (fwd, bwd) = (ss * (1.0 - b) / mu, ss * b / mu);
        let c = collimated_layer(k, s, sa, ss, b, mu, d).unwrap();
        let (r, t) = rk4_layer(k, s, beta, fwd, bwd, d, 4000);
        assert!((c.r - r).abs() < 1e-11, "case {i}: R {} vs RK4 {r}", c.r);
        assert!((c.t - t).abs() < 1e-11, "case {i}: T {} vs RK4 {t}", c.t);
        assert!((c.direct - (-beta * d).exp()).abs() < 1e-16);
        assert!((c.r + c.t + c.direct + c.a - 1.0).abs() < 4e-16, "case {i}: balance");
    }
}

/// Continuity through the resonance: `beta` a relative 1e-9 either side of
/// `lambda` changes the answer by about that much, not by `eps / 1e-9`.
#[test]
fn the_resonance_is_smooth() {
    let (k, s, sa, ss, b, d) = (2.0f64, 0.075, 1.0, 0.1, 0.5, 1.0);
    let lambda = (k * (k + 2.0 * s)).sqrt();
    let mu0 = (sa + ss) / lambda;
    let at = collimated_layer(k, s, sa, ss, b, mu0, d).unwrap();
    for eps in [1e-9, -1e-9] {
        let c = collimated_layer(k, s, sa, ss, b, mu0 * (1.0 + eps), d).unwrap();
        assert!((c.r - at.r).abs() < 1e-8 * at.r && (c.t - at.t).abs() < 1e-8 * at.t);
    }
}

/// A layer split in two and added back (eq. K23) is the whole layer:
/// checks the collimated responses' dependence on thickness, including the
/// beam reflected between the halves (none here: no interface).
#[test]
fn split_layers_add_back_to_the_whole() {
    let four = |d: f64| {
        let (k, s, sa, ss, b, mu) = (0.3, 0.8, 0.15, 1.1, 0.27, 0.66);
        FourSlab::layer(
            &Slab::layer(k, s, d).unwrap(),
            &collimated_layer(k, s, sa, ss, b, mu, d).unwrap(),
        )
    };
    for (d1, d2) in [(0.5, 0.5), (0.1, 2.9), (1.7, 0.3), (4.0, 6.0)] {
        let whole = four(d1 + d2);
        let sum = add_four(&four(d1), &four(d2));
        for (x, y) in [
            (sum.r_top.dc, whole.r_top.dc),
            (sum.t_tb.dc, whole.t_tb.dc),
            (sum.t_tb.cc, whole.t_tb.cc),
            (sum.r_bottom.dc, whole.r_bottom.dc),
            (sum.a_top[0], whole.a_top[0]),
        ] {
            assert!((x - y).abs() < 1e-15, "{d1} + {d2}: {x} vs {y}");
        }
    }
}

fn scene(text: &str) -> Scene {
    Scene::from_toml_str(text).unwrap()
}

/// The closed-form plate: interfaces of beam reflectances `r1` (top) and
/// `r2` (bottom) around a clear layer of one-way transmittance `a`
/// (incoherent multiple reflections):
/// `R = r1 + (1 - r1)^2 r2 a^2 / (1 - r1 r2 a^2)`,
/// `T = (1 - r1)(1 - r2) a / (1 - r1 r2 a^2)`.
fn fresnel_plate(r1: f64, r2: f64, a: f64) -> (f64, f64) {
    let den = 1.0 - r1 * r2 * a * a;
    (r1 + (1.0 - r1).powi(2) * r2 * a * a / den, (1.0 - r1) * (1.0 - r2) * a / den)
}

/// A clear glass plate and a clear (absorbing or not) film on a glass
/// substrate are the closed-form Fresnel plate under the four-flux model,
/// to rounding (1e-15), at every angle and for every mapping that accepts
/// the layer (star1988 refuses an absorbing layer without scattering): no
/// diffuse light is made.
#[test]
fn clear_plate_and_clear_film_are_exact() {
    for theta in [0.0f64, 30.0, 60.0, 75.0] {
        let mu0 = theta.to_radians().cos();
        let sin0 = theta.to_radians().sin();
        for (tau, n_film, n_sub) in
            [(0.0, 1.5, 1.0), (1.0, 1.5, 1.0), (0.3, 1.7, 1.5), (0.0, 1.3, 1.5)]
        {
            let text = format!(
                "[light]\nkind = \"collimated\"\ntheta_deg = {theta}\n[[layer]]\ntau = {tau}\n\
                 albedo = 0\nn = {n_film}\n[substrate]\nkind = \"transparent\"\nn = {n_sub}\n"
            );
            let mu1 = (1.0 - (sin0 / n_film).powi(2)).sqrt();
            let r1 = fresnel::reflectance(mu0, 1.0, n_film);
            let r2 = fresnel::reflectance(mu1, n_film, n_sub);
            let (r, t) = fresnel_plate(r1, r2, (-tau / mu1).exp());
            let mappings: &[&str] =
                if tau == 0.0 { &["seed", "star1988", "gate1974"] } else { &["seed", "gate1974"] };
            for mapping in mappings {
                let opts = KmOptions { mapping: mapping.parse().unwrap(), ..Default::default() };
                let c = &solve(&scene(&text), &opts).unwrap().channels[0];
                let what = format!("theta {theta}, tau {tau}, n {n_film} on {n_sub}, {mapping}");
                assert!((c.reflectance - r).abs() < 1e-15, "{what}: R {} vs {r}", c.reflectance);
                assert!(
                    (c.transmittance - t).abs() < 1e-15,
                    "{what}: T {} vs {t}",
                    c.transmittance
                );
                assert_eq!(c.reflectance, c.reflectance_specular, "{what}: all specular");
                assert_eq!(c.transmittance, c.transmittance_direct, "{what}: all direct");
            }
        }
    }
}

/// A glass plate: n 1.5, tau 0, normal incidence: R = 0.0769, T = 0.923
/// (2 r / (1 + r) with r = 0.04), where the two-flux model gives 0.399.
#[test]
fn a_glass_plate_at_normal_incidence() {
    let s = scene("[[layer]]\ntau = 0\nalbedo = 0\nn = 1.5\n");
    let four = &solve(&s, &KmOptions::default()).unwrap().channels[0];
    assert!((four.reflectance - 0.08 / 1.04).abs() < 1e-16);
    let two = KmOptions { model: KmModel::TwoFlux, ..Default::default() };
    let two = &solve(&s, &two).unwrap().channels[0];
    assert!((two.reflectance - 0.3986).abs() < 1e-4, "{}", two.reflectance);
}

/// Diffuse light: the four-flux model is the two-flux one, bit for bit.
#[test]
fn diffuse_light_is_two_flux() {
    let s = scene(
        "[light]\nkind = \"diffuse\"\n[[layer]]\ntau = 1\nalbedo = 0.9\ng = 0.5\nn = 1.4\n\
         [substrate]\nkind = \"lambertian\"\nalbedo = 0.6\n",
    );
    for mapping in ["seed", "gate1974"] {
        let m = mapping.parse().unwrap();
        let four = solve(&s, &KmOptions { mapping: m, model: KmModel::FourFlux }).unwrap();
        let two = solve(&s, &KmOptions { mapping: m, model: KmModel::TwoFlux }).unwrap();
        assert_eq!(four.channels, two.channels);
    }
}

/// Energy balance and non-negativity over stacks of several layers with
/// interfaces, on every substrate (half-space last included), at oblique
/// incidence; and a conservative stack over a white ground reflects all.
#[test]
fn stacks_conserve_energy() {
    let subs = [
        "kind = \"transparent\"\nn = 1.5",
        "kind = \"lambertian\"\nalbedo = 0.7",
        "kind = \"black\"",
    ];
    for sub in subs {
        for theta in [0.0, 50.0, 80.0] {
            let text = format!(
                "[light]\nkind = \"collimated\"\ntheta_deg = {theta}\n\
                 [[layer]]\ntau = 0.5\nalbedo = 0.3\ng = 0.6\nn = 1.5\n\
                 [[layer]]\ntau = 2\nalbedo = 0.95\ng = -0.2\nn = 1.2\n\
                 [[layer]]\ntau = 0.2\nalbedo = 0\nn = 1.7\n[substrate]\n{sub}\n"
            );
            let c = &solve(&scene(&text), &KmOptions::default()).unwrap().channels[0];
            let total = c.reflectance + c.transmittance + c.absorptance;
            assert!((total - 1.0).abs() < 1e-14, "{sub} at {theta}: R+T+A = {total}");
            let layers: f64 = c.absorptance_layers.as_ref().unwrap().iter().sum();
            assert!(layers <= c.absorptance + 1e-15 && layers >= 0.0);
            assert!(
                c.reflectance_specular <= c.reflectance
                    && c.transmittance_direct <= c.transmittance
            );
        }
    }
    let white = scene(
        "[light]\nkind = \"collimated\"\ntheta_deg = 40\n[[layer]]\ntau = 3\nalbedo = 1\ng = 0.7\n\
         n = 1.4\n[substrate]\nkind = \"lambertian\"\nalbedo = 1\n",
    );
    let c = &solve(&white, &KmOptions::default()).unwrap().channels[0];
    assert!((c.reflectance - 1.0).abs() < 1e-14, "{}", c.reflectance);
    let half =
        scene("[[layer]]\nthickness = \"inf\"\nsigma_a = 0\nsigma_s = 1\ng = 0.5\nn = 1.3\n");
    let c = &solve(&half, &KmOptions::default()).unwrap().channels[0];
    assert!((c.reflectance - 1.0).abs() < 1e-14, "{}", c.reflectance);
}

/// `b(mu)` against a direct double integral of the Henyey–Greenstein
/// function over the upper hemisphere (Gauss–Legendre in `mu'` on 16
/// panels graded toward the horizon, trapezoid in azimuth, 1e-9).
#[test]
fn backscatter_fraction_matches_the_hemisphere_integral() {
    use km_core::phase::{Phase, PhaseFunction};
    for g in [-0.5, 0.3, 0.8, 0.95] {
        let p = Phase::henyey_greenstein(g).unwrap();
        for mu in [1.0, 0.7, 0.3, 0.05] {
            let st = (1.0f64 - mu * mu).sqrt();
            let n_phi = 2048;
            let ring = |m2: f64| {
                let s2 = (1.0 - m2 * m2).max(0.0).sqrt();
                let mut sum = 0.0;
                for j in 0..n_phi {
                    let phi = std::f64::consts::PI * (j as f64 + 0.5) / n_phi as f64;
                    sum += p.eval(mu * m2 + st * s2 * phi.cos());
                }
                2.0 * std::f64::consts::PI * sum / n_phi as f64
            };
            let mut total = 0.0;
            let edges: Vec<f64> = (0..=16).map(|i| -(1.0 - i as f64 / 16.0).powi(3)).collect();
            for w in edges.windows(2) {
                total += km_core::quadrature::integrate_gl(ring, w[0], w[1], 24);
            }
            let b = backscatter_fraction(&p, mu);
            assert!((b - total).abs() < 1e-9, "g {g}, mu {mu}: {b} vs {total}");
        }
    }
}

/// The four-flux layer with a beam at normal incidence and isotropic
/// scattering in the thin limit: single scattering sends half of
/// `sigma_s d` back (`R_cd -> sigma_s d / 2`).
#[test]
fn thin_layer_single_scattering_limit() {
    let d = 1e-6;
    let c = collimated_layer(0.2, 0.5, 0.1, 0.5, 0.5, 1.0, d).unwrap();
    assert!((c.r / (0.25 * d) - 1.0).abs() < 1e-5, "{}", c.r / d);
    let rt = layer_rt(0.2, 0.5, d).unwrap();
    assert!(rt.r < 1e-6);
}

/// Extreme but valid layers (coefficients from 1e-300 to 1e300, thickness
/// from 1e-300 to inf): finite, non-negative, conserving answers.
#[test]
fn extreme_layers_stay_finite_and_conserve() {
    for (k, s, sa, ss, d) in [
        (0.2, 0.75e300, 0.1, 1e300, 1.0),
        (2e300, 1e-300, 1e300, 1e-300, 1.0),
        (1e-300, 1e-300, 1e-300, 1e-300, 1e300),
        (0.3, 0.7, 0.2, 0.9, 1e-300),
        (0.3, 0.7, 0.2, 0.9, f64::INFINITY),
        (0.0, 1e300, 0.0, 1e300, f64::INFINITY),
    ] {
        for mu in [1.0, 0.3] {
            let c = collimated_layer(k, s, sa, ss, 0.4, mu, d).unwrap();
            let sum = c.r + c.t + c.direct + c.a;
            assert!(
                [c.r, c.t, c.direct, c.a].iter().all(|x| x.is_finite() && *x >= 0.0)
                    && (sum - 1.0).abs() < 1e-14,
                "{k} {s} {sa} {ss} {d} {mu}: {c:?}"
            );
        }
    }
}
