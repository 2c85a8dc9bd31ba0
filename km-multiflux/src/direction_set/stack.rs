//! Interfaces, substrates and stacks on matched direction sets (seed eq. 14
//! and 21, §3.4), and the responses of a scene: the BRDF for one incidence,
//! the whole BRDF matrix, the totals.

use super::*;

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
/// of `below` (`n_b`), on matched sets (docs eq. DS11). Direction `j` keeps its
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
/// `r_ij = (albedo / pi) mu_j w_j` (docs eq. DS12), no transmission
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
    if scene.has_rough_face() || matches!(scene.substrate(), Substrate::Conductor { .. }) {
        return Err(MultifluxError::Scene(km_core::CoreError::unsupported(
            "multiflux (direction set)",
            "rough faces and conductor substrates are built in the Fourier-Gauss mode only \
             (the default; docs/rough.md)",
        )));
    }
    let mut ops = Vec::new();
    let mut n_prev = scene.ambient_n();
    for layer in scene.layers() {
        if (layer.n() - n_prev).abs() > 1e-12 * n_prev {
            ops.push(interface_operators(sets.set(n_prev)?, sets.set(layer.n())?)?);
        }
        let set = sets.set(layer.n())?;
        if layer.is_half_space() && layer.sigma_t() == 0.0 {
            return Err(MultifluxError::Scene(km_core::CoreError::unsupported(
                "multiflux (direction set)",
                "a clear half-space layer: use a transparent substrate",
            )));
        }
        ops.push(if scatter {
            set.layer_operators(layer)?
        } else {
            absorber_operators(set.mu(), layer.sigma_t(), layer.thickness())
        });
        n_prev = layer.n();
    }
    match scene.substrate() {
        Substrate::Transparent { n } => {
            if (n - n_prev).abs() > 1e-12 * n_prev {
                ops.push(interface_operators(sets.set(n_prev)?, sets.set(n)?)?);
            }
        }
        Substrate::Lambertian { albedo } => {
            let a = if scatter { albedo } else { 0.0 };
            ops.push(lambertian_operators(sets.set(n_prev)?, a)?);
        }
        Substrate::Black | Substrate::Conductor { .. } => {
            ops.push(lambertian_operators(sets.set(n_prev)?, 0.0)?)
        }
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
/// `f_r(j) = I_r,j / mu0` (docs eq. DS13). The delta parts are the response of
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
/// let r = brdf_for_incidence(&scene.channels()[0], 100, Combine::Exact).unwrap();
/// assert!(r.absorptance > 0.0 && r.reflectance > 0.0);
/// ```
pub fn brdf_for_incidence(
    scene: &MonoScene,
    n_target: usize,
    how: Combine,
) -> Result<StackResponse> {
    let Light::Collimated { theta_deg } = scene.light() else {
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
    let mut media = vec![scene.ambient_n()];
    media.extend(scene.layers().iter().map(|l| l.n()));
    if let Some(n) = scene.substrate_n() {
        media.push(n);
    }
    let inc = theta_deg.map(|t| Incidence { n: scene.ambient_n(), theta_deg: t });
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
    let top = sets.set(scene.ambient_n())?;
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
    let sets = scene_sets(scene, n_target, None)?;
    let total = fold(&stack_operators(scene, &sets, true)?, Combine::Exact)?;
    let top = sets.set(scene.ambient_n())?.clone();
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
    match scene.light() {
        Light::Collimated { .. } => {
            let r = brdf_for_incidence(scene, n_target, Combine::Exact)?;
            Ok((r.reflectance, r.transmittance))
        }
        Light::Diffuse => {
            let sets = scene_sets(scene, n_target, None)?;
            let total = fold(&stack_operators(scene, &sets, true)?, Combine::Exact)?;
            let top = sets.set(scene.ambient_n())?;
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
