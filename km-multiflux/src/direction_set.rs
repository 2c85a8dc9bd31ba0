//! # Direction-set mode: the seed's own discretisation on the sphere
//!
//! Seed 000 §3 discretises the sphere of directions into a finite set
//! `{s_i}` (303 directions in its §4.2) and solves the discretised radiative
//! transfer equation (seed eq. 18)
//!
//! `K dI/dz = (-sigma_t + sigma_s P) I`, `Q = K^-1 (-sigma_t + sigma_s P)`   (eq. DS1)
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
//!   while `w_i P_ij = w_j P_ji` (reciprocity) is kept (eq. DS3): built and
//!   rescaled in `crate::phase_matrix`, with the Fourier–Gauss blocks.
//! * **Eigen-solution** ([`DiscreteModes`]): the plus/minus symmetry reduces
//!   the `2N x 2N` problem to a symmetric `N x N` one (Stamnes & Swanson 1981),
//!   solved by [`crate::eigen`] as for the Fourier–Gauss slab;
//!   the slab operators are written with `tanh` and `sech^2` of `lambda z0 / 2`
//!   only, so no exponential grows, the half-space is the limit `z0 = inf`,
//!   and conservative scattering (`lambda = 0`) needs no special case.
//! * **Interfaces and substrates** as [`LayerOperators`]: Fresnel with
//!   refraction on matched sets, Lambertian and black substrates; stacks are
//!   combined with [`crate::adding`] (seed eq. 14), exactly or by the
//!   truncated Neumann series of seed eq. 21.
#![allow(non_snake_case)]

use std::f64::consts::PI;

use faer::Mat;
use faer::linalg::solvers::Solve;
use km_core::fresnel::reflectance;
use km_core::phase::Phase;
use km_core::quadrature::gauss_legendre;
use km_core::{Layer, Light, MonoScene, Substrate};

use crate::adding::{LayerOperators, add, add_truncated};
use crate::error::MultifluxError;
use crate::phase_matrix::direction_blocks;

mod modes;
mod stack;

pub use modes::DiscreteModes;
pub(crate) use stack::absorber_operators;
pub use stack::{
    Combine, Distribution, StackResponse, brdf_for_incidence, full_brdf, interface_operators,
    lambertian_operators, totals,
};

type Result<T> = std::result::Result<T, MultifluxError>;

fn invalid(name: &'static str, value: f64, reason: &'static str) -> MultifluxError {
    MultifluxError::Option { name, value, reason }
}

fn numerical(what: &'static str, detail: impl Into<String>) -> MultifluxError {
    MultifluxError::Numerical { what, detail: detail.into() }
}

// ---------------------------------------------------------------------------
// Quadrature

/// The Gauss–Radau rule with the fixed node `x = 1` lives in
/// [`km_core::quadrature`] beside the Gauss–Legendre rule; re-exported under
/// its old path.
pub use km_core::quadrature::gauss_radau_upper;

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
    /// Layout (docs eq. DS2): `n_mu = round(sqrt(pi N_h / 8))` Gauss–Legendre
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

    /// The two blocks of the discrete phase matrix (docs eq. DS3):
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
        // Cosines between direction i and direction j or its mirror (x, y, -z).
        let cos_same = |i: usize, j: usize| {
            let (a, b) = (dirs[i], dirs[j]);
            (a[0] * b[0] + a[1] * b[1] + a[2] * b[2]).clamp(-1.0, 1.0)
        };
        let cos_mirror = |i: usize, j: usize| {
            let (a, b) = (dirs[i], dirs[j]);
            (a[0] * b[0] + a[1] * b[1] - a[2] * b[2]).clamp(-1.0, 1.0)
        };
        // The phase function between every pair of directions: from its
        // interpolant where it has no closed form (km-core eq. P18).
        direction_blocks(&self.weight, cos_same, cos_mirror, |c| phase.eval_tabulated(c))
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
    /// set (seed eq. 20, in the stable form of docs eq. DS8–DS10). Operators act
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
        if layer.sigma_s() == 0.0 || layer.thickness() == 0.0 {
            return Ok(absorber_operators(&self.mu, layer.sigma_t(), layer.thickness()));
        }
        // In optical units (sigma_t = 1, thickness tau): the operators
        // depend on sigma_a z0 and sigma_s z0 only, and the modes' matrices
        // stay of order 1 (sigma_t = 1e200 overflowed the eigen-solver).
        let st = layer.sigma_t();
        let tau = if layer.is_half_space() { f64::INFINITY } else { st * layer.thickness() };
        // A layer no light crosses to rounding is the half-space: even a
        // conservative one transmits about 1 / (0.75 tau (1 - g)), below
        // 1e-13 from tau = HALF_SPACE_TAU on (g <= 0.99).
        let tau = if tau > HALF_SPACE_TAU { f64::INFINITY } else { tau };
        self.modes(layer.sigma_a() / st, layer.sigma_s() / st, layer.phase())?.operators(tau)
    }
}

/// Optical thickness from which the direction-set solver takes a layer for
/// a half-space (its transmission is below 1e-13 even without absorption).
pub const HALF_SPACE_TAU: f64 = 1e16;

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
/// `n_k^2 mu_k dmu_k = n_l^2 mu_l dmu_l`, docs eq. DS4), followed by rings of
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
        let fixed = incidence_node(&media, incidence)?;

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
        let pm: Vec<(usize, f64)> = nodes.iter().map(|nd| (nd.panel, nd.mu)).collect();
        let counts = ring_counts(&pm, half);

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
                // Etendue: n_j^2 mu_j dmu_j = n_k^2 mu_k dmu_k (docs eq. DS4).
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

/// The node of a collimated beam: the panel of the medium where its Snell
/// invariant first propagates and its cosine there (`None` without a beam).
fn incidence_node(media: &[f64], incidence: Option<Incidence>) -> Result<Option<(usize, f64)>> {
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
        return Ok(Some((k, (1.0 - s * s).max(0.0).sqrt())));
    }
    Ok(None)
}

/// Azimuths per ring, `m = max(1, round(C sin theta))`, with `C` fitted so
/// that the rings of panel 0 hold about `half` directions; `nodes` are
/// `(panel, mu)`.
fn ring_counts(nodes: &[(usize, f64)], half: f64) -> Vec<usize> {
    let count = |c: f64, mu: f64| ((c * (1.0 - mu * mu).max(0.0).sqrt()).round() as usize).max(1);
    let total0 =
        |c: f64| -> usize { nodes.iter().filter(|nd| nd.0 == 0).map(|nd| count(c, nd.1)).sum() };
    let (mut lo, mut hi) = (0.0, 4.0 * half + 4.0);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if (total0(mid) as f64) < half {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let c =
        if (total0(lo) as f64 - half).abs() <= (total0(hi) as f64 - half).abs() { lo } else { hi };
    nodes.iter().map(|nd| count(c, nd.1)).collect()
}
