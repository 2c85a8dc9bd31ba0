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
//! `L^T H- L y = k^2 y`, `v~ = L y`, `z~ = L^-T y` (S3), solved by
//! [`crate::eigen::half_size_modes`] (N x N instead of 2N x 2N; the same
//! solve serves the direction set). The phase matrix `P` comes from
//! `phase_matrix::fourier_blocks_in`.
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

mod beam;
mod field;
/// Public only for the LU benchmark of km-bench (`benches/lu.rs`).
#[doc(hidden)]
pub mod lu;
mod operators;
mod probe;

use faer::Mat;

use crate::MultifluxError;
use crate::correction::{atten, phi};
use crate::eigen::{EigenFailure, HalfSizeModes, half_size_modes_in};
use crate::legendre::LegendreRecurrence;
use crate::phase_matrix::fourier_blocks_in;
use crate::workspace::{Workspace, with_workspace};
pub use field::{FieldModes, FieldWeights};
use lu::{Lu, solve_right};
pub(crate) use operators::slab_augmented_kept;
pub use operators::{absorber_operators, slab_beam_reflection, slab_beam_response, slab_operators};

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
        let (t, chi, lam, rec) = Self::node_tables(mu, w, p);
        let renorm_m0 = m == 0;

        let fail = |what: &'static str| MultifluxError::Numerical {
            what,
            detail: format!("N = {n}, tau = {tau}, omega = {omega}, m = {m}"),
        };
        // Eq. S3-S5 in matrices and vectors of the workspace (handed back by
        // `SlabSolution::recycle`).
        with_workspace(|ws| {
            // One medium's nodes: cosines ascending (a refracting layer's
            // are the refracted ones of the medium above, then its own).
            let one_medium = mu.is_sorted();
            let (pe, po) = fourier_blocks_in(w, (m, one_medium), &chi, &lam, n, ws);
            let (hp, hm) = h_matrices(mu, w, omega, &pe, &po, ws);
            ws.give_mat(pe);
            ws.give_mat(po);
            // Eq. S3 (crate::eigen eq. EG1). Conservative scattering: the
            // discrete system conserves energy exactly (renormalised above),
            // so the smallest eigenvalue is exactly 0.
            let modes = half_size_modes_in(&hp, &hm, (m == 0 && omega == 1.0, one_medium), ws);
            let HalfSizeModes { k, v, z } = match modes {
                Ok(modes) => modes,
                Err(e) => {
                    ws.give_mat(hp);
                    ws.give_mat(hm);
                    return Err(match e {
                        EigenFailure::Cholesky(_) => fail("Cholesky of H+"),
                        EigenFailure::Eigen(_) => fail("eigen-solver"),
                    });
                }
            };
            let half = tau.is_infinite();
            let (e, [cp, cp_out, cm, cm_out]) = boundary_matrices(&v, &z, &k, tau, ws);
            // LU factors of Cp and Cm: every later use is a solve, never an inverse.
            let lu_p = Lu::new_in(&cp, ws);
            let lu_m = (!half).then(|| Lu::new_in(&cm, ws));
            let rt = Self::node_parts(
                n,
                full,
                (&lu_p, lu_m.as_ref()),
                [&cp, &cp_out, &cm, &cm_out],
                &t,
                ws,
            );
            ws.give_mat(cp);
            ws.give_mat(cm);
            let (r, tr) = rt.map_err(fail)?;
            let (mut mu_c, mut w_c) = (ws.take_for_overwrite(n), ws.take_for_overwrite(n));
            mu_c.copy_from_slice(mu);
            w_c.copy_from_slice(w);
            Ok(SlabSolution {
                n,
                tau,
                omega,
                m,
                t,
                mu: mu_c,
                w: w_c,
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
        })
    }

    /// `t = sqrt(w mu)`, the weighted moments `chi` and the Legendre table
    /// `Lambda_l^m(mu_i)` (node-major) of order `p.m`, in vectors of the
    /// workspace (handed back by `SlabSolution::recycle`); every element is
    /// written here (the recurrence's coefficient vectors by `new_in`).
    fn node_tables(
        mu: &[f64],
        w: &[f64],
        p: &SlabOrder<'_>,
    ) -> (Vec<f64>, Vec<f64>, Vec<f64>, LegendreRecurrence) {
        let (n, m, nl) = (mu.len(), p.m, p.chi.len());
        let (mut t, mut chi, mut lam, ra, rb) = with_workspace(|ws| {
            (
                ws.take_for_overwrite(n),
                ws.take_for_overwrite(nl),
                ws.take_for_overwrite(n * nl),
                ws.take_for_overwrite(nl),
                ws.take_for_overwrite(nl),
            )
        });
        for ((t, u), w) in t.iter_mut().zip(mu).zip(w) {
            *t = (u * w).sqrt();
        }
        for (l, c) in chi.iter_mut().enumerate() {
            *c = if l < m { 0.0 } else { (2 * l + 1) as f64 * p.chi[l] };
        }
        let rec = LegendreRecurrence::new_in(m, nl, ra, rb);
        for (i, &x) in mu.iter().enumerate() {
            rec.eval(x, &mut lam[i * nl..(i + 1) * nl]);
        }
        (t, chi, lam, rec)
    }

    /// The node-to-node `R` and `T` when `full` (eq. S5), else empty after
    /// checking that the factors are usable; `Err` names the failure.
    fn node_parts(
        n: usize,
        full: bool,
        (lu_p, lu_m): (&Lu, Option<&Lu>),
        c: [&Mat<f64>; 4],
        t: &[f64],
        ws: &mut Workspace,
    ) -> Result<(Mat<f64>, Mat<f64>), &'static str> {
        if full {
            node_rt(lu_p, lu_m, c, t, ws).ok_or("layer operators (non-finite)")
        } else {
            // Only the factors are kept: check that they are usable.
            let finite = lu_p.lu.iter().all(|x| x.is_finite())
                && lu_m.is_none_or(|l| l.lu.iter().all(|x| x.is_finite()));
            let regular = (0..n)
                .all(|k| lu_p.lu[k * n + k] != 0.0 && lu_m.is_none_or(|l| l.lu[k * n + k] != 0.0));
            if !(finite && regular) {
                return Err("layer operators (singular boundary matrix)");
            }
            Ok((Mat::zeros(0, 0), Mat::zeros(0, 0)))
        }
    }

    /// Hand this solution's matrices and vectors that came from the
    /// workspace back to it (the end of a layer's order).
    pub(crate) fn recycle(self, ws: &mut Workspace) {
        // One field at a time (an array of them would be a copy of its own).
        let (ra, rb) = self.rec.into_buffers();
        ws.give(self.mu);
        ws.give(self.w);
        ws.give(self.ek);
        ws.give(self.k);
        ws.give(self.t);
        ws.give(self.chi);
        ws.give(self.lam);
        ws.give(ra);
        ws.give(rb);
        self.lu_p.recycle(ws);
        if let Some(lu) = self.lu_m {
            lu.recycle(ws);
        }
        ws.give_mat(self.cp_out);
        ws.give_mat(self.cm_out);
        ws.give_mat(self.r);
        ws.give_mat(self.tr);
        ws.give_mat(self.v);
        ws.give_mat(self.z);
        ws.give_mat(self.hp);
        ws.give_mat(self.hm);
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
}

