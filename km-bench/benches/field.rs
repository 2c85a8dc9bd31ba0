//! Criterion benchmark of the multi-flux depth field (`docs/field.md` §5):
//! phi(z), A(z), F(z) at 1,000 depths from one solve at 16 streams (one
//! top-down and one bottom-up pass of the adding give the streams at every
//! layer face, each layer eigen-solved once, then O(N) per depth), on a
//! one-layer tissue slab under a Fresnel interface at 30 degrees and on a
//! three-layer skin-like stack; and the evaluation alone. The radiance
//! inside (`docs/field.md` §2a, eq. D12-D18) at 4 depths and 6 directions
//! of the slab (the delta-M radiance with its single-scattering and
//! second-order corrections and the unscattered beams).
//!
//! Short run: `cargo bench --profile dev -p km-bench --bench field -- --noplot
//! --warm-up-time 1 --measurement-time 3`.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use km_core::Scene;
use km_multiflux::MultifluxOptions;
use km_multiflux::depth::DepthField;

const SLAB: &str = "[light]\ntheta_deg = 30.0\n[[layer]]\nsigma_a = 0.3\nsigma_s = 10.0\n\
    g = 0.8\nn = 1.4\nthickness = 1.0\n";
const SKIN: &str = "[[layer]]\nsigma_a = 1.0\nsigma_s = 30.0\ng = 0.8\nn = 1.5\nthickness = 0.1\n\
    [[layer]]\nsigma_a = 0.3\nsigma_s = 20.0\ng = 0.9\nn = 1.4\nthickness = 1.0\n\
    [[layer]]\nsigma_a = 0.1\nsigma_s = 10.0\ng = 0.8\nn = 1.44\nthickness = 2.0\n";

fn bench(c: &mut Criterion) {
    let o = MultifluxOptions { streams: Some(16), ..Default::default() };
    for (name, text) in [("slab", SLAB), ("3 layers", SKIN)] {
        let s = Scene::from_toml_str(text).expect("valid scene");
        let mono = &s.channels()[0];
        let d: f64 = mono.layers().iter().map(|l| l.thickness()).sum();
        let zs: Vec<f64> = (0..1000).map(|i| d * i as f64 / 999.0).collect();
        c.bench_function(&format!("field 1000 depths 16 streams {name}"), |b| {
            b.iter(|| {
                let f = DepthField::new(black_box(mono), &o).expect("solves");
                f.profile(black_box(&zs)).expect("in the stack")
            })
        });
        let f = DepthField::new(mono, &o).expect("solves");
        c.bench_function(&format!("field 1000 depths evaluation only {name}"), |b| {
            b.iter(|| f.profile(black_box(&zs)).expect("in the stack"))
        });
    }
}

fn radiance(c: &mut Criterion) {
    let o = MultifluxOptions { streams: Some(16), ..Default::default() };
    let s = Scene::from_toml_str(SLAB).expect("valid scene");
    let mono = &s.channels()[0];
    let depths = [0.1, 0.4, 0.7, 1.0];
    let dirs =
        [[20.0, 180.0], [30.0, 0.0], [45.0, 90.0], [60.0, 180.0], [120.0, 0.0], [160.0, 90.0]];
    c.bench_function("radiance inside 4 depths x 6 directions 16 streams slab", |b| {
        b.iter(|| {
            km_multiflux::inside::inside_radiance(black_box(mono), &o, &depths, &dirs)
                .expect("solves")
        })
    });
}

criterion_group!(benches, bench, radiance);
criterion_main!(benches);
