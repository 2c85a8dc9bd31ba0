//! The scene entry point: a stack of layers, interfaces and a substrate,
//! solved per Fourier order by adding (Fourier–Gauss mode).
//!
//! Per spectral channel:
//! 1. one [`AngularGrid`] for all media (quadratures that map under Snell);
//! 2. extra directions: the collimated beam and the probes at the requested
//!    exit directions (BRDF above, BTDF below), each by its Snell invariant;
//! 3. delta-M scaling of every layer (Wiscombe 1977) with `2N` moments kept;
//! 4. for each Fourier order `m = 0..M` (`M = 0` for totals; up to the last
//!    non-negligible scaled moment, at most `2N - 1`, for a BRDF): the
//!    operators of every interface and layer, added top to bottom (exact,
//!    or truncated Neumann series of order `k`), then the substrate;
//! 5. totals from `m = 0`; BRDF/BTDF `= sum_m I^m cos m(phi - 180 deg)`;
//! 6. the delta parts (mirror reflection, unscattered beam) from a separate
//!    one-direction pass with the unscaled optical thicknesses.

use std::time::Instant;

use faer::Mat;
use km_core::phase::PhaseFunction;
use km_core::{ChannelResult, MonoScene, Scene, Solution, Substrate};

use crate::MultifluxError;
use crate::adding::LayerOperators;
use crate::exits::{Azimuths, ChannelExtras, add_order};
pub use crate::field::{InternalField, internal_field};
use crate::interface::lambertian_reflection;
use crate::legendre::delta_m;
pub use crate::options::{
    DEFAULT_STREAMS, DEFAULT_STREAMS_ANGULAR, DEFAULT_STREAMS_HARD, DEFAULT_STREAMS_PEAKED,
    FOURIER_TOL, MultifluxOptions, default_bsdf_streams, default_streams,
};
use crate::quadrature::{AngularGrid, MediumNodes};
use crate::slab::{
    Extra, SlabOrder, SlabSolution, Tms, slab_beam_reflection, slab_beam_response, slab_operators,
};
pub(crate) use crate::stack::Scaled;
use crate::stack::{StackPieces, add_stack, delta_parts};

/// Solve every channel of a scene (Fourier–Gauss mode).
///
/// Fills `reflectance`, `reflectance_specular`, `transmittance`,
/// `transmittance_direct`, `absorptance`, and `brdf`/`btdf` at the scene's
/// `directions_deg` (collimated light: per unit irradiance on the surface;
/// azimuth 180 is the mirror side; BTDF only with a transparent substrate).
/// `seconds` is the solver's own wall time; `extra` has `streams` and
/// `fourier_orders`; `notes` names the work cut. Changes no global state.
///
/// # Errors
/// Invalid options or scene ([`MultifluxError::Option`], [`MultifluxError::Scene`]),
/// numerical failures ([`MultifluxError::Numerical`]).
///
/// ```
/// use km_multiflux::{solve, MultifluxOptions};
/// let scene = km_core::Scene::from_toml_str("[[layer]]\ntau = 1.0\nalbedo = 0.9\n").unwrap();
/// let s = solve(&scene, &MultifluxOptions::default()).unwrap();
/// let c = &s.channels[0];
/// assert!((c.reflectance + c.transmittance + c.absorptance - 1.0).abs() < 1e-12);
/// ```
pub fn solve(scene: &Scene, opts: &MultifluxOptions) -> Result<Solution, MultifluxError> {
    crate::budget::check(scene, opts)?;
    // The matrices are small (tens of rows): faer runs sequentially, one core
    // per solve (parallelise over channels or scenes outside, as `km::solve`
    // does with [`solve_channel`] and [`assemble`]). The workspace builds faer
    // without its rayon feature, so its global default is already sequential:
    // the solve changes no global state.
    let start = Instant::now();
    let parts =
        scene.channels().iter().map(|ch| solve_channel(ch, opts)).collect::<Result<Vec<_>, _>>()?;
    Ok(assemble(scene, opts, parts, start.elapsed().as_secs_f64()))
}

