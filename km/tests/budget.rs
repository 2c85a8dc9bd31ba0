//! An accuracy target's stream search spends one work budget in all
//! (docs/limits.md, eq. W1), not one budget per solve.

use km::{KmError, MultifluxOptions, Scene};
use km_multiflux::MultifluxError;
use km_multiflux::budget::estimate;

#[test]
fn the_stream_search_is_refused_when_its_solves_together_exceed_the_budget() {
    let scene = Scene::from_toml_str("[[layer]]\ntau = 1.0\nalbedo = 0.9\ng = 0.5\n").unwrap();
    let units = |n: usize| {
        estimate(&scene, &MultifluxOptions { streams: Some(n), ..Default::default() }).units
    };
    // A loose target is met by the first solves: 4 streams checked at 8,
    // with 2 for the contraction test (eq. E1a; premise, below); a budget
    // one unit short of the three together, although each alone fits.
    let budget = units(2) + units(4) + units(8) - 1.0;
    assert!(units(8) < budget && units(4) < budget && units(2) < budget);
    let tight = MultifluxOptions { max_work: Some(budget), ..Default::default() };
    match km::accuracy::multiflux(&scene, &tight, 1e-2) {
        Err(KmError::Multiflux(MultifluxError::TooExpensive { .. })) => {}
        other => panic!("expected a budget refusal, got {other:?}"),
    }
    // With room for the whole search the same target is met.
    let roomy = MultifluxOptions { max_work: Some(1e3 * units(64)), ..Default::default() };
    let sol = km::accuracy::multiflux(&scene, &roomy, 1e-2).unwrap();
    let report = sol.accuracy.unwrap();
    assert!(report.reached);
    assert!(report.work.contains(&("streams".to_string(), 4)), "{:?}", report.work);
    // A budget for the three solves (with one unit to spare) is enough.
    let just = MultifluxOptions {
        max_work: Some(units(2) + units(4) + units(8) + 1.0),
        ..Default::default()
    };
    assert!(km::accuracy::multiflux(&scene, &just, 1e-2).is_ok());
}
