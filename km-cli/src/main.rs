//! `km`: light in stacks of flat scattering layers, from the command line.
//!
//! Thin: parse the command line and the scene file, call the libraries, print.

mod bsdf;
mod fit;
mod fit_km;
mod methods;
mod stdout;

use std::io::IsTerminal;
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{Context, bail};
use clap::builder::TypedValueParser;
use clap::{CommandFactory, FromArgMatches, Parser, Subcommand, ValueEnum};
use km::Method;

/// The scene solved by `km demo`.
const DEMO_SCENE: &str = include_str!("../../examples/seed-three-layers.toml");

#[derive(Parser)]
#[command(
    name = "km",
    version,
    about = "Reflection, transmission and the light field of stacks of flat scattering layers",
    long_about = "Reflection, transmission and the light field of stacks of flat scattering \
layers (paint, coatings, skin, milk, clouds), by five methods over one scene file:\n\
  km             two-flux Kubelka–Munk, closed form\n\
  multiflux      multi-flux eigenvalue solver (discrete ordinates)\n\
  direction-set  multi-flux on the seed's direction set on the sphere (totals)\n\
  mc             Monte Carlo reference tracer\n\
  dipole         diffusion dipole for semi-infinite media\n\n\
Without a subcommand, runs `km reproduce --quick` (the paper's figures and the \
accuracy/time study, into out/).",
    after_help = "Examples:\n  km solve examples/seed-three-layers.toml --method multiflux --json\n  \
km plan examples/paint-over-primer.toml\n  km demo\n  km reproduce --quick --out out"
)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Subcommand)]
#[allow(clippy::large_enum_variant)] // parsed once per process; boxing buys nothing
enum Command {
    /// Solve a scene file with one method and print the result.
    #[command(
        after_help = "Examples:\n  km solve examples/fresnel-slab.toml --method multiflux\n  \
km solve examples/seed-three-layers.toml --method km --json\n  \
km solve examples/fresnel-slab.toml --method mc --samples 1000000 --seed 7 --json\n  \
km solve examples/fresnel-slab.toml --method mc --samples 4000000 --shard 0/4 --out part0.json\n  \
km solve examples/marble-half-space.toml --method dipole\n  \
km solve examples/cloud-deck.toml --method multiflux --tolerance 1e-4 --json"
    )]
    Solve(SolveArgs),
    /// Optical properties from measured reflectance and transmittance (the inverse problem).
    Fit(fit::FitArgs),
    /// The whole BSDF of the stack as a table (npz, csv) or a Fourier BSDF file (Mitsuba 0.6, pbrt-v3).
    #[command(
        after_help = "Examples:\n  km bsdf examples/paint-over-primer.toml --out paint.npz\n  \
km bsdf examples/fresnel-slab.toml --out slab.csv --theta-i 0,30,60 --theta-o 0:90:5 --phi 0,180\n  \
km bsdf examples/paint-over-primer.toml --out paint.bsdf --format fourier\n  \
km bsdf examples/seed-three-layers.toml --out seed.npz --plot out/bsdf"
    )]
    Bsdf(bsdf::BsdfArgs),
    /// Combine Monte Carlo shard files into the result of one run.
    #[command(
        after_help = "Example:\n  km merge part0.json part1.json part2.json part3.json --json"
    )]
    Merge {
        /// Partial tally files written by `km solve --method mc --shard i/N --out FILE`.
        #[arg(required = true)]
        parts: Vec<PathBuf>,
        /// Print JSON instead of a table (the same as `--format json`).
        #[arg(long, conflicts_with = "format")]
        json: bool,
        /// Output format: table, json (the contract of docs/cli.md) or csv.
        #[arg(long, value_enum)]
        format: Option<OutputFormat>,
        /// Also write the JSON result to this file (atomically).
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Radially resolved diffuse reflectance Rd(r) of a pencil beam at normal incidence.
    #[command(after_help = "Examples:\n  km profile examples/marble-half-space.toml\n  \
km profile examples/marble-half-space.toml --method mc --r-max 10 --points 40 --json")]
    Profile {
        /// Scene file (its single layer must be a half-space for the dipole).
        scene: PathBuf,
        /// Edit the scene before validation: KEY=VALUE, keys as the errors spell them
        /// (`layer[1].g=0.8`, `light.theta_deg=60`); repeatable.
        #[arg(long = "set", value_name = "KEY=VALUE")]
        set: Vec<String>,
        /// `dipole` (closed form) or `mc` (Monte Carlo annuli).
        #[arg(long, short, value_parser = profile_method_parser(), default_value = "dipole")]
        method: Method,
        /// Largest radius, in the scene's length unit (default: 10 transport lengths).
        #[arg(long)]
        r_max: Option<f64>,
        /// Number of radii (dipole) or annuli (mc).
        #[arg(long, default_value_t = 20)]
        points: usize,
        /// Monte Carlo photons [mc].
        #[arg(long, default_value_t = 1_000_000)]
        samples: u64,
        /// Monte Carlo seed [mc].
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Print JSON instead of a table (the same as `--format json`).
        #[arg(long, conflicts_with = "format")]
        json: bool,
        /// Output format: table, json or csv (one row per radius).
        #[arg(long, value_enum)]
        format: Option<OutputFormat>,
    },
    /// Solve a scene over a grid of edited values, one row per point (and channel).
    #[command(
        after_help = "Examples:\n  km sweep examples/fresnel-slab.toml --set layer[1].g=0:0.9:10\n  \
km sweep examples/fresnel-slab.toml --set layer[1].albedo=0.5:0.9:3 \
--set light.theta_deg=0:60:3 --method km --format csv"
    )]
    Sweep {
        /// Scene file (TOML, see docs/scene-file.md).
        scene: PathBuf,
        /// KEY=START:STOP:N (N equally spaced values, a grid over several; the first
        /// varies slowest) or KEY=VALUE (a fixed edit); repeatable.
        #[arg(long = "set", value_name = "KEY=START:STOP:N", required = true)]
        set: Vec<String>,
        /// Method (at its default settings).
        #[arg(long, short, value_parser = method_parser(), default_value = "multiflux")]
        method: Method,
        /// Output format.
        #[arg(long, value_enum, default_value_t = km::SweepFormat::Table)]
        format: km::SweepFormat,
    },
    /// Print what a scene calls for: effects present, work skipped and why.
    #[command(after_help = "Examples:\n  km plan examples/seed-three-layers.toml\n  \