/// One channel solved by [`solve_channel`]: its result and what
/// [`assemble`] needs to describe the whole solve (streams, Fourier orders,
/// conservation fix-up, thick-layer cut).
#[derive(Debug, Clone)]
pub struct ChannelPart {
    result: ChannelResult,
    streams: usize,
    orders: usize,
    residual: f64,
    cutoff: Option<f64>,
}

/// Solve one channel of a scene as [`solve`] does (no budget check: call
/// [`crate::budget::check`] on the whole scene first). Channels are
/// independent, so they may be solved in any order or at the same time;
/// [`assemble`] of the parts in channel order is bit-identical to [`solve`].
///
/// # Errors
/// As [`solve`].
///
/// ```
/// use km_multiflux::{MultifluxOptions, assemble, solve, solve_channel};
/// let scene = km_core::Scene::from_toml_str("[[layer]]\ntau = 1.0\nalbedo = 0.9\n").unwrap();
/// let o = MultifluxOptions::default();
/// let parts: Vec<_> = scene.channels().iter().map(|c| solve_channel(c, &o).unwrap()).collect();
/// let a = assemble(&scene, &o, parts, 0.0);
/// assert_eq!(a.channels, solve(&scene, &o).unwrap().channels);
/// ```
pub fn solve_channel(
    ch: &MonoScene,
    opts: &MultifluxOptions,
) -> Result<ChannelPart, MultifluxError> {
    let streams = opts.streams.unwrap_or_else(|| default_streams(ch));
    let (r, cut) = (std::cell::Cell::new(0.0), std::cell::Cell::new(None));
    let (result, orders) = solve_mono_residual(ch, opts, &r, &cut)?;
    Ok(ChannelPart { result, streams, orders, residual: r.get(), cutoff: cut.get() })
}

/// The [`Solution`] of `scene` from its channels' parts (in channel order)
/// and the wall time `seconds` they took: the largest stream count, Fourier
/// order, conservation fix-up (eq. 18a of `docs/multiflux.md`) and
/// thick-layer bound (eq. PL1 of `docs/planner.md`) over the channels.
pub fn assemble(
    scene: &Scene,
    opts: &MultifluxOptions,
    parts: Vec<ChannelPart>,
    seconds: f64,
) -> Solution {
    let mut channels = Vec::with_capacity(parts.len());
    let mut orders = 0;
    let mut streams = 0;
    let mut cutoff: Option<f64> = None;
    let mut residual = 0.0f64;
    for p in parts {
        streams = streams.max(p.streams);
        residual = residual.max(p.residual);
        orders = orders.max(p.orders);
        channels.push(p.result);
        if let Some(b) = p.cutoff {
            cutoff = Some(cutoff.map_or(b, |c: f64| c.max(b)));
        }
    }
    let mut notes = Vec::new();
    if let Some(b) = cutoff {
        notes.push(format!(
            "transmission rule: a thick layer was solved as a half-space; the light \
             neglected below it is < {b:.1e} of the incident (docs/planner.md eq. PL1)"
        ));
    }
    let diagnostics = km_core::solution::MultifluxDiagnostics {
        streams,
        fourier_orders: orders,
        all_effects: opts.all_effects,
        neumann_order: opts.neumann_order,
        cutoff_bound: cutoff,
        // Size of the conservation fix-up (docs/multiflux.md eq. 18a).
        conservation_residual: (residual > 0.0).then_some(residual),
    };
    Solution {
        method: "multiflux".into(),
        channels,
        labels: scene.labels().to_vec(),
        seconds,
        notes,
        diagnostics: km_core::solution::Diagnostics {
            method: km_core::solution::MethodDiagnostics::Multiflux(diagnostics),
            ..Default::default()
        },
        ..Default::default()
    }
}

