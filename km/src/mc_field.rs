//! Monte Carlo values at requested depths: the fluence rate `phi(z)`, the
//! absorbed power density `A(z)` and the net flux `F(z)` of a broad beam,
//! with standard errors, from the depth bins of
//! [`km_montecarlo::depth::depth_field`] (docs/montecarlo.md §7).
//!
//! Monte Carlo estimates bin averages. For a depth `z` the value reported
//! is the linear interpolation between the averages of the two bins whose
//! centres bracket `z` (the first bin's average above the first centre),
//! and for the flux between the two bin edges that bracket `z`: a bias of
//! order `dz^2` times the second derivative, and larger where a layer
//! interface lies within a bin of `z` (`A` jumps there). For a strict
//! comparison use the bin averages themselves ([`McDepthValues::bins`]
//! and [`km_montecarlo::depth::DepthField::z_scores`]).

use km_core::Scene;
use km_montecarlo::McOptions;
use km_montecarlo::depth::{DepthField, depth_field};

use crate::KmError;

/// Most depth bins of one request.
pub const MAX_DEPTH_BINS: usize = 100_000;

/// Values at the requested depths, per channel.
#[derive(Debug, Clone, PartialEq)]
pub struct McDepthValues {
    /// The requested depths, in the scene's length unit, as given.
    pub depths: Vec<f64>,
    /// Per channel, `phi(z)` per unit incident irradiance (dimensionless).
    pub fluence: Vec<Vec<f64>>,
    /// Their standard errors (interpolated, covariance between bins neglected).
    pub fluence_se: Vec<Vec<f64>>,
    /// Per channel, `A(z)`, absorbed power per unit depth per unit incident power (1/L).
    pub absorbed: Vec<Vec<f64>>,
    /// Their standard errors.
    pub absorbed_se: Vec<Vec<f64>>,
    /// Per channel, the net downward flux per unit incident power.
    pub net_flux: Vec<Vec<f64>>,
    /// Their standard errors.
    pub net_flux_se: Vec<Vec<f64>>,
    /// The bins the values come from (bin averages, flux at the edges, the run's totals).
    pub bins: DepthField,
}

/// The depths of a field request (every method's): at least one, at most
/// [`MAX_DEPTH_BINS`], each finite and `>= 0`. The one check of them.
pub(crate) fn check_depths(depths: &[f64]) -> Result<(), KmError> {
    let bad = |value: String, reason| Err(KmError::Option { name: "depths", value, reason });
    if depths.is_empty() {
        return bad(
            "[]".into(),
            "no depth asked for: add [output] depths = [...] or { step, max } to the scene",
        );
    }
    if depths.len() > MAX_DEPTH_BINS {
        return bad(depths.len().to_string(), "at most 100000 depths");
    }
    if let Some(z) = depths.iter().find(|z| !(z.is_finite() && **z >= 0.0)) {
        return bad(z.to_string(), "every depth must be finite and >= 0");
    }
    Ok(())
}

