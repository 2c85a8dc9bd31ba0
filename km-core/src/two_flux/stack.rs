//! Slabs (layers, interfaces, substrates) and their concatenation: the adding
//! form (seed eq. 14 re-derived) and the transfer-matrix form (seed eq. 11–13).

use crate::error::CoreError;
use crate::fresnel;
use crate::scene::Light;

use super::{check_ks, check_thickness, layer_parts, layer_rt};

/// Anything with two faces for the two fluxes: a layer, an interface, a stack
/// or an opaque ground. Reflectances and transmittances for diffuse flux from
/// above (`_top`, `_tb`) and from below (`_bottom`, `_bt`); `r + t + a = 1` on
/// each side.
///
/// In the notation of seed eq. 11: `R11 = t_tb`, `R21 = r_top`,
/// `R12 = r_bottom`, `R22 = t_bt`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Slab {
    /// Reflectance for flux from above (`R21`).
    pub r_top: f64,
    /// Transmittance top to bottom (`R11`).
    pub t_tb: f64,
    /// Reflectance for flux from below (`R12`).
    pub r_bottom: f64,
    /// Transmittance bottom to top (`R22`).
    pub t_bt: f64,
    /// Absorptance for flux from above.
    pub a_top: f64,
    /// Absorptance for flux from below.
    pub a_bottom: f64,
}

impl Slab {
    /// Nothing at all: `t = 1` both ways.
    pub const CLEAR: Slab =
        Slab { r_top: 0.0, t_tb: 1.0, r_bottom: 0.0, t_bt: 1.0, a_top: 0.0, a_bottom: 0.0 };

    /// A symmetric two-flux layer ([`layer_rt`]); `thickness = inf` gives a half-space.
    ///
    /// # Errors
    /// Those of [`layer_rt`].
    pub fn layer(k: f64, s: f64, thickness: f64) -> Result<Slab, CoreError> {
        let rt = layer_rt(k, s, thickness)?;
        Ok(Slab {
            r_top: rt.r,
            t_tb: rt.t,
            r_bottom: rt.r,
            t_bt: rt.t,
            a_top: rt.a,
            a_bottom: rt.a,
        })
    }

    /// An opaque ground of hemispherical reflectance `albedo` in `[0, 1]`
    /// (Lambertian substrate; `albedo = 0` is black; a half-space layer is the
    /// ground `R_inf`). Nothing is transmitted; light from below is irrelevant.
    ///
    /// # Errors
    /// `albedo` outside `[0, 1]`.
    pub fn ground(albedo: f64) -> Result<Slab, CoreError> {
        if !(0.0..=1.0).contains(&albedo) {
            return Err(CoreError::invalid("albedo", albedo, "must lie in [0, 1]"));
        }
        Ok(Slab {
            r_top: albedo,
            t_tb: 0.0,
            r_bottom: 0.0,
            t_bt: 0.0,
            a_top: 1.0 - albedo,
            a_bottom: 1.0,
        })
    }

    /// A smooth interface between indices `n_above` and `n_below` for diffuse
    /// flux on both sides: `r_top = R_h(n_above -> n_below)`,
    /// `r_bottom = R_h(n_below -> n_above)` (hemispherical Fresnel reflectance,
    /// [`fresnel::diffuse_reflectance`]), `t = 1 - r`, no absorption.
    ///
    /// # Errors
    /// Indices not finite or below 1.
    pub fn interface_diffuse(n_above: f64, n_below: f64) -> Result<Slab, CoreError> {
        HemisphericalCache::default().interface(n_above, n_below)
    }

    /// Saunderson's top interface (Saunderson 1942): external reflectance
    /// `r_e` for the scene's light (collimated at `theta`: the Fresnel
    /// reflectance at `theta`; diffuse: the hemispherical one from outside)
    /// and internal diffuse reflectance `r_i = R_h(n_layer -> n_ambient)`.
    /// Added on top of a stack of reflectance `R`, it gives Saunderson's
    /// `R' = r_e + (1 - r_e)(1 - r_i) R / (1 - r_i R)` (eq. K12).
    ///
    /// # Errors
    /// Indices not finite or below 1.
    pub fn saunderson_top(light: Light, n_ambient: f64, n_layer: f64) -> Result<Slab, CoreError> {
        HemisphericalCache::default().saunderson_top(light, n_ambient, n_layer)
    }

    /// A lossless interface of reflectances `r_top`, `r_bottom` (`t = 1 - r`).
    fn interface(r_top: f64, r_bottom: f64) -> Slab {
        Slab { r_top, t_tb: 1.0 - r_top, r_bottom, t_bt: 1.0 - r_bottom, a_top: 0.0, a_bottom: 0.0 }
    }

