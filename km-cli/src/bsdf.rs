//! `km bsdf`: the whole BSDF of a scene's stack as a table file (npz, csv)
//! or a Fourier BSDF file for Mitsuba 0.6 / pbrt-v3 (`docs/bsdf.md`),
//! computed by `km::bsdf_file`.

use std::path::{Path, PathBuf};

use anyhow::{Context, anyhow, bail};
use clap::Args;
use km::bsdf::Bsdf;
use km::bsdf_file::{BsdfFile, BsdfFormat, BsdfRequest};

// The flags of `km bsdf` (no doc comment: it would become the command's about).
#[derive(Args, Debug)]
pub struct BsdfArgs {
    /// Scene file (TOML, see docs/scene-file.md); its light and [output] are ignored.
    pub scene: PathBuf,
    /// Output file, written atomically (a temporary file, then a rename).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// File format (default: from the extension of --out: .npz, .csv, .bsdf → fourier; else npz).
    #[arg(long, value_enum)]
    pub format: Option<BsdfFormat>,
    /// Incidence polar angles, degrees in [0, 90): a list `0,30,60`, a range
    /// `START:STOP:STEP` (STOP excluded) or `gauss:N` (arccosines of N Gauss
    /// nodes in mu). Default 0 and gauss:32 (npz, csv); for fourier, 48 angles
    /// uniform in theta from 0 (`0:90:1.875`).
    #[arg(long, allow_hyphen_values = true)]
    pub theta_i: Option<String>,
    /// Exit polar angles, degrees in [0, 90), same syntax; default the --theta-i
    /// given, else gauss:32 (npz, csv) or as --theta-i (fourier).
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
    /// Factor on the grid budgets (angle pairs, table values) and on the work
    /// budget of the operators (docs/limits.md).
    #[arg(long, default_value_t = 1.0)]
    pub budget: f64,
}

/// `km bsdf`: compute, write (nothing half-written), plot, and print a
/// summary on stderr.
pub fn run(args: &BsdfArgs) -> anyhow::Result<()> {
    if args.out.is_none() && args.plot.is_none() {
        bail!("km bsdf needs --out FILE, --plot DIR, or both");
    }
    let limits = km::SceneLimits::from_env();
    let text = km::read_scene_text(&args.scene, limits.max_bytes)
        .with_context(|| format!("{}", args.scene.display()))?;
    let scene = km::Scene::from_toml_str_with(&text, &limits)
        .with_context(|| format!("{}", args.scene.display()))?;
    let format = args.format.unwrap_or_else(|| BsdfFormat::from_path(args.out.as_deref()));
    let (theta_i, theta_o, phi) =
        (args.theta_i.as_deref(), args.theta_o.as_deref(), args.phi.as_deref());
    let mut request =
        BsdfRequest::from_lists(theta_i, theta_o, phi, args.from_below, args.streams, format)
            .map_err(|e| anyhow!(e.flag_words()))?;
    if !(args.budget.is_finite() && args.budget > 0.0) {
        bail!("--budget must be a finite number > 0, not {}", args.budget);
    }
    request.budget = args.budget;
    request.channel_mix = spectrum_mix(&scene, format)?;
    let name = args.scene.display().to_string();
    let file = km::bsdf_file::bsdf_file(&scene, &name, &text, &request, args.out.is_some())?;
    if let Some(out) = &args.out {
        // Never over an input: `--out` naming the scene file is refused.
        if let Some(totals) = file.write(out, std::slice::from_ref(&args.scene))? {
            crate::stdout::eprint(&format!("wrote {} (totals, delta parts)\n", totals.display()))?;
        }
    }
    if request.channel_mix.is_some() {
        crate::stdout::eprint(
            "the spectrum is written as its luminance Y and linear sRGB R, B (CIE 1931 2°, D65; \
             docs/bsdf.md)\n",
        )?;
    }
    crate::stdout::eprint(&file.summary(args.out.as_deref()))?;
    if let Some(dir) = &args.plot {
        for f in plots(&file, &scene, dir)? {
            crate::stdout::eprint(&format!("wrote {}\n", f.display()))?;
        }
    }
    Ok(())
}

/// For a Fourier file of a spectral scene (several wavelengths): the linear
/// sRGB weights of its wavelengths (`km_inverse::colour`), so that the file
/// holds the spectrum's colour; `None` for other scenes and formats.
fn spectrum_mix(scene: &km::Scene, format: BsdfFormat) -> anyhow::Result<Option<Vec<[f64; 3]>>> {
    match scene.wavelengths_nm() {
        Some(w) if format == BsdfFormat::Fourier && w.len() > 1 => {
            let weights = km_inverse::colour::linear_srgb_weights(w)
                .map_err(|e| anyhow!("[spectrum] wavelengths_nm: {e}"))?;
            Ok(Some(weights))
        }
        _ => Ok(None),
    }
}

/// The pictures of `km bsdf --plot`: the table's incidence angles nearest
/// to 0, 30, 60, 75 degrees, recomputed on exit angles every degree so that
/// the curves are smooth whatever the table's grid.
fn plots(c: &BsdfFile, scene: &km::Scene, dir: &Path) -> anyhow::Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let picks: Vec<f64> =
        km_plot::bsdf::chosen_incidences(&c.bsdf).into_iter().map(|i| c.bsdf.theta_i[i]).collect();
    let dense: Vec<f64> = (0..90).map(f64::from).collect();
    let b = Bsdf::new(scene, &picks, &dense, &c.options)?;
    km_plot::bsdf::write_all(&b, dir)
}
