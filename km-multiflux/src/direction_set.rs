//! # Direction-set mode: the seed's own discretisation on the sphere
//!
//! Seed 000 §3 discretises the sphere of directions into a finite set
//! `{s_i}` (303 directions in its §4.2) and solves the discretised radiative
//! transfer equation (seed eq. 18)
//!
//! `K dI/dz = (-sigma_t + sigma_s P) I`, `Q = K^-1 (-sigma_t + sigma_s P)`   (eq. D1)
//!
//! exactly in depth by eigen-decomposition of `Q` (seed eq. 19–20). This
//! module is that scheme, made correct and stable (docs/multiflux-direction-set.md); the
//! Fourier–Gauss mode of the crate is the fast default, this one reproduces
//! the paper. The full derivation is in `docs/multiflux-direction-set.md`.
//!
//! * **Direction set** ([`DirectionSet`], [`MatchedSets`]): Gauss–Legendre
//!   rings in `mu = cos(theta)` per hemisphere (no `mu = 0`), each ring with
//!   `m_r ~ sin(theta_r)` equally spaced azimuths starting at 0, weights
//!   `w = 2 pi dmu_r / m_r` (the ring's Gauss weight shared equally), so
//!   `sum w = 4 pi` exactly. Upward direction `j` is the mirror image
//!   `(x, y, -z)` of downward direction `j`. A collimated beam is put on a
//!   node (a centred odd Gauss panel, or a Gauss–Radau node at `mu = 1` for
//!   normal incidence). Media of different refractive index get *matched*
//!   sets: the rings of a lower-index medium are mapped by Snell's law into
//!   the higher-index one (weights by the invariance of `n^2 mu dw`) and the
//!   total-internal-reflection cone gets rings of its own.
//! * **Phase matrix** `P_ij = p(s_i . s_j) w_j`, rescaled symmetrically
//!   (`p_ij -> d_i d_j p_ij`, symmetric Sinkhorn–Knopp) so every row sums to 1
//!   while `w_i P_ij = w_j P_ji` (reciprocity) is kept (eq. D3).
//! * **Eigen-solution** ([`DiscreteModes`]): the plus/minus symmetry reduces
//!   the `2N x 2N` problem to a symmetric `N x N` one (Stamnes & Swanson 1981);
//!   the slab operators are written with `tanh` and `sech^2` of `lambda z0 / 2`
//!   only, so no exponential grows, the half-space is the limit `z0 = inf`,
//!   and conservative scattering (`lambda = 0`) needs no special case.
//! * **Interfaces and substrates** as [`LayerOperators`]: Fresnel with
//!   refraction on matched sets, Lambertian and black substrates; stacks are
//!   combined with [`crate::adding`] (seed eq. 14), exactly or by the
//!   truncated Neumann series of seed eq. 21.
#![allow(non_snake_case)]

use std::f64::consts::PI;

use faer::linalg::solvers::Solve;
use faer::{Mat, Side};
use km_core::fresnel::{gauss_legendre, reflectance};
use km_core::phase::{Phase, PhaseFunction};
use km_core::{Layer, Light, MonoScene, Substrate};

use crate::adding::{LayerOperators, add, add_truncated};
use crate::error::MultifluxError;

type Result<T> = std::result::Result<T, MultifluxError>;

fn invalid(name: &'static str, value: f64, reason: &'static str) -> MultifluxError {
    MultifluxError::Option { name, value, reason }
}

fn numerical(what: &'static str, detail: impl Into<String>) -> MultifluxError {
    MultifluxError::Numerical { what, detail: detail.into() }
}

// ---------------------------------------------------------------------------
// Quadrature

/// `(P_n(x), P_{n-1}(x))` by the three-term recurrence.
fn legendre_pair(n: usize, x: f64) -> (f64, f64) {
    let (mut p0, mut p1) = (1.0, x);
    if n == 0 {
        return (1.0, 0.0);
    }
    for k in 2..=n {
        let p2 = ((2 * k - 1) as f64 * x * p1 - (k - 1) as f64 * p0) / k as f64;
        p0 = p1;
        p1 = p2;
    }
    (p1, p0)
}

/// Gauss–Radau rule on `[-1, 1]` with the fixed node `x = 1`, `n >= 1` points,
/// exact for polynomials of degree `2n - 2` (Abramowitz & Stegun 25.4.31,
/// reflected): the free nodes are the roots of `P_{n-1}(x) - P_n(x)` in
/// `(-1, 1)`, with weights `(1 + x_i) / (n^2 P_{n-1}(x_i)^2)`; the fixed node
/// has weight `2 / n^2`. Returned with the fixed node first, then descending.
pub fn gauss_radau_upper(n: usize) -> Result<(Vec<f64>, Vec<f64>)> {
    if n == 0 {
        return Err(invalid("radau points", 0.0, "need at least one point"));
    }
    let nf = n as f64;
    let mut x = vec![1.0];
    let mut w = vec![2.0 / (nf * nf)];
    for k in 1..n {
        // Chebyshev–Radau node as the initial guess, then Newton on
        // f = P_{n-1} - P_n, f' from P_k' = k (x P_k - P_{k-1}) / (x^2 - 1).
        let mut z = (2.0 * PI * k as f64 / (2.0 * nf - 1.0)).cos();
        for _ in 0..100 {
            let (pn, pn1) = legendre_pair(n, z);
            let (_, pn2) = legendre_pair(n - 1, z);
            let f = pn1 - pn;
            let dpn = nf * (z * pn - pn1) / (z * z - 1.0);
            let dpn1 = if n >= 2 { (nf - 1.0) * (z * pn1 - pn2) / (z * z - 1.0) } else { 0.0 };
            let dz = f / (dpn1 - dpn);
            z -= dz;
            if dz.abs() < 1e-15 {
                break;
            }
        }
        let (_, pn1) = legendre_pair(n, z);
        x.push(z);
        w.push((1.0 + z) / (nf * nf * pn1 * pn1));
    }
    // The rule must integrate 1 exactly; anything else means Newton failed.
    let total: f64 = w.iter().sum();
    if (total - 2.0).abs() > 1e-10 || x.iter().any(|v| !v.is_finite() || v.abs() > 1.0) {
        return Err(numerical("gauss_radau_upper", format!("n = {n}: weights sum to {total}")));
    }
    Ok((x, w))
}

