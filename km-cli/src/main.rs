//! `km`: light in stacks of flat scattering layers, from the command line.
//!
//! Argument parsing and printing only: the libraries (`km`, `km_inverse`,
//! `km_bench`) compute and write the text; this crate turns the flags into
//! their options, their refusals into messages naming the flags, and prints.
//! The longer `--help` texts live in `km-cli/help/`.

/// The text of `km-cli/help/NAME.txt` (for `long_about` and `after_help`).
macro_rules! help {
    ($name:literal) => {
        include_str!(concat!("../help/", $name, ".txt"))
    };
}

mod bsdf;
mod colour;
mod field;
mod fit;
mod mc;
mod phase;
#[cfg(test)]
mod settings_parity;
mod solve;
mod stdout;
mod sweep;

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};
use km::Method;
use km::settings::command_line::method_parser;
use solve::{OutputFormat, SceneArg};

/// The scene solved by `km demo`.
const DEMO_SCENE: &str = include_str!("../../examples/seed-three-layers.toml");

#[derive(Parser)]
#[command(
    name = "km",
    version,
    about = "Reflection, transmission and the light field of stacks of flat scattering layers",
    long_about = help!("about").trim_end(),
    after_help = help!("km")
)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Subcommand)]
#[allow(clippy::large_enum_variant)] // parsed once per process; boxing buys nothing
enum Command {
    /// Solve a scene file with one method and print the result.
    #[command(after_help = help!("solve"))]
    Solve(solve::SolveArgs),
    /// Optical properties from measured reflectance and transmittance (the inverse problem).
    Fit(fit::FitArgs),
    /// The whole BSDF of the stack as a table (npz, csv) or a Fourier BSDF file (Mitsuba 0.6, pbrt-v3).
    #[command(after_help = help!("bsdf"))]
    Bsdf(bsdf::BsdfArgs),
    /// Run an MCML input file (.mci): every run, written as MCML output (.mco) and .npz.
    #[command(after_help = help!("mc"))]
    Mc(mc::McArgs),
    /// Fluence rate, absorbed power density and net flux at the scene's [output] depths.
    #[command(after_help = help!("field"))]
    Field(field::FieldArgs),
    /// Each layer's phase function, its Legendre moments, g, and the particles' Mie efficiencies.
    #[command(after_help = help!("phase"))]
    Phase(phase::PhaseArgs),
    /// Combine Monte Carlo shard files into the result of one run.
    #[command(after_help = help!("merge"))]
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
    /// Radially resolved diffuse reflectance Rd(r) of a pencil beam (dipole: normal incidence).
    #[command(after_help = help!("profile"))]
    #[command(mut_arg("scene", |a| {
        a.help("Scene file (its single layer must be a half-space for the dipole)")
    }))]
    Profile {
        #[command(flatten)]
        input: SceneArg,
        #[command(flatten)]
        options: km::ProfileOptions,
        /// Print JSON instead of a table (the same as `--format json`).
        #[arg(long, conflicts_with = "format")]
        json: bool,
        /// Output format: table, json or csv (one row per radius).
        #[arg(long, value_enum)]
        format: Option<OutputFormat>,
    },
    /// Solve a scene over a grid of edited values, one row per point (and channel).
    #[command(after_help = help!("sweep"))]
    Sweep(sweep::SweepArgs),
    /// Print what a scene calls for: effects present, work skipped and why.
    #[command(after_help = help!("plan"))]
    Plan {
        #[command(flatten)]
        input: SceneArg,
        /// Method whose decisions to show.
        #[arg(long, short, value_parser = method_parser(&Method::ALL), default_value = "multiflux")]
        method: Method,
        /// Print JSON instead of words.
        #[arg(long)]
        json: bool,
        /// Turn the planner off (compute every effect), for comparison.
        #[arg(long)]
        all_effects: bool,
    },
    /// Parse and validate a scene file, and print what it describes.
    #[command(after_help = help!("check"))]
    Check(SceneArg),
    /// Solve the built-in example scene (the seed paper's three-layer example) by km, multiflux
    /// and mc (the dipole treats one semi-infinite layer only: skipped, with its reason).
    #[command(after_help = help!("demo"))]
    Demo,
    /// Regenerate the seed paper's figures and the accuracy/time study into DIR/report.md.
    #[command(after_help = help!("reproduce"))]
    Reproduce(km_bench::ReproduceRequest),
}

