//! Cone means of the BRDF/BTDF: what a Monte Carlo bin measures, and the
//! multi-flux value averaged over the same cones for comparison
//! (docs/montecarlo.md §6, eq. B1–B2' and B5).
//!
//! A Monte Carlo BRDF/BTDF value is the solid-angle mean of `f` over a cone
//! of half-angle `alpha_d` around the output direction (eq. B1), `alpha_d`
//! the requested half-angle narrowed near the horizon and near a critical
//! angle (eq. B2'). With `--cone DEG` the multi-flux solver gives the same
//! mean, by a product rule over the cap (eq. B5): in cone coordinates
//! (`beta` from the axis, `psi` around it, `dw = sin(beta) dbeta dpsi`),
//! Gauss–Legendre in `beta` on [`PANELS`] graded toward the axis (where a
//! forward peak sits) and the midpoint rule in `psi`, which is exact for
//! trigonometric polynomials of degree below [`AZIMUTHS`]:
//! `f_B = sum_jk w_j sin(beta_j) f(beta_j, psi_k) / sum_jk w_j sin(beta_j)`.

use km_core::solution::Cones;
use km_core::{ChannelResult, MonoScene, Scene, Solution, Uncertainty};

use crate::{KmError, MethodOptions, Solver};

/// Edges of the radial panels, as fractions of the cone's half-angle:
/// geometric toward the axis so that a peak of a tenth of the cone's width
/// there is resolved.
pub const PANELS: [f64; 5] = [0.0, 1.0 / 27.0, 1.0 / 9.0, 1.0 / 3.0, 1.0];
/// Gauss–Legendre nodes per radial panel.
pub const NODES_PER_PANEL: usize = 6;
/// Azimuths around the axis.
pub const AZIMUTHS: usize = 8;

/// The half-angles a cone must lie in, degrees: Monte Carlo's bins (more
/// than 45 degrees would mix the hemisphere's structure into one number).
pub const MAX_CONE_DEG: f64 = 45.0;

/// Check a cone half-angle (the `cone` option), degrees.
///
/// # Errors
/// [`KmError::Option`] named `cone` outside `(0, 45]`.
pub fn check_cone(deg: f64) -> Result<(), KmError> {
    if deg.is_finite() && deg > 0.0 && deg <= MAX_CONE_DEG {
        Ok(())
    } else {
        Err(KmError::Option {
            name: "cone",
            value: deg.to_string(),
            reason: "the cone half-angle must lie in (0, 45] degrees",
        })
    }
}

/// The settings with the cone applied: Monte Carlo's bins set to `deg`;
/// multi-flux unchanged (its values are averaged after the solve by
/// [`solve_mean`]); other methods refuse a cone.
///
/// # Errors
/// [`KmError::Option`] named `cone` for a half-angle outside `(0, 45]` or a
/// method without angular values to average.
pub(crate) fn with_cone(o: MethodOptions, cone_deg: Option<f64>) -> Result<MethodOptions, KmError> {
    let Some(deg) = cone_deg else { return Ok(o) };
    check_cone(deg)?;
    match o {
        MethodOptions::Mc(m) => {
            Ok(MethodOptions::Mc(km_montecarlo::McOptions { bin_half_angle_deg: deg, ..m }))
        }
        o @ MethodOptions::Multiflux(_) => Ok(o),
        _ => Err(KmError::Option {
            name: "cone",
            value: deg.to_string(),
            reason: "applies to --method mc (its bins) and multiflux (its values averaged alike)",
        }),
    }
}

/// The note of a Monte Carlo answer with BRDF/BTDF values: they are cone
/// means, and how to compare them with multi-flux.
pub(crate) fn note_mc(sol: &mut Solution) {
    let Some(c) = sol.channels.iter().find_map(|c| c.cones.as_ref()) else { return };
    let widest = c.brdf.iter().chain(&c.btdf).copied().fold(0.0, f64::max);
    sol.notes.push(format!(
        "Monte Carlo brdf and btdf are solid-angle means over cones of half-angle up to \
         {widest:.2} degrees around each direction (cone_half_angle_deg; narrower near the \
         horizon and critical angles), so a peak narrower than the cone reads low: set the \
         cone with --cone DEG, and compare with --method multiflux --cone {widest:.2}"
    ));
}

