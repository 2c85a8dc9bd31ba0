//! Tiny dense linear algebra for the 2x2 and 3x3 systems of the fit.

/// Solve `A x = y` for a small square `A` (row-major, `n x n`) by Gaussian
/// elimination with partial pivoting; `None` when `A` is singular to
/// working precision (a pivot below `1e-300` or not finite).
///
/// ```
/// let x = km_inverse::linalg::solve(&[2.0, 1.0, 1.0, 3.0], &[3.0, 5.0], 2).unwrap();
/// assert!((x[0] - 0.8).abs() < 1e-15 && (x[1] - 1.4).abs() < 1e-15);
/// ```
pub fn solve(a: &[f64], y: &[f64], n: usize) -> Option<Vec<f64>> {
    let mut m = a.to_vec();
    let mut x = y.to_vec();
    for k in 0..n {
        // Pivot: the largest entry of column k at or below row k.
        let p = (k..n).max_by(|&i, &j| m[i * n + k].abs().total_cmp(&m[j * n + k].abs()))?;
        let pivot = m[p * n + k].abs();
        if pivot.is_nan() || pivot <= 1e-300 || pivot.is_infinite() {
            return None;
        }
        if p != k {
            for c in 0..n {
                m.swap(k * n + c, p * n + c);
            }
            x.swap(k, p);
        }
        // Eliminate below the pivot.
        for i in k + 1..n {
            let f = m[i * n + k] / m[k * n + k];
            for c in k..n {
                m[i * n + c] -= f * m[k * n + c];
            }
            x[i] -= f * x[k];
        }
    }
    // Back substitution.
    for k in (0..n).rev() {
        let s: f64 = (k + 1..n).map(|c| m[k * n + c] * x[c]).sum();
        x[k] = (x[k] - s) / m[k * n + k];
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
}

/// Inverse of a small square matrix (row-major), column by column with [`solve`].
pub fn inverse(a: &[f64], n: usize) -> Option<Vec<f64>> {
    let mut inv = vec![0.0; n * n];
    for c in 0..n {
        let mut e = vec![0.0; n];
        e[c] = 1.0;
        let col = solve(a, &e, n)?;
        for r in 0..n {
            inv[r * n + c] = col[r];
        }
    }
    Some(inv)
}
