//! The internal field I(z, mu) of a stack (seed eq. 19): energy balance in
//! depth, boundary values, and agreement with the single-layer mode solution.

mod common;
use common::scene;
use km_multiflux::quadrature::AngularGrid;
use km_multiflux::slab::{SlabOrder, SlabSolution};
use km_multiflux::{MultifluxOptions, internal_field, solve};

const STACK: &str = "[light]\ntheta_deg = 30.0\n\
    [[layer]]\nsigma_a = 0.2\nsigma_s = 1.0\nthickness = 0.5\ng = 0.6\nn = 1.5\n\
    [[layer]]\nsigma_a = 0.05\nsigma_s = 2.0\nthickness = 1.0\ng = 0.2\nn = 1.3\n\
    [substrate]\nkind = \"transparent\"\nn = 1.2\n";

/// Net flux through the stack: 1 - R just below the top, T at the bottom,
/// non-increasing in between (absorption >= 0); rounding 1e-10.
#[test]
fn net_flux_goes_from_one_minus_r_to_t() {
    let o = MultifluxOptions { streams: Some(12), ..Default::default() };
    let sc = scene(STACK);
    let mono = &sc.channels()[0];
    let c = solve(&sc, &o).unwrap().channels.remove(0);
    let mut prev = f64::INFINITY;
    for k in 0..=30 {
        let z = 1.5 * k as f64 / 30.0;
        let f = internal_field(mono, &o, z, 0).unwrap().net_flux();
        if k == 0 {
            assert!((f - (1.0 - c.reflectance)).abs() < 1e-10, "{f} vs {}", 1.0 - c.reflectance);
        }
        if k == 30 {
            assert!((f - c.transmittance).abs() < 1e-10, "{f} vs {}", c.transmittance);
        }
        assert!(f <= prev + 1e-10, "z = {z}: {f} > {prev}");
        prev = f;
    }
    assert!(internal_field(mono, &o, 1.6, 0).is_err());
}

/// A conservative layer carries the same net flux at every depth (1e-10).
#[test]
fn conservative_layer_has_constant_net_flux() {
    let o = MultifluxOptions { streams: Some(12), ..Default::default() };
    let sc =
        scene("[light]\ntheta_deg = 60.0\n[[layer]]\ntau = 3.0\nalbedo = 1.0\ng = 0.8\nn = 1.4\n");
    let mono = &sc.channels()[0];
    let f0 = internal_field(mono, &o, 0.0, 0).unwrap().net_flux();
    for k in 1..=10 {
        let f = internal_field(mono, &o, 0.1 * k as f64, 0).unwrap().net_flux();
        assert!((f - f0).abs() < 1e-10, "{f} vs {f0}");
    }
}

/// The stack field (cut and added) equals the mode solution of the layer
/// (eq. 13) inside one index-matched, isotropic layer over a black floor: two
/// independent routes, rounding only (1e-10).
#[test]
fn stack_field_equals_the_mode_solution() {
    let n = 8;
    let o = MultifluxOptions { streams: Some(n), ..Default::default() };
    let sc = scene(
        "[light]\ntheta_deg = 40.0\n[[layer]]\ntau = 2.0\nalbedo = 0.9\n[substrate]\nkind = \"black\"\n",
    );
    let nodes = AngularGrid::new(&[1.0], n).medium(1.0);
    let chi = {
        let mut c = vec![0.0; 2 * n];
        c[0] = 1.0;
        c
    };
    let sol = SlabSolution::new(
        &nodes.mu,
        &nodes.w,
        &SlabOrder { tau: 2.0, omega: 0.9, chi: &chi, m: 0 },
    )
    .unwrap();
    let zero = vec![0.0; n];
    let mu0 = 40f64.to_radians().cos();
    // tau = 2 on a unit thickness: optical depth 2 z.
    for z in [0.0, 0.15, 0.5, 0.85, 1.0] {
        let f = internal_field(&sc.channels()[0], &o, z, 0).unwrap();
        let (dn, up) = sol.field(2.0 * z, &zero, &zero, Some((mu0, 1.0))).unwrap();
        for i in 0..n {
            assert!(
                (f.down[i] - dn[i]).abs() < 1e-10 && (f.up[i] - up[i]).abs() < 1e-10,
                "z = {z} i {i}: {} {} / {} {}",
                f.down[i],
                dn[i],
                f.up[i],
                up[i]
            );
        }
        assert!((f.beam_down - (-2.0 * z / mu0).exp()).abs() < 1e-12);
    }
}
