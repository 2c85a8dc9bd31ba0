//! Criterion benchmarks of two-flux Kubelka–Munk (km-core only): one layer's
//! closed form, one scene channel (Saunderson interface, layer, Lambertian
//! ground, as in seed 000 §4.4) by the seed's two-flux model and by the
//! four-flux model, and ten-layer stacks by both concatenation forms.
//!
//! Short run: `cargo bench -p km-bench --bench two_flux -- --warm-up-time 1 --measurement-time 2`.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use km_core::two_flux::{KmOptions, Slab, Transfer, layer_rt, solve_mono, stack_adding};
use km_core::{Layer, Light, MonoScene, Substrate};

fn bench(c: &mut Criterion) {
    c.bench_function("km layer_rt", |b| {
        b.iter(|| layer_rt(black_box(0.1), black_box(0.4), black_box(1.0)))
    });

    // Seed §4.4: n = 1.3, sigma_a = 0.1, sigma_s = 0.4, z0 = 1/(2 sigma_t), ground 0.8, 45 degrees.
    let scene = MonoScene::new(
        Light::Collimated { theta_deg: 45.0 },
        1.0,
        vec![Layer::new(0.1, 0.4, 1.0, 0.0, 1.3).expect("valid layer")],
        Substrate::Lambertian { albedo: 0.8 },
        vec![],
    )
    .expect("valid scene");
    let opts = KmOptions::SEED;
    c.bench_function("km solve_mono seed 4.4 scene", |b| {
        b.iter(|| solve_mono(black_box(&scene), &opts))
    });
    let four = KmOptions::default();
    c.bench_function("km four-flux solve_mono seed 4.4 scene", |b| {
        b.iter(|| solve_mono(black_box(&scene), &four))
    });

    // The same layer with the ambient's index: no Fresnel integrals.
    let matched = scene
        .with_layers(vec![Layer::new(0.1, 0.4, 1.0, 0.0, 1.0).expect("valid layer")])
        .expect("valid scene");
    c.bench_function("km solve_mono index-matched scene", |b| {
        b.iter(|| solve_mono(black_box(&matched), &opts))
    });
    c.bench_function("km four-flux solve_mono index-matched scene", |b| {
        b.iter(|| solve_mono(black_box(&matched), &four))
    });

    let slabs: Vec<Slab> = (0..10)
        .map(|i| Slab::layer(0.1 + 0.01 * i as f64, 0.4, 0.3).expect("valid layer"))
        .collect();
    c.bench_function("km stack_adding 10 layers", |b| b.iter(|| stack_adding(black_box(&slabs))));
    let mats: Vec<Transfer> =
        slabs.iter().map(|s| Transfer::from_slab(s).expect("transmitting")).collect();
    c.bench_function("km transfer product 10 layers", |b| {
        b.iter(|| black_box(&mats).iter().fold(Transfer::IDENTITY, |acc, m| acc.then(m)).to_slab())
    });
}

// No plots: the workspace builds plotters without system fonts, and criterion's
// plotting backend then fails with `FontUnavailable`.
criterion_group! {
    name = benches;
    config = Criterion::default().without_plots();
    targets = bench
}
criterion_main!(benches);
