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
use km_core::{ChannelResult, Light, MonoScene, Scene, Solution, Substrate};

use crate::MultifluxError;
use crate::adding::{LayerOperators, add, add_truncated};
use crate::interface::{fresnel_operators, lambertian_reflection};
use crate::legendre::delta_m;
use crate::quadrature::{AngularGrid, MediumNodes, mu_of_invariant};
use crate::slab::{Extra, SlabOrder, SlabSolution, Tms, slab_beam_response, slab_operators};

/// Default number of Gauss nodes per hemisphere (per Snell segment): meets
/// the 1e-4 accuracy target on the reference cases (see `docs/multiflux.md`).
pub const DEFAULT_STREAMS: usize = 16;

/// Default for the slow corners of the hard-case grid (`docs/multiflux.md` §8):
/// a strongly peaked phase function (`|g| > 0.8`) inside a layer whose index
/// differs from the ambient's, or incidence beyond 80 degrees.
pub const DEFAULT_STREAMS_HARD: usize = 32;

/// Default for totals with a nearly singular forward peak (`|g| > 0.95`) at
/// incidence beyond 80 degrees on an index-matched stack; see
/// [`default_streams`].
pub const DEFAULT_STREAMS_PEAKED: usize = 128;

/// Default when exit directions are asked for in a layer with `|g| > 0.9`
/// (BRDF/BTDF within 1 % up to g = 0.95; see [`default_streams`]).
pub const DEFAULT_STREAMS_ANGULAR: usize = 48;

/// The stream count used when the options give none: [`DEFAULT_STREAMS`], or
/// [`DEFAULT_STREAMS_HARD`] for the slow corners (measured: |g| = 0.9 in an
/// index of 1.5 or 2.5 is 1.2e-3 from converged at 16 streams, 3e-5 at 32;
/// 89 degrees with g = 0.9, 1e-3 and 7e-6).
///
/// A scattering layer with `|g| > 0.95` needs more (`docs/multiflux.md` §8,
/// measured at g = 0.99 against 256 streams): 32 streams at least (in air
/// up to 75 degrees 16 streams miss by 1.5e-4, 32 by 2e-5), and for totals
/// at incidence beyond 80 degrees on an index-matched stack
/// [`DEFAULT_STREAMS_PEAKED`] (89 degrees: 2e-2 at 16 streams, 2e-3 at 32,
/// 1.5e-3 at 64, 9e-5 at 128 for w = 0.99, 1.5e-4 for w = 0.5; 4.5 ms).
/// With BRDF/BTDF directions the answer is the angular distribution and the
/// rule follows its convergence (measured against DISORT at 256 streams, the
/// worst value of 48 slabs at 30-85 degrees, `docs/multiflux.md` §8): 32
/// streams for `0.8 < |g| <= 0.9`, [`DEFAULT_STREAMS_ANGULAR`] beyond; totals
/// alone keep the rules above. [`DEFAULT_STREAMS_PEAKED`] is not taken with
/// directions (all `2N` Fourier orders are
/// needed there: 1 s at 128 streams), nor with refractive interfaces, where 128 streams (2-4 N
/// nodes per medium) lose energy balance to 1e-8..4e-7, beyond the
/// 1e-9 the solver otherwise keeps (g = 0.99 in n = 1.5 stays ~1e-3 off at
/// 32 streams; ask for `streams` explicitly to trade).
pub fn default_streams(scene: &MonoScene) -> usize {
    let grazing = scene.light.mu0().is_some_and(|mu0| mu0 < 80f64.to_radians().cos());
    let peaked_mismatch = scene
        .layers
        .iter()
        .any(|l| l.g().abs() > 0.8 && l.albedo() > 0.0 && l.n != scene.ambient_n);
    let very_peaked = scene.layers.iter().any(|l| l.g().abs() > 0.95 && l.albedo() > 0.0);
    let matched = scene.layers.iter().all(|l| l.n == scene.ambient_n)
        && !matches!(scene.substrate, Substrate::Transparent { n } if n != scene.ambient_n);
    // Exit directions asked for (BRDF/BTDF within 1 % or 1e-4 for |g| <= 0.95
    // up to 85 degrees; `docs/multiflux.md` §8, table 8b): 48 streams beyond
    // |g| = 0.9 (g = 0.95: 1.0e-2 worst at 32, 1.2e-3 at 48), 32 beyond 0.8
    // (g = 0.9: 8.3e-4 at 24, 1.0e-4 at 32; g = 0.8: 6.9e-5 at 16).
    let angles = !scene.directions_deg.is_empty();
    let max_g =
        scene.layers.iter().filter(|l| l.albedo() > 0.0).fold(0.0f64, |a, l| a.max(l.g().abs()));
    if angles && max_g > 0.9 {
        DEFAULT_STREAMS_ANGULAR
    } else if very_peaked && grazing && matched && !angles {
        DEFAULT_STREAMS_PEAKED
    } else if grazing || peaked_mismatch || very_peaked || (angles && max_g > 0.8) {
        DEFAULT_STREAMS_HARD
    } else {
        DEFAULT_STREAMS
    }
}