/// Nodes `(mu, dmu)` of one panel `[a, b]` in `mu` with about `n` points, and
/// optionally a node exactly at `fixed`: at `fixed = b` a Gauss–Radau panel,
/// inside a Gauss panel centred on `fixed` with an odd number of points (its
/// middle node) plus a Gauss panel for the rest. Returned in descending `mu`.
fn panel_nodes(a: f64, b: f64, n: usize, fixed: Option<f64>) -> Result<Vec<(f64, f64)>> {
    let gauss = |a: f64, b: f64, n: usize| -> Vec<(f64, f64)> {
        let (x, w) = gauss_legendre(n);
        let (h, c) = (0.5 * (b - a), 0.5 * (b + a));
        x.iter().zip(&w).map(|(xi, wi)| (c + h * xi, h * wi)).collect()
    };
    let mut out = match fixed {
        None => gauss(a, b, n),
        Some(x0) if (b - x0).abs() <= 1e-14 * b.max(1.0) => {
            let (x, w) = gauss_radau_upper(n)?;
            let (h, c) = (0.5 * (b - a), 0.5 * (b + a));
            x.iter()
                .zip(&w)
                .map(|(xi, wi)| (if *xi == 1.0 { b } else { c + h * xi }, h * wi))
                .collect()
        }
        Some(x0) => {
            if !(x0 > a && x0 < b) {
                return Err(invalid("incidence cosine", x0, "outside its panel"));
            }
            // Centred sub-panel [x0 - hw, x0 + hw], odd count so x0 is its middle node.
            let hw = (x0 - a).min(b - x0);
            let share = 2.0 * hw / (b - a);
            let mut nc = ((n as f64 * share).round() as usize).max(1);
            if nc.is_multiple_of(2) {
                nc += 1;
            }
            let mut v = gauss(x0 - hw, x0 + hw, nc);
            // Pin the middle node to x0 exactly (it is x0 up to rounding).
            v[nc / 2].0 = x0;
            let (ra, rb) = if x0 - a > b - x0 { (a, x0 - hw) } else { (x0 + hw, b) };
            if rb - ra > 1e-12 * (b - a) {
                let nr = n.saturating_sub(nc).max(1);
                v.extend(gauss(ra, rb, nr));
            }
            v
        }
    };
    out.sort_by(|p, q| q.0.total_cmp(&p.0));
    Ok(out)
}

// ---------------------------------------------------------------------------
// Direction sets

/// One ring of directions sharing the polar cosine `mu`.
#[derive(Debug, Clone, PartialEq)]
pub struct Ring {
    /// Cosine of the polar angle in this set's medium, `0 < mu <= 1`.
    pub mu: f64,
    /// Snell invariant `n sin(theta)`, the same in every matched medium.
    pub h: f64,
    /// Number of equally spaced azimuths `2 pi q / count`, `q = 0..count`.
    pub count: usize,
    /// Index of the ring's first direction (azimuth 0) in the set.
    pub first: usize,
}

/// A set of `N` downward unit directions with solid-angle weights, and their
/// `N` mirror images travelling upward (direction `j` up = `(x, y, -z)` of
/// direction `j` down). Weights sum to `2 pi` per hemisphere in a medium whose
/// rings cover the whole hemisphere.
///
/// Travel azimuths: ring directions sit at `phi = 2 pi q / m_r`. The light of
/// a scene arrives from BRDF azimuth 0, i.e. it *travels* at azimuth 180°;
/// internally its node is at travel azimuth 0, and the reported exit azimuths
/// ([`Distribution`]) are shifted by 180° to the BRDF convention.
#[derive(Debug, Clone, PartialEq)]
pub struct DirectionSet {
    n: f64,
    mu: Vec<f64>,
    phi: Vec<f64>,
    weight: Vec<f64>,
    rings: Vec<Ring>,
    incidence: Option<usize>,
}

impl DirectionSet {
    /// A set on the sphere of about `n_target` directions (both hemispheres)
    /// in a medium of index 1, without a prescribed incidence node.
    ///
    /// Layout (docs eq. D2): `n_mu = round(sqrt(pi N_h / 8))` Gauss–Legendre
    /// rings per hemisphere (`N_h = n_target / 2`), azimuth counts
    /// `m_r = max(1, round(C sin theta_r))` with `C` chosen so that the
    /// hemisphere holds about `N_h` directions.
    ///
    /// # Errors
    /// `n_target < 4` or `> 20000`.
    ///
    /// ```
    /// let s = km_multiflux::direction_set::DirectionSet::sphere(300).unwrap();
    /// let total: f64 = s.weights().iter().sum::<f64>() * 2.0;
    /// assert!((total - 4.0 * std::f64::consts::PI).abs() < 1e-12);
    /// assert!(s.mu().iter().all(|&m| m > 0.0));
    /// ```
    pub fn sphere(n_target: usize) -> Result<DirectionSet> {
        Ok(MatchedSets::new(n_target, &[1.0], None)?.sets.remove(0))
    }