/// Solve one channel; returns the result and the number of Fourier orders used.
///
/// # Errors
/// See [`solve`].
pub fn solve_mono(
    scene: &MonoScene,
    opts: &MultifluxOptions,
) -> Result<(ChannelResult, usize), MultifluxError> {
    solve_mono_residual(scene, opts, &std::cell::Cell::new(0.0), &std::cell::Cell::new(None))
}

/// [`solve_mono`], also reporting in `out_residual` the size of the
/// conservation fix-up of eq. 18a (0 when none was needed) and in
/// `out_cutoff` the bound of the planner's thick-layer cut (eq. PL1 of
/// `docs/planner.md`; `None` when no layer was cut), so that the plan is
/// made once per channel.
fn solve_mono_residual(
    scene: &MonoScene,
    opts: &MultifluxOptions,
    out_residual: &std::cell::Cell<f64>,
    out_cutoff: &std::cell::Cell<Option<f64>>,
) -> Result<(ChannelResult, usize), MultifluxError> {
    let streams = resolve_streams(scene, opts)?;
    // The plan's `transmission` rule: a layer through which nothing measurable
    // returns is a half-space; nothing below it is built.
    let (cut, bound) = planned_cutoff(scene, opts);
    out_cutoff.set(bound);
    let scene = cut.as_ref().unwrap_or(scene);
    let all = opts.all_effects;

    // Media, top to bottom: ambient, layers, substrate (if transparent).
    let n0 = scene.ambient_n();
    let (n_sub, grid) = media_grid(scene, streams);
    // Legendre moments kept (delta-M truncation at chi_{2N}, Wiscombe 1977).
    let n_keep = 2 * streams;
    let ex = ChannelExtras::new(scene, n_sub, opts.delta_m);
    let beam = ex.beam;
    let tms_on = opts.delta_m && beam.is_some();
    let extras_in = |n: f64| ex.in_medium(n);

    // Delta-M scaling of each layer.
    let layers = scale_layers(scene, opts, n_keep);
    let dirs = scene.directions_deg();
    let mut m_max = last_order(&layers, opts, !dirs.is_empty() && beam.is_some(), streams);
    if scene.has_rough_face() && !dirs.is_empty() && beam.is_some() && !opts.all_effects {
        // A rough face's lobe needs every order the streams resolve (the
        // azimuthal convergence test ends the series early).
        m_max = (2 * streams - 1).min(opts.max_fourier_order.unwrap_or(usize::MAX));
    }

    let nodes0 = grid.medium(n0);
    let e0 = extras_in(n0);
    let nodes_sub = n_sub.map(|n| grid.medium(n));
    let na0 = nodes0.mu.len();
    let mut out = ChannelResult {
        brdf: vec![0.0; dirs.len()],
        // Opaque substrates and half-spaces transmit nothing: their BTDF is 0.
        btdf: vec![0.0; dirs.len()],
        ..Default::default()
    };
    let (mut r_tot, mut t_tot) = (0.0, 0.0);

    let mut stop = FourierStop::default();
    let mut m_used = 0;
    let lone = lone_layer(scene, &layers, beam, n_sub, all);
    // cos m(phi - 180 deg) once per distinct azimuth and order.
    let azimuths = Azimuths::new(dirs);
    let mut cos_m = vec![0.0; azimuths.values.len()];
    for m in 0..=m_max {
        m_used = m;
        azimuths.cos_order(m, &mut cos_m);
        let (up, down) = if let Some((b, l)) = lone {
            let p = SlabOrder { tau: l.tau, omega: l.omega, chi: &l.chi, m };
            let t = (tms_on && !dirs.is_empty() && m == 0).then(|| l.correction(n_keep));
            let t = t.as_ref();
            if nodes_sub.is_some() {
                slab_beam_response(&nodes0.mu, &nodes0.w, &e0, b, &p, t)?
            } else {
                // Nothing below receives the transmitted light: reflection only.
                (slab_beam_reflection(&nodes0.mu, &nodes0.w, &e0, b, &p, t)?, Vec::new())
            }
        } else {
            let ops = stack_operators(
                scene,
                &grid,
                &layers,
                n_sub,
                &extras_in,
                (m, m_max + 1),
                opts.neumann_order,
                tms_on && !dirs.is_empty(),
                all,
            )?;
            let a = top_input(na0, &e0, beam, m);
            let down = if nodes_sub.is_some() { apply(&ops.t_down, &a) } else { Vec::new() };
            (apply(&ops.r_top, &a), down)
        };
        if m == 0 {
            r_tot = flux(&nodes0, &up[..na0]) + beam.map_or(0.0, |b| up[na0 + b]);
        }
        let (of, c) = (&azimuths.of, &cos_m);
        let mut term = add_order(&mut out.brdf, &up[na0..], &ex.brdf_ix, of, c);
        if let Some(ns) = &nodes_sub {
            let nb = ns.mu.len();
            if m == 0 {
                t_tot = flux(ns, &down[..nb]) + beam.map_or(0.0, |b| down[nb + b]);
            }
            term = term.max(add_order(&mut out.btdf, &down[nb..], &ex.btdf_ix, of, c));
        }
        // The order's exit radiances go back to the workspace (reused by the next order).
        crate::workspace::with_workspace(|ws| [up, down].into_iter().for_each(|v| ws.give(v)));
        if m > 0 && !all && stop.converged(term, &out) {
            break;
        }
    }
    finish(scene, &layers, n_sub, &ex, &nodes0, (r_tot, t_tot), &mut out, out_residual)?;
    Ok((out, m_used + 1))
}

