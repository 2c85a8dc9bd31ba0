//! The search of the slab inverse (`docs/inverse.md` §4): the unbounded
//! search variables, the residuals, Levenberg–Marquardt with a
//! Broyden-updated Jacobian, the two-flux start and the restarts, and the
//! stream ladder of the accuracy rule (eq. I7). Used by [`crate::slab::fit`].

use crate::InverseError;
use crate::forward::{Optical, tau_from_unscattered, unscattered_transmittance};
use crate::linalg;
use crate::measurement::{Measurement, Setup, model, model_with};
use crate::stack::StackModel;

/// Bounds of the search variables: `|u| <= 36` keeps `a` within 2e-16 of
/// 0 and 1; `b` in `[1e-6, 1e4]` (iad clamps `b >= 1e-6` too); `|g| <= 0.995`.
pub(crate) const U_MAX: f64 = 36.0;
pub(crate) const V_MIN: f64 = -13.8;
pub(crate) const V_MAX: f64 = 9.2;
pub(crate) const W_MAX: f64 = 2.99; // atanh(0.995)

/// The free parameters and their transforms (step 2 of the module doc).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Space {
    /// `g` is free.
    pub(crate) fit_g: bool,
    /// `g` when fixed.
    pub(crate) g_fixed: f64,
}

impl Space {
    pub(crate) fn dim(&self) -> usize {
        if self.fit_g { 3 } else { 2 }
    }
    pub(crate) fn optical_at(&self, x: &[f64]) -> Optical {
        let albedo = 1.0 / (1.0 + (-x[0]).exp());
        let tau = x[1].exp();
        let g = if self.fit_g { x[2].tanh() } else { self.g_fixed };
        Optical { albedo, tau, g }
    }
    pub(crate) fn point_of(&self, p: &Optical) -> Vec<f64> {
        let a = p.albedo.clamp(1e-12, 1.0 - 1e-12);
        let mut x = vec![(a / (1.0 - a)).ln(), p.tau.ln()];
        if self.fit_g {
            x.push(p.g.atanh());
        }
        self.clamp(&mut x);
        x
    }
    pub(crate) fn clamp(&self, x: &mut [f64]) {
        x[0] = x[0].clamp(-U_MAX, U_MAX);
        x[1] = x[1].clamp(V_MIN, V_MAX);
        if self.fit_g {
            x[2] = x[2].clamp(-W_MAX, W_MAX);
        }
    }
    /// `d(natural)/d(transformed)` per variable: `a (1 - a)`, `b`, `1 - g^2`.
    pub(crate) fn chain(&self, p: &Optical) -> Vec<f64> {
        let mut c = vec![p.albedo * (1.0 - p.albedo), p.tau];
        if self.fit_g {
            c.push(1.0 - p.g * p.g);
        }
        c
    }
}

/// Residuals of the search: `(model_i - measured_i) / scale_i`.
pub(crate) struct Problem<'a> {
    pub(crate) set: &'a Setup,
    pub(crate) space: Space,
    pub(crate) meas: Vec<f64>,
    pub(crate) scale: Vec<f64>,
    /// Log-ratio residuals (square systems) instead of `(M - m) / scale`.
    pub(crate) log: bool,
    /// The forward model at the current stream count.
    pub(crate) stack: StackModel,
    pub(crate) evaluations: usize,
    /// The last point evaluated and its model (a repeated point costs nothing).
    pub(crate) last: Option<(Vec<f64>, usize, [f64; 3])>,
}

