//! Accuracy targets: the method's setting chosen so that every number the
//! scene asks for is within the target (docs/planner.md, eq. E1–E3).
//!
//! **What is bounded** (eq. E3): every number of every channel that the
//! scene asks for: reflectance, transmittance, their delta parts
//! (`reflectance_specular`, `transmittance_direct`) and, when the scene has
//! output directions, each BRDF and BTDF value. A number `x` with error
//! estimate `e` meets the target `tol` when
//!
//! `e <= tol * max(1, |x|)`                                            (E3)
//!
//! i.e. an absolute bound for the totals (which lie in `[0, 1]`) and for
//! BRDF/BTDF values up to 1/sr, a relative one for larger (peaked) values.
//! The number with the largest `e / (tol max(1, |x|))` is reported as the
//! one that limited the choice ([`km_core::solution::AccuracyReport`]). A
//! target the allowed work cannot meet is an error
//! ([`KmError::TargetUnreachable`]), never a quiet miss.
//!
//! **Multi-flux** (eq. E1): solve at `N` and `2N` streams per hemisphere for
//! `N = 4, 8, 16, ...` and report the answer at `N` with the estimate
//!
//! `e_N = 2 |X_N - X_2N| + 1e-12`                                      (E1)
//!
//! Since `|e_N| <= |X_N - X_2N| + |e_2N|`, (E1) bounds the true error
//! whenever one doubling at least halves the error (double-Gauss
//! quadratures converge much faster for smooth fields, and at least like
//! `N^-2` across the kinks that total internal reflection puts in the
//! angular distribution). The first `N` meeting (E3) is taken, up to
//! `N = MAX_STREAMS / 2`. A truncated adding (`neumann_order`) adds its own
//! difference from the exact adding at that `N`. The premise is checked
//! (E1a): no bounded number's difference may have grown from the doubling
//! `N/2 -> N` to `N -> 2N` (unless it is below a thousandth of its
//! allowance), which catches the plateau a forward peak shows before enough
//! streams resolve it; the search therefore starts with a solve at 2 streams.
//!
//! **Monte Carlo** (eq. E2): a pilot run of `10^4` photons gives the
//! per-photon standard deviation `s_k` of every bounded tally `k`; the run
//! then takes `n = max_k ceil((3 s_k / (tol max(1, |x_k|)))^2)` photons and
//! reports
//!
//! `e_k = max(3 * stderr_k, 3 / (n w_k))`                              (E2)
//!
//! i.e. a 99.7 % confidence bound for a normally distributed mean, and the
//! "rule of three" 95 % bound for a tally that saw no photon at all (`w_k` =
//! 1 for totals, the cone's solid angle times the cosine of the direction for
//! a BRDF/BTDF value). Runs that would need more than [`MAX_PHOTONS`] photons
//! are refused with their expected cost.

use km_core::solution::AccuracyReport;
use km_core::{ChannelResult, Scene, Solution, Uncertainty};
use km_montecarlo::McOptions;
use km_multiflux::MultifluxOptions;

use crate::KmError;

mod forecast;

/// Largest stream count tried by [`multiflux`] (the check run's).
pub const MAX_STREAMS: usize = 256;

/// Largest Monte Carlo run [`monte_carlo`] accepts.
pub const MAX_PHOTONS: u64 = 10_000_000_000;

/// Photons of the Monte Carlo pilot run.
pub const PILOT_PHOTONS: u64 = 10_000;

fn check_target(tol: f64) -> Result<(), KmError> {
    if !tol.is_finite() || tol <= 0.0 || tol >= 1.0 {
        return Err(KmError::Option {
            name: "accuracy target",
            value: tol.to_string(),
            reason: "must lie in (0, 1)",
        });
    }
    Ok(())
}

/// The bounded numbers of one channel, by name: `(name, value)`.
fn bounded(c: &ChannelResult) -> Vec<(String, f64)> {
    let mut v = vec![
        ("reflectance".to_string(), c.reflectance),
        ("reflectance_specular".to_string(), c.reflectance_specular),
        ("transmittance".to_string(), c.transmittance),
        ("transmittance_direct".to_string(), c.transmittance_direct),
    ];
    v.extend(c.brdf.iter().enumerate().map(|(i, &x)| (format!("brdf[{i}]"), x)));
    v.extend(c.btdf.iter().enumerate().map(|(i, &x)| (format!("btdf[{i}]"), x)));
    v
}

/// The allowance of eq. E3 for a number `x`.
fn allowed(tol: f64, x: f64) -> f64 {
    tol * x.abs().max(1.0)
}

