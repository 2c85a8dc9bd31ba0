//! The multi-flux stream search planned before its expensive solves
//! (docs/planner.md, eq. E4, E5).
//!
//! **Work of the search** (eq. E4). The search of eq. E1 solves at
//! `4, 8, 16, ...` streams; reporting the answer at `N` needs every solve up
//! to its check at `2N`, so it costs
//!
//! `C(N) = sum_{k = 4, 8, ..., 2N} W(k)`                                (E4)
//!
//! in the units of eq. W1 (`km_multiflux::budget::estimate`; with a
//! truncated adding also the exact solve at each `k`). `N_max`, the largest
//! `N` with `C(N)` within the work budget, is known before anything is
//! solved.
//!
//! **Convergence forecast** (eq. E5). After the comparisons at `N/2` and `N`
//! (the cheap solves the search makes anyway), the estimate `e_k` of every
//! bounded number `k` is extrapolated to `N' = N 2^j`:
//!
//! * geometric: if it fell, `r = e_k(N) / e_k(N/2) < 1`, as fast as a
//!   Gauss quadrature can converge (exponentially in the node count, so
//!   that the ratio squares at each doubling): `e_k(N 2^j) = e_k(N)
//!   r^(2^j - 1)`;
//! * moments: the error follows the Legendre moments the `2N'` streams
//!   cannot carry (what limits a forward-peaked phase function before the
//!   quadrature resolves its peak): `e_k(N') = e_k(N) m(N') / m(N)` with
//!   `m(N) = max |chi_{2N}|` over the scattering layers of every channel
//!   (`g^{2N}` for Henyey–Greenstein), when `m(N) > 0`;
//!
//! and the forecast is the smaller of the two that apply (none: no
//! forecast). It is optimistic on purpose (the fastest convergence the
//! estimate's history and the phase function allow), so that a target is
//! refused only when even the forecast misses it at `N_max`; and it is made
//! only when the rest of the search up to `N_max` would cost more than
//! [`FORECAST_MIN_WORK`] (below that the search itself answers in about a
//! second). The refusal names the target, the number that limits it, the
//! streams it would need and the best accuracy reachable within the budget
//! (the forecast at `N_max`).

use km_core::Scene;
use km_core::phase::PhaseFunction;
use km_multiflux::MultifluxOptions;

use crate::KmError;

/// Streams of the forecast's largest step (`2^20`): beyond it the need is
/// reported as "more than".
const FORECAST_LIMIT: usize = 1 << 20;

/// Work (eq. W1 units) the rest of the search must cost for the forecast
/// to be made: `10^9`, 0.7 to 2.6 s at the calibration of eq. W1.
pub const FORECAST_MIN_WORK: f64 = 1e9;

/// The work of each level of the search and the largest `N` the budget allows (eq. E4).
#[derive(Debug, Clone)]
pub(crate) struct Schedule {
    /// `(N, C(N))`: the answer at `N` streams and the work through its check at `2N`.
    levels: Vec<(usize, f64)>,
    /// The largest `N` with `C(N) <=` budget (0 when even `N = 4` does not fit).
    pub n_max: usize,
    /// The work budget.
    pub budget: f64,
}

impl Schedule {
    /// The schedule of [`super::multiflux`] on `scene` (eq. E4), up to `max_n`.
    pub fn new(scene: &Scene, base: &MultifluxOptions, budget: f64, max_n: usize) -> Schedule {
        let work = |n: usize| {
            let at = |order| {
                let o = MultifluxOptions { streams: Some(n), neumann_order: order, ..base.clone() };
                km_multiflux::budget::estimate(scene, &o).units
            };
            let w = at(base.neumann_order);
            if base.neumann_order.is_some() { w + at(None) } else { w }
        };
        let mut total = work(4);
        let mut levels = Vec::new();
        let mut n = 4;
        while n <= max_n {
            total += work(2 * n);
            levels.push((n, total));
            n *= 2;
        }
        let n_max = levels.iter().filter(|(_, c)| *c <= budget).map(|(n, _)| *n).max();
        Schedule { levels, n_max: n_max.unwrap_or(0), budget }
    }

    /// `C(N)` of eq. E4 (0 before the schedule, its last value beyond it).
    fn cost(&self, n: usize) -> f64 {
        self.levels.iter().take_while(|(m, _)| *m <= n).last().map_or(0.0, |(_, c)| *c)
    }
}

