//! An accuracy target instead of knobs (`km solve --tolerance TOL`).
//!
//! **Multi-flux** (eq. E1): solve at `N` and `2N` streams per hemisphere for
//! `N = 4, 8, 16, ...` and report the answer at `N` with the estimate
//!
//! `e_N = 2 |X_N - X_2N| + 1e-12`                                      (E1)
//!
//! for `X` = reflectance and transmittance (and the largest BRDF/BTDF
//! difference when directions are asked). Since `|e_N| <= |X_N - X_2N| +
//! |e_2N|`, (E1) bounds the true error whenever one doubling at least halves
//! the error (double-Gauss quadratures converge much faster for smooth
//! fields, and at least like `N^-2` across the kinks that total internal
//! reflection puts in the angular distribution). The first `N` with
//! `e_N <= TOL` is taken. A truncated adding (`--order k`) adds its own
//! difference from the exact adding at that `N`.
//!
//! **Monte Carlo** (eq. E2): a pilot run of `10^4` photons gives the
//! per-photon standard deviation `s`; the run then takes
//! `n = ceil((3 s / TOL)^2)` photons and reports
//!
//! `e = max(3 * stderr, 3 / n)`                                        (E2)
//!
//! i.e. a 99.7 % confidence bound for a normally distributed mean, and the
//! "rule of three" 95 % bound for a tally that saw no photon at all. Runs that
//! would need more than `10^10` photons are refused with their expected cost.

use anyhow::{Result, bail};
use km_core::{Scene, Solution};
use serde_json::{Map, Value, json};

/// Largest stream count tried by [`multiflux`].
pub const MAX_STREAMS: usize = 256;

/// Largest Monte Carlo run [`monte_carlo`] accepts.
pub const MAX_PHOTONS: u64 = 10_000_000_000;

fn check_tolerance(tol: f64) -> Result<()> {
    if !tol.is_finite() || tol <= 0.0 || tol >= 1.0 {
        bail!("--tolerance {tol}: must lie in (0, 1)");
    }
    Ok(())
}

fn max_abs_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max)
}

/// Multi-flux to an accuracy target (eq. E1).
///
/// # Errors
/// A tolerance outside `(0, 1)`, and the solver's errors.
pub fn multiflux(
    scene: &Scene,
    base: &km_multiflux::MultifluxOptions,
    tol: f64,
) -> Result<Solution> {
    check_tolerance(tol)?;
    let at = |n: usize, order: Option<usize>| {
        let opts = km_multiflux::MultifluxOptions {
            streams: Some(n),
            neumann_order: order,
            ..base.clone()
        };
        km_multiflux::solve(scene, &opts)
    };
    let mut seconds = 0.0;
    let mut n = 4;
    let mut coarse = at(n, base.neumann_order)?;
    seconds += coarse.seconds;
    loop {
        let fine = at(2 * n, base.neumann_order)?;
        seconds += fine.seconds;
        // Eq. E1, channel by channel.
        let mut worst = 0.0f64;
        let mut estimates = Vec::with_capacity(coarse.channels.len());
        for (c, f) in coarse.channels.iter().zip(&fine.channels) {
            let er = 2.0 * (c.reflectance - f.reflectance).abs() + 1e-12;
            let et = 2.0 * (c.transmittance - f.transmittance).abs() + 1e-12;
            let eb = 2.0 * max_abs_diff(&c.brdf, &f.brdf);
            let ebt = 2.0 * max_abs_diff(&c.btdf, &f.btdf);
            worst = worst.max(er).max(et);
            estimates.push((er, et, eb, ebt));
        }
        let last = 2 * n >= MAX_STREAMS;
        if worst <= tol || last {
            // Truncated adding: add its own difference from the exact adding.
            if base.neumann_order.is_some() {
                let exact = at(n, None)?;
                seconds += exact.seconds;
                for ((er, et, _, _), (c, x)) in
                    estimates.iter_mut().zip(coarse.channels.iter().zip(&exact.channels))
                {
                    *er += (c.reflectance - x.reflectance).abs();
                    *et += (c.transmittance - x.transmittance).abs();
                }
            }
            for (c, (er, et, eb, ebt)) in coarse.channels.iter_mut().zip(&estimates) {
                let mut m = Map::new();
                m.insert("reflectance".into(), json!(er));
                m.insert("transmittance".into(), json!(et));
                if !c.brdf.is_empty() {
                    m.insert("brdf_max".into(), json!(eb));
                }
                if !c.btdf.is_empty() {
                    m.insert("btdf_max".into(), json!(ebt));
                }
                c.error_estimate = Some(m);
            }
            coarse.seconds = seconds;
            coarse.extra.insert(
                "tolerance".into(),
                json!({
                    "target": tol,
                    "reached": worst <= tol,
                    "streams": n,
                    "check_streams": 2 * n,
                    "rule": "2 |X_N - X_2N| (docs/planner.md, eq. E1)",
                }),
            );
            if worst > tol {
                notes(&mut coarse).push(json!(format!(
                    "tolerance {tol} not reached at {n} streams: estimated error {worst:.2e}"
                )));
            }
            return Ok(coarse);
        }
        n *= 2;
        coarse = fine;
    }
}

