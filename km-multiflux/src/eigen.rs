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
//! back to radiances (`T^-1`).

use faer::dyn_stack::StackReq;
use faer::linalg::cholesky::llt::factor::{cholesky_in_place, cholesky_in_place_scratch};
use faer::linalg::evd::{ComputeEigenvectors, self_adjoint_evd, self_adjoint_evd_scratch};
use faer::linalg::matmul::matmul;
use faer::linalg::triangular_solve::solve_upper_triangular_in_place;
use faer::{Accum, Mat, Par};

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
    half_size_modes_in(hp, hm, conservative, &mut Workspace::default())
}

/// [`half_size_modes`] with its matrices, vectors and faer's scratch taken
/// from `ws` (the per-order loop of a solve allocates nothing here once the
/// workspace is warm). The columns `v`, `z` and `k` are the workspace's: the
/// caller hands them back ([`Workspace::give_mat`], [`Workspace::give`]).
/// The steps are those of faer's `Mat::llt`, `Mat::self_adjoint_eigen` and
/// `*` (the same low-level routines, default parameters, `Par::Seq`), so
/// the result is the same bit for bit.
pub(crate) fn half_size_modes_in(
    hp: &Mat<f64>,
    hm: &Mat<f64>,
    conservative: bool,
    ws: &mut Workspace,
) -> Result<HalfSizeModes, EigenFailure> {
    let n = hp.nrows();
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

#[cfg(test)]
mod tests {
    use super::*;
    use faer::Side;

    /// A symmetric positive definite `H+` and a symmetric `H-` of the
    /// slab's shape (diagonal `1/mu` minus a dense symmetric part).
    fn operators(n: usize) -> (Mat<f64>, Mat<f64>) {
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

    /// The workspace path gives the same bits as faer's high-level calls
    /// (`Mat::llt`, the `*` products, `Mat::self_adjoint_eigen`), which it
    /// replaces; a warm workspace hands out every matrix, vector and the
    /// scratch without a new allocation; and `k^2`, `v~`, `z~` satisfy eq.
    /// EG1: `H- v~ = k^2 z~` and `H+ z~ = v~` (tolerance: 1e-12 relative to
    /// the largest entry, a few hundred roundings of `N = 8..24` products).
    #[test]
    fn workspace_path_is_faers_high_level_path_bit_for_bit() {
        let mut ws = Workspace::default();
        for (pass, n) in [1, 3, 8, 24, 8].into_iter().enumerate() {
            let (hp, hm) = operators(n);
            let (_, fresh0) = ws.counts();
            let m = half_size_modes_in(&hp, &hm, false, &mut ws).unwrap();
            let (_, fresh1) = ws.counts();
            if pass == 4 {
                // The second solve at N = 8: everything kept from the first.
                assert_eq!(fresh1, fresh0, "a warm eigen-solve takes nothing new");
            }
            // The replaced high-level path.
            let lf = hp.llt(Side::Lower).unwrap().L().to_owned();
            let sym = lf.transpose() * (&hm * &lf);
            let evd = sym.self_adjoint_eigen(Side::Lower).unwrap();
            let y = evd.U().to_owned();
            let v = &lf * &y;
            let mut z = y.clone();
            solve_upper_triangular_in_place(lf.transpose(), z.as_mut(), Par::Seq);
            for j in 0..n {
                let kj = evd.S().column_vector()[j].max(0.0).sqrt();
                assert_eq!(m.k[j].to_bits(), kj.to_bits(), "k_{j}, N = {n}");
                for i in 0..n {
                    assert_eq!(m.v[(i, j)].to_bits(), v[(i, j)].to_bits(), "v, N = {n}");
                    assert_eq!(m.z[(i, j)].to_bits(), z[(i, j)].to_bits(), "z, N = {n}");
                }
            }
            // Eq. EG1.
            let (hmv, hpz) = (&hm * &m.v, &hp * &m.z);
            for j in 0..n {
                for i in 0..n {
                    let k2z = m.k[j] * m.k[j] * m.z[(i, j)];
                    assert!((hmv[(i, j)] - k2z).abs() < 1e-12 * (1.0 + hmv[(i, j)].abs()));
                    assert!((hpz[(i, j)] - m.v[(i, j)]).abs() < 1e-12 * (1.0 + m.v[(i, j)].abs()));
                }
            }
            ws.give(m.k);
            ws.give_mat(m.v);
            ws.give_mat(m.z);
        }
    }

    /// A non-positive-definite `H+` is refused by name, and the workspace
    /// gets its matrices back.
    #[test]
    fn indefinite_h_plus_is_refused() {
        let mut ws = Workspace::default();
        let hp = Mat::from_fn(2, 2, |i, j| if i == j { [1.0, -1.0][i] } else { 0.0 });
        let hm = Mat::<f64>::identity(2, 2);
        let e = half_size_modes_in(&hp, &hm, false, &mut ws).err();
        assert!(matches!(e, Some(EigenFailure::Cholesky(_))));
        let (_, fresh) = ws.counts();
        let _ = ws.take_mat(2, 2);
        assert_eq!(ws.counts().1, fresh, "the factor's matrix is handed back");
    }
}
