//! Physical invariants on a randomised grid (fixed-seed generator): energy
//! balance, conservation, reciprocity, positivity, and the doubling identity.

mod common;
use common::{run, scene};
use faer::Mat;
use km_multiflux::adding::{LayerOperators, add};
use km_multiflux::interface::fresnel_operators;
use km_multiflux::legendre::delta_m;
use km_multiflux::quadrature::AngularGrid;
use km_multiflux::slab::{Extra, SlabOrder, slab_operators};
use km_multiflux::{MultifluxOptions, solve};
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;

fn max_diff(a: &Mat<f64>, b: &Mat<f64>) -> f64 {
    let mut d = 0.0f64;
    for j in 0..a.ncols() {
        for i in 0..a.nrows() {
            d = d.max((a[(i, j)] - b[(i, j)]).abs());
        }
    }
    d
}

/// A random layer's delta-M scaled (tau, omega, chi) with `2n` moments.
fn random_layer(rng: &mut Pcg64, n: usize) -> (f64, f64, Vec<f64>) {
    let tau = 10f64.powf(rng.random_range(-3.0..2.0));
    let omega: f64 =
        if rng.random_range(0.0..1.0) < 0.2 { 1.0 } else { rng.random_range(0.0..1.0) };
    let g: f64 = rng.random_range(-0.9..0.95);
    let chi: Vec<f64> = (0..=2 * n).map(|l| g.powi(l as i32)).collect();
    let (c, w, f) = delta_m(&chi, omega, 2 * n);
    (tau * f, w, c)
}

/// Doubling identity: a layer equals its two halves added (seed eq. 14),
/// including the beam and probe columns, for every Fourier order; 1e-10
/// absolute (rounding of the eigen-solutions and of the star product).
#[test]
fn two_half_layers_added_equal_the_whole_layer() {
    let mut rng = Pcg64::seed_from_u64(20261122);
    let n = 8;
    let nodes = AngularGrid::new(&[1.0], n).medium(1.0);
    let mut worst = 0.0f64;
    for _ in 0..40 {
        let (tau, omega, chi) = random_layer(&mut rng, n);
        let mu_b: f64 = rng.random_range(0.05..1.0);
        let extras = [
            Extra { mu: Some(mu_b), beam: true, phi_deg: 0.0 },
            Extra { mu: Some(rng.random_range(0.05..1.0)), beam: false, phi_deg: 0.0 },
            Extra { mu: Some(mu_b), beam: false, phi_deg: 0.0 },
        ];
        for m in [0, 1, 5] {
            let whole = SlabOrder { tau, omega, chi: &chi, m };
            let half = SlabOrder { tau: 0.5 * tau, ..whole };
            let a = slab_operators(&nodes.mu, &nodes.w, &extras, &whole, None).unwrap();
            let h = slab_operators(&nodes.mu, &nodes.w, &extras, &half, None).unwrap();
            let b = add(&h, &h).unwrap();
            let d = max_diff(&a.r_top, &b.r_top)
                .max(max_diff(&a.t_down, &b.t_down))
                .max(max_diff(&a.r_bottom, &b.r_bottom))
                .max(max_diff(&a.t_up, &b.t_up));
            worst = worst.max(d);
        }
    }
    assert!(worst < 1e-10, "doubling identity: {worst:.3e}");
}

