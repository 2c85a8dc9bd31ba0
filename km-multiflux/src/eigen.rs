//! The eigen-solution of a homogeneous slab (seed eq. 18–19) in the
//! half-size symmetric form shared by both discretisations.
//!
//! The discrete radiative transfer equation of a homogeneous medium (seed
//! eq. 18) couples the down- and up-going radiances `I+`, `I-` by
//! `d/dz [I+; I-] = [[-alpha, beta], [-beta, alpha]] [I+; I-]`. Its
//! eigenvalues come in pairs `±k` (seed eq. 19); with `v = g+ + g-` the
//! decaying mode `g± e^{-k z}` satisfies the half-size problem
//! `(alpha + beta)(alpha - beta) v = k^2 v`, `g+ - g- = k z`,
//! `z = (alpha + beta)^-1 v` (Stamnes & Swanson 1981). Each discretisation
//! scales its operators to the symmetric `H+ = T (alpha + beta) T^-1`,
//! `H- = T (alpha - beta) T^-1` (`T = diag(sqrt(w mu))`): the Fourier–Gauss
//! slab (docs/multiflux.md eq. 9) and the direction set (docs eq. DS7). With
//! the Cholesky factor `H+ = L L^T` the problem becomes
//!
//! ```text
//!   L^T H- L y = k^2 y,   v~ = L y,   z~ = L^-T y                             (EG1)
//! ```
//!
//! with `y` orthonormal, solved here once for both: `N x N` symmetric
//! instead of `2N x 2N` general. The callers build `H±` and map `v~`, `z~`
//! back to radiances (`T^-1`). Up to 64 nodes by plain loops (cyclic
//! Jacobi up to 6, Householder tridiagonalisation and implicit QL above: on
//! fixed-size arrays up to 12, on flat buffers with the nodes ordered by the
//! diagonal of `S` from 13, on one medium's nodes), from there on and for
//! the nodes of a refracting layer by faer's routines (docs/multiflux.md
//! §9 (iv), (vi)).

use faer::dyn_stack::StackReq;
use faer::linalg::cholesky::llt::factor::{cholesky_in_place, cholesky_in_place_scratch};
use faer::linalg::evd::{ComputeEigenvectors, self_adjoint_evd, self_adjoint_evd_scratch};
use faer::linalg::matmul::matmul;
use faer::linalg::triangular_solve::solve_upper_triangular_in_place;
use faer::{Accum, Mat, Par};

use crate::symmetric_eigen::{jacobi, tridiagonal_ql, tridiagonal_ql_flat};
use crate::workspace::Workspace;

/// The modes of eq. EG1 in the scaled coordinates: decay constants `k_j >= 0`
/// ascending, and the columns `v~_j = L y_j`, `z~_j = L^-T y_j`.
pub struct HalfSizeModes {
    /// Decay constants `k_j = sqrt(max(k_j^2, 0))`, ascending.
    pub k: Vec<f64>,
    /// `v~ = L Y` (columns per mode).
    pub v: Mat<f64>,
    /// `z~ = L^-T Y = H+^-1 v~` (columns per mode).
    pub z: Mat<f64>,
}

/// Which step of eq. EG1 failed.
#[derive(Debug, Clone, PartialEq)]
pub enum EigenFailure {
    /// `H+` is not numerically positive definite.
    Cholesky(String),
    /// The symmetric eigen-solver did not converge.
    Eigen(String),
}

/// Solve eq. EG1 for the symmetric `H+` (positive definite) and `H-`
/// (`N x N`; the lower triangles are read). `conservative` marks a system
/// whose smallest eigenvalue is exactly 0 (conservative scattering with a
/// renormalised phase matrix: the isotropic radiance is a null mode):
/// rounding would leave `k_0 ~ 1e-8`, which matters at `tau ~ 1e4`, so it is
/// set to 0.
///
/// # Reference
/// Seed 000 eq. 18–19; Stamnes & Swanson (1981); docs/multiflux.md eq. 8–9,
/// docs/multiflux-direction-set.md eq. DS6–DS7.
///
/// # Errors
/// [`EigenFailure`] naming the failed step (the callers add the layer's
/// parameters).
///
/// ```
/// use faer::Mat;
/// use km_multiflux::eigen::half_size_modes;
/// // H+ = I, H- = diag(4, 1): k = (1, 2), z~ = v~ (L = I).
/// let hp = Mat::<f64>::identity(2, 2);
/// let hm = Mat::from_fn(2, 2, |i, j| if i == j { [4.0, 1.0][i] } else { 0.0 });
/// let m = half_size_modes(&hp, &hm, false).unwrap();
/// assert!((m.k[0] - 1.0).abs() < 1e-15 && (m.k[1] - 2.0).abs() < 1e-15);
/// ```
pub fn half_size_modes(
    hp: &Mat<f64>,
    hm: &Mat<f64>,
    conservative: bool,
) -> Result<HalfSizeModes, EigenFailure> {
    half_size_modes_in(hp, hm, (conservative, true), &mut Workspace::default())
}

