//! `km field SCENE`: the fluence rate, absorbed power density and net flux
//! at the scene's `[output] depths` by one method (docs/cli.md,
//! docs/field.md), as a table, JSON or CSV, and optionally a chart.

use std::path::PathBuf;

use anyhow::{Result, bail};
use km::Method;
use km::field::{FieldMethod, FieldOptions, field};
use km_plot::chart::chart_target;
use km_plot::field::write_field_chart;

use crate::solve::{OutputFormat, SceneArg, method_parser};
use crate::stdout;

/// The flags of `km field`.
#[derive(clap::Args)]
pub struct FieldArgs {
    #[command(flatten)]
    pub input: SceneArg,
    /// Method: multiflux, km (two-flux), mc or dipole (direction-set refuses with the reason).
    #[arg(long, short, value_parser = method_parser(), default_value = "multiflux")]
    pub method: Method,
    /// Depths instead of the scene's [output] depths (comma-separated, the layers' length unit).
    #[arg(long, value_delimiter = ',', num_args = 1..)]
    pub depths: Option<Vec<f64>>,
    /// Gauss nodes per hemisphere [multiflux] (default: the solver's choice).
    #[arg(long)]
    pub streams: Option<usize>,
    /// Monte Carlo photons [mc].
    #[arg(long, default_value_t = 100_000)]
    pub samples: u64,
    /// Monte Carlo seed [mc].
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Monte Carlo depth-bin width [mc] (default: half the smallest gap between depths).
    #[arg(long)]
    pub dz: Option<f64>,
    /// Directions of the radiance inside, THETA:PHI in degrees, comma-separated
    /// (theta from the downward normal, > 90 up-going) instead of the scene's
    /// [output] inside_directions_deg [multiflux, mc].
    #[arg(long, value_delimiter = ',', num_args = 1.., value_parser = direction_parser)]
    pub directions: Option<Vec<[f64; 2]>>,
    /// Half-angle in degrees of the cone the Monte Carlo radiance inside is averaged over [mc].
    #[arg(long, default_value_t = km::field::DEFAULT_INSIDE_CONE_DEG)]
    pub mc_cone: f64,
    /// How F_dr is computed [dipole].
    #[arg(long, value_enum, default_value_t = km::DipoleOptions::default().fdr)]
    pub fdr: km::FdrModel,
    /// Which dipole [dipole].
    #[arg(long, value_enum, default_value_t = km::DipoleOptions::default().model)]
    pub dipole: km::DipoleModel,
    /// Print JSON (the same as `--format json`).
    #[arg(long, conflicts_with_all = ["format", "csv"])]
    pub json: bool,
    /// Print CSV, one row per channel and depth (the same as `--format csv`).
    #[arg(long, conflicts_with = "format")]
    pub csv: bool,
    /// Output format: table, json or csv.
    #[arg(long, value_enum)]
    pub format: Option<OutputFormat>,
    /// Draw phi(z) and A(z) into this SVG file (and a PNG next to it).
    #[arg(long, value_name = "FILE.svg")]
    pub plot: Option<PathBuf>,
}

/// Run `km field`.
pub fn run(args: &FieldArgs) -> Result<()> {
    let scene = args.input.load()?;
    if args.samples == 0 {
        bail!("--samples 0: need at least one photon");
    }
    let plot = args.plot.as_deref().map(chart_target).transpose()?;
    let mut opts = FieldOptions {
        method: FieldMethod(args.method),
        dz: args.dz,
        directions: args.directions.clone(),
        mc_cone_deg: Some(args.mc_cone),
        ..Default::default()
    };
    opts.multiflux.streams = args.streams;
    opts.mc.samples = args.samples;
    opts.mc.seed = args.seed;
    opts.dipole = km::DipoleOptions { fdr: args.fdr, model: args.dipole };
    let f = field(&scene, args.depths.as_deref(), &opts)?;
    if let Some((dir, stem)) = plot {
        write_field_chart(&f, &dir, &stem)?;
    }
    let format =
        if args.csv { OutputFormat::Csv } else { OutputFormat::of(args.json, args.format) };
    stdout::print(&format.text(|| f.table(), || f.csv(), || f.to_json()))
}

/// `THETA:PHI` in degrees.
fn direction_parser(s: &str) -> std::result::Result<[f64; 2], String> {
    let (t, p) = s.split_once(':').ok_or_else(|| format!("{s}: expected THETA:PHI in degrees"))?;
    let num = |x: &str| x.trim().parse::<f64>().map_err(|e| format!("{s}: {e}"));
    Ok([num(t)?, num(p)?])
}