km plan examples/paint-over-primer.toml --method mc --json")]
    Plan {
        /// Scene file (TOML, see docs/scene-file.md).
        scene: PathBuf,
        /// Edit the scene before validation: KEY=VALUE, keys as the errors spell them
        /// (`layer[1].g=0.8`, `light.theta_deg=60`); repeatable.
        #[arg(long = "set", value_name = "KEY=VALUE")]
        set: Vec<String>,
        /// Method whose decisions to show.
        #[arg(long, short, value_parser = method_parser(), default_value = "multiflux")]
        method: Method,
        /// Print JSON instead of words.
        #[arg(long)]
        json: bool,
        /// Turn the planner off (compute every effect), for comparison.
        #[arg(long)]
        all_effects: bool,
    },
    /// Parse and validate a scene file, and print what it describes.
    #[command(after_help = "Example:\n  km check examples/paint-over-primer.toml")]
    Check {
        /// Scene file (TOML, see docs/scene-file.md).
        scene: PathBuf,
        /// Edit the scene before validation: KEY=VALUE, keys as the errors spell them
        /// (`layer[1].g=0.8`, `light.theta_deg=60`); repeatable.
        #[arg(long = "set", value_name = "KEY=VALUE")]
        set: Vec<String>,
    },
    /// Solve the built-in example scene (the seed paper's three-layer example) by km, multiflux
    /// and mc (the dipole treats one semi-infinite layer only: skipped, with its reason).
    #[command(after_help = "Example:\n  km demo")]
    Demo,
    /// Regenerate the seed paper's figures and the accuracy/time study into DIR/report.md.
    #[command(
        after_help = "Examples:\n  km reproduce --quick\n  km reproduce --full --out out-full"
    )]
    Reproduce {
        /// Output directory.
        #[arg(long, default_value = "out")]
        out: PathBuf,
        /// Quick run (under two minutes; the default).
        #[arg(long, conflicts_with = "full")]
        quick: bool,
        /// Paper-scale run (10^5 Monte Carlo samples per direction, all directions).
        #[arg(long)]
        full: bool,
        /// Seed of the Monte Carlo runs.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// No progress on stderr (it is also off when stderr is not a terminal).
        #[arg(long)]
        quiet: bool,
        /// Regenerate one figure or study only (fig3, fig4, fig5, fig6, fig7, fig9, fig10,
        /// speedup, dipole, diffusion-limits, pareto, stability, savings); its section goes
        /// to DIR/report-NAME.md.
        #[arg(long, value_name = "NAME")]
        only: Option<String>,
    },
}