/// [`half_size_modes`] with its matrices, vectors and faer's scratch taken
/// from `ws` (the per-order loop of a solve allocates nothing here once the
/// workspace is warm). The columns `v`, `z` and `k` are the workspace's: the
/// caller hands them back ([`Workspace::give_mat`], [`Workspace::give`]).
/// The steps are those of faer's `Mat::llt`, `Mat::self_adjoint_eigen` and
/// `*` (the same low-level routines, default parameters, `Par::Seq`), so
/// the result is the same bit for bit.
///
/// `one_medium` says that the nodes are one medium's cosines (ascending);
/// from `SMALL + 1` to [`OWN_MAX`] nodes only those are solved by
/// [`small_modes`] (up to [`SMALL_ONE_MEDIUM`]) and [`ql_modes`], the nodes of a refracting layer (the refracted ones of the
/// medium above, then its own) by faer's routines. Both are backward
/// stable, but in a nearly conservative refracting layer tens of optical
/// depths thick the smallest `k` carries the rounding of the whole `S`,
/// amplified by `e^{-k tau}`, and the outputs of such layers stored before
/// the own solver existed (the marble half-space, paint over primer of
/// examples/) were made by faer's path: QL moved them by 3.1e-12 and
/// 5.8e-12 (towards Jacobi rotations' values, but not the same numbers).
pub(crate) fn half_size_modes_in(
    hp: &Mat<f64>,
    hm: &Mat<f64>,
    (conservative, one_medium): (bool, bool),
    ws: &mut Workspace,
) -> Result<HalfSizeModes, EigenFailure> {
    let n = hp.nrows();
    if n <= SMALL || (n <= SMALL_ONE_MEDIUM && one_medium) {
        return small_modes(hp, hm, conservative, ws);
    }
    if n <= OWN_MAX && one_medium {
        return ql_modes(hp, hm, conservative, ws);
    }
    let par = Par::Seq;
    let req = StackReq::any_of(&[
        cholesky_in_place_scratch::<f64>(n, par, Default::default()),
        self_adjoint_evd_scratch::<f64>(n, ComputeEigenvectors::Yes, par, Default::default()),
    ]);
    // H+ = L L^T: the lower triangle of H+, factored in place; the strict
    // upper triangle stays zero (the workspace matrix is zero-filled).
    let mut lf = ws.take_mat(n, n);
    lf.copy_from_triangular_lower(hp);
    if let Err(e) =
        cholesky_in_place(lf.as_mut(), Default::default(), par, ws.stack(req), Default::default())
    {
        ws.give_mat(lf);
        return Err(EigenFailure::Cholesky(format!("{e:?}")));
    }
    for j in 1..n {
        lf.col_as_slice_mut(j)[..j].fill(0.0);
    }
    // L^T H- L y = k^2 y (eq. EG1).
    let mut hl = ws.take_mat(n, n);
    matmul(hl.as_mut(), Accum::Replace, hm.as_ref(), lf.as_ref(), 1.0, par);
    let mut sym = ws.take_mat(n, n);
    matmul(sym.as_mut(), Accum::Replace, lf.transpose(), hl.as_ref(), 1.0, par);
    let mut s = ws.take_mat(n, 1);
    let mut y = ws.take_mat(n, n);
    let evd = self_adjoint_evd(
        sym.as_ref(),
        s.col_mut(0).as_diagonal_mut(),
        Some(y.as_mut()),
        par,
        ws.stack(req),
        Default::default(),
    );
    ws.give_mat(hl);
    ws.give_mat(sym);
    if let Err(e) = evd {
        for m in [lf, s, y] {
            ws.give_mat(m);
        }
        return Err(EigenFailure::Eigen(format!("{e:?}")));
    }
    // k^2 >= 0 in exact arithmetic: clamp rounding.
    let mut k = ws.take(n);
    for (kj, &sj) in k.iter_mut().zip(s.col_as_slice(0)) {
        *kj = sj.max(0.0).sqrt();
    }
    ws.give_mat(s);
    if conservative && n > 0 {
        k[0] = 0.0;
    }
    let mut v = ws.take_mat(n, n);
    matmul(v.as_mut(), Accum::Replace, lf.as_ref(), y.as_ref(), 1.0, par);
    // z~ = H+^-1 v~ = L^-T y: one triangular solve.
    let mut z = y;
    solve_upper_triangular_in_place(lf.transpose(), z.as_mut(), par);
    ws.give_mat(lf);
    Ok(HalfSizeModes { k, v, z })
}

/// Up to this size eq. EG1 is solved by the own loops ([`small_modes`],
/// [`ql_modes`]) instead of faer's blocked routines, whose fixed cost
/// dominates a small problem and whose vector loops slow down at sizes
/// that are not multiples of their blocks (docs/multiflux.md §9 (vi): the
/// 30-direction BRDF at 17 nodes cost as much as at 24 before). The cost
/// of the own path rises smoothly with the size; faer's blocking pays from
/// about this size on.
pub(crate) const OWN_MAX: usize = 64;

/// Up to this size eq. EG1 is solved on fixed-size arrays ([`small_modes`]:
/// with the loops' bounds known the compiler unrolls them; the same steps on
/// flat buffers took about 40 % more instructions at 12 nodes), above it by
/// [`ql_modes`].
pub(crate) const SMALL: usize = 12;

