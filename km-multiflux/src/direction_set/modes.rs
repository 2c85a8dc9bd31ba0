//! The eigen-solution of a slab on a direction set (seed eq. 18–20: the
//! operators `H_o`, `H_e` of docs eq. DS7 handed to the half-size solve of
//! [`crate::eigen`]) with its reflection and transmission operators. The
//! phase matrix is built and renormalised in `crate::phase_matrix` (eq. DS3).

use super::*;
use crate::eigen::{EigenFailure, HalfSizeModes, half_size_modes_in};
use crate::workspace::with_workspace;

// ---------------------------------------------------------------------------
// Eigen-solution of one homogeneous medium

/// The discrete modes of a homogeneous medium (seed eq. 18–19), in the
/// half-size form of the plus/minus symmetry (Stamnes & Swanson 1981).
///
/// With `M = diag(mu)`, `W = diag(w)`, `A = M^-1 (sigma_t - sigma_s P++)`,
/// `B = M^-1 sigma_s P+-`, the system is `d/dz [I+; I-] = [[-A, B], [-B, A]] [I+; I-]`.
/// Its eigenvalues are `+-lambda_k` with `lambda_k^2` the eigenvalues of
/// `(A + B)(A - B)` (docs eq. DS6). The decaying mode `exp(-lambda z)` has
/// `I+ = (S + lambda F) / 2`, `I- = (S - lambda F) / 2` with
/// `(A + B)(A - B) S = lambda^2 S` and `F = (A + B)^-1 S`; the growing one is
/// its mirror image. `(A + B)(A - B)` is similar to the symmetric
/// `L^T H_e L` (`H_o = L L^T`, `H_o,e = (MW)^-1/2 W (sigma_t - sigma_s (P++ -+ P+-)) (MW)^-1/2`),
/// so `S = (MW)^-1/2 L Y`, `F = (MW)^-1/2 L^-T Y` with `Y` orthonormal (docs eq. DS7).
#[derive(Debug, Clone)]
pub struct DiscreteModes {
    mu: Vec<f64>,
    lambda: Vec<f64>,
    S: Mat<f64>,
    F: Mat<f64>,
}

impl DiscreteModes {
    /// Modes from the cosines `mu` (`> 0`), weights `w` and renormalised phase
    /// blocks `P++`, `P+-` (with `w_i P_ij = w_j P_ji`), for coefficients
    /// `sigma_a, sigma_s >= 0` (1/length) with `sigma_t > 0`.
    ///
    /// # Errors
    /// Invalid coefficients, a failed Cholesky or eigen-decomposition.
    pub fn new(
        mu: &[f64],
        w: &[f64],
        PP: &Mat<f64>,
        PM: &Mat<f64>,
        sigma_a: f64,
        sigma_s: f64,
    ) -> Result<DiscreteModes> {
        if !sigma_a.is_finite() || sigma_a < 0.0 {
            return Err(invalid("sigma_a", sigma_a, "must be finite and >= 0"));
        }
        if !sigma_s.is_finite() || sigma_s < 0.0 {
            return Err(invalid("sigma_s", sigma_s, "must be finite and >= 0"));
        }
        let sigma_t = sigma_a + sigma_s;
        if sigma_t <= 0.0 {
            return Err(invalid("sigma_t", sigma_t, "modes need sigma_t > 0"));
        }
        let n = mu.len();
        // Symmetric odd / even operators H_o, H_e (docs eq. DS7).
        let rs: Vec<f64> = (0..n).map(|i| (mu[i] * w[i]).sqrt().recip()).collect();
        let h = |sign: f64| {
            Mat::from_fn(n, n, |i, j| {
                let c = |i: usize, j: usize| {
                    let id = if i == j { sigma_t } else { 0.0 };
                    w[i] * (id - sigma_s * (PP[(i, j)] + sign * PM[(i, j)]))
                };
                0.5 * (c(i, j) + c(j, i)) * rs[i] * rs[j]
            })
        };
        let h_odd = h(-1.0);
        let h_even = h(1.0);
        // H_o = L L^T (positive definite for |g| < 1), L^T H_e L Y = lambda^2 Y
        // (crate::eigen eq. EG1). Conservative scattering has exactly one null
        // mode (the isotropic radiance; docs eq. DS7): rounding would give it
        // lambda ~ 1e-8 sigma_t / mu_min, which matters at tau ~ 1e4 and above,
        // so its value is set to 0.
        let HalfSizeModes { k: lambda, v, z } = with_workspace(|ws| {
            half_size_modes_in(&h_odd, &h_even, (sigma_a == 0.0, mu.is_sorted()), ws)
        })
        .map_err(|e| match e {
            EigenFailure::Cholesky(d) => numerical("Cholesky of the odd operator", d),
            EigenFailure::Eigen(d) => numerical("symmetric eigen-decomposition", d),
        })?;
        // Back from the symmetric coordinates: S = (MW)^-1/2 v~, F = (MW)^-1/2 z~.
        let (mut S, mut F) = (v, z);
        for i in 0..n {
            for k in 0..n {
                S[(i, k)] *= rs[i];
                F[(i, k)] *= rs[i];
            }
        }
        if S.col_iter().any(|c| c.iter().any(|v| !v.is_finite())) {
            return Err(numerical("discrete modes", format!("non-finite eigenvectors, N = {n}")));
        }
        Ok(DiscreteModes { mu: mu.to_vec(), lambda, S, F })
    }