impl Problem<'_> {
    /// Use `streams` from now on (a new [`StackModel`] when it changes).
    pub(crate) fn set_streams(&mut self, streams: usize) -> Result<(), InverseError> {
        if self.stack.streams() != streams {
            self.stack = StackModel::new(&self.set.sample, streams)?;
        }
        Ok(())
    }

    /// The measurement model at the search point `x` (memoised for the last point).
    pub(crate) fn model_at(&mut self, x: &[f64]) -> Result<[f64; 3], InverseError> {
        let n = self.stack.streams();
        if let Some((lx, ln, lm)) = &self.last
            && lx.as_slice() == x
            && *ln == n
        {
            return Ok(*lm);
        }
        self.evaluations += 1;
        let m = model_with(self.set, &self.stack, &self.space.optical_at(x))?;
        self.last = Some((x.to_vec(), n, m));
        Ok(m)
    }

    pub(crate) fn residuals(&mut self, x: &[f64]) -> Result<(Vec<f64>, [f64; 3]), InverseError> {
        let m = self.model_at(x)?;
        let r = (0..self.meas.len())
            .map(|i| {
                if self.log {
                    // Log ratio: symmetric in over- and undershoot, so tiny
                    // M_T or M_U do not drive the search to a = 0.
                    (m[i].max(1e-300) / self.meas[i].max(1e-300)).ln()
                } else {
                    (m[i] - self.meas[i]) / self.scale[i]
                }
            })
            .collect();
        Ok((r, m))
    }

    /// Forward-difference Jacobian in the transformed variables (row-major,
    /// measurements x parameters); step `1e-7` (about the square root of the
    /// forward model's relative precision, ~1e-14).
    pub(crate) fn jacobian(&mut self, x: &[f64], r0: &[f64]) -> Result<Vec<f64>, InverseError> {
        let (m, n) = (r0.len(), x.len());
        let mut jac = vec![0.0; m * n];
        for j in 0..n {
            let h = 1e-7 * x[j].abs().max(1.0);
            let mut xh = x.to_vec();
            // Step inward at a bound so the model stays defined.
            xh[j] += if x[j] + h > bound_hi(&self.space, j) { -h } else { h };
            let step = xh[j] - x[j];
            let (rh, _) = self.residuals(&xh)?;
            for i in 0..m {
                jac[i * n + j] = (rh[i] - r0[i]) / step;
            }
        }
        Ok(jac)
    }

    /// Levenberg–Marquardt from `x` (Marquardt 1963; Press et al.,
    /// *Numerical Recipes* §15.5): returns the best point and its residuals.
    ///
    /// The Jacobian is computed by forward differences once, then carried
    /// along by Broyden's rank-one update after each accepted step (Broyden
    /// 1965; Dennis & Schnabel 1996 §8.1): `J += (dr - J dx) dx^T / (dx^T dx)`,
    /// one forward solve per step instead of one plus one per parameter. It is
    /// recomputed by differences when a damped step fails with the updated
    /// Jacobian; the search ends only when a fresh Jacobian gives no descent.
    pub(crate) fn levenberg_marquardt(
        &mut self,
        mut x: Vec<f64>,
    ) -> Result<(Vec<f64>, f64), InverseError> {
        let n = x.len();
        let (mut r, _) = self.residuals(&x)?;
        let mut chi2 = sq(&r);
        let mut lambda = 1e-3;
        let mut jac = self.jacobian(&x, &r)?;
        let mut fresh = true;
        for _ in 0..200 {
            // Converged to round-off: the relative residuals are at the
            // forward model's precision (~1e-15).
            if chi2 < 1e-26 {
                break;
            }
            let (a, grad) = normal_equations(&jac, &r, n);
            let mut accepted = None;
            while lambda < 1e12 {
                // Damped step (A + lambda diag A) dx = -grad.
                let mut ad = a.clone();
                for p in 0..n {
                    ad[p * n + p] += lambda * a[p * n + p].max(1e-30);
                }
                let neg: Vec<f64> = grad.iter().map(|g| -g).collect();
                let Some(dx) = linalg::solve(&ad, &neg, n) else {
                    lambda *= 10.0;
                    continue;
                };
                let mut xn: Vec<f64> = x.iter().zip(&dx).map(|(a, b)| a + b).collect();
                self.space.clamp(&mut xn);
                let (rn, _) = self.residuals(&xn)?;
                if sq(&rn) < chi2 {
                    accepted = Some((xn, rn));
                    lambda = (lambda / 10.0).max(1e-12);
                    break;
                }
                lambda *= 10.0;
            }
            let Some((xn, rn)) = accepted else {
                if fresh {
                    break;
                }
                // The updated Jacobian led nowhere: differences again.
                jac = self.jacobian(&x, &r)?;
                (fresh, lambda) = (true, 1e-3);
                continue;
            };
            let dx: Vec<f64> = xn.iter().zip(&x).map(|(a, b)| a - b).collect();
            let step = dx.iter().fold(0.0f64, |s, d| s.max(d.abs()));
            broyden_update(&mut jac, &dx, &r, &rn);
            fresh = false;
            (x, r) = (xn, rn);
            let before = chi2;
            chi2 = sq(&r);
            // A step below 1e-13 changes nothing further; nor does a step
            // that lowers chi^2 by less than 1e-12 of itself (a minimum
            // that is not a root: the search would crawl on to the cap).
            if step < 1e-13 || before - chi2 <= 1e-12 * before {
                break;
            }
        }
        Ok((x, chi2))
    }
}

