//! Criterion benchmarks of the BSDF table (`docs/bsdf.md` §6):
//! the full default table of the seed's 3-layer scene (32 incidence x 32
//! exit polar angles x 72 azimuths, BRDF and BTDF), 1,000 exit directions
//! for one incidence on the 2-layer coating (`examples/paint-over-primer.toml`,
//! one channel and all three), and the growth with the number of polar angles
//! and of azimuths.
//!
//! Short run: `cargo bench -p km-bench --bench bsdf -- --warm-up-time 1 --measurement-time 3`.

use std::hint::black_box;

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use km_core::Scene;
use km_multiflux::bsdf::{Bsdf, BsdfOptions, gauss_angles};

const SEED: &str = include_str!("../../examples/seed-three-layers.toml");
const PAINT: &str = include_str!("../../examples/paint-over-primer.toml");

fn bench(c: &mut Criterion) {
    let o = BsdfOptions::default();
    let phi72: Vec<f64> = (0..72).map(|k| 5.0 * k as f64).collect();
    let mut g = c.benchmark_group("bsdf");
    g.sample_size(10);

    // The seed scene's full default table.
    let seed = Scene::from_toml_str(SEED).expect("seed scene");
    let (t32, _) = gauss_angles(32);
    g.bench_function("seed table 32x32x72", |b| {
        b.iter(|| {
            let t = Bsdf::new(black_box(&seed), &t32, &t32, &o).expect("bsdf");
            t.table(&phi72)
        })
    });

    // 1,000 exit directions (one polar angle, 1,000 azimuths) for one incidence.
    let paint = Scene::from_toml_str(PAINT).expect("paint scene");
    let red = paint.select(&[0]);
    let phi1000: Vec<f64> = (0..1000).map(|k| 0.36 * k as f64).collect();
    for (name, s) in [("paint 1 channel", &red), ("paint 3 channels", &paint)] {
        g.bench_function(format!("{name}: 1 incidence, 1000 azimuths"), |b| {
            b.iter(|| {
                let t = Bsdf::new(black_box(s), &[30.0], &[45.0], &o).expect("bsdf");
                t.table(&phi1000)
            })
        });
    }
    // 1,000 exit directions as 10 polar angles x 100 azimuths.
    let t10: Vec<f64> = (0..10).map(|k| 8.5 * k as f64).collect();
    let phi100: Vec<f64> = (0..100).map(|k| 3.6 * k as f64).collect();
    g.bench_function("paint 1 channel: 1 incidence, 10 polar x 100 azimuths", |b| {
        b.iter(|| {
            let t = Bsdf::new(black_box(&red), &[30.0], &t10, &o).expect("bsdf");
            t.table(&phi100)
        })
    });

    // Growth with the number of polar angles (incidence = exit grid, 72 azimuths).
    for n in [4usize, 8, 16, 32] {
        let (t, _) = gauss_angles(n);
        g.bench_with_input(BenchmarkId::new("paint 1 channel polar n x n x 72", n), &n, |b, _| {
            b.iter(|| Bsdf::new(black_box(&red), &t, &t, &o).expect("bsdf").table(&phi72))
        });
    }
    // Growth with the number of azimuths (8 x 8 polar angles).
    let (t8, _) = gauss_angles(8);
    let fixed = Bsdf::new(&red, &t8, &t8, &o).expect("bsdf");
    for n in [1usize, 72, 720, 7200] {
        let phis: Vec<f64> = (0..n).map(|k| 360.0 * k as f64 / n as f64).collect();
        g.bench_with_input(BenchmarkId::new("paint 8x8 table, azimuths", n), &n, |b, _| {
            b.iter(|| fixed.table(black_box(&phis)))
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
