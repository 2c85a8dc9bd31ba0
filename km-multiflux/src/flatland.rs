//! # Flatland: the 2-D direction-set variant of seed 000 §4.2 (figures 3 and 4)
//!
//! The seed draws its eigenvectors (fig. 3) and the radiance inside a slab
//! (fig. 4) in two dimensions: directions are angles `theta` on the circle,
//! measured from the depth axis `+z`, and the phase function is the 2-D
//! Henyey–Greenstein function normalised on the circle
//! ([`km_core::phase::henyey_greenstein_2d`], eq. P5 of km-core):
//!
//! `cos(theta) dI/dz = -sigma_t I + sigma_s integral p2(cos(theta - theta')) I(theta') dtheta'`  (eq. F1)
//!
//! Discretisation ([`CircleSet`]): `N = 4m + 2` equally spaced angles
//! `theta_k = 2 pi k / N` with weights `dtheta = 2 pi / N`. Then `theta = 0`
//! and `theta = pi` are nodes (the normal beam and its reflection) while
//! `+-pi/2` are not (no direction parallel to the surface, so `K^-1` exists).
//! The `2m + 1` downward angles `|theta| < pi/2` and their mirrors
//! `pi - theta` form the same plus/minus structure as the sphere, so the same
//! machinery ([`DiscreteModes`]) solves it: symmetric rescaling of the phase
//! matrix, the half-size eigenproblem, bounded slab operators.
//!
//! Everything here returns data; the figures are drawn by km-bench.

use std::f64::consts::PI;

use faer::Mat;
use km_core::phase::{Anisotropy, henyey_greenstein_2d};

use crate::adding::LayerOperators;
use crate::direction_set::{DiscreteModes, absorber_operators};
use crate::error::MultifluxError;
use crate::phase_matrix::direction_blocks;

type Result<T> = std::result::Result<T, MultifluxError>;

fn invalid(name: &'static str, value: f64, reason: &'static str) -> MultifluxError {
    MultifluxError::Option { name, value, reason }
}

/// Equally spaced directions on the circle, `N = 4m + 2` of them (eq. F2).
#[derive(Debug, Clone, PartialEq)]
pub struct CircleSet {
    /// Downward angles `theta_j` (radians, `|theta| < pi/2`), ascending; the
    /// upward direction `j` is at `pi - theta_j`.
    theta: Vec<f64>,
    mu: Vec<f64>,
    w: Vec<f64>,
}

impl CircleSet {
    /// The set of `n_dirs` directions (`n_dirs = 4m + 2`, `m >= 1`).
    ///
    /// # Errors
    /// `n_dirs` not of the form `4m + 2` with `6 <= n_dirs <= 10002`.
    ///
    /// ```
    /// let s = km_multiflux::flatland::CircleSet::new(38).unwrap();
    /// assert_eq!(s.len(), 19);
    /// assert!(km_multiflux::flatland::CircleSet::new(40).is_err());
    /// ```
    pub fn new(n_dirs: usize) -> Result<CircleSet> {
        if n_dirs % 4 != 2 || !(6..=10_002).contains(&n_dirs) {
            return Err(invalid("n_dirs", n_dirs as f64, "must be 4m + 2, between 6 and 10002"));
        }
        let m = (n_dirs - 2) / 4;
        let d = 2.0 * PI / n_dirs as f64;
        let theta: Vec<f64> = (-(m as i64)..=m as i64).map(|k| k as f64 * d).collect();
        let mu = theta.iter().map(|t| t.cos()).collect();
        Ok(CircleSet { w: vec![d; theta.len()], theta, mu })
    }