/// `phi`, `A` and `F` of `scene` by Monte Carlo at `depths` (each finite
/// and `>= 0`, in the scene's length unit), on bins of width `dz` (default:
/// half the smallest gap between distinct depths, or the deepest depth / 200,
/// whichever is smaller; at most [`MAX_DEPTH_BINS`] bins down to the deepest
/// depth).
///
/// # Errors
/// An empty list, a negative or non-finite depth or `dz`, too many bins
/// ([`KmError::Option`]), and the Monte Carlo's errors.
///
/// ```
/// let s = km_core::Scene::from_toml_str(
///     "[[layer]]\nsigma_a = 1.0\nsigma_s = 0.0\nthickness = 3.0\n").unwrap();
/// let o = km::McOptions { samples: 20_000, ..Default::default() };
/// let v = km::mc_field::mc_depths(&s, &[0.5, 1.0], None, &o).unwrap();
/// // No scattering: F(z) = exp(-z).
/// assert!((v.net_flux[0][1] - (-1.0f64).exp()).abs() < 5.0 * v.net_flux_se[0][1] + 1e-3);
/// ```
pub fn mc_depths(
    scene: &Scene,
    depths: &[f64],
    dz: Option<f64>,
    opts: &McOptions,
) -> Result<McDepthValues, KmError> {
    check_depths(depths)?;
    let bad = |name, value: String, reason| Err(KmError::Option { name, value, reason });
    let deepest = depths.iter().copied().fold(0.0, f64::max);
    let dz = match dz {
        Some(d) if d.is_finite() && d > 0.0 => d,
        Some(d) => return bad("dz", d.to_string(), "must be finite and > 0"),
        None => default_dz(depths, deepest),
    };
    let nz = (deepest / dz).floor() as usize + 2;
    if !(deepest / dz).is_finite() || nz > MAX_DEPTH_BINS {
        return bad("dz", dz.to_string(), "more than 100000 bins down to the deepest depth");
    }
    let f = depth_field(scene, opts, dz, nz)?;
    let mut v = McDepthValues {
        depths: depths.to_vec(),
        fluence: Vec::new(),
        fluence_se: Vec::new(),
        absorbed: Vec::new(),
        absorbed_se: Vec::new(),
        net_flux: Vec::new(),
        net_flux_se: Vec::new(),
        bins: f.clone(),
    };
    // The bin centres each depth may be interpolated between: those of the
    // bins inside its layer (a depth on an interface belongs to the layer
    // above, docs/field.md §1), so that no value mixes in a bin across a
    // jump of A or phi, or the empty bins below the stack.
    let mut bounds = vec![0.0];
    for l in scene.channels()[0].layers() {
        bounds.push(bounds[bounds.len() - 1] + l.thickness());
    }
    let span = |z: f64| -> (f64, f64) {
        let k = bounds.windows(2).position(|w| z <= w[1]).unwrap_or(bounds.len() - 2);
        let (top, bottom) = (bounds[k], bounds[k + 1]);
        let (lo, hi) = ((top / dz).ceil(), (bottom / dz).floor() - 1.0);
        // A layer thinner than a bin: the bin holding z.
        if hi < lo {
            ((z / dz).floor().min(hi.max(0.0)), (z / dz).floor().min(hi.max(0.0)))
        } else {
            (lo, hi)
        }
    };
    for c in 0..f.phi.len() {
        let at_centres = |x: &[f64], se: &[f64]| -> (Vec<f64>, Vec<f64>) {
            depths
                .iter()
                .map(|&z| {
                    let (lo, hi) = span(z);
                    interpolate(x, se, (z / dz - 0.5).clamp(lo, hi))
                })
                .unzip()
        };
        let (p, ps) = at_centres(&f.phi[c], &f.phi_se[c]);
        let (a, as_) = at_centres(&f.a[c], &f.a_se[c]);
        let (n, ns): (Vec<f64>, Vec<f64>) =
            depths.iter().map(|&z| interpolate(&f.flux[c], &f.flux_se[c], z / dz)).unzip();
        v.fluence.push(p);
        v.fluence_se.push(ps);
        v.absorbed.push(a);
        v.absorbed_se.push(as_);
        v.net_flux.push(n);
        v.net_flux_se.push(ns);
    }
    Ok(v)
}

/// Half the smallest gap between distinct depths, at most `deepest / 200`
/// (and 1 when every depth is 0).
fn default_dz(depths: &[f64], deepest: f64) -> f64 {
    let mut d: Vec<f64> = depths.to_vec();
    d.sort_by(f64::total_cmp);
    d.dedup();
    let gap = d.windows(2).map(|w| w[1] - w[0]).fold(f64::INFINITY, f64::min);
    let dz = (0.5 * gap).min(deepest / 200.0);
    if dz > 0.0 && dz.is_finite() { dz } else { 1.0 }
}