/// The worst number over channels: `(ratio e / allowed, name, e, allowed)`.
#[derive(Debug, Clone, Default)]
struct Worst {
    ratio: f64,
    name: String,
    estimate: f64,
    allowed: f64,
}

impl Worst {
    fn consider(&mut self, name: String, e: f64, allowed: f64) {
        let ratio = e / allowed;
        if ratio > self.ratio || self.name.is_empty() {
            *self = Worst { ratio, name, estimate: e, allowed };
        }
    }
}

fn with_channel(name: &str, labels: &[String], c: usize) -> String {
    if labels.len() > 1 { format!("{name} (channel {})", labels[c]) } else { name.to_string() }
}

/// The [`Uncertainty`] of one channel from per-number estimates in the order of [`bounded`].
fn to_uncertainty(c: &ChannelResult, e: &[f64]) -> Uncertainty {
    let nb = c.brdf.len();
    let brdf = e[4..4 + nb].to_vec();
    let btdf = e[4 + nb..].to_vec();
    let max = |v: &[f64]| v.iter().copied().fold(0.0, f64::max);
    Uncertainty {
        reflectance: Some(e[0]),
        reflectance_specular: Some(e[1]),
        transmittance: Some(e[2]),
        transmittance_direct: Some(e[3]),
        brdf_max: (!c.brdf.is_empty()).then(|| max(&brdf)),
        btdf_max: (!c.btdf.is_empty()).then(|| max(&btdf)),
        brdf: (!c.brdf.is_empty()).then_some(brdf),
        btdf: (!c.btdf.is_empty()).then_some(btdf),
        ..Default::default()
    }
}

/// The estimates of eq. E1, number by number, channel by channel.
fn e1(coarse: &Solution, fine: &Solution) -> Vec<Vec<f64>> {
    coarse
        .channels
        .iter()
        .zip(&fine.channels)
        .map(|(c, f)| {
            bounded(c)
                .iter()
                .zip(bounded(f))
                .map(|((_, x), (_, y))| 2.0 * (x - y).abs() + 1e-12)
                .collect()
        })
        .collect()
}

/// The worst number against the target (eq. E3), and every number as
/// `(name, estimate, allowed, max(1, |x|))` for the forecast (eq. E5).
#[allow(clippy::type_complexity)]
fn judge(
    sol: &Solution,
    estimates: &[Vec<f64>],
    tol: f64,
) -> (Worst, Vec<(String, f64, f64, f64)>) {
    let mut worst = Worst::default();
    let mut all = Vec::new();
    for (ch, (c, e)) in sol.channels.iter().zip(estimates).enumerate() {
        for ((name, x), &ei) in bounded(c).into_iter().zip(e) {
            let name = with_channel(&name, &sol.labels, ch);
            worst.consider(name.clone(), ei, allowed(tol, x));
            all.push((name, ei, allowed(tol, x), x.abs().max(1.0)));
        }
    }
    (worst, all)
}

/// Fraction of a number's allowance (E3) below which a difference counts
/// as settled whatever the one before it (E1a): rounding, not convergence.
const SETTLED: f64 = 1e-3;

/// Eq. E1a: the first bounded number whose difference grew from the
/// doubling `N/2 -> N` to `N -> 2N` while above [`SETTLED`] of its
/// allowance, as a [`Worst`] over the target (ratio > 1 whatever its E1
/// estimate), or `None`.
fn growing(before: &Solution, coarse: &Solution, fine: &Solution, tol: f64) -> Option<Worst> {
    for (ch, ((b, c), f)) in
        before.channels.iter().zip(&coarse.channels).zip(&fine.channels).enumerate()
    {
        for (((name, xb), (_, xc)), (_, xf)) in
            bounded(b).into_iter().zip(bounded(c)).zip(bounded(f))
        {
            let (was, now) = ((xb - xc).abs(), (xc - xf).abs());
            let a = allowed(tol, xc);
            if now > was && now > SETTLED * a {
                let name = format!(
                    "{} (its difference grew from {was:.1e} to {now:.1e} at the last doubling, \
                     eq. E1a)",
                    with_channel(&name, &coarse.labels, ch)
                );
                // Over the target by construction: E1 is no bound here.
                let ratio = ((2.0 * now + 1e-12) / a).max(1.0 + f64::EPSILON.sqrt());
                return Some(Worst { ratio, name, estimate: 2.0 * now + 1e-12, allowed: a });
            }
        }
    }
    None
}

/// The azimuthal tolerance of a search to the target `TOL` is at least this
/// times `TOL` (`MultifluxOptions::fourier_tol`, docs/multiflux.md eq. 5j):
/// the series' error stayed within `fourier_tol` of the largest value in the
/// tests, so a thousandth of the target leaves the target to the streams.
pub const FOURIER_TOL_OF_TARGET: f64 = 1e-3;

