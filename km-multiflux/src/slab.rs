//! One homogeneous layer, one Fourier order: reflection and transmission
//! operators from the half-size eigenproblem, with no growing exponential.
//!
//! Notation (seed 000 eq. 17–20 in discrete-ordinate form; Stamnes & Swanson
//! 1981; Stamnes et al. 1988). `N` nodes `mu_i, w_i` per hemisphere, `M =
//! diag(mu)`, `W = diag(w)`, `I+` down-going, `I-` up-going radiances at the
//! nodes, `tau` optical depth (downward). With `A = omega P(mu_i, mu_j) W`
//! and `B = omega P(mu_i, -mu_j) W` (`P = p^m` of [`crate::legendre`]):
//!
//! ```text
//!   dI+/dtau = -alpha I+ + beta I-,  dI-/dtau = -beta I+ + alpha I-     (S1)
//!   alpha = M^-1 (1 - A),  beta = M^-1 B
//! ```
//!
//! `I± = g± exp(-k tau)` gives `(alpha + beta)(alpha - beta) v = k^2 v` with
//! `v = g+ + g-`, `g+ - g- = k z`, `z = (alpha + beta)^-1 v` (S2). With
//! `T = diag(sqrt(w mu))`, `H± = T (alpha ± beta) T^-1` are symmetric, and
//! with the Cholesky factor `H+ = L L^T` the problem becomes the symmetric
//! `L^T H- L y = k^2 y`, `v~ = L y`, `z~ = L^-T y` (S3), solved by faer's
//! `self_adjoint_eigen` (N x N instead of 2N x 2N).
//!
//! Every mode is anchored where it decays from: `c_j g±_j e^{-k tau}` at the
//! top and `d_j g∓_j e^{-k (tau0 - tau)}` at the bottom (Stamnes & Conklin
//! 1984), so with `e = exp(-k tau0) <= 1` and `phi = (1 - e)/k` (`= tau0` at
//! `k = 0`) the boundary conditions `I+(0) = a`, `I-(tau0) = b` read
//!
//! ```text
//!   Cp s = a + b,   Cm y = a - b,   s = c + d,  y = k (c - d)           (S4)
//!   Cp = 1/2 [v (1+e) + k z (1-e)],   Cm = 1/2 [v phi + z (1+e)]
//!   R + T = 1/2 [v (1+e) - k z (1-e)] Cp^-1                              (S5)
//!   R - T = 1/2 [v phi  - z (1+e)]    Cm^-1
//! ```
//!
//! (columns per mode). Nothing grows, and `k = 0` (conservative scattering,
//! `m = 0`: the pair of modes becomes the constant and the linear solution)
//! needs no special case: `phi -> tau0`. The half-space is `e = 0`,
//! `R = 1/2 [v - k z] (1/2 [v + k z])^-1`, `T = 0`.
//!
//! Collimated beam (`mu_b`, unit irradiance on a horizontal plane at the top):
//! particular solution `Z± exp(-tau/mu_b)` with (S6)
//! `[(alpha-beta)(alpha+beta) - mu_b^-2] Delta = sigma+ / mu_b + (alpha-beta) sigma-`,
//! `Sigma = mu_b [(alpha+beta) Delta - sigma-]`, `Z± = (Sigma ± Delta)/2`,
//! `sigma± = M^-1 (s+ ± s-)`, `s±_i = omega (2-delta_m0)/(2pi) p^m(±mu_i, mu_b)/mu_b`,
//! solved in the eigenbasis (`H- H+ z~_j = k_j^2 z~_j`, dual basis `v~_j`).
//!
//! User directions ("probes", zero quadrature weight): the radiance leaving
//! the layer is the integral of the source function along the path
//! (Stamnes et al. 1988 §3.6), done analytically per mode (eq. 14 in
//! `docs/multiflux.md`).

use faer::linalg::solvers::Solve;
use faer::{Mat, Side};

use crate::MultifluxError;
use crate::adding::LayerOperators;
use crate::correction::{e2, phi};
use crate::legendre::LegendreRecurrence;

/// An extra direction carried besides the quadrature nodes, in one medium.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Extra {
    /// Cosine in this medium; `None` if the direction cannot propagate here.
    pub mu: Option<f64>,
    /// True for the collimated beam (its value is an irradiance on a
    /// horizontal plane and it scatters); false for a probe (a radiance of
    /// zero quadrature weight, which receives but does not scatter).
    pub beam: bool,
    /// Azimuth of a probe in degrees (BRDF convention: 180 = mirror side);
    /// used by the single-scattering correction only.
    pub phi_deg: f64,
}

/// The intensity correction of the beam into the probes (TMS and IMS,
/// Nakajima & Tanaka 1988; eq. 5 and 5a–5h of `docs/multiflux.md`), applied in
/// the `m = 0` operators: [`crate::correction::PeakCorrection`].
pub type Tms = crate::correction::PeakCorrection;

/// The optical properties of a layer for one Fourier order.
#[derive(Debug, Clone, Copy)]
pub struct SlabOrder<'a> {
    /// Optical thickness (delta-M scaled), `>= 0`, may be infinite.
    pub tau: f64,
    /// Single-scattering albedo (delta-M scaled), `[0, 1]`.
    pub omega: f64,
    /// Legendre moments (delta-M scaled) `chi_0..chi_{L-1}`.
    pub chi: &'a [f64],
    /// Fourier order.
    pub m: usize,
}

