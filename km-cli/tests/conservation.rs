//! Exact conservation in every method: a lossless stack (albedo 1, nothing
//! transmitted: a conservative half-space below an index change, the case
//! where the multi-flux adding once gave R = 1 + 1e-12 .. 1e-10) absorbs
//! nothing, and no method reports a total outside [0, 1] or A < 0 there.
//!
//! Tolerances: none (A >= 0 and R, T in [0, 1] exactly; the multi-flux also
//! R = 1 and A = 0 exactly, `docs/multiflux.md` eq. 18a). Monte Carlo counts
//! every photon as reflected, transmitted or absorbed, so with albedo 1 and
//! no exit below it must report R = 1 exactly: no absorption event exists.

use km_core::Scene;
use km_core::two_flux::KmOptions;
use km_dipole::DipoleOptions;
use km_montecarlo::McOptions;
use km_multiflux::MultifluxOptions;

fn scenes() -> Vec<String> {
    let mut out = Vec::new();
    for &(g, n, theta) in
        &[(0.99, 1.5, 0.0), (0.9, 1.33, 45.0), (0.0, 2.5, 0.0), (0.99, 1.5, 75.0), (0.5, 1.0, 0.0)]
    {
        out.push(format!(
            "[light]\ntheta_deg = {theta}\n[[layer]]\ntau = \"inf\"\nalbedo = 1.0\ng = {g}\nn = {n}\n"
        ));
    }
    out
}

fn check(method: &str, t: &str, c: &km_core::ChannelResult) {
    let (r, tr, a) = (c.reflectance, c.transmittance, c.absorptance);
    assert!(
        (0.0..=1.0).contains(&r) && (0.0..=1.0).contains(&tr) && (0.0..=1.0).contains(&a),
        "{method}: R {r} T {tr} A {a}\n{t}"
    );
}

#[test]
fn lossless_half_spaces_absorb_nothing_in_any_method() {
    for t in scenes() {
        let s = Scene::from_toml_str(&t).unwrap();
        let mf = km_multiflux::solve(&s, &MultifluxOptions::default()).unwrap();
        check("multiflux", &t, &mf.channels[0]);
        assert_eq!(mf.channels[0].reflectance, 1.0, "multiflux\n{t}");
        assert_eq!(mf.channels[0].absorptance, 0.0, "multiflux\n{t}");
        let km = km_core::two_flux::solve(&s, &KmOptions::default()).unwrap();
        check("two-flux", &t, &km.channels[0]);
        // The dipole refuses nothing here: a conservative half-space is its home case.
        match km_dipole::solve(&s, &DipoleOptions::default()) {
            Ok(d) => check("dipole", &t, &d.channels[0]),
            Err(e) => panic!("dipole refused a half-space: {e}\n{t}"),
        }
        // Few photons: in a conservative half-space each walks thousands of steps.
        let o = McOptions { samples: 300, seed: 11, ..Default::default() };
        let mc = km_montecarlo::solve(&s, &o).unwrap();
        check("montecarlo", &t, &mc.channels[0]);
        assert_eq!(mc.channels[0].absorptance, 0.0, "montecarlo\n{t}");
    }
}