    /// As [`DirectionSet::sphere`], with a node at polar angle `theta_deg`
    /// (`0 <= theta < 90`) and azimuth 0 for a collimated beam
    /// ([`DirectionSet::incidence`] gives its index).
    ///
    /// # Errors
    /// Those of [`DirectionSet::sphere`] and an angle outside `[0, 90)`.
    pub fn sphere_with_incidence(n_target: usize, theta_deg: f64) -> Result<DirectionSet> {
        let inc = Incidence { n: 1.0, theta_deg };
        Ok(MatchedSets::new(n_target, &[1.0], Some(inc))?.sets.remove(0))
    }

    /// Refractive index of the medium the set lives in.
    pub fn n(&self) -> f64 {
        self.n
    }
    /// Number `N` of downward directions (the set has `2N`).
    pub fn len(&self) -> usize {
        self.mu.len()
    }
    /// True for an empty set (never produced by the constructors).
    pub fn is_empty(&self) -> bool {
        self.mu.is_empty()
    }
    /// Cosines `mu_j > 0` of the downward directions.
    pub fn mu(&self) -> &[f64] {
        &self.mu
    }
    /// Travel azimuths `phi_j` (radians) of the directions.
    pub fn phi(&self) -> &[f64] {
        &self.phi
    }
    /// Solid-angle weights `w_j` (sr), the same for a direction and its mirror.
    pub fn weights(&self) -> &[f64] {
        &self.weight
    }
    /// The rings, in increasing Snell invariant (decreasing `mu` per panel).
    pub fn rings(&self) -> &[Ring] {
        &self.rings
    }
    /// Index of the collimated-beam node, when the set was built with one.
    pub fn incidence(&self) -> Option<usize> {
        self.incidence
    }

    /// Downward unit vector of direction `j`: `(sin cos phi, sin sin phi, mu)`.
    pub fn direction(&self, j: usize) -> [f64; 3] {
        let s = (1.0 - self.mu[j] * self.mu[j]).max(0.0).sqrt();
        [s * self.phi[j].cos(), s * self.phi[j].sin(), self.mu[j]]
    }

    /// The two blocks of the discrete phase matrix (docs eq. D3):
    /// `P++_ij = p(s_i . s_j) w_j` (down to down) and `P+-_ij = p(s_i . s'_j) w_j`
    /// (`s'_j` the mirror of `s_j`), rescaled symmetrically so that every row of
    /// `[P++ P+-]` sums to 1 and `w_i P_ij = w_j P_ji`. By mirror symmetry
    /// `P-- = P++` and `P-+ = P+-`.
    ///
    /// # Errors
    /// A non-convergent rescaling (non-positive phase values).
    pub fn phase_blocks(&self, phase: &Phase) -> Result<(Mat<f64>, Mat<f64>)> {
        let n = self.len();
        let dirs: Vec<[f64; 3]> = (0..n).map(|j| self.direction(j)).collect();
        let pp = Mat::from_fn(n, n, |i, j| {
            let (a, b) = (dirs[i], dirs[j]);
            phase.eval((a[0] * b[0] + a[1] * b[1] + a[2] * b[2]).clamp(-1.0, 1.0))
        });
        let pm = Mat::from_fn(n, n, |i, j| {
            let (a, b) = (dirs[i], dirs[j]);
            phase.eval((a[0] * b[0] + a[1] * b[1] - a[2] * b[2]).clamp(-1.0, 1.0))
        });
        renormalised_blocks(pp, pm, &self.weight)
    }

    /// The eigen-solution of a homogeneous medium on this set (seed eq. 18–19).
    ///
    /// # Errors
    /// Invalid coefficients, numerical failure of the eigen-solver.
    pub fn modes(&self, sigma_a: f64, sigma_s: f64, phase: &Phase) -> Result<DiscreteModes> {
        let (pp, pm) = self.phase_blocks(phase)?;
        DiscreteModes::new(&self.mu, &self.weight, &pp, &pm, sigma_a, sigma_s)
    }

    /// Reflection and transmission operators of one homogeneous layer on this
    /// set (seed eq. 20, in the stable form of docs eq. D8–D10). Operators act
    /// on radiance vectors: `I_up(0) = r_top I_down(0)`, `I_down(z0) = t_down I_down(0)`.
    /// The layer's own index `n` is not used (interfaces are separate operators).
    /// A pure absorber (`sigma_s = 0`) or a clear layer needs no eigen-solve:
    /// `T = diag(exp(-tau / mu_j))`, `R = 0`.
    ///
    /// # Errors
    /// Those of [`DirectionSet::modes`].
    ///
    /// ```
    /// use km_multiflux::direction_set::DirectionSet;
    /// let set = DirectionSet::sphere(60).unwrap();
    /// let layer = km_core::Layer::from_tau_albedo(1.0, 0.9, 0.0, 1.0).unwrap();
    /// let ops = set.layer_operators(&layer).unwrap();
    /// assert_eq!(ops.r_top.nrows(), set.len());
    /// ```
    pub fn layer_operators(&self, layer: &Layer) -> Result<LayerOperators> {
        if layer.sigma_s == 0.0 || layer.thickness == 0.0 {
            return Ok(absorber_operators(&self.mu, layer.sigma_t(), layer.thickness));
        }
        self.modes(layer.sigma_a, layer.sigma_s, &layer.phase)?.operators(layer.thickness)
    }
}

/// Where a collimated beam arrives: polar angle `theta_deg` in the medium of index `n`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Incidence {
    /// Index of the medium the beam travels in.
    pub n: f64,
    /// Polar angle in that medium, degrees, `0 <= theta < 90`.
    pub theta_deg: f64,
}