/// Normal equations of a row-major Jacobian `J` (`m x n`): `(J^T J, J^T r)`.
fn normal_equations(jac: &[f64], r: &[f64], n: usize) -> (Vec<f64>, Vec<f64>) {
    let mut a = vec![0.0; n * n];
    let mut grad = vec![0.0; n];
    for (i, ri) in r.iter().enumerate() {
        for p in 0..n {
            grad[p] += jac[i * n + p] * ri;
            for q in 0..n {
                a[p * n + q] += jac[i * n + p] * jac[i * n + q];
            }
        }
    }
    (a, grad)
}

/// Broyden's rank-one update of a row-major Jacobian after the step `dx`
/// that moved the residuals from `r` to `rn` (Broyden 1965, the "good"
/// update): `J += (rn - r - J dx) dx^T / (dx^T dx)`.
fn broyden_update(jac: &mut [f64], dx: &[f64], r: &[f64], rn: &[f64]) {
    let n = dx.len();
    let dd: f64 = dx.iter().map(|d| d * d).sum();
    if dd == 0.0 {
        return;
    }
    for i in 0..r.len() {
        let jdx: f64 = (0..n).map(|j| jac[i * n + j] * dx[j]).sum();
        let f = (rn[i] - r[i] - jdx) / dd;
        for j in 0..n {
            jac[i * n + j] += f * dx[j];
        }
    }
}

fn bound_hi(space: &Space, j: usize) -> f64 {
    match j {
        0 => U_MAX,
        1 => V_MAX,
        _ => {
            let _ = space;
            W_MAX
        }
    }
}

fn sq(r: &[f64]) -> f64 {
    r.iter().map(|v| v * v).sum()
}

/// Starting point from the two-flux inverse (`docs/inverse.md` eq. I4–I6):
/// Kubelka's closed forms for a layer of diffuse reflectance `R` and
/// transmittance `T`,
///
/// `A = (1 + R^2 - T^2) / (2R)`, `B = sqrt(A^2 - 1)`,
/// `S d = ln((1 - R (A - B)) / T) / B`, `K d = S d (A - 1)`, (I4)
///
/// with `K = 2 mu_a`, `S = (3 mu_s' - mu_a) / 4` (I5), then
/// `a = a' / (1 - g + a' g)`, `b = b' / (1 - a g)` from the reduced
/// `a' = mu_s' / (mu_a + mu_s')`, `b' = (mu_a + mu_s') d` (I6).
/// With `M_U`, `b` comes from (F3) instead.
pub(crate) fn start(set: &Setup, meas: &Measurement, g: f64) -> Optical {
    let (r_b, _) = crate::forward::boundary(set.sample.n_sample, set.sample.n_slide);
    // Diffuse parts, roughly: remove the first-surface specular reflection.
    let r = (meas.m_r - set.specular_in_m_r * r_b).max(1e-4);
    let t = meas.m_t.max(1e-6);
    let fallback = Optical { albedo: 0.9, tau: 1.0, g };
    let ka = (1.0 + r * r - t * t) / (2.0 * r);
    let kb = (ka * ka - 1.0).max(0.0).sqrt();
    let (sd, kd) = if kb > 1e-8 && r + t < 1.0 {
        let sd = ((1.0 - r * (ka - kb)) / t).ln() / kb;
        (sd, sd * (ka - 1.0))
    } else {
        // No absorption in the two-flux sense: T = 1 / (1 + S d).
        ((1.0 - t) / t, 1e-3)
    };
    let mu_a = (kd / 2.0).max(1e-6);
    let mu_sp = ((4.0 * sd + mu_a) / 3.0).max(1e-6);
    let ap = mu_sp / (mu_a + mu_sp);
    let bp = mu_a + mu_sp;
    let mut p = Optical { albedo: ap / (1.0 - g + ap * g), tau: 0.0, g };
    p.tau = bp / (1.0 - p.albedo * g);
    if let Some(u) = meas.m_u
        && let Ok(b) = tau_from_unscattered(u, set.sample.n_sample, set.sample.n_slide)
    {
        p.tau = b;
        p.albedo = (1.0 - mu_a / b.max(1e-9)).clamp(0.05, 0.999);
    }
    p.albedo = p.albedo.clamp(0.05, 0.999);
    p.tau = p.tau.clamp(1e-3, 1e3);
    if p.albedo.is_finite() && p.tau.is_finite() { p } else { fallback }
}

