//! The angular engine: every exit direction of every request (a solve's
//! BRDF/BTDF directions, the whole BSDF table) from one set of augmented
//! operators per Fourier order (`docs/bsdf.md` eq. B1–B2).
//!
//! A channel is prepared once ([`Prepared`]: streams, the Snell-mapped grid,
//! the delta-M scaled layers, the plan's thick-layer cut, the corrections of
//! the peaked layers). A request names the incidences (beams by Snell
//! invariant, or diffuse light) and the exit polar angles; the engine carries
//! one probe per distinct exit polar angle and side, and per probe and
//! corrected layer the markers of the single-scattering correction, through
//! the one stack builder ([`crate::stack::add_stack`]) on operators that keep
//! the probes apart from the core ([`crate::adding::probed`]), so that the
//! cost is linear in the number of exit directions. Per polar pair it
//! returns the Fourier coefficients `c_m` and the correction weights; an
//! exit direction at azimuth `phi` is then a cosine sum (eq. B1).
//!
//! The azimuthal series stops as the request says ([`Stop`]): for a table,
//! once two orders are below `fourier_tol` of the largest order-0
//! coefficient; for a solve, once two orders are below `fourier_tol` of the
//! largest value so far at the solve's own directions (DISORT's ACCUR test).
//! Where the corrected layers give each order's once-scattered part in
//! closed form, the rule tests the rest, and the orders after the stop are
//! that closed form alone (eq. 5i–5k of docs/multiflux.md).

mod extras;
mod pieces;
mod response;
pub(crate) mod rough_paths;
mod rough_pieces;

use std::borrow::Cow;
use std::sync::Arc;

use km_core::{MonoScene, Substrate};

use crate::MultifluxError;
use crate::correction::PeakCorrection;
use crate::options::MultifluxOptions;
use crate::prepare::{media_grid, planned_cutoff, scale_layers};
use crate::quadrature::{AngularGrid, MediumNodes};
use crate::slab::{SlabOrder, slab_beam_reflection, slab_beam_response};
use crate::stack::{Scaled, delta_parts};
pub(crate) use extras::{ExtraSetup, Extras, Kind};
pub(crate) use pieces::{OrderPieces, marker_path};
pub use response::ChannelBsdf;

/// A channel prepared for the engine.
pub(crate) struct Prepared<'s> {
    /// The scene as the plan's `transmission` rule leaves it.
    pub(crate) scene: Cow<'s, MonoScene>,
    /// The bound of the light neglected by the cut (`None`: nothing cut).
    pub(crate) cutoff: Option<f64>,
    pub(crate) opts: &'s MultifluxOptions,
    pub(crate) streams: usize,
    pub(crate) grid: Arc<AngularGrid>,
    pub(crate) n_sub: Option<f64>,
    pub(crate) layers: Vec<Scaled>,
    /// The layers that carry a single-scattering correction, and the
    /// correction of each layer (`None` for the others).
    pub(crate) tms_layers: Vec<usize>,
    pub(crate) corr: Vec<Option<PeakCorrection>>,
    /// The ambient medium's nodes and, if light leaves below, the substrate's.
    pub(crate) nodes0: Arc<MediumNodes>,
    pub(crate) nodes_sub: Option<Arc<MediumNodes>>,
}

impl<'s> Prepared<'s> {
    /// Prepare `scene` at `streams` nodes per segment under `opts`.
    pub(crate) fn new(scene: &'s MonoScene, opts: &'s MultifluxOptions, streams: usize) -> Self {
        let (cut, cutoff) = planned_cutoff(scene, opts);
        let scene = cut.map_or(Cow::Borrowed(scene), Cow::Owned);
        let (n_sub, grid) = media_grid(&scene, streams);
        // Legendre moments kept (delta-M truncation at chi_{2N}, Wiscombe 1977,
        // or at chi_{3N/2} for an unresolved peak, eq. 4b).
        let layers = scale_layers(&scene, opts, streams);
        let tms_layers = corrected_layers(&scene, &layers, opts.delta_m);
        let corr = (0..layers.len())
            .map(|l| tms_layers.contains(&l).then(|| layers[l].correction()))
            .collect();
        let nodes0 = grid.shared(scene.ambient_n());
        let nodes_sub = n_sub.map(|n| grid.shared(n));
        Prepared {
            scene,
            cutoff,
            opts,
            streams,
            grid,
            n_sub,
            layers,
            tms_layers,
            corr,
            nodes0,
            nodes_sub,
        }
    }

    /// Node counts of the ambient medium and of the medium below (0 if opaque).
    pub(crate) fn exit_counts(&self) -> (usize, usize) {
        (self.nodes0.mu.len(), self.nodes_sub.as_ref().map_or(0, |n| n.mu.len()))
    }
}