/// Up to this size one medium's nodes (ascending cosines) take the
/// fixed-size arrays of [`small_modes`] too, where [`ql_modes`] took the
/// same steps on flat buffers: 8.7 % fewer instructions for the
/// 30-direction BRDF at 13 nodes, 6.3 % at 16, the step from 12 to 13
/// nodes +28 % instead of +41 % (about the `(13/12)^3` of the work); from
/// 17 nodes on the arrays gain nothing (20 nodes: -0.8 %, 24: +2.2 %;
/// docs/multiflux.md §9 (vii)). The outputs move by rounding only (the
/// BRDFs of the g = 0.9 slab by at most 1.8e-15, 1.1e-13 of the largest;
/// the totals not at all). A refracting layer's nodes keep faer's path
/// above `SMALL` (see [`half_size_modes_in`]).
pub(crate) const SMALL_ONE_MEDIUM: usize = 16;

/// Up to this size the symmetric eigenproblem of [`small_modes`] is solved
/// by Jacobi rotations, above it by tridiagonal QL (faster from 5 on: the
/// totals of one slab at 5 and 6 streams took 4.4 and 5.3 us by QL against
/// 4.9 and 6.4 us by Jacobi, where 7 took 6.2; docs/benchmarks.md §9).
const JACOBI_MAX: usize = 4;

/// Eq. EG1 for `N <= SMALL`: the Cholesky factor of `H+` by the textbook
/// recurrence, `S = L^T H- L` by loops, `S = Y diag(k^2) Y^T` by [`jacobi`]
/// (`N <= JACOBI_MAX`) or [`tridiagonal_ql`], then `v~ = L Y` and
/// `z~ = L^-T Y` by back substitution; modes ascending in `k`.
fn small_modes(
    hp: &Mat<f64>,
    hm: &Mat<f64>,
    conservative: bool,
    ws: &mut Workspace,
) -> Result<HalfSizeModes, EigenFailure> {
    // Arrays sized to the problem (their zeroing and moves are a good part
    // of the cost at these sizes).
    match hp.nrows() {
        0..=3 => small_modes_in::<3>(hp, hm, conservative, ws),
        4..=6 => small_modes_in::<6>(hp, hm, conservative, ws),
        7..=8 => small_modes_in::<8>(hp, hm, conservative, ws),
        9..=SMALL => small_modes_in::<SMALL>(hp, hm, conservative, ws),
        _ => small_modes_in::<SMALL_ONE_MEDIUM>(hp, hm, conservative, ws),
    }
}

/// [`small_modes`] on `M x M` arrays (`N <= M`).
fn small_modes_in<const M: usize>(
    hp: &Mat<f64>,
    hm: &Mat<f64>,
    conservative: bool,
    ws: &mut Workspace,
) -> Result<HalfSizeModes, EigenFailure> {
    let n = hp.nrows();
    // H+ = L L^T (lower triangle of H+).
    let mut l = [[0.0f64; M]; M];
    for j in 0..n {
        let d = hp[(j, j)] - (0..j).map(|k| l[j][k] * l[j][k]).sum::<f64>();
        if !(d > 0.0 && d.is_finite()) {
            return Err(EigenFailure::Cholesky(format!("non-positive pivot {d:e} at {j}")));
        }
        l[j][j] = d.sqrt();
        for i in j + 1..n {
            l[i][j] = (hp[(i, j)] - (0..j).map(|k| l[i][k] * l[j][k]).sum::<f64>()) / l[j][j];
        }
    }
    // S = L^T (H- L), symmetric: the lower triangle, mirrored.
    let mut hl = [[0.0f64; M]; M];
    for i in 0..n {
        for j in 0..n {
            hl[i][j] = (j..n).map(|k| hm[(i, k)] * l[k][j]).sum();
        }
    }
    // QL wants the large entries in the bottom-right corner (Press et al.
    // 2007 §11.4): S's largest are at the smallest cosines, node 0 first, so
    // from 7 nodes on S is written on the reversed node order (row and
    // column i at n - 1 - i) and Y's rows are read back reversed.
    let ql = n > JACOBI_MAX;
    let mut a = [[0.0f64; M]; M];
    for i in 0..n {
        for j in 0..=i {
            let x: f64 = (i..n).map(|k| l[k][i] * hl[k][j]).sum();
            let (r, c) = if ql { (n - 1 - i, n - 1 - j) } else { (i, j) };
            a[r][c] = x;
            a[c][r] = x;
        }
    }
    // Eigenvalues, and the eigenvectors as Y (Jacobi: `y[c][e]` is component
    // c of eigenvector e) or as reversed rows of Y^T (QL: `y[e][n - 1 - c]`).
    let mut y = [[0.0f64; M]; M];
    let lam = if ql { tridiagonal_ql(&mut a, &mut y, n) } else { jacobi(&mut a, &mut y, n) }
        .map_err(|e| EigenFailure::Eigen(e.0))?;
    // Ascending eigenvalues (k^2), clamped at 0 as in the general path.
    let mut order: [usize; M] = std::array::from_fn(|i| i);
    order[..n].sort_by(|&i, &j| lam[i].total_cmp(&lam[j]));
    // Every element of k, v~ and z~ is written below.
    let mut k = ws.take_for_overwrite(n);
    let (mut v, mut z) = (ws.take_mat_for_overwrite(n, n), ws.take_mat_for_overwrite(n, n));
    // Y with its columns in ascending order of k; then v~ = L Y and, by back
    // substitution with L^T (upper triangular), z~ = L^-T Y, row by row with
    // every column at once (independent columns: no chain of dependent
    // roundings through the loop).
    let mut ys = [[0.0f64; M]; M];
    for (c, row) in ys.iter_mut().enumerate().take(n) {
        for (col, &e) in order[..n].iter().enumerate() {
            row[col] = if ql { y[e][n - 1 - c] } else { y[c][e] };
        }
    }
    let mut va = [[0.0f64; M]; M];
    for i in 0..n {
        for c in 0..=i {
            let lic = l[i][c];
            for (x, &yc) in va[i][..n].iter_mut().zip(&ys[c][..n]) {
                *x += lic * yc;
            }
        }
    }
    let mut za = [[0.0f64; M]; M];
    for i in (0..n).rev() {
        let mut row = ys[i];
        for r in i + 1..n {
            let lri = l[r][i];
            for (x, &zr) in row[..n].iter_mut().zip(&za[r][..n]) {
                *x -= lri * zr;
            }
        }
        let inv = 1.0 / l[i][i];
        for (x, &w) in za[i][..n].iter_mut().zip(&row[..n]) {
            *x = w * inv;
        }
    }
    for (col, &e) in order[..n].iter().enumerate() {
        k[col] = lam[e].max(0.0).sqrt();
        let (vc, zc) = (v.col_as_slice_mut(col), z.col_as_slice_mut(col));
        for i in 0..n {
            vc[i] = va[i][col];
        }
        for i in 0..n {
            zc[i] = za[i][col];
        }
    }
    if conservative && n > 0 {
        k[0] = 0.0;
    }
    Ok(HalfSizeModes { k, v, z })
}