/// The arguments `T` of the command line `argv`, every flag not in it at
/// its default (the defaults are the flags' own, written once in their attributes).
fn parse_args<T: clap::Args + FromArgMatches>(argv: &[&'static str]) -> T {
    let cmd = T::augment_args(clap::Command::new(argv[0]));
    T::from_arg_matches(&cmd.get_matches_from(argv)).unwrap_or_else(|e| e.exit())
}

fn main() -> ExitCode {
    stdout::init();
    let cli = Cli::command().mut_subcommand("fit", fit::help_order);
    // `km bsdf`'s help lists --plot before --budget.
    let bsdf = |c| km::settings::command_line::place_after(c, "streams", "plot");
    let matches = cli.mut_subcommand("bsdf", bsdf).get_matches();
    let cli = Cli::from_arg_matches(&matches).unwrap_or_else(|e| e.exit());
    let command = cli.command.unwrap_or_else(|| Command::Reproduce(parse_args(&["reproduce"])));
    let checked =
        km::settings::command_line::refuse_given_flags(&matches).map_err(anyhow::Error::msg);
    let checked = checked.and_then(|()| fit::check_flags(&matches));
    match checked.and_then(|()| run(command)) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            stdout::report_error(&e);
            ExitCode::from(2)
        }
    }
}

fn run(command: Command) -> anyhow::Result<()> {
    match command {
        Command::Solve(args) => solve::run(&args),
        Command::Fit(args) => fit::run(&args),
        Command::Bsdf(args) => bsdf::run(&args),
        Command::Mc(args) => mc::run(&args),
        Command::Field(args) => field::run(&args),
        Command::Phase(args) => phase::run(&args),
        Command::Merge { parts, json, format, out } => {
            let sol = km::mc_merge_files(&parts)?;
            if let Some(out) = &out {
                solve::write_json(out, &sol.to_json(), &parts)?;
            }
            solve::print(&sol, None, OutputFormat::of(json, format))
        }
        Command::Profile { input, options, json, format } => {
            solve::profile(&input.load()?, &options, OutputFormat::of(json, format))
        }
        Command::Sweep(args) => sweep::run(&args),
        Command::Plan { input, method, json, all_effects } => {
            // The same check as `km solve`: a refused scene has no plan.
            let options = km::Options::new(method).with_all_effects(all_effects);
            let plan = km::check(&input.load()?, &options)
                .map_err(|e| km::settings::method_flag_error(e, method))?;
            if json {
                return stdout::print_json(&km::text::plan_json(&plan, method));
            }
            stdout::print(&km::text::plan_words(&plan, method))
        }
        Command::Check(input) => stdout::print(&km::text::describe(&input.load()?)),
        Command::Demo => {
            let scene = km::Scene::from_toml_str(DEMO_SCENE)?;
            stdout::print("km: built-in example (examples/seed-three-layers.toml)\n\n")?;
            for method in [Method::Km, Method::Multiflux, Method::Mc] {
                let sol = km::solve(&scene, &km::Options::new(method))?;
                stdout::print(&format!("{}\n", km::text::table(&sol, Some(&scene))))?;
            }
            if let Err(e) = km::solve(&scene, &km::Options::new(Method::Dipole)) {
                stdout::print(&format!("dipole: skipped: {e}\n"))?;
            }
            Ok(())
        }
        Command::Reproduce(request) => {
            let summary = km_bench::reproduce(&request.options())?;
            stdout::print(&summary.to_string())?;
            Ok(summary.check()?)
        }
    }
}
