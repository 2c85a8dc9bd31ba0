//! `km solve` and the commands that run a method (`profile`, `sweep`):
//! from the flags to the library's options (`km::Options`), the flag names
//! added to the library's refusals, and the output in the chosen format.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use clap::ValueEnum;
use clap::builder::TypedValueParser;
use km::settings::{FlagError, option_flag};
use km::{KmError, Method, Scene, Solution};

use crate::stdout;

// A scene file and its edits (no doc comment: it would become the command's about).
#[derive(clap::Args, Debug, Clone)]
pub struct SceneArg {
    /// Scene file (TOML, see docs/scene-file.md).
    pub scene: PathBuf,
    /// Edit the scene before validation: KEY=VALUE, keys as the errors spell them
    /// (`layer[1].g=0.8`, `light.theta_deg=60`); repeatable.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
}

impl SceneArg {
    /// The scene file with the `--set` edits applied (km_core::set).
    pub fn load(&self) -> Result<Scene> {
        let edits = self.set.iter().map(|s| km::SetEdit::parse(s)).collect::<Result<Vec<_>, _>>();
        Ok(Scene::from_path_edited(&self.scene, &edits?)?)
    }
}

// The flags of `km solve` (no doc comment: it would become the command's about).
#[derive(clap::Args, Debug, Clone)]
pub struct SolveArgs {
    #[command(flatten)]
    pub input: SceneArg,
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
    #[command(flatten)]
    pub settings: MethodArgs,
    #[command(flatten)]
    pub colour: crate::colour::ColourArgs,
}

// The settings of a solve, one flag each (km::settings::SETTINGS; the same
// flags in `km solve` and `km sweep`; no doc comment: it would become the
// command's about).
#[derive(clap::Args, Debug, Clone)]
pub struct MethodArgs {
    /// Accuracy target: every number asked for (R, T, their delta parts, each BRDF/BTDF value)
    /// within TOL * max(1, |x|); chooses streams or samples, reports `error_estimate` and
    /// `tolerance.limited_by`, fails when unreachable [multiflux, mc].
    #[arg(long)]
    pub tolerance: Option<f64>,
    /// Compute every effect (planner off), for comparison.
    #[arg(long)]
    pub all_effects: bool,
    /// Two-flux coefficients K, S from the scene [km] (default gate1974, the least error
    /// against multi-flux on the grid of docs/two-flux.md §13; seed: the paper's K = sigma_a,
    /// S = sigma_s).
    #[arg(long, value_enum, default_value_t = km::KmMapping::Gate1974)]
    pub km_mapping: km::KmMapping,
    /// Two-flux model [km]: four-flux carries a collimated beam as a beam (refracted,
    /// Beer–Lambert on its path, Fresnel at its own angle); two-flux is the seed's diffuse
    /// model (default four-flux; the same for diffuse light).
    #[arg(long, value_enum, default_value_t = km::KmModel::FourFlux)]
    pub km_model: km::KmModel,
    /// Gauss nodes per hemisphere [multiflux] (default 16).
    #[arg(long)]
    pub streams: Option<usize>,
    /// Truncate adding after this Neumann order (seed eq. 21) [multiflux]; default exact.
    #[arg(long)]
    pub order: Option<usize>,
    /// Directions on the sphere, both hemispheres, in the medium of lowest index (4..=2000)
    /// [direction-set] (the default is the seed's 303).
    #[arg(long, value_name = "N", default_value_t = km::direction_set::DEFAULT_DIRECTIONS)]
    pub directions: usize,
    /// BRDF/BTDF values as means over cones of this half-angle, degrees, in (0, 45]: the
    /// Monte Carlo bins (default 5), or the multi-flux values averaged over the same cones
    /// for comparison with them [mc, multiflux].
    #[arg(long, value_name = "DEG")]
    pub cone: Option<f64>,
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
    /// Multiply every default work and memory budget by this factor: one solve's (Monte Carlo
    /// photon steps and tally memory, multi-flux work) and a request of many points' (every
    /// method); see docs/limits.md.
    #[arg(long, value_name = "FACTOR", default_value_t = 1.0)]
    pub budget: f64,
    /// Solve K times in this process: `seconds` stays the first (cold) call's,
    /// `seconds_best` and `seconds_median` are over all K calls (1..=10000).
    #[arg(long, value_name = "K", default_value_t = 1,
          value_parser = clap::value_parser!(u32).range(1..=10_000))]
    pub repeat: u32,
    /// No progress bar on stderr (it is drawn only for a solve expected to last more than
    /// 2 s, and never when stderr is not a terminal).
    #[arg(long)]
    pub quiet: bool,
    /// How F_dr is computed [dipole].
    #[arg(long, value_enum, default_value_t = km::FdrModel::Exact)]
    pub fdr: km::FdrModel,
    /// Which dipole [dipole].
    #[arg(long, value_enum, default_value_t = km::DipoleModel::Jensen2001)]
    pub dipole: km::DipoleModel,
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

