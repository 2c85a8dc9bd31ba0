//! The valid-once types: every constructor refuses what the scene file
//! refuses, the `with_*` variants check what they change, and what they
//! keep is untouched (docs/architecture.md, "Valid-once types").

use km_core::layer::{check_index, is_refractive_index};
use km_core::phase::{Anisotropy, Phase};
use km_core::{CoreError, Layer, Light, MonoScene, Scene, Substrate};

fn layer() -> Layer {
    Layer::new(0.1, 0.4, 1.0, 0.5, 1.3).unwrap()
}

fn mono(layers: Vec<Layer>) -> Result<MonoScene, CoreError> {
    MonoScene::new(Light::Diffuse, 1.0, layers, Substrate::Black, vec![])
}

/// The key a scene error names.
fn key(e: CoreError) -> String {
    match e {
        CoreError::Scene { key, .. } | CoreError::Invalid { name: key, .. } => key,
        other => panic!("unexpected {other}"),
    }
}

#[test]
fn anisotropy_is_the_one_check_of_g() {
    for g in [-0.999, -0.5, 0.0, 0.3, 0.999] {
        assert_eq!(Anisotropy::new(g).unwrap().get(), g);
        assert_eq!(Phase::henyey_greenstein(g).unwrap().g(), g);
    }
    for g in [-1.0, 1.0, 1.5, f64::NAN, f64::INFINITY] {
        assert!(!Anisotropy::admits(g), "{g}");
        assert!(Anisotropy::new(g).is_err() && Phase::henyey_greenstein(g).is_err());
        assert!(Layer::new(0.1, 0.4, 1.0, g, 1.3).is_err());
    }
    // sigma_s' = sigma_s (1 - g): 0.4 * 0.5 exactly.
    assert_eq!(layer().sigma_s_reduced(), 0.2);
    assert_eq!(Anisotropy::new(0.5).unwrap().squared().get(), 0.25);
}

#[test]
fn one_refractive_index_check() {
    for n in [1.0, 1.5, 4.0] {
        assert!(is_refractive_index(n) && check_index("n", n).is_ok());
    }
    for n in [0.99, -1.0, f64::NAN, f64::INFINITY] {
        assert!(!is_refractive_index(n) && check_index("n", n).is_err(), "{n}");
        assert!(layer().with_n(n).is_err() && Substrate::transparent(n).is_err());
        assert_eq!(key(layer().with_n(n).unwrap_err()), "n");
        let e = MonoScene::new(Light::Diffuse, n, vec![layer()], Substrate::Black, vec![]);
        assert_eq!(key(e.unwrap_err()), "ambient.n");
    }
}

#[test]
fn with_variants_check_what_they_change_and_keep_the_rest() {
    let l = layer();
    let t = l.with_thickness(3.0).unwrap();
    assert_eq!((t.sigma_a(), t.sigma_s(), t.g(), t.n(), t.thickness()), (0.1, 0.4, 0.5, 1.3, 3.0));
    assert!(l.with_thickness(-1.0).is_err() && l.with_thickness(f64::NAN).is_err());
    assert!(l.with_thickness(f64::INFINITY).unwrap().is_half_space());
    let c = l.with_coefficients(0.2, 0.0).unwrap();
    assert_eq!((c.sigma_a(), c.sigma_s(), c.thickness(), c.g()), (0.2, 0.0, 1.0, 0.5));
    assert_eq!(key(l.with_coefficients(-0.1, 0.4).unwrap_err()), "sigma_a");
    assert_eq!(key(l.with_coefficients(0.1, f64::NAN).unwrap_err()), "sigma_s");
    // sigma_t and tau must be representable (the parser refuses them too).
    assert!(l.with_coefficients(1e308, 1e308).is_err());
    assert!(l.with_coefficients(1e300, 0.0).unwrap().with_thickness(1e10).is_err());
    let p = l.with_phase(Phase::Isotropic);
    assert_eq!((p.g(), p.sigma_s(), p.n()), (0.0, 0.4, 1.3));
}

