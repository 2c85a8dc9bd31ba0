//! `km field SCENE`: the fluence rate, absorbed power density and net flux
//! at the scene's `[output] depths` by one method (docs/cli.md,
//! docs/field.md), as a table, JSON or CSV, and optionally a chart.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use km::Method;
use km::field::{Field, FieldMethod, FieldOptions, field};
use km_plot::chart::{LineChart, Mark, Series, write_chart};

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
    let plot = args.plot.as_deref().map(plot_target).transpose()?;
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
        write_plot(&f, &dir, &stem)?;
    }
    let format =
        if args.csv { OutputFormat::Csv } else { OutputFormat::of(args.json, args.format) };
    match format {
        OutputFormat::Json => stdout::print_json(&f.to_json()),
        OutputFormat::Csv => stdout::print(&join(csv(&f), f.inside_csv())),
        OutputFormat::Table => stdout::print(&join(table(&f), f.inside_table())),
    }
}

/// The depth table and, when asked, the radiance's after a blank line.
fn join(a: String, b: String) -> String {
    if b.is_empty() { a } else { format!("{a}\n{b}") }
}

/// `THETA:PHI` in degrees.
fn direction_parser(s: &str) -> std::result::Result<[f64; 2], String> {
    let (t, p) = s.split_once(':').ok_or_else(|| format!("{s}: expected THETA:PHI in degrees"))?;
    let num = |x: &str| x.trim().parse::<f64>().map_err(|e| format!("{s}: {e}"));
    Ok([num(t)?, num(p)?])
}

/// The directory and stem of `--plot FILE.svg` (the file must end in `.svg`).
pub(crate) fn plot_target(path: &Path) -> Result<(PathBuf, String)> {
    let is_svg = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("svg"));
    let stem = path.file_stem().and_then(|s| s.to_str()).filter(|s| !s.is_empty());
    let (Some(stem), true) = (stem, is_svg) else {
        bail!("--plot {}: the chart is an SVG file, give a name ending in .svg", path.display());
    };
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    if !dir.is_dir() {
        bail!("--plot {}: directory {} does not exist", path.display(), dir.display());
    }
    // Never replace a file that is not a chart.
    for (ext, magic) in [("svg", &b"<svg"[..]), ("png", &b"\x89PNG"[..])] {
        let p = dir.join(format!("{stem}.{ext}"));
        if p.exists() && !looks_like(&p, magic) {
            bail!("--plot: {} exists and is not an {ext} chart; not replaced", p.display());
        }
    }
    Ok((dir, stem.to_string()))
}

/// Whether the file at `p` is a regular file whose first bytes hold `magic`
/// (an SVG may open with an XML declaration: its first 256 bytes are searched).
fn looks_like(p: &Path, magic: &[u8]) -> bool {
    use std::io::Read;
    let Ok(file) = std::fs::File::open(p) else { return false };
    let mut head = Vec::new();
    if file.take(256).read_to_end(&mut head).is_err() || !p.is_file() {
        return false;
    }
    head.windows(magic.len()).any(|w| w == magic)
}

fn table(f: &Field) -> String {
    let mut s = format!("method: {}\n", f.method);
    for (c, label) in f.labels.iter().enumerate() {
        if f.labels.len() > 1 {
            let _ = writeln!(s, "channel {label}");
        }
        let _ = writeln!(s, "{:>12} {:>14} {:>14} {:>14}", "z", "phi", "A", "F");
        for (i, z) in f.depths.iter().enumerate() {
            let se = |v: &Vec<Vec<f64>>| format!(" ± {:.2e}", v[c][i]);
            let (ps, as_, ns) =
                f.stderr.as_ref().map_or((String::new(), String::new(), String::new()), |e| {
                    (se(&e.fluence), se(&e.absorbed), se(&e.net_flux))
                });
            let _ = writeln!(
                s,
                "{z:>12.6} {:>14.6e}{ps} {:>14.6e}{as_} {:>14.6e}{ns}",
                f.fluence[c][i], f.absorbed[c][i], f.net_flux[c][i]
            );
        }
        let layers: Vec<String> =
            f.absorptance_layers[c].iter().map(|a| format!("{a:.6}")).collect();
        let _ = writeln!(s, "absorptance per layer: {}", layers.join(", "));
    }
    s
}

fn csv(f: &Field) -> String {
    let mut s = String::from("channel,z,fluence,absorbed,net_flux");
    if f.stderr.is_some() {
        s += ",fluence_se,absorbed_se,net_flux_se";
    }
    s += "\n";
    for (c, label) in f.labels.iter().enumerate() {
        for (i, z) in f.depths.iter().enumerate() {
            let _ = write!(
                s,
                "{label},{z},{},{},{}",
                f.fluence[c][i], f.absorbed[c][i], f.net_flux[c][i]
            );
            if let Some(e) = &f.stderr {
                let _ = write!(s, ",{},{},{}", e.fluence[c][i], e.absorbed[c][i], e.net_flux[c][i]);
            }
            s += "\n";
        }
    }
    s
}

/// phi(z) and A(z) of every channel against depth (Monte Carlo with error bars).
fn write_plot(f: &Field, dir: &Path, stem: &str) -> Result<()> {
    let mut series = Vec::new();
    for (c, label) in f.labels.iter().enumerate() {
        let ch = if f.labels.len() > 1 { format!(" ({label})") } else { String::new() };
        let pts = |v: &Vec<Vec<f64>>| f.depths.iter().copied().zip(v[c].iter().copied()).collect();
        let mark = if f.stderr.is_some() { Mark::LinePoints } else { Mark::Line };
        let mut phi = Series::new(format!("phi(z){ch}"), pts(&f.fluence), mark, 2 * c);
        let mut a = Series::new(format!("A(z){ch}"), pts(&f.absorbed), Mark::Dashed, 2 * c + 1);
        if let Some(e) = &f.stderr {
            phi = phi.with_y_err(e.fluence[c].clone());
            a = a.with_y_err(e.absorbed[c].clone());
        }
        series.extend([phi, a]);
    }
    let chart = LineChart {
        title: format!("km field, {}: fluence rate and absorbed power density", f.method),
        x_label: "depth z".into(),
        y_label: "phi (per unit irradiance), A (per unit depth)".into(),
        series,
        ..Default::default()
    };
    write_chart(dir, stem, &chart)
        .with_context(|| format!("drawing {}/{stem}.svg", dir.display()))?;
    Ok(())
}