/// Operator invariants of single layers (m = 0): positivity (isotropic and
/// moderately peaked phase functions, whose discrete phase matrix is
/// positive), energy balance of every column (absorbed part >= 0, exactly 0
/// for omega = 1), and reciprocity `mu_i w_i R_ij = mu_j w_j R_ji`.
#[test]
fn layer_operators_conserve_energy_are_reciprocal_and_positive() {
    let mut rng = Pcg64::seed_from_u64(7);
    let n = 12;
    let nodes = AngularGrid::new(&[1.0], n).medium(1.0);
    let (mu, w) = (&nodes.mu, &nodes.w);
    for _ in 0..60 {
        let (tau, omega, chi) = random_layer(&mut rng, n);
        let mu_b: f64 = rng.random_range(0.05..1.0);
        let extras = [Extra { mu: Some(mu_b), beam: true, phi_deg: 0.0 }];
        let p = SlabOrder { tau, omega, chi: &chi, m: 0 };
        let ops = slab_operators(mu, w, &extras, &p, None).unwrap();
        let (r, t) = (&ops.r_top, &ops.t_down);
        for j in 0..=n {
            // Flux out per unit flux in: node column j (flux 2 pi w mu), or the beam.
            let mut out: f64 = (0..n).map(|i| 2.0 * w[i] * mu[i] * (r[(i, j)] + t[(i, j)])).sum();
            if j < n {
                out /= 2.0 * w[j] * mu[j];
            } else {
                out = std::f64::consts::PI * out + t[(n, n)];
            }
            assert!(out <= 1.0 + 1e-12, "column {j}: {out}");
            if omega == 1.0 {
                assert!((out - 1.0).abs() < 1e-10, "conservative column {j}: {out}");
            }
        }
        for i in 0..n {
            for j in 0..n {
                let (a, b) = (mu[i] * w[i] * r[(i, j)], mu[j] * w[j] * r[(j, i)]);
                assert!((a - b).abs() <= 1e-12 * a.abs().max(b.abs()).max(1e-3), "{a} {b}");
                if chi[1].abs() < 0.5 {
                    assert!(r[(i, j)] >= -1e-13 && t[(i, j)] >= -1e-13);
                }
            }
        }
    }
}

/// Reciprocity of a whole stack with refractive interfaces: the reflection
/// operator seen from the ambient medium, `mu_i w_i R_ij` symmetric (1e-12).
#[test]
fn stack_with_interfaces_is_reciprocal() {
    let mut rng = Pcg64::seed_from_u64(99);
    let n = 8;
    for _ in 0..10 {
        let (n1, n2): (f64, f64) = (rng.random_range(1.0..2.0), rng.random_range(1.0..2.0));
        let grid = AngularGrid::new(&[1.0, n1, n2], n);
        let (m0, m1, m2) = (grid.medium(1.0), grid.medium(n1), grid.medium(n2));
        let none: [Extra; 0] = [];
        let mut acc = fresnel_operators(&m0, &m1, &none, &none);
        for (a, b) in [(&m1, &m2), (&m2, &m0)] {
            let (tau, omega, chi) = random_layer(&mut rng, n);
            let p = SlabOrder { tau, omega, chi: &chi, m: 0 };
            let slab: LayerOperators = slab_operators(&a.mu, &a.w, &none, &p, None).unwrap();
            acc = add(&acc, &slab).unwrap();
            acc = add(&acc, &fresnel_operators(a, b, &none, &none)).unwrap();
        }
        let r = &acc.r_top;
        for i in 0..m0.mu.len() {
            for j in 0..m0.mu.len() {
                let a = m0.mu[i] * m0.w[i] * r[(i, j)];
                let b = m0.mu[j] * m0.w[j] * r[(j, i)];
                assert!((a - b).abs() <= 1e-12 * a.abs().max(b.abs()).max(1e-3), "{a} {b}");
            }
        }
    }
}

/// BRDF reciprocity through the whole solver (beam and probe at any angle,
/// Fresnel interfaces, anisotropic scattering, single-scattering correction):
/// `f(theta_1 -> theta_2, phi) = f(theta_2 -> theta_1, phi)`; tolerance 1e-8
/// relative (converged discretisation; exactly reciprocal only in the limit
/// of the Fourier sum, which is complete here).
#[test]
fn brdf_is_reciprocal() {
    let mut rng = Pcg64::seed_from_u64(3);
    for _ in 0..6 {
        let (t1, t2): (f64, f64) = (rng.random_range(0.0..80.0), rng.random_range(0.0..80.0));
        let phi: f64 = rng.random_range(0.0..360.0);
        let g: f64 = rng.random_range(-0.5..0.8);
        let n: f64 = rng.random_range(1.0..1.8);
        let body = format!(
            "[[layer]]\ntau = 0.7\nalbedo = 0.9\ng = {g}\nn = {n}\n[[layer]]\ntau = 2.0\nalbedo = 0.6\ng = 0.3\nn = 1.2\n[substrate]\nkind = \"lambertian\"\nalbedo = 0.5\n"
        );
        let f = |a: f64, b: f64| {
            run(
                &format!(
                    "[light]\ntheta_deg = {a}\n{body}[output]\ndirections_deg = [[{b}, {phi}]]\n"
                ),
                16,
            )
            .brdf[0]
        };
        let (x, y) = (f(t1, t2), f(t2, t1));
        assert!((x - y).abs() <= 1e-8 * x.abs(), "{t1} {t2} {phi}: {x} vs {y}");
    }
}

