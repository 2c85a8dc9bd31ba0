//! Criterion benchmarks of the multi-flux solver at every stream count from
//! 2 to 32: the totals of one slab and its BRDF at 30 exit directions, so
//! that a cost that does not rise smoothly with the stream count (a change
//! of algorithm, a block size, a workspace size) shows as a step between
//! neighbouring counts (docs/benchmarks.md §9). The slab: tau = 1, albedo
//! 0.9, Henyey–Greenstein g = 0.9, light at 30 degrees; totals with a clear
//! half-space below (R and T), the BRDF with a black one (30 directions:
//! theta 10..60 by 10 x phi 0..180 by 45, every Fourier order the series
//! needs). C DISORT's times at NSTR = 2N come from
//! `km-bench/scripts/peers.py --sweep`, outside the timed benches.
//!
//! Each case is measured briefly (10 samples, 1 s) so that the 62 cases
//! take about two minutes: `cargo bench -p km-bench --bench multiflux_sweep`;
//! `km-bench/examples/sweep_chart.rs` draws the medians.
//!
//! A third group, `km::solve totals (plan included)`, times the totals at
//! N = 2 to 8 through the library's front door (`km::solve`: the plan, the
//! dispatch and the result around the solver), as `km solve --repeat` and
//! `peers.py --totals-ladder` time them: at these sizes the work around
//! the solver is a tenth of the whole.

use std::hint::black_box;
use std::time::Duration;

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use km_core::Scene;
use km_multiflux::{MultifluxOptions, solve};

/// The slab of the sweep with `below` as its substrate and `output` appended.
fn scene(below: &str, output: &str) -> Scene {
    let text = format!(
        "[light]\ntheta_deg = 30.0\n[[layer]]\ntau = 1.0\nalbedo = 0.9\ng = 0.9\n\
         [substrate]\nkind = \"{below}\"\n{output}"
    );
    Scene::from_toml_str(&text).expect("valid benchmark scene")
}

fn bench(c: &mut Criterion) {
    let totals = scene("transparent", "");
    let mut dirs = String::new();
    for t in [10, 20, 30, 40, 50, 60] {
        for p in [0, 45, 90, 135, 180] {
            dirs += &format!("[{t}.0, {p}.0], ");
        }
    }
    let brdf = scene("black", &format!("[output]\ndirections_deg = [{dirs}]\n"));
    for (name, s) in [("totals", &totals), ("BRDF at 30 directions", &brdf)] {
        let mut g = c.benchmark_group(format!("multiflux sweep g = 0.9 {name}"));
        g.sample_size(10).warm_up_time(Duration::from_millis(300));
        g.measurement_time(Duration::from_secs(1));
        for n in 2usize..=32 {
            let o = MultifluxOptions { streams: Some(n), ..Default::default() };
            g.bench_with_input(BenchmarkId::from_parameter(n), &n, |b, _| {
                b.iter(|| solve(black_box(s), &o).expect("solve"))
            });
        }
        g.finish();
    }
    let mut g = c.benchmark_group("km::solve totals (plan included)");
    g.sample_size(20).warm_up_time(Duration::from_millis(300));
    g.measurement_time(Duration::from_secs(1));
    for n in 2usize..=8 {
        let o = km::Options::from(MultifluxOptions { streams: Some(n), ..Default::default() });
        g.bench_with_input(BenchmarkId::from_parameter(n), &n, |b, _| {
            b.iter(|| km::solve(black_box(&totals), &o).expect("solve"))
        });
    }
    g.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().without_plots();
    targets = bench
}
criterion_main!(benches);