    /// `1 - r_top`, as the sum `t_tb + a_top` (no cancellation when `r_top -> 1`).
    fn one_minus_r_top(&self) -> f64 {
        self.t_tb + self.a_top
    }

    /// `1 - r_bottom`, as the sum `t_bt + a_bottom`.
    fn one_minus_r_bottom(&self) -> f64 {
        self.t_bt + self.a_bottom
    }
}

/// Adding two slabs, `top` over `bottom` (seed eq. 14, first line re-derived;
/// van de Hulst's adding formula / the Redheffer star product).
///
/// With `D = 1 - r_bottom(1) r_top(2)` (the geometric series of the
/// inter-reflections between the two slabs):
///
/// ```text
/// t_tb(12)     = t_tb(2) t_tb(1) / D                            (14a)
/// r_top(12)    = r_top(1) + t_bt(1) r_top(2) t_tb(1) / D        (14b)
/// r_bottom(12) = r_bottom(2) + t_tb(2) r_bottom(1) t_bt(2) / D  (14c)
/// t_bt(12)     = t_bt(1) t_bt(2) / D                            (14d)
/// ```
///
/// For symmetric layers `R12 = R1 + T1^2 R2 / (1 - R1 R2)` and
/// `T12 = T1 T2 / (1 - R1 R2)`. `D` is evaluated as
/// `(1 - r_bottom(1)) + r_bottom(1) (1 - r_top(2))` with each `1 - r` taken as
/// `t + a`, so every term is non-negative. The absorptances follow from the
/// flux at the junction (eq. K8).
///
/// # Reference
/// Seed 000 eq. 14; van de Hulst (1980), the adding method.
///
/// ```
/// use km_core::two_flux::{add, Slab};
/// let one = Slab::layer(0.1, 0.4, 1.0).unwrap();
/// let half = Slab::layer(0.1, 0.4, 0.5).unwrap();
/// let two = add(&half, &half);
/// assert!((two.r_top - one.r_top).abs() < 1e-15 && (two.t_tb - one.t_tb).abs() < 1e-15);
/// ```
pub fn add(top: &Slab, bottom: &Slab) -> Slab {
    // Inter-reflection denominator, all terms >= 0.
    let den = top.one_minus_r_bottom() + top.r_bottom * bottom.one_minus_r_top();
    let inv = if den > 0.0 { 1.0 / den } else { 0.0 };
    // Downward flux at the junction for unit flux from above; upward for unit flux from below.
    let down = top.t_tb * inv;
    let up = bottom.t_bt * inv;
    Slab {
        r_top: top.r_top + top.t_bt * bottom.r_top * down,
        t_tb: bottom.t_tb * down,
        r_bottom: bottom.r_bottom + bottom.t_tb * top.r_bottom * up,
        t_bt: top.t_bt * up,
        // Absorbed in the top slab (from the junction) and in the bottom one.
        a_top: top.a_top + down * (top.a_bottom * bottom.r_top + bottom.a_top),
        a_bottom: bottom.a_bottom + up * (bottom.a_top * top.r_bottom + top.a_bottom),
    }
}

/// The fluxes of a stack lit by a unit flux from above.
#[derive(Debug, Clone, PartialEq)]
pub struct StackFluxes {
    /// Total reflectance of the stack.
    pub r: f64,
    /// Total transmittance (out of the bottom of the last slab).
    pub t: f64,
    /// Fraction absorbed in each slab, top first.
    pub absorbed: Vec<f64>,
    /// Downward flux just above each slab, and below the last (`len + 1` values).
    pub down: Vec<f64>,
    /// Upward flux just above each slab, and below the last (`len + 1` values).
    pub up: Vec<f64>,
}

/// Any number of slabs, top first, by the adding form (seed eq. 14), with the
/// fluxes at every junction and the absorption in every slab.
///
/// First the stacks below each junction are added from the bottom up
/// (`B_k = slab_k + B_{k+1}`), then the fluxes go down:
/// `d_{k+1} = t_tb(k) d_k / (1 - r_bottom(k) r_top(B_{k+1}))`,
/// `u_k = r_top(B_k) d_k`, and slab `k` absorbs `a_top(k) d_k + a_bottom(k) u_{k+1}`
/// (eq. K9). An empty slice is a clear stack (`r = 0, t = 1`).
///
/// # Reference
/// Seed 000 eq. 14; van de Hulst (1980), the adding method.
///
/// ```
/// use km_core::two_flux::{stack_adding, Slab};
/// let s = [Slab::layer(0.1, 0.4, 1.0).unwrap(), Slab::ground(0.8).unwrap()];
/// let f = stack_adding(&s);
/// let a: f64 = f.absorbed.iter().sum();
/// assert!((f.r + f.t + a - 1.0).abs() < 1e-15);
/// ```
pub fn stack_adding(slabs: &[Slab]) -> StackFluxes {
    let n = slabs.len();
    // below[k]: everything from slab k down (below[n]: nothing, clear).
    let mut below = vec![Slab::CLEAR; n + 1];
    for k in (0..n).rev() {
        below[k] = add(&slabs[k], &below[k + 1]);
    }
    // Down pass: total downward flux above each slab and the upward flux there.
    let mut down = vec![0.0; n + 1];
    let mut up = vec![0.0; n + 1];
    let mut absorbed = vec![0.0; n];
    down[0] = 1.0;
    for k in 0..n {
        let s = &slabs[k];
        let b = &below[k + 1];
        let den = s.one_minus_r_bottom() + s.r_bottom * b.one_minus_r_top();
        let inv = if den > 0.0 { 1.0 / den } else { 0.0 };
        down[k + 1] = s.t_tb * down[k] * inv;
        up[k + 1] = b.r_top * down[k + 1];
        up[k] = below[k].r_top * down[k];
        absorbed[k] = s.a_top * down[k] + s.a_bottom * up[k + 1];
    }
    StackFluxes { r: below[0].r_top, t: down[n], absorbed, down, up }
}