/// Unit vector of `[theta, phi]` (degrees) in the frame of its hemisphere.
fn unit(d: [f64; 2]) -> [f64; 3] {
    let (t, p) = (d[0].to_radians(), d[1].to_radians());
    [t.sin() * p.cos(), t.sin() * p.sin(), t.cos()]
}

/// `[theta, phi]` (degrees) of a unit vector.
fn angles(v: [f64; 3]) -> [f64; 2] {
    [v[2].clamp(-1.0, 1.0).acos().to_degrees(), v[1].atan2(v[0]).to_degrees()]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Two unit vectors completing `p` to an orthonormal frame.
fn frame(p: [f64; 3]) -> ([f64; 3], [f64; 3]) {
    let seed = if p[2].abs() < 0.9 { [0.0, 0.0, 1.0] } else { [1.0, 0.0, 0.0] };
    let d = dot(seed, p);
    let e1 = std::array::from_fn(|i| seed[i] - d * p[i]);
    let n = dot(e1, e1).sqrt();
    let e1: [f64; 3] = std::array::from_fn(|i| e1[i] / n);
    let e2 =
        [p[1] * e1[2] - p[2] * e1[1], p[2] * e1[0] - p[0] * e1[2], p[0] * e1[1] - p[1] * e1[0]];
    (e1, e2)
}

/// Gauss–Legendre nodes and weights on `[lo, hi]` mapped through
/// `r = mid + half sin(pi t / 2)`, which crowds them toward both ends
/// (where the cap's arcs open like a square root), weights with the
/// Jacobian.
fn crowded(lo: f64, hi: f64, x: &[f64], w: &[f64]) -> impl Iterator<Item = (f64, f64)> {
    let (mid, half, q) = (0.5 * (lo + hi), 0.5 * (hi - lo), 0.5 * std::f64::consts::PI);
    x.iter().zip(w).map(move |(t, wt)| (mid + half * (q * t).sin(), wt * half * q * (q * t).cos()))
}

/// The directions `[theta, phi]` (degrees) and weights (summing to 1) of
/// the rule of eq. B5 on the cap of half-angle `alpha_deg` around `center`
/// (`[theta, phi]`, degrees; the frame of its hemisphere), in polar
/// coordinates `(r, psi)` about `pole`: the centre itself, or a direction
/// where the BRDF/BTDF may peak (the transmitted beam, the mirror or the
/// retro direction), so that a peak anywhere in or near the cone sits where
/// the radial nodes crowd. With `d` the pole's distance from the centre, the
/// circle of radius `r` about the pole lies in the cap for
/// `r <= alpha - d`, and otherwise meets it in the arc
/// `|psi - psi_a| <= acos((cos alpha - cos r cos d) / (sin r sin d))`
/// (eq. B5a, the spherical law of cosines) about the azimuth `psi_a` of the
/// centre. Radii: Gauss–Legendre on [`PANELS`] graded toward the pole over
/// the full circles, then over the arcs, each panel crowded toward its ends
/// (the arcs open like square roots); azimuths: the midpoint rule on full
/// circles, Gauss–Legendre on arcs.
///
/// ```
/// let rule = km::cone::cone_rule([30.0, 180.0], 5.0, [30.0, 180.0]);
/// let sum: f64 = rule.iter().map(|r| r.1).sum();
/// assert!((sum - 1.0).abs() < 1e-15);
/// let off = km::cone::cone_rule([30.0, 180.0], 5.0, [22.0, 180.0]);
/// assert!(off.iter().all(|(d, _)| (d[0] - 30.0).abs() <= 5.0 + 1e-9));
/// ```
pub fn cone_rule(center: [f64; 2], alpha_deg: f64, pole: [f64; 2]) -> Vec<([f64; 2], f64)> {
    let alpha = alpha_deg.to_radians();
    let (a, p) = (unit(center), unit(pole));
    let d = dot(p, a).clamp(-1.0, 1.0).acos();
    let (e1, e2) = frame(p);
    let toward = dot(a, e2).atan2(dot(a, e1));
    let (x, w) = km_core::quadrature::gauss_legendre(NODES_PER_PANEL);
    let (xa, wa) = km_core::quadrature::gauss_legendre(AZIMUTHS);
    let mut rule = Vec::new();
    let mut ring = |r: f64, wr: f64, full: bool| {
        let arc = if full {
            std::f64::consts::PI
        } else {
            ((alpha.cos() - r.cos() * d.cos()) / (r.sin() * d.sin())).clamp(-1.0, 1.0).acos()
        };
        for k in 0..AZIMUTHS {
            let (psi, wpsi) = if full {
                (
                    2.0 * std::f64::consts::PI * (k as f64 + 0.5) / AZIMUTHS as f64,
                    1.0 / AZIMUTHS as f64,
                )
            } else {
                (toward + arc * xa[k], arc * wa[k] / (2.0 * std::f64::consts::PI))
            };
            let u: [f64; 3] = std::array::from_fn(|i| psi.cos() * e1[i] + psi.sin() * e2[i]);
            let v = std::array::from_fn(|i| r.cos() * p[i] + r.sin() * u[i]);
            rule.push((angles(v), wr * r.sin() * wpsi));
        }
    };
    // Full circles about the pole, then the arcs out to the far edge.
    let (inner, lo, hi) = ((alpha - d).max(0.0), (d - alpha).abs(), d + alpha);
    for (full, start, end) in [(true, 0.0, inner), (false, lo, hi)] {
        if end <= start {
            continue;
        }
        for q in PANELS.windows(2) {
            let (p0, p1) = (start + q[0] * (end - start), start + q[1] * (end - start));
            let nodes: Vec<(f64, f64)> = if full {
                x.iter()
                    .zip(&w)
                    .map(|(t, wt)| (0.5 * (p0 + p1) + 0.5 * (p1 - p0) * t, 0.5 * (p1 - p0) * wt))
                    .collect()
            } else {
                crowded(p0, p1, &x, &w).collect()
            };
            for (r, wr) in nodes {
                ring(r, wr, full);
            }
        }
    }
    let total: f64 = rule.iter().map(|r| r.1).sum();
    rule.iter_mut().for_each(|r| r.1 /= total);
    rule
}

/// The nodes of one output direction's cones: directions, weights, and
/// where the reflection and transmission nodes lie among them.
struct DirectionNodes {
    directions: Vec<[f64; 2]>,
    weights: Vec<f64>,
    reflect: std::ops::Range<usize>,
    transmit: std::ops::Range<usize>,
}

/// One channel's cones: the half-angles (eq. B2') and the nodes of each
/// output direction.
struct ConePlan {
    nodes: Vec<DirectionNodes>,
    cones: Cones,
}

/// Where the BRDF (`reflect`) or BTDF may peak under a collimated beam: the
/// mirror and the retro direction above, the transmitted beam below (when
/// it leaves into a clear medium).
fn peaks(mono: &MonoScene, reflect: bool) -> Vec<[f64; 2]> {
    let (Some(nu), km_core::Light::Collimated { theta_deg }) =
        (mono.beam_invariant(), mono.light())
    else {
        return Vec::new();
    };
    if reflect {
        return vec![[theta_deg, 180.0], [theta_deg, 0.0]];
    }
    let last = &mono.layers()[mono.layers().len() - 1];
    let exit_n = match mono.substrate() {
        _ if last.is_half_space() => last.n(),
        km_core::Substrate::Transparent { n } => n,
        _ => return Vec::new(),
    };
    let sin_t = nu / exit_n;
    if sin_t < 1.0 { vec![[sin_t.asin().to_degrees(), 180.0]] } else { Vec::new() }
}

/// The pole of the rule for the cone around `center`: the nearest of
/// `peaks` (the BRDF/BTDF varies most with the distance from a peak), else
/// the centre.
fn pole(center: [f64; 2], peaks: &[[f64; 2]]) -> [f64; 2] {
    let a = unit(center);
    let distance = |p: &[f64; 2]| dot(a, unit(*p)).clamp(-1.0, 1.0).acos();
    peaks.iter().min_by(|p, q| distance(p).total_cmp(&distance(q))).copied().unwrap_or(center)
}

fn plan(mono: &MonoScene, cone_deg: f64) -> ConePlan {
    let (ar, at) = km_montecarlo::cone_bins(mono, cone_deg);
    let (peaks_r, peaks_t) = (peaks(mono, true), peaks(mono, false));
    // In degrees, the requested half-angle itself where eq. B2' keeps it.
    let deg = |a: &f64| if *a == cone_deg.to_radians() { cone_deg } else { a.to_degrees() };
    let cones = Cones { brdf: ar.iter().map(deg).collect(), btdf: at.iter().map(deg).collect() };
    let nodes = mono
        .directions_deg()
        .iter()
        .enumerate()
        .map(|(i, &d)| {
            let (mut directions, mut weights) = (Vec::new(), Vec::new());
            let mut push = |alpha: f64, peaks: &[[f64; 2]]| {
                let start = directions.len();
                for (dir, w) in cone_rule(d, alpha.to_degrees(), pole(d, peaks)) {
                    directions.push(dir);
                    weights.push(w);
                }
                start..directions.len()
            };
            let reflect = push(ar[i], &peaks_r);
            // The same nodes serve both sides when their cones and poles agree.
            let (pr, pt) = (pole(d, &peaks_r), pole(d, &peaks_t));
            let same = at[i] == ar[i] && dot(unit(pr), unit(pt)) > 1.0 - 1e-15;
            let transmit = if same { reflect.clone() } else { push(at[i], &peaks_t) };
            DirectionNodes { directions, weights, reflect, transmit }
        })
        .collect();
    ConePlan { nodes, cones }
}

/// `sum_j w_j v_j` over `range`.
fn mean(values: &[f64], weights: &[f64], range: &std::ops::Range<usize>) -> f64 {
    range.clone().map(|j| weights[j] * values[j]).sum()
}

/// What a cone-mean solve gathers per channel: values and error bounds per
/// output direction.
#[derive(Default)]
struct Gathered {
    brdf: Vec<f64>,
    btdf: Vec<f64>,
    brdf_err: Vec<f64>,
    btdf_err: Vec<f64>,
}

impl Gathered {
    /// Add direction `nodes`' means from the node-level result `c`.
    fn push(&mut self, c: &ChannelResult, nodes: &DirectionNodes) {
        let w = &nodes.weights;
        self.brdf.push(mean(&c.brdf, w, &nodes.reflect));
        self.btdf.push(mean(&c.btdf, w, &nodes.transmit));
        // An error bound of a mean: the mean of the bounds.
        if let Some(e) = &c.error_estimate {
            self.brdf_err.push(e.brdf.as_ref().map_or(0.0, |v| mean(v, w, &nodes.reflect)));
            self.btdf_err.push(e.btdf.as_ref().map_or(0.0, |v| mean(v, w, &nodes.transmit)));
        }
    }

    /// The channel's result with the means in place of the node values.
    fn into_result(self, c: ChannelResult, cones: Cones) -> ChannelResult {
        let max = |v: &[f64]| v.iter().copied().fold(0.0, f64::max);
        let error_estimate = c.error_estimate.map(|u| Uncertainty {
            brdf_max: Some(max(&self.brdf_err)),
            btdf_max: Some(max(&self.btdf_err)),
            brdf: Some(self.brdf_err),
            btdf: Some(self.btdf_err),
            ..u
        });
        ChannelResult { brdf: self.brdf, btdf: self.btdf, error_estimate, cones: Some(cones), ..c }
    }
}

/// Solve `scene` by the multi-flux `solver` with every BRDF/BTDF value the
/// mean over the cone Monte Carlo would bin it in for bins of `cone_deg`
/// (eq. B1, B2', B5), to `tolerance` when given. One solve per output
/// direction, each with that direction's cone nodes as exit directions
/// ([`PANELS`]` - 1` x [`NODES_PER_PANEL`] x [`AZIMUTHS`] per side): the
/// work budget is that of a solve with one cone's nodes.
///
/// # Errors
/// The solver's.
pub(crate) fn solve_mean(
    solver: &MethodOptions,
    scene: &Scene,
    cone_deg: f64,
    tolerance: Option<f64>,
) -> Result<Solution, KmError> {
    let run = |s: &Scene| match tolerance {
        Some(tol) => solver.solve_unplanned_to(s, tol),
        None => solver.solve_unplanned(s),
    };
    let plans: Vec<ConePlan> = scene.channels().iter().map(|c| plan(c, cone_deg)).collect();
    let count = plans.iter().map(|p| p.nodes.len()).max().unwrap_or(0);
    if count == 0 {
        return run(scene);
    }
    let mut gathered: Vec<Gathered> = plans.iter().map(|_| Gathered::default()).collect();
    let (mut first, mut seconds) = (None, 0.0);
    for i in 0..count {
        // Every channel's cone nodes of output direction i (none past its last).
        let channels = scene.channels().iter().zip(&plans).map(|(c, p)| {
            c.with_directions(p.nodes.get(i).map_or(Vec::new(), |n| n.directions.clone()))
        });
        let sol = run(&scene.with_channels(channels.collect::<Result<Vec<_>, _>>()?)?)?;
        seconds += sol.seconds;
        for ((g, c), p) in gathered.iter_mut().zip(&sol.channels).zip(&plans) {
            if let Some(nodes) = p.nodes.get(i) {
                g.push(c, nodes);
            }
        }
        first.get_or_insert(sol);
    }
    let Some(mut sol) = first else { return run(scene) };
    sol.seconds = seconds;
    let parts = gathered.into_iter().zip(plans).zip(std::mem::take(&mut sol.channels));
    sol.channels = parts.map(|((g, p), c)| g.into_result(c, p.cones)).collect();
    sol.notes.push(format!(
        "brdf and btdf are solid-angle means over cones of half-angle {cone_deg} degrees \
         (narrower near the horizon and critical angles: cone_half_angle_deg), as Monte \
         Carlo bins them, by a {}-direction quadrature of each cone (one solve per direction)",
        (PANELS.len() - 1) * NODES_PER_PANEL * AZIMUTHS
    ));
    Ok(sol)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The cap mean by a fine midpoint rule about the centre (400 x 256
    /// cells): the reference of the rule's accuracy.
    fn fine_mean(center: [f64; 2], alpha_deg: f64, f: &dyn Fn([f64; 2]) -> f64) -> f64 {
        let (nb, np) = (400, 256);
        let alpha = alpha_deg.to_radians();
        let a = unit(center);
        let (e1, e2) = frame(a);
        let (mut sum, mut total) = (0.0, 0.0);
        for i in 0..nb {
            let b = (i as f64 + 0.5) * alpha / nb as f64;
            for j in 0..np {
                let psi = 2.0 * std::f64::consts::PI * (j as f64 + 0.5) / np as f64;
                let v = std::array::from_fn(|k| {
                    b.cos() * a[k] + b.sin() * (psi.cos() * e1[k] + psi.sin() * e2[k])
                });
                sum += b.sin() * f(angles(v));
                total += b.sin();
            }
        }
        sum / total
    }

    /// A forward peak of the width of a g = 0.99 Henyey–Greenstein lobe
    /// (`(1 - g)` rad, 0.57 degree) at the pole, the cone's centre from 0
    /// to 12 degrees away from it (inside, on the edge, outside), and a
    /// smooth function: the rule (384 directions at most) against the fine
    /// midpoint rule, 1e-4 (measured at most 3.3e-5, the reference's own
    /// error included).
    #[test]
    fn the_rule_resolves_a_peak_anywhere_in_or_near_the_cone() {
        let w = 0.01f64;
        let peak = |d: [f64; 2]| 1.0 / (w * w + d[0].to_radians().powi(2)).powf(1.5);
        let smooth = |d: [f64; 2]| 2.0 + d[1].to_radians().cos() + (d[0] / 10.0).powi(2);
        for offset in [0.0, 2.0, 4.0, 4.99, 5.0, 5.01, 6.0, 12.0] {
            let center = [offset, 180.0];
            let rule = cone_rule(center, 5.0, [0.0, 0.0]);
            assert!(rule.len() <= 384);
            for (name, f) in [("peak", &peak as &dyn Fn([f64; 2]) -> f64), ("smooth", &smooth)] {
                let ours: f64 = rule.iter().map(|(d, wt)| wt * f(*d)).sum();
                let fine = fine_mean(center, 5.0, f);
                assert!((ours / fine - 1.0).abs() < 1e-4, "{name} at {offset}: {ours} vs {fine}");
            }
        }
    }

    #[test]
    fn every_node_lies_in_the_cap_and_cones_are_checked() {
        for (center, pole) in [([30.0, 180.0], [30.0, 180.0]), ([40.0, 10.0], [30.0, 180.0])] {
            let a = unit(center);
            for (d, w) in cone_rule(center, 5.0, pole) {
                assert!(w >= 0.0);
                assert!(dot(a, unit(d)) >= 5f64.to_radians().cos() - 1e-12, "{d:?}");
            }
        }
        assert!(check_cone(0.0).is_err() && check_cone(46.0).is_err());
        assert!(check_cone(f64::NAN).is_err() && check_cone(45.0).is_ok());
    }
}
