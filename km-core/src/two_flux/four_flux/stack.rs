//! Four-flux slabs and their adding: seed eq. 14 with 2 x 2 lower
//! triangular matrices over the components `(collimated, diffuse)`
//! (docs/two-flux.md eq. K23–K24).

use crate::error::CoreError;

use super::CollimatedRt;
use crate::two_flux::Slab;

/// A 2 x 2 lower triangular matrix `[[cc, 0], [dc, dd]]` acting on
/// `(collimated, diffuse)`: `cc` takes a beam to a beam, `dc` a beam to
/// diffuse light, `dd` diffuse light to diffuse light; diffuse light never
/// becomes a beam.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Lower {
    /// Collimated to collimated.
    pub cc: f64,
    /// Collimated to diffuse.
    pub dc: f64,
    /// Diffuse to diffuse.
    pub dd: f64,
}

impl Lower {
    /// The identity.
    pub const IDENTITY: Lower = Lower { cc: 1.0, dc: 0.0, dd: 1.0 };

    /// The product `self * other` (`other` acts first).
    pub fn mul(&self, other: &Lower) -> Lower {
        Lower {
            cc: self.cc * other.cc,
            dc: self.dc * other.cc + self.dd * other.dc,
            dd: self.dd * other.dd,
        }
    }

    /// `self (c, d)^t`.
    pub fn apply(&self, v: [f64; 2]) -> [f64; 2] {
        [self.cc * v[0], self.dc * v[0] + self.dd * v[1]]
    }

    /// The row vector `a` times `self`.
    fn left(&self, a: [f64; 2]) -> [f64; 2] {
        [a[0] * self.cc + a[1] * self.dc, a[1] * self.dd]
    }

    fn plus(&self, o: &Lower) -> Lower {
        Lower { cc: self.cc + o.cc, dc: self.dc + o.dc, dd: self.dd + o.dd }
    }
}

/// A slab of the four-flux model: reflection and transmission matrices
/// ([`Lower`]) for light from above (`_top`, `_tb`) and from below
/// (`_bottom`, `_bt`), and the absorbed fraction of each input component
/// (`a_top[0]` of a beam from above, `a_top[1]` of diffuse light from
/// above). Each column is conserved: a beam from above gives
/// `r_top.cc + r_top.dc + t_tb.cc + t_tb.dc + a_top[0] = 1`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FourSlab {
    /// Reflection of light from above.
    pub r_top: Lower,
    /// Transmission from top to bottom.
    pub t_tb: Lower,
    /// Reflection of light from below.
    pub r_bottom: Lower,
    /// Transmission from bottom to top.
    pub t_bt: Lower,
    /// Absorbed fraction of a beam and of diffuse light from above.
    pub a_top: [f64; 2],
    /// Absorbed fraction of a beam and of diffuse light from below.
    pub a_bottom: [f64; 2],
}

impl FourSlab {
    /// Nothing: everything passes.
    pub const CLEAR: FourSlab = FourSlab {
        r_top: Lower { cc: 0.0, dc: 0.0, dd: 0.0 },
        t_tb: Lower::IDENTITY,
        r_bottom: Lower { cc: 0.0, dc: 0.0, dd: 0.0 },
        t_bt: Lower::IDENTITY,
        a_top: [0.0; 2],
        a_bottom: [0.0; 2],
    };

    /// A layer: its two-flux slab for the diffuse pair and its response to
    /// a beam ([`super::collimated_layer`]), the same from both faces.
    pub fn layer(diffuse: &Slab, beam: &CollimatedRt) -> FourSlab {
        let r = Lower { cc: 0.0, dc: beam.r, dd: diffuse.r_top };
        let t = Lower { cc: beam.direct, dc: beam.t, dd: diffuse.t_tb };
        let a = [beam.a, diffuse.a_top];
        FourSlab { r_top: r, t_tb: t, r_bottom: r, t_bt: t, a_top: a, a_bottom: a }
    }

    /// A smooth interface: the beam reflected with the Fresnel reflectance
    /// `r_beam` at its own angle (the same from both sides, Stokes), diffuse
    /// light with the hemispherical reflectances of `diffuse`
    /// ([`Slab::interface_diffuse`]).
    pub fn interface(r_beam: f64, diffuse: &Slab) -> FourSlab {
        let t_beam = 1.0 - r_beam;
        FourSlab {
            r_top: Lower { cc: r_beam, dc: 0.0, dd: diffuse.r_top },
            t_tb: Lower { cc: t_beam, dc: 0.0, dd: diffuse.t_tb },
            r_bottom: Lower { cc: r_beam, dc: 0.0, dd: diffuse.r_bottom },
            t_bt: Lower { cc: t_beam, dc: 0.0, dd: diffuse.t_bt },
            a_top: [0.0; 2],
            a_bottom: [0.0; 2],
        }
    }

