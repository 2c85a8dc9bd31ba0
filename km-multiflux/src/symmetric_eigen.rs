//! Dense symmetric eigenproblems of up to a few dozen nodes: cyclic Jacobi
//! rotations and, up to 12 nodes, QL on fixed-size arrays and Householder tridiagonalisation with the implicit QL
//! iteration (flat row-major storage; the solvers of the own path of [`crate::eigen`],
//! docs/multiflux.md §9 (iv), (vi)). Plain products throughout: `f64::mul_add` is
//! a library call on the default x86-64 target (no FMA at compile time),
//! and in these loops it made the 12-node solve half again as slow.

/// The iteration did not converge (or met a non-finite value): what and
/// where, for the caller's error ([`crate::eigen::EigenFailure::Eigen`]).
#[derive(Debug)]
pub(crate) struct NoConvergence(pub(crate) String);

/// Eigenvalues and eigenvectors (columns of `Y`, `S = Y diag(lam) Y^T`) of the
/// symmetric `n x n` leading block of `a` by cyclic Jacobi rotations (Golub &
/// Van Loan 2013 §8.5): each rotation zeroes one off-diagonal pair; stop when
/// every `|s_pq| <= eps sqrt(|s_pp s_qq|)` (the relative criterion of Demmel &
/// Veselić 1992, under which the eigenvalues carry a small relative error) or
/// `|s_pq| <= eps^2 max |s_ii|` (a zero eigenvalue, conservative scattering:
/// its `k` then errs by at most `eps sqrt(|S|)`, far below the general
/// path's rounding).
/// `a` is overwritten, `Y` written into `y` (zero on entry) and the
/// eigenvalues returned.
pub(crate) fn jacobi<const M: usize>(
    a: &mut [[f64; M]; M],
    y: &mut [[f64; M]; M],
    n: usize,
) -> Result<[f64; M], NoConvergence> {
    const MAX_SWEEPS: usize = 60;
    for (i, row) in y.iter_mut().enumerate().take(n) {
        row[i] = 1.0;
    }
    let scale = (0..n).map(|i| a[i][i].abs()).fold(0.0, f64::max);
    let converged = |a: &[[f64; M]; M]| {
        (0..n).all(|p| {
            (p + 1..n).all(|q| {
                let x = a[p][q].abs();
                x <= f64::EPSILON * (a[p][p] * a[q][q]).abs().sqrt()
                    || x <= f64::EPSILON * f64::EPSILON * scale
            })
        })
    };
    let mut sweeps = 0;
    while !converged(a) {
        sweeps += 1;
        if sweeps > MAX_SWEEPS || a.iter().flatten().any(|x| !x.is_finite()) {
            return Err(NoConvergence(format!("Jacobi: no convergence in {MAX_SWEEPS} sweeps")));
        }
        for p in 0..n {
            for q in p + 1..n {
                let apq = a[p][q];
                if apq == 0.0 {
                    continue;
                }
                // t = tan of the rotation angle, the smaller root (|angle| <= pi/4).
                let theta = (a[q][q] - a[p][p]) / (2.0 * apq);
                let t = if theta.abs() > 1e150 {
                    0.5 / theta
                } else {
                    theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt())
                };
                let c = 1.0 / (t * t + 1.0).sqrt();
                let sn = t * c;
                for r in 0..n {
                    let (arp, arq) = (a[r][p], a[r][q]);
                    a[r][p] = c * arp - sn * arq;
                    a[r][q] = sn * arp + c * arq;
                }
                for r in 0..n {
                    let (apr, aqr) = (a[p][r], a[q][r]);
                    a[p][r] = c * apr - sn * aqr;
                    a[q][r] = sn * apr + c * aqr;
                }
                a[p][q] = 0.0;
                a[q][p] = 0.0;
                for row in y.iter_mut().take(n) {
                    let (yp, yq) = (row[p], row[q]);
                    row[p] = c * yp - sn * yq;
                    row[q] = sn * yp + c * yq;
                }
            }
        }
    }
    Ok(std::array::from_fn(|i| if i < n { a[i][i] } else { 0.0 }))
}