/// Transfer matrix `A` of a slab or stack (seed eq. 11–13), kept scaled:
/// `A = exp(log_scale) M` with `max |M_ij| = 1`, and `ln det A` kept apart.
///
/// `A` maps the fluxes above a slab to those below,
/// `(i+_below, i-_below) = A (i+_above, i-_above)`, so a stack is the product
/// `A_n ... A_2 A_1` (seed eq. 11's concatenation). From a slab (seed eq. 12):
/// `A11 = t_tb - r_bottom r_top / t_bt`, `A12 = r_bottom / t_bt`,
/// `A21 = -r_top / t_bt`, `A22 = 1 / t_bt`, and `det A = t_tb / t_bt`.
/// Back to a slab (seed eq. 13), with the first line rewritten through the
/// determinant, `t_tb = A11 - A12 A21 / A22 = det A / A22`, which avoids the
/// cancellation of the seed's form (relative error `eps exp(2 lambda z0)`).
/// Opaque slabs (`t = 0`) have no transfer matrix: a ground enters as the
/// boundary condition of [`Transfer::reflectance_over`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Transfer {
    /// Scaled matrix `M`, rows then columns.
    pub m: [[f64; 2]; 2],
    /// `ln` of the scale factor: `A = exp(log_scale) M`.
    pub log_scale: f64,
    /// `ln det A` (0 for symmetric slabs).
    pub log_det: f64,
}

impl Transfer {
    /// The identity (no slab).
    pub const IDENTITY: Transfer =
        Transfer { m: [[1.0, 0.0], [0.0, 1.0]], log_scale: 0.0, log_det: 0.0 };

    /// The transfer matrix of one two-flux layer of finite thickness, built
    /// from the scaled eq. K2 so that `1/T` never overflows:
    /// `A = (1/T) [[T^2 - R^2, R], [-R, 1]]`.
    ///
    /// # Errors
    /// Those of [`layer_rt`]; an infinite thickness (a half-space is opaque:
    /// use it as the ground of [`Transfer::reflectance_over`]).
    pub fn layer(k: f64, s: f64, thickness: f64) -> Result<Transfer, CoreError> {
        check_ks(k, s)?;
        check_thickness(thickness)?;
        if thickness.is_infinite() {
            return Err(CoreError::invalid(
                "thickness",
                thickness,
                "a half-space has no transfer matrix; use it as the ground",
            ));
        }
        let p = layer_parts(k, s, thickness, true);
        let (r, t) = (p.r, p.t);
        Ok(Transfer { m: [[t * t - r * r, r], [-r, 1.0]], log_scale: -p.ln_t, log_det: 0.0 }
            .normalised())
    }

    /// The transfer matrix of a slab (seed eq. 12).
    ///
    /// # Errors
    /// A slab that does not transmit both ways (`t_tb = 0` or `t_bt = 0`).
    pub fn from_slab(slab: &Slab) -> Result<Transfer, CoreError> {
        if slab.t_bt <= 0.0 || slab.t_tb <= 0.0 {
            return Err(CoreError::invalid(
                "t",
                slab.t_bt.min(slab.t_tb),
                "an opaque slab has no transfer matrix; use it as the ground",
            ));
        }
        let m = [
            [slab.t_tb * slab.t_bt - slab.r_bottom * slab.r_top, slab.r_bottom],
            [-slab.r_top, 1.0],
        ];
        Ok(Transfer { m, log_scale: -slab.t_bt.ln(), log_det: (slab.t_tb / slab.t_bt).ln() }
            .normalised())
    }

    fn normalised(self) -> Transfer {
        let big = self.m.iter().flatten().fold(0.0f64, |acc, x| acc.max(x.abs()));
        if big == 0.0 || !big.is_finite() {
            return self;
        }
        let m = self.m.map(|row| row.map(|x| x / big));
        Transfer { m, log_scale: self.log_scale + big.ln(), ..self }
    }