/// Multi-flux to an accuracy target (eq. E1, E1a, E3); the azimuthal
/// series of every solve stops at `max(fourier_tol, 1e-3 TOL)`
/// ([`FOURIER_TOL_OF_TARGET`]).
///
/// # Errors
/// A target outside `(0, 1)`, streams given together with a target, a
/// target not met at [`MAX_STREAMS`] / 2 streams, and the solver's errors.
///
/// ```
/// let s = km_core::Scene::from_toml_str("[[layer]]\ntau = 1\nalbedo = 0.9\n").unwrap();
/// let sol = km::accuracy::multiflux(&s, &Default::default(), 1e-5).unwrap();
/// assert!(sol.channels[0].error_estimate.as_ref().unwrap().get("reflectance").unwrap() <= 1e-5);
/// assert!(km::accuracy::multiflux(&s, &Default::default(), 1e-13).is_err());
/// ```
pub fn multiflux(scene: &Scene, base: &MultifluxOptions, tol: f64) -> Result<Solution, KmError> {
    check_target(tol)?;
    if let Some(n) = base.streams {
        return Err(KmError::Option {
            name: "streams",
            value: n.to_string(),
            reason: "an accuracy target chooses the streams: leave them unset",
        });
    }
    // One work budget for the whole search (eq. W1, docs/limits.md): each
    // solve may spend only what the earlier ones left.
    let budget = base.max_work.unwrap_or(km_multiflux::budget::DEFAULT_MAX_WORK);
    let spent = std::cell::Cell::new(0.0f64);
    let at = |n: usize, order: Option<usize>| {
        let left = (budget - spent.get()).max(f64::MIN_POSITIVE);
        let opts = MultifluxOptions {
            streams: Some(n),
            neumann_order: order,
            max_work: Some(left),
            fourier_tol: base.fourier_tol.max(FOURIER_TOL_OF_TARGET * tol),
            ..base.clone()
        };
        let sol = km_multiflux::solve(scene, &opts)?;
        spent.set(spent.get() + km_multiflux::budget::estimate(scene, &opts).units);
        Ok::<_, km_multiflux::MultifluxError>(sol)
    };
    // The search's work level by level (eq. E4), known before any solve.
    let schedule = forecast::Schedule::new(scene, base, budget, MAX_STREAMS / 2);
    let mut tracked: Vec<forecast::Tracked> = Vec::new();
    let mut seconds = 0.0;
    let mut n = 4;
    // The level below the first comparison, for the contraction test (E1a).
    let mut before = at(n / 2, base.neumann_order)?;
    seconds += before.seconds;
    let mut coarse = at(n, base.neumann_order)?;
    seconds += coarse.seconds;
    // The last comparison's worst number, reported if the budget stops the search.
    let mut last: Option<(Worst, usize)> = None;
    loop {
        let fine = match (at(2 * n, base.neumann_order), last.take()) {
            (Err(km_multiflux::MultifluxError::TooExpensive { .. }), Some((worst, m))) => {
                return Err(budget_stopped(worst, m, tol));
            }
            (r, _) => r?,
        };
        seconds += fine.seconds;
        let mut estimates = e1(&coarse, &fine);
        // Truncated adding: add its own difference from the exact adding.
        if base.neumann_order.is_some() {
            let exact = at(n, None)?;
            seconds += exact.seconds;
            add_truncation(&mut estimates, &coarse, &exact);
        }
        let (mut worst, now) = judge(&coarse, &estimates, tol);
        // Eq. E1a: a difference that grew from one doubling to the next is
        // no bound yet (the plateau before a forward peak is resolved).
        if worst.ratio <= 1.0
            && let Some(u) = growing(&before, &coarse, &fine, tol)
        {
            worst = u;
        }
        if worst.ratio <= 1.0 {
            return Ok(reached(coarse, &estimates, worst, tol, n, seconds));
        }
        if 2 * n >= MAX_STREAMS {
            return Err(KmError::TargetUnreachable {
                target: tol,
                limited_by: worst.name,
                estimate: worst.estimate,
                allowed: worst.allowed,
                work: format!("{n} streams (checked at {})", 2 * n),
            });
        }
        // Eq. E5: refuse before the expensive solves when no stream count
        // within the budget is forecast to meet the target.
        tracked = forecast::track(tracked, now);
        if tracked.iter().all(|t| t.before.is_finite()) {
            forecast::check(scene, &schedule, tol, n, &tracked)?;
        }
        last = Some((worst, n));
        n *= 2;
        before = std::mem::replace(&mut coarse, fine);
    }
}

