//! `km bsdf`: the whole BSDF of a scene's stack as a table file (npz, csv)
//! or a Fourier BSDF file for Mitsuba 0.6 / pbrt-v3 (`docs/bsdf.md`).

use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use clap::{Args, ValueEnum};
use km::MultifluxOptions;
use km::bsdf::write::{FourierSettings, Table, fourier, write_atomic};
use km::bsdf::{Bsdf, BsdfOptions, Side, check, gauss_angles};
use serde_json::json;

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

/// Parse an angle list: `a,b,c`, `start:stop:step` (stop excluded) or `gauss:N`.
pub fn parse_angles(name: &str, text: &str) -> anyhow::Result<Vec<f64>> {
    let text = text.trim();
    if let Some(n) = text.strip_prefix("gauss:") {
        let n: usize = n.trim().parse().with_context(|| format!("--{name} {text}: N"))?;
        if n == 0 || n > 1024 {
            bail!("--{name} {text}: N must lie in 1..=1024");
        }
        return Ok(gauss_angles(n).0);
    }
    if text.contains(':') {
        let parts: Vec<&str> = text.split(':').collect();
        let [a, b, s] = parts[..] else {
            bail!("--{name} {text}: a range is START:STOP:STEP");
        };
        let num = |x: &str| -> anyhow::Result<f64> {
            let v: f64 = x.trim().parse().with_context(|| format!("--{name} {text}: `{x}`"))?;
            if !v.is_finite() {
                bail!("--{name} {text}: `{x}` is not finite");
            }
            Ok(v)
        };
        let (a, b, s) = (num(a)?, num(b)?, num(s)?);
        if s <= 0.0 || b <= a {
            bail!("--{name} {text}: needs STOP > START and STEP > 0");
        }
        let count = ((b - a) / s - 1e-9).ceil();
        if count > 100_000.0 {
            bail!("--{name} {text}: {count} values (at most 100000)");
        }
        return Ok((0..count as usize).map(|k| a + s * k as f64).collect());
    }
    let v: anyhow::Result<Vec<f64>> = text
        .split(',')
        .map(|x| {
            let v: f64 =
                x.trim().parse().with_context(|| format!("--{name}: `{x}` is not a number"))?;
            if !v.is_finite() {
                bail!("--{name}: `{x}` is not finite");
            }
            Ok(v)
        })
        .collect();
    let v = v?;
    if v.len() > 100_000 {
        bail!("--{name}: {} values (at most 100000)", v.len());
    }
    Ok(v)
}

/// The format: the flag, else the extension of `out`, else npz.
fn resolve_format(args: &BsdfArgs) -> Format {
    if let Some(f) = args.format {
        return f;
    }
    match args.out.as_ref().and_then(|p| p.extension()).and_then(|e| e.to_str()) {
        Some("csv") => Format::Csv,
        Some("bsdf") => Format::Fourier,
        _ => Format::Npz,
    }
}

/// What `km bsdf` computed (for the summary line and the pictures).
pub struct Computed {
    /// The BSDF (light from the chosen side).
    pub bsdf: Bsdf,
    /// The azimuths of the table.
    pub phi: Vec<f64>,
    /// The meta JSON of the file.
    pub meta: serde_json::Value,
    /// Seconds spent computing the operators and the table.
    pub seconds: f64,
    /// The scene and the options used (for the pictures).
    pub scene: km::Scene,
    /// Options of the table.
    pub options: BsdfOptions,
}

