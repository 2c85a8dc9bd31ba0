//! `km::solve` on a scene with `[output] depths` and `[output]
//! inside_directions_deg` carries the radiance inside of `km field`
//! (docs/field.md §6): the same numbers, names and shapes, from the solve
//! itself (Monte Carlo: from the run that gives the answer).

use km::field::{DEFAULT_INSIDE_CONE_DEG, FieldMethod, FieldOptions, field};
use km::{DipoleOptions, KmOptions, McOptions, Method, MultifluxOptions, Options};
use km_core::Scene;

/// Two layers of different index and phase function, light at 30 degrees;
/// depths at the top, inside, on the interface and at the bottom; down- and
/// up-going directions on both sides of the plane of incidence.
const TWO: &str = "[light]\nkind = \"collimated\"\ntheta_deg = 30.0\n\
    [[layer]]\nsigma_a = 0.5\nsigma_s = 3.0\ng = 0.7\nthickness = 0.6\nn = 1.4\n\
    [[layer]]\nsigma_a = 0.1\nsigma_s = 5.0\ng = 0.3\nthickness = 1.0\nn = 1.33\n\
    [output]\ndepths = [0.0, 0.3, 0.6, 1.6]\n\
    inside_directions_deg = [[20.0, 180.0], [60.0, 0.0], [140.0, 90.0], [170.0, 180.0]]\n";

fn scene(text: &str) -> Scene {
    Scene::from_toml_str(text).unwrap()
}

/// The scene without the directions (the depths kept).
fn without_directions(text: &str) -> Scene {
    let cut = text.find("inside_directions_deg").unwrap();
    scene(&text[..cut])
}

/// Largest absolute difference of two channel x depth x direction cubes,
/// relative to the largest value (the shapes must agree).
fn cube_difference(a: &[Vec<Vec<f64>>], b: &[Vec<Vec<f64>>]) -> f64 {
    assert_eq!(a.len(), b.len());
    let mut scale = 0.0f64;
    let mut worst = 0.0f64;
    for (ca, cb) in a.iter().zip(b) {
        assert_eq!(ca.len(), cb.len());
        for (ka, kb) in ca.iter().zip(cb) {
            assert_eq!(ka.len(), kb.len());
            for (x, y) in ka.iter().zip(kb) {
                scale = scale.max(x.abs()).max(y.abs());
                worst = worst.max((x - y).abs());
            }
        }
    }
    assert!(scale > 0.0, "the radiance must not vanish everywhere");
    worst / scale
}

/// Multi-flux: the solve's radiance is `km::field::field`'s at the solve's
/// streams (the same function on the same channel: 1e-12 of the largest
/// value allows only rounding, and in fact both are one computation), the
/// beams likewise; the totals and the depth field are those of the scene
/// without directions (the key adds, it changes nothing else), and the
/// note that the radiance is not part of a solve is gone.
#[test]
fn multiflux_solve_gives_the_radiance_of_km_field() {
    let s = scene(TWO);
    let o = MultifluxOptions { streams: Some(12), ..Default::default() };
    let sol = km::solve(&s, &Options::from(o.clone())).unwrap();
    let plain = km::solve(&without_directions(TWO), &Options::from(o.clone())).unwrap();
    assert_eq!(sol.channels, plain.channels);
    let f = sol.field.as_ref().expect("field attached");
    let pf = plain.field.as_ref().unwrap();
    assert_eq!((&f.fluence, &f.absorbed, &f.net_flux), (&pf.fluence, &pf.absorbed, &pf.net_flux));
    assert!(pf.radiance.is_none(), "no directions, no radiance");
    let r = f.radiance.as_ref().expect("radiance attached");
    let opts =
        FieldOptions { method: FieldMethod(Method::Multiflux), multiflux: o, ..Default::default() };
    let want = field(&s, None, &opts).unwrap().inside.unwrap();
    assert_eq!(r.directions, want.directions);
    assert!(cube_difference(&r.radiance, &want.radiance) <= 1e-12);
    let ([d, u], [wd, wu]) = (r.beams.as_ref().unwrap(), want.beams.as_ref().unwrap());
    for (x, y) in d
        .iter()
        .flatten()
        .chain(u.iter().flatten())
        .zip(wd.iter().flatten().chain(wu.iter().flatten()))
    {
        assert!((x - y).abs() <= 1e-12 * y.abs().max(1e-300), "{x} {y}");
    }
    assert!(r.stderr.is_none() && r.cone_half_angle_deg.is_none());
    assert!(!sol.notes.iter().any(|n| n.contains("inside_directions_deg")), "{:?}", sol.notes);
    // The JSON's `radiance` is `km field --json`'s object, key for key.
    let json = sol.to_json();
    let fj = field(&s, None, &opts).unwrap().to_json();
    assert_eq!(json["radiance"]["directions"], fj["radiance"]["directions"]);
    for key in ["values", "beam_down", "beam_up"] {
        let (a, b) = (&json["radiance"][key], &fj["radiance"][key]);
        assert_eq!(a.as_array().map(Vec::len), b.as_array().map(Vec::len), "{key}");
    }
    let v = json["radiance"]["values"].as_array().unwrap();
    assert_eq!(v.len(), 4, "depths");
    assert!(v.iter().all(|row| row.as_array().map(Vec::len) == Some(4)), "directions");
    assert!(plain.to_json().get("radiance").is_none());
}

