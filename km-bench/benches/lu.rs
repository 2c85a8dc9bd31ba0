//! Criterion benchmark: the hand-written LU of the multi-flux slab
//! (`km_multiflux::slab::lu`) against faer's partial-pivoting LU on the
//! slab's own boundary matrices `Cp`, `Cm` (eq. S4 of `km_multiflux::slab`) at
//! N = 4, 8, 16, 32, 64 nodes per hemisphere, doing the work one slab does
//! for a BRDF with 5 exit directions: factor `Cp` and `Cm`, the node
//! operators `X = C_out C^-1` for both (eq. S5), one solve `C x = b` each
//! (the beam) and five `C^T x = b` each (the probes).
//!
//! Three variants: `hand` (the hand-written LU of `lu.rs` for everything,
//! forced below its switch), `faer` (faer's `partial_piv_lu` and its in-place
//! solves for everything) and `slab` (what the slab does: `Lu::new`, which
//! is the hand-written LU below 48 nodes and faer's factors from 48 on,
//! `lu::solve_right`, the hand-written vector solves).
//!
//! Short run: `cargo bench -p km-bench --bench lu -- --warm-up-time 1 --measurement-time 3`.

use std::hint::black_box;

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use faer::Mat;
use faer::linalg::solvers::Solve;
use km_core::phase::{Phase, PhaseFunction};
use km_multiflux::slab::lu::{Lu, solve_right};
use km_multiflux::slab::{SlabOrder, SlabSolution};

/// Probes per slab (vector solves with `C^T`).
const PROBES: usize = 5;

/// `[Cp, Cp_out, Cm, Cm_out]` of a slab tau = 1, albedo 0.9, HG g = 0.5
/// (2N moments), order 0, on N Gauss nodes of `[0, 1]`, rebuilt from its
/// public modes: with `t = sqrt(w mu)`, `v~ = t (g+ + g-)`, `k z~ = t (g+ - g-)`,
/// `e = exp(-k tau)`, `phi = (1 - e)/k`:
/// `Cp = (v~ (1+e) + k z~ (1-e))/2`, `Cp_out = (v~ (1+e) - k z~ (1-e))/2`,
/// `Cm = (v~ phi + z~ (1+e))/2`, `Cm_out = (v~ phi - z~ (1+e))/2`.
fn boundary_matrices(n: usize) -> [Mat<f64>; 4] {
    let (x, w) = km_core::quadrature::gauss_legendre(n);
    let mu: Vec<f64> = x.iter().map(|x| 0.5 * (x + 1.0)).collect();
    let w: Vec<f64> = w.iter().map(|w| 0.5 * w).collect();
    let hg = Phase::henyey_greenstein(0.5).expect("|g| < 1");
    let chi: Vec<f64> = (0..2 * n).map(|l| hg.legendre_moment(l)).collect();
    let tau = 1.0;
    let slab = SlabSolution::new(&mu, &w, &SlabOrder { tau, omega: 0.9, chi: &chi, m: 0 })
        .expect("benchmark slab");
    let (k, gp, gm) = slab.eigenvectors();
    let t: Vec<f64> = mu.iter().zip(&w).map(|(u, w)| (u * w).sqrt()).collect();
    let v = Mat::from_fn(n, n, |i, j| t[i] * (gp[(i, j)] + gm[(i, j)]));
    let kz = Mat::from_fn(n, n, |i, j| t[i] * (gp[(i, j)] - gm[(i, j)]));
    let e: Vec<f64> = k.iter().map(|k| (-k * tau).exp()).collect();
    let ph: Vec<f64> = k.iter().zip(&e).map(|(k, e)| (1.0 - e) / k).collect();
    let c = |s: f64, a: &dyn Fn(usize) -> f64, b: &dyn Fn(usize) -> f64, z_scaled: bool| {
        Mat::from_fn(n, n, |i, j| {
            let z = if z_scaled { kz[(i, j)] } else { kz[(i, j)] / k[j] };
            0.5 * (v[(i, j)] * a(j) + s * z * b(j))
        })
    };
    let (one_p, one_m) = (|j: usize| 1.0 + e[j], |j: usize| 1.0 - e[j]);
    [
        c(1.0, &one_p, &one_m, true),
        c(-1.0, &one_p, &one_m, true),
        c(1.0, &|j| ph[j], &one_p, false),
        c(-1.0, &|j| ph[j], &one_p, false),
    ]
}

