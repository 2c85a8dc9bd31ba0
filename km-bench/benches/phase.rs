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
use km_core::mie::{Complex, Sphere, phase_moments};
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

/// Two-term Henyey–Greenstein (w = 0.9, g1 = 0.9, g2 = -0.3; chi_1 = 0.78)
/// written out as 1000 Legendre moments, `chi_l = w g1^l + (1 - w) g2^l`.
fn thousand_moments() -> String {
    let (w, g1, g2) = (0.9_f64, 0.9_f64, -0.3_f64);
    let chi: Vec<String> =
        (1..=1000).map(|l| format!("{:e}", w * g1.powi(l) + (1.0 - w) * g2.powi(l))).collect();
    format!("phase = {{ kind = \"legendre\", moments = [{}] }}", chi.join(", "))
}

fn moments(c: &mut Criterion) {
    let hg = "g = 0.78";
    let legendre = thousand_moments();
    let o = MultifluxOptions { streams: Some(32), ..Default::default() };
    let mut g = c.benchmark_group("phase moments");
    for (name, phase) in [("hg", hg), ("1000 moments", legendre.as_str())] {
        let totals = scene(&slab(phase));
        let brdf = scene(&format!("{}{}", slab(phase), directions()));
        g.bench_function(format!("{name} totals N=32"), |b| {
            b.iter(|| solve(black_box(&totals), &o).expect("solve"))
        });
        g.bench_function(format!("{name} 30 directions N=32"), |b| {
            b.iter(|| solve(black_box(&brdf), &o).expect("solve"))
        });
    }
    g.finish();
}

fn mie(c: &mut Criterion) {
    // Wiscombe's (1979) test index of water, m = 1.33 + 1e-5 i, at x = 1000.
    let m = Complex::new(1.33, 1e-5);
    let x = 1000.0;
    let mut g = c.benchmark_group("mie");
    g.bench_function("x=1000 efficiencies and g", |b| {
        b.iter(|| {
            let s = Sphere::new(black_box(m), black_box(x)).expect("sphere");
            (s.q_ext(), s.q_sca(), s.q_back(), s.g())
        })
    });
    let s = Sphere::new(m, x).expect("sphere");
    g.bench_function("x=1000 amplitudes at 10 angles", |b| {
        b.iter(|| {
            let mut sum = 0.0;
            for k in 0..10 {
                let (s1, s2) = s.amplitudes(black_box(1.0 - 0.2 * k as f64));
                sum += s1.norm_sqr() + s2.norm_sqr();
            }
            sum
        })
    });
    g.bench_function("x=1000 Legendre moments", |b| b.iter(|| phase_moments(black_box(&s))));
    g.finish();
}

// Criterion's plots need a font plotters cannot find here (two_flux.rs).
criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(40).without_plots();
    targets = hg_path, moments, mie
}
criterion_main!(benches);
