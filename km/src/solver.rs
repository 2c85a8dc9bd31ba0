//! One solver interface over the five methods: [`Solver`], implemented by
//! each method's own option type, and [`Options`], what [`crate::solve`] takes.

use std::time::Instant;

use km_core::two_flux::KmOptions;
use km_core::{Scene, Solution};
use km_dipole::DipoleOptions;
use km_montecarlo::McOptions;
use km_multiflux::MultifluxOptions;
use rayon::prelude::*;

use crate::direction_set::DirectionSetOptions;
use crate::error::{KmError, Reason, Unsupported};
use crate::{Method, accuracy};

/// A method at its settings: what it can treat and how it solves.
///
/// Implemented by each method's option type ([`KmOptions`],
/// [`MultifluxOptions`], [`DirectionSetOptions`], [`McOptions`],
/// [`DipoleOptions`]) and by
/// [`MethodOptions`]. [`Solver::solve_unplanned`] is the bare solver (no plan applied
/// from outside, no channel merging, no thick-layer cut): [`crate::solve`]
/// adds those.
pub trait Solver {
    /// The method.
    fn method(&self) -> Method;

    /// Whether the method can treat `scene`, and if not, why.
    ///
    /// # Errors
    /// [`Unsupported`] with the reason, in the library's words.
    fn supports(&self, scene: &Scene) -> Result<(), Unsupported> {
        let _ = scene;
        Ok(())
    }

    /// Solve `scene` at these settings as it is: no plan applied from
    /// outside, no channel merging, no thick-layer cut, no capability check
    /// ([`crate::solve`] does those and is what a user calls; this is the
    /// method's own step, for benchmarks and for the front ends' internals).
    ///
    /// # Errors
    /// The solver's refusal or failure.
    fn solve_unplanned(&self, scene: &Scene) -> Result<Solution, KmError>;

    /// Solve `scene` to the accuracy target `tol` (docs/planner.md, eq. E1
    /// and E2): the method's setting is chosen so that every number asked for
    /// meets `e <= tol * max(1, |x|)`.
    ///
    /// # Errors
    /// [`KmError::NoAccuracySetting`] for the closed forms,
    /// [`KmError::TargetUnreachable`] when the allowed work does not suffice.
    fn solve_unplanned_to(&self, scene: &Scene, tol: f64) -> Result<Solution, KmError> {
        let _ = scene;
        Err(KmError::NoAccuracySetting { method: self.method(), target: tol })
    }
}

impl Solver for KmOptions {
    fn method(&self) -> Method {
        Method::Km
    }
    fn solve_unplanned(&self, scene: &Scene) -> Result<Solution, KmError> {
        Ok(km_core::two_flux::solve(scene, self)?)
    }
}

/// Scenes with at least this many channels have them solved on all cores
/// (below it the thread pool's start costs more than it saves).
const PARALLEL_CHANNELS: usize = 4;

impl Solver for MultifluxOptions {
    fn method(&self) -> Method {
        Method::Multiflux
    }
    /// The channels of a scene with at least four of them
    /// are solved on all cores (rayon); each channel is computed alone, and
    /// the parts are assembled in channel order, so the result is
    /// bit-identical to the serial [`km_multiflux::solve`] (the first
    /// failing channel's error is the one returned, as there).
    fn solve_unplanned(&self, scene: &Scene) -> Result<Solution, KmError> {
        if scene.channels().len() < PARALLEL_CHANNELS {
            return Ok(km_multiflux::solve(scene, self)?);
        }
        km_multiflux::budget::check(scene, self)?;
        let start = Instant::now();
        let parts: Vec<_> =
            scene.channels().par_iter().map(|ch| km_multiflux::solve_channel(ch, self)).collect();
        let parts = parts.into_iter().collect::<Result<Vec<_>, _>>()?;
        Ok(km_multiflux::assemble(scene, self, parts, start.elapsed().as_secs_f64()))
    }
    fn solve_unplanned_to(&self, scene: &Scene, tol: f64) -> Result<Solution, KmError> {
        accuracy::multiflux(scene, self, tol)
    }
}

