//! Criterion benchmarks of `km solve`'s exit directions through the angular
//! engine (`docs/multiflux.md` §7, probes apart from the core): one layer
//! (sigma_a 0.05, sigma_s 2, thickness 0.5, g 0.6) under a beam at 45
//! degrees, without and with an index change (n 1.0 and 1.5), at 16 streams,
//! with D = 10 ... 10,000 exit directions laid out as D/10 polar angles x 10
//! azimuths (so that the distinct polar angles, which carry the cost, grow
//! with D too); and the two-layer coating over glass with 40 polar angles x
//! 25 azimuths. The cost must grow linearly in D (the dense adding grew as
//! D^2 to D^3).
//!
//! Short run: `cargo bench -p km-bench --bench directions -- --warm-up-time 1 --measurement-time 3`.

use std::fmt::Write;
use std::hint::black_box;

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use km_core::Scene;
use km_multiflux::MultifluxOptions;

/// `polar x azimuths` exit directions in the reflected hemisphere.
fn directions(polar: usize, azimuths: usize) -> String {
    let mut s = String::from("[output]\ndirections_deg = [");
    for i in 0..polar {
        let theta = 89.0 * (i as f64 + 0.5) / polar as f64;
        for k in 0..azimuths {
            let phi = 360.0 * k as f64 / azimuths as f64;
            write!(s, "[{theta}, {phi}],").unwrap();
        }
    }
    s.push_str("]\n");
    s
}

fn one_layer(n: f64, d: usize) -> Scene {
    let toml = format!(
        "[light]\ntheta_deg = 45\n[[layer]]\nsigma_a = 0.05\nsigma_s = 2.0\nthickness = 0.5\n\
         g = 0.6\nn = {n}\n{}",
        directions(d / 10, 10)
    );
    Scene::from_toml_str(&toml).expect("one-layer scene")
}

fn coating() -> Scene {
    let toml = format!(
        "[light]\ntheta_deg = 45\n\
         [[layer]]\nsigma_a = 0.01\nsigma_s = 2.0\nthickness = 1.0\ng = 0.6\nn = 1.5\n\
         [[layer]]\nsigma_a = 0.01\nsigma_s = 6.0\nthickness = 1.0\ng = 0.3\nn = 1.5\n\
         [substrate]\nkind = \"transparent\"\nn = 1.5\n{}",
        directions(40, 25)
    );
    Scene::from_toml_str(&toml).expect("coating scene")
}

fn bench(c: &mut Criterion) {
    let o = MultifluxOptions { streams: Some(16), max_work: Some(1e13), ..Default::default() };
    let mut g = c.benchmark_group("directions");
    g.sample_size(10);
    for n in [1.0, 1.5] {
        for d in [10usize, 100, 1000, 10_000] {
            let s = one_layer(n, d);
            g.bench_with_input(BenchmarkId::new(format!("one layer n {n}"), d), &d, |b, _| {
                b.iter(|| km_multiflux::solve(black_box(&s), &o).expect("solve"))
            });
        }
    }
    let s = coating();
    let o = MultifluxOptions { max_work: Some(1e13), ..Default::default() };
    g.bench_function("coating over glass, 40 polar x 25 azimuths", |b| {
        b.iter(|| km_multiflux::solve(black_box(&s), &o).expect("solve"))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
