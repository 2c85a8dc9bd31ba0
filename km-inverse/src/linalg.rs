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

/// Solve `A X = B` for a square `A` (`n x n`) and `k` right-hand sides `B`
/// (`n x k`), both row-major, by one LU factorisation with partial pivoting
/// (Golub & Van Loan 2013, alg. 3.4.1); `None` when `A` is singular to
/// working precision. For the adding steps of [`crate::stack`] (`n` ~ 10–130).
///
/// ```
/// let x = km_inverse::linalg::solve_many(&[2.0, 1.0, 1.0, 3.0], &[3.0, 1.0, 5.0, 2.0], 2, 2)
///     .unwrap();
/// assert!((x[0] - 0.8).abs() < 1e-15 && (x[2] - 1.4).abs() < 1e-15);
/// assert!((x[1] - 0.2).abs() < 1e-15 && (x[3] - 0.6).abs() < 1e-15);
/// ```
pub fn solve_many(a: &[f64], b: &[f64], n: usize, k: usize) -> Option<Vec<f64>> {
    let mut m = a.to_vec();
    let mut x = b.to_vec();
    for c in 0..n {
        // Pivot: the largest entry of column c at or below row c.
        let p = (c..n).max_by(|&i, &j| m[i * n + c].abs().total_cmp(&m[j * n + c].abs()))?;
        let pivot = m[p * n + c].abs();
        if pivot.is_nan() || pivot <= 1e-300 || pivot.is_infinite() {
            return None;
        }
        if p != c {
            for j in 0..n {
                m.swap(c * n + j, p * n + j);
            }
            for j in 0..k {
                x.swap(c * k + j, p * k + j);
            }
        }
        // Eliminate below the pivot (rows of A and of B together).
        let (head, tail) = m.split_at_mut((c + 1) * n);
        let prow = &head[c * n..];
        let (xhead, xtail) = x.split_at_mut((c + 1) * k);
        let xrow = &xhead[c * k..];
        for (row, xr) in tail.chunks_exact_mut(n).zip(xtail.chunks_exact_mut(k)) {
            let f = row[c] / prow[c];
            if f != 0.0 {
                for j in c..n {
                    row[j] -= f * prow[j];
                }
                for j in 0..k {
                    xr[j] -= f * xrow[j];
                }
            }
        }
    }
    // Back substitution, all right-hand sides at once.
    for c in (0..n).rev() {
        for r in c + 1..n {
            let f = m[c * n + r];
            if f != 0.0 {
                for j in 0..k {
                    x[c * k + j] -= f * x[r * k + j];
                }
            }
        }
        let d = m[c * n + c];
        for j in 0..k {
            x[c * k + j] /= d;
        }
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
}