impl OutputFormat {
    /// `--json` or `--format` (table by default).
    pub fn of(json: bool, format: Option<OutputFormat>) -> OutputFormat {
        format.unwrap_or(if json { OutputFormat::Json } else { OutputFormat::Table })
    }
}

/// The `--method` values: the library's method registry.
pub fn method_parser() -> impl TypedValueParser<Value = Method> {
    clap::builder::PossibleValuesParser::new(Method::ALL.map(Method::name))
        .try_map(|s| s.parse::<Method>())
}

/// The `km profile --method` values: the methods that give `Rd(r)`.
pub fn profile_method_parser() -> impl TypedValueParser<Value = Method> {
    clap::builder::PossibleValuesParser::new([Method::Dipole.name(), Method::Mc.name()])
        .try_map(|s| s.parse::<Method>())
}

impl SolveArgs {
    /// `km solve - --method METHOD`, every other flag at its default (`km demo`, `km sweep`).
    pub fn defaults(method: Method) -> SolveArgs {
        crate::parse_args(&["solve", "-", "--method", method.name()])
    }
}

/// `km solve`: one run, or one shard of a Monte Carlo run written to `--out`.
pub fn run(args: &SolveArgs) -> Result<()> {
    let scene = args.input.load()?;
    let inputs = std::slice::from_ref(&args.input.scene);
    if let Some(shard) = &args.settings.shard {
        let (i, n) = parse_shard(shard)?;
        if args.settings.repeat > 1 {
            bail!("--repeat does not combine with --shard (a shard is written once)");
        }
        if args.method != Method::Mc {
            bail!("--shard applies to --method mc only");
        }
        let Some(out) = &args.out else {
            bail!("--shard {shard} needs --out FILE for the partial tally");
        };
        let mut opts = args.settings.options(args.method)?;
        let _bar = args.progress().then(|| km::progress::attach(&scene, &mut opts));
        let part = km::mc_shard(&scene, &opts, i, n)?;
        write_json(out, &serde_json::to_value(&part)?, inputs)?;
        stdout::eprint(&format!("wrote shard {i}/{n} to {}\n", out.display()))?;
        return Ok(());
    }
    let format = OutputFormat::of(args.json, args.format);
    if args.colour.colour {
        return run_colour(args, &scene, format);
    }
    let sol = solve(&scene, args)?;
    if let Some(out) = &args.out {
        write_json(out, &sol.to_json(), inputs)?;
    }
    print(&sol, Some(&scene), format)
}

/// `km solve --colour [--swatch FILE]`: the solution with the colours of its
/// spectra (JSON key `colour`, or lines after the table).
fn run_colour(args: &SolveArgs, scene: &Scene, format: OutputFormat) -> Result<()> {
    let inputs = std::slice::from_ref(&args.input.scene);
    if args.settings.shard.is_some() {
        bail!("--colour does not combine with --shard (a shard prints nothing; `km merge` does)");
    }
    if format == OutputFormat::Csv {
        bail!(
            "--colour is the colour of the whole spectrum, not a value per wavelength: use \
             --format table or json"
        );
    }
    let wavelengths = crate::colour::wavelengths(scene)?;
    let sol = solve(scene, args)?;
    let colours = crate::colour::of_solution(&wavelengths, &sol)?;
    let mut v = sol.to_json();
    v["colour"] = crate::colour::json(&colours);
    if let Some(path) = &args.colour.swatch {
        let patches: Vec<_> =
            colours.iter().map(|(n, c)| crate::colour::patch((*n).into(), c)).collect();
        crate::colour::write_swatch(path, &patches, inputs)?;
    }
    if let Some(out) = &args.out {
        write_json(out, &v, inputs)?;
    }
    match format {
        OutputFormat::Table => stdout::print(
            &(km::text::table(&sol, Some(scene)) + &crate::colour::table_lines(&colours)),
        ),
        _ => stdout::print_json(&v),
    }
}

