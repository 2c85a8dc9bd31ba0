//! The direction-set method (`direction-set`) through the one interface:
//! against the Fourier–Gauss multi-flux on scenes it treats, its refusals,
//! and its options.
//!
//! Tolerances: docs/multiflux-direction-set.md §7 measures the direction
//! set's discretisation error at 303 directions against DISORT and
//! adding-doubling (Table 1): at most 1.3e-5 for isotropic scattering and
//! 7.5e-4 with `g != 0`; its own test asserts 3e-5 and 1e-3. The same bounds
//! apply here, against the Fourier–Gauss mode at 64 streams, whose own error
//! on these totals is far smaller (docs/multiflux.md).

use std::path::PathBuf;

use km::{DirectionSetOptions, KmError, Method, MultifluxOptions, Options, Reason, Scene, Solver};

/// Bound of docs/multiflux-direction-set.md §7 at 303 directions, g = 0.
const TOL_ISOTROPIC: f64 = 3e-5;
/// The same, g != 0.
const TOL_ANISOTROPIC: f64 = 1e-3;

fn example(name: &str) -> Scene {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..");
    Scene::from_path(&root.join("examples").join(name)).unwrap()
}

fn reference(scene: &Scene) -> km::Solution {
    let o = MultifluxOptions { streams: Some(64), ..Default::default() };
    km::solve(scene, &Options::from(o)).unwrap()
}

/// Worst absolute difference of R, T (within `tol`) and A (within `2 tol`) over
/// channels, with the delta parts checked at `tol_delta`.
fn compare(scene: &Scene, tol: f64, tol_delta: f64, tag: &str) -> f64 {
    let ds = km::solve(scene, &Options::new(Method::DirectionSet)).unwrap();
    let mf = reference(scene);
    assert_eq!(ds.method, "direction-set");
    let mut worst = 0.0f64;
    for (a, b) in ds.channels.iter().zip(&mf.channels) {
        for (x, y, t, what) in [
            (a.reflectance, b.reflectance, tol, "R"),
            (a.transmittance, b.transmittance, tol, "T"),
            // A = 1 - R - T carries the errors of both.
            (a.absorptance, b.absorptance, 2.0 * tol, "A"),
            (a.reflectance_specular, b.reflectance_specular, tol_delta, "R_specular"),
            (a.transmittance_direct, b.transmittance_direct, tol_delta, "T_direct"),
        ] {
            assert!((x - y).abs() < t, "{tag} {what}: direction set {x} vs multiflux {y}");
            worst = worst.max((x - y).abs());
        }
        assert!(a.absorptance > -1e-12, "{tag}: A = {}", a.absorptance);
    }
    eprintln!("{tag}: worst |difference| {worst:.2e}");
    worst
}

#[test]
fn agrees_with_fourier_gauss_on_collimated_scenes() {
    // Collimated beam on a node: the delta parts are Fresnel and Beer-Lambert
    // at the beam's own angle, exact in both methods up to rounding (1e-12).
    compare(&example("fresnel-slab.toml"), TOL_ISOTROPIC, 1e-12, "fresnel slab, 45 deg");
    let iso = Scene::from_toml_str("[[layer]]\ntau = 1\nalbedo = 0.9\n").unwrap();
    compare(&iso, TOL_ISOTROPIC, 1e-12, "isotropic slab, normal");
    let stack = Scene::from_toml_str(
        "[light]\nkind = \"collimated\"\ntheta_deg = 30\n\
         [[layer]]\ntau = 0.5\nalbedo = 0.8\ng = 0.5\nn = 1.5\n\
         [[layer]]\ntau = 2\nalbedo = 0.95\ng = 0.3\nn = 1.3\n\
         [substrate]\nkind = \"lambertian\"\nalbedo = 0.6\n",
    )
    .unwrap();
    compare(&stack, TOL_ANISOTROPIC, 1e-12, "two layers, index change, Lambertian, g != 0");
    let half = example("marble-half-space.toml");
    compare(&half, TOL_ANISOTROPIC, 1e-12, "marble half-space");
}

#[test]
fn agrees_with_fourier_gauss_under_diffuse_light() {
    // Diffuse light: the delta parts are hemispherical integrals, which the
    // set's rings integrate with the same quadrature error as the totals.
    let text = "[light]\nkind = \"diffuse\"\n[[layer]]\ntau = 1\nalbedo = 0.9\nn = 1.0\n";
    let iso = Scene::from_toml_str(text).unwrap();
    compare(&iso, TOL_ISOTROPIC, TOL_ISOTROPIC, "isotropic slab, diffuse");
    let fresnel = Scene::from_toml_str(
        "[light]\nkind = \"diffuse\"\n[[layer]]\ntau = 0.5\nalbedo = 0.8\nn = 1.3\n",
    )
    .unwrap();
    compare(&fresnel, TOL_ISOTROPIC, TOL_ISOTROPIC, "Fresnel slab, diffuse");
}