/// Eq. EG1 for `SMALL_ONE_MEDIUM < N <= OWN_MAX` (one medium's nodes) by plain loops on flat
/// row-major buffers of the workspace (the steps and the order of every sum
/// as in [`small_modes_in`], each loop arranged to run along rows): the
/// Cholesky factor of `H+`, `H- L` and `S = L^T (H- L)` (written on the
/// reversed node order, for QL), [`tridiagonal_ql_flat`], then `v~ = L Y`
/// and `z~ = L^-T Y`; modes ascending in `k`.
fn ql_modes(
    hp: &Mat<f64>,
    hm: &Mat<f64>,
    conservative: bool,
    ws: &mut Workspace,
) -> Result<HalfSizeModes, EigenFailure> {
    let n = hp.nrows();
    let nn = n * n;
    // Every element that is read is written first (L: its lower triangle;
    // the others in full); `va` accumulates (zeroed).
    let mut l = ws.take_for_overwrite(nn);
    let mut hl = ws.take_for_overwrite(nn);
    let mut a = ws.take_for_overwrite(nn);
    let mut y = ws.take_for_overwrite(nn);
    let mut sc = ws.take_for_overwrite(3 * n);
    let (mut pos, mut order) = (ws.take_idx(n), ws.take_idx(n));
    let result =
        ql_modes_in(hp, hm, [&mut l, &mut hl, &mut a, &mut y], &mut sc, [&mut pos, &mut order], n);
    let out = result.map(|()| {
        // `y` holds Y on the reversed order (rows = eigenvectors), `sc[..n]`
        // the eigenvalues. Ascending eigenvalues (k^2), clamped at 0.
        let lam = &sc[..n];
        for (i, o) in order.iter_mut().enumerate() {
            *o = i;
        }
        order.sort_by(|&i, &j| lam[i].total_cmp(&lam[j]));
        // Y with its columns in ascending order of k, row-major, into `a`.
        for c in 0..n {
            let row = &mut a[c * n..(c + 1) * n];
            for (x, &e) in row.iter_mut().zip(order.iter()) {
                *x = y[e * n + pos[c]];
            }
        }
        // v~ = L Y (rows of Y scaled and summed, into `hl` zeroed).
        hl.fill(0.0);
        for i in 0..n {
            let (ys, va) = (&a[..(i + 1) * n], &mut hl[i * n..(i + 1) * n]);
            for c in 0..=i {
                let lic = l[i * n + c];
                for (x, &yc) in va.iter_mut().zip(&ys[c * n..(c + 1) * n]) {
                    *x += lic * yc;
                }
            }
        }
        // z~ = L^-T Y by back substitution, row by row with every column at
        // once (into `y`).
        for i in (0..n).rev() {
            let (head, done) = y.split_at_mut((i + 1) * n);
            let row = &mut head[i * n..];
            row.copy_from_slice(&a[i * n..(i + 1) * n]);
            for r in i + 1..n {
                let lri = l[r * n + i];
                for (x, &zr) in row.iter_mut().zip(&done[(r - i - 1) * n..(r - i) * n]) {
                    *x -= lri * zr;
                }
            }
            let inv = 1.0 / l[i * n + i];
            row.iter_mut().for_each(|x| *x *= inv);
        }
        let mut k = ws.take_for_overwrite(n);
        let (mut v, mut z) = (ws.take_mat_for_overwrite(n, n), ws.take_mat_for_overwrite(n, n));
        for (col, &e) in order.iter().enumerate() {
            k[col] = lam[e].max(0.0).sqrt();
            let (vc, zc) = (v.col_as_slice_mut(col), z.col_as_slice_mut(col));
            for i in 0..n {
                vc[i] = hl[i * n + col];
                zc[i] = y[i * n + col];
            }
        }
        if conservative && n > 0 {
            k[0] = 0.0;
        }
        HalfSizeModes { k, v, z }
    });
    ws.give_idx(order);
    ws.give_idx(pos);
    for b in [l, hl, a, y, sc] {
        ws.give(b);
    }
    out
}