/// Which layers carry a single-scattering correction: scattering ones whose
/// phase function the kept moments do not represent exactly, above the
/// first rough face (below it no beam arrives collimated, and no marker
/// passes a rough face: `rough_pieces`).
pub(crate) fn corrected_layers(scene: &MonoScene, layers: &[Scaled], delta_m: bool) -> Vec<usize> {
    if !delta_m {
        return Vec::new();
    }
    let mut n_above = scene.ambient_n();
    let first_rough = layers
        .iter()
        .position(|l| {
            let rough = l.rough.is_some() && l.n != n_above;
            n_above = l.n;
            rough
        })
        .unwrap_or(layers.len());
    (0..first_rough)
        .filter(|&l| {
            let s = &layers[l];
            s.omega > 0.0
                && s.tau > 0.0
                && !s.phase.is_isotropic()
                && !matches!(s.phase, km_core::phase::Phase::HenyeyGreenstein { g } if g == 0.0)
        })
        .collect()
}

/// The light of a request.
#[derive(Debug, Clone, Copy)]
pub(crate) enum Incidence<'a> {
    /// Collimated beams of these Snell invariants (`n0 sin theta`).
    Beams(&'a [f64]),
    /// Diffuse light of unit irradiance (order 0 only).
    Diffuse,
}

/// When the azimuthal series stops.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Stop {
    /// Two orders below `fourier_tol` of the largest order-0 coefficient.
    Table,
    /// Two orders below `fourier_tol` of the largest value so far at the
    /// request's directions.
    Values,
    /// Every order up to the last (all effects).
    Never,
}

/// The values at a solve's exit directions (smooth BRDF above, BTDF below;
/// correction included), with the order they were summed to.
pub(crate) struct DirectionValues {
    pub(crate) brdf: Vec<f64>,
    pub(crate) btdf: Vec<f64>,
}

/// A request to the engine for one prepared channel.
pub(crate) struct Request<'a> {
    pub(crate) incidence: Incidence<'a>,
    /// Exit polar angles, degrees, `[0, 90)`, distinct.
    pub(crate) theta_o: &'a [f64],
    /// Exit directions `[theta, phi]` (degrees; `theta` among `theta_o`) whose
    /// values are summed (none for a table).
    pub(crate) directions: &'a [[f64; 2]],
    /// The index in `theta_o` of each direction's polar angle.
    pub(crate) o_of: &'a [usize],
    pub(crate) stop: Stop,
    /// The last Fourier order to compute.
    pub(crate) last_order: usize,
}