/// `H± = diag(1/mu) - omega sqrt(w/mu) P_{odd/even} sqrt(w/mu)` (eq. S3).
fn h_matrices(
    mu: &[f64],
    w: &[f64],
    omega: f64,
    pe: &Mat<f64>,
    po: &Mat<f64>,
    ws: &mut Workspace,
) -> (Mat<f64>, Mat<f64>) {
    let n = mu.len();
    let mut sq = ws.take_for_overwrite(n);
    for ((s, u), w) in sq.iter_mut().zip(mu).zip(w) {
        *s = (w / u).sqrt();
    }
    // Every element of both is written below.
    let mut hp = ws.take_mat_for_overwrite(n, n);
    let mut hm = ws.take_mat_for_overwrite(n, n);
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
    ws.give(sq);
    (hp, hm)
}

/// The boundary matrices of eq. S4–S5 from the modes `v~`, `z~`, `k`:
/// `e = exp(-k tau0)` and `[Cp, Cp_out, Cm, Cm_out]` (the `Cm` pair zero for
/// a half-space).
fn boundary_matrices(
    v: &Mat<f64>,
    z: &Mat<f64>,
    k: &[f64],
    tau: f64,
    ws: &mut Workspace,
) -> (Vec<f64>, [Mat<f64>; 4]) {
    let n = k.len();
    let half = tau.is_infinite();
    // Both written for every mode below.
    let (mut e, mut ph) = (ws.take_for_overwrite(n), ws.take_for_overwrite(n));
    for (j, &kj) in k.iter().enumerate() {
        e[j] = if half { 0.0 } else { (-kj * tau).exp() };
        ph[j] = phi(kj, tau);
    }
    // Every element is written below (the Cm pair zeroed for a half-space).
    let mut cp = ws.take_mat_for_overwrite(n, n);
    let mut cp_out = ws.take_mat_for_overwrite(n, n);
    let (mut cm, mut cm_out) = if half {
        (ws.take_mat(n, n), ws.take_mat(n, n))
    } else {
        (ws.take_mat_for_overwrite(n, n), ws.take_mat_for_overwrite(n, n))
    };
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
    ws.give(ph);
    (e, [cp, cp_out, cm, cm_out])
}

