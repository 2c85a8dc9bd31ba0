//! The scene file: every class of bad input is refused with an error that
//! names the key and its line; good files give the channels they describe.

use km_core::{CoreError, Light, Scene, Substrate};

/// Parse and expect a refusal naming `key` at `line`.
fn refused(text: &str, key: &str, line: Option<usize>) -> String {
    match Scene::from_toml_str(text) {
        Ok(_) => panic!("accepted a bad scene:\n{text}"),
        Err(CoreError::Scene { key: k, line: l, message }) => {
            assert!(k.contains(key), "error names `{k}`, expected `{key}` ({message})");
            assert_eq!(l, line, "line of `{k}`: {message}");
            message
        }
        Err(e) => panic!("not a scene error: {e}"),
    }
}

const LAYER: &str = "[[layer]]\nsigma_a = 0.1\nsigma_s = 0.4\nthickness = 1.0\n";

#[test]
fn negative_coefficients() {
    refused("[[layer]]\nsigma_a = -0.1\nsigma_s = 1\nthickness = 1\n", "layer[1].sigma_a", Some(2));
    refused("[[layer]]\nsigma_a = 0.1\nsigma_s = -1\nthickness = 1\n", "layer[1].sigma_s", Some(3));
    refused(
        "[[layer]]\nsigma_a = 0.1\nsigma_s = 1\nthickness = -1\n",
        "layer[1].thickness",
        Some(4),
    );
    refused("[[layer]]\ntau = -1\nalbedo = 0.5\n", "layer[1].tau", Some(2));
    refused("[[layer]]\ntau = 1\nalbedo = 1.5\n", "layer[1].albedo", Some(3));
}

#[test]
fn asymmetry_out_of_range() {
    for g in ["1.0", "-1.0", "1.5"] {
        refused(&format!("{LAYER}g = {g}\n"), "layer[1].g", Some(5));
    }
}

#[test]
fn index_below_one() {
    refused(&format!("{LAYER}n = 0.9\n"), "layer[1].n", Some(5));
    refused(&format!("[ambient]\nn = 0.5\n{LAYER}"), "ambient.n", Some(2));
    refused(
        &format!("{LAYER}[substrate]\nkind = \"transparent\"\nn = 0.2\n"),
        "substrate.n",
        Some(7),
    );
}

#[test]
fn nan_and_infinity_where_not_allowed() {
    refused("[[layer]]\nsigma_a = nan\nsigma_s = 1\nthickness = 1\n", "layer[1].sigma_a", Some(2));
    refused("[[layer]]\nsigma_a = inf\nsigma_s = 1\nthickness = 1\n", "layer[1].sigma_a", Some(2));
    refused(&format!("[light]\ntheta_deg = nan\n{LAYER}"), "light.theta_deg", Some(2));
    refused(&format!("[light]\ntheta_deg = 90\n{LAYER}"), "light.theta_deg", Some(2));
}

#[test]
fn empty_stack() {
    refused("[light]\nkind = \"collimated\"\n", "layer", None);
    refused("", "layer", None);
}

#[test]
fn lists_of_different_lengths() {
    let m = refused(
        "[[layer]]\nsigma_a = [0.1, 0.2]\nsigma_s = [1, 2, 3]\nthickness = 1\n",
        "layer[1].sigma_s",
        Some(3),
    );
    assert!(m.contains("layer[1].sigma_a"), "{m}");
    refused(
        "[spectrum]\nlabels = [\"R\", \"G\"]\n[[layer]]\nsigma_a = [0.1, 0.2, 0.3]\nsigma_s = 1\nthickness = 1\n",
        "layer[1].sigma_a",
        Some(4),
    );
}

#[test]
fn unknown_keys() {
    refused(&format!("{LAYER}sigmaa = 3\n"), "sigmaa", Some(5));
    refused(&format!("[light]\ntheta = 3\n{LAYER}"), "theta", Some(2));
    refused(&format!("{LAYER}[outputs]\n"), "outputs", Some(5));
}

#[test]
fn both_forms_at_once() {
    refused(
        "[[layer]]\nsigma_a = 0.1\nsigma_s = 1\ntau = 1\nalbedo = 0.5\n",
        "layer[1].tau",
        Some(4),
    );
    refused("[[layer]]\ntau = 1\nalbedo = 0.5\nthickness = 2\n", "layer[1].thickness", Some(4));
}

#[test]
fn half_space_only_at_the_bottom() {
    let text = "[[layer]]\ntau = \"inf\"\nalbedo = 0.5\n[[layer]]\ntau = 1\nalbedo = 0.5\n";
    refused(text, "layer[1].tau", Some(2));
}

#[test]
fn wrong_types_and_kinds() {
    refused(
        "[[layer]]\nsigma_a = \"x\"\nsigma_s = 1\nthickness = 1\n",
        "layer[1].sigma_a",
        Some(2),
    );
    refused(&format!("[light]\nkind = \"laser\"\n{LAYER}"), "light.kind", Some(2));
    refused(&format!("{LAYER}[substrate]\nkind = \"mirror\"\n"), "substrate.kind", Some(6));
    refused(&format!("{LAYER}[substrate]\nkind = \"lambertian\"\n"), "substrate.albedo", Some(6));
    refused(
        &format!("{LAYER}[output]\ndirections_deg = [[95.0, 0.0]]\n"),
        "output.directions_deg",
        Some(6),
    );
    refused("[[layer]]\npreset = \"cheese\"\n", "layer[1].preset", Some(2));
}

#[test]
fn good_scene_with_channels() {
    let s = Scene::from_toml_str(
        "[light]\nkind = \"diffuse\"\n[[layer]]\nsigma_a = [0.1, 0.2, 0.3]\nsigma_s = 1\nthickness = \"inf\"\n",
    )
    .unwrap();
    assert_eq!(s.channels().len(), 3);
    assert_eq!(s.labels(), ["R", "G", "B"]);
    assert_eq!(s.channels()[2].layers()[0].sigma_a(), 0.3);
    assert_eq!(s.channels()[0].light(), Light::Diffuse);
    assert!(s.channels()[0].layers()[0].is_half_space());
    // Defaults: substrate is a clear half-space of the ambient index; layer index = ambient.
    assert_eq!(s.channels()[0].substrate(), Substrate::Transparent { n: 1.0 });
    assert_eq!(s.channels()[0].layers()[0].n(), 1.0);
}

#[test]
fn tau_form_and_preset() {
    let s = Scene::from_toml_str("[[layer]]\ntau = 2\nalbedo = 0.75\ng = 0.5\n").unwrap();
    let l = &s.channels()[0].layers()[0];
    assert!((l.tau() - 2.0).abs() < 1e-15 && (l.albedo() - 0.75).abs() < 1e-15);
    let s = Scene::from_toml_str("[[layer]]\npreset = \"marble\"\ng = 0.5\n").unwrap();
    assert_eq!(s.channels().len(), 3);
    let l = &s.channels()[0].layers()[0];
    // sigma_s = sigma_s' / (1 - g) with the preset's reduced scattering.
    let p = km_core::presets::lookup("marble").unwrap();
    assert!((l.sigma_s() * 0.5 - p.sigma_s_prime[0]).abs() < 1e-12);
    assert_eq!(l.n(), p.eta);
}
