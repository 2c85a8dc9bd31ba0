//! From the command line's flags to the library's options (`km::Options`),
//! and the flag names added to the library's refusals.

use std::sync::Mutex;
use std::time::Instant;

use anyhow::{Context, Result, bail};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use km::{KmError, Method, Scene, Solution};

use crate::{OutputFormat, SolveArgs};

/// Solve `scene` with the method and options of `args` (through
/// [`km::solve_repeated`], `--repeat` times).
pub fn solve(scene: &Scene, args: &SolveArgs) -> Result<Solution> {
    if args.tolerance.is_some() && args.streams.is_some() {
        bail!("give either --streams or --tolerance, not both");
    }
    let opts = options(args)?;
    km::solve_repeated(scene, &opts, args.repeat).map_err(|e| with_flags(e, args))
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
        (KmError::Option { name: "directions", .. }, _) => option_flag(e),
        (KmError::Unsupported(_), _) => {
            anyhow::Error::new(e).context(format!("--method {}", args.method.name()))
        }
        _ => e.into(),
    }
}

/// The library options of `args`.
pub fn options(args: &SolveArgs) -> Result<km::Options> {
    let method = match args.method {
        Method::Km => km::MethodOptions::Km(km::KmOptions { mapping: args.km_mapping }),
        Method::Multiflux => km::MethodOptions::Multiflux(km::MultifluxOptions {
            streams: args.streams,
            neumann_order: args.order,
            all_effects: args.all_effects,
            ..Default::default()
        }),
        Method::DirectionSet => km::MethodOptions::DirectionSet(km::DirectionSetOptions {
            directions: args.directions.unwrap_or(km::direction_set::DEFAULT_DIRECTIONS),
        }),
        Method::Mc => km::MethodOptions::Mc(mc_options(args)?),
        Method::Dipole => km::MethodOptions::Dipole(dipole_options(args)),
    };
    let opts = km::Options { method, tolerance: args.tolerance, all_effects: args.all_effects };
    opts.with_budget(args.budget).map_err(option_flag)
}

/// A library option error in the words of its flag: `--NAME VALUE: REASON`.
fn option_flag(e: KmError) -> anyhow::Error {
    match e {
        KmError::Option { name, value, reason } => {
            anyhow::anyhow!("--{} {value}: {reason}", name.replace('_', "-"))
        }
        e => e.into(),
    }
}

fn mc_options(args: &SolveArgs) -> Result<km::McOptions> {
    if args.samples == 0 {
        bail!("--samples must be at least 1");
    }
    Ok(km::McOptions {
        samples: args.samples,
        seed: args.seed,
        threads: args.threads,
        estimator: args.estimator,
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
    km::DipoleOptions { fdr: args.fdr, model: args.dipole }
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

/// `km profile`: Rd(r) by the dipole or Monte Carlo, printed.
pub fn profile(scene: &Scene, opts: &km::ProfileOptions, format: OutputFormat) -> Result<()> {
    let p = km::profile(scene, opts).map_err(|e| match e {
        e @ KmError::Option { .. } => option_flag(e),
        e => anyhow::Error::new(e).context(format!("--method {}", opts.method.name())),
    })?;
    crate::stdout::print(&match format {
        OutputFormat::Json => format!("{}\n", serde_json::to_string_pretty(&p.to_json())?),
        OutputFormat::Csv => p.csv(),
        OutputFormat::Table => p.table(),
    })
}

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
            for km::MethodSetting { name, methods, sets } in km::METHOD_SETTINGS {
                if given(m, name) && !methods.contains(&method) {
                    let names: Vec<_> = methods.iter().map(|x| x.name()).collect();
                    bail!(
                        "{} does not apply to --method {}: it sets {sets} (--method {})",
                        flag(name),
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
