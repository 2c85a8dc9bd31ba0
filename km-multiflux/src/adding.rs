//! Adding of two layers: the Redheffer star product (seed 000 eq. 14) and its
//! truncated Neumann series (seed 000 eq. 21).
//!
//! # The operators of a layer
//!
//! A layer (a slab, an interface, a substrate, or a stack already added) is
//! described by four linear operators that map the light entering it to the
//! light leaving it ([`LayerOperators`]):
//!
//! ```text
//!            a (down, above)    u_top (up, above)
//!                 |                  ^
//!        =========v==================|=========   top side
//!                      layer
//!        =========|==================^=========   bottom side
//!                 v                  |
//!         d_bot (down, below)    b (up, below)
//!
//!   u_top = r_top    a + t_up b                                       (A1)
//!   d_bot = t_down   a + r_bottom b
//! ```
//!
//! `r_top` is the reflection seen from above, `t_down` the transmission top to
//! bottom, `r_bottom` the reflection seen from below and `t_up` the
//! transmission bottom to top. The vectors hold the downward (`a`, `d_bot`)
//! and upward (`b`, `u_top`) streams on each side; the sides may use different
//! direction sets (refraction), so the operators may be rectangular:
//! with `D_a, U_a` the sizes of the down/up vectors above and `D_b, U_b` below,
//! `r_top` is `U_a x D_a`, `t_down` is `D_b x D_a`, `r_bottom` is `D_b x U_b`
//! and `t_up` is `U_a x U_b`.
//!
//! The star product only needs the weighting of the vectors to be the same on
//! both sides of the common boundary; the solver of this crate uses radiances
//! at the quadrature directions (and, for a collimated beam, its irradiance on
//! a horizontal plane), see `docs/multiflux.md`.
//!
//! # Derivation of the adding formula (seed eq. 14, re-derived)
//!
//! Stack layer 1 (`top`) over layer 2 (`bottom`). Let `d` and `u` be the
//! downward and upward streams at their common boundary. Then (A1) for each
//! layer gives
//!
//! ```text
//!   d = T1 a + R1' u,      u = R2 d + T2' b                          (A2)
//! ```
//!
//! with `R1 = top.r_top`, `T1 = top.t_down`, `R1' = top.r_bottom`,
//! `T1' = top.t_up` and likewise for layer 2. Eliminating `u`:
//!
//! ```text
//!   (I - R1' R2) d = T1 a + R1' T2' b                                 (A3)
//! ```
//!
//! so with `X = I - R1' R2` the combined operators are
//!
//! ```text
//!   r_top    = R1  + T1' R2 X^-1 T1                                   (A4)
//!   t_down   = T2  X^-1 T1
//!   r_bottom = R2' + T2  X^-1 R1' T2'
//!   t_up     = T1' (I + R2 X^-1 R1') T2' = T1' (I - R2 R1')^-1 T2'
//! ```
//!
//! These are van de Hulst's adding equations and the Redheffer star product
//! of scattering matrices; the first line of seed eq. 14 is garbled in the
//! seed (it lacks the factor `R2` and the product structure), the others agree
//! with (A4) up to the seed's naming (`R_11 = T`, `R_21 = R`).
//!
//! # Truncated Neumann series (seed eq. 21)
//!
//! `X^-1 = sum_j (R1' R2)^j` converges because the spectral radius of
//! `R1' R2` is below 1 for any layer that absorbs or leaks light; term `j`
//! is the light that made `j` round trips between the two layers.
//! [`add_truncated`] keeps the terms `j = 0..=order` in every line of (A4)
//! (for `t_up`, `(I - R2 R1')^-1` is truncated the same way), so order 0 is the
//! "no inter-reflection" approximation of the seed and order `k -> inf` tends
//! to [`add`].
//!
//! # References
//! - H. C. van de Hulst, *Multiple Light Scattering*, Academic Press (1980), ch. 4.
//! - R. Redheffer, "On the relation of transmission-line theory to scattering
//!   and transfer", J. Math. Phys. 41 (1962) 1–41.
//! - Seed 000, eq. 11–14 and 21.

