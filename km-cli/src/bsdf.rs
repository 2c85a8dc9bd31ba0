//! `km bsdf`: the whole BSDF of a scene's stack as a table file (npz, csv)
//! or a Fourier BSDF file for Mitsuba 0.6 / pbrt-v3 (`docs/bsdf.md`).

use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use clap::{Args, ValueEnum};
use km::bsdf::Bsdf;
use km::bsdf::write::write_atomic;
use km::bsdf_file::{AngleListError, BsdfFile, BsdfFormat, BsdfRequest, bsdf_file, default_phi};

/// File format of `km bsdf`.
#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
pub enum Format {
    /// numpy `.npz` (zip of `.npy` arrays; names in docs/bsdf.md).
    Npz,
    /// Long-format CSV, one row per (channel, theta_i, theta_o, phi).
    Csv,
    /// The layerlab Fourier BSDF file read by Mitsuba 0.6 and pbrt-v3 (`fourier` material).
    Fourier,
}

/// Arguments of `km bsdf`.
#[derive(Args, Debug)]
pub struct BsdfArgs {
    /// Scene file (TOML, see docs/scene-file.md); its light and [output] are ignored.
    pub scene: PathBuf,
    /// Output file, written atomically (a temporary file, then a rename).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// File format (default: from the extension of --out: .npz, .csv, .bsdf → fourier; else npz).
    #[arg(long, value_enum)]
    pub format: Option<Format>,
    /// Incidence polar angles, degrees in [0, 90): a list `0,30,60`, a range
    /// `START:STOP:STEP` (STOP excluded) or `gauss:N` (arccosines of N Gauss
    /// nodes in mu). Default gauss:32 (npz, csv); for fourier, 48 angles
    /// uniform in theta from 0 (`0:90:1.875`).
    #[arg(long, allow_hyphen_values = true)]
    pub theta_i: Option<String>,
    /// Exit polar angles, degrees in [0, 90), same syntax; default as --theta-i.
    #[arg(long, allow_hyphen_values = true)]
    pub theta_o: Option<String>,
    /// Azimuths, degrees (180 = mirror side), same syntax; default `0:360:5` (72).
    #[arg(long, allow_hyphen_values = true)]
    pub phi: Option<String>,
    /// Light from below (through a transparent substrate) instead of above [npz, csv].
    #[arg(long)]
    pub from_below: bool,
    /// Gauss nodes per hemisphere and Snell segment (default: as `km solve`
    /// would choose for the most demanding incidence).
    #[arg(long)]
    pub streams: Option<usize>,
    /// Write PNG and SVG pictures (in-plane polar plots, heat maps) into this directory.
    #[arg(long)]
    pub plot: Option<PathBuf>,
}

/// An angle list of flag `--NAME` ([`km::bsdf_file::parse_angles`]).
fn parse_angles(name: &str, text: &str) -> anyhow::Result<Vec<f64>> {
    km::bsdf_file::parse_angles(text).map_err(|e| match e {
        e @ AngleListError::Grid { .. } => anyhow::anyhow!("--{name} {e}"),
        e @ AngleListError::List { .. } => anyhow::anyhow!("--{name}: {e}"),
    })
}

/// The format: the flag, else the extension of `out`, else npz.
fn resolve_format(args: &BsdfArgs) -> BsdfFormat {
    match args.format {
        Some(Format::Npz) => BsdfFormat::Npz,
        Some(Format::Csv) => BsdfFormat::Csv,
        Some(Format::Fourier) => BsdfFormat::Fourier,
        None => BsdfFormat::from_path(args.out.as_deref()),
    }
}

/// Compute the BSDF of the scene file and write the file; returns what was
/// computed and the scene (for the pictures).
///
/// # Errors
/// Bad scene or flags, solver failures, write failures (nothing half-written).
pub fn run(args: &BsdfArgs) -> anyhow::Result<(BsdfFile, km::Scene)> {
    if args.out.is_none() && args.plot.is_none() {
        bail!("km bsdf needs --out FILE, --plot DIR, or both");
    }
    let limits = km::SceneLimits::from_env();
    let text = km::read_scene_text(&args.scene, limits.max_bytes)
        .with_context(|| format!("{}", args.scene.display()))?;
    let scene = km::Scene::from_toml_str_with(&text, &limits)
        .with_context(|| format!("{}", args.scene.display()))?;
    let format = resolve_format(args);
    let theta_i = match &args.theta_i {
        Some(t) => parse_angles("theta-i", t)?,
        None => format.default_theta(),
    };
    let theta_o = match &args.theta_o {
        Some(t) => parse_angles("theta-o", t)?,
        None => theta_i.clone(),
    };
    let phi = match &args.phi {
        Some(t) => parse_angles("phi", t)?,
        None => default_phi(),
    };
    if format == BsdfFormat::Fourier && args.from_below {
        bail!("--from-below does not apply to --format fourier (the file holds both sides)");
    }
    let (from_below, streams) = (args.from_below, args.streams);
    let request = BsdfRequest { theta_i, theta_o, phi, from_below, streams, format };
    let name = args.scene.display().to_string();
    let file = bsdf_file(&scene, &name, &text, &request, args.out.is_some())?;
    if let (Some(out), Some(bytes)) = (&args.out, &file.bytes) {
        write_atomic(out, bytes)?;
    }
    Ok((file, scene))
}

/// `km bsdf`: compute, write, plot, and print a one-paragraph summary on stderr.
pub fn main(args: &BsdfArgs) -> anyhow::Result<()> {
    let (c, scene) = run(args)?;
    let b = &c.bsdf;
    if let Some(out) = &args.out {
        eprintln!(
            "wrote {} ({} channel(s) x {} incidence x {} exit polar angles x {} azimuths) in {:.3} s",
            out.display(),
            b.channels.len(),
            b.theta_i.len(),
            b.theta_o.len(),
            c.phi.len(),
            c.seconds
        );
    }
    let checks = &c.meta["checks"];
    eprintln!(
        "checks: energy {:.1e}, reflection reciprocity {}, negative values {} of {}",
        checks["energy_max_error"].as_f64().unwrap_or(f64::NAN),
        checks["reflection_reciprocity_max_relative"]
            .as_f64()
            .map_or("n/a (grids differ)".into(), |v| format!("{v:.1e}")),
        checks["negative_values"],
        checks["values"]
    );
    if let Some(dir) = &args.plot {
        let files = plots(&c, &scene, dir)?;
        for f in files {
            eprintln!("wrote {}", f.display());
        }
    }
    Ok(())
}

/// The pictures of `km bsdf --plot`: the table's incidence angles nearest
/// to 0, 30, 60, 75 degrees, recomputed on exit angles every degree so that
/// the curves are smooth whatever the table's grid.
fn plots(c: &BsdfFile, scene: &km::Scene, dir: &Path) -> anyhow::Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let picks: Vec<f64> = km_bench::bsdf_plot::chosen_incidences(&c.bsdf)
        .into_iter()
        .map(|i| c.bsdf.theta_i[i])
        .collect();
    let dense: Vec<f64> = (0..90).map(f64::from).collect();
    let b = Bsdf::new(scene, &picks, &dense, &c.options)?;
    km_bench::bsdf_plot::write_all(&b, dir)
}
