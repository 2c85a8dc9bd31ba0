//! Criterion benchmarks of the multi-flux solver (Fourier–Gauss mode):
//! one layer at N = 8, 16, 32, 64 streams per hemisphere, totals only
//! (Fourier order 0) and a full BRDF/BTDF (all Fourier orders the phase
//! function needs, 5 exit directions); a 3-layer stack with interfaces
//! (totals); the seed 000 §4.4 scene (Fresnel surface, layer, Lambertian 0.8);
//! the intensity correction (TMS + IMS) of one exit direction; 512 distinct
//! spectral channels of one slab, serial (`km_multiflux::solve`) against all
//! cores (`km::solve`).
//!
//! Short run: `cargo bench -p km-bench --bench multiflux -- --warm-up-time 1 --measurement-time 2`.

use std::hint::black_box;

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use km_core::Scene;
use km_multiflux::{MultifluxOptions, solve};

fn scene(text: &str) -> Scene {
    Scene::from_toml_str(text).expect("valid benchmark scene")
}

fn bench(c: &mut Criterion) {
    // One slab: tau = 1, albedo 0.9, Henyey–Greenstein g = 0.5, 30 degrees, no interface.
    let slab = "[light]\ntheta_deg = 30.0\n[[layer]]\ntau = 1.0\nalbedo = 0.9\ng = 0.5\n";
    let totals = scene(slab);
    let brdf = scene(&format!(
        "{slab}[output]\ndirections_deg = [[0.0, 0.0], [30.0, 180.0], [45.0, 90.0], [60.0, 0.0], [80.0, 180.0]]\n"
    ));
    let mut g = c.benchmark_group("multiflux one layer");
    for n in [8usize, 16, 32, 64] {
        let o = MultifluxOptions { streams: Some(n), ..Default::default() };
        g.bench_with_input(BenchmarkId::new("totals", n), &n, |b, _| {
            b.iter(|| solve(black_box(&totals), &o).expect("solve"))
        });
        g.bench_with_input(BenchmarkId::new("full brdf", n), &n, |b, _| {
            b.iter(|| solve(black_box(&brdf), &o).expect("solve"))
        });
    }
    g.finish();

    // The BRDF case of docs/benchmarks.md §6 (`peers.py --brdf`): tau = 1,
    // albedo 0.9, black below, light at 30 degrees, 30 exit directions (theta
    // 10..60 by 10 x phi 0..180 by 45), each g at km's cheapest stream count
    // within 1 % of the reference.
    let mut dirs = String::new();
    for t in [10, 20, 30, 40, 50, 60] {
        for p in [0, 45, 90, 135, 180] {
            dirs += &format!("[{t}.0, {p}.0], ");
        }
    }
    let mut g = c.benchmark_group("multiflux BRDF at 30 directions");
    for (gg, n) in [(0.5, 3usize), (0.8, 7), (0.9, 20)] {
        let s = scene(&format!(
            "[light]\ntheta_deg = 30.0\n[[layer]]\ntau = 1.0\nalbedo = 0.9\ng = {gg}\n\
             [substrate]\nkind = \"black\"\n[output]\ndirections_deg = [{dirs}]\n"
        ));
        let o = MultifluxOptions { streams: Some(n), ..Default::default() };
        g.bench_with_input(BenchmarkId::new(format!("g = {gg}"), n), &n, |b, _| {
            b.iter(|| solve(black_box(&s), &o).expect("solve"))
        });
    }
    g.finish();

    // The intensity correction of one exit direction inside the forward cone
    // (both terms evaluated): g = 0.95, 2N moments.
    let mut g = c.benchmark_group("multiflux correction per exit direction");
    for n in [16usize, 48] {
        let pc = km_multiflux::correction::PeakCorrection::new(
            km_core::phase::Phase::henyey_greenstein(0.95).expect("|g| < 1"),
            0.9,
            2 * n,
            true,
        );
        g.bench_with_input(BenchmarkId::new("tms+ims", n), &n, |b, _| {
            b.iter(|| pc.radiance(black_box(0.8), black_box(0.75), black_box(170.0), 1.5))
        });
    }
    g.finish();

    // Three layers of different indices over glass, collimated at 45 degrees.
    let stack = scene(
        "[light]\ntheta_deg = 45.0\n\
         [[layer]]\ntau = 0.5\nalbedo = 0.8\nn = 1.5\n\
         [[layer]]\ntau = 2.0\nalbedo = 0.95\ng = 0.7\nn = 1.3\n\
         [[layer]]\ntau = 1.0\nalbedo = 0.6\ng = 0.3\nn = 1.4\n\
         [substrate]\nkind = \"transparent\"\nn = 1.5\n",
    );
    let seed = scene(
        "[light]\ntheta_deg = 45.0\n[[layer]]\nsigma_a = 0.1\nsigma_s = 0.4\nthickness = 1.0\nn = 1.3\n\
         [substrate]\nkind = \"lambertian\"\nalbedo = 0.8\n",
    );
    let o = MultifluxOptions::default();
    c.bench_function("multiflux 3-layer stack totals (N = 16)", |b| {
        b.iter(|| solve(black_box(&stack), &o).expect("solve"))
    });
    c.bench_function("multiflux seed 4.4 scene totals (N = 16)", |b| {
        b.iter(|| solve(black_box(&seed), &o).expect("solve"))
    });

    // 512 distinct channels (albedo 0.5..0.99, g 0.1..0.8 across the
    // spectrum) of one slab at 30 degrees, totals, N = 16.
    let k = 512;
    let list = |f: &dyn Fn(f64) -> f64| {
        let v: Vec<String> = (0..k).map(|i| format!("{:.6}", f(i as f64 / k as f64))).collect();
        format!("[{}]", v.join(", "))
    };
    let spectral = scene(&format!(
        "[spectrum]\nwavelengths_nm = {}\n[light]\ntheta_deg = 30.0\n\
         [[layer]]\ntau = 1.0\nalbedo = {}\ng = {}\n",
        list(&|x| 400.0 + 300.0 * x),
        list(&|x| 0.5 + 0.49 * x),
        list(&|x| 0.1 + 0.7 * x)
    ));
    let mut g = c.benchmark_group("multiflux 512 channels (N = 16)");
    g.bench_function("serial", |b| b.iter(|| solve(black_box(&spectral), &o).expect("solve")));
    let all = km::Options::from(o.clone());
    g.bench_function("all cores", |b| {
        b.iter(|| km::solve(black_box(&spectral), &all).expect("solve"))
    });
    g.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(20).without_plots();
    targets = bench
}
criterion_main!(benches);