/// [`jacobi`]'s eigenvalues by Householder reduction to tridiagonal form with
/// the transformation accumulated, then the implicit QL iteration with
/// Wilkinson-type shifts on the tridiagonal matrix (the EISPACK routines
/// `tred2` and `tql2`, Martin, Reinsch & Wilkinson 1968, Bowdler et al. 1968;
/// Press et al. 2007 §11.4–11.5); an off-diagonal element counts as zero
/// when adding it to its two diagonal neighbours changes nothing. `a` is
/// overwritten; the eigenvectors come back as the rows of `q` (`q[j]` =
/// eigenvector `j`, i.e. `Y^T`: the rotations accumulate them so, combining
/// two contiguous rows), which needs no zeroing.
pub(crate) fn tridiagonal_ql<const M: usize>(
    a: &mut [[f64; M]; M],
    q: &mut [[f64; M]; M],
    n: usize,
) -> Result<[f64; M], NoConvergence> {
    let (mut d, mut e) = householder_tridiagonal(a, n);
    for (i, row) in a.iter().enumerate().take(n) {
        for (j, x) in row.iter().enumerate().take(n) {
            q[j][i] = *x;
        }
    }
    implicit_ql(&mut d, &mut e, q, n)?;
    Ok(d)
}

/// `tred2`: the Householder reduction of the symmetric leading `n x n`
/// block of `a` to the tridiagonal `(d, e)` (the diagonal, and in `e[i]` the
/// element left of the diagonal in row `i`); `a` becomes the orthogonal `Q`
/// with `Q^T A Q` tridiagonal.
fn householder_tridiagonal<const M: usize>(
    a: &mut [[f64; M]; M],
    n: usize,
) -> ([f64; M], [f64; M]) {
    let (mut d, mut e) = ([0.0f64; M], [0.0f64; M]);
    for i in (1..n).rev() {
        let l = i - 1;
        let mut h = 0.0;
        if l > 0 {
            let scale: f64 = (0..=l).map(|k| a[i][k].abs()).sum();
            if scale == 0.0 {
                e[i] = a[i][l];
            } else {
                for k in 0..=l {
                    a[i][k] /= scale;
                    h += a[i][k] * a[i][k];
                }
                let f = a[i][l];
                let g = if f >= 0.0 { -h.sqrt() } else { h.sqrt() };
                e[i] = scale * g;
                h -= f * g;
                a[i][l] = f - g;
                let mut f = 0.0;
                for j in 0..=l {
                    a[j][i] = a[i][j] / h;
                    let mut g = 0.0;
                    for k in 0..=j {
                        g += a[j][k] * a[i][k];
                    }
                    for k in j + 1..=l {
                        g += a[k][j] * a[i][k];
                    }
                    e[j] = g / h;
                    f += e[j] * a[i][j];
                }
                let hh = f / (h + h);
                for j in 0..=l {
                    let f = a[i][j];
                    let g = e[j] - hh * f;
                    e[j] = g;
                    for k in 0..=j {
                        a[j][k] -= f * e[k] + g * a[i][k];
                    }
                }
            }
        } else {
            e[i] = a[i][l];
        }
        d[i] = h;
    }
    d[0] = 0.0;
    e[0] = 0.0;
    for i in 0..n {
        if d[i] != 0.0 {
            for j in 0..i {
                let g: f64 = (0..i).map(|k| a[i][k] * a[k][j]).sum();
                for k in 0..i {
                    a[k][j] -= g * a[k][i];
                }
            }
        }
        d[i] = a[i][i];
        a[i][i] = 1.0;
        for j in 0..i {
            a[j][i] = 0.0;
            a[i][j] = 0.0;
        }
    }
    (d, e)
}