/// The steps of [`ql_modes`] up to the eigen-solve: `L` (rows `l[i * n..]`,
/// lower triangle), `H- L` in `hl`, `S` on the reversed order in `a`, then
/// [`tridiagonal_ql_flat`] (eigenvectors as the rows of `y`, eigenvalues in
/// `sc[..n]`, `sc` holding `3 n` values).
fn ql_modes_in(
    hp: &Mat<f64>,
    hm: &Mat<f64>,
    [l, hl, a, y]: [&mut [f64]; 4],
    sc: &mut [f64],
    [pos, order]: [&mut [usize]; 2],
    n: usize,
) -> Result<(), EigenFailure> {
    // H+ = L L^T (lower triangle of H+).
    for j in 0..n {
        let d = hp[(j, j)] - l[j * n..j * n + j].iter().map(|x| x * x).sum::<f64>();
        if !(d > 0.0 && d.is_finite()) {
            return Err(EigenFailure::Cholesky(format!("non-positive pivot {d:e} at {j}")));
        }
        let ljj = d.sqrt();
        l[j * n + j] = ljj;
        // Rows below j: the sums over the rows' slices (no index checks).
        let (upper, lower) = l.split_at_mut((j + 1) * n);
        let lj = &upper[j * n..j * n + j];
        for (r, row) in lower.chunks_exact_mut(n).enumerate() {
            let s: f64 = row[..j].iter().zip(lj).map(|(a, b)| a * b).sum();
            row[j] = (hp[(j + 1 + r, j)] - s) / ljj;
        }
    }
    // H- L: row i is sum_k hm_ik L_k. over k ascending (L_kj = 0 for j > k).
    for i in 0..n {
        let row = &mut hl[i * n..(i + 1) * n];
        row.fill(-0.0);
        for k in 0..n {
            let h = hm[(i, k)];
            for (x, &lkj) in row[..=k].iter_mut().zip(&l[k * n..k * n + k + 1]) {
                *x += h * lkj;
            }
        }
    }
    // S = L^T (H- L), lower triangle by rows, mirrored (into `y`, free
    // until the eigen-solve).
    let (d, rest) = sc.split_at_mut(n);
    let (e, acc) = rest.split_at_mut(n);
    for i in 0..n {
        let acc = &mut acc[..=i];
        acc.fill(-0.0);
        for k in i..n {
            let lki = l[k * n + i];
            for (x, &h) in acc.iter_mut().zip(&hl[k * n..k * n + i + 1]) {
                *x += lki * h;
            }
        }
        for (j, &x) in acc.iter().enumerate() {
            y[i * n + j] = x;
            y[j * n + i] = x;
        }
    }
    // QL keeps its accuracy when the large entries sit in the bottom-right
    // corner (Press et al. 2007 §11.4): the nodes in ascending order of
    // `S_ii` (ties: the later node first), so that the largest, at the
    // smallest cosines, come last. On one medium's Gauss nodes (cosines
    // ascending) this is the reversed node order; in a refracting layer,
    // whose nodes are the refracted ones of the medium above followed by
    // its own, it is not.
    for (r, o) in order.iter_mut().enumerate() {
        *o = n - 1 - r;
    }
    order.sort_by(|&p, &q| y[p * n + p].total_cmp(&y[q * n + q]));
    for (r, &p) in order.iter().enumerate() {
        pos[p] = r;
    }
    for (r, &p) in order.iter().enumerate() {
        for (c, &q) in order.iter().enumerate() {
            a[r * n + c] = y[p * n + q];
        }
    }
    let res = tridiagonal_ql_flat(a, y, [d, e, acc], n);
    res.map_err(|e| EigenFailure::Eigen(e.0))
}

/// [`ql_modes`] whatever the size and nodes (also those of a refracting
/// layer, which the solver leaves to faer's routines): the reference of
/// QL's accuracy on such nodes in the tests.
#[cfg(test)]
pub(crate) fn ql_modes_any_order(hp: &Mat<f64>, hm: &Mat<f64>) -> HalfSizeModes {
    ql_modes(hp, hm, false, &mut Workspace::default()).unwrap()
}

/// [`small_modes`] whatever the size up to [`SMALL_ONE_MEDIUM`]: the
/// reference of the tests that one medium's nodes take it.
#[cfg(test)]
pub(crate) fn small_modes_any(hp: &Mat<f64>, hm: &Mat<f64>) -> HalfSizeModes {
    small_modes(hp, hm, false, &mut Workspace::default()).unwrap()
}

/// faer's high-level path for eq. EG1 (`Mat::llt`, the `*` products,
/// `Mat::self_adjoint_eigen`, the triangular solve): `(k, v~, z~)`, the
/// reference of the tests of the own small path.
#[cfg(test)]
pub(crate) fn faer_modes(hp: &Mat<f64>, hm: &Mat<f64>) -> (Vec<f64>, Mat<f64>, Mat<f64>) {
    let lf = hp.llt(faer::Side::Lower).unwrap().L().to_owned();
    let sym = lf.transpose() * (hm * &lf);
    let evd = sym.self_adjoint_eigen(faer::Side::Lower).unwrap();
    let y = evd.U().to_owned();
    let v = &lf * &y;
    let mut z = y.clone();
    solve_upper_triangular_in_place(lf.transpose(), z.as_mut(), Par::Seq);
    let k = evd.S().column_vector().iter().map(|s| s.max(0.0).sqrt()).collect();
    (k, v, z)
}

