//! The covariance of the fitted parameters (`docs/inverse.md` §5, eq.
//! I8–I10): the Jacobian of the measurements at the answer (from the
//! search's own, or by one-sided differences at an albedo bound), the
//! condition test of "not unique", and the propagation to `mu_a`, `mu_s`,
//! `mu_s'` with the ill-conditioning flags.

use crate::InverseError;
use crate::forward::Optical;
use crate::linalg;
use crate::measurement::model_with;
use crate::search::Problem;

/// The albedo sits at a bound of the search (`a < 1e-9` or `1 - a < 1e-9`):
/// the direction of an inward step in `a` (`+1` at 0, `-1` at 1).
pub(crate) fn albedo_edge(p: &Optical) -> Option<f64> {
    if p.albedo < 1e-9 {
        Some(1.0)
    } else if 1.0 - p.albedo < 1e-9 {
        Some(-1.0)
    } else {
        None
    }
}

/// The Jacobian of the answer from the search's own (in the unbounded
/// variables): whether it is singular (the measurements cannot tell the
/// parameters apart at any precision: scaled condition number above 1e12),
/// and the Jacobian of the measurements in units of sigma in the natural
/// variables `(a, b[, g])`, `J_nat = J_search / chain`, unscaled from log
/// ratios (`d ln M = dM / M`) when the search used them.
pub(crate) fn search_jacobian(
    prob: &mut Problem<'_>,
    x: &[f64],
    fitted: &[f64; 3],
    sigma: &[f64],
) -> Result<(bool, Vec<f64>), InverseError> {
    let (r0, _) = prob.residuals(x)?;
    let j_search = prob.jacobian(x, &r0)?;
    let (m, nd) = (r0.len(), x.len());
    let singular = scaled_condition(&normal_matrix(&j_search, m, nd), nd) > 1e12;
    let chain = prob.space.chain(&prob.space.optical_at(x));
    let jac = (0..m * nd)
        .map(|ix| {
            let (i, j) = (ix / nd, ix % nd);
            let jt = if prob.log { j_search[ix] * fitted[i] / sigma[i] } else { j_search[ix] };
            jt / chain[j].max(1e-300)
        })
        .collect();
    Ok((singular, jac))
}

/// The Jacobian at an albedo bound, by one-sided differences in the natural
/// variables (the search variable `u = ln(a / (1 - a))` flattens the model
/// there: `da/du = a (1 - a) = 0`, which would call every such answer
/// singular): step `1e-6` inward in `a`, relative `1e-7` in `b`, `1e-7` in `g`.
pub(crate) fn edge_jacobian(
    prob: &mut Problem<'_>,
    p: &Optical,
    fitted: &[f64; 3],
    sigma: &[f64],
    dir: f64,
) -> Result<(bool, Vec<f64>), InverseError> {
    let (m, nd) = (sigma.len(), prob.space.dim());
    let mut jac = vec![0.0; m * nd];
    for j in 0..nd {
        let mut q = *p;
        let h = match j {
            0 => dir * 1e-6,
            1 => 1e-7 * p.tau,
            // Inward in g, away from the nearer of -1 and 1.
            _ => {
                if p.g >= 0.0 {
                    -1e-7
                } else {
                    1e-7
                }
            }
        };
        match j {
            0 => q.albedo += h,
            1 => q.tau += h,
            _ => q.g += h,
        }
        prob.evaluations += 1;
        let mh = model_with(prob.set, &prob.stack, &q)?;
        for i in 0..m {
            jac[i * nd + j] = (mh[i] - fitted[i]) / (h * sigma[i]);
        }
    }
    let singular = scaled_condition(&normal_matrix(&jac, m, nd), nd) > 1e12;
    Ok((singular, jac))
}

/// `J^T J` of a row-major `m x n` Jacobian.
fn normal_matrix(jac: &[f64], m: usize, n: usize) -> Vec<f64> {
    let mut a = vec![0.0; n * n];
    for i in 0..m {
        for j in 0..n {
            for k in 0..n {
                a[j * n + k] += jac[i * n + j] * jac[i * n + k];
            }
        }
    }
    a
}

/// 1-norm condition number of a symmetric `n x n` matrix after Jacobi
/// scaling to a unit diagonal (explicit inverse: `n <= 3`); infinite when singular.
fn scaled_condition(a: &[f64], n: usize) -> f64 {
    let d: Vec<f64> = (0..n).map(|j| a[j * n + j].sqrt().max(1e-300)).collect();
    let s: Vec<f64> = (0..n * n).map(|ix| a[ix] / (d[ix / n] * d[ix % n])).collect();
    let norm1 = |v: &[f64]| {
        (0..n).map(|c| (0..n).map(|r| v[r * n + c].abs()).sum::<f64>()).fold(0.0, f64::max)
    };
    linalg::inverse(&s, n).map_or(f64::INFINITY, |inv| norm1(&s) * norm1(&inv))
}

