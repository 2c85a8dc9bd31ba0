//! Running a solve: the work budgets scaled by one factor, a solve repeated
//! for its timing, one shard of a Monte Carlo run (the settings that apply
//! to some methods only are in [`crate::settings::SETTINGS`]).

use km_core::{Scene, Solution};

use km_montecarlo::McOptions;

use crate::{KmError, MethodOptions, Options};

impl Options {
    /// Every default work and memory budget multiplied by `factor`: the
    /// multi-flux work (eq. W1 of docs/limits.md), the Monte Carlo photon
    /// steps and tally memory. The two-flux and dipole closed forms and the
    /// direction set (bounded by its own limits, [`crate::direction_set`])
    /// have no budget for one solve; `factor` scales what a request of many
    /// of their points may cost ([`Options::budget`]).
    ///
    /// # Errors
    /// [`KmError::Option`] named `budget` when `factor` is not finite and > 0.
    ///
    /// ```
    /// let o = km::Options::new(km::Method::Multiflux).with_budget(2.0).unwrap();
    /// let km::MethodOptions::Multiflux(m) = &o.method else { unreachable!() };
    /// assert_eq!(m.max_work, Some(2.0 * km::multiflux_budget::DEFAULT_MAX_WORK));
    /// assert!(km::Options::new(km::Method::Mc).with_budget(0.0).is_err());
    /// ```
    pub fn with_budget(mut self, factor: f64) -> Result<Options, KmError> {
        if !(factor.is_finite() && factor > 0.0) {
            return Err(KmError::Option {
                name: "budget",
                value: factor.to_string(),
                reason: "must be a finite factor > 0",
            });
        }
        self.budget = factor;
        let scale = |x: u64| (x as f64 * factor).min(u64::MAX as f64) as u64;
        match &mut self.method {
            MethodOptions::Multiflux(o) => {
                o.max_work =
                    Some(o.max_work.unwrap_or(crate::multiflux_budget::DEFAULT_MAX_WORK) * factor);
            }
            MethodOptions::Mc(o) => {
                o.max_events = o.max_events.map(scale);
                o.max_tally_bytes = scale(o.max_tally_bytes);
            }
            MethodOptions::Km(_) | MethodOptions::DirectionSet(_) | MethodOptions::Dipole(_) => {}
        }
        Ok(self)
    }
}

/// [`crate::solve`] called `repeat` times: the first call's solution, its
/// `seconds` the first (cold) call's; for `repeat > 1` its diagnostics gain
/// the timing over all calls ([`km_core::solution::RepeatedTiming`]: JSON
/// `repeat`, `seconds_best` (the least) and `seconds_median` (the median,
/// the mean of the middle two for an even count)).
///
/// # Errors
/// The first failing call's error.
pub fn solve_repeated(scene: &Scene, options: &Options, repeat: u32) -> Result<Solution, KmError> {
    let mut sol = crate::solve(scene, options)?;
    if repeat > 1 {
        // Warm calls after the first: the same answer, timed again.
        let mut times = vec![sol.seconds];
        for _ in 1..repeat {
            times.push(crate::solve(scene, options)?.seconds);
        }
        times.sort_by(f64::total_cmp);
        let mid = times.len() / 2;
        let median =
            if times.len() % 2 == 1 { times[mid] } else { 0.5 * (times[mid - 1] + times[mid]) };
        sol.diagnostics.repeated = Some(km_core::solution::RepeatedTiming {
            repeat,
            seconds_best: times[0],
            seconds_median: median,
        });
    }
    Ok(sol)
}

/// Shard `index` of `count` of a Monte Carlo run (docs/montecarlo.md): the
/// partial tally that `km_montecarlo::merge_files` combines with the others.
///
/// # Errors
/// A method other than Monte Carlo ([`KmError::Option`] named `method`);
/// the tracer's errors.
pub fn mc_shard(
    scene: &Scene,
    options: &Options,
    index: u64,
    count: u64,
) -> Result<km_montecarlo::Partial, KmError> {
    let MethodOptions::Mc(o) = &options.method else {
        return Err(KmError::Option {
            name: "method",
            value: options.method().name().into(),
            reason: "shards are parts of a Monte Carlo run",
        });
    };
    match &options.cancel {
        Some(c) if o.cancel.is_none() => {
            let o = McOptions { cancel: Some(c.clone()), ..o.clone() };
            Ok(km_montecarlo::run_shard(scene, &o, index, count)?)
        }
        _ => Ok(km_montecarlo::run_shard(scene, o, index, count)?),
    }
}