/// Direction sets for several media, matched across their interfaces: the
/// set of the medium of index `n_k` holds the rings of every lower-index set
/// mapped by Snell's law (`n sin theta` conserved, weights by
/// `n_k^2 mu_k dmu_k = n_l^2 mu_l dmu_l`, docs eq. D4), followed by rings of
/// its own in the total-internal-reflection cone `0 < mu < mu_c`. A direction
/// keeps its index in every set it belongs to, so refraction and mirror
/// reflection are diagonal operators (seed §3.4 without interpolation).
#[derive(Debug, Clone, PartialEq)]
pub struct MatchedSets {
    sets: Vec<DirectionSet>,
}

impl MatchedSets {
    /// Matched sets of about `n_target` directions in the lowest-index medium.
    ///
    /// # Errors
    /// `n_target` outside `[4, 20000]`, an index that is not finite and
    /// positive, an incidence angle outside `[0, 90)` or in a medium not listed.
    pub fn new(n_target: usize, indices: &[f64], incidence: Option<Incidence>) -> Result<Self> {
        if !(4..=20_000).contains(&n_target) {
            return Err(invalid("directions", n_target as f64, "must lie in [4, 20000]"));
        }
        let mut media: Vec<f64> = Vec::new();
        for &n in indices {
            if !n.is_finite() || n <= 0.0 {
                return Err(invalid("n", n, "refractive index must be finite and > 0"));
            }
            if !media.iter().any(|&m| (m - n).abs() <= 1e-12 * n) {
                media.push(n);
            }
        }
        if media.is_empty() {
            return Err(invalid("media", 0.0, "at least one refractive index is needed"));
        }
        media.sort_by(f64::total_cmp);
        let half = n_target as f64 / 2.0;
        let n_mu = ((PI * half / 8.0).sqrt().round() as usize).max(2);

        // Panels: k = 0 is the whole hemisphere of the lowest index; k >= 1 the
        // TIR cone 0 < mu < mu_c of medium k (the rings no lower medium reaches).
        let mut panels: Vec<(usize, f64, usize)> = vec![(0, 1.0, n_mu)];
        for k in 1..media.len() {
            let r = media[k - 1] / media[k];
            let mu_c = (1.0 - r * r).sqrt();
            let nk = ((n_mu as f64 * mu_c.asin() / (PI / 2.0)).round() as usize).max(2);
            panels.push((k, mu_c, nk));
        }

        // The incidence node: its panel and cosine in that panel's medium.
        let mut fixed: Option<(usize, f64)> = None;
        if let Some(inc) = incidence {
            if !(0.0..90.0).contains(&inc.theta_deg) {
                return Err(invalid("theta_deg", inc.theta_deg, "must lie in [0, 90)"));
            }
            if !media.iter().any(|&m| (m - inc.n).abs() <= 1e-12 * m) {
                return Err(invalid("incidence n", inc.n, "not one of the media"));
            }
            let h0 = inc.n * inc.theta_deg.to_radians().sin();
            let k = media.iter().position(|&m| h0 < m).unwrap_or(media.len() - 1);
            let s = h0 / media[k];
            fixed = Some((k, (1.0 - s * s).max(0.0).sqrt()));
        }

        // Nodes of every panel, in increasing Snell invariant h.
        struct Node {
            panel: usize,
            mu: f64,
            dmu: f64,
            h: f64,
            is_fixed: bool,
        }
        let mut nodes: Vec<Node> = Vec::new();
        for &(k, b, nk) in &panels {
            let fx = fixed.filter(|f| f.0 == k).map(|f| f.1);
            for (mu, dmu) in panel_nodes(0.0, b, nk, fx)? {
                let h = media[k] * (1.0 - mu * mu).max(0.0).sqrt();
                nodes.push(Node { panel: k, mu, dmu, h, is_fixed: fx == Some(mu) });
            }
        }

        // Azimuth counts m = max(1, round(C sin theta)), C fitted on panel 0.
        let count =
            |c: f64, mu: f64| ((c * (1.0 - mu * mu).max(0.0).sqrt()).round() as usize).max(1);
        let total0 = |c: f64| -> usize {
            nodes.iter().filter(|nd| nd.panel == 0).map(|nd| count(c, nd.mu)).sum()
        };
        let (mut lo, mut hi) = (0.0, 4.0 * half + 4.0);
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if (total0(mid) as f64) < half {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let c = if (total0(lo) as f64 - half).abs() <= (total0(hi) as f64 - half).abs() {
            lo
        } else {
            hi
        };
        let counts: Vec<usize> = nodes.iter().map(|nd| count(c, nd.mu)).collect();

        // One set per medium: the rings of panels 0..=j, mapped into medium j.
        let mut sets = Vec::with_capacity(media.len());
        for (j, &nj) in media.iter().enumerate() {
            let mut set = DirectionSet {
                n: nj,
                mu: Vec::new(),
                phi: Vec::new(),
                weight: Vec::new(),
                rings: Vec::new(),
                incidence: None,
            };
            for (nd, &m) in nodes.iter().zip(&counts).filter(|(nd, _)| nd.panel <= j) {
                let nk = media[nd.panel];
                let s = nd.h / nj;
                let mu_j = (1.0 - s * s).max(0.0).sqrt();
                // Etendue: n_j^2 mu_j dmu_j = n_k^2 mu_k dmu_k (docs eq. D4).
                let dmu_j = if nd.panel == j {
                    nd.dmu
                } else {
                    nd.dmu * nk * nk * nd.mu / (nj * nj * mu_j)
                };
                let mu_j = if nd.panel == j { nd.mu } else { mu_j };
                let first = set.mu.len();
                if nd.is_fixed && incidence.is_some_and(|inc| (inc.n - nj).abs() <= 1e-12 * nj) {
                    set.incidence = Some(first);
                }
                for q in 0..m {
                    set.mu.push(mu_j);
                    set.phi.push(2.0 * PI * q as f64 / m as f64);
                    set.weight.push(2.0 * PI * dmu_j / m as f64);
                }
                set.rings.push(Ring { mu: mu_j, h: nd.h, count: m, first });
            }
            sets.push(set);
        }
        Ok(MatchedSets { sets })
    }

    /// The set of the medium of index `n`.
    ///
    /// # Errors
    /// No set for that index.
    pub fn set(&self, n: f64) -> Result<&DirectionSet> {
        self.sets
            .iter()
            .find(|s| (s.n - n).abs() <= 1e-12 * n)
            .ok_or_else(|| invalid("n", n, "no direction set for this medium"))
    }

    /// All sets, by increasing index.
    pub fn sets(&self) -> &[DirectionSet] {
        &self.sets
    }
}

/// Symmetric rescaling of a discrete phase function (docs eq. D3): given raw
/// values `p++_ij = p(s_i . s_j)`, `p+-_ij = p(s_i . s'_j)` (symmetric
/// matrices) and weights `w`, find `d > 0` with
/// `sum_j d_i d_j (p++_ij + p+-_ij) w_j = 1` by the symmetric Sinkhorn–Knopp
/// iteration `d_i <- sqrt(d_i / sum_j k_ij w_j d_j)` (Knight 2008), and return
/// `P++_ij = d_i d_j p++_ij w_j`, `P+-_ij = d_i d_j p+-_ij w_j`. The result
/// conserves energy (rows sum to 1) and keeps `w_i P_ij = w_j P_ji`.
pub(crate) fn renormalised_blocks(
    pp: Mat<f64>,
    pm: Mat<f64>,
    w: &[f64],
) -> Result<(Mat<f64>, Mat<f64>)> {
    let n = w.len();
    let k = Mat::from_fn(n, n, |i, j| (pp[(i, j)] + pp[(j, i)] + pm[(i, j)] + pm[(j, i)]) * 0.5);
    let mut d = vec![1.0; n];
    // Linear convergence to rounding level; stop when the worst row error is
    // at rounding level (< 1e-12) and has stopped improving.
    let (mut best, mut stall) = (f64::INFINITY, 0);
    for _ in 0..5_000 {
        let mut worst: f64 = 0.0;
        let sums: Vec<f64> =
            (0..n).map(|i| (0..n).map(|j| k[(i, j)] * w[j] * d[j]).sum::<f64>() * d[i]).collect();
        for i in 0..n {
            worst = worst.max((sums[i] - 1.0).abs());
            if sums[i].is_nan() || sums[i] <= 0.0 {
                return Err(numerical(
                    "phase renormalisation",
                    format!("row {i} sums to {}", sums[i]),
                ));
            }
            d[i] /= sums[i].sqrt();
        }
        if worst < 0.5 * best {
            best = worst;
            stall = 0;
        } else {
            stall += 1;
        }
        if best < 1e-12 && stall >= 3 {
            break;
        }
    }
    if best >= 1e-12 {
        return Err(numerical("phase renormalisation", format!("row sums off by {best:e}")));
    }
    let sym = |m: &Mat<f64>, i: usize, j: usize| 0.5 * (m[(i, j)] + m[(j, i)]);
    let PP = Mat::from_fn(n, n, |i, j| d[i] * d[j] * sym(&pp, i, j) * w[j]);
    let PM = Mat::from_fn(n, n, |i, j| d[i] * d[j] * sym(&pm, i, j) * w[j]);
    Ok((PP, PM))
}

// ---------------------------------------------------------------------------
// Eigen-solution of one homogeneous medium

/// The discrete modes of a homogeneous medium (seed eq. 18–19), in the
/// half-size form of the plus/minus symmetry (Stamnes & Swanson 1981).
///
/// With `M = diag(mu)`, `W = diag(w)`, `A = M^-1 (sigma_t - sigma_s P++)`,
/// `B = M^-1 sigma_s P+-`, the system is `d/dz [I+; I-] = [[-A, B], [-B, A]] [I+; I-]`.
/// Its eigenvalues are `+-lambda_k` with `lambda_k^2` the eigenvalues of
/// `(A + B)(A - B)` (docs eq. D6). The decaying mode `exp(-lambda z)` has
/// `I+ = (S + lambda F) / 2`, `I- = (S - lambda F) / 2` with
/// `(A + B)(A - B) S = lambda^2 S` and `F = (A + B)^-1 S`; the growing one is
/// its mirror image. `(A + B)(A - B)` is similar to the symmetric
/// `L^T H_e L` (`H_o = L L^T`, `H_o,e = (MW)^-1/2 W (sigma_t - sigma_s (P++ -+ P+-)) (MW)^-1/2`),
/// so `S = (MW)^-1/2 L Y`, `F = (MW)^-1/2 L^-T Y` with `Y` orthonormal (docs eq. D7).
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
        // Symmetric odd / even operators H_o, H_e (docs eq. D7).
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
        // H_o = L L^T (positive definite for |g| < 1).
        let llt = h_odd
            .llt(Side::Lower)
            .map_err(|e| numerical("Cholesky of the odd operator", format!("{e:?}")))?;
        let L = llt.L().to_owned();
        let mut m = L.transpose() * &h_even * &L;
        for i in 0..n {
            for j in 0..i {
                let v = 0.5 * (m[(i, j)] + m[(j, i)]);
                m[(i, j)] = v;
                m[(j, i)] = v;
            }
        }
        let evd = m
            .self_adjoint_eigen(Side::Lower)
            .map_err(|e| numerical("symmetric eigen-decomposition", format!("{e:?}")))?;
        let Y = evd.U().to_owned();
        let nu = evd.S().column_vector().to_owned();
        // lambda^2 >= 0 in exact arithmetic: clamp rounding. Conservative
        // scattering has exactly one null mode (the isotropic radiance; docs
        // eq. D7): rounding would give it lambda ~ 1e-8 sigma_t / mu_min, which
        // matters at tau ~ 1e4 and above, so its value is set to 0.
        let mut nu: Vec<f64> = (0..n).map(|k| nu[k].max(0.0)).collect();
        if sigma_a == 0.0 {
            nu[0] = 0.0;
        }
        let lambda: Vec<f64> = nu.iter().map(|v| v.sqrt()).collect();
        let mut S = &L * &Y;
        let mut F = Y.clone();
        L.transpose().solve_upper_triangular_in_place(F.as_mut());
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
    /// (`X+- = (S +- lambda F) / 2`, docs eq. D6). The growing mode
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
    /// (length, `>= 0`, `inf` for a half-space). Docs eq. D8–D10, with
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
        // Per-mode factors, all bounded (docs eq. D9).
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
        // T = S D1^-1 F sech^2 D2^-1 (docs eq. D10): decays like exp(-lambda z0).
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

/// A non-scattering layer: `R = 0`, `T = diag(exp(-sigma_t z0 / mu_j))` (no eigen-solve).
pub(crate) fn absorber_operators(mu: &[f64], sigma_t: f64, thickness: f64) -> LayerOperators {
    let n = mu.len();
    let tau = if sigma_t == 0.0 { 0.0 } else { sigma_t * thickness };
    let mut t = Mat::zeros(n, n);
    for j in 0..n {
        t[(j, j)] = (-tau / mu[j]).exp();
    }
    LayerOperators {
        r_top: Mat::zeros(n, n),
        t_down: t.clone(),
        r_bottom: Mat::zeros(n, n),
        t_up: t,
    }
}

// ---------------------------------------------------------------------------
// Interfaces and substrates (seed §3.4)

/// A smooth Fresnel interface from the medium of `above` (index `n_a`) to that
/// of `below` (`n_b`), on matched sets (docs eq. D11). Direction `j` keeps its
/// index across the interface, so every operator is diagonal:
///
/// * `r_top_jj = R_F(mu_a,j)`, `t_down_jj = (1 - R_F) (n_b / n_a)^2` (n^2 radiance law),
/// * `r_bottom_jj = R_F(mu_b,j)`, `t_up_jj = (1 - R_F) (n_a / n_b)^2`,
///
/// with `R_F = 1` for the directions of the TIR cone of the denser side,
/// which have no partner on the other side.
///
/// # Errors
/// Sets that are not matched (different leading directions).
pub fn interface_operators(above: &DirectionSet, below: &DirectionSet) -> Result<LayerOperators> {
    let (na, nb) = (above.len(), below.len());
    let common = na.min(nb);
    for j in 0..common {
        let (ha, hb) = (
            above.n * (1.0 - above.mu[j] * above.mu[j]).max(0.0).sqrt(),
            below.n * (1.0 - below.mu[j] * below.mu[j]).max(0.0).sqrt(),
        );
        if (ha - hb).abs() > 1e-9 || (above.phi[j] - below.phi[j]).abs() > 1e-12 {
            return Err(MultifluxError::Shape {
                what: "interface_operators",
                detail: format!("direction {j} is not matched across the interface"),
            });
        }
    }
    let (n_a, n_b) = (above.n, below.n);
    let mut ops = LayerOperators {
        r_top: Mat::zeros(na, na),
        t_down: Mat::zeros(nb, na),
        r_bottom: Mat::zeros(nb, nb),
        t_up: Mat::zeros(na, nb),
    };
    for j in 0..na {
        ops.r_top[(j, j)] = if j < common { reflectance(above.mu[j], n_a, n_b) } else { 1.0 };
    }
    for j in 0..nb {
        ops.r_bottom[(j, j)] = if j < common { reflectance(below.mu[j], n_b, n_a) } else { 1.0 };
    }
    for j in 0..common {
        // Stokes: the same Fresnel value from both sides of a matched pair.
        let rf = reflectance(above.mu[j], n_a, n_b);
        ops.t_down[(j, j)] = (1.0 - rf) * (n_b / n_a) * (n_b / n_a);
        ops.t_up[(j, j)] = (1.0 - rf) * (n_a / n_b) * (n_a / n_b);
    }
    Ok(ops)
}

/// A Lambertian reflector of `albedo` in `[0, 1]` as an operator on radiance:
/// `r_ij = (albedo / pi) mu_j w_j` (docs eq. D12), no transmission
/// (`t_down` has 0 rows). `albedo = 0` is the black substrate.
///
/// # Errors
/// Albedo outside `[0, 1]`.
pub fn lambertian_operators(set: &DirectionSet, albedo: f64) -> Result<LayerOperators> {
    if !(0.0..=1.0).contains(&albedo) {
        return Err(invalid("albedo", albedo, "must lie in [0, 1]"));
    }
    let n = set.len();
    Ok(LayerOperators {
        r_top: Mat::from_fn(n, n, |_, j| albedo / PI * set.mu[j] * set.weight[j]),
        t_down: Mat::zeros(0, n),
        r_bottom: Mat::zeros(0, 0),
        t_up: Mat::zeros(n, 0),
    })
}

// ---------------------------------------------------------------------------
// Stacks

/// How layers are combined (seed eq. 14 and 21).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Combine {
    /// The exact adding formula (with the inverse of `1 - R_rr`).
    Exact,
    /// The Neumann series `(1 - R_rr)^-1 ~ 1 + R_rr + ... + R_rr^k` (seed eq. 21).
    Neumann(usize),
}