/// Covariance of the fitted parameters and its propagation (eq. I8–I10):
///
/// `C = (J^T J)^-1` with `J_ij = (dM_i / dp_j) / sigma_i`, (I8)
/// `u(f)^2 = grad f^T C grad f` for `f` in `mu_a = (1 - a) b / d`,
/// `mu_s = a b / d`, `mu_s' = a b (1 - g) / d`, (I9)
/// `rho_jk = C_jk / sqrt(C_jj C_kk)`. (I10)
///
/// Flags: a singular or nearly singular `J^T J` (condition number of the
/// scaled matrix above 1e12: the measurements do not determine the
/// parameters), a relative uncertainty above 1, and `a` within two
/// standard uncertainties of 1 (the `a = 1` edge, where the linearisation fails).
///
/// # Reference
/// JCGM 100:2008 (GUM) §5.1.2 and JCGM 102:2011 §6.2 (propagation with the
/// covariance matrix); Press et al., *Numerical Recipes* §15.6.
pub(crate) fn covariance(
    jac: &[f64],
    m: usize,
    n: usize,
    p: &Optical,
    d: f64,
    fit_g: bool,
    sigma_given: bool,
) -> Uncertainty {
    let a = normal_matrix(jac, m, n);
    let dsc: Vec<f64> = (0..n).map(|j| a[j * n + j].sqrt().max(1e-300)).collect();
    let scaled: Vec<f64> = (0..n * n).map(|ix| a[ix] / (dsc[ix / n] * dsc[ix % n])).collect();
    let mut reasons = Vec::new();
    let inv_scaled = linalg::inverse(&scaled, n);
    let cond = scaled_condition(&a, n);
    let singular = cond.is_nan() || cond >= 1e12;
    let nan_u = || Uncertainty {
        albedo: f64::INFINITY,
        tau: f64::INFINITY,
        g: if fit_g { f64::INFINITY } else { 0.0 },
        mu_a: f64::INFINITY,
        mu_s: f64::INFINITY,
        mu_s_prime: f64::INFINITY,
        correlation: Vec::new(),
        ill_conditioned: true,
        reasons: Vec::new(),
        sigma_given,
    };
    if singular {
        let mut u = nan_u();
        u.reasons.push(format!(
            "the Jacobian of the measurements is singular (condition number {cond:.1e}): \
             the measurements do not determine the parameters"
        ));
        return u;
    }
    let inv = inv_scaled.unwrap_or_default();
    let c: Vec<f64> = (0..n * n).map(|ix| inv[ix] / (dsc[ix / n] * dsc[ix % n])).collect();
    let (aa, b, g) = (p.albedo, p.tau, p.g);
    // Gradients with respect to (a, b, g) of the derived quantities (I9).
    let mut grads = [
        vec![-b / d, (1.0 - aa) / d, 0.0],
        vec![b / d, aa / d, 0.0],
        vec![b * (1.0 - g) / d, aa * (1.0 - g) / d, -aa * b / d],
    ];
    for gr in &mut grads {
        gr.truncate(n);
    }
    let quad = |x: &[f64], y: &[f64]| -> f64 {
        (0..n).map(|j| (0..n).map(|k| x[j] * c[j * n + k] * y[k]).sum::<f64>()).sum()
    };
    let sd = |j: usize| c[j * n + j].max(0.0).sqrt();
    let rho = |j: usize, k: usize| c[j * n + k] / (sd(j) * sd(k));
    let mut correlation = vec![("albedo_tau".to_string(), rho(0, 1))];
    if fit_g {
        correlation.push(("albedo_g".into(), rho(0, 2)));
        correlation.push(("tau_g".into(), rho(1, 2)));
    }
    let (u_mua, u_musp) = (quad(&grads[0], &grads[0]).sqrt(), quad(&grads[2], &grads[2]).sqrt());
    correlation.push(("mu_a_mu_s_prime".into(), quad(&grads[0], &grads[2]) / (u_mua * u_musp)));
    let u = Uncertainty {
        albedo: sd(0),
        tau: sd(1),
        g: if fit_g { sd(2) } else { 0.0 },
        mu_a: u_mua,
        mu_s: quad(&grads[1], &grads[1]).sqrt(),
        mu_s_prime: u_musp,
        correlation,
        ill_conditioned: false,
        reasons: Vec::new(),
        sigma_given,
    };
    if cond > 1e8 {
        reasons.push(format!("nearly singular Jacobian (condition number {cond:.1e})"));
    }
    if aa + 2.0 * u.albedo >= 1.0 {
        reasons.push("albedo within two standard uncertainties of 1 (the a = 1 edge)".into());
    }
    if u.tau > b {
        reasons
            .push("u(tau) > tau: the transmittance carries no information on the thickness".into());
    }
    if fit_g && u.g > 1.0 {
        reasons.push("u(g) > 1: the measurements do not determine g".into());
    }
    let ill = !reasons.is_empty();
    Uncertainty { ill_conditioned: ill, reasons, ..u }
}

/// Standard uncertainties of the fitted parameters (same keys as the result).
#[derive(Debug, Clone, PartialEq)]
pub struct Uncertainty {
    /// `u(a)`.
    pub albedo: f64,
    /// `u(b)`.
    pub tau: f64,
    /// `u(g)` (0 when `g` was fixed).
    pub g: f64,
    /// `u(mu_a)`, 1/length.
    pub mu_a: f64,
    /// `u(mu_s)`, 1/length.
    pub mu_s: f64,
    /// `u(mu_s')`, 1/length.
    pub mu_s_prime: f64,
    /// Correlation coefficients: `(name, value)` for the pairs
    /// `albedo_tau`, `albedo_g`, `tau_g` (when `g` is fitted), `mu_a_mu_s_prime`.
    pub correlation: Vec<(String, f64)>,
    /// The problem is ill-conditioned at the answer (see `reasons`).
    pub ill_conditioned: bool,
    /// Why it is flagged.
    pub reasons: Vec<String>,
    /// The measurement uncertainties were given (`false`: [`DEFAULT_SIGMA`](crate::slab::DEFAULT_SIGMA) assumed).
    pub sigma_given: bool,
}