#[test]
fn the_channel_constructor_holds_every_check() {
    let half = layer().with_thickness(f64::INFINITY).unwrap();
    assert_eq!(key(mono(vec![]).unwrap_err()), "layer");
    assert_eq!(key(mono(vec![half.clone(), layer()]).unwrap_err()), "layer[1].thickness");
    assert!(mono(vec![layer(), half.clone()]).is_ok());
    let m = mono(vec![layer()]).unwrap();
    assert_eq!(
        key(m.with_light(Light::Collimated { theta_deg: 90.0 }).unwrap_err()),
        "light.theta_deg"
    );
    assert!(Light::collimated(89.9999999).is_err() && Light::collimated(89.999999).is_ok());
    let lambertian = |albedo| Substrate::Lambertian { albedo };
    assert_eq!(key(m.with_substrate(lambertian(1.1)).unwrap_err()), "substrate.albedo");
    assert!(Substrate::lambertian(-0.1).is_err() && Substrate::lambertian(1.0).is_ok());
    assert_eq!(key(m.with_directions(vec![[90.0, 0.0]]).unwrap_err()), "output.directions_deg");
    assert!(m.with_directions(vec![[10.0, f64::NAN]]).is_err());
    assert!(m.with_ambient_n(0.5).is_err());
    // The edits check what they change and keep the rest.
    assert_eq!(key(m.with_layers(vec![]).unwrap_err()), "layer");
    assert_eq!(key(m.with_layers(vec![half.clone(), layer()]).unwrap_err()), "layer[1].thickness");
    let edited = m.with_directions(vec![[10.0, 45.0]]).unwrap().with_layers(vec![layer(), half]);
    let edited = edited.unwrap();
    assert_eq!((edited.layers().len(), edited.directions_deg()), (2, &[[10.0, 45.0]][..]));
    assert_eq!((edited.light(), edited.substrate()), (m.light(), m.substrate()));
    // The Snell invariant of the beam: n0 sin(theta).
    let lit = m.with_light(Light::collimated(30.0).unwrap()).unwrap();
    let lit = lit.with_ambient_n(1.5).unwrap();
    assert!((lit.beam_invariant().unwrap() - 0.75).abs() < 1e-15);
    assert_eq!(m.beam_invariant(), None);
}

#[test]
fn the_thick_layer_cut_makes_the_layer_a_half_space() {
    let m = mono(vec![layer(), layer().with_n(1.5).unwrap(), layer()]).unwrap();
    let cut = m.cut_below(1).unwrap();
    assert_eq!(cut.layers().len(), 2);
    assert_eq!(cut.layers()[0], m.layers()[0]);
    assert!(cut.layers()[1].is_half_space() && cut.layers()[1].n() == 1.5);
    assert!(m.cut_below(3).is_err());
}

#[test]
fn a_scene_has_a_label_per_channel() {
    let m = mono(vec![layer()]).unwrap();
    let labels = |k: usize| (0..k).map(|i| i.to_string()).collect::<Vec<_>>();
    assert!(Scene::new(vec![], vec![], None).is_err());
    assert!(Scene::new(vec![m.clone(), m.clone()], labels(1), None).is_err());
    assert!(Scene::new(vec![m.clone()], labels(1), Some(vec![500.0, 600.0])).is_err());
    assert!(Scene::new(vec![m.clone()], labels(1), Some(vec![-1.0])).is_err());
    let s = Scene::new(vec![m.clone(), m.clone()], labels(2), Some(vec![500.0, 600.0])).unwrap();
    let one = s.select(&[1]);
    assert_eq!((one.labels(), one.wavelengths_nm()), (&labels(2)[1..], Some(&[600.0][..])));
    assert!(s.with_channels(vec![m]).is_err());
}

#[test]
fn the_parser_goes_through_the_constructors() {
    let s = Scene::from_toml_str("[[layer]]\ntau = [1, 2]\nalbedo = 0.5\ng = 0.3\n").unwrap();
    for c in s.channels() {
        let again = MonoScene::new(
            c.light(),
            c.ambient_n(),
            c.layers().to_vec(),
            c.substrate(),
            c.directions_deg().to_vec(),
        );
        assert_eq!(again.as_ref(), Ok(c));
    }
}