/// Azimuthal convergence (as DISORT's ACCUR test): stop after two
/// consecutive orders whose Fourier amplitudes `|I^m|` are all below
/// [`FOURIER_TOL`] times the largest BRDF/BTDF value so far.
#[derive(Default)]
struct FourierStop {
    small_orders: usize,
}

impl FourierStop {
    /// After an order whose largest amplitude is `term`: whether the series has converged.
    fn converged(&mut self, term: f64, out: &ChannelResult) -> bool {
        let largest = out.brdf.iter().chain(&out.btdf).fold(0.0f64, |a, &b| a.max(b.abs()));
        self.small_orders = if term <= FOURIER_TOL * largest { self.small_orders + 1 } else { 0 };
        self.small_orders == 2
    }
}

/// The last Fourier order: 0 for totals; with exit directions under a beam
/// (`angles`), up to the last non-negligible moment; every order the streams
/// resolve (`2N - 1`) with all effects; never above the options' bound.
fn last_order(layers: &[Scaled], opts: &MultifluxOptions, angles: bool, streams: usize) -> usize {
    let bound = opts.max_fourier_order.unwrap_or(usize::MAX);
    if opts.all_effects {
        return (2 * streams - 1).min(bound);
    }
    if !angles {
        return 0;
    }
    last_moment(layers).min(bound)
}

/// The last non-negligible (`> 1e-12`) scaled moment over the scattering
/// layers: the last Fourier order a BRDF needs.
pub(crate) fn last_moment(layers: &[Scaled]) -> usize {
    let mut m = 0;
    for l in layers {
        if l.omega > 0.0
            && let Some(last) = l.chi.iter().rposition(|c| c.abs() > 1e-12)
        {
            m = m.max(last);
        }
    }
    m
}