impl Solver for McOptions {
    fn method(&self) -> Method {
        Method::Mc
    }
    fn solve_unplanned(&self, scene: &Scene) -> Result<Solution, KmError> {
        Ok(km_montecarlo::solve(scene, self)?)
    }
    fn solve_unplanned_to(&self, scene: &Scene, tol: f64) -> Result<Solution, KmError> {
        accuracy::monte_carlo(scene, self, tol)
    }
}

impl Solver for DipoleOptions {
    fn method(&self) -> Method {
        Method::Dipole
    }
    /// One homogeneous, semi-infinite, scattering layer (after the planner's
    /// thick-layer cut, which [`crate::solve`] applies first).
    fn supports(&self, scene: &Scene) -> Result<(), Unsupported> {
        let no = |reason| Err(Unsupported { method: Method::Dipole, reason });
        for (channel, c) in scene.channels().iter().enumerate() {
            if c.layers().len() != 1 {
                return no(Reason::Stack { layers: c.layers().len() });
            }
            let l = &c.layers()[0];
            if !l.is_half_space() {
                return no(Reason::FiniteLayer { tau: l.tau() });
            }
            if l.sigma_s() <= 0.0 {
                return no(Reason::NoScattering { channel });
            }
        }
        Ok(())
    }
    fn solve_unplanned(&self, scene: &Scene) -> Result<Solution, KmError> {
        Ok(km_dipole::solve(scene, self)?)
    }
}

/// The settings of one method.
#[derive(Debug, Clone)]
pub enum MethodOptions {
    /// Two-flux Kubelka–Munk.
    Km(KmOptions),
    /// Multi-flux.
    Multiflux(MultifluxOptions),
    /// Multi-flux on a direction set.
    DirectionSet(DirectionSetOptions),
    /// Monte Carlo.
    Mc(McOptions),
    /// Diffusion dipole.
    Dipole(DipoleOptions),
}

impl MethodOptions {
    /// The default settings of `method`.
    pub fn new(method: Method) -> MethodOptions {
        match method {
            Method::Km => MethodOptions::Km(KmOptions::default()),
            Method::Multiflux => MethodOptions::Multiflux(MultifluxOptions::default()),
            Method::DirectionSet => MethodOptions::DirectionSet(DirectionSetOptions::default()),
            Method::Mc => MethodOptions::Mc(McOptions::default()),
            Method::Dipole => MethodOptions::Dipole(DipoleOptions::default()),
        }
    }

    fn solver(&self) -> &dyn Solver {
        match self {
            MethodOptions::Km(o) => o,
            MethodOptions::Multiflux(o) => o,
            MethodOptions::DirectionSet(o) => o,
            MethodOptions::Mc(o) => o,
            MethodOptions::Dipole(o) => o,
        }
    }

    /// Whether the method's own settings switch the planner off.
    pub fn all_effects(&self) -> bool {
        match self {
            MethodOptions::Multiflux(m) => m.all_effects,
            MethodOptions::Mc(m) => m.all_effects,
            MethodOptions::Km(_) | MethodOptions::DirectionSet(_) | MethodOptions::Dipole(_) => {
                false
            }
        }
    }

    /// The same settings with the planner switched on or off (`all_effects`).
    pub(crate) fn with_all_effects(&self, all_effects: bool) -> MethodOptions {
        let mut o = self.clone();
        match &mut o {
            MethodOptions::Multiflux(m) => m.all_effects = all_effects,
            MethodOptions::Mc(m) => m.all_effects = all_effects,
            MethodOptions::Km(_) | MethodOptions::DirectionSet(_) | MethodOptions::Dipole(_) => {}
        }
        o
    }
}

impl Solver for MethodOptions {
    fn method(&self) -> Method {
        self.solver().method()
    }
    fn supports(&self, scene: &Scene) -> Result<(), Unsupported> {
        self.solver().supports(scene)
    }
    fn solve_unplanned(&self, scene: &Scene) -> Result<Solution, KmError> {
        self.solver().solve_unplanned(scene)
    }
    fn solve_unplanned_to(&self, scene: &Scene, tol: f64) -> Result<Solution, KmError> {
        self.solver().solve_unplanned_to(scene, tol)
    }
}

