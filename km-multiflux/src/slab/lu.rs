//! LU factors with partial pivoting of the small matrices `Cp`, `Cm` of
//! eq. S4 (vector solves for the probes, the beam and the internal field),
//! and `X = B C^-1` for the node operators.
//!
//! Hand-written up to 47 nodes, faer's LU from 48 on: up to 32 nodes (the
//! default stream counts) everything is the code of this file; from 33 to
//! 47 the node operators `X = C_out C^-1` use faer's LU; from 48 on the
//! factors and every solve are faer's (the factors are also copied into
//! this file's layout, the permutation as exchanges, for [`Lu::right_solve`]
//! and the slab's regularity check). The criterion measurements behind the
//! switch (`km-bench/benches/lu.rs` and the `multiflux` bench) are in
//! docs/benchmarks.md, "LU factors of the slab".

use crate::workspace::Workspace;
use faer::Mat;
use faer::linalg::solvers::{PartialPivLu, Solve};

/// Size from which [`Lu::new`] factors with faer (see the module header).
const FAER_FROM: usize = 48;

/// `X = B C^-1` for square `C`, `B`, column-major (`x[j * n + i] = X_ij`),
/// from the factors `lu` of `C`: by whole-column updates
/// ([`Lu::right_solve`]) up to 32 nodes, by faer's blocked LU of `C` from 33
/// to 47 (the hand-written factors then serve the vector solves only), by
/// faer's factor object in `lu` from `FAER_FROM` (48) on. A singular `C` gives non-finite entries,
/// which the caller refuses.
pub fn solve_right(lu: &Lu, c: &Mat<f64>, b: &Mat<f64>) -> Vec<f64> {
    let n = lu.n;
    let mut x = vec![0.0; n * n];
    if let Some(f) = &lu.faer {
        let mut xm = b.clone();
        f.rsolve_in_place(xm.as_mut());
        for j in 0..n {
            x[j * n..(j + 1) * n].copy_from_slice(xm.col_as_slice(j));
        }
        return x;
    }
    if n > 32 {
        // Between 33 and 47 nodes: the hand-written factors serve the vector
        // solves, faer's blocked LU of `C` the node operators (X^T = C^-T B^T).
        let s = c.partial_piv_lu().solve_transpose(b.transpose());
        for j in 0..n {
            for (i, v) in s.col_as_slice(j).iter().enumerate() {
                x[i * n + j] = *v;
            }
        }
        return x;
    }
    for j in 0..n {
        x[j * n..(j + 1) * n].copy_from_slice(b.col_as_slice(j));
    }
    lu.right_solve(&mut x);
    x
}

/// LU factors with partial pivoting of a small square matrix `C`
/// (`P C = L U`, unit lower `L`), column-major in one contiguous buffer,
/// for the vector solves `C x = b` and `C^T x = b` of the probes, the
/// beam and the internal field (Golub & Van Loan 2013, alg. 3.4.1). A
/// singular `C` gives non-finite solutions, which the callers refuse.
pub struct Lu {
    pub(super) n: usize,
    /// `L` below and `U` on and above the diagonal: `lu[col * n + row]`.
    pub(super) lu: Vec<f64>,
    /// Row exchanged with row `k` at elimination step `k`.
    pub(super) piv: Vec<usize>,
    /// faer's factor object (from `FAER_FROM` (48) nodes on), for every solve.
    /// Boxed: the slab's solution carries two of these and is moved whole
    /// in every Fourier order, so the common case (no faer factors) keeps it
    /// small.
    faer: Option<Box<PartialPivLu<f64>>>,
}

impl Lu {
    /// Factor `C` (`n x n`): `P C = L U` with partial pivoting, by the
    /// unblocked elimination below `FAER_FROM` (48) nodes, by faer's blocked LU
    /// from there on (module header: the measured times).
    pub fn new(c: &Mat<f64>) -> Self {
        if c.nrows() >= FAER_FROM {
            return Self::from_faer(c.partial_piv_lu());
        }
        Self::hand_written(c)
    }

    /// [`Lu::new`] by the hand-written elimination at every size (the
    /// benchmark's reference).
    pub fn hand_written(c: &Mat<f64>) -> Self {
        let n = c.nrows();
        Self::hand_written_into(c, vec![0.0; n * n], vec![0; n])
    }