fn combine(a: &LayerOperators, b: &LayerOperators, how: Combine) -> Result<LayerOperators> {
    match how {
        Combine::Exact => add(a, b),
        Combine::Neumann(k) => add_truncated(a, b, k),
    }
}

/// The operators of a scene's stack, top to bottom: the ambient/first-layer
/// interface, each layer, interfaces between layers of different index, and
/// the substrate (a Lambertian or black reflector, or the interface to a
/// clear half-space). `scatter = false` gives the same stack without
/// scattering and with a black substrate: its response is exactly the delta
/// (specular and unscattered) part of the full response.
fn stack_operators(
    scene: &MonoScene,
    sets: &MatchedSets,
    scatter: bool,
) -> Result<Vec<LayerOperators>> {
    let mut ops = Vec::new();
    let mut n_prev = scene.ambient_n;
    for layer in &scene.layers {
        if (layer.n - n_prev).abs() > 1e-12 * n_prev {
            ops.push(interface_operators(sets.set(n_prev)?, sets.set(layer.n)?)?);
        }
        let set = sets.set(layer.n)?;
        if layer.is_half_space() && layer.sigma_t() == 0.0 {
            return Err(MultifluxError::Scene(km_core::CoreError::unsupported(
                "multiflux (direction set)",
                "a clear half-space layer: use a transparent substrate",
            )));
        }
        ops.push(if scatter {
            set.layer_operators(layer)?
        } else {
            absorber_operators(set.mu(), layer.sigma_t(), layer.thickness)
        });
        n_prev = layer.n;
    }
    match scene.substrate {
        Substrate::Transparent { n } => {
            if (n - n_prev).abs() > 1e-12 * n_prev {
                ops.push(interface_operators(sets.set(n_prev)?, sets.set(n)?)?);
            }
        }
        Substrate::Lambertian { albedo } => {
            let a = if scatter { albedo } else { 0.0 };
            ops.push(lambertian_operators(sets.set(n_prev)?, a)?);
        }
        Substrate::Black => ops.push(lambertian_operators(sets.set(n_prev)?, 0.0)?),
    }
    Ok(ops)
}

