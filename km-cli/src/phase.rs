//! `km phase SCENE`: each layer's phase function at angles, its Legendre
//! moments, `g`, and the Mie efficiencies of particle layers
//! (`km::phase_report`, docs/phase.md §6), as a table, JSON or CSV, and
//! optionally a chart of `p(theta)` (`km_plot::phase`).

use std::path::PathBuf;

use anyhow::{Context, Result};
use km::phase_report::{PhaseOptions, csv, parse_angles, phase_report, table};

use crate::solve::{OutputFormat, SceneArg};
use crate::stdout;

/// The flags of `km phase`.
#[derive(clap::Args)]
pub struct PhaseArgs {
    #[command(flatten)]
    pub input: SceneArg,
    /// Output format: table, json or csv (one row per value: layer, channel, quantity, key, value).
    #[arg(long, value_enum, default_value = "table")]
    pub format: OutputFormat,
    /// Scattering angles in degrees, in [0, 180]: a list `0,1,5,90` or a range
    /// `START:STOP:STEP` (STOP excluded). Default: every 0.05 below 1, every
    /// 0.25 to 10, every degree to 180 (227 angles).
    #[arg(long, value_name = "SPEC", allow_hyphen_values = true)]
    pub angles: Option<String>,
    /// K: print the Legendre moments chi_0 .. chi_K (default 2N, N the default
    /// multi-flux streams of the scene: the moments its delta-M uses).
    #[arg(long, value_name = "K")]
    pub moments: Option<usize>,
    /// Draw p(theta) of every scattering layer and channel into FILE.svg and FILE.png.
    #[arg(long, value_name = "FILE.svg")]
    pub plot: Option<PathBuf>,
    /// Also write the JSON report to this file (atomically; never over the scene).
    #[arg(long, value_name = "FILE")]
    pub out: Option<PathBuf>,
}

/// Run `km phase`.
pub fn run(args: &PhaseArgs) -> Result<()> {
    let scene = args.input.load()?;
    let angles = |spec: &str| parse_angles(spec).with_context(|| format!("--angles {spec}"));
    let angles_deg = args.angles.as_deref().map(angles).transpose()?;
    let plot = args.plot.as_deref().map(km_plot::chart::chart_target).transpose()?;
    let opts = PhaseOptions { angles_deg, moments: args.moments };
    let report = phase_report(&scene, &opts).map_err(|e| {
        let flag = match &e {
            km::CoreError::Invalid { name, .. } if name == "angles_deg" => "--angles",
            _ => "--moments",
        };
        anyhow::Error::new(e).context(flag)
    })?;
    if let Some(out) = &args.out {
        crate::solve::write_json(out, &report.to_json(), std::slice::from_ref(&args.input.scene))?;
    }
    if let Some((dir, stem)) = plot {
        km_plot::phase::write_phase_chart(&report, &dir, &stem)?;
    }
    stdout::print(&args.format.text(|| table(&report), || csv(&report), || report.to_json()))
}
