//! `km::solve` on a scene with `[output] depths` carries the field of
//! `km field` (docs/field.md §7, the JSON keys of `km solve --json`): the
//! same numbers from the solve itself, consistent with its totals.

use km::field::{FieldMethod, FieldOptions, field};
use km::{McOptions, Method, MultifluxOptions, Options};
use km_core::Scene;

/// Two layers of different absorption and index over a Lambertian floor,
/// light at 30 degrees; depths include the top, the interface at 0.6 and
/// the bottom at 1.6 (the layers' length unit).
const TWO: &str = "[light]\nkind = \"collimated\"\ntheta_deg = 30.0\n\
    [[layer]]\nsigma_a = 0.5\nsigma_s = 3.0\ng = 0.7\nthickness = 0.6\nn = 1.4\n\
    [[layer]]\nsigma_a = 0.1\nsigma_s = 5.0\ng = 0.3\nthickness = 1.0\nn = 1.33\n\
    [substrate]\nkind = \"lambertian\"\nalbedo = 0.5\n\
    [output]\ndepths = [0.0, 0.3, 0.6, 1.0, 1.6]\n";

fn scene(text: &str) -> Scene {
    Scene::from_toml_str(text).unwrap()
}

fn without_depths(text: &str) -> Scene {
    scene(&text.replace("[output]\ndepths = [0.0, 0.3, 0.6, 1.0, 1.6]\n", ""))
}

#[test]
fn multiflux_solve_carries_the_field_and_its_totals_are_unchanged() {
    let s = scene(TWO);
    let opts = MultifluxOptions { streams: Some(12), ..Default::default() };
    let sol = km::solve(&s, &Options::from(opts.clone())).unwrap();
    let plain = km::solve(&without_depths(TWO), &Options::from(opts.clone())).unwrap();
    assert_eq!(sol.channels[0].reflectance, plain.channels[0].reflectance);
    let f = sol.field.as_ref().expect("field attached");
    let want = field(
        &s,
        None,
        &FieldOptions {
            method: FieldMethod(Method::Multiflux),
            multiflux: opts,
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(f.fluence, want.fluence);
    assert_eq!(f.net_flux, want.net_flux);
    // Energy (docs/field.md §1): F(0+) = 1 - R; the layers' absorptance
    // adds up to A (the floor's absorption is the rest of F at the bottom).
    let c = &sol.channels[0];
    assert!((f.net_flux[0][0] - (1.0 - c.reflectance)).abs() < 1e-10);
    let layers = c.absorptance_layers.as_ref().expect("per-layer absorptance");
    assert_eq!(layers.len(), 2);
    let floor = f.net_flux[0][4];
    assert!((layers.iter().sum::<f64>() + floor + c.reflectance - 1.0).abs() < 1e-10);
    let json = sol.to_json();
    for key in ["depths", "fluence", "absorbed", "net_flux"] {
        assert_eq!(json[key].as_array().map(Vec::len), Some(5), "{key}");
    }
}

#[test]
fn monte_carlo_tallies_the_field_in_the_run_that_gives_the_answer() {
    let mc = McOptions { samples: 200_000, seed: 7, ..Default::default() };
    let sol = km::solve(&scene(TWO), &Options::from(mc.clone())).unwrap();
    let plain = km::solve(&without_depths(TWO), &Options::from(mc.clone())).unwrap();
    // The depth tally draws no random number: the same photons, the same answer.
    assert_eq!(sol.channels[0].reflectance, plain.channels[0].reflectance);
    assert_eq!(sol.channels[0].transmittance, plain.channels[0].transmittance);
    let f = sol.field.as_ref().unwrap();
    let se = f.stderr.as_ref().expect("standard errors");
    let json = sol.to_json();
    assert!(json["stderr"]["fluence"].is_array() && json["stderr"]["reflectance"].is_number());
    // Against multi-flux at 32 streams, every depth within 4 standard errors
    // (5 depths x 3 quantities; 4 sigma keeps a false alarm below 1e-3),
    // including the depth on the interface (the layer above's value) and on
    // the bottom: there the bins across the interface or below the stack
    // must not enter the interpolation (before, phi at the bottom came out
    // at half its value).
    let mf = MultifluxOptions { streams: Some(32), ..Default::default() };
    let r = km::solve(&scene(TWO), &Options::from(mf)).unwrap();
    let rf = r.field.as_ref().unwrap();
    for (q, (x, y)) in
        [(&f.fluence, &rf.fluence), (&f.absorbed, &rf.absorbed), (&f.net_flux, &rf.net_flux)]
            .into_iter()
            .enumerate()
    {
        for i in 0..5 {
            let z = (x[0][i] - y[0][i]) / se[q][0][i];
            // Bins are averages over dz: the profile's curvature is within
            // the allowance at the default dz (half the smallest gap / 200 of the depth).
            assert!(
                z.abs() < 4.0,
                "quantity {q} depth {}: mc {} mf {} z {z}",
                f.depths[i],
                x[0][i],
                y[0][i]
            );
        }
    }
}

#[test]
fn an_accuracy_target_gives_the_field_at_the_streams_it_chose() {
    let s = scene(TWO);
    let sol = km::solve(&s, &Options::new(Method::Multiflux).with_tolerance(1e-4)).unwrap();
    let f = sol.field.as_ref().unwrap();
    assert!((f.net_flux[0][0] - (1.0 - sol.channels[0].reflectance)).abs() < 1e-10);
}

#[test]
fn methods_without_a_depth_field_say_so() {
    let s = scene(TWO);
    let sol = km::solve(&s, &Options::new(Method::DirectionSet)).unwrap();
    assert!(sol.field.is_none());
    assert!(sol.notes.iter().any(|n| n.contains("depths ignored")), "{:?}", sol.notes);
}