    /// [`Lu::new`] with the factors' buffer (below `FAER_FROM` nodes) taken
    /// from the workspace; [`Lu::recycle`] hands it back.
    pub(crate) fn new_in(c: &Mat<f64>, ws: &mut Workspace) -> Self {
        let n = c.nrows();
        if n >= FAER_FROM {
            return Self::from_faer(c.partial_piv_lu());
        }
        // Every element of both is written by the elimination.
        Self::hand_written_into(c, ws.take_for_overwrite(n * n), ws.take_idx(n))
    }

    /// Hand the factors' buffers back to the workspace.
    pub(crate) fn recycle(self, ws: &mut Workspace) {
        ws.give(self.lu);
        ws.give_idx(self.piv);
    }

    /// The hand-written elimination in `lu` (`n * n` values) with the
    /// pivots in `piv` (`n`; both overwritten).
    fn hand_written_into(c: &Mat<f64>, lu: Vec<f64>, piv: Vec<usize>) -> Self {
        let n = c.nrows();
        // Up to 12 nodes on arrays sized to the problem (the same operations
        // in the same order: the same bits, with the loops' bounds known).
        match n {
            0..=4 => return Self::small_into::<4>(c, lu, piv),
            5..=8 => return Self::small_into::<8>(c, lu, piv),
            9..=12 => return Self::small_into::<12>(c, lu, piv),
            _ => {}
        }
        Self::general_into(c, lu, piv)
    }

    /// [`Lu::hand_written_into`] at any size, on the buffer `lu` itself.
    fn general_into(c: &Mat<f64>, mut lu: Vec<f64>, mut piv: Vec<usize>) -> Self {
        let n = c.nrows();
        for j in 0..n {
            lu[j * n..(j + 1) * n].copy_from_slice(c.col_as_slice(j));
        }
        for k in 0..n {
            // Pivot: largest |C(r, k)| for r >= k.
            let col = &lu[k * n..(k + 1) * n];
            let p = (k..n).fold(k, |b, r| if col[r].abs() > col[b].abs() { r } else { b });
            piv[k] = p;
            if p != k {
                for j in 0..n {
                    lu.swap(j * n + k, j * n + p);
                }
            }
            // Multipliers of column k, then the rank-one update of the rest.
            let inv = 1.0 / lu[k * n + k];
            for r in k + 1..n {
                lu[k * n + r] *= inv;
            }
            let (left, right) = lu.split_at_mut((k + 1) * n);
            let lk = &left[k * n + k + 1..k * n + n];
            for j in 0..n - k - 1 {
                let colj = &mut right[j * n..(j + 1) * n];
                let ukj = colj[k];
                if ukj != 0.0 {
                    for (x, l) in colj[k + 1..].iter_mut().zip(lk) {
                        *x -= l * ukj;
                    }
                }
            }
        }
        Lu { n, lu, piv, faer: None }
    }

    /// [`Lu::hand_written_into`] for `n <= M` nodes on an `M x M` array
    /// (`a[col][row]`): the same pivots, multipliers and updates.
    fn small_into<const M: usize>(c: &Mat<f64>, mut lu: Vec<f64>, mut piv: Vec<usize>) -> Self {
        let n = c.nrows();
        assert!(n <= M && lu.len() == n * n && piv.len() == n, "small_into: {n} nodes, M = {M}");
        let mut a = [[0.0f64; M]; M];
        for (j, col) in a.iter_mut().enumerate().take(n) {
            col[..n].copy_from_slice(c.col_as_slice(j));
        }
        for k in 0..n {
            // Pivot: largest |C(r, k)| for r >= k (the first of equals).
            let mut p = k;
            for r in k + 1..n {
                if a[k][r].abs() > a[k][p].abs() {
                    p = r;
                }
            }
            piv[k] = p;
            if p != k {
                for col in a.iter_mut().take(n) {
                    col.swap(k, p);
                }
            }
            // Multipliers of column k, then the rank-one update of the rest.
            let inv = 1.0 / a[k][k];
            for x in &mut a[k][k + 1..n] {
                *x *= inv;
            }
            let lk = a[k];
            for col in a.iter_mut().take(n).skip(k + 1) {
                let ukj = col[k];
                if ukj != 0.0 {
                    for (x, l) in col[k + 1..n].iter_mut().zip(&lk[k + 1..n]) {
                        *x -= l * ukj;
                    }
                }
            }
        }
        for (j, col) in a.iter().enumerate().take(n) {
            lu[j * n..(j + 1) * n].copy_from_slice(&col[..n]);
        }
        Lu { n, lu, piv, faer: None }
    }