/// Random stacks through the scene entry point: everything finite,
/// 0 <= R, T <= 1, absorptance >= 0 (and 0 for conservative stacks over a
/// clear substrate), BRDF/BTDF finite and non-negative up to 1e-9.
#[test]
fn random_scenes_balance_energy() {
    let mut rng = Pcg64::seed_from_u64(1234);
    let mut count = 0;
    for _ in 0..40 {
        let layers = rng.random_range(1..4usize);
        let conservative = rng.random_range(0.0..1.0) < 0.3;
        let mut t = format!("[light]\ntheta_deg = {}\n", rng.random_range(0.0..89.0));
        for _ in 0..layers {
            let omega: f64 = if conservative { 1.0 } else { rng.random_range(0.0..1.0) };
            t += &format!(
                "[[layer]]\ntau = {}\nalbedo = {omega}\ng = {}\nn = {}\n",
                10f64.powf(rng.random_range(-2.0..1.5)),
                rng.random_range(-0.8..0.9),
                rng.random_range(1.0..2.0)
            );
        }
        let kind = if conservative { 0 } else { rng.random_range(0..3) };
        t += match kind {
            0 => "[substrate]\nkind = \"transparent\"\nn = 1.2\n",
            1 => "[substrate]\nkind = \"lambertian\"\nalbedo = 0.7\n",
            _ => "[substrate]\nkind = \"black\"\n",
        };
        t += "[output]\ndirections_deg = [[0.0, 0.0], [40.0, 180.0], [70.0, 30.0]]\n";
        let o = MultifluxOptions { streams: Some(12), ..Default::default() };
        let c = solve(&scene(&t), &o).unwrap().channels.remove(0);
        for x in [c.reflectance, c.transmittance, c.reflectance_specular, c.transmittance_direct] {
            assert!(x.is_finite() && (-1e-12..=1.0 + 1e-12).contains(&x), "{x}\n{t}");
        }
        // Rounding of a few star products with near-conservative round trips: 1e-10.
        assert!(c.absorptance >= -1e-10, "A = {}\n{t}", c.absorptance);
        if conservative {
            assert!(c.absorptance.abs() < 1e-9, "A = {}\n{t}", c.absorptance);
        }
        for &x in c.brdf.iter().chain(&c.btdf) {
            assert!(x.is_finite() && x >= -1e-9, "{x}\n{t}");
        }
        count += 1;
    }
    assert_eq!(count, 40);
}

/// The internal field (seed eq. 19) meets its boundary values and the
/// layer's operators: at the top `I+ = a`, `I- = R a + T b (+ beam)`, at the
/// bottom `I- = b`, `I+ = T a + R b (+ beam)`; 1e-10.
#[test]
fn internal_field_matches_the_operators_at_the_boundaries() {
    use km_multiflux::slab::SlabSolution;
    let mut rng = Pcg64::seed_from_u64(5);
    let n = 8;
    let nodes = AngularGrid::new(&[1.0], n).medium(1.0);
    for _ in 0..20 {
        let (tau, omega, chi) = random_layer(&mut rng, n);
        let mu_b: f64 = rng.random_range(0.1..1.0);
        let m = rng.random_range(0..3usize);
        let p = SlabOrder { tau, omega, chi: &chi, m };
        let sol = SlabSolution::new(&nodes.mu, &nodes.w, &p).unwrap();
        let extras = [Extra { mu: Some(mu_b), beam: true, phi_deg: 0.0 }];
        let ops = sol.operators(&extras, None);
        let a: Vec<f64> = (0..n).map(|_| rng.random_range(0.0..1.0)).collect();
        let b: Vec<f64> = (0..n).map(|_| rng.random_range(0.0..1.0)).collect();
        let (d0, u0) = sol.field(0.0, &a, &b, Some((mu_b, 1.0))).unwrap();
        let (d1, u1) = sol.field(tau, &a, &b, Some((mu_b, 1.0))).unwrap();
        for i in 0..n {
            let ru: f64 = ops.r_top[(i, n)]
                + (0..n).map(|j| ops.r_top[(i, j)] * a[j] + ops.t_up[(i, j)] * b[j]).sum::<f64>();
            let td: f64 = ops.t_down[(i, n)]
                + (0..n)
                    .map(|j| ops.t_down[(i, j)] * a[j] + ops.r_bottom[(i, j)] * b[j])
                    .sum::<f64>();
            let scale = 1.0 + ru.abs() + td.abs();
            assert!((d0[i] - a[i]).abs() < 1e-10 * scale, "top in {} vs {}", d0[i], a[i]);
            assert!((u1[i] - b[i]).abs() < 1e-10 * scale, "bottom in {} vs {}", u1[i], b[i]);
            assert!((u0[i] - ru).abs() < 1e-10 * scale, "top out {} vs {ru}", u0[i]);
            assert!((d1[i] - td).abs() < 1e-10 * scale, "bottom out {} vs {td}", d1[i]);
        }
    }
}

