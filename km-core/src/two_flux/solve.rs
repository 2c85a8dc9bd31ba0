//! The scene-level two-flux solver.

use std::f64::consts::PI;
use std::time::Instant;

use crate::error::CoreError;
use crate::scene::{MonoScene, Scene, Substrate};
use crate::solution::{ChannelResult, Solution};

use super::stack::{HemisphericalCache, Slab, stack_adding};
use super::{KmMapping, KmModel};

/// Options of the two-flux solver.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct KmOptions {
    /// How `(sigma_a, sigma_s, g)` become `(K, S)`.
    pub mapping: KmMapping,
    /// Four-flux (the default: a collimated beam is carried as a beam) or
    /// the seed's two-flux model.
    pub model: KmModel,
}

impl KmOptions {
    /// The seed paper's model: two diffuse fluxes with `K = sigma_a`,
    /// `S = sigma_s` (seed §2). The paper's figures are computed with it.
    pub const SEED: KmOptions = KmOptions { mapping: KmMapping::Seed, model: KmModel::TwoFlux };
}

/// `(K, S)` of layer `index` (0-based) under `mapping`, a refusal naming the layer.
pub(super) fn layer_coefficients(
    mapping: KmMapping,
    layer: &crate::layer::Layer,
    index: usize,
) -> Result<(f64, f64), CoreError> {
    mapping.coefficients(layer).map_err(|e| match e {
        CoreError::Unsupported { method, reason } => {
            CoreError::Unsupported { method, reason: format!("layer[{}]: {reason}", index + 1) }
        }
        other => other,
    })
}

/// The stack of one channel as slabs, with bookkeeping for the answer.
pub(super) struct Built {
    pub(super) slabs: Vec<Slab>,
    /// Index of the slab of each layer.
    pub(super) layer_slab: Vec<usize>,
    /// Specular (mirror) reflectance of the top surface.
    r_specular: f64,
    /// Zero-order (never scattered, never reflected) transmittance.
    t_direct: f64,
    /// True when light can leave through the bottom.
    open_bottom: bool,
}

pub(super) fn build(
    mono: &MonoScene,
    mapping: KmMapping,
    cache: &mut HemisphericalCache,
) -> Result<Built, CoreError> {
    let mut slabs = Vec::with_capacity(2 * mono.layers().len() + 2);
    let mut layer_slab = Vec::with_capacity(mono.layers().len());
    let first_n = mono.layers()[0].n();
    let mut r_specular = 0.0;
    let mut t_direct = if mono.light().mu0().is_some() { 1.0 } else { 0.0 };
    // Saunderson's top interface (eq. K12).
    if first_n != mono.ambient_n() {
        if let Some(mf) = mono.layers()[0].roughness() {
            // A rough top face: no mirror part, no unscattered beam (eq. R9).
            let light = Some(mono.light()).filter(|l| l.mu0().is_some());
            slabs.push(super::rough::rough_face(&mf, light, mono.ambient_n(), first_n));
            t_direct = 0.0;
        } else {
            let top = cache.saunderson_top(mono.light(), mono.ambient_n(), first_n)?;
            r_specular = top.r_top;
            t_direct *= top.t_tb;
            slabs.push(top);
        }
    }
    let mut n_above = first_n;
    let mut open_bottom = true;
    for (i, layer) in mono.layers().iter().enumerate() {
        // Interfaces between layers of different index: diffuse flux both sides.
        if layer.n() != n_above && i > 0 {
            if let Some(mf) = layer.roughness() {
                slabs.push(super::rough::rough_face(&mf, None, n_above, layer.n()));
                t_direct = 0.0;
            } else {
                let iface = cache.interface(n_above, layer.n())?;
                t_direct *= iface.t_tb;
                slabs.push(iface);
            }
        }
        let (k, s) = layer_coefficients(mapping, layer, i)?;
        let slab = Slab::layer(k, s, layer.thickness())?;
        t_direct *= if layer.is_half_space() {
            if k + s == 0.0 { 1.0 } else { 0.0 }
        } else {
            (-(k + s) * layer.thickness()).exp()
        };
        layer_slab.push(slabs.len());
        slabs.push(slab);
        n_above = layer.n();
        if layer.is_half_space() {
            // Nothing below a half-space matters.
            open_bottom = k + s == 0.0;
            return Ok(Built { slabs, layer_slab, r_specular, t_direct, open_bottom });
        }
    }
    match mono.substrate() {
        Substrate::Transparent { n } => {
            if n != n_above {
                if let Some(mf) = mono.substrate_roughness() {
                    slabs.push(super::rough::rough_face(&mf, None, n_above, n));
                    t_direct = 0.0;
                } else {
                    let iface = cache.interface(n_above, n)?;
                    t_direct *= iface.t_tb;
                    slabs.push(iface);
                }
            }
        }
        Substrate::Conductor { n, k } => {
            let mf = mono.substrate_roughness();
            slabs.push(super::rough::conductor_ground(mf.as_ref(), n_above, n, k)?);
            open_bottom = false;
        }
        Substrate::Lambertian { albedo } => {
            slabs.push(Slab::ground(albedo)?);
            open_bottom = false;
        }
        Substrate::Black => {
            slabs.push(Slab::ground(0.0)?);
            open_bottom = false;
        }
    }
    if !open_bottom {
        t_direct = 0.0;
    }
    Ok(Built { slabs, layer_slab, r_specular, t_direct, open_bottom })
}