/// A layer alone in the ambient medium under a beam (no interface, nothing
/// below it): the answer is one column of its operators, computed without
/// the node-to-node operators (`slab_beam_response`). Never with all effects.
fn lone_layer<'a>(
    scene: &MonoScene,
    layers: &'a [Scaled],
    beam: Option<usize>,
    n_sub: Option<f64>,
    all: bool,
) -> Option<(usize, &'a Scaled)> {
    match (beam, layers) {
        (Some(b), [l]) if !all && l.n == scene.ambient_n() => {
            let floor_free = l.tau.is_infinite()
                || match scene.substrate() {
                    Substrate::Black => true,
                    Substrate::Transparent { .. } => n_sub.is_none_or(|ns| ns == scene.ambient_n()),
                    Substrate::Lambertian { .. } | Substrate::Conductor { .. } => false,
                };
            floor_free.then_some((b, l))
        }
        _ => None,
    }
}

/// The input at the top for order `m`: the beam's unit irradiance, or for
/// diffuse light (order 0 only) uniform radiance 1/pi (unit irradiance) in
/// every down-going direction: the nodes and the probes (whose direct
/// transmission and mirror reflection are smooth in angle for diffuse light,
/// so they belong to the BRDF/BTDF).
fn top_input(na0: usize, e0: &[Extra], beam: Option<usize>, m: usize) -> Vec<f64> {
    let mut a = vec![0.0; na0 + e0.len()];
    match beam {
        Some(b) => a[na0 + b] = 1.0,
        None if m == 0 => {
            for (i, x) in a.iter_mut().enumerate() {
                if i < na0 || e0[i - na0].mu.is_some() {
                    *x = 1.0 / std::f64::consts::PI;
                }
            }
        }
        None => {}
    }
    a
}

/// The channel's totals: the delta parts with the true (unscaled) optical
/// thicknesses, exact conservation (eq. 18a), and a refusal of non-finite
/// results; `(r_tot, t_tot)` are the diffuse-and-all totals from order 0.
#[allow(clippy::too_many_arguments)]
fn finish(
    scene: &MonoScene,
    layers: &[Scaled],
    n_sub: Option<f64>,
    ex: &ChannelExtras,
    nodes0: &MediumNodes,
    (r_tot, t_tot): (f64, f64),
    out: &mut ChannelResult,
    out_residual: &std::cell::Cell<f64>,
) -> Result<(), MultifluxError> {
    let n0 = scene.ambient_n();
    let (spec, direct) = match ex.beam {
        Some(b) => delta_parts(scene, layers, n_sub, ex.ex_s[b].0),
        None => {
            let (mut s, mut d) = (0.0, 0.0);
            for i in 0..nodes0.mu.len() {
                let sx = n0 * (1.0 - nodes0.mu[i] * nodes0.mu[i]).max(0.0).sqrt();
                let (si, di) = delta_parts(scene, layers, n_sub, sx);
                let f = 2.0 * nodes0.w[i] * nodes0.mu[i];
                s += f * si;
                d += f * di;
            }
            (s, d)
        }
    };
    // Exact conservation (eq. 18a): nothing absorbs when every layer scatters
    // conservatively and the floor does not absorb.
    // A rough face loses its single-scattering deficit (docs/rough.md).
    let lossless = !scene.has_rough_face()
        && layers.iter().all(|l| l.tau_true == 0.0 || l.omega_true == 1.0)
        && (layers.last().is_some_and(|l| l.tau.is_infinite())
            || match scene.substrate() {
                Substrate::Transparent { .. } => true,
                Substrate::Lambertian { albedo } => albedo == 1.0,
                Substrate::Black | Substrate::Conductor { .. } => false,
            });
    let (r_tot, t_tot, a_tot, residual) = conserve(r_tot, t_tot, lossless);
    out.reflectance = r_tot;
    out.reflectance_specular = spec;
    out.transmittance = t_tot;
    out.transmittance_direct = direct;
    out.absorptance = a_tot;
    out_residual.set(residual);
    let finite = [r_tot, t_tot, spec, direct].iter().all(|x| x.is_finite())
        && out.brdf.iter().chain(&out.btdf).all(|x| x.is_finite());
    if !finite {
        return Err(MultifluxError::Numerical {
            what: "solve",
            detail: "non-finite result".into(),
        });
    }
    Ok(())
}