/// The eigenvectors satisfy the discrete transfer equation (eq. 7):
/// `-k g+ = -alpha g+ + beta g-` and `-k g- = -beta g+ + alpha g-`, checked
/// through the mode it generates: the field of a layer driven by one mode's
/// boundary values is that mode (1e-9 relative).
#[test]
fn eigenvectors_are_modes_of_the_layer() {
    use km_multiflux::slab::SlabSolution;
    let n = 6;
    let nodes = AngularGrid::new(&[1.0], n).medium(1.0);
    let chi: Vec<f64> = (0..2 * n).map(|l| 0.6f64.powi(l as i32)).collect();
    let tau = 0.8;
    let sol =
        SlabSolution::new(&nodes.mu, &nodes.w, &SlabOrder { tau, omega: 0.9, chi: &chi, m: 0 })
            .unwrap();
    let (k, gp, gm) = sol.eigenvectors();
    for j in 0..n {
        // Mode j anchored at the top: I+(0) = g+, I-(tau0) = g- e^{-k tau0}.
        let a: Vec<f64> = (0..n).map(|i| gp[(i, j)]).collect();
        let b: Vec<f64> = (0..n).map(|i| gm[(i, j)] * (-k[j] * tau).exp()).collect();
        let (dn, up) = sol.field(0.5 * tau, &a, &b, None).unwrap();
        let e = (-k[j] * 0.5 * tau).exp();
        let scale = a.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        for i in 0..n {
            assert!((dn[i] - gp[(i, j)] * e).abs() < 1e-9 * scale, "mode {j}");
            assert!((up[i] - gm[(i, j)] * e).abs() < 1e-9 * scale, "mode {j}");
        }
    }
}

/// The beam's column computed alone (`slab_beam_response`: eq. 12', vector
/// solves, no node-to-node operators) against an independent route: the two
/// halves of the layer built with their full operators (eq. S5, `n` solves)
/// and added (eq. A4), for nodes and probes, Fourier orders 0-3; a
/// half-space against a layer of tau = 1e3 (whose bottom returns less than
/// e^-1000 / mu of anything). 1e-10 relative, as the doubling identity.
#[test]
fn beam_response_alone_equals_the_added_halves() {
    use km_multiflux::slab::slab_beam_response;
    let mut rng = Pcg64::seed_from_u64(77);
    let n = 8;
    let nodes = AngularGrid::new(&[1.0], n).medium(1.0);
    let mut worst = 0.0f64;
    for case in 0..40 {
        let (tau, omega, chi) = random_layer(&mut rng, n);
        let m = rng.random_range(0..4usize);
        let extras = [
            Extra { mu: Some(rng.random_range(0.05..1.0)), beam: false, phi_deg: 30.0 },
            Extra { mu: Some(rng.random_range(0.05..1.0)), beam: true, phi_deg: 0.0 },
            Extra { mu: Some(rng.random_range(0.05..1.0)), beam: false, phi_deg: 180.0 },
            Extra { mu: None, beam: false, phi_deg: 0.0 },
        ];
        let (r_ref, t_ref, alone) = if case % 5 == 0 {
            // Half-space against a thick layer (both on the lone route, different branches).
            let thick = SlabOrder { tau: 1e3, omega, chi: &chi, m };
            let half = SlabOrder { tau: f64::INFINITY, omega, chi: &chi, m };
            let (r, _) = slab_beam_response(&nodes.mu, &nodes.w, &extras, 1, &thick, None).unwrap();
            let a = slab_beam_response(&nodes.mu, &nodes.w, &extras, 1, &half, None).unwrap();
            (r, vec![0.0; n + extras.len()], a)
        } else {
            let whole = SlabOrder { tau, omega, chi: &chi, m };
            let halfp = SlabOrder { tau: 0.5 * tau, omega, chi: &chi, m };
            let h = slab_operators(&nodes.mu, &nodes.w, &extras, &halfp, None).unwrap();
            let s = add(&h, &h).unwrap();
            let col = |x: &Mat<f64>| (0..n + extras.len()).map(|i| x[(i, n + 1)]).collect();
            let a = slab_beam_response(&nodes.mu, &nodes.w, &extras, 1, &whole, None).unwrap();
            (col(&s.r_top), col(&s.t_down), a)
        };
        for i in 0..n + extras.len() {
            let (r, t) = (r_ref[i], t_ref[i]);
            let e = ((alone.0[i] - r).abs() / (1.0 + r.abs()))
                .max((alone.1[i] - t).abs() / (1.0 + t.abs()));
            worst = worst.max(e);
        }
    }
    println!("beam column alone vs added halves: worst {worst:.1e}");
    assert!(worst < 1e-10, "worst difference {worst:e}");
}