/// `X = B C^-1` for square `C`, `B`, column-major (`x[j * n + i] = X_ij`):
/// for small `C` from its LU factors `lu` (already needed by the probes and
/// the beam, [`Lu::right_solve`]); larger (`n > 32`), faer's blocked LU
/// wins. A singular `C` gives non-finite entries, which the caller refuses.
fn solve_right(lu: &Lu, c: &Mat<f64>, b: &Mat<f64>) -> Vec<f64> {
    let n = c.nrows();
    let mut x = vec![0.0; n * n];
    if n > 32 {
        // X^T = C^-T B^T.
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
struct Lu {
    n: usize,
    /// `L` below and `U` on and above the diagonal: `lu[col * n + row]`.
    lu: Vec<f64>,
    /// Row exchanged with row `k` at elimination step `k`.
    piv: Vec<usize>,
}

impl Lu {
    fn new(c: &Mat<f64>) -> Self {
        let n = c.nrows();
        let mut lu = vec![0.0; n * n];
        for j in 0..n {
            lu[j * n..(j + 1) * n].copy_from_slice(c.col_as_slice(j));
        }
        let mut piv = vec![0; n];
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
        Lu { n, lu, piv }
    }

    /// `x <- C^-1 x`.
    fn solve(&self, x: &mut [f64]) {
        let n = self.n;
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

    /// `x <- C^-T x`.
    fn solve_transpose(&self, x: &mut [f64]) {
        let n = self.n;
        // U^T y = b: row k of U^T is column k of U (contiguous).
        for k in 0..n {
            let d = dot(&self.lu[k * n..k * n + k], &x[..k]);
            x[k] = (x[k] - d) / self.lu[k * n + k];
        }
        // L^T w = y: column k of L below the diagonal.
        for k in (0..n).rev() {
            x[k] -= dot(&self.lu[k * n + k + 1..(k + 1) * n], &x[k + 1..]);
        }
        // x = P^T w: undo the exchanges in reverse order.
        for k in (0..n).rev() {
            x.swap(k, self.piv[k]);
        }
    }

    /// `X <- X C^-1` for an `n x n` block `X`, column-major (`x[j * n + i]`),
    /// by whole columns (contiguous updates): with `C = P^T L U`, first
    /// `W U = X` (columns left to right), then `Y L = W` (right to left),
    /// then `X = Y P` (the column exchanges in reverse order).
    fn right_solve(&self, x: &mut [f64]) {
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

/// What a probe (a user direction of zero weight) needs from one layer and
/// order: the mode coefficients of its rows `R_xq`, `T_xq` and, for the beam's source integral, its
/// Legendre values and the even/odd kernels to the nodes.
struct Probe {
    /// The probe's cosine in this layer.
    mu: f64,
    /// Path integrals per mode (eq. 14): `R_xq = (us Cp^-1 + uy Cm^-1) T`.
    us: Vec<f64>,
    uy: Vec<f64>,
    lam: Vec<f64>,
    ev: Vec<f64>,
    od: Vec<f64>,
}

/// The probes of one layer and order, computed once per distinct cosine:
/// everything in a probe's rows depends on its polar angle only, so the exit
/// directions that share one (any number of azimuths) share one [`Probe`].
struct Probes {
    /// One entry per distinct probe cosine, in order of first appearance.
    rows: Vec<Probe>,
    /// For each extra: its entry in `rows` (`None` for the beam and for
    /// directions absent from this medium).
    of: Vec<Option<usize>>,
}

/// `exp(-t / mu)`, 0 for an infinite `t`.
fn atten(t: f64, mu: f64) -> f64 {
    if t.is_infinite() { 0.0 } else { (-t / mu).exp() }
}

/// The eigen-solution of one layer and order (eq. S2–S5), kept to evaluate
/// the operators, the beam's particular solution and the internal field.
pub struct SlabSolution {
    n: usize,
    tau: f64,
    omega: f64,
    m: usize,
    /// `sqrt(w mu)` (the diagonal of `T`).
    t: Vec<f64>,
    mu: Vec<f64>,
    w: Vec<f64>,
    /// Weighted moments `(2l+1) chi_l` for `l = m..L`.
    chi: Vec<f64>,
    /// `Lambda_l^m(mu_i)`, node-major: `lam[i * L + l]`.
    lam: Vec<f64>,
    /// The recurrence of `Lambda_l^m` at other cosines (probes, beam).
    rec: LegendreRecurrence,
    /// Eigenvalues `k_j >= 0`.
    pub k: Vec<f64>,
    /// `exp(-k_j tau0)` (0 for a half-space).
    ek: Vec<f64>,
    /// `v~` (columns), transformed coordinates.
    v: Mat<f64>,
    /// `z~` (columns), transformed coordinates.
    z: Mat<f64>,
    /// `H+` and `H-`.
    hp: Mat<f64>,
    hm: Mat<f64>,
    /// LU factors of `Cp` and `Cm` of eq. S4 (`Cm` absent for a half-space).
    lu_p: Lu,
    lu_m: Option<Lu>,
    /// The `C_out` of eq. S5 for `R~ + T~` and `R~ - T~` (`cm_out` empty for a half-space).
    cp_out: Mat<f64>,
    cm_out: Mat<f64>,
    /// Reflection and transmission between the nodes (original coordinates;
    /// empty when built without `full`).
    r: Mat<f64>,
    tr: Mat<f64>,
    /// Scale of the beam coupling to the nodes for m = 0 (energy renormalisation).
    renorm_m0: bool,
}

impl SlabSolution {
    /// Solve the layer (eq. S1–S5) on the nodes `mu`, `w`.
    ///
    /// # Errors
    /// [`MultifluxError::Numerical`] if the Cholesky factorisation of `H+` or the
    /// eigen-solver fails, or the operators are not finite.
    pub fn new(mu: &[f64], w: &[f64], p: &SlabOrder<'_>) -> Result<Self, MultifluxError> {
        Self::build(mu, w, p, true)
    }

    /// [`SlabSolution::new`]; `full = false` skips the node-to-node `R` and `T`
    /// (eq. S5, `n` solves each), which a layer alone under a beam does not
    /// need ([`slab_beam_response`]): the beam, the probes and the internal
    /// field use only the LU factors of `Cp` and `Cm` (vector solves).
    ///
    /// # Errors
    /// As [`SlabSolution::new`].
    pub fn build(
        mu: &[f64],
        w: &[f64],
        p: &SlabOrder<'_>,
        full: bool,
    ) -> Result<Self, MultifluxError> {
        let n = mu.len();
        let (tau, omega, m) = (p.tau, p.omega, p.m);
        let nl = p.chi.len();
        let t: Vec<f64> = mu.iter().zip(w).map(|(u, w)| (u * w).sqrt()).collect();
        let chi: Vec<f64> =
            (0..nl).map(|l| if l < m { 0.0 } else { (2 * l + 1) as f64 * p.chi[l] }).collect();

        // Legendre table Lambda_l^m(mu_i), node-major.
        let rec = LegendreRecurrence::new(m, nl);
        let mut lam = vec![0.0; n * nl];
        for (i, &x) in mu.iter().enumerate() {
            rec.eval(x, &mut lam[i * nl..(i + 1) * nl]);
        }
        // Even and odd (in l + m) parts of the phase matrix: P(mu,mu') ± P(mu,-mu')
        // = sum_l c_l Lambda_l(mu_i) Lambda_l(mu_j), as dot products of rows.
        let mut ae = Mat::<f64>::zeros(n, nl);
        let mut ao = Mat::<f64>::zeros(n, nl);
        let mut lt = Mat::<f64>::zeros(nl, n);
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
        let mut pe = &ae * &lt;
        let mut po = &ao * &lt;
        // m = 0: renormalise symmetrically so that sum_j P_even,ij w_j = 1 exactly
        // (energy conservation of the discrete scattering; docs/multiflux.md). Symmetric
        // Sinkhorn–Knopp scaling d_i P_ij d_j keeps reciprocity.
        let renorm_m0 = m == 0;
        if renorm_m0 {
            let mut d = vec![1.0; n];
            let mut r = vec![0.0; n];
            for _ in 0..60 {
                r.iter_mut().for_each(|x| *x = 0.0);
                for j in 0..n {
                    let c = pe.col_as_slice(j);
                    let f = w[j] * d[j];
                    for i in 0..n {
                        r[i] += c[i] * f;
                    }
                }
                let mut worst = 0.0f64;
                for i in 0..n {
                    r[i] *= d[i];
                    worst = worst.max((r[i] - 1.0).abs());
                }
                if worst < 1e-15 || r.iter().any(|&x| x <= 0.0) {
                    break;
                }
                for i in 0..n {
                    d[i] /= r[i].sqrt();
                }
            }
            for j in 0..n {
                let (ce, co) = (pe.col_as_slice_mut(j), po.col_as_slice_mut(j));
                for i in 0..n {
                    ce[i] *= d[i] * d[j];
                    co[i] *= d[i] * d[j];
                }
            }
        }
        // H± = diag(1/mu) - omega sqrt(w/mu) P_{odd/even} sqrt(w/mu)   (eq. S3).
        let sq: Vec<f64> = mu.iter().zip(w).map(|(u, w)| (w / u).sqrt()).collect();
        let mut hp = Mat::<f64>::zeros(n, n);
        let mut hm = Mat::<f64>::zeros(n, n);
        for j in 0..n {
            let (ce, co) = (pe.col_as_slice(j), po.col_as_slice(j));
            let hpc = hp.col_as_slice_mut(j);
            for i in 0..n {
                hpc[i] = -omega * sq[i] * co[i] * sq[j];
            }
            hpc[j] += 1.0 / mu[j];
            let hmc = hm.col_as_slice_mut(j);
            for i in 0..n {
                hmc[i] = -omega * sq[i] * ce[i] * sq[j];
            }
            hmc[j] += 1.0 / mu[j];
        }

        let fail = |what: &'static str| MultifluxError::Numerical {
            what,
            detail: format!("N = {n}, tau = {tau}, omega = {omega}, m = {m}"),
        };
        let llt = hp.llt(Side::Lower).map_err(|_| fail("Cholesky of H+"))?;
        let lf = llt.L().to_owned();
        let sym = lf.transpose() * (&hm * &lf);
        let evd = sym.self_adjoint_eigen(Side::Lower).map_err(|_| fail("eigen-solver"))?;
        let s = evd.S().column_vector().to_owned();
        let y = evd.U().to_owned();
        let mut k: Vec<f64> = (0..n).map(|j| s[j].max(0.0).sqrt()).collect();
        if m == 0 && omega == 1.0 {
            // Conservative scattering: the discrete system conserves energy exactly
            // (renormalised above), so the smallest eigenvalue is exactly 0.
            k[0] = 0.0;
        }
        let v = &lf * &y;
        // z~ = H+^-1 v~ = L^-T y: one triangular solve (eq. S3).
        let mut z = y.clone();
        faer::linalg::triangular_solve::solve_upper_triangular_in_place(
            lf.transpose(),
            z.as_mut(),
            faer::Par::Seq,
        );

        // Eq. S4-S5, column by column.
        let half = tau.is_infinite();
        let e: Vec<f64> = k.iter().map(|&kj| if half { 0.0 } else { (-kj * tau).exp() }).collect();
        let ph: Vec<f64> = k.iter().map(|&kj| phi(kj, tau)).collect();
        let mut cp = Mat::<f64>::zeros(n, n);
        let mut cp_out = Mat::<f64>::zeros(n, n);
        let mut cm = Mat::<f64>::zeros(n, n);
        let mut cm_out = Mat::<f64>::zeros(n, n);
        for j in 0..n {
            let (vc, zc) = (v.col_as_slice(j), z.col_as_slice(j));
            let (a, b) = (0.5 * (1.0 + e[j]), 0.5 * k[j] * (1.0 - e[j]));
            let c = cp.col_as_slice_mut(j);
            for i in 0..n {
                c[i] = a * vc[i] + b * zc[i];
            }
            let c = cp_out.col_as_slice_mut(j);
            for i in 0..n {
                c[i] = a * vc[i] - b * zc[i];
            }
            if !half {
                let (a, b) = (0.5 * ph[j], 0.5 * (1.0 + e[j]));
                let c = cm.col_as_slice_mut(j);
                for i in 0..n {
                    c[i] = a * vc[i] + b * zc[i];
                }
                let c = cm_out.col_as_slice_mut(j);
                for i in 0..n {
                    c[i] = a * vc[i] - b * zc[i];
                }
            }
        }
        // LU factors of Cp and Cm: every later use is a solve, never an inverse.
        let lu_p = Lu::new(&cp);
        let lu_m = (!half).then(|| Lu::new(&cm));
        let (r, tr) = if full {
            // R~ ± T~ = C_out C^-1 (eq. S5); transposed: C^-T C_out^T.
            let xp = solve_right(&lu_p, &cp, &cp_out);
            let xm = match &lu_m {
                Some(lu) => solve_right(lu, &cm, &cm_out),
                None => xp.clone(),
            };
            // Back to radiances: R_ji = R~_ji t_i / t_j, by columns i of R.
            let mut r = Mat::<f64>::zeros(n, n);
            let mut tr = Mat::<f64>::zeros(n, n);
            let mut finite = true;
            for i in 0..n {
                let (xpc, xmc) = (&xp[i * n..(i + 1) * n], &xm[i * n..(i + 1) * n]);
                let (rc, tc) = (r.col_as_slice_mut(i), tr.col_as_slice_mut(i));
                for j in 0..n {
                    let f = t[i] / t[j];
                    let rv = 0.5 * (xpc[j] + xmc[j]) * f;
                    let tv = if half { 0.0 } else { 0.5 * (xpc[j] - xmc[j]) * f };
                    finite &= rv.is_finite() && tv.is_finite();
                    rc[j] = rv;
                    tc[j] = tv;
                }
            }
            if !finite {
                return Err(fail("layer operators (non-finite)"));
            }
            (r, tr)
        } else {
            // Only the factors are kept: check that they are usable.
            let finite = lu_p.lu.iter().all(|x| x.is_finite())
                && lu_m.as_ref().is_none_or(|l| l.lu.iter().all(|x| x.is_finite()));
            let regular = (0..n).all(|k| {
                lu_p.lu[k * n + k] != 0.0 && lu_m.as_ref().is_none_or(|l| l.lu[k * n + k] != 0.0)
            });
            if !(finite && regular) {
                return Err(fail("layer operators (singular boundary matrix)"));
            }
            (Mat::zeros(0, 0), Mat::zeros(0, 0))
        };
        Ok(SlabSolution {
            n,
            tau,
            omega,
            m,
            t,
            mu: mu.to_vec(),
            w: w.to_vec(),
            chi,
            lam,
            rec,
            k,
            ek: e,
            v,
            z,
            hp,
            hm,
            lu_p,
            lu_m,
            cp_out,
            cm_out,
            r,
            tr,
            renorm_m0,
        })
    }

    /// The eigen-solutions (seed 000 fig. 3): `(k, G+, G-)` with column `j` of
    /// `G±` the down/up-going radiances at the nodes of the mode
    /// `g±_j e^{-k_j tau}` (eq. 8: `g± = (v ± k z)/2`, original coordinates);
    /// the mirrored modes `g∓_j e^{-k_j (tau0 - tau)}` swap the two.
    pub fn eigenvectors(&self) -> (Vec<f64>, Mat<f64>, Mat<f64>) {
        let n = self.n;
        let gp = Mat::from_fn(n, n, |i, j| {
            0.5 * (self.v[(i, j)] + self.k[j] * self.z[(i, j)]) / self.t[i]
        });
        let gm = Mat::from_fn(n, n, |i, j| {
            0.5 * (self.v[(i, j)] - self.k[j] * self.z[(i, j)]) / self.t[i]
        });
        (self.k.clone(), gp, gm)
    }

    /// Reflection matrix between the nodes (radiance in, radiance out).
    pub fn r(&self) -> &Mat<f64> {
        &self.r
    }

    /// Transmission matrix between the nodes.
    pub fn t(&self) -> &Mat<f64> {
        &self.tr
    }

    /// `Lambda_l^m(mu)` for this order.
    fn lam_at(&self, mu: f64) -> Vec<f64> {
        let mut b = vec![0.0; self.chi.len()];
        self.rec.eval(mu, &mut b);
        b
    }

    /// Even and odd (in l+m) kernels between direction `mu` and every node:
    /// `sum_{l+m even/odd} (2l+1) chi_l Lambda_l(mu) Lambda_l(mu_j)`.
    fn kernels(&self, lam_x: &[f64]) -> (Vec<f64>, Vec<f64>) {
        let nl = self.chi.len();
        // The weights split by parity of l + m (zero elsewhere), then dot products.
        let (mut we, mut wo) = (vec![0.0; nl], vec![0.0; nl]);
        for l in self.m..nl {
            let x = self.chi[l] * lam_x[l];
            if (l + self.m).is_multiple_of(2) { we[l] = x } else { wo[l] = x }
        }
        let (mut ev, mut od) = (vec![0.0; self.n], vec![0.0; self.n]);
        for j in 0..self.n {
            let row = &self.lam[j * nl..(j + 1) * nl];
            ev[j] = dot(&we, row);
            od[j] = dot(&wo, row);
        }
        (ev, od)
    }

    /// Particular solution for a beam of unit horizontal irradiance entering
    /// at the top at `mu_b` (eq. S6): `(Z+, Z-)` in radiances at the nodes.
    fn particular(&self, mu_b: f64) -> (Vec<f64>, Vec<f64>) {
        let n = self.n;
        let lam_b = self.lam_at(mu_b);
        let (mut ev, mut od) = self.kernels(&lam_b);
        let cm = if self.m == 0 { 1.0 } else { 2.0 } / (2.0 * std::f64::consts::PI);
        if self.renorm_m0 {
            // Make the scattered beam integrate to omega exactly over the nodes.
            let s: f64 = (0..n).map(|j| ev[j] * self.w[j]).sum();
            if s > 0.0 {
                ev.iter_mut().for_each(|x| *x /= s);
                od.iter_mut().for_each(|x| *x /= s);
            }
        }
        // s+ + s- = omega c_m / mu_b * ev ; s+ - s- = omega c_m / mu_b * od.
        let f = self.omega * cm / mu_b;
        // sigma~± = T M^-1 (s+ ± s-) = sqrt(w/mu) (s+ ± s-).
        let sp: Vec<f64> = (0..n).map(|i| (self.w[i] / self.mu[i]).sqrt() * f * ev[i]).collect();
        let sm: Vec<f64> = (0..n).map(|i| (self.w[i] / self.mu[i]).sqrt() * f * od[i]).collect();
        // rhs = sigma+ / mu_b + H- sigma-.
        let rhs: Vec<f64> = (0..n)
            // H- is symmetric: row i is column i.
            .map(|i| sp[i] / mu_b + dot(self.hm.col_as_slice(i), &sm))
            .collect();
        // Delta = sum_j z_j (v_j . rhs) / (k_j^2 - mu_b^-2).
        let lb = 1.0 / (mu_b * mu_b);
        let mut delta = vec![0.0; n];
        for j in 0..n {
            let c: f64 = dot(self.v.col_as_slice(j), &rhs) / (self.k[j] * self.k[j] - lb);
            for i in 0..n {
                delta[i] += c * self.z[(i, j)];
            }
        }
        // Sigma = mu_b (H+ Delta - sigma-).
        let sigma: Vec<f64> =
            (0..n).map(|i| mu_b * (dot(self.hp.col_as_slice(i), &delta) - sm[i])).collect();
        let zp = (0..n).map(|i| 0.5 * (sigma[i] + delta[i]) / self.t[i]).collect();
        let zm = (0..n).map(|i| 0.5 * (sigma[i] - delta[i]) / self.t[i]).collect();
        (zp, zm)
    }

    /// Rows for a probe at cosine `mu_x`: `(R_xq, T_xq)`, the up-going radiance
    /// at `mu_x` leaving the top per unit down-going radiance at each node
    /// entering at the top, and the same from the bottom (eq. 14 of docs/multiflux.md).
    fn probe_rows(&self, mu_x: f64) -> Probe {
        let n = self.n;
        let lam_x = self.lam_at(mu_x);
        let (ev, od) = self.kernels(&lam_x);
        let beta = 1.0 / mu_x;
        let eb = atten(self.tau, mu_x);
        // a_j = omega w ev . v_j ; b_j = -omega w od . z_j (up-going probe), original coords.
        let fe: Vec<f64> = (0..n).map(|i| self.omega * self.w[i] / self.t[i] * ev[i]).collect();
        let fo: Vec<f64> = (0..n).map(|i| self.omega * self.w[i] / self.t[i] * od[i]).collect();
        let mut us = vec![0.0; n];
        let mut uy = vec![0.0; n];
        for j in 0..n {
            let a = dot(&fe, self.v.col_as_slice(j));
            let b = -dot(&fo, self.z.col_as_slice(j));
            let k = self.k[j];
            if self.tau.is_infinite() {
                // Only top-anchored modes: out = 1/2 (a + b k) beta/(k + beta) c, c = s.
                us[j] = 0.5 * (a + b * k) * beta / (k + beta);
                continue;
            }
            let t0 = self.tau;
            // phi(k + beta) and e2(k, beta) of the path integral, from the
            // exponentials of the mode and of the probe when no cancellation
            // threatens (exponent differences above 1/2: at most ~4 ulp lost),
            // else by expm1.
            let ek = self.ek[j];
            let k1 = if (k + beta) * t0 > 0.5 {
                beta * (1.0 - ek * eb) / (k + beta)
            } else {
                beta * phi(k + beta, t0)
            };
            let k2 = if (beta - k).abs() * t0 > 0.5 {
                beta * (ek - eb) / (beta - k)
            } else {
                beta * e2(k, beta, t0)
            };
            let kd = if k > 0.0 {
                (k1 - k2) / k
            } else {
                // limit: beta int_0^t0 e^{-beta t} (t0 - 2 t) dt
                let x = beta * t0;
                let om = -(-x).exp_m1();
                t0 * om - 2.0 * (om - x * (-x).exp()) / beta
            };
            us[j] = 0.25 * (a * (k1 + k2) + b * k * (k1 - k2));
            uy[j] = 0.25 * (a * kd + b * (k1 + k2));
        }
        if self.tau.is_infinite() {
            uy.iter_mut().for_each(|x| *x = 0.0);
        }
        Probe { mu: mu_x, us, uy, lam: lam_x, ev, od }
    }

    /// `(R_xq, T_xq)` of a probe: `R_xq = (us Cp^-1 + uy Cm^-1) T`,
    /// `T_xq = (us Cp^-1 - uy Cm^-1) T`, the row vectors by transposed solves
    /// `Cp^-T us`, `Cm^-T uy`.
    fn probe_row_vectors(&self, pr: &Probe) -> (Vec<f64>, Vec<f64>) {
        let n = self.n;
        let (mut p, mut q) = (pr.us.clone(), pr.uy.clone());
        self.lu_p.solve_transpose(&mut p);
        match &self.lu_m {
            Some(lu) => lu.solve_transpose(&mut q),
            None => q.iter_mut().for_each(|x| *x = 0.0),
        }
        let mut rx = vec![0.0; n];
        let mut tx = vec![0.0; n];
        for i in 0..n {
            rx[i] = (p[i] + q[i]) * self.t[i];
            tx[i] = (p[i] - q[i]) * self.t[i];
        }
        if self.tau.is_infinite() {
            tx.iter_mut().for_each(|x| *x = 0.0);
        }
        (rx, tx)
    }

    /// The beam's columns of `R` and `T` (nodes and probes; eq. S6 and eq. 14 of docs/multiflux.md):
    /// particular solution, homogeneous part fixed by the boundary values
    /// `-Z+` at the top and `-Z- e^{-tau/mu_b}` at the bottom, and the source
    /// integral along each probe.
    fn beam_columns(
        &self,
        mu_b: f64,
        extras: &[Extra],
        probes: &Probes,
        tms: Option<&Tms>,
    ) -> (Vec<f64>, Vec<f64>) {
        let n = self.n;
        let dim = n + extras.len();
        let (mut cr, mut ct) = (vec![0.0; dim], vec![0.0; dim]);
        let (zp, zm) = self.particular(mu_b);
        let eb_att = atten(self.tau, mu_b);
        // Homogeneous part: boundary values a = -Z+, b = -Z- e_b.
        let a: Vec<f64> = zp.iter().map(|x| -x).collect();
        let b: Vec<f64> = zm.iter().map(|x| -x * eb_att).collect();
        let (hs, hd, sp, sm) = self.homogeneous_out(&a, &b);
        for i in 0..n {
            cr[i] = zm[i] + hs[i];
            ct[i] = zp[i] * eb_att + hd[i];
        }
        // Beam -> probes: homogeneous rows plus the particular source integral,
        // once per distinct probe cosine (`per`); only the peak correction
        // depends on the azimuth.
        let lam_b = self.lam_at(mu_b);
        let cm = if self.m == 0 { 1.0 } else { 2.0 } / (2.0 * std::f64::consts::PI);
        let per: Vec<[f64; 4]> = probes
            .rows
            .iter()
            .map(|pr| {
                let (us, uy, lam_x, ev, od) = (&pr.us, &pr.uy, &pr.lam, &pr.ev, &pr.od);
                // Direct single scattering of the beam into ±mu_x.
                let (mut se, mut so) = (0.0, 0.0);
                for l in self.m..self.chi.len() {
                    let x = self.chi[l] * lam_x[l] * lam_b[l];
                    if (l + self.m).is_multiple_of(2) { se += x } else { so += x }
                }
                // p^m(sigma mu_x, mu_b) = 1/2 (se + sigma so).
                let direct_up = self.omega * cm * 0.5 * (se - so) / mu_b;
                let direct_dn = self.omega * cm * 0.5 * (se + so) / mu_b;
                // Scattering of Z± into ±mu_x: omega sum_j w_j [p(sx, mu_j) Z+_j + p(sx, -mu_j) Z-_j].
                let (mut up, mut dn) = (direct_up, direct_dn);
                for j in 0..n {
                    let f = self.omega * self.w[j] * 0.5;
                    // p(-x, mu_j) = (ev - od)/2 ; p(-x, -mu_j) = (ev + od)/2 ; signs flip for +x.
                    up += f * ((ev[j] - od[j]) * zp[j] + (ev[j] + od[j]) * zm[j]);
                    dn += f * ((ev[j] + od[j]) * zp[j] + (ev[j] - od[j]) * zm[j]);
                }
                let beta = 1.0 / pr.mu;
                let kb = 1.0 / mu_b;
                // R_xq a + T_xq b = us . Cp^-1 T (a + b) + uy . Cm^-1 T (a - b).
                [
                    up * beta * phi(kb + beta, self.tau),
                    dn * beta * e2(kb, beta, self.tau),
                    dot(us, &sp),
                    dot(uy, &sm),
                ]
            })
            .collect();
        for (ex_i, exx) in extras.iter().enumerate() {
            let (Some(p), Some(mu_x)) = (probes.of[ex_i], exx.mu) else { continue };
            let [mut out_up, mut out_dn, hp, hm] = per[p];
            if let (Some(t), 0) = (tms, self.m) {
                // Eq. 5 and 5a-5h of docs/multiflux.md: exact single scattering
                // (TMS) and the forward peak's second order (IMS), real space.
                let (du, dd) = t.radiance(mu_b, mu_x, exx.phi_deg, self.tau);
                out_up += du;
                out_dn += dd;
            }
            // T_xq a + R_xq b is the same with the sign of the second term
            // flipped (nothing leaves the bottom of a half-space).
            out_up += hp + hm;
            if !self.tau.is_infinite() {
                out_dn += hp - hm;
            }
            cr[n + ex_i] = out_up;
            ct[n + ex_i] = out_dn;
        }
        (cr, ct)
    }

    /// The radiance field inside the layer at optical depth `tau` (seed 000
    /// eq. 19, in the scaled form S4): down-going `I+` and up-going `I-` at
    /// the nodes, for down-going radiances `top_in` entering at the top,
    /// up-going `bottom_in` entering at the bottom, and optionally a beam
    /// `(mu_b, F)` of horizontal irradiance `F` entering at the top. Radiances
    /// are the Fourier component of order `m` of this solution.
    ///
    /// ```text
    ///   I~± = 1/2 v [s (e1+e2)/2 + y D/2] ± 1/2 z [s k (e1-e2)/2 + y (e1+e2)/2]
    ///   e1 = e^{-k tau}, e2 = e^{-k (tau0 - tau)}, D = (e1 - e2)/k (-> tau0 - 2 tau)
    /// ```
    ///
    /// plus the particular solution `Z± F e^{-tau/mu_b}` (eq. S6).
    ///
    /// # Errors
    /// [`MultifluxError::Shape`] if the inputs do not have one value per node,
    /// [`MultifluxError::Option`] if `tau` lies outside `[0, tau0]`.
    pub fn field(
        &self,
        tau: f64,
        top_in: &[f64],
        bottom_in: &[f64],
        beam: Option<(f64, f64)>,
    ) -> Result<(Vec<f64>, Vec<f64>), MultifluxError> {
        let n = self.n;
        if top_in.len() != n || bottom_in.len() != n {
            return Err(MultifluxError::Shape {
                what: "field",
                detail: format!("{n} nodes, inputs {} and {}", top_in.len(), bottom_in.len()),
            });
        }
        if !(0.0..=self.tau).contains(&tau) || tau.is_infinite() {
            return Err(MultifluxError::Option {
                name: "tau",
                value: tau,
                reason: "depth must lie in [0, tau0] and be finite",
            });
        }
        // Boundary values of the homogeneous part (transformed coordinates).
        let (mut a, mut b) = (top_in.to_vec(), bottom_in.to_vec());
        let mut part = None;
        if let Some((mu_b, f)) = beam {
            let (zp, zm) = self.particular(mu_b);
            let eb = atten(self.tau, mu_b);
            for i in 0..n {
                a[i] -= f * zp[i];
                b[i] -= f * zm[i] * eb;
            }
            let e = (-tau / mu_b).exp() * f;
            part = Some((
                zp.iter().map(|x| x * e).collect::<Vec<_>>(),
                zm.iter().map(|x| x * e).collect::<Vec<_>>(),
            ));
        }
        let at: Vec<f64> = (0..n).map(|i| a[i] * self.t[i]).collect();
        let bt: Vec<f64> = (0..n).map(|i| b[i] * self.t[i]).collect();
        let half = self.tau.is_infinite();
        // s = Cp^-1 (a~ + b~), y = Cm^-1 (a~ - b~) (eq. S4).
        let mut s: Vec<f64> = (0..n).map(|i| at[i] + if half { 0.0 } else { bt[i] }).collect();
        self.lu_p.solve(&mut s);
        let mut y: Vec<f64> = (0..n).map(|i| at[i] - bt[i]).collect();
        match &self.lu_m {
            Some(lu) => lu.solve(&mut y),
            None => y.iter_mut().for_each(|x| *x = 0.0),
        }
        let (mut dn, mut up) = (vec![0.0; n], vec![0.0; n]);
        for j in 0..n {
            let k = self.k[j];
            let e1 = (-k * tau).exp();
            let (cv, cz) = if half {
                // Only top-anchored modes: c = s.
                (0.5 * s[j] * e1, 0.5 * s[j] * k * e1)
            } else {
                let e2 = (-k * (self.tau - tau)).exp();
                let d = if k > 0.0 { (e1 - e2) / k } else { self.tau - 2.0 * tau };
                (
                    0.5 * (0.5 * s[j] * (e1 + e2) + 0.5 * y[j] * d),
                    0.5 * (0.5 * s[j] * k * (e1 - e2) + 0.5 * y[j] * (e1 + e2)),
                )
            };
            for i in 0..n {
                dn[i] += cv * self.v[(i, j)] + cz * self.z[(i, j)];
                up[i] += cv * self.v[(i, j)] - cz * self.z[(i, j)];
            }
        }
        for i in 0..n {
            dn[i] /= self.t[i];
            up[i] /= self.t[i];
        }
        if let Some((zp, zm)) = part {
            for i in 0..n {
                dn[i] += zp[i];
                up[i] += zm[i];
            }
        }
        Ok((dn, up))
    }

    /// The operators on the augmented space `[nodes, extras]` (same layout for
    /// down- and up-going vectors; the layer is symmetric, so `r_bottom = r_top`
    /// and `t_up = t_down`).
    pub fn operators(&self, extras: &[Extra], tms: Option<&Tms>) -> LayerOperators {
        let n = self.n;
        let dim = n + extras.len();
        let mut rr = Mat::<f64>::zeros(dim, dim);
        let mut tt = Mat::<f64>::zeros(dim, dim);
        let lazy;
        let (r, tr) = if self.r.nrows() == n {
            (&self.r, &self.tr)
        } else {
            // Built without `full`: the node operators from the factors.
            lazy = self.node_operators();
            (&lazy.0, &lazy.1)
        };
        for j in 0..n {
            rr.col_as_slice_mut(j)[..n].copy_from_slice(r.col_as_slice(j));
            tt.col_as_slice_mut(j)[..n].copy_from_slice(tr.col_as_slice(j));
        }
        // Probe rows first (needed by the beam columns), once per distinct cosine.
        let probes = self.probes(extras);
        let vectors: Vec<_> = probes.rows.iter().map(|pr| self.probe_row_vectors(pr)).collect();
        for (e, ex) in extras.iter().enumerate() {
            if let Some(mu_x) = ex.mu {
                tt[(n + e, n + e)] = atten(self.tau, mu_x);
            }
            if let Some(p) = probes.of[e] {
                let (rx, tx) = &vectors[p];
                for i in 0..n {
                    rr[(n + e, i)] = rx[i];
                    tt[(n + e, i)] = tx[i];
                }
            }
        }
        for (eb, ex) in extras.iter().enumerate() {
            let (true, Some(mu_b)) = (ex.beam, ex.mu) else { continue };
            let (cr, ct) = self.beam_response_rows(mu_b, extras, &probes, tms);
            for i in 0..dim {
                if i < n || probes.of[i - n].is_some() {
                    rr[(i, n + eb)] = cr[i];
                    tt[(i, n + eb)] = ct[i];
                }
            }
        }
        LayerOperators { r_top: rr.clone(), t_down: tt.clone(), r_bottom: rr, t_up: tt }
    }

    /// The column of the beam `extras[eb]` in the `r_top` and `t_down` of
    /// [`SlabSolution::operators`], computed without the node-to-node
    /// operators: all a layer alone under a collimated beam needs.
    pub fn beam_response(
        &self,
        extras: &[Extra],
        eb: usize,
        tms: Option<&Tms>,
    ) -> (Vec<f64>, Vec<f64>) {
        let n = self.n;
        let dim = n + extras.len();
        let (mut cr, mut ct) = (vec![0.0; dim], vec![0.0; dim]);
        let (true, Some(mu_b)) = (extras[eb].beam, extras[eb].mu) else {
            return (cr, ct);
        };
        let probes = self.probes(extras);
        let (r, t) = self.beam_response_rows(mu_b, extras, &probes, tms);
        for i in 0..dim {
            if i < n || probes.of[i - n].is_some() {
                cr[i] = r[i];
                ct[i] = t[i];
            }
        }
        // The unscattered beam itself.
        ct[n + eb] = atten(self.tau, mu_b);
        (cr, ct)
    }

    /// The probes of `extras`, one [`Probe`] per distinct cosine (the beam
    /// and directions absent from this medium have none).
    fn probes(&self, extras: &[Extra]) -> Probes {
        let mut rows: Vec<Probe> = Vec::new();
        let of = extras
            .iter()
            .map(|ex| match (ex.beam, ex.mu) {
                (false, Some(mu_x)) => Some(match rows.iter().position(|p| p.mu == mu_x) {
                    Some(i) => i,
                    None => {
                        rows.push(self.probe_rows(mu_x));
                        rows.len() - 1
                    }
                }),
                _ => None,
            })
            .collect();
        Probes { rows, of }
    }

    /// The beam's columns (nodes and probes) with the resonance guard.
    fn beam_response_rows(
        &self,
        mu_b: f64,
        extras: &[Extra],
        probes: &Probes,
        tms: Option<&Tms>,
    ) -> (Vec<f64>, Vec<f64>) {
        // Eq. S6 is singular at k_j mu_b = 1 (the full response is not): at
        // an exact resonance (|k mu_b - 1| < 1e-9, a set of measure zero)
        // the response is the mean at mu_b (1 ± 1e-6) (error ~1e-12; one-sided
        // 1e-6 at mu_b = 1). Near it, the cancellation costs only
        // log10(1/|k mu_b - 1|) digits.
        let near = self.k.iter().any(|&k| (k * mu_b - 1.0).abs() < 1e-9);
        if !near {
            self.beam_columns(mu_b, extras, probes, tms)
        } else if mu_b * (1.0 + 1e-6) < 1.0 {
            let (a, b) = (
                self.beam_columns(mu_b * (1.0 - 1e-6), extras, probes, tms),
                self.beam_columns(mu_b * (1.0 + 1e-6), extras, probes, tms),
            );
            let avg = |x: &[f64], y: &[f64]| -> Vec<f64> {
                x.iter().zip(y).map(|(p, q)| 0.5 * (p + q)).collect()
            };
            (avg(&a.0, &b.0), avg(&a.1, &b.1))
        } else {
            self.beam_columns(mu_b * (1.0 - 1e-6), extras, probes, tms)
        }
    }

    /// `(R a + T b, T a + R b)` at the nodes (radiances), for down-going `a`
    /// entering at the top and up-going `b` at the bottom, by two vector
    /// solves (eq. S5): with `a~ = T a`, `b~ = T b`,
    /// `R~ a~ + T~ b~ = 1/2 [Cp_out Cp^-1 (a~ + b~) + Cm_out Cm^-1 (a~ - b~)]`.
    /// Also returns `Cp^-1 (a~ + b~)` and `Cm^-1 (a~ - b~)` (0 for a half-space).
    fn homogeneous_out(&self, a: &[f64], b: &[f64]) -> (Vec<f64>, Vec<f64>, Vec<f64>, Vec<f64>) {
        let n = self.n;
        // Half-space: R~ = Cp_out Cp^-1, T~ = 0 (nothing enters from below).
        let half = self.lu_m.is_none();
        let bh = |i: usize| if half { 0.0 } else { b[i] };
        let mut s: Vec<f64> = (0..n).map(|i| self.t[i] * (a[i] + bh(i))).collect();
        let mut d: Vec<f64> = (0..n).map(|i| self.t[i] * (a[i] - bh(i))).collect();
        self.lu_p.solve(&mut s);
        let hp = mat_vec(&self.cp_out, &s);
        let hm = match &self.lu_m {
            Some(lu) => {
                lu.solve(&mut d);
                mat_vec(&self.cm_out, &d)
            }
            None => {
                d.iter_mut().for_each(|x| *x = 0.0);
                hp.clone()
            }
        };
        let rs = (0..n).map(|i| 0.5 * (hp[i] + hm[i]) / self.t[i]).collect();
        let td =
            (0..n).map(|i| if half { 0.0 } else { 0.5 * (hp[i] - hm[i]) / self.t[i] }).collect();
        (rs, td, s, d)
    }

    /// The node-to-node `R` and `T` (eq. S5) from the kept factors.
    fn node_operators(&self) -> (Mat<f64>, Mat<f64>) {
        let n = self.n;
        let mut r = Mat::<f64>::zeros(n, n);
        let mut tr = Mat::<f64>::zeros(n, n);
        let (mut xp, mut xm) = (vec![0.0; n], vec![0.0; n]);
        for j in 0..n {
            // Row j of X = C_out C^-1 is C^-T applied to row j of C_out.
            for i in 0..n {
                xp[i] = self.cp_out[(j, i)];
            }
            self.lu_p.solve_transpose(&mut xp);
            match &self.lu_m {
                Some(lu) => {
                    for i in 0..n {
                        xm[i] = self.cm_out[(j, i)];
                    }
                    lu.solve_transpose(&mut xm);
                }
                None => xm.copy_from_slice(&xp),
            }
            for i in 0..n {
                let f = self.t[i] / self.t[j];
                r[(j, i)] = 0.5 * (xp[i] + xm[i]) * f;
                tr[(j, i)] = if self.lu_m.is_none() { 0.0 } else { 0.5 * (xp[i] - xm[i]) * f };
            }
        }
        (r, tr)
    }
}

/// `sum_i a_i b_i` with four partial sums (lets the compiler use SIMD; the
/// rounding differs from a sequential sum only in the last bits).
#[inline]
fn dot(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len());
    let (a, b) = (&a[..n], &b[..n]);
    let mut acc = [0.0f64; 4];
    let (ca, cb) = (a.chunks_exact(4), b.chunks_exact(4));
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        for k in 0..4 {
            acc[k] += x[k] * y[k];
        }
    }
    let tail: f64 = ra.iter().zip(rb).map(|(x, y)| x * y).sum();
    (acc[0] + acc[1]) + (acc[2] + acc[3]) + tail
}

/// `M x` for a small dense matrix, by columns.
fn mat_vec(m: &Mat<f64>, x: &[f64]) -> Vec<f64> {
    let mut y = vec![0.0; m.nrows()];
    for (j, &xj) in x.iter().enumerate() {
        for (yi, mij) in y.iter_mut().zip(m.col_as_slice(j)) {
            *yi += mij * xj;
        }
    }
    y
}

/// Operators of a layer that does not scatter in this order (pure absorber,
/// or an order above the phase function's last moment): `R = 0`,
/// `T = diag(exp(-tau/mu))` (Beer–Lambert), no eigen-solve.
pub fn absorber_operators(mu: &[f64], extras: &[Extra], tau: f64) -> LayerOperators {
    let n = mu.len();
    let dim = n + extras.len();
    let mut tt = Mat::<f64>::zeros(dim, dim);
    for i in 0..n {
        tt[(i, i)] = atten(tau, mu[i]);
    }
    for (e, ex) in extras.iter().enumerate() {
        if let Some(mu_x) = ex.mu {
            tt[(n + e, n + e)] = atten(tau, mu_x);
        }
    }
    LayerOperators {
        r_top: Mat::zeros(dim, dim),
        t_down: tt.clone(),
        r_bottom: Mat::zeros(dim, dim),
        t_up: tt,
    }
}

/// Operators of one layer and order on the augmented space, choosing the
/// absorber shortcut when nothing scatters.
///
/// # Errors
/// Those of [`SlabSolution::new`].
pub fn slab_operators(
    mu: &[f64],
    w: &[f64],
    extras: &[Extra],
    p: &SlabOrder<'_>,
    tms: Option<&Tms>,
) -> Result<LayerOperators, MultifluxError> {
    let scatters =
        p.omega > 0.0 && p.tau > 0.0 && p.m < p.chi.len() && p.chi[p.m..].iter().any(|&c| c != 0.0);
    if !scatters {
        return Ok(absorber_operators(mu, extras, p.tau));
    }
    Ok(SlabSolution::build(mu, w, p, true)?.operators(extras, tms))
}

/// The column of the beam `extras[eb]` in the `r_top` and `t_down` of
/// [`slab_operators`] (the same numbers up to rounding), without the
/// node-to-node operators (eq. S5 by vector solves, eq. S6 and eq. 14 of
/// `docs/multiflux.md`): the whole answer for a layer alone under a
/// collimated beam, at about half the cost per Fourier order.
///
/// # Errors
/// Those of [`SlabSolution::new`].
pub fn slab_beam_response(
    mu: &[f64],
    w: &[f64],
    extras: &[Extra],
    eb: usize,
    p: &SlabOrder<'_>,
    tms: Option<&Tms>,
) -> Result<(Vec<f64>, Vec<f64>), MultifluxError> {
    let scatters =
        p.omega > 0.0 && p.tau > 0.0 && p.m < p.chi.len() && p.chi[p.m..].iter().any(|&c| c != 0.0);
    if !scatters {
        // Beer–Lambert: only the unscattered beam.
        let dim = mu.len() + extras.len();
        let mut ct = vec![0.0; dim];
        if let Some(mu_b) = extras[eb].mu {
            ct[mu.len() + eb] = atten(p.tau, mu_b);
        }
        return Ok((vec![0.0; dim], ct));
    }
    Ok(SlabSolution::build(mu, w, p, false)?.beam_response(extras, eb, tms))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `X = B C^-1` by the LU factors (column updates) and by faer's LU
    /// agree, and `X C` gives back `B`: a matrix that needs pivoting (zero
    /// and small leading entries) at sizes on both sides of the switch.
    #[test]
    fn right_solve_inverts_from_the_right() {
        for n in [1usize, 2, 5, 17, 32, 40] {
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
