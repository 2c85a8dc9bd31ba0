//! From the command line's flags to the library's options (`km::Options`),
//! and the flag names added to the library's refusals.

use std::sync::Mutex;
use std::time::Instant;

use anyhow::{Context, Result, bail};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use km::{KmError, Method, Scene, Solution};

use crate::{DipoleArg, EstimatorArg, FdrArg, KmMappingArg, OutputFormat, SolveArgs, SweepFormat};

/// Solve `scene` with the method and options of `args` (through [`km::solve`]).
pub fn solve(scene: &Scene, args: &SolveArgs) -> Result<Solution> {
    if args.tolerance.is_some() && args.streams.is_some() {
        bail!("give either --streams or --tolerance, not both");
    }
    let opts = options(args)?;
    km::solve(scene, &opts).map_err(|e| with_flags(e, args))
}

/// The library's refusal, with the flag that caused it named.
fn with_flags(e: KmError, args: &SolveArgs) -> anyhow::Error {
    match (&e, args.tolerance) {
        (
            KmError::NoAccuracySetting { .. }
            | KmError::TargetUnreachable { .. }
            | KmError::Option { name: "accuracy target", .. },
            Some(t),
        ) => anyhow::Error::new(e).context(format!("--tolerance {t}")),
        (KmError::Unsupported(_), _) => {
            anyhow::Error::new(e).context(format!("--method {}", args.method.name()))
        }
        _ => e.into(),
    }
}

/// The library options of `args`.
pub fn options(args: &SolveArgs) -> Result<km::Options> {
    let method = match args.method {
        Method::Km => km::MethodOptions::Km(km::KmOptions { mapping: km_mapping(args.km_mapping) }),
        Method::Multiflux => km::MethodOptions::Multiflux(km::MultifluxOptions {
            streams: args.streams,
            neumann_order: args.order,
            all_effects: args.all_effects,
            max_work: Some(km::multiflux_budget::DEFAULT_MAX_WORK * budget_factor(args)?),
            ..Default::default()
        }),
        Method::Mc => km::MethodOptions::Mc(mc_options(args)?),
        Method::Dipole => km::MethodOptions::Dipole(dipole_options(args)),
    };
    Ok(km::Options { method, tolerance: args.tolerance, all_effects: args.all_effects })
}

fn km_mapping(m: KmMappingArg) -> km::KmMapping {
    match m {
        KmMappingArg::Seed => km::KmMapping::Seed,
        KmMappingArg::Star1988 => km::KmMapping::StarEtAl1988,
        KmMappingArg::Gate1974 => km::KmMapping::Gate1974,
    }
}

/// `--budget FACTOR`: finite and > 0 (docs/limits.md).
fn budget_factor(args: &SolveArgs) -> Result<f64> {
    if !(args.budget.is_finite() && args.budget > 0.0) {
        bail!("--budget {}: must be a finite factor > 0", args.budget);
    }
    Ok(args.budget)
}

fn mc_options(args: &SolveArgs) -> Result<km::McOptions> {
    if args.samples == 0 {
        bail!("--samples must be at least 1");
    }
    let factor = budget_factor(args)?;
    let scale = |x: u64| (x as f64 * factor).min(u64::MAX as f64) as u64;
    Ok(km::McOptions {
        max_events: Some(scale(km_montecarlo::options::DEFAULT_MAX_EVENTS)),
        max_tally_bytes: scale(km_montecarlo::options::DEFAULT_MAX_TALLY_BYTES),
        samples: args.samples,
        seed: args.seed,
        threads: args.threads,
        estimator: match args.estimator {
            EstimatorArg::Survival => km::Estimator::SurvivalBiasing,
            EstimatorArg::Analog => km::Estimator::Analog,
        },
        progress: args.progress().then(progress_bar),
        all_effects: args.all_effects,
        ..Default::default()
    })
}

/// A progress bar on stderr, shown once the run has lasted a second.
fn progress_bar() -> km::Progress {
    let bar = ProgressBar::with_draw_target(None, ProgressDrawTarget::hidden());
    let start = Instant::now();
    let shown = Mutex::new(false);
    km::Progress::new(move |done, total| {
        let mut shown = shown.lock().unwrap_or_else(|e| e.into_inner());
        if !*shown && start.elapsed().as_secs_f64() > 1.0 {
            *shown = true;
            bar.set_length(total);
            bar.set_style(
                ProgressStyle::with_template("mc {bar:40} {pos}/{len} batches, eta {eta}")
                    .unwrap_or_else(|_| ProgressStyle::default_bar()),
            );
            bar.set_draw_target(ProgressDrawTarget::stderr());
        }
        bar.set_position(done);
        if done >= total {
            bar.finish_and_clear();
        }
    })
}