fn fold(ops: &[LayerOperators], how: Combine) -> Result<LayerOperators> {
    let mut acc = ops[0].clone();
    for op in &ops[1..] {
        acc = combine(&acc, op, how)?;
    }
    Ok(acc)
}

/// Values on the nodes of one hemisphere of a direction set.
#[derive(Debug, Clone, PartialEq)]
pub struct Distribution {
    /// Polar angle from the normal on the exit side, degrees.
    pub theta_deg: Vec<f64>,
    /// Azimuth in the BRDF convention (light arrives from 0, mirror side 180), degrees.
    pub phi_deg: Vec<f64>,
    /// Solid-angle weight of each node, sr.
    pub weight: Vec<f64>,
    /// Cosine of the exit direction (from the normal on the exit side).
    pub mu: Vec<f64>,
    /// Smooth (delta-free) BRDF or BTDF, 1/sr: exit radiance per unit irradiance on the surface.
    pub value: Vec<f64>,
    /// Full node radiance per unit irradiance (smooth + delta / weight), 1/sr:
    /// what the discrete system carries, used by the seed's RMS comparison.
    pub node_value: Vec<f64>,
}

/// The response of a stack to a collimated beam on a node (seed §4.4, fig. 9).
#[derive(Debug, Clone, PartialEq)]
pub struct StackResponse {
    /// Reflected distribution above the stack (BRDF).
    pub reflected: Distribution,
    /// Transmitted distribution in the clear medium below (BTDF), if any.
    pub transmitted: Option<Distribution>,
    /// Total reflectance (delta included), fraction of `mu0 E`.
    pub reflectance: f64,
    /// Delta (mirror) part of the reflectance.
    pub reflectance_specular: f64,
    /// Total transmittance (unscattered beam included).
    pub transmittance: f64,
    /// Unscattered (delta) part of the transmittance.
    pub transmittance_direct: f64,
    /// `1 - R - T`.
    pub absorptance: f64,
    /// Number of directions (both hemispheres) of the ambient set.
    pub n_directions: usize,
}