/// What [`crate::solve`] takes: a method at its settings, an optional
/// accuracy target, and whether the planner is off.
///
/// ```
/// use km::{Method, Options};
/// let o = Options::new(Method::Multiflux).with_tolerance(1e-4);
/// assert_eq!(o.method(), Method::Multiflux);
/// let mc = Options::from(km::McOptions { samples: 10_000, seed: 3, ..Default::default() });
/// assert_eq!(mc.method(), Method::Mc);
/// ```
#[derive(Debug, Clone)]
pub struct Options {
    /// The method and its settings.
    pub method: MethodOptions,
    /// Accuracy target `tol`: every number asked for within `tol * max(1, |x|)`
    /// (eq. E1, E2 of docs/planner.md); the method's setting is then chosen.
    pub tolerance: Option<f64>,
    /// Switch the planner off: compute every effect (for comparison).
    pub all_effects: bool,
    /// Cone half-angle, degrees, of the BRDF/BTDF values: Monte Carlo's
    /// bins, or the multi-flux values averaged over the same cones
    /// ([`crate::cone`]); `None`: Monte Carlo's default bins, multi-flux
    /// values at the directions themselves.
    pub cone_deg: Option<f64>,
    /// Factor on the default budgets (`--budget`; 1 by default), set by
    /// [`Options::with_budget`]: the methods with a work budget have theirs
    /// scaled there; a request of many points of the methods without one
    /// (two-flux, dipole, direction set) is held to the default multi-flux
    /// budget times this factor ([`crate::request_budget`]).
    pub budget: f64,
    /// A flag that stops the work under way when raised ([`km_core::Cancel`]):
    /// [`crate::solve`] reads it before it starts and hands it to the Monte
    /// Carlo tracer (between batches and every
    /// [`km_montecarlo::CANCEL_CHECK_PHOTONS`] photons), so a sweep or a
    /// repeated solve stops before its next point; the call then returns
    /// [`KmError::Cancelled`] (or the tracer's `Cancelled`; see
    /// [`KmError::is_cancelled`]). A multi-flux, two-flux, dipole or
    /// direction-set solve is not stopped within: its work budget bounds it.
    pub cancel: Option<km_core::Cancel>,
}

impl Options {
    /// The default settings of `method`, no accuracy target, planner on.
    pub fn new(method: Method) -> Options {
        MethodOptions::new(method).into()
    }

    /// The method.
    pub fn method(&self) -> Method {
        self.method.method()
    }

    /// With an accuracy target.
    pub fn with_tolerance(mut self, tol: f64) -> Options {
        self.tolerance = Some(tol);
        self
    }

    /// With the planner off (`true`) or on.
    pub fn with_all_effects(mut self, all_effects: bool) -> Options {
        self.all_effects = all_effects;
        self
    }

    /// With a cancel flag ([`Options::cancel`]).
    pub fn with_cancel(mut self, cancel: km_core::Cancel) -> Options {
        self.cancel = Some(cancel);
        self
    }

    /// With BRDF/BTDF values that are means over cones of half-angle
    /// `deg` degrees (Monte Carlo, multi-flux; docs/montecarlo.md §6).
    pub fn with_cone(mut self, deg: f64) -> Options {
        self.cone_deg = Some(deg);
        self
    }
}

impl From<MethodOptions> for Options {
    fn from(method: MethodOptions) -> Options {
        Options {
            method,
            tolerance: None,
            all_effects: false,
            cone_deg: None,
            budget: 1.0,
            cancel: None,
        }
    }
}

macro_rules! from_options {
    ($t:ty, $v:ident) => {
        impl From<$t> for Options {
            fn from(o: $t) -> Options {
                MethodOptions::$v(o).into()
            }
        }
    };
}
from_options!(KmOptions, Km);
from_options!(MultifluxOptions, Multiflux);
from_options!(DirectionSetOptions, DirectionSet);
from_options!(McOptions, Mc);
from_options!(DipoleOptions, Dipole);
