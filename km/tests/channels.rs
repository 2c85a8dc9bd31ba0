//! Spectral channels solved on all cores (`km::solve`, multi-flux) give the
//! same bits as the serial solver, channel by channel.

use km::Options;

/// A two-layer Fresnel stack with `k` distinct channels (albedo, g and tau
/// vary with the channel) and three exit directions.
fn spectral_scene(k: usize) -> km::Scene {
    let list = |f: &dyn Fn(f64) -> f64| {
        let v: Vec<String> = (0..k).map(|i| format!("{:.6}", f(i as f64 / k as f64))).collect();
        format!("[{}]", v.join(", "))
    };
    let wl = list(&|x| 400.0 + 300.0 * x);
    let albedo = list(&|x| 0.5 + 0.49 * x);
    let g = list(&|x| 0.1 + 0.7 * x);
    let tau = list(&|x| 0.5 + 2.0 * x);
    let toml = format!(
        "[spectrum]\nwavelengths_nm = {wl}\n[light]\ntheta_deg = 30.0\n\
         [[layer]]\ntau = {tau}\nalbedo = {albedo}\ng = {g}\nn = 1.4\n\
         [[layer]]\ntau = 1.0\nalbedo = 0.8\ng = 0.5\nn = 1.5\n\
         [output]\ndirections_deg = [[0.0, 0.0], [30.0, 0.0], [60.0, 180.0]]\n"
    );
    km::Scene::from_toml_str(&toml).unwrap()
}

#[test]
fn parallel_channels_are_bit_identical_to_serial() {
    let scene = spectral_scene(37);
    let opts = km::MultifluxOptions { streams: Some(6), ..Default::default() };
    let serial = km_multiflux::solve(&scene, &opts).unwrap();
    let par = km::solve(&scene, &Options::from(opts.clone())).unwrap();
    assert_eq!(par.channels.len(), 37);
    // Distinct channels: the test would not see a channel mix-up otherwise.
    assert!(par.channels.windows(2).all(|w| w[0].reflectance != w[1].reflectance));
    for (i, (p, s)) in par.channels.iter().zip(&serial.channels).enumerate() {
        // Exact equality: each channel is the same computation, in any thread.
        assert_eq!(p.reflectance.to_bits(), s.reflectance.to_bits(), "channel {i}");
        assert_eq!(p.transmittance.to_bits(), s.transmittance.to_bits(), "channel {i}");
        assert_eq!(p.absorptance.to_bits(), s.absorptance.to_bits(), "channel {i}");
        assert_eq!(p.brdf, s.brdf, "channel {i}");
        assert_eq!(p.btdf, s.btdf, "channel {i}");
    }
    assert_eq!(par.to_json().get("streams"), serial.to_json().get("streams"));
    assert_eq!(par.to_json().get("fourier_orders"), serial.to_json().get("fourier_orders"));
    assert_eq!(par.notes, serial.notes);
}

#[test]
fn an_over_budget_spectral_scene_is_refused_as_serially() {
    // A work budget below the estimate: refused before any channel runs.
    let scene = spectral_scene(8);
    let opts = km::MultifluxOptions { streams: Some(6), max_work: Some(1.0), ..Default::default() };
    assert!(km_multiflux::solve(&scene, &opts).is_err());
    assert!(km::solve(&scene, &Options::from(opts)).is_err());
}