/// Linear interpolation of `x` (with standard errors `se`) at fractional
/// index `t`, clamped to the ends.
fn interpolate(x: &[f64], se: &[f64], t: f64) -> (f64, f64) {
    let last = x.len() - 1;
    if t <= 0.0 {
        return (x[0], se[0]);
    }
    let i = (t.floor() as usize).min(last);
    if i >= last {
        return (x[last], se[last]);
    }
    let w = t - i as f64;
    let v = (1.0 - w) * x[i] + w * x[i + 1];
    let s = ((1.0 - w).powi(2) * se[i].powi(2) + w * w * se[i + 1].powi(2)).sqrt();
    (v, s)
}

/// The radiance at `directions` and `depths` by Monte Carlo (docs/field.md
/// §4a): the photons crossing the plane at each depth within a cone of
/// half-angle `cone_deg` around each direction
/// ([`km_montecarlo::solve_inside`]), as cone averages with standard errors
/// (the cone is the estimator's resolution). A run of its own, with the
/// options' photons and seed ([`mc_depths_inside`] gives it with the depth
/// profiles of the same run).
///
/// # Errors
/// Depths or directions out of range, a cone outside `(0, 45]` degrees
/// ([`KmError::MonteCarlo`] naming the option), and the run's errors.
pub fn mc_inside(
    scene: &Scene,
    depths: &[f64],
    directions: &[[f64; 2]],
    cone_deg: f64,
    opts: &McOptions,
) -> Result<crate::inside::InsideField, KmError> {
    let (o, cones) = with_inside(depths, directions, cone_deg, opts)?;
    let (_, results) = km_montecarlo::solve_inside(scene, &o)?;
    Ok(inside_field(directions, &results, cones))
}

/// [`mc_depths`] and [`mc_inside`] from one run: the photons, and so every
/// value, are those of the two separate runs of the same options and seed
/// (a tally draws no random number), at the cost of one.
///
/// # Errors
/// Those of [`mc_depths`] and [`mc_inside`].
pub fn mc_depths_inside(
    scene: &Scene,
    depths: &[f64],
    dz: Option<f64>,
    directions: &[[f64; 2]],
    cone_deg: f64,
    opts: &McOptions,
) -> Result<(McDepthValues, crate::inside::InsideField), KmError> {
    let (o, cones) = with_inside(depths, directions, cone_deg, opts)?;
    let mut v = mc_depths(scene, depths, dz, &o)?;
    let results = v.bins.inside.take().unwrap_or_default();
    Ok((v, inside_field(directions, &results, cones)))
}

/// `opts` with the planes and cones of the radiance inside, and the cones'
/// half-angles in degrees (narrowed near the horizon).
fn with_inside(
    depths: &[f64],
    directions: &[[f64; 2]],
    cone_deg: f64,
    opts: &McOptions,
) -> Result<(McOptions, Vec<f64>), KmError> {
    let bins = km_montecarlo::options::InsideBins {
        depths: depths.to_vec(),
        directions: directions.to_vec(),
        half_angle_deg: cone_deg,
    };
    bins.validate()?;
    let cones: Vec<f64> = bins.half_angles().iter().map(|a| a.to_degrees()).collect();
    Ok((McOptions { inside: Some(Box::new(bins)), ..opts.clone() }, cones))
}

/// The run's radiance inside as the field's answer (plane-major values
/// split per depth).
fn inside_field(
    directions: &[[f64; 2]],
    results: &[km_montecarlo::InsideResult],
    cones: Vec<f64>,
) -> crate::inside::InsideField {
    let nd = directions.len();
    let split = |v: &[f64]| -> Vec<Vec<f64>> { v.chunks(nd).map(<[f64]>::to_vec).collect() };
    crate::inside::InsideField {
        directions: directions.to_vec(),
        radiance: results.iter().map(|r| split(&r.radiance)).collect(),
        stderr: Some(results.iter().map(|r| split(&r.radiance_se)).collect()),
        beams: None,
        cone_half_angle_deg: Some(cones),
    }
}
