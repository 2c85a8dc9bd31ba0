//! Seed 000 §4.4: the 3-layer example (Fresnel surface n = 1.3, scattering
//! layer sigma_a = 0.1, sigma_s = 0.4, thickness 1/(2 sigma_t), isotropic
//! scattering as the seed names no g, Lambertian 0.8 underneath, light at 45
//! degrees) and the Neumann truncation (eq. 21) of its 2-layer part.

mod common;
use common::run;
use km_core::fresnel::reflectance;
use km_multiflux::{MultifluxOptions, solve};

/// Exit directions: theta 0..85 by 5 degrees, phi 0..330 by 30 degrees.
fn grid() -> String {
    let mut d = Vec::new();
    for it in 0..18 {
        for ip in 0..12 {
            d.push(format!("[{}, {}]", 5.0 * it as f64, 30.0 * ip as f64));
        }
    }
    format!("[output]\ndirections_deg = [{}]\n", d.join(", "))
}

/// The seed's scene file (defined once, in examples/).
const SEED: &str = include_str!("../../examples/seed-three-layers.toml");

/// The seed's scene up to `section` (light, ambient, the coating; with
/// `[output]`, its substrate too).
fn seed_up_to(section: &str) -> &'static str {
    &SEED[..SEED.find(section).expect("the example has this section")]
}

#[test]
fn seed_three_layer_example() {
    // thickness = 1 / (2 sigma_t) = 1 / (2 * 0.5) = 1: tau = 0.5, albedo 0.8.
    let t = format!("{}{}", seed_up_to("[output]"), grid());
    let c = run(&t, 16);
    println!(
        "seed 3-layer: R = {:.6} (specular {:.6}), A = {:.6}",
        c.reflectance, c.reflectance_specular, c.absorptance
    );
    // The specular part is the Fresnel reflectance from air at 45 degrees
    // (the beam's internal mirror reflections are diffused by the Lambertian floor
    // or scattered), up to the unscattered internal round trip.
    let r_air = reflectance(45f64.to_radians().cos(), 1.0, 1.3);
    assert!((c.reflectance_specular - r_air).abs() < 1e-3, "{} vs {r_air}", c.reflectance_specular);
    assert!(c.absorptance > 0.0 && c.reflectance < 1.0);
    assert!(c.brdf.iter().all(|&x| x.is_finite() && x > 0.0));
    // Converged: 16 vs 32 streams within 1e-5 on the totals.
    let c32 = run(&t, 32);
    assert!((c.reflectance - c32.reflectance).abs() < 1e-5);
}

/// Fresnel reflectance at 45 degrees for n = 1.3: ~0.024 from air and ~0.093
/// from inside (the seed's "about 0.1" is the inside value).
#[test]
fn seed_fresnel_values_at_45_degrees() {
    let mu = 45f64.to_radians().cos();
    let (outside, inside) = (reflectance(mu, 1.0, 1.3), reflectance(mu, 1.3, 1.0));
    println!("Fresnel 45 deg, n = 1.3: from air {outside:.4}, from inside {inside:.4}");
    assert!((outside - 0.024).abs() < 1e-3 && (inside - 0.093).abs() < 1e-3);
}

/// RMS difference between exact adding and its order-0 / order-1 Neumann
/// truncation for the seed's 2-layer system (interface + scattering layer,
/// the layer's medium below), over the smooth BRDF and BTDF on a direction
/// grid, relative to the RMS of the exact values; and on the totals.
#[test]
fn seed_neumann_truncation_rms() {
    let t = format!(
        "{}[substrate]\nkind = \"transparent\"\nn = 1.3\n{}",
        seed_up_to("[substrate]"),
        grid()
    );
    let sc = common::scene(&t);
    let go = |k: Option<usize>| {
        let o = MultifluxOptions { streams: Some(16), neumann_order: k, ..Default::default() };
        solve(&sc, &o).unwrap().channels.remove(0)
    };
    let exact = go(None);
    let vals = |c: &km_core::ChannelResult| -> Vec<f64> {
        c.brdf.iter().chain(&c.btdf).copied().collect()
    };
    let ex = vals(&exact);
    let norm = (ex.iter().map(|x| x * x).sum::<f64>() / ex.len() as f64).sqrt();
    let mut rms = Vec::new();
    for k in [0, 1, 2] {
        let c = go(Some(k));
        let a = vals(&c);
        let r = (a.iter().zip(&ex).map(|(x, y)| (x - y) * (x - y)).sum::<f64>() / ex.len() as f64)
            .sqrt()
            / norm;
        println!(
            "Neumann order {k}: RMS(BRDF+BTDF) {:.4} %, dR {:+.2e}, dT {:+.2e}",
            100.0 * r,
            c.reflectance - exact.reflectance,
            c.transmittance - exact.transmittance
        );
        rms.push(r);
    }
    // Each further round trip multiplies the remainder by about the spectral
    // radius of R_rr = R_interface,below * R_slab,above (seed eq. 21), computed
    // here from the m = 0 operators by power iteration.
    let rho = round_trip_radius();
    println!("spectral radius of R_rr (m = 0): {rho:.4}");
    for k in 0..2 {
        let q = rms[k + 1] / rms[k];
        assert!(q > 0.5 * rho && q < 2.0 * rho, "order {k}: ratio {q} vs rho {rho}");
    }
}

/// Spectral radius of the round-trip operator `R_rr` between the interface
/// (air over n = 1.3, seen from below) and the slab (seen from above), m = 0.
fn round_trip_radius() -> f64 {
    use km_multiflux::interface::fresnel_operators;
    use km_multiflux::quadrature::AngularGrid;
    use km_multiflux::slab::{SlabOrder, slab_operators};
    let grid = AngularGrid::new(&[1.0, 1.3], 16);
    let (air, slab) = (grid.medium(1.0), grid.medium(1.3));
    let iface = fresnel_operators(&air, &slab, &[], &[]);
    // Isotropic scattering: chi_0 = 1, all other moments 0.
    let mut chi = vec![0.0; 32];
    chi[0] = 1.0;
    let p = SlabOrder { tau: 0.5, omega: 0.8, chi: &chi, m: 0 };
    let ops = slab_operators(&slab.mu, &slab.w, &[], &p, None).unwrap();
    let rr = &iface.r_bottom * &ops.r_top;
    let n = rr.nrows();
    let mut x = vec![1.0; n];
    let mut rho = 0.0;
    for _ in 0..500 {
        let y: Vec<f64> = (0..n).map(|i| (0..n).map(|j| rr[(i, j)] * x[j]).sum()).collect();
        let norm = y.iter().fold(0.0f64, |a, &b| a.max(b.abs()));
        rho = norm / x.iter().fold(0.0f64, |a, &b| a.max(b.abs()));
        x = y.iter().map(|v| v / norm).collect();
    }
    rho
}