/// Starting points of the restarts (step 2 of `crate::slab`): a grid over
/// `(a, b)` that includes `b` just above the Beer–Lambert bound of `M_T`
/// (the unscattered beam alone bounds `b` from below, `T >= T_u(b)`: thick
/// samples start just above that bound).
fn restart_grid(set: &Setup, meas: &Measurement) -> [(f64, f64); 8] {
    let (n_s, n_g) = (set.sample.n_sample, set.sample.n_slide);
    let top = 0.999 * unscattered_transmittance(n_s, n_g, 0.0);
    let b_min = tau_from_unscattered(meas.m_t.min(top), n_s, n_g).unwrap_or(1.0).max(0.01);
    [
        (0.5, 0.3),
        (0.99, 3.0),
        (0.9, 30.0),
        (0.3, 3.0),
        (0.999, 0.5),
        (0.3, 1.05 * b_min),
        (0.7, 1.05 * b_min),
        (0.95, 1.05 * b_min),
    ]
}

/// The search over the stream ladder (steps 2–3 of `crate::slab`): at each
/// stream count `N` a Levenberg–Marquardt search from the previous answer
/// (restarted from [`restart_grid`] when a square system ends off a root),
/// then the stream rule (eq. I7): stop when the model at `2N` moves by less
/// than `sigma_min / 10`. Returns the answer in search variables; remarks go
/// to `notes`.
pub(crate) fn search_ladder(
    prob: &mut Problem<'_>,
    mut x: Vec<f64>,
    ladder: &[usize],
    meas: &Measurement,
    sigma_min: f64,
    notes: &mut Vec<String>,
) -> Result<Vec<f64>, InverseError> {
    let square = prob.meas.len() == prob.space.dim();
    for (k, &n) in ladder.iter().enumerate() {
        prob.set_streams(n)?;
        let (xn, mut chi2) = prob.levenberg_marquardt(x)?;
        x = xn;
        // Restarts when the start did not lead to a root (step 2), at the
        // first stream count only: later counts start from its answer.
        if square && chi2 > 1e-12 && k == 0 {
            let g = if prob.space.fit_g { 0.5 } else { prob.space.g_fixed };
            for (a, b) in restart_grid(prob.set, meas) {
                let xs = prob.space.point_of(&Optical { albedo: a, tau: b, g });
                let (xr, cr) = prob.levenberg_marquardt(xs)?;
                if cr < chi2 {
                    (x, chi2) = (xr, cr);
                }
            }
            notes.push(format!("restarted from a grid of starting points at {n} streams"));
        }
        if ladder.len() == 1 {
            break;
        }
        // No root at this stream count (a relative misfit above 1e-4): more
        // streams will not make one; the answer is the nearest point.
        if square && chi2 > 1e-8 {
            notes.push(format!(
                "no exact solution at {n} streams (chi^2 = {chi2:.1e} of log ratios): \
                 finer stream counts not tried"
            ));
            break;
        }
        // Stream rule (I7): the forward model at 2N moves by < sigma_min / 10.
        let m_n = prob.model_at(&x)?;
        let m_2n = model(prob.set, &prob.space.optical_at(&x), 2 * n)?;
        prob.evaluations += 1;
        let moved = (0..prob.meas.len()).map(|i| (m_n[i] - m_2n[i]).abs()).fold(0.0, f64::max);
        if moved < 0.1 * sigma_min {
            break;
        }
        if k + 1 == ladder.len() {
            notes.push(format!(
                "stream rule not met: the model moves by {moved:.1e} from {n} to {} streams \
                 (wanted < {:.1e})",
                2 * n,
                0.1 * sigma_min
            ));
        }
    }
    Ok(x)
}
