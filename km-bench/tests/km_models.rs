//! Two-flux and four-flux Kubelka–Munk, and the dipole, against converged
//! multi-flux on the grids of `km_bench::km_models` (docs/two-flux.md
//! §13–14).
//!
//! The converged answers are stored in tests/data/ (multi-flux at 64
//! streams, checked at 48; written by this project's solver, see the file
//! headers) so that these tests take a second; the ignored test
//! `stored_references_are_the_converged_multiflux` recomputes them and
//! compares (about 30 s):
//! `cargo test -p km-bench --test km_models -- --ignored`
//! (with `KM_WRITE_REFERENCES=1` it rewrites the files instead).

use std::path::PathBuf;

use km::{KmMapping, KmModel, Method};
use km_bench::km_models::{
    GridPoint, Reference, best_mapping, comparison, dipole_grid, estimate_stats, grid, markdown,
    read_reference_csv, reference_csv, references,
};

fn data(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data").join(name)
}

fn stored(name: &str) -> (Vec<GridPoint>, Vec<Reference>) {
    read_reference_csv(&std::fs::read_to_string(data(name)).unwrap()).unwrap()
}

/// The grid's table (printed for docs/two-flux.md §13), and what it must
/// show: four-flux exact on every clear scene (albedo 0: a plate of any
/// index and thickness at any angle, 1e-12 against multi-flux), better
/// than two-flux in median and worst case, and the default mapping the one
/// of least mean error among those that treat every scene.
#[test]
fn four_flux_against_multiflux_on_the_grid() {
    let (points, refs) = stored("km-grid-reference.csv");
    assert_eq!(points, grid(), "the stored grid is the grid");
    let rows = comparison(&points, &refs).unwrap();
    println!("{}", markdown(&rows));
    let row = |model: KmModel, mapping: KmMapping| {
        let label = format!("{}, {}", model.name(), mapping.name());
        rows.iter().find(|r| r.label == label).unwrap()
    };
    // Clear scenes: the beam alone, exact.
    let four = row(KmModel::FourFlux, KmMapping::default());
    let clear: Vec<usize> = (0..points.len()).filter(|&i| points[i].albedo == 0.0).collect();
    let worst_clear = clear.iter().map(|&i| four.err_r[i].max(four.err_t[i])).fold(0.0, f64::max);
    println!("clear scenes: {}, worst error {worst_clear:e}", clear.len());
    assert!(clear.len() >= 81 && worst_clear < 1e-12, "{worst_clear:e}");
    // Four-flux beats two-flux, both at their best mapping.
    let two = row(KmModel::TwoFlux, KmMapping::Gate1974);
    for (f, t) in [(four.r_stats(), two.r_stats()), (four.t_stats(), two.t_stats())] {
        assert!(f.0 < t.0 && f.1 < t.1, "median, worst: four {f:?} two {t:?}");
    }
    assert_eq!(best_mapping(&rows), Some(KmMapping::default()));
}

/// `model_error_estimate` (eq. K25) bounds the true error `|x - x_ref|` of
/// R and T in at least 95 % of the numbers and is at most 10x the true
/// error in at least 90 % (both up to 1e-6, below the references'
/// convergence), for `--method km` on the two-flux grid and for the
/// dipole on the half-space grid.
#[test]
fn model_error_estimate_bounds_the_true_error() {
    for (file, method) in
        [("km-grid-reference.csv", Method::Km), ("dipole-grid-reference.csv", Method::Dipole)]
    {
        let (points, refs) = stored(file);
        let s = estimate_stats(&points, &refs, method).unwrap();
        let (b, l) = (s.bounded as f64 / s.count as f64, s.within_10x as f64 / s.count as f64);
        println!(
            "{method}: {} numbers, bounded {:.1} %, within 10x {:.1} %, median ratio {:.2}",
            s.count,
            100.0 * b,
            100.0 * l,
            s.median_ratio
        );
        assert!(b >= 0.95 && l >= 0.90, "{method}: bounded {b}, within 10x {l}");
    }
}

/// The stored references are the multi-flux answers at 64 streams (to
/// 1e-12: the same code), and converged (64 against 48 streams within 1e-5).
#[test]
#[ignore = "about 30 s of multi-flux solves: cargo test -p km-bench --test km_models -- --ignored"]
fn stored_references_are_the_converged_multiflux() {
    for (file, points) in
        [("km-grid-reference.csv", grid()), ("dipole-grid-reference.csv", dipole_grid())]
    {
        let refs = references(&points).unwrap();
        if std::env::var_os("KM_WRITE_REFERENCES").is_some() {
            std::fs::write(data(file), reference_csv(&points, &refs)).unwrap();
            continue;
        }
        let (p, r) = stored(file);
        assert_eq!(p, points);
        for (a, b) in r.iter().zip(&refs) {
            assert!((a.r - b.r).abs() < 1e-12 && (a.t - b.t).abs() < 1e-12, "{a:?} vs {b:?}");
        }
        let spread = refs.iter().map(|r| r.spread).fold(0.0, f64::max);
        println!("{file}: largest change from 48 to 64 streams {spread:e}");
        assert!(spread < 1e-5);
    }
}
