//! The scene entry point: a stack of layers, interfaces and a substrate,
//! solved per Fourier order by adding (Fourier–Gauss mode).
//!
//! Per spectral channel:
//! 1. one [`AngularGrid`] for all media (quadratures that map under Snell);
//! 2. delta-M scaling of every layer (Wiscombe 1977) with `2N` moments kept
//!    (`3N/2` for a peak the `2N` do not resolve, eq. 4b),
//!    and the plan's thick-layer cut ([`crate::engine::Prepared`]);
//! 3. extra directions: the collimated beam, one probe per distinct exit
//!    polar angle on each side, and the markers of the single-scattering
//!    correction of each peaked layer ([`crate::engine`]);
//! 4. for each Fourier order `m = 0..M` (`M = 0` for totals; up to the last
//!    non-negligible scaled moment, at most `2N - 1`, for a BRDF): the
//!    operators of every interface and layer, added top to bottom (exact,
//!    or truncated Neumann series of order `k`), then the substrate;
//! 5. totals from `m = 0`; BRDF/BTDF `= sum_m I^m cos m(phi - 180 deg)` plus
//!    the correction at each direction's azimuth (eq. B1 of `docs/bsdf.md`);
//! 6. the delta parts (mirror reflection, unscattered beam) from a separate
//!    one-direction pass with the unscaled optical thicknesses.

use std::time::Instant;

use km_core::{ChannelResult, MonoScene, Scene, Solution, Substrate};

use crate::MultifluxError;
use crate::engine::{ChannelBsdf, DirectionValues, Incidence, Prepared, Request, Stop, last_order};
pub use crate::field::{InternalField, internal_field};
pub use crate::options::{
    DEFAULT_STREAMS, DEFAULT_STREAMS_ANGULAR, DEFAULT_STREAMS_HARD, DEFAULT_STREAMS_PEAKED,
    FOURIER_TOL, MultifluxOptions, default_bsdf_streams, default_streams,
};
use crate::prepare::resolve_streams;

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
    // Sized to the channels: `collect` through `Result` would reserve room
    // for four parts, a request glibc serves past its per-thread cache.
    let mut parts = Vec::with_capacity(scene.channels().len());
    for ch in scene.channels() {
        parts.push(solve_channel(ch, opts)?);
    }
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
    solve_mono_parts(ch, opts)
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
    solve_mono_parts(scene, opts).map(|p| (p.result, p.orders))
}

/// One channel by the angular engine ([`crate::engine`]): the channel
/// prepared once (streams, grid, delta-M, the plan's cut), its exit
/// directions as one probe per distinct polar angle and side, the azimuths
/// as cosine sums; with the size of the conservation fix-up of eq. 18a and
/// the bound of the planner's thick-layer cut (eq. PL1 of `docs/planner.md`).
fn solve_mono_parts(
    scene: &MonoScene,
    opts: &MultifluxOptions,
) -> Result<ChannelPart, MultifluxError> {
    let streams = resolve_streams(scene, opts)?;
    let prep = Prepared::new(scene, opts, streams);
    let dirs = prep.scene.directions_deg();
    let (theta_o, o_of) = distinct_polar(dirs);
    let beam = prep.scene.beam_invariant();
    let beams: Vec<f64> = beam.into_iter().collect();
    let incidence = if beam.is_some() { Incidence::Beams(&beams) } else { Incidence::Diffuse };
    let stop = if opts.all_effects { Stop::Never } else { Stop::Values };
    let last = last_order(&prep, !dirs.is_empty() && beam.is_some());
    let req = Request {
        incidence,
        theta_o: &theta_o,
        directions: dirs,
        o_of: &o_of,
        stop,
        last_order: last,
    };
    let (table, values) = prep.respond(&req)?;
    let values = values.unwrap_or(DirectionValues { brdf: Vec::new(), btdf: Vec::new() });
    let mut out = ChannelResult { brdf: values.brdf, btdf: values.btdf, ..Default::default() };
    let residual = finish(&prep, &table, &mut out)?;
    Ok(ChannelPart { result: out, streams, orders: table.solved, residual, cutoff: prep.cutoff })
}

/// The distinct exit polar angles of `dirs` in order of first appearance,
/// and the index of each direction's angle among them. Angles are told
/// apart by their bits, by a linear search among those found so far, or
/// through a map when the request has more than 64 directions.
fn distinct_polar(dirs: &[[f64; 2]]) -> (Vec<f64>, Vec<usize>) {
    let mut theta_o: Vec<f64> = Vec::with_capacity(dirs.len().min(64));
    let mut index: Option<std::collections::HashMap<u64, usize>> =
        (dirs.len() > 64).then(std::collections::HashMap::new);
    let o_of = dirs
        .iter()
        .map(|d| {
            let bits = d[0].to_bits();
            let found = match &index {
                Some(map) => map.get(&bits).copied(),
                None => theta_o.iter().position(|t| t.to_bits() == bits),
            };
            found.unwrap_or_else(|| {
                theta_o.push(d[0]);
                if let Some(map) = &mut index {
                    map.insert(bits, theta_o.len() - 1);
                }
                theta_o.len() - 1
            })
        })
        .collect();
    (theta_o, o_of)
}

/// The channel's totals: the delta parts with the true (unscaled) optical
/// thicknesses (integrated over the nodes for diffuse light), exact
/// conservation (eq. 18a), and a refusal of non-finite results. Returns the
/// size of the conservation fix-up.
fn finish(
    prep: &Prepared<'_>,
    table: &ChannelBsdf,
    out: &mut ChannelResult,
) -> Result<f64, MultifluxError> {
    let (scene, layers) = (&prep.scene, &prep.layers);
    let n0 = scene.ambient_n();
    let (spec, direct) = if scene.beam_invariant().is_some() {
        (table.reflectance_specular[0], table.transmittance_direct[0])
    } else {
        let nodes0 = &prep.nodes0;
        let (mut s, mut d) = (0.0, 0.0);
        for i in 0..nodes0.mu.len() {
            let sx = n0 * (1.0 - nodes0.mu[i] * nodes0.mu[i]).max(0.0).sqrt();
            let (si, di) = prep.delta_parts(sx);
            let f = 2.0 * nodes0.w[i] * nodes0.mu[i];
            s += f * si;
            d += f * di;
        }
        (s, d)
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
    let (r_tot, t_tot) = (table.reflectance[0], table.transmittance[0]);
    let (r_tot, t_tot, a_tot, residual) = conserve(r_tot, t_tot, lossless);
    out.reflectance = r_tot;
    out.reflectance_specular = spec;
    out.transmittance = t_tot;
    out.transmittance_direct = direct;
    out.absorptance = a_tot;
    let finite = [r_tot, t_tot, spec, direct].iter().all(|x| x.is_finite())
        && out.brdf.iter().chain(&out.btdf).all(|x| x.is_finite());
    if !finite {
        return Err(MultifluxError::Numerical {
            what: "solve",
            detail: "non-finite result".into(),
        });
    }
    Ok(residual)
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
