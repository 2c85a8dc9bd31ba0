//! The multi-flux stream search planned before its expensive solves
//! (docs/planner.md, eq. E4, E5): an unreachable target refused at once,
//! a reachable one still solved and met.

use std::time::Instant;

use km::{KmError, Scene};

/// A strongly forward-peaked layer (g = 0.99, n = 1.33) over glass (n =
/// 1.5), lit at 80 degrees, with the BRDF at four directions: the forward
/// peak needs hundreds of streams. Before the forecast, `--tolerance 1e-3`
/// ran the search to 64 streams (checked at 128) for 18.6 s and then stopped
/// at the work budget.
fn peaked(g: f64) -> Scene {
    Scene::from_toml_str(&format!(
        "[light]\nkind = \"collimated\"\ntheta_deg = 80.0\n\n\
         [[layer]]\ntau = 1.0\nalbedo = 0.9\ng = {g}\nn = 1.33\n\n\
         [substrate]\nkind = \"transparent\"\nn = 1.5\n\n\
         [output]\ndirections_deg = [[0.0, 0.0], [30.0, 180.0], [60.0, 180.0], [80.0, 180.0]]\n"
    ))
    .unwrap()
}

#[test]
fn an_unreachable_target_is_refused_before_the_long_solves() {
    let scene = peaked(0.99);
    let start = Instant::now();
    let r = km::accuracy::multiflux(&scene, &Default::default(), 1e-3);
    let wall = start.elapsed().as_secs_f64();
    let e = r.map(|s| s.accuracy).expect_err("1e-3 is out of reach within the default budget");
    let text = e.to_string();
    // The cheap solves at 4, 8 and 16 streams take about 0.03 s; the bound
    // is generous for a loaded machine and far below the 18.6 s the search
    // took before it was refused.
    assert!(wall < 0.5, "refused after {wall} s: {text}");
    let KmError::TargetOverBudget { target, limited_by, needed, reachable, best, .. } = e else {
        panic!("expected TargetOverBudget, got {text}");
    };
    assert_eq!(target, 1e-3);
    // The forward direction (80 degrees, azimuth 180) is the slow one.
    assert_eq!(limited_by, "brdf[3]", "{text}");
    assert!(needed.contains("streams") && reachable == "64 streams", "{text}");
    assert!(best > 1e-3 && best < 1.0, "{text}");
    for words in ["accuracy target 1e-3", "would need", "streams", "best accuracy reachable"] {
        assert!(text.contains(words), "{words:?} missing from {text}");
    }
}

#[test]
fn a_reachable_target_is_still_solved_and_met() {
    // g = 0.9: the forecast lets the search run; the answer meets the target
    // against an independent solve at 64 streams (E3's allowance).
    let scene = peaked(0.9);
    let tol = 1e-3;
    let sol = km::accuracy::multiflux(&scene, &Default::default(), tol).unwrap();
    let acc = sol.accuracy.as_ref().unwrap();
    assert!(acc.reached);
    let streams = acc.work.iter().find(|(k, _)| k == "streams").unwrap().1;
    assert!(streams < 64, "answered at {streams} streams");
    let opts = km::MultifluxOptions { streams: Some(64), ..Default::default() };
    let reference = km_multiflux_solve(&scene, &opts);
    let (a, b) = (&sol.channels[0], &reference.channels[0]);
    let pairs = [(a.reflectance, b.reflectance), (a.transmittance, b.transmittance)];
    let angular = a.brdf.iter().zip(&b.brdf).chain(a.btdf.iter().zip(&b.btdf));
    for (x, y) in pairs.into_iter().chain(angular.map(|(x, y)| (*x, *y))) {
        assert!((x - y).abs() <= tol * y.abs().max(1.0), "{x} vs {y} at {streams} streams");
    }
}

#[test]
fn a_forecast_that_allows_the_target_lets_the_search_run() {
    // g = 0.95 at 1e-3: the estimates fall slowly at 4 and 8 streams (ratio
    // 0.87) but the phase function's moments (0.95^{2N}) say the peak is
    // resolved within the budget; the search meets it at 32 streams.
    let sol = km::accuracy::multiflux(&peaked(0.95), &Default::default(), 1e-3).unwrap();
    let acc = sol.accuracy.unwrap();
    assert!(acc.reached && acc.estimate <= 1e-3, "{acc:?}");
}

