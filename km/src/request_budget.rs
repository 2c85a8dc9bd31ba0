//! One budget for a request of many points (a sweep, a batch of scenes):
//! the points' estimated work is summed before any is solved and held to
//! the budget of one solve of the method (`docs/limits.md` §1, eq. L4), so
//! that a grid of 10^5 points is refused at once instead of running for
//! minutes.

use km_core::Scene;

use crate::{KmError, MethodOptions, Options};

/// Work units charged to every multi-flux point of `km sweep` besides its
/// eq. W1 estimate, for what eq. W1 leaves out (parsing the edited scene
/// text, planning, the row's text): 0.3 ms at 1.5 ns per unit (a sweep of
/// 10^5 points of a two-layer scene took about 60 s, 0.6 ms a point).
pub const SWEEP_POINT_OVERHEAD: f64 = 2e5;

/// Work of one two-flux point of a sweep, everything included (the edited
/// scene, the four-flux solve and its 2-4-stream model error estimate, the
/// row), in multi-flux work units of 1.5 ns: 0.69 ms of CPU per point
/// (measured: a 10^5-point `km sweep --method km` of one layer took 34.7 s
/// on 2 cores at load 8).
pub const KM_POINT_WORK: f64 = 4.6e5;

/// The same for a dipole point (its model error estimate included): 1.2 ms
/// of CPU (a 10^5-point sweep of `examples/marble-half-space.toml` over `g`
/// took 60.6 s on 2 cores).
pub const DIPOLE_POINT_WORK: f64 = 8e5;

/// Work of one direction-set solve at the paper's 303 directions: 0.57 s
/// (measured on one layer; 50 / 100 / 303 / 1000 directions took 0.012 /
/// 0.064 / 0.57 / 5.1 s, close to the square of the count above 100, the
/// scaling used for other counts).
pub const DIRECTION_SET_303_WORK: f64 = 3.8e8;

/// Multi-flux work units one Monte Carlo photon step costs, for the budget
/// of a request of many points (eq. L5 of `docs/limits.md`): a step took 28 ns
/// of CPU (4 x 10^6 photons of a two-layer scene, 3.47 x 10^7 steps in
/// 0.96 s, one thread, unloaded) against 0.7 ns a multi-flux unit unloaded.
/// A single run keeps its own step budget (`max_events`, 2 x 10^10 steps:
/// the guard of one deliberate long run); a request of many points is held
/// to the request budget every method shares (the default multi-flux work
/// budget, 7 to 25 s), that is 2.5 x 10^8 photon steps at `--budget 1`.
pub const MC_STEP_WORK: f64 = 40.0;

/// Work of one point of a request, in the units of the method's budget, and
/// that budget: multi-flux work units (eq. W1 of `km-multiflux/src/budget.rs`)
/// against `max_work`; Monte Carlo photon steps projected by the pilot of
/// eq. L2 against the request's share of steps ([`MC_STEP_WORK`], eq. L5). The methods without a budget of their own
/// (two-flux, dipole, direction set) are charged their measured cost per
/// point ([`KM_POINT_WORK`], [`DIPOLE_POINT_WORK`],
/// [`DIRECTION_SET_303_WORK`]) in multi-flux work units against the default
/// multi-flux budget times [`Options::budget`]. `None` for a Monte Carlo
/// run without a step budget.
pub fn point_work(scene: &Scene, options: &Options) -> Option<(f64, f64, &'static str)> {
    let shared = crate::multiflux_budget::DEFAULT_MAX_WORK * options.budget;
    match &options.method {
        MethodOptions::Multiflux(o) => {
            let w = km_multiflux::budget::estimate(scene, o).units;
            let budget = o.max_work.unwrap_or(crate::multiflux_budget::DEFAULT_MAX_WORK);
            Some((w, budget, "multi-flux work units"))
        }
        MethodOptions::Mc(o) => {
            // The request's share of the shared budget, in photon steps
            // (eq. L5), scaled as the run's own step budget is (by
            // `--budget`, or a library caller's `max_events`).
            let scale = o.max_events? as f64 / km_montecarlo::options::DEFAULT_MAX_EVENTS as f64;
            let budget = crate::multiflux_budget::DEFAULT_MAX_WORK / MC_STEP_WORK * scale;
            // The pilot of the run's own budget check (eq. L2); at least
            // one step per photon if the options are refused (the run then
            // reports them).
            let floor = o.samples as f64 * scene.channels().len() as f64;
            let steps = km_montecarlo::projected_steps(scene, o).unwrap_or(floor);
            Some((steps, budget, "photon steps"))
        }
        MethodOptions::Km(_) => Some((KM_POINT_WORK, shared, "multi-flux work units")),
        MethodOptions::Dipole(_) => Some((DIPOLE_POINT_WORK, shared, "multi-flux work units")),
        MethodOptions::DirectionSet(o) => {
            let d = o.directions as f64 / 303.0;
            Some((DIRECTION_SET_303_WORK * d * d, shared, "multi-flux work units"))
        }
    }
}

/// Refuse a request of `points` points like `scene` whose summed work
///
/// `W_request = points x W_point`   (eq. L4)
///
/// exceeds the budget of one solve (scaled by `--budget`), before any point
/// is solved; `overhead` is added to each multi-flux point's work
/// ([`SWEEP_POINT_OVERHEAD`] for `km sweep`). `scene` stands for every point (the points of a sweep differ in
/// values, not in structure).
///
/// # Errors
/// [`KmError::RequestTooLarge`] with the numbers.
pub fn check_points(
    scene: &Scene,
    points: usize,
    options: &Options,
    overhead: f64,
) -> Result<(), KmError> {
    let Some((work, budget, unit)) = point_work(scene, options) else {
        return Ok(());
    };
    // The overhead is the multi-flux and direction-set points' (the
    // closed forms' measured costs include it; Monte Carlo's steps dwarf it).
    let dense =
        matches!(options.method, MethodOptions::Multiflux(_) | MethodOptions::DirectionSet(_));
    let per_point = if dense { work + overhead } else { work };
    let total = per_point * points as f64;
    if points > 1 && total > budget {
        return Err(KmError::RequestTooLarge { points, per_point, total, budget, unit });
    }
    Ok(())
}
