//! Rough faces and metals: km's Monte Carlo (an independent implementation:
//! sampled facets, eq. R17 of docs/rough.md) against the multi-flux
//! operators (integrated facets, eq. R10–R16) on the same stacks.

use km_core::Scene;

/// `(scene, BRDF directions checked)`: a rough clear coat over a scattering
/// layer on a rough conductor, and a layer rough on both faces in air.
fn stacks() -> Vec<String> {
    let dirs =
        "[output]\ndirections_deg = [[0.0, 0.0], [30.0, 180.0], [50.0, 0.0], [60.0, 180.0]]\n";
    vec![
        format!(
            "[light]\ntheta_deg = 30.0\n[[layer]]\ntau = 1.0\nalbedo = 0.9\ng = 0.5\nn = 1.5\n\
             roughness = 0.3\n[substrate]\nkind = \"conductor\"\nn = 0.35\nk = 2.7\nroughness = 0.2\n{dirs}"
        ),
        format!(
            "[light]\ntheta_deg = 45.0\n[[layer]]\ntau = 0.5\nalbedo = 0.95\ng = 0.7\nn = 1.33\n\
             roughness = 0.2\ndistribution = \"beckmann\"\n[substrate]\nkind = \"transparent\"\n\
             n = 1.0\nroughness = 0.4\n{dirs}"
        ),
    ]
}

/// Totals within 3.5 standard errors of the Monte Carlo (plus 2e-3 for the
/// multi-flux discretisation at 16 streams, which the stream study of
/// docs/rough.md §7 bounds), BRDF/BTDF within 3.5 standard errors plus 3 %
/// (the Monte Carlo's cone bins of 2 degrees average the lobes).
///
/// Known to fail (docs/rough.md §7): the multi-flux BRDF at a probe in the
/// quadrature cell of the beam's mirror direction carries a spurious term
/// of the delta corrections (33.4 against 0.187 at 30/180 degrees), and other
/// directions differ by up to 14 %. Totals agree to 1.5e-3.
#[test]
#[ignore = "fails until the probe/beam cell fix (docs/rough.md §7); a few seconds of Monte Carlo: cargo test -p km-bench --test rough -- --ignored"]
fn monte_carlo_agrees_with_multiflux_on_rough_stacks() {
    for text in stacks() {
        let scene = Scene::from_toml_str(&text).unwrap();
        let mf_opts = km_multiflux::MultifluxOptions { streams: Some(16), ..Default::default() };
        let mf = km_multiflux::solve(&scene, &mf_opts).unwrap().channels[0].clone();
        let mc_opts =
            km_montecarlo::options::McOptions { samples: 2_000_000, seed: 3, ..Default::default() };
        let mc = km_montecarlo::run::solve(&scene, &mc_opts).unwrap().channels[0].clone();
        let se = mc.stderr.clone().unwrap();
        eprintln!("mf {mf:?}\nmc {mc:?}");
        let close = |a: f64, b: f64, s: f64, rel: f64| (a - b).abs() <= 3.5 * s + rel;
        assert!(close(mf.reflectance, mc.reflectance, se.reflectance.unwrap(), 2e-3), "R");
        assert!(close(mf.transmittance, mc.transmittance, se.transmittance.unwrap(), 2e-3), "T");
        assert_eq!(mf.reflectance_specular, 0.0);
        for k in 0..mf.brdf.len() {
            let s = se.brdf.as_ref().unwrap()[k];
            assert!(close(mf.brdf[k], mc.brdf[k], s, 0.03 * mc.brdf[k]), "brdf[{k}]");
            let s = se.btdf.as_ref().unwrap()[k];
            assert!(close(mf.btdf[k], mc.btdf[k], s, 0.03 * mc.btdf[k]), "btdf[{k}]");
        }
    }
}