/// Compute the BSDF of `scene_path` and write the file; returns what was computed.
///
/// # Errors
/// Bad scene or flags, solver failures, write failures (nothing half-written).
pub fn run(args: &BsdfArgs) -> anyhow::Result<Computed> {
    if args.out.is_none() && args.plot.is_none() {
        bail!("km bsdf needs --out FILE, --plot DIR, or both");
    }
    let limits = km::SceneLimits::from_env();
    let text = km::read_scene_text(&args.scene, limits.max_bytes)
        .with_context(|| format!("{}", args.scene.display()))?;
    let scene = km::Scene::from_toml_str_with(&text, &limits)
        .with_context(|| format!("{}", args.scene.display()))?;
    let format = resolve_format(args);
    let fourier_grid: Vec<f64> = (0..48).map(|k| 1.875 * k as f64).collect();
    let default_theta =
        if format == Format::Fourier { fourier_grid.clone() } else { gauss_angles(32).0 };
    let theta_i = match &args.theta_i {
        Some(t) => parse_angles("theta-i", t)?,
        None => default_theta.clone(),
    };
    let theta_o = match &args.theta_o {
        Some(t) => parse_angles("theta-o", t)?,
        None => theta_i.clone(),
    };
    let phi = match &args.phi {
        Some(t) => parse_angles("phi", t)?,
        None => (0..72).map(|k| 5.0 * k as f64).collect(),
    };
    if format == Format::Fourier && args.from_below {
        bail!("--from-below does not apply to --format fourier (the file holds both sides)");
    }
    let solver = MultifluxOptions { streams: args.streams, ..Default::default() };
    let side = if args.from_below { Side::Below } else { Side::Above };
    let start = std::time::Instant::now();
    let options = BsdfOptions { solver: solver.clone(), side };
    let bsdf = Bsdf::new(&scene, &theta_i, &theta_o, &options)?;
    let table = Table::new(&bsdf, &phi)?;
    let seconds = start.elapsed().as_secs_f64();

    // The checks go into the file's meta and the summary.
    let energy = check::energy(&bsdf, phi.len().max(72));
    let recip = check::reciprocity(&bsdf, &[0.0, 90.0, 180.0], 1e-6);
    let neg = check::negatives(&bsdf, &phi);
    let meta = json!({
        "km_version": env!("CARGO_PKG_VERSION"),
        "scene_file": args.scene.display().to_string(),
        "scene": text,
        "channels": scene.labels,
        "solver": {
            "method": "multiflux",
            "streams": bsdf.channels.iter().map(|c| c.streams).max(),
            "fourier_orders": (0..bsdf.channels.len()).map(|c| bsdf.orders(c)).max(),
            "delta_m": solver.delta_m,
            "single_scattering_correction": solver.delta_m,
        },
        "side": if args.from_below { "below" } else { "above" },
        "units": {"angles": "degrees", "brdf": "1/sr", "btdf": "1/sr"},
        "conventions": "light arrives from phi = 0; phi = 180 is the mirror side; theta from \
            the normal on each side; brdf/btdf are the smooth parts per unit irradiance on the \
            surface (divided by cos theta_i), delta parts in reflectance_specular and \
            transmittance_direct",
        "checks": {
            "energy_max_error": energy.max_error,
            "energy_rule": "hemispherical integral of the table (Gauss rule when theta_o is \
                gauss:N, else trapezoid in mu) plus delta parts, against the solver's totals",
            "reflection_reciprocity_max_relative": recip,
            "negative_values": neg.count,
            "values": neg.total,
            "most_negative": neg.worst.map(|w| json!({
                "value": w.0, "channel": w.1, "theta_i": w.2, "theta_o": w.3, "phi": w.4,
                "transmitted": w.5,
            })),
        },
        "seconds": seconds,
    });
    if let Some(out) = &args.out {
        let bytes = match format {
            Format::Npz => table.npz(&serde_json::to_string(&meta)?),
            Format::Csv => {
                let mut head = String::new();
                for line in serde_json::to_string(&meta)?.lines() {
                    head.push_str(&format!("# {line}\n"));
                }
                let mut b = head.into_bytes();
                b.extend(table.csv());
                b
            }
            Format::Fourier => {
                let below = if bsdf.transmits {
                    let o = BsdfOptions { solver, side: Side::Below };
                    Some(Bsdf::new(&scene, &theta_i, &theta_o, &o)?)
                } else {
                    None
                };
                fourier(&bsdf, below.as_ref(), &FourierSettings::default())?
            }
        };
        write_atomic(out, &bytes)?;
    }
    Ok(Computed { bsdf, phi, meta, seconds, scene, options })
}

/// `km bsdf`: compute, write, plot, and print a one-paragraph summary on stderr.
pub fn main(args: &BsdfArgs) -> anyhow::Result<()> {
    let c = run(args)?;
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
        let files = plots(&c, dir)?;
        for f in files {
            eprintln!("wrote {}", f.display());
        }
    }
    Ok(())
}

/// The pictures of `km bsdf --plot`: the table's incidence angles nearest
/// to 0, 30, 60, 75 degrees, recomputed on exit angles every degree so that
/// the curves are smooth whatever the table's grid.
fn plots(c: &Computed, dir: &Path) -> anyhow::Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let picks: Vec<f64> = km_bench::bsdf_plot::chosen_incidences(&c.bsdf)
        .into_iter()
        .map(|i| c.bsdf.theta_i[i])
        .collect();
    let dense: Vec<f64> = (0..90).map(f64::from).collect();
    let b = Bsdf::new(&c.scene, &picks, &dense, &c.options)?;
    km_bench::bsdf_plot::write_all(&b, dir)
}
