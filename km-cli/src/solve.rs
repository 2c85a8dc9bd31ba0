//! `km solve` and the commands that run a method (`profile`, `sweep`):
//! from the flags to the library's options (`km::Options`), the flag names
//! added to the library's refusals, and the output in the chosen format.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use km::settings::command_line::method_parser;
use km::settings::method_flag_error;
use km::{Method, Scene, Solution};

pub use km::text::Format as OutputFormat;

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
    #[arg(long, short, value_parser = method_parser(&Method::ALL), default_value = "multiflux")]
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
    pub settings: km::settings::command_line::SolveFlags,
    #[command(flatten)]
    pub colour: crate::colour::ColourArgs,
}

/// `km solve`: one run, or one shard of a Monte Carlo run written to `--out`.
pub fn run(args: &SolveArgs) -> Result<()> {
    let scene = args.input.load()?;
    let inputs = std::slice::from_ref(&args.input.scene);
    let settings = args.settings.settings(args.method)?;
    if let Some((i, n)) = settings.shard() {
        if args.colour.colour {
            bail!(
                "--colour does not combine with --shard (a shard prints nothing; `km merge` does)"
            );
        }
        let Some(out) = &args.out else {
            bail!("--shard {i}/{n} needs --out FILE for the partial tally");
        };
        let part = args.settings.shard(&scene, &settings, (i, n))?;
        write_json(out, &serde_json::to_value(&part)?, inputs)?;
        stdout::eprint(&format!("wrote shard {i}/{n} to {}\n", out.display()))?;
        return Ok(());
    }
    let format = OutputFormat::of(args.json, args.format);
    if args.colour.colour {
        return run_colour(args, &scene, format);
    }
    let sol = args.settings.solve(&scene, args.method)?;
    if let Some(out) = &args.out {
        write_json(out, &sol.to_json(), inputs)?;
    }
    print(&sol, Some(&scene), format)
}

/// `km solve --colour [--swatch FILE]`: the solution with the colours of its
/// spectra (JSON key `colour`, or lines after the table).
fn run_colour(args: &SolveArgs, scene: &Scene, format: OutputFormat) -> Result<()> {
    let inputs = std::slice::from_ref(&args.input.scene);
    if format == OutputFormat::Csv {
        bail!(
            "--colour is the colour of the whole spectrum, not a value per wavelength: use \
             --format table or json"
        );
    }
    let wavelengths = crate::colour::wavelengths(scene)?;
    let sol = args.settings.solve(scene, args.method)?;
    let colours = crate::colour::of_solution(&wavelengths, &sol)?;
    let mut v = sol.to_json();
    v["colour"] = crate::colour::json(&colours);
    if let Some(path) = &args.colour.swatch {
        let patches: Vec<_> = colours.iter().map(|(n, c)| c.patch((*n).into())).collect();
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
    let (table, csv) = (|| km::text::table(sol, scene), || km::text::csv(sol, scene));
    stdout::print(&format.text(table, csv, || sol.to_json()))
}

/// Write `value` to `path` atomically, never over one of `inputs` (docs/limits.md).
pub fn write_json(path: &Path, value: &serde_json::Value, inputs: &[PathBuf]) -> Result<()> {
    let text = serde_json::to_string_pretty(value)?;
    let opts = km::atomic_file::WriteOptions { inputs: inputs.to_vec(), ..Default::default() };
    km::atomic_file::write_atomic_with(path, text.as_bytes(), &opts)
        .with_context(|| format!("cannot write {}", path.display()))
}

/// `km profile`: Rd(r) by the dipole or Monte Carlo, printed.
pub fn profile(scene: &Scene, opts: &km::ProfileOptions, format: OutputFormat) -> Result<()> {
    let p = km::profile(scene, opts).map_err(|e| method_flag_error(e, opts.method))?;
    stdout::print(&format.text(|| p.table(), || p.csv(), || p.to_json()))
}
