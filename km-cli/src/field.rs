//! `km field SCENE`: the fluence rate, absorbed power density and net flux
//! at the scene's `[output] depths` by one method (docs/cli.md,
//! docs/field.md), as a table, JSON or CSV, and optionally a chart.

use std::path::PathBuf;

use anyhow::Result;
use km::field::{FieldRequest, field};
use km::settings::option_flag;
use km_plot::chart::chart_target;
use km_plot::field::write_field_chart;

use crate::solve::{OutputFormat, SceneArg};
use crate::stdout;

/// The flags of `km field`.
#[derive(clap::Args)]
pub struct FieldArgs {
    #[command(flatten)]
    pub input: SceneArg,
    #[command(flatten)]
    pub request: FieldRequest,
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
    let opts = args.request.options().map_err(option_flag)?;
    let plot = args.plot.as_deref().map(chart_target).transpose()?;
    let f = field(&scene, args.request.depths.as_deref(), &opts)?;
    if let Some((dir, stem)) = plot {
        write_field_chart(&f, &dir, &stem)?;
    }
    let format =
        if args.csv { OutputFormat::Csv } else { OutputFormat::of(args.json, args.format) };
    stdout::print(&format.text(|| f.table(), || f.csv(), || f.to_json()))
}