    /// The factors of faer's `P C = L U` in this layout: `L` below and `U` on
    /// and above the diagonal, the row permutation (`(P C)_i = C_{perm(i)}`)
    /// written as the exchanges `piv` of the elimination steps.
    fn from_faer(f: PartialPivLu<f64>) -> Self {
        let n = f.L().nrows();
        let (l, u) = (f.L(), f.U());
        let mut lu = vec![0.0; n * n];
        for (j, col) in lu.chunks_exact_mut(n).enumerate() {
            for (i, (x, (lij, uij))) in
                col.iter_mut().zip(l.col(j).iter().zip(u.col(j).iter())).enumerate()
            {
                *x = if i > j { *lij } else { *uij };
            }
        }
        // Exchanges that bring row perm(k) to position k, step by step:
        // `at[r]` is where original row r sits now, `row[p]` the row at p.
        let perm = f.P().arrays().0;
        let mut at: Vec<usize> = (0..n).collect();
        let mut row: Vec<usize> = (0..n).collect();
        let mut piv = vec![0; n];
        for k in 0..n {
            let p = at[perm[k]];
            piv[k] = p;
            let (rk, rp) = (row[k], row[p]);
            row.swap(k, p);
            at[rk] = p;
            at[rp] = k;
        }
        Lu { n, lu, piv, faer: Some(Box::new(f)) }
    }

    /// `x <- C^-1 x` (faer's in-place solve from `FAER_FROM` (48) nodes on).
    pub fn solve(&self, x: &mut [f64]) {
        let n = self.n;
        if let Some(f) = &self.faer {
            f.solve_in_place(faer::MatMut::from_column_major_slice_mut(x, n, 1));
            return;
        }
        for k in 0..n {
            x.swap(k, self.piv[k]);
        }
        // L y = P b (unit diagonal), by columns.
        for k in 0..n {
            let xk = x[k];
            if xk != 0.0 {
                for (xi, l) in x[k + 1..].iter_mut().zip(&self.lu[k * n + k + 1..(k + 1) * n]) {
                    *xi -= l * xk;
                }
            }
        }
        // U x = y, by columns from the last.
        for k in (0..n).rev() {
            let xk = x[k] / self.lu[k * n + k];
            x[k] = xk;
            for (xi, u) in x[..k].iter_mut().zip(&self.lu[k * n..k * n + k]) {
                *xi -= u * xk;
            }
        }
    }

    /// `Y <- C^-T Y` for `m` right-hand sides at once, `y` row-major `n x m`
    /// (`y[i * m + r]`: component `i` of right-hand side `r`): `U^T Z = B`,
    /// then `L^T W = Z`, then `Y = P^T W`, with the right-hand sides
    /// innermost, so each step is a contiguous `axpy` over them (a probe row
    /// per distinct exit cosine, or a node row per column of `R` and `T`, in
    /// one call instead of one solve each; `m = 1` is the single solve).
    pub fn solve_transpose_rows(&self, y: &mut [f64], m: usize) {
        let n = self.n;
        debug_assert_eq!(y.len(), n * m);
        if m == 0 {
            return;
        }
        if let Some(f) = &self.faer {
            f.solve_transpose_in_place(faer::MatMut::from_row_major_slice_mut(y, n, m));
            return;
        }
        // U^T Z = B: row k of Z is (row k of B - sum_{j<k} U_jk Z_j) / U_kk.
        for k in 0..n {
            let (done, rest) = y.split_at_mut(k * m);
            let yk = &mut rest[..m];
            for (j, u) in self.lu[k * n..k * n + k].iter().enumerate() {
                if *u != 0.0 {
                    for (a, b) in yk.iter_mut().zip(&done[j * m..(j + 1) * m]) {
                        *a -= u * b;
                    }
                }
            }
            let inv = 1.0 / self.lu[k * n + k];
            yk.iter_mut().for_each(|a| *a *= inv);
        }
        // L^T W = Z (unit diagonal): row k -= sum_{j>k} L_jk W_j, from the last.
        for k in (0..n).rev() {
            let (head, tail) = y.split_at_mut((k + 1) * m);
            let yk = &mut head[k * m..];
            for (j, l) in self.lu[k * n + k + 1..(k + 1) * n].iter().enumerate() {
                if *l != 0.0 {
                    for (a, b) in yk.iter_mut().zip(&tail[j * m..(j + 1) * m]) {
                        *a -= l * b;
                    }
                }
            }
        }
        // Y = P^T W: undo the row exchanges in reverse order.
        for k in (0..n).rev() {
            let p = self.piv[k];
            if p != k {
                let (lo, hi) = (k.min(p), k.max(p));
                let (a, b) = y.split_at_mut(hi * m);
                a[lo * m..(lo + 1) * m].swap_with_slice(&mut b[..m]);
            }
        }
    }

