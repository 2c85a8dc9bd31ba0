//! The planner names each simplification it takes, and only when it applies.

use km_core::Scene;
use km_core::plan::{Plan, Request, plan_scene};

fn plan(text: &str, directions: bool) -> Plan {
    let s = Scene::from_toml_str(text).unwrap();
    Plan::new(&s.channels()[0], Request { directions, ..Request::default() }, false)
}

#[test]
fn matched_indices_skip_the_interface() {
    let p = plan("[[layer]]\ntau = 1\nalbedo = 0.5\n", false);
    assert!(p.skips("interface"));
    assert!(!p.effects.iter().any(|e| e == "interface"));
    let p = plan("[[layer]]\ntau = 1\nalbedo = 0.5\nn = 1.5\n", false);
    assert!(p.effects.iter().any(|e| e == "interface"));
    assert!(p.effects.iter().any(|e| e == "total-internal-reflection"));
    assert!(!p.skips("interface"), "{:?}", p.reasons);
    assert!(p.layers[0].interface_above);
}

#[test]
fn absorbers_skip_scattering() {
    let p = plan(
        "[[layer]]\nsigma_a = 1\nsigma_s = 0\nthickness = 1\n[[layer]]\ntau = 1\nalbedo = 0.9\n",
        false,
    );
    assert!(p.skips("scattering"));
    assert!(!p.layers[0].scatters && p.layers[1].scatters);
    let p = plan("[[layer]]\nsigma_a = 1\nsigma_s = 0.1\nthickness = 1\n", false);
    assert!(!p.skips("scattering"));
}

#[test]
fn azimuth_only_when_it_carries_nothing() {
    let aniso = "[light]\ntheta_deg = 30\n[[layer]]\ntau = 1\nalbedo = 0.9\ng = 0.5\n[output]\ndirections_deg = [[10.0, 0.0]]\n";
    assert!(!plan(aniso, true).skips("azimuth"));
    assert!(plan(aniso, false).skips("azimuth"), "totals only");
    let iso = "[light]\ntheta_deg = 30\n[[layer]]\ntau = 1\nalbedo = 0.9\n";
    assert!(plan(iso, true).skips("azimuth"), "isotropic");
    let diffuse = "[light]\nkind = \"diffuse\"\n[[layer]]\ntau = 1\nalbedo = 0.9\ng = 0.5\n";
    assert!(plan(diffuse, true).skips("azimuth"), "diffuse light");
}

#[test]
fn thick_absorbing_layers_become_half_spaces_conservative_never() {
    let thick = "[[layer]]\ntau = 1e4\nalbedo = 0.9\n[[layer]]\ntau = 1\nalbedo = 0.5\n[substrate]\nkind = \"lambertian\"\nalbedo = 1\n";
    let p = plan(thick, false);
    assert!(p.skips("transmission") && p.skips("substrate"));
    assert_eq!(p.active_layers, 1);
    assert!(p.layers[0].cutoff_bound.unwrap() < 1e-14);
    let cons = "[[layer]]\ntau = 1e6\nalbedo = 1.0\n[substrate]\nkind = \"black\"\n";
    let p = plan(cons, false);
    assert!(!p.skips("transmission"), "a conservative layer always transmits something");
    let thin = "[[layer]]\ntau = 10\nalbedo = 0.9\n";
    assert!(!plan(thin, false).skips("transmission"));
}

#[test]
fn all_effects_skips_nothing() {
    let s = Scene::from_toml_str("[[layer]]\nsigma_a = 1\nsigma_s = 0\nthickness = 1e9\n").unwrap();
    let p = Plan::new(&s.channels()[0], Request::default(), true);
    assert!(p.skipped.is_empty(), "{:?}", p.skipped);
    assert!(p.angular_tallies && !p.azimuth_independent);
}

#[test]
fn duplicate_channels_are_named() {
    let s = Scene::from_toml_str("[[layer]]\ntau = [1, 2, 1]\nalbedo = 0.5\n").unwrap();
    let p = plan_scene(&s, Request::default(), false);
    assert!(p.skips("duplicate-channels"));
    let s = Scene::from_toml_str("[[layer]]\ntau = [1, 2, 3]\nalbedo = 0.5\n").unwrap();
    assert!(
        !plan_scene(&s, Request::default(), false)
            .skips(km_core::plan::Simplification::DuplicateChannels)
    );
}

#[test]
fn angular_tallies_only_when_directions_are_asked() {
    assert!(plan("[[layer]]\ntau = 1\nalbedo = 0.5\n", false).skips("angular-tallies"));
    assert!(!plan("[[layer]]\ntau = 1\nalbedo = 0.5\n", true).skips("angular-tallies"));
}

#[test]
fn each_method_sees_only_its_simplifications() {
    let s = Scene::from_toml_str("[[layer]]\ntau = 1\nalbedo = 0.5\n").unwrap();
    let p = plan_scene(&s, Request::default(), false);
    assert!(p.skips("azimuth"));
    assert!(p.skips("angular-tallies"));
    let mf = p.clone().for_method("multiflux");
    assert!(mf.skips("azimuth") && !mf.skips("angular-tallies"));
    let mc = p.for_method("mc");
    assert!(!mc.skips("azimuth") && mc.skips("angular-tallies"));
    use km_core::plan::Simplification::{AngularTallies, Azimuth};
    assert!(mc.reasons.contains_key(&AngularTallies) && !mc.reasons.contains_key(&Azimuth));
}
