//! The seed's §4.4 example (km_bench::seed): its layers alone against
//! their closed forms, the Lambertian stack against the scalar series of
//! multiple reflections, and the truncation study's errors by order.

use std::f64::consts::PI;

use faer::Mat;
use km_bench::seed::{seed_example_3_layers, seed_layer, seed_scene_file, seed_truncation_study};
use km_multiflux::adding::{LayerOperators, add};
use km_multiflux::direction_set::{DirectionSet, Incidence, MatchedSets, interface_operators};

#[test]
fn the_scene_file_is_the_seed_example() {
    // The numbers of seed 000 §4.4, read back from the one definition.
    let s = seed_scene_file();
    let l = &s.channels()[0].layers()[0];
    assert_eq!(
        (l.sigma_a(), l.sigma_s(), l.thickness(), l.n()),
        (0.1, 0.4, 1.0 / (2.0 * 0.5), 1.3)
    );
    assert_eq!(s.channels()[0].light(), km_core::Light::Collimated { theta_deg: 45.0 });
    assert_eq!(s.channels()[0].substrate(), km_core::Substrate::Lambertian { albedo: 0.8 });
}

#[test]
fn seed_example_layers_alone_have_their_closed_forms() {
    let ex = seed_example_3_layers(303).unwrap();
    let c45 = f64::to_radians(45.0).cos();
    let rf = km_core::fresnel::reflectance(c45, 1.0, 1.3);
    // (a) interface: mirror reflection only, the rest transmitted (rounding).
    assert!((ex.interface.reflectance - rf).abs() < 1e-14);
    assert!((ex.interface.reflectance_specular - rf).abs() < 1e-14);
    assert!((ex.interface.transmittance - (1.0 - rf)).abs() < 1e-13);
    assert!(ex.interface.reflected.value.iter().all(|v| v.abs() < 1e-13));
    // (c) Lambertian: R = 0.8 (Gauss in mu integrates mu exactly), BRDF 0.8 / pi.
    assert!((ex.lambertian.reflectance - 0.8).abs() < 1e-13);
    assert!(ex.lambertian.reflected.value.iter().all(|v| (v - 0.8 / PI).abs() < 1e-13));
    // (b), (d): energy balance with absorption, the mirror part is Fresnel's.
    for r in [&ex.layer, &ex.combined] {
        assert!(r.absorptance > 0.0 && r.absorptance < 1.0);
    }
    assert!((ex.combined.reflectance_specular - rf).abs() < 1e-14);
    assert_eq!(ex.combined.transmittance, 0.0);
}

#[test]
fn lambertian_substrate_matches_the_scalar_multiple_reflection_series() {
    // The Lambertian reflector is rank one, so the stack over it has the
    // closed form R = R_0 + F rho t_d / (1 - rho r_d) (van de Hulst ch. 4):
    // R_0 the stack over black, F the flux reaching the substrate, r_d and t_d
    // the stack's reflectance and transmittance for Lambertian light from below.
    let coat = seed_layer();
    let inc = Incidence { n: 1.0, theta_deg: 45.0 };
    let sets = MatchedSets::new(303, &[1.0, 1.3], Some(inc)).unwrap();
    let (top, inside) = (sets.set(1.0).unwrap(), sets.set(1.3).unwrap());
    let stack: LayerOperators =
        add(&interface_operators(top, inside).unwrap(), &inside.layer_operators(&coat).unwrap())
            .unwrap();
    let i0 = top.incidence().unwrap();
    let (w0, mu0) = (top.weights()[i0], top.mu()[i0]);
    let flux = |m: &Mat<f64>, set: &DirectionSet, v: &[f64]| -> f64 {
        (0..m.nrows())
            .map(|i| {
                set.mu()[i]
                    * set.weights()[i]
                    * (0..m.ncols()).map(|j| m[(i, j)] * v[j]).sum::<f64>()
            })
            .sum()
    };
    let mut beam = vec![0.0; top.len()];
    beam[i0] = 1.0 / (w0 * mu0);
    let r0 = flux(&stack.r_top, top, &beam);
    let f = flux(&stack.t_down, inside, &beam);
    let lamb = vec![1.0 / PI; inside.len()];
    let r_d = flux(&stack.r_bottom, inside, &lamb);
    let t_d = flux(&stack.t_up, top, &lamb);
    let rho = 0.8;
    let expect = r0 + f * rho * t_d / (1.0 - rho * r_d);
    let ex = seed_example_3_layers(303).unwrap();
    assert!(
        (ex.combined.reflectance - expect).abs() < 1e-12,
        "{} vs {expect}",
        ex.combined.reflectance
    );
}

#[test]
fn seed_truncation_errors_shrink_with_order() {
    let st = seed_truncation_study(303).unwrap();
    // Inter-reflections only add light: truncations reflect and transmit less.
    assert!(st.order0.reflectance < st.order1.reflectance);
    assert!(st.order1.reflectance < st.exact.reflectance);
    assert!(st.rms1.with_delta < st.rms0.with_delta);
    // The ratio of successive errors is about the round-trip norm of R_rr.
    let ratio = st.rms1.with_delta / st.rms0.with_delta;
    assert!(ratio < st.rr_spectral_radius * 1.5, "{ratio} vs {}", st.rr_spectral_radius);
    // Which side of the interface is "about 0.1": the inside value.
    assert!((st.fresnel_45_inside - 0.093).abs() < 1e-3);
    assert!((st.fresnel_45_outside - 0.024).abs() < 1e-3);
    // The seed's Kubelka–Munk estimate of the coating's reflectance, 0.26.
    assert!((st.km_reflectance - 0.26).abs() < 0.005);
    // Specular and unscattered parts are exact in every order.
    assert!((st.order0.reflectance_specular - st.exact.reflectance_specular).abs() < 1e-15);
}
