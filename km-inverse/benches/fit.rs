//! One inversion (0 spheres, g fixed) at iad's default accuracy (measurement
//! uncertainty 1e-4 = iad's tolerance, so the stream rule keeps the forward
//! error below 1e-5): n = 1.4 between slides n = 1.5, the cases of
//! `examples/fit-synthetic.rxt`.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use km_inverse::forward::{Optical, Sample};
use km_inverse::slab::{FitOptions, Measurement, Setup, fit, model};

fn bench(c: &mut Criterion) {
    let set = Setup::new(Sample::new(1.0, 1.4, Some(1.5)).unwrap());
    let mut group = c.benchmark_group("fit");
    group.sample_size(20);
    for (a, b) in [(0.9, 1.0), (0.99, 4.0), (0.8, 8.0)] {
        let m = model(&set, &Optical { albedo: a, tau: b, g: 0.0 }, 64).unwrap();
        let meas = Measurement::rt(m[0], m[1]);
        let opts = FitOptions { g: Some(0.0), streams: None };
        group.bench_function(format!("a{a}_b{b}"), |bn| {
            bn.iter(|| fit(black_box(&set), black_box(&meas), &opts).unwrap())
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
