//! The phase matrix of each discretisation, built in one place, and its one
//! renormalisation.
//!
//! Both discretisations split the discrete phase function into the block
//! between directions of the same hemisphere and the block between a
//! direction and the mirror images of the others:
//!
//! * **Fourier–Gauss** ([`fourier_blocks`]): for Fourier order `m` on Gauss
//!   nodes `mu_i`, the addition theorem (eq. L1–L2 of [`crate::legendre`])
//!   gives `P(mu_i, mu_j) ± P(mu_i, -mu_j) = sum_l c_l Lambda_l^m(mu_i) Lambda_l^m(mu_j)`
//!   over the `l + m` even (odd) degrees, `c_l = (2l+1) chi_l`
//!   (docs/multiflux.md §2–3).
//! * **Direction set** ([`direction_blocks`]): the phase function between
//!   directions, `p++_ij = p(s_i . s_j)`, `p+-_ij = p(s_i . s'_j)` (`s'` the
//!   mirror image), on the sphere or the circle (docs/multiflux-direction-set.md §3).
//!
//! A finite quadrature does not integrate the phase function exactly, so
//! neither block pair conserves energy by itself. Both are rescaled
//! symmetrically by [`symmetric_scaling`] (docs/multiflux-direction-set.md eq. DS3):
//!
//! ```text
//!   P_ij = d_i d_j p_ij w_j,   sum_j d_i d_j k_ij w_j = 1,   k = p++ + p+-      (PM1)
//!   d_i <- d_i / sqrt(d_i sum_j k_ij w_j d_j)                                   (PM2)
//! ```
//!
//! the symmetric Sinkhorn–Knopp iteration (Sinkhorn & Knopp 1967; Knight
//! 2008). `d_i d_j k_ij` stays symmetric, so `w_i P_ij = w_j P_ji`
//! (reciprocity) is kept; scaling rows alone would conserve energy but break
//! reciprocity. The Fourier–Gauss blocks need it only for `m = 0` (energy is
//! carried by the azimuthal mean).

use faer::linalg::matmul::matmul;
use faer::{Accum, Mat, Par};

use crate::MultifluxError;
use crate::workspace::Workspace;

/// Rounding level of a row sum: below it the scaling stops at once.
const ROUNDING: f64 = 1e-15;
/// A scaling is accepted once the worst row error is below this and has
/// stopped halving for [`STALL`] iterations (linear convergence ends at
/// rounding level, a few ulps of `n` terms).
const ACCEPTED: f64 = 1e-12;
/// Iterations without halving the best row error that end the iteration.
const STALL: usize = 3;
/// Bound on the iterations (linear convergence; a few dozen suffice for a
/// positive kernel, Knight 2008).
const MAX_ITERATIONS: usize = 5_000;

/// How the iteration PM2 ended.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Outcome {
    /// Every row sums to 1 within [`ACCEPTED`] (at rounding level).
    Converged,
    /// A row of `d_i sum_j k_ij w_j d_j` is not positive (or NaN): a kernel
    /// with negative rows, which no positive `d` can normalise.
    NonPositiveRow {
        /// The row.
        row: usize,
        /// Its sum.
        sum: f64,
    },
    /// [`MAX_ITERATIONS`] did not bring the worst row error below [`ACCEPTED`].
    NotConverged {
        /// The smallest worst row error reached.
        residual: f64,
    },
}

/// The symmetric scaling `d` of eq. PM1 and how its iteration ended: `d` is
/// the last iterate whose row sums were measured (all ones for a kernel that
/// is already normalised to rounding level).
pub(crate) struct Scaling {
    pub(crate) d: Vec<f64>,
    pub(crate) outcome: Outcome,
}

