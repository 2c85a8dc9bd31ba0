//! `km`: light in stacks of flat scattering layers, from the command line.
//!
//! Thin: parse the command line and the scene file, call the libraries, print.

mod methods;
mod output;

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand, ValueEnum};

/// The scene solved by `km` (and `cargo run`) without arguments.
const DEMO_SCENE: &str = include_str!("../../examples/seed-three-layers.toml");

#[derive(Parser)]
#[command(
    name = "km",
    version,
    about = "Reflection, transmission and the light field of stacks of flat scattering layers",
    long_about = "Reflection, transmission and the light field of stacks of flat scattering \
layers (paint, coatings, skin, milk, clouds), by four methods over one scene file:\n\
  km         two-flux Kubelka–Munk, closed form\n\
  multiflux  multi-flux eigenvalue solver (discrete ordinates)\n\
  mc         Monte Carlo reference tracer\n\
  dipole     diffusion dipole for semi-infinite media\n\n\
Without a subcommand, solves a built-in example scene (the seed paper's three-layer example).",
    after_help = "Examples:\n  km solve examples/seed-three-layers.toml --method km --json\n  km check examples/paint-over-primer.toml\n  km"
)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Subcommand)]
enum Command {
    /// Solve a scene file with one method and print the result.
    #[command(after_help = "Examples:\n  km solve examples/fresnel-slab.toml --method km\n  \
km solve examples/seed-three-layers.toml --method km --json\n  \
km solve examples/paint-over-primer.toml --method km --km-mapping star-1988 --json")]
    Solve(SolveArgs),
    /// Print what a scene calls for: effects present, work skipped and why.
    #[command(after_help = "Examples:\n  km plan examples/seed-three-layers.toml\n  \
km plan examples/paint-over-primer.toml --method mc --json")]
    Plan {
        /// Scene file (TOML, see docs/scene-file.md).
        scene: PathBuf,
        /// Method whose decisions to show.
        #[arg(long, short, value_enum, default_value_t = Method::Multiflux)]
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
    },
}

/// Arguments of `km solve`.
#[derive(clap::Args, Debug, Clone)]
pub struct SolveArgs {
    /// Scene file (TOML, see docs/scene-file.md).
    pub scene: PathBuf,
    /// Method.
    #[arg(long, short, value_enum, default_value_t = Method::Km)]
    pub method: Method,
    /// Print one JSON object (the contract of docs/cli.md) instead of a table.
    #[arg(long)]
    pub json: bool,
    /// Two-flux coefficients from (sigma_a, sigma_s, g) [km].
    #[arg(long, value_enum, default_value_t = KmMappingArg::Seed)]
    pub km_mapping: KmMappingArg,
}

/// The methods of km.
#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    /// Two-flux Kubelka–Munk (closed form).
    Km,
    /// Multi-flux eigenvalue solver (coming).
    Multiflux,
    /// Monte Carlo reference (coming).
    Mc,
    /// Diffusion dipole for a semi-infinite layer (coming).
    Dipole,
}

impl Method {
    /// The name used in JSON and messages.
    pub fn name(self) -> &'static str {
        match self {
            Method::Km => "km",
            Method::Multiflux => "multiflux",
            Method::Mc => "mc",
            Method::Dipole => "dipole",
        }
    }
}

/// How the two-flux coefficients K, S are obtained from the scene.
#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum KmMappingArg {
    /// K = sigma_a, S = sigma_s, as in the seed paper.
    Seed,
    /// The named published mapping from (sigma_a, sigma_s, g), see docs/two-flux.md.
    #[value(name = "star-1988")]
    Star1988,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::from(2)
        }
    }
}

fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        None => {
            // The built-in example: the seed's three-layer scene by two-flux KM.
            let scene = km_core::Scene::from_toml_str(DEMO_SCENE)?;
            println!("km: built-in example (examples/seed-three-layers.toml)\n");
            for method in [Method::Km] {
                let args = SolveArgs {
                    scene: PathBuf::from("examples/seed-three-layers.toml"),
                    method,
                    json: false,
                    km_mapping: KmMappingArg::Seed,
                };
                let sol = methods::solve(&scene, &args)?;
                print!("{}", output::table(&sol, &scene));
                println!();
            }
            println!("Try: km solve examples/paint-over-primer.toml --method km --json");
            Ok(())
        }
        Some(Command::Solve(args)) => {
            let scene = km_core::Scene::from_path(&args.scene)?;
            let sol = methods::solve(&scene, &args)?;
            if args.json {
                println!("{}", serde_json::to_string_pretty(&sol.to_json())?);
            } else {
                print!("{}", output::table(&sol, &scene));
            }
            Ok(())
        }
        Some(Command::Plan { scene, method, json, all_effects }) => {
            let s = km_core::Scene::from_path(&scene)?;
            let request = km_core::plan::Request::from_scene(&s.channels[0]);
            let plan = km_core::plan::plan_scene(&s, request, all_effects);
            if json {
                let mut v = plan.to_json();
                v["method"] = serde_json::json!(method.name());
                println!("{}", serde_json::to_string_pretty(&v)?);
            } else {
                print!("{}", output::plan_words(&plan, method));
            }
            Ok(())
        }
        Some(Command::Check { scene }) => {
            let s = km_core::Scene::from_path(&scene)?;
            print!("{}", output::describe(&s));
            Ok(())
        }
    }
}