/// An accuracy target: the radiance at the streams the target chose (the
/// field's numbers at those streams).
#[test]
fn an_accuracy_target_gives_the_radiance_at_the_streams_it_chose() {
    let s = scene(TWO);
    let sol = km::solve(&s, &Options::new(Method::Multiflux).with_tolerance(1e-4)).unwrap();
    let acc = sol.accuracy.as_ref().unwrap();
    let n = acc.work.iter().find(|(k, _)| k == "streams").expect("streams chosen").1 as usize;
    let opts = FieldOptions {
        multiflux: MultifluxOptions { streams: Some(n), ..Default::default() },
        ..Default::default()
    };
    let want = field(&s, None, &opts).unwrap().inside.unwrap();
    let r = sol.field.as_ref().unwrap().radiance.as_ref().unwrap();
    assert!(cube_difference(&r.radiance, &want.radiance) <= 1e-12);
}

/// Monte Carlo: the radiance comes from the run that gives the answer, so
/// that it is bit for bit `km field --method mc`'s of the same photons and
/// seed (one run there too; a tally draws no random number), with the same
/// default cone, and the totals bit for bit those of the run without the
/// directions or the depths.
#[test]
fn monte_carlo_solve_gives_the_radiance_of_the_same_run() {
    let s = scene(TWO);
    let mc = McOptions { samples: 20_000, seed: 11, ..Default::default() };
    let sol = km::solve(&s, &Options::from(mc.clone())).unwrap();
    let plain = km::solve(&without_directions(TWO), &Options::from(mc.clone())).unwrap();
    assert_eq!(sol.channels, plain.channels);
    assert!(!sol.notes.iter().any(|n| n.contains("second run")), "{:?}", sol.notes);
    let r = sol.field.as_ref().unwrap().radiance.as_ref().expect("radiance attached");
    let opts = FieldOptions { method: FieldMethod(Method::Mc), mc, ..Default::default() };
    let want = field(&s, None, &opts).unwrap().inside.unwrap();
    assert_eq!(r, &want, "bit for bit km field's");
    let cones = r.cone_half_angle_deg.as_ref().unwrap();
    assert!(cones.iter().all(|&c| c <= DEFAULT_INSIDE_CONE_DEG) && cones[0] == 5.0);
    assert!(r.stderr.is_some() && r.beams.is_none());
    // Something was scored: a down-going direction at depth 0.3 has light.
    assert!(r.radiance[0][1][0] > 0.0);
    let json = sol.to_json();
    for key in ["values", "stderr", "cone_half_angle_deg", "directions"] {
        assert!(json["radiance"][key].is_array(), "{key}");
    }
}

/// Methods without the radiance inside (two-flux, the dipole, the
/// direction set) answer the solve as before and say that the key was
/// ignored (`km field` refuses it for them); a scene with directions but
/// no depths says that the radiance needs depths.
#[test]
fn methods_without_the_radiance_say_so() {
    let s = scene(TWO);
    for (opts, words) in [
        (Options::from(KmOptions::default()), "the km method gives no radiance"),
        (Options::new(Method::DirectionSet), "the direction-set method gives no radiance"),
    ] {
        let sol = km::solve(&s, &opts).unwrap();
        assert!(sol.field.as_ref().is_none_or(|f| f.radiance.is_none()));
        assert!(sol.notes.iter().any(|n| n.contains(words)), "{:?}", sol.notes);
    }
    let half = scene(
        "[[layer]]\nsigma_a = 0.1\nsigma_s = 10.0\ng = 0.8\nthickness = \"inf\"\nn = 1.4\n\
         [output]\ndepths = [0.0, 1.0]\ninside_directions_deg = [[30.0, 0.0]]\n",
    );
    let sol = km::solve(&half, &Options::from(DipoleOptions::default())).unwrap();
    assert!(sol.field.as_ref().unwrap().radiance.is_none());
    assert!(sol.notes.iter().any(|n| n.contains("the dipole method gives no radiance")));
    let no_depths = scene(&TWO.replace("depths = [0.0, 0.3, 0.6, 1.6]\n", ""));
    let sol = km::solve(&no_depths, &Options::new(Method::Multiflux)).unwrap();
    assert!(sol.field.is_none());
    assert!(sol.notes.iter().any(|n| n.contains("asks for none")), "{:?}", sol.notes);
}