/// The refusal when the work budget stops the search after the comparison
/// of `m` with `2 m` streams (`worst`: that comparison's worst number).
fn budget_stopped(worst: Worst, m: usize, tol: f64) -> KmError {
    KmError::TargetUnreachable {
        target: tol,
        limited_by: worst.name,
        estimate: worst.estimate,
        allowed: worst.allowed,
        work: format!(
            "{m} streams (checked at {}; {} would exceed the work budget, \
             --budget or max_work)",
            2 * m,
            4 * m
        ),
    }
}

/// Truncated adding: adds to each estimate its own difference from the
/// exact adding (`exact`, at the same streams as `coarse`).
fn add_truncation(estimates: &mut [Vec<f64>], coarse: &Solution, exact: &Solution) {
    for (e, (c, x)) in estimates.iter_mut().zip(coarse.channels.iter().zip(&exact.channels)) {
        for (ei, ((_, a), (_, b))) in e.iter_mut().zip(bounded(c).iter().zip(bounded(x))) {
            *ei += (a - b).abs();
        }
    }
}

/// The search's answer once the target is met at `n` streams: `coarse` with
/// its error estimates, the total seconds and the accuracy report.
fn reached(
    mut coarse: Solution,
    estimates: &[Vec<f64>],
    worst: Worst,
    tol: f64,
    n: usize,
    seconds: f64,
) -> Solution {
    for (c, e) in coarse.channels.iter_mut().zip(estimates) {
        c.error_estimate = Some(to_uncertainty(c, e));
    }
    coarse.seconds = seconds;
    coarse.accuracy = Some(AccuracyReport {
        target: tol,
        reached: true,
        limited_by: worst.name,
        estimate: worst.estimate,
        rule: "2 |X_N - X_2N| <= tol max(1, |X|), |X_N - X_2N| <= |X_N/2 - X_N| \
               (docs/planner.md, eq. E1, E1a, E3)"
            .into(),
        work: vec![("streams".into(), n as u64), ("check_streams".into(), 2 * n as u64)],
    });
    coarse
}

/// Per-photon weights `w_k` of the rule of three (eq. E2), in the order of [`bounded`].
fn photon_weights(c: &ChannelResult, scene: &Scene, opts: &McOptions) -> Vec<f64> {
    let h = opts.bin_half_angle_deg.to_radians();
    let cone = 2.0 * std::f64::consts::PI * (1.0 - h.cos());
    let dirs = scene.channels()[0].directions_deg();
    let w = |i: usize| {
        let theta = dirs.get(i).map_or(0.0, |d| d[0]).to_radians();
        cone * theta.cos().abs().max(1e-3)
    };
    let mut v = vec![1.0; 4];
    v.extend((0..c.brdf.len()).map(w));
    v.extend((0..c.btdf.len()).map(w));
    v
}

/// Standard errors in the order of [`bounded`].
fn stderrs(c: &ChannelResult) -> Vec<f64> {
    let se = c.stderr.clone().unwrap_or_default();
    let mut v: Vec<f64> =
        ["reflectance", "reflectance_specular", "transmittance", "transmittance_direct"]
            .iter()
            .map(|k| se.get(k).unwrap_or(0.0))
            .collect();
    v.extend(se.brdf.clone().unwrap_or_else(|| vec![0.0; c.brdf.len()]));
    v.extend(se.btdf.clone().unwrap_or_else(|| vec![0.0; c.btdf.len()]));
    v
}

