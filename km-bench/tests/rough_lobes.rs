//! BRDF lobes against roughness (docs/rough.md §9): the Monte Carlo lobes
//! of km's rough faces behave as a microfacet lobe must, and tend to the
//! smooth stack's multi-flux BRDF away from the mirror direction.

use km_bench::recipes::rough_lobes::{
    ALPHAS, LobeStack, THETA_I, mc_lobe, mc_lobe_in_cones, plane_exits, smooth_multiflux,
};

/// Lacquer over gold (no scattering, so the BRDF is the lobe alone): as
/// alpha grows over 0.05, 0.1, 0.2, 0.4 the BRDF at the mirror direction
/// falls and the full width at half maximum grows. Both change by factors
/// of about 2-4 per step (measured: 59, 16, 4.1, 1.2 /sr; 7, 12, 23, 38
/// degrees), far beyond the noise: the test requires each step to exceed
/// 3 standard errors (mirror value) or to be wider by more than the 2.5-degree
/// direction spacing (width), so it fails on a lobe that does not narrow
/// with alpha, not on noise.
#[test]
fn gold_lobe_falls_and_widens_with_roughness() {
    let (exits, psi) = plane_exits(2.5, 80.0);
    let lobes: Vec<_> = ALPHAS
        .iter()
        .map(|&a| mc_lobe(LobeStack::LacquerOverGold, a, &exits, 100_000, 7).unwrap())
        .collect();
    for w in lobes.windows(2) {
        let (a, b) = (&w[0], &w[1]);
        let ((pa, sa), (pb, sb)) = (a.at(&psi, THETA_I), b.at(&psi, THETA_I));
        eprintln!(
            "alpha {} -> {}: mirror {pa:.4} +- {sa:.4} -> {pb:.4} +- {sb:.4}",
            a.alpha, b.alpha
        );
        assert!(pa - pb > 3.0 * (sa * sa + sb * sb).sqrt(), "mirror BRDF must fall");
        let (fa, fb) = (a.fwhm(&psi, &[]), b.fwhm(&psi, &[]));
        eprintln!("  width {fa:.1} -> {fb:.1} deg");
        assert!(fb - fa > 2.5, "lobe must widen");
        // The peak sits at the mirror direction (within one spacing and the
        // cone) for a dielectric-over-metal lobe.
        let ip = a.peak_index();
        assert!((psi[ip] - THETA_I).abs() <= 2.5, "peak at {} deg", psi[ip]);
    }
}

/// Clear coat over pigment, alpha = 0.01: away from the mirror direction
/// (more than 30 degrees off it, where the GGX tail of alpha 0.01 is below
/// 1e-3 of the body) the Monte Carlo BRDF is the smooth stack's multi-flux
/// BRDF. Compared: the mean over 9 directions (back side 0..70 degrees, and
/// 10 degrees on the mirror side), in 5-degree cones. Tolerance: 3 standard
/// errors of the mean (the cones do not overlap, so the bins' covariance is
/// negative and the root sum of their variances bounds the mean's), plus
/// the cone error bounded by the multi-flux ring mean at the cone's edge
/// minus its centre (a disc mean differs from the centre by half that, to
/// second order), plus the multi-flux discretisation error (16 against 32
/// streams).
#[test]
fn coat_at_small_roughness_meets_the_smooth_multiflux_body() {
    let cone = 5.0;
    let mut exits: Vec<[f64; 2]> = (0..8).map(|k| [10.0 * k as f64, 0.0]).collect();
    exits.push([10.0, 180.0]);
    let stack = LobeStack::CoatOverPigment;
    let lobe = mc_lobe_in_cones(stack, 0.01, &exits, 200_000, 11, cone).unwrap();
    let (fine, _) = smooth_multiflux(stack, &exits, 32).unwrap();
    let (coarse, _) = smooth_multiflux(stack, &exits, 16).unwrap();
    // The ring of 4 points at angular distance `cone` around each direction.
    let mut ring = Vec::new();
    for d in &exits {
        let (t, p) = (d[0].to_radians(), d[1].to_radians());
        let c = [t.sin() * p.cos(), t.sin() * p.sin(), t.cos()];
        let u = if t.abs() < 1e-9 {
            [1.0, 0.0, 0.0]
        } else {
            [t.cos() * p.cos(), t.cos() * p.sin(), -t.sin()]
        };
        let v = [c[1] * u[2] - c[2] * u[1], c[2] * u[0] - c[0] * u[2], c[0] * u[1] - c[1] * u[0]];
        let a = cone.to_radians();
        for (cu, cv) in [(1.0, 0.0), (-1.0, 0.0), (0.0, 1.0), (0.0, -1.0)] {
            let w: Vec<f64> =
                (0..3).map(|i| a.cos() * c[i] + a.sin() * (cu * u[i] + cv * v[i])).collect();
            let theta = w[2].clamp(-1.0, 1.0).acos().to_degrees();
            let phi = w[1].atan2(w[0]).to_degrees().rem_euclid(360.0);
            ring.push([theta, phi]);
        }
    }
    let (ring_mf, _) = smooth_multiflux(stack, &ring, 32).unwrap();
    let k = exits.len() as f64;
    let mean = |v: &[f64]| v.iter().sum::<f64>() / k;
    let mc = mean(&lobe.brdf);
    let se = lobe.stderr.iter().map(|s| s * s).sum::<f64>().sqrt() / k;
    let mf = mean(&fine);
    let disc = (mf - mean(&coarse)).abs();
    let cone_err =
        (ring_mf.chunks(4).map(|r| r.iter().sum::<f64>() / 4.0).sum::<f64>() / k - mf).abs();
    eprintln!("MC {mc:.5} +- {se:.5}, multi-flux {mf:.5} (disc. {disc:.1e}, cone {cone_err:.1e})");
    assert!((mc - mf).abs() <= 3.0 * se + cone_err + disc, "MC {mc} vs multi-flux {mf}");
    // Not vacuous: the body is far above the tolerance.
    assert!(3.0 * se + cone_err + disc < 0.1 * mf);
}

/// The recipe at the full size into `target/rough-lobes-full` (the numbers
/// of docs/rough.md §9).
#[test]
#[ignore = "a few minutes of Monte Carlo: cargo test -p km-bench --test rough_lobes -- --ignored --nocapture"]
fn full_size_figures() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../target/rough-lobes-full");
    let opts = km_bench::ReproduceOptions {
        only: Some("rough-lobes".into()),
        quiet: true,
        ..km_bench::ReproduceOptions::full(dir)
    };
    let summary = km_bench::reproduce(&opts).unwrap();
    eprintln!("{summary}");
    assert_eq!(summary.failures(), 0);
}