/// Solve one channel by the adding form (seed eq. 14).
///
/// # Errors
/// A mapping that cannot treat a layer.
pub fn solve_mono(mono: &MonoScene, opts: &KmOptions) -> Result<ChannelResult, CoreError> {
    solve_channel(mono, opts, &mut HemisphericalCache::default())
}

/// The four-flux model carries a collimated beam through smooth faces onto
/// a transparent, Lambertian or black floor; a rough face (which spreads the
/// beam) or a conductor floor takes the two-flux model with the faces'
/// albedos (docs/rough.md §5), noted in the answer.
pub(super) fn four_flux_applies(mono: &MonoScene) -> bool {
    !mono.has_rough_face() && !matches!(mono.substrate(), Substrate::Conductor { .. })
}

fn solve_channel(
    mono: &MonoScene,
    opts: &KmOptions,
    cache: &mut HemisphericalCache,
) -> Result<ChannelResult, CoreError> {
    if opts.model == KmModel::FourFlux && mono.light().mu0().is_some() && four_flux_applies(mono) {
        return super::four_flux::solve_channel(mono, opts.mapping, cache);
    }
    let b = build(mono, opts.mapping, cache)?;
    let f = stack_adding(&b.slabs);
    let t = if b.open_bottom { f.t } else { 0.0 };
    // Everything not reflected or transmitted is absorbed, in a layer or in the ground.
    let absorptance: f64 = f.absorbed.iter().sum();
    let layers: Vec<f64> = b.layer_slab.iter().map(|&i| f.absorbed[i]).collect();
    let (brdf, btdf) = if mono.directions_deg().is_empty() {
        (Vec::new(), Vec::new())
    } else {
        // KM has no angles: Lambertian-equivalent values of the diffuse parts.
        let rd = (f.r - b.r_specular).max(0.0) / PI;
        let td = (t - b.t_direct).max(0.0) / PI;
        (vec![rd; mono.directions_deg().len()], vec![td; mono.directions_deg().len()])
    };
    Ok(ChannelResult {
        reflectance: f.r,
        reflectance_specular: b.r_specular,
        transmittance: t,
        transmittance_direct: b.t_direct,
        absorptance,
        brdf,
        btdf,
        absorptance_layers: Some(layers),
        ..ChannelResult::default()
    })
}