    /// `X <- X C^-1` for an `n x n` block `X`, column-major (`x[j * n + i]`),
    /// by whole columns (contiguous updates): with `C = P^T L U`, first
    /// `W U = X` (columns left to right), then `Y L = W` (right to left),
    /// then `X = Y P` (the column exchanges in reverse order).
    pub fn right_solve(&self, x: &mut [f64]) {
        let n = self.n;
        // W U = B: W_j = (B_j - sum_{k<j} U_kj W_k) / U_jj.
        for j in 0..n {
            let (done, rest) = x.split_at_mut(j * n);
            let xj = &mut rest[..n];
            let uj = &self.lu[j * n..(j + 1) * n];
            for (k, wk) in done.chunks_exact(n).enumerate() {
                let u = uj[k];
                if u != 0.0 {
                    for (a, b) in xj.iter_mut().zip(wk) {
                        *a -= u * b;
                    }
                }
            }
            let inv = 1.0 / uj[j];
            xj.iter_mut().for_each(|a| *a *= inv);
        }
        // Y L = W (unit diagonal): Y_j = W_j - sum_{k>j} L_kj Y_k.
        for j in (0..n).rev() {
            let (head, done) = x.split_at_mut((j + 1) * n);
            let yj = &mut head[j * n..];
            let lj = &self.lu[j * n..(j + 1) * n];
            for (k, yk) in done.chunks_exact(n).enumerate() {
                let l = lj[j + 1 + k];
                if l != 0.0 {
                    for (a, b) in yj.iter_mut().zip(yk) {
                        *a -= l * b;
                    }
                }
            }
        }
        // X = Y P: exchange columns k and piv[k], last step first.
        for k in (0..n).rev() {
            let p = self.piv[k];
            if p != k {
                let (lo, hi) = x.split_at_mut(p * n);
                lo[k * n..(k + 1) * n].swap_with_slice(&mut hi[..n]);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `C x = b` and `C^T x = b` by the factors (hand-written below 48 nodes,
    /// faer's from 48 on) give back `b` when multiplied out: residuals at the
    /// backward error of a pivoted LU (a few hundred ulps here).
    #[test]
    fn vector_solves_invert_on_both_sides_of_the_switch() {
        for n in [3usize, 32, 47, 48, 64] {
            let mut s = 777u64 + n as u64;
            let mut rnd = move || {
                s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                ((s >> 11) as f64) / ((1u64 << 53) as f64) - 0.5
            };
            let c = Mat::from_fn(n, n, |i, j| if i == j { 1e-3 * rnd() } else { rnd() });
            let b: Vec<f64> = (0..n).map(|_| rnd()).collect();
            let lu = Lu::new(&c);
            let (mut x, mut y) = (b.clone(), b.clone());
            lu.solve(&mut x);
            lu.solve_transpose_rows(&mut y, 1);
            for i in 0..n {
                let cx: f64 = (0..n).map(|j| c[(i, j)] * x[j]).sum();
                let cty: f64 = (0..n).map(|j| c[(j, i)] * y[j]).sum();
                assert!((cx - b[i]).abs() < 1e-11, "n = {n}, row {i}: C x");
                assert!((cty - b[i]).abs() < 1e-11, "n = {n}, row {i}: C^T y");
            }
        }
    }

    /// `C^T Y = B` for many right-hand sides at once (row-major) gives back
    /// `B` when multiplied out, and equals the one-at-a-time solve to
    /// rounding, on both sides of the switch to faer's factors.
    #[test]
    fn transposed_solves_of_many_right_hand_sides_invert() {
        for (n, m) in [(3usize, 1usize), (5, 7), (32, 40), (47, 3), (48, 9), (64, 33)] {
            let mut s = 4242u64 + (n * 100 + m) as u64;
            let mut rnd = move || {
                s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                ((s >> 11) as f64) / ((1u64 << 53) as f64) - 0.5
            };
            let c = Mat::from_fn(n, n, |i, j| if i == j { 1e-3 * rnd() } else { rnd() });
            let b: Vec<f64> = (0..n * m).map(|_| rnd()).collect();
            let lu = Lu::new(&c);
            let mut y = b.clone();
            lu.solve_transpose_rows(&mut y, m);
            for r in 0..m {
                // Each right-hand side alone gives the same column.
                let mut one: Vec<f64> = (0..n).map(|i| b[i * m + r]).collect();
                lu.solve_transpose_rows(&mut one, 1);
                for i in 0..n {
                    let cty: f64 = (0..n).map(|j| c[(j, i)] * y[j * m + r]).sum();
                    assert!((cty - b[i * m + r]).abs() < 1e-11, "n = {n}, rhs {r}, row {i}");
                    let scale = one.iter().fold(1.0f64, |a, v| a.max(v.abs()));
                    assert!((one[i] - y[i * m + r]).abs() <= 1e-13 * scale, "n = {n}, rhs {r}");
                }
            }
        }
    }

    /// The elimination on arrays sized to the problem (up to 12 nodes) is
    /// the general one bit for bit: the same pivots and factors, on matrices
    /// that need pivoting (small leading entries), with a pivot tie, zero
    /// multipliers (zeros in column 0) and skipped updates (zeros in row 0).
    #[test]
    fn small_elimination_is_the_general_one_bit_for_bit() {
        for n in 0usize..=12 {
            for case in 0..3 {
                let mut s = 4242u64 + 31 * n as u64 + case;
                let mut rnd = move || {
                    s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                    ((s >> 11) as f64) / ((1u64 << 53) as f64) - 0.5
                };
                let c = Mat::from_fn(n, n, |i, j| match case {
                    0 => rnd(),
                    1 if i == j => 1e-3 * rnd(),
                    // Equal entries (a pivot tie) and zeros in column 0 below
                    // row 1; zeros in row 0 right of column 1 (u_0j = 0).
                    2 if j == 0 => {
                        if i < 2 {
                            0.25
                        } else {
                            0.0
                        }
                    }
                    2 if i == 0 && j >= 2 => 0.0,
                    _ => rnd(),
                });
                let (a, b) = (
                    Lu::hand_written_into(&c, vec![0.0; n * n], vec![0; n]),
                    Lu::general_into(&c, vec![0.0; n * n], vec![0; n]),
                );
                assert_eq!(a.piv, b.piv, "n = {n}, case {case}");
                let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                assert_eq!(bits(&a.lu), bits(&b.lu), "n = {n}, case {case}");
            }
        }
    }

    /// `X = B C^-1` by the LU factors (column updates) and by faer's LU
    /// agree, and `X C` gives back `B`: a matrix that needs pivoting (zero
    /// and small leading entries) at sizes on both sides of the switch.
    #[test]
    fn right_solve_inverts_from_the_right() {
        for n in [1usize, 2, 5, 17, 32, 47, 48, 64] {
            let mut s = 12345u64 + n as u64;
            let mut rnd = move || {
                s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                ((s >> 11) as f64) / ((1u64 << 53) as f64) - 0.5
            };
            let c = Mat::from_fn(n, n, |i, j| if i == j { 1e-3 * rnd() } else { rnd() });
            let b = Mat::from_fn(n, n, |_, _| rnd());
            let lu = Lu::new(&c);
            let x = solve_right(&lu, &c, &b);
            let xm = Mat::from_fn(n, n, |i, j| x[j * n + i]);
            let back = &xm * &c;
            let reference = c.partial_piv_lu().solve_transpose(b.transpose());
            for j in 0..n {
                for i in 0..n {
                    // Backward error of a pivoted LU: a few hundred ulps here.
                    assert!((back[(i, j)] - b[(i, j)]).abs() < 1e-11, "n = {n}");
                    let r = reference[(j, i)];
                    assert!((xm[(i, j)] - r).abs() < 1e-9 * (1.0 + r.abs()), "n = {n}");
                }
            }
        }
    }
}