fn dipole_options(args: &SolveArgs) -> km::DipoleOptions {
    km::DipoleOptions {
        fdr: match args.fdr {
            FdrArg::Exact => km::FdrModel::Exact,
            FdrArg::EganHilgeman => km::FdrModel::EganHilgeman,
        },
        model: match args.dipole {
            DipoleArg::Jensen2001 => km::DipoleModel::Jensen2001,
            DipoleArg::Better => km::DipoleModel::Better,
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

/// `km profile`: Rd(r) by the dipole or Monte Carlo, printed.
pub fn profile(scene: &Scene, opts: &km::ProfileOptions, format: OutputFormat) -> Result<()> {
    let p = km::profile(scene, opts).map_err(|e| match e {
        KmError::Option { name, value, reason } => {
            anyhow::anyhow!("--{} {value}: {reason}", name.replace('_', "-"))
        }
        e => anyhow::Error::new(e).context(format!("--method {}", opts.method.name())),
    })?;
    use std::fmt::Write;
    match format {
        OutputFormat::Json => {
            return crate::stdout::print(&format!(
                "{}\n",
                serde_json::to_string_pretty(&p.to_json())?
            ));
        }
        OutputFormat::Csv => {
            // One row per radius: r, then Rd (and its standard error) per channel.
            let one = p.labels.len() == 1;
            let name = |base: &str, l: &str| {
                if one { base.to_string() } else { format!("{base}_{l}") }
            };
            let mut cols = vec!["r".to_string()];
            for l in &p.labels {
                cols.push(name("rd", l));
                if p.stderr.is_some() {
                    cols.push(name("stderr_rd", l));
                }
            }
            let mut t = cols.join(",") + "\n";
            for (i, ri) in p.r.iter().enumerate() {
                let _ = write!(t, "{ri:e}");
                for (c, rd) in p.rd.iter().enumerate() {
                    let _ = write!(t, ",{:e}", rd[i]);
                    if let Some(se) = &p.stderr {
                        let _ = write!(t, ",{:e}", se[c][i]);
                    }
                }
                t.push('\n');
            }
            return crate::stdout::print(&t);
        }
        OutputFormat::Table => {}
    }
    // r in the scene's length unit; Rd(r) per unit area: 1/length^2.
    let mut t = format!("{:>12}", "r [L]");
    for l in &p.labels {
        let name = if p.labels.len() == 1 { "Rd".to_string() } else { format!("Rd {l}") };
        let _ = write!(t, "{:>16}", format!("{name} [1/L^2]"));
    }
    t.push('\n');
    for (i, ri) in p.r.iter().enumerate() {
        let _ = write!(t, "{ri:>12.5}");
        for c in &p.rd {
            let _ = write!(t, "{:>16.6e}", c[i]);
        }
        t.push('\n');
    }
    t.push_str("L: the scene's length unit (that of 1/sigma_t)\n");
    crate::stdout::print(&t)
}

/// The `km solve` flags that apply to some methods only: argument id, the
/// methods it applies to, and what it sets.
const SOLVE_FLAGS: &[(&str, &[Method], &str)] = &[
    ("samples", &[Method::Mc], "the photon count of Monte Carlo"),
    ("seed", &[Method::Mc], "the random seed of Monte Carlo"),
    ("threads", &[Method::Mc], "the worker threads of Monte Carlo"),
    ("estimator", &[Method::Mc], "the absorption estimator of Monte Carlo"),
    ("shard", &[Method::Mc], "a share of a Monte Carlo run"),
    ("streams", &[Method::Multiflux], "the Gauss nodes per hemisphere of multi-flux"),
    ("order", &[Method::Multiflux], "the Neumann order of multi-flux adding"),
    ("km_mapping", &[Method::Km], "how two-flux K, S come from the scene"),
    ("fdr", &[Method::Dipole], "how the dipole computes F_dr"),
    ("dipole", &[Method::Dipole], "which dipole"),
    (
        "tolerance",
        &[Method::Multiflux, Method::Mc],
        "an accuracy target, met by choosing streams or photons; km and dipole are closed \
         forms with no accuracy setting",
    ),
];

/// `--flag-name` of an argument id.
fn flag(id: &str) -> String {
    format!("--{}", id.replace('_', "-"))
}

/// Whether the user gave argument `id` on the command line (not a default).
fn given(m: &clap::ArgMatches, id: &str) -> bool {
    matches!(m.try_get_raw(id), Ok(Some(_)))
        && m.value_source(id) == Some(clap::parser::ValueSource::CommandLine)
}

/// Refuse a flag that does not apply to the chosen method or mode (clap cannot
/// know the method: checked after parsing), saying why.
pub fn check_flags(matches: &clap::ArgMatches) -> Result<()> {
    match matches.subcommand() {
        Some(("solve", m)) => {
            let method = m.get_one::<Method>("method").copied().unwrap_or(Method::Multiflux);
            for (id, methods, what) in SOLVE_FLAGS {
                if given(m, id) && !methods.contains(&method) {
                    let names: Vec<_> = methods.iter().map(|x| x.name()).collect();
                    bail!(
                        "{} does not apply to --method {}: it sets {what} (--method {})",
                        flag(id),
                        method.name(),
                        names.join(" or ")
                    );
                }
            }
            if given(m, "shard") && (given(m, "json") || given(m, "format")) {
                bail!(
                    "--shard writes its partial tally to --out and prints no result: --json and \
                     --format apply to `km merge` and to whole runs"
                );
            }
            if given(m, "tolerance") && given(m, "samples") {
                bail!("give either --samples or --tolerance: the target chooses the photon count");
            }
            if given(m, "tolerance") && given(m, "shard") {
                bail!(
                    "--tolerance does not combine with --shard (every shard would choose its own \
                     photon count): run a pilot `km solve SCENE --method mc --tolerance T --json`, \
                     read the sample count it chose (`tolerance.samples` of the JSON), then shard with \
                     `--samples N --shard I/K --out FILE` and `km merge`"
                );
            }
        }
        Some(("profile", m)) => {
            let method = m.get_one::<Method>("method").copied().unwrap_or(Method::Dipole);
            for id in ["samples", "seed"] {
                if given(m, id) && method != Method::Mc {
                    bail!(
                        "{} does not apply to --method {}: it sets the Monte Carlo run \
                         (--method mc)",
                        flag(id),
                        method.name()
                    );
                }
            }
        }
        _ => {}
    }
    Ok(())
}

/// `km sweep`: one row per point (and channel), in grid order.
pub fn print_sweep(
    axes: &[km::SweepAxis],
    points: &[km::SweepPoint],
    format: SweepFormat,
) -> Result<()> {
    // Built whole, then written through the checked stdout.
    let mut out = String::new();
    let spectral = points.first().is_some_and(|p| p.solution.channels.len() > 1);
    let quantities = [
        "reflectance",
        "reflectance_specular",
        "transmittance",
        "transmittance_direct",
        "absorptance",
    ];
    let mut header: Vec<String> = axes.iter().map(|a| a.key.clone()).collect();
    if spectral {
        header.push("channel".into());
    }
    header.extend(quantities.iter().map(|q| q.to_string()));
    match format {
        SweepFormat::Csv => outln(&mut out, header.join(",")),
        SweepFormat::Table => {
            outln(&mut out, header.iter().map(|h| format!("{h:>22}")).collect::<String>())
        }
        SweepFormat::Jsonl => {}
    }
    for p in points {
        for (c, ch) in p.solution.channels.iter().enumerate() {
            let nums = [
                ch.reflectance,
                ch.reflectance_specular,
                ch.transmittance,
                ch.transmittance_direct,
                ch.absorptance,
            ];
            let label = p.solution.labels.get(c).cloned().unwrap_or_default();
            match format {
                SweepFormat::Jsonl => {
                    let mut o = serde_json::Map::new();
                    for (a, v) in axes.iter().zip(&p.values) {
                        o.insert(a.key.clone(), (*v).into());
                    }
                    if spectral {
                        o.insert("channel".into(), label.into());
                    }
                    for (q, v) in quantities.iter().zip(nums) {
                        o.insert((*q).into(), v.into());
                    }
                    outln(&mut out, serde_json::Value::Object(o).to_string());
                }
                SweepFormat::Csv | SweepFormat::Table => {
                    let mut cells: Vec<String> = p.values.iter().map(|v| v.to_string()).collect();
                    if spectral {
                        cells.push(label);
                    }
                    cells.extend(nums.iter().map(|v| v.to_string()));
                    if format == SweepFormat::Csv {
                        outln(&mut out, cells.join(","));
                    } else {
                        outln(
                            &mut out,
                            cells.iter().map(|c| format!("{c:>22}")).collect::<String>(),
                        );
                    }
                }
            }
        }
    }
    crate::stdout::print(&out)
}

/// Append one line to `out`.
fn outln(out: &mut String, line: String) {
    out.push_str(&line);
    out.push('\n');
}
