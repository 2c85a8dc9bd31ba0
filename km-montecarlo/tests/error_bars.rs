//! The error bars mean what they say: over independent runs (different
//! seeds) the scatter of an estimate matches the standard error each run
//! reports from its own batch statistics (eq. T1 of tally.rs).
//!
//! With `M` runs, `X = sum_i (x_i - mean)^2 / mean_i(se_i^2)` follows a
//! chi-square law with `M - 1` degrees of freedom when the reported `se` is
//! right (the `se_i` are themselves estimates from ~100 batches, a 10 %
//! effect on `se^2` averaged over the runs, small against the band). The
//! test accepts the central 99.9 % of that law: too-small error bars (or
//! correlated streams) push `X` above it, too-large ones below.

use km_core::Scene;
use km_montecarlo::{Estimator, McOptions, solve};
use statrs::distribution::{ChiSquared, ContinuousCDF};

#[test]
fn reported_standard_errors_match_the_scatter_between_seeds() {
    let s = Scene::from_toml_str(
        "[light]\ntheta_deg = 30.0\n[[layer]]\ntau = 1.0\nalbedo = 0.9\ng = 0.5\nn = 1.3\n\
         [output]\ndirections_deg = [[20.0, 180.0]]\n",
    )
    .unwrap();
    let m = 40;
    let chi = ChiSquared::new((m - 1) as f64).unwrap();
    let (lo, hi) = (chi.inverse_cdf(0.0005), chi.inverse_cdf(0.9995));
    for est in [Estimator::SurvivalBiasing, Estimator::Analog] {
        let runs: Vec<_> = (0..m)
            .map(|i| {
                let o = McOptions {
                    samples: 10_000,
                    seed: 1000 + i as u64,
                    estimator: est,
                    ..Default::default()
                };
                solve(&s, &o).unwrap()
            })
            .collect();
        let pick = |f: &dyn Fn(&km_core::Solution) -> (f64, f64), name: &str| {
            let v: Vec<(f64, f64)> = runs.iter().map(f).collect();
            let mean = v.iter().map(|p| p.0).sum::<f64>() / m as f64;
            let var = v.iter().map(|p| p.1 * p.1).sum::<f64>() / m as f64;
            let x = v.iter().map(|p| (p.0 - mean).powi(2)).sum::<f64>() / var;
            eprintln!("{est:?} {name}: X = {x:.1} (accept [{lo:.1}, {hi:.1}])");
            assert!(x > lo && x < hi, "{est:?} {name}: X = {x}");
        };
        let se =
            |s: &km_core::Solution, k: &str| s.channels[0].stderr.as_ref().unwrap().get(k).unwrap();
        let se_brdf = |s: &km_core::Solution| {
            s.channels[0].stderr.as_ref().unwrap().brdf.as_ref().unwrap()[0]
        };
        pick(&|s| (s.channels[0].reflectance, se(s, "reflectance")), "R");
        pick(&|s| (s.channels[0].transmittance, se(s, "transmittance")), "T");
        pick(&|s| (s.channels[0].absorptance, se(s, "absorptance")), "A");
        pick(&|s| (s.channels[0].brdf[0], se_brdf(s)), "brdf");
    }
}
