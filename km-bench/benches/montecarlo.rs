//! Criterion benchmarks of the Monte Carlo tracer (km-montecarlo), one core:
//!
//! * `mc events/...`: scattering events (interactions) per second per core on
//!   two representative scenes, MCML's validation slab (tau = 2, albedo 0.9,
//!   g = 0.75, index-matched) and a paint-like stack (clear coat n = 1.5 over
//!   a g = 0.9 pigment layer n = 1.4 over a Lambertian ground, 45 degrees).
//!   Criterion's throughput is set to the (deterministic) number of
//!   interactions of one run, so "elem/s" reads as events per second.
//! * The figure of merit `FOM = 1 / (se(R)^2 t)` of the total reflectance,
//!   survival biasing vs analog absorption (printed before the benchmarks;
//!   se from batch statistics of a 1e6-photon (vdH) or 3e5-photon (paint)
//!   run, t its tracing time, best of three).
//! * `mc photons/...`: photons per second per core, survival biasing, on the
//!   scenes of the side-by-side comparison with MCML (tau-2 slab, three-layer
//!   skin).
//!
//! Short run: `cargo bench -p km-bench --bench montecarlo -- --warm-up-time 1 --measurement-time 2`.

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use km_core::Scene;
use km_montecarlo::{Estimator, McOptions, solve};

const VDH: &str = "[[layer]]\nsigma_a = 10.0\nsigma_s = 90.0\nthickness = 0.02\ng = 0.75\n";
const PAINT: &str = r#"
[light]
theta_deg = 45.0
[[layer]]
sigma_a = 0.0
sigma_s = 0.0
thickness = 0.05
n = 1.5
[[layer]]
tau = 4.0
albedo = 0.95
g = 0.9
n = 1.4
[substrate]
kind = "lambertian"
albedo = 0.8
[output]
directions_deg = [[0.0, 0.0], [45.0, 180.0], [70.0, 0.0]]
"#;

/// Three-layer skin (epidermis, dermis, subcutis; cm^-1 and cm) for the
/// photon rate side by side with MCML.
const SKIN: &str = "[[layer]]\nsigma_a = 1.0\nsigma_s = 100.0\nthickness = 0.01\ng = 0.8\nn = 1.4\n\
                    [[layer]]\nsigma_a = 0.3\nsigma_s = 200.0\nthickness = 0.2\ng = 0.9\nn = 1.4\n\
                    [[layer]]\nsigma_a = 0.5\nsigma_s = 100.0\nthickness = 0.3\ng = 0.8\nn = 1.44\n";

fn opts(samples: u64, estimator: Estimator) -> McOptions {
    McOptions { samples, estimator, threads: Some(1), seed: 3, ..Default::default() }
}

/// Interactions of one run (deterministic for a seed).
fn interactions(scene: &Scene, o: &McOptions) -> u64 {
    let sol = solve(scene, o).expect("valid scene");
    sol.to_json()["mc"]["interactions"].as_u64().unwrap_or(0)
}

fn figure_of_merit() {
    for (name, text, samples) in [("vdH slab", VDH, 1_000_000), ("paint stack", PAINT, 300_000)] {
        let scene = Scene::from_toml_str(text).expect("valid scene");
        for est in [Estimator::SurvivalBiasing, Estimator::Analog] {
            // Same seed: identical results; the best of three timings.
            let runs: Vec<_> =
                (0..3).map(|_| solve(&scene, &opts(samples, est)).expect("valid scene")).collect();
            let t = runs.iter().map(|s| s.seconds).fold(f64::INFINITY, f64::min);
            let sol = &runs[0];
            let se = sol.channels[0].stderr.as_ref().and_then(|m| m.get("reflectance"));
            let se = se.unwrap_or(f64::NAN);
            let ev = sol.to_json()["mc"]["interactions"].as_f64().unwrap_or(f64::NAN);
            println!(
                "FOM {name:12} {:17} N = {samples}, R = {:.5} +- {:.2e}, t = {:.3} s, \
                 {:.2e} events/s, {:.1} events/photon, FOM = 1/(se^2 t) = {:.3e}",
                est.name(),
                sol.channels[0].reflectance,
                se,
                t,
                ev / t,
                ev / samples as f64,
                1.0 / (se * se * t)
            );
        }
    }
}

fn bench(c: &mut Criterion) {
    figure_of_merit();
    let mut g = c.benchmark_group("mc events");
    g.sample_size(10);
    for (name, text) in [("vdH slab", VDH), ("paint stack", PAINT)] {
        let scene = Scene::from_toml_str(text).expect("valid scene");
        for est in [Estimator::SurvivalBiasing, Estimator::Analog] {
            let o = opts(20_000, est);
            g.throughput(Throughput::Elements(interactions(&scene, &o)));
            g.bench_function(format!("{name} {}", est.name()), |b| {
                b.iter(|| solve(black_box(&scene), &o))
            });
        }
    }
    g.finish();
    // Photons per second per core on the two scenes of the side-by-side
    // comparison with MCML (docs/montecarlo.md §11): the tau-2 slab and a
    // three-layer skin model (cm^-1, cm), survival biasing, roulette 1e-4 / 0.1.
    let mut g = c.benchmark_group("mc photons");
    g.sample_size(10);
    for (name, text, photons) in [("vdH slab", VDH, 20_000), ("skin 3 layers", SKIN, 500)] {
        let scene = Scene::from_toml_str(text).expect("valid scene");
        let o = opts(photons, Estimator::SurvivalBiasing);
        g.throughput(Throughput::Elements(photons));
        g.bench_function(name, |b| b.iter(|| solve(black_box(&scene), &o)));
    }
    g.finish();
}

// No plots: criterion's plotters backend needs a system font (see STYLE.md).
criterion_group! {
    name = benches;
    config = Criterion::default().without_plots();
    targets = bench
}
criterion_main!(benches);