/// Arguments of `km solve`.
#[derive(clap::Args, Debug, Clone)]
pub struct SolveArgs {
    /// Scene file (TOML, see docs/scene-file.md).
    pub scene: PathBuf,
    /// Edit the scene before validation: KEY=VALUE, keys as the errors spell them
    /// (`layer[1].g=0.8`, `light.theta_deg=60`); repeatable.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    /// Method.
    #[arg(long, short, value_parser = method_parser(), default_value = "multiflux")]
    pub method: Method,
    /// Print one JSON object (the contract of docs/cli.md) instead of a table
    /// (the same as --format json).
    #[arg(long, conflicts_with = "format")]
    pub json: bool,
    /// Output: table (text; one row per wavelength for spectral scenes), json, or csv
    /// (a header, one row per channel).
    #[arg(long, value_enum)]
    pub format: Option<OutputFormat>,
    /// Also write the JSON result (or, with --shard, the partial tally) to this file, atomically.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Accuracy target: every number asked for (R, T, their delta parts, each BRDF/BTDF value)
    /// within TOL * max(1, |x|); chooses streams or samples, reports `error_estimate` and
    /// `tolerance.limited_by`, fails when unreachable [multiflux, mc].
    #[arg(long)]
    pub tolerance: Option<f64>,
    /// Compute every effect (planner off), for comparison.
    #[arg(long)]
    pub all_effects: bool,
    /// Two-flux coefficients K, S from the scene [km] (default seed: K = sigma_a, S = sigma_s).
    #[arg(long, value_enum, default_value_t = km::KmMapping::Seed)]
    pub km_mapping: km::KmMapping,
    /// Gauss nodes per hemisphere [multiflux] (default 16).
    #[arg(long)]
    pub streams: Option<usize>,
    /// Truncate adding after this Neumann order (seed eq. 21) [multiflux]; default exact.
    #[arg(long)]
    pub order: Option<usize>,
    /// Directions on the sphere, both hemispheres, in the medium of lowest index (4..=2000)
    /// [direction-set] (default 303, the seed's).
    #[arg(long, value_name = "N")]
    pub directions: Option<usize>,
    /// Photons per channel [mc].
    #[arg(long, default_value_t = 1_000_000)]
    pub samples: u64,
    /// Seed [mc]; the same seed gives bit-identical results for any thread count.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Worker threads [mc] (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Absorption estimator [mc].
    #[arg(long, value_enum, default_value_t = km::Estimator::SurvivalBiasing)]
    pub estimator: km::Estimator,
    /// Run shard I of N (0-based) and write its partial tally to --out [mc].
    #[arg(long, value_name = "I/N")]
    pub shard: Option<String>,
    /// Multiply every default work and memory budget (Monte Carlo photon steps and tally
    /// memory, multi-flux work) by this factor; see docs/limits.md [mc, multiflux].
    #[arg(long, value_name = "FACTOR", default_value_t = 1.0)]
    pub budget: f64,
    /// Solve K times in this process: `seconds` stays the first (cold) call's,
    /// `seconds_best` and `seconds_median` are over all K calls (1..=10000).
    #[arg(long, value_name = "K", default_value_t = 1,
          value_parser = clap::value_parser!(u32).range(1..=10_000))]
    pub repeat: u32,
    /// How F_dr is computed [dipole].
    #[arg(long, value_enum, default_value_t = km::FdrModel::Exact)]
    pub fdr: km::FdrModel,
    /// Which dipole [dipole].
    #[arg(long, value_enum, default_value_t = km::DipoleModel::Jensen2001)]
    pub dipole: km::DipoleModel,
}

/// The `--method` values: the library's method registry.
fn method_parser() -> impl clap::builder::TypedValueParser<Value = Method> {
    clap::builder::PossibleValuesParser::new(Method::ALL.map(Method::name))
        .try_map(|s| s.parse::<Method>())
}

