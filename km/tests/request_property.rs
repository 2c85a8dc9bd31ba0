//! One budget for a request of many points (docs/limits.md §1, eq. L4),
//! over random sweeps: every sweep either completes with work within its
//! budget or is refused before any point is solved, naming the numbers —
//! never a panic, never a point's own failure, never unbounded work.
//!
//! The grid sizes (1 to 3 axes of 1 to 3000 values, so up to 2.7 10^10
//! points), the method (multi-flux at 2 to 16 streams, Monte Carlo at 10
//! to 10^5 photons) and the budget (10^6 to 10^8 work units or photon
//! steps) are random; budgets are kept small so that a completed sweep
//! takes at most a fraction of a second, and a hang would show as the 60 s guard.

use std::time::Instant;

use km::request_budget::{SWEEP_POINT_OVERHEAD, point_work};
use km::{KmError, McOptions, MultifluxOptions, Options, Scene, SweepAxis};
use proptest::prelude::*;

const SCENE: &str = "[[layer]]\ntau = 1.0\nalbedo = 0.9\ng = 0.5\nn = 1.3\n";

/// The keys an axis may sweep, with their ranges.
const KEYS: [(&str, f64, f64); 3] =
    [("layer[1].tau", 0.1, 5.0), ("layer[1].albedo", 0.1, 0.99), ("layer[1].g", -0.5, 0.9)];

/// The options of one case: multi-flux (`streams`) or Monte Carlo (`photons`).
fn options(mc: bool, setting: u64, budget: f64) -> Options {
    if mc {
        Options::from(McOptions {
            samples: setting,
            seed: 7,
            max_events: Some(budget as u64),
            ..Default::default()
        })
    } else {
        Options::from(MultifluxOptions {
            streams: Some(2 * setting as usize),
            max_work: Some(budget),
            ..Default::default()
        })
    }
}

fn case() -> impl Strategy<Value = (Vec<(usize, usize)>, bool, u64, f64)> {
    let axis = (0..KEYS.len(), 1usize..=3000);
    let axes = proptest::collection::vec(axis, 1..=3);
    // Grid sizes 3000^(u^2) for u uniform: small grids (that run) more
    // often than huge ones (that must be refused).
    let axes = axes.prop_map(|a| {
        a.into_iter()
            .map(|(k, n)| (k, 3000f64.powf((n as f64 / 3000.0).powi(2)).round() as usize))
            .collect()
    });
    (axes, any::<bool>(), 1u64..=8, 6.0f64..8.0).prop_map(|(axes, mc, s, b)| {
        let setting = if mc { 10u64.pow(1 + (s as u32 % 5)) } else { s };
        (axes, mc, setting, 10f64.powf(b))
    })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 16, ..ProptestConfig::default() })]

    #[test]
    fn a_sweep_completes_within_its_budget_or_is_refused_up_front(
        (axes, mc, setting, budget) in case()
    ) {
        let axes: Vec<SweepAxis> = axes
            .iter()
            .map(|&(k, n)| {
                let (key, lo, hi) = KEYS[k];
                SweepAxis::parse(&format!("{key}={lo}:{hi}:{n}")).unwrap()
            })
            .collect();
        let total: f64 = axes.iter().map(|a| a.n as f64).product();
        let opts = options(mc, setting, budget);
        // The sweep's estimate is that of its first point, for all of them.
        let first: Vec<km::SetEdit> = axes
            .iter()
            .map(|a| km::SetEdit { key: a.key.clone(), value: format!("{:?}", a.values()[0]) })
            .collect();
        let scene = Scene::from_toml_str_edited(SCENE, &first).unwrap();
        let (per_point, limit, _) = point_work(&scene, &opts).unwrap();
        let overhead = if mc { 0.0 } else { SWEEP_POINT_OVERHEAD };
        let t = Instant::now();
        let out = km::sweep(SCENE, &[], &axes, &opts);
        let secs = t.elapsed().as_secs_f64();
        prop_assert!(secs < 60.0, "{total} points took {secs} s");
        match out {
            Ok(points) => {
                prop_assert_eq!(points.len() as f64, total);
                // What ran was within the budget by the same estimate.
                if total > 1.0 {
                    prop_assert!(total * (per_point + overhead) <= limit,
                        "{total} points of {per_point} ran over the budget {limit}");
                }
            }
            Err(KmError::RequestTooLarge { points, total: work, budget: b, .. }) => {
                prop_assert_eq!(points as f64, total);
                prop_assert!(work > b, "refused at {work} within {b}");
                // Refused before the work: no point was solved (a pilot of
                // Monte Carlo's step count is all that ran).
                prop_assert!(secs < 10.0, "the refusal took {secs} s");
            }
            Err(KmError::Scene(e)) => {
                // The grid cap (10^5 points), refused before anything.
                prop_assert!(total > km::SWEEP_MAX_POINTS as f64, "{e}");
                prop_assert!(e.to_string().contains("more than"), "{e}");
            }
            Err(e) if total == 1.0 => {
                // One point: the solve's own budget, refused by the method.
                prop_assert!(per_point > limit, "one point within budget failed: {e}");
            }
            Err(e) => prop_assert!(false, "{total} points: unexpected error {e}"),
        }
    }
}