impl Prepared<'_> {
    /// The response of the prepared channel to `req`: Fourier coefficients
    /// and correction weights per polar pair, totals and delta parts per
    /// incidence; with `directions` also the values there.
    ///
    /// # Errors
    /// The eigen-solves' and the adding's failures; a non-finite result.
    pub(crate) fn respond(
        &self,
        req: &Request<'_>,
    ) -> Result<(ChannelBsdf, Option<DirectionValues>), MultifluxError> {
        let beams: &[f64] = match req.incidence {
            Incidence::Beams(b) => b,
            Incidence::Diffuse => &[],
        };
        let setup = ExtraSetup {
            n0: self.scene.ambient_n(),
            n_sub: self.n_sub,
            layers: &self.layers,
            tms_layers: &self.tms_layers,
            corr: &self.corr,
            secondary: self.opts.secondary_correction,
        };
        let extras = Extras::new(beams, req.theta_o, &setup);
        let ni = beams.len().max(1);
        let mut acc = response::Accumulator::new(self, &extras, req, ni);
        // A lone layer's nodes and extra directions are those of every order;
        // its medium is the ambient one (`lone_layer`), whose nodes are kept.
        let lone = self.lone_layer(beams).map(|l| {
            let n = self.layers[l].n;
            let directions = extras.in_medium(n, extras.base_len);
            let all = extras.in_medium(n, extras.ex.len());
            LoneLayer { l, directions, all }
        });
        for m in 0..=req.last_order {
            let order = match &lone {
                Some(lone) => self.lone_order(&extras, lone, m)?,
                None => self.stack_order(&extras, m, req.last_order + 1)?,
            };
            let read = response::Readout { prep: self, order: &order, extras: &extras, ni };
            let done = acc.add_order(&read, m)?;
            if let response::Order::Lone { up, down, .. } = order {
                // The column vectors go back to the workspace (reused next order).
                crate::workspace::with_workspace(|ws| {
                    [up, down].into_iter().for_each(|v| ws.give(v))
                });
            }
            if done {
                break;
            }
        }
        acc.finish()
    }

    /// The stack's operators for order `m` on nodes, beams, probes and (at
    /// `m = 0`) markers.
    fn stack_order(
        &self,
        extras: &Extras,
        m: usize,
        orders: usize,
    ) -> Result<response::Order, MultifluxError> {
        let count = if m == 0 { extras.ex.len() } else { extras.base_len };
        let pieces = OrderPieces {
            grid: &self.grid,
            extras,
            corr: &self.corr,
            count,
            m,
            orders,
            all_effects: self.opts.all_effects,
        };
        let ops = pieces.stack(&self.scene, &self.layers, self.n_sub, self.opts.neumann_order)?;
        Ok(response::Order::Stack(Box::new(ops)))
    }

    /// A layer alone in the ambient medium under one beam (no interface,
    /// nothing below it to send light back): the layer's index when the
    /// beam's column alone answers (`slab_beam_response`). Never with all
    /// effects.
    fn lone_layer(&self, beams: &[f64]) -> Option<usize> {
        let (scene, layers) = (&self.scene, &self.layers);
        match layers.as_slice() {
            [l] if beams.len() == 1 && !self.opts.all_effects && l.n == scene.ambient_n() => {
                let floor_free = l.tau.is_infinite()
                    || match scene.substrate() {
                        Substrate::Black => true,
                        Substrate::Transparent { .. } => {
                            self.n_sub.is_none_or(|ns| ns == scene.ambient_n())
                        }
                        Substrate::Lambertian { .. } | Substrate::Conductor { .. } => false,
                    };
                floor_free.then_some(0)
            }
            _ => None,
        }
    }

    /// Order `m` of a lone layer: the beam's column on nodes and probes by
    /// vector solves, the markers' path integrals in closed form.
    fn lone_order(
        &self,
        extras: &Extras,
        lone: &LoneLayer,
        m: usize,
    ) -> Result<response::Order, MultifluxError> {
        let LoneLayer { l: li, ref directions, ref all } = *lone;
        let (l, nodes) = (&self.layers[li], &self.nodes0);
        let p = SlabOrder { tau: l.tau, omega: l.omega, chi: &l.chi, m };
        let (up, down) = if self.n_sub.is_some() {
            slab_beam_response(&nodes.mu, &nodes.w, directions, 0, &p, None)?
        } else {
            // Nothing below receives the transmitted light: reflection only.
            (slab_beam_reflection(&nodes.mu, &nodes.w, directions, 0, &p, None)?, Vec::new())
        };
        let mut markers = Vec::with_capacity(if m == 0 { extras.marker_of.len() } else { 0 });
        if m == 0 {
            for (k, &(p, ml, slot)) in extras.marker_of.iter().enumerate() {
                let x = extras.base_len + k;
                // Nothing above or below sends light back: a marker of a BRDF
                // probe sees only the path of the side the beam entered (slot
                // 0), one of a BTDF probe only the far side's (slots 1, 2).
                let same_side = p < extras.t0;
                let v = match (all[0].mu, all[x].mu) {
                    (Some(mu_b), Some(mu_x)) if ml == li && (slot == 0) == same_side => {
                        marker_path(slot, mu_b, mu_x, l, self.corr[li].as_ref())
                    }
                    _ => 0.0,
                };
                markers.push(v);
            }
        }
        Ok(response::Order::Lone { up, down, markers })
    }

    /// The delta parts (mirror reflection, unscattered transmission) of a
    /// beam of Snell invariant `s`, with the true optical thicknesses.
    pub(crate) fn delta_parts(&self, s: f64) -> (f64, f64) {
        delta_parts(&self.scene, &self.layers, self.n_sub, s)
    }
}

/// A layer alone under one beam ([`Prepared::lone_layer`]) with what every
/// Fourier order of it reads besides its nodes (the ambient medium's,
/// [`Prepared::nodes0`]): the extra directions in it (`directions`: beams
/// and probes; `all`: the markers too).
struct LoneLayer {
    l: usize,
    directions: Vec<crate::slab::Extra>,
    all: Vec<crate::slab::Extra>,
}

/// The last Fourier order of a request: 0 for totals or diffuse light; with
/// exit directions under a beam, up to the last non-negligible moment; every
/// order the streams resolve (`2N - 1`) with all effects; never above the
/// options' bound.
pub(crate) fn last_order(prep: &Prepared<'_>, angles: bool) -> usize {
    let bound = prep.opts.max_fourier_order.unwrap_or(usize::MAX);
    if prep.opts.all_effects {
        return (2 * prep.streams - 1).min(bound);
    }
    if !angles {
        return 0;
    }
    if prep.scene.has_rough_face() {
        // A rough face's lobe needs every order the streams resolve (the
        // azimuthal convergence test ends the series early).
        return (2 * prep.streams - 1).min(bound);
    }
    last_moment(&prep.layers).min(bound)
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

/// Azimuthal convergence (as DISORT's ACCUR test): after two consecutive
/// orders whose Fourier amplitudes (or their multiply scattered parts,
/// eq. 5j of docs/multiflux.md) are all below
/// [`MultifluxOptions::fourier_tol`] times the reference value (the largest
/// value so far, or the table's largest order-0 coefficient).
pub(crate) struct FourierStop {
    small_orders: usize,
    tol: f64,
}

impl FourierStop {
    /// The rule at the relative tolerance `tol` ([`MultifluxOptions::fourier_tol`]).
    pub(crate) fn new(tol: f64) -> Self {
        FourierStop { small_orders: 0, tol }
    }

    /// After an order whose largest amplitude is `term`: whether the series has converged.
    pub(crate) fn converged(&mut self, term: f64, reference: f64) -> bool {
        self.small_orders = if term <= self.tol * reference { self.small_orders + 1 } else { 0 };
        self.small_orders == 2
    }
}