/// `tql2`: the eigenvalues of the tridiagonal `(d, e)` of
/// [`householder_tridiagonal`] into `d`, each rotation applied to two rows
/// of `q` (the columns of `Q`, transposed).
fn implicit_ql<const M: usize>(
    d: &mut [f64; M],
    e: &mut [f64; M],
    q: &mut [[f64; M]; M],
    n: usize,
) -> Result<(), NoConvergence> {
    const MAX_ITER: usize = 60;
    for i in 1..n {
        e[i - 1] = e[i];
    }
    if n > 0 {
        e[n - 1] = 0.0;
    }
    for l in 0..n {
        let mut iter = 0;
        loop {
            let mut m = l;
            while m + 1 < n {
                let dd = d[m].abs() + d[m + 1].abs();
                if e[m].abs() + dd == dd {
                    break;
                }
                m += 1;
            }
            if m == l {
                break;
            }
            iter += 1;
            if iter > MAX_ITER || !d[l].is_finite() {
                return Err(NoConvergence(format!("QL: no convergence in {MAX_ITER} steps")));
            }
            let mut g = (d[l + 1] - d[l]) / (2.0 * e[l]);
            let mut r = pythag(g, 1.0);
            g = d[m] - d[l] + e[l] / (g + r.copysign(g));
            let (mut s, mut c, mut p) = (1.0, 1.0, 0.0);
            let mut deflated = false;
            for i in (l..m).rev() {
                let f = s * e[i];
                let b = c * e[i];
                r = pythag(f, g);
                e[i + 1] = r;
                if r == 0.0 {
                    d[i + 1] -= p;
                    e[m] = 0.0;
                    deflated = true;
                    break;
                }
                let inv = 1.0 / r;
                s = f * inv;
                c = g * inv;
                g = d[i + 1] - p;
                r = (d[i] - g) * s + 2.0 * c * b;
                p = s * r;
                d[i + 1] = g + p;
                g = c * r - b;
                let (lo, hi) = q.split_at_mut(i + 1);
                for (x, y) in lo[i][..n].iter_mut().zip(&mut hi[0][..n]) {
                    let f = *y;
                    *y = s * *x + c * f;
                    *x = c * *x - s * f;
                }
            }
            if deflated {
                continue;
            }
            d[l] -= p;
            e[l] = g;
            e[m] = 0.0;
        }
    }
    Ok(())
}

/// `sqrt(a^2 + b^2)` without overflow or harmful underflow (scaled by the
/// larger magnitude; libm's `hypot`, correctly rounded, cost a tenth of a
/// QL solve).
fn pythag(a: f64, b: f64) -> f64 {
    let (a, b) = (a.abs(), b.abs());
    let (big, small) = if a >= b { (a, b) } else { (b, a) };
    if big == 0.0 || !big.is_finite() {
        return big;
    }
    if big < 1e150 && small > 1e-150 {
        // No overflow or underflow in the squares: one square root.
        return (a * a + b * b).sqrt();
    }
    let t = small / big;
    big * (t * t + 1.0).sqrt()
}

/// Eigenvalues and eigenvectors of the symmetric `n x n` matrix `a` (flat,
/// row-major, `a[i * n + k]`, both triangles equal bit for bit) by
/// Householder reduction to tridiagonal form with the transformation
/// accumulated, then the implicit QL iteration with Wilkinson-type shifts
/// on the tridiagonal matrix (the EISPACK routines `tred2` and `tql2`,
/// Martin, Reinsch & Wilkinson 1968, Bowdler et al. 1968; Press et al.
/// 2007 §11.4–11.5); an off-diagonal element counts as zero when adding it
/// to its two diagonal neighbours changes nothing. `a` is overwritten; the
/// eigenvalues go to `d`, the eigenvectors to the rows of `q` (`q[j * n..]`
/// = eigenvector `j`: the rotations combine two contiguous rows); `e` and
/// `gv` are scratch of `n` values. Every loop runs along rows (see
/// [`householder_tridiagonal_flat`]).
pub(crate) fn tridiagonal_ql_flat(
    a: &mut [f64],
    q: &mut [f64],
    [d, e, gv]: [&mut [f64]; 3],
    n: usize,
) -> Result<(), NoConvergence> {
    householder_tridiagonal_flat(a, n, d, e, gv);
    for i in 0..n {
        for j in 0..n {
            q[j * n + i] = a[i * n + j];
        }
    }
    implicit_ql_flat(d, e, q, n)
}