/// The BRDF/BTDF of a scene for its collimated light (seed §4.2–4.4) on a
/// direction set of about `n_target` directions in the ambient medium, with
/// the layers combined as `how` says (seed eq. 14 or its truncation eq. 21).
///
/// The beam is a node of the ambient set (`I_inc = e_i0 / w_i0` for unit
/// irradiance normal to the beam); reflected radiance `I_r = R e_i0 / w_i0`;
/// `f_r(j) = I_r,j / mu0` (docs eq. D13). The delta parts are the response of
/// the same stack without scattering and with a black substrate.
///
/// # Errors
/// Diffuse light, an invalid scene, numerical failure.
///
/// ```
/// use km_multiflux::direction_set::{brdf_for_incidence, Combine};
/// let scene = km_core::Scene::from_toml_str(r#"
/// [light]
/// kind = "collimated"
/// theta_deg = 30.0
/// [[layer]]
/// tau = 1.0
/// albedo = 0.9
/// "#).unwrap();
/// let r = brdf_for_incidence(&scene.channels[0], 100, Combine::Exact).unwrap();
/// assert!(r.absorptance > 0.0 && r.reflectance > 0.0);
/// ```
pub fn brdf_for_incidence(
    scene: &MonoScene,
    n_target: usize,
    how: Combine,
) -> Result<StackResponse> {
    scene.validate()?;
    let Light::Collimated { theta_deg } = scene.light else {
        return Err(MultifluxError::Scene(km_core::CoreError::unsupported(
            "multiflux (direction set)",
            "brdf_for_incidence needs collimated light",
        )));
    };
    let sets = scene_sets(scene, n_target, Some(theta_deg))?;
    let total = fold(&stack_operators(scene, &sets, true)?, how)?;
    let delta = fold(&stack_operators(scene, &sets, false)?, Combine::Exact)?;
    response(scene, &sets, &total, &delta)
}