/// Monte Carlo to an accuracy target (eq. E2, E3).
///
/// # Errors
/// A target outside `(0, 1)`, a run that would need more than
/// [`MAX_PHOTONS`] photons or misses the target after three sizings, and the
/// tracer's errors.
pub fn monte_carlo(scene: &Scene, base: &McOptions, tol: f64) -> Result<Solution, KmError> {
    check_target(tol)?;
    let pilot_opts = McOptions {
        samples: PILOT_PHOTONS,
        seed: base.seed ^ 0x9e37_79b9_7f4a_7c15,
        progress: None,
        ..base.clone()
    };
    let pilot = km_montecarlo::solve(scene, &pilot_opts)?;
    // Photons needed by each bounded tally, from its per-photon standard
    // deviation; a pilot that saw no variance at all (e.g. a clear layer)
    // still needs photons (s >= 1e-3).
    let mut needed = 0.0f64;
    let mut limited = String::new();
    for (ch, c) in pilot.channels.iter().enumerate() {
        for ((name, x), se) in bounded(c).into_iter().zip(stderrs(c)) {
            let s = (se * (PILOT_PHOTONS as f64).sqrt()).max(1e-3);
            let n = (3.0 * s / allowed(tol, x)).powi(2).ceil();
            if n > needed {
                needed = n;
                limited = with_channel(&name, &pilot.labels, ch);
            }
        }
    }
    let too_many = |n: f64, name: String| KmError::TargetUnreachable {
        target: tol,
        limited_by: name,
        estimate: f64::NAN,
        allowed: tol,
        work: format!("about {n:.2e} photons needed, more than {MAX_PHOTONS:.0e}"),
    };
    if needed > MAX_PHOTONS as f64 {
        return Err(too_many(needed, limited));
    }
    // A 25 % margin over the pilot's projection; if the run still falls short
    // (the pilot's variance is itself noisy), rerun with the projection from
    // the larger run, at most three times.
    let mut n = ((needed * 1.25) as u64).max(PILOT_PHOTONS);
    // Eq. E6: refused before the run when its photon steps exceed the budget.
    photons_within_budget(scene, base, tol, n, &limited)?;
    let mut seconds = pilot.seconds;
    let mut attempt = 0;
    loop {
        attempt += 1;
        let opts = McOptions { samples: n, ..base.clone() };
        let mut sol = km_montecarlo::solve(scene, &opts)?;
        seconds += sol.seconds;
        let mut worst = Worst::default();
        for (ch, c) in sol.channels.iter_mut().enumerate() {
            let w = photon_weights(c, scene, base);
            let e: Vec<f64> = stderrs(c)
                .iter()
                .zip(&w)
                .map(|(se, w)| (3.0 * se).max(3.0 / (n as f64 * w)))
                .collect();
            for ((name, x), &ei) in bounded(c).into_iter().zip(&e) {
                worst.consider(with_channel(&name, &sol.labels, ch), ei, allowed(tol, x));
            }
            c.error_estimate = Some(to_uncertainty(c, &e));
        }
        if worst.ratio <= 1.0 {
            sol.seconds = seconds;
            sol.notes.push(format!(
                "{n} photons chosen for tolerance {tol:e} (a pilot of {PILOT_PHOTONS}, eq. E2)"
            ));
            sol.accuracy = Some(AccuracyReport {
                target: tol,
                reached: true,
                limited_by: worst.name,
                estimate: worst.estimate,
                rule: "3 standard errors (99.7 %) <= tol max(1, |X|) (docs/planner.md, eq. E2, \
                       E3)"
                .into(),
                work: vec![("samples".into(), n), ("pilot_samples".into(), PILOT_PHOTONS)],
            });
            return Ok(sol);
        }
        let next = (n as f64 * worst.ratio.powi(2) * 1.1).ceil();
        if attempt == 3 {
            return Err(KmError::TargetUnreachable {
                target: tol,
                limited_by: worst.name,
                estimate: worst.estimate,
                allowed: worst.allowed,
                work: format!("{n} photons after three sizings"),
            });
        }
        if next > MAX_PHOTONS as f64 {
            return Err(too_many(next, worst.name));
        }
        n = next as u64;
    }
}

/// Refuse a Monte Carlo run of `n` photons whose projected photon steps
/// (eq. L2 of docs/limits.md) exceed the budget `max_events`, before it is
/// traced (eq. E6): the photons the budget affords are `n_b = n B / S` for
/// `S` projected steps and budget `B`, and since the standard error falls
/// like `n^-1/2` the best target they reach is `tol sqrt(n / n_b)`.
fn photons_within_budget(
    scene: &Scene,
    base: &McOptions,
    tol: f64,
    n: u64,
    limited: &str,
) -> Result<(), KmError> {
    let Some(budget) = base.max_events else { return Ok(()) };
    let opts = McOptions { samples: n, progress: None, ..base.clone() };
    let steps = km_montecarlo::projected_steps(scene, &opts)?;
    if steps <= budget as f64 {
        return Ok(());
    }
    let afford = n as f64 * budget as f64 / steps;
    Err(KmError::TargetOverBudget {
        target: tol,
        limited_by: limited.to_string(),
        needed: format!("about {n:.2e} photons ({steps:.2e} photon steps)"),
        reachable: format!("about {afford:.2e} photons"),
        best: tol * (n as f64 / afford).sqrt(),
        basis: format!(
            "the photons come from a pilot of {PILOT_PHOTONS} (eq. E2), the steps from the \
             budget check's pilot (eq. L2 of docs/limits.md); the budget is {budget:.2e} photon \
             steps (--budget FACTOR or max_events)"
        ),
    })
}
