//! Tests of the 2-D (flatland) direction-set variant (seed 000 §4.2, fig. 3–4).

use std::f64::consts::PI;

use faer::Mat;
use km_core::phase::Anisotropy;
use km_multiflux::flatland::*;

/// The full `2N x 2N` matrix `Q = K^-1 (-sigma_t + sigma_s P)` in the order
/// (down 0..N, up 0..N), built from the public phase blocks.
fn full_q(set: &CircleSet, sigma_a: f64, sigma_s: f64, g: f64) -> Mat<f64> {
    let (pp, pm) = set.phase_blocks(an(g)).unwrap();
    let n = set.len();
    let st = sigma_a + sigma_s;
    Mat::from_fn(2 * n, 2 * n, |i, j| {
        let (bi, bj) = (i / n, j / n);
        let (ii, jj) = (i % n, j % n);
        let p = if bi == bj { pp[(ii, jj)] } else { pm[(ii, jj)] };
        let diag = if i == j { -st } else { 0.0 };
        // K = diag(mu) for down, diag(-mu) for up.
        let k = if bi == 0 { set.mu()[ii] } else { -set.mu()[ii] };
        (diag + sigma_s * p) / k
    })
}

#[test]
fn circle_set_has_the_normal_and_no_grazing_direction() {
    for n_dirs in [6, 38, 102] {
        let s = CircleSet::new(n_dirs).unwrap();
        assert_eq!(2 * s.len(), n_dirs);
        assert_eq!(s.theta()[s.normal_index()], 0.0);
        assert!(s.mu().iter().all(|&m| m > 1e-3));
        let total: f64 = s.weights().iter().sum();
        assert!((total - PI).abs() < 1e-13);
    }
    assert!(CircleSet::new(36).is_err());
}

#[test]
fn phase_rows_sum_to_one() {
    let s = CircleSet::new(62).unwrap();
    for g in [0.0, 0.5, 0.9, -0.7] {
        let (pp, pm) = s.phase_blocks(an(g)).unwrap();
        for i in 0..s.len() {
            let row: f64 = (0..s.len()).map(|j| pp[(i, j)] + pm[(i, j)]).sum();
            assert!((row - 1.0).abs() < 1e-12, "g={g}: {row}");
        }
    }
}

#[test]
fn eigenvalues_come_in_plus_minus_pairs_and_match_the_full_eigenproblem() {
    // Independent check: faer's general (complex, unsorted) eigen-solver on the
    // full 2N x 2N matrix Q against the half-size symmetric solution.
    for (sa, ss, g) in [(0.2, 0.8, 0.0), (0.1, 0.9, 0.6), (0.5, 0.5, -0.4)] {
        let n_dirs = 38;
        let set = CircleSet::new(n_dirs).unwrap();
        let q = full_q(&set, sa, ss, g);
        let mut full: Vec<f64> = q
            .eigenvalues()
            .unwrap()
            .iter()
            .map(|z| {
                // Q is similar to a real symmetric-definite pencil: real spectrum.
                assert!(z.im.abs() < 1e-9 * z.re.abs().max(1.0), "complex eigenvalue {z:?}");
                z.re
            })
            .collect();
        full.sort_by(f64::total_cmp);
        // Pairing within the full spectrum: nu and -nu both present.
        for k in 0..full.len() {
            let partner = full[full.len() - 1 - k];
            assert!((full[k] + partner).abs() < 1e-9 * full[k].abs().max(1.0));
        }
        let e = eigenmodes(sa, ss, an(g), n_dirs).unwrap();
        let mut mine = e.eigenvalues.clone();
        mine.sort_by(f64::total_cmp);
        for (a, b) in mine.iter().zip(&full) {
            assert!((a - b).abs() < 1e-9 * b.abs().max(1.0), "{a} vs {b}");
        }
    }
}

#[test]
fn eigenvectors_satisfy_q_v_equals_lambda_v() {
    let (sa, ss, g) = (0.1, 0.9, 0.5);
    let set = CircleSet::new(30).unwrap();
    let q = full_q(&set, sa, ss, g);
    let e = eigenmodes(sa, ss, an(g), 30).unwrap();
    // Map the output angle order back to (down, up) positions.
    let n = set.len();
    let pos = |angle: f64| -> usize {
        for j in 0..n {
            if (set.theta()[j] - angle).abs() < 1e-12 {
                return j;
            }
            let up = PI - set.theta()[j];
            let up = if up > PI { up - 2.0 * PI } else { up };
            if (up - angle).abs() < 1e-12 {
                return n + j;
            }
        }
        panic!("angle {angle} not in the set");
    };
    let idx: Vec<usize> = e.angles.iter().map(|&a| pos(a)).collect();
    for (nu, v) in e.eigenvalues.iter().zip(&e.vectors) {
        let mut x = vec![0.0; 2 * n];
        for (k, &i) in idx.iter().enumerate() {
            x[i] = v[k];
        }
        for i in 0..2 * n {
            let qx: f64 = (0..2 * n).map(|j| q[(i, j)] * x[j]).sum();
            // Residual relative to the scale |Q| ~ sigma_t / mu_min.
            assert!((qx - nu * x[i]).abs() < 1e-9 * (1.0 + nu.abs()) * 20.0, "nu={nu}");
        }
    }
    // Fig. 3: the first (slowest) mode is the most diffuse: all one sign.
    assert!(e.vectors[0].iter().all(|&x| x >= 0.0));
}

