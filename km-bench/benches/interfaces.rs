//! Criterion benchmarks of the interface operators (docs/rough.md §3, §7;
//! docs/multiflux.md §6): the four operators `R`, `T` of one face per
//! Fourier order on the augmented spaces `[nodes, extras]` of its two
//! media, as a solve builds them, for a smooth Fresnel face (eq. 15 of
//! docs/multiflux.md), rough dielectric faces (GGX alpha 0.3 and 0.05, air
//! over glass n = 1.5, and water over air: total reflection inside) and a
//! rough conductor floor (gold at 550 nm under glass, GGX 0.2), at 6 and 16
//! streams, 6 Fourier orders, one beam (40 degrees in air) and one probe
//! (25 degrees) as extras; and GGX 0.3 (air over glass, water over air)
//! with the `2N` orders a solve with exit directions builds.
//!
//! The rough operators are computed anew in every iteration
//! (`rough_operators`, not the per-thread cache a solve reads them through).
//!
//! Short run: `cargo bench -p km-bench --bench interfaces -- --warm-up-time 1 --measurement-time 3`.

use std::hint::black_box;

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use km_core::microfacet::{Distribution, Far, Microfacet};
use km_multiflux::interface::fresnel_operators;
use km_multiflux::quadrature::{AngularGrid, mu_of_invariant};
use km_multiflux::rough::{RoughFace, rough_operators};
use km_multiflux::slab::Extra;

/// Fourier orders built per face.
const ORDERS: usize = 6;

/// A beam at 40 degrees in air and a probe at 25 degrees, in a medium of index `n`.
fn extras(n: f64) -> Vec<Extra> {
    [(40f64, true), (25f64, false)]
        .iter()
        .map(|&(t, beam)| Extra {
            mu: mu_of_invariant(t.to_radians().sin(), n),
            beam,
            phi_deg: 180.0,
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("interfaces");
    g.sample_size(10);
    for streams in [6usize, 16] {
        let (na, nb) = (1.0, 1.5);
        let grid = AngularGrid::new(&[na, nb], streams);
        let (a, b) = (grid.medium(na), grid.medium(nb));
        let (ea, eb) = (extras(na), extras(nb));
        g.bench_with_input(BenchmarkId::new("smooth air/1.5", streams), &streams, |bch, _| {
            bch.iter(|| black_box(fresnel_operators(&a, &b, &ea, &eb)))
        });
        for alpha in [0.3, 0.05] {
            let mf = Microfacet::new(alpha, Distribution::Ggx).expect("alpha in (0, 1]");
            let face = RoughFace { mf, n_above: na, below: Far::Dielectric(nb) };
            let id = BenchmarkId::new(format!("ggx {alpha} air/1.5"), streams);
            g.bench_with_input(id, &streams, |bch, _| {
                bch.iter(|| black_box(rough_operators(face, &a, Some(&b), &ea, &eb, ORDERS)))
            });
            if alpha == 0.3 {
                // As many orders as a solve with exit directions builds (2N).
                let id = BenchmarkId::new("ggx 0.3 air/1.5, 2N orders", streams);
                g.bench_with_input(id, &streams, |bch, _| {
                    bch.iter(|| {
                        black_box(rough_operators(face, &a, Some(&b), &ea, &eb, 2 * streams))
                    })
                });
            }
        }
        // Water over air: the face seen from the denser side (total reflection).
        let (nw, nair) = (1.33, 1.0);
        let gw = AngularGrid::new(&[nw, nair], streams);
        let (w, air) = (gw.medium(nw), gw.medium(nair));
        let (ew, eair) = (extras(nw), extras(nair));
        let mf = Microfacet::new(0.3, Distribution::Ggx).expect("alpha in (0, 1]");
        let face = RoughFace { mf, n_above: nw, below: Far::Dielectric(nair) };
        g.bench_with_input(BenchmarkId::new("ggx 0.3 1.33/air", streams), &streams, |bch, _| {
            bch.iter(|| black_box(rough_operators(face, &w, Some(&air), &ew, &eair, ORDERS)))
        });
        let id = BenchmarkId::new("ggx 0.3 1.33/air, 2N orders", streams);
        g.bench_with_input(id, &streams, |bch, _| {
            bch.iter(|| black_box(rough_operators(face, &w, Some(&air), &ew, &eair, 2 * streams)))
        });
        // Gold (n + ik = 0.47 + 2.4i at 550 nm) under glass.
        let gg = AngularGrid::new(&[nb], streams);
        let glass = gg.medium(nb);
        let mf = Microfacet::new(0.2, Distribution::Ggx).expect("alpha in (0, 1]");
        let face = RoughFace { mf, n_above: nb, below: Far::Conductor(0.47, 2.4) };
        g.bench_with_input(BenchmarkId::new("ggx 0.2 gold floor", streams), &streams, |bch, _| {
            bch.iter(|| black_box(rough_operators(face, &glass, None, &eb, &[], ORDERS)))
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
