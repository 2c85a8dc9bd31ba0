//! The uncertainty of a fitted film's `K` and `S` from that of its readings
//! (first-order propagation, JCGM 100:2008 §5.1.2; `docs/inverse-km.md`).

use super::{Film, KubelkaError, from_black_white, from_r_inf_r0};

/// Standard uncertainties of a fitted film's `K` and `S`, and their correlation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Uncertainty {
    /// Standard uncertainty of `K` (1/length).
    pub k: f64,
    /// Standard uncertainty of `S` (1/length).
    pub s: f64,
    /// Correlation coefficient of the errors of `K` and `S`, in `[-1, 1]`.
    pub correlation: f64,
}

/// First-order propagation of independent reading uncertainties through an
/// inverse `f(r1, r2) -> (K, S)`: `Cov = J diag(u1^2, u2^2) J^T`, the
/// Jacobian `J` by central differences (step `1e-6`, clipped to `[0, 1]`;
/// truncation ~1e-12 and rounding ~eps/1e-6 relative, far below any
/// reading's uncertainty).
fn propagate(
    r: [f64; 2],
    u: [f64; 2],
    f: impl Fn(f64, f64) -> Result<Film, KubelkaError>,
) -> Result<Uncertainty, KubelkaError> {
    for (name, v) in [("u_1", u[0]), ("u_2", u[1])] {
        if !v.is_finite() || v < 0.0 {
            return Err(KubelkaError::invalid(name, v, "an uncertainty must be finite and >= 0"));
        }
    }
    const H: f64 = 1e-6;
    let mut jac = [[0.0; 2]; 2];
    for i in 0..2 {
        // Central difference, one-sided at the ends of [0, 1].
        let (mut lo, mut hi) = (r, r);
        lo[i] = (r[i] - H).max(0.0);
        hi[i] = (r[i] + H).min(1.0);
        let (a, b) = (f(lo[0], lo[1])?, f(hi[0], hi[1])?);
        let d = hi[i] - lo[i];
        jac[0][i] = (b.k - a.k) / d;
        jac[1][i] = (b.s - a.s) / d;
    }
    let var = |p: usize, q: usize| {
        jac[p][0] * jac[q][0] * u[0] * u[0] + jac[p][1] * jac[q][1] * u[1] * u[1]
    };
    let (vk, vs, cks) = (var(0, 0), var(1, 1), var(0, 1));
    let correlation =
        if vk > 0.0 && vs > 0.0 { (cks / (vk * vs).sqrt()).clamp(-1.0, 1.0) } else { 0.0 };
    Ok(Uncertainty { k: vk.sqrt(), s: vs.sqrt(), correlation })
}

/// Standard uncertainties of `K`, `S` from [`from_black_white`], for
/// independent standard uncertainties `u_black`, `u_white` of the two
/// (internal) readings; the grounds and the thickness are taken as exact.
///
/// First order: `Cov(K, S) = J diag(u_black^2, u_white^2) J^T` with the
/// Jacobian of (I6)+(I4) by central differences. Near opacity the
/// uncertainties grow like `exp(2 b S X)` (docs/inverse-km.md §6): this is
/// how far a fit can be trusted.
///
/// # Errors
/// Those of [`from_black_white`] at the readings or a step away from them;
/// a negative or non-finite uncertainty.
///
/// # Reference
/// JCGM 100:2008 (GUM), §5.1.2 (law of propagation of uncertainty).
///
/// ```
/// use km_inverse::kubelka::{black_white_uncertainty, reflectance_over_ground};
/// let (k, s, x) = (0.3, 2.0, 0.5);
/// let rb = reflectance_over_ground(k, s, x, 0.0).unwrap();
/// let rw = reflectance_over_ground(k, s, x, 0.8).unwrap();
/// let u = black_white_uncertainty(rb, 0.0, rw, 0.8, x, 1e-3, 1e-3).unwrap();
/// assert!(u.k > 0.0 && u.s > 0.0 && u.correlation.abs() <= 1.0);
/// ```
pub fn black_white_uncertainty(
    r_black: f64,
    g_black: f64,
    r_white: f64,
    g_white: f64,
    thickness: f64,
    u_black: f64,
    u_white: f64,
) -> Result<Uncertainty, KubelkaError> {
    from_black_white(r_black, g_black, r_white, g_white, thickness)?;
    propagate([r_black, r_white], [u_black, u_white], |rb, rw| {
        from_black_white(rb, g_black, rw, g_white, thickness)
    })
}

/// Standard uncertainties of `K`, `S` from [`from_r_inf_r0`], for independent
/// standard uncertainties `u_r_inf`, `u_r0` of the two (internal) readings,
/// as [`black_white_uncertainty`].
///
/// # Errors
/// Those of [`from_r_inf_r0`] at the readings or a step away from them; a
/// negative or non-finite uncertainty.
///
/// # Reference
/// JCGM 100:2008 (GUM), §5.1.2.
///
/// ```
/// use km_inverse::kubelka::r_inf_r0_uncertainty;
/// let u = r_inf_r0_uncertainty(0.6, 0.4, 1.0, 1e-3, 1e-3).unwrap();
/// assert!(u.k > 0.0 && u.s > 0.0);
/// ```
pub fn r_inf_r0_uncertainty(
    r_inf: f64,
    r0: f64,
    thickness: f64,
    u_r_inf: f64,
    u_r0: f64,
) -> Result<Uncertainty, KubelkaError> {
    from_r_inf_r0(r_inf, r0, thickness)?;
    propagate([r_inf, r0], [u_r_inf, u_r0], |ri, r| from_r_inf_r0(ri, r, thickness))
}