/// The symmetric Sinkhorn–Knopp scaling (eq. PM1–PM2) of the kernel `k`
/// (`n x n`, symmetric up to rounding: row `i` is read) with weights `w > 0`.
///
/// # Reference
/// Sinkhorn & Knopp (1967); Knight (2008) for the symmetric form; docs eq. DS3.
pub(crate) fn symmetric_scaling(k: &Mat<f64>, w: &[f64]) -> Scaling {
    let n = w.len();
    let mut d = vec![1.0; n];
    let mut r = crate::workspace::zeros(n);
    let mut best = f64::INFINITY;
    let mut stall = 0;
    for _ in 0..MAX_ITERATIONS {
        // Row sums r_i = d_i sum_j k_ij w_j d_j, by columns (contiguous).
        r.iter_mut().for_each(|x| *x = 0.0);
        for j in 0..n {
            let f = w[j] * d[j];
            for (ri, kij) in r.iter_mut().zip(k.col_as_slice(j)) {
                *ri += kij * f;
            }
        }
        let mut worst = 0.0f64;
        for i in 0..n {
            r[i] *= d[i];
            if r[i].is_nan() || r[i] <= 0.0 {
                return Scaling { d, outcome: Outcome::NonPositiveRow { row: i, sum: r[i] } };
            }
            worst = worst.max((r[i] - 1.0).abs());
        }
        // Stop at rounding level, or once the error has stopped halving below
        // the accepted level (the iteration converges linearly).
        if worst < ROUNDING {
            return Scaling { d, outcome: Outcome::Converged };
        }
        if worst < 0.5 * best {
            best = worst;
            stall = 0;
        } else {
            stall += 1;
        }
        if best < ACCEPTED && stall >= STALL {
            return Scaling { d, outcome: Outcome::Converged };
        }
        // Eq. PM2.
        for i in 0..n {
            d[i] /= r[i].sqrt();
        }
    }
    Scaling { d, outcome: Outcome::NotConverged { residual: best } }
}

/// [`fourier_blocks_in`] with a workspace of its own.
#[cfg(test)]
pub(crate) fn fourier_blocks(
    w: &[f64],
    m: usize,
    chi: &[f64],
    lam: &[f64],
    n: usize,
) -> (Mat<f64>, Mat<f64>) {
    fourier_blocks_in(w, (m, true), chi, lam, n, &mut Workspace::default())
}

/// The Fourier–Gauss phase blocks of order `m` on `n` nodes with weights `w`:
/// `(P_even, P_odd)` with `P_even ± ... = P(mu_i, mu_j) ± P(mu_i, -mu_j)`, the
/// even and odd (in `l + m`) parts of `sum_l c_l Lambda_l^m(mu_i) Lambda_l^m(mu_j)`
/// (`c_l = (2l+1) chi_l` in `chi`, Legendre table `lam` node-major,
/// `lam[i * L + l]`), for `m = 0` rescaled by [`symmetric_scaling`] so that
/// `sum_j P_even,ij w_j = 1` (energy conservation of the discrete
/// scattering, docs/multiflux.md §2).
///
/// With Gauss nodes the quadrature integrates the truncated phase series
/// exactly, so the scaling only removes rounding; if it cannot proceed (a
/// kernel with a non-positive row) the blocks are used as scaled so far.
///
/// # Reference
/// Stamnes et al. (1988) eq. 2–4 (addition theorem); docs eq. DS3 / PM1.
///
/// Its matrices are taken from `ws` (the two returned blocks are the
/// workspace's: the caller hands them back); the products are those of
/// faer's `*` (`matmul`, replacing, `Par::Seq`), the same bit for bit.
///
/// Up to [`crate::eigen::SMALL`] nodes, and up to [`crate::eigen::OWN_MAX`]
/// on one medium's nodes (`one_medium`: cosines ascending), the sums are
/// taken along rows ([`blocks_by_rows`]); on the nodes of a refracting
/// layer above `SMALL` (the refracted ones of the medium above, then its
/// own) they stay faer's products, as the eigen-solve stays faer's there
/// (`crate::eigen`, `ql_modes`): the other order of the sums moved the
/// stored output of a nearly conservative refracting layer (paint over
/// primer) by 8.5e-12 with faer's eigen-solve.
pub(crate) fn fourier_blocks_in(
    w: &[f64],
    (m, one_medium): (usize, bool),
    chi: &[f64],
    lam: &[f64],
    n: usize,
    ws: &mut Workspace,
) -> (Mat<f64>, Mat<f64>) {
    let rows = n <= crate::eigen::SMALL || (one_medium && n <= crate::eigen::OWN_MAX);
    let (mut pe, mut po) = if rows {
        blocks_by_rows(m, chi, lam, n, ws)
    } else {
        blocks_by_products(m, chi, lam, n, ws)
    };
    if m == 0 {
        rescale_symmetric(&mut pe, &mut po, w);
    }
    (pe, po)
}