/// Solve a scene by two-flux Kubelka–Munk, one [`ChannelResult`] per channel.
///
/// Conventions (see `docs/two-flux.md` §7):
/// * the two fluxes are diffuse; a collimated beam's angle enters only through
///   the Fresnel reflectance of the top interface (Saunderson);
/// * `reflectance_specular` is that interface's mirror reflection;
/// * `transmittance_direct` is the zero-order term of the two-flux series
///   (never scattered, never reflected: `prod exp(-(K+S) z0)` times the
///   interface transmittances) for collimated light, 0 for diffuse light; it
///   is not the Beer–Lambert beam at oblique incidence;
/// * `brdf`/`btdf` (when the scene asks for directions) are the
///   Lambertian-equivalent `(R - R_specular)/pi` and `(T - T_direct)/pi`;
/// * `absorptance_layers` are the fractions absorbed in each layer (interfaces
///   absorb nothing; the ground's absorption is in `absorptance` only);
/// * `seconds` is the solver's own wall time.
///
/// # Errors
/// An invalid channel, or a mapping that cannot treat a layer.
///
/// ```
/// use km_core::two_flux::{solve, KmOptions};
/// let scene = km_core::Scene::from_toml_str("[[layer]]\nsigma_a = 0.1\nsigma_s = 0.4\nthickness = 1.0\n").unwrap();
/// let sol = solve(&scene, &KmOptions::SEED).unwrap();
/// let rt = km_core::two_flux::layer_rt(0.1, 0.4, 1.0).unwrap();
/// assert!((sol.channels[0].reflectance - rt.r).abs() < 1e-15);
/// ```
pub fn solve(scene: &Scene, opts: &KmOptions) -> Result<Solution, CoreError> {
    let start = Instant::now();
    let channels = {
        let mut cache = HemisphericalCache::default();
        scene
            .channels()
            .iter()
            .map(|m| solve_channel(m, opts, &mut cache))
            .collect::<Result<Vec<_>, _>>()?
    };
    let seconds = start.elapsed().as_secs_f64();
    // The collimated-beam notes only where a beam falls on the stack.
    let collimated = scene.channels().iter().any(|m| m.light().mu0().is_some());
    let mut notes = Vec::new();
    let four = scene.channels().iter().all(four_flux_applies);
    if collimated && opts.model == KmModel::FourFlux && !four {
        notes.push(
            "four-flux does not treat rough faces or conductor floors: this scene is solved by \
             the two-flux model with the faces' albedos (docs/rough.md)"
                .to_string(),
        );
    }
    if collimated && opts.model == KmModel::FourFlux && four {
        notes.push(
            "four-flux: the collimated beam crosses each interface with the Fresnel reflectance \
             at its own angle and decays along its refracted path; what it scatters feeds the \
             diffuse Kubelka-Munk pair (Saunderson interfaces); reflectance_specular and \
             transmittance_direct are the beam's mirror reflections and the beam leaving the \
             bottom"
                .to_string(),
        );
    } else if collimated {
        notes.push(
            "two-flux fluxes are diffuse: a collimated beam's angle enters only through the \
             Fresnel reflectance of the top interface (Saunderson)"
                .to_string(),
        );
        notes.push(
            "transmittance_direct is the zero-order (never scattered) term of the two-flux \
             series, not the Beer-Lambert beam at oblique incidence"
                .to_string(),
        );
    }
    if scene.channels().iter().any(|m| !m.directions_deg().is_empty()) {
        notes.push(
            "KM has no angles: brdf and btdf are the Lambertian-equivalent values \
             (R - R_specular)/pi and (T - T_direct)/pi, the same in every direction"
                .to_string(),
        );
    }
    if opts.mapping == KmMapping::Seed
        && scene.channels().iter().flat_map(|m| m.layers()).any(|l| l.g() != 0.0)
    {
        notes.push("mapping seed ignores g (K = sigma_a, S = sigma_s)".to_string());
    }
    Ok(Solution {
        method: "km".into(),
        channels,
        labels: scene.labels().to_vec(),
        seconds,
        notes,
        diagnostics: crate::solution::Diagnostics {
            method: crate::solution::MethodDiagnostics::TwoFlux {
                mapping: opts.mapping,
                model: opts.model,
            },
            ..Default::default()
        },
        ..Default::default()
    })
}