/// Totals that obey the bounds exactly (eq. 18a of `docs/multiflux.md`):
/// returns `(R, T, A, residual)`. In a lossless stack (`lossless`: every layer
/// conservative, a floor that does not absorb) `A = 0` and `R = 1 - T` by
/// construction; otherwise `R` and `T` are clamped to `[0, 1]` and, should
/// rounding make `R + T > 1`, both are divided by `R + T` and `A = 0`.
/// `residual` is `|R + T + A - 1|` of the computed values before the fix-up
/// when one was made (the adding's rounding: ~1e-12..1e-10), else 0.
fn conserve(r: f64, t: f64, lossless: bool) -> (f64, f64, f64, f64) {
    if lossless {
        let t = t.clamp(0.0, 1.0);
        let residual = (r + t - 1.0).abs();
        return (1.0 - t, t, 0.0, residual);
    }
    let (rc, tc) = (r.clamp(0.0, 1.0), t.clamp(0.0, 1.0));
    let sum = rc + tc;
    if sum > 1.0 {
        return (rc / sum, tc / sum, 0.0, (r + t - 1.0).abs());
    }
    let residual = if rc != r || tc != t { (rc - r).abs().max((tc - t).abs()) } else { 0.0 };
    (rc, tc, 1.0 - rc - tc, residual)
}

/// Delta-M scaling (eq. 4) of every layer, keeping `n_keep` moments.
pub(crate) fn scale_layers(
    scene: &MonoScene,
    opts: &MultifluxOptions,
    n_keep: usize,
) -> Vec<Scaled> {
    scene
        .layers()
        .iter()
        .map(|l| {
            let chi: Vec<f64> = (0..=n_keep).map(|i| l.phase().legendre_moment(i)).collect();
            let omega = l.albedo();
            let (chi_s, omega_s, factor) = if opts.delta_m {
                delta_m(&chi, omega, n_keep)
            } else {
                (chi[..n_keep].to_vec(), omega, 1.0)
            };
            let tau = l.tau();
            Scaled {
                tau: tau * factor,
                tau_true: tau,
                omega: omega_s,
                chi: chi_s,
                n: l.n(),
                omega_true: omega,
                phase: l.phase(),
                factor,
                secondary: opts.secondary_correction,
                rough: l.roughness(),
            }
        })
        .collect()
}

/// `2 pi sum_i w_i mu_i I_i`: the flux of a radiance vector at the nodes.
pub(crate) fn flux(nodes: &MediumNodes, i: &[f64]) -> f64 {
    2.0 * std::f64::consts::PI
        * nodes.mu.iter().zip(&nodes.w).zip(i).map(|((u, w), x)| u * w * x).sum::<f64>()
}

fn apply(m: &Mat<f64>, a: &[f64]) -> Vec<f64> {
    (0..m.nrows()).map(|i| (0..m.ncols()).map(|j| m[(i, j)] * a[j]).sum()).collect()
}