    /// Number of downward directions (`2m + 1`; the set has twice as many).
    pub fn len(&self) -> usize {
        self.theta.len()
    }
    /// True for an empty set (never produced by [`CircleSet::new`]).
    pub fn is_empty(&self) -> bool {
        self.theta.is_empty()
    }
    /// Downward angles, radians.
    pub fn theta(&self) -> &[f64] {
        &self.theta
    }
    /// Cosines of the downward angles, `> 0`.
    pub fn mu(&self) -> &[f64] {
        &self.mu
    }
    /// Angular weights `dtheta`.
    pub fn weights(&self) -> &[f64] {
        &self.w
    }
    /// Index of the normal direction `theta = 0` among the downward ones.
    pub fn normal_index(&self) -> usize {
        self.theta.len() / 2
    }

    /// The rescaled discrete phase blocks `P++_ij = p2(cos(theta_i - theta_j)) dtheta`,
    /// `P+-_ij = p2(cos(theta_i - pi + theta_j)) dtheta`, rows of `[P++ P+-]`
    /// summing to 1 (same symmetric rescaling as the sphere, docs eq. DS3).
    ///
    /// `g` is checked by its type (`|g| < 1`).
    ///
    /// # Errors
    /// None today (the renormalisation's own failures).
    pub fn phase_blocks(&self, g: Anisotropy) -> Result<(Mat<f64>, Mat<f64>)> {
        let g = g.get();
        let t = &self.theta;
        // Cosines between direction i and direction j or its mirror pi - theta_j.
        let cos_same = |i: usize, j: usize| (t[i] - t[j]).cos();
        let cos_mirror = |i: usize, j: usize| (t[i] - PI + t[j]).cos();
        direction_blocks(&self.w, cos_same, cos_mirror, |c| henyey_greenstein_2d(g, c))
    }

    /// The modes of a medium on this set (seed eq. 18–19 in 2-D).
    ///
    /// # Errors
    /// Invalid coefficients or `g`; numerical failure.
    pub fn modes(&self, sigma_a: f64, sigma_s: f64, g: Anisotropy) -> Result<DiscreteModes> {
        let (pp, pm) = self.phase_blocks(g)?;
        DiscreteModes::new(&self.mu, &self.w, &pp, &pm, sigma_a, sigma_s)
    }

    /// Slab operators on this set (docs eq. DS8–DS10); no eigen-solve without scattering.
    ///
    /// # Errors
    /// Those of [`CircleSet::modes`] and a negative thickness.
    pub fn layer_operators(
        &self,
        sigma_a: f64,
        sigma_s: f64,
        g: Anisotropy,
        thickness: f64,
    ) -> Result<LayerOperators> {
        if thickness.is_nan() || thickness < 0.0 {
            return Err(invalid("thickness", thickness, "must be >= 0 or inf"));
        }
        if sigma_s == 0.0 || thickness == 0.0 {
            if !sigma_a.is_finite() || sigma_a < 0.0 {
                return Err(invalid("sigma_a", sigma_a, "must be finite and >= 0"));
            }
            return Ok(absorber_operators(&self.mu, sigma_a + sigma_s, thickness));
        }
        self.modes(sigma_a, sigma_s, g)?.operators(thickness)
    }

    /// All `2N` angles in output order: ascending in `(-pi, pi]`, with the
    /// position of each in the down/up layout (`(true, j)` = downward `j`).
    fn layout(&self) -> Vec<(f64, bool, usize)> {
        let mut v: Vec<(f64, bool, usize)> = Vec::with_capacity(2 * self.len());
        for (j, &t) in self.theta.iter().enumerate() {
            v.push((t, true, j));
            let up = PI - t;
            v.push((if up > PI { up - 2.0 * PI } else { up }, false, j));
        }
        v.sort_by(|a, b| a.0.total_cmp(&b.0));
        v
    }
}

/// Eigenvalues and eigenvectors of `Q = K^-1 (-sigma_t + sigma_s P)` on the
/// circle (seed eq. 18–19, fig. 3).
#[derive(Debug, Clone, PartialEq)]
pub struct Eigenmodes {
    /// The `2N` direction angles (radians from `+z`, ascending in `(-pi, pi]`).
    pub angles: Vec<f64>,
    /// Eigenvalues of `Q` (1/length), in pairs `-lambda_k, +lambda_k`, by
    /// increasing `lambda_k` (the first pair is the most diffuse mode).
    pub eigenvalues: Vec<f64>,
    /// One vector per eigenvalue, the radiance over [`Eigenmodes::angles`],
    /// scaled to a maximum absolute value of 1 with a positive largest entry.
    pub vectors: Vec<Vec<f64>>,
}

