//! Dispatch of `km solve` and `km profile` to the method libraries.

use anyhow::{Context, Result, bail};
use km_core::plan::{Request, expand_channels, plan_scene, reduce_channels};
use km_core::{Scene, Solution};

use crate::{DipoleArg, EstimatorArg, FdrArg, KmMappingArg, Method, SolveArgs};

/// Solve `scene` with the method and options of `args`; the plan used is
/// added to the solution under `"plan"`.
pub fn solve(scene: &Scene, args: &SolveArgs) -> Result<Solution> {
    let request = Request::from_scene(&scene.channels[0]);
    let plan = plan_scene(scene, request, args.all_effects).for_method(args.method.name());
    // Channels with identical coefficients are solved once (`duplicate-channels`).
    let (reduced, map) = reduce_channels(scene);
    let dedup = plan.skips("duplicate-channels");
    let full_scene = scene;
    let scene = if dedup { &reduced } else { scene };
    let mut sol = match args.method {
        Method::Km => {
            no_tolerance(args)?;
            let opts = km_core::two_flux::KmOptions { mapping: km_mapping(args.km_mapping) };
            km_core::two_flux::solve(scene, &opts)?
        }
        Method::Multiflux => {
            budget_factor(args)?;
            let opts = multiflux_options(args);
            match args.tolerance {
                Some(tol) if args.streams.is_none() => {
                    km_cli::tolerance::multiflux(scene, &opts, tol)?
                }
                Some(_) => bail!("give either --streams or --tolerance, not both"),
                None => km_multiflux::solve(scene, &opts)?,
            }
        }
        Method::Mc => {
            let opts = mc_options(args)?;
            match args.tolerance {
                Some(tol) => km_cli::tolerance::monte_carlo(scene, &opts, tol)?,
                None => km_montecarlo::solve(scene, &opts)?,
            }
        }
        Method::Dipole => {
            no_tolerance(args)?;
            match as_half_space(scene, args.all_effects) {
                Some((half, bound)) => {
                    let mut sol = km_dipole::solve(&half, &dipole_options(args))?;
                    let note = format!(
                        "{} < {:.1e} {}",
                        "the top layer is so thick that the light returning from below it is",
                        bound.max(f64::MIN_POSITIVE),
                        "of the incident (planner rule `transmission`): solved as a half-space"
                    );
                    let notes = sol.extra.entry("notes").or_insert_with(|| serde_json::json!([]));
                    if let Some(a) = notes.as_array_mut() {
                        a.push(serde_json::json!(note));
                    }
                    sol
                }
                None => km_dipole::solve(scene, &dipole_options(args))?,
            }
        }
    };
    if dedup {
        sol = expand_channels(sol, &map, &full_scene.labels);
    }
    sol.extra.insert("plan".into(), plan.to_json());
    Ok(sol)
}

/// The dipole treats half-spaces only; a finite top layer that the planner's
/// `transmission` rule makes a half-space in every channel is one (with the
/// largest bound of the neglected light).
fn as_half_space(scene: &Scene, all_effects: bool) -> Option<(Scene, f64)> {
    if all_effects {
        return None;
    }
    let mut half = scene.clone();
    let mut bound = 0.0f64;
    for c in &mut half.channels {
        let plan = km_core::plan::Plan::new(c, Request::default(), false);
        let cut = plan.layers.first().and_then(|l| l.cutoff_bound)?;
        bound = bound.max(cut);
        c.layers.truncate(1);
        c.layers[0].thickness = f64::INFINITY;
    }
    Some((half, bound))
}

fn no_tolerance(args: &SolveArgs) -> Result<()> {
    if let Some(t) = args.tolerance {
        bail!(
            "--tolerance {t}: method {} is a closed form with no accuracy knob; \
             its error against transport theory is not bounded by any setting",
            args.method.name()
        );
    }
    Ok(())
}

fn km_mapping(m: KmMappingArg) -> km_core::two_flux::KmMapping {
    use km_core::two_flux::KmMapping;
    match m {
        KmMappingArg::Seed => KmMapping::Seed,
        KmMappingArg::Star1988 => KmMapping::StarEtAl1988,
        KmMappingArg::Gate1974 => KmMapping::Gate1974,
    }
}

fn multiflux_options(args: &SolveArgs) -> km_multiflux::MultifluxOptions {
    km_multiflux::MultifluxOptions {
        streams: args.streams,
        neumann_order: args.order,
        all_effects: args.all_effects,
        max_work: Some(km_multiflux::budget::DEFAULT_MAX_WORK * args.budget),
        ..Default::default()
    }
}

/// `--budget FACTOR`: finite and > 0 (docs/limits.md).
fn budget_factor(args: &SolveArgs) -> Result<f64> {
    if !(args.budget.is_finite() && args.budget > 0.0) {
        bail!("--budget {}: must be a finite factor > 0", args.budget);
    }
    Ok(args.budget)
}

