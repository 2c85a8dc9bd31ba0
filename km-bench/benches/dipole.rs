//! Criterion benchmarks of the diffusion dipole (km-dipole): one `Rd(r)`
//! evaluation, the closed-form total, the diffusion quantities with the
//! exact and the fitted `F_dr`, a whole three-channel scene, and the better
//! dipole of d'Eon 2012.
//!
//! Short run: `cargo bench -p km-bench --bench dipole -- --warm-up-time 1 --measurement-time 2`.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use km_core::Scene;
use km_dipole::better_dipole::BetterDipole;
use km_dipole::dipole::{rd_radial, rd_total};
use km_dipole::{DiffusionParams, DipoleOptions, FdrModel, profile, solve};

fn bench(c: &mut Criterion) {
    // Marble, R channel (Jensen et al. 2001), exact F_dr.
    let p = DiffusionParams::from_reduced(0.0021, 2.19, 1.5, FdrModel::Exact).expect("valid");
    c.bench_function("dipole rd_radial one r", |b| {
        b.iter(|| rd_radial(black_box(&p), black_box(1.0)))
    });
    c.bench_function("dipole rd_total closed form", |b| b.iter(|| rd_total(black_box(&p))));
    c.bench_function("dipole params exact F_dr", |b| {
        b.iter(|| DiffusionParams::from_reduced(black_box(0.0021), 2.19, 1.5, FdrModel::Exact))
    });
    c.bench_function("dipole params Egan-Hilgeman F_dr", |b| {
        b.iter(|| {
            DiffusionParams::from_reduced(black_box(0.0021), 2.19, 1.5, FdrModel::EganHilgeman)
        })
    });

    let scene = Scene::from_toml_str(
        "[light]\nkind = \"collimated\"\ntheta_deg = 30.0\n[[layer]]\npreset = \"marble\"\n\
         [output]\ndirections_deg = [[0.0, 0.0], [45.0, 180.0]]\n",
    )
    .expect("valid scene");
    let opts = DipoleOptions::default();
    c.bench_function("dipole solve marble 3 channels", |b| {
        b.iter(|| solve(black_box(&scene), &opts))
    });
    let eh = DipoleOptions { fdr: FdrModel::EganHilgeman, ..Default::default() };
    c.bench_function("dipole solve marble 3 channels Egan-Hilgeman", |b| {
        b.iter(|| solve(black_box(&scene), &eh))
    });
    let better = BetterDipole::from_reduced(0.0021, 2.19, 1.5).expect("valid");
    c.bench_function("better dipole rd_radial one r", |b| {
        b.iter(|| black_box(&better).rd_radial(black_box(1.0)))
    });
    c.bench_function("better dipole params (two Fresnel moments)", |b| {
        b.iter(|| BetterDipole::from_reduced(black_box(0.0021), 2.19, 1.5))
    });
    let r: Vec<f64> = (0..100).map(|i| 0.1 * i as f64).collect();
    c.bench_function("dipole profile marble 3 x 100 r", |b| {
        b.iter(|| profile(black_box(&scene), black_box(&r), &opts))
    });
}

// No plots: criterion's plotters backend needs a system font (see STYLE.md).
criterion_group! {
    name = benches;
    config = Criterion::default().without_plots();
    targets = bench
}
criterion_main!(benches);