/// The `km profile --method` values: the methods that give `Rd(r)`.
fn profile_method_parser() -> impl clap::builder::TypedValueParser<Value = Method> {
    clap::builder::PossibleValuesParser::new([Method::Dipole.name(), Method::Mc.name()])
        .try_map(|s| s.parse::<Method>())
}

/// `--json` or `--format` (table by default).
fn output_format(json: bool, format: Option<OutputFormat>) -> OutputFormat {
    format.unwrap_or(if json { OutputFormat::Json } else { OutputFormat::Table })
}

/// Output format of `km solve`, `km merge` and `km profile`.
#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum OutputFormat {
    /// Text for people.
    Table,
    /// The JSON contract of docs/cli.md.
    Json,
    /// Comma-separated values with a header.
    Csv,
}

fn main() -> ExitCode {
    stdout::init();
    let matches = Cli::command().get_matches();
    let cli = Cli::from_arg_matches(&matches).unwrap_or_else(|e| e.exit());
    match methods::check_flags(&matches).and_then(|()| run(cli)) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::from(2)
        }
    }
}

fn print_solution(
    sol: &km::Solution,
    scene: Option<&km::Scene>,
    format: OutputFormat,
) -> anyhow::Result<()> {
    match format {
        OutputFormat::Json => {
            stdout::print(&format!("{}\n", serde_json::to_string_pretty(&sol.to_json())?))
        }
        OutputFormat::Csv => stdout::print(&km::text::csv(sol, scene)),
        OutputFormat::Table => stdout::print(&km::text::table(sol, scene)),
    }
}

/// Write `value` to `path` atomically, never over one of `inputs` (docs/limits.md).
fn write_json(
    path: &std::path::Path,
    value: &serde_json::Value,
    inputs: &[PathBuf],
) -> anyhow::Result<()> {
    let text = serde_json::to_string_pretty(value)?;
    let opts = km::atomic_file::WriteOptions { inputs: inputs.to_vec(), ..Default::default() };
    km::atomic_file::write_atomic_with(path, text.as_bytes(), &opts)
        .with_context(|| format!("cannot write {}", path.display()))
}

/// Read a scene file with the `--set` edits applied (km_core::set).
fn load(path: &std::path::Path, set: &[String]) -> anyhow::Result<km::Scene> {
    let edits = set.iter().map(|s| km::SetEdit::parse(s)).collect::<Result<Vec<_>, _>>()?;
    Ok(km::Scene::from_path_edited(path, &edits)?)
}

/// `km solve`: one run, or one shard of a Monte Carlo run written to `--out`.
fn solve(args: &SolveArgs) -> anyhow::Result<()> {
    let scene = load(&args.scene, &args.set)?;
    if let Some(shard) = &args.shard {
        let (i, n) = methods::parse_shard(shard)?;
        if args.repeat > 1 {
            bail!("--repeat does not combine with --shard (a shard is written once)");
        }
        if args.method != Method::Mc {
            bail!("--shard applies to --method mc only");
        }
        let Some(out) = &args.out else {
            bail!("--shard {shard} needs --out FILE for the partial tally");
        };
        let part = km::mc_shard(&scene, &methods::options(args)?, i, n)?;
        write_json(out, &serde_json::to_value(&part)?, std::slice::from_ref(&args.scene))?;
        eprintln!("wrote shard {i}/{n} to {}", out.display());
        return Ok(());
    }
    let sol = methods::solve(&scene, args)?;
    if let Some(out) = &args.out {
        write_json(out, &sol.to_json(), std::slice::from_ref(&args.scene))?;
    }
    print_solution(&sol, Some(&scene), args.output_format())
}

/// `km sweep`: the fixed edits and the axes of `--set`, solved over the grid, printed.
fn sweep(
    scene: &std::path::Path,
    set: &[String],
    method: Method,
    format: km::SweepFormat,
) -> anyhow::Result<()> {
    // Read as every scene file is read (regular file or `-`, size limit).
    let text = km::read_scene_text(scene, km::SceneLimits::from_env().max_bytes)
        .with_context(|| format!("{}", scene.display()))?;
    let (mut edits, mut axes) = (Vec::new(), Vec::new());
    for s in set {
        if s.split_once('=').is_some_and(|(_, v)| v.split(':').count() == 3) {
            axes.push(km::SweepAxis::parse(s)?);
        } else {
            edits.push(km::SetEdit::parse(s)?);
        }
    }
    if axes.is_empty() {
        bail!("km sweep needs at least one --set KEY=START:STOP:N");
    }
    let opts = methods::options(&SolveArgs::defaults(method))?;
    let points = km::sweep(&text, &edits, &axes, &opts)?;
    stdout::print(&km::sweep_text(&axes, &points, format))
}

