//! The four-flux model (`--method km`'s default for collimated light)
//! against the multi-flux solver: exact where the light is a beam (clear
//! plates, clear films, stacks of them over clear substrates), and the
//! substrates that turn the beam diffuse (Lambertian, black) handled.

use km::{KmOptions, Method, Options, Scene, Solver};

fn scene(text: &str) -> Scene {
    Scene::from_toml_str(text).unwrap()
}

fn light(theta: f64) -> String {
    format!("[light]\nkind = \"collimated\"\ntheta_deg = {theta}\n")
}

/// Clear plates and films (no scattering; absorbing or not), alone or
/// stacked, over clear substrates, at 0 to 75 degrees: every number of the
/// four-flux answer equals the multi-flux one to 1e-12 (both carry the beam
/// exactly; measured up to 2e-15).
#[test]
fn clear_stacks_are_exact_against_multiflux() {
    let stacks = [
        "[[layer]]\ntau = 0\nalbedo = 0\nn = 1.5\n",
        "[[layer]]\ntau = 1\nalbedo = 0\nn = 1.5\n[substrate]\nkind = \"transparent\"\nn = 1.0\n",
        "[[layer]]\ntau = 0.3\nalbedo = 0\nn = 1.7\n[substrate]\nkind = \"transparent\"\nn = 1.5\n",
        "[[layer]]\ntau = 0.2\nalbedo = 0\nn = 1.3\n[[layer]]\ntau = 0.5\nalbedo = 0\nn = 1.6\n\
         [substrate]\nkind = \"transparent\"\nn = 1.45\n",
        "[ambient]\nn = 1.33\n[[layer]]\ntau = 0.4\nalbedo = 0\nn = 1.5\n[[layer]]\ntau = 0\n\
         albedo = 0\nn = 1.2\n[substrate]\nkind = \"transparent\"\nn = 1.0\n",
    ];
    let mut worst = 0.0f64;
    for (k, stack) in stacks.iter().enumerate() {
        for theta in [0.0, 30.0, 60.0, 75.0] {
            let s = scene(&format!("{}{stack}", light(theta)));
            let four = &KmOptions::default().solve_unplanned(&s).unwrap().channels[0];
            let multi = &km::MultifluxOptions::default().solve_unplanned(&s).unwrap().channels[0];
            for (a, b, what) in [
                (four.reflectance, multi.reflectance, "R"),
                (four.reflectance_specular, multi.reflectance_specular, "R_specular"),
                (four.transmittance, multi.transmittance, "T"),
                (four.transmittance_direct, multi.transmittance_direct, "T_direct"),
                (four.absorptance, multi.absorptance, "A"),
            ] {
                worst = worst.max((a - b).abs());
                assert!((a - b).abs() < 1e-12, "stack {k} at {theta}: {what} {a} vs {b}");
            }
        }
    }
    println!("largest difference: {worst:e}");
}

/// A clear film over a Lambertian ground: the beam reaches the ground
/// exactly (Fresnel, Beer–Lambert on its slant path), and the diffuse light
/// of a non-absorbing film is exact too (the ground re-emits Lambertian
/// light whatever reaches it): `R = r + (1 - r) rho (1 - r_i) / (1 - rho r_i)`
/// with `r` the beam's Fresnel reflectance and `r_i` the internal
/// hemispherical reflectance.
/// Against the closed form to rounding; against multi-flux to its own
/// convergence at 16 streams (the hemispherical reflectance by quadrature
/// on Snell-mapped nodes: measured below 1e-7; tolerance 1e-6).
#[test]
fn clear_film_over_a_lambertian_ground() {
    let (n, rho) = (1.5, 0.6);
    for theta in [0.0f64, 40.0, 70.0] {
        let text = format!(
            "{}[[layer]]\ntau = 0\nalbedo = 0\nn = {n}\n[substrate]\nkind = \"lambertian\"\n\
             albedo = {rho}\n",
            light(theta)
        );
        let s = scene(&text);
        let r = km_core::fresnel::reflectance(theta.to_radians().cos(), 1.0, n);
        let r_i = km_core::fresnel::diffuse_reflectance(n, 1.0);
        let exact = r + (1.0 - r) * rho * (1.0 - r_i) / (1.0 - rho * r_i);
        let four = KmOptions::default().solve_unplanned(&s).unwrap().channels[0].reflectance;
        let multi =
            km::MultifluxOptions::default().solve_unplanned(&s).unwrap().channels[0].reflectance;
        assert!((four - exact).abs() < 1e-15, "{theta}: {four} vs {exact}");
        assert!((multi - exact).abs() < 1e-6, "{theta}: multiflux {multi} vs {exact}");
    }
}

/// Scattering stacks on every substrate (transparent, Lambertian, black,
/// half-space), through `km::solve`: energy balance, and the answer within
/// its own `model_error_estimate` of the converged multi-flux answer (32
/// streams; the two-flux model's error printed beside it: the four-flux
/// model is not better on every scene, only on the grid as a whole,
/// docs/two-flux.md §13).
#[test]
fn scattering_stacks_on_every_substrate() {
    let subs = [
        "[substrate]\nkind = \"transparent\"\nn = 1.5\n",
        "[substrate]\nkind = \"lambertian\"\nalbedo = 0.8\n",
        "[substrate]\nkind = \"black\"\n",
        "[[layer]]\nthickness = \"inf\"\nsigma_a = 0.05\nsigma_s = 2\ng = 0.3\nn = 1.4\n",
    ];
    for sub in subs {
        let text = format!(
            "{}[[layer]]\ntau = 1\nalbedo = 0.9\ng = 0.7\nn = 1.5\n[[layer]]\ntau = 2\n\
             albedo = 0.99\ng = 0.4\nn = 1.4\n{sub}",
            light(35.0)
        );
        let s = scene(&text);
        let four = km::solve(&s, &Options::new(Method::Km)).unwrap();
        let c = &four.channels[0];
        assert!((c.reflectance + c.transmittance + c.absorptance - 1.0).abs() < 1e-14);
        let two = KmOptions { model: km::KmModel::TwoFlux, ..Default::default() };
        let two = &two.solve_unplanned(&s).unwrap().channels[0];
        let o = km::MultifluxOptions { streams: Some(32), ..Default::default() };
        let exact = &o.solve_unplanned(&s).unwrap().channels[0];
        let err = |x: &km::ChannelResult| {
            (x.reflectance - exact.reflectance)
                .abs()
                .max((x.transmittance - exact.transmittance).abs())
        };
        let est = c.model_error_estimate.as_ref().unwrap();
        let bound = est.reflectance.unwrap().max(est.transmittance.unwrap());
        println!(
            "{sub:?}: four-flux {:.2e} (estimate {bound:.2e}), two-flux {:.2e}",
            err(c),
            err(two)
        );
        assert!(err(c) <= bound, "{sub}: error {} above its estimate {bound}", err(c));
    }
}