/// The reflected column alone (`slab_beam_reflection`, which skips the
/// probes' transmitted values and reuses the beam's order-independent path
/// factors) is the reflected column of `slab_beam_response` bit for bit, with
/// and without the peak correction, for orders 0-5 solved in turn (so that
/// the kept path factors of one order serve the next) and with another beam
/// in between (so that they are recomputed when the beam changes); the
/// reference is computed on a thread of its own (a fresh workspace).
#[test]
fn beam_reflection_alone_is_the_reflected_column_bit_for_bit() {
    use km_core::phase::Phase;
    use km_multiflux::correction::PeakCorrection;
    use km_multiflux::slab::{slab_beam_reflection, slab_beam_response};
    let mut rng = Pcg64::seed_from_u64(78);
    let n = 6;
    let nodes = AngularGrid::new(&[1.0], n).medium(1.0);
    let mut compared = 0;
    for case in 0..12 {
        let (tau, omega, chi) = random_layer(&mut rng, n);
        let tau = if case % 4 == 0 { f64::INFINITY } else { tau };
        let g = rng.random_range(0.1..0.9);
        let tms = PeakCorrection::new(Phase::henyey_greenstein(g).unwrap(), omega, 2 * n, true);
        let mut extras =
            vec![Extra { mu: Some(rng.random_range(0.2..1.0)), beam: true, phi_deg: 0.0 }];
        for k in 0..6 {
            let mu = [0.3, 0.55, 0.8][k % 3];
            extras.push(Extra { mu: Some(mu), beam: false, phi_deg: 45.0 * k as f64 });
        }
        let mut other = extras.clone();
        other[0].mu = Some(0.37);
        for m in 0..6 {
            let p = SlabOrder { tau, omega, chi: &chi, m };
            let t = (m == 0 && case % 2 == 0).then_some(&tms);
            // Order 3 also with another beam in between: the kept factors
            // must follow the beam.
            let beams: &[&[Extra]] = if m == 3 { &[&other, &extras] } else { &[&extras] };
            for ex in beams {
                let alone = slab_beam_reflection(&nodes.mu, &nodes.w, ex, 0, &p, t).unwrap();
                // The reference on a new thread: its own, empty workspace.
                let (both, _) = std::thread::scope(|sc| {
                    sc.spawn(|| slab_beam_response(&nodes.mu, &nodes.w, ex, 0, &p, t).unwrap())
                        .join()
                        .unwrap()
                });
                assert_eq!(alone.len(), both.len());
                for (a, b) in alone.iter().zip(&both) {
                    assert_eq!(a.to_bits(), b.to_bits(), "case {case}, m = {m}: {a} vs {b}");
                    compared += 1;
                }
            }
        }
    }
    assert_eq!(compared, 12 * 7 * (n + 7));
}