    /// The decay constants `lambda_k >= 0` (1/length), ascending; the
    /// eigenvalues of `Q` are `+-lambda_k` (seed eq. 19).
    pub fn lambda(&self) -> &[f64] {
        &self.lambda
    }

    /// Eigenvectors of the decaying modes `exp(-lambda_k z)`: column `k` of
    /// `(X+, X-)` is the downward and upward radiance of mode `k`
    /// (`X+- = (S +- lambda F) / 2`, docs eq. DS6). The growing mode
    /// `exp(+lambda_k z)` is `(X-, X+)`.
    pub fn eigenvectors(&self) -> (Mat<f64>, Mat<f64>) {
        let n = self.mu.len();
        let xp =
            Mat::from_fn(n, n, |i, k| 0.5 * (self.S[(i, k)] + self.lambda[k] * self.F[(i, k)]));
        let xm =
            Mat::from_fn(n, n, |i, k| 0.5 * (self.S[(i, k)] - self.lambda[k] * self.F[(i, k)]));
        (xp, xm)
    }

    /// Reflection and transmission operators of a slab of `thickness`
    /// (length, `>= 0`, `inf` for a half-space). Docs eq. DS8–DS10, with
    /// `t_k = tanh(lambda_k z0 / 2)`, `c_k = t_k / lambda_k` (`-> z0 / 2`):
    ///
    /// * `R + T = (S - F diag(lambda t)) (S + F diag(lambda t))^-1`
    /// * `R - T = (S diag(c) - F) (S diag(c) + F)^-1`
    /// * `T = S (S + F diag(lambda t))^-1 F diag(sech^2(lambda z0 / 2)) (S diag(c) + F)^-1`
    ///
    /// Every factor is bounded for every `lambda >= 0` and `z0`: this is the
    /// seed's eq. 20 with each mode anchored at the face it decays from.
    ///
    /// # Errors
    /// Negative or NaN thickness; a singular system.
    pub fn operators(&self, thickness: f64) -> Result<LayerOperators> {
        if thickness.is_nan() || thickness < 0.0 {
            return Err(invalid("thickness", thickness, "must be >= 0 or inf"));
        }
        let n = self.mu.len();
        if thickness == 0.0 {
            return Ok(LayerOperators {
                r_top: Mat::zeros(n, n),
                t_down: Mat::identity(n, n),
                r_bottom: Mat::zeros(n, n),
                t_up: Mat::identity(n, n),
            });
        }
        let (S, F, lam) = (&self.S, &self.F, &self.lambda);
        if thickness.is_infinite() {
            // Half-space: t = 1, T = 0, R = (S - F Lambda)(S + F Lambda)^-1.
            let num = Mat::from_fn(n, n, |i, k| S[(i, k)] - F[(i, k)] * lam[k]);
            let den = Mat::from_fn(n, n, |i, k| S[(i, k)] + F[(i, k)] * lam[k]);
            let r = den.partial_piv_lu().rsolve(&num);
            check_finite(&r, "half-space reflection")?;
            return Ok(LayerOperators {
                r_top: r.clone(),
                t_down: Mat::zeros(n, n),
                r_bottom: r,
                t_up: Mat::zeros(n, n),
            });
        }
        // Per-mode factors, all bounded (docs eq. DS9).
        let mut lt = vec![0.0; n];
        let mut c = vec![0.0; n];
        let mut sech2 = vec![0.0; n];
        for k in 0..n {
            let x = lam[k] * thickness;
            let t = (0.5 * x).tanh();
            lt[k] = lam[k] * t;
            c[k] = if x < 1e-4 { 0.5 * thickness * (1.0 - x * x / 12.0) } else { t / lam[k] };
            let e = (-x).exp();
            sech2[k] = 4.0 * e / ((1.0 + e) * (1.0 + e));
        }
        let n1 = Mat::from_fn(n, n, |i, k| S[(i, k)] - F[(i, k)] * lt[k]);
        let d1 = Mat::from_fn(n, n, |i, k| S[(i, k)] + F[(i, k)] * lt[k]);
        let n2 = Mat::from_fn(n, n, |i, k| S[(i, k)] * c[k] - F[(i, k)]);
        let d2 = Mat::from_fn(n, n, |i, k| S[(i, k)] * c[k] + F[(i, k)]);
        let lu1 = d1.partial_piv_lu();
        let lu2 = d2.partial_piv_lu();
        let sum = lu1.rsolve(&n1);
        let diff = lu2.rsolve(&n2);
        // T = S D1^-1 F sech^2 D2^-1 (docs eq. DS10): decays like exp(-lambda z0).
        let fs = Mat::from_fn(n, n, |i, k| F[(i, k)] * sech2[k]);
        let t = lu2.rsolve(&(lu1.rsolve(S) * fs));
        let r = Mat::from_fn(n, n, |i, j| 0.5 * (sum[(i, j)] + diff[(i, j)]));
        check_finite(&r, "slab reflection")?;
        check_finite(&t, "slab transmission")?;
        Ok(LayerOperators { r_top: r.clone(), t_down: t.clone(), r_bottom: r, t_up: t })
    }
}

fn check_finite(m: &Mat<f64>, what: &'static str) -> Result<()> {
    if m.col_iter().all(|c| c.iter().all(|v| v.is_finite())) {
        Ok(())
    } else {
        Err(numerical(what, format!("singular system ({} x {})", m.nrows(), m.ncols())))
    }
}
