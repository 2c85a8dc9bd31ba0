//! Depth-resolved Monte Carlo output: `phi(z)`, `A(z)` and the net flux
//! `F(z)` of a broad beam, with standard errors (docs/montecarlo.md §7,
//! eqs. G3–G5), and the comparison of a reference field with them.

use km_core::Scene;
use km_core::quadrature::gauss_legendre;

use crate::error::McError;
use crate::grid::McGrid;
use crate::options::McOptions;

/// Depth profiles of a run on uniform bins `[i dz, (i + 1) dz)`,
/// `i < nz`, per channel. Values are per unit incident power (per unit
/// incident irradiance of a broad beam): `phi` is dimensionless, `a` is
/// per unit length (1/L), `flux` is dimensionless.
#[derive(Debug, Clone, PartialEq)]
pub struct DepthField {
    /// Bin width, in the scene's length unit.
    pub dz: f64,
    /// Bin edges `i dz`, `i = 0..=nz`.
    pub edges: Vec<f64>,
    /// Per channel, the bin averages of the fluence rate (eq. G4).
    pub phi: Vec<Vec<f64>>,
    /// Their standard errors (eq. T1).
    pub phi_se: Vec<Vec<f64>>,
    /// Per channel, the bin averages of the absorbed power density (eq. G3).
    pub a: Vec<Vec<f64>>,
    /// Their standard errors.
    pub a_se: Vec<Vec<f64>>,
    /// Per channel, the net downward flux at the edges (eq. G5).
    pub flux: Vec<Vec<f64>>,
    /// Their standard errors.
    pub flux_se: Vec<Vec<f64>>,
    /// Per channel, the power absorbed below the last edge (per unit incident power).
    pub a_below: Vec<f64>,
    /// The whole solution of the run (totals, absorptance per layer, ...).
    pub solution: km_core::Solution,
    /// Per channel, the radiance inside at the planes and directions of the
    /// options' `inside`, when they ask for it (the same run: [`crate::run::solve_grid_inside`]).
    pub inside: Option<Vec<crate::run::InsideResult>>,
}

/// What [`DepthField::z_scores`] compares.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DepthQuantity {
    /// Fluence rate, against the reference's bin average.
    Phi,
    /// Absorbed power density, against the reference's bin average.
    A,
    /// Net downward flux, against the reference at the edges.
    Flux,
}

/// `phi(z)`, `A(z)` and `F(z)` of `scene` on `nz` bins of width `dz` from
/// the top surface (the run's other options from `opts`; its `grid` is
/// replaced by this one with no radial or angular resolution). With
/// `opts.inside` the same run also gives the radiance inside
/// ([`DepthField::inside`]).
///
/// # Errors
/// Those of [`crate::solve`]; a non-positive `dz` or `nz = 0` ([`McError::Option`]).
///
/// ```
/// use km_montecarlo::{McOptions, depth::depth_field};
/// let scene = km_core::Scene::from_toml_str(
///     "[[layer]]\nsigma_a = 1.0\nsigma_s = 0.0\nthickness = 2.0\n").unwrap();
/// let f = depth_field(&scene, &McOptions { samples: 20_000, ..Default::default() }, 0.5, 4)
///     .unwrap();
/// // No scattering: A(z) = exp(-z), averaged over each bin.
/// let want = (1.0 - (-0.5f64).exp()) / 0.5;
/// assert!((f.a[0][0] - want).abs() < 4.0 * f.a_se[0][0]);
/// ```
pub fn depth_field(
    scene: &Scene,
    opts: &McOptions,
    dz: f64,
    nz: usize,
) -> Result<DepthField, McError> {
    let grid = McGrid { dz, nz, dr: 1.0, nr: 0, na: 0 };
    let o = McOptions { grid: Some(grid), ..opts.clone() };
    let (solution, grids, inside) = crate::run::solve_grid_inside(scene, &o)?;
    let take = |v: &Vec<f64>| v[..nz].to_vec();
    Ok(DepthField {
        dz,
        edges: (0..=nz).map(|i| i as f64 * dz).collect(),
        phi: grids.iter().map(|g| take(&g.phi_z)).collect(),
        phi_se: grids.iter().map(|g| take(&g.phi_z_se)).collect(),
        a: grids.iter().map(|g| take(&g.a_z)).collect(),
        a_se: grids.iter().map(|g| take(&g.a_z_se)).collect(),
        flux: grids.iter().map(|g| g.flux_z.clone()).collect(),
        flux_se: grids.iter().map(|g| g.flux_z_se.clone()).collect(),
        a_below: grids.iter().map(|g| g.raw.a_z[nz]).collect(),
        solution,
        inside,
    })
}

impl DepthField {
    /// Per bin (or edge, for the flux), `(mc - ref) / se` of channel
    /// `channel` against a reference function of depth: the bin average of
    /// `reference` (8-point Gauss–Legendre on the bin) for `Phi` and `A`,
    /// its value at the edge for `Flux`. A bin whose standard error is 0 or
    /// undefined gives NaN.
    ///
    /// # Panics
    /// When `channel` is out of range.
    pub fn z_scores(
        &self,
        channel: usize,
        quantity: DepthQuantity,
        reference: impl Fn(f64) -> f64,
    ) -> Vec<f64> {
        let score = |x: f64, r: f64, se: f64| if se > 0.0 { (x - r) / se } else { f64::NAN };
        match quantity {
            DepthQuantity::Flux => (0..self.edges.len())
                .map(|i| {
                    score(self.flux[channel][i], reference(self.edges[i]), self.flux_se[channel][i])
                })
                .collect(),
            DepthQuantity::Phi | DepthQuantity::A => {
                let (v, se) = if quantity == DepthQuantity::Phi {
                    (&self.phi[channel], &self.phi_se[channel])
                } else {
                    (&self.a[channel], &self.a_se[channel])
                };
                (0..v.len())
                    .map(|i| {
                        let r = bin_average(&reference, self.edges[i], self.edges[i + 1]);
                        score(v[i], r, se[i])
                    })
                    .collect()
            }
        }
    }
}

/// The mean of `f` over `[lo, hi]` by 8-point Gauss–Legendre (exact for
/// polynomials of degree 15; a reference with a kink inside the bin, at a
/// layer interface, is averaged less precisely: split such bins).
pub fn bin_average(f: &impl Fn(f64) -> f64, lo: f64, hi: f64) -> f64 {
    let (x, w) = gauss_legendre(8);
    let (c, h) = (0.5 * (lo + hi), 0.5 * (hi - lo));
    0.5 * x.iter().zip(&w).map(|(x, w)| w * f(c + h * x)).sum::<f64>()
}