pub mod probed;

use faer::linalg::solvers::Solve;
use faer::{Mat, MatRef};

use crate::MultifluxError;

/// The four reflection/transmission operators of a layer (see the module doc, eq. A1).
#[derive(Debug, Clone, PartialEq)]
pub struct LayerOperators {
    /// Reflection seen from above: down-going light above -> up-going light above (`U_a x D_a`).
    pub r_top: Mat<f64>,
    /// Transmission top -> bottom: down-going above -> down-going below (`D_b x D_a`).
    pub t_down: Mat<f64>,
    /// Reflection seen from below: up-going below -> down-going below (`D_b x U_b`).
    pub r_bottom: Mat<f64>,
    /// Transmission bottom -> top: up-going below -> up-going above (`U_a x U_b`).
    pub t_up: Mat<f64>,
}

/// Sizes `(D_a, U_a, D_b, U_b)` of the down/up vectors above and below a layer.
pub type SideSizes = (usize, usize, usize, usize);

impl LayerOperators {
    /// A layer that does nothing: `r = 0`, `t = I` on `n_down` downward and
    /// `n_up` upward streams (the identity of the star product).
    pub fn transparent(n_down: usize, n_up: usize) -> Self {
        LayerOperators {
            r_top: Mat::zeros(n_up, n_down),
            t_down: Mat::identity(n_down, n_down),
            r_bottom: Mat::zeros(n_down, n_up),
            t_up: Mat::identity(n_up, n_up),
        }
    }

    /// Check that the four shapes are consistent and return `(D_a, U_a, D_b, U_b)`.
    ///
    /// # Errors
    /// [`MultifluxError::Shape`] naming the inconsistent operator.
    pub fn sizes(&self) -> Result<SideSizes, MultifluxError> {
        let (u_a, d_a) = (self.r_top.nrows(), self.r_top.ncols());
        let (d_b, u_b) = (self.r_bottom.nrows(), self.r_bottom.ncols());
        let ok = self.t_down.nrows() == d_b
            && self.t_down.ncols() == d_a
            && self.t_up.nrows() == u_a
            && self.t_up.ncols() == u_b;
        if !ok {
            return Err(MultifluxError::Shape {
                what: "LayerOperators",
                detail: format!(
                    "r_top {u_a}x{d_a}, t_down {}x{}, r_bottom {d_b}x{u_b}, t_up {}x{}",
                    self.t_down.nrows(),
                    self.t_down.ncols(),
                    self.t_up.nrows(),
                    self.t_up.ncols()
                ),
            });
        }
        Ok((d_a, u_a, d_b, u_b))
    }
}

/// Check that `top`'s bottom side matches `bottom`'s top side.
fn check_pair(top: &LayerOperators, bottom: &LayerOperators) -> Result<(), MultifluxError> {
    let (_, _, d_b, u_b) = top.sizes()?;
    let (d_a2, u_a2, _, _) = bottom.sizes()?;
    if d_b != d_a2 || u_b != u_a2 {
        return Err(MultifluxError::Shape {
            what: "adding",
            detail: format!(
                "top layer's bottom side has {d_b} down / {u_b} up streams, \
                 bottom layer's top side {d_a2} / {u_a2}"
            ),
        });
    }
    Ok(())
}