/// The unscaled blocks of [`fourier_blocks_in`] for few nodes: the sums
/// directly, once per pair (the blocks are symmetric), without the fixed
/// cost of a general product.
#[cfg(test)]
fn blocks_by_sums(
    m: usize,
    chi: &[f64],
    lam: &[f64],
    n: usize,
    ws: &mut Workspace,
) -> (Mat<f64>, Mat<f64>) {
    let nl = chi.len();
    {
        // Every element is written below (both triangles).
        let (mut pe, mut po) = (ws.take_mat_for_overwrite(n, n), ws.take_mat_for_overwrite(n, n));
        for j in 0..n {
            let lj = &lam[j * nl..(j + 1) * nl];
            for i in 0..=j {
                let li = &lam[i * nl..(i + 1) * nl];
                // The l + m even terms into se, the odd into so (each in order of l).
                let (mut se, mut so) = (0.0, 0.0);
                for l in (m..nl).step_by(2) {
                    se += chi[l] * li[l] * lj[l];
                }
                for l in (m + 1..nl).step_by(2) {
                    so += chi[l] * li[l] * lj[l];
                }
                pe[(i, j)] = se;
                pe[(j, i)] = se;
                po[(i, j)] = so;
                po[(j, i)] = so;
            }
        }
        (pe, po)
    }
}

/// [`blocks_by_sums`] arranged along rows: for each node `i` the weights
/// `chi_l Lambda_l(mu_i)` times the rows `Lambda_l(mu_j)`, `j >= i`, of the
/// transposed table, summed over `l` in the same order, so every element
/// gets the same terms in the same order as there (the same bits), with
/// the loops over `j` vectorised.
fn blocks_by_rows(
    m: usize,
    chi: &[f64],
    lam: &[f64],
    n: usize,
    ws: &mut Workspace,
) -> (Mat<f64>, Mat<f64>) {
    let nl = chi.len();
    // The table transposed: `lt[l * n + j] = Lambda_l(mu_j)`; every element
    // of it and of the weights is written before it is read.
    let mut lt = ws.take_for_overwrite(nl * n);
    for j in 0..n {
        for l in 0..nl {
            lt[l * n + j] = lam[j * nl + l];
        }
    }
    let mut wi = ws.take_for_overwrite(nl);
    let (mut se, mut so) = (ws.take_for_overwrite(n), ws.take_for_overwrite(n));
    // Every element is written below (both triangles).
    let (mut pe, mut po) = (ws.take_mat_for_overwrite(n, n), ws.take_mat_for_overwrite(n, n));
    for i in 0..n {
        for l in m..nl {
            wi[l] = chi[l] * lam[i * nl + l];
        }
        // The l + m even terms into se, the odd into so (each in order of l).
        let (se, so) = (&mut se[i..n], &mut so[i..n]);
        se.fill(0.0);
        so.fill(0.0);
        for (acc, first) in [(&mut *se, m), (&mut *so, m + 1)] {
            for l in (first..nl).step_by(2) {
                let w = wi[l];
                for (x, &t) in acc.iter_mut().zip(&lt[l * n + i..(l + 1) * n]) {
                    *x += w * t;
                }
            }
        }
        for (jj, (&e, &o)) in se.iter().zip(so.iter()).enumerate() {
            let j = i + jj;
            pe[(i, j)] = e;
            pe[(j, i)] = e;
            po[(i, j)] = o;
            po[(j, i)] = o;
        }
    }
    for v in [lt, wi, se, so] {
        ws.give(v);
    }
    (pe, po)
}

/// The unscaled blocks of [`fourier_blocks_in`] as two products (faer's
/// `*`, the same bits as before the sums of [`blocks_by_sums`] existed).
fn blocks_by_products(
    m: usize,
    chi: &[f64],
    lam: &[f64],
    n: usize,
    ws: &mut Workspace,
) -> (Mat<f64>, Mat<f64>) {
    let nl = chi.len();
    // Even and odd (in l + m) parts of the phase matrix: P(mu,mu') ± P(mu,-mu')
    // = sum_l c_l Lambda_l(mu_i) Lambda_l(mu_j), as dot products of rows.
    let mut ae = ws.take_mat(n, nl);
    let mut ao = ws.take_mat(n, nl);
    let mut lt = ws.take_mat(nl, n);
    for i in 0..n {
        let c = lt.col_as_slice_mut(i);
        c.copy_from_slice(&lam[i * nl..(i + 1) * nl]);
    }
    for l in m..nl {
        let (ce, co) = (ae.col_as_slice_mut(l), ao.col_as_slice_mut(l));
        let even = (l + m).is_multiple_of(2);
        for i in 0..n {
            let x = chi[l] * lam[i * nl + l];
            if even { ce[i] = x } else { co[i] = x }
        }
    }
    let (mut pe, mut po) = (ws.take_mat(n, n), ws.take_mat(n, n));
    matmul(pe.as_mut(), Accum::Replace, ae.as_ref(), lt.as_ref(), 1.0, Par::Seq);
    matmul(po.as_mut(), Accum::Replace, ao.as_ref(), lt.as_ref(), 1.0, Par::Seq);
    for a in [ae, ao, lt] {
        ws.give_mat(a);
    }
    (pe, po)
}