/// `m(N)` of eq. E5: the largest `|chi_{2N}|` of any scattering layer of any channel.
fn moment_scale(scene: &Scene, n: usize) -> f64 {
    let mut m = 0.0f64;
    for ch in scene.channels() {
        for l in ch.layers().iter().filter(|l| l.sigma_s() > 0.0) {
            m = m.max(l.phase().legendre_moment(2 * n).abs());
        }
    }
    m
}

/// One bounded number's estimate at `N/2` and `N`, with its name and allowance.
#[derive(Debug, Clone)]
pub(crate) struct Tracked {
    /// Its name (as in `limited_by`).
    pub name: String,
    /// `e(N/2)`.
    pub before: f64,
    /// `e(N)`.
    pub now: f64,
    /// `tol max(1, |x|)`.
    pub allowed: f64,
    /// `max(1, |x|)`.
    pub scale: f64,
}

/// The numbers of the comparison at `N`, `(name, e, allowed, scale)`, with
/// their estimates at `N/2` from `last` (infinite at the first comparison).
pub(crate) fn track(last: Vec<Tracked>, now: Vec<(String, f64, f64, f64)>) -> Vec<Tracked> {
    now.into_iter()
        .enumerate()
        .map(|(i, (name, e, allowed, scale))| Tracked {
            before: last.get(i).map_or(f64::INFINITY, |t| t.now),
            name,
            now: e,
            allowed,
            scale,
        })
        .collect()
}

/// The forecast `e(N 2^j)` of eq. E5 for one number (`None`: no forecast).
fn extrapolate(t: &Tracked, scene: &Scene, n: usize, target_n: usize) -> Option<f64> {
    if target_n <= n {
        return Some(t.now);
    }
    let r = t.now / t.before;
    let geometric = (r.is_finite() && r < 1.0).then(|| {
        let j = (target_n / n).trailing_zeros() as i32;
        t.now * r.powf(2f64.powi(j) - 1.0)
    });
    let m = moment_scale(scene, n);
    let moments = (m > 0.0).then(|| t.now * moment_scale(scene, target_n) / m);
    // The more optimistic of the two.
    let e = match (geometric, moments) {
        (Some(a), Some(b)) => a.min(b),
        (a, b) => a.or(b)?,
    };
    Some(e.max(1e-12))
}

/// Refuse the search after its comparison at `n` when eq. E5 says no
/// number of streams within the budget (`schedule.n_max`) meets the target.
pub(crate) fn check(
    scene: &Scene,
    schedule: &Schedule,
    tol: f64,
    n: usize,
    tracked: &[Tracked],
) -> Result<(), KmError> {
    let n_max = schedule.n_max;
    if n_max <= n || schedule.cost(n_max) - schedule.cost(n) < FORECAST_MIN_WORK {
        return Ok(()); // the search itself answers soon
    }
    // The number that misses the target at n_max by the most.
    let mut worst: Option<(&Tracked, f64)> = None;
    let mut best_tol = 0.0f64;
    for t in tracked {
        let Some(e) = extrapolate(t, scene, n, n_max) else { continue };
        best_tol = best_tol.max(e / t.scale);
        if e > t.allowed && worst.is_none_or(|(_, w)| e / t.allowed > w) {
            worst = Some((t, e / t.allowed));
        }
    }
    let Some((t, _)) = worst else { return Ok(()) };
    let mut need = 2 * n_max;
    while need < FORECAST_LIMIT && extrapolate(t, scene, n, need).is_none_or(|e| e > t.allowed) {
        need *= 2;
    }
    let needed = if need >= FORECAST_LIMIT {
        format!("more than {FORECAST_LIMIT} streams")
    } else {
        format!("about {need} streams")
    };
    Err(KmError::TargetOverBudget {
        target: tol,
        limited_by: t.name.clone(),
        needed,
        basis: format!(
            "an optimistic forecast: it extrapolates the estimate {:.2e} at {n} streams ({:.2e} at {}) by eq. \
             E5 of docs/planner.md; the budget is {:.2e} multi-flux work units (--budget \
             FACTOR or max_work)",
            t.now,
            t.before,
            n / 2,
            schedule.budget
        ),
        reachable: format!("{n_max} streams"),
        best: best_tol,
    })
}