/// The hand-written LU for everything; returns a checksum.
fn hand(c: &[Mat<f64>; 4], rhs: &[f64]) -> f64 {
    let n = rhs.len();
    let mut sum = 0.0;
    for (cm, out) in [(&c[0], &c[1]), (&c[2], &c[3])] {
        let lu = Lu::hand_written(cm);
        let mut x = vec![0.0; n * n];
        for j in 0..n {
            x[j * n..(j + 1) * n].copy_from_slice(out.col_as_slice(j));
        }
        lu.right_solve(&mut x);
        let mut b = rhs.to_vec();
        lu.solve(&mut b);
        sum += x[0] + b[0];
        for _ in 0..PROBES {
            let mut p = rhs.to_vec();
            lu.solve_transpose_rows(&mut p, 1);
            sum += p[0];
        }
    }
    sum
}

/// faer's partial-pivoting LU for everything; returns a checksum.
fn faer_lu(c: &[Mat<f64>; 4], rhs: &Mat<f64>) -> f64 {
    let mut sum = 0.0;
    for (cm, out) in [(&c[0], &c[1]), (&c[2], &c[3])] {
        let lu = cm.partial_piv_lu();
        let mut x = out.clone();
        lu.rsolve_in_place(x.as_mut());
        let mut b = rhs.clone();
        lu.solve_in_place(b.as_mut());
        sum += x[(0, 0)] + b[(0, 0)];
        for _ in 0..PROBES {
            let mut p = rhs.clone();
            lu.solve_transpose_in_place(p.as_mut());
            sum += p[(0, 0)];
        }
    }
    sum
}

/// What the slab does (`Lu::new` switches to faer's factors from 48 nodes on).
fn slab(c: &[Mat<f64>; 4], rhs: &[f64]) -> f64 {
    let mut sum = 0.0;
    for (cm, out) in [(&c[0], &c[1]), (&c[2], &c[3])] {
        let lu = Lu::new(cm);
        let x = solve_right(&lu, cm, out);
        let mut b = rhs.to_vec();
        lu.solve(&mut b);
        sum += x[0] + b[0];
        for _ in 0..PROBES {
            let mut p = rhs.to_vec();
            lu.solve_transpose_rows(&mut p, 1);
            sum += p[0];
        }
    }
    sum
}

fn bench(cr: &mut Criterion) {
    let mut g = cr.benchmark_group("slab LU");
    for n in [4usize, 8, 16, 32, 64] {
        let c = boundary_matrices(n);
        let rhs: Vec<f64> = (0..n).map(|i| 1.0 + 0.1 * i as f64).collect();
        let rhs_mat = Mat::from_fn(n, 1, |i, _| rhs[i]);
        // The three variants solve the same systems: their checksums agree
        // to rounding (relative 1e-9 allows the growth of a pivoted LU at
        // these condition numbers).
        let (a, b, s) = (hand(&c, &rhs), faer_lu(&c, &rhs_mat), slab(&c, &rhs));
        assert!((a - b).abs() <= 1e-9 * a.abs().max(1.0), "N = {n}: {a} vs {b}");
        assert!((a - s).abs() <= 1e-9 * a.abs().max(1.0), "N = {n}: {a} vs {s}");
        g.bench_with_input(BenchmarkId::new("hand", n), &n, |bch, _| {
            bch.iter(|| hand(black_box(&c), &rhs))
        });
        g.bench_with_input(BenchmarkId::new("faer", n), &n, |bch, _| {
            bch.iter(|| faer_lu(black_box(&c), &rhs_mat))
        });
        g.bench_with_input(BenchmarkId::new("slab", n), &n, |bch, _| {
            bch.iter(|| slab(black_box(&c), &rhs))
        });
    }
    g.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(20).without_plots();
    targets = bench
}
criterion_main!(benches);