/// The operators of the whole stack for Fourier order `m`, substrate included.
#[allow(clippy::too_many_arguments)]
pub(crate) fn stack_operators(
    scene: &MonoScene,
    grid: &AngularGrid,
    layers: &[Scaled],
    n_sub: Option<f64>,
    extras_in: &dyn Fn(f64) -> Vec<Extra>,
    (m, orders): (usize, usize),
    neumann: Option<usize>,
    tms: bool,
    all_effects: bool,
) -> Result<LayerOperators, MultifluxError> {
    let faces = crate::rough::Faces { grid, extras_in, m, orders };
    let interface = |na: f64, nb: f64, rough| faces.interface(na, nb, rough);
    let conductor = |na: f64, n: f64, k: f64, rough| faces.conductor(na, n, k, rough);
    let layer = |_: usize, l: &Scaled| {
        let nodes = grid.medium(l.n);
        let ex = extras_in(l.n);
        let p = SlabOrder { tau: l.tau, omega: l.omega, chi: &l.chi, m };
        let t = (tms && m == 0).then(|| l.correction(2 * grid.streams));
        let t = t.as_ref();
        // The plan's `scattering` rule lives in `slab_operators` (a layer that
        // does not scatter is Beer–Lambert attenuation); with all effects every
        // layer of finite positive thickness is eigen-solved.
        if all_effects && l.tau > 0.0 {
            eigen_operators(&nodes.mu, &nodes.w, &ex, &p, t)
        } else {
            slab_operators(&nodes.mu, &nodes.w, &ex, &p, t)
        }
    };
    let lambertian =
        |n: f64, albedo: f64| lambertian_reflection(&grid.medium(n), &extras_in(n), albedo, m);
    let pieces = StackPieces {
        interface: &interface,
        layer: &layer,
        lambertian: &lambertian,
        conductor: &conductor,
    };
    add_stack(scene, layers, n_sub, neumann, all_effects, &pieces)
}

/// The stream count of `opts`, or the scene's default; `1..=512`.
pub(crate) fn resolve_streams(
    scene: &MonoScene,
    opts: &MultifluxOptions,
) -> Result<usize, MultifluxError> {
    let streams = opts.streams.unwrap_or_else(|| default_streams(scene));
    if streams == 0 || streams > 512 {
        return Err(MultifluxError::Option {
            name: "streams",
            value: streams as f64,
            reason: "must lie in 1..=512",
        });
    }
    Ok(streams)
}

/// The media of the stack, top to bottom (ambient, layers, and a transparent
/// substrate unless a half-space hides it), and their Snell-mapped grid.
pub(crate) fn media_grid(scene: &MonoScene, streams: usize) -> (Option<f64>, AngularGrid) {
    let half = scene.layers().last().is_some_and(|l| l.is_half_space() && l.tau() > 0.0);
    let n_sub = match scene.substrate() {
        Substrate::Transparent { n } if !half => Some(n),
        _ => None,
    };
    let mut all_n = vec![scene.ambient_n()];
    all_n.extend(scene.layers().iter().map(|l| l.n()));
    all_n.extend(n_sub);
    (n_sub, AngularGrid::new(&all_n, streams))
}

/// Operators of one layer and order by the eigen-solve (eq. S1–S5), also when
/// the layer does not scatter (`--all-effects`: the closed form of
/// [`slab_operators`] is not taken).
fn eigen_operators(
    mu: &[f64],
    w: &[f64],
    extras: &[Extra],
    p: &SlabOrder<'_>,
    tms: Option<&Tms>,
) -> Result<LayerOperators, MultifluxError> {
    let s = SlabSolution::build(mu, w, p, true)?;
    Ok(crate::workspace::with_workspace(|ws| {
        let ops = s.operators_in(extras, tms, ws);
        s.recycle(ws);
        ops
    }))
}

/// The scene as the plan's `transmission` rule leaves it (eq. PL1 of
/// `docs/planner.md`): when a layer is so thick that less than the returned
/// bound of the incident light comes back from below it, the stack is cut
/// there and that layer becomes a half-space. Returns the cut scene (`None`
/// when nothing is cut, or with all effects) and the bound.
pub(crate) fn planned_cutoff(
    scene: &MonoScene,
    opts: &MultifluxOptions,
) -> (Option<MonoScene>, Option<f64>) {
    if opts.all_effects {
        return (None, None);
    }
    let Some((i, bound)) = km_core::plan::transmission_cut(scene) else {
        return (None, None);
    };
    // The plan's layer index is in range, so the cut cannot fail.
    match scene.cut_below(i) {
        Ok(cut) => (Some(cut), Some(bound)),
        Err(_) => (None, None),
    }
}
