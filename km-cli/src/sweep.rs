//! `km sweep`: one scene solved over a grid of edited values, with every
//! setting `km solve` takes ([`MethodArgs`], the same flags), one row per
//! point (and channel), computed by `km::sweep`.

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use km::Method;
use km_inverse::colour::MAX_PATCHES;

use crate::stdout;
use km::settings::command_line::{method_parser, solve_error};

// The flags of `km sweep` (no doc comment: it would become the command's about).
#[derive(clap::Args, Debug)]
pub struct SweepArgs {
    /// Scene file (TOML, see docs/scene-file.md).
    pub scene: PathBuf,
    /// KEY=START:STOP:N (N equally spaced values, a grid over several; the first
    /// varies slowest) or KEY=VALUE (a fixed edit); repeatable.
    #[arg(long = "set", value_name = "KEY=START:STOP:N", required = true)]
    pub set: Vec<String>,
    /// Method.
    #[arg(long, short, value_parser = method_parser(&Method::ALL), default_value = "multiflux")]
    pub method: Method,
    /// Output format.
    #[arg(long, value_enum, default_value_t = km::SweepFormat::Table)]
    pub format: km::SweepFormat,
    #[command(flatten)]
    pub settings: km::settings::command_line::SolveFlags,
    #[command(flatten)]
    pub colour: crate::colour::ColourArgs,
}

/// `km sweep`: the fixed edits and the axes of `--set`, solved over the grid
/// with the method's settings, printed.
pub fn run(args: &SweepArgs) -> Result<()> {
    // Read as every scene file is read (regular file or `-`, size limit).
    let text = km::read_scene_text(&args.scene, km::SceneLimits::from_env().max_bytes)
        .with_context(|| format!("{}", args.scene.display()))?;
    let (edits, axes) = km::SweepAxis::split(&args.set)?;
    if axes.is_empty() {
        bail!("km sweep needs at least one --set KEY=START:STOP:N");
    }
    let settings = args.settings.settings(args.method)?;
    if let Some(km::settings::Value::Real(b)) = settings.get("budget")
        && !(b.is_finite() && *b > 0.0)
    {
        bail!("--budget must be a finite factor > 0, not {b}");
    }
    // The colour needs the scene's wavelengths: checked before any point is solved.
    let wavelengths = if args.colour.colour {
        let scene = km::Scene::from_toml_str_edited(&text, &edits)
            .with_context(|| format!("{}", args.scene.display()))?;
        let points: usize = axes.iter().map(|a| a.n).product();
        if args.colour.swatch.is_some() && points > MAX_PATCHES {
            bail!(
                "--swatch draws one patch per point, at most {MAX_PATCHES}; the sweep has {points}"
            );
        }
        Some(crate::colour::wavelengths(&scene)?)
    } else {
        None
    };
    // The points run in parallel: no progress bar.
    let opts = args.settings.options(&settings)?;
    let points = km::sweep(&text, &edits, &axes, &opts).map_err(|e| solve_error(e, &settings))?;
    let Some(w) = wavelengths else {
        return stdout::print(&km::sweep_text(&axes, &points, args.format));
    };
    let (rows, patches) = crate::colour::sweep_text(&axes, &points, &w, args.format)?;
    if let Some(path) = &args.colour.swatch {
        crate::colour::write_swatch(path, &patches, std::slice::from_ref(&args.scene))?;
    }
    stdout::print(&rows)
}