fn notes(sol: &mut Solution) -> &mut Vec<Value> {
    let v = sol.extra.entry("notes").or_insert_with(|| json!([]));
    if !v.is_array() {
        *v = json!([]);
    }
    v.as_array_mut().expect("just made an array")
}

/// Monte Carlo to an accuracy target (eq. E2).
///
/// # Errors
/// A tolerance outside `(0, 1)`, a run that would need more than
/// [`MAX_PHOTONS`] photons, and the tracer's errors.
pub fn monte_carlo(scene: &Scene, base: &km_montecarlo::McOptions, tol: f64) -> Result<Solution> {
    check_tolerance(tol)?;
    let pilot_n = 10_000u64;
    let pilot_opts = km_montecarlo::McOptions {
        samples: pilot_n,
        seed: base.seed ^ 0x9e37_79b9_7f4a_7c15,
        progress: false,
        ..base.clone()
    };
    let pilot = km_montecarlo::solve(scene, &pilot_opts)?;
    // Per-photon standard deviation, the largest over channels and totals.
    let mut s = 0.0f64;
    for c in &pilot.channels {
        if let Some(se) = &c.stderr {
            for key in ["reflectance", "transmittance"] {
                let v = se.get(key).and_then(Value::as_f64).unwrap_or(0.0);
                s = s.max(v * (pilot_n as f64).sqrt());
            }
        }
    }
    // A pilot that saw no variance at all (e.g. a clear layer) still needs photons.
    let s = s.max(1e-3);
    let needed = ((3.0 * s / tol).powi(2)).ceil();
    if needed > MAX_PHOTONS as f64 {
        bail!(
            "--tolerance {tol} needs about {needed:.2e} photons per channel (per-photon standard \
             deviation {s:.3}); more than the {MAX_PHOTONS:.0e} this command runs: loosen the \
             tolerance or run shards (--shard) on several machines"
        );
    }
    // A 25 % margin over the pilot's projection; if the run still falls short
    // (the pilot's variance is itself noisy), rerun with the projection from
    // the larger run, at most three times.
    let mut n = ((needed * 1.25) as u64).max(pilot_n);
    let mut seconds = pilot.seconds;
    let mut attempt = 0;
    let (mut sol, worst, n) = loop {
        let opts = km_montecarlo::McOptions { samples: n, ..base.clone() };
        let mut sol = km_montecarlo::solve(scene, &opts)?;
        seconds += sol.seconds;
        let mut worst = 0.0f64;
        for c in &mut sol.channels {
            let mut m = Map::new();
            if let Some(se) = &c.stderr {
                for key in ["reflectance", "transmittance"] {
                    // Rule of three: a tally that saw nothing in n photons may
                    // still be as large as 3 / n (95 % upper bound).
                    let e = (3.0 * se.get(key).and_then(Value::as_f64).unwrap_or(0.0))
                        .max(3.0 / n as f64);
                    worst = worst.max(e);
                    m.insert(key.into(), json!(e));
                }
            }
            c.error_estimate = Some(m);
        }
        attempt += 1;
        if worst <= tol || attempt == 3 {
            break (sol, worst, n);
        }
        let grow = (worst / tol).powi(2) * 1.1;
        let next = (n as f64 * grow).ceil();
        if next > MAX_PHOTONS as f64 {
            bail!(
                "--tolerance {tol} needs about {next:.2e} photons per channel; more than {MAX_PHOTONS:.0e}"
            );
        }
        n = next as u64;
    };
    sol.seconds = seconds;
    sol.extra.insert(
        "tolerance".into(),
        json!({
            "target": tol,
            "reached": worst <= tol,
            "samples": n,
            "pilot_samples": pilot_n,
            "rule": "3 standard errors (99.7 %), docs/planner.md eq. E2",
        }),
    );
    Ok(sol)
}