/// Relative size below which two consecutive Fourier orders end the azimuthal
/// series of the BRDF/BTDF (DISORT's azimuthal convergence test, ACCUR).
pub const FOURIER_TOL: f64 = 1e-9;

/// Options of the Fourier–Gauss solver.
#[derive(Debug, Clone, PartialEq)]
pub struct MultifluxOptions {
    /// Gauss nodes per hemisphere and per Snell segment (`None`: [`default_streams`]).
    pub streams: Option<usize>,
    /// Truncate the adding of layers after this many round trips (seed eq. 21);
    /// `None` = exact adding.
    pub neumann_order: Option<usize>,
    /// Upper bound on the Fourier order used for BRDF/BTDF (`None`: as needed).
    pub max_fourier_order: Option<usize>,
    /// Delta-M scaling of the phase function (Wiscombe 1977); default true.
    pub delta_m: bool,
    /// Switch the planner ([`km_core::plan::Plan`]) off: build every interface
    /// (also between equal indices, where it is the identity), eigen-solve
    /// every layer (also those that only absorb), compute every Fourier order
    /// the streams resolve (`2N - 1`) even for totals, and never cut a thick
    /// layer (`docs/planner.md`). Default false: the plan is obeyed.
    pub all_effects: bool,
    /// The second-order (IMS) part of the intensity correction at user exit
    /// directions (`docs/multiflux.md` eq. 5a–5e; Nakajima & Tanaka 1988);
    /// default true. The single-scattering part (TMS) comes with `delta_m`.
    pub secondary_correction: bool,
    /// Work budget of one solve (eq. W1 of [`crate::budget`]; `None`:
    /// [`crate::budget::DEFAULT_MAX_WORK`]). A solve estimated above it is refused before
    /// it starts.
    pub max_work: Option<f64>,
}

impl Default for MultifluxOptions {
    fn default() -> Self {
        MultifluxOptions {
            streams: None,
            neumann_order: None,
            max_fourier_order: None,
            delta_m: true,
            all_effects: false,
            secondary_correction: true,
            max_work: None,
        }
    }
}

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
        scene.channels.iter().map(|ch| solve_channel(ch, opts)).collect::<Result<Vec<_>, _>>()?;
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
/// let parts: Vec<_> = scene.channels.iter().map(|c| solve_channel(c, &o).unwrap()).collect();
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
        labels: scene.labels.clone(),
        seconds,
        notes,
        diagnostics: km_core::solution::Diagnostics {
            method: km_core::solution::MethodDiagnostics::Multiflux(diagnostics),
            ..Default::default()
        },
        ..Default::default()
    }
}

/// One layer after delta-M scaling.
#[derive(Clone)]
pub(crate) struct Scaled {
    pub(crate) tau: f64,
    pub(crate) tau_true: f64,
    pub(crate) omega: f64,
    pub(crate) chi: Vec<f64>,
    pub(crate) n: f64,
    pub(crate) omega_true: f64,
    pub(crate) phase: km_core::phase::Phase,
    /// Delta-M factor on tau, `1 - omega f`.
    pub(crate) factor: f64,
    /// Apply the second-order (IMS) correction at exit directions.
    pub(crate) secondary: bool,
}