#[test]
fn the_seeds_three_layer_scene_without_output_directions() {
    // docs/multiflux-direction-set.md §8: R = 0.4482 of which 0.0238 specular,
    // A = 0.5518 on 302 directions (rounded to 4 digits there).
    let scene = example("seed-three-layers.toml");
    let scene =
        scene.with_channels(vec![scene.channels()[0].with_directions(vec![]).unwrap()]).unwrap();
    let sol = km::solve(&scene, &Options::new(Method::DirectionSet)).unwrap();
    let c = &sol.channels[0];
    assert!((c.reflectance - 0.4482).abs() < 5e-5, "R = {}", c.reflectance);
    assert!((c.reflectance_specular - 0.0238).abs() < 5e-5);
    assert!((c.absorptance - 0.5518).abs() < 5e-5);
    assert_eq!(sol.to_json()["direction_set"]["nodes"], 302);
    compare(&scene, TOL_ISOTROPIC, 1e-12, "seed three layers");
}

#[test]
fn spectral_channels_are_solved_each_on_its_own_sets() {
    let text = "[spectrum]\nwavelengths_nm = [450, 550, 650]\n[[layer]]\n\
                sigma_a = [0.1, 0.2, 0.3]\nsigma_s = 1\nthickness = 2\nn = [1.3, 1.4, 1.5]\n";
    let scene = Scene::from_toml_str(text).unwrap();
    let all = DirectionSetOptions::default().solve_unplanned(&scene).unwrap();
    for (k, c) in all.channels.iter().enumerate() {
        let one = Scene::single(scene.channels()[k].clone());
        let alone = DirectionSetOptions::default().solve_unplanned(&one).unwrap();
        assert_eq!(c, &alone.channels[0], "channel {k}");
    }
    assert_eq!(all.to_json()["direction_set"]["nodes"].as_array().unwrap().len(), 3);
    compare(&scene, TOL_ISOTROPIC, 1e-12, "three channels, three indices");
}

#[test]
fn more_directions_converge_towards_fourier_gauss() {
    // Table 1: the g != 0 error falls by more than 5x from 100 to 303 directions.
    let scene = Scene::from_toml_str("[[layer]]\ntau = 1\nalbedo = 0.9\ng = 0.75\n").unwrap();
    let r_ref = reference(&scene).channels[0].reflectance;
    let err = |directions| {
        let s = DirectionSetOptions { directions }.solve_unplanned(&scene).unwrap();
        (s.channels[0].reflectance - r_ref).abs()
    };
    let (e100, e303) = (err(100), err(303));
    eprintln!("g 0.75: |R - R_ref| {e100:.2e} at 100, {e303:.2e} at 303");
    assert!(e303 < e100 / 5.0 && e303 < TOL_ANISOTROPIC);
}

#[test]
fn refuses_what_the_direction_set_lacks_with_a_typed_reason() {
    let no = |scene: &Scene, o: DirectionSetOptions| match km::solve(scene, &Options::from(o)) {
        Err(KmError::Unsupported(u)) => {
            assert_eq!(u.method, Method::DirectionSet);
            u.reason
        }
        other => panic!("expected a refusal, got {other:?}"),
    };
    let d = DirectionSetOptions::default();
    // Output directions: values on its own nodes only.
    let seed = example("seed-three-layers.toml");
    assert_eq!(no(&seed, d), Reason::OutputDirections { directions: 6 });
    assert!(d.supports(&seed).is_err(), "the bare interface refuses too");
    // A clear half-space layer has no set of its own.
    let clear = Scene::from_toml_str(
        "[[layer]]\ntau = 1\nalbedo = 0.5\n[[layer]]\nsigma_a = 0\nsigma_s = 0\n\
         thickness = inf\nn = 1.5\n",
    )
    .unwrap();
    assert_eq!(no(&clear, d), Reason::ClearHalfSpace { layer: 2 });
    assert!(km::solve(&clear, &Options::new(Method::Multiflux)).is_ok(), "multiflux treats it");
    // Every distinct index adds its total-internal-reflection cone to the sets
    // of the denser media (docs eq. D4): five indices at 2000 directions in
    // air need 3531 downward directions in the densest (the beam's Radau rings included).
    let mut text = String::new();
    for n in [1.2, 1.5, 2.0, 2.5, 3.0] {
        text += &format!("[[layer]]\ntau = 0.2\nalbedo = 0.5\nn = {n}\n");
    }
    let dense = Scene::from_toml_str(&text).unwrap();
    let reason = no(&dense, DirectionSetOptions { directions: 2000 });
    let want = Reason::SetTooLarge { channel: 0, directions: 3531, limit: 2000 };
    assert_eq!(reason, want);
    assert!(km::solve(&dense, &Options::new(Method::DirectionSet)).is_ok(), "303 is fine");
    // The refusal names what the method lacks.
    let text = km::Unsupported { method: Method::DirectionSet, reason: no(&seed, d) }.to_string();
    assert!(text.contains("output directions"), "{text}");
}

#[test]
fn out_of_range_options_and_accuracy_targets_are_refused() {
    let scene = example("fresnel-slab.toml");
    for directions in [0, 3, 2001, usize::MAX] {
        let o = Options::from(DirectionSetOptions { directions });
        assert!(
            matches!(km::solve(&scene, &o), Err(KmError::Option { name: "directions", .. })),
            "{directions}"
        );
    }
    let o = Options::new(Method::DirectionSet).with_tolerance(1e-4);
    assert!(matches!(km::solve(&scene, &o), Err(KmError::Option { name: "accuracy target", .. })));
    assert!(!Method::DirectionSet.has_accuracy_knob());
    assert_eq!("direction-set".parse::<Method>(), Ok(Method::DirectionSet));
}