/// `tred2`: the Householder reduction of the symmetric `a` to the
/// tridiagonal `(d, e)` (the diagonal, and in `e[i]` the element left of
/// the diagonal in row `i`); `a` becomes the orthogonal `Q` with `Q^T A Q`
/// tridiagonal. The matrix is kept in full so that every loop runs along a
/// row: the product `A u` as a sum of rows (`sum_k u_k A_k.`, each
/// element's terms in the order of `k` of the textbook's column-and-row
/// walk of the lower triangle), the rank-two update `A -= u q^T + q u^T` on
/// whole rows (an upper element gets the same two products as its lower
/// mirror, added in the other order: the same bits, so `A` stays
/// symmetric bit for bit), and the accumulation of `Q` as a row vector
/// times a matrix and a rank-one update.
fn householder_tridiagonal_flat(
    a: &mut [f64],
    n: usize,
    d: &mut [f64],
    e: &mut [f64],
    gv: &mut [f64],
) {
    for i in (1..n).rev() {
        let l = i - 1;
        let mut h = 0.0;
        let (top, rest) = a.split_at_mut(i * n);
        let ai = &mut rest[..n];
        if l > 0 {
            let scale: f64 = ai[..=l].iter().map(|x| x.abs()).sum();
            if scale == 0.0 {
                e[i] = ai[l];
            } else {
                for x in &mut ai[..=l] {
                    *x /= scale;
                    h += *x * *x;
                }
                let f = ai[l];
                let g = if f >= 0.0 { -h.sqrt() } else { h.sqrt() };
                e[i] = scale * g;
                h -= f * g;
                ai[l] = f - g;
                // (A u)_j = sum_k A_jk u_k over the active block, by rows k.
                let gv = &mut gv[..=l];
                gv.fill(0.0);
                for k in 0..=l {
                    let uk = ai[k];
                    for (g, &x) in gv.iter_mut().zip(&top[k * n..k * n + l + 1]) {
                        *g += x * uk;
                    }
                }
                let mut f = 0.0;
                for j in 0..=l {
                    top[j * n + i] = ai[j] / h;
                    e[j] = gv[j] / h;
                    f += e[j] * ai[j];
                }
                let hh = f / (h + h);
                for j in 0..=l {
                    e[j] -= hh * ai[j];
                }
                // A -= u q^T + q u^T (q in e), whole rows of the active block.
                for j in 0..=l {
                    let (uj, qj) = (ai[j], e[j]);
                    let row = &mut top[j * n..j * n + l + 1];
                    for ((x, &ek), &uk) in row.iter_mut().zip(&e[..=l]).zip(&ai[..=l]) {
                        *x -= uj * ek + qj * uk;
                    }
                }
            }
        } else {
            e[i] = ai[l];
        }
        d[i] = h;
    }
    if n > 0 {
        d[0] = 0.0;
        e[0] = 0.0;
    }
    for i in 0..n {
        if d[i] != 0.0 {
            // g_j = sum_k a_ik a_kj (j < i), then a_kj -= g_j a_ki.
            let (top, rest) = a.split_at_mut(i * n);
            let ai = &rest[..i];
            let gv = &mut gv[..i];
            gv.fill(-0.0);
            for (k, &aik) in ai.iter().enumerate() {
                for (g, &x) in gv.iter_mut().zip(&top[k * n..k * n + i]) {
                    *g += aik * x;
                }
            }
            for k in 0..i {
                let row = &mut top[k * n..k * n + i + 1];
                let aki = row[i];
                for (x, &g) in row[..i].iter_mut().zip(gv.iter()) {
                    *x -= g * aki;
                }
            }
        }
        d[i] = a[i * n + i];
        a[i * n + i] = 1.0;
        for j in 0..i {
            a[j * n + i] = 0.0;
            a[i * n + j] = 0.0;
        }
    }
}