impl Scaled {
    /// The intensity correction of this layer (TMS and IMS, eq. 5–5h) with
    /// `n_keep` moments kept by delta-M.
    pub(crate) fn correction(&self, n_keep: usize) -> Tms {
        Tms::new(self.phase, self.omega_true, n_keep, self.secondary)
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
    scene.validate()?;
    let streams = resolve_streams(scene, opts)?;
    // The plan's `transmission` rule: a layer through which nothing measurable
    // returns is a half-space; nothing below it is built.
    let (cut, bound) = planned_cutoff(scene, opts);
    out_cutoff.set(bound);
    let scene = cut.as_ref().unwrap_or(scene);
    let all = opts.all_effects;

    // Media, top to bottom: ambient, layers, substrate (if transparent).
    let n0 = scene.ambient_n;
    let (n_sub, grid) = media_grid(scene, streams);
    // Legendre moments kept (delta-M truncation at chi_{2N}, Wiscombe 1977).
    let n_keep = 2 * streams;

    // Extras: the beam, then probes (by Snell invariant s).
    // (s, is_beam, phi): probes share an extra when s (and, for the
    // single-scattering correction of a beam, phi) agree.
    let mut ex_s: Vec<(f64, bool, f64)> = Vec::new();
    let beam = match scene.light {
        Light::Collimated { theta_deg } => {
            ex_s.push((n0 * theta_deg.to_radians().sin(), true, 0.0));
            Some(0)
        }
        Light::Diffuse => None,
    };
    let tms_on = opts.delta_m && beam.is_some();
    let probe = |s: f64, phi: f64, ex_s: &mut Vec<(f64, bool, f64)>| -> usize {
        let phi = if tms_on { phi } else { 0.0 };
        if let Some(i) = ex_s.iter().position(|&(t, b, p)| !b && t == s && p == phi) {
            return i;
        }
        ex_s.push((s, false, phi));
        ex_s.len() - 1
    };
    let dirs = &scene.directions_deg;
    let brdf_ix: Vec<usize> =
        dirs.iter().map(|d| probe(n0 * d[0].to_radians().sin(), d[1], &mut ex_s)).collect();
    let btdf_ix: Vec<usize> = match n_sub {
        Some(ns) => {
            dirs.iter().map(|d| probe(ns * d[0].to_radians().sin(), d[1], &mut ex_s)).collect()
        }
        None => Vec::new(),
    };
    let extras_in = |n: f64| -> Vec<Extra> {
        ex_s.iter()
            .map(|&(s, beam, phi_deg)| Extra { mu: mu_of_invariant(s, n), beam, phi_deg })
            .collect()
    };

    // Delta-M scaling of each layer.
    let layers = scale_layers(scene, opts, n_keep);

    // Fourier orders: 0 for totals; up to the last non-negligible moment for angles.
    let need_angles = !dirs.is_empty();
    let m_max = if need_angles && beam.is_some() {
        let mut m = 0;
        for l in &layers {
            if l.omega > 0.0
                && let Some(last) = l.chi.iter().rposition(|c| c.abs() > 1e-12)
            {
                m = m.max(last);
            }
        }
        m.min(opts.max_fourier_order.unwrap_or(usize::MAX))
    } else {
        0
    };
    // Everything on: every order the streams resolve, even for totals.
    let m_max = if all {
        (2 * streams - 1).min(opts.max_fourier_order.unwrap_or(usize::MAX))
    } else {
        m_max
    };

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

    // Azimuthal convergence (as DISORT's ACCUR test): stop after two
    // consecutive orders whose Fourier amplitudes |I^m| are all below
    // `FOURIER_TOL` times the largest BRDF/BTDF value so far.
    let mut small_orders = 0;
    let mut m_used = 0;
    // A layer alone in the ambient medium under a beam (no interface, nothing
    // below it): the answer is one column of its operators, computed without
    // the node-to-node operators (`slab_beam_response`). Never with all effects.
    let lone = match (beam, &layers[..]) {
        (Some(b), [l]) if !all && l.n == n0 => {
            let floor_free = l.tau.is_infinite()
                || match scene.substrate {
                    Substrate::Black => true,
                    Substrate::Transparent { .. } => n_sub.is_none_or(|ns| ns == n0),
                    Substrate::Lambertian { .. } => false,
                };
            floor_free.then_some((b, l))
        }
        _ => None,
    };
    for m in 0..=m_max {
        m_used = m;
        let (up, down) = if let Some((b, l)) = lone {
            let p = SlabOrder { tau: l.tau, omega: l.omega, chi: &l.chi, m };
            let t = (tms_on && !dirs.is_empty() && m == 0).then(|| l.correction(n_keep));
            let t = t.as_ref();
            let (cr, ct) = slab_beam_response(&nodes0.mu, &nodes0.w, &e0, b, &p, t)?;
            (cr, if nodes_sub.is_some() { ct } else { Vec::new() })
        } else {
            let ops = stack_operators(
                scene,
                &grid,
                &layers,
                n_sub,
                &extras_in,
                m,
                opts.neumann_order,
                tms_on && !dirs.is_empty(),
                all,
            )?;
            // Input at the top.
            let a = {
                let mut a = vec![0.0; na0 + e0.len()];
                match beam {
                    Some(b) => a[na0 + b] = 1.0,
                    None if m == 0 => {
                        // Uniform radiance 1/pi (unit irradiance) in every down-going
                        // direction: the nodes and the probes (whose direct
                        // transmission and mirror reflection are smooth in angle
                        // for diffuse light, so they belong to the BRDF/BTDF).
                        for (i, x) in a.iter_mut().enumerate() {
                            if i < na0 || e0[i - na0].mu.is_some() {
                                *x = 1.0 / std::f64::consts::PI;
                            }
                        }
                    }
                    None => {}
                }
                a
            };
            let down = if nodes_sub.is_some() { apply(&ops.t_down, &a) } else { Vec::new() };
            (apply(&ops.r_top, &a), down)
        };
        let cosm = |phi_deg: f64| (m as f64 * (phi_deg - 180.0).to_radians()).cos();
        if m == 0 {
            r_tot = flux(&nodes0, &up[..na0]) + beam.map_or(0.0, |b| up[na0 + b]);
        }
        let mut term = 0.0f64;
        for (k, d) in dirs.iter().enumerate() {
            let x = up[na0 + brdf_ix[k]];
            out.brdf[k] += x * cosm(d[1]);
            term = term.max(x.abs());
        }
        if let Some(ns) = &nodes_sub {
            let nb = ns.mu.len();
            if m == 0 {
                t_tot = flux(ns, &down[..nb]) + beam.map_or(0.0, |b| down[nb + b]);
            }
            for (k, d) in dirs.iter().enumerate() {
                let x = down[nb + btdf_ix[k]];
                out.btdf[k] += x * cosm(d[1]);
                term = term.max(x.abs());
            }
        }
        if m > 0 && !all {
            let largest = out.brdf.iter().chain(&out.btdf).fold(0.0f64, |a, &b| a.max(b.abs()));
            small_orders = if term <= FOURIER_TOL * largest { small_orders + 1 } else { 0 };
            if small_orders == 2 {
                break;
            }
        }
    }

    // Delta parts with the true (unscaled) optical thicknesses.
    let (spec, direct) = match beam {
        Some(b) => delta_parts(scene, &layers, n_sub, ex_s[b].0),
        None => {
            let (mut s, mut d) = (0.0, 0.0);
            for i in 0..na0 {
                let sx = n0 * (1.0 - nodes0.mu[i] * nodes0.mu[i]).max(0.0).sqrt();
                let (si, di) = delta_parts(scene, &layers, n_sub, sx);
                let f = 2.0 * nodes0.w[i] * nodes0.mu[i];
                s += f * si;
                d += f * di;
            }
            (s, d)
        }
    };
    // Exact conservation (eq. 18a): nothing absorbs when every layer scatters
    // conservatively and the floor does not absorb.
    let lossless = layers.iter().all(|l| l.tau_true == 0.0 || l.omega_true == 1.0)
        && (layers.last().is_some_and(|l| l.tau.is_infinite())
            || match scene.substrate {
                Substrate::Transparent { .. } => true,
                Substrate::Lambertian { albedo } => albedo == 1.0,
                Substrate::Black => false,
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
    Ok((out, m_used + 1))
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
        .layers
        .iter()
        .map(|l| {
            let chi: Vec<f64> = (0..=n_keep).map(|i| l.phase.legendre_moment(i)).collect();
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
                n: l.n,
                omega_true: omega,
                phase: l.phase,
                factor,
                secondary: opts.secondary_correction,
            }
        })
        .collect()
}

/// The radiance field at one depth of a stack, for one Fourier order.
#[derive(Debug, Clone, PartialEq)]
pub struct InternalField {
    /// Refractive index of the medium at that depth.
    pub n: f64,
    /// Node cosines `mu > 0` of that medium.
    pub mu: Vec<f64>,
    /// Node weights (`integral_0^1 dmu`).
    pub w: Vec<f64>,
    /// Down-going radiance at the nodes (Fourier order `m`, per unit incident irradiance).
    pub down: Vec<f64>,
    /// Up-going radiance at the nodes.
    pub up: Vec<f64>,
    /// Irradiance on a horizontal plane of the down-going collimated beam
    /// (delta-M scaled: the forward peak travels with it); 0 for diffuse light.
    pub beam_down: f64,
    /// The same for the beam reflected by interfaces below, going up.
    pub beam_up: f64,
}

impl InternalField {
    /// Net downward flux `2 pi sum w mu (down - up) + beam_down - beam_up` (order 0).
    pub fn net_flux(&self) -> f64 {
        let diffuse: f64 =
            (0..self.mu.len()).map(|i| self.w[i] * self.mu[i] * (self.down[i] - self.up[i])).sum();
        2.0 * std::f64::consts::PI * diffuse + self.beam_down - self.beam_up
    }
}

/// The radiance field `I(z, mu)` at geometric depth `z` (length units from
/// the top of the first layer, inside the stack) for Fourier order `m`
/// (`m = 0`: the azimuthal mean), at the nodes of the medium there (seed 000
/// eq. 19 generalised to the stack). The stack is cut at `z` into the part
/// above and the part below (each layer piece is a layer of its own optical
/// thickness); with their operators `A` and `B`,
/// `d = (I - A.r_bottom B.r_top)^-1 A.t_down a` and `u = B.r_top d` (eq. 19').
///
/// # Errors
/// A depth outside the stack ([`MultifluxError::Option`]), and those of [`solve`].
pub fn internal_field(
    scene: &MonoScene,
    opts: &MultifluxOptions,
    z: f64,
    m: usize,
) -> Result<InternalField, MultifluxError> {
    scene.validate()?;
    let streams = resolve_streams(scene, opts)?;
    let total: f64 = scene.layers.iter().map(|l| l.thickness).sum();
    if !(z >= 0.0 && z <= total && z.is_finite()) {
        return Err(MultifluxError::Option {
            name: "z",
            value: z,
            reason: "depth must lie in the stack",
        });
    }
    let n0 = scene.ambient_n;
    let (n_sub, grid) = media_grid(scene, streams);
    let layers = scale_layers(scene, opts, 2 * streams);
    let ex_s: Vec<(f64, bool)> = match scene.light {
        Light::Collimated { theta_deg } => vec![(n0 * theta_deg.to_radians().sin(), true)],
        Light::Diffuse => Vec::new(),
    };
    let extras_in = |n: f64| -> Vec<Extra> {
        ex_s.iter()
            .map(|&(s, beam)| Extra { mu: mu_of_invariant(s, n), beam, phi_deg: 0.0 })
            .collect()
    };
    // Find the layer holding z and split it.
    let (mut i_cut, mut z_top) = (0, 0.0);
    for (i, l) in scene.layers.iter().enumerate() {
        i_cut = i;
        if z <= z_top + l.thickness {
            break;
        }
        z_top += l.thickness;
    }
    let lc = &scene.layers[i_cut];
    let frac_tau = |tau: f64| if lc.thickness > 0.0 { tau / lc.thickness } else { 0.0 };
    let dz = (z - z_top).max(0.0);
    let mut upper = layers[i_cut].clone();
    let mut lower = layers[i_cut].clone();
    // Piece above the cut: optical thickness (z - z_top) sigma_t (scaled and true).
    let (per_len, per_len_true) = if lc.thickness.is_infinite() {
        (lc.sigma_t() * layers[i_cut].factor, lc.sigma_t())
    } else {
        (frac_tau(layers[i_cut].tau), frac_tau(layers[i_cut].tau_true))
    };
    upper.tau = per_len * dz;
    upper.tau_true = per_len_true * dz;
    let rest = lc.thickness - dz;
    lower.tau = if rest.is_infinite() { f64::INFINITY } else { per_len * rest };
    lower.tau_true = if rest.is_infinite() { f64::INFINITY } else { per_len_true * rest };
    let mut above: Vec<Scaled> = layers[..i_cut].to_vec();
    above.push(upper);
    let mut below = vec![lower];
    below.extend_from_slice(&layers[i_cut + 1..]);

    let n_cut = lc.n;
    let mut scene_above = scene.clone();
    scene_above.substrate = Substrate::Transparent { n: n_cut };
    let mut scene_below = scene.clone();
    scene_below.ambient_n = n_cut;
    let tms = false;
    let a_ops = stack_operators(
        &scene_above,
        &grid,
        &above,
        Some(n_cut),
        &extras_in,
        m,
        opts.neumann_order,
        tms,
        opts.all_effects,
    )?;
    let b_ops = stack_operators(
        &scene_below,
        &grid,
        &below,
        n_sub,
        &extras_in,
        m,
        opts.neumann_order,
        tms,
        opts.all_effects,
    )?;

    // Input at the top.
    let nodes0 = grid.medium(n0);
    let na0 = nodes0.mu.len();
    let mut a = Mat::<f64>::zeros(na0 + ex_s.len(), 1);
    if ex_s.is_empty() {
        if m == 0 {
            for i in 0..na0 {
                a[(i, 0)] = 1.0 / std::f64::consts::PI;
            }
        }
    } else {
        a[(na0, 0)] = 1.0;
    }
    // Eq. 19': the streams at the cut.
    let dim = b_ops.r_top.ncols();
    let mut x = Mat::<f64>::identity(dim, dim);
    x -= &a_ops.r_bottom * &b_ops.r_top;
    use faer::linalg::solvers::Solve;
    let d = x.partial_piv_lu().solve(&a_ops.t_down * &a);
    let u = &b_ops.r_top * &d;
    let nodes = grid.medium(n_cut);
    let nn = nodes.mu.len();
    let out = InternalField {
        n: n_cut,
        down: (0..nn).map(|i| d[(i, 0)]).collect(),
        up: (0..nn).map(|i| u[(i, 0)]).collect(),
        beam_down: if ex_s.is_empty() { 0.0 } else { d[(nn, 0)] },
        beam_up: if ex_s.is_empty() { 0.0 } else { u[(nn, 0)] },
        mu: nodes.mu,
        w: nodes.w,
    };
    let finite = out.down.iter().chain(&out.up).all(|v| v.is_finite());
    if !finite {
        return Err(MultifluxError::Numerical {
            what: "internal_field",
            detail: format!("z = {z}"),
        });
    }
    Ok(out)
}

/// `2 pi sum_i w_i mu_i I_i`: the flux of a radiance vector at the nodes.
pub(crate) fn flux(nodes: &MediumNodes, i: &[f64]) -> f64 {
    2.0 * std::f64::consts::PI
        * nodes.mu.iter().zip(&nodes.w).zip(i).map(|((u, w), x)| u * w * x).sum::<f64>()
}

fn apply(m: &Mat<f64>, a: &[f64]) -> Vec<f64> {
    (0..m.nrows()).map(|i| (0..m.ncols()).map(|j| m[(i, j)] * a[j]).sum()).collect()
}

pub(crate) fn combine(
    acc: Option<LayerOperators>,
    next: LayerOperators,
    neumann: Option<usize>,
) -> Result<LayerOperators, MultifluxError> {
    match acc {
        None => Ok(next),
        Some(a) => match neumann {
            None => add(&a, &next),
            Some(k) => add_truncated(&a, &next, k),
        },
    }
}

/// The operators of the whole stack for Fourier order `m`, substrate included.
#[allow(clippy::too_many_arguments)]
fn stack_operators(
    scene: &MonoScene,
    grid: &AngularGrid,
    layers: &[Scaled],
    n_sub: Option<f64>,
    extras_in: &dyn Fn(f64) -> Vec<Extra>,
    m: usize,
    neumann: Option<usize>,
    tms: bool,
    all_effects: bool,
) -> Result<LayerOperators, MultifluxError> {
    let mut acc: Option<LayerOperators> = None;
    let mut n_above = scene.ambient_n;
    let interface = |na: f64, nb: f64| {
        fresnel_operators(&grid.medium(na), &grid.medium(nb), &extras_in(na), &extras_in(nb))
    };
    for l in layers {
        // The plan's `interface` rule: equal indices are no interface (the
        // Fresnel operator would be the identity); built anyway with all effects.
        if l.n != n_above || all_effects {
            acc = Some(combine(acc, interface(n_above, l.n), neumann)?);
        }
        let nodes = grid.medium(l.n);
        let ex = extras_in(l.n);
        let p = SlabOrder { tau: l.tau, omega: l.omega, chi: &l.chi, m };
        let t = (tms && m == 0).then(|| l.correction(2 * grid.streams));
        let t = t.as_ref();
        // The plan's `scattering` rule lives in `slab_operators` (a layer that
        // does not scatter is Beer–Lambert attenuation); with all effects every
        // layer of finite positive thickness is eigen-solved.
        let ops = if all_effects && l.tau > 0.0 {
            eigen_operators(&nodes.mu, &nodes.w, &ex, &p, t)?
        } else {
            slab_operators(&nodes.mu, &nodes.w, &ex, &p, t)?
        };
        acc = Some(combine(acc, ops, neumann)?);
        n_above = l.n;
    }
    let half_space = layers.last().is_some_and(|l| l.tau.is_infinite());
    let lambertian =
        |n: f64, albedo: f64| lambertian_reflection(&grid.medium(n), &extras_in(n), albedo, m);
    let close = Closing { half_space, n_above, n_sub, all_effects, neumann };
    close_stack(scene, acc, &close, &interface, &lambertian)
}

/// How a stack of layer operators ends (see [`close_stack`]).
pub(crate) struct Closing {
    /// The last layer is a half-space: nothing lies below it.
    pub(crate) half_space: bool,
    /// Refractive index of the last layer.
    pub(crate) n_above: f64,
    /// Index of a clear substrate (`None`: that of the last layer).
    pub(crate) n_sub: Option<f64>,
    /// Build the substrate's interface even between equal indices.
    pub(crate) all_effects: bool,
    /// Truncated adding (seed eq. 21), or exact.
    pub(crate) neumann: Option<usize>,
}

/// Close the operators `acc` of a stack's layers: refuse an empty stack, stop
/// at a half-space, then add the substrate (seed §3.4): the Fresnel interface
/// into a clear half-space of another index, or the Lambertian floor
/// `lambertian(n, albedo)` (its reflection operator), or nothing for a black one.
pub(crate) fn close_stack(
    scene: &MonoScene,
    acc: Option<LayerOperators>,
    close: &Closing,
    interface: &dyn Fn(f64, f64) -> LayerOperators,
    lambertian: &dyn Fn(f64, f64) -> Mat<f64>,
) -> Result<LayerOperators, MultifluxError> {
    let Some(mut acc) = acc else {
        return Err(MultifluxError::Scene(km_core::CoreError::scene(
            "layer",
            None,
            "the stack has no layer",
        )));
    };
    if close.half_space {
        return Ok(acc);
    }
    let (n_above, neumann) = (close.n_above, close.neumann);
    match scene.substrate {
        Substrate::Transparent { .. } => {
            let ns = close.n_sub.unwrap_or(n_above);
            if ns != n_above || close.all_effects {
                acc = combine(Some(acc), interface(n_above, ns), neumann)?;
            }
        }
        Substrate::Lambertian { albedo } => {
            let g = lambertian(n_above, albedo);
            let dim = g.nrows();
            let floor = LayerOperators {
                r_top: g,
                t_down: Mat::zeros(0, dim),
                r_bottom: Mat::zeros(0, 0),
                t_up: Mat::zeros(dim, 0),
            };
            acc = combine(Some(acc), floor, neumann)?;
        }
        Substrate::Black => {}
    }
    Ok(acc)
}

/// Mirror reflectance and unscattered transmittance of a direction of Snell
/// invariant `s` entering from above: a one-direction adding pass with the
/// true optical thicknesses and flux (not radiance) Fresnel factors.
pub(crate) fn delta_parts(
    scene: &MonoScene,
    layers: &[Scaled],
    n_sub: Option<f64>,
    s: f64,
) -> (f64, f64) {
    // Scalar operators (r_top, t_down, r_bottom, t_up) and their star product
    // (eq. A4 of the adding module with 1 x 1 operators).
    type Op = (f64, f64, f64, f64);
    let star = |(r1, t1, r1p, t1p): Op, (r2, t2, r2p, t2p): Op| -> Op {
        let x = 1.0 - r1p * r2;
        if x == 0.0 {
            // Facing total reflections with nothing between: nothing enters.
            return (r1, 0.0, r2p, 0.0);
        }
        (r1 + t1p * r2 * t1 / x, t2 * t1 / x, r2p + t2 * r1p * t2p / x, t1p * t2p / x)
    };
    let iface = |na: f64, nb: f64| -> Op {
        match (mu_of_invariant(s, na), mu_of_invariant(s, nb)) {
            (Some(a), Some(b)) => {
                let ra = km_core::fresnel::reflectance(a, na, nb);
                let rb = km_core::fresnel::reflectance(b, nb, na);
                (ra, 1.0 - ra, rb, 1.0 - rb)
            }
            (Some(_), None) => (1.0, 0.0, 0.0, 0.0),
            (None, Some(_)) => (0.0, 0.0, 1.0, 0.0),
            (None, None) => (0.0, 0.0, 0.0, 0.0),
        }
    };
    let mut acc: Op = (0.0, 1.0, 0.0, 1.0);
    let mut n_above = scene.ambient_n;
    for l in layers {
        if l.n != n_above {
            acc = star(acc, iface(n_above, l.n));
        }
        let t = match mu_of_invariant(s, l.n) {
            Some(mu) if l.tau_true.is_finite() => (-l.tau_true / mu).exp(),
            _ => 0.0,
        };
        acc = star(acc, (0.0, t, 0.0, t));
        n_above = l.n;
    }
    let mut transmits = false;
    if let (Substrate::Transparent { .. }, Some(ns)) = (scene.substrate, n_sub) {
        if ns != n_above {
            acc = star(acc, iface(n_above, ns));
        }
        transmits = true;
    }
    (acc.0, if transmits { acc.1 } else { 0.0 })
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
    let half = scene.layers.last().is_some_and(|l| l.is_half_space() && l.tau() > 0.0);
    let n_sub = match scene.substrate {
        Substrate::Transparent { n } if !half => Some(n),
        _ => None,
    };
    let mut all_n = vec![scene.ambient_n];
    all_n.extend(scene.layers.iter().map(|l| l.n));
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
    Ok(SlabSolution::build(mu, w, p, true)?.operators(extras, tms))
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
    let plan = km_core::plan::Plan::new(scene, km_core::plan::Request::from_scene(scene), false);
    let Some((i, bound)) =
        plan.layers.iter().enumerate().find_map(|(i, l)| l.cutoff_bound.map(|b| (i, b)))
    else {
        return (None, None);
    };
    let mut cut = scene.clone();
    cut.layers.truncate(i + 1);
    cut.layers[i].thickness = f64::INFINITY;
    (Some(cut), Some(bound))
}