    /// This stack with `below` under it: `A = A_below A_self` (seed eq. 11).
    pub fn then(&self, below: &Transfer) -> Transfer {
        let (a, b) = (&below.m, &self.m);
        let m = [
            [a[0][0] * b[0][0] + a[0][1] * b[1][0], a[0][0] * b[0][1] + a[0][1] * b[1][1]],
            [a[1][0] * b[0][0] + a[1][1] * b[1][0], a[1][0] * b[0][1] + a[1][1] * b[1][1]],
        ];
        Transfer {
            m,
            log_scale: self.log_scale + below.log_scale,
            log_det: self.log_det + below.log_det,
        }
        .normalised()
    }

    /// Back to reflectances and transmittances (seed eq. 13, first line through `det A`).
    /// The absorptances are `1 - r - t`, clamped at 0 against rounding.
    pub fn to_slab(&self) -> Slab {
        let m = &self.m;
        let r_top = -m[1][0] / m[1][1];
        let r_bottom = m[0][1] / m[1][1];
        let ln_m22 = m[1][1].ln();
        let t_bt = (-self.log_scale - ln_m22).exp();
        let t_tb = (self.log_det - self.log_scale - ln_m22).exp();
        Slab {
            r_top,
            t_tb,
            r_bottom,
            t_bt,
            a_top: (1.0 - r_top - t_tb).max(0.0),
            a_bottom: (1.0 - r_bottom - t_bt).max(0.0),
        }
    }

    /// Reflectance of this stack over an opaque ground of reflectance `r_ground`:
    /// the bottom boundary condition `i-_below = r_ground i+_below` gives
    /// `R = (r_ground A11 - A21) / (A22 - r_ground A12)` (eq. K10).
    pub fn reflectance_over(&self, r_ground: f64) -> f64 {
        let m = &self.m;
        (r_ground * m[0][0] - m[1][0]) / (m[1][1] - r_ground * m[0][1])
    }
}

/// Concatenate slabs (top first) by transfer matrices (seed eq. 11–13). An opaque
/// last slab (a ground, or a half-space layer) enters as a boundary condition.
/// Returns `(R, T)` of the stack.
///
/// # Errors
/// A slab other than the last that does not transmit.
///
/// # Reference
/// Seed 000 eq. 11–13.
pub fn stack_transfer(slabs: &[Slab]) -> Result<(f64, f64), CoreError> {
    let (last, rest) = match slabs.split_last() {
        None => return Ok((0.0, 1.0)),
        Some(x) => x,
    };
    let opaque = last.t_tb == 0.0;
    let upper = if opaque { rest } else { slabs };
    let mut a = Transfer::IDENTITY;
    for s in upper {
        a = a.then(&Transfer::from_slab(s)?);
    }
    if opaque {
        Ok((a.reflectance_over(last.r_top), 0.0))
    } else {
        let s = a.to_slab();
        Ok((s.r_top, s.t_tb))
    }
}

/// Hemispherical Fresnel reflectances already computed in this solve: the
/// integral of [`fresnel::diffuse_reflectance`] dominates the cost of a
/// channel, and spectral channels usually share their indices.
#[derive(Default)]
pub(super) struct HemisphericalCache {
    memo: Vec<(f64, f64, f64)>,
}

impl HemisphericalCache {
    pub(super) fn get(&mut self, n_i: f64, n_t: f64) -> f64 {
        if let Some(&(_, _, r)) = self.memo.iter().find(|m| m.0 == n_i && m.1 == n_t) {
            return r;
        }
        let r = fresnel::diffuse_reflectance(n_i, n_t);
        self.memo.push((n_i, n_t, r));
        r
    }

    /// The diffuse interface slab of [`Slab::interface_diffuse`].
    pub(super) fn interface(&mut self, n_above: f64, n_below: f64) -> Result<Slab, CoreError> {
        crate::layer::check_index("n_above", n_above)?;
        crate::layer::check_index("n_below", n_below)?;
        Ok(Slab::interface(self.get(n_above, n_below), self.get(n_below, n_above)))
    }

    /// Saunderson's top interface of [`Slab::saunderson_top`].
    pub(super) fn saunderson_top(
        &mut self,
        light: Light,
        n0: f64,
        n: f64,
    ) -> Result<Slab, CoreError> {
        crate::layer::check_index("n_ambient", n0)?;
        crate::layer::check_index("n_layer", n)?;
        let r_e = match light.mu0() {
            Some(mu0) => fresnel::reflectance(mu0, n0, n),
            None => self.get(n0, n),
        };
        Ok(Slab::interface(r_e, self.get(n, n0)))
    }
}
