//! The MCML-style grid tallies (docs/montecarlo.md §7): their sums against
//! the totals (identities that hold photon by photon), exact references
//! for an absorbing, non-scattering slab, and the bit-identical merge.

use km_montecarlo::depth::{DepthQuantity, depth_field};
use km_montecarlo::{McGrid, McOptions, Partial, merge_grid, run_shard, solve_grid};

fn scene(text: &str) -> km_core::Scene {
    km_core::Scene::from_toml_str(text).unwrap()
}

const SKIN: &str = "[[layer]]\nsigma_a = 1.0\nsigma_s = 100.0\ng = 0.9\nn = 1.37\nthickness = 0.1\n\
                    [[layer]]\nsigma_a = 2.0\nsigma_s = 10.0\ng = 0.0\nn = 1.37\nthickness = 0.2\n";

#[test]
fn grid_sums_match_the_totals() {
    // Every identity here holds photon by photon, so only rounding separates
    // the two sides (1e-12 of sums of order 1).
    let grid = McGrid { dz: 0.01, nz: 25, dr: 0.01, nr: 30, na: 7 };
    let opts = McOptions { samples: 20_000, grid: Some(grid), ..Default::default() };
    let (sol, g) = solve_grid(&scene(SKIN), &opts).unwrap();
    let (c, g) = (&sol.channels[0], &g[0]);
    let raw = &g.raw;
    // A(z) with its overflow bin is the absorptance; A(r, z) sums to A(z).
    let a_z: f64 = raw.a_z.iter().sum();
    assert!((a_z - c.absorptance).abs() < 1e-12, "{a_z} {}", c.absorptance);
    for iz in 0..=grid.nz {
        let col: f64 = (0..=grid.nr).map(|ir| raw.a_rz[ir * (grid.nz + 1) + iz]).sum();
        assert!((col - raw.a_z[iz]).abs() < 1e-12);
    }
    // Rd + the launch's Fresnel reflection is R; Tt is T.
    let rsp = km_core::fresnel::reflectance(1.0, 1.0, 1.37);
    assert!((g.rd + rsp - c.reflectance).abs() < 1e-12, "{} {rsp} {}", g.rd, c.reflectance);
    assert!((g.tt - c.transmittance).abs() < 1e-12);
    // The marginals sum to the totals.
    let s = |v: &[f64]| v.iter().sum::<f64>();
    for v in [&raw.rd_r, &raw.rd_a, &raw.rd_ra] {
        assert!((s(v) - g.rd).abs() < 1e-12);
    }
    for v in [&raw.tt_r, &raw.tt_a, &raw.tt_ra] {
        assert!((s(v) - g.tt).abs() < 1e-12);
    }
    // Net flux: 1 - R at the top, T (no substrate absorption) below the stack.
    assert!((g.flux_z[0] - (1.0 - c.reflectance)).abs() < 1e-12);
    // At the last edge (z = 0.25, inside the stack) what is still to come:
    // T and the absorption below.
    let last = g.flux_z[grid.nz];
    assert!((last - (c.transmittance + raw.a_z[grid.nz])).abs() < 1e-12);
    // Normalised values: Rd(r) times the ring areas gives the raw sums back.
    for (i, x) in g.rd_r.iter().enumerate() {
        let back = x * km_montecarlo::grid::ring_area(i, grid.dr);
        assert!((back - raw.rd_r[i]).abs() < 1e-15 + 1e-12 * raw.rd_r[i]);
    }
}

#[test]
fn absorbing_slab_without_scattering_is_exact() {
    // sigma_t = sigma_a = 2 per unit length, matched indices, normal
    // incidence: the beam decays as exp(-2 z); every photon is absorbed at
    // its first interaction or leaves through the bottom. Reference bin
    // means: phi = (e^{-2 z0} - e^{-2 z1}) / (2 dz), A = 2 phi, and the net
    // flux F(z) = exp(-2 z). Tolerance: 4 standard errors per bin (over 40
    // values a 4-sigma miss has probability ~2.5e-3 for a correct tracer).
    let s = scene("[[layer]]\nsigma_a = 2.0\nsigma_s = 0.0\nthickness = 1.0\n");
    let f = depth_field(&s, &McOptions { samples: 40_000, ..Default::default() }, 0.1, 10).unwrap();
    let phi = |z: f64| (-2.0 * z).exp();
    for (q, r) in [
        (DepthQuantity::Phi, &phi as &dyn Fn(f64) -> f64),
        (DepthQuantity::A, &|z: f64| 2.0 * phi(z)),
        (DepthQuantity::Flux, &phi),
    ] {
        let z = f.z_scores(0, q, r);
        // The flux at z = 0 is exactly 1 (no reflection): its se is 0.
        let worst = z.iter().filter(|x| x.is_finite()).fold(0.0f64, |m, x| m.max(x.abs()));
        assert!(worst < 4.0, "{q:?}: {z:?}");
    }
    assert_eq!(f.flux[0][0], 1.0);
    // A wrong normalisation (a factor 2 on phi) must be caught.
    let bad = f.z_scores(0, DepthQuantity::Phi, |z| 2.0 * phi(z));
    assert!(bad.iter().any(|x| x.abs() > 10.0));
}

#[test]
fn grid_shards_merge_bit_identically() {
    let grid = McGrid { dz: 0.02, nz: 10, dr: 0.02, nr: 10, na: 5 };
    let opts = McOptions { samples: 3_000, seed: 9, grid: Some(grid), ..Default::default() };
    let s = scene(SKIN);
    let whole = solve_grid(&s, &opts).unwrap();
    let parts: Vec<Partial> = (0..3)
        .map(|i| {
            let p = run_shard(&s, &opts, i, 3).unwrap();
            serde_json::from_str(&serde_json::to_string(&p).unwrap()).unwrap()
        })
        .collect();
    let merged = merge_grid(&parts).unwrap();
    assert_eq!(merged.1, whole.1);
    assert_eq!(merged.0.channels, whole.0.channels);
}

#[test]
fn grid_counts_in_the_tally_memory() {
    let grid = McGrid { dz: 0.01, nz: 1000, dr: 0.01, nr: 1000, na: 10 };
    let opts = McOptions { samples: 1_000_000, grid: Some(grid), ..Default::default() };
    let e = solve_grid(&scene(SKIN), &opts).unwrap_err();
    assert!(e.to_string().contains("tallies need"), "{e}");
    let bad = McGrid { dz: 0.0, ..grid };
    let e = solve_grid(&scene(SKIN), &McOptions { grid: Some(bad), ..opts }).unwrap_err();
    assert!(e.to_string().contains("grid.dz"), "{e}");
}