/// `tql2`: the eigenvalues of the tridiagonal `(d, e)` of
/// [`householder_tridiagonal_flat`] into `d`, each rotation applied to two
/// rows of `q` (the columns of `Q`, transposed; row-major, `n x n`).
fn implicit_ql_flat(
    d: &mut [f64],
    e: &mut [f64],
    q: &mut [f64],
    n: usize,
) -> Result<(), NoConvergence> {
    const MAX_ITER: usize = 60;
    for i in 1..n {
        e[i - 1] = e[i];
    }
    if n > 0 {
        e[n - 1] = 0.0;
    }
    // An off-diagonal element below eps^2 times the matrix's scale counts
    // as zero too (as in [`jacobi`]): between two zero eigenvalues (a
    // conservative layer's null modes) the relative test alone can stall.
    let scale = (0..n).map(|i| d[i].abs() + e[i].abs()).fold(0.0, f64::max);
    let tiny = f64::EPSILON * f64::EPSILON * scale;
    for l in 0..n {
        let mut iter = 0;
        loop {
            let mut m = l;
            while m + 1 < n {
                let dd = d[m].abs() + d[m + 1].abs();
                if e[m].abs() + dd == dd || e[m].abs() <= tiny {
                    break;
                }
                m += 1;
            }
            if m == l {
                break;
            }
            iter += 1;
            if iter > MAX_ITER || !d[l].is_finite() {
                return Err(NoConvergence(format!("QL: no convergence in {MAX_ITER} steps")));
            }
            let mut g = (d[l + 1] - d[l]) / (2.0 * e[l]);
            let mut r = pythag(g, 1.0);
            g = d[m] - d[l] + e[l] / (g + r.copysign(g));
            let (mut s, mut c, mut p) = (1.0, 1.0, 0.0);
            let mut deflated = false;
            for i in (l..m).rev() {
                let f = s * e[i];
                let b = c * e[i];
                r = pythag(f, g);
                e[i + 1] = r;
                if r == 0.0 {
                    d[i + 1] -= p;
                    e[m] = 0.0;
                    deflated = true;
                    break;
                }
                let inv = 1.0 / r;
                s = f * inv;
                c = g * inv;
                g = d[i + 1] - p;
                r = (d[i] - g) * s + 2.0 * c * b;
                p = s * r;
                d[i + 1] = g + p;
                g = c * r - b;
                let (lo, hi) = q.split_at_mut((i + 1) * n);
                for (x, y) in lo[i * n..].iter_mut().zip(&mut hi[..n]) {
                    let f = *y;
                    *y = s * *x + c * f;
                    *x = c * *x - s * f;
                }
            }
            if deflated {
                continue;
            }
            d[l] -= p;
            e[l] = g;
            e[m] = 0.0;
        }
    }
    Ok(())
}

/// [`jacobi`] on flat row-major storage of any size (the reference of the
/// tests of the QL path): `a` (`n x n`,
/// symmetric) is overwritten, the eigenvalues go to `d` and `Y` (columns
/// = eigenvectors, row-major) to `y`.
#[cfg(test)]
pub(crate) fn jacobi_flat(
    a: &mut [f64],
    y: &mut [f64],
    d: &mut [f64],
    n: usize,
) -> Result<(), NoConvergence> {
    const MAX_SWEEPS: usize = 60;
    y[..n * n].fill(0.0);
    for i in 0..n {
        y[i * n + i] = 1.0;
    }
    let scale = (0..n).map(|i| a[i * n + i].abs()).fold(0.0, f64::max);
    let converged = |a: &[f64]| {
        (0..n).all(|p| {
            (p + 1..n).all(|q| {
                let x = a[p * n + q].abs();
                x <= f64::EPSILON * (a[p * n + p] * a[q * n + q]).abs().sqrt()
                    || x <= f64::EPSILON * f64::EPSILON * scale
            })
        })
    };
    let mut sweeps = 0;
    while !converged(a) {
        sweeps += 1;
        if sweeps > MAX_SWEEPS || a[..n * n].iter().any(|x| !x.is_finite()) {
            return Err(NoConvergence(format!("Jacobi: no convergence in {MAX_SWEEPS} sweeps")));
        }
        for p in 0..n {
            for q in p + 1..n {
                let apq = a[p * n + q];
                if apq == 0.0 {
                    continue;
                }
                let theta = (a[q * n + q] - a[p * n + p]) / (2.0 * apq);
                let t = if theta.abs() > 1e150 {
                    0.5 / theta
                } else {
                    theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt())
                };
                let c = 1.0 / (t * t + 1.0).sqrt();
                let sn = t * c;
                for r in 0..n {
                    let (arp, arq) = (a[r * n + p], a[r * n + q]);
                    a[r * n + p] = c * arp - sn * arq;
                    a[r * n + q] = sn * arp + c * arq;
                }
                let (lo, hi) = a.split_at_mut(q * n);
                for (x, y) in lo[p * n..p * n + n].iter_mut().zip(&mut hi[..n]) {
                    let (apr, aqr) = (*x, *y);
                    *x = c * apr - sn * aqr;
                    *y = sn * apr + c * aqr;
                }
                a[p * n + q] = 0.0;
                a[q * n + p] = 0.0;
                for r in 0..n {
                    let (yp, yq) = (y[r * n + p], y[r * n + q]);
                    y[r * n + p] = c * yp - sn * yq;
                    y[r * n + q] = sn * yp + c * yq;
                }
            }
        }
    }
    for i in 0..n {
        d[i] = a[i * n + i];
    }
    Ok(())
}
