//! The pieces of a stack for one Fourier order on nodes, beams and probes
//! (eq. PA1 of [`crate::adding::probed`]): interfaces, layers and floors as
//! [`Augmented`] operators, assembled by the one stack builder
//! [`crate::stack::add_stack`].
//!
//! Probes (exit polar angles) and markers (the single-scattering
//! correction's path integrals, eq. B1–B2 of `docs/bsdf.md`) only receive:
//! a layer gives its probes the rows of its eigen-solution (source-function
//! integration, eq. 14 of `docs/multiflux.md`) and each marker only the path
//! integral of its own layer from the beam; an interface passes every probe
//! and marker on by its own Fresnel factors (eq. F1); a Lambertian floor
//! lights the probes and none of the markers.

use faer::Mat;

use super::extras::{Extras, Kind};
use crate::MultifluxError;
use crate::adding::LayerOperators;
use crate::adding::probed::{Augmented, ProbeRows};
use crate::correction::{PeakCorrection, atten, e2, phi};
use crate::interface::{fresnel_entries, fresnel_operators};
use crate::quadrature::AngularGrid;
use crate::slab::{SlabOrder, SlabSolution, slab_augmented_kept};
use crate::stack::{LayerCuts, Scaled, StackPieces, add_stack, stack_cuts};
use crate::workspace::with_workspace;
use km_core::MonoScene;
use km_core::microfacet::Microfacet;

/// What one order's pieces are built from.
pub(crate) struct OrderPieces<'a> {
    pub(crate) grid: &'a AngularGrid,
    pub(crate) extras: &'a Extras,
    /// The corrections of the layers (markers' third slot).
    pub(crate) corr: &'a [Option<PeakCorrection>],
    /// Extras carried in this order (all of them at `m = 0`, no markers above).
    pub(crate) count: usize,
    pub(crate) m: usize,
    /// The orders the request computes (a rough face builds them at once).
    pub(crate) orders: usize,
    pub(crate) all_effects: bool,
}