fn mc_options(args: &SolveArgs) -> Result<km_montecarlo::McOptions> {
    if args.samples == 0 {
        bail!("--samples must be at least 1");
    }
    let factor = budget_factor(args)?;
    let scale = |x: u64| (x as f64 * factor).min(u64::MAX as f64) as u64;
    Ok(km_montecarlo::McOptions {
        max_events: Some(scale(km_montecarlo::options::DEFAULT_MAX_EVENTS)),
        max_tally_bytes: scale(km_montecarlo::options::DEFAULT_MAX_TALLY_BYTES),
        samples: args.samples,
        seed: args.seed,
        threads: args.threads,
        estimator: match args.estimator {
            EstimatorArg::Survival => km_montecarlo::Estimator::SurvivalBiasing,
            EstimatorArg::Analog => km_montecarlo::Estimator::Analog,
        },
        progress: args.progress(),
        all_effects: args.all_effects,
        ..Default::default()
    })
}

fn dipole_options(args: &SolveArgs) -> km_dipole::DipoleOptions {
    km_dipole::DipoleOptions {
        fdr: match args.fdr {
            FdrArg::Exact => km_dipole::FdrModel::Exact,
            FdrArg::EganHilgeman => km_dipole::FdrModel::EganHilgeman,
        },
        model: match args.dipole {
            DipoleArg::Jensen2001 => km_dipole::DipoleModel::Jensen2001,
            DipoleArg::Better => km_dipole::DipoleModel::Better,
        },
    }
}

/// `I/N` with `0 <= I < N`.
pub fn parse_shard(text: &str) -> Result<(u64, u64)> {
    let (i, n) =
        text.split_once('/').with_context(|| format!("--shard {text}: expected I/N, e.g. 0/4"))?;
    let i: u64 = i.trim().parse().with_context(|| format!("--shard {text}: I is not a number"))?;
    let n: u64 = n.trim().parse().with_context(|| format!("--shard {text}: N is not a number"))?;
    if n == 0 || i >= n {
        bail!("--shard {text}: need 0 <= I < N");
    }
    Ok((i, n))
}

/// One shard of a Monte Carlo run.
pub fn mc_shard(scene: &Scene, args: &SolveArgs, i: u64, n: u64) -> Result<km_montecarlo::Partial> {
    let opts = mc_options(args)?;
    Ok(km_montecarlo::run_shard(scene, &opts, i, n)?)
}

/// Values per channel, then per radius.
type PerChannel = Vec<Vec<f64>>;

/// `km profile`: Rd(r) by the dipole or Monte Carlo.
pub fn profile(
    scene: &Scene,
    method: Method,
    r_max: Option<f64>,
    points: usize,
    samples: u64,
    seed: u64,
    json: bool,
) -> Result<()> {
    if points == 0 || points > km_montecarlo::options::MAX_RADIAL_BINS {
        bail!("--points {points}: must lie in 1..=1000000 (docs/limits.md)");
    }
    // Default range: 10 transport mean free paths of the first channel's layer.
    let l = &scene.channels[0].layers[0];
    let sigma_t_prime = l.sigma_a + l.sigma_s * (1.0 - l.g());
    let r_max = match r_max {
        Some(r) if r.is_finite() && r > 0.0 => r,
        Some(r) => bail!("--r-max {r}: must be finite and > 0"),
        None if sigma_t_prime > 0.0 => 10.0 / sigma_t_prime,
        None => bail!("the layer neither scatters nor absorbs: give --r-max"),
    };
    let (r, rd, se): (Vec<f64>, PerChannel, Option<PerChannel>) = match method {
        Method::Dipole => {
            let r: Vec<f64> =
                (0..points).map(|i| r_max * (i as f64 + 0.5) / points as f64).collect();
            let rd = km_dipole::profile(scene, &r, &Default::default())?;
            (r, rd, None)
        }
        Method::Mc => {
            let opts = km_montecarlo::McOptions { samples, seed, ..Default::default() };
            let bins = km_montecarlo::RadialBins { dr: r_max / points as f64, count: points };
            let p = km_montecarlo::radial_profile(scene, &opts, bins)?;
            (p.r, p.rd, Some(p.stderr))
        }
        m => bail!("km profile supports --method dipole or mc, not {}", m.name()),
    };
    if json {
        let v = serde_json::json!({
            "method": method.name(),
            "r": r,
            "rd": if rd.len() == 1 { serde_json::json!(rd[0]) } else { serde_json::json!(rd) },
            "stderr": se.map(|s| if s.len() == 1 { serde_json::json!(s[0]) } else { serde_json::json!(s) }),
            "channels": scene.labels,
        });
        crate::stdout::print(&format!("{}\n", serde_json::to_string_pretty(&v)?))
    } else {
        use std::fmt::Write;
        let mut t = format!("{:>12}", "r");
        for l in &scene.labels {
            let _ = write!(t, "{:>16}", format!("Rd {l}"));
        }
        t.push('\n');
        for (i, ri) in r.iter().enumerate() {
            let _ = write!(t, "{ri:>12.5}");
            for c in &rd {
                let _ = write!(t, "{:>16.6e}", c[i]);
            }
            t.push('\n');
        }
        crate::stdout::print(&t)
    }
}