fn run(cli: Cli) -> anyhow::Result<()> {
    let command = cli.command.unwrap_or(Command::Reproduce {
        out: PathBuf::from("out"),
        quick: true,
        full: false,
        seed: 1,
        quiet: false,
        only: None,
    });
    match command {
        Command::Demo => {
            let scene = km::Scene::from_toml_str(DEMO_SCENE)?;
            stdout::print("km: built-in example (examples/seed-three-layers.toml)\n\n")?;
            for method in [Method::Km, Method::Multiflux, Method::Mc] {
                let args = SolveArgs::defaults(method);
                let sol = methods::solve(&scene, &args)?;
                stdout::print(&format!("{}\n", km::text::table(&sol, Some(&scene))))?;
            }
            if let Err(e) = km::solve(&scene, &km::Options::new(Method::Dipole)) {
                stdout::print(&format!("dipole: skipped: {e}\n"))?;
            }
            Ok(())
        }
        Command::Solve(args) => solve(&args),
        Command::Bsdf(args) => bsdf::main(&args),
        Command::Merge { parts, json, format, out } => {
            let sol = km_montecarlo::merge_files(&parts)?;
            if let Some(out) = &out {
                write_json(out, &sol.to_json(), &parts)?;
            }
            print_solution(&sol, None, output_format(json, format))
        }
        Command::Profile { scene, set, method, r_max, points, samples, seed, json, format } => {
            let s = load(&scene, &set)?;
            let opts = km::ProfileOptions { method, r_max, points, samples, seed };
            methods::profile(&s, &opts, output_format(json, format))
        }
        Command::Sweep { scene, set, method, format } => sweep(&scene, &set, method, format),
        Command::Plan { scene, set, method, json, all_effects } => {
            let s = load(&scene, &set)?;
            let plan = km::plan_for(&s, method, all_effects);
            if json {
                let mut v = plan.to_json();
                v["method"] = serde_json::json!(method.name());
                stdout::print(&format!("{}\n", serde_json::to_string_pretty(&v)?))
            } else {
                stdout::print(&km::text::plan_words(&plan, method))
            }
        }
        Command::Fit(args) => fit::run(&args),
        Command::Check { scene, set } => {
            let s = load(&scene, &set)?;
            stdout::print(&km::text::describe(&s))
        }
        Command::Reproduce { out, quick: _, full, seed, quiet, only } => {
            let mut opts = if full {
                km_bench::ReproduceOptions::full(out)
            } else {
                km_bench::ReproduceOptions::quick(out)
            };
            opts.seed = seed;
            opts.quiet = quiet;
            opts.only = only;
            let summary = km_bench::reproduce(&opts)?;
            stdout::print(&summary.to_string())?;
            if summary.failures() > 0 {
                bail!("{} item(s) of the reproduction failed (see the report)", summary.failures());
            }
            Ok(())
        }
    }
}

impl SolveArgs {
    /// The arguments of `km solve SCENE --method METHOD` with every other
    /// flag at its default (`km demo`, `km sweep`): the defaults are the
    /// flags' own, written once in the attributes above.
    fn defaults(method: Method) -> SolveArgs {
        let cmd = <SolveArgs as clap::Args>::augment_args(clap::Command::new("solve"));
        let m = cmd.get_matches_from(["solve", "-", "--method", method.name()]);
        SolveArgs::from_arg_matches(&m).unwrap_or_else(|e| e.exit())
    }

    /// The output format (`--json` is `--format json`).
    pub fn output_format(&self) -> OutputFormat {
        if self.json { OutputFormat::Json } else { self.format.unwrap_or(OutputFormat::Table) }
    }

    /// Whether a progress bar may be shown (text output, stderr is a terminal).
    pub fn progress(&self) -> bool {
        self.output_format() == OutputFormat::Table && std::io::stderr().is_terminal()
    }
}
