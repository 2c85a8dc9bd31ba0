//! `km bsdf`: the whole BSDF of a scene's stack as a table file (npz, csv)
//! or a Fourier BSDF file for Mitsuba 0.6 / pbrt-v3 (`docs/bsdf.md`),
//! computed by `km::bsdf_file`.

use std::path::PathBuf;

use anyhow::{Context, anyhow, bail};
use clap::Args;
use km::bsdf_file::{BsdfFormat, BsdfLists, BsdfRequest};
use km_inverse::colour::spectrum_channel_mix;

// The flags of `km bsdf` (no doc comment: it would become the command's about).
#[derive(Args, Debug)]
pub struct BsdfArgs {
    /// Scene file (TOML, see docs/scene-file.md); its light and [output] are ignored.
    pub scene: PathBuf,
    /// Output file, written atomically (a temporary file, then a rename).
    #[arg(long)]
    pub out: Option<PathBuf>,
    #[command(flatten)]
    pub lists: BsdfLists,
    /// Write PNG and SVG pictures (in-plane polar plots, heat maps) into this directory.
    #[arg(long)]
    pub plot: Option<PathBuf>,
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
    let mut request = BsdfRequest::from_lists(&args.lists, args.out.as_deref())
        .map_err(|e| anyhow!(e.flag_words()))?;
    if request.format == BsdfFormat::Fourier {
        request.channel_mix = spectrum_channel_mix(scene.wavelengths_nm())
            .map_err(|e| anyhow!("[spectrum] wavelengths_nm: {e}"))?;
    }
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
        for f in km_plot::bsdf::write_file_plots(&file, &scene, dir)? {
            crate::stdout::eprint(&format!("wrote {}\n", f.display()))?;
        }
    }
    Ok(())
}