/// m = 0: the symmetric rescaling `d_i P_ij d_j` of both parts (eq. PM1).
fn rescale_symmetric(pe: &mut Mat<f64>, po: &mut Mat<f64>, w: &[f64]) {
    let n = w.len();
    let d = symmetric_scaling(pe, w).d;
    for j in 0..n {
        let (ce, co) = (pe.col_as_slice_mut(j), po.col_as_slice_mut(j));
        for i in 0..n {
            ce[i] *= d[i] * d[j];
            co[i] *= d[i] * d[j];
        }
    }
}

/// The direction-set phase blocks `(P++, P+-)` on `n` directions with
/// weights `w` (docs eq. DS3): the raw values `p++_ij = p(cos_same(i, j))`,
/// `p+-_ij = p(cos_mirror(i, j))` (`p` the phase function of the cosine of
/// the scattering angle, `cos_mirror` the cosine between direction `i` and
/// the mirror of `j`), symmetrised and rescaled by [`symmetric_scaling`]:
/// `P_ij = d_i d_j p_ij w_j`, every row of `[P++ P+-]` summing to 1 and
/// `w_i P_ij = w_j P_ji`.
///
/// # Reference
/// Seed 000 eq. 18 (the discrete phase matrix); docs eq. DS3 / PM1.
///
/// # Errors
/// [`MultifluxError::Numerical`] for a kernel the scaling cannot normalise
/// (a non-positive row, or no convergence to 1e-12).
pub(crate) fn direction_blocks(
    w: &[f64],
    cos_same: impl Fn(usize, usize) -> f64,
    cos_mirror: impl Fn(usize, usize) -> f64,
    p: impl Fn(f64) -> f64,
) -> Result<(Mat<f64>, Mat<f64>), MultifluxError> {
    let n = w.len();
    let pp = Mat::from_fn(n, n, |i, j| p(cos_same(i, j)));
    let pm = Mat::from_fn(n, n, |i, j| p(cos_mirror(i, j)));
    // Symmetrised kernel k = p++ + p+- (eq. PM1).
    let k = Mat::from_fn(n, n, |i, j| (pp[(i, j)] + pp[(j, i)] + pm[(i, j)] + pm[(j, i)]) * 0.5);
    let fail = |detail: String| MultifluxError::Numerical { what: "phase renormalisation", detail };
    let d = match symmetric_scaling(&k, w) {
        Scaling { d, outcome: Outcome::Converged } => d,
        Scaling { outcome: Outcome::NonPositiveRow { row, sum }, .. } => {
            return Err(fail(format!("row {row} sums to {sum}")));
        }
        Scaling { outcome: Outcome::NotConverged { residual }, .. } => {
            return Err(fail(format!("row sums off by {residual:e}")));
        }
    };
    let sym = |m: &Mat<f64>, i: usize, j: usize| 0.5 * (m[(i, j)] + m[(j, i)]);
    let pp_out = Mat::from_fn(n, n, |i, j| d[i] * d[j] * sym(&pp, i, j) * w[j]);
    let pm_out = Mat::from_fn(n, n, |i, j| d[i] * d[j] * sym(&pm, i, j) * w[j]);
    Ok((pp_out, pm_out))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A positive symmetric kernel far from normalised: the scaling brings
    /// every row sum to 1 at rounding level (1e-12, the accepted level) and
    /// `d_i k_ij d_j` stays symmetric.
    #[test]
    fn scaling_normalises_rows_and_keeps_symmetry() {
        let n = 7;
        let w: Vec<f64> = (0..n).map(|i| 0.1 + 0.05 * i as f64).collect();
        let k = Mat::from_fn(n, n, |i, j| 1.0 + ((i * j) as f64).sin().abs() + (i + j) as f64);
        let s = symmetric_scaling(&k, &w);
        assert_eq!(s.outcome, Outcome::Converged);
        for i in 0..n {
            let row: f64 = (0..n).map(|j| s.d[i] * s.d[j] * k[(i, j)] * w[j]).sum();
            assert!((row - 1.0).abs() < 1e-12, "row {i}: {row}");
        }
    }

    /// A kernel with a negative row cannot be normalised: reported, not hidden.
    #[test]
    fn negative_rows_are_reported() {
        let k = Mat::from_fn(3, 3, |i, _| if i == 1 { -1.0 } else { 1.0 });
        let s = symmetric_scaling(&k, &[1.0, 1.0, 1.0]);
        assert!(matches!(s.outcome, Outcome::NonPositiveRow { row: 1, .. }));
        assert!(direction_blocks(&[1.0; 3], |_, _| 0.0, |_, _| 0.0, |_| -1.0).is_err());
    }

    /// The Fourier–Gauss blocks of isotropic scattering (`c_0 = 1`) on the
    /// 4-point Gauss rule of `[0, 1]`: `P_even = 1`, so every row sums to the
    /// weights' sum 1, and `P_odd = 0`.
    #[test]
    fn blocks_by_sums_equal_the_products() {
        // Both unscaled routes on the same table, N = 3 and 12, orders 0-5:
        // equal to 1e-15 of the largest entry (sums of a few dozen terms in
        // another order).
        let mut ws = Workspace::default();
        for n in [3usize, 12, 13, 24] {
            let nl = 2 * n;
            let mu: Vec<f64> = km_core::quadrature::gauss_legendre(2 * n)
                .0
                .into_iter()
                .filter(|&x| x > 0.0)
                .collect();
            let chi: Vec<f64> =
                (0..nl).map(|l| (2 * l + 1) as f64 * 0.7f64.powi(l as i32)).collect();
            for m in 0..6 {
                let rec = km_core::legendre::LegendreRecurrence::new(m, nl);
                let mut lam = vec![0.0; n * nl];
                for (i, &x) in mu.iter().enumerate() {
                    rec.eval(x, &mut lam[i * nl..(i + 1) * nl]);
                }
                let (se, so) = blocks_by_sums(m, &chi, &lam, n, &mut ws);
                let (re, ro) = blocks_by_rows(m, &chi, &lam, n, &mut ws);
                for i in 0..n {
                    for j in 0..n {
                        assert_eq!(re[(i, j)].to_bits(), se[(i, j)].to_bits(), "N = {n}, m = {m}");
                        assert_eq!(ro[(i, j)].to_bits(), so[(i, j)].to_bits(), "N = {n}, m = {m}");
                    }
                }
                let (pe, po) = blocks_by_products(m, &chi, &lam, n, &mut ws);
                let top = (0..n)
                    .flat_map(|i| (0..n).map(move |j| (i, j)))
                    .fold(0.0f64, |a, (i, j)| a.max(pe[(i, j)].abs()).max(po[(i, j)].abs()));
                for i in 0..n {
                    for j in 0..n {
                        assert!((se[(i, j)] - pe[(i, j)]).abs() <= 1e-15 * top, "N = {n}, m = {m}");
                        assert!((so[(i, j)] - po[(i, j)]).abs() <= 1e-15 * top, "N = {n}, m = {m}");
                    }
                }
            }
        }
    }

    #[test]
    fn isotropic_fourier_blocks_conserve_energy() {
        let (x, w) = km_core::quadrature::gauss_legendre(4);
        let mu: Vec<f64> = x.iter().map(|x| 0.5 * (x + 1.0)).collect();
        let w: Vec<f64> = w.iter().map(|w| 0.5 * w).collect();
        let lam = crate::legendre::legendre_table(0, &mu, 1);
        let (pe, po) = fourier_blocks(&w, 0, &[1.0], &lam, 4);
        for i in 0..4 {
            let row: f64 = (0..4).map(|j| pe[(i, j)] * w[j]).sum();
            // Weights sum to 1 up to rounding: 4 ulp.
            assert!((row - 1.0).abs() < 1e-15, "row {i}: {row}");
            assert!((0..4).all(|j| po[(i, j)] == 0.0));
        }
    }
}