/// The matched sets a scene needs (ambient, every layer, a clear substrate).
fn scene_sets(scene: &MonoScene, n_target: usize, theta_deg: Option<f64>) -> Result<MatchedSets> {
    let mut media = vec![scene.ambient_n];
    media.extend(scene.layers.iter().map(|l| l.n));
    if let Some(n) = scene.substrate_n() {
        media.push(n);
    }
    let inc = theta_deg.map(|t| Incidence { n: scene.ambient_n, theta_deg: t });
    MatchedSets::new(n_target, &media, inc)
}

fn distribution(set: &DirectionSet, smooth: Vec<f64>, node: Vec<f64>) -> Distribution {
    Distribution {
        theta_deg: set.mu.iter().map(|m| m.acos().to_degrees()).collect(),
        phi_deg: set.phi.iter().map(|p| (p.to_degrees() + 180.0) % 360.0).collect(),
        weight: set.weight.clone(),
        mu: set.mu.clone(),
        value: smooth,
        node_value: node,
    }
}

fn response(
    scene: &MonoScene,
    sets: &MatchedSets,
    total: &LayerOperators,
    delta: &LayerOperators,
) -> Result<StackResponse> {
    let top = sets.set(scene.ambient_n)?;
    let i0 =
        top.incidence.ok_or_else(|| invalid("incidence", f64::NAN, "set without a beam node"))?;
    let (w0, mu0) = (top.weight[i0], top.mu[i0]);
    // Radiances per unit irradiance on the surface: column i0 / (w0 mu0).
    let col = |m: &Mat<f64>, j: usize| m[(j, i0)] / (w0 * mu0);
    let n_top = top.len();
    let node_r: Vec<f64> = (0..n_top).map(|j| col(&total.r_top, j)).collect();
    let smooth_r: Vec<f64> =
        (0..n_top).map(|j| col(&total.r_top, j) - col(&delta.r_top, j)).collect();
    let flux = |set: &DirectionSet, v: &[f64]| -> f64 {
        v.iter().zip(&set.mu).zip(&set.weight).map(|((x, m), w)| x * m * w).sum()
    };
    let reflectance = flux(top, &node_r);
    let reflectance_specular =
        flux(top, &(0..n_top).map(|j| col(&delta.r_top, j)).collect::<Vec<_>>());
    let mut transmitted = None;
    let (mut transmittance, mut transmittance_direct) = (0.0, 0.0);
    if let Some(nb) = scene.substrate_n() {
        let bottom = sets.set(nb)?;
        let nbot = bottom.len();
        let node_t: Vec<f64> = (0..nbot).map(|j| col(&total.t_down, j)).collect();
        let delta_t: Vec<f64> = (0..nbot).map(|j| col(&delta.t_down, j)).collect();
        transmittance = flux(bottom, &node_t);
        transmittance_direct = flux(bottom, &delta_t);
        let smooth_t = node_t.iter().zip(&delta_t).map(|(a, b)| a - b).collect();
        transmitted = Some(distribution(bottom, smooth_t, node_t));
    }
    Ok(StackResponse {
        reflected: distribution(top, smooth_r, node_r),
        transmitted,
        reflectance,
        reflectance_specular,
        transmittance,
        transmittance_direct,
        absorptance: 1.0 - reflectance - transmittance,
        n_directions: 2 * n_top,
    })
}

/// The whole discrete BRDF of a scene (seed §4.2: "the BRDF in 8.5 s"): the
/// reflection operator of the stack on the ambient set of about `n_target`
/// directions, as `f_r(i <- j) = R_ij / (mu_j w_j)` (1/sr, delta parts
/// included on the diagonal), for every incidence node `j` at once.
///
/// # Errors
/// Those of [`brdf_for_incidence`] (the scene's light is not used).
pub fn full_brdf(scene: &MonoScene, n_target: usize) -> Result<(DirectionSet, Mat<f64>)> {
    scene.validate()?;
    let sets = scene_sets(scene, n_target, None)?;
    let total = fold(&stack_operators(scene, &sets, true)?, Combine::Exact)?;
    let top = sets.set(scene.ambient_n)?.clone();
    let f = Mat::from_fn(top.len(), top.len(), |i, j| {
        total.r_top[(i, j)] / (top.mu[j] * top.weight[j])
    });
    Ok((top, f))
}

/// Totals of a scene under its light (collimated on a node, or diffuse:
/// uniform radiance `1/pi` on every downward node of the ambient set), as
/// `(R, T)` fractions of the incident flux, on about `n_target` directions.
///
/// # Errors
/// Those of [`brdf_for_incidence`].
pub fn totals(scene: &MonoScene, n_target: usize) -> Result<(f64, f64)> {
    match scene.light {
        Light::Collimated { .. } => {
            let r = brdf_for_incidence(scene, n_target, Combine::Exact)?;
            Ok((r.reflectance, r.transmittance))
        }
        Light::Diffuse => {
            scene.validate()?;
            let sets = scene_sets(scene, n_target, None)?;
            let total = fold(&stack_operators(scene, &sets, true)?, Combine::Exact)?;
            let top = sets.set(scene.ambient_n)?;
            // Incident flux sum mu w / pi (1 up to quadrature), used as the divisor.
            let fin: f64 = top.mu.iter().zip(&top.weight).map(|(m, w)| m * w / PI).sum();
            let out = |m: &Mat<f64>, set: &DirectionSet| -> f64 {
                let mut s = 0.0;
                for i in 0..m.nrows() {
                    let row: f64 = (0..m.ncols()).map(|j| m[(i, j)] / PI).sum();
                    s += row * set.mu[i] * set.weight[i];
                }
                s / fin
            };
            let r = out(&total.r_top, top);
            let t = match scene.substrate_n() {
                Some(nb) => out(&total.t_down, sets.set(nb)?),
                None => 0.0,
            };
            Ok((r, t))
        }
    }
}