/// Print a solution as a table, JSON or CSV.
pub fn print(sol: &Solution, scene: Option<&Scene>, format: OutputFormat) -> Result<()> {
    stdout::print(&match format {
        OutputFormat::Json => return stdout::print_json(&sol.to_json()),
        OutputFormat::Csv => km::text::csv(sol, scene),
        OutputFormat::Table => km::text::table(sol, scene),
    })
}

/// Write `value` to `path` atomically, never over one of `inputs` (docs/limits.md).
pub fn write_json(path: &Path, value: &serde_json::Value, inputs: &[PathBuf]) -> Result<()> {
    let text = serde_json::to_string_pretty(value)?;
    let opts = km::atomic_file::WriteOptions { inputs: inputs.to_vec(), ..Default::default() };
    km::atomic_file::write_atomic_with(path, text.as_bytes(), &opts)
        .with_context(|| format!("cannot write {}", path.display()))
}

/// Solve `scene` with the method and options of `args` (through
/// [`km::solve_repeated`], `--repeat` times; progress on stderr when it may be shown).
pub fn solve(scene: &Scene, args: &SolveArgs) -> Result<Solution> {
    let s = &args.settings;
    let mut opts = args.settings.options(args.method)?;
    let _bar = args.progress().then(|| km::progress::attach(scene, &mut opts));
    km::solve_repeated(scene, &opts, s.repeat).map_err(|e| flag_error(e, args.method, s.tolerance))
}

/// A library refusal in the words of the flags that caused it
/// (`km::settings::solve_flag_error`).
pub fn flag_error(e: KmError, method: Method, tolerance: Option<f64>) -> anyhow::Error {
    km::settings::solve_flag_error(e, method, tolerance).into()
}

impl SolveArgs {
    /// Whether a progress bar may be shown (stderr is a terminal, no `--quiet`).
    fn progress(&self) -> bool {
        km::progress::wanted(self.settings.quiet)
    }
}

impl MethodArgs {
    /// The library options of these settings for `method`.
    pub fn options(&self, method: Method) -> Result<km::Options> {
        if self.tolerance.is_some() && self.streams.is_some() {
            bail!("give either --streams or --tolerance, not both");
        }
        options(method, self)
    }
}

/// The library options of the settings `args` for `method`.
fn options(method: Method, args: &MethodArgs) -> Result<km::Options> {
    let method = match method {
        Method::Km => {
            km::MethodOptions::Km(km::KmOptions { mapping: args.km_mapping, model: args.km_model })
        }
        Method::Multiflux => km::MethodOptions::Multiflux(km::MultifluxOptions {
            streams: args.streams,
            neumann_order: args.order,
            all_effects: args.all_effects,
            ..Default::default()
        }),
        Method::DirectionSet => {
            km::MethodOptions::DirectionSet(km::DirectionSetOptions { directions: args.directions })
        }
        Method::Mc if args.samples == 0 => bail!("--samples must be at least 1"),
        Method::Mc => km::MethodOptions::Mc(km::McOptions {
            samples: args.samples,
            seed: args.seed,
            threads: args.threads,
            estimator: args.estimator,
            all_effects: args.all_effects,
            ..Default::default()
        }),
        Method::Dipole => {
            km::MethodOptions::Dipole(km::DipoleOptions { fdr: args.fdr, model: args.dipole })
        }
    };
    let opts = km::Options {
        method,
        tolerance: args.tolerance,
        all_effects: args.all_effects,
        cone_deg: args.cone,
        budget: 1.0,
        cancel: None,
    };
    Ok(opts.with_budget(args.budget).map_err(option_flag)?)
}

/// `I/N` with `0 <= I < N`.
fn parse_shard(text: &str) -> Result<(u64, u64)> {
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
        e => FlagError::after(format!("--method {}", opts.method.name()), e),
    })?;
    stdout::print(&match format {
        OutputFormat::Json => return stdout::print_json(&p.to_json()),
        OutputFormat::Csv => p.csv(),
        OutputFormat::Table => p.table(),
    })
}

/// Refuse a flag that does not apply to the chosen method or mode (clap cannot
/// know the method: checked after parsing; `km::settings::refuse_flags`).
pub fn check_flags(matches: &clap::ArgMatches) -> Result<()> {
    let Some((command, m)) = matches.subcommand() else { return Ok(()) };
    let given = |id: &str| {
        matches!(m.try_get_raw(id), Ok(Some(_)))
            && m.value_source(id) == Some(clap::parser::ValueSource::CommandLine)
    };
    let method = m.try_get_one::<Method>("method").ok().flatten().copied();
    km::settings::refuse_flags(command, method, given).map_err(anyhow::Error::msg)
}
