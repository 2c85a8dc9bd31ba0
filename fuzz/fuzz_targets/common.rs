//! What the fit targets share: fit the first rows, check each answer.

use km_inverse::slab::FitOptions;
use km_inverse::spectrum::{RowOverrides, fit_rows};

/// Rows fitted per input (a fit takes milliseconds; more would slow the
/// fuzzer without reaching new code).
const ROWS: usize = 2;

/// Fit the first [`ROWS`] rows; a fitted albedo lies in [0, 1], an optical
/// thickness is non-negative, every value is finite or the refusal says why.
pub fn fit_first_rows(rows: &[km_inverse::rxt::Row]) {
    let n = rows.len().min(ROWS);
    for fit in fit_rows(&rows[..n], &RowOverrides::default(), &FitOptions::default()) {
        if let Ok(r) = fit.result {
            assert!(r.albedo.is_finite() && (0.0..=1.0).contains(&r.albedo), "albedo {}", r.albedo);
            assert!(r.tau.is_finite() && r.tau >= 0.0, "tau {}", r.tau);
            assert!(r.g.is_finite() && r.g.abs() <= 1.0, "g {}", r.g);
        }
    }
}