    /// An opaque Lambertian ground of reflectance `albedo` in `[0, 1]`: a
    /// beam and diffuse light are both sent back diffuse.
    ///
    /// # Errors
    /// `albedo` outside `[0, 1]`.
    pub fn ground(albedo: f64) -> Result<FourSlab, CoreError> {
        if !(0.0..=1.0).contains(&albedo) {
            return Err(CoreError::invalid("albedo", albedo, "must lie in [0, 1]"));
        }
        let zero = Lower { cc: 0.0, dc: 0.0, dd: 0.0 };
        Ok(FourSlab {
            r_top: Lower { cc: 0.0, dc: albedo, dd: albedo },
            t_tb: zero,
            r_bottom: zero,
            t_bt: zero,
            a_top: [1.0 - albedo; 2],
            a_bottom: [1.0; 2],
        })
    }

    /// `1 - r` of each component of light from above, as the sum of what
    /// else becomes of it (no cancellation as `r -> 1`).
    fn one_minus_r_top(&self) -> [f64; 2] {
        let (r, t) = (&self.r_top, &self.t_tb);
        [r.dc + t.cc + t.dc + self.a_top[0], t.dd + self.a_top[1]]
    }

    /// `1 - r` of each component of light from below.
    fn one_minus_r_bottom(&self) -> [f64; 2] {
        let (r, t) = (&self.r_bottom, &self.t_bt);
        [r.dc + t.cc + t.dc + self.a_bottom[0], t.dd + self.a_bottom[1]]
    }
}

/// `(I - r1 r2)^-1` for lower triangular `r1`, `r2`, with the diagonal
/// denominators `1 - r1 r2 = (1 - r1) + r1 (1 - r2)` written as sums of
/// non-negative terms (`m1`, `m2` are `1 - r1`, `1 - r2` per component).
fn inter_reflections(r1: &Lower, m1: [f64; 2], r2: &Lower, m2: [f64; 2]) -> Lower {
    let den_c = m1[0] + r1.cc * m2[0];
    let den_d = m1[1] + r1.dd * m2[1];
    let inv_c = if den_c > 0.0 { 1.0 / den_c } else { 0.0 };
    let inv_d = if den_d > 0.0 { 1.0 / den_d } else { 0.0 };
    // The off-diagonal of r1 r2, and of its Neumann series sum.
    let off = r1.dc * r2.cc + r1.dd * r2.dc;
    Lower { cc: inv_c, dc: off * inv_c * inv_d, dd: inv_d }
}