/// The node-to-node `R` and `T` (eq. S5): `R~ ± T~ = C_out C^-1` from the
/// factors of `Cp`, `Cm` (`lu_m = None`: a half-space), back to radiances
/// with `t = sqrt(w mu)`; `None` if not finite.
fn node_rt(
    lu_p: &Lu,
    lu_m: Option<&Lu>,
    c: [&Mat<f64>; 4],
    t: &[f64],
    ws: &mut Workspace,
) -> Option<(Mat<f64>, Mat<f64>)> {
    let [cp, cp_out, cm, cm_out] = c;
    let n = t.len();
    let half = lu_m.is_none();
    // R~ ± T~ = C_out C^-1 (eq. S5); transposed: C^-T C_out^T.
    let xp = solve_right(lu_p, cp, cp_out);
    let xm = match lu_m {
        Some(lu) => solve_right(lu, cm, cm_out),
        None => xp.clone(),
    };
    // Back to radiances: R_ji = R~_ji t_i / t_j, by columns i of R.
    // Every element of both is written below.
    let mut r = ws.take_mat_for_overwrite(n, n);
    let mut tr = ws.take_mat_for_overwrite(n, n);
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
    finite.then_some((r, tr))
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

/// [`dot`] of `b` with the vector that holds `a_l` at `l = first, first + 2,
/// ...` and zeros elsewhere, without reading or multiplying the zeros: the
/// same four partial sums (by `l mod 4`) and the same sequential tail as
/// [`dot`], so the value is [`dot`]'s bit for bit (a zero term adds nothing
/// to a partial sum; only the sign of an all-zero result may differ).
#[inline]
fn dot_every_other(a: &[f64], b: &[f64], first: usize) -> f64 {
    let n = a.len().min(b.len());
    let (a, b) = (&a[..n], &b[..n]);
    let full = n - n % 4;
    // Of each chunk of four only lanes `p` and `p + 2` hold terms: two
    // partial sums (`lo`, `hi`), the other two stay zero.
    let p = first & 1;
    let (mut lo, mut hi) = (0.0f64, 0.0f64);
    let mut base = first & !3;
    if base < full {
        // The chunk holding `first`: lane `p` only if it is not before it.
        if base + p >= first {
            lo += a[base + p] * b[base + p];
        }
        hi += a[base + p + 2] * b[base + p + 2];
        base += 4;
        for (x, y) in a[base..full].chunks_exact(4).zip(b[base..full].chunks_exact(4)) {
            lo += x[p] * y[p];
            hi += x[p + 2] * y[p + 2];
        }
    }
    let mut tail = -0.0;
    let mut l = if first >= full { first } else { full + p };
    while l < n {
        tail += a[l] * b[l];
        l += 2;
    }
    // (acc0 + acc1) + (acc2 + acc3) of `dot`, with a zero in each pair.
    lo + hi + tail
}

/// `y += M x` for a small dense matrix, by columns (`y` zero on entry gives `M x`).
fn mat_vec_into(m: &Mat<f64>, x: &[f64], y: &mut [f64]) {
    for (j, &xj) in x.iter().enumerate() {
        for (yi, mij) in y.iter_mut().zip(m.col_as_slice(j)) {
            *yi += mij * xj;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// [`dot_every_other`] is [`dot`] of the zero-filled vector bit for bit,
    /// at every length (remainders 0-3 of the chunks of four) and start.
    #[test]
    fn dot_every_other_is_dot_of_the_zero_filled_vector() {
        let mut s = 99u64;
        let mut rnd = move || {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((s >> 11) as f64) / ((1u64 << 53) as f64) - 0.5
        };
        for n in 0usize..=21 {
            let a: Vec<f64> = (0..n).map(|_| rnd()).collect();
            let b: Vec<f64> = (0..n).map(|_| rnd() * 1e3).collect();
            for first in 0..n + 2 {
                let z: Vec<f64> = (0..n)
                    .map(|l| if l >= first && (l - first) % 2 == 0 { a[l] } else { 0.0 })
                    .collect();
                assert_eq!(
                    dot_every_other(&a, &b, first).to_bits(),
                    dot(&z, &b).to_bits(),
                    "n = {n}, first = {first}"
                );
            }
        }
    }

    /// `(H+, H-)` of a layer for Fourier order `m` on `n` Gauss nodes, built
    /// as [`SlabSolution::build`] does.
    fn operators(n: usize, omega: f64, chi: &[f64], m: usize) -> (Mat<f64>, Mat<f64>) {
        let nodes = crate::quadrature::AngularGrid::new(&[1.0], n).medium(1.0);
        let nl = chi.len();
        let c: Vec<f64> =
            (0..nl).map(|l| if l < m { 0.0 } else { (2 * l + 1) as f64 * chi[l] }).collect();
        let rec = LegendreRecurrence::new(m, nl);
        let mut lam = vec![0.0; n * nl];
        for (i, &x) in nodes.mu.iter().enumerate() {
            rec.eval(x, &mut lam[i * nl..(i + 1) * nl]);
        }
        with_workspace(|ws| {
            let (pe, po) = fourier_blocks_in(&nodes.w, (m, true), &c, &lam, n, ws);
            h_matrices(&nodes.mu, &nodes.w, omega, &pe, &po, ws)
        })
    }

    /// The own eigen-solve (Jacobi up to 6 nodes, QL on the nodes ordered
    /// by the diagonal of `S` from 7 to `OWN_MAX`) against faer's path on
    /// the operators of the cloud deck of examples/ (albedo 0.999999, g =
    /// 0.85, delta-M at 2N moments, a strongly graded problem: k from ~1e-3
    /// to ~1e1), every Fourier order: each `k` within 1e-13 of the largest `k`
    /// (measured: at most 8.5e-15 up to 12 nodes; a QL on the unreversed
    /// order, whose large entries sit top-left where QL loses accuracy,
    /// differed by up to 1.5e-11 at N = 10, its smallest `k` off by 1.6e-6
    /// relative).
    /// A nearly conservative refracting layer (n = 1.5 under air: the
    /// refracted nodes of the air above, cosines 0.75..1, then the layer's
    /// own, 0..0.75), order 0, where `S` is graded but its largest entries
    /// sit in the middle of the node order: QL on the nodes ordered by the
    /// diagonal of `S` against Jacobi rotations on the same `S` (relative
    /// accuracy for small eigenvalues, Demmel & Veselić 1992), each `k`
    /// within 1e-10 relative (measured: at most 4e-12 relative; on the
    /// reversed node order QL's smallest `k` moved the marble half-space's
    /// reflectance by 1.4e-11, on this order by 3e-12).
    #[test]
    fn refracting_layer_keeps_its_small_eigenvalues() {
        for streams in [4usize, 8, 12, 16, 24, 32] {
            let nodes = crate::quadrature::AngularGrid::new(&[1.0, 1.5], streams).medium(1.5);
            let (mu, w) = (&nodes.mu, &nodes.w);
            let n = mu.len();
            let nl = 2 * streams;
            let chi: Vec<f64> =
                (0..nl).map(|l| (2 * l + 1) as f64 * 0.3f64.powi(l as i32)).collect();
            let rec = LegendreRecurrence::new(0, nl);
            let mut lam = vec![0.0; n * nl];
            for (i, &x) in mu.iter().enumerate() {
                rec.eval(x, &mut lam[i * nl..(i + 1) * nl]);
            }
            let (hp, hm) = with_workspace(|ws| {
                let (pe, po) = fourier_blocks_in(w, (0, false), &chi, &lam, n, ws);
                h_matrices(mu, w, 0.999, &pe, &po, ws)
            });
            let ours = crate::eigen::ql_modes_any_order(&hp, &hm);
            let k = crate::eigen::jacobi_k(&hp, &hm);
            for j in 0..n {
                let e = (ours.k[j] - k[j]).abs() / k[j];
                assert!(e <= 1e-10, "N = {n}, k_{j}: {} vs {} ({e:.1e})", ours.k[j], k[j]);
            }
        }
    }

    /// On one medium's Gauss nodes the diagonal of `S` falls along the
    /// nodes in every Fourier order, so that the solve of 13 to 64 nodes is
    /// the own one, never faer's (which refracting layers keep): the modes
    /// the solver returns are those of the fixed-size arrays up to
    /// `SMALL_ONE_MEDIUM` nodes and of QL above, bit for bit (faer's differ
    /// in the last bits), for the slabs of the speed benches (albedo 0.9,
    /// HG g = 0.5, 0.9, delta-M at 2N moments) and a nearly conservative one.
    #[test]
    fn one_mediums_nodes_take_the_own_solve() {
        for (g, albedo) in [(0.5f64, 0.9), (0.9, 0.9), (0.85, 0.999_999)] {
            for n in (crate::eigen::SMALL + 1..=32).chain([48, 64]) {
                let moments: Vec<f64> = (0..=2 * n).map(|l| g.powi(l as i32)).collect();
                let (chi, omega, _) = crate::legendre::delta_m(&moments, albedo, 2 * n);
                for m in 0..2 * n {
                    let (hp, hm) = operators(n, omega, &chi, m);
                    let got = crate::eigen::half_size_modes(&hp, &hm, false).unwrap();
                    let ql = if n <= crate::eigen::SMALL_ONE_MEDIUM {
                        crate::eigen::small_modes_any(&hp, &hm)
                    } else {
                        crate::eigen::ql_modes_any_order(&hp, &hm)
                    };
                    for j in 0..n {
                        assert_eq!(got.k[j].to_bits(), ql.k[j].to_bits(), "g {g}, N {n}, m {m}");
                        for i in 0..n {
                            let (a, b) = (got.v[(i, j)], ql.v[(i, j)]);
                            assert_eq!(a.to_bits(), b.to_bits(), "g {g}, N {n}, m {m}");
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn small_eigen_solve_agrees_with_faers_on_a_cloud() {
        let g: f64 = 0.85;
        for n in (2..=16).chain([24, 32]) {
            let moments: Vec<f64> = (0..=2 * n).map(|l| g.powi(l as i32)).collect();
            let (chi, omega, _) = crate::legendre::delta_m(&moments, 0.999_999, 2 * n);
            for m in 0..2 * n {
                let (hp, hm) = operators(n, omega, &chi, m);
                let ours = crate::eigen::half_size_modes(&hp, &hm, false).unwrap();
                let (k, _, _) = crate::eigen::faer_modes(&hp, &hm);
                let top = k.iter().fold(0.0f64, |a, &b| a.max(b));
                for j in 0..n {
                    let d = (ours.k[j] - k[j]).abs() / top;
                    assert!(
                        d <= 1e-13,
                        "N = {n}, m = {m}, k_{j}: {} vs {} ({d:.1e})",
                        ours.k[j],
                        k[j]
                    );
                }
            }
        }
    }
}