impl OrderPieces<'_> {
    /// The stack's operators for this order (substrate included).
    ///
    /// # Errors
    /// Those of the eigen-solves and of the adding.
    pub(crate) fn stack(
        &self,
        scene: &MonoScene,
        layers: &[Scaled],
        n_sub: Option<f64>,
        neumann: Option<usize>,
    ) -> Result<Augmented, MultifluxError> {
        self.with_pieces(None, |p| add_stack(scene, layers, n_sub, neumann, self.all_effects, p))
    }

    /// The stack cut at both faces of every layer ([`stack_cuts`]: one
    /// top-down and one bottom-up pass of the adding over the pieces of
    /// [`OrderPieces::stack`]).
    ///
    /// # Errors
    /// Those of the eigen-solves and of the adding.
    /// `built[i]`, where given, is layer `i`'s operator (from
    /// [`OrderPieces::layer_kept`]), taken instead of building it again.
    ///
    /// # Errors
    /// Those of the eigen-solves and of the adding.
    pub(crate) fn cuts(
        &self,
        scene: &MonoScene,
        layers: &[Scaled],
        n_sub: Option<f64>,
        neumann: Option<usize>,
        built: Vec<Option<Augmented>>,
    ) -> Result<Vec<LayerCuts>, MultifluxError> {
        let built = std::cell::RefCell::new(built);
        self.with_pieces(Some(&built), |p| {
            stack_cuts(scene, layers, n_sub, neumann, self.all_effects, p)
        })
    }

    /// `f` on this order's [`StackPieces`] (layer `i` taken out of
    /// `built[i]` where given there).
    fn with_pieces<T>(
        &self,
        built: Option<&std::cell::RefCell<Vec<Option<Augmented>>>>,
        f: impl FnOnce(&StackPieces<'_>) -> T,
    ) -> T {
        let interface = |na: f64, nb: f64, rough: Option<Microfacet>| match rough {
            None => Ok(self.interface(na, nb)),
            Some(mf) => self.rough_interface(na, nb, mf),
        };
        let conductor = |na: f64, n: f64, k: f64, rough| self.conductor(na, n, k, rough);
        let layer = |i: usize, l: &Scaled| {
            let given = built.and_then(|b| b.borrow_mut().get_mut(i).and_then(Option::take));
            given.map_or_else(|| self.layer(i, l), Ok)
        };
        let floor = |n: f64, albedo: f64| self.lambertian(n, albedo);
        let pieces = StackPieces {
            interface: &interface,
            layer: &layer,
            lambertian: &floor,
            conductor: &conductor,
        };
        f(&pieces)
    }

    fn probes(&self) -> usize {
        self.count - self.extras.beams
    }

    /// The smooth interface from index `na` to `nb` (eq. F1): diagonal on
    /// the core, and each probe and marker by its own Fresnel factors.
    fn interface(&self, na: f64, nb: f64) -> Augmented {
        let (a, b) = (self.grid.shared(na), self.grid.shared(nb));
        let (ea, eb) =
            (self.extras.in_medium(na, self.count), self.extras.in_medium(nb, self.count));
        let nbeam = self.extras.beams;
        let core = fresnel_operators(&a, &b, &ea[..nbeam], &eb[..nbeam]);
        let (ca, cb) = (a.mu.len() + nbeam, b.mu.len() + nbeam);
        let mut probes = ProbeRows::zeros(self.probes(), ca, cb);
        for e in nbeam..self.count {
            let f = fresnel_entries(ea[e].mu, eb[e].mu, na, nb, true);
            for (d, v) in probes.diag.iter_mut().zip(f) {
                d[e - nbeam] = v;
            }
        }
        Augmented { core, probes }
    }

    /// One layer (eq. S1–S6): its eigen-solution on the nodes, beams and
    /// probes, then the markers of this layer (their path integrals from each
    /// beam) and the attenuation of every marker's direction.
    fn layer(&self, li: usize, l: &Scaled) -> Result<Augmented, MultifluxError> {
        let (aug, sol) = self.layer_kept(li, l)?;
        if let Some(s) = sol {
            with_workspace(|ws| s.recycle(ws));
        }
        Ok(aug)
    }

    /// [`OrderPieces::layer`] with the eigen-solution it was computed from
    /// (`None` for the Beer–Lambert shortcut), kept for the field inside.
    ///
    /// # Errors
    /// Those of the eigen-solve.
    pub(crate) fn layer_kept(
        &self,
        li: usize,
        l: &Scaled,
    ) -> Result<(Augmented, Option<SlabSolution>), MultifluxError> {
        let (ex, nodes) = (self.extras, self.grid.shared(l.n));
        let directions = ex.in_medium(l.n, self.count);
        let base = ex.base_len.min(self.count);
        let p = SlabOrder { tau: l.tau, omega: l.omega, chi: &l.chi, m: self.m };
        // With all effects every layer of finite positive thickness is
        // eigen-solved (the plan's `scattering` rule lives in `slab_augmented`).
        let (mut aug, sol) = slab_augmented_kept(
            &nodes.mu,
            &nodes.w,
            &directions[..base],
            ex.beams,
            &p,
            self.all_effects,
        )?;
        if self.count > base {
            self.add_markers(&mut aug, li, l, &directions, nodes.mu.len());
        }
        Ok((aug, sol))
    }

    /// Append the marker rows to a layer's probe part: zero but for this
    /// layer's markers in the beam columns (unit `F` of eq. B1), and the
    /// attenuation of each marker's direction on its diagonal.
    fn add_markers(
        &self,
        aug: &mut Augmented,
        li: usize,
        l: &Scaled,
        directions: &[crate::slab::Extra],
        nn: usize,
    ) {
        let ex = self.extras;
        let (base, nbeam) = (ex.base_len, ex.beams);
        let pr = &mut aug.probes;
        let grow =
            |m: &Mat<f64>| {
                Mat::from_fn(self.count - nbeam, m.ncols(), |i, j| {
                    if i < m.nrows() { m[(i, j)] } else { 0.0 }
                })
            };
        let [r_top, t_down, r_bottom, t_up] =
            [&pr.r_top, &pr.t_down, &pr.r_bottom, &pr.t_up].map(grow);
        (pr.r_top, pr.t_down, pr.r_bottom, pr.t_up) = (r_top, t_down, r_bottom, t_up);
        for d in pr.diag.iter_mut() {
            d.resize(self.count - nbeam, 0.0);
        }
        for x in base..self.count {
            let Some(mu_x) = directions[x].mu else { continue };
            let t = atten(l.tau, mu_x);
            pr.diag[1][x - nbeam] = t;
            pr.diag[3][x - nbeam] = t;
            let Kind::Marker { l: ml, slot } = ex.ex[x].1 else { continue };
            if ml != li {
                continue;
            }
            for b in 0..nbeam {
                let Some(mu_b) = directions[b].mu else { continue };
                let v = marker_path(slot, mu_b, mu_x, l, self.corr[li].as_ref());
                let (row, col) = (x - nbeam, nn + b);
                if slot == 0 {
                    pr.r_top[(row, col)] = v;
                    pr.r_bottom[(row, col)] = v;
                } else {
                    pr.t_down[(row, col)] = v;
                    pr.t_up[(row, col)] = v;
                }
            }
        }
    }

    /// A Lambertian floor of `albedo` under index `n` (eq. F2): its
    /// reflection of the core, the probes lit by it, the markers dark.
    fn lambertian(&self, n: f64, albedo: f64) -> Augmented {
        let nodes = self.grid.shared(n);
        let ex = self.extras;
        let directions = ex.in_medium(n, self.count);
        let (nn, nbeam) = (nodes.mu.len(), ex.beams);
        let dim = nn + nbeam;
        // Flux weight of each incoming component (order 0 only).
        let lit = self.m == 0 && albedo != 0.0;
        let col: Vec<f64> = (0..dim)
            .map(|j| match (lit, j < nn) {
                (false, _) => 0.0,
                (true, true) => albedo * 2.0 * nodes.w[j] * nodes.mu[j],
                (true, false) if directions[j - nn].mu.is_some() => albedo / std::f64::consts::PI,
                (true, false) => 0.0,
            })
            .collect();
        // Out-going radiance into every node and present probe (not a beam).
        let r_top = Mat::from_fn(dim, dim, |i, j| if i < nn { col[j] } else { 0.0 });
        let core = LayerOperators {
            r_top,
            t_down: Mat::zeros(0, dim),
            r_bottom: Mat::zeros(0, 0),
            t_up: Mat::zeros(dim, 0),
        };
        let mut probes = ProbeRows::zeros(self.probes(), dim, 0);
        for e in nbeam..ex.base_len.min(self.count) {
            if directions[e].mu.is_some() {
                for j in 0..dim {
                    probes.r_top[(e - nbeam, j)] = col[j];
                }
            }
        }
        Augmented { core, probes }
    }
}

/// A marker's path integral in its layer for a beam of cosine `mu_b` and an
/// exit of cosine `mu_x` (eq. B1–B2 of `docs/bsdf.md`): `beta phi(1/mu_b +
/// beta, tau)` on the side the beam entered (slot 0), `beta E2(1/mu_b, beta,
/// tau)` on the far side (slot 1), the IMS path factor at the unscaled
/// thickness (slot 2), `beta = 1/mu_x`.
pub(crate) fn marker_path(
    slot: usize,
    mu_b: f64,
    mu_x: f64,
    l: &Scaled,
    corr: Option<&PeakCorrection>,
) -> f64 {
    let (beta, kb) = (1.0 / mu_x, 1.0 / mu_b);
    match slot {
        0 => beta * phi(kb + beta, l.tau),
        1 => beta * e2(kb, beta, l.tau),
        // Eq. B2: as the correction's `PeakCorrection::radiance`.
        _ => {
            corr.map_or(0.0, |c| c.secondary_path(mu_b, mu_x, l.tau / (1.0 - l.omega_true * c.f())))
        }
    }
}