/// Eigenvalues and eigenvectors of the flatland transfer matrix for a medium
/// (`sigma_a`, `sigma_s` in 1/length, 2-D HG asymmetry `g`) on `n_dirs = 4m + 2`
/// directions (seed fig. 3). The mode with eigenvalue `-lambda` decays into
/// the medium as `exp(-lambda z)`; its partner `+lambda` is its mirror image.
///
/// # Errors
/// Invalid parameters, `sigma_t = 0`, numerical failure.
///
/// ```
/// let g = km_core::phase::Anisotropy::new(0.5).unwrap();
/// let e = km_multiflux::flatland::eigenmodes(0.2, 0.8, g, 38).unwrap();
/// assert_eq!(e.eigenvalues.len(), 38);
/// assert!((e.eigenvalues[0] + e.eigenvalues[1]).abs() < 1e-12);
/// ```
pub fn eigenmodes(sigma_a: f64, sigma_s: f64, g: Anisotropy, n_dirs: usize) -> Result<Eigenmodes> {
    let set = CircleSet::new(n_dirs)?;
    let modes = set.modes(sigma_a, sigma_s, g)?;
    let (xp, xm) = modes.eigenvectors();
    let layout = set.layout();
    let mut eigenvalues = Vec::with_capacity(2 * set.len());
    let mut vectors = Vec::with_capacity(2 * set.len());
    for (k, &lam) in modes.lambda().iter().enumerate() {
        for (sign, (down, up)) in [(-1.0, (&xp, &xm)), (1.0, (&xm, &xp))] {
            let mut v: Vec<f64> = layout
                .iter()
                .map(|&(_, is_down, j)| if is_down { down[(j, k)] } else { up[(j, k)] })
                .collect();
            let big =
                v.iter().copied().fold(0.0, |a: f64, b| if b.abs() > a.abs() { b } else { a });
            if big != 0.0 {
                v.iter_mut().for_each(|x| *x /= big);
            }
            eigenvalues.push(sign * lam);
            vectors.push(v);
        }
    }
    Ok(Eigenmodes { angles: layout.iter().map(|a| a.0).collect(), eigenvalues, vectors })
}

/// The radiance at one depth for a normal beam (seed fig. 4).
#[derive(Debug, Clone, PartialEq)]
pub struct DepthProfile {
    /// Depth, length units.
    pub z: f64,
    /// Angles of the directions (radians from `+z`, ascending in `(-pi, pi]`).
    pub angles: Vec<f64>,
    /// Scattered radiance per unit incident flux at each angle, 1/rad.
    pub diffuse: Vec<f64>,
    /// Unscattered beam flux at this depth, `exp(-sigma_t z)` (a delta at angle 0).
    pub direct: f64,
}