#[test]
fn a_plateau_before_the_peak_is_resolved_is_not_taken_for_convergence() {
    // g = 0.99 at a target of 0.1: the mirror-direction BRDF is 1.682,
    // 1.675 and 1.635 /sr at 2, 4 and 8 streams and 0.85 at 128, so eq. E1
    // alone accepted 4 streams with an estimate of 0.079 against a true error
    // of about 0.8. Eq. E1a (the difference grew, 0.007 -> 0.040) must keep
    // the search going; within the default budget it is then refused.
    let scene = peaked(0.99);
    let tol = 0.1;
    match km::accuracy::multiflux(&scene, &Default::default(), tol) {
        Ok(sol) => {
            // Whatever it answers must be within its own estimate of an
            // independent solve at 96 streams (itself still 0.04 above the
            // 128-stream value, so this is the lenient side).
            let opts = km::MultifluxOptions { streams: Some(96), ..Default::default() };
            let reference = km_multiflux_solve(&scene, &opts);
            let (a, b) = (&sol.channels[0], &reference.channels[0]);
            let est = a.error_estimate.as_ref().unwrap().brdf.clone().unwrap();
            assert!((a.brdf[3] - b.brdf[3]).abs() <= est[3], "{} vs {}", a.brdf[3], b.brdf[3]);
        }
        Err(e) => {
            let text = e.to_string();
            assert!(text.contains("brdf[3]") && text.contains("1e-1"), "{text}");
        }
    }
    // The rule itself: E1 alone is met at 4 streams (the premise of this test).
    let at = |n: usize| {
        let o = km::MultifluxOptions { streams: Some(n), ..Default::default() };
        km_multiflux_solve(&scene, &o).channels[0].brdf[3]
    };
    let (x2, x4, x8) = (at(2), at(4), at(8));
    assert!(2.0 * (x4 - x8).abs() <= tol * x4.abs().max(1.0));
    assert!((x4 - x8).abs() > (x2 - x4).abs());
}

fn km_multiflux_solve(scene: &Scene, opts: &km::MultifluxOptions) -> km::Solution {
    km::solve(scene, &km::Options::from(opts.clone())).unwrap()
}

/// The seed paper's three-layer scene (examples/seed-three-layers.toml).
const SEED: &str = include_str!("../../examples/seed-three-layers.toml");

#[test]
fn monte_carlo_refuses_a_target_over_its_step_budget_before_tracing() {
    // 1e-3 needs about 1e8 photons (7e8 photon steps) on this scene; a
    // budget of 2e8 steps cannot afford them.
    let scene = Scene::from_toml_str(SEED).unwrap();
    let opts = km::McOptions { max_events: Some(200_000_000), ..Default::default() };
    let start = Instant::now();
    let e = km::accuracy::monte_carlo(&scene, &opts, 1e-3).map(|s| s.accuracy).unwrap_err();
    let wall = start.elapsed().as_secs_f64();
    let text = e.to_string();
    // Two pilots of 10^4 photons: about 0.02 s; the run it refuses took 44.5 s.
    assert!(wall < 0.5, "refused after {wall} s: {text}");
    let KmError::TargetOverBudget { needed, reachable, best, .. } = e else {
        panic!("expected TargetOverBudget, got {text}");
    };
    assert!(needed.contains("photons") && reachable.contains("photons"), "{text}");
    // The best target within the budget: tol sqrt(n / n_b) > tol.
    assert!(best > 1e-3 && best < 1e-2, "{text}");
}

#[test]
fn monte_carlo_names_the_photon_count_it_chose() {
    let scene = Scene::from_toml_str(SEED).unwrap();
    let sol = km::accuracy::monte_carlo(&scene, &Default::default(), 1e-2).unwrap();
    let acc = sol.accuracy.as_ref().unwrap();
    let n = acc.work.iter().find(|(k, _)| k == "samples").unwrap().1;
    let note = format!("{n} photons chosen for tolerance 1e-2");
    assert!(sol.notes.iter().any(|x| x.starts_with(&note)), "{:?}", sol.notes);
}