/// Exact adding of two layers, `top` over `bottom` (eq. A4; seed 000 eq. 14).
///
/// One LU factorisation of `X = I - R1' R2` (size `D_b`); the inverse is never formed.
///
/// # Errors
/// [`MultifluxError::Shape`] for operators that do not fit;
/// [`MultifluxError::Numerical`] when `X` is singular (two non-absorbing
/// mirrors facing each other) and the result is not finite.
///
/// ```
/// use faer::Mat;
/// use km_multiflux::adding::{add, LayerOperators};
/// // Two scalar "layers" (one stream each way): the classic two-flux adding formula
/// // R = R1 + T1^2 R2 / (1 - R1 R2).
/// let l = |r: f64, t: f64| LayerOperators {
///     r_top: Mat::from_fn(1, 1, |_, _| r),
///     t_down: Mat::from_fn(1, 1, |_, _| t),
///     r_bottom: Mat::from_fn(1, 1, |_, _| r),
///     t_up: Mat::from_fn(1, 1, |_, _| t),
/// };
/// let s = add(&l(0.2, 0.7), &l(0.3, 0.5)).unwrap();
/// let expect = 0.2 + 0.7 * 0.7 * 0.3 / (1.0 - 0.2 * 0.3);
/// assert!((s.r_top[(0, 0)] - expect).abs() < 1e-15);
/// ```
pub fn add(
    top: &LayerOperators,
    bottom: &LayerOperators,
) -> Result<LayerOperators, MultifluxError> {
    Ok(add_parts(top, bottom)?.0)
}

/// [`add`], also returning `X^-1 T1` and `X^-1 R1' T2'` (the down-going
/// streams at the common boundary, for light from above and from below),
/// which the adding of probes needs ([`probed::add`]).
pub(crate) fn add_parts(
    top: &LayerOperators,
    bottom: &LayerOperators,
) -> Result<(LayerOperators, Mat<f64>, Mat<f64>), MultifluxError> {
    check_pair(top, bottom)?;
    let (r1, t1, r1p, t1p) = (&top.r_top, &top.t_down, &top.r_bottom, &top.t_up);
    let (r2, t2, r2p, t2p) = (&bottom.r_top, &bottom.t_down, &bottom.r_bottom, &bottom.t_up);
    let d_b = r1p.nrows();

    // X = I - R1' R2: the operator of the round trips between the two layers.
    let mut x = Mat::<f64>::identity(d_b, d_b);
    x -= r1p * r2;
    let r1t2 = r1p * t2p;
    decouple_trapped(&mut x, t1, &r1t2);
    let lu = x.partial_piv_lu();

    // X^-1 T1: light from above, after all round trips, going down at the boundary.
    let xt1 = lu.solve(t1);
    // X^-1 R1' T2': light from below, reflected by layer 1, after all round trips.
    let xr = lu.solve(&r1t2);

    let out = LayerOperators {
        r_top: r1 + t1p * (r2 * &xt1),
        t_down: t2 * &xt1,
        r_bottom: r2p + t2 * &xr,
        t_up: t1p * (t2p + r2 * &xr),
    };
    check_finite(&out, "adding: I - R1' R2 is singular")?;
    Ok((out, xt1, xr))
}

/// Adding with the Neumann series of `X^-1` truncated after `order` round
/// trips (seed 000 eq. 21): `X^-1 ~ sum_{j=0}^{order} (R1' R2)^j`, and
/// `(I - R2 R1')^-1 ~ sum_{j=0}^{order} (R2 R1')^j` in `t_up`.
///
/// Order 0 neglects all inter-reflections between the two layers. The error
/// of order `k` is of the order of `||R1' R2||^(k+1)`.
///
/// # Errors
/// [`MultifluxError::Shape`] for operators that do not fit.
///
/// ```
/// use faer::Mat;
/// use km_multiflux::adding::{add, add_truncated, LayerOperators};
/// let l = |r: f64, t: f64| LayerOperators {
///     r_top: Mat::from_fn(1, 1, |_, _| r),
///     t_down: Mat::from_fn(1, 1, |_, _| t),
///     r_bottom: Mat::from_fn(1, 1, |_, _| r),
///     t_up: Mat::from_fn(1, 1, |_, _| t),
/// };
/// let (a, b) = (l(0.2, 0.7), l(0.3, 0.5));
/// let s0 = add_truncated(&a, &b, 0).unwrap();
/// assert!((s0.r_top[(0, 0)] - (0.2 + 0.7 * 0.3 * 0.7)).abs() < 1e-15);
/// let s = add(&a, &b).unwrap();
/// let s40 = add_truncated(&a, &b, 40).unwrap();
/// assert!((s40.r_top[(0, 0)] - s.r_top[(0, 0)]).abs() < 1e-15);
/// ```
pub fn add_truncated(
    top: &LayerOperators,
    bottom: &LayerOperators,
    order: usize,
) -> Result<LayerOperators, MultifluxError> {
    Ok(add_truncated_parts(top, bottom, order)?.0)
}