/// The radiance `I(z, theta)` inside a slab lit by a normal collimated beam of
/// unit flux (seed fig. 4: `z = 0, 1/sigma_t, 5/sigma_t`), for `sigma_a`,
/// `sigma_s` (1/length), 2-D HG `g`, `thickness` (length, `inf` for a
/// half-space) on `n_dirs = 4m + 2` directions.
///
/// The field at depth `z` follows from the operators of the two sub-slabs
/// `[0, z]` (a) and `[z, z0]` (b) (docs eq. DS14):
/// `I+(z) = (1 - R_a R_b)^-1 T_a I_inc`, `I-(z) = R_b I+(z)`; this is seed
/// eq. 19 with every exponential bounded. The unscattered beam is reported
/// separately (`direct`); `diffuse` is the rest.
///
/// # Errors
/// Invalid parameters, a depth outside `[0, thickness]`, numerical failure.
///
/// ```
/// use km_core::phase::Anisotropy;
/// let p = km_multiflux::flatland::intensity_at_depths(
///     0.2,
///     0.8,
///     Anisotropy::ISOTROPIC,
///     f64::INFINITY,
///     38,
///     &[0.0, 1.0],
/// )
/// .unwrap();
/// assert!((p[1].direct - (-1.0f64).exp()).abs() < 1e-15);
/// ```
pub fn intensity_at_depths(
    sigma_a: f64,
    sigma_s: f64,
    g: Anisotropy,
    thickness: f64,
    n_dirs: usize,
    depths: &[f64],
) -> Result<Vec<DepthProfile>> {
    let set = CircleSet::new(n_dirs)?;
    if thickness.is_nan() || thickness < 0.0 {
        return Err(invalid("thickness", thickness, "must be >= 0 or inf"));
    }
    let sigma_t = sigma_a + sigma_s;
    let n = set.len();
    let j0 = set.normal_index();
    let w0 = set.w[j0];
    let modes = if sigma_s > 0.0 { Some(set.modes(sigma_a, sigma_s, g)?) } else { None };
    let ops = |z: f64| -> Result<LayerOperators> {
        match &modes {
            Some(m) => m.operators(z),
            None => Ok(absorber_operators(&set.mu, sigma_t, z)),
        }
    };
    let layout = set.layout();
    let mut out = Vec::with_capacity(depths.len());
    for &z in depths {
        if !(z >= 0.0 && z <= thickness) || z.is_infinite() {
            return Err(invalid("depth", z, "must lie in [0, thickness] and be finite"));
        }
        let a = ops(z)?;
        let b =
            ops(if thickness.is_infinite() { f64::INFINITY } else { (thickness - z).max(0.0) })?;
        // I+(z) = (1 - R_a,bottom R_b,top)^-1 T_a e_j0 / w0.
        let mut lhs = Mat::<f64>::identity(n, n);
        lhs -= &a.r_bottom * &b.r_top;
        let rhs = Mat::from_fn(n, 1, |i, _| a.t_down[(i, j0)] / w0);
        use faer::linalg::solvers::Solve;
        let down = lhs.partial_piv_lu().solve(&rhs);
        let up = &b.r_top * &down;
        let direct = (-sigma_t * z).exp();
        let diffuse: Vec<f64> = layout
            .iter()
            .map(|&(_, is_down, j)| {
                if is_down {
                    down[(j, 0)] - if j == j0 { direct / w0 } else { 0.0 }
                } else {
                    up[(j, 0)]
                }
            })
            .collect();
        if diffuse.iter().any(|v| !v.is_finite()) {
            return Err(MultifluxError::Numerical {
                what: "flatland field",
                detail: format!("non-finite radiance at z = {z}"),
            });
        }
        out.push(DepthProfile { z, angles: layout.iter().map(|a| a.0).collect(), diffuse, direct });
    }
    Ok(out)
}

/// Reflectance and transmittance (fractions of the incident flux) of a
/// flatland slab lit by a normal beam, from the slab operators.
///
/// # Errors
/// Those of [`CircleSet::layer_operators`].
pub fn slab_totals(
    sigma_a: f64,
    sigma_s: f64,
    g: Anisotropy,
    thickness: f64,
    n_dirs: usize,
) -> Result<(f64, f64)> {
    let set = CircleSet::new(n_dirs)?;
    let ops = set.layer_operators(sigma_a, sigma_s, g, thickness)?;
    let j0 = set.normal_index();
    // Beam radiance e_j0 / w0 carries unit flux (mu0 = 1).
    let flux = |m: &Mat<f64>| -> f64 {
        (0..set.len()).map(|i| m[(i, j0)] / set.w[j0] * set.mu[i] * set.w[i]).sum()
    };
    Ok((flux(&ops.r_top), flux(&ops.t_down)))
}