/// The `k` of eq. EG1 by Jacobi rotations on `S = L^T H- L` (the same `L`
/// and `S` as faer's path), ascending: the reference of relative accuracy
/// for the tests of the QL path.
#[cfg(test)]
pub(crate) fn jacobi_k(hp: &Mat<f64>, hm: &Mat<f64>) -> Vec<f64> {
    let n = hp.nrows();
    let lf = hp.llt(faer::Side::Lower).unwrap().L().to_owned();
    let sym = lf.transpose() * (hm * &lf);
    let mut a: Vec<f64> = (0..n * n).map(|x| sym[(x / n, x % n)]).collect();
    let (mut y, mut d) = (vec![0.0; n * n], vec![0.0; n]);
    crate::symmetric_eigen::jacobi_flat(&mut a, &mut y, &mut d, n).unwrap();
    let mut k: Vec<f64> = d.iter().map(|x| x.max(0.0).sqrt()).collect();
    k.sort_by(f64::total_cmp);
    k
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A symmetric positive definite `H+` and a symmetric `H-` of the
    /// slab's shape (diagonal `1/mu` minus a dense symmetric part, on
    /// ascending cosines: the diagonal falls along the nodes, as on one
    /// medium's nodes).
    fn operators(n: usize) -> (Mat<f64>, Mat<f64>) {
        let (hp, hm) = rising_operators(n);
        let r = |m: &Mat<f64>| Mat::from_fn(n, n, |i, j| m[(n - 1 - i, n - 1 - j)]);
        (r(&hp), r(&hm))
    }

    /// [`operators`] on the reversed node order: the diagonal rises along
    /// the nodes, as it does not on one medium's nodes.
    fn rising_operators(n: usize) -> (Mat<f64>, Mat<f64>) {
        let s = |i: usize, j: usize, c: f64| 0.3 / (1.0 + (i + j) as f64 + c * (i * j) as f64);
        let hp =
            Mat::from_fn(
                n,
                n,
                |i, j| {
                    if i == j { 2.0 + i as f64 - s(i, j, 0.1) } else { -s(i, j, 0.1) }
                },
            );
        let hm =
            Mat::from_fn(
                n,
                n,
                |i, j| {
                    if i == j { 1.5 + i as f64 - s(i, j, 0.7) } else { -s(i, j, 0.7) }
                },
            );
        (hp, hm)
    }

    /// Hand the modes' vectors and matrices back to `ws`.
    fn give_back(ws: &mut Workspace, m: HalfSizeModes) {
        ws.give(m.k);
        ws.give_mat(m.v);
        ws.give_mat(m.z);
    }

    /// Eq. EG1 for the modes `m`: `H- v~ = k^2 z~` and `H+ z~ = v~`, each
    /// entry to `tol` relative to `1 + |entry|`.
    fn assert_eg1(hp: &Mat<f64>, hm: &Mat<f64>, m: &HalfSizeModes, tol: f64) {
        let n = hp.nrows();
        let (hmv, hpz) = (hm * &m.v, hp * &m.z);
        for j in 0..n {
            for i in 0..n {
                let k2z = m.k[j] * m.k[j] * m.z[(i, j)];
                let r = (hmv[(i, j)] - k2z).abs() / (1.0 + hmv[(i, j)].abs());
                assert!(r < tol, "N = {n}: {r:e} ({i}, {j}) k = {}", m.k[j]);
                assert!((hpz[(i, j)] - m.v[(i, j)]).abs() < tol * (1.0 + m.v[(i, j)].abs()));
            }
        }
    }

    /// Above [`OWN_MAX`], the workspace path gives the same bits as faer's
    /// high-level calls (`Mat::llt`, the `*` products,
    /// `Mat::self_adjoint_eigen`), which it replaces; a warm workspace hands out every matrix, vector and the
    /// scratch without a new allocation; and `k^2`, `v~`, `z~` satisfy eq.
    /// EG1: `H- v~ = k^2 z~` and `H+ z~ = v~` (tolerance: `1e-15 N^2`
    /// relative to `1 + |entry|`, the rounding of `N`-term products with
    /// `k^2` up to ~N^2 here).
    #[test]
    fn workspace_path_is_faers_high_level_path_bit_for_bit() {
        let mut ws = Workspace::default();
        for (pass, n) in [OWN_MAX + 1, OWN_MAX + 2, 80, 96, OWN_MAX + 2].into_iter().enumerate() {
            let (hp, hm) = operators(n);
            let (_, fresh0) = ws.counts();
            let m = half_size_modes_in(&hp, &hm, (false, true), &mut ws).unwrap();
            let (_, fresh1) = ws.counts();
            if pass == 4 {
                // The second solve at OWN_MAX + 2: everything kept from the first.
                assert_eq!(fresh1, fresh0, "a warm eigen-solve takes nothing new");
            }
            // The replaced high-level path.
            let (k, v, z) = faer_modes(&hp, &hm);
            for j in 0..n {
                assert_eq!(m.k[j].to_bits(), k[j].to_bits(), "k_{j}, N = {n}");
                for i in 0..n {
                    assert_eq!(m.v[(i, j)].to_bits(), v[(i, j)].to_bits(), "v, N = {n}");
                    assert_eq!(m.z[(i, j)].to_bits(), z[(i, j)].to_bits(), "z, N = {n}");
                }
            }
            // Rounding grows with N and with k^2 (~N^2 here): 1e-15 N^2.
            assert_eg1(&hp, &hm, &m, 1e-15 * (n * n) as f64);
            give_back(&mut ws, m);
        }
    }

    /// Up to [`OWN_MAX`] (Jacobi to 6 nodes, QL above): the same modes as
    /// faer's path to rounding. `k` to 1e-14 of the largest; each column of
    /// `v~`, `z~` equal up to its sign to 1e-12 of the column's largest entry
    /// (distinct eigenvalues, so the columns are unique up to sign; the
    /// tolerance is a few hundred roundings of N <= 64 products); eq. EG1 to
    /// `1e-15 N^2` (at least 1e-13) and `z~^T v~ = I` (the eigenvectors `y`
    /// orthonormal) to 1e-13. A warm
    /// solve takes nothing new.
    #[test]
    fn small_problems_match_faers_modes() {
        let mut ws = Workspace::default();
        for n in (1..=24).chain([32, 47, 64]) {
            let (hp, hm) = operators(n);
            let m = half_size_modes_in(&hp, &hm, (false, true), &mut ws).unwrap();
            let (k, v, z) = faer_modes(&hp, &hm);
            let kmax = m.k.iter().fold(0.0f64, |a, &b| a.max(b));
            for j in 0..n {
                assert!((m.k[j] - k[j]).abs() <= 1e-14 * kmax, "k_{j}, N = {n}");
                let sign = if m.v[(0, j)] * v[(0, j)] < 0.0 { -1.0 } else { 1.0 };
                let (vs, zs) = (
                    (0..n).map(|i| v[(i, j)].abs()).fold(0.0, f64::max),
                    (0..n).map(|i| z[(i, j)].abs()).fold(0.0, f64::max),
                );
                for i in 0..n {
                    assert!((sign * m.v[(i, j)] - v[(i, j)]).abs() <= 1e-12 * vs, "v, N = {n}");
                    assert!((sign * m.z[(i, j)] - z[(i, j)]).abs() <= 1e-12 * zs, "z, N = {n}");
                }
            }
            // Rounding grows with N and with k^2 (~N^2 here): 1e-15 N^2.
            assert_eg1(&hp, &hm, &m, 1e-15 * (n.max(10) * n.max(10)) as f64);
            let ztv = m.z.transpose() * &m.v;
            for j in 0..n {
                for i in 0..n {
                    let id = if i == j { 1.0 } else { 0.0 };
                    assert!((ztv[(i, j)] - id).abs() < 1e-13, "z~^T v~, N = {n}");
                }
            }
            let (_, fresh0) = ws.counts();
            give_back(&mut ws, m);
            let again = half_size_modes_in(&hp, &hm, (false, true), &mut ws).unwrap();
            assert_eq!(ws.counts().1, fresh0, "a warm small solve takes nothing new");
            give_back(&mut ws, again);
        }
    }

    /// From `SMALL + 1` to [`OWN_MAX`] nodes, where the diagonal of `S` does
    /// not fall along the nodes (a refracting layer's node set), the solve
    /// is faer's: the same bits as its high-level path; a warm solve takes
    /// nothing new.
    #[test]
    fn nodes_of_two_media_keep_faers_modes() {
        let mut ws = Workspace::default();
        for n in [SMALL + 1, 16, 24, 33, OWN_MAX] {
            let (hp, hm) = rising_operators(n);
            let m = half_size_modes_in(&hp, &hm, (false, false), &mut ws).unwrap();
            let (k, v, z) = faer_modes(&hp, &hm);
            for j in 0..n {
                assert_eq!(m.k[j].to_bits(), k[j].to_bits(), "k_{j}, N = {n}");
                for i in 0..n {
                    assert_eq!(m.v[(i, j)].to_bits(), v[(i, j)].to_bits(), "v, N = {n}");
                    assert_eq!(m.z[(i, j)].to_bits(), z[(i, j)].to_bits(), "z, N = {n}");
                }
            }
            let (_, fresh0) = ws.counts();
            give_back(&mut ws, m);
            let again = half_size_modes_in(&hp, &hm, (false, false), &mut ws).unwrap();
            assert_eq!(ws.counts().1, fresh0, "a warm solve takes nothing new, N = {n}");
            give_back(&mut ws, again);
        }
    }

    /// QL on the nodes ordered by the diagonal of `S` against Jacobi
    /// rotations (relative accuracy for small eigenvalues, Demmel & Veselić
    /// 1992) on the same `S`: the slab-shaped operators, a graded problem
    /// and a singular `H-`, N = 7..64: every `k^2` within 1e-14 N of the
    /// largest (the backward-stable bound of both; measured below 1e-15 N).
    #[test]
    fn ql_agrees_with_jacobi() {
        for n in (JACOBI_MAX + 1..=24).chain([33, 48, 64]) {
            let d = |i: usize| 10f64.powf(3.0 - 9.0 * i as f64 / (n - 1) as f64);
            let graded = Mat::from_fn(n, n, |i, j| match () {
                _ if i == j => d(i),
                _ if i + j == n - 1 => 0.15 * (d(i) * d(j)).sqrt(),
                _ => 0.0,
            });
            let (hp, hm) = operators(n);
            for (p, m) in [
                (hp.clone(), hm.clone()),
                (Mat::<f64>::identity(n, n), graded),
                (hp, Mat::from_fn(n, n, |_, _| 1.0)),
            ] {
                let ours = half_size_modes(&p, &m, false).unwrap();
                let k = jacobi_k(&p, &m);
                let top = k.iter().fold(0.0f64, |a, &b| a.max(b * b));
                for j in 0..n {
                    let e = (ours.k[j] * ours.k[j] - k[j] * k[j]).abs() / top;
                    assert!(e <= 1e-14 * n as f64, "N = {n}, k_{j}: {} vs {}", ours.k[j], k[j]);
                }
            }
        }
    }

    /// The own path (Jacobi, QL) converges on singular `H-` with repeated
    /// zero eigenvalues (a rank-one matrix of ones: eigenvalues 0, ..., 0,
    /// N), the shape of conservative scattering's null mode: `k = 0, ...,
    /// 0, sqrt(N)`, a zero `k^2` within the backward-stable bound `10 N eps
    /// max k^2` (so `k <= N sqrt(10 eps)`, about 5e-8 N; measured up to
    /// 1.1e-7 at N = 20, as in the general path).
    #[test]
    fn small_singular_problems_converge() {
        let mut ws = Workspace::default();
        for n in (1..=24).chain([40, 64]) {
            let hp = Mat::<f64>::identity(n, n);
            let hm = Mat::from_fn(n, n, |_, _| 1.0);
            let m = half_size_modes_in(&hp, &hm, (false, true), &mut ws).unwrap();
            for j in 0..n - 1 {
                let bound = n as f64 * (10.0 * f64::EPSILON).sqrt();
                assert!(m.k[j] < bound, "k_{j} = {}, N = {n}", m.k[j]);
            }
            assert!((m.k[n - 1] - (n as f64).sqrt()).abs() < 1e-14, "N = {n}");
        }
    }

    /// A strongly graded `S` (diagonal from 1e3 at node 0 down to 1e-6 at
    /// the last, as at the smallest cosines of a near-conservative layer):
    /// node `i` coupled to node `n - 1 - i` only (`s = 0.15 sqrt(s_ii s_jj)`),
    /// so that the eigenvalues are those of 2 x 2 blocks, `lam+ = (a + c)/2 +
    /// sqrt(((a - c)/2)^2 + b^2)` and `lam- = (a c - b^2) / lam+` (no
    /// cancellation beyond 2 %). Jacobi (up to `JACOBI_MAX`): each `k` within
    /// 1e-14 relative, the relative accuracy of its stopping rule (measured:
    /// 2e-16; faer's path misses the smallest `k` by up to 4e-9 here). QL:
    /// each `k^2` within the backward-stable bound `10 N eps max k^2` (as
    /// faer's path: measured errors equal to faer's to two digits).
    #[test]
    fn graded_problems_keep_their_small_eigenvalues() {
        let mut ws = Workspace::default();
        for n in (2..=24).chain([40, 64]) {
            let d = |i: usize| 10f64.powf(3.0 - 9.0 * i as f64 / (n - 1) as f64);
            let hp = Mat::<f64>::identity(n, n);
            let hm = Mat::from_fn(n, n, |i, j| match () {
                _ if i == j => d(i),
                _ if i + j == n - 1 => 0.15 * (d(i) * d(j)).sqrt(),
                _ => 0.0,
            });
            let mut exact = Vec::new();
            for i in 0..n / 2 {
                let (a, c, b) = (d(i), d(n - 1 - i), hm[(i, n - 1 - i)]);
                let big = 0.5 * (a + c) + (0.25 * (a - c) * (a - c) + b * b).sqrt();
                exact.extend([big, (a * c - b * b) / big]);
            }
            if n % 2 == 1 {
                exact.push(d(n / 2));
            }
            exact.sort_by(f64::total_cmp);
            let m = half_size_modes_in(&hp, &hm, (false, true), &mut ws).unwrap();
            let top = exact[n - 1];
            for j in 0..n {
                let kj = exact[j].sqrt();
                if n <= JACOBI_MAX {
                    assert!(
                        (m.k[j] - kj).abs() <= 1e-14 * kj,
                        "k_{j} = {} vs {kj}, N = {n}",
                        m.k[j]
                    );
                } else {
                    let dk2 = (m.k[j] * m.k[j] - exact[j]).abs();
                    assert!(dk2 <= 10.0 * n as f64 * f64::EPSILON * top, "k_{j}^2 off by {dk2:e}");
                }
            }
        }
    }

    /// A non-positive-definite `H+` is refused by name (both paths), and
    /// the workspace gets its matrices back.
    #[test]
    fn indefinite_h_plus_is_refused() {
        for n in [2, 9, OWN_MAX + 2] {
            let mut ws = Workspace::default();
            let hp = Mat::from_fn(n, n, |i, j| if i == j { [1.0, -1.0][i % 2] } else { 0.0 });
            let hm = Mat::<f64>::identity(n, n);
            let e = half_size_modes_in(&hp, &hm, (false, true), &mut ws).err();
            assert!(matches!(e, Some(EigenFailure::Cholesky(_))), "N = {n}");
            if n > OWN_MAX {
                let (_, fresh) = ws.counts();
                let _ = ws.take_mat(n, n);
                assert_eq!(ws.counts().1, fresh, "the factor's matrix is handed back");
            }
        }
    }
}