/// [`add_truncated`], also returning the truncated `X^-1 T1`,
/// `X^-1 R1' T2'` and `(I - R2 R1')^-1 T2'` ([`probed::add_truncated`]).
#[allow(clippy::type_complexity)]
pub(crate) fn add_truncated_parts(
    top: &LayerOperators,
    bottom: &LayerOperators,
    order: usize,
) -> Result<(LayerOperators, Mat<f64>, Mat<f64>, Mat<f64>), MultifluxError> {
    check_pair(top, bottom)?;
    let (r1, t1, r1p, t1p) = (&top.r_top, &top.t_down, &top.r_bottom, &top.t_up);
    let (r2, t2, r2p, t2p) = (&bottom.r_top, &bottom.t_down, &bottom.r_bottom, &bottom.t_up);

    // sum_{j<=order} (A B)^j C, by Horner-free repeated application.
    let series = |a: &Mat<f64>, b: &Mat<f64>, c: MatRef<'_, f64>| -> Mat<f64> {
        let mut acc = c.to_owned();
        let mut term = c.to_owned();
        for _ in 0..order {
            term = a * (b * &term);
            acc += &term;
        }
        acc
    };
    // Down-going light at the common boundary, from above and from below (eq. A3).
    let xt1 = series(r1p, r2, t1.as_ref());
    let xr = series(r1p, r2, (r1p * t2p).as_ref());
    // Up-going light at the common boundary from below, for t_up.
    let yt2 = series(r2, r1p, t2p.as_ref());

    let out = LayerOperators {
        r_top: r1 + t1p * (r2 * &xt1),
        t_down: t2 * &xt1,
        r_bottom: r2p + t2 * &xr,
        t_up: t1p * &yt2,
    };
    Ok((out, xt1, xr, yt2))
}

/// Directions trapped between two total reflections with nothing between
/// (a clear layer of higher index between interfaces) give a row and column
/// of `X` that are zero: no light can enter them (their rows of `T1` and
/// `R1' T2'` are zero too), so their stream is 0 and the equation is
/// replaced by `d_i = 0` (diagonal set to 1). Anything else stays singular.
fn decouple_trapped(x: &mut Mat<f64>, t1: &Mat<f64>, r1t2: &Mat<f64>) {
    let n = x.nrows();
    for i in 0..n {
        if x[(i, i)] != 0.0 {
            continue;
        }
        let isolated = (0..n).all(|j| j == i || (x[(i, j)] == 0.0 && x[(j, i)] == 0.0))
            && (0..t1.ncols()).all(|j| t1[(i, j)] == 0.0)
            && (0..r1t2.ncols()).all(|j| r1t2[(i, j)] == 0.0);
        if isolated {
            x[(i, i)] = 1.0;
        }
    }
}