#[test]
fn energy_is_conserved_and_thick_layers_stay_finite() {
    for &albedo in &[0.0, 0.5, 0.9, 0.999999, 1.0] {
        for &tau in &[1e-6, 0.1, 1.0, 10.0, 1e4] {
            for &g in &[-0.5, 0.0, 0.8] {
                let (r, t) = slab_totals(1.0 - albedo, albedo, an(g), tau, 38).unwrap();
                assert!(r.is_finite() && t.is_finite());
                let a = 1.0 - r - t;
                assert!(a >= -1e-12 && r >= 0.0 && t >= 0.0, "albedo={albedo} tau={tau}: A={a}");
                if albedo == 1.0 {
                    // Conservative: rounding only (1e-10).
                    assert!(a.abs() < 1e-10, "tau={tau} g={g}: R+T-1 = {}", -a);
                }
            }
        }
    }
}

#[test]
fn thin_slab_single_scattering_limit() {
    // Independent reference: for tau -> 0 and isotropic 2-D scattering, half
    // the scattered light goes up: R = albedo tau / 2 (relative 1e-3 at tau = 1e-5).
    let (r, _) = slab_totals(0.2, 0.8, an(0.0), 1e-5, 62).unwrap();
    assert!((r / (0.8e-5 / 2.0) - 1.0).abs() < 1e-3, "{r}");
}

#[test]
fn thin_slab_backscatter_fraction_of_2d_henyey_greenstein() {
    // Independent reference for the anisotropic phase blocks: single scattering
    // of a normal beam, R = albedo tau b(g) with b the backward fraction
    // integral_{pi/2}^{3pi/2} p2(cos t) dt, here by a fine midpoint rule. The
    // discrete set is a midpoint rule too (+-pi/2 fall between nodes), with
    // error O(h^2) ~ 1e-4 at 202 directions: tolerance 1e-3 relative.
    for g in [0.6, -0.3] {
        let m = 200_000;
        let h = PI / m as f64;
        let b: f64 = (0..m)
            .map(|k| {
                km_core::phase::henyey_greenstein_2d(g, (0.5 * PI + (k as f64 + 0.5) * h).cos()) * h
            })
            .sum();
        let tau = 1e-6;
        let (r, _) = slab_totals(0.2, 0.8, an(g), tau, 202).unwrap();
        let expect = 0.8 * tau * b;
        assert!((r / expect - 1.0).abs() < 1e-3, "g={g}: {r} vs {expect}");
    }
}

#[test]
fn field_inside_conserves_flux_and_starts_as_the_beam() {
    // omega = 1: the net downward flux is the same at every depth and equals T.
    let (sa, ss, g, z0) = (0.0, 2.0, 0.5, 3.0);
    let n_dirs = 46;
    let set = CircleSet::new(n_dirs).unwrap();
    let depths = [0.0, 0.5, 1.5, 2.5, 3.0];
    let prof = intensity_at_depths(sa, ss, an(g), z0, n_dirs, &depths).unwrap();
    let (_, t) = slab_totals(sa, ss, an(g), z0, n_dirs).unwrap();
    let w = set.weights()[0];
    for p in &prof {
        let net: f64 =
            p.angles.iter().zip(&p.diffuse).map(|(a, i)| a.cos() * i * w).sum::<f64>() + p.direct;
        assert!((net - t).abs() < 1e-10, "z={}: net {net} vs T {t}", p.z);
        assert!((p.direct - (-2.0 * p.z).exp()).abs() < 1e-15);
    }
    // At z = 0 the downward radiance is the beam alone (seed fig. 4).
    for (a, i) in prof[0].angles.iter().zip(&prof[0].diffuse) {
        if a.cos() > 0.0 {
            assert!(i.abs() < 1e-12, "angle {a}: {i}");
        }
    }
    // At the bottom nothing comes up.
    for (a, i) in prof[4].angles.iter().zip(&prof[4].diffuse) {
        if a.cos() < 0.0 {
            assert!(i.abs() < 1e-12);
        }
    }
}

#[test]
fn field_in_a_half_space_is_finite_and_decays() {
    let prof =
        intensity_at_depths(0.2, 0.8, an(0.3), f64::INFINITY, 38, &[0.0, 1.0, 5.0, 50.0]).unwrap();
    let total = |p: &DepthProfile| p.diffuse.iter().sum::<f64>();
    assert!(prof.iter().all(|p| p.diffuse.iter().all(|v| v.is_finite() && *v > -1e-12)));
    assert!(total(&prof[3]) < 1e-3 * total(&prof[1]));
    assert!(intensity_at_depths(0.2, 0.8, an(0.3), 2.0, 38, &[3.0]).is_err());
}

/// A checked asymmetry parameter (the values here are all valid).
fn an(g: f64) -> Anisotropy {
    Anisotropy::new(g).unwrap()
}
