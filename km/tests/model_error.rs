//! Every two-flux and dipole answer of `km::solve` carries
//! `model_error_estimate` (docs/two-flux.md eq. K25), in the JSON and the
//! table, with a note when it exceeds 1 % of a total; its bound statistics
//! on the grids are in km-bench's tests/km_models.rs.

use km::{KmOptions, Method, Options, Scene};

fn root() -> std::path::PathBuf {
    std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn example(name: &str) -> Scene {
    Scene::from_path(&root().join("examples").join(name)).unwrap()
}

fn has_note(sol: &km::Solution) -> bool {
    sol.notes.iter().any(|n| n.starts_with("model error: "))
}

/// Paint over primer (three channels): the estimate per channel and key,
/// each bounding the error against converged multi-flux (32 streams), the
/// note naming the worst channel (G: the four-flux answer 0.0757, converged
/// 0.0671), and the table's rows.
#[test]
fn paint_over_primer_carries_its_estimate_and_note() {
    let scene = example("paint-over-primer.toml");
    let sol = km::solve(&scene, &Options::new(Method::Km)).unwrap();
    let reference = km::solve(
        &scene,
        &Options::from(km::MultifluxOptions { streams: Some(32), ..Default::default() }),
    )
    .unwrap();
    for (c, r) in sol.channels.iter().zip(&reference.channels) {
        let e = c.model_error_estimate.as_ref().unwrap();
        let truth = (c.reflectance - r.reflectance).abs();
        assert!(e.reflectance.unwrap() >= truth, "{} < {truth}", e.reflectance.unwrap());
        assert_eq!(e.brdf.as_ref().unwrap().len(), 3);
    }
    let j = sol.to_json();
    assert_eq!(j["model_error_estimate"]["reflectance"].as_array().unwrap().len(), 3);
    assert_eq!(j["km_model"], "four-flux");
    assert_eq!(j["km_mapping"], "gate1974");
    let note = sol.notes.iter().find(|n| n.starts_with("model error: ")).unwrap();
    assert!(note.contains("reflectance [G]"), "{note}");
    let table = km::text::table(&sol, Some(&scene));
    assert!(table.contains("model error estimate"), "{table}");
}

/// A clear glass plate (n 1.5, normal incidence): the four-flux answer is exact and its estimate
/// is rounding (no note); the seed's two-flux answer (0.399 against 0.0769)
/// is flagged, the estimate covering its error.
#[test]
fn the_glass_plate_exact_and_the_two_flux_answer_flagged() {
    let scene = Scene::from_toml_str("[[layer]]\ntau = 0\nalbedo = 0\nn = 1.5\n").unwrap();
    let four = km::solve(&scene, &Options::new(Method::Km)).unwrap();
    let e = four.channels[0].model_error_estimate.as_ref().unwrap();
    assert!(e.reflectance.unwrap() < 1e-14 && e.transmittance.unwrap() < 1e-14);
    assert!(!has_note(&four));
    let two = km::solve(&scene, &Options::from(KmOptions::SEED)).unwrap();
    let c = &two.channels[0];
    let e = c.model_error_estimate.as_ref().unwrap();
    // The multi-flux checks are exact here, so the estimate is the error
    // itself (to the checks' rounding, 1e-12).
    let truth = (c.reflectance - 0.08 / 1.04).abs();
    assert!((e.reflectance.unwrap() - truth).abs() < 1e-12 && truth > 0.3);
    assert!(has_note(&two));
}

/// The dipole carries it too; the other methods do not (their errors are
/// `stderr` and `error_estimate`); diffuse light is covered.
#[test]
fn the_dipole_carries_it_and_the_other_methods_do_not() {
    let marble = example("marble-half-space.toml");
    let d = km::solve(&marble, &Options::new(Method::Dipole)).unwrap();
    assert!(d.channels.iter().all(|c| c.model_error_estimate.is_some()));
    assert!(d.to_json().get("model_error_estimate").is_some());
    let m = km::solve(&marble, &Options::new(Method::Multiflux)).unwrap();
    assert!(m.to_json().get("model_error_estimate").is_none());
    let diffuse = Scene::from_toml_str(
        "[light]\nkind = \"diffuse\"\n[[layer]]\ntau = 2\nalbedo = 0.95\ng = 0.8\n",
    )
    .unwrap();
    let k = km::solve(&diffuse, &Options::new(Method::Km)).unwrap();
    assert!(k.channels[0].model_error_estimate.as_ref().unwrap().reflectance.unwrap() > 0.0);
}

/// The check's work is bounded: a scene of more layers over its channels
/// than `MAX_CHECK_LAYERS` is answered without the estimate, and a note
/// says why.
#[test]
fn the_check_is_bounded() {
    let n = km::model_error::MAX_CHECK_LAYERS + 1;
    let albedos: Vec<String> =
        (0..n).map(|i| format!("{}", 0.5 + 0.4 * i as f64 / n as f64)).collect();
    let text = format!("[[layer]]\ntau = 1.0\nalbedo = [{}]\n", albedos.join(", "));
    let scene = Scene::from_toml_str(&text).unwrap();
    let sol = km::solve(&scene, &Options::new(Method::Km)).unwrap();
    assert!(sol.channels.iter().all(|c| c.model_error_estimate.is_none()));
    assert!(sol.notes.iter().any(|n| n.starts_with("no model_error_estimate")), "{:?}", sol.notes);
}