/// Refuse non-finite operators (a singular `X` gives infinities or NaN).
fn check_finite(ops: &LayerOperators, what: &'static str) -> Result<(), MultifluxError> {
    let all = [&ops.r_top, &ops.t_down, &ops.r_bottom, &ops.t_up];
    let finite =
        all.iter().all(|m| (0..m.ncols()).all(|j| (0..m.nrows()).all(|i| m[(i, j)].is_finite())));
    if finite {
        Ok(())
    } else {
        Err(MultifluxError::Numerical { what, detail: "non-finite result".into() })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A deterministic pseudo-random layer with `n` streams each way whose
    /// operators are non-negative and leak light (column sums of R + T < 1).
    fn layer(n: usize, seed: u64) -> LayerOperators {
        let mut s = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        let mut rnd = move || {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((s >> 11) as f64) / ((1u64 << 53) as f64)
        };
        let mut m = || Mat::from_fn(n, n, |_, _| rnd() * 0.9 / (2.0 * n as f64));
        LayerOperators { r_top: m(), t_down: m(), r_bottom: m(), t_up: m() }
    }

    fn max_diff(a: &Mat<f64>, b: &Mat<f64>) -> f64 {
        let mut d = 0.0f64;
        for j in 0..a.ncols() {
            for i in 0..a.nrows() {
                d = d.max((a[(i, j)] - b[(i, j)]).abs());
            }
        }
        d
    }

    #[test]
    fn transparent_layer_is_the_identity_of_adding() {
        let l = layer(3, 7);
        let id = LayerOperators::transparent(3, 3);
        for s in [add(&id, &l).unwrap(), add(&l, &id).unwrap()] {
            // Only rounding: the identity adds exact zeros and ones.
            assert!(max_diff(&s.r_top, &l.r_top) < 1e-15);
            assert!(max_diff(&s.t_down, &l.t_down) < 1e-15);
            assert!(max_diff(&s.r_bottom, &l.r_bottom) < 1e-15);
            assert!(max_diff(&s.t_up, &l.t_up) < 1e-15);
        }
    }

    #[test]
    fn adding_is_associative() {
        // The star product is associative; rounding only (tolerance 1e-13).
        let (a, b, c) = (layer(4, 1), layer(4, 2), layer(4, 3));
        let l = add(&add(&a, &b).unwrap(), &c).unwrap();
        let r = add(&a, &add(&b, &c).unwrap()).unwrap();
        assert!(max_diff(&l.r_top, &r.r_top) < 1e-13);
        assert!(max_diff(&l.t_down, &r.t_down) < 1e-13);
        assert!(max_diff(&l.r_bottom, &r.r_bottom) < 1e-13);
        assert!(max_diff(&l.t_up, &r.t_up) < 1e-13);
    }

    #[test]
    fn truncated_series_converges_to_exact_adding() {
        let (a, b) = (layer(5, 11), layer(5, 12));
        let exact = add(&a, &b).unwrap();
        let mut prev = f64::INFINITY;
        for k in 0..6 {
            let s = add_truncated(&a, &b, k).unwrap();
            let e = max_diff(&s.r_top, &exact.r_top).max(max_diff(&s.t_up, &exact.t_up));
            // Each round trip multiplies the remainder by ||R1' R2|| < 0.2 here.
            assert!(e < 0.5 * prev, "order {k}: {e} vs {prev}");
            prev = e;
        }
        assert!(prev < 1e-6);
    }

    #[test]
    fn mismatched_shapes_are_refused() {
        assert!(matches!(add(&layer(3, 1), &layer(4, 2)), Err(MultifluxError::Shape { .. })));
    }

    #[test]
    fn facing_perfect_mirrors_are_refused_not_panicking() {
        let one = |v: f64| Mat::from_fn(1, 1, |_, _| v);
        // Light enters a lossless cavity and can never leave: refused.
        let leaky = LayerOperators {
            r_top: one(0.5),
            t_down: one(0.5),
            r_bottom: one(1.0),
            t_up: one(0.0),
        };
        let mirror = LayerOperators {
            r_top: one(1.0),
            t_down: one(0.0),
            r_bottom: one(1.0),
            t_up: one(0.0),
        };
        assert!(add(&leaky, &mirror).is_err());
        // Nothing can enter the cavity: it is decoupled, the top mirror reflects all.
        let s = add(&mirror, &mirror).unwrap();
        assert_eq!(s.r_top[(0, 0)], 1.0);
        assert_eq!(s.t_down[(0, 0)], 0.0);
    }
}