/// Adding `top` over `bottom` (seed eq. 14 with matrices, eq. K23): with
/// `X = (I - R_bottom(1) R_top(2))^-1`, `Y = (I - R_top(2) R_bottom(1))^-1`,
///
/// ```text
/// T_tb(12) = T_tb(2) X T_tb(1),   R_top(12) = R_top(1) + T_bt(1) R_top(2) X T_tb(1)
/// T_bt(12) = T_bt(1) Y T_bt(2),   R_bottom(12) = R_bottom(2) + T_tb(2) R_bottom(1) Y T_bt(2)
/// ```
///
/// and the absorbed fractions from the junction fluxes `X T_tb(1)` and
/// `Y T_bt(2)`.
///
/// # Reference
/// Seed 000 eq. 14; van de Hulst (1980), the adding method.
///
/// ```
/// use km_core::two_flux::{add_four, collimated_layer, FourSlab, Slab};
/// let half = FourSlab::layer(
///     &Slab::layer(0.1, 0.4, 0.5).unwrap(),
///     &collimated_layer(0.1, 0.4, 0.05, 0.6, 0.3, 0.8, 0.5).unwrap(),
/// );
/// let one = FourSlab::layer(
///     &Slab::layer(0.1, 0.4, 1.0).unwrap(),
///     &collimated_layer(0.1, 0.4, 0.05, 0.6, 0.3, 0.8, 1.0).unwrap(),
/// );
/// let two = add_four(&half, &half);
/// assert!((two.r_top.dc - one.r_top.dc).abs() < 1e-15);
/// assert!((two.t_tb.dc - one.t_tb.dc).abs() < 1e-15);
/// ```
pub fn add_four(top: &FourSlab, bottom: &FourSlab) -> FourSlab {
    let (m1b, m2t) = (top.one_minus_r_bottom(), bottom.one_minus_r_top());
    let x = inter_reflections(&top.r_bottom, m1b, &bottom.r_top, m2t);
    let y = inter_reflections(&bottom.r_top, m2t, &top.r_bottom, m1b);
    // Junction fluxes: down for unit light from above, up for unit light from below.
    let down = x.mul(&top.t_tb);
    let up = y.mul(&bottom.t_bt);
    let a_from_down = bottom.r_top.left(top.a_bottom);
    let a_from_up = top.r_bottom.left(bottom.a_top);
    let a_top = down.left([a_from_down[0] + bottom.a_top[0], a_from_down[1] + bottom.a_top[1]]);
    let a_bottom = up.left([a_from_up[0] + top.a_bottom[0], a_from_up[1] + top.a_bottom[1]]);
    FourSlab {
        r_top: top.r_top.plus(&top.t_bt.mul(&bottom.r_top).mul(&down)),
        t_tb: bottom.t_tb.mul(&down),
        r_bottom: bottom.r_bottom.plus(&bottom.t_tb.mul(&top.r_bottom).mul(&up)),
        t_bt: top.t_bt.mul(&up),
        a_top: [top.a_top[0] + a_top[0], top.a_top[1] + a_top[1]],
        a_bottom: [bottom.a_bottom[0] + a_bottom[0], bottom.a_bottom[1] + a_bottom[1]],
    }
}

/// The fluxes of a four-flux stack lit from above.
#[derive(Debug, Clone, PartialEq)]
pub struct FourStackFluxes {
    /// Reflected `(collimated, diffuse)`.
    pub r: [f64; 2],
    /// Transmitted out of the bottom of the last slab `(collimated, diffuse)`.
    pub t: [f64; 2],
    /// Fraction absorbed in each slab, top first.
    pub absorbed: Vec<f64>,
}

/// Any number of slabs, top first, lit from above by `incident`
/// `(collimated, diffuse)`, by adding (eq. K24): the stacks below each
/// junction are added from the bottom up (`B_k = slab_k + B_{k+1}`), then the
/// fluxes go down, `d_{k+1} = (I - R_bottom(k) R_top(B_{k+1}))^-1 T_tb(k) d_k`,
/// `u_{k+1} = R_top(B_{k+1}) d_{k+1}`, and slab `k` absorbs
/// `a_top(k) . d_k + a_bottom(k) . u_{k+1}`.
///
/// # Reference
/// Seed 000 eq. 14; van de Hulst (1980), the adding method.
///
/// ```
/// use km_core::two_flux::{stack_four, FourSlab, Slab};
/// let s = [FourSlab::interface(0.04, &Slab::interface_diffuse(1.0, 1.5).unwrap()),
///          FourSlab::ground(0.8).unwrap()];
/// let f = stack_four(&s, [1.0, 0.0]);
/// let a: f64 = f.absorbed.iter().sum();
/// assert!((f.r[0] + f.r[1] + a - 1.0).abs() < 1e-15 && f.r[0] == 0.04);
/// ```
pub fn stack_four(slabs: &[FourSlab], incident: [f64; 2]) -> FourStackFluxes {
    let n = slabs.len();
    let mut below = vec![FourSlab::CLEAR; n + 1];
    for k in (0..n).rev() {
        below[k] = add_four(&slabs[k], &below[k + 1]);
    }
    // Down pass: the fluxes at each junction and the absorption in each slab.
    let mut down = incident;
    let mut absorbed = vec![0.0; n];
    for k in 0..n {
        let (s, b) = (&slabs[k], &below[k + 1]);
        let x =
            inter_reflections(&s.r_bottom, s.one_minus_r_bottom(), &b.r_top, b.one_minus_r_top());
        let next = x.mul(&s.t_tb).apply(down);
        let up_next = b.r_top.apply(next);
        absorbed[k] = s.a_top[0] * down[0]
            + s.a_top[1] * down[1]
            + s.a_bottom[0] * up_next[0]
            + s.a_bottom[1] * up_next[1];
        down = next;
    }
    FourStackFluxes { r: below[0].r_top.apply(incident), t: down, absorbed }
}
